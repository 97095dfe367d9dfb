//! Bricks of the cell array, one per rank, balanced by work: recursive
//! bisection of the grid's cells, each cut a plane of cells across the
//! box's longest side, placed (on a multiple of `align` cells) where the
//! work on each side is nearest to its share of the ranks. Every rank
//! computes the same bricks from the same cells.

use crate::cells::CellKind;
use crate::error::{Error, Result};
use crate::grid::{CellBox, Grid};

/// The work of a cut cell against an inside cell's 1 (its rule, its
/// factored forms and its recovery samples cost several inside cells').
pub const CUT_CELL_WORK: f64 = 4.0;

/// The work of each cell of `grid` by its kind (outside cells none).
pub fn cell_work(kinds: &[CellKind]) -> Vec<f64> {
    kinds
        .iter()
        .map(|k| match k {
            CellKind::Outside => 0.0,
            CellKind::Inside => 1.0,
            CellKind::Cut => CUT_CELL_WORK,
        })
        .collect()
}

/// `parts` bricks covering `grid`'s cells once, with cut planes on
/// multiples of `align` cells, balanced by `work` (per cell).
/// [`Error::InvalidGrid`] when the grid has too few cells for that many
/// bricks.
pub fn bricks(grid: &Grid, work: &[f64], parts: usize, align: usize) -> Result<Vec<CellBox>> {
    assert_eq!(work.len(), grid.num_cells(), "one work per cell");
    assert!(
        parts > 0 && align > 0,
        "at least one brick, aligned to a cell"
    );
    let mut out = Vec::with_capacity(parts);
    split(grid, work, grid.all_cells(), parts, align, &mut out)?;
    Ok(out)
}

/// Splits `b` into `parts` bricks, appended to `out` in order.
fn split(
    grid: &Grid,
    work: &[f64],
    b: CellBox,
    parts: usize,
    align: usize,
    out: &mut Vec<CellBox>,
) -> Result<()> {
    if parts == 1 {
        out.push(b);
        return Ok(());
    }
    let left = parts / 2;
    let mut axes = [0usize, 1, 2];
    axes.sort_by_key(|&a| std::cmp::Reverse(b.hi[a] - b.lo[a]));
    let Some((axis, cut)) = axes.iter().find_map(|&a| {
        best_cut(grid, work, &b, a, left as f64 / parts as f64, align).map(|c| (a, c))
    }) else {
        return Err(Error::InvalidGrid {
            what: "ranks".into(),
            reason: format!(
                "{parts} ranks cannot share the {:?} cells of a box at level {} \
                 (bricks of at least {align} cells a side); use fewer ranks or a finer level",
                [0, 1, 2].map(|a| b.hi[a] - b.lo[a]),
                grid.level
            ),
        });
    };
    let (mut lower, mut upper) = (b, b);
    lower.hi[axis] = cut;
    upper.lo[axis] = cut;
    split(grid, work, lower, left, align, out)?;
    split(grid, work, upper, parts - left, align, out)
}

/// The plane of `axis` (a multiple of `align` strictly inside `b`) whose
/// lower side's share of `b`'s work is nearest to `share` (the lowest such
/// plane on ties); `None` when no plane fits.
fn best_cut(
    grid: &Grid,
    work: &[f64],
    b: &CellBox,
    axis: usize,
    share: f64,
    align: usize,
) -> Option<usize> {
    let slabs = slab_work(grid, work, b, axis);
    let total: f64 = slabs.iter().sum();
    let mut below = 0.0;
    let mut best: Option<(f64, usize)> = None;
    for (s, w) in slabs.iter().enumerate() {
        below += w;
        let plane = b.lo[axis] + s + 1;
        if !plane.is_multiple_of(align) || plane <= b.lo[axis] || plane >= b.hi[axis] {
            continue;
        }
        let miss = (below - share * total).abs();
        if best.is_none_or(|(m, _)| miss < m) {
            best = Some((miss, plane));
        }
    }
    best.map(|(_, plane)| plane)
}

/// The work of each plane of cells of `b` across `axis`.
fn slab_work(grid: &Grid, work: &[f64], b: &CellBox, axis: usize) -> Vec<f64> {
    let mut slabs = vec![0.0; b.hi[axis] - b.lo[axis]];
    for k in b.lo[2]..b.hi[2] {
        for j in b.lo[1]..b.hi[1] {
            for i in b.lo[0]..b.hi[0] {
                let ijk = [i, j, k];
                slabs[ijk[axis] - b.lo[axis]] += work[grid.cell_index(ijk)];
            }
        }
    }
    slabs
}

/// The rank whose brick holds cell `ijk`.
///
/// # Panics
/// When no brick holds it (the bricks do not cover the grid).
pub fn owner(bricks: &[CellBox], ijk: [usize; 3]) -> usize {
    bricks
        .iter()
        .position(|b| b.contains(ijk))
        .expect("the bricks cover the grid")
}
