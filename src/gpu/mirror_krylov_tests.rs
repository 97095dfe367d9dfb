//! The fused CG iteration's mirrors (`q1_nodes` with its dot, `cg_update`
//! taking α from the partials, `cg_direction`) against the iteration kernel
//! by kernel (`dot`, `reduce`, `scalar_ratio`, `cg_update`, `krylov_check`,
//! `xpay`): the same iterates to round-off, the same count, the same
//! breakdown; the fused kernels on the device against these mirrors; and
//! device CG fused against CG kernel by kernel.

use super::device_krylov::{solve_device, DeviceOptions};
use super::fused_cg::{fused_params, CgSlots, FusedCg};
use super::kernels::{reduction_groups, RedParams, ScalParams};
use super::kernels::{UpdateParams, VecParams};
use super::mirror;
use super::mirror_krylov::{cg_direction, cg_update, krylov_check, scalar_ratio};
use super::q1_operator::Q1Arrays;
use super::{context_or_skip, GpuBackend, GpuOperator, Precision, PrecisionChoice};
use crate::backend::{Backend, LinearOperator};
use crate::driver::setup::Setup;
use crate::solver::{KrylovMethod, KrylovOptions, Preconditioner};

const TOL2: u32 = 0;
const DONE: u32 = 1;
const ITERS: u32 = 2;
const RHO: u32 = 3;
const SIGMA: u32 = 4;
const ALPHA: u32 = 5;
const BETA: u32 = 7;
const RR: u32 = 9;
const RHO_NEXT: u32 = 10;
const BAD: u32 = 11;
const BROKE: u32 = 14;
const SLOTS: CgSlots = CgSlots {
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

/// A small Q1 operator's plan (the sphere at level 3, S-term on).
struct Plan {
    setup: Setup,
    a: Q1Arrays,
    n: usize,
    diagonal: Vec<f64>,
}

/// `v` as the device holds it in `precision`.
fn as_device(precision: Precision, v: &[f64]) -> Vec<f64> {
    match precision {
        Precision::F64 => v.to_vec(),
        Precision::F32 => v.iter().map(|&x| x as f32 as f64).collect(),
    }
}

impl Plan {
    fn new() -> Plan {
        let path = format!("{}/cases/sphere.toml", env!("CARGO_MANIFEST_DIR"));
        let set = ["stabilisation.k2=0.01".to_string()];
        let case = crate::case::Case::from_file_with(std::path::Path::new(&path), &set).unwrap();
        let setup = Setup::new(&case, Some(3)).unwrap();
        let a = Q1Arrays::new(&setup.op).expect("a Q1 plan");
        Plan {
            n: setup.op.nrows(),
            diagonal: setup.op.diagonal(),
            a,
            setup,
        }
    }

    /// The plan's numbers as the device holds them in `precision`.
    fn rounded(mut self, precision: Precision) -> Plan {
        self.a.k_cells = as_device(precision, &self.a.k_cells);
        self.a.stencil = as_device(precision, &self.a.stencil);
        self
    }

    /// `y = A x`, and with `partials` the `q1_nodes` partials of `x · y`.
    fn apply(&self, x: &[f64], y: &mut [f64], partials: Option<&mut [f64]>) {
        let a = &self.a;
        let mut z = vec![0.0; a.z_len()];
        mirror::q1_cells(
            &a.params,
            &a.cell_nodes,
            &a.partial_of,
            &a.k_cells,
            x,
            &mut z,
        );
        let (segs, bnd, links) = (&a.segments, &a.boundary, &a.links);
        mirror::q1_nodes(&a.params, &a.stencil, segs, bnd, links, &z, x, y, partials);
    }

    fn node_groups(&self) -> u32 {
        let p = &self.a.params;
        p.n_segments + p.n_boundary.div_ceil(super::q1_terms::SEG as u32)
    }
}

/// CG's state: the device scalars and the vectors.
struct State {
    scal: Vec<f64>,
    x: Vec<f64>,
    r: Vec<f64>,
    z: Vec<f64>,
    p: Vec<f64>,
}

/// From `x = 0`: `r = b`, `z = d ∘ r`, `p = z`, `ρ = r · z` in `RHO`.
fn start(b: &[f64], d: &[f64], tol2: f64) -> State {
    let n = b.len();
    let z: Vec<f64> = b.iter().zip(d).map(|(r, d)| r * d).collect();
    let mut scal = vec![0.0; 16];
    scal[TOL2 as usize] = tol2;
    let groups = reduction_groups(n as u32);
    let mut partials = vec![0.0; groups as usize];
    let first = RedParams {
        n: n as u32,
        groups,
        comps: 1,
        total: groups,
        ..Default::default()
    };
    mirror::dot(&first, b, &z, &mut partials);
    let second = RedParams {
        n: groups,
        out: RHO,
        groups: 1,
        comps: 1,
        ..Default::default()
    };
    mirror::reduce(&second, &partials, &mut scal);
    State {
        scal,
        x: vec![0.0; n],
        r: b.to_vec(),
        p: z.clone(),
        z,
    }
}

/// One iteration kernel by kernel, as `device_krylov`'s unfused path records it.
fn unfused(plan: &Plan, d: &[f64], s: &mut State) {
    let n = plan.n;
    let groups = reduction_groups(n as u32);
    let mut q = vec![0.0; n];
    plan.apply(&s.p, &mut q, None);
    let red = |out, comps| RedParams {
        n: groups,
        out,
        groups: 1,
        comps,
        ..Default::default()
    };
    let mut partials = vec![0.0; 2 * groups as usize];
    let first = RedParams {
        n: n as u32,
        groups,
        comps: 1,
        total: groups,
        ..Default::default()
    };
    mirror::dot(&first, &s.p, &q, &mut partials);
    mirror::reduce(&red(SIGMA, 1), &partials, &mut s.scal);
    let ratio = ScalParams {
        done: DONE,
        iters: ITERS,
        tol2: TOL2,
        positive: 1,
        bad: BAD,
        ..Default::default()
    };
    let alpha = ScalParams {
        num: RHO,
        den: SIGMA,
        out: ALPHA,
        ..ratio
    };
    scalar_ratio(&alpha, &mut s.scal);
    let step = UpdateParams {
        n: n as u32,
        groups,
        ia: ALPHA,
        ib: ALPHA + 1,
        precond: 1,
        ..Default::default()
    };
    let (x, r, z) = (&mut s.x, &mut s.r, &mut s.z);
    cg_update(&step, &mut s.scal, &s.p, &q, d, x, r, z, &mut partials);
    mirror::reduce(&red(RR, 2), &partials, &mut s.scal);
    krylov_check(&ScalParams { num: RR, ..ratio }, &mut s.scal);
    let beta = ScalParams {
        num: RHO_NEXT,
        den: RHO,
        out: BETA,
        roll: 1,
        ..ratio
    };
    scalar_ratio(&beta, &mut s.scal);
    let xpay = VecParams {
        n: n as u32,
        ia: BETA,
        ib: 0,
        stride: 0,
    };
    mirror::xpay(&xpay, &s.scal, &s.z, &mut s.p);
}

/// Iteration `k` fused, as `device_krylov`'s fused path records it.
fn fused(plan: &Plan, d: &[f64], k: usize, s: &mut State) {
    let n = plan.n;
    let terms = plan.node_groups();
    let (step, direction) = fused_params(&SLOTS, k, n, terms, true);
    let mut partials = vec![0.0; (terms + 2 * step.groups) as usize];
    let mut q = vec![0.0; n];
    plan.apply(&s.p, &mut q, Some(&mut partials[..terms as usize]));
    let (x, r, z) = (&mut s.x, &mut s.r, &mut s.z);
    cg_update(&step, &mut s.scal, &s.p, &q, d, x, r, z, &mut partials);
    cg_direction(&direction, &mut s.scal, &partials, &s.z, &mut s.p);
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, a| m.max(a.abs()))
}

