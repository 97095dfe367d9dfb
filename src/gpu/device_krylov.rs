//! CG, CGS and BiCGStab with their scalars on the device: ρ, σ, α, β (ω) live in
//! slots of the backend's scalar buffer, computed by the one-invocation kernel
//! `scalar_ratio` from the reductions of the same iteration; `krylov_check`
//! counts iterations and marks the solve done when `‖r‖² ≤ (τ ‖b‖)²`. The
//! host submits [`DeviceOptions::check_every`] iterations at a time and reads
//! back the slots from `done` to `‖r‖²` in one read between batches. Once
//! done, α = 0, so the iterations left in a batch leave `x` and `r` unchanged
//! and the iteration count is exactly the host-scalar path's.
//!
//! The algorithms are those of `crate::solver` (same formulas, same order of
//! operations, Jacobi right preconditioning for CGS, the `r`/`z` split for CG),
//! and [`solve_device`] runs them under the same driver
//! ([`crate::solver::drive`]: true residual around the cycles, restarts). A
//! breakdown is detected on the device by `scalar_ratio` (a zero `ρ` or `σ`;
//! for CG a `p·Ap` or `r·M⁻¹r` that is not positive), which records the
//! culprit for the host's [`Error::Breakdown`]; non-finite values show in the
//! `‖r‖²` read back. Not kept: the per-iteration residual history (one entry
//! per batch) and the Lanczos coefficients of CG.
//!
//! Where the operator runs on the Q1 plan and the vectors fit one binding,
//! CG's iteration is recorded in four dispatches instead of ten
//! ([`super::fused_cg`], [`DeviceOptions::fuse`]): the second passes of the
//! dots and the scalar kernels are folded into the kernels around them.
//! Otherwise the first iteration's dispatches are kept as recorded
//! (uniforms and bind groups included) and the next iterations replay them:
//! an iteration's dispatches and their slots are the same every time.

use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::solver::{breakdown, drive, Cycles, Precond};
use crate::solver::{KrylovMethod, KrylovOptions, KrylovStats, Preconditioner};

use super::backend::{GpuBackend, GpuVector};
use super::fused_cg::{CgSlots, FusedCg};
use super::kernels::{reduction_groups, Kernel, ScalParams};
use super::operator::GpuOperator;
use super::record::Step;

/// Slots of the device scalars (next to the backend's host slots 0..4).
const TOL2: u32 = 8;
const DONE: u32 = 9;
const ITERS: u32 = 10;
const RHO: u32 = 11;
const SIGMA: u32 = 12;
/// α and −α.
const ALPHA: u32 = 13;
const NALPHA: u32 = 14;
/// β (and −β, unused).
const BETA: u32 = 15;
/// `dot2` lands (‖r‖², ρ') here.
const RR: u32 = 17;
const RHO_NEXT: u32 = 18;
/// `scalar_ratio` records a breakdown's (num, den, out) here.
const BAD: u32 = 19;
/// The fused CG iteration's breakdown flag (`cg_update` to `cg_direction`).
const BROKE: u32 = 31;
/// BiCGStab: ω and −ω; ρ/ρ_prev and α/ω (each with its negative); ‖s‖²,
/// t·s and t·t.
const OMEGA: u32 = 22;
const NOMEGA: u32 = 23;
const RATIO_RHO: u32 = 24;
const RATIO_ALPHA: u32 = 26;
const SS: u32 = 28;
const TS: u32 = 29;
const TT: u32 = 30;

/// How often the host looks, and how CG's iteration is recorded.
#[derive(Clone, Copy, Debug)]
pub struct DeviceOptions {
    /// Iterations per submit between read-backs of the residual.
    pub check_every: usize,
    /// CG in four dispatches an iteration where the operator runs on the Q1
    /// plan and the vectors fit one window: `q1_cells`, `q1_nodes` with
    /// `p · Ap`'s partials, `cg_update` taking α from them, `cg_direction`
    /// (the dots' second passes and the scalar kernels folded in). `false`
    /// records the iteration kernel by kernel (the tests' reference).
    pub fuse: bool,
}

impl Default for DeviceOptions {
    fn default() -> Self {
        DeviceOptions {
            check_every: 8,
            fuse: true,
        }
    }
}

