//! Degrees of freedom: the active nodes (nodes of cells with positive volume)
//! numbered in lattice order, three displacement components each
//! (`dof = 3 · active + component`), and the node ↔ cell incidences that the
//! node-centred operator uses. Where the body's parts around a node do not
//! meet ([`crate::cells::split`]), the node's extra copies follow the
//! lattice's active nodes, and the pieces of the split cells take their
//! nodes from them.

use std::sync::Arc;

use crate::cells::split::{Split, SplitCell, PRIMARY};
use crate::cells::Cells;
use crate::element::ElementOrder;
use crate::grid::Grid;

/// The map from lattice nodes to unknowns.
#[derive(Clone, Debug)]
pub struct DofMap {
    pub order: ElementOrder,
    /// Lattice node → active index (`u32::MAX` when inactive).
    pub node_to_active: Vec<u32>,
    /// Active index → lattice node (a copy → the node it copies).
    pub active_to_node: Vec<u32>,
    /// The lattice's active nodes, `active_to_node[..lattice]`; the copies
    /// follow.
    pub lattice: usize,
    /// The copies and the split cells (none by default).
    pub split: Arc<Split>,
}

impl DofMap {
    pub fn new(grid: &Grid, cells: &Cells, order: ElementOrder) -> DofMap {
        let (node_to_active, count) = cells.active_nodes(grid, order);
        let mut active_to_node = vec![0u32; count];
        for (n, &a) in node_to_active.iter().enumerate() {
            if a != u32::MAX {
                active_to_node[a as usize] = n as u32;
            }
        }
        DofMap {
            order,
            lattice: active_to_node.len(),
            node_to_active,
            active_to_node,
            split: Arc::default(),
        }
    }

    /// [`DofMap::new`] for Q1 elements with the copies and split cells of
    /// `split` (its copies are of active nodes: nodes of cut cells).
    pub fn with_split(grid: &Grid, cells: &Cells, split: Split) -> DofMap {
        let mut dofs = DofMap::new(grid, cells, ElementOrder::Q1);
        dofs.active_to_node
            .extend(split.extra_nodes.iter().map(|&n| n as u32));
        dofs.split = Arc::new(split);
        dofs
    }

    /// Whether some nodes have copies.
    pub fn has_copies(&self) -> bool {
        self.active_to_node.len() > self.lattice
    }

    /// The copies as (active index, the lattice node they copy).
    pub fn copies(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        (self.lattice..self.active_to_node.len()).map(|a| (a, self.active_to_node[a] as usize))
    }

    /// Active indices of the nodes of piece `piece` of a split cell, in
    /// local order.
    pub fn piece_active_nodes(
        &self,
        grid: &Grid,
        cell: &SplitCell,
        piece: usize,
        out: &mut [usize],
    ) {
        self.cell_active_nodes(grid, cell.cell, out);
        for (a, &copy) in out.iter_mut().zip(&cell.pieces[piece]) {
            if copy != PRIMARY {
                *a = self.lattice + copy as usize;
            }
        }
    }

    /// Active indices of the nodes whose shape functions are those of
    /// `cell` at its point `x`: the cell's, or in a split cell those of the
    /// piece `x` lies in.
    pub fn point_active_nodes(&self, grid: &Grid, cell: usize, x: [f64; 3], out: &mut [usize]) {
        match self.split.cell(cell) {
            Some(s) => self.piece_active_nodes(grid, s, s.piece_of(x), out),
            None => self.cell_active_nodes(grid, cell, out),
        }
    }

    pub fn num_active(&self) -> usize {
        self.active_to_node.len()
    }

    pub fn ndofs(&self) -> usize {
        3 * self.num_active()
    }

    /// Active indices of a (non-outside) cell's nodes, in local order.
    pub fn cell_active_nodes(&self, grid: &Grid, cell: usize, out: &mut [usize]) {
        grid.cell_nodes(self.order, cell, out);
        for n in out.iter_mut() {
            let a = self.node_to_active[*n];
            debug_assert!(a != u32::MAX, "cell {cell} has an inactive node");
            *n = a as usize;
        }
    }
}

/// The cells that contain a lattice node and the node's local index in each:
/// along each axis a node at a cell vertex (`I mod p = 0`) lies in the cells
/// on both sides, an interior node (Q2 mid-edge, mid-face, centre) in one.
pub fn node_cells(grid: &Grid, order: ElementOrder, node: usize, out: &mut Vec<(usize, usize)>) {
    out.clear();
    let p = order.degree();
    let m = grid.nodes_per_axis(order);
    let ijk = [node % m[0], (node / m[0]) % m[1], node / (m[0] * m[1])];
    // Per axis: up to two (cell index, local coordinate) choices.
    let mut choices = [[(0usize, 0usize); 2]; 3];
    let mut counts = [0usize; 3];
    for ax in 0..3 {
        let (q, r) = (ijk[ax] / p, ijk[ax] % p);
        if r == 0 {
            if q > 0 {
                choices[ax][counts[ax]] = (q - 1, p);
                counts[ax] += 1;
            }
            if q < grid.n[ax] {
                choices[ax][counts[ax]] = (q, 0);
                counts[ax] += 1;
            }
        } else {
            choices[ax][0] = (q, r);
            counts[ax] = 1;
        }
    }
    let np = p + 1;
    for c in &choices[2][..counts[2]] {
        for b in &choices[1][..counts[1]] {
            for a in &choices[0][..counts[0]] {
                let cell = grid.cell_index([a.0, b.0, c.0]);
                let local = a.1 + np * (b.1 + np * c.1);
                out.push((cell, local));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spatial::Aabb;

    #[test]
    fn node_cells_invert_cell_nodes() {
        let grid = Grid::new(&Aabb::new([0.0; 3], [3.0, 2.0, 1.0]), 2, [0.0; 3]).unwrap();
        for order in [ElementOrder::Q1, ElementOrder::Q2] {
            let mut incidence = vec![Vec::new(); grid.num_nodes(order)];
            let mut nodes = vec![0; order.nodes_per_cell()];
            for c in 0..grid.num_cells() {
                grid.cell_nodes(order, c, &mut nodes);
                for (l, &n) in nodes.iter().enumerate() {
                    incidence[n].push((c, l));
                }
            }
            let mut out = Vec::new();
            for (n, expected) in incidence.iter_mut().enumerate() {
                node_cells(&grid, order, n, &mut out);
                out.sort();
                expected.sort();
                assert_eq!(&out, expected, "{order:?} node {n}");
            }
        }
    }
}
