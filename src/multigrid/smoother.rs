//! The smoother of every level but the coarsest: Chebyshev iteration over the
//! preconditioned operator `B⁻¹A`, `B` Jacobi inside the body and block
//! Jacobi on the cut band ([`super::blocks`]; `B = D = diag A`, floored as
//! the Jacobi preconditioner floors it, [`crate::solver::floor_diagonal`],
//! where there are no cut cells).
//!
//! # The polynomial
//! With the eigenvalues of `B⁻¹A` taken in `[a, b]`, `θ = (b + a)/2`,
//! `δ = (b − a)/2`, `σ = θ/δ`, one smoothing step of degree `k` from `x`
//! (Saad, *Iterative Methods*, Alg. 12.1 with the preconditioner `B⁻¹`) is
//!
//! ```text
//! r = b − A x;  d = B⁻¹ r / θ;  x = x + d;  ρ = 1/σ
//! repeat k − 1 times:
//!     r = r − A d;  ρ' = 1/(2σ − ρ)
//!     d = ρ'ρ d + (2ρ'/δ) B⁻¹ r;  x = x + d;  ρ = ρ'
//! ```
//! so that the error goes to `E e`, `E = T_k((θ − B⁻¹A)/δ) / T_k(σ)`: small
//! over `[a, b]` (the high frequencies the coarse grid cannot see), at most 1
//! over `(0, b]`. `E = I − N A` with `N = q(B⁻¹A) B⁻¹` symmetric (`B`
//! symmetric positive definite), so the step is self-adjoint in the energy
//! product and the same step before and after the coarse correction makes a
//! symmetric V-cycle.
//!
//! # The interval
//! `b = 1.2 λ̃` where `λ̃` is the largest Ritz value of [`LANCZOS_STEPS`]
//! Lanczos steps on `B⁻¹A` in the `B` inner product (a lower bound of
//! `λ_max`, the margin covers the gap), and `a = b / SMOOTHING_RANGE`, as
//! deal.II's `PreconditionChebyshev` (step-37) does. With `b ≥ λ_max`,
//! `|E| ≤ 1` on the whole spectrum: the smoother never amplifies an error
//! component.
//!
//! The vector kernels are explicit loops over fixed chunks, as the CPU
//! backend's are, so that WGSL kernels can mirror them.

use rayon::prelude::*;

use super::blocks::BlockJacobi;
use crate::backend::LinearOperator;
use crate::error::{Error, Result};
use crate::fem::operator::ElasticOperator;
use crate::solver::{floor_diagonal, tridiagonal_eigenvalue};

/// Default degree `k` of the Chebyshev polynomial (applies of `A` per smoothing step,
/// counting the residual of a non-zero start).
pub const DEGREE: usize = 4;

/// `b / a`: the part of the spectrum of `B⁻¹A` the smoother damps.
pub const SMOOTHING_RANGE: f64 = 15.0;

/// Lanczos steps for the estimate of `λ_max(B⁻¹A)`.
pub const LANCZOS_STEPS: usize = 12;

/// Safety factor on the largest Ritz value.
const EIGENVALUE_MARGIN: f64 = 1.2;

/// Entries per parallel task of the vector kernels.
const CHUNK: usize = 8192;

/// The Chebyshev smoother of one level.
pub struct Chebyshev {
    pub(crate) pre: BlockJacobi,
    /// Degree `k` of the polynomial.
    pub(crate) degree: usize,
    /// The interval `[a, b]` of `B⁻¹A` it damps.
    pub lo: f64,
    pub hi: f64,
    /// Jacobi diagonal entries at round-off level that were floored.
    pub floored: usize,
}

impl Chebyshev {
    /// The smoother of `op`: its block Jacobi preconditioner over the
    /// floored diagonal and the interval from a Lanczos estimate (module
    /// doc). A diagonal entry that is not finite or is negative beyond the
    /// floor is a breakdown.
    pub fn new(op: &ElasticOperator, degree: usize) -> Result<Chebyshev> {
        assert!(degree >= 1, "Chebyshev smoother of degree 0");
        let mut d = op.diagonal();
        let floored = floor_diagonal(&mut d, true).map_err(|(i, v)| Error::Breakdown {
            method: "multigrid".into(),
            iterations: 0,
            what: format!("smoother: diagonal entry {i} of a level operator is {v:e}"),
        })?;
        let inv_diag: Vec<f64> = d.iter().map(|v| 1.0 / v).collect();
        let pre = BlockJacobi::new(op, &inv_diag);
        let lambda = largest_eigenvalue(op, &pre, LANCZOS_STEPS);
        if !(lambda.is_finite() && lambda > 0.0) {
            return Err(Error::Breakdown {
                method: "multigrid".into(),
                iterations: 0,
                what: format!("smoother: the Lanczos estimate of λ_max(B⁻¹A) is {lambda:e}"),
            });
        }
        let hi = EIGENVALUE_MARGIN * lambda;
        Ok(Chebyshev {
            pre,
            degree,
            lo: hi / SMOOTHING_RANGE,
            hi,
            floored,
        })
    }

    /// The cut-band blocks of its preconditioner and the unknowns they hold.
    pub fn block_sizes(&self) -> (usize, usize) {
        self.pre.block_sizes()
    }
}