/// Solves `A x = b` with CG, CGS or BiCGStab, scalars on the device, from the
/// `x` given.
pub fn solve_device(
    be: &GpuBackend,
    op: &GpuOperator<'_>,
    diag: Option<&GpuVector>,
    b: &GpuVector,
    x: &mut GpuVector,
    opts: &KrylovOptions,
    dev: &DeviceOptions,
) -> Result<KrylovStats> {
    drive(be, op, b, x, opts, |b_norm| {
        Ok(Cycle {
            be,
            op,
            pre: Precond::new(be, op, diag, opts)?,
            n: be.nrows(op),
            b_norm,
            opts,
            every: dev.check_every.max(1),
            fuse: dev.fuse,
        })
    })
}

/// Runs exactly `iterations` iterations of CG or CGS (no preconditioner, no
/// convergence test) from `x`, for timing one iteration of the solver (the
/// benches); returns the last relative residual `‖r‖ / ‖b‖` it computed.
pub fn run_iterations(
    be: &GpuBackend,
    op: &GpuOperator<'_>,
    method: KrylovMethod,
    b: &GpuVector,
    x: &mut GpuVector,
    iterations: usize,
) -> f64 {
    let n = be.nrows(op);
    let opts = KrylovOptions {
        method,
        preconditioner: Preconditioner::None,
        rel_tol: f64::MIN_POSITIVE,
        max_iterations: iterations,
    };
    let b_norm = be.dot(b, b).sqrt();
    let cx = Cycle {
        be,
        op,
        pre: Precond::new(be, op, None, &opts).expect("no preconditioner"),
        n,
        b_norm,
        opts: &opts,
        every: iterations.max(1),
        fuse: true,
    };
    let mut r = be.zeros(n);
    be.apply(op, x, &mut r);
    be.xpay(b, -1.0, &mut r);
    let mut stats = KrylovStats::default();
    // A breakdown shows as a non-finite or stalled residual in the result.
    let _ = cx.cycle(x, &mut r, &mut stats);
    stats.relative_residual
}

/// `name = v` as a breakdown: not finite, or (`positive`) not positive
/// (worded like the host path's).
fn describe(name: &str, v: f64, positive: Option<&str>) -> String {
    match positive {
        _ if !v.is_finite() => format!("{name} is not finite ({v})"),
        Some(culprit) => format!("{name} = {v:e} ≤ 0: {culprit} is not positive definite"),
        None => format!("{name} = 0"),
    }
}

/// The slots of [`solve_device`]'s CG.
const CG_SLOTS: CgSlots = CgSlots {
    tol2: TOL2,
    done: DONE,
    iters: ITERS,
    rho: [RHO, RHO_NEXT],
    alpha: ALPHA,
    beta: BETA,
    rr: RR,
    bad: BAD,
    broke: BROKE,
};

/// What one cycle needs.
struct Cycle<'a, 'o> {
    be: &'a GpuBackend,
    op: &'a GpuOperator<'o>,
    pre: Precond<'a, GpuBackend>,
    n: usize,
    b_norm: f64,
    opts: &'a KrylovOptions,
    every: usize,
    fuse: bool,
}

/// The params of `scalar_ratio` / `krylov_check`; `positive` for CG.
fn scal_params(num: u32, den: u32, out: u32, roll: bool, positive: bool) -> ScalParams {
    ScalParams {
        num,
        den,
        out,
        roll: u32::from(roll),
        done: DONE,
        iters: ITERS,
        tol2: TOL2,
        positive: u32::from(positive),
        bad: BAD,
        ..Default::default()
    }
}

impl Cycles<GpuBackend> for Cycle<'_, '_> {
    fn cycle(&self, x: &mut GpuVector, r: &mut GpuVector, stats: &mut KrylovStats) -> Result<()> {
        self.run(x, r, stats)
    }

    fn floored_diagonal_entries(&self) -> usize {
        self.pre.floored()
    }
}

impl Cycle<'_, '_> {
    fn scalar(&self, enc: &mut wgpu::CommandEncoder, kernel: Kernel, p: ScalParams) {
        self.be.record_scalar(enc, kernel, &p);
    }