#[test]
fn fused_cg_mirrors_iterate_like_the_kernels_taken_apart() {
    let plan = Plan::new();
    let n = plan.n;
    let d: Vec<f64> = plan.diagonal.iter().map(|v| 1.0 / v).collect();
    let b: Vec<f64> = (0..n)
        .map(|i| ((i * 37) % 23) as f64 / 11.0 - 1.0)
        .collect();
    let bb: f64 = b.iter().map(|v| v * v).sum();
    // Converges within the 400 iterations (sets done = 1 and stops counting).
    let tol2 = 1e-16 * bb;
    let (mut a, mut f) = (start(&b, &d, tol2), start(&b, &d, tol2));
    let mut converged_at = None;
    for k in 0..400 {
        unfused(&plan, &d, &mut a);
        fused(&plan, &d, k, &mut f);
        let (da, df) = (a.scal[DONE as usize], f.scal[DONE as usize]);
        assert_eq!(da, df, "iteration {k}: done");
        assert_eq!(
            a.scal[ITERS as usize], f.scal[ITERS as usize],
            "iteration {k}"
        );
        if k < 20 || da == 0.0 {
            let dx: Vec<f64> = a.x.iter().zip(&f.x).map(|(u, v)| u - v).collect();
            assert!(max_abs(&dx) <= 1e-9 * max_abs(&a.x), "iteration {k}: x");
        }
        if da != 0.0 && converged_at.is_none() {
            converged_at = Some(k + 1);
        }
    }
    let iterations = converged_at.expect("CG converges on the sphere at level 3");
    assert_eq!(f.scal[ITERS as usize], iterations as f64);
    assert!(f.scal[RR as usize] <= tol2);
    // Once done the fused iteration leaves x and r as they are.
    let (x, r) = (f.x.clone(), f.r.clone());
    fused(&plan, &d, 400, &mut f);
    assert_eq!((f.x, f.r), (x, r));
}

