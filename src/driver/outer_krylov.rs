//! The recovered terms solved for by a Krylov method instead of the paper's
//! fixed point (`[solver] outer = "fgmres"`, the default).
//!
//! # The system
//! The paper's loop ([`super::fixed_point`]) solves `A U = F + R(U)`, where
//! `R(U)` is the recovered right-hand side: the SPR traction of the
//! Dirichlet points with its flux correction and, with the S-term, `F_S(U)`.
//! `R` is *affine* in `U`: least-squares fits of `σ(U)` and `U`, linear, but
//! the S-term's fits carry the equilibrium constraints `∇·σ(û) + b = 0` and
//! `σ(û) n = t`, whose data make `R(0) ≠ 0` (checked in the tests). With
//! `R(U) = B U + R(0)` the converged answer solves
//!
//! ```text
//! M U = F + R(0),    M = A − B,    B U = R(U) − R(0)
//! ```
//!
//! and the paper's loop is Richardson's iteration on it preconditioned with
//! `A⁻¹`: `U_{k+1} = U_k + A⁻¹ (F + R(0) − M U_k)`. It contracts like the
//! spectral radius of `A⁻¹B`: a factor 0.02–0.05 per iteration on the Q1 sphere, 0.2 on
//! Q2, 0.4 on the torus and 0.85–0.96 on rotated thin parts with the S-term.
//! Every iteration solves with `A` to a tightening tolerance, so a run costs
//! 6–20 solves.
//!
//! # The method
//! Flexible GMRES ([`crate::solver::fgmres`]) on `M U = F + R(0)`, right-preconditioned by an inner
//! Krylov solve of `A z = v` to the loose relative tolerance `inner_rel_tol`
//! (the case's method and preconditioner, from `z = 0`). Flexible, because the
//! inexact inner solve is a different operator each time; GMRES, because it
//! minimises the true residual `‖F + R(0) − M U‖` over the directions found,
//! so the slow modes of `A⁻¹B` that make the plain loop crawl are removed together
//! rather than one contraction at a time. Each outer iteration costs one inner
//! solve, one product with `A` (on the host operator) and one recovery — as
//! many recoveries as the paper's loop per iteration (and one for `R(0)`),
//! and inner solves that reduce their residual by `inner_rel_tol` instead of
//! 1e-8.
//!
//! It stops when `‖F + R(U) − A U‖ ≤ fixed_point_tol · ‖F + R(0)‖` (the
//! residual of the whole system, not the change of `U` as in the paper's
//! loop), and that residual is the true one: when a cycle's estimate reaches
//! the tolerance, the residual of its `U` is computed afresh and, if it is
//! not there, the next cycle starts from it (iterative refinement). The
//! estimate is the true residual in exact arithmetic only: on a rotated
//! thin plate (the STL plate with holes at level 5, `tests/suite/fem/patch_exact.rs`)
//! the coefficients of the 43 directions cancel, the round-off of each
//! `M z_j` adds up, and a cycle whose estimate was 2.7e-15 left a true
//! residual of 2.5e-11 and an energy error of 2.5e-8.
//!
//! The Arnoldi basis is restarted after [`restart_length`] directions, at
//! least [`MIN_RESTART`] and as many as fit in [`BASIS_BYTES`], so the
//! memory is `2 (length + 1)` vectors, allocated as the directions come.
//! 20 and not 10: on rotated coarse brackets (`tests/suite/runs/robustness_runs.rs`,
//! 16 placements of seed 20261123) a cycle of 10 took 40–80 outer
//! iterations, one of 20 took 20–41. Longer where memory allows: on the
//! rotated thin plate a cycle of 20 crawled (500 outer iterations to a
//! residual of 8e-12), one of 300 needed 43 directions.

use super::fixed_point::{recorded_recovery, recorded_solve, FixedPointOptions, FixedPointReport};
use super::linear::LinearSolver;
use crate::backend::LinearOperator;
use crate::error::{Error, Result};
use crate::progress::{Event, Progress};
use crate::solver::fgmres::{fgmres, FgmresOptions, FlexibleSystem};

/// Directions kept before the outer iteration restarts, whatever the size.
pub const MIN_RESTART: usize = 20;

/// Directions kept at most, where memory allows.
pub const MAX_RESTART: usize = 200;

/// Memory the basis may take before the cycle restarts (1 GiB).
pub const BASIS_BYTES: usize = 1 << 30;

/// Directions a cycle keeps for `n` unknowns: as many of the two vectors
/// per direction (`v_j`, `z_j`) as fit in [`BASIS_BYTES`], within
/// [`MIN_RESTART`]..=[`MAX_RESTART`] (200 up to 335 k unknowns, 20 from
/// 3.4 M: the Q1 sphere at level 7).
pub fn restart_length(n: usize) -> usize {
    (BASIS_BYTES / (2 * 8 * n.max(1))).clamp(MIN_RESTART, MAX_RESTART)
}

