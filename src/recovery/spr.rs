//! Patch recovery over the grid's Q1 vertex nodes: gathering a node's patch
//! ring by ring and fitting it ([`super::fit_polynomial`]) in parallel over the requested
//! nodes, into a [`Recovered`] field.
//!
//! The work is proportional to the number of requested nodes: each patch visits
//! only the cells of its rings (8, 64, 216, … cells for rings 1, 2, 3), asks the
//! caller for those cells' samples once each, and the result stores one
//! polynomial per requested node.

use rayon::prelude::*;

use super::fit::{
    fit_and_factor, plan_factor, FitFactor, FitFailure, FitOptions, LinearConstraints,
};
use super::mirror::{reflect_sample, ring_cells, Mirror, PatchCell};
use super::recovered::Recovered;
use super::regular::{is_regular, RegularFit};
use super::sample_cache::SampleCache;
use super::{Monomials, Sample};
use crate::cells::CellKind;
use crate::element::ElementOrder;
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

    /// The moments `Σ_s φ_j(ξ_c(x_s)) v_{s,c}` of `cell`'s samples about
    /// the cell's centre (`ξ_c = (x − x_c)/h`), into `out` (`n_b · NC`, term
    /// `j`, component `c` at `j·NC + c`), where they can be had without the
    /// samples ([`super::InsideMoments`]); `false` (the default, nothing
    /// written) otherwise.
    fn moments(&self, _cell: usize, _basis: &Monomials, _out: &mut [f64]) -> bool {
        false
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

pub(super) fn scaled(center: [f64; 3], h: f64, x: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|k| (x[k] - center[k]) / h)
}

/// Options of [`recover`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SprOptions<'a> {
    /// Largest ring tried (at least 1 is always tried).
    pub max_rings: usize,
    /// Acceptance of a ring's fit; a rejected fit enlarges the patch.
    pub fit: FitOptions,
    /// Faces of the grid box that are symmetry planes: patches continue
    /// across them for fields that [`PatchSamples::reflected`] reflects.
    pub mirror: Mirror,
    /// The body's piece of each cell ([`crate::cells::pieces::Pieces`]):
    /// a patch keeps to its node's piece, so that no fit couples two pieces
    /// that share no node. `None`: one piece.
    pub pieces: Option<&'a [u32]>,
}

impl Default for SprOptions<'_> {
    /// Up to 3 rings (216 cells), default [`FitOptions`], no mirror, one
    /// piece.
    fn default() -> Self {
        SprOptions {
            max_rings: 3,
            fit: FitOptions::default(),
            mirror: Mirror::none(),
            pieces: None,
        }
    }
}

/// What one node's accepted patch was.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
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
    recover_around(grid, kinds, nodes, degree, samples, opts, None)
}

/// [`recover`], taking the fit of every node that `known` holds from it (a
/// recovery of the same field with the same samples and options on some of
/// the nodes, e.g. the last one of a loop); `None`: [`recover`].
///
/// # Panics
/// As [`recover`]; and when `known` has another degree.
pub fn recover_around<const NC: usize, S: PatchSamples<NC>>(
    grid: &Grid,
    kinds: &[CellKind],
    nodes: &[usize],
    degree: usize,
    samples: &S,
    opts: &SprOptions,
    known: Option<&Recovered<NC>>,
) -> Result<Recovered<NC>> {
    if let Some(k) = known {
        assert_eq!(
            k.basis.degree(),
            degree,
            "a known recovery of another degree"
        );
    }
    let planning = Planning::Search;
    recover_with(grid, kinds, nodes, degree, samples, opts, planning, known).map(|(r, _)| r)
}

/// Whether [`recover_with`] returns each accepted fit's plan.
#[derive(Clone, Copy)]
pub(super) enum Planning {
    /// Search the rings from 1.
    Search,
    /// Search, and return each accepted fit's plan (one per distinct node,
    /// ascending).
    SearchAndKeep,
    /// [`Planning::SearchAndKeep`] without the fits: the plans only, the
    /// coefficients left zero (the samples' values are not read).
    PlanOnly,
}

