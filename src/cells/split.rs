//! One set of unknowns per piece: where the body's parts around a grid node
//! do not meet inside the node's cells (the walls of a slot thinner than a
//! cell, found as in [`super::glued`]), the node gets one copy per part, so
//! the walls move apart. Each cut cell that touches such a node and holds a
//! part of another copy is *split*: each of its pieces is an element with
//! its own nodes (per vertex the node itself or one of its copies) and the
//! cell's quadrature points that lie in that piece.
//!
//! The pieces of a cell are its inside sub-cells ([`super::glued::SUB`]³)
//! joined by 26-connectivity, less the pieces whose volume points of the
//! cell's rule weigh nothing (a part thinner than the rule resolves belongs
//! to the piece around it). Nodes with a cut cell around them
//! whose rule has a weight that is not positive (a repaired or polyhedral
//! rule of a mesh with defects) are not copied: a piece's matrix is
//! positive only where its points' weights are. A point is in the piece of its sub-cell, or of the
//! nearest inside sub-cell where its own centre is outside. The copy that
//! holds an inside cell, or else the largest, is the node itself (the
//! *primary* copy): cells that are not split use only primary copies, so
//! everything that works on the lattice is unchanged for them.

use rayon::prelude::*;

use super::glued::{candidate_nodes, cell_labels, cut_cells_around, node_cells, piece_roots};
use super::glued::{pieces, Labels};
use super::glued::{INSIDE, SUB};
use super::{face_neighbour, face_rule, CellKind, Cells};
use crate::element::ElementOrder;
use crate::geometry::Geometry;
use crate::grid::Grid;
use crate::quadrature::saye::VolumePoint;
use crate::spatial::Aabb;

/// The copy of a vertex that is the lattice node itself.
pub const PRIMARY: u32 = u32::MAX;

/// The copies of the glued nodes and the cells split into pieces.
#[derive(Clone, Debug, Default)]
pub struct Split {
    /// The vertex-lattice node of each extra copy, in copy order.
    pub extra_nodes: Vec<usize>,
    /// The split cells, ascending by cell.
    pub cells: Vec<SplitCell>,
}

/// A cut cell split into pieces.
#[derive(Clone, Debug, PartialEq)]
pub struct SplitCell {
    pub cell: usize,
    /// Per piece, per local vertex (Q1 order, `x` fastest): [`PRIMARY`] or
    /// the index of an extra copy.
    pub pieces: Vec<[u32; 8]>,
    /// The piece (from 1) of each sub-cell, 0 outside (as
    /// [`super::glued`]); empty for a cell of one piece.
    labels: Labels,
    /// The cell's box.
    bounds: Aabb,
}

impl SplitCell {
    /// The piece (index into [`SplitCell::pieces`]) that a point of the
    /// cell lies in.
    pub fn piece_of(&self, x: [f64; 3]) -> usize {
        piece_at(&self.labels, &self.bounds, x) as usize - 1
    }
}

