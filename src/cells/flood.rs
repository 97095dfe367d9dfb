//! Classification of the cells of a mesh solid by flood fill: the cells whose
//! box meets a facet's box are the candidates (they get the polyhedral rule);
//! the other cells fall into connected regions (face neighbours) that no
//! facet crosses, so each region is inside or outside as a whole, decided by
//! one winding number at one of its cells.
//!
//! Work: the facets' boxes rasterised into the grid, one pass over the cells,
//! and one winding number per region (a handful), where the block descent of
//! [`super::descend`] asks one per undecided block along the whole surface.

use super::CellKind;
use crate::grid::Grid;
use crate::mesh::MeshSolid;

/// Marks `kinds` (inside regions) and lists the candidate cells, ascending.
pub(super) fn classify(grid: &Grid, mesh: &MeshSolid, kinds: &mut [CellKind]) -> Vec<usize> {
    const CANDIDATE: u8 = 1;
    const SEEN: u8 = 2;
    let mut state = vec![0u8; grid.num_cells()];
    let gbox = grid.bounding_box();
    let cell_range = |lo: f64, hi: f64, axis: usize| -> Option<(usize, usize)> {
        let to_cell = |x: f64| (x - gbox.lo[axis]) / grid.h;
        let (a, b) = (to_cell(lo).floor(), to_cell(hi).floor());
        if b < 0.0 || a >= grid.n[axis] as f64 {
            return None;
        }
        Some((a.max(0.0) as usize, (b as usize).min(grid.n[axis] - 1)))
    };
    for t in 0..mesh.num_triangles() {
        let v = mesh.triangle(t);
        // The facet's box, padded as the polyhedral rules' box queries pad it.
        let lo = [0, 1, 2].map(|i| v[0][i].min(v[1][i]).min(v[2][i]));
        let hi = [0, 1, 2].map(|i| v[0][i].max(v[1][i]).max(v[2][i]));
        let size = (0..3).map(|i| hi[i] - lo[i]).fold(0.0, f64::max);
        let pad = 1e-10 * size + 1e-300 + 1e-12 * grid.h;
        let ranges = [0, 1, 2].map(|i| cell_range(lo[i] - pad, hi[i] + pad, i));
        let [Some(rx), Some(ry), Some(rz)] = ranges else {
            continue;
        };
        for k in rz.0..=rz.1 {
            for j in ry.0..=ry.1 {
                let row = grid.cell_index([0, j, k]);
                state[row + rx.0..=row + rx.1].fill(CANDIDATE);
            }
        }
    }
    let mut stack = Vec::new();
    for start in 0..state.len() {
        if state[start] != 0 {
            continue;
        }
        let b = grid.cell_box(start);
        let c = [0, 1, 2].map(|i| 0.5 * (b.lo[i] + b.hi[i]));
        let kind = if mesh.phi(c) < 0.0 {
            CellKind::Inside
        } else {
            CellKind::Outside
        };
        state[start] = SEEN;
        stack.push(start);
        while let Some(cell) = stack.pop() {
            kinds[cell] = kind;
            let ijk = grid.cell_ijk(cell);
            for axis in 0..3 {
                for step in [-1i64, 1] {
                    let m = ijk[axis] as i64 + step;
                    if m < 0 || m >= grid.n[axis] as i64 {
                        continue;
                    }
                    let mut nb = ijk;
                    nb[axis] = m as usize;
                    let n = grid.cell_index(nb);
                    if state[n] == 0 {
                        state[n] = SEEN;
                        stack.push(n);
                    }
                }
            }
        }
    }
    (0..state.len())
        .filter(|&c| state[c] == CANDIDATE)
        .collect()
}