/// The recovery of [`recover`], [`recover_around`] and
/// [`super::recover_planned`], each node's fit as `planning` says (the
/// nodes that `known` holds taken from it); returns the kept plans (empty
/// unless [`Planning::SearchAndKeep`]).
#[allow(clippy::too_many_arguments)]
pub(super) fn recover_with<const NC: usize, S: PatchSamples<NC>>(
    grid: &Grid,
    kinds: &[CellKind],
    nodes: &[usize],
    degree: usize,
    samples: &S,
    opts: &SprOptions,
    planning: Planning,
    known: Option<&Recovered<NC>>,
) -> Result<(Recovered<NC>, Vec<NodePlan>)> {
    assert_eq!(kinds.len(), grid.num_cells(), "one kind per cell");
    let mut nodes = nodes.to_vec();
    nodes.sort_unstable();
    nodes.dedup();
    let keep = matches!(planning, Planning::SearchAndKeep | Planning::PlanOnly);
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
        keep,
        fits: !matches!(planning, Planning::PlanOnly),
    };
    let stride = NC * basis.len();
    let mut coeffs = vec![0.0; nodes.len() * stride];
    let mut info = vec![PatchInfo::default(); nodes.len()];
    // Which nodes are fitted: those that `known` holds, then the regular
    // patches from their cells' moments (not for kept plans, whose patches
    // are at the boundary), then every other patch on its own.
    let mut fitted = vec![false; nodes.len()];
    // `known` holds few of the nodes (the boundary's): each is looked up.
    if let Some(k) = known {
        for (s, node) in k.nodes.iter().enumerate() {
            if let Ok(i) = nodes.binary_search(node) {
                coeffs[i * stride..(i + 1) * stride]
                    .copy_from_slice(&k.coeffs[s * stride..(s + 1) * stride]);
                (info[i], fitted[i]) = (k.info[s], true);
            }
        }
    }
    if let Some(r) = (!keep).then(|| ctx.regular_fit(&nodes)).flatten() {
        let mut candidates = ctx.regular_nodes(&nodes);
        for (c, f) in candidates.iter_mut().zip(&fitted) {
            *c &= !f;
        }
        r.fit_into(
            grid,
            &basis,
            samples,
            &nodes,
            &candidates,
            &mut coeffs,
            &mut fitted,
        );
        let ring_one = PatchInfo {
            ring: 1,
            cells: 8,
            samples: r.samples,
        };
        for ((i, &c), &f) in info.iter_mut().zip(&candidates).zip(&fitted) {
            if c && f {
                *i = ring_one;
            }
        }
    }
    // The searched fits' plans, or the first (lowest node's) failure.
    let searched: Vec<Result<NodePlan>> = (coeffs.par_chunks_mut(stride).zip(&mut info))
        .zip(&nodes)
        .zip(&fitted)
        .filter(|(_, &f)| !f)
        .map_init(
            || (Vec::new(), SampleCache::new()),
            |(buf, cache), (((c, i), &node), _)| {
                let fit = ctx.fit_node(node, buf, cache);
                fit.map(|fit| {
                    if !fit.coefficients.is_empty() {
                        c.copy_from_slice(&fit.coefficients);
                    }
                    *i = fit.info;
                    fit.plan
                })
                .transpose()
            },
        )
        .flatten()
        .collect();
    let kept = searched.into_iter().collect::<Result<Vec<_>>>()?;
    let recovered = Recovered {
        grid: grid.clone(),
        basis,
        nodes,
        coeffs,
        info,
    };
    Ok((recovered, kept))
}

/// One node's accepted fit: its patch's cells with their mirror masks (in
/// the order their samples were fitted), what the patch was, and the
/// [`FitFactor`] of its samples.
pub(super) struct NodePlan {
    pub(super) cells: Vec<(usize, u8)>,
    pub(super) info: PatchInfo,
    pub(super) factor: FitFactor,
}

/// What [`Context::fit_node`] returns.
struct NodeFit {
    /// Empty for [`Planning::PlanOnly`].
    coefficients: Vec<f64>,
    info: PatchInfo,
    /// The accepted fit, when the recovery keeps them.
    plan: Option<NodePlan>,
}

/// What every patch fit reads.
struct Context<'a, S> {
    grid: &'a Grid,
    kinds: &'a [CellKind],
    basis: &'a Monomials,
    samples: &'a S,
    opts: &'a SprOptions<'a>,
    /// The faces patches continue across (none for a field that does not
    /// reflect).
    mirror: Mirror,
    /// Whether each fit returns its [`NodePlan`] ([`Planning::SearchAndKeep`]).
    keep: bool,
    /// Whether the fits are solved (not for [`Planning::PlanOnly`]).
    fits: bool,
}

