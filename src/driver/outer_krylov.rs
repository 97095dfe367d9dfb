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
//! Flexible GMRES (Saad 1993) on `M U = F + R(0)`, right-preconditioned by an inner
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
    Outer {
        solver,
        op,
        recovered,
        constant: Vec::new(),
        opts,
        report,
        progress,
        restart: restart_length(fixed.len()),
    }
    .solve(fixed)
}

/// The pieces one cycle needs.
struct Outer<'a, 'b> {
    solver: &'a mut dyn LinearSolver,
    op: &'a dyn LinearOperator,
    recovered: &'a mut dyn FnMut(&[f64]) -> Result<Vec<f64>>,
    /// `R(0)`.
    constant: Vec<f64>,
    opts: &'a FixedPointOptions,
    report: &'a mut FixedPointReport,
    progress: &'b dyn Progress,
    /// Directions per cycle.
    restart: usize,
}

impl Outer<'_, '_> {
    /// FGMRES on `M U = F + R(0)` from `U = 0`, in cycles of `self.restart`
    /// directions, each from the true residual; converged when the true
    /// residual is below the tolerance.
    fn solve(&mut self, fixed: &[f64]) -> Result<Vec<f64>> {
        let mut u = vec![0.0; fixed.len()];
        self.constant = self.recover(&u)?;
        let b: Vec<f64> = fixed
            .iter()
            .zip(&self.constant)
            .map(|(f, c)| f + c)
            .collect();
        let b_norm = norm(&b);
        if b_norm == 0.0 {
            self.report.converged = true;
            return Ok(u);
        }
        let target = self.opts.tol * b_norm;
        // r_0 = b (U_0 = 0, and M 0 = 0).
        let mut r = b.clone();
        let mut r_norm = b_norm;
        loop {
            let (du, estimate) = self.cycle(&r, r_norm, target, b_norm)?;
            for (a, d) in u.iter_mut().zip(&du) {
                *a += d;
            }
            // The true residual: where the cycle stopped short, to restart
            // from; where its estimate says converged, to confirm it.
            let mu = self.apply_m(&u)?;
            r = b.iter().zip(&mu).map(|(f, m)| f - m).collect();
            r_norm = norm(&r);
            self.report.final_relative_residual = r_norm / b_norm;
            if r_norm <= target {
                self.report.converged = true;
                return Ok(u);
            }
            if self.report.iterations >= self.opts.max_iterations {
                return Err(Error::MaxIterations {
                    method: "fixed point (fgmres)".into(),
                    iterations: self.report.iterations,
                    residual: r_norm / b_norm,
                });
            }
            tracing::debug!(
                estimate = estimate / b_norm,
                true_residual = r_norm / b_norm,
                "outer cycle restarts"
            );
        }
    }

    /// `M x = A x − R(x) + R(0)`: one host product and one recovery.
    fn apply_m(&mut self, x: &[f64]) -> Result<Vec<f64>> {
        let rec = self.recover(x)?;
        let mut y = vec![0.0; x.len()];
        self.op.apply(x, &mut y);
        for ((a, r), c) in y.iter_mut().zip(&rec).zip(&self.constant) {
            *a -= r - c;
        }
        Ok(y)
    }

    /// `R(x)`, timed and reported as a recovery.
    fn recover(&mut self, x: &[f64]) -> Result<Vec<f64>> {
        recorded_recovery(self.recovered, x, self.report, self.progress)
    }

    /// `z ≈ A⁻¹ v` to `inner_rel_tol` from `z = 0`, one solve of the report.
    fn precondition(&mut self, v: &[f64]) -> Result<Vec<f64>> {
        let mut krylov = self.opts.krylov.clone();
        krylov.rel_tol = self.opts.inner_rel_tol;
        let mut z = vec![0.0; v.len()];
        recorded_solve(self.solver, v, &mut z, &krylov, self.report, self.progress)?;
        Ok(z)
    }

