//! Q2 (hex27) on the GPU backend (lavapipe in CI): whole solves of
//! `cases/sphere_q2.toml` (S-term, CG with Jacobi, the fixed-point loop)
//! equal the CPU backend's to 1e-10 relative in f64. The GPU operator
//! handles Q2 through the generic node-centred gather kernel. Without an
//! adapter each test prints "skipped: no GPU adapter" and passes, unless
//! `CI=true` (then it fails): see `cgfem_gpu::gpu::context_or_skip`.

use cgfem_gpu::backend::LinearOperator;
use cgfem_gpu::case::physics::OuterMethod;
use cgfem_gpu::case::Case;
use cgfem_gpu::discrete::field::error_norms;
use cgfem_gpu::driver::fixed_point::FixedPointReport;
use cgfem_gpu::driver::linear::{CpuSolver, LinearSolver};
use cgfem_gpu::driver::setup::Setup;
use cgfem_gpu::driver::solve::solve_with;
use cgfem_gpu::fem::operator::ElasticOperator;
use cgfem_gpu::gpu::linear::{GpuSolver, Scalars};
use cgfem_gpu::gpu::{context_or_skip, PrecisionChoice};
use cgfem_gpu::solver::{KrylovOptions, KrylovStats};

fn sphere_q2(level: u32) -> (Case, Setup) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/cases/sphere_q2.toml");
    let mut case = Case::from_file_with(std::path::Path::new(path), &[]).unwrap();
    // Solve by solve against the CPU: the paper's loop runs the same sequence
    // of solves on both backends, whereas the flexible outer FGMRES turns
    // round-off differences of its loose inner solves into different (equally
    // converged) iterates. Both outer methods share the backend's solves.
    case.spec.solver.outer = OuterMethod::Picard;
    // The paper's S-term, whose fixed point contracts fastest in its loop.
    case.spec.stabilisation.balanced = Some(false);
    let setup = Setup::new(&case, Some(level)).unwrap();
    (case, setup)
}

/// The solution, the Krylov iterations per solve, the final true residual
/// and the relative energy error.
fn solve(
    case: &Case,
    setup: &Setup,
    solver: &mut dyn LinearSolver,
) -> (Vec<f64>, Vec<usize>, f64, f64) {
    let mut report = FixedPointReport::default();
    let sol = solve_with(setup, &case.spec.solver, solver, &mut report).unwrap();
    let exact = setup.problem.exact.as_ref().unwrap();
    let (l, m) = (setup.problem.lambda, setup.problem.mu);
    let (grid, cells, dofs) = (&setup.grid, &setup.cells, &setup.op.dofs);
    let e = error_norms(grid, cells, dofs, &sol.u, exact, l, m);
    (
        sol.u,
        report.iterations_per_solve,
        report.final_relative_residual,
        e.energy_relative,
    )
}

/// `max |a − b| / max |b|`.
fn max_relative_difference(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = b.iter().fold(1e-300f64, |m, v| m.max(v.abs()));
    let diff = a
        .iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    diff / scale
}

/// A CPU solver that keeps every system it is asked to solve (right-hand
/// side, initial guess, options) with its iteration count.
struct Recording<'a> {
    cpu: CpuSolver<'a>,
    systems: Vec<(Vec<f64>, Vec<f64>, KrylovOptions, usize)>,
}

impl LinearSolver for Recording<'_> {
    fn solve(
        &mut self,
        rhs: &[f64],
        u: &mut Vec<f64>,
        opts: &KrylovOptions,
    ) -> cgfem_gpu::error::Result<KrylovStats> {
        let start = u.clone();
        let stats = self.cpu.solve(rhs, u, opts)?;
        self.systems
            .push((rhs.to_vec(), start, opts.clone(), stats.iterations));
        Ok(stats)
    }
}

/// The operator applied by the node-centred gather, the CPU twin of the
/// device's Q2 apply: the CPU's own Q2 apply (stencils along runs) sums in
/// another order, and on this ill-conditioned system a CG + Jacobi solve
/// that ends on a plateau moves by several iterations under such round-off
/// (134 against 126 in the fourth system).
struct Gather<'a>(&'a ElasticOperator);

