//! The faces of grid cells and the area rules of their parts inside the body.
//!
//! A face is named by the cell on its low side along `axis` and the face's
//! own lattice position, so the two cells sharing it build the *same* box from
//! the same node coordinates (bit for bit) and get the same rule: that is what
//! makes the face terms of the consistency correction cancel between
//! neighbours (see [`crate::fem::flux_consistency`]).

use rayon::prelude::*;

use super::CellKind;
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

/// The area rules ([`face_rule`]) of every face between two cut cells,
/// each made once for the two cells that share it (the same rule from
/// either side, bit for bit: the module doc).
pub struct CutFaceRules {
    /// Per face, its low cell and axis, ascending.
    faces: Vec<(usize, usize)>,
    rules: Vec<Vec<VolumePoint>>,
}

impl CutFaceRules {
    /// The rules of `q` points per segment and dimension of the faces of the
    /// cells of `cut` whose neighbour across the face is cut too (`kinds`).
    pub fn new(
        g: &Geometry,
        grid: &Grid,
        kinds: &[CellKind],
        cut: &[usize],
        q: usize,
    ) -> CutFaceRules {
        let mut faces: Vec<(usize, usize)> = Vec::new();
        for &c in cut {
            for axis in 0..3 {
                for side in 0..2 {
                    match face_neighbour(grid, c, axis, side) {
                        Some(nb) if kinds[nb] == CellKind::Cut => {
                            faces.push((if side == 0 { nb } else { c }, axis));
                        }
                        _ => {}
                    }
                }
            }
        }
        faces.sort_unstable();
        faces.dedup();
        let rules = faces
            .par_iter()
            .map(|&(c, axis)| face_rule(g, grid, c, axis, 1, q))
            .collect();
        CutFaceRules { faces, rules }
    }

    /// The rule of the face normal to `axis` on the high side of `low`, a
    /// face between two cut cells of [`CutFaceRules::new`] (a cell's face
    /// `(axis, 0)` is its low neighbour's `(axis, 1)`).
    ///
    /// # Panics
    /// When that face is not one of the rules'.
    pub fn rule(&self, low: usize, axis: usize) -> &[VolumePoint] {
        let k = self
            .faces
            .binary_search(&(low, axis))
            .expect("a face between two cut cells");
        &self.rules[k]
    }
}
