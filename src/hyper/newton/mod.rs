//! The nonlinear solve: load stepping, Newton–Raphson with a backtracking line
//! search, and automatic cutting of a failed step.
//!
//! # Load steps
//! The load factor `t` runs from 0 to 1 in `steps` equal increments; it scales
//! the prescribed displacements `g` and the dead loads `f_ext` together
//! (see [`super::residual`]). Each step starts from the last converged `u`.
//!
//! # Newton–Raphson
//! At iteration `k`: solve `K_T(u_k) Δu = −R(u_k)` with the Krylov method of the
//! options (through [`TangentSolver`], so that any backend can run it), then
//! backtrack `α = 1, 1/2, 1/4, …` until `‖R(u_k + α Δu)‖ ≤ (1 − 10⁻⁴ α) ‖R(u_k)‖`
//! (Armijo on the residual norm; a trial with `det F ≤ 0` somewhere, or a
//! non-finite residual, counts as a failed trial). Where no trial passes,
//! Newton takes the trial with the smallest residual anyway, as long as it
//! is not above the step's starting residual, up to 3 times per solve (a
//! non-monotone step): contact's active set and master patches make `R`
//! only piecewise smooth, and at a kink the Newton direction need not
//! decrease `‖R‖` although the next iterate converges. The step has converged at
//! `u_k` when both
//! ```text
//! ‖R(u_k)‖ ≤ residual_tol · ‖R(u_0)‖      and      |Δu_k · R(u_k)| ≤ energy_tol · |Δu_0 · R(u_0)|
//! ```
//! hold (`u_0`: the last converged displacement at the new load factor;
//! a step whose `‖R(u_0)‖` is at round-off, 1e-13 of the largest starting
//! residual so far, is converged as it stands: a load path holding still):
//! the residual is small and so is the energy of the correction Newton would
//! still make. That costs one linear solve at the converged state, but the two
//! tests then look at the same state, and a residual already at round-off
//! never has to pass the line search again (it could not decrease further).
//!
//! # Inexact solves
//! With [`Forcing::Adaptive`](crate::case::physics::Forcing::Adaptive) (the
//! default) the linear solve at `u_k` is converged to
//! `η_k = ‖R(u_k)‖/‖R(u_0)‖` relative, within `[krylov.rel_tol, 10⁻⁴]`
//! ([`NewtonOptions::krylov_tol`]). The residual after the update is then
//! `O(‖R_k‖²)` as with an exact solve (an inexact Newton method whose forcing
//! term is proportional to the residual), so the rate stays quadratic while
//! the first iterations of a step cost a few Krylov iterations instead of a
//! full solve. The solve at a state whose residual already passes
//! `residual_tol` first only feeds the energy test (`Δu` to a few digits is
//! enough), so it is converged to 10⁻²; where the test fails, it goes on
//! from that `Δu` to the update's tolerance before the update.
//! [`Forcing::Fixed`](crate::case::physics::Forcing::Fixed) converges every
//! solve to `krylov.rel_tol`.
//!
//! # Recovered terms
//! A problem may carry terms recovered from the solution (by SPR) that `R`
//! holds fixed and `K_T` does not differentiate: the recovered normal
//! traction `T̂_N` of contact and the recovered displacement of the S-term.
//! They make each step a fixed point around Newton, as the linear path's fixed point is: at
//! the start of an attempt they are evaluated at the last converged `u`;
//! Newton converges (pass 0); then, pass after pass, they are re-evaluated at
//! the pass's solution `u_k` and Newton runs again from there, until
//! ```text
//! ε_k = ‖u_k − u_{k−1}‖ / ‖u_k‖ < fixed_point_tol
//! ```
//! (`u_{−1}`: the start of the step). Every pass is held to the tolerances
//! relative to the first pass's `‖R(u_0)‖` and `|Δu_0 · R(u_0)|`, and the
//! history is relative to them too. More than
//! `max_fixed_point` passes fail the attempt like a Newton failure. Each pass
//! is a whole Newton solve, so its last iterations keep Newton's quadratic
//! rate; the step's report concatenates the passes' histories (a pass's
//! residuals start where the refreshed terms put it) and lists each pass in
//! `passes`.
//!
//! With [`RecoveryMode::Step`] they are evaluated once, at the start of the
//! attempt, and held for its one Newton solve (they lag one load step).
//! With [`RecoveryMode::Embedded`] the terms are instead re-evaluated after
//! every Newton update (and the residual with them), in one Newton loop: the
//! step converges when the residual with terms recovered at the same `u` is
//! small, i.e. at the fixed point. One pass is reported, its `change` the
//! relative change of `u` over the step.
//!
//! # Problems
//! The solve only sees a [`NonlinearProblem`]: `R(u, t)` and the tangent at
//! `u` as a [`LinearOperator`]. [`HyperProblem`] (one body) implements it, and
//! so does the multi-body problem of [`crate::bodies`] (the bodies' dofs
//! stacked, plus a coupling term such as contact).
//!
//! # Step cutting
//! A step fails when Newton runs out of iterations, the line search finds no
//! decrease (after the non-monotone steps are spent), or the Krylov solve
//! fails. The displacement is then reset to the
//! last converged one and the increment halved. The cut increment is kept
//! until the load has passed the point that failed; after that, each
//! converged step doubles it again (up to the nominal one). (Doubling sooner
//! would aim every success short of the failed point at it again, spending
//! the cuts on near-identical attempts.) More than `max_cuts` halvings of one
//! increment end the solve with
//! [`Error::LoadStepFailed`], which names the last converged step; the
//! [`HyperSolution`] passed in then holds that step's displacement.

