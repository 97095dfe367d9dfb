//! CG + multigrid on the GPU (the V-cycle on the device) against the CPU's:
//! every solve's iteration count within ±1, and the same answer: energy
//! errors equal to 1e-10 where the case has an exact field, the solution's
//! energy `uᵀAu` to 1e-10 where it has not. The sphere in Q1 at level 4,
//! in Q2 at level 3 and the bracket at level 4; in the long tier
//! (`CGFEM_LONG=1`) one level higher each (the Q2 sphere at level 4 takes
//! about a minute on lavapipe, where the Q2 operator runs on the gather).

use cgfem_gpu::backend::LinearOperator;
use cgfem_gpu::driver::fixed_point::FixedPointReport;
use cgfem_gpu::driver::linear::{CpuSolver, LinearSolver};
use cgfem_gpu::driver::setup::Setup;
use cgfem_gpu::driver::solve::solve_with;
use cgfem_gpu::gpu::linear::{GpuSolver, Scalars};
use cgfem_gpu::gpu::{context_or_skip, GpuBackend, PrecisionChoice};

use super::{case_with, solve_sphere};

/// `uᵀ A u` and the iterations per solve of the case's solve with `solver`.
fn energy_and_iterations(
    case: &cgfem_gpu::case::Case,
    setup: &Setup,
    solver: &mut dyn LinearSolver,
) -> (f64, Vec<usize>) {
    let mut report = FixedPointReport::default();
    let sol = solve_with(setup, &case.spec.solver, solver, &mut report).unwrap();
    let mut au = vec![0.0; sol.u.len()];
    setup.op.apply(&sol.u, &mut au);
    let energy = sol.u.iter().zip(&au).map(|(a, b)| a * b).sum();
    (energy, report.iterations_per_solve)
}

fn assert_within_one(what: &str, gpu: &[usize], cpu: &[usize]) {
    assert_eq!(gpu.len(), cpu.len(), "{what}: solves {gpu:?} vs {cpu:?}");
    for (a, b) in gpu.iter().zip(cpu) {
        assert!(a.abs_diff(*b) <= 1, "{what}: iterations {gpu:?} vs {cpu:?}");
    }
}

fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// The fast tier's level, one higher in the long tier (`CGFEM_LONG=1`).
fn level(fast: u32) -> u32 {
    fast + u32::from(std::env::var_os("CGFEM_LONG").is_some())
}

const MULTIGRID_CG: [&str; 2] = ["solver.method=cg", "solver.preconditioner=multigrid"];

/// The sphere `name` at `level` with CG + multigrid on the device and on the
/// CPU: iterations within one, energy errors equal to 1e-10.
fn sphere_like_on_the_cpu(name: &str, level: u32) {
    let Some(ctx) = context_or_skip(PrecisionChoice::F64) else {
        return;
    };
    let (case, setup) = case_with(name, level, &MULTIGRID_CG);
    let (_, it_cpu, _, e_cpu) = solve_sphere(&case, &setup, &mut CpuSolver::for_setup(&setup));
    let be = GpuBackend::new(ctx);
    let (mut gpu, _) = GpuSolver::for_setup(be, &setup, Scalars::Device, false).unwrap();
    let (_, it, res, e) = solve_sphere(&case, &setup, &mut gpu);
    let what = format!("{name} level {level}");
    assert_within_one(&what, &it, &it_cpu);
    assert!(res <= case.spec.solver.rel_tol, "{what}: residual {res:e}");
    let d = relative(e, e_cpu);
    assert!(
        d <= 1e-10,
        "{what}: energy error {e:e} vs {e_cpu:e} ({d:e})"
    );
}

#[test]
fn multigrid_cg_on_the_gpu_like_on_the_cpu_q1_sphere() {
    sphere_like_on_the_cpu("sphere", level(4));
}

#[test]
fn multigrid_cg_on_the_gpu_like_on_the_cpu_q2_sphere() {
    sphere_like_on_the_cpu("sphere_q2", level(3));
}

#[test]
fn multigrid_cg_on_the_gpu_like_on_the_cpu_bracket() {
    let Some(ctx) = context_or_skip(PrecisionChoice::F64) else {
        return;
    };
    let level = level(4);
    let (case, setup) = case_with("bracket", level, &MULTIGRID_CG);
    let (e_cpu, it_cpu) = energy_and_iterations(&case, &setup, &mut CpuSolver::for_setup(&setup));
    let (mut gpu, _) =
        GpuSolver::for_setup(GpuBackend::new(ctx), &setup, Scalars::Device, false).unwrap();
    let (e, it) = energy_and_iterations(&case, &setup, &mut gpu);
    let what = format!("bracket level {level}");
    assert_within_one(&what, &it, &it_cpu);
    let d = relative(e, e_cpu);
    assert!(d <= 1e-10, "{what}: uᵀAu {e:e} vs {e_cpu:e} ({d:e})");
}
