//! The consistent tangent `K_T(u) = ∂R/∂u` of the residual of
//! [`super::residual`]:
//! ```text
//! (K_T v)_{a i} = Σ_q w_q (A(F_q) : ∇v_q)_iJ ∂N_a/∂X_J  +  Σ_p w_p (β/h) N_a m_i (N v)_i  (+ K_S v)
//! ```
//! with `K_S` the constant S-term mass of [`super::stabilisation`] on Ω*
//! (cut cells, so also in [`TangentOperator::add_cut_cells`]).
//! applied matrix-free (the states `F`, `F⁻ᵀ`, `ln J` of every point are
//! evaluated once at the linearisation point; each apply gathers the cell's
//! `v`, forms `∇v` and `A : ∇v` per point and scatters), its diagonal (for
//! Jacobi) and the same operator assembled as a faer sparse matrix, for checks
//! and direct solves. For a hyperelastic material `A` has major symmetry, so
//! `K_T` is symmetric.

use faer::sparse::{SparseColMat, Triplet};
use nalgebra::Matrix3;
use rayon::prelude::*;

use super::material::PointState;
use super::problem::{HyperProblem, CELL_DOFS, NODES};
use super::residual::{
    add_bt_stress, add_penalty, deformation_gradient, field_gradient, CellVector,
};
use crate::backend::LinearOperator;

/// `K_T(u)` of a problem at one displacement.
pub struct TangentOperator<'p> {
    pub problem: &'p HyperProblem,
    /// Per entry of [`HyperProblem::cells`], its points' states, back to back.
    states: Vec<PointState>,
    state_start: Vec<usize>,
}