use std::cell::Cell;

mod history;
mod line_search;
mod options;
mod tangent_solver;

pub use history::{HyperSolution, PassReport, StepReport};
use line_search::{line_search, NON_MONOTONE_STEPS};
pub use options::NewtonOptions;

use crate::case::physics::RecoveryMode;
pub use tangent_solver::{CpuTangentSolver, TangentSolver};

use super::problem::HyperProblem;
use super::residual::residual;
use super::tangent::TangentOperator;
use crate::backend::LinearOperator;
use crate::error::{Error, Result};
use crate::progress::{Event, Progress};
use crate::solver::{KrylovOptions, KrylovStats};

/// A nonlinear problem for [`solve_load_steps`]: the residual `R(u, t)` at
/// load factor `t` and its tangent `∂R/∂u`.
pub trait NonlinearProblem {
    /// Number of unknowns.
    fn ndofs(&self) -> usize;
    /// `R(u, t)`, or `None` where `u` is inadmissible (some `det F ≤ 0`).
    fn residual(&self, u: &[f64], t: f64) -> Option<Vec<f64>>;
    /// `K_T(u, t)`, or `None` where `u` is inadmissible.
    fn tangent<'a>(&'a self, u: &[f64], t: f64) -> Option<Box<dyn LinearOperator + 'a>>;
    /// Re-evaluates at `u` (load factor `t`) the terms recovered from the
    /// solution and held fixed in `R` and `K_T` (the contact's recovered
    /// normal traction, the S-term's recovered displacement); `false` when
    /// the problem has none, so one Newton solve per step is enough (see
    /// the module doc, *Recovered terms*). An error ends the solve.
    fn refresh_recovered(&self, _u: &[f64], _t: f64) -> Result<bool> {
        Ok(false)
    }
}

impl NonlinearProblem for HyperProblem {
    fn ndofs(&self) -> usize {
        HyperProblem::ndofs(self)
    }

    fn residual(&self, u: &[f64], t: f64) -> Option<Vec<f64>> {
        residual(self, u, t)
    }

    fn tangent<'a>(&'a self, u: &[f64], _t: f64) -> Option<Box<dyn LinearOperator + 'a>> {
        TangentOperator::new(self, u).map(|k| Box::new(k) as Box<dyn LinearOperator + 'a>)
    }

    fn refresh_recovered(&self, u: &[f64], _t: f64) -> Result<bool> {
        self.refresh_s_term(u)
    }
}

/// Runs the load steps from `solution` (usually [`HyperSolution::zero`]) to load
/// factor 1. On failure `solution` holds the last converged step.
pub fn solve_load_steps(
    problem: &dyn NonlinearProblem,
    opts: &NewtonOptions,
    solver: &mut dyn TangentSolver,
    progress: &dyn Progress,
    solution: &mut HyperSolution,
) -> Result<()> {
    solve_load_steps_with(problem, opts, solver, progress, solution, &mut |_| Ok(()))
}

