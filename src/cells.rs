//! Classification of the grid's cells against the geometry (inside / outside /
//! cut), the cut cells' quadrature rules, volume fractions and active nodes.
//!
//! The classification descends a block hierarchy: a block of cells whose level
//! set bounds (interval arithmetic) are strictly negative is inside as a whole,
//! strictly positive outside; only blocks the boundary may cross are split, so
//! the work follows the number of cut cells (~4× per level), not the number of
//! cells (8× per level). A geometry that is one mesh solid is classified by
//! flood fill instead ([`flood`]); a CSG tree with mesh leaves takes the
//! descent, a mesh's bounds over a block being decided by whether a triangle
//! meets it. Single candidate cells get their cut rule (in parallel).
//! A candidate whose rule has no volume is outside; one with full volume and no
//! boundary points is inside; the rest are cut. A cell with a boundary part on
//! one of its faces and the body on its side is cut with volume fraction 1: it
//! carries that part's boundary points. A cut cell with a negligible part of
//! the body is merged into a neighbour ([`merge`]); the faces of cells and
//! their area rules are in [`faces`].

mod faces;
mod flood;
mod merge;
pub mod glued;
pub mod split;
pub mod pieces;

pub use faces::{face_box, face_neighbour, face_rule, CutFaceRules};
pub use merge::NEGLIGIBLE_FRACTION;

use rayon::prelude::*;

use crate::element::ElementOrder;
use crate::error::{Error, Result};
use crate::geometry::Geometry;
use crate::grid::{CellBox, Grid};
use crate::progress::{Event, Phase, Progress, Silent};
use crate::quadrature::saye::{box_rule, BoxRule, SurfacePoint, VolumePoint};

/// The class of a cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum CellKind {
    Outside = 0,
    Inside = 1,
    Cut = 2,
}

/// Points per segment and dimension of the cut-cell rules: 2 for Q1 (its own
/// Gauss order) and 4 for Q2 (one more than its Gauss order).
///
/// Saye's rules converge at about order 2q in h on curved boundaries (measured
/// on the unit sphere, see `tests/suite/geometry/quadrature.rs`): q = 2 gives 4th order,
/// above the 2nd that Q1 needs. Q2 needs 3rd order, which q = 3 would give, but
/// the cell-by-cell divergence theorem to 1e-10 at level 5 needs q = 4 (q = 3
/// leaves 3e-9 on the few cells whose cut is strongly curved relative to h).
pub fn cut_rule_points(order: ElementOrder) -> usize {
    match order {
        ElementOrder::Q1 => 2,
        ElementOrder::Q2 => 4,
    }
}

/// A cut cell gives its fits all of its points up to this many
/// ([`Cells::fit_points`]): Q1 cut cells have about 14 with the default
/// rule (the plate with a hole of `tests/suite/fem/symmetry.rs`: 8 to 128), Q2 64 to
/// 384 on the sphere at level 3; only cells refined where several surfaces
/// meet have more (Hertz's ball at its pole on two symmetry planes: over
/// 1 000). With every point, `quadrature.points = 8` made the recovery of a
/// level-3 patch test minutes long (512 points a cell). Lower caps cost the
/// Q2 fixed point its conditioning: with 128 the Q2 sphere's Jacobi and
/// multigrid answers were 2.6e-7 apart (`tests/suite/fem/multigrid_fixed_point.rs`
/// asks 1e-7), as with a density-following symmetric subset of 64.
pub const MAX_FIT_POINTS: usize = 384;

/// The cells of a grid classified against a geometry, with the cut cells'
/// rules stored flat (cut cell `i`'s volume points are
/// `volume[volume_start[i]..volume_start[i + 1]]`, likewise for the surface).
#[derive(Clone, Debug)]
pub struct Cells {
    pub kinds: Vec<CellKind>,
    /// Cut cell ids, ascending.
    pub cut: Vec<usize>,
    /// `|c ∩ Ω| / h³` per cut cell, in [0, 1].
    pub fraction: Vec<f64>,
    pub volume_start: Vec<usize>,
    pub volume: Vec<VolumePoint>,
    pub surface_start: Vec<usize>,
    pub surface: Vec<SurfacePoint>,
    /// Sample points of the cut cells whose volume points are not all in
    /// the body ([`BoxRule::samples`]), flat like the rules.
    pub sample_start: Vec<usize>,
    pub samples: Vec<[f64; 3]>,
    pub num_inside: usize,
    /// Cut cells of negligible volume merged into a neighbour ([`merge`]),
    /// ascending.
    pub merged: Vec<usize>,
    /// Cut cells, ascending, whose rule is the first-order repaired one of
    /// a mesh with defects ([`crate::quadrature::repaired`]).
    pub repaired: Vec<usize>,
}

