//! The linear-elastic solve of a set-up case: the fixed-point loop with the
//! SPR-recovered Dirichlet traction and, when the S-term is on, the recovered
//! displacement on the pathological cells; then the recovered tractions at the
//! converged solution and the reactions.

use std::sync::OnceLock;

use super::fixed_point::{fixed_point_with_progress, FixedPointOptions, FixedPointReport};
use super::linear::{CpuSolver, LinearSolver};
use super::outer_krylov::fgmres_fixed_point;
use super::recovery::{
    plan_stress, reactions, recover_stress, recovered_tractions, traction_patch_nodes,
};
use super::setup::Setup;
use super::share::{CellShare, Whole};
use super::stabilisation::{plan_displacement, recover_displacement, s_rhs};
use crate::backend::LinearOperator;
use crate::case::physics::{OuterMethod, SolverSpec};
use crate::error::{Error, Result};
use crate::exact::ExactSum;
use crate::fem::rhs::{traction_rhs, DirichletPoint};
use crate::progress::{Event, Phase, Progress, Silent};
use crate::recovery::{FitPlans, Recovered};
use crate::solver::KrylovOptions;

/// A converged solution.
#[derive(Clone, Debug)]
pub struct Solution {
    pub u: Vec<f64>,
    /// Recovered traction `t̂` at each Dirichlet point.
    pub t_hat: Vec<[f64; 3]>,
    /// Reaction `λ_q` at each Dirichlet point.
    pub reactions: Vec<[f64; 3]>,
    /// The stress recovered from `u` on the traction's patches, which the
    /// output's recovery of every vertex takes over.
    pub stress: Recovered<6>,
}

/// What the solution's recovery gives at the Dirichlet points.
pub struct Reactions {
    /// Recovered traction `t̂` at each Dirichlet point.
    pub t_hat: Vec<[f64; 3]>,
    /// Reaction `λ_q` at each Dirichlet point.
    pub reactions: Vec<[f64; 3]>,
    /// The stress recovered on the traction's patches.
    pub stress: Recovered<6>,
}

/// `Σ_q w_q λ_q` over the Dirichlet points of each boundary tag (of
/// `tags`) in the cells that `share` counts, `reactions` holding each
/// point's `λ_q`: added exactly and over the ranks (the same bits however
/// threads or ranks split the points); `None` for a tag with no Dirichlet
/// point.
pub fn reactions_by_tag(
    dirichlet: &[DirichletPoint],
    reactions: &[[f64; 3]],
    tags: usize,
    share: &dyn CellShare,
) -> Vec<Option<[f64; 3]>> {
    // Per tag: the force and the number of points.
    let mut sums = vec![ExactSum::new(); 4 * tags];
    for (p, r) in dirichlet.iter().zip(reactions) {
        if share.counts(p.cell) {
            let t = 4 * p.tag as usize;
            for k in 0..3 {
                sums[t + k].add(p.w * r[k]);
            }
            sums[t + 3].add(1.0);
        }
    }
    share.sum_exact(&mut sums);
    sums.chunks_exact(4)
        .map(|f| (f[3].value() > 0.0).then(|| [0, 1, 2].map(|k| f[k].value())))
        .collect()
}

/// The loop settings of a case's `[solver]` table.
pub fn fixed_point_options(spec: &SolverSpec) -> FixedPointOptions {
    FixedPointOptions {
        krylov: KrylovOptions {
            method: spec.method,
            preconditioner: spec.preconditioner,
            rel_tol: spec.rel_tol,
            max_iterations: spec.max_iterations,
        },
        min_rel_tol: spec.min_rel_tol,
        tol: spec.fixed_point_tol(),
        max_iterations: spec.max_fixed_point,
        inner_rel_tol: spec.inner_rel_tol(),
    }
}

/// Solves on the CPU; the loop's report is filled in even when the solve fails.
pub fn solve(setup: &Setup, spec: &SolverSpec, report: &mut FixedPointReport) -> Result<Solution> {
    solve_with(setup, spec, &mut CpuSolver::for_setup(setup), report)
}

/// Solves with `solver` for the linear systems (any backend).
pub fn solve_with(
    setup: &Setup,
    spec: &SolverSpec,
    solver: &mut dyn LinearSolver,
    report: &mut FixedPointReport,
) -> Result<Solution> {
    solve_with_progress(setup, spec, solver, report, &Silent)
}