/// [`solve_load_steps`], calling `on_converged` with the solution after each
/// converged step (to write that step's outputs); an error it returns ends
/// the solve.
pub fn solve_load_steps_with(
    problem: &dyn NonlinearProblem,
    opts: &NewtonOptions,
    solver: &mut dyn TangentSolver,
    progress: &dyn Progress,
    solution: &mut HyperSolution,
    on_converged: &mut dyn FnMut(&HyperSolution) -> Result<()>,
) -> Result<()> {
    opts.validate()?;
    let nominal = 1.0 / opts.steps as f64;
    let mut increment = nominal;
    let mut cuts = 0;
    // The load of the last failed attempt, until a converged step passes it.
    let mut failed_at: Option<f64> = None;
    let mut solves = 0;
    let scale = Cell::new(0.0);
    while solution.load_factor < 1.0 {
        let from = solution.load_factor;
        // The last increment lands exactly on 1.
        let to = if from + increment > 1.0 - 1e-12 {
            1.0
        } else {
            from + increment
        };
        let mut report = StepReport {
            from,
            to,
            cuts,
            ..StepReport::default()
        };
        let mut u = solution.u.clone();
        let ctx = Context {
            problem,
            opts,
            progress,
            step: solution.converged_steps + 1,
            refresh_each: None,
            scale: &scale,
        };
        let outcome = recovered_step(&ctx, to, &mut u, solver, &mut report, &mut solves);
        if !matches!(outcome, Err(StepFailure::Interrupted(_))) {
            progress.event(&Event::LoadStep {
                step: solution.converged_steps + 1,
                steps: opts.steps,
                load_factor: to,
                cuts,
                newton_iterations: report.alphas.len(),
                converged: outcome.is_ok(),
            });
        }
        match outcome {
            Ok(()) => {
                report.converged = true;
                solution.u = u;
                solution.load_factor = to;
                solution.converged_steps += 1;
                solution.attempts.push(report);
                on_converged(solution)?;
                let short_of_failure = failed_at.is_some_and(|f| to < f - 1e-12);
                if !short_of_failure {
                    failed_at = None;
                    if cuts > 0 {
                        cuts -= 1;
                        increment *= 2.0;
                    }
                }
            }
            Err(StepFailure::Interrupted(iterations)) => {
                solution.attempts.push(report);
                return Err(Error::Interrupted { iterations });
            }
            Err(StepFailure::Diverged(reason)) => {
                report.failure = Some(reason.clone());
                solution.attempts.push(report);
                failed_at = Some(to);
                if cuts == opts.max_cuts {
                    return Err(Error::LoadStepFailed {
                        step: solution.converged_steps + 1,
                        load_factor: to,
                        cuts,
                        reason,
                        last_converged_step: solution.converged_steps,
                        last_converged_load: from,
                    });
                }
                cuts += 1;
                increment *= 0.5;
            }
        }
    }
    Ok(())
}

enum StepFailure {
    /// Recoverable by a smaller increment.
    Diverged(String),
    /// Stopped by the observer after this many Newton iterations.
    Interrupted(usize),
}

#[derive(Clone, Copy)]
struct Context<'a> {
    problem: &'a dyn NonlinearProblem,
    opts: &'a NewtonOptions,
    progress: &'a dyn Progress,
    /// The load step being attempted (from 1).
    step: usize,
    /// Embedded recovery: re-evaluates the recovered terms after each update.
    refresh_each: Option<&'a Refresh<'a>>,
    /// The largest starting residual `‖R(u_0)‖` of the solve so far.
    scale: &'a Cell<f64>,
}

