//! f32 inner solves inside f64 defect correction, for adapters
//! without `SHADER_F64` (or `--precision f32`):
//!
//! ```text
//! repeat
//!     r = b − A x                 f64, on the host, with the CPU operator
//!     stop when ‖r‖ ≤ τ ‖b‖
//!     A d = r                     f32 on the device (for r / ‖r‖, so that f32
//!                                 keeps its range), to τ_in = max(τ ‖b‖ / ‖r‖, τ_f32)
//!     x = x + d                   f64
//! ```
//!
//! The inner tolerance never asks f32 for more than [`F32_INNER_TOL`]; each
//! outer step then gains about that factor, and the accuracy of `x` is set by
//! the f64 residual alone. An outer step that does not reduce `‖r‖` by at
//! least [`MIN_CONTRACTION`] ends the solve with [`Error::MaxIterations`].

use crate::backend::{Backend, LinearOperator};
use crate::error::{Error, Result};
use crate::solver::{KrylovOptions, KrylovStats};

use super::backend::{GpuBackend, GpuVector};
use super::device_krylov::{solve_device, DeviceOptions};
use super::operator::GpuOperator;

/// The tightest relative tolerance asked of an f32 inner solve.
pub const F32_INNER_TOL: f64 = 1e-4;
/// An outer step must at least multiply `‖r‖` by this.
pub const MIN_CONTRACTION: f64 = 0.5;

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|a| a * a).sum::<f64>().sqrt()
}

/// Solves `A x = b` to `opts.rel_tol` (true f64 residual of `host`), from the
/// `x` given, with inner solves on `be` (any precision; meant for f32).
/// `stats.iterations` sums the inner iterations, `restarts` counts the outer
/// steps after the first.
pub fn solve_defect_correction(
    be: &GpuBackend,
    op: &GpuOperator<'_>,
    diag: Option<&GpuVector>,
    host: &dyn LinearOperator,
    b: &[f64],
    x: &mut [f64],
    opts: &KrylovOptions,
) -> Result<KrylovStats> {
    opts.validate()?;
    let n = host.nrows();
    assert!(b.len() == n && x.len() == n, "defect correction: sizes");
    let b_norm = norm(b);
    let mut stats = KrylovStats::default();
    if b_norm == 0.0 {
        x.fill(0.0);
        stats.residual_history.push(0.0);
        return Ok(stats);
    }
    let mut r = vec![0.0; n];
    let mut last = f64::INFINITY;
    for step in 0.. {
        host.apply(x, &mut r);
        for (ri, bi) in r.iter_mut().zip(b) {
            *ri = bi - *ri;
        }
        let r_norm = norm(&r);
        let rel = r_norm / b_norm;
        stats.true_relative_residual = rel;
        stats.relative_residual = rel;
        stats.residual_history.push(rel);
        if rel <= opts.rel_tol {
            return Ok(stats);
        }
        if !rel.is_finite() || rel > MIN_CONTRACTION * last {
            break;
        }
        if stats.iterations >= opts.max_iterations {
            break;
        }
        last = rel;
        stats.restarts = step;
        let inner = KrylovOptions {
            rel_tol: (opts.rel_tol / rel).max(F32_INNER_TOL),
            max_iterations: opts.max_iterations - stats.iterations,
            ..opts.clone()
        };
        // Unit right-hand side: f32 keeps its range whatever the scale of r.
        let unit: Vec<f64> = r.iter().map(|v| v / r_norm).collect();
        let rd = be.upload(&unit);
        let mut d = be.zeros(n);
        let result = solve_device(be, op, diag, &rd, &mut d, &inner, &DeviceOptions::default());
        match result {
            Ok(s) => {
                stats.iterations += s.iterations;
                stats.floored_diagonal_entries = s.floored_diagonal_entries;
            }
            // f32 may stall short of its tolerance: keep what it reached and
            // let the f64 residual judge.
            Err(Error::MaxIterations { iterations, .. }) => stats.iterations += iterations,
            Err(e) => return Err(e),
        }
        for (xi, di) in x.iter_mut().zip(be.download(&d)) {
            *xi += r_norm * di;
        }
    }
    Err(Error::MaxIterations {
        method: format!("{} (f32 defect correction)", opts.method.name()),
        iterations: stats.iterations,
        residual: stats.true_relative_residual,
    })
}
