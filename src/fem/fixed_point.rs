//! The fixed-point loop of the paper (§2.2, DESIGN §3.3). The matrix
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
}

/// What the loop did.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct FixedPointReport {
    /// Fixed-point iterations after the initial solve.
    pub iterations: usize,
    /// `ε_k` per iteration.
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
    /// Seconds spent in the Krylov solves.
    pub krylov_seconds: f64,
    /// Seconds spent computing the recovered right-hand side.
    pub recovery_seconds: f64,
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
    let mut krylov = opts.krylov.clone();
    let mut run_solve =
        |rhs: &[f64], u: &mut Vec<f64>, tol: f64, report: &mut FixedPointReport| -> Result<()> {
            krylov.rel_tol = tol;
            let t = std::time::Instant::now();
            let result = solver.solve(rhs, u, &krylov);
            report.krylov_seconds += t.elapsed().as_secs_f64();
            let stats: KrylovStats = match result {
                Ok(stats) => stats,
                Err(e) => {
                    // The failed solve's iterations count too (what was spent).
                    if let Error::MaxIterations { iterations, .. }
                    | Error::Breakdown { iterations, .. } = &e
                    {
                        report.iterations_per_solve.push(*iterations);
                        report.total_iterations += iterations;
                    }
                    return Err(e);
                }
            };
            report.iterations_per_solve.push(stats.iterations);
            report.total_iterations += stats.iterations;
            report.tolerances.push(tol);
            report.final_relative_residual = stats.true_relative_residual;
            Ok(())
        };
    let mut u = vec![0.0; fixed.len()];
    let mut tau = opts.krylov.rel_tol;
    run_solve(fixed, &mut u, tau, report)?;
    for _ in 0..opts.max_iterations {
        let t = std::time::Instant::now();
        let extra = recovered(&u)?;
        report.recovery_seconds += t.elapsed().as_secs_f64();
        let rhs: Vec<f64> = fixed.iter().zip(&extra).map(|(a, b)| a + b).collect();
        let mut next = u.clone();
        run_solve(&rhs, &mut next, tau, report)?;
        let diff: f64 = next
            .iter()
            .zip(&u)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt();
        let norm: f64 = next.iter().map(|a| a * a).sum::<f64>().sqrt();
        let eps = if norm > 0.0 { diff / norm } else { 0.0 };
        report.iterations += 1;
        report.eps_history.push(eps);
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
