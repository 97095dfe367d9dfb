//! The pieces of split cells ([`crate::cells::split`]) as elements of their
//! own: each piece's matrix `Σ_vol w BᵀDB + Σ_{Dirichlet points} w (β/h)
//! NᵀN` over the cell's points that lie in it, stored dense with the active
//! indices of its nodes (some of them copies), and applied as a list after
//! the lattice's cells. The split cells themselves keep no weights in the
//! lattice's operator, so nothing is counted twice.
//!
//! The list is short (the cells along a glued wall), so it is applied
//! sequentially.

use rayon::prelude::*;

use super::moment_fit::FitBasis;
use crate::cells::Cells;
use crate::discrete::dofs::DofMap;
use crate::grid::Grid;

/// Dofs of a (Q1) piece.
const NE: usize = 24;

/// The stiffness and mass weights of cut cell `i` over its points `x` with
/// `keep(x)`.
pub type WeightsOf<'a> = dyn Fn(usize, &dyn Fn([f64; 3]) -> bool) -> Vec<f64> + Sync + 'a;

/// The pieces' matrices and nodes.
#[derive(Clone, Debug, Default)]
pub struct SplitElements {
    /// Per piece, the active indices of its eight nodes.
    nodes: Vec<[usize; 8]>,
    /// Per piece, its `24 × 24` matrix, row-major, back to back.
    matrices: Vec<f64>,
}

impl SplitElements {
    /// The matrices of the pieces of `dofs`' split cells: `weights(i, keep)`
    /// gives the stiffness and mass weights ([`FitBasis::expand`]) of cut
    /// cell `i` over its points `x` with `keep(x)`.
    pub fn new(
        grid: &Grid,
        cells: &Cells,
        dofs: &DofMap,
        basis: &FitBasis,
        lame: (f64, f64),
        weights: &WeightsOf,
    ) -> SplitElements {
        let pieces: Vec<(usize, usize)> = dofs
            .split
            .cells
            .iter()
            .enumerate()
            .flat_map(|(k, s)| (0..s.pieces.len()).map(move |p| (k, p)))
            .collect();
        let nq = basis.num_points();
        let built: Vec<([usize; 8], Vec<f64>)> = pieces
            .par_iter()
            .map(|&(k, p)| {
                let s = &dofs.split.cells[k];
                let i = cells.cut_position(s.cell).expect("a split cell is cut");
                let w = weights(i, &|x| s.piece_of(x) == p);
                let matrix = basis.expand(&w[..nq], &w[nq..], lame, 1.0 / grid.h);
                let mut nodes = [0usize; 8];
                dofs.piece_active_nodes(grid, s, p, &mut nodes);
                (nodes, matrix)
            })
            .collect();
        SplitElements {
            nodes: built.iter().map(|b| b.0).collect(),
            matrices: built.into_iter().flat_map(|b| b.1).collect(),
        }
    }

    /// `y += Σ_e K_e x_e`.
    pub fn apply_add(&self, x: &[f64], y: &mut [f64]) {
        for (nodes, k) in self.iter() {
            let xe: [f64; NE] = std::array::from_fn(|r| x[3 * nodes[r / 3] + r % 3]);
            for (r, row) in k.chunks_exact(NE).enumerate() {
                y[3 * nodes[r / 3] + r % 3] += row.iter().zip(&xe).map(|(a, b)| a * b).sum::<f64>();
            }
        }
    }

    /// `d += diag(Σ_e K_e)`.
    pub fn add_diagonal(&self, d: &mut [f64]) {
        for (nodes, k) in self.iter() {
            for r in 0..NE {
                d[3 * nodes[r / 3] + r % 3] += k[r * NE + r];
            }
        }
    }

    /// The pieces as (active indices of their nodes, row-major matrix).
    pub fn iter(&self) -> impl Iterator<Item = (&[usize; 8], &[f64])> {
        self.nodes.iter().zip(self.matrices.chunks_exact(NE * NE))
    }

    /// Bytes of the matrices and node lists.
    pub fn bytes(&self) -> usize {
        8 * (self.matrices.len() + 8 * self.nodes.len())
    }
}

#[cfg(test)]
mod tests;
