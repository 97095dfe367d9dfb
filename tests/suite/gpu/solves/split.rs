//! Arrays over several storage bindings, and device CG's breakdown.
//!
//! A binding of 4096 entries forced on the level-4 sphere (10 347 dofs)
//! splits every vector into 3 windows and the apply into ≥ 3 windows with
//! their halos: apply, dot, dot2 and (f64) a whole CGS solve then equal the
//! unsplit GPU run bitwise (the windows keep every sum in the same order)
//! and the CPU backend's (1e-12 relative for apply and dots, 1e-10 and ±2
//! iterations for the solve, as for the unsplit GPU).

use cgfem_gpu::backend::{Backend, CpuBackend, LinearOperator};
use cgfem_gpu::driver::linear::{CpuSolver, LinearSolver};
use cgfem_gpu::error::Error;
use cgfem_gpu::fem::operator::ElasticOperator;
use cgfem_gpu::gpu::linear::{GpuSolver, Scalars};
use cgfem_gpu::gpu::{context_or_skip, GpuBackend, GpuOperator, PrecisionChoice};
use cgfem_gpu::solver::{KrylovMethod, KrylovOptions, Preconditioner};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::{assert_close, random, sphere_with};

/// The forced binding, in entries: 32 KiB in f64, 16 KiB in f32.
const SPLIT_ENTRIES: u64 = 4096;

/// `y = A x` on `be`.
fn apply(be: &GpuBackend, op: &GpuOperator<'_>, x: &[f64]) -> Vec<f64> {
    let mut y = be.zeros(x.len());
    be.apply(op, &be.upload(x), &mut y);
    be.download(&y)
}

/// `(x·y, (x·y, x·x))` on `be`.
fn dots(be: &GpuBackend, x: &[f64], y: &[f64]) -> (f64, (f64, f64)) {
    let (gx, gy) = (be.upload(x), be.upload(y));
    (be.dot(&gx, &gy), be.dot2(&gx, &gy, &gx))
}

/// Own matrices in one chunk: the chunk passes are tested elsewhere, and one
/// pass per window keeps the sums in the unsplit order.
fn upload<'o>(be: &GpuBackend, op: &'o ElasticOperator) -> GpuOperator<'o> {
    GpuOperator::with_chunk_entries(be, op, u64::MAX).unwrap()
}

/// f64: split equals unsplit bitwise and the CPU (apply, dots, a CGS solve).
#[test]
fn split_bindings_give_the_unsplit_results_and_the_cpus() {
    let Some(ctx) = context_or_skip(PrecisionChoice::F64) else {
        return;
    };
    let (_, setup) = sphere_with(4, &[]);
    let op = &setup.op;
    let n = op.nrows();
    let whole = GpuBackend::new(ctx.clone());
    let split = GpuBackend::with_max_binding_bytes(ctx, SPLIT_ENTRIES * 8);
    let (op_whole, op_split) = (upload(&whole, op), upload(&split, op));
    let (x, y) = inputs(n, &split, &op_split);

    let a_split = apply(&split, &op_split, &x);
    assert_eq!(a_split, apply(&whole, &op_whole, &x), "apply: bitwise");
    let mut host = vec![0.0; n];
    op.apply(&x, &mut host);
    assert_close("split apply vs CPU", &a_split, &host, 1e-12);

    let d_split = dots(&split, &x, &y);
    assert_eq!(d_split, dots(&whole, &x, &y), "dot, dot2: bitwise");
    let cpu = CpuBackend::new();
    let mag: f64 = x.iter().zip(&y).map(|(a, b)| (a * b).abs()).sum();
    assert!((d_split.0 - cpu.dot(&x, &y)).abs() <= 1e-12 * mag);
    assert!((d_split.1 .1 - cpu.dot(&x, &x)).abs() <= 1e-12 * cpu.dot(&x, &x));

    // One whole CGS solve (Jacobi, device scalars) of A u = A x.
    let opts = KrylovOptions {
        method: KrylovMethod::Cgs,
        preconditioner: Preconditioner::Jacobi,
        rel_tol: 1e-10,
        max_iterations: 5000,
    };
    let solve = |solver: &mut dyn LinearSolver| {
        let mut u = vec![0.0; n];
        let stats = solver.solve(&host, &mut u, &opts).unwrap();
        (u, stats.iterations)
    };
    let (u_cpu, it_cpu) = solve(&mut CpuSolver::new(op));
    let (u_whole, it_whole) = solve(&mut GpuSolver::with_operator(
        whole,
        op_whole,
        Scalars::Device,
    ));
    let (u_split, it_split) = solve(&mut GpuSolver::with_operator(
        split,
        op_split,
        Scalars::Device,
    ));
    assert_eq!((&u_split, it_split), (&u_whole, it_whole), "solve: bitwise");
    assert_close("split solve vs CPU", &u_split, &u_cpu, 1e-10);
    assert!(it_split.abs_diff(it_cpu) <= 2, "{it_split} vs {it_cpu}");
}

