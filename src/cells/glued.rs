//! Walls of the body glued by a shared node: a grid node whose eight cells
//! hold parts of the body that do not touch inside those cells (the walls of
//! a slot or a gap thinner than a cell). The node's one unknown moves both
//! walls together, so the discrete part is stiffer than the part: a slot
//! that a cell spans is glued shut. [`glued_nodes`] finds such nodes so a run
//! can say where its answer is not the part's.
//!
//! A node is a candidate when the boundary normals in its cells face each
//! other (some pair with `n_a · n_b < −½`): two walls, or a body thinner than
//! a cell. Each candidate's cut cells are sampled at the centres of
//! [`SUB`]³ sub-cells; a cell's inside sub-cells fall into pieces by
//! 26-connectivity, and pieces of two face-adjacent cells meet where inside
//! sub-cells touch across the shared face. A node is glued when the pieces
//! of its cells form two or more components. A gap narrower than about
//! `√3 h / SUB` is not seen, and a cut cell with no inside sub-cell counts
//! as one piece that meets every neighbour.

use rayon::prelude::*;

use super::{CellKind, Cells};
use crate::geometry::Geometry;
use crate::grid::Grid;
use crate::spatial::vec3::{dot, sub};
use crate::spatial::Aabb;

/// Sub-cells per axis of a sampled cell.
pub const SUB: usize = 8;

/// Boundary normals below this dot product face each other.
const FACING: f64 = -0.5;

/// The piece (1, 2, …) of each sub-cell of a cell, 0 where the sub-cell's
/// centre is outside the body; sub-cell `(a, b, c)` is entry `a + SUB (b +
/// SUB c)`.
pub(super) type Labels = Vec<u8>;

/// The nodes of `grid`'s vertex lattice (`(n + 1)³`, lattice order) whose
/// cells hold parts of the body that do not meet inside them, ascending.
pub fn glued_nodes(grid: &Grid, cells: &Cells, geometry: &Geometry) -> Vec<usize> {
    let candidates = candidate_nodes(grid, cells);
    if candidates.is_empty() {
        return Vec::new();
    }
    let sampled = cut_cells_around(grid, cells, &candidates);
    let labels: Vec<Labels> = sampled
        .par_iter()
        .map(|&c| cell_labels(geometry, &grid.cell_box(c)))
        .collect();
    let labels_of = |c: usize| match cells.kinds[c] {
        CellKind::Outside => None,
        CellKind::Inside => Some(&INSIDE[..]),
        CellKind::Cut => Some(&labels[sampled.binary_search(&c).expect("sampled")][..]),
    };
    candidates
        .into_par_iter()
        .filter(|&v| {
            let around = node_cells(grid, v).map(|c| c.and_then(labels_of));
            components(&around) > 1
        })
        .collect()
}

/// The box around the cells of `nodes`, `None` when there are none.
pub fn nodes_box(grid: &Grid, nodes: &[usize]) -> Option<Aabb> {
    let m = grid.n.map(|n| n + 1);
    nodes
        .iter()
        .map(|&v| {
            let ijk = [v % m[0], (v / m[0]) % m[1], v / (m[0] * m[1])];
            let lo = ijk.map(|i| i.saturating_sub(1));
            let hi = [0, 1, 2].map(|a| (ijk[a] + 1).min(grid.n[a]));
            grid.block_box(lo, hi)
        })
        .reduce(|a, b| a.union(&b))
}

/// The cut cells around the vertex-lattice `nodes`, ascending.
pub(super) fn cut_cells_around(grid: &Grid, cells: &Cells, nodes: &[usize]) -> Vec<usize> {
    let mut around: Vec<usize> = nodes
        .iter()
        .flat_map(|&v| node_cells(grid, v))
        .flatten()
        .filter(|&c| cells.kinds[c] == CellKind::Cut)
        .collect();
    around.sort_unstable();
    around.dedup();
    around
}

/// Every sub-cell of an inside cell is in its one piece.
pub(super) static INSIDE: [u8; SUB * SUB * SUB] = [1; SUB * SUB * SUB];

/// The eight cells around vertex-lattice node `v`, `None` beyond the grid;
/// entry `d = dx + 2 dy + 4 dz` is the cell on the high side of the node
/// along each axis where `d`'s bit is set.
pub(super) fn node_cells(grid: &Grid, v: usize) -> [Option<usize>; 8] {
    let m = grid.n.map(|n| n + 1);
    let ijk = [v % m[0], (v / m[0]) % m[1], v / (m[0] * m[1])];
    std::array::from_fn(|d| {
        let mut c = [0usize; 3];
        for a in 0..3 {
            let i = ijk[a] + (d >> a & 1);
            if i == 0 || i > grid.n[a] {
                return None;
            }
            c[a] = i - 1;
        }
        Some(grid.cell_index(c))
    })
}

