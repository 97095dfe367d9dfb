//! The preconditioner inside the Chebyshev smoother ([`super::smoother`]):
//! Jacobi on the inside of the body, block Jacobi on the cut band.
//!
//! # Why blocks
//! On a cut cell the basis functions restricted to the body are nearly
//! linearly dependent (de Prenter et al., Comput. Mech. 2020): the diagonal
//! no longer represents the cell's matrix, `D⁻¹A` has eigenvalues far above
//! those of the uncut cells (λ_max 8.3 on a Q2 sphere at level 3, 2.2 on a
//! cuboid whose cuts are planar; 3.0 with the blocks), and a Chebyshev interval
//! `[b/15, b]` stretched to cover them no longer damps the inside of the
//! body. Inverting the whole block of a cut cell's unknowns removes those
//! eigenvalues: each block is smoothed exactly.
//!
//! # The blocks
//! The cut cells are visited in ascending order; each claims the active
//! nodes of its own that no earlier cut cell claimed, and its block is the
//! operator restricted to their unknowns, `A_b = R_b A R_bᵀ` (summed over
//! every cell around them, inside cells included). The blocks do not
//! overlap, so
//!
//! ```text
//! B = diag(D_rest, A_1, A_2, …),     B⁻¹ r = D_rest⁻¹ r_rest + Σ_b R_bᵀ A_b⁻¹ R_b r
//! ```
//!
//! is symmetric positive definite whenever `A` is (principal submatrices),
//! and the smoother stays self-adjoint in the energy product. `D_rest` is
//! the floored diagonal ([`crate::solver::floor_diagonal`]); a block whose
//! Cholesky factorisation fails (a near-null sliver without the S-term)
//! keeps its floored diagonal instead.

use nalgebra::DMatrix;
use rayon::prelude::*;

use crate::fem::dofs::node_cells;
use crate::fem::operator::ElasticOperator;

/// Entries per parallel task of the pointwise part.
const CHUNK: usize = 8192;

/// One block: its unknowns and the inverse of the operator restricted to
/// them, row-major.
struct Block {
    dofs: Vec<usize>,
    inverse: Vec<f64>,
}

/// `B⁻¹` of the module doc, its blocks stored back to back.
pub struct BlockJacobi {
    /// `D⁻¹` on the unknowns outside every block, 0 on the blocks'.
    point: Vec<f64>,
    /// The blocks' unknowns: block `k` holds `dofs[starts[k]..starts[k + 1]]`.
    dofs: Vec<usize>,
    starts: Vec<usize>,
    /// The blocks' inverses, row-major, block `k`'s from `inverse_starts[k]`.
    inverses: Vec<f64>,
    inverse_starts: Vec<usize>,
}

impl BlockJacobi {
    /// The block Jacobi preconditioner of `op` with its floored diagonal
    /// inverted, `inv_diag`.
    pub fn new(op: &ElasticOperator, inv_diag: &[f64]) -> BlockJacobi {
        let claims = claim_nodes(op);
        let blocks: Vec<Block> = claims
            .par_iter()
            .filter_map(|nodes| block_of(op, nodes))
            .collect();
        let mut pre = BlockJacobi {
            point: inv_diag.to_vec(),
            dofs: Vec::new(),
            starts: vec![0],
            inverses: Vec::new(),
            inverse_starts: vec![0],
        };
        for b in blocks {
            for &i in &b.dofs {
                pre.point[i] = 0.0;
            }
            pre.dofs.extend(&b.dofs);
            pre.starts.push(pre.dofs.len());
            pre.inverses.extend(&b.inverse);
            pre.inverse_starts.push(pre.inverses.len());
        }
        pre
    }

    /// Number of blocks and the unknowns they hold.
    pub fn block_sizes(&self) -> (usize, usize) {
        (self.starts.len() - 1, self.dofs.len())
    }

    /// The unknowns of block `k` and its inverse.
    fn block(&self, k: usize) -> (&[usize], &[f64]) {
        (
            &self.dofs[self.starts[k]..self.starts[k + 1]],
            &self.inverses[self.inverse_starts[k]..self.inverse_starts[k + 1]],
        )
    }

    /// `z = B⁻¹ r`.
    pub fn apply(&self, r: &[f64], z: &mut [f64]) {
        z.par_chunks_mut(CHUNK).enumerate().for_each(|(t, zc)| {
            let base = t * CHUNK;
            for i in 0..zc.len() {
                zc[i] = self.point[base + i] * r[base + i];
            }
        });
        let solved: Vec<f64> = (0..self.starts.len() - 1)
            .into_par_iter()
            .flat_map_iter(|k| {
                let (dofs, inverse) = self.block(k);
                let m = dofs.len();
                (0..m).map(move |i| {
                    let row = &inverse[i * m..(i + 1) * m];
                    row.iter().zip(dofs).map(|(a, &j)| a * r[j]).sum::<f64>()
                })
            })
            .collect();
        for (&i, x) in self.dofs.iter().zip(solved) {
            z[i] = x;
        }
    }
}

