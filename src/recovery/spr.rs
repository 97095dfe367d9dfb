//! Patch recovery over the grid's Q1 vertex nodes: gathering a node's patch
//! ring by ring, fitting it ([`super::fit_polynomial`]) in parallel over the
//! requested nodes, and evaluating the CPE blend ([`Recovered::eval`]).
//!
//! The work is proportional to the number of requested nodes: each patch visits
//! only the cells of its rings (8, 64, 216, … cells for rings 1, 2, 3), asks the
//! caller for those cells' samples once each, and the result stores one
//! polynomial per requested node.

use rayon::prelude::*;

use super::fit::{fit_polynomial, FitFailure, FitOptions, LinearConstraints};
use super::mirror::{reflect_point, reflected_axes, ring_cells, Mirror};
use super::sample_cache::SampleCache;
use super::{Monomials, Sample};
use crate::cells::CellKind;
use crate::element::{shape_values, ElementOrder};
use crate::error::{Error, Result};
use crate::grid::Grid;

/// The caller's FE field at the sample points: for a cell with positive volume
/// (kind ≠ outside), its sample points in Ω in physical coordinates and the
/// `NC` field components there (Gauss points of inside cells, cut-cell volume
/// points of cut cells). Closures `Fn(cell, &mut out)` implement it.
pub trait PatchSamples<const NC: usize>: Sync {
    /// Appends the samples of `cell` to `out` (without clearing it).
    fn samples(&self, cell: usize, out: &mut Vec<Sample<NC>>);

    /// Linear constraints `C a = d` on the stacked coefficients of the fit on
    /// `patch` in the scaled basis `basis` (see [`LinearConstraints`],
    /// [`Patch::scaled`]); none by default. Asked again for every ring tried.
    fn constraints(&self, _patch: &Patch<'_>, _basis: &Monomials) -> Option<LinearConstraints> {
        None
    }

    /// The field value `value` seen in the mirror across a plane normal to
    /// `axis` ([`super::Mirror`]); `None` (the default) for a field that
    /// cannot be reflected, whose patches then stop at the grid box.
    fn reflected(&self, _axis: usize, _value: [f64; NC]) -> Option<[f64; NC]> {
        None
    }
}

impl<F, const NC: usize> PatchSamples<NC> for F
where
    F: Fn(usize, &mut Vec<Sample<NC>>) + Sync,
{
    fn samples(&self, cell: usize, out: &mut Vec<Sample<NC>>) {
        self(cell, out)
    }
}

/// A patch being fitted: its vertex node, the node's position (the origin of
/// the scaled coordinates), the cell size, the ring and the patch's cells.
#[derive(Clone, Copy, Debug)]
pub struct Patch<'a> {
    pub node: usize,
    pub center: [f64; 3],
    pub h: f64,
    pub ring: usize,
    pub cells: &'a [usize],
}

impl Patch<'_> {
    /// The scaled coordinates `ξ = (x − x_node)/h` of a physical point.
    pub fn scaled(&self, x: [f64; 3]) -> [f64; 3] {
        scaled(self.center, self.h, x)
    }
}

fn scaled(center: [f64; 3], h: f64, x: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|k| (x[k] - center[k]) / h)
}

/// Options of [`recover`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SprOptions {
    /// Largest ring tried (at least 1 is always tried).
    pub max_rings: usize,
    /// Acceptance of a ring's fit; a rejected fit enlarges the patch.
    pub fit: FitOptions,
    /// Faces of the grid box that are symmetry planes: patches continue
    /// across them for fields that [`PatchSamples::reflected`] reflects.
    pub mirror: Mirror,
}

impl Default for SprOptions {
    /// Up to 3 rings (216 cells), default [`FitOptions`], no mirror.
    fn default() -> Self {
        SprOptions {
            max_rings: 3,
            fit: FitOptions::default(),
            mirror: Mirror::none(),
        }
    }
}

/// What one node's accepted patch was.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PatchInfo {
    /// Ring of the accepted fit (1: the cells sharing the vertex).
    pub ring: usize,
    /// Cells with positive volume in the patch.
    pub cells: usize,
    /// Sample points fitted.
    pub samples: usize,
}

/// Counts over all recovered patches, for reports.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RecoveryStats {
    pub patches: usize,
    /// Patches that needed more than one ring.
    pub enlarged: usize,
    /// `per_ring[r − 1]`: patches accepted at ring `r`.
    pub per_ring: Vec<usize>,
    /// Fewest samples of an accepted patch (0 when there is none).
    pub min_samples: usize,
}