/// f32: split apply and dots equal the unsplit ones bitwise (the unsplit f32
/// kernels are checked against their mirrors in `tests/suite/gpu/solves.rs`).
#[test]
fn split_bindings_give_the_unsplit_results_in_f32() {
    let Some(ctx) = context_or_skip(PrecisionChoice::F32) else {
        return;
    };
    let (_, setup) = sphere_with(4, &[]);
    let n = setup.op.nrows();
    let whole = GpuBackend::new(ctx.clone());
    let split = GpuBackend::with_max_binding_bytes(ctx, SPLIT_ENTRIES * 4);
    let (op_whole, op_split) = (upload(&whole, &setup.op), upload(&split, &setup.op));
    let (x, y) = inputs(n, &split, &op_split);
    let a_whole = apply(&whole, &op_whole, &x);
    assert_eq!(apply(&split, &op_split, &x), a_whole, "apply: bitwise");
    assert_eq!(dots(&split, &x, &y), dots(&whole, &x, &y), "dots: bitwise");
}

/// Seeded inputs, after checking that `be` splits vectors and `op` into at
/// least three windows each.
fn inputs(n: usize, be: &GpuBackend, op: &GpuOperator<'_>) -> (Vec<f64>, Vec<f64>) {
    let entries = be.bindings().vector_window(be.precision().bytes());
    assert!(
        n.div_ceil(entries) >= 3,
        "{n} entries in windows of {entries}"
    );
    assert!(op.windows() >= 3, "{} apply windows", op.windows());
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    (random(&mut rng, n), random(&mut rng, n))
}

/// The level-3 sphere's operator with a cut cell's matrix shifted by
/// `−shift · M_ref` (the reference vector mass): indefinite once the shift
/// outweighs the cell's stiffness.
fn indefinite(op: &ElasticOperator, shift: f64) -> ElasticOperator {
    let mut op = op.clone();
    let cell = op.own_cells()[op.own_cells().len() / 2];
    let h3 = op.grid.h.powi(3);
    op.add_cut_cell_mass(cell, -shift / h3);
    op
}

/// CG on an indefinite operator: the device detects `p·Ap ≤ 0` and reports
/// the same typed breakdown (exit code 3) at the same iteration as the CPU.
#[test]
fn device_cg_reports_the_breakdown_of_an_indefinite_operator() {
    let Some(ctx) = context_or_skip(PrecisionChoice::F64) else {
        return;
    };
    let (_, setup) = sphere_with(3, &[]);
    let opts = KrylovOptions {
        method: KrylovMethod::Cg,
        preconditioner: Preconditioner::None,
        rel_tol: 1e-10,
        max_iterations: 2000,
    };
    for shift in [1e7, 1e5] {
        let op = indefinite(&setup.op, shift);
        let n = op.nrows();
        let rhs = random(&mut ChaCha8Rng::seed_from_u64(3), n);
        let breakdown = |solver: &mut dyn LinearSolver| {
            let mut u = vec![0.0; n];
            match solver.solve(&rhs, &mut u, &opts) {
                Err(e @ Error::Breakdown { .. }) => e,
                other => panic!("shift {shift}: expected a breakdown, got {other:?}"),
            }
        };
        let cpu = breakdown(&mut CpuSolver::new(&op));
        let mut gpu_solver = GpuSolver::new(ctx.clone(), &op, Scalars::Device).unwrap();
        let gpu = breakdown(&mut gpu_solver);
        assert_eq!(gpu.exit_code(), 3);
        let (
            Error::Breakdown { iterations: ic, .. },
            Error::Breakdown {
                iterations: ig,
                what,
                ..
            },
        ) = (&cpu, &gpu)
        else {
            unreachable!()
        };
        assert!(
            what.contains("p·Ap") && what.contains("not positive definite"),
            "{gpu}"
        );
        assert!(
            ic.abs_diff(*ig) <= 2,
            "shift {shift}: cpu {cpu} vs gpu {gpu}"
        );
    }
}