/// The active nodes each cut cell claims (module doc), in cut-cell order;
/// cells that claim none are left out.
fn claim_nodes(op: &ElasticOperator) -> Vec<Vec<usize>> {
    let npc = op.dofs.order.nodes_per_cell();
    let mut claimed = vec![false; op.dofs.num_active()];
    let mut nodes = vec![0usize; npc];
    let mut out = Vec::new();
    for &cell in op.own_cells() {
        op.dofs.cell_active_nodes(&op.grid, cell, &mut nodes);
        let mine: Vec<usize> = nodes
            .iter()
            .copied()
            .filter(|&a| !std::mem::replace(&mut claimed[a], true))
            .collect();
        if !mine.is_empty() {
            out.push(mine);
        }
    }
    out
}

/// The block of the active nodes `nodes`: `R_b A R_bᵀ` summed over the cells
/// around them, inverted; `None` where its Cholesky factorisation fails.
fn block_of(op: &ElasticOperator, nodes: &[usize]) -> Option<Block> {
    let m = 3 * nodes.len();
    let local = |active: usize| nodes.iter().position(|&a| a == active);
    let mut cells = Vec::new();
    let mut around = Vec::with_capacity(8);
    for &a in nodes {
        node_cells(
            &op.grid,
            op.dofs.order,
            op.dofs.active_to_node[a] as usize,
            &mut around,
        );
        cells.extend(around.iter().map(|&(c, _)| c));
    }
    cells.sort_unstable();
    cells.dedup();
    let ne = op.dofs_per_cell();
    let mut cell_nodes = vec![0usize; ne / 3];
    let mut a = DMatrix::<f64>::zeros(m, m);
    for &cell in &cells {
        let Some(k) = op.cell_matrix(cell) else {
            continue;
        };
        op.dofs.cell_active_nodes(&op.grid, cell, &mut cell_nodes);
        let map: Vec<(usize, usize)> = cell_nodes
            .iter()
            .enumerate()
            .filter_map(|(l, &an)| local(an).map(|b| (l, b)))
            .collect();
        for &(li, bi) in &map {
            for &(lj, bj) in &map {
                for i in 0..3 {
                    for j in 0..3 {
                        a[(3 * bi + i, 3 * bj + j)] += k[(3 * li + i) * ne + 3 * lj + j];
                    }
                }
            }
        }
    }
    let inverse = a.cholesky()?.inverse();
    let dofs = nodes
        .iter()
        .flat_map(|&n| (0..3).map(move |c| 3 * n + c))
        .collect();
    Some(Block {
        dofs,
        inverse: (0..m)
            .flat_map(|i| (0..m).map(move |j| (i, j)))
            .map(|(i, j)| inverse[(i, j)])
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::LinearOperator;
    use crate::fem::setup::Setup;
    use crate::multigrid::tests::{scrambled, sphere};

    /// On the cut Q2 sphere: every block of `B⁻¹` inverts the assembled
    /// operator restricted to its unknowns, `B⁻¹` is the inverted diagonal
    /// elsewhere, and the blocks cover every active node of the cut cells.
    #[test]
    fn blocks_invert_the_assembled_operator_on_the_cut_band() {
        let case = sphere("q2", 0.01);
        let setup = Setup::new(&case, Some(3)).unwrap();
        let op = &setup.op;
        let a = op.assemble();
        let d = op.diagonal();
        let inv_diag: Vec<f64> = d.iter().map(|v| 1.0 / v).collect();
        let pre = BlockJacobi::new(op, &inv_diag);
        let (count, block_dofs) = pre.block_sizes();
        let band: usize = claim_nodes(op).iter().map(|b| 3 * b.len()).sum();
        assert!(
            count > 0 && block_dofs == band,
            "{count} blocks, {block_dofs} of {band} dofs"
        );

        let n = op.nrows();
        let r = scrambled(n, 5);
        let mut z = vec![0.0; n];
        pre.apply(&r, &mut z);
        let mut in_block = vec![false; n];
        for k in 0..count {
            let (dofs, _) = pre.block(k);
            for &i in dofs {
                in_block[i] = true;
            }
            for &i in dofs {
                let rows = a.row_idx_of_col_raw(i);
                let vals = a.val_of_col(i);
                let az: f64 = rows
                    .iter()
                    .zip(vals)
                    .filter(|(j, _)| dofs.contains(j))
                    .map(|(&j, v)| v * z[j])
                    .sum();
                assert!(
                    (az - r[i]).abs() <= 1e-9 * r[i].abs().max(1.0),
                    "dof {i}: {az} vs {}",
                    r[i]
                );
            }
        }
        for i in (0..n).filter(|&i| !in_block[i]) {
            assert_eq!(z[i], inv_diag[i] * r[i], "dof {i}");
        }
    }
}