impl Split {
    /// The copies and split cells of `cells` on `grid` (none where no
    /// node's parts are apart).
    pub fn new(grid: &Grid, cells: &Cells, geometry: &Geometry) -> Split {
        let candidates = candidate_nodes(grid, cells);
        if candidates.is_empty() {
            return Split::default();
        }
        let sampled = cut_cells_around(grid, cells, &candidates);
        let labels: Vec<Labels> = sampled
            .par_iter()
            .map(|&c| {
                let b = grid.cell_box(c);
                let i = cells.cut_position(c).expect("cut");
                prune(cell_labels(geometry, &b), &b, cells.volume_points(i))
            })
            .collect();
        let labels_of = |c: usize| match cells.kinds[c] {
            CellKind::Outside => None,
            CellKind::Inside => Some(&INSIDE[..]),
            CellKind::Cut => Some(&labels[sampled.binary_search(&c).expect("sampled")][..]),
        };
        // Per glued node: (cell, local vertex, piece, copy), copies numbered
        // per node from 1 (0 is the primary).
        let per_node: Vec<(usize, Vec<Assignment>)> = candidates
            .into_par_iter()
            .filter_map(|v| {
                let around = node_cells(grid, v);
                // A piece's matrix is positive only where its points'
                // weights are.
                if around.iter().flatten().any(|&c| !positive_rule(cells, c)) {
                    return None;
                }
                let roots = piece_roots(&around.map(|c| c.and_then(labels_of)));
                let copies = copies_of(&roots, |d| {
                    around[d].is_some_and(|c| cells.kinds[c] == CellKind::Inside)
                })?;
                let entries = roots
                    .iter()
                    .zip(copies)
                    .map(|(&(d, l, _), copy)| (around[d].expect("a cell"), 7 - d, l, copy))
                    .collect();
                Some((v, entries))
            })
            .collect();
        let mut extra_nodes = Vec::new();
        let mut assigned: Vec<(usize, usize, usize, u32)> = Vec::new();
        for (v, entries) in per_node {
            let first = extra_nodes.len() as u32;
            let count = entries.iter().map(|e| e.3).max().unwrap_or(0);
            extra_nodes.extend(std::iter::repeat_n(v, count));
            for (c, local, l, copy) in entries {
                if copy > 0 {
                    assigned.push((c, local, l, first + copy as u32 - 1));
                }
            }
        }
        assigned.sort_unstable();
        let mut split = Vec::new();
        for group in assigned.chunk_by(|a, b| a.0 == b.0) {
            let c = group[0].0;
            let own = &labels[sampled.binary_search(&c).expect("sampled")];
            let mut pieces_of = vec![[PRIMARY; 8]; pieces(own).count()];
            for &(_, local, l, copy) in group {
                pieces_of[l - 1][local] = copy;
            }
            split.push(SplitCell {
                cell: c,
                pieces: pieces_of,
                labels: own.clone(),
                bounds: grid.cell_box(c),
            });
        }
        let mut split = Split {
            extra_nodes,
            cells: split,
        };
        loop {
            let torn = split.torn_vertices(grid, cells, geometry);
            if torn.is_empty() {
                return split;
            }
            split = split.glued_at(&torn);
        }
    }

    /// The vertices where a face between two cells holds the body but the
    /// pieces on its two sides take different copies: the sampling missed
    /// a connection, and the copies would tear the body there.
    fn torn_vertices(&self, grid: &Grid, cells: &Cells, geometry: &Geometry) -> Vec<usize> {
        let mut torn: Vec<usize> = self
            .cells
            .par_iter()
            .flat_map_iter(|s| {
                let mut out = Vec::new();
                let mut vertices = [0usize; 8];
                grid.cell_nodes(ElementOrder::Q1, s.cell, &mut vertices);
                for (axis, side) in (0..3).flat_map(|a| [(a, 0), (a, 1)]) {
                    let Some(nb) = face_neighbour(grid, s.cell, axis, side) else {
                        continue;
                    };
                    if cells.kinds[nb] == CellKind::Outside {
                        continue;
                    }
                    let other = self.cell(nb);
                    // Local vertices of the face in this cell and in the
                    // neighbour (the same grid vertices).
                    let face: Vec<(usize, usize)> = (0..8)
                        .filter(|l| (l >> axis & 1) == side)
                        .map(|l| (l, l ^ (1 << axis)))
                        .collect();
                    for p in face_rule(geometry, grid, s.cell, axis, side, 2) {
                        let mine = &s.pieces[s.piece_of(p.x)];
                        let theirs = other.map_or([PRIMARY; 8], |o| o.pieces[o.piece_of(p.x)]);
                        for &(l, m) in &face {
                            if mine[l] != theirs[m] {
                                out.push(vertices[l]);
                            }
                        }
                    }
                }
                out
            })
            .collect();
        torn.sort_unstable();
        torn.dedup();
        torn
    }

    /// This split with the vertices `glued` (ascending) back to one
    /// unknown: their copies dropped, the others renumbered, and cells that
    /// no longer take a copy no longer split.
    fn glued_at(self, glued: &[usize]) -> Split {
        let mut renumber = vec![PRIMARY; self.extra_nodes.len()];
        let mut extra_nodes = Vec::new();
        for (k, &v) in self.extra_nodes.iter().enumerate() {
            if glued.binary_search(&v).is_err() {
                renumber[k] = extra_nodes.len() as u32;
                extra_nodes.push(v);
            }
        }
        let cells = self
            .cells
            .into_iter()
            .filter_map(|mut s| {
                for copies in &mut s.pieces {
                    for c in copies.iter_mut().filter(|c| **c != PRIMARY) {
                        *c = renumber[*c as usize];
                    }
                }
                let any = s.pieces.iter().flatten().any(|&c| c != PRIMARY);
                any.then_some(s)
            })
            .collect();
        Split { extra_nodes, cells }
    }

    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// The split cell `cell`, if it is split.
    pub fn cell(&self, cell: usize) -> Option<&SplitCell> {
        self.cells
            .binary_search_by_key(&cell, |s| s.cell)
            .ok()
            .map(|i| &self.cells[i])
    }