/// The outer FGMRES (module doc). `op` is `A` on the host (for `M z`);
/// `solver` solves with `A`; `recovered(U)` returns `R(U)`; `fixed` is `F`.
/// The report counts outer iterations in `iterations`, the relative outer
/// residual per iteration in `eps_history`, and each inner solve.
pub fn fgmres_fixed_point(
    solver: &mut dyn LinearSolver,
    op: &dyn LinearOperator,
    fixed: &[f64],
    recovered: &mut dyn FnMut(&[f64]) -> Result<Vec<f64>>,
    opts: &FixedPointOptions,
    report: &mut FixedPointReport,
    progress: &dyn Progress,
) -> Result<Vec<f64>> {
    let start = report.iterations;
    Outer {
        solver,
        op,
        recovered,
        constant: Vec::new(),
        opts,
        report,
        progress,
        start,
    }
    .solve(fixed, restart_length(fixed.len()))
}

/// The system the outer FGMRES solves: `M = A − B` applied with one host
/// product and one recovery, preconditioned by an inner solve with `A`.
struct Outer<'a, 'b> {
    solver: &'a mut dyn LinearSolver,
    op: &'a dyn LinearOperator,
    recovered: &'a mut dyn FnMut(&[f64]) -> Result<Vec<f64>>,
    /// `R(0)`.
    constant: Vec<f64>,
    opts: &'a FixedPointOptions,
    report: &'a mut FixedPointReport,
    progress: &'b dyn Progress,
    /// The report's iterations before this solve.
    start: usize,
}

impl Outer<'_, '_> {
    /// FGMRES on `M U = F + R(0)` from `U = 0` in cycles of `restart`
    /// directions (module doc).
    fn solve(&mut self, fixed: &[f64], restart: usize) -> Result<Vec<f64>> {
        self.constant = self.recover(&vec![0.0; fixed.len()])?;
        let b: Vec<f64> = fixed
            .iter()
            .zip(&self.constant)
            .map(|(f, c)| f + c)
            .collect();
        let opts = FgmresOptions {
            tol: self.opts.tol,
            max_iterations: self.opts.max_iterations.saturating_sub(self.start),
            restart,
        };
        match fgmres(self, &b, &opts, "fixed point (fgmres)") {
            Ok(o) => {
                if o.iterations > 0 {
                    self.report.final_relative_residual = o.relative_residual;
                }
                self.report.converged = true;
                Ok(o.x)
            }
            Err(e) => {
                if let Error::MaxIterations { residual, .. } = &e {
                    self.report.final_relative_residual = *residual;
                }
                Err(e)
            }
        }
    }

    /// `R(x)`, timed and reported as a recovery.
    fn recover(&mut self, x: &[f64]) -> Result<Vec<f64>> {
        recorded_recovery(self.recovered, x, self.report, self.progress)
    }
}

impl FlexibleSystem for Outer<'_, '_> {
    /// `M x = A x − R(x) + R(0)`: one host product and one recovery.
    fn apply(&mut self, x: &[f64]) -> Result<Vec<f64>> {
        let rec = self.recover(x)?;
        let mut y = vec![0.0; x.len()];
        self.op.apply(x, &mut y);
        for ((a, r), c) in y.iter_mut().zip(&rec).zip(&self.constant) {
            *a -= r - c;
        }
        Ok(y)
    }

    /// `z ≈ A⁻¹ v` to `inner_rel_tol` from `z = 0`, one solve of the report.
    fn precondition(&mut self, v: &[f64]) -> Result<Vec<f64>> {
        let mut krylov = self.opts.krylov.clone();
        krylov.rel_tol = self.opts.inner_rel_tol;
        let mut z = vec![0.0; v.len()];
        recorded_solve(self.solver, v, &mut z, &krylov, self.report, self.progress)?;
        Ok(z)
    }

    fn before_direction(&mut self, _iterations: usize) -> Result<()> {
        if self.solver.stop(self.progress.should_stop()) {
            return Err(Error::Interrupted {
                iterations: self.report.iterations,
            });
        }
        Ok(())
    }

    fn dot(&self, a: &[f64], b: &[f64]) -> f64 {
        self.solver.dot(a, b)
    }

    fn after_direction(&mut self, iterations: usize, eps: f64) {
        self.report.iterations = self.start + iterations;
        self.report.eps_history.push(eps);
        let krylov_iterations = self
            .report
            .iterations_per_solve
            .last()
            .copied()
            .unwrap_or(0);
        tracing::info!(eps, krylov_iterations, "fixed-point iteration (fgmres)");
        self.progress.event(&Event::FixedPoint {
            iteration: self.report.iterations,
            eps,
            krylov_iterations,
        });
    }
}

#[cfg(test)]
#[path = "outer_krylov_tests.rs"]
mod tests;