/// The nodes whose cut cells' boundary normals face each other, ascending:
/// for each pair of cut cells that share nodes (a cell with itself
/// included), their shared nodes when some normal of one faces some normal
/// of the other.
pub(super) fn candidate_nodes(grid: &Grid, cells: &Cells) -> Vec<usize> {
    // A few directions per cut cell stand for all of its normals.
    let directions: Vec<Vec<Wall>> = (0..cells.cut.len())
        .into_par_iter()
        .map(|i| {
            let mut dirs: Vec<Wall> = Vec::new();
            for p in cells.surface_points(i) {
                if dirs.len() < 8 && dirs.iter().all(|d| dot(d.n, p.n) < 0.9) {
                    dirs.push(Wall { x: p.x, n: p.n });
                }
            }
            dirs
        })
        .collect();
    let m = grid.n.map(|n| n + 1);
    let facing = |a: &[Wall], b: &[Wall]| a.iter().any(|p| b.iter().any(|q| p.faces(q)));
    let mut nodes: Vec<usize> = (0..cells.cut.len())
        .into_par_iter()
        .flat_map_iter(|i| {
            let c = grid.cell_ijk(cells.cut[i]);
            let mut out = Vec::new();
            for d in 0..27 {
                let step = [d % 3, (d / 3) % 3, d / 9];
                let Some(e) = (0..3).try_fold([0usize; 3], |mut e, a| {
                    e[a] = (c[a] + step[a]).checked_sub(1).filter(|&v| v < grid.n[a])?;
                    Some(e)
                }) else {
                    continue;
                };
                let Some(j) = cells.cut_position(grid.cell_index(e)) else {
                    continue;
                };
                if j < i || !facing(&directions[i], &directions[j]) {
                    continue;
                }
                // The nodes of both cells.
                let lo = [0, 1, 2].map(|a| c[a].max(e[a]));
                let hi = [0, 1, 2].map(|a| c[a].min(e[a]) + 1);
                for k in lo[2]..=hi[2] {
                    for jj in lo[1]..=hi[1] {
                        for ii in lo[0]..=hi[0] {
                            out.push(ii + m[0] * (jj + m[1] * k));
                        }
                    }
                }
            }
            out
        })
        .collect();
    nodes.sort_unstable();
    nodes.dedup();
    nodes
}

/// A boundary point and its outward normal.
#[derive(Clone, Copy, Debug)]
struct Wall {
    x: [f64; 3],
    n: [f64; 3],
}

impl Wall {
    /// Whether the two points face each other across a gap: normals
    /// opposed, and each point ahead of the other along the other's normal
    /// (the two faces of a thin body are opposed too, but each lies behind
    /// the other).
    fn faces(&self, other: &Wall) -> bool {
        let d = sub(other.x, self.x);
        dot(self.n, other.n) < FACING && dot(d, self.n) > 0.0 && dot(d, other.n) < 0.0
    }
}

/// The pieces of the body in the box `b`: its [`SUB`]³ sub-cells' centres
/// tested against the body, the inside ones labelled by 26-connected
/// component. A box with no inside centre (a part thinner than a sub-cell)
/// gets no labels: it is one piece that meets every piece of its
/// neighbours.
pub(super) fn cell_labels(geometry: &Geometry, b: &Aabb) -> Labels {
    let s = [0, 1, 2].map(|a| (b.hi[a] - b.lo[a]) / SUB as f64);
    let mut labels: Labels = (0..SUB * SUB * SUB)
        .map(|e| {
            let ijk = [e % SUB, (e / SUB) % SUB, e / (SUB * SUB)];
            let x = [0, 1, 2].map(|a| b.lo[a] + (ijk[a] as f64 + 0.5) * s[a]);
            u8::from(geometry.inside(x))
        })
        .collect();
    if labels.iter().all(|&l| l == 0) {
        return Vec::new();
    }
    // Flood each unlabelled inside sub-cell's component with the next label;
    // inside sub-cells are marked 255 until reached.
    labels.iter_mut().for_each(|l| *l *= u8::MAX);
    let mut next = 0u8;
    let mut stack = Vec::new();
    for start in 0..labels.len() {
        if labels[start] != u8::MAX {
            continue;
        }
        next += 1;
        labels[start] = next;
        stack.push(start);
        while let Some(e) = stack.pop() {
            let ijk = [e % SUB, (e / SUB) % SUB, e / (SUB * SUB)];
            for d in 0..27 {
                let step = [d % 3, (d / 3) % 3, d / 9];
                let Some(n) = offset(ijk, step) else { continue };
                let f = n[0] + SUB * (n[1] + SUB * n[2]);
                if labels[f] == u8::MAX {
                    labels[f] = next;
                    stack.push(f);
                }
            }
        }
    }
    labels
}

