//! The linear solves of the fixed-point loop, behind one trait so that the
//! loop runs on any backend: [`CpuSolver`] here (the reference), the GPU one in
//! [`crate::gpu::linear`]. A solver holds the operator (and its diagonal) for
//! all the solves of a run; each call solves `A u = rhs` from the `u` given.

use crate::backend::{CpuBackend, LinearOperator};
use crate::error::Result;
use crate::solver::{solve, KrylovOptions, KrylovStats};

/// Solves `A u = rhs` with the Krylov options given, warm-started at `u`.
pub trait LinearSolver {
    fn solve(&mut self, rhs: &[f64], u: &mut Vec<f64>, opts: &KrylovOptions)
        -> Result<KrylovStats>;
}

/// The CPU backend with a host operator and its diagonal (computed once).
pub struct CpuSolver<'a> {
    op: &'a dyn LinearOperator,
    diag: Vec<f64>,
    be: CpuBackend,
}

impl<'a> CpuSolver<'a> {
    pub fn new(op: &'a dyn LinearOperator) -> Self {
        CpuSolver {
            op,
            diag: op.diagonal(),
            be: CpuBackend::new(),
        }
    }
}

impl LinearSolver for CpuSolver<'_> {
    fn solve(
        &mut self,
        rhs: &[f64],
        u: &mut Vec<f64>,
        opts: &KrylovOptions,
    ) -> Result<KrylovStats> {
        solve(&self.be, self.op, Some(&self.diag), &rhs.to_vec(), u, opts)
    }
}