/// A step whose starting residual is at most this times the largest one of
/// the solve so far has nothing left to solve (a load path holding still):
/// round-off cannot be decreased further.
const STILL: f64 = 1e-13;

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// One attempt at load factor `t` from `u`: Newton, in fixed-point passes
/// when the problem has recovered terms (module doc); fills `report`.
fn recovered_step(
    ctx: &Context<'_>,
    t: f64,
    u: &mut [f64],
    solver: &mut dyn TangentSolver,
    report: &mut StepReport,
    solves: &mut usize,
) -> std::result::Result<(), StepFailure> {
    let refresh = |u: &[f64]| {
        ctx.problem
            .refresh_recovered(u, t)
            .map_err(|e| StepFailure::Diverged(format!("recovery: {e}")))
    };
    let recovered = refresh(u)?;
    let mut previous = u.to_vec();
    let mut refs = References::default();
    if recovered && ctx.opts.recovery != RecoveryMode::Passes {
        // One Newton loop: the terms held from the start (step), or
        // refreshed after every update (embedded).
        let each = |u: &[f64]| refresh(u).map(|_| ());
        let inner = Context {
            refresh_each: (ctx.opts.recovery == RecoveryMode::Embedded).then_some(&each as _),
            ..*ctx
        };
        let outcome = newton_step(&inner, t, u, solver, report, solves, &mut refs);
        report.passes.push(PassReport {
            newton_iterations: report.alphas.len(),
            krylov_iterations: report.krylov_iterations.iter().sum(),
            change: Some(relative_change(u, &previous)),
        });
        return outcome;
    }
    for _ in 0..ctx.opts.max_fixed_point {
        let (alphas, krylov) = (report.alphas.len(), report.krylov_iterations.len());
        let outcome = newton_step(ctx, t, u, solver, report, solves, &mut refs);
        let change = recovered.then(|| relative_change(u, &previous));
        report.passes.push(PassReport {
            newton_iterations: report.alphas.len() - alphas,
            krylov_iterations: report.krylov_iterations[krylov..].iter().sum(),
            change,
        });
        outcome?;
        match change {
            None => return Ok(()),
            Some(eps) if eps < ctx.opts.fixed_point_tol => return Ok(()),
            Some(_) => {}
        }
        previous.copy_from_slice(u);
        refresh(u)?;
    }
    Err(StepFailure::Diverged(format!(
        "the recovered terms did not settle in {} passes (ε = {:.3e})",
        ctx.opts.max_fixed_point,
        report
            .passes
            .last()
            .and_then(|p| p.change)
            .unwrap_or(f64::NAN)
    )))
}

/// `‖u − v‖ / ‖u‖` (0 where both vanish).
fn relative_change(u: &[f64], v: &[f64]) -> f64 {
    let d: f64 = u.iter().zip(v).map(|(a, b)| (a - b) * (a - b)).sum();
    let n = norm(u);
    if n > 0.0 {
        d.sqrt() / n
    } else {
        d.sqrt()
    }
}

/// The norms a step's tolerances are relative to: `‖R(u_0)‖` and
/// `|Δu_0 · R(u_0)|` of the step's first pass.
#[derive(Clone, Copy, Debug, Default)]
struct References {
    residual: Option<f64>,
    energy: Option<f64>,
}

/// Re-evaluates the recovered terms at a `u` (embedded recovery).
type Refresh<'a> = dyn Fn(&[f64]) -> std::result::Result<(), StepFailure> + 'a;

/// One Newton iteration's linear system `K_T Δu = −R`.
struct LinearSolve<'a> {
    ctx: &'a Context<'a>,
    tangent: &'a dyn LinearOperator,
    rhs: &'a [f64],
}

impl LinearSolve<'_> {
    /// Solves to `rel_tol` from `du`, reporting the solve as progress; a
    /// failed solve's iterations are spent too, so they are counted.
    fn solve(
        &self,
        solver: &mut dyn TangentSolver,
        du: &mut Vec<f64>,
        rel_tol: f64,
        solves: &mut usize,
        report: &mut StepReport,
    ) -> std::result::Result<KrylovStats, StepFailure> {
        let krylov = KrylovOptions {
            rel_tol,
            ..self.ctx.opts.krylov.clone()
        };
        let stats = match solver.solve(self.tangent, self.rhs, du, &krylov) {
            Ok(stats) => stats,
            Err(e) => {
                if let Error::MaxIterations { iterations, .. }
                | Error::Breakdown { iterations, .. } = &e
                {
                    report.krylov_iterations.push(*iterations);
                }
                return Err(StepFailure::Diverged(format!("linear solve: {e}")));
            }
        };
        self.ctx.progress.event(&Event::KrylovSolve {
            index: *solves,
            iterations: stats.iterations,
            relative_residual: stats.true_relative_residual,
        });
        *solves += 1;
        Ok(stats)
    }
}