impl<S> Context<'_, S> {
    /// The template of the regular patches ([`super::regular`]), from the
    /// lowest of `nodes` (ascending) whose first ring is regular; `None`
    /// when no node's is, or when that fit is constrained or not fit to
    /// serve the others.
    fn regular_fit<const NC: usize>(&self, nodes: &[usize]) -> Option<RegularFit>
    where
        S: PatchSamples<NC>,
    {
        let mut ring = Vec::new();
        let node = nodes
            .iter()
            .copied()
            .find(|&node| self.ring_one_is_regular(node, &mut ring))?;
        let center = self.grid.node_position(ElementOrder::Q1, node);
        let cells: Vec<usize> = ring.iter().map(|&(c, _)| c).collect();
        let per_cell: Vec<Vec<Sample<NC>>> = cells
            .iter()
            .map(|&c| {
                let mut samples = Vec::new();
                self.samples.samples(c, &mut samples);
                samples
            })
            .collect();
        if self.constrained(node, &cells) {
            return None;
        }
        RegularFit::new(
            self.grid,
            self.basis,
            center,
            &cells,
            &per_cell,
            &self.opts.fit,
        )
    }

    /// Whether each of `nodes` has a regular first ring and no constraints.
    fn regular_nodes<const NC: usize>(&self, nodes: &[usize]) -> Vec<bool>
    where
        S: PatchSamples<NC>,
    {
        nodes
            .par_iter()
            .map_init(Vec::new, |ring, &node| {
                self.ring_one_is_regular(node, ring) && {
                    let cells: Vec<usize> = ring.iter().map(|&(c, _)| c).collect();
                    !self.constrained(node, &cells)
                }
            })
            .collect()
    }

    /// Whether `node`'s first ring (left in `ring`) is regular.
    fn ring_one_is_regular(&self, node: usize, ring: &mut Vec<PatchCell>) -> bool {
        ring.clear();
        let vertex = node_ijk(self.grid, node);
        ring_cells(self.grid, self.kinds, &self.mirror, vertex, 1, ring);
        is_regular(self.kinds, ring)
    }

    /// Whether the caller constrains the first-ring fit of `node` on `cells`.
    fn constrained<const NC: usize>(&self, node: usize, cells: &[usize]) -> bool
    where
        S: PatchSamples<NC>,
    {
        let patch = Patch {
            node,
            center: self.grid.node_position(ElementOrder::Q1, node),
            h: self.grid.h,
            ring: 1,
            cells,
        };
        self.samples.constraints(&patch, self.basis).is_some()
    }

    /// Fits `node`'s patch ring by ring up to the ring limit; `buf` is
    /// scratch, `cache` the worker's memo of cell samples.
    fn fit_node<const NC: usize>(
        &self,
        node: usize,
        buf: &mut Vec<Sample<NC>>,
        cache: &mut SampleCache<NC>,
    ) -> Result<NodeFit>
    where
        S: PatchSamples<NC>,
    {
        let center = self.grid.node_position(ElementOrder::Q1, node);
        let vertex = node_ijk(self.grid, node);
        let (mut patch_cells, mut cells) = (Vec::new(), Vec::new());
        let mut points = Vec::new();
        let mut piece: Option<Option<u32>> = None;
        buf.clear();
        let mut failure = None;
        let max_rings = self.opts.max_rings.max(1);
        for ring in 1..=max_rings {
            let first = patch_cells.len();
            ring_cells(
                self.grid,
                self.kinds,
                &self.mirror,
                vertex,
                ring,
                &mut patch_cells,
            );
            if let Some(of_cell) = self.opts.pieces {
                // Ring 1's cells share the node, so they are all its piece.
                let own =
                    *piece.get_or_insert_with(|| patch_cells.first().map(|&(c, _)| of_cell[c]));
                patch_cells.retain(|&(c, _)| Some(of_cell[c]) == own);
            }
            for &(c, mask) in &patch_cells[first..] {
                let samples = cache.get(self.samples, c);
                if mask == 0 {
                    cells.push(c);
                }
                buf.extend(samples.iter().map(|&(x, v)| {
                    let (x, v) = reflect_sample(self.grid, self.samples, mask, (x, v));
                    (scaled(center, self.grid.h, x), v)
                }));
            }
            let patch = Patch {
                node,
                center,
                h: self.grid.h,
                ring,
                cells: &cells,
            };
            let constraints = self.samples.constraints(&patch, self.basis);
            let (basis, fit) = (self.basis, &self.opts.fit);
            let fitted = match self.fits {
                true => fit_and_factor(basis, buf, constraints.as_ref(), fit),
                false => {
                    points.clear();
                    points.extend(buf.iter().map(|(x, _)| *x));
                    plan_factor(basis, &points, NC, constraints.as_ref(), fit)
                        .map(|factor| (Vec::new(), factor))
                }
            };
            match fitted {
                Ok((coefficients, factor)) => {
                    let info = PatchInfo {
                        ring,
                        cells: patch_cells.len(),
                        samples: buf.len(),
                    };
                    return Ok(NodeFit {
                        coefficients,
                        info,
                        plan: self.keep.then_some(NodePlan {
                            cells: patch_cells,
                            info,
                            factor,
                        }),
                    });
                }
                Err(f) => failure = Some(f),
            }
        }
        Err(Error::Recovery {
            node,
            reason: format!(
                "no acceptable patch fit within {max_rings} ring(s) of cells: {}",
                failure.map_or_else(String::new, |f: FitFailure| f.to_string())
            ),
        })
    }
}

/// Lattice indices of a Q1 node.
pub(super) fn node_ijk(grid: &Grid, node: usize) -> [usize; 3] {
    let m = grid.nodes_per_axis(ElementOrder::Q1);
    [node % m[0], (node / m[0]) % m[1], node / (m[0] * m[1])]
}
