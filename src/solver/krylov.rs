//! One cycle of each Krylov method, from a given true residual `r = b − A x`
//! until the recursive residual meets the tolerance or the iteration budget is
//! used up. [`super::solve`] checks the true residual around the cycles.
//!
//! Every scalar of an iteration is a function of the dot products of that
//! iteration, and dot products are batched with [`Backend::dot2`] where two are
//! needed of the same vector at the same point, so a GPU backend can keep them
//! on the device. CG takes `‖r‖²` before its preconditioner and `r·M⁻¹r`
//! after it, so that the converged iteration applies no preconditioner.

use crate::backend::Backend;
use crate::error::{Error, Result};

use super::{KrylovMethod, KrylovStats, Precond};

/// What a cycle needs besides its vectors.
pub(super) struct Problem<'a, 'o, B: Backend> {
    pub backend: &'a B,
    pub op: &'a B::Operator<'o>,
    pub pre: Precond<'a, B>,
    pub method: KrylovMethod,
    pub b_norm: f64,
    pub rel_tol: f64,
    pub max_iterations: usize,
}

/// The breakdown error of `method` at `iterations`.
pub(crate) fn breakdown(method: KrylovMethod, iterations: usize, what: String) -> Error {
    Error::Breakdown {
        method: method.name().into(),
        iterations,
        what,
    }
}

impl<B: Backend> Problem<'_, '_, B> {
    /// `value` if finite, else a breakdown naming `what`.
    pub fn finite(&self, value: f64, iterations: usize, what: &str) -> Result<f64> {
        if value.is_finite() {
            Ok(value)
        } else {
            let what = format!("{what} is not finite ({value})");
            Err(breakdown(self.method, iterations, what))
        }
    }

    /// `value` if finite and non-zero (a divisor), else a breakdown.
    fn divisor(&self, value: f64, iterations: usize, what: &str) -> Result<f64> {
        let v = self.finite(value, iterations, what)?;
        if v == 0.0 {
            Err(breakdown(self.method, iterations, format!("{what} = 0")))
        } else {
            Ok(v)
        }
    }

    /// `value` if finite and positive, else a breakdown blaming `culprit`.
    fn positive(&self, value: f64, iterations: usize, what: &str, culprit: &str) -> Result<f64> {
        let v = self.finite(value, iterations, what)?;
        if v > 0.0 {
            Ok(v)
        } else {
            let what = format!("{what} = {v:e} ≤ 0: {culprit} is not positive definite");
            Err(breakdown(self.method, iterations, what))
        }
    }

    /// Whether `‖r‖² = rr` meets the tolerance (computed as [`super::solve`]
    /// checks the true residual).
    fn converged(&self, rr: f64) -> bool {
        rr.sqrt() / self.b_norm <= self.rel_tol
    }

    /// Ends an iteration with residual `‖r‖² = rr`: counts it, records the
    /// relative residual, and says whether the cycle stops (converged or out of
    /// iterations).
    fn step(&self, stats: &mut KrylovStats, rr: f64) -> Result<bool> {
        stats.iterations += 1;
        let rr = self.finite(rr, stats.iterations, "‖r‖²")?;
        let rel = rr.sqrt() / self.b_norm;
        stats.relative_residual = rel;
        stats.residual_history.push(rel);
        Ok(self.converged(rr) || stats.iterations >= self.max_iterations)
    }
}