impl<'p> TangentOperator<'p> {
    /// The tangent at `u`, or `None` if some point has `det F ≤ 0`.
    pub fn new(problem: &'p HyperProblem, u: &[f64]) -> Option<TangentOperator<'p>> {
        let per_cell: Option<Vec<Vec<PointState>>> = (0..problem.cells.len())
            .into_par_iter()
            .map(|k| {
                let ue = problem.gather(k, u);
                problem
                    .points(k)
                    .iter()
                    .map(|q| PointState::new(deformation_gradient(&ue, q)))
                    .collect()
            })
            .collect();
        let per_cell = per_cell?;
        let mut state_start = Vec::with_capacity(per_cell.len() + 1);
        state_start.push(0);
        for s in &per_cell {
            state_start.push(state_start.last().copied().unwrap_or(0) + s.len());
        }
        Some(TangentOperator {
            problem,
            states: per_cell.into_iter().flatten().collect(),
            state_start,
        })
    }

    /// The states of the `k`-th cell's points.
    pub fn cell_states(&self, k: usize) -> &[PointState] {
        &self.states[self.state_start[k]..self.state_start[k + 1]]
    }

    /// `(K_c v_c)`: the cell's tangent applied to its nodal values.
    pub fn cell_apply(&self, k: usize, ve: &CellVector) -> CellVector {
        let p = self.problem;
        let mut out = [[0.0; 3]; NODES];
        for (q, s) in p.points(k).iter().zip(self.cell_states(k)) {
            let dp = p.material.tangent_action(s, &field_gradient(ve, q));
            add_bt_stress(&dp, q, &mut out);
        }
        add_penalty(p.penalty_points(k), ve, 0.0, &mut out);
        if let Some(s) = &p.s_term {
            s.add_cell_tangent(k, ve, &mut out);
        }
        out
    }

    /// The cell's dense tangent, row-major `24 × 24` (dof `3 a + i`): column
    /// `3 b + k` is the cell apply of the unit vector of that dof.
    pub fn cell_matrix(&self, k: usize) -> Vec<f64> {
        let mut m = vec![0.0; CELL_DOFS * CELL_DOFS];
        for col in 0..CELL_DOFS {
            let mut e = [[0.0; 3]; NODES];
            e[col / 3][col % 3] = 1.0;
            let y = self.cell_apply(k, &e);
            for row in 0..CELL_DOFS {
                m[row * CELL_DOFS + col] = y[row / 3][row % 3];
            }
        }
        m
    }

    /// The cell's diagonal entries, `[node][component]`.
    fn cell_diagonal(&self, k: usize) -> CellVector {
        let p = self.problem;
        let mut d = [[0.0; 3]; NODES];
        for (q, s) in p.points(k).iter().zip(self.cell_states(k)) {
            for a in 0..NODES {
                for i in 0..3 {
                    // dF = e_i ⊗ ∇N_a; the entry is w (A : dF)_iJ ∂N_a/∂X_J.
                    let mut df = Matrix3::zeros();
                    for j in 0..3 {
                        df[(i, j)] = q.grads[a][j];
                    }
                    let dp = p.material.tangent_action(s, &df);
                    d[a][i] += q.w * (0..3).map(|j| dp[(i, j)] * q.grads[a][j]).sum::<f64>();
                }
            }
        }
        for pp in p.penalty_points(k) {
            for a in 0..NODES {
                for i in 0..3 {
                    d[a][i] += pp.weight * pp.mask[i] * pp.n[a] * pp.n[a];
                }
            }
        }
        if let Some(s) = &p.s_term {
            s.add_cell_diagonal(k, &mut d);
        }
        d
    }

    /// `y += K_cut x`: the cut cells' part of the tangent (their volume points
    /// and the Dirichlet penalty), which the GPU kernel of
    /// [`super::mirror`] leaves to the CPU.
    pub fn add_cut_cells(&self, x: &[f64], y: &mut [f64]) {
        let p = self.problem;
        let cut: Vec<usize> = (0..p.cells.len())
            .filter(|&k| p.cut_index[k].is_some())
            .collect();
        let cell_vectors: Vec<(usize, CellVector)> = cut
            .into_par_iter()
            .map(|k| (k, self.cell_apply(k, &p.gather(k, x))))
            .collect();
        for (k, v) in cell_vectors {
            for (a, &node) in p.cell_nodes[k].iter().enumerate() {
                for i in 0..3 {
                    y[3 * node as usize + i] += v[a][i];
                }
            }
        }
    }

    /// `K_T` assembled (faer, duplicates summed).
    pub fn assemble(&self) -> SparseColMat<usize, f64> {
        let p = self.problem;
        let blocks: Vec<Vec<f64>> = (0..p.cells.len())
            .into_par_iter()
            .map(|k| self.cell_matrix(k))
            .collect();
        let mut triplets = Vec::with_capacity(blocks.len() * CELL_DOFS * CELL_DOFS);
        for (k, m) in blocks.iter().enumerate() {
            let dof = |l: usize| 3 * p.cell_nodes[k][l / 3] as usize + l % 3;
            for row in 0..CELL_DOFS {
                for col in 0..CELL_DOFS {
                    triplets.push(Triplet::new(dof(row), dof(col), m[row * CELL_DOFS + col]));
                }
            }
        }
        let n = p.ndofs();
        SparseColMat::try_new_from_triplets(n, n, &triplets)
            .expect("triplet indices lie within the dofs")
    }
}

impl LinearOperator for TangentOperator<'_> {
    fn nrows(&self) -> usize {
        self.problem.ndofs()
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let p = self.problem;
        let cell_vectors: Vec<CellVector> = (0..p.cells.len())
            .into_par_iter()
            .map(|k| self.cell_apply(k, &p.gather(k, x)))
            .collect();
        y.fill(0.0);
        p.scatter(&cell_vectors, y);
    }

    fn diagonal(&self) -> Vec<f64> {
        let p = self.problem;
        let cell_vectors: Vec<CellVector> = (0..p.cells.len())
            .into_par_iter()
            .map(|k| self.cell_diagonal(k))
            .collect();
        let mut d = vec![0.0; p.ndofs()];
        p.scatter(&cell_vectors, &mut d);
        d
    }
}
