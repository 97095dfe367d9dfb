//! The linear path's solve on one rank of several: the outer strategies of
//! [`crate::driver`] (FGMRES or the paper's fixed point) over the rank's
//! [`RankSolver`] and [`RankOperator`], with the recovered load of the
//! rank's window ([`RecoveredLoad::shared`]): the displacement's ghosts are
//! brought from their owners first, so the recovery's patches around the
//! owned unknowns see the whole grid's values, and the S-term's rigid-body
//! fits add up each rank's brick ([`BrickShare`]).

use super::backend::{DistBackend, DistOperator};
use super::halo::Halo;
use super::halo::Reach;
use super::multigrid::RankMultigrid;
use super::RankSetup;
use crate::backend::{Backend, CpuBackend, LinearOperator};
use crate::case::Case;
use crate::comm::agree;
use crate::comm::Comm;
use crate::discrete::field::{error_sums, ErrorNorms};
use crate::driver::fixed_point::FixedPointReport;
use crate::driver::linear::LinearSolver;
use crate::driver::share::CellShare;
use crate::driver::solve::{outer_solve, reactions_by_tag, RecoveredLoad};
use crate::error::Result;
use crate::exact::ExactSum;
use crate::grid::{CellBox, Grid};
use crate::progress::Progress;
use crate::solver::{
    solve, solve_preconditioned, ApplyInverse, KrylovOptions, KrylovStats, Preconditioner,
    TimedInverse,
};

/// A rank counts the cells of its brick.
pub struct BrickShare<'a> {
    grid: &'a Grid,
    brick: CellBox,
    comm: &'a dyn Comm,
}

impl CellShare for BrickShare<'_> {
    fn counts(&self, cell: usize) -> bool {
        self.brick.contains(self.grid.cell_ijk(cell))
    }

    fn sum_exact(&self, sums: &mut [ExactSum]) {
        self.comm.sum_exact(sums)
    }
}

/// The rank's Krylov solves: its [`DistBackend`] (over the CPU, or the
/// rank's GPU) with Jacobi, or with the V-cycle of the rank's multigrid
/// levels (CPU) when the set-up built them.
pub struct RankSolver<'a, B: Backend + 'static = CpuBackend> {
    be: DistBackend<'a, B>,
    op: DistOperator<'a, B>,
    diag: B::Vector,
    multigrid: Option<Box<dyn ApplyInverse<DistBackend<'a, B>> + 'a>>,
    /// The V-cycles applied so far and their seconds.
    cycles: (usize, f64),
    /// The outer loop's host products.
    host: CpuBackend,
}

impl<'a> RankSolver<'a, CpuBackend> {
    /// The rank's solver on its CPU, with the set-up's multigrid levels.
    pub fn new(rs: &'a RankSetup, comm: &'a dyn Comm) -> Self {
        let multigrid = rs.multigrid.as_ref().map(|h| {
            Box::new(RankMultigrid::new(rs, h, comm)) as Box<dyn ApplyInverse<DistBackend<'a>>>
        });
        RankSolver::with(DistBackend::new(comm), &rs.setup.op, &rs.halo, multigrid)
    }
}

impl<'a, B: Backend + 'static> RankSolver<'a, B> {
    /// The solver of the rank's operator `local` on `be`, with its halo and
    /// a V-cycle where there is one.
    pub fn with(
        be: DistBackend<'a, B>,
        local: &'a B::Operator<'a>,
        halo: &'a Halo,
        multigrid: Option<Box<dyn ApplyInverse<DistBackend<'a, B>> + 'a>>,
    ) -> Self {
        let op = DistOperator::new(&be, local, halo);
        let diag = be.diagonal(&op);
        RankSolver {
            be,
            op,
            diag,
            multigrid,
            cycles: (0, 0.0),
            host: CpuBackend::new(),
        }
    }
}

impl<B: Backend + 'static> LinearSolver for RankSolver<'_, B> {
    fn solve(
        &mut self,
        rhs: &[f64],
        u: &mut Vec<f64>,
        opts: &KrylovOptions,
    ) -> Result<KrylovStats> {
        let rhs = self.be.upload(rhs);
        let mut x = self.be.upload(u);
        let stats = match (&self.multigrid, opts.preconditioner) {
            (Some(mg), Preconditioner::Multigrid | Preconditioner::Auto) => {
                let timed = TimedInverse::new(mg.as_ref());
                let stats = solve_preconditioned(&self.be, &self.op, &timed, &rhs, &mut x, opts);
                let (n, seconds) = timed.totals();
                self.cycles = (self.cycles.0 + n, self.cycles.1 + seconds);
                stats
            }
            _ => solve(&self.be, &self.op, Some(&self.diag), &rhs, &mut x, opts),
        };
        *u = self.be.download(&x);
        stats
    }

