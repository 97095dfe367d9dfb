//! The linear solves of the fixed-point loop, behind one trait so that the
//! loop runs on any backend: [`CpuSolver`] here (the reference), the GPU one in
//! [`crate::gpu::linear`]. A solver holds the operator (and its diagonal, or
//! the multigrid V-cycle) for all the solves of a run; each call solves
//! `A u = rhs` from the `u` given.

use crate::backend::{CpuBackend, LinearOperator};
use crate::driver::setup::Setup;
use crate::error::Result;
use crate::multigrid::Multigrid;
use crate::solver::fgmres::local_dot;
use crate::solver::{
    solve, solve_preconditioned, KrylovOptions, KrylovStats, Preconditioner, TimedInverse,
};

/// Solves `A u = rhs` with the Krylov options given, warm-started at `u`.
pub trait LinearSolver {
    fn solve(&mut self, rhs: &[f64], u: &mut Vec<f64>, opts: &KrylovOptions)
        -> Result<KrylovStats>;

    /// The multigrid V-cycles applied so far and their seconds, where the
    /// solver times them on the host (`None`: not timed, or no V-cycle).
    fn v_cycles(&self) -> Option<(usize, f64)> {
        None
    }

    /// `a · b` over the whole body (the solver of one rank of several sums
    /// its part over the ranks).
    fn dot(&self, a: &[f64], b: &[f64]) -> f64 {
        local_dot(a, b)
    }

    /// Whether the run stops at this iteration boundary, `asked` being
    /// this process's wish (Ctrl-C). The solver of one rank of several
    /// stops when any rank asks, so that all leave the loop together.
    fn stop(&self, asked: bool) -> bool {
        asked
    }
}

/// The CPU backend with a host operator and its diagonal (computed once),
/// and the multigrid V-cycle when the set-up built a hierarchy.
pub struct CpuSolver<'a> {
    op: &'a dyn LinearOperator,
    diag: Vec<f64>,
    multigrid: Option<Multigrid<'a>>,
    be: CpuBackend,
    /// The V-cycles applied so far and their seconds.
    cycles: (usize, f64),
}

impl<'a> CpuSolver<'a> {
    /// The solver of `op` (none, Jacobi: a multigrid option is refused by
    /// the solve, [`crate::Error::InvalidSolverOptions`]).
    pub fn new(op: &'a dyn LinearOperator) -> Self {
        CpuSolver {
            op,
            diag: op.diagonal(),
            multigrid: None,
            be: CpuBackend::new(),
            cycles: (0, 0.0),
        }
    }

    /// The solver of a set-up's operator, with its multigrid hierarchy when
    /// it has one.
    pub fn for_setup(setup: &'a Setup) -> Self {
        CpuSolver {
            multigrid: setup
                .multigrid
                .as_ref()
                .map(|h| Multigrid::new(&setup.op, h)),
            ..CpuSolver::new(&setup.op)
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
        let rhs = rhs.to_vec();
        match (&self.multigrid, opts.preconditioner) {
            (Some(mg), Preconditioner::Multigrid | Preconditioner::Auto) => {
                let timed = TimedInverse::new(mg);
                let stats = solve_preconditioned(&self.be, self.op, &timed, &rhs, u, opts);
                let (n, seconds) = timed.totals();
                self.cycles = (self.cycles.0 + n, self.cycles.1 + seconds);
                stats
            }
            _ => solve(&self.be, self.op, Some(&self.diag), &rhs, u, opts),
        }
    }

    fn v_cycles(&self) -> Option<(usize, f64)> {
        self.multigrid.as_ref().map(|_| self.cycles)
    }
}
