//! The smoother of every level but the coarsest: Chebyshev iteration over the
//! Jacobi-preconditioned operator `D⁻¹A` (`D = diag A`, floored as the Jacobi
//! preconditioner floors it, [`crate::solver::floor_diagonal`]).
//!
//! # The polynomial
//! With the eigenvalues of `D⁻¹A` taken in `[a, b]`, `θ = (b + a)/2`,
//! `δ = (b − a)/2`, `σ = θ/δ`, one smoothing step of degree `k` from `x`
//! (Saad, *Iterative Methods*, Alg. 12.1 with the preconditioner `D⁻¹`) is
//!
//! ```text
//! r = b − A x;  d = D⁻¹ r / θ;  x = x + d;  ρ = 1/σ
//! repeat k − 1 times:
//!     r = r − A d;  ρ' = 1/(2σ − ρ)
//!     d = ρ'ρ d + (2ρ'/δ) D⁻¹ r;  x = x + d;  ρ = ρ'
//! ```
//! so that the error goes to `E e`, `E = T_k((θ − D⁻¹A)/δ) / T_k(σ)`: small
//! over `[a, b]` (the high frequencies the coarse grid cannot see), at most 1
//! over `(0, b]`. `E = I − N A` with `N = q(D⁻¹A) D⁻¹ = D^{-1/2} q(S) D^{-1/2}`
//! symmetric (`S = D^{-1/2} A D^{-1/2}`), so the step is self-adjoint in the
//! energy product and the same step before and after the coarse correction
//! makes a symmetric V-cycle.
//!
//! # The interval
//! `b = 1.2 λ̃` where `λ̃` is the largest Ritz value of [`LANCZOS_STEPS`]
//! Lanczos steps on `S` (a lower bound of `λ_max`, the margin covers the
//! gap), and `a = b / SMOOTHING_RANGE`, as deal.II's `PreconditionChebyshev`
//! (step-37) does. With `b ≥ λ_max`, `|E| ≤ 1` on the whole spectrum: the
//! smoother never amplifies an error component.
//!
//! The vector kernels are explicit loops over fixed chunks, as the CPU
//! backend's are, so that WGSL kernels can mirror them.

use rayon::prelude::*;

use crate::backend::LinearOperator;
use crate::error::{Error, Result};
use crate::solver::{floor_diagonal, tridiagonal_eigenvalue};

/// Default degree `k` of the Chebyshev polynomial (applies of `A` per smoothing step,
/// counting the residual of a non-zero start).
pub const DEGREE: usize = 4;

/// `b / a`: the part of the spectrum of `D⁻¹A` the smoother damps.
pub const SMOOTHING_RANGE: f64 = 15.0;

/// Lanczos steps for the estimate of `λ_max(D⁻¹A)`.
pub const LANCZOS_STEPS: usize = 12;

/// Safety factor on the largest Ritz value.
const EIGENVALUE_MARGIN: f64 = 1.2;

/// Entries per parallel task of the vector kernels.
const CHUNK: usize = 8192;

/// The Chebyshev smoother of one level.
pub struct Chebyshev {
    inv_diag: Vec<f64>,
    /// Degree `k` of the polynomial.
    degree: usize,
    /// The interval `[a, b]` of `D⁻¹A` it damps.
    pub lo: f64,
    pub hi: f64,
    /// Jacobi diagonal entries at round-off level that were floored.
    pub floored: usize,
}

/// The smoother's scratch vectors on one level: residual, update and `A d`.
pub struct Work {
    r: Vec<f64>,
    d: Vec<f64>,
    ad: Vec<f64>,
}

impl Work {
    pub fn new(n: usize) -> Work {
        Work {
            r: vec![0.0; n],
            d: vec![0.0; n],
            ad: vec![0.0; n],
        }
    }

    /// The residual `b − A x` left by the last [`Chebyshev::residual`].
    pub fn residual(&self) -> &[f64] {
        &self.r
    }
}

impl Chebyshev {
    /// The smoother of `op`: its floored, inverted diagonal and the interval
    /// from a Lanczos estimate (module doc). A diagonal entry that is not
    /// finite or is negative beyond the floor is a breakdown.
    pub fn new(op: &dyn LinearOperator, degree: usize) -> Result<Chebyshev> {
        assert!(degree >= 1, "Chebyshev smoother of degree 0");
        let mut d = op.diagonal();
        let floored = floor_diagonal(&mut d, true).map_err(|(i, v)| Error::Breakdown {
            method: "multigrid".into(),
            iterations: 0,
            what: format!("smoother: diagonal entry {i} of a level operator is {v:e}"),
        })?;
        let inv_diag: Vec<f64> = d.iter().map(|v| 1.0 / v).collect();
        let lambda = largest_eigenvalue(op, &inv_diag, LANCZOS_STEPS);
        if !(lambda.is_finite() && lambda > 0.0) {
            return Err(Error::Breakdown {
                method: "multigrid".into(),
                iterations: 0,
                what: format!("smoother: the Lanczos estimate of λ_max(D⁻¹A) is {lambda:e}"),
            });
        }
        let hi = EIGENVALUE_MARGIN * lambda;
        Ok(Chebyshev {
            inv_diag,
            degree,
            lo: hi / SMOOTHING_RANGE,
            hi,
            floored,
        })
    }