/// Newton iterations at load factor `t` from `u`; fills `report`. With
/// `ctx.refresh_each`, the recovered terms (and the residual) are re-evaluated
/// after every update. The
/// tolerances (and the history) are relative to `refs`, set by the first
/// pass of the step, so later passes (which start near convergence) are
/// held to the same absolute accuracy.
fn newton_step(
    ctx: &Context<'_>,
    t: f64,
    u: &mut [f64],
    solver: &mut dyn TangentSolver,
    report: &mut StepReport,
    solves: &mut usize,
    refs: &mut References,
) -> std::result::Result<(), StepFailure> {
    let (p, opts) = (ctx.problem, ctx.opts);
    let diverged = |s: &str| StepFailure::Diverged(s.to_string());
    let mut r = p
        .residual(u, t)
        .ok_or_else(|| diverged("an element is inverted at the start"))?;
    let r0 = *refs.residual.get_or_insert(norm(&r));
    ctx.scale.set(ctx.scale.get().max(r0));
    if r0 <= STILL * ctx.scale.get() {
        report.residuals.push(1.0);
        return Ok(());
    }
    report.residuals.push(norm(&r) / r0);
    let mut non_monotone_left = NON_MONOTONE_STEPS;
    for k in 0..opts.max_iterations {
        if ctx.progress.should_stop() {
            return Err(StepFailure::Interrupted(k));
        }
        ctx.progress.event(&Event::NewtonIteration {
            step: ctx.step,
            steps: opts.steps,
            load_factor: t,
            iteration: k,
            relative_residual: report.residuals.last().copied().unwrap_or(1.0),
        });
        let tangent = p
            .tangent(u, t)
            .ok_or_else(|| diverged("an element is inverted at the linearisation point"))?;
        let rhs: Vec<f64> = r.iter().map(|v| -v).collect();
        let mut du = vec![0.0; u.len()];
        let relative = report.residuals.last().copied().unwrap_or(1.0);
        let update_tol = opts.krylov_tol(relative);
        let first_tol = opts.check_tol(relative).unwrap_or(update_tol);
        let linear = LinearSolve {
            ctx,
            tangent: tangent.as_ref(),
            rhs: &rhs,
        };
        let stats = linear.solve(solver, &mut du, first_tol, solves, report)?;
        report.krylov_iterations.push(stats.iterations);
        let energy = dot(&du, &r).abs();
        let e_ref = *refs.energy.get_or_insert(energy);
        let rel_energy = if e_ref > 0.0 { energy / e_ref } else { 0.0 };
        report.energies.push(rel_energy);
        if report
            .residuals
            .last()
            .is_some_and(|&rel| rel <= opts.residual_tol)
            && rel_energy <= opts.energy_tol
        {
            return Ok(());
        }
        if first_tol > update_tol {
            // That solve only checked the energy: on from its Δu to the
            // tolerance of an update.
            let more = linear.solve(solver, &mut du, update_tol, solves, report)?;
            if let Some(last) = report.krylov_iterations.last_mut() {
                *last += more.iterations;
            }
        }
        let backtracks = opts.line_search.then_some(opts.max_backtracks);
        let trial = line_search(p, t, u, &du, &r, backtracks)
            .ok_or_else(|| diverged("every trial of the line search inverts an element"))?;
        if !trial.decreased {
            if non_monotone_left == 0 || norm(&trial.residual) > r0 {
                return Err(diverged(
                    "the line search found no decrease of the residual",
                ));
            }
            non_monotone_left -= 1;
        }
        let (alpha, r_new) = (trial.alpha, trial.residual);
        for (x, d) in u.iter_mut().zip(&du) {
            *x += alpha * d;
        }
        r = match ctx.refresh_each {
            Some(refresh) => {
                refresh(u)?;
                p.residual(u, t)
                    .ok_or_else(|| diverged("an element is inverted after the update"))?
            }
            None => r_new,
        };
        report.residuals.push(norm(&r) / r0);
        report.alphas.push(alpha);
    }
    Err(StepFailure::Diverged(format!(
        "no convergence in {} Newton iterations (relative residual {:.3e})",
        opts.max_iterations,
        report.residuals.last().copied().unwrap_or(f64::NAN)
    )))
}
