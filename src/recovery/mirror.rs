//! Patches across symmetry planes: where a face of the grid box is a plane of
//! mirror symmetry of the problem (a half, quarter or eighth model), a patch
//! that reaches past it continues into the mirror image of the body — the
//! cells beyond the face are the reflections of the cells inside it, their
//! samples reflected in position and value — so that the fit is the one the
//! full model makes there.
//!
//! Along axis `a`, a cell index `i < 0` beyond the low face is the reflection
//! of cell `−1 − i`, and `i ≥ n_a` beyond the high face that of
//! `2 n_a − 1 − i`. A reflection across a plane normal to `a` maps the point
//! `x_a ↦ 2 p_a − x_a` and the field by [`super::PatchSamples::reflected`]
//! (for a displacement: `u_a ↦ −u_a`).

use super::spr::PatchSamples;
use super::Sample;
use crate::cells::CellKind;
use crate::grid::Grid;

/// The faces of the grid box that are symmetry planes: per axis, the low and
/// the high face.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Mirror {
    pub faces: [[bool; 2]; 3],
}

impl Mirror {
    /// No symmetry plane: patches stop at the grid box.
    pub fn none() -> Mirror {
        Mirror::default()
    }

    /// Whether any face is a symmetry plane.
    pub fn any(&self) -> bool {
        self.faces.iter().flatten().any(|&f| f)
    }
}

/// A patch cell: a grid cell, and the faces across which it is reflected
/// (bit `a` for the low face of axis `a`, bit `a + 3` for its high face; 0
/// for the cell itself).
pub(super) type PatchCell = (usize, u8);

/// Appends the cells with positive volume exactly `ring` cells away from the
/// vertex `v`, continued across the mirror faces: cell `i` along an axis is
/// at distance `v − i` when `i < v`, else `i − v + 1`, and a cell's distance
/// is the largest over the axes.
pub(super) fn ring_cells(
    grid: &Grid,
    kinds: &[CellKind],
    mirror: &Mirror,
    v: [usize; 3],
    ring: usize,
    out: &mut Vec<PatchCell>,
) {
    let (r, v) = (ring as i64, v.map(|x| x as i64));
    let n = grid.n.map(|x| x as i64);
    let lo: [i64; 3] = [0, 1, 2].map(|a| match mirror.faces[a][0] {
        true => v[a] - r,
        false => (v[a] - r).max(0),
    });
    let hi: [i64; 3] = [0, 1, 2].map(|a| match mirror.faces[a][1] {
        true => v[a] + r,
        false => (v[a] + r).min(n[a]),
    });
    let dist = |a: usize, i: i64| if i < v[a] { v[a] - i } else { i - v[a] + 1 };
    // The grid cell of index `i` along `a`, and the mask bit of the face
    // it is reflected across (0: none).
    let fold = |a: usize, i: i64| -> Option<(usize, u8)> {
        let (j, bit) = if i < 0 {
            (-1 - i, 1 << a)
        } else if i >= n[a] {
            (2 * n[a] - 1 - i, 1 << (a + 3))
        } else {
            (i, 0)
        };
        (0..n[a]).contains(&j).then_some((j as usize, bit))
    };
    for k in lo[2]..hi[2] {
        for j in lo[1]..hi[1] {
            for i in lo[0]..hi[0] {
                if dist(0, i).max(dist(1, j)).max(dist(2, k)) != ring as i64 {
                    continue;
                }
                let (Some(x), Some(y), Some(z)) = (fold(0, i), fold(1, j), fold(2, k)) else {
                    continue;
                };
                let c = grid.cell_index([x.0, y.0, z.0]);
                if kinds[c] != CellKind::Outside {
                    out.push((c, x.1 | y.1 | z.1));
                }
            }
        }
    }
}

/// The mirror image of the point `x` across the faces in `mask` of `grid`'s
/// box.
pub(super) fn reflect_point(grid: &Grid, mask: u8, x: [f64; 3]) -> [f64; 3] {
    let b = grid.bounding_box();
    [0, 1, 2].map(|a| {
        if mask & (1 << a) != 0 {
            2.0 * b.lo[a] - x[a]
        } else if mask & (1 << (a + 3)) != 0 {
            2.0 * b.hi[a] - x[a]
        } else {
            x[a]
        }
    })
}

/// A sample of a cell seen across the faces in `mask`: its point mirrored,
/// its value reflected by the field ([`PatchSamples::reflected`]).
pub(super) fn reflect_sample<const NC: usize, S: PatchSamples<NC>>(
    grid: &Grid,
    samples: &S,
    mask: u8,
    (x, v): Sample<NC>,
) -> Sample<NC> {
    if mask == 0 {
        return (x, v);
    }
    (
        reflect_point(grid, mask, x),
        reflect_value(samples, mask, v),
    )
}

/// A field value seen across the faces in `mask`.
pub(super) fn reflect_value<const NC: usize, S: PatchSamples<NC>>(
    samples: &S,
    mask: u8,
    v: [f64; NC],
) -> [f64; NC] {
    reflected_axes(mask).fold(v, |v, a| {
        samples
            .reflected(a, v)
            .expect("mirrored patches only for reflectable fields")
    })
}

/// The axes of the faces in `mask`.
pub(super) fn reflected_axes(mask: u8) -> impl Iterator<Item = usize> {
    (0..3).filter(move |a| mask & (1 << a | 1 << (a + 3)) != 0)
}
