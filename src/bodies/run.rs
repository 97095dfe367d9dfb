//! The multi-body run: set-up, the load steps (each converged step's
//! ParaView files written as it converges, so that a failed or interrupted
//! run keeps the last converged step, as many of them as its
//! [`ParaView`] selects), and the report.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use super::multigrid::BodiesMultigrid;
use super::output::Series;
use super::setup::BodiesSetup;
use crate::case::Case;
use crate::driver::output::ParaView;
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::hyper::convergence::convergence_order;
use crate::hyper::newton::{
    solve_load_steps_with, CpuTangentSolver, HyperSolution, NonlinearProblem, StepReport,
};
use crate::multigrid::MultigridOptions;
use crate::progress::Progress;
use crate::report::newton::{LoadReport, LoadStepRow, NewtonHistory, ReactionRow};
use crate::report::{BodyReport, Report};
use crate::solver::Preconditioner;

/// What a run produced: the set-up, the last converged state, the report
/// (status filled in), how the solve ended, and the files written (names in
/// the output folder, in order; `solution.pvd` last when any).
pub struct RunOutcome {
    pub setup: BodiesSetup,
    pub solution: HyperSolution,
    pub report: Report,
    pub result: Result<()>,
    pub files: Vec<String>,
}

/// Runs `case` (every body at `level` when given), writing the series into
/// `dir` when given (created after a successful set-up). A set-up error is
/// returned as such; a solve error is in [`RunOutcome::result`].
pub fn run(
    case: &Case,
    level: Option<u32>,
    dir: Option<&Path>,
    progress: &dyn Progress,
) -> Result<RunOutcome> {
    run_on(case, level, dir, None, progress)
}

/// [`run`] with the bodies' inside-cell tangents on `device` when given
/// ([`crate::bodies::problem::BodiesProblem::use_device`]).
pub fn run_on(
    case: &Case,
    level: Option<u32>,
    dir: Option<&Path>,
    device: Option<Arc<GpuContext>>,
    progress: &dyn Progress,
) -> Result<RunOutcome> {
    let paraview = ParaView::default();
    run_writing(case, level, dir, paraview, device, progress)
}

/// [`run_on`] writing the files of `paraview` into `dir`.
pub fn run_writing(
    case: &Case,
    level: Option<u32>,
    dir: Option<&Path>,
    paraview: ParaView,
    device: Option<Arc<GpuContext>>,
    progress: &dyn Progress,
) -> Result<RunOutcome> {
    let t = Instant::now();
    let mut setup = BodiesSetup::new(case, level, progress)?;
    if let Some(ctx) = device {
        setup.problem.use_device(ctx)?;
    }
    let setup_seconds = t.elapsed().as_secs_f64();
    let mut outcome = run_setup_writing(case, setup, dir, paraview, progress)?;
    outcome
        .report
        .timings
        .insert("setup".to_string(), setup_seconds);
    Ok(outcome)
}

/// Runs a set-up case (with whatever coupling its problem carries): the load
/// steps, each converged one written into `dir` (created here) and told to the
/// coupling, whose rows form the report's `contact`.
pub fn run_setup(
    case: &Case,
    setup: BodiesSetup,
    dir: Option<&Path>,
    progress: &dyn Progress,
) -> Result<RunOutcome> {
    run_setup_writing(case, setup, dir, ParaView::default(), progress)
}