/// The recovered field: one fitted polynomial per requested vertex node.
#[derive(Clone, Debug)]
pub struct Recovered<const NC: usize> {
    grid: Grid,
    basis: Monomials,
    /// Requested nodes, ascending and distinct.
    nodes: Vec<usize>,
    /// Stacked coefficients, `NC · n_b` per node.
    coeffs: Vec<f64>,
    info: Vec<PatchInfo>,
}

/// Recovers an `NC`-component field by SPR of degree `degree` on the patches of
/// the Q1 vertex nodes `nodes` (duplicates allowed) of `grid`, whose cell kinds
/// are `kinds`. Patches are fitted in parallel; each starts at ring 1 and is
/// enlarged ring by ring until its fit is accepted.
///
/// Errors: [`Error::Recovery`] for a node id outside the Q1 lattice, or for the
/// lowest-numbered node whose patch has no acceptable fit at
/// [`SprOptions::max_rings`].
///
/// # Panics
/// When `kinds` does not have one entry per cell of `grid`, or when
/// `degree` exceeds [`super::MAX_DEGREE`] (see [`Monomials::new`]).
pub fn recover<const NC: usize, S: PatchSamples<NC>>(
    grid: &Grid,
    kinds: &[CellKind],
    nodes: &[usize],
    degree: usize,
    samples: &S,
    opts: &SprOptions,
) -> Result<Recovered<NC>> {
    recover_from_rings(grid, kinds, nodes, degree, samples, opts, None)
}

/// [`recover`], with each patch's first fitted ring taken from `rings` (one
/// per node of the ascending, distinct `nodes`, as [`Recovered::rings`]
/// returns them after an earlier recovery with the same nodes, sample
/// positions and constraints); `None` starts every patch at ring 1.
///
/// A fit's acceptance depends on the sample positions and the constraint
/// matrix only, never on the values, so a later recovery of another field on
/// the same patches skips the fits that were rejected before and gives
/// bit-identical coefficients (about half of the S-term's displacement
/// patches on the sphere are enlarged).
///
/// # Panics
/// As [`recover`]; and when `rings` does not have one entry per distinct node.
pub fn recover_from_rings<const NC: usize, S: PatchSamples<NC>>(
    grid: &Grid,
    kinds: &[CellKind],
    nodes: &[usize],
    degree: usize,
    samples: &S,
    opts: &SprOptions,
    rings: Option<&[usize]>,
) -> Result<Recovered<NC>> {
    assert_eq!(kinds.len(), grid.num_cells(), "one kind per cell");
    let mut nodes = nodes.to_vec();
    nodes.sort_unstable();
    nodes.dedup();
    if let Some(r) = rings {
        assert_eq!(r.len(), nodes.len(), "one first ring per distinct node");
    }
    let num_nodes = grid.num_nodes(ElementOrder::Q1);
    if let Some(&node) = nodes.iter().find(|&&n| n >= num_nodes) {
        return Err(Error::Recovery {
            node,
            reason: format!("not a Q1 node of the grid (it has {num_nodes})"),
        });
    }
    let basis = Monomials::new(degree);
    // Patches continue across the mirror faces only for a field that reflects.
    let reflects = (0..3).all(|a| samples.reflected(a, [0.0; NC]).is_some());
    let ctx = Context {
        grid,
        kinds,
        basis: &basis,
        samples,
        opts,
        mirror: if reflects {
            opts.mirror
        } else {
            Mirror::none()
        },
    };
    let fits: Vec<Result<(Vec<f64>, PatchInfo)>> = nodes
        .par_iter()
        .enumerate()
        .map_init(
            || (Vec::new(), SampleCache::new()),
            |(buf, cache), (slot, &node)| {
                let first_ring = rings.map_or(1, |r| r[slot]);
                ctx.fit_node(node, first_ring, buf, cache)
            },
        )
        .collect();
    let mut coeffs = Vec::with_capacity(nodes.len() * NC * basis.len());
    let mut info = Vec::with_capacity(nodes.len());
    for fit in fits {
        let (a, i) = fit?;
        coeffs.extend(a);
        info.push(i);
    }
    Ok(Recovered {
        grid: grid.clone(),
        basis,
        nodes,
        coeffs,
        info,
    })
}

/// What every patch fit reads.
struct Context<'a, S> {
    grid: &'a Grid,
    kinds: &'a [CellKind],
    basis: &'a Monomials,
    samples: &'a S,
    opts: &'a SprOptions,
    /// The faces patches continue across (none for a field that does not
    /// reflect).
    mirror: Mirror,
}