/// `ijk + step − 1` when it stays in the sub-cell lattice.
fn offset(ijk: [usize; 3], step: [usize; 3]) -> Option<[usize; 3]> {
    let mut out = [0usize; 3];
    for a in 0..3 {
        let v = (ijk[a] + step[a]).checked_sub(1)?;
        if v >= SUB {
            return None;
        }
        out[a] = v;
    }
    Some(out)
}

/// The number of components of the pieces of the eight cells around a node
/// (entries as [`node_cells`]).
fn components(around: &[Option<&[u8]>; 8]) -> usize {
    let roots = piece_roots(around);
    let mut distinct: Vec<u16> = roots.iter().map(|r| r.2).collect();
    distinct.sort_unstable();
    distinct.dedup();
    distinct.len()
}

/// The component of each piece of the eight cells around a node (entries
/// as [`node_cells`]), as `(cell entry, piece label, root)` in entry and
/// label order: pieces of face-adjacent cells are joined where their inside
/// sub-cells touch across the face; two pieces are in one component when
/// their roots are equal.
pub(super) fn piece_roots(around: &[Option<&[u8]>; 8]) -> Vec<(usize, usize, u16)> {
    // Piece `l` of cell `d` is element `256 d + l` of the union-find.
    let mut parent: Vec<u16> = (0..8 * 256).collect();
    let find = |parent: &mut Vec<u16>, mut a: u16| {
        while parent[a as usize] != a {
            a = parent[a as usize];
        }
        a
    };
    for d in 0..8 {
        for axis in 0..3 {
            if d >> axis & 1 == 1 {
                continue;
            }
            let e = d | 1 << axis;
            let (Some(low), Some(high)) = (around[d], around[e]) else {
                continue;
            };
            if low.is_empty() || high.is_empty() {
                for (l, h) in pieces(low).flat_map(|l| pieces(high).map(move |h| (l, h))) {
                    let ra = find(&mut parent, (256 * d + l) as u16);
                    let rb = find(&mut parent, (256 * e + h) as u16);
                    parent[ra.max(rb) as usize] = ra.min(rb);
                }
                continue;
            }
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            for i in 0..SUB * SUB {
                let (a, b) = (i % SUB, i / SUB);
                let mut at_low = [0usize; 3];
                at_low[axis] = SUB - 1;
                at_low[u] = a;
                at_low[v] = b;
                let la = low[at_low[0] + SUB * (at_low[1] + SUB * at_low[2])];
                if la == 0 {
                    continue;
                }
                // Its neighbours across the face, diagonal ones included.
                for (da, db) in (0..9).map(|s| (s % 3, s / 3)) {
                    let (Some(a2), Some(b2)) = ((a + da).checked_sub(1), (b + db).checked_sub(1))
                    else {
                        continue;
                    };
                    if a2 >= SUB || b2 >= SUB {
                        continue;
                    }
                    let mut at_high = [0usize; 3];
                    at_high[u] = a2;
                    at_high[v] = b2;
                    let lb = high[at_high[0] + SUB * (at_high[1] + SUB * at_high[2])];
                    if lb != 0 {
                        let ra = find(&mut parent, (256 * d + la as usize) as u16);
                        let rb = find(&mut parent, (256 * e + lb as usize) as u16);
                        parent[ra.max(rb) as usize] = ra.min(rb);
                    }
                }
            }
        }
    }
    let mut roots = Vec::new();
    for (d, labels) in around.iter().enumerate() {
        let Some(labels) = labels else { continue };
        for l in pieces(labels) {
            roots.push((d, l, find(&mut parent, (256 * d + l) as u16)));
        }
    }
    roots
}

/// The piece labels of a cell: `1..=max`, or the one piece of a cell
/// without labels.
pub(super) fn pieces(labels: &[u8]) -> std::ops::RangeInclusive<usize> {
    1..=labels.iter().copied().max().unwrap_or(1) as usize
}

#[cfg(test)]
pub(crate) mod tests;