/// [`run_setup`] writing the files of `paraview` into `dir`.
pub fn run_setup_writing(
    case: &Case,
    setup: BodiesSetup,
    dir: Option<&Path>,
    paraview: ParaView,
    progress: &dyn Progress,
) -> Result<RunOutcome> {
    if let Some(dir) = dir {
        std::fs::create_dir_all(dir).map_err(|e| Error::Io {
            path: dir.display().to_string(),
            reason: e.to_string(),
        })?;
    }
    let multigrid = match setup.newton.krylov.preconditioner {
        Preconditioner::Multigrid | Preconditioner::Auto => Some(BodiesMultigrid::new(
            case,
            &setup,
            &MultigridOptions::default(),
        )?),
        _ => None,
    };
    let t = Instant::now();
    let mut solution = HyperSolution::zero(&setup.problem);
    let mut series = Series::new(paraview);
    let mut contact = Vec::new();
    let mut reactions = Vec::new();
    let problem = &setup.problem;
    let mut converged = |s: &HyperSolution| {
        let points = problem.contact_points(&s.u);
        contact.extend(problem.step_converged(&s.u, s.converged_steps));
        reactions.extend(reaction_rows(&setup, s));
        match dir {
            Some(dir) => {
                let nb = problem.bodies.len();
                let parts: Vec<&[f64]> = (0..nb).map(|b| problem.part(b, &s.u)).collect();
                let (bodies, problems) = (&setup.bodies, &problem.bodies);
                let (step, t) = (s.converged_steps, s.load_factor);
                series.write_step(dir, bodies, problems, &parts, step, t)?;
                series.write_contact(dir, &points, nb, step, t)?;
                let first = nb + points.len();
                series.write_surfaces(dir, bodies, problems, &parts, first, step, t)
            }
            None => Ok(()),
        }
    };
    let preconditioner = multigrid.as_ref().map(|mg| mg.preconditioner(&setup));
    let mut solver = match &preconditioner {
        Some(pre) => CpuTangentSolver::with_multigrid(pre),
        None => CpuTangentSolver::default(),
    };
    let result = solve_load_steps_with(
        problem,
        &setup.newton,
        &mut solver,
        progress,
        &mut solution,
        &mut converged,
    );
    // The preconditioner borrows `setup`, which the outcome takes below.
    drop(preconditioner);
    let mut timings = BTreeMap::new();
    if let Some(mg) = &multigrid {
        timings.insert("multigrid".to_string(), mg.seconds);
    }
    timings.insert("solve".to_string(), t.elapsed().as_secs_f64());
    let mut report = report(case, &setup, &solution, &result, timings);
    report.contact = contact;
    report.reactions = reactions;
    Ok(RunOutcome {
        setup,
        solution,
        report,
        result,
        files: series.files(),
    })
}

/// The Dirichlet reactions of every body at the converged `s`.
fn reaction_rows(setup: &BodiesSetup, s: &HyperSolution) -> Vec<ReactionRow> {
    let problem = &setup.problem;
    let mut rows = Vec::new();
    for (b, (body, p)) in setup.bodies.iter().zip(&problem.bodies).enumerate() {
        for (tag, force) in p.dirichlet_reactions(problem.part(b, &s.u), s.load_factor) {
            rows.push(ReactionRow {
                body: body.name.clone(),
                part: body.solid.tag_name(tag).to_string(),
                step: s.converged_steps,
                force,
            });
        }
    }
    rows
}

/// The report of a run that ended with `result`.
fn report(
    case: &Case,
    setup: &BodiesSetup,
    solution: &HyperSolution,
    result: &Result<()>,
    timings: BTreeMap<String, f64>,
) -> Report {
    let mut report = Report::new(case);
    for (b, c) in setup.bodies.iter().zip(&case.bodies) {
        report.push_body(BodyReport::new(
            &b.name,
            c.model,
            c.spec.element,
            &b.solid,
            &b.grid,
            &b.cells,
            c.spec.plane_strain,
        ));
    }
    if let Err(e) = result {
        report.fail(e);
    }
    if let Some(name) = setup.problem.device_name() {
        report.backend = "gpu".into();
        report.adapter = Some(name.to_string());
    }
    report.dofs = setup.problem.ndofs();
    report.held_dofs = setup.problem.num_held();
    report.load = Some(LoadReport {
        steps: setup.newton.steps,
        converged_steps: solution.converged_steps,
        load_factor: solution.load_factor,
        load_steps: load_step_rows(&solution.attempts),
    });
    report.timings = timings;
    report
}

/// One row per attempt, numbered by the step it tried to reach.
pub fn load_step_rows(attempts: &[StepReport]) -> Vec<LoadStepRow> {
    let mut converged = 0;
    attempts
        .iter()
        .map(|a| {
            // The first Newton pass solves the step; later passes (recovered
            // terms) start near its solution and are too short to tell.
            let first = a.passes.first().map_or(a.energies.len(), |p| {
                (p.newton_iterations + 1).min(a.energies.len())
            });
            let order = convergence_order(&a.energies[..first]);
            let row = LoadStepRow {
                step: converged + 1,
                load_factor: a.to,
                converged: a.converged,
                cuts: a.cuts,
                newton: NewtonHistory {
                    iterations: a.alphas.len(),
                    residual_history: a.residuals.clone(),
                    energy_history: a.energies.clone(),
                    line_search: a.alphas.clone(),
                    convergence_order: order.map(|(q, _)| q),
                    quadratic_constant: order.map(|(_, c)| c),
                },
                krylov_iterations: a.krylov_iterations.clone(),
                passes: a.passes.clone(),
                failure: a.failure.clone(),
            };
            converged += a.converged as usize;
            row
        })
        .collect()
}
