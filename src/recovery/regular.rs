//! The regular patches of one recovery, fitted from their cells' moments.
//!
//! A node whose first ring is eight inside cells, none seen across a
//! mirror face, whose fit has no constraints, has the same sample points in
//! its scaled coordinates `ξ = (x − x_node)/h` as every other such node when
//! every inside cell has the same points about its own centre (the caller's
//! rule of an inside cell). Its fit's acceptance and its factored normal
//! equations are then those of any one of them: [`RegularFit`] makes them
//! once, from the lowest regular node of the recovery.
//!
//! Each regular node then needs its samples only through `Aᵀ B`, the
//! moments of its values in the template's centred coordinates. As the
//! later recoveries of [`super::moments`] do, each cell's moments are taken
//! once, about the cell's centre, and moved into the patches of its eight
//! vertices by the binomial theorem ([`Monomials::for_each_shift`]); a node
//! then costs eight shifts and one solve ([`FitFactor::fit_moments`]). The
//! cells' moments are held for a few node planes at a time
//! ([`PLANES_PER_PASS`]), so the memory is a few cell layers whatever the
//! grid. A cell whose points are not the template's (to
//! [`POSITION_TOLERANCE`] in scaled units) leaves the nodes around it to
//! their own fits.
//!
//! The template is used only when its normal matrix is well conditioned
//! ([`FitFactor::solves_from_moments`]): one solve then loses
//! `cond(M̃)·ε` of the coefficients, where the refined solve of a general
//! patch loses about `√cond(M̃)·ε`; both are round-off for these patches.

use rayon::prelude::*;

use super::fit::{fit_and_factor, FitFactor, FitOptions};
use super::mirror::PatchCell;
use super::spr::{node_ijk, scaled, PatchSamples};
use super::{Monomials, Sample};
use crate::cells::CellKind;
use crate::element::ElementOrder;
use crate::grid::Grid;

/// Largest difference, in scaled units, between a cell's sample point and
/// the template's for the template to fit the cell's nodes.
const POSITION_TOLERANCE: f64 = 1e-12;

/// Node planes whose regular patches are fitted together: the moments of
/// `PLANES_PER_PASS + 1` cell layers are held at once.
const PLANES_PER_PASS: usize = 4;

/// The cells of a patch's first ring when they make a regular patch: eight
/// cells, all inside, none mirrored.
pub(super) fn is_regular(kinds: &[CellKind], ring_one: &[PatchCell]) -> bool {
    ring_one.len() == 8
        && ring_one
            .iter()
            .all(|&(c, mask)| mask == 0 && kinds[c] == CellKind::Inside)
}

/// The factored fit of a regular patch, for every regular patch of one
/// recovery.
pub(super) struct RegularFit {
    /// The sample points of an inside cell, scaled about its centre.
    cell_points: Vec<[f64; 3]>,
    /// The template's number of samples.
    pub(super) samples: usize,
    /// `W_b` (`n_b × n_b`, row-major) for the cell at each corner `b` of the
    /// node (bit `a` of `b`: the cell above the node along axis `a`): a
    /// component's coefficients are `Σ_b W_b m_b` of its cells' moments.
    weights: Vec<f64>,
}

impl RegularFit {
    /// The template of the regular patch of `cells` (its first ring) whose
    /// samples, in physical coordinates, are `per_cell[i]` for `cells[i]`
    /// and whose node is at `centre`; `None` when the cells' points differ
    /// about their centres, or the fit is not accepted or not well enough
    /// conditioned to be solved once.
    pub(super) fn new<const NC: usize>(
        grid: &Grid,
        basis: &Monomials,
        centre: [f64; 3],
        cells: &[usize],
        per_cell: &[Vec<Sample<NC>>],
        opts: &FitOptions,
    ) -> Option<RegularFit> {
        let about_centre = |cell: usize, samples: &[Sample<NC>]| -> Vec<[f64; 3]> {
            let c = cell_centre(grid, cell);
            samples.iter().map(|(x, _)| scaled(c, grid.h, *x)).collect()
        };
        let cell_points = about_centre(cells[0], &per_cell[0]);
        let same = cells
            .iter()
            .zip(per_cell)
            .all(|(&c, s)| same_points(&about_centre(c, s), &cell_points));
        if !same {
            return None;
        }
        let samples: Vec<Sample<NC>> = per_cell
            .iter()
            .flatten()
            .map(|&(x, v)| (scaled(centre, grid.h, x), v))
            .collect();
        let (_, factor) = fit_and_factor(basis, &samples, None, opts).ok()?;
        if !factor.solves_from_moments() {
            return None;
        }
        Some(RegularFit {
            cell_points,
            samples: samples.len(),
            weights: corner_weights::<NC>(basis, &factor)?,
        })
    }

