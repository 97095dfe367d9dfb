//! The linear solves inside Newton: [`TangentSolver`], and its CPU
//! implementation with Jacobi or the bodies' multigrid.

use crate::backend::{CpuBackend, LinearOperator};
use crate::error::Result;
use crate::solver::{
    solve, solve_preconditioned, ApplyInverse, KrylovOptions, KrylovStats, Preconditioner,
};

/// Solves `K_T Δu = rhs` on some backend, warm-started at `du`.
pub trait TangentSolver {
    fn solve(
        &mut self,
        tangent: &dyn LinearOperator,
        rhs: &[f64],
        du: &mut Vec<f64>,
        opts: &KrylovOptions,
    ) -> Result<KrylovStats>;
}

/// The CPU backend with the matrix-free tangent: Jacobi (its diagonal per
/// tangent) or none, and the multigrid preconditioner when one is given
/// ([`crate::bodies::multigrid`]); a multigrid option without one is refused
/// by the solve ([`crate::Error::InvalidSolverOptions`]).
#[derive(Clone, Default)]
pub struct CpuTangentSolver<'a> {
    be: CpuBackend,
    multigrid: Option<&'a dyn ApplyInverse<CpuBackend>>,
}

impl<'a> CpuTangentSolver<'a> {
    /// The solver with `multigrid` as the preconditioner of
    /// `preconditioner = "multigrid"`.
    pub fn with_multigrid(multigrid: &'a dyn ApplyInverse<CpuBackend>) -> Self {
        CpuTangentSolver {
            be: CpuBackend::new(),
            multigrid: Some(multigrid),
        }
    }
}

impl TangentSolver for CpuTangentSolver<'_> {
    fn solve(
        &mut self,
        tangent: &dyn LinearOperator,
        rhs: &[f64],
        du: &mut Vec<f64>,
        opts: &KrylovOptions,
    ) -> Result<KrylovStats> {
        let rhs = rhs.to_vec();
        if let (Some(mg), Preconditioner::Multigrid | Preconditioner::Auto) =
            (self.multigrid, opts.preconditioner)
        {
            return solve_preconditioned(&self.be, tangent, mg, &rhs, du, opts);
        }
        let diag = (opts.preconditioner == Preconditioner::Jacobi).then(|| tangent.diagonal());
        solve(&self.be, tangent, diag.as_ref(), &rhs, du, opts)
    }
}
