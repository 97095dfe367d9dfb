//! Krylov solvers: CGS (the paper's method), CG for SPD operators
//! (a case's default, `A` being SPD) and BiCGStab for non-symmetric ones, each with no or Jacobi
//! preconditioning, or with a preconditioner built by the caller
//! ([`solve_preconditioned`]: the multigrid V-cycle of [`crate::multigrid`]),
//! written once against [`Backend`].
//!
//! # Stopping, honestly
//! A solve stops when the relative residual `‖b − A x‖₂ / ‖b‖₂` is at most
//! `rel_tol`. All three methods are preconditioned so that the residual they
//! update recursively is the unpreconditioned one (right preconditioning for CGS
//! and BiCGStab, the `r`/`z = M⁻¹ r` split for CG), so the check during the
//! iteration is on the recursive estimate of the true residual. When that
//! estimate says "converged", [`solve`] recomputes the true residual `b − A x`;
//! only if that one meets the tolerance is the solve accepted. Otherwise (the
//! recursive and the true residual drifted apart, as they can for CGS) the method
//! restarts from the true residual, within the same iteration budget. The true
//! relative residual is reported in [`KrylovStats::true_relative_residual`], and in
//! [`Error::MaxIterations`] when the budget runs out.
//!
//! # Special cases and failures
//! - `b = 0`: `x = 0` is returned at once, with 0 iterations.
//! - A zero divisor (`r̃·r`, `r̃·v`, `t·t`, `ω`), a non-positive `p·Ap` or
//!   `r·M⁻¹r` in CG, or any non-finite value: [`Error::Breakdown`].
//! - A zero or negative Jacobi diagonal entry at round-off level (a cut
//!   artefact) is floored,
//!   not a breakdown, and counted in
//!   [`KrylovStats::floored_diagonal_entries`]; see [`DIAGONAL_FLOOR`].
//! - Iteration budget used up: [`Error::MaxIterations`]. Both exit with code 3.

pub mod fgmres;
mod krylov;
pub mod lanczos;
mod precond;
#[cfg(test)]
pub(crate) mod test_operators;
#[cfg(test)]
mod tests;

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::backend::Backend;
use crate::error::{Error, Result};

pub use lanczos::{lanczos_extreme_eigenvalues, tridiagonal_eigenvalue};

pub(crate) use krylov::breakdown;
use krylov::Problem;
pub(crate) use precond::Precond;
pub use precond::{
    floor_diagonal, floor_diagonal_against, ApplyInverse, TimedInverse, DIAGONAL_FLOOR,
};

/// The Krylov method of a solve.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum KrylovMethod {
    /// Conjugate gradients (A and the preconditioner SPD).
    Cg,
    /// Conjugate gradient squared (the paper's method).
    #[default]
    Cgs,
    /// Stabilised bi-conjugate gradients.
    BiCgStab,
}

impl KrylovMethod {
    /// The lowercase name, as in case files and reports.
    pub fn name(self) -> &'static str {
        match self {
            KrylovMethod::Cg => "cg",
            KrylovMethod::Cgs => "cgs",
            KrylovMethod::BiCgStab => "bicgstab",
        }
    }
}

impl fmt::Display for KrylovMethod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The preconditioner `M ≈ A` of a solve.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Preconditioner {
    /// `M = I` (reproduces the paper).
    #[default]
    None,
    /// `M = diag(A)`.
    Jacobi,
    /// `M⁻¹` = one geometric multigrid V-cycle on the case's nested grids
    /// ([`crate::multigrid`] on the CPU, `crate::gpu::multigrid` on an f64
    /// GPU).
    Multigrid,
    /// Multigrid on the CPU and on an f64 GPU, Jacobi on an f32-only GPU
    /// (the default): the runner resolves it once the
    /// backend is known; a solve given no hierarchy takes Jacobi.
    Auto,
}

impl Preconditioner {
    /// The lowercase name, as in case files and reports.
    pub fn name(self) -> &'static str {
        match self {
            Preconditioner::None => "none",
            Preconditioner::Jacobi => "jacobi",
            Preconditioner::Multigrid => "multigrid",
            Preconditioner::Auto => "auto",
        }
    }
}

/// What to solve with and when to stop.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct KrylovOptions {
    pub method: KrylovMethod,
    pub preconditioner: Preconditioner,
    /// Stop when `‖b − A x‖₂ ≤ rel_tol ‖b‖₂`.
    pub rel_tol: f64,
    /// Iteration budget of the solve, restarts included.
    pub max_iterations: usize,
}

