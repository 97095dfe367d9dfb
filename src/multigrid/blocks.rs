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
//! every cell around them, inside cells included, and the pieces of split
//! cells; the copies of [`crate::cells::split`] are in no block). The
//! blocks do not overlap, so
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

use crate::discrete::dofs::node_cells;
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
    pub(crate) point: Vec<f64>,
    /// The blocks' unknowns: block `k` holds `dofs[starts[k]..starts[k + 1]]`.
    pub(crate) dofs: Vec<usize>,
    pub(crate) starts: Vec<usize>,
    /// The blocks' inverses, row-major, block `k`'s from `inverse_starts[k]`.
    pub(crate) inverses: Vec<f64>,
    pub(crate) inverse_starts: Vec<usize>,
}

impl BlockJacobi {
    /// The block Jacobi preconditioner of `op` with its floored diagonal
    /// inverted, `inv_diag`.
    pub fn new(op: &ElasticOperator, inv_diag: &[f64]) -> BlockJacobi {
        let claims = claim_nodes(op);
        let blocks: Vec<Block> = block_matrices(op, &claims)
            .into_par_iter()
            .zip(&claims)
            .filter_map(|(a, nodes)| inverted(a, nodes))
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
        // Each block's values, gathered once, through its inverse into its
        // slice of `solved`.
        let mut solved = vec![0.0; self.dofs.len()];
        let mut parts = Vec::with_capacity(self.starts.len() - 1);
        let mut rest = solved.as_mut_slice();
        for w in self.starts.windows(2) {
            let (part, tail) = rest.split_at_mut(w[1] - w[0]);
            parts.push(part);
            rest = tail;
        }
        parts
            .into_par_iter()
            .enumerate()
            .for_each_init(Vec::new, |local, (k, out)| {
                let (dofs, inverse) = self.block(k);
                local.clear();
                local.extend(dofs.iter().map(|&j| r[j]));
                // In the order of the device's kernel and its mirror.
                for (o, row) in out.iter_mut().zip(inverse.chunks_exact(dofs.len())) {
                    *o = row.iter().zip(local.iter()).map(|(a, b)| a * b).sum();
                }
            });
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

/// Cells whose contributions are gathered in parallel before they are summed
/// into the blocks: bounds the memory of the contributions in flight.
const CELLS_PER_PASS: usize = 512;

/// `R_b A R_bᵀ` of every block `b` of `claims`, summed over the cells around
/// its nodes. Each cell's matrix is built once (a cut cell's is rebuilt
/// from its weights), its contributions to the blocks gathered in parallel
/// and summed in cell order.
fn block_matrices(op: &ElasticOperator, claims: &[Vec<usize>]) -> Vec<DMatrix<f64>> {
    let mut owner = vec![None; op.dofs.num_active()];
    for (b, nodes) in claims.iter().enumerate() {
        for (l, &a) in nodes.iter().enumerate() {
            owner[a] = Some((b, l));
        }
    }
    let mut cells = Vec::new();
    let mut around = Vec::with_capacity(8);
    for &a in claims.iter().flatten() {
        let node = op.dofs.active_to_node[a] as usize;
        node_cells(&op.grid, op.dofs.order, node, &mut around);
        cells.extend(around.iter().map(|&(c, _)| c));
    }
    cells.sort_unstable();
    cells.dedup();
    let mut blocks: Vec<DMatrix<f64>> = claims
        .iter()
        .map(|nodes| DMatrix::zeros(3 * nodes.len(), 3 * nodes.len()))
        .collect();
    let pieces = op
        .split_elements()
        .iter()
        .map(|(nodes, k)| element_contributions(&owner, k, nodes));
    for parts in cells
        .chunks(CELLS_PER_PASS)
        .map(|pass| {
            pass.par_iter()
                .map(|&cell| contributions(op, &owner, cell))
                .collect::<Vec<_>>()
        })
        .chain(std::iter::once(pieces.collect()))
    {
        for (b, locals, values) in parts.into_iter().flatten() {
            let g = 3 * locals.len();
            for (p, &bp) in locals.iter().enumerate() {
                for (q, &bq) in locals.iter().enumerate() {
                    for i in 0..3 {
                        for j in 0..3 {
                            blocks[b][(3 * bp + i, 3 * bq + j)] +=
                                values[(3 * p + i) * g + 3 * q + j];
                        }
                    }
                }
            }
        }
    }
    blocks
}

/// A cell's part of one block: the block, the block-local indices of the
/// cell's nodes in it, and their `3g × 3g` submatrix of the cell's matrix.
type Contribution = (usize, Vec<usize>, Vec<f64>);

/// The contributions of `cell` to the blocks that own its nodes (`owner`:
/// block and local index per active node).
fn contributions(
    op: &ElasticOperator,
    owner: &[Option<(usize, usize)>],
    cell: usize,
) -> Vec<Contribution> {
    let Some(k) = op.cell_matrix(cell) else {
        return Vec::new();
    };
    let mut nodes = vec![0usize; op.dofs_per_cell() / 3];
    op.dofs.cell_active_nodes(&op.grid, cell, &mut nodes);
    element_contributions(owner, &k, &nodes)
}

/// The contributions of an element with matrix `k` (row-major) on the
/// active nodes `nodes` to the blocks that own them.
fn element_contributions(
    owner: &[Option<(usize, usize)>],
    k: &[f64],
    nodes: &[usize],
) -> Vec<Contribution> {
    let ne = 3 * nodes.len();
    // (block, local in block, local in element), grouped by block.
    let mut owned: Vec<(usize, usize, usize)> = nodes
        .iter()
        .enumerate()
        .filter_map(|(l, &a)| owner[a].map(|(b, bl)| (b, bl, l)))
        .collect();
    owned.sort_unstable();
    owned
        .chunk_by(|x, y| x.0 == y.0)
        .map(|group| {
            let g = 3 * group.len();
            let mut values = vec![0.0; g * g];
            for (p, &(_, _, lp)) in group.iter().enumerate() {
                for (q, &(_, _, lq)) in group.iter().enumerate() {
                    for i in 0..3 {
                        for j in 0..3 {
                            values[(3 * p + i) * g + 3 * q + j] = k[(3 * lp + i) * ne + 3 * lq + j];
                        }
                    }
                }
            }
            (group[0].0, group.iter().map(|x| x.1).collect(), values)
        })
        .collect()
}

/// The block of the active nodes `nodes` with matrix `a`, inverted; `None`
/// where its Cholesky factorisation fails.
fn inverted(a: DMatrix<f64>, nodes: &[usize]) -> Option<Block> {
    let m = a.nrows();
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
    use crate::driver::setup::Setup;
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
