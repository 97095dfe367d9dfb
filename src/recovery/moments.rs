//! The later recoveries on planned patches, from the moments of the cells'
//! samples.
//!
//! A patch fit needs its samples only through `Aᵀ B`, the moments
//! `Σ_s φ_e(ζ_s) v_s` of the values in the patch's centred coordinates
//! `ζ = (x − x_node)/h − ξ̄`. A cell lies in up to 8 patches (more for
//! enlarged rings), so each cell's moments are taken once, about its own
//! centre `x_c` in `ξ_c = (x − x_c)/h`, and moved into each patch by the
//! binomial theorem ([`Monomials::for_each_shift`]): `ζ = ξ_c + t` with
//! `t = (x_c − x_node)/h − ξ̄`. A cell
//! seen across a mirror face has its moments reflected: the image of a
//! point has `ξ_c` negated on the mirrored axes (a sign `(−1)^{f_a}` per
//! monomial) and its value reflected by [`PatchSamples::reflected`], which
//! is linear. A recovery's samples are then evaluated once per cell and
//! touched once, and a patch costs a few small products per cell and one
//! solve with its kept factor ([`super::FitFactor::fit_moments`]).
//!
//! The normal equations solved from moments lose `cond(M̃)·ε` of the
//! coefficients, where the refined solve on the samples loses about
//! `√cond(M̃)·ε`; a patch whose factor is worse conditioned than
//! [`super::FitFactor::solves_from_moments`] allows is refined on its
//! samples as the first recovery was, bit for bit, and its cells' samples
//! are kept for it.

use rayon::prelude::*;

use super::mirror::{reflect_point, reflect_sample, reflect_value, reflected_axes};
use super::plan::FitPlans;
use super::regular::cell_centre;
use super::spr::{scaled, PatchSamples};
use super::{Monomials, Recovered, Sample};
use crate::element::ElementOrder;
use crate::grid::Grid;

/// The recovery on `nodes` (ascending, distinct, those `plans` was made
/// for) from the moments of `samples`; `None` when a fit gives non-finite
/// coefficients (non-finite samples), which the caller then searches anew.
pub(super) fn recover_from_moments<const NC: usize, S: PatchSamples<NC>>(
    grid: &Grid,
    nodes: Vec<usize>,
    samples: &S,
    plans: &FitPlans,
) -> Option<Recovered<NC>> {
    let basis = Monomials::new(plans.degree);
    let stride = basis.len() * NC;
    let cells = cell_data(grid, &basis, samples, plans);
    let mut coeffs = vec![0.0; nodes.len() * stride];
    let solved = coeffs
        .par_chunks_mut(stride)
        .zip(&plans.plans)
        .zip(&nodes)
        .map_init(
            || (vec![0.0; stride], vec![0.0; stride], Vec::new(), Vec::new()),
            |(atb, mirrored, buf, scratch), ((out, plan), &node)| {
                let centre = grid.node_position(ElementOrder::Q1, node);
                if !plan.factor.solves_from_moments() {
                    buf.clear();
                    for &(slot, mask) in &plan.cells {
                        buf.extend(cells.samples[slot].iter().map(|&sample| {
                            let (x, v) = reflect_sample(grid, samples, mask, sample);
                            (scaled(centre, grid.h, x), v)
                        }));
                    }
                    let fit = plan.factor.fit(&basis, buf).ok()?;
                    out.copy_from_slice(&fit);
                    return Some(());
                }
                atb.fill(0.0);
                let centroid = plan.factor.centroid();
                for &(slot, mask) in &plan.cells {
                    let mut m = &cells.moments[slot * stride..(slot + 1) * stride];
                    let mut x = cell_centre(grid, plans.cells[slot]);
                    if mask != 0 {
                        reflect_moments(samples, &basis, mask, m, mirrored);
                        m = mirrored;
                        x = reflect_point(grid, mask, x);
                    }
                    let t = [0, 1, 2].map(|k| (x[k] - centre[k]) / grid.h - centroid[k]);
                    basis.shift_moments::<NC>(t, m, atb);
                }
                plan.factor.fit_moments_into(atb, NC, out, scratch).ok()
            },
        )
        .all(|fit| fit.is_some());
    if !solved {
        return None;
    }
    Some(Recovered {
        grid: grid.clone(),
        basis,
        nodes,
        coeffs,
        info: plans.plans.iter().map(|p| p.info).collect(),
    })
}

/// What a recovery reads of each cell of the plans (by slot).
struct CellData<const NC: usize> {
    /// The moments of the cell's samples about its centre, `n_b · NC` a
    /// cell (term `j`, component `c` at `j·NC + c`).
    moments: Vec<f64>,
    /// The samples themselves, for the cells of the patches refined on
    /// their samples (empty for the others).
    samples: Vec<Vec<Sample<NC>>>,
}

/// The samples of every cell of `plans`, taken once, as moments about the
/// cell's centre `Σ_s φ_j(ξ_c(x_s)) v_{s,c}` and, where a refined patch
/// needs them, as they are.
fn cell_data<const NC: usize, S: PatchSamples<NC>>(
    grid: &Grid,
    basis: &Monomials,
    samples: &S,
    plans: &FitPlans,
) -> CellData<NC> {
    let stride = basis.len() * NC;
    let mut keep = vec![false; plans.cells.len()];
    for plan in plans.plans.iter() {
        if !plan.factor.solves_from_moments() {
            plan.cells.iter().for_each(|&(slot, _)| keep[slot] = true);
        }
    }
    let mut data = CellData {
        moments: vec![0.0; plans.cells.len() * stride],
        samples: vec![Vec::new(); plans.cells.len()],
    };
    data.moments
        .par_chunks_mut(stride)
        .zip(&mut data.samples)
        .zip(&plans.cells)
        .zip(&keep)
        .for_each_init(
            || (Vec::new(), vec![0.0; basis.len()]),
            |(buf, phi), (((m, kept), &cell), &keep)| {
                if !keep && samples.moments(cell, basis, m) {
                    return;
                }
                buf.clear();
                samples.samples(cell, buf);
                let centre = cell_centre(grid, cell);
                for (x, v) in buf.iter() {
                    basis.values(scaled(centre, grid.h, *x), phi);
                    for (row, p) in m.chunks_exact_mut(NC).zip(phi.iter()) {
                        for (r, vc) in row.iter_mut().zip(v) {
                            *r += p * vc;
                        }
                    }
                }
                if keep {
                    kept.extend_from_slice(buf);
                }
            },
        );
    data
}

/// The moments of a cell's mirror image across the faces in `mask`.
fn reflect_moments<const NC: usize, S: PatchSamples<NC>>(
    samples: &S,
    basis: &Monomials,
    mask: u8,
    m: &[f64],
    out: &mut [f64],
) {
    for ((row, e), o) in m
        .chunks_exact(NC)
        .zip(basis.exponents())
        .zip(out.chunks_exact_mut(NC))
    {
        let odd = reflected_axes(mask).filter(|&a| e[a] % 2 == 1).count();
        let sign = if odd % 2 == 1 { -1.0 } else { 1.0 };
        let v: [f64; NC] = std::array::from_fn(|c| sign * row[c]);
        o.copy_from_slice(&reflect_value(samples, mask, v));
    }
}