#[test]
fn fused_cg_mirrors_report_the_breakdowns_of_the_kernels_taken_apart() {
    let plan = Plan::new();
    let n = plan.n;
    let b: Vec<f64> = (0..n)
        .map(|i| ((i * 37) % 23) as f64 / 11.0 - 1.0)
        .collect();
    // A negative preconditioner makes ρ = r · M⁻¹ r negative: the first α
    // breaks down, x stays 0 and the iteration is not counted.
    let d: Vec<f64> = plan.diagonal.iter().map(|v| -1.0 / v).collect();
    let (mut a, mut f) = (start(&b, &d, 0.0), start(&b, &d, 0.0));
    unfused(&plan, &d, &mut a);
    fused(&plan, &d, 0, &mut f);
    for s in [&a, &f] {
        assert_eq!(s.scal[DONE as usize], 2.0);
        assert_eq!(s.scal[ITERS as usize], 0.0);
        assert_eq!(s.scal[BAD as usize + 2], ALPHA as f64);
        assert!(s.scal[BAD as usize] < 0.0, "ρ recorded");
        assert_eq!(max_abs(&s.x), 0.0);
    }
    let rel = |u: f64, v: f64| (u - v).abs() <= 1e-12 * u.abs().max(v.abs());
    assert!(rel(a.scal[BAD as usize], f.scal[BAD as usize]));
    assert!(rel(a.scal[BAD as usize + 1], f.scal[BAD as usize + 1]));
}

/// `max |a − b| ≤ tol · max |b|` (or both zero).
fn assert_close(what: &str, a: &[f64], b: &[f64], tol: f64) {
    let diff: Vec<f64> = a.iter().zip(b).map(|(u, v)| u - v).collect();
    let (d, scale) = (max_abs(&diff), max_abs(b));
    assert!(
        d <= tol * scale,
        "{what}: max difference {d:e}, scale {scale:e}"
    );
}