    fn v_cycles(&self) -> Option<(usize, f64)> {
        self.multigrid.as_ref().map(|_| self.cycles)
    }

    /// The outer loop's product ([`CpuBackend::total_dot`]; the ghosts'
    /// entries are zero). Collective.
    fn dot(&self, a: &[f64], b: &[f64]) -> f64 {
        self.host.total_dot(self.be.comm(), a, b)
    }

    /// Any rank's interrupt stops every rank at the same boundary.
    /// Collective.
    fn stop(&self, asked: bool) -> bool {
        let flag = [if asked { 1.0 } else { 0.0 }];
        self.be.comm().all_gather(&flag).iter().any(|r| r[0] != 0.0)
    }
}

/// The rank's operator as the outer loop applies it (`M z = A z − …`).
pub struct RankOperator<'a> {
    be: DistBackend<'a>,
    op: DistOperator<'a>,
}

impl<'a> RankOperator<'a> {
    pub fn new(rs: &'a RankSetup, comm: &'a dyn Comm) -> Self {
        let be = DistBackend::new(comm);
        let op = DistOperator::new(&be, &rs.setup.op, &rs.halo);
        RankOperator { be, op }
    }
}

impl LinearOperator for RankOperator<'_> {
    fn nrows(&self) -> usize {
        self.be.nrows(&self.op)
    }

    /// Collective.
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let mut out = vec![0.0; y.len()];
        self.be.apply(&self.op, &x.to_vec(), &mut out);
        y.copy_from_slice(&out);
    }

    fn diagonal(&self) -> Vec<f64> {
        self.be.diagonal(&self.op)
    }
}

/// What a rank's solve gives.
pub struct RankSolution {
    /// The rank's unknowns, the ghosts' values filled in.
    pub u: Vec<f64>,
    /// `Σ_q w_q λ_q` over the Dirichlet points of each boundary tag (by
    /// tag, `None` for a tag with no Dirichlet point), summed over the
    /// ranks.
    pub reactions: Vec<Option<[f64; 3]>>,
    /// The error norms against the case's exact solution, where it has one
    /// (over the whole body).
    pub error: Option<ErrorNorms>,
}

/// Solves the rank's share of the case (the fixed point of the recovered
/// load, as [`crate::driver::solve::solve_with_progress`] does on one
/// rank, with the rank's `solver`: [`RankSolver`]), then recovers the reactions and takes the error norms, each
/// summed over the ranks. An error on any rank is an error on every rank.
/// Collective.
pub fn solve_rank(
    rs: &RankSetup,
    case: &Case,
    comm: &dyn Comm,
    solver: &mut dyn LinearSolver,
    report: &mut FixedPointReport,
    progress: &dyn Progress,
) -> Result<RankSolution> {
    let setup = &rs.setup;
    let share = BrickShare {
        grid: &setup.grid,
        brick: rs.bricks[comm.rank()],
        comm,
    };
    let load = RecoveredLoad::shared(setup, &share);
    let mut recovered = |u: &[f64]| {
        let mut full = u.to_vec();
        rs.halo.fill_ghosts(comm, &mut full, Reach::Window);
        let mut f = agree(comm, load.at(&full))?;
        rs.halo.zero_ghosts(&mut f);
        Ok(f)
    };
    let fixed = rs.fixed_rhs();
    let plan = || agree(comm, load.plan());
    let plan = (!load.is_zero()).then_some(&plan as &dyn Fn() -> Result<f64>);
    let op = RankOperator::new(rs, comm);
    let spec = &case.spec.solver;
    let solver = &mut *solver;
    let mut u = outer_solve(
        plan,
        solver,
        &op,
        &fixed,
        &mut recovered,
        spec,
        report,
        progress,
    )?;
    report.v_cycles = solver.v_cycles();
    rs.halo.fill_ghosts(comm, &mut u, Reach::Window);
    let tags = case.body().geometry.tag_names().len();
    let reactions = agree(comm, load.reactions(&u))?.reactions;
    let reactions = reactions_by_tag(&setup.dirichlet, &reactions, tags, &share);
    let error = setup.problem.exact.as_ref().map(|exact| {
        let (grid, cells, dofs) = (&setup.grid, &setup.cells, &setup.op.dofs);
        let (lambda, mu) = (setup.problem.lambda, setup.problem.mu);
        let brick = rs.bricks[comm.rank()];
        let counts = |c: usize| brick.contains(grid.cell_ijk(c));
        let mut sums = error_sums(grid, cells, dofs, &u, exact, lambda, mu, &counts);
        comm.sum_exact(&mut sums);
        ErrorNorms::from_sums(&sums)
    });
    Ok(RankSolution {
        u,
        reactions,
        error,
    })
}