/// Preconditioned conjugate gradients (Saad, Alg. 9.1), `M` SPD:
///
/// ```text
/// z = M⁻¹ r;  p = z;  ρ = r·z
/// repeat
///     q = A p;  σ = p·q                (σ ≤ 0: A not SPD)
///     α = ρ / σ
///     x = x + α p;  r = r − α q
///     stop on ‖r‖ (before the preconditioner, whose last `M⁻¹ r` the loop
///     would not use)
///     z = M⁻¹ r;  ρ' = r·z                (ρ' ≤ 0: M not SPD)
///     β = ρ' / ρ;  ρ = ρ'
///     p = z + β p
/// ```
///
/// `r` stays the unpreconditioned residual. The `α_k`, `β_k` are recorded in
/// [`KrylovStats::lanczos`]: the Lanczos tridiagonal of `M⁻¹A` is
/// `T_kk = 1/α_k + β_{k−1}/α_{k−1}`, `T_{k,k+1} = √β_k / α_k`.
pub(super) fn cg<B: Backend>(
    pb: &Problem<'_, '_, B>,
    x: &mut B::Vector,
    r: &mut B::Vector,
    stats: &mut KrylovStats,
) -> Result<()> {
    let (be, n) = (pb.backend, pb.backend.len(r));
    let (mut p, mut q, mut z) = (be.zeros(n), be.zeros(n), pb.pre.scratch(be, n));
    let (mut alphas, mut betas) = (Vec::new(), Vec::new());
    let zr = pb.pre.apply(be, r, &mut z);
    be.copy(zr, &mut p);
    let pre_spd = "the preconditioner";
    let mut rho = pb.positive(be.dot(r, zr), stats.iterations, "r·M⁻¹r", pre_spd)?;
    loop {
        be.apply(pb.op, &p, &mut q);
        let sigma = pb.positive(be.dot(&p, &q), stats.iterations, "p·Ap", "the operator")?;
        let alpha = rho / sigma;
        alphas.push(alpha);
        be.axpy(alpha, &p, x);
        be.axpy(-alpha, &q, r);
        // Stop before the preconditioner: the last iteration's `M⁻¹ r` (a
        // V-cycle with multigrid) would not be used.
        if pb.step(stats, be.dot(r, r))? {
            break;
        }
        let zr = pb.pre.apply(be, r, &mut z);
        let rho_next = be.dot(r, zr);
        let rho_next = pb.positive(rho_next, stats.iterations, "r·M⁻¹r", pre_spd)?;
        let beta = rho_next / rho;
        betas.push(beta);
        rho = rho_next;
        be.xpay(zr, beta, &mut p);
    }
    stats.lanczos = Some((alphas, betas));
    Ok(())
}

/// Conjugate gradient squared with right preconditioning (Sonneveld 1989; the
/// preconditioned form of Barrett et al., *Templates*, Fig. 2.9), solving
/// `A M⁻¹ y = b`, `x = M⁻¹ y`, so that `r` is the true residual `b − A x`:
///
/// ```text
/// r̃ = r;  ρ = r̃·r;  q = p = 0
/// repeat
///     (ρ = 0: breakdown)  β = ρ / ρ_prev    (q = p = 0 at first: β immaterial)
///     u = r + β q;  p = u + β (q + β p)     cgs_update_up
///     v = A M⁻¹ p;  σ = r̃·v                 (σ = 0: breakdown)
///     α = ρ / σ
///     q = u − α v;  u = u + q               cgs_update_qu
///     û = M⁻¹ u
///     x = x + α û;  r = r − α A û
///     (‖r‖², ρ') = (r·r, r·r̃)               stop on ‖r‖
///     ρ_prev = ρ;  ρ = ρ'
/// ```
///
/// Vectors: `r, r̃, u, p, q, v` and one preconditioner scratch (`M⁻¹p`, then
/// `M⁻¹u`); `v` holds `A M⁻¹ p`, then `A û`.
pub(super) fn cgs<B: Backend>(
    pb: &Problem<'_, '_, B>,
    x: &mut B::Vector,
    r: &mut B::Vector,
    stats: &mut KrylovStats,
) -> Result<()> {
    let (be, n) = (pb.backend, pb.backend.len(r));
    let mut rt = be.zeros(n);
    be.copy(r, &mut rt);
    let (mut u, mut p, mut q, mut v) = (be.zeros(n), be.zeros(n), be.zeros(n), be.zeros(n));
    let mut z = pb.pre.scratch(be, n);
    let mut rho = pb.finite(be.dot(r, &rt), stats.iterations, "ρ = r̃·r")?;
    let mut rho_prev = rho;
    loop {
        let rho_now = pb.divisor(rho, stats.iterations, "ρ = r̃·r")?;
        let beta = rho_now / pb.divisor(rho_prev, stats.iterations, "ρ = r̃·r")?;
        be.cgs_update_up(beta, r, &q, &mut u, &mut p);
        let ph = pb.pre.apply(be, &p, &mut z);
        be.apply(pb.op, ph, &mut v);
        let alpha = rho_now / pb.divisor(be.dot(&rt, &v), stats.iterations, "σ = r̃·v")?;
        be.cgs_update_qu(alpha, &v, &mut q, &mut u);
        let uh = pb.pre.apply(be, &u, &mut z);
        be.axpy(alpha, uh, x);
        be.apply(pb.op, uh, &mut v);
        be.axpy(-alpha, &v, r);
        let (rr, rho_next) = be.dot2(r, r, &rt);
        if pb.step(stats, rr)? {
            return Ok(());
        }
        rho_prev = rho_now;
        rho = pb.finite(rho_next, stats.iterations, "ρ = r̃·r")?;
    }
}