impl Cells {
    /// Classifies `grid`'s cells and builds cut-cell rules with `q` points per
    /// segment.
    pub fn classify(grid: &Grid, geometry: &Geometry, q: usize) -> Result<Cells> {
        Cells::classify_with_progress(grid, geometry, q, &Silent)
    }

    /// [`Cells::classify`], reporting each cut-cell rule built to `progress`
    /// (phase [`Phase::Quadrature`], one step per candidate cell).
    pub fn classify_with_progress(
        grid: &Grid,
        geometry: &Geometry,
        q: usize,
        progress: &dyn Progress,
    ) -> Result<Cells> {
        Cells::classify_in(grid, geometry, q, &grid.all_cells(), progress)
    }

    /// [`Cells::classify_with_progress`] over the cells of `window` only:
    /// every other cell is outside (a rank's cells and its ghost layers).
    /// Each cell in the window gets the kind and rule it gets in the whole
    /// grid's classification, except where a negligible cut cell would
    /// merge into a neighbour outside the window ([`merge`]). A window that
    /// meets no solid is not an error; the whole grid is.
    pub fn classify_in(
        grid: &Grid,
        geometry: &Geometry,
        q: usize,
        window: &CellBox,
        progress: &dyn Progress,
    ) -> Result<Cells> {
        let gbox = grid.bounding_box();
        if geometry.bounding_box().intersection(&gbox).is_empty() {
            return Err(Error::GeometryOutsideGrid {
                lo: gbox.lo,
                hi: gbox.hi,
            });
        }
        let mut kinds = vec![CellKind::Outside; grid.num_cells()];
        let mut candidates = Vec::new();
        match geometry.mesh() {
            Some(mesh) => {
                candidates = flood::classify(grid, mesh, &mut kinds);
                if *window != grid.all_cells() {
                    keep_window(grid, window, &mut kinds, &mut candidates);
                }
            }
            None => descend(
                grid,
                geometry,
                window.lo,
                window.hi,
                &mut kinds,
                &mut candidates,
            ),
        }
        candidates.sort_unstable();
        let phase = Phase::Quadrature;
        progress.event(&Event::Start {
            phase,
            total: Some(candidates.len() as u64),
        });
        let rules: Vec<BoxRule> = candidates
            .par_iter()
            .map(|&c| {
                let rule = box_rule(geometry, &grid.cell_box(c), &[0, 1, 2], q);
                progress.event(&Event::Advance { phase, steps: 1 });
                rule
            })
            .collect();
        progress.event(&Event::Finish { phase });
        let cell_volume = grid.h.powi(3);
        let mut entries = Vec::with_capacity(candidates.len());
        for (c, rule) in candidates.into_iter().zip(rules) {
            let vol: f64 = rule.volume.iter().map(|p| p.w).sum();
            if vol.is_nan() || vol <= 0.0 {
                continue;
            }
            if rule.surface.is_empty() && vol / cell_volume > 1.0 - 1e-12 {
                kinds[c] = CellKind::Inside;
                continue;
            }
            kinds[c] = CellKind::Cut;
            entries.push((c, rule));
        }
        let merged = merge::merge_negligible(grid, geometry, q, &mut kinds, &mut entries);
        let mut cells = Cells {
            kinds,
            cut: Vec::with_capacity(entries.len()),
            fraction: Vec::with_capacity(entries.len()),
            volume_start: vec![0],
            volume: Vec::new(),
            surface_start: vec![0],
            surface: Vec::new(),
            sample_start: vec![0],
            samples: Vec::new(),
            num_inside: 0,
            merged,
            repaired: Vec::new(),
        };
        for (c, rule) in entries {
            if rule.repaired {
                cells.repaired.push(c);
            }
            let vol: f64 = rule.volume.iter().map(|p| p.w).sum();
            cells.cut.push(c);
            cells.fraction.push((vol / cell_volume).clamp(0.0, 1.0));
            cells.volume.extend(rule.volume);
            cells.volume_start.push(cells.volume.len());
            cells.surface.extend(rule.surface);
            cells.surface_start.push(cells.surface.len());
            cells.samples.extend(rule.samples);
            cells.sample_start.push(cells.samples.len());
        }
        cells.num_inside = cells
            .kinds
            .iter()
            .filter(|k| **k == CellKind::Inside)
            .count();
        let whole = *window == grid.all_cells();
        if whole && cells.num_inside == 0 && cells.cut.is_empty() {
            return Err(Error::EmptyGeometry {
                what: format!("no cell of the level-{} grid meets the solid", grid.level),
            });
        }
        Ok(cells)
    }