impl<S> Context<'_, S> {
    /// Fits `node`'s patch from ring `first_ring` (the cells of the rings
    /// inside it included), enlarging it up to the ring limit; `buf` is
    /// scratch, `cache` the worker's memo of cell samples.
    fn fit_node<const NC: usize>(
        &self,
        node: usize,
        first_ring: usize,
        buf: &mut Vec<Sample<NC>>,
        cache: &mut SampleCache<NC>,
    ) -> Result<(Vec<f64>, PatchInfo)>
    where
        S: PatchSamples<NC>,
    {
        let center = self.grid.node_position(ElementOrder::Q1, node);
        let vertex = node_ijk(self.grid, node);
        let (mut patch_cells, mut cells) = (Vec::new(), Vec::new());
        buf.clear();
        let mut failure = None;
        let first_ring = first_ring.min(self.opts.max_rings.max(1));
        for ring in 1..=self.opts.max_rings.max(1) {
            let first = patch_cells.len();
            ring_cells(
                self.grid,
                self.kinds,
                &self.mirror,
                vertex,
                ring,
                &mut patch_cells,
            );
            for &(c, mask) in &patch_cells[first..] {
                let samples = cache.get(self.samples, c);
                if mask == 0 {
                    cells.push(c);
                }
                buf.extend(samples.iter().map(|&(x, v)| {
                    let (x, v) = self.reflect(mask, x, v);
                    (scaled(center, self.grid.h, x), v)
                }));
            }
            if ring < first_ring {
                continue;
            }
            let patch = Patch {
                node,
                center,
                h: self.grid.h,
                ring,
                cells: &cells,
            };
            let constraints = self.samples.constraints(&patch, self.basis);
            match fit_polynomial(self.basis, buf, constraints.as_ref(), &self.opts.fit) {
                Ok(a) => {
                    let info = PatchInfo {
                        ring,
                        cells: patch_cells.len(),
                        samples: buf.len(),
                    };
                    return Ok((a, info));
                }
                Err(f) => failure = Some(f),
            }
        }
        Err(Error::Recovery {
            node,
            reason: format!(
                "no acceptable patch fit within {} ring(s) of cells: {}",
                self.opts.max_rings.max(1),
                failure.map_or_else(String::new, |f: FitFailure| f.to_string())
            ),
        })
    }
}

impl<S> Context<'_, S> {
    /// A sample of a cell seen across the faces in `mask`.
    fn reflect<const NC: usize>(&self, mask: u8, x: [f64; 3], v: [f64; NC]) -> Sample<NC>
    where
        S: PatchSamples<NC>,
    {
        if mask == 0 {
            return (x, v);
        }
        let v = reflected_axes(mask).fold(v, |v, a| {
            self.samples
                .reflected(a, v)
                .expect("mirrored patches only for reflectable fields")
        });
        (reflect_point(self.grid, mask, x), v)
    }
}

/// Lattice indices of a Q1 node.
fn node_ijk(grid: &Grid, node: usize) -> [usize; 3] {
    let m = grid.nodes_per_axis(ElementOrder::Q1);
    [node % m[0], (node / m[0]) % m[1], node / (m[0] * m[1])]
}

impl<const NC: usize> Recovered<NC> {
    /// The polynomial basis of the patches.
    pub fn basis(&self) -> &Monomials {
        &self.basis
    }

    /// The recovered nodes, ascending.
    pub fn nodes(&self) -> &[usize] {
        &self.nodes
    }

    fn slot(&self, node: usize) -> Result<usize> {
        self.nodes
            .binary_search(&node)
            .map_err(|_| Error::Recovery {
                node,
                reason: "no patch was recovered for this node (it was not requested)".into(),
            })
    }

    /// The accepted patch of `node`, if it was requested.
    pub fn patch(&self, node: usize) -> Option<PatchInfo> {
        self.slot(node).ok().map(|s| self.info[s])
    }

    /// Stacked coefficients of `node`'s polynomial in the scaled basis
    /// (component `c`, term `j` at `c · n_b + j`).
    pub fn coefficients(&self, node: usize) -> Result<&[f64]> {
        let len = NC * self.basis.len();
        let s = self.slot(node)?;
        Ok(&self.coeffs[s * len..(s + 1) * len])
    }

    /// The accepted ring of each patch, in the order of [`Recovered::nodes`]
    /// (the hint of [`recover_from_rings`]).
    pub fn rings(&self) -> Vec<usize> {
        self.info.iter().map(|i| i.ring).collect()
    }