/// BiCGStab with right preconditioning (van der Vorst 1992; *Templates*,
/// Fig. 2.10), so that `r` is the true residual `b − A x`:
///
/// ```text
/// r̃ = r;  ρ = r̃·r;  p = v = 0;  α = ω = 1;  ρ_prev = ρ
/// repeat
///     (ρ = 0: breakdown)  β = (ρ / ρ_prev)(α / ω)
///     p = r + β (p − ω v)                   bicgstab_update_p
///     p̂ = M⁻¹ p;  v = A p̂;  α = ρ / (r̃·v)   (r̃·v = 0: breakdown)
///     s = r − α v                            (in place in r)
///     if ‖s‖ meets the tolerance: x = x + α p̂, stop
///     ŝ = M⁻¹ s;  t = A ŝ;  (t·s, t·t)       (t·t = 0 or ω = 0: breakdown)
///     ω = t·s / t·t
///     x = x + α p̂ + ω ŝ                      axpy2
///     r = s − ω t;  (‖r‖², ρ') = (r·r, r·r̃)  stop on ‖r‖
///     ρ_prev = ρ;  ρ = ρ'
/// ```
pub(super) fn bicgstab<B: Backend>(
    pb: &Problem<'_, '_, B>,
    x: &mut B::Vector,
    r: &mut B::Vector,
    stats: &mut KrylovStats,
) -> Result<()> {
    let (be, n) = (pb.backend, pb.backend.len(r));
    let mut rt = be.zeros(n);
    be.copy(r, &mut rt);
    let (mut p, mut v, mut t) = (be.zeros(n), be.zeros(n), be.zeros(n));
    let (mut zp, mut zs) = (pb.pre.scratch(be, n), pb.pre.scratch(be, n));
    let mut rho = pb.finite(be.dot(r, &rt), stats.iterations, "ρ = r̃·r")?;
    let (mut rho_prev, mut alpha, mut omega) = (rho, 1.0, 1.0);
    loop {
        let it = stats.iterations;
        let rho_now = pb.divisor(rho, it, "ρ = r̃·r")?;
        let beta = (rho_now / pb.divisor(rho_prev, it, "ρ = r̃·r")?) * (alpha / omega);
        be.bicgstab_update_p(beta, omega, r, &v, &mut p);
        let ph = pb.pre.apply(be, &p, &mut zp);
        be.apply(pb.op, ph, &mut v);
        alpha = rho_now / pb.divisor(be.dot(&rt, &v), it, "r̃·v")?;
        be.axpy(-alpha, &v, r);
        let ss = pb.finite(be.dot(r, r), it, "‖s‖²")?;
        if pb.converged(ss) {
            be.axpy(alpha, ph, x);
            pb.step(stats, ss)?;
            return Ok(());
        }
        let sh = pb.pre.apply(be, r, &mut zs);
        be.apply(pb.op, sh, &mut t);
        let (ts, tt) = be.dot2(&t, r, &t);
        omega = pb.finite(ts, it, "t·s")? / pb.divisor(tt, it, "t·t")?;
        pb.divisor(omega, it, "ω")?;
        be.axpy2(alpha, ph, omega, sh, x);
        be.axpy(-omega, &t, r);
        let (rr, rho_next) = be.dot2(r, r, &rt);
        if pb.step(stats, rr)? {
            return Ok(());
        }
        rho_prev = rho_now;
        rho = pb.finite(rho_next, stats.iterations, "ρ = r̃·r")?;
    }
}