    /// The kinds of `grid`'s cells without their rules: the cells that
    /// classification would give a rule (the candidates) are marked cut.
    /// For weighing work ([`crate::distributed::partition`]) before the
    /// cells are shared out.
    pub fn rough_kinds(grid: &Grid, geometry: &Geometry) -> Vec<CellKind> {
        let mut kinds = vec![CellKind::Outside; grid.num_cells()];
        let candidates = match geometry.mesh() {
            Some(mesh) => flood::classify(grid, mesh, &mut kinds),
            None => {
                let mut candidates = Vec::new();
                descend(grid, geometry, [0; 3], grid.n, &mut kinds, &mut candidates);
                candidates
            }
        };
        for c in candidates {
            kinds[c] = CellKind::Cut;
        }
        kinds
    }

    /// Position of `cell` in [`Cells::cut`], if it is cut (binary search: the
    /// list is ascending).
    pub fn cut_position(&self, cell: usize) -> Option<usize> {
        self.cut.binary_search(&cell).ok()
    }

    /// Volume points of the `i`-th cut cell.
    pub fn volume_points(&self, i: usize) -> &[VolumePoint] {
        &self.volume[self.volume_start[i]..self.volume_start[i + 1]]
    }

    /// Sample points of the `i`-th cut cell for least-squares fits: its own
    /// list when its volume points are not all in the body, else empty (use
    /// the volume points).
    pub fn sample_points(&self, i: usize) -> &[[f64; 3]] {
        &self.samples[self.sample_start[i]..self.sample_start[i + 1]]
    }

    /// Points of the `i`-th cut cell for least-squares fits (SPR samples):
    /// its [`Self::sample_points`] or, where it has none, its volume points,
    /// all of them up to `max` (the recoveries of the solution take
    /// [`MAX_FIT_POINTS`]), else about that many strided in the rule's sweep
    /// order. The samples keep the base rule's points
    /// where the volume rule took more
    /// ([`crate::quadrature::saye::box_rule`]), so the fits do not depend on
    /// the accuracy of the volume rule.
    ///
    /// All points, where they are not too many, because a strided subset is
    /// not mirror symmetric: a mirror image of the cell lists its points in
    /// another order, so a symmetric problem would get a recovery that is
    /// not symmetric (`tests/suite/fem/symmetry.rs`). A cell over the cap (a raised
    /// `quadrature.points`, or a cell refined where several surfaces meet)
    /// is strided and not symmetric.
    pub fn fit_points(&self, i: usize, max: usize) -> Vec<[f64; 3]> {
        let own = self.sample_points(i);
        let stride = |n: usize| n.div_ceil(max).max(1);
        if own.is_empty() {
            let pts = self.volume_points(i);
            pts.iter().step_by(stride(pts.len())).map(|q| q.x).collect()
        } else {
            own.iter().step_by(stride(own.len())).copied().collect()
        }
    }

    /// Boundary points of the `i`-th cut cell.
    pub fn surface_points(&self, i: usize) -> &[SurfacePoint] {
        &self.surface[self.surface_start[i]..self.surface_start[i + 1]]
    }

