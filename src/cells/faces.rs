//! The faces of grid cells and the area rules of their parts inside the body.
//!
//! A face is named by the cell on its low side along `axis` and the face's
//! own lattice position, so the two cells sharing it build the *same* box from
//! the same node coordinates (bit for bit) and get the same rule: that is what
//! makes the face terms of the consistency correction cancel between
//! neighbours (see [`crate::fem::flux_consistency`]).

use crate::geometry::Geometry;
use crate::grid::Grid;
use crate::quadrature::saye::{box_rule, VolumePoint};
use crate::spatial::Aabb;

/// The box of the face of `cell` normal to `axis`, on its low (`side = 0`) or
/// high (`side = 1`) end: degenerate along `axis`.
pub fn face_box(grid: &Grid, cell: usize, axis: usize, side: usize) -> Aabb {
    let mut lo = grid.cell_ijk(cell);
    lo[axis] += side;
    let mut hi = lo.map(|v| v + 1);
    hi[axis] = lo[axis];
    grid.block_box(lo, hi)
}

/// The face-neighbour of `cell` across its face `(axis, side)`, if the grid
/// has one.
pub fn face_neighbour(grid: &Grid, cell: usize, axis: usize, side: usize) -> Option<usize> {
    let mut ijk = grid.cell_ijk(cell);
    if side == 0 {
        ijk[axis] = ijk[axis].checked_sub(1)?;
    } else {
        ijk[axis] += 1;
        if ijk[axis] >= grid.n[axis] {
            return None;
        }
    }
    Some(grid.cell_index(ijk))
}

/// Saye's area rule (`q` points per segment and dimension) on the part of the
/// face `(axis, side)` of `cell` inside the body.
pub fn face_rule(
    g: &Geometry,
    grid: &Grid,
    cell: usize,
    axis: usize,
    side: usize,
    q: usize,
) -> Vec<VolumePoint> {
    let free: Vec<usize> = (0..3).filter(|&a| a != axis).collect();
    box_rule(g, &face_box(grid, cell, axis, side), &free, q).volume
}