    /// Counts of rings and samples over the patches.
    pub fn stats(&self) -> RecoveryStats {
        let max_ring = self.info.iter().map(|i| i.ring).max().unwrap_or(0);
        let mut per_ring = vec![0; max_ring];
        for i in &self.info {
            per_ring[i.ring - 1] += 1;
        }
        RecoveryStats {
            patches: self.info.len(),
            enlarged: self.info.iter().filter(|i| i.ring > 1).count(),
            per_ring,
            min_samples: self.info.iter().map(|i| i.samples).min().unwrap_or(0),
        }
    }

    /// `σ*_node(x)`, the patch polynomial of `node` at the physical point `x`
    /// (any point: the polynomial extends beyond its patch).
    pub fn eval_node_polynomial(&self, node: usize, x: [f64; 3]) -> Result<[f64; NC]> {
        let a = self.coefficients(node)?;
        let center = self.grid.node_position(ElementOrder::Q1, node);
        let mut phi = vec![0.0; self.basis.len()];
        Ok(polynomial_at(
            self.basis(),
            a,
            center,
            self.grid.h,
            x,
            &mut phi,
        ))
    }

    /// The CPE blend `σ̂(x) = Σ_i N_i^lin(x) σ*_i(x)` over the 8 vertices `i` of
    /// `cell`, for `x` in the cell's box (also outside Ω). Error
    /// [`Error::Recovery`] when a vertex of the cell was not recovered.
    ///
    /// # Panics
    /// When `cell` is not a cell of the grid.
    pub fn eval(&self, cell: usize, x: [f64; 3]) -> Result<[f64; NC]> {
        Ok(self.cell_blend(cell)?.eval(x))
    }

    /// [`Recovered::eval`] on `cell` with the cell's vertices looked up once,
    /// for callers that evaluate many points of one cell.
    ///
    /// # Panics
    /// When `cell` is not a cell of the grid.
    pub fn cell_blend(&self, cell: usize) -> Result<CellBlend<'_, NC>> {
        assert!(cell < self.grid.num_cells(), "cell {cell} out of range");
        let mut vertices = [0; 8];
        self.grid.cell_nodes(ElementOrder::Q1, cell, &mut vertices);
        let mut coeffs: [&[f64]; 8] = [&[]; 8];
        for (slot, &node) in coeffs.iter_mut().zip(&vertices) {
            *slot = self.coefficients(node)?;
        }
        Ok(CellBlend {
            basis: &self.basis,
            h: self.grid.h,
            lo: self.grid.cell_box(cell).lo,
            centers: vertices.map(|node| self.grid.node_position(ElementOrder::Q1, node)),
            coeffs,
        })
    }
}

/// The CPE blend on one cell: its 8 vertices' positions and polynomials
/// ([`Recovered::cell_blend`]).
pub struct CellBlend<'a, const NC: usize> {
    basis: &'a Monomials,
    h: f64,
    lo: [f64; 3],
    centers: [[f64; 3]; 8],
    coeffs: [&'a [f64]; 8],
}

impl<const NC: usize> CellBlend<'_, NC> {
    /// `σ̂(x) = Σ_i N_i^lin(x) σ*_i(x)` for `x` in the cell's box.
    pub fn eval(&self, x: [f64; 3]) -> [f64; NC] {
        let mut hat = [0.0; 8];
        shape_values(ElementOrder::Q1, scaled(self.lo, self.h, x), &mut hat);
        let nb = self.basis.len();
        let mut small = [0.0; SMALL_BASIS];
        let mut large = Vec::new();
        let phi = if nb <= SMALL_BASIS {
            &mut small[..nb]
        } else {
            large.resize(nb, 0.0);
            &mut large[..]
        };
        let mut out = [0.0; NC];
        for ((center, a), &w) in self.centers.iter().zip(&self.coeffs).zip(&hat) {
            let s: [f64; NC] = polynomial_at(self.basis, a, *center, self.h, x, phi);
            for c in 0..NC {
                out[c] += w * s[c];
            }
        }
        out
    }
}

/// The patch polynomial with stacked coefficients `a` (component `c`, term
/// `j` at `c · n_b + j`) of the vertex at `center` at the physical point `x`;
/// `phi` is scratch of the basis's length.
fn polynomial_at<const NC: usize>(
    basis: &Monomials,
    a: &[f64],
    center: [f64; 3],
    h: f64,
    x: [f64; 3],
    phi: &mut [f64],
) -> [f64; NC] {
    basis.values(scaled(center, h, x), phi);
    let nb = phi.len();
    std::array::from_fn(|c| (0..nb).map(|j| a[c * nb + j] * phi[j]).sum())
}

/// Basis sizes up to this (degree 3) are evaluated in a stack buffer.
const SMALL_BASIS: usize = 20;