    /// Calls `f(x, w)` for every volume quadrature point of `Ω ∩ grid`: the
    /// `n^3` tensor Gauss rule on inside cells and the cut-cell rules.
    pub fn for_each_volume_point(&self, grid: &Grid, n: usize, mut f: impl FnMut([f64; 3], f64)) {
        let rule = crate::element::tensor_gauss_rule(n);
        let vol = grid.h.powi(3);
        for (c, kind) in self.kinds.iter().enumerate() {
            if *kind == CellKind::Inside {
                let lo = grid.cell_box(c).lo;
                for (xi, w) in &rule {
                    f([0, 1, 2].map(|i| lo[i] + grid.h * xi[i]), w * vol);
                }
            }
        }
        for p in &self.volume {
            f(p.x, p.w);
        }
    }

    /// `|Ω ∩ grid|`: inside cells exactly plus the cut-cell rules, summed
    /// with compensation (millions of weights summed plainly lose 1e-13
    /// relative, above what the rules themselves reach).
    pub fn volume(&self, grid: &Grid) -> f64 {
        let cut = compensated_sum(self.volume.iter().map(|p| p.w));
        self.num_inside as f64 * grid.h.powi(3) + cut
    }

    /// `|∂Ω ∩ grid|` by the surface rules (compensated sum).
    pub fn boundary_area(&self) -> f64 {
        compensated_sum(self.surface.iter().map(|p| p.w))
    }

    /// Map node → dof-node index (`u32::MAX` for inactive nodes): the nodes of
    /// cells with positive volume, numbered in node order.
    pub fn active_nodes(&self, grid: &Grid, order: ElementOrder) -> (Vec<u32>, usize) {
        let mut map = vec![u32::MAX; grid.num_nodes(order)];
        let mut nodes = vec![0; order.nodes_per_cell()];
        for (c, kind) in self.kinds.iter().enumerate() {
            if *kind != CellKind::Outside {
                grid.cell_nodes(order, c, &mut nodes);
                for &n in &nodes {
                    map[n] = 0;
                }
            }
        }
        let mut count = 0usize;
        for m in map.iter_mut().filter(|m| **m == 0) {
            *m = count as u32;
            count += 1;
        }
        (map, count)
    }
}

/// Classifies the block `lo ≤ ijk < hi` by interval bounds, splitting it until
/// it is decided or a single candidate cell.
/// Marks the cells outside `window` outside and drops them from the
/// candidates.
fn keep_window(grid: &Grid, window: &CellBox, kinds: &mut [CellKind], candidates: &mut Vec<usize>) {
    for (c, kind) in kinds.iter_mut().enumerate() {
        if !window.contains(grid.cell_ijk(c)) {
            *kind = CellKind::Outside;
        }
    }
    candidates.retain(|&c| window.contains(grid.cell_ijk(c)));
}

fn descend(
    grid: &Grid,
    g: &Geometry,
    lo: [usize; 3],
    hi: [usize; 3],
    kinds: &mut [CellKind],
    candidates: &mut Vec<usize>,
) {
    let bounds = g.bounds(&grid.block_box(lo, hi));
    if bounds.lo > 0.0 {
        return;
    }
    if bounds.hi < 0.0 {
        for k in lo[2]..hi[2] {
            for j in lo[1]..hi[1] {
                let row = grid.cell_index([lo[0], j, k]);
                kinds[row..row + hi[0] - lo[0]].fill(CellKind::Inside);
            }
        }
        return;
    }
    let size = [0, 1, 2].map(|i| hi[i] - lo[i]);
    if size == [1, 1, 1] {
        candidates.push(grid.cell_index(lo));
        return;
    }
    // Halve every axis longer than one cell.
    let mid = [0, 1, 2].map(|i| lo[i] + size[i] / 2);
    for corner in 0..8 {
        let mut a = lo;
        let mut b = hi;
        let mut empty = false;
        for i in 0..3 {
            if corner >> i & 1 == 0 {
                b[i] = if size[i] > 1 { mid[i] } else { hi[i] };
            } else if size[i] > 1 {
                a[i] = mid[i];
            } else {
                empty = true;
            }
        }
        if !empty {
            descend(grid, g, a, b, kinds, candidates);
        }
    }
}

/// Neumaier's compensated sum.
pub(crate) fn compensated_sum(values: impl Iterator<Item = f64>) -> f64 {
    let (mut sum, mut carry) = (0.0f64, 0.0f64);
    for v in values {
        let t = sum + v;
        carry += if sum.abs() >= v.abs() {
            (sum - t) + v
        } else {
            (v - t) + sum
        };
        sum = t;
    }
    sum + carry
}
