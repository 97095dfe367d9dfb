//! The GPU backend on a real adapter (lavapipe in CI): every kernel against
//! its CPU mirror, in f64 and f32, and whole solves of `cases/sphere.toml`
//! against the CPU backend. Without an adapter each test prints "skipped: no
//! GPU adapter" and passes, unless `CI=true` (then it fails): see
//! `cgfem_gpu::gpu::context_or_skip`.

use std::sync::Arc;

use cgfem_gpu::backend::{Backend, LinearOperator};
use cgfem_gpu::case::Case;
use cgfem_gpu::discrete::field::error_norms;
use cgfem_gpu::driver::fixed_point::FixedPointReport;
use cgfem_gpu::driver::linear::{CpuSolver, LinearSolver};
use cgfem_gpu::driver::setup::Setup;
use cgfem_gpu::driver::solve::solve_with;
use cgfem_gpu::gpu::kernels::VecParams;
use cgfem_gpu::gpu::kernels::{reduction_groups, ApplyParams, Kernel, RedParams, ScalParams};
use cgfem_gpu::gpu::linear::{GpuSolver, Scalars};
use cgfem_gpu::gpu::{context_or_skip, mirror, mirror_krylov, GpuBackend, GpuContext, GpuOperator};
use cgfem_gpu::gpu::{Precision, PrecisionChoice};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

mod multigrid;
mod split;

const SIZES: [usize; 6] = [0, 1, 255, 257, 2049, 10_007];