    /// The number of elements (pieces of split cells).
    pub fn num_elements(&self) -> usize {
        self.cells.iter().map(|s| s.pieces.len()).sum()
    }
}

/// A piece's copy at a node: (cell, local vertex, piece label, copy from 1;
/// 0 the primary).
type Assignment = (usize, usize, usize, usize);

/// The copy (0 the primary) of each piece in `roots` ([`piece_roots`]), or
/// `None` when they form one component. Components that hold an inside
/// cell (`inside(entry)`) are one copy, the primary; otherwise the primary
/// is the component with the most pieces.
fn copies_of(roots: &[(usize, usize, u16)], inside: impl Fn(usize) -> bool) -> Option<Vec<usize>> {
    let inside_root = roots.iter().find(|r| inside(r.0)).map(|r| r.2);
    let root = |r: &(usize, usize, u16)| {
        if inside(r.0) {
            inside_root.expect("inside")
        } else {
            r.2
        }
    };
    let mut distinct: Vec<u16> = roots.iter().map(root).collect();
    distinct.sort_unstable();
    distinct.dedup();
    if distinct.len() < 2 {
        return None;
    }
    let size = |d: u16| roots.iter().filter(|r| root(r) == d).count();
    let primary = inside_root.unwrap_or_else(|| {
        *distinct
            .iter()
            .max_by_key(|&&d| (size(d), std::cmp::Reverse(d)))
            .expect("two components")
    });
    distinct.retain(|&d| d != primary);
    Some(
        roots
            .iter()
            .map(|r| match distinct.binary_search(&root(r)) {
                Ok(k) => k + 1,
                Err(_) => 0,
            })
            .collect(),
    )
}

/// Whether cell `c`'s rule can be split into pieces: not repaired (first
/// order), all its volume weights positive (a polyhedral rule of a mesh
/// with defects need not have them).
fn positive_rule(cells: &Cells, c: usize) -> bool {
    match cells.cut_position(c) {
        Some(i) => {
            cells.repaired.binary_search(&c).is_err()
                && cells.volume_points(i).iter().all(|q| q.w > 0.0)
        }
        None => true,
    }
}

/// `labels` without the pieces whose share of the cell's `volume` points
/// weighs nothing (or less), the rest renumbered from 1 in order.
fn prune(mut labels: Labels, b: &Aabb, volume: &[VolumePoint]) -> Labels {
    if labels.is_empty() {
        return labels;
    }
    let mut weight = [0.0f64; 256];
    for q in volume {
        weight[piece_at(&labels, b, q.x) as usize] += q.w;
    }
    let mut renumber = [0u8; 256];
    let mut next = 0u8;
    for l in 1..256 {
        if weight[l] > 0.0 {
            next += 1;
            renumber[l] = next;
        }
    }
    if next == 0 {
        return Vec::new();
    }
    labels.iter_mut().for_each(|l| *l = renumber[*l as usize]);
    labels
}

/// The piece (from 1) of point `x` of the cell with box `b`: that of its
/// sub-cell, or of the nearest inside sub-cell where its own is outside; 1
/// for a cell without labels.
fn piece_at(labels: &[u8], b: &Aabb, x: [f64; 3]) -> u8 {
    if labels.is_empty() {
        return 1;
    }
    let s = [0, 1, 2].map(|a| (b.hi[a] - b.lo[a]) / SUB as f64);
    let local = [0, 1, 2].map(|a| (x[a] - b.lo[a]) / s[a]);
    let ijk = local.map(|t| (t.max(0.0) as usize).min(SUB - 1));
    let own = labels[ijk[0] + SUB * (ijk[1] + SUB * ijk[2])];
    if own != 0 {
        return own;
    }
    let distance = |e: usize| {
        let c = [e % SUB, (e / SUB) % SUB, e / (SUB * SUB)];
        (0..3)
            .map(|a| (c[a] as f64 + 0.5 - local[a]).powi(2))
            .sum::<f64>()
    };
    (0..labels.len())
        .filter(|&e| labels[e] != 0)
        .min_by(|&e, &f| distance(e).total_cmp(&distance(f)))
        .map(|e| labels[e])
        .expect("a labelled sub-cell")
}

#[cfg(test)]
mod tests;