    /// Fits each of `nodes` (ascending Q1 vertices of `grid`) marked in
    /// `regular` from the moments of their cells' `samples`: its
    /// coefficients (in the node basis, as [`super::fit_polynomial`]) into
    /// its slice of `coeffs`, and `fitted` set. Nodes next to a cell whose
    /// points are not the template's, and non-finite fits, are left
    /// unfitted.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn fit_into<const NC: usize, S: PatchSamples<NC>>(
        &self,
        grid: &Grid,
        basis: &Monomials,
        samples: &S,
        nodes: &[usize],
        regular: &[bool],
        coeffs: &mut [f64],
        fitted: &mut [bool],
    ) {
        let stride = basis.len() * NC;
        let plane = {
            let m = grid.nodes_per_axis(ElementOrder::Q1);
            m[0] * m[1]
        };
        let layer = grid.n[0] * grid.n[1];
        let window = (PLANES_PER_PASS + 1) * layer;
        let mut moments = vec![0.0; window * stride];
        let (mut needed, mut valid) = (vec![false; window], vec![false; window]);
        let mut start = 0;
        while start < nodes.len() {
            let k0 = nodes[start] / plane;
            let end = start + nodes[start..].partition_point(|&n| n / plane < k0 + PLANES_PER_PASS);
            // Node plane k touches cell layers k − 1 and k.
            let first = k0.saturating_sub(1) * layer;
            needed.fill(false);
            for (&node, _) in nodes[start..end]
                .iter()
                .zip(&regular[start..end])
                .filter(|(_, &r)| r)
            {
                ring_one(grid, node).for_each(|c| needed[c - first] = true);
            }
            moments
                .par_chunks_mut(stride)
                .zip(&mut valid)
                .zip(&needed)
                .enumerate()
                .filter(|(_, (_, &need))| need)
                .for_each_init(
                    || (Vec::new(), vec![0.0; basis.len()]),
                    |(buf, phi), (i, ((m, ok), _))| {
                        buf.clear();
                        samples.samples(first + i, buf);
                        *ok = self.cell_moments(grid, basis, first + i, buf, phi, m);
                    },
                );
            let (moments, valid) = (&moments, &valid);
            let nb = basis.len();
            coeffs[start * stride..end * stride]
                .par_chunks_mut(stride)
                .zip(&mut fitted[start..end])
                .zip(&nodes[start..end])
                .zip(&regular[start..end])
                .filter(|(_, &r)| r)
                .for_each(|(((a, done), &node), _)| {
                    a.fill(0.0);
                    for (b, cell) in ring_one(grid, node).enumerate() {
                        let slot = cell - first;
                        if !valid[slot] {
                            return;
                        }
                        let m = &moments[slot * stride..(slot + 1) * stride];
                        let w = &self.weights[b * nb * nb..(b + 1) * nb * nb];
                        for (j, row) in w.chunks_exact(nb).enumerate() {
                            for (f, &wjf) in row.iter().enumerate() {
                                for c in 0..NC {
                                    a[c * nb + j] += wjf * m[f * NC + c];
                                }
                            }
                        }
                    }
                    *done = a.iter().all(|v| v.is_finite());
                });
            start = end;
        }
    }

    /// The moments `Σ_s φ_j(ξ_c(x_s)) v_{s,c}` of the samples `buf` of
    /// `cell` about its centre, into `m` (`phi` scratch); false when its
    /// points are not the template's.
    fn cell_moments<const NC: usize>(
        &self,
        grid: &Grid,
        basis: &Monomials,
        cell: usize,
        buf: &[Sample<NC>],
        phi: &mut [f64],
        m: &mut [f64],
    ) -> bool {
        if buf.len() != self.cell_points.len() {
            return false;
        }
        m.fill(0.0);
        let centre = cell_centre(grid, cell);
        for ((x, v), p) in buf.iter().zip(&self.cell_points) {
            let xi = scaled(centre, grid.h, *x);
            if (0..3).any(|k| (xi[k] - p[k]).abs() > POSITION_TOLERANCE) {
                return false;
            }
            basis.values(xi, phi);
            for (row, p) in m.chunks_exact_mut(NC).zip(phi.iter()) {
                for (r, vc) in row.iter_mut().zip(v) {
                    *r += p * vc;
                }
            }
        }
        true
    }
}

/// The weights `W_b` of [`RegularFit`]: column `f` of `W_b` is the fit
/// (first component) of a unit moment of term `f` of the cell at corner
/// `b`, moved into the template's centred coordinates; `None` when a fit is
/// not finite.
fn corner_weights<const NC: usize>(basis: &Monomials, factor: &FitFactor) -> Option<Vec<f64>> {
    let nb = basis.len();
    let centroid = factor.centroid();
    let mut weights = vec![0.0; 8 * nb * nb];
    let mut atb = vec![0.0; nb * NC];
    for (b, w) in weights.chunks_exact_mut(nb * nb).enumerate() {
        // The cell's centre from the node, in cells: ±1/2 per axis.
        let t = [0, 1, 2].map(|a| (b >> a & 1) as f64 - 0.5 - centroid[a]);
        for f in 0..nb {
            atb.fill(0.0);
            basis.for_each_shift(t, |e, g, v| {
                if g == f {
                    atb[e * NC] += v;
                }
            });
            let column = factor.fit_moments(&atb, NC).ok()?;
            for j in 0..nb {
                w[j * nb + f] = column[j];
            }
        }
    }
    Some(weights)
}

/// Whether two lists of scaled points agree to [`POSITION_TOLERANCE`].
fn same_points(a: &[[f64; 3]], b: &[[f64; 3]]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(p, q)| (0..3).all(|k| (p[k] - q[k]).abs() <= POSITION_TOLERANCE))
}

/// The eight cells around an interior Q1 vertex (a regular node's ring).
fn ring_one(grid: &Grid, node: usize) -> impl Iterator<Item = usize> + '_ {
    let v = node_ijk(grid, node);
    (0..8).map(move |b| grid.cell_index([0, 1, 2].map(|a| v[a] + (b >> a & 1) - 1)))
}

/// The centre of a cell.
pub(super) fn cell_centre(grid: &Grid, cell: usize) -> [f64; 3] {
    let lo = grid.cell_box(cell).lo;
    lo.map(|v| v + 0.5 * grid.h)
}