fn random(rng: &mut ChaCha8Rng, n: usize) -> Vec<f64> {
    (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect()
}

/// `max |a − b| ≤ tol · max(max |b|, 1e-300)`.
fn assert_close(what: &str, a: &[f64], b: &[f64], tol: f64) {
    assert_eq!(a.len(), b.len(), "{what}: lengths");
    let scale = b.iter().fold(1e-300f64, |m, v| m.max(v.abs()));
    let diff = a
        .iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    assert!(
        diff <= tol * scale,
        "{what}: max difference {diff:e}, scale {scale:e}"
    );
}

fn tolerance(ctx: &GpuContext) -> f64 {
    match ctx.precision {
        Precision::F64 => 1e-13,
        Precision::F32 => 1e-5,
    }
}

/// Values as the device holds them (rounded to f32 in f32), so that the mirror
/// sees the same inputs.
fn as_device(ctx: &GpuContext, v: Vec<f64>) -> Vec<f64> {
    match ctx.precision {
        Precision::F64 => v,
        Precision::F32 => v.into_iter().map(|x| x as f32 as f64).collect(),
    }
}

fn vector_kernels_match_their_mirrors(ctx: Arc<GpuContext>) {
    let tol = tolerance(&ctx);
    let be = GpuBackend::new(ctx.clone());
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for n in SIZES {
        let mut v = || as_device(&ctx, random(&mut rng, n));
        let (x, y, z, w) = (v(), v(), v(), v());
        let (a, b) = (0.75, -1.25);
        let scal = [a, b];
        let prm = VecParams {
            n: n as u32,
            ia: 0,
            ib: 1,
            stride: 0,
        };
        let [gx, gy, gz] = [&x, &y, &z].map(|v| be.upload(v));
        let check = |what: &str, got: &cgfem_gpu::gpu::GpuVector, want: &[f64]| {
            assert_close(&format!("{what} n={n}"), &be.download(got), want, tol)
        };

        let (mut d, mut e) = (be.zeros(n), vec![0.0; n]);
        be.copy(&gx, &mut d);
        mirror::copy(&prm, &x, &mut e);
        check("copy", &d, &e);

        let (mut d, mut e) = (be.upload(&y), y.clone());
        be.scale(a, &mut d);
        mirror::scale(&prm, &scal, &mut e);
        check("scale", &d, &e);

        let (mut d, mut e) = (be.upload(&y), y.clone());
        be.axpy(a, &gx, &mut d);
        mirror::axpy(&prm, &scal, &x, &mut e);
        check("axpy", &d, &e);

        let (mut d, mut e) = (be.upload(&y), y.clone());
        be.xpay(&gx, a, &mut d);
        mirror::xpay(&prm, &scal, &x, &mut e);
        check("xpay", &d, &e);

        let (mut d, mut e) = (be.upload(&y), y.clone());
        be.axpy2(a, &gx, b, &gz, &mut d);
        mirror::axpy2(&prm, &scal, &x, &z, &mut e);
        check("axpy2", &d, &e);

        let (mut d, mut e) = (be.zeros(n), vec![0.0; n]);
        be.pointwise_mul(&gx, &gy, &mut d);
        mirror::pointwise_mul(&prm, &x, &y, &mut e);
        check("pointwise_mul", &d, &e);

        let (mut du, mut dp, mut eu, mut ep) = (be.upload(&z), be.upload(&w), z.clone(), w.clone());
        be.cgs_update_up(a, &gx, &gy, &mut du, &mut dp);
        mirror::cgs_update_up(&prm, &scal, &x, &y, &mut eu, &mut ep);
        check("cgs_update_up u", &du, &eu);
        check("cgs_update_up p", &dp, &ep);

        let (mut dq, mut du, mut eq, mut eu) = (be.upload(&z), be.upload(&w), z.clone(), w.clone());
        be.cgs_update_qu(a, &gx, &mut dq, &mut du);
        mirror::cgs_update_qu(&prm, &scal, &x, &mut eq, &mut eu);
        check("cgs_update_qu q", &dq, &eq);
        check("cgs_update_qu u", &du, &eu);

        let (mut d, mut e) = (be.upload(&w), w.clone());
        be.bicgstab_update_p(a, b, &gx, &gy, &mut d);
        mirror::bicgstab_update_p(&prm, &scal, &x, &y, &mut e);
        check("bicgstab_update_p", &d, &e);

        // Reductions: both passes mirrored.
        let groups = reduction_groups(n as u32);
        let first = RedParams {
            n: n as u32,
            out: 0,
            groups,
            comps: 2,
            total: groups,
            ..Default::default()
        };
        let second = RedParams {
            n: groups,
            out: 0,
            groups: 1,
            comps: 2,
            ..Default::default()
        };
        let mut partials = vec![0.0; 2 * groups as usize];
        let mut s = vec![0.0; 2];
        mirror::dot2(&first, &x, &y, &z, &mut partials);
        mirror::reduce(&second, &partials, &mut s);
        let (g1, g2) = be.dot2(&gx, &gy, &gz);
        // Relative to Σ|x y|, the scale of the rounding of a sum.
        let mag: f64 = x.iter().zip(&y).map(|(a, b)| (a * b).abs()).sum::<f64>() + 1e-300;
        assert!(
            (g1 - s[0]).abs() <= tol * mag,
            "dot2 n={n}: {g1} vs {}",
            s[0]
        );
        let mag2: f64 = x.iter().zip(&z).map(|(a, b)| (a * b).abs()).sum::<f64>() + 1e-300;
        assert!(
            (g2 - s[1]).abs() <= tol * mag2,
            "dot2 n={n}: {g2} vs {}",
            s[1]
        );
        mirror::dot(&RedParams { comps: 1, ..first }, &x, &y, &mut partials);
        mirror::reduce(&RedParams { comps: 1, ..second }, &partials, &mut s);
        let g = be.dot(&gx, &gy);
        assert!((g - s[0]).abs() <= tol * mag, "dot n={n}: {g} vs {}", s[0]);
    }
}

/// `cg_update` against its mirror (with and without a diagonal), and the
/// dots it reduces against `reduce` of the mirror's partials.
fn cg_update_matches_its_mirror(ctx: Arc<GpuContext>) {
    use cgfem_gpu::gpu::kernels::UpdateParams;
    let tol = tolerance(&ctx);
    let be = GpuBackend::new(ctx.clone());
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    for n in SIZES.into_iter().filter(|&n| n > 0) {
        let mut v = || as_device(&ctx, random(&mut rng, n));
        let (p, q, d, x, r) = (v(), v(), v(), v(), v());
        let alpha = as_device(&ctx, vec![0.625])[0];
        for precond in [false, true] {
            let (mut gx, mut gr, mut gz) = (be.upload(&x), be.upload(&r), be.zeros(n));
            let gd = be.upload(&d);
            let (gp, gq) = (be.upload(&p), be.upload(&q));
            let got = be.cg_update(
                alpha,
                &gp,
                &gq,
                precond.then_some(&gd),
                &mut gx,
                &mut gr,
                &mut gz,
            );
            let (g1, g2) = got.expect("one window");
            let groups = reduction_groups(n as u32);
            let prm = UpdateParams {
                n: n as u32,
                groups,
                ia: 0,
                ib: 1,
                precond: u32::from(precond),
                ..Default::default()
            };
            let (mut ex, mut er, mut ez) = (x.clone(), r.clone(), vec![0.0; n]);
            let mut partials = vec![0.0; 2 * groups as usize];
            let mut scal = [alpha, -alpha];
            mirror_krylov::cg_update(
                &prm,
                &mut scal,
                &p,
                &q,
                &d,
                &mut ex,
                &mut er,
                &mut ez,
                &mut partials,
            );
            let what = format!("cg_update n={n} precond={precond}");
            assert_close(&format!("{what}: x"), &be.download(&gx), &ex, tol);
            assert_close(&format!("{what}: r"), &be.download(&gr), &er, tol);
            if precond {
                assert_close(&format!("{what}: z"), &be.download(&gz), &ez, tol);
            }
            let second = RedParams {
                n: groups,
                groups: 1,
                comps: 2,
                ..Default::default()
            };
            let mut s = vec![0.0; 2];
            mirror::reduce(&second, &partials, &mut s);
            let zr = if precond { &ez } else { &er };
            let mag: f64 = er.iter().map(|a| a * a).sum::<f64>() + 1e-300;
            let mag2: f64 = er.iter().zip(zr).map(|(a, b)| (a * b).abs()).sum::<f64>() + 1e-300;
            assert!((g1 - s[0]).abs() <= tol * mag, "{what}: {g1} vs {}", s[0]);
            assert!((g2 - s[1]).abs() <= tol * mag2, "{what}: {g2} vs {}", s[1]);
        }
    }
}

#[test]
fn cg_update_matches_its_mirror_f64_and_f32() {
    for precision in [PrecisionChoice::F64, PrecisionChoice::F32] {
        if let Some(ctx) = context_or_skip(precision) {
            cg_update_matches_its_mirror(ctx);
        }
    }
}

#[test]
fn vector_kernels_match_their_mirrors_f64() {
    if let Some(ctx) = context_or_skip(PrecisionChoice::F64) {
        vector_kernels_match_their_mirrors(ctx);
    }
}

#[test]
fn vector_kernels_match_their_mirrors_f32() {
    if let Some(ctx) = context_or_skip(PrecisionChoice::F32) {
        vector_kernels_match_their_mirrors(ctx);
    }
}

#[test]
fn scalar_kernels_match_their_mirrors() {
    let Some(ctx) = context_or_skip(PrecisionChoice::F64) else {
        return;
    };
    let be = GpuBackend::new(ctx);
    let prm = ScalParams {
        num: 8,
        den: 9,
        out: 10,
        roll: 1,
        done: 12,
        iters: 13,
        tol2: 14,
        bad: 15,
        ..Default::default()
    };
    // (num, den, ‖r‖², done, positive, product, early): ratios, zero
    // divisors, CG's non-positive (and NaN) p·Ap, a done solve, products
    // (a zero factor is no breakdown), BiCGStab's half-step check met and not.
    for (num, den, rr, done, positive, product, early) in [
        (3.0, 4.0, 0.5, 0.0, 0, 0, 0),
        (1.0, 0.0, 2.0, 0.0, 0, 0, 0),
        (0.0, 3.0, 2.0, 0.0, 0, 0, 0),
        (1.0, -3.0, 2.0, 0.0, 0, 0, 0),
        (1.0, -3.0, 2.0, 0.0, 1, 0, 0),
        (-1.0, 3.0, 2.0, 0.0, 1, 0, 0),
        (1.0, f64::NAN, 2.0, 0.0, 1, 0, 0),
        (2.0, 5.0, 1.0, 1.0, 0, 0, 0),
        (3.0, -4.0, 0.5, 0.0, 0, 1, 1),
        (0.0, 4.0, 2.0, 0.0, 0, 1, 1),
        (3.0, 4.0, 0.5, 1.0, 0, 1, 0),
    ] {
        let prm = ScalParams {
            positive,
            product,
            early,
            ..prm
        };
        let init = [num, den, 7.0, 7.0, done, 3.0, 1.0, 0.0, 0.0, 0.0];
        let mut want = init.to_vec();
        be.write_slots(8, &init);
        be.scalar_kernel(Kernel::ScalarRatio, &prm);
        let mut m = vec![0.0; 8];
        m.extend_from_slice(&want);
        mirror_krylov::scalar_ratio(&prm, &mut m);
        let got = be.read_slots(8, 10);
        let what = format!("scalar_ratio {num}, {den} positive={positive} product={product}");
        assert_eq!(format!("{got:?}"), format!("{:?}", &m[8..]), "{what}");
        want.copy_from_slice(&m[8..]);
        want[0] = rr;
        be.write_slots(8, &want);
        let check = ScalParams { num: 8, ..prm };
        be.scalar_kernel(Kernel::KrylovCheck, &check);
        let mut m = vec![0.0; 8];
        m.extend_from_slice(&want);
        mirror_krylov::krylov_check(&check, &mut m);
        let got = be.read_slots(8, 10);
        assert_eq!(
            format!("{got:?}"),
            format!("{:?}", &m[8..]),
            "krylov_check rr={rr} early={early}"
        );
    }
}

#[test]
fn dispatch_in_2d_past_65535_workgroups() {
    let Some(ctx) = context_or_skip(PrecisionChoice::F32) else {
        return;
    };
    let be = GpuBackend::new(ctx);
    let n = 65_536 * 256 + 5;
    let x: Vec<f64> = (0..n).map(|i| (i % 1000) as f64).collect();
    let gx = be.upload(&x);
    let mut y = be.zeros(n);
    be.copy(&gx, &mut y);
    assert_eq!(be.download(&y), x);
    assert_eq!(be.dot(&gx, &gx), be.dot(&y, &y));
}

fn sphere(level: u32) -> (Case, Setup) {
    sphere_with(level, &[])
}

/// `cases/sphere.toml` on the paper's settings (CGS with Jacobi, no S-term;
/// `cgfem-gpu reproduce`'s), with `--set` overrides after them.
fn sphere_with(level: u32, set: &[&str]) -> (Case, Setup) {
    let mut paper = vec![
        "solver.method=cgs",
        "solver.preconditioner=jacobi",
        "solver.max_fixed_point=50",
        "stabilisation.k2=0",
        "stabilisation.A=0.01",
    ];
    paper.extend_from_slice(set);
    case_with("sphere", level, &paper)
}

/// `cases/<name>.toml` with `--set` overrides.
fn case_with(name: &str, level: u32, set: &[&str]) -> (Case, Setup) {
    let path = format!("{}/cases/{name}.toml", env!("CARGO_MANIFEST_DIR"));
    let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
    let case = Case::from_file_with(std::path::Path::new(&path), &set).unwrap();
    let setup = Setup::new(&case, Some(level)).unwrap();
    (case, setup)
}

#[test]
fn apply_matches_its_mirror_and_the_host_operator() {
    for precision in [PrecisionChoice::F64, PrecisionChoice::F32] {
        let Some(ctx) = context_or_skip(precision) else {
            return;
        };
        let tol = tolerance(&ctx);
        let be = GpuBackend::new(ctx.clone());
        // The shell octant's rollers add the partial-mask penalty to its
        // cut cells' matrices.
        for name in ["sphere", "shell_pressure"] {
            for (element, level) in [("q1", 3), ("q2", 2)] {
                let (_, setup) = case_with(name, level, &[&format!("element={element}")]);
                apply_matches(&ctx, &be, &setup, tol);
            }
        }
    }
}

fn apply_matches(ctx: &GpuContext, be: &GpuBackend, setup: &Setup, tol: f64) {
    let op = &setup.op;
    let n = op.nrows();
    let x = as_device(ctx, random(&mut ChaCha8Rng::seed_from_u64(9), n));
    let ne2 = op.dofs_per_cell().pow(2) as u64;
    for chunk in [u64::MAX, 7 * ne2] {
        let gop = GpuOperator::with_chunk_entries(be, op, chunk).unwrap();
        let mut y = be.zeros(n);
        be.apply(&gop, &be.upload(&x), &mut y);
        let y = be.download(&y);
        let mut want = vec![0.0; n];
        let prm = ApplyParams {
            n_active: op.dofs.num_active() as u32,
            ncx: op.grid.n[0] as u32,
            ncy: op.grid.n[1] as u32,
            ncz: op.grid.n[2] as u32,
            degree: op.dofs.order.degree() as u32,
            ne: op.dofs_per_cell() as u32,
            own_lo: 0,
            own_hi: op.own_cells().len() as u32,
            first: 1,
            ..Default::default()
        };
        let own = as_device(ctx, op.own_matrices().to_vec());
        let inside = as_device(ctx, op.inside_matrix().to_vec());
        let (a2n, n2a) = (&op.dofs.active_to_node, &op.dofs.node_to_active);
        mirror::apply(
            &prm,
            a2n,
            n2a,
            op.cell_slots(),
            &inside,
            &own,
            &x,
            &mut want,
        );
        assert_close(&format!("apply, {} chunks", gop.chunks()), &y, &want, tol);
        if chunk != u64::MAX {
            assert!(gop.chunks() > 2);
        }
        let mut host = vec![0.0; n];
        op.apply(&x, &mut host);
        assert_close("apply vs host", &y, &host, 10.0 * tol.max(1e-12));
    }
    q1_apply_matches(ctx, be, setup, &x, tol);
}

/// The Q1 plan (`q1_cells` then `q1_nodes`, which `GpuOperator::new` picks
/// for Q1) against its mirrors on the same data, and the host operator.
fn q1_apply_matches(ctx: &GpuContext, be: &GpuBackend, setup: &Setup, x: &[f64], tol: f64) {
    use cgfem_gpu::gpu::q1_operator::Q1Arrays;
    let op = &setup.op;
    let n = op.nrows();
    let gop = GpuOperator::new(be, op).unwrap();
    let Some(a) = Q1Arrays::new(op) else {
        assert!(op.fast_apply().q1().is_none(), "Q1 has its plan");
        assert!(gop.q1().is_none(), "Q2 runs on the gather");
        return;
    };
    assert_eq!(gop.q1().expect("Q1 runs on its plan").params(), a.params);
    let mut y = be.zeros(n);
    be.apply(&gop, &be.upload(x), &mut y);
    let y = be.download(&y);
    let k_cells = as_device(ctx, a.k_cells.clone());
    let stencil = as_device(ctx, a.stencil.clone());
    let mut z = vec![0.0; a.z_len()];
    mirror::q1_cells(&a.params, &a.cell_nodes, &a.partial_of, &k_cells, x, &mut z);
    let z = as_device(ctx, z);
    let mut want = vec![0.0; n];
    let (segs, bnd, links) = (&a.segments, &a.boundary, &a.links);
    mirror::q1_nodes(
        &a.params, &stencil, segs, bnd, links, &z, x, &mut want, None,
    );
    assert_close("q1 apply", &y, &want, tol);
    let mut host = vec![0.0; n];
    op.apply(x, &mut host);
    assert_close("q1 apply vs host", &y, &host, 10.0 * tol.max(1e-12));
}

/// Solves the sphere with `solver`; (u, iterations per solve, final true
/// residual, energy error).
fn solve_sphere(
    case: &Case,
    setup: &Setup,
    solver: &mut dyn LinearSolver,
) -> (Vec<f64>, Vec<usize>, f64, f64) {
    let mut report = FixedPointReport::default();
    let sol = solve_with(setup, &case.spec.solver, solver, &mut report).unwrap();
    let exact = setup.problem.exact.as_ref().unwrap();
    let (l, m) = (setup.problem.lambda, setup.problem.mu);
    let e = error_norms(
        &setup.grid,
        &setup.cells,
        &setup.op.dofs,
        &sol.u,
        exact,
        l,
        m,
    );
    (
        sol.u,
        report.iterations_per_solve,
        report.final_relative_residual,
        e.energy,
    )
}

fn assert_iterations_close(what: &str, a: &[usize], b: &[usize]) {
    assert_eq!(a.len(), b.len(), "{what}: number of solves {a:?} vs {b:?}");
    for (x, y) in a.iter().zip(b) {
        assert!(x.abs_diff(*y) <= 2, "{what}: iterations {a:?} vs {b:?}");
    }
}

/// Host scalars at level 3 (the generic solver on the GPU backend), device
/// scalars (the production path of Jacobi) at levels 3 and 4 (CGS and
/// BiCGStab; CG at level 3), and CGS at level
/// 5 (66 627 dofs, about 20 s on lavapipe) in the long tier (`CGFEM_LONG=1`).
#[test]
fn sphere_solves_on_the_gpu_in_f64_like_on_the_cpu() {
    let Some(ctx) = context_or_skip(PrecisionChoice::F64) else {
        return;
    };
    let mut runs = vec![
        (3, "cgs"),
        (4, "cgs"),
        (3, "cg"),
        (3, "bicgstab"),
        (4, "bicgstab"),
    ];
    if std::env::var_os("CGFEM_LONG").is_some() {
        runs.push((5, "cgs"));
    }
    for (level, method) in runs {
        let (case, setup) = sphere_with(level, &[&format!("solver.method={method}")]);
        let (u_cpu, it_cpu, _, _) = solve_sphere(&case, &setup, &mut CpuSolver::new(&setup.op));
        let scalars = match level {
            3 => vec![Scalars::Host, Scalars::Device],
            _ => vec![Scalars::Device],
        };
        for scalars in scalars {
            let mut gpu = GpuSolver::new(ctx.clone(), &setup.op, scalars).unwrap();
            let (u, it, res, _) = solve_sphere(&case, &setup, &mut gpu);
            let what = format!("level {level}, {method}, {scalars:?} scalars");
            assert_close(&what, &u, &u_cpu, 1e-10);
            assert_iterations_close(&what, &it, &it_cpu);
            assert!(res <= case.spec.solver.rel_tol, "{what}: residual {res:e}");
        }
    }
}

#[test]
fn sphere_solves_in_f32_with_defect_correction() {
    let Some(ctx) = context_or_skip(PrecisionChoice::F32) else {
        return;
    };
    assert_eq!(ctx.precision, Precision::F32);
    let (case, setup) = sphere(3);
    let (_, _, res_cpu, e_cpu) = solve_sphere(&case, &setup, &mut CpuSolver::new(&setup.op));
    let mut gpu = GpuSolver::new(ctx, &setup.op, Scalars::Device).unwrap();
    let (_, _, res, e) = solve_sphere(&case, &setup, &mut gpu);
    assert!(res <= case.spec.solver.rel_tol, "f32 residual {res:e}");
    assert!(
        (res.log10() - res_cpu.log10()).abs() <= 1.5,
        "residual order: f32 {res:e} vs f64 {res_cpu:e}"
    );
    assert!(
        (e - e_cpu).abs() <= 1e-6 * e_cpu,
        "energy error {e:e} vs {e_cpu:e}"
    );
}

/// The binary with no Vulkan driver visible (the loader finds no ICD).
fn cli_without_adapters(args: &[&str]) -> std::process::Output {
    let out = std::env::temp_dir().join(format!("cgfem-gpu-noadapter-{}", std::process::id()));
    let case = concat!(env!("CARGO_MANIFEST_DIR"), "/cases/sphere.toml");
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"));
    if args[0] == "run" {
        cmd.args(["run", case, "--level", "2", "--out", out.to_str().unwrap()]);
        cmd.args(&args[1..]);
    } else {
        cmd.args(args);
    }
    let o = cmd
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
        .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .env_remove("CGFEM_BACKEND")
        .env_remove("CGFEM_ADAPTER")
        .output()
        .unwrap();
    let _ = std::fs::remove_dir_all(&out);
    o
}

#[test]
fn without_an_adapter_gpu_exits_2_and_auto_falls_back_to_the_cpu() {
    let o = cli_without_adapters(&["run", "--backend", "gpu"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("no GPU adapter"), "{err}");

    let o = cli_without_adapters(&["run", "--backend", "auto"]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let notice: Vec<&str> = text.lines().filter(|l| l.contains("GPU")).collect();
    assert_eq!(notice.len(), 1, "one notice line: {text}");
    assert!(notice[0].contains("no GPU adapter") && notice[0].contains("solving on the CPU"));
    assert!(text.contains("backend cpu (f64)"), "{text}");

    let o = cli_without_adapters(&["run", "--backend", "cpu", "--precision", "f32"]);
    assert_eq!(o.status.code(), Some(2));

    let o = cli_without_adapters(&["info"]);
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stdout).contains("no GPU adapter found"));
}

/// `run` on the sphere at level 2 with the adapters the machine has; stdout.
fn cli_with_adapters(args: &[&str]) -> String {
    let out = std::env::temp_dir().join(format!(
        "cgfem-gpu-adapters-{}-{}",
        std::process::id(),
        args.join("-")
    ));
    let case = concat!(env!("CARGO_MANIFEST_DIR"), "/cases/sphere.toml");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"))
        .args(["run", case, "--level", "2", "--out", out.to_str().unwrap()])
        .args(args)
        .env_remove("CGFEM_BACKEND")
        .env_remove("CGFEM_ADAPTER")
        .output()
        .unwrap();
    let _ = std::fs::remove_dir_all(&out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// On a machine with no desktop session, a run that probes the adapters
/// prints no driver noise (Mesa's device-select layer is off).
#[test]
fn probing_adapters_without_a_desktop_session_prints_no_driver_errors() {
    if context_or_skip(PrecisionChoice::Auto).is_none() {
        return;
    }
    let out = std::env::temp_dir().join(format!("cgfem-gpu-quiet-{}", std::process::id()));
    let case = concat!(env!("CARGO_MANIFEST_DIR"), "/cases/sphere.toml");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"))
        .args([
            "-q",
            "run",
            case,
            "--level",
            "2",
            "--out",
            out.to_str().unwrap(),
        ])
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("NODEVICE_SELECT")
        .env_remove("CGFEM_BACKEND")
        .output()
        .unwrap();
    let _ = std::fs::remove_dir_all(&out);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(!stderr.contains("error"), "driver noise: {stderr}");
}

#[test]
fn auto_never_picks_a_software_adapter_unless_it_is_named() {
    let Some(ctx) = context_or_skip(PrecisionChoice::Auto) else {
        return;
    };
    let software = ctx.adapter.device_type == "Cpu";
    let auto = cli_with_adapters(&["--backend", "auto"]);
    let gpu = cli_with_adapters(&["--backend", "gpu"]);
    assert!(gpu.contains("backend gpu"), "{gpu}");
    if software {
        assert!(auto.contains("backend cpu (f64)"), "{auto}");
        assert!(auto.contains("not a software rasteriser"), "{auto}");
        let named = cli_with_adapters(&["--backend", "auto", "--adapter", &ctx.adapter.name]);
        assert!(named.contains("backend gpu"), "{named}");
    } else {
        assert!(auto.contains("backend gpu"), "{auto}");
    }
}

#[test]
fn info_lists_the_adapter_with_f64_and_limits() {
    if context_or_skip(PrecisionChoice::Auto).is_none() {
        return;
    }
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"))
        .arg("info")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success());
    for key in [
        "[0]",
        "f64:",
        "max storage binding",
        "workgroups per dimension",
    ] {
        assert!(text.contains(key), "{key} missing in: {text}");
    }
}
