//! Flexible GMRES (Saad 1993) with restarts from the true residual.
//!
//! FGMRES solves `M x = b` right-preconditioned by an operator that may change
//! from one direction to the next (an inexact inner solve): direction `j`
//! keeps both the Arnoldi vector `v_j` and its preconditioned `z_j`, and the
//! correction is `Σ y_j z_j` with `y` the least-squares solution of the
//! Hessenberg system, reduced by Givens rotations as its columns arrive, so
//! the residual estimate `|g_{j+1}|` costs nothing per direction. The basis
//! is orthogonalised by modified Gram–Schmidt, twice, so it stays orthonormal
//! to round-off and the estimate is the true residual in exact arithmetic.
//!
//! A cycle stops after `restart` directions or when its estimate reaches the
//! tolerance; then the true residual `b − M x` is computed afresh, and the
//! solve stops only if that is below the tolerance — else the next cycle
//! starts from it (iterative refinement). The caller supplies `M`, the
//! preconditioner and a hook per direction through [`FlexibleSystem`].

use crate::backend::CpuBackend;
use crate::error::{Error, Result};

/// What FGMRES needs from the system it solves.
pub trait FlexibleSystem {
    /// `M x`.
    fn apply(&mut self, x: &[f64]) -> Result<Vec<f64>>;
    /// `z ≈ M⁻¹ v` (may differ from one call to the next).
    fn precondition(&mut self, v: &[f64]) -> Result<Vec<f64>>;
    /// Called before direction `iterations + 1` is formed: an error stops
    /// the solve (an interrupt, say).
    fn before_direction(&mut self, iterations: usize) -> Result<()>;
    /// Called after each direction with the iterations so far and the
    /// relative residual estimate `|g_{j+1}| / ‖b‖`.
    fn after_direction(&mut self, iterations: usize, estimate: f64);
    /// `a · b` over the whole system ([`local_dot`] where the vectors are
    /// whole; summed over the ranks where each holds a part).
    fn dot(&self, a: &[f64], b: &[f64]) -> f64;
}

/// Tolerance, iteration cap and restart length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FgmresOptions {
    /// Converged when `‖b − M x‖ ≤ tol ‖b‖` (the true residual).
    pub tol: f64,
    /// Directions at most, over all cycles.
    pub max_iterations: usize,
    /// Directions per cycle.
    pub restart: usize,
}

/// The answer and how it was reached.
#[derive(Clone, Debug, PartialEq)]
pub struct FgmresOutcome {
    pub x: Vec<f64>,
    /// Directions formed over all cycles.
    pub iterations: usize,
    /// `‖b − M x‖ / ‖b‖` of the returned `x` (0 when `b = 0`).
    pub relative_residual: f64,
}

/// FGMRES on `M x = b` from `x = 0` (module doc). `method` names the solve in
/// [`Error::MaxIterations`], which is returned when `max_iterations`
/// directions do not reach the tolerance.
pub fn fgmres(
    system: &mut dyn FlexibleSystem,
    b: &[f64],
    opts: &FgmresOptions,
    method: &str,
) -> Result<FgmresOutcome> {
    let mut x = vec![0.0; b.len()];
    let b_norm = norm(system, b);
    if b_norm == 0.0 {
        return Ok(FgmresOutcome {
            x,
            iterations: 0,
            relative_residual: 0.0,
        });
    }
    let target = opts.tol * b_norm;
    // r_0 = b (x_0 = 0, and M 0 = 0).
    let mut r = b.to_vec();
    let mut r_norm = b_norm;
    let mut iterations = 0;
    loop {
        let (dx, estimate) = cycle(system, &r, r_norm, target, b_norm, opts, &mut iterations)?;
        for (a, d) in x.iter_mut().zip(&dx) {
            *a += d;
        }
        // The true residual: where the cycle stopped short, to restart from;
        // where its estimate says converged, to confirm it.
        let mx = system.apply(&x)?;
        r = b.iter().zip(&mx).map(|(f, m)| f - m).collect();
        r_norm = norm(system, &r);
        if r_norm <= target {
            return Ok(FgmresOutcome {
                x,
                iterations,
                relative_residual: r_norm / b_norm,
            });
        }
        if iterations >= opts.max_iterations {
            return Err(Error::MaxIterations {
                method: method.into(),
                iterations,
                residual: r_norm / b_norm,
            });
        }
        tracing::debug!(
            estimate = estimate / b_norm,
            true_residual = r_norm / b_norm,
            "fgmres cycle restarts"
        );
    }
}

/// One cycle of at most `opts.restart` directions from the residual `r`
/// (norm `r_norm`): the correction and the residual norm estimate.
fn cycle(
    system: &mut dyn FlexibleSystem,
    r: &[f64],
    r_norm: f64,
    target: f64,
    b_norm: f64,
    opts: &FgmresOptions,
    iterations: &mut usize,
) -> Result<(Vec<f64>, f64)> {
    let mut v: Vec<Vec<f64>> = vec![r.iter().map(|x| x / r_norm).collect()];
    let mut z: Vec<Vec<f64>> = Vec::new();
    let mut h = Hessenberg::new(r_norm);
    let mut estimate = r_norm;
    while z.len() < opts.restart && estimate > target {
        if *iterations >= opts.max_iterations {
            break;
        }
        system.before_direction(*iterations)?;
        let j = z.len();
        let _span = tracing::info_span!("fgmres", iteration = *iterations + 1).entered();
        let zj = system.precondition(&v[j])?;
        let mut w = system.apply(&zj)?;
        z.push(zj);
        let mut column = vec![0.0; j + 2];
        for _ in 0..2 {
            for (i, vi) in v.iter().enumerate() {
                let c = system.dot(&w, vi);
                column[i] += c;
                for (a, b) in w.iter_mut().zip(vi) {
                    *a -= c * b;
                }
            }
        }
        let w_norm = norm(system, &w);
        column[j + 1] = w_norm;
        estimate = h.push(column);
        *iterations += 1;
        system.after_direction(*iterations, estimate / b_norm);
        if w_norm == 0.0 {
            // Lucky breakdown: the space is invariant, the solve exact.
            break;
        }
        v.push(w.iter().map(|x| x / w_norm).collect());
    }
    let y = h.solve();
    let mut dx = vec![0.0; r.len()];
    for (yj, zj) in y.iter().zip(&z) {
        for (a, b) in dx.iter_mut().zip(zj) {
            *a += yj * b;
        }
    }
    Ok((dx, estimate))
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

/// `a · b` on one process: the CPU backend's exact sum of the rounded
/// products, rounded once (the same bits however the vectors are split).
pub fn local_dot(a: &[f64], b: &[f64]) -> f64 {
    CpuBackend::new().exact_dot(a, b).value()
}

fn norm(system: &dyn FlexibleSystem, a: &[f64]) -> f64 {
    system.dot(a, a).sqrt()
}