/// [`solve_with`], reporting the solves, iterations and recoveries to
/// `progress`, which may stop the run at an iteration boundary
/// ([`crate::Error::Interrupted`]).
pub fn solve_with_progress(
    setup: &Setup,
    spec: &SolverSpec,
    solver: &mut dyn LinearSolver,
    report: &mut FixedPointReport,
    progress: &dyn Progress,
) -> Result<Solution> {
    let _span = tracing::info_span!("solve", dofs = setup.fixed_rhs.len()).entered();
    setup.check_held()?;
    let load = RecoveredLoad::new(setup);
    let mut traction_load = |u: &[f64]| load.at(u);
    let plan = || load.plan();
    let plan = (!load.is_zero()).then_some(&plan as &dyn Fn() -> Result<f64>);
    let (op, fixed) = (&setup.op, &setup.fixed_rhs);
    let u = outer_solve(
        plan,
        solver,
        op,
        fixed,
        &mut traction_load,
        spec,
        report,
        progress,
    )?;
    let _span = tracing::info_span!("recovery").entered();
    let t = std::time::Instant::now();
    progress.event(&Event::Start {
        phase: Phase::Recovery,
        total: None,
    });
    let recovered = load.reactions(&u);
    progress.event(&Event::Finish {
        phase: Phase::Recovery,
    });
    report.recovery_seconds += t.elapsed().as_secs_f64();
    report.recoveries += 1;
    report.v_cycles = solver.v_cycles();
    let Reactions {
        t_hat,
        reactions,
        stress,
    } = recovered?;
    tracing::info!(
        points = t_hat.len(),
        "recovered the tractions and reactions"
    );
    Ok(Solution {
        u,
        t_hat,
        reactions,
        stress,
    })
}

/// Solves `A U = F + R(U)` (`fixed` is `F`, `recovered(U)` is `R(U)`) by
/// the case's outer method, after planning the recoveries' fits
/// (`plan`, [`RecoveredLoad::plan`]: its seconds go to the report); `plan`
/// `None`: nothing is recovered, and one solve is the answer. `op` is `A`
/// on the host, for the outer FGMRES.
#[allow(clippy::too_many_arguments)]
pub fn outer_solve(
    plan: Option<&dyn Fn() -> Result<f64>>,
    solver: &mut dyn LinearSolver,
    op: &dyn LinearOperator,
    fixed: &[f64],
    recovered: &mut dyn FnMut(&[f64]) -> Result<Vec<f64>>,
    spec: &SolverSpec,
    report: &mut FixedPointReport,
    progress: &dyn Progress,
) -> Result<Vec<f64>> {
    let opts = fixed_point_options(spec);
    let Some(plan) = plan else {
        return solve_once(fixed, solver, &opts, report, progress);
    };
    report.plan_seconds = plan()?;
    match spec.outer {
        OuterMethod::Fgmres => {
            fgmres_fixed_point(solver, op, fixed, recovered, &opts, report, progress)
        }
        OuterMethod::Picard => {
            fixed_point_with_progress(solver, fixed, recovered, &opts, report, progress)
        }
    }
}

/// The part of the right-hand side recovered from a displacement: the
/// traction `F_T(u)` of the Dirichlet points with its flux correction and,
/// when the S-term is on, `F_S(u)`. The system of the fixed point is
/// `A U = fixed_rhs + RecoveredLoad::at(U)`.
///
/// The first evaluation keeps each patch's accepted fit (of the stress and of
/// the displacement recovery), and the later ones reuse it
/// ([`crate::recovery::recover_planned`]): the same coefficients without the
/// ring search, the stability checks and the factorisations.
pub struct RecoveredLoad<'a> {
    setup: &'a Setup,
    /// The cells this rank counts in the S-term's fits.
    share: &'a dyn CellShare,
    /// Whether the S-term is on and some rank has a pathological cell.
    stabilised: bool,
    /// Whether some rank has a Dirichlet point.
    held: bool,
    /// The [`traction_patch_nodes`].
    nodes: Vec<usize>,
    stress_plans: OnceLock<FitPlans>,
    displacement_plans: OnceLock<FitPlans>,
}

impl<'a> RecoveredLoad<'a> {
    pub fn new(setup: &'a Setup) -> Self {
        RecoveredLoad::shared(setup, &Whole)
    }