impl Default for KrylovOptions {
    fn default() -> Self {
        KrylovOptions {
            method: KrylovMethod::Cgs,
            preconditioner: Preconditioner::None,
            rel_tol: 1e-8,
            max_iterations: 10_000,
        }
    }
}

impl KrylovOptions {
    /// Checks the ranges: `rel_tol` finite and positive.
    pub fn validate(&self) -> Result<()> {
        if !(self.rel_tol.is_finite() && self.rel_tol > 0.0) {
            return Err(Error::InvalidSolverOptions {
                what: "rel_tol".into(),
                reason: format!("must be finite and positive, got {}", self.rel_tol),
            });
        }
        Ok(())
    }
}

/// What a successful solve reports.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct KrylovStats {
    /// Iterations over all cycles (one iteration of CGS and BiCGStab applies
    /// the operator twice, one of CG once).
    pub iterations: usize,
    /// Restarts from the true residual after the recursive one drifted away.
    pub restarts: usize,
    /// The last relative residual the method updated recursively
    /// (the true one when no iteration was needed).
    pub relative_residual: f64,
    /// `‖b − A x‖₂ / ‖b‖₂`, recomputed from the returned `x`.
    pub true_relative_residual: f64,
    /// Relative residuals: the true one at the start of each cycle, then the
    /// recursive one after each iteration.
    pub residual_history: Vec<f64>,
    /// CG only: the step lengths `α_k` and direction coefficients `β_k` of the
    /// last cycle, for [`lanczos_extreme_eigenvalues`]. With Jacobi they describe
    /// `M⁻¹A` rather than `A`.
    pub lanczos: Option<(Vec<f64>, Vec<f64>)>,
    /// Jacobi only: diagonal entries at round-off level (cut artefacts) that
    /// the preconditioner floored instead of failing (see [`DIAGONAL_FLOOR`]).
    pub floored_diagonal_entries: usize,
}

/// Solves `A x = b` for `x`, starting from the `x` given (warm start).
///
/// `diag` is the diagonal of `A` for the Jacobi preconditioner; when it is
/// `None` and Jacobi is asked for, it is computed with [`Backend::diagonal`]
/// (pass it in to reuse it over the solves of a fixed-point loop). It is
/// ignored without a preconditioner.
///
/// # Panics
/// If `b`, `x` (or `diag`) do not have the size of `op`.
pub fn solve<B: Backend>(
    backend: &B,
    op: &B::Operator<'_>,
    diag: Option<&B::Vector>,
    b: &B::Vector,
    x: &mut B::Vector,
    opts: &KrylovOptions,
) -> Result<KrylovStats> {
    drive(backend, op, b, x, opts, |b_norm| {
        Ok(Problem {
            backend,
            op,
            pre: Precond::new(backend, op, diag, opts)?,
            method: opts.method,
            b_norm,
            rel_tol: opts.rel_tol,
            max_iterations: opts.max_iterations,
        })
    })
}

/// [`solve`] with the preconditioner `pre` built by the caller (the
/// multigrid V-cycle); `opts.preconditioner` is not looked at.
///
/// # Panics
/// If `b` or `x` do not have the size of `op`.
pub fn solve_preconditioned<B: Backend>(
    backend: &B,
    op: &B::Operator<'_>,
    pre: &dyn ApplyInverse<B>,
    b: &B::Vector,
    x: &mut B::Vector,
    opts: &KrylovOptions,
) -> Result<KrylovStats> {
    drive(backend, op, b, x, opts, |b_norm| {
        Ok(Problem {
            backend,
            op,
            pre: Precond::external(pre),
            method: opts.method,
            b_norm,
            rel_tol: opts.rel_tol,
            max_iterations: opts.max_iterations,
        })
    })
}

/// The cycles of one Krylov method as [`drive`] runs them.
pub(crate) trait Cycles<B: Backend> {
    /// One cycle from the true residual `r = b − A x`, until the recursive
    /// residual meets the tolerance or the iteration budget is used up
    /// (`Ok`), or a breakdown (`Err`); counts its iterations in `stats`.
    fn cycle(&self, x: &mut B::Vector, r: &mut B::Vector, stats: &mut KrylovStats) -> Result<()>;