/// The coefficients `(a, c)` of the `degree` updates `d = a d + c B⁻¹r`
/// of one smoothing step over the interval `[lo, hi]` (module doc): `(0,
/// 1/θ)` first, then `(ρ'ρ, 2ρ'/δ)` with `ρ' = 1/(2σ − ρ)`. Every backend's
/// step takes them from here ([`super::cycle`]; the device keeps them in a
/// buffer per level).
pub fn chebyshev_coefficients(lo: f64, hi: f64, degree: usize) -> Vec<(f64, f64)> {
    let theta = 0.5 * (hi + lo);
    let delta = 0.5 * (hi - lo);
    let sigma = theta / delta;
    let mut out = vec![(0.0, 1.0 / theta)];
    let mut rho = 1.0 / sigma;
    for _ in 1..degree {
        let rho_next = 1.0 / (2.0 * sigma - rho);
        out.push((rho_next * rho, 2.0 * rho_next / delta));
        rho = rho_next;
    }
    out
}

/// `d = a d + c z` (`z = B⁻¹ r`), then `x = x + d`, entry by entry.
pub(crate) fn chebyshev_update(a: f64, c: f64, z: &[f64], d: &mut [f64], x: &mut [f64]) {
    d.par_chunks_mut(CHUNK)
        .zip(x.par_chunks_mut(CHUNK))
        .enumerate()
        .for_each(|(t, (dc, xc))| {
            let base = t * CHUNK;
            for i in 0..dc.len() {
                let di = a * dc[i] + c * z[base + i];
                dc[i] = di;
                xc[i] += di;
            }
        });
}

/// `r = r − v`.
pub(crate) fn sub_assign(r: &mut [f64], v: &[f64]) {
    r.par_chunks_mut(CHUNK).enumerate().for_each(|(t, rc)| {
        let base = t * CHUNK;
        for i in 0..rc.len() {
            rc[i] -= v[base + i];
        }
    });
}

/// `r = b − r`.
pub(crate) fn rsub_assign(r: &mut [f64], b: &[f64]) {
    r.par_chunks_mut(CHUNK).enumerate().for_each(|(t, rc)| {
        let base = t * CHUNK;
        for i in 0..rc.len() {
            rc[i] = b[base + i] - rc[i];
        }
    });
}

/// The largest Ritz value of `steps` Lanczos steps on `B⁻¹A` in the `B`
/// inner product (`pre = B⁻¹`) from a fixed start vector, without
/// reorthogonalisation (the extreme Ritz value converges first). With the
/// Lanczos vectors `q_k` and `p_k = B q_k`:
///
/// ```text
/// z = B⁻¹ v;  β = √(v·z);  q₀ = z/β;  p₀ = v/β;  β₀ = 0
/// w = A q_k − β_k p_{k−1};  α_k = w·q_k;  w = w − α_k p_k
/// z = B⁻¹ w;  β_{k+1} = √(w·z);  q_{k+1} = z/β_{k+1};  p_{k+1} = w/β_{k+1}
/// ```
/// and the top eigenvalue of the tridiagonal `(α, β)`
/// ([`tridiagonal_eigenvalue`]). Not `condition::lanczos`: that one keeps the
/// whole basis (full reorthogonalisation, Ritz vectors) for κ; a smoother
/// bound needs only the top Ritz value, so the three-term recurrence holds
/// a few vectors instead of `steps` at every level of the hierarchy.
fn largest_eigenvalue(op: &dyn LinearOperator, pre: &BlockJacobi, steps: usize) -> f64 {
    let n = op.nrows();
    // A fixed start with every entry non-zero and no grid-aligned pattern.
    let mut p: Vec<f64> = (0..n)
        .map(|i| 1.0 + 0.5 * ((i as f64 + 1.0) * 0.618_033_988_749_895).fract())
        .collect();
    let mut q = vec![0.0; n];
    pre.apply(&p, &mut q);
    let norm = dot(&p, &q).sqrt();
    scale(&mut p, 1.0 / norm);
    scale(&mut q, 1.0 / norm);
    let (mut p_prev, mut w, mut z) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let (mut diag, mut off2) = (Vec::new(), Vec::new());
    let mut beta = 0.0;
    for _ in 0..steps.min(n) {
        op.apply(&q, &mut w);
        for i in 0..n {
            w[i] -= beta * p_prev[i];
        }
        let alpha = dot(&w, &q);
        for i in 0..n {
            w[i] -= alpha * p[i];
        }
        diag.push(alpha);
        pre.apply(&w, &mut z);
        beta = dot(&w, &z).max(0.0).sqrt();
        if beta.is_nan() || beta <= 1e-12 * alpha.abs() {
            break;
        }
        off2.push(beta * beta);
        std::mem::swap(&mut p_prev, &mut p);
        for i in 0..n {
            p[i] = w[i] / beta;
            q[i] = z[i] / beta;
        }
    }
    off2.truncate(diag.len() - 1);
    tridiagonal_eigenvalue(&diag, &off2, diag.len() - 1)
}

/// `a · b`.
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `v = s v`.
fn scale(v: &mut [f64], s: f64) {
    for x in v.iter_mut() {
        *x *= s;
    }
}