impl LinearOperator for Gather<'_> {
    fn nrows(&self) -> usize {
        self.0.nrows()
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.0.apply_gather(x, y);
    }

    fn diagonal(&self) -> Vec<f64> {
        self.0.diagonal()
    }
}

/// Level 2 (2,187 dofs), host and device scalars: the whole run gives the
/// same solution to 1e-10 and the same energy error; and each of the CPU
/// run's systems, solved again on the GPU from the same right-hand side and
/// initial guess, reaches the same tolerance (its true residual checked)
/// in at most the CPU's iterations plus 2. (Fewer is not a failure: the
/// fourth system ends on a plateau of its residual, where the dot products'
/// last bits decide the count. The GPU adds each workgroup's products in a
/// tree, the CPU adds them exactly (`cgfem_gpu::exact`): the GPU takes 126
/// iterations to a true residual of 3.9e-10, the CPU 134; before the CPU's
/// products were exact both took 126.) (The iterations of the two whole runs are not
/// compared solve by solve: each solve's right-hand side inherits the
/// round-off of the solves before it, and a CG + Jacobi solve that ends on
/// a plateau of its residual moves by several iterations under such
/// perturbations: with the S-term's constrained fits solved through the
/// Schur complement instead of an LU, which changes the recovered load in
/// the last digits, the GPU run's fourth solve took 134 iterations against
/// 126, while the CPU's counts moved by at most 1.)
/// Measured once at level 3 (12,099 dofs, host scalars, about 4 minutes of
/// lavapipe on two busy cores, too slow for CI): max relative difference
/// 1.3e-12, iterations within 1 per solve over 13 solves.
#[test]
fn q2_sphere_solves_on_the_gpu_in_f64_like_on_the_cpu() {
    let Some(ctx) = context_or_skip(PrecisionChoice::F64) else {
        return;
    };
    // The device's scalars (the default); the host's too in the long tier.
    let mut runs = vec![(2, Scalars::Device)];
    if std::env::var_os("CGFEM_LONG").is_some() {
        runs.push((2, Scalars::Host));
    }
    for (level, scalars) in runs {
        let (case, setup) = sphere_q2(level);
        let gather = Gather(&setup.op);
        let mut recording = Recording {
            cpu: CpuSolver::new(&gather),
            systems: Vec::new(),
        };
        let (u_cpu, it_cpu, _, e_cpu) = solve(&case, &setup, &mut recording);
        let mut gpu = GpuSolver::new(ctx.clone(), &setup.op, scalars).unwrap();
        let (u, it, res, e) = solve(&case, &setup, &mut gpu);
        let diff = max_relative_difference(&u, &u_cpu);
        println!(
            "level {level}, {scalars:?} scalars: max relative difference {diff:.2e}, energy {e:.6e} (CPU {e_cpu:.6e}), iterations {it:?} (CPU {it_cpu:?})"
        );
        assert!(diff <= 1e-10, "level {level}: {diff:e}");
        assert_eq!(it.len(), it_cpu.len(), "{it:?} vs {it_cpu:?}");
        assert!(res <= case.spec.solver.rel_tol, "residual {res:e}");
        assert!((e / e_cpu - 1.0).abs() < 1e-8);
        for (k, (rhs, start, opts, cpu_its)) in recording.systems.iter().enumerate() {
            let mut u_gpu = start.clone();
            let stats = gpu.solve(rhs, &mut u_gpu, opts).unwrap();
            println!(
                "  system {k}: GPU {} iterations, CPU {cpu_its}, true residual {:.2e}",
                stats.iterations, stats.true_relative_residual
            );
            assert!(stats.iterations <= cpu_its + 2, "system {k}");
            assert!(
                stats.true_relative_residual <= 2.0 * opts.rel_tol,
                "system {k}"
            );
        }
    }
}
