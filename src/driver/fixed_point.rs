//! The fixed-point loop of the paper (§2.2). The matrix
//! `A = K + K_p (+ K_S)` is fixed; the recovered terms `F_T(U) (+ F_S(U))`
//! move to the right-hand side:
//!
//! 1. `U_0` solves `A U = F` with `t̂ = 0` (and `S = 0`) to `τ_0`;
//! 2. `U_{k+1}` solves `A U = F + F_rec(U_k)` to `τ_k`, warm-started at `U_k`;
//! 3. `ε_k = ‖U_{k+1} − U_k‖ / ‖U_{k+1}‖`, `τ_{k+1} = max(ε_k τ_k, τ_min)`;
//! 4. stop when `ε_k < Tol`.

use serde::Serialize;

use super::linear::LinearSolver;
use crate::error::{Error, Result};
use crate::plot::{Chart, Series};
use crate::progress::{Event, Phase, Progress, Silent};
use crate::solver::{KrylovOptions, KrylovStats};

/// Settings of the loop.
#[derive(Clone, Debug)]
pub struct FixedPointOptions {
    /// The Krylov method, its preconditioner, `τ_0` and the per-solve budget.
    pub krylov: KrylovOptions,
    /// Floor of the adaptive Krylov tolerance, `τ_min`.
    pub min_rel_tol: f64,
    /// `Tol` on the relative change of `U`.
    pub tol: f64,
    /// Fixed-point iterations allowed (recovery solves, after `U_0`).
    pub max_iterations: usize,
    /// The outer FGMRES's inner tolerance ([`super::outer_krylov`]).
    pub inner_rel_tol: f64,
}

/// What the loop did.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct FixedPointReport {
    /// Fixed-point iterations after the initial solve (the outer FGMRES:
    /// its iterations, one inner solve each).
    pub iterations: usize,
    /// `ε_k` per iteration (the outer FGMRES: the relative residual
    /// `‖F + R(U) − A U‖/‖F‖`).
    pub eps_history: Vec<f64>,
    /// Krylov iterations of each solve (the initial one first).
    pub iterations_per_solve: Vec<usize>,
    /// Their sum: the paper's accumulated iterations.
    pub total_iterations: usize,
    /// Krylov tolerance of each solve.
    pub tolerances: Vec<f64>,
    /// True relative residual `‖F − A U‖/‖F‖` of the last solve.
    pub final_relative_residual: f64,
    /// Did `ε` fall below the tolerance?
    pub converged: bool,
    /// Jacobi diagonal entries floored as cut artefacts (the most over the
    /// solves; the diagonal is the same for all of them).
    pub floored_diagonal_entries: usize,
    /// Seconds spent in the Krylov solves.
    pub krylov_seconds: f64,
    /// Seconds spent computing the recovered right-hand side (and, after the
    /// loop, the recovered tractions of the reactions).
    pub recovery_seconds: f64,
    /// The recoveries those seconds were spent on (the loop's, and the one
    /// of the reactions).
    pub recoveries: usize,
    /// Seconds spent planning the recoveries' patch fits before the loop
    /// ([`super::solve::RecoveredLoad::plan`]): not in `recovery_seconds`.
    pub plan_seconds: f64,
    /// The multigrid V-cycles of the solves and their seconds, where the
    /// solver timed them ([`LinearSolver::v_cycles`]).
    pub v_cycles: Option<(usize, f64)>,
}

impl FixedPointReport {
    /// The loop's timings for a report: `krylov`, `recovery`,
    /// `recovery_plans` (when the fits were planned before the loop),
    /// `recovery_each` (the mean of one recovery) and `v_cycle_each` (the
    /// mean of one V-cycle, where the solver timed them), in seconds.
    pub fn timings(&self) -> Vec<(String, f64)> {
        let mut out = vec![
            ("krylov".to_string(), self.krylov_seconds),
            ("recovery".to_string(), self.recovery_seconds),
        ];
        if self.plan_seconds > 0.0 {
            out.push(("recovery_plans".to_string(), self.plan_seconds));
        }
        if self.recoveries > 0 {
            let each = self.recovery_seconds / self.recoveries as f64;
            out.push(("recovery_each".to_string(), each));
        }
        if let Some((n, seconds)) = self.v_cycles.filter(|&(n, _)| n > 0) {
            out.push(("v_cycle_each".to_string(), seconds / n as f64));
        }
        out
    }
}

