//! The operator assembled: its rows gathered node by node from the cells
//! around each node (the lattice's cells and the pieces of split cells), as
//! a faer sparse matrix, for the coarsest multigrid level's factor and for
//! the tests of the matrix-free apply.

use rayon::prelude::*;

use super::{ElasticOperator, INSIDE, OUTSIDE};
use crate::discrete::dofs::node_cells;

impl ElasticOperator {
    /// Calls `f(cell, local, matrix)` for the non-outside cells around an
    /// active node, the cut cells' matrices read from `own`
    /// ([`Self::own_matrices`]).
    fn for_node_cells(&self, active: usize, own: &[f64], mut f: impl FnMut(usize, usize, &[f64])) {
        let node = self.dofs.active_to_node[active] as usize;
        let mut around = Vec::with_capacity(8);
        node_cells(&self.grid, self.dofs.order, node, &mut around);
        let ne2 = self.ne * self.ne;
        for &(cell, local) in &around {
            match self.slot[cell] {
                OUTSIDE => {}
                INSIDE => f(cell, local, &self.k_inside),
                s => f(cell, local, &own[s as usize * ne2..(s as usize + 1) * ne2]),
            }
        }
    }

    /// Rows of the matrix for an active node, as (column dof, value) triples
    /// per component, summed over cells: for the assembly and its tests.
    fn node_rows(&self, active: usize, own: &[f64]) -> [Vec<(usize, f64)>; 3] {
        let npc = self.dofs.order.nodes_per_cell();
        let mut nodes = vec![0; npc];
        let mut rows: [Vec<(usize, f64)>; 3] = Default::default();
        self.for_node_cells(active, own, |cell, l, k| {
            self.dofs.cell_active_nodes(&self.grid, cell, &mut nodes);
            for i in 0..3 {
                let row = &k[(3 * l + i) * self.ne..(3 * l + i + 1) * self.ne];
                for (m, &a) in nodes.iter().enumerate() {
                    for j in 0..3 {
                        rows[i].push((3 * a + j, row[3 * m + j]));
                    }
                }
            }
        });
        rows
    }

    /// The operator as a faer sparse matrix (symmetric, so CSR = CSC).
    pub fn assemble(&self) -> faer::sparse::SparseColMat<usize, f64> {
        let n = self.dofs.ndofs();
        let own = self.own_matrices();
        let mut blocks: Vec<[Vec<(usize, f64)>; 3]> = (0..self.dofs.num_active())
            .into_par_iter()
            .map(|a| match a < self.dofs.lattice {
                true => self.node_rows(a, &own),
                false => Default::default(),
            })
            .collect();
        for (nodes, k) in self.split.iter() {
            for (r, row) in k.chunks_exact(24).enumerate() {
                let entries = row
                    .iter()
                    .enumerate()
                    .map(|(m, &v)| (3 * nodes[m / 3] + m % 3, v));
                blocks[nodes[r / 3]][r % 3].extend(entries);
            }
        }
        blocks.par_iter_mut().flatten().for_each(sum_duplicates);
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        let mut values = Vec::new();
        col_ptr.push(0);
        for rows in &blocks {
            for r in rows {
                for &(c, v) in r {
                    row_idx.push(c);
                    values.push(v);
                }
                col_ptr.push(row_idx.len());
            }
        }
        let symbolic =
            faer::sparse::SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        faer::sparse::SparseColMat::new(symbolic, values)
    }
}

/// A row's (column, value) entries sorted by column, those of one column
/// summed.
fn sum_duplicates(row: &mut Vec<(usize, f64)>) {
    row.sort_by_key(|e| e.0);
    row.dedup_by(|b, a| {
        if a.0 == b.0 {
            a.1 += b.1;
            true
        } else {
            false
        }
    });
}