    /// One smoothing step of degree `k` on `A x = b` (module doc),
    /// from `x = 0` when `zero_start` (saving the residual's apply), else
    /// from the `x` given.
    pub fn smooth(
        &self,
        op: &dyn LinearOperator,
        b: &[f64],
        x: &mut [f64],
        zero_start: bool,
        w: &mut Work,
    ) {
        let theta = 0.5 * (self.hi + self.lo);
        let delta = 0.5 * (self.hi - self.lo);
        let sigma = theta / delta;
        if zero_start {
            w.r.copy_from_slice(b);
            x.fill(0.0);
        } else {
            self.residual(op, b, x, w);
        }
        w.d.fill(0.0);
        chebyshev_update(0.0, 1.0 / theta, &self.inv_diag, &w.r, &mut w.d, x);
        let mut rho = 1.0 / sigma;
        for _ in 1..self.degree {
            op.apply(&w.d, &mut w.ad);
            sub_assign(&mut w.r, &w.ad);
            let rho_next = 1.0 / (2.0 * sigma - rho);
            let (a, c) = (rho_next * rho, 2.0 * rho_next / delta);
            chebyshev_update(a, c, &self.inv_diag, &w.r, &mut w.d, x);
            rho = rho_next;
        }
    }

    /// `w.r = b − A x`.
    pub fn residual(&self, op: &dyn LinearOperator, b: &[f64], x: &[f64], w: &mut Work) {
        op.apply(x, &mut w.r);
        rsub_assign(&mut w.r, b);
    }
}

/// `d = a d + c D⁻¹ r`, then `x = x + d`, entry by entry.
fn chebyshev_update(a: f64, c: f64, inv_diag: &[f64], r: &[f64], d: &mut [f64], x: &mut [f64]) {
    d.par_chunks_mut(CHUNK)
        .zip(x.par_chunks_mut(CHUNK))
        .enumerate()
        .for_each(|(t, (dc, xc))| {
            let base = t * CHUNK;
            for i in 0..dc.len() {
                let di = a * dc[i] + c * inv_diag[base + i] * r[base + i];
                dc[i] = di;
                xc[i] += di;
            }
        });
}

/// `r = r − v`.
fn sub_assign(r: &mut [f64], v: &[f64]) {
    r.par_chunks_mut(CHUNK).enumerate().for_each(|(t, rc)| {
        let base = t * CHUNK;
        for i in 0..rc.len() {
            rc[i] -= v[base + i];
        }
    });
}

/// `r = b − r`.
fn rsub_assign(r: &mut [f64], b: &[f64]) {
    r.par_chunks_mut(CHUNK).enumerate().for_each(|(t, rc)| {
        let base = t * CHUNK;
        for i in 0..rc.len() {
            rc[i] = b[base + i] - rc[i];
        }
    });
}

/// The largest Ritz value of `steps` Lanczos steps on
/// `S = D^{-1/2} A D^{-1/2}` (`inv_diag = D⁻¹`) from a fixed start vector,
/// without reorthogonalisation (the extreme Ritz value converges first):
///
/// ```text
/// q₀ = v/‖v‖;  β₀ = 0
/// w = S q_k − β_k q_{k−1};  α_k = w·q_k;  w = w − α_k q_k;  β_{k+1} = ‖w‖
/// ```
/// and the top eigenvalue of the tridiagonal `(α, β)`
/// ([`tridiagonal_eigenvalue`]). Not `condition::lanczos`: that one keeps the
/// whole basis (full reorthogonalisation, Ritz vectors) for κ; a smoother
/// bound needs only the top Ritz value, so the three-term recurrence holds
/// three vectors instead of `steps` at every level of the hierarchy.
pub fn largest_eigenvalue(op: &dyn LinearOperator, inv_diag: &[f64], steps: usize) -> f64 {
    let n = inv_diag.len();
    let scale: Vec<f64> = inv_diag.iter().map(|v| v.sqrt()).collect();
    // A fixed start with every entry non-zero and no grid-aligned pattern.
    let mut q: Vec<f64> = (0..n)
        .map(|i| 1.0 + 0.5 * ((i as f64 + 1.0) * 0.618_033_988_749_895).fract())
        .collect();
    normalise(&mut q);
    let (mut q_prev, mut t, mut w) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let (mut diag, mut off2) = (Vec::new(), Vec::new());
    let mut beta = 0.0;
    for _ in 0..steps.min(n) {
        for i in 0..n {
            t[i] = scale[i] * q[i];
        }
        op.apply(&t, &mut w);
        for i in 0..n {
            w[i] = scale[i] * w[i] - beta * q_prev[i];
        }
        let alpha: f64 = w.iter().zip(&q).map(|(a, b)| a * b).sum();
        for i in 0..n {
            w[i] -= alpha * q[i];
        }
        diag.push(alpha);
        beta = w.iter().map(|v| v * v).sum::<f64>().sqrt();
        if beta.is_nan() || beta <= 1e-12 * alpha.abs() {
            break;
        }
        off2.push(beta * beta);
        std::mem::swap(&mut q_prev, &mut q);
        for i in 0..n {
            q[i] = w[i] / beta;
        }
    }
    off2.truncate(diag.len() - 1);
    tridiagonal_eigenvalue(&diag, &off2, diag.len() - 1)
}

/// `v = v / ‖v‖`.
fn normalise(v: &mut [f64]) {
    let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    for x in v.iter_mut() {
        *x /= norm;
    }
}