/// Runs the loop, solving with `solver` (any backend). `recovered(U)` returns
/// `F_rec(U)`; `fixed` is the rest of the right-hand side. On failure the
/// report so far comes back with the error.
pub fn fixed_point(
    solver: &mut dyn LinearSolver,
    fixed: &[f64],
    recovered: &mut dyn FnMut(&[f64]) -> Result<Vec<f64>>,
    opts: &FixedPointOptions,
    report: &mut FixedPointReport,
) -> Result<Vec<f64>> {
    fixed_point_with_progress(solver, fixed, recovered, opts, report, &Silent)
}

/// [`fixed_point`], reporting each solve and iteration to `progress` and
/// stopping with [`Error::Interrupted`] at the first iteration boundary (before
/// the initial solve, or after any solve) where `progress.should_stop()`
/// (on several ranks: on any rank, [`LinearSolver::stop`]).
pub fn fixed_point_with_progress(
    solver: &mut dyn LinearSolver,
    fixed: &[f64],
    recovered: &mut dyn FnMut(&[f64]) -> Result<Vec<f64>>,
    opts: &FixedPointOptions,
    report: &mut FixedPointReport,
    progress: &dyn Progress,
) -> Result<Vec<f64>> {
    let stop = |solver: &dyn LinearSolver, report: &FixedPointReport| -> Result<()> {
        if solver.stop(progress.should_stop()) {
            tracing::info!(iterations = report.iterations, "interrupted");
            return Err(Error::Interrupted {
                iterations: report.iterations,
            });
        }
        Ok(())
    };
    let mut krylov = opts.krylov.clone();
    let mut run_solve = |solver: &mut dyn LinearSolver,
                         rhs: &[f64],
                         u: &mut Vec<f64>,
                         tol: f64,
                         report: &mut FixedPointReport|
     -> Result<()> {
        krylov.rel_tol = tol;
        recorded_solve(solver, rhs, u, &krylov, report, progress)
    };
    let mut u = vec![0.0; fixed.len()];
    let mut tau = opts.krylov.rel_tol;
    stop(solver, report)?;
    run_solve(solver, fixed, &mut u, tau, report)?;
    for k in 1..=opts.max_iterations {
        stop(solver, report)?;
        let _span = tracing::info_span!("fixed_point", iteration = k).entered();
        let extra = recorded_recovery(recovered, &u, report, progress)?;
        let rhs: Vec<f64> = fixed.iter().zip(&extra).map(|(a, b)| a + b).collect();
        let mut next = u.clone();
        run_solve(solver, &rhs, &mut next, tau, report)?;
        let change: Vec<f64> = next.iter().zip(&u).map(|(a, b)| a - b).collect();
        let diff = solver.dot(&change, &change).sqrt();
        let norm = solver.dot(&next, &next).sqrt();
        let eps = if norm > 0.0 { diff / norm } else { 0.0 };
        report.iterations += 1;
        report.eps_history.push(eps);
        let krylov_iterations = report.iterations_per_solve.last().copied().unwrap_or(0);
        tracing::info!(eps, krylov_iterations, "fixed-point iteration");
        progress.event(&Event::FixedPoint {
            iteration: k,
            eps,
            krylov_iterations,
        });
        u = next;
        if eps < opts.tol {
            report.converged = true;
            return Ok(u);
        }
        tau = (eps * tau).max(opts.min_rel_tol);
    }
    Err(Error::MaxIterations {
        method: "fixed point".into(),
        iterations: report.iterations,
        residual: report.eps_history.last().copied().unwrap_or(f64::NAN),
    })
}