    /// One FGMRES cycle of at most `self.restart` directions from the residual
    /// `r` (norm `r_norm`): the correction and the residual norm estimate.
    fn cycle(
        &mut self,
        r: &[f64],
        r_norm: f64,
        target: f64,
        b_norm: f64,
    ) -> Result<(Vec<f64>, f64)> {
        let n = r.len();
        let mut v: Vec<Vec<f64>> = vec![r.iter().map(|x| x / r_norm).collect()];
        let mut z: Vec<Vec<f64>> = Vec::new();
        let mut h = Hessenberg::new(r_norm);
        let mut estimate = r_norm;
        while z.len() < self.restart && estimate > target {
            if self.report.iterations >= self.opts.max_iterations {
                break;
            }
            if self.progress.should_stop() {
                return Err(Error::Interrupted {
                    iterations: self.report.iterations,
                });
            }
            let j = z.len();
            let _span = tracing::info_span!("fixed_point", iteration = j + 1).entered();
            let zj = self.precondition(&v[j])?;
            let mut w = self.apply_m(&zj)?;
            z.push(zj);
            // Modified Gram–Schmidt, twice (the basis must stay orthonormal
            // to round-off for the residual estimate to be the true one).
            let mut column = vec![0.0; j + 2];
            for _ in 0..2 {
                for (i, vi) in v.iter().enumerate() {
                    let c = dot(&w, vi);
                    column[i] += c;
                    for (a, b) in w.iter_mut().zip(vi) {
                        *a -= c * b;
                    }
                }
            }
            let w_norm = norm(&w);
            column[j + 1] = w_norm;
            estimate = h.push(column);
            self.report.iterations += 1;
            let eps = estimate / b_norm;
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
            if w_norm == 0.0 {
                // Lucky breakdown: the space is invariant, the solve exact.
                break;
            }
            v.push(w.iter().map(|x| x / w_norm).collect());
        }
        let y = h.solve();
        let mut du = vec![0.0; n];
        for (yj, zj) in y.iter().zip(&z) {
            for (a, b) in du.iter_mut().zip(zj) {
                *a += yj * b;
            }
        }
        Ok((du, estimate))
    }
}

/// The Arnoldi Hessenberg matrix reduced to upper triangular by Givens
/// rotations as its columns arrive, with the rotated right-hand side `β e₁`.
struct Hessenberg {
    /// Rotated columns, upper triangular (column `j` has `j + 1` entries).
    columns: Vec<Vec<f64>>,
    /// `(c, s)` of each rotation.
    rotations: Vec<(f64, f64)>,
    /// `g = Qᵀ β e₁`.
    g: Vec<f64>,
}

impl Hessenberg {
    fn new(beta: f64) -> Self {
        Hessenberg {
            columns: Vec::new(),
            rotations: Vec::new(),
            g: vec![beta],
        }
    }

    /// Adds column `j` (`j + 2` entries), returns `|g_{j+1}|`, the residual
    /// norm of the least-squares solution over the `j + 1` directions.
    fn push(&mut self, mut column: Vec<f64>) -> f64 {
        let j = self.columns.len();
        for (i, &(c, s)) in self.rotations.iter().enumerate() {
            let (a, b) = (column[i], column[i + 1]);
            column[i] = c * a + s * b;
            column[i + 1] = -s * a + c * b;
        }
        let (a, b) = (column[j], column[j + 1]);
        let r = a.hypot(b);
        let (c, s) = if r == 0.0 { (1.0, 0.0) } else { (a / r, b / r) };
        column[j] = r;
        column.truncate(j + 1);
        self.rotations.push((c, s));
        let gj = self.g[j];
        self.g[j] = c * gj;
        self.g.push(-s * gj);
        self.columns.push(column);
        self.g[j + 1].abs()
    }

    /// `y` of the triangular system `R y = g[..k]` (back substitution).
    fn solve(&self) -> Vec<f64> {
        let k = self.columns.len();
        let mut y = vec![0.0; k];
        for i in (0..k).rev() {
            let mut s = self.g[i];
            for (jj, yj) in y.iter().enumerate().skip(i + 1) {
                s -= self.columns[jj][i] * yj;
            }
            let d = self.columns[i][i];
            y[i] = if d == 0.0 { 0.0 } else { s / d };
        }
        y
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

#[cfg(test)]
#[path = "outer_krylov_tests.rs"]
mod tests;