    /// The recovered load of one rank's set-up, its S-term's fits over the
    /// cells `share` counts, summed over the ranks.
    pub fn shared(setup: &'a Setup, share: &'a dyn CellShare) -> Self {
        let counted =
            |cells: &mut dyn Iterator<Item = usize>| cells.filter(|&c| share.counts(c)).count();
        let mut counts = [
            ExactSum::of([counted(&mut setup.omega_star.iter().copied()) as f64]),
            ExactSum::of([counted(&mut setup.dirichlet.iter().map(|p| p.cell)) as f64]),
        ];
        share.sum_exact(&mut counts);
        RecoveredLoad {
            setup,
            share,
            stabilised: setup.s_factor > 0.0 && counts[0].value() > 0.0,
            held: counts[1].value() > 0.0,
            nodes: traction_patch_nodes(setup),
            stress_plans: OnceLock::new(),
            displacement_plans: OnceLock::new(),
        }
    }

    /// The recovered traction `t̂` and the reaction at each Dirichlet point
    /// for the solution `u`, with the stress recovered on the traction's
    /// patches.
    pub fn reactions(&self, u: &[f64]) -> Result<Reactions> {
        let setup = self.setup;
        let sigma = recover_stress(setup, u, &self.nodes, Some(&self.stress_plans))?;
        let t_hat = recovered_tractions(&setup.dirichlet, &sigma)?;
        let extra = setup
            .flux
            .dirichlet_densities(&setup.cells, &sigma, &setup.dirichlet)?;
        let mut reactions = reactions(setup, u, &t_hat);
        for (r, e) in reactions.iter_mut().zip(&extra) {
            for k in 0..3 {
                r[k] += e[k];
            }
        }
        Ok(Reactions {
            t_hat,
            reactions,
            stress: sigma,
        })
    }

    /// Plans the patch fits of the loop's recoveries (the stress's and,
    /// with the S-term, the displacement's) from their sample positions, so
    /// that every recovery of the loop solves its fits from the cells'
    /// moments ([`crate::recovery::recover_planned`]); returns the seconds
    /// it took. The plans depend on the geometry and the loads only: this is
    /// the set-up of the recoveries, done once before the loop.
    pub fn plan(&self) -> Result<f64> {
        let t = std::time::Instant::now();
        let setup = self.setup;
        if self.held {
            plan_stress(setup, &self.nodes, &self.stress_plans)?;
        }
        if self.stabilised {
            plan_displacement(setup, &setup.omega_star, &self.displacement_plans)?;
        }
        Ok(t.elapsed().as_secs_f64())
    }

    /// Whether nothing is recovered into the right-hand side (no Dirichlet
    /// point, no S-term): then one solve is the answer.
    pub fn is_zero(&self) -> bool {
        !self.held && !self.stabilised
    }

    /// `F_T(u) (+ F_S(u))`.
    pub fn at(&self, u: &[f64]) -> Result<Vec<f64>> {
        let setup = self.setup;
        let sigma = recover_stress(setup, u, &self.nodes, Some(&self.stress_plans))?;
        let t = recovered_tractions(&setup.dirichlet, &sigma)?;
        let mut f = traction_rhs(&setup.grid, &setup.op.dofs, &setup.dirichlet, &t);
        setup
            .flux
            .add_recovered(&setup.grid, &setup.cells, &setup.op.dofs, &sigma, &mut f)?;
        if self.stabilised {
            let s =
                recover_displacement(setup, u, &setup.omega_star, Some(&self.displacement_plans))?;
            let fs = s_rhs(
                setup,
                &setup.omega_star,
                u,
                &s,
                setup.s_factor,
                setup.s_balanced,
                self.share,
            )?;
            for (a, b) in f.iter_mut().zip(&fs) {
                *a += b;
            }
        }
        Ok(f)
    }
}

/// A single Krylov solve of `A U = F` (`fixed`: nothing is recovered).
fn solve_once(
    fixed: &[f64],
    solver: &mut dyn LinearSolver,
    opts: &FixedPointOptions,
    report: &mut FixedPointReport,
    progress: &dyn Progress,
) -> Result<Vec<f64>> {
    if solver.stop(progress.should_stop()) {
        return Err(Error::Interrupted { iterations: 0 });
    }
    let mut u = vec![0.0; fixed.len()];
    let t = std::time::Instant::now();
    let stats = solver.solve(fixed, &mut u, &opts.krylov)?;
    report.krylov_seconds = t.elapsed().as_secs_f64();
    progress.event(&Event::KrylovSolve {
        index: 0,
        iterations: stats.iterations,
        relative_residual: stats.true_relative_residual,
    });
    report.iterations_per_solve.push(stats.iterations);
    report.total_iterations = stats.iterations;
    report.tolerances.push(opts.krylov.rel_tol);
    report.final_relative_residual = stats.true_relative_residual;
    report.converged = true;
    Ok(u)
}