/// Solves `A u = rhs` with `krylov` (warm-started at `u`), timed, announced
/// to `progress` and recorded in `report`: iterations (also those of a solve
/// that failed: what was spent), tolerance, true residual, floored diagonal
/// entries. Both outer loops solve through it.
pub(super) fn recorded_solve(
    solver: &mut dyn LinearSolver,
    rhs: &[f64],
    u: &mut Vec<f64>,
    krylov: &KrylovOptions,
    report: &mut FixedPointReport,
    progress: &dyn Progress,
) -> Result<()> {
    let t = std::time::Instant::now();
    let result = solver.solve(rhs, u, krylov);
    report.krylov_seconds += t.elapsed().as_secs_f64();
    let stats: KrylovStats = match result {
        Ok(stats) => stats,
        Err(e) => {
            if let Error::MaxIterations { iterations, .. } | Error::Breakdown { iterations, .. } =
                &e
            {
                report.iterations_per_solve.push(*iterations);
                report.total_iterations += iterations;
            }
            return Err(e);
        }
    };
    progress.event(&Event::KrylovSolve {
        index: report.iterations_per_solve.len(),
        iterations: stats.iterations,
        relative_residual: stats.true_relative_residual,
    });
    tracing::debug!(
        iterations = stats.iterations,
        residual = stats.true_relative_residual,
        tol = krylov.rel_tol,
        "Krylov solve"
    );
    report.iterations_per_solve.push(stats.iterations);
    report.total_iterations += stats.iterations;
    report.tolerances.push(krylov.rel_tol);
    report.final_relative_residual = stats.true_relative_residual;
    report.floored_diagonal_entries = report
        .floored_diagonal_entries
        .max(stats.floored_diagonal_entries);
    Ok(())
}

/// `recovered(u)`, timed into `report.recovery_seconds` and announced to
/// `progress` as the recovery phase.
pub(super) fn recorded_recovery(
    recovered: &mut dyn FnMut(&[f64]) -> Result<Vec<f64>>,
    u: &[f64],
    report: &mut FixedPointReport,
    progress: &dyn Progress,
) -> Result<Vec<f64>> {
    let t = std::time::Instant::now();
    progress.event(&Event::Start {
        phase: Phase::Recovery,
        total: None,
    });
    let extra = recovered(u);
    progress.event(&Event::Finish {
        phase: Phase::Recovery,
    });
    let extra = extra?;
    report.recovery_seconds += t.elapsed().as_secs_f64();
    report.recoveries += 1;
    Ok(extra)
}

impl FixedPointReport {
    /// The convergence of the loop as a chart (log y): `ε` per fixed-point
    /// iteration and the Krylov iterations of each solve (solve 0 is the
    /// initial one). Zero values, which a log axis cannot show, are left out.
    pub fn residual_chart(&self, title: &str) -> Chart {
        let positive = |p: &(f64, f64)| p.1 > 0.0;
        Chart {
            title: title.into(),
            x_label: "fixed-point iteration (solve)".into(),
            y_label: "ε; Krylov iterations".into(),
            x_log: false,
            series: vec![
                Series {
                    label: "ε = ‖ΔU‖/‖U‖".into(),
                    points: (1..)
                        .zip(&self.eps_history)
                        .map(|(k, &e)| (k as f64, e))
                        .filter(positive)
                        .collect(),
                    reference: false,
                },
                Series {
                    label: "Krylov iterations per solve".into(),
                    points: (0..)
                        .zip(&self.iterations_per_solve)
                        .map(|(k, &n)| (k as f64, n as f64))
                        .filter(positive)
                        .collect(),
                    reference: false,
                },
            ],
        }
    }
}

#[cfg(test)]
#[path = "fixed_point_tests.rs"]
mod tests;