/// The fused iteration's kernels on the device (`q1_cells`, `q1_nodes` with
/// its dot, `cg_update` with α from the partials, `cg_direction`) against
/// their mirrors, each iteration from the state the device holds (both
/// parities of ρ's slots), f64 and f32.
#[test]
fn fused_cg_kernels_match_their_mirrors_f64_and_f32() {
    for choice in [PrecisionChoice::F64, PrecisionChoice::F32] {
        let Some(ctx) = context_or_skip(choice) else {
            continue;
        };
        let precision = ctx.precision;
        let tol = match precision {
            Precision::F64 => 1e-12,
            Precision::F32 => 1e-5,
        };
        let be = GpuBackend::new(ctx);
        let plan = Plan::new();
        let gop = GpuOperator::new(&be, &plan.setup.op).unwrap();
        let q1 = gop.q1().expect("Q1 runs on its plan");
        let mirrored = Plan::new().rounded(precision);
        let n = plan.n;
        let inv: Vec<f64> = plan.diagonal.iter().map(|v| 1.0 / v).collect();
        let d = as_device(precision, &inv);
        let b: Vec<f64> = (0..n)
            .map(|i| ((i * 37) % 23) as f64 / 11.0 - 1.0)
            .collect();
        let s = start(&as_device(precision, &b), &d, 0.0);
        be.write_slots(0, &as_device(precision, &s.scal));
        let up = |v: &[f64]| be.upload(&as_device(precision, v));
        let (gx, gr, gz, gp, gd) = (up(&s.x), up(&s.r), up(&s.z), up(&s.p), up(&d));
        let gq = be.zeros(n);
        let len = plan.node_groups() + 2 * reduction_groups(n as u32);
        let partials = be.zeros(len as usize);
        let bufs = [&gp.buf, &gq.buf, &gx.buf, &gr.buf, &gz.buf];
        let pb = &partials.buf;
        let iteration = FusedCg::new(&be, q1, pb, &SLOTS, n, bufs, Some(&gd.buf));
        for k in 0..3 {
            let mut m = State {
                scal: be.read_slots(0, 16),
                x: be.download(&gx),
                r: be.download(&gr),
                z: be.download(&gz),
                p: be.download(&gp),
            };
            let mut enc = be.encoder();
            iteration.record(&be, &mut enc, k);
            be.submit(enc);
            fused(&mirrored, &d, k, &mut m);
            let what = |v: &str| format!("{precision:?} iteration {k}: {v}");
            assert_close(&what("x"), &be.download(&gx), &m.x, tol);
            assert_close(&what("r"), &be.download(&gr), &m.r, tol);
            assert_close(&what("z"), &be.download(&gz), &m.z, tol);
            assert_close(&what("p"), &be.download(&gp), &m.p, tol);
            let got = be.read_slots(0, 16);
            for slot in [ALPHA, BETA, RR, RHO, RHO_NEXT] {
                let (g, w) = (got[slot as usize], m.scal[slot as usize]);
                assert!(
                    (g - w).abs() <= tol * w.abs(),
                    "{}: {g} vs {w}",
                    what("slot")
                );
            }
            assert_eq!(
                got[DONE as usize],
                m.scal[DONE as usize],
                "{}",
                what("done")
            );
            assert_eq!(got[ITERS as usize], (k + 1) as f64, "{}", what("count"));
        }
    }
}

/// CG on the device, fused against kernel by kernel, with and without
/// Jacobi: the same iterations (±1: `p · Ap` is summed in another order)
/// and the same solution to the solve's tolerance.
#[test]
fn fused_device_cg_solves_like_cg_kernel_by_kernel() {
    let Some(ctx) = context_or_skip(PrecisionChoice::F64) else {
        return;
    };
    let be = GpuBackend::new(ctx);
    let plan = Plan::new();
    let gop = GpuOperator::new(&be, &plan.setup.op).unwrap();
    let n = plan.n;
    let b: Vec<f64> = (0..n)
        .map(|i| ((i * 37) % 23) as f64 / 11.0 - 1.0)
        .collect();
    let gb = be.upload(&b);
    let gd = be.upload(&plan.diagonal);
    for (pre, diag) in [
        (Preconditioner::Jacobi, Some(&gd)),
        (Preconditioner::None, None),
    ] {
        let opts = KrylovOptions {
            method: KrylovMethod::Cg,
            preconditioner: pre,
            rel_tol: 1e-10,
            max_iterations: 2000,
        };
        let solve = |fuse: bool| {
            let mut x = be.zeros(n);
            let dev = DeviceOptions {
                fuse,
                check_every: 1,
            };
            let stats = solve_device(&be, &gop, diag, &gb, &mut x, &opts, &dev).unwrap();
            (stats, be.download(&x))
        };
        let ((fs, fx), (us, ux)) = (solve(true), solve(false));
        let what = format!("{pre:?}: {} vs {} iterations", fs.iterations, us.iterations);
        assert!(fs.iterations.abs_diff(us.iterations) <= 1, "{what}");
        assert!(fs.relative_residual <= 1e-10, "{what}");
        assert_close(&what, &fx, &ux, 1e-8);
    }
}