    /// Diagonal entries the preconditioner floored ([`DIAGONAL_FLOOR`]).
    fn floored_diagonal_entries(&self) -> usize;
}

impl<B: Backend> Cycles<B> for Problem<'_, '_, B> {
    fn cycle(&self, x: &mut B::Vector, r: &mut B::Vector, stats: &mut KrylovStats) -> Result<()> {
        match self.method {
            KrylovMethod::Cg => krylov::cg(self, x, r, stats),
            KrylovMethod::Cgs => krylov::cgs(self, x, r, stats),
            KrylovMethod::BiCgStab => krylov::bicgstab(self, x, r, stats),
        }
    }

    fn floored_diagonal_entries(&self) -> usize {
        self.pre.floored()
    }
}

/// The driver of every Krylov solve, host or device scalars (the module
/// doc's stopping rules): checks the options and `b`, returns at once for
/// `b = 0`, then runs the cycles that `setup(‖b‖)` makes, with the true
/// residual computed around them and restarts within the iteration budget.
pub(crate) fn drive<B: Backend, C: Cycles<B>>(
    backend: &B,
    op: &B::Operator<'_>,
    b: &B::Vector,
    x: &mut B::Vector,
    opts: &KrylovOptions,
    setup: impl FnOnce(f64) -> Result<C>,
) -> Result<KrylovStats> {
    opts.validate()?;
    let n = backend.nrows(op);
    assert!(
        backend.len(b) == n && backend.len(x) == n,
        "solve: b and x must have the {n} rows of the operator"
    );
    let b_norm = backend.dot(b, b).sqrt();
    if !b_norm.is_finite() {
        let what = format!("the right-hand side is not finite (‖b‖ = {b_norm})");
        return Err(krylov::breakdown(opts.method, 0, what));
    }
    let mut stats = KrylovStats::default();
    if b_norm == 0.0 {
        backend.copy(b, x);
        stats.residual_history.push(0.0);
        return Ok(stats);
    }
    let cycles = setup(b_norm)?;
    stats.floored_diagonal_entries = cycles.floored_diagonal_entries();
    let mut r = backend.zeros(n);
    for cycle in 0.. {
        let rel = true_residual(
            backend,
            op,
            opts.method,
            b,
            x,
            &mut r,
            b_norm,
            stats.iterations,
        )?;
        stats.true_relative_residual = rel;
        if cycle == 0 {
            stats.relative_residual = rel;
        }
        if rel <= opts.rel_tol {
            return Ok(stats);
        }
        if stats.iterations >= opts.max_iterations {
            break;
        }
        stats.restarts = cycle;
        stats.residual_history.push(rel);
        let started = stats.iterations;
        match cycles.cycle(x, &mut r, &mut stats) {
            Ok(()) => {}
            // A vanishing r̃·r or r̃·v in CGS/BiCGStab (a "lucky" or serious
            // breakdown of the bi-orthogonalisation) after some progress:
            // restart from the true residual with a fresh shadow residual.
            Err(Error::Breakdown { what, .. })
                if opts.method != KrylovMethod::Cg
                    && what.ends_with("= 0")
                    && stats.iterations > started => {}
            Err(e) => return Err(e),
        }
    }
    Err(Error::MaxIterations {
        method: opts.method.name().into(),
        iterations: stats.iterations,
        residual: stats.true_relative_residual,
    })
}

/// `r = b − A x`; returns `‖r‖₂ / ‖b‖₂`. From `x = 0` (every solve of the
/// outer iteration starts there) `r` is `b` without a product with `A`.
#[allow(clippy::too_many_arguments)]
fn true_residual<B: Backend>(
    backend: &B,
    op: &B::Operator<'_>,
    method: KrylovMethod,
    b: &B::Vector,
    x: &B::Vector,
    r: &mut B::Vector,
    b_norm: f64,
    iterations: usize,
) -> Result<f64> {
    if backend.dot(x, x) == 0.0 {
        backend.copy(b, r);
    } else {
        backend.apply(op, x, r);
        backend.xpay(b, -1.0, r);
    }
    let rr = backend.dot(r, r);
    if !rr.is_finite() {
        let what = format!("‖b − A x‖² of the true residual is not finite ({rr})");
        return Err(krylov::breakdown(method, iterations, what));
    }
    Ok(rr.sqrt() / b_norm)
}
