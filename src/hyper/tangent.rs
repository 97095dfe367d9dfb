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
use super::points::QuadPoint;
use super::problem::{CellBuffer, HyperProblem, MAX_NODES};
use super::residual::{add_bt_stress, add_penalty, deformation_gradient, field_gradient};
use crate::backend::LinearOperator;
use crate::element::ElementOrder;

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
        let n = problem.cells.len();
        let states: Option<Vec<PointState>> = (0..n)
            .into_par_iter()
            .flat_map_iter(|k| {
                let mut buffer: CellBuffer = [[0.0; 3]; MAX_NODES];
                let npc = problem.gather(k, u, &mut buffer).len();
                problem
                    .points(k)
                    .map(move |q| PointState::new(deformation_gradient(&buffer[..npc], &q)))
            })
            .collect();
        let mut state_start = Vec::with_capacity(n + 1);
        state_start.push(0);
        for k in 0..n {
            state_start.push(state_start[k] + problem.points(k).len());
        }
        Some(TangentOperator {
            problem,
            states: states?,
            state_start,
        })
    }

    /// The states of the `k`-th cell's points.
    pub fn cell_states(&self, k: usize) -> &[PointState] {
        &self.states[self.state_start[k]..self.state_start[k + 1]]
    }

    /// `out += K_c v_c`: the cell's tangent applied to its nodal values.
    pub fn cell_apply(&self, k: usize, ve: &[[f64; 3]], out: &mut [[f64; 3]]) {
        let p = self.problem;
        // The point loop with the element's node count known to the
        // compiler (its gradient and scatter loops unrolled).
        let rows = "a cell's nodes";
        match p.order() {
            ElementOrder::Q1 => {
                let (ve, out) = (ve.try_into().expect(rows), out.try_into().expect(rows));
                self.points_apply::<8>(k, ve, out)
            }
            ElementOrder::Q2 => {
                let (ve, out) = (ve.try_into().expect(rows), out.try_into().expect(rows));
                self.points_apply::<27>(k, ve, out)
            }
        }
        add_penalty(p.penalty_points(k), ve, 0.0, out);
        if let Some(s) = &p.s_term {
            s.add_cell_tangent(k, ve, out);
        }
    }

    /// The volume points' part of [`Self::cell_apply`] for `N` nodes.
    fn points_apply<const N: usize>(&self, k: usize, ve: &[[f64; 3]; N], out: &mut [[f64; 3]; N]) {
        let p = self.problem;
        for (q, s) in p.points(k).zip(self.cell_states(k)) {
            let grads: &[[f64; 3]; N] = q.grads.try_into().expect("N gradients a point");
            let q = QuadPoint { grads, w: q.w };
            let dp = p.material.tangent_action(s, &field_gradient(ve, &q));
            add_bt_stress(&dp, &q, out);
        }
    }

    /// `K_c` of the `k`-th cell applied to the global vector `x`, into `out`.
    fn cell_apply_global(&self, k: usize, x: &[f64], out: &mut [[f64; 3]]) {
        let mut buffer: CellBuffer = [[0.0; 3]; MAX_NODES];
        self.cell_apply(k, self.problem.gather(k, x, &mut buffer), out);
    }

    /// The cell's dense tangent, row-major `3n × 3n` for `n` nodes (dof
    /// `3 a + i`): column `3 b + k` is the cell apply of the unit vector of
    /// that dof.
    pub fn cell_matrix(&self, k: usize) -> Vec<f64> {
        let dofs = 3 * self.problem.nodes_per_cell();
        let mut m = vec![0.0; dofs * dofs];
        let mut e: CellBuffer = [[0.0; 3]; MAX_NODES];
        let mut y: CellBuffer = [[0.0; 3]; MAX_NODES];
        for col in 0..dofs {
            e[col / 3][col % 3] = 1.0;
            y.iter_mut().for_each(|v| *v = [0.0; 3]);
            self.cell_apply(k, &e[..dofs / 3], &mut y[..dofs / 3]);
            e[col / 3][col % 3] = 0.0;
            for row in 0..dofs {
                m[row * dofs + col] = y[row / 3][row % 3];
            }
        }
        m
    }

    /// The cell's diagonal entries, `[node][component]`, into `d` (zeroed).
    fn cell_diagonal(&self, k: usize, d: &mut [[f64; 3]]) {
        let p = self.problem;
        for (q, s) in p.points(k).zip(self.cell_states(k)) {
            for (da, grad) in d.iter_mut().zip(q.grads) {
                for i in 0..3 {
                    // dF = e_i ⊗ ∇N_a; the entry is w (A : dF)_iJ ∂N_a/∂X_J.
                    let mut df = Matrix3::zeros();
                    for j in 0..3 {
                        df[(i, j)] = grad[j];
                    }
                    let dp = p.material.tangent_action(s, &df);
                    da[i] += q.w * (0..3).map(|j| dp[(i, j)] * grad[j]).sum::<f64>();
                }
            }
        }
        for (pp, n) in p.penalty_points(k) {
            for (da, n) in d.iter_mut().zip(n) {
                for i in 0..3 {
                    da[i] += pp.weight * pp.mask[i] * n * n;
                }
            }
        }
        if let Some(s) = &p.s_term {
            s.add_cell_diagonal(k, d);
        }
    }

    /// `y += K_cut x`: the cut cells' part of the tangent (their volume points
    /// and the Dirichlet penalty), which the GPU kernel of
    /// [`super::mirror`] leaves to the CPU.
    pub fn add_cut_cells(&self, x: &[f64], y: &mut [f64]) {
        let p = self.problem;
        let cut: Vec<usize> = (0..p.cells.len())
            .filter(|&k| p.cut_index[k].is_some())
            .collect();
        let npc = p.nodes_per_cell();
        let mut cell_vectors = vec![[0.0; 3]; npc * cut.len()];
        cell_vectors
            .par_chunks_mut(npc)
            .zip(&cut)
            .for_each(|(out, &k)| self.cell_apply_global(k, x, out));
        for (out, &k) in cell_vectors.chunks_exact(npc).zip(&cut) {
            p.scatter_cell(k, out, y);
        }
    }

    /// `K_T` assembled (faer, duplicates summed).
    pub fn assemble(&self) -> SparseColMat<usize, f64> {
        let p = self.problem;
        let blocks: Vec<Vec<f64>> = (0..p.cells.len())
            .into_par_iter()
            .map(|k| self.cell_matrix(k))
            .collect();
        let dofs = 3 * p.nodes_per_cell();
        let mut triplets = Vec::with_capacity(blocks.len() * dofs * dofs);
        for (k, m) in blocks.iter().enumerate() {
            let nodes = p.cell_nodes(k);
            let dof = |l: usize| 3 * nodes[l / 3] as usize + l % 3;
            for row in 0..dofs {
                for col in 0..dofs {
                    triplets.push(Triplet::new(dof(row), dof(col), m[row * dofs + col]));
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
        let cell_vectors = p.cell_vectors(|k, out| self.cell_apply_global(k, x, out));
        y.fill(0.0);
        p.scatter(&cell_vectors, y);
    }

    fn diagonal(&self) -> Vec<f64> {
        let p = self.problem;
        let cell_vectors = p.cell_vectors(|k, d| self.cell_diagonal(k, d));
        let mut d = vec![0.0; p.ndofs()];
        p.scatter(&cell_vectors, &mut d);
        d
    }
}