    /// The breakdown `scalar_ratio` recorded (its num, den, out).
    fn device_breakdown(&self, iterations: usize) -> Error {
        let s = self.be.read_slots(BAD, 3);
        let (num, den, alpha) = (s[0], s[1], s[2] == f64::from(ALPHA));
        let what = if self.opts.method == KrylovMethod::BiCgStab {
            let out = s[2] as u32;
            match out {
                ALPHA => describe("r̃·v", den, None),
                OMEGA if num == 0.0 => describe("ω = t·s / t·t", num, None),
                OMEGA => describe("t·t", den, None),
                _ => describe("ρ = r̃·r", if num == 0.0 { num } else { den }, None),
            }
        } else if self.opts.method == KrylovMethod::Cg {
            let (pre, op) = (Some("the preconditioner"), Some("the operator"));
            if alpha && (num > 0.0) {
                describe("p·Ap", den, op)
            } else {
                describe("r·M⁻¹r", num, pre)
            }
        } else if alpha && num != 0.0 {
            describe("σ = r̃·v", den, None)
        } else {
            describe("ρ = r̃·r", num, None)
        };
        breakdown(self.opts.method, iterations, what)
    }

    /// Records `z = M⁻¹ v` and returns the buffer holding `M⁻¹ v`.
    fn precond<'b>(
        &self,
        enc: &mut wgpu::CommandEncoder,
        v: &'b wgpu::Buffer,
        z: &'b wgpu::Buffer,
    ) -> &'b wgpu::Buffer {
        match self.pre.inverse_diagonal() {
            None => v,
            Some(inv) => {
                let bufs = [&inv.buf, v, z];
                self.be
                    .record_vec(enc, Kernel::PointwiseMul, self.n, (0, 0), &bufs);
                z
            }
        }
    }

    /// Runs one cycle from the true residual `r`: `Ok` when converged or
    /// out of iterations, the breakdown the device marked or a non-finite
    /// `‖r‖²`.
    fn run(&self, x: &mut GpuVector, r: &mut GpuVector, stats: &mut KrylovStats) -> Result<()> {
        let (be, n) = (self.be, self.n);
        let tol2 = (self.opts.rel_tol * self.b_norm).powi(2);
        be.write_slots(TOL2, &[tol2, 0.0, 0.0]);
        be.write_slots(BETA, &[0.0, 0.0]);
        be.write_slots(BROKE, &[0.0]);
        let z = self.pre.scratch(be, n);
        let (p, q, v) = (be.zeros(n), be.zeros(n), be.zeros(n));
        let method = self.opts.method;
        let cg = method == KrylovMethod::Cg;
        let rt = be.zeros(if cg { 0 } else { n });
        let u = match method {
            KrylovMethod::Cg => be.zeros(0),
            KrylovMethod::Cgs => be.zeros(n),
            KrylovMethod::BiCgStab => self.pre.scratch(be, n),
        };
        let mut enc = be.encoder();
        if !cg {
            be.record_vec(&mut enc, Kernel::Copy, n, (0, 0), &[&r.buf, &rt.buf]);
            be.record_dot(&mut enc, n, &[&r.buf, &rt.buf], RHO);
        }
        if method == KrylovMethod::BiCgStab {
            // ρ_prev = ρ, α = ω = 1: the first β is 1 and p = r (v = 0).
            be.record_dot(&mut enc, n, &[&r.buf, &rt.buf], RHO_NEXT);
            be.write_slots(ALPHA, &[1.0]);
            be.write_slots(OMEGA, &[1.0]);
        } else if cg {
            let zr = self.precond(&mut enc, &r.buf, &z.buf);
            be.record_vec(&mut enc, Kernel::Copy, n, (0, 0), &[zr, &p.buf]);
            be.record_dot(&mut enc, n, &[&r.buf, zr], RHO);
        }
        be.submit(enc);
        let fused = self.fused(method, x, r, [&p, &q, &z]);
        // The other iterations: the first one's dispatches, replayed.
        let mut tape: Option<Vec<Step>> = None;
        let start = stats.iterations;
        let mut k = 0;
        loop {
            let left = self.opts.max_iterations - stats.iterations;
            let mut enc = be.encoder();
            for _ in 0..self.every.min(left) {
                match (&fused, &tape) {
                    (Some(fused), _) => fused.record(be, &mut enc, k),
                    (None, Some(tape)) => be.replay(&mut enc, tape),
                    (None, None) => {
                        be.begin_capture();
                        match method {
                            KrylovMethod::Cg => self.cg_iteration(&mut enc, x, r, [&p, &q, &z]),
                            KrylovMethod::Cgs => {
                                self.cgs_iteration(&mut enc, x, r, [&rt, &u, &p, &q, &v, &z])
                            }
                            KrylovMethod::BiCgStab => {
                                let vecs = [&rt, &p, &v, &q, &z, &u];
                                self.bicgstab_iteration(&mut enc, x, r, vecs)
                            }
                        }
                        tape = Some(be.end_capture());
                    }
                }
                k += 1;
            }
            be.submit(enc);
            // One read-back per batch: DONE, ITERS … RR.
            let s = be.read_slots(DONE, RR - DONE + 1);
            let rr = s[(RR - DONE) as usize];
            stats.iterations = start + s[1] as usize;
            stats.relative_residual = rr.sqrt() / self.b_norm;
            stats.residual_history.push(stats.relative_residual);
            if s[0] == 2.0 {
                return Err(self.device_breakdown(stats.iterations));
            }
            if !rr.is_finite() {
                let what = format!("‖r‖² is not finite ({rr})");
                return Err(breakdown(self.opts.method, stats.iterations, what));
            }
            if s[0] != 0.0 || stats.iterations >= self.opts.max_iterations {
                return Ok(());
            }
        }
    }

    /// One CG iteration (see `crate::solver` for the formulas); the step
    /// `x += α p`, `r −= α q`, `z = M⁻¹ r` and its dots in one `cg_update`
    /// where the vectors fit one window.
    fn cg_iteration(
        &self,
        enc: &mut wgpu::CommandEncoder,
        x: &GpuVector,
        r: &GpuVector,
        [p, q, z]: [&GpuVector; 3],
    ) {
        let (be, n) = (self.be, self.n);
        self.op.record_apply(be, enc, &p.buf, &q.buf);
        be.record_dot(enc, n, &[&p.buf, &q.buf], SIGMA);
        self.scalar(
            enc,
            Kernel::ScalarRatio,
            scal_params(RHO, SIGMA, ALPHA, false, true),
        );
        let d = self.pre.inverse_diagonal().map(|inv| &inv.buf);
        let zr = if d.is_some() { &z.buf } else { &r.buf };
        let bufs = [&p.buf, &q.buf, &x.buf, &r.buf, &z.buf];
        if !be.record_cg_update(enc, n, bufs, d, (ALPHA, NALPHA), RR) {
            let s = &be.scal;
            be.record_vec(enc, Kernel::Axpy, n, (ALPHA, 0), &[s, &p.buf, &x.buf]);
            be.record_vec(enc, Kernel::Axpy, n, (NALPHA, 0), &[s, &q.buf, &r.buf]);
            self.precond(enc, &r.buf, &z.buf);
            be.record_dot(enc, n, &[&r.buf, &r.buf, zr], RR);
        }
        self.scalar(
            enc,
            Kernel::KrylovCheck,
            scal_params(RR, 0, 0, false, false),
        );
        self.scalar(
            enc,
            Kernel::ScalarRatio,
            scal_params(RHO_NEXT, RHO, BETA, true, true),
        );
        be.record_vec(enc, Kernel::Xpay, n, (BETA, 0), &[&be.scal, zr, &p.buf]);
    }

    /// CG's iteration in four dispatches over these vectors, where the
    /// operator runs on the Q1 plan and the vectors fit one window (and
    /// [`DeviceOptions::fuse`]); its partials: the plan's `q1_nodes`
    /// partials, then `cg_update`'s pairs.
    fn fused(
        &self,
        method: KrylovMethod,
        x: &GpuVector,
        r: &GpuVector,
        [p, q, z]: [&GpuVector; 3],
    ) -> Option<FusedCg> {
        let q1 = self.op.q1()?;
        let fits = self.n > 0 && self.n <= self.be.vector_window();
        if !(self.fuse && fits && method == KrylovMethod::Cg) {
            return None;
        }
        let len = q1.node_groups() + 2 * reduction_groups(self.n as u32);
        let partials = self.be.zeros(len as usize);
        let d = self.pre.inverse_diagonal().map(|inv| &inv.buf);
        let bufs = [&p.buf, &q.buf, &x.buf, &r.buf, &z.buf];
        let pb = &partials.buf;
        Some(FusedCg::new(self.be, q1, pb, &CG_SLOTS, self.n, bufs, d))
    }

    /// One CGS iteration (see `crate::solver` for the formulas).
    fn cgs_iteration(
        &self,
        enc: &mut wgpu::CommandEncoder,
        x: &GpuVector,
        r: &GpuVector,
        [rt, u, p, q, v, z]: [&GpuVector; 6],
    ) {
        let (be, n, s) = (self.be, self.n, &self.be.scal);
        let bufs = [s, &r.buf, &q.buf, &u.buf, &p.buf];
        be.record_vec(enc, Kernel::CgsUpdateUp, n, (BETA, 0), &bufs);
        let ph = self.precond(enc, &p.buf, &z.buf);
        self.op.record_apply(be, enc, ph, &v.buf);
        be.record_dot(enc, n, &[&rt.buf, &v.buf], SIGMA);
        self.scalar(
            enc,
            Kernel::ScalarRatio,
            scal_params(RHO, SIGMA, ALPHA, false, false),
        );
        let bufs = [s, &v.buf, &q.buf, &u.buf];
        be.record_vec(enc, Kernel::CgsUpdateQu, n, (ALPHA, 0), &bufs);
        let uh = self.precond(enc, &u.buf, &z.buf);
        be.record_vec(enc, Kernel::Axpy, n, (ALPHA, 0), &[s, uh, &x.buf]);
        self.op.record_apply(be, enc, uh, &v.buf);
        be.record_vec(enc, Kernel::Axpy, n, (NALPHA, 0), &[s, &v.buf, &r.buf]);
        be.record_dot(enc, n, &[&r.buf, &r.buf, &rt.buf], RR);
        self.scalar(
            enc,
            Kernel::KrylovCheck,
            scal_params(RR, 0, 0, false, false),
        );
        self.scalar(
            enc,
            Kernel::ScalarRatio,
            scal_params(RHO_NEXT, RHO, BETA, true, false),
        );
    }

    /// One BiCGStab iteration (see `crate::solver` for the formulas; `x`
    /// takes `α p̂` and `ω ŝ` in two steps). ρ_prev is in `RHO`, ρ in
    /// `RHO_NEXT`; the half step's check counts the iteration only when `‖s‖`
    /// meets the tolerance, and then ω = 0 leaves `x` and `r = s` as they are.
    fn bicgstab_iteration(
        &self,
        enc: &mut wgpu::CommandEncoder,
        x: &GpuVector,
        r: &GpuVector,
        [rt, p, v, t, zp, zs]: [&GpuVector; 6],
    ) {
        let (be, n, s) = (self.be, self.n, &self.be.scal);
        let ratio = |num, den, out, roll| scal_params(num, den, out, roll, false);
        self.scalar(
            enc,
            Kernel::ScalarRatio,
            ratio(RHO_NEXT, RHO, RATIO_RHO, true),
        );
        self.scalar(
            enc,
            Kernel::ScalarRatio,
            ratio(ALPHA, OMEGA, RATIO_ALPHA, false),
        );
        let beta = ScalParams {
            product: 1,
            ..ratio(RATIO_RHO, RATIO_ALPHA, BETA, false)
        };
        self.scalar(enc, Kernel::ScalarRatio, beta);
        let bufs = [s, &r.buf, &v.buf, &p.buf];
        be.record_vec(enc, Kernel::BicgstabUpdateP, n, (BETA, OMEGA), &bufs);
        let ph = self.precond(enc, &p.buf, &zp.buf);
        self.op.record_apply(be, enc, ph, &v.buf);
        be.record_dot(enc, n, &[&rt.buf, &v.buf], SIGMA);
        self.scalar(enc, Kernel::ScalarRatio, ratio(RHO, SIGMA, ALPHA, false));
        be.record_vec(enc, Kernel::Axpy, n, (NALPHA, 0), &[s, &v.buf, &r.buf]);
        be.record_vec(enc, Kernel::Axpy, n, (ALPHA, 0), &[s, ph, &x.buf]);
        be.record_dot(enc, n, &[&r.buf, &r.buf], SS);
        let half = ScalParams {
            early: 1,
            ..scal_params(SS, 0, 0, false, false)
        };
        self.scalar(enc, Kernel::KrylovCheck, half);
        let sh = self.precond(enc, &r.buf, &zs.buf);
        self.op.record_apply(be, enc, sh, &t.buf);
        be.record_dot(enc, n, &[&t.buf, &r.buf, &t.buf], TS);
        self.scalar(enc, Kernel::ScalarRatio, ratio(TS, TT, OMEGA, false));
        be.record_vec(enc, Kernel::Axpy, n, (OMEGA, 0), &[s, sh, &x.buf]);
        be.record_vec(enc, Kernel::Axpy, n, (NOMEGA, 0), &[s, &t.buf, &r.buf]);
        be.record_dot(enc, n, &[&r.buf, &r.buf, &rt.buf], RR);
        self.scalar(
            enc,
            Kernel::KrylovCheck,
            scal_params(RR, 0, 0, false, false),
        );
    }
}
