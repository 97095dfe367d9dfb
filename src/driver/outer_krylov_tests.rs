//! The outer FGMRES on `(A − R) U = F` with `A` the 7-point Laplacian of a
//! 6³ grid and `R U = θ λ_min(A) S U`, `S` a cyclic shift: `‖A⁻¹R‖ ≤ θ`, so
//! the paper's loop contracts at most by `θ` per iteration and, at `θ = 0.9`,
//! slowly. Inner solves are CG + Jacobi on the CPU to `inner_rel_tol`.

use super::*;
use crate::driver::fixed_point::fixed_point_with_progress;
use crate::driver::linear::CpuSolver;
use crate::progress::Silent;
use crate::solver::test_operators::{laplacian_extreme_eigenvalues, Stencil7};
use crate::solver::{KrylovMethod, KrylovOptions, Preconditioner};

const N: usize = 6;

fn norm(a: &[f64]) -> f64 {
    a.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn shifted(u: &[f64], theta: f64) -> Vec<f64> {
    let scale = theta * laplacian_extreme_eigenvalues(N).0;
    (0..u.len()).map(|i| scale * u[(i + 1) % u.len()]).collect()
}

fn options(tol: f64, max_iterations: usize) -> FixedPointOptions {
    FixedPointOptions {
        krylov: KrylovOptions {
            method: KrylovMethod::Cg,
            preconditioner: Preconditioner::Jacobi,
            rel_tol: 1e-12,
            max_iterations: 1000,
        },
        min_rel_tol: 1e-13,
        tol,
        max_iterations,
        inner_rel_tol: 1e-2,
    }
}

fn load() -> Vec<f64> {
    (0..N.pow(3))
        .map(|i| ((i * 7919) % 13) as f64 - 6.0)
        .collect()
}

/// `‖F − (A − R) U‖ / ‖F‖`, computed apart from the method.
fn true_residual(op: &Stencil7, f: &[f64], u: &[f64], theta: f64) -> f64 {
    let mut au = vec![0.0; u.len()];
    op.apply(u, &mut au);
    let ru = shifted(u, theta);
    let r: Vec<f64> = (0..u.len()).map(|i| f[i] - au[i] + ru[i]).collect();
    norm(&r) / norm(f)
}

fn run_fgmres(theta: f64, opts: &FixedPointOptions) -> (Result<Vec<f64>>, FixedPointReport) {
    let op = Stencil7::laplacian(N);
    let mut solver = CpuSolver::new(&op);
    let mut recovered = |u: &[f64]| -> Result<Vec<f64>> { Ok(shifted(u, theta)) };
    let mut report = FixedPointReport::default();
    let u = fgmres_fixed_point(
        &mut solver,
        &op,
        &load(),
        &mut recovered,
        opts,
        &mut report,
        &Silent,
    );
    (u, report)
}

#[test]
fn converges_to_the_true_residual_asked_for_with_loose_inner_solves() {
    let theta = 0.9;
    let (u, report) = run_fgmres(theta, &options(1e-10, 200));
    let u = u.unwrap();
    let r = true_residual(&Stencil7::laplacian(N), &load(), &u, theta);
    assert!(report.converged);
    assert!(r <= 1e-10 * 1.01, "true residual {r:e}");
    // The estimate it stopped on is the true residual (to round-off).
    assert!(
        (report.final_relative_residual - r).abs() <= 1e-12,
        "{report:?}"
    );
    assert_eq!(report.iterations, report.iterations_per_solve.len());
    assert!(report.tolerances.iter().all(|&t| t == 1e-2));
}

#[test]
fn reaches_the_paper_loops_answer_in_far_fewer_solves() {
    let theta = 0.9;
    let (u, report) = run_fgmres(theta, &options(1e-11, 200));
    let u = u.unwrap();
    let op = Stencil7::laplacian(N);
    let mut solver = CpuSolver::new(&op);
    let mut recovered = |u: &[f64]| -> Result<Vec<f64>> { Ok(shifted(u, theta)) };
    let mut picard = FixedPointReport::default();
    let v = fixed_point_with_progress(
        &mut solver,
        &load(),
        &mut recovered,
        &options(1e-12, 1000),
        &mut picard,
        &Silent,
    )
    .unwrap();
    let diff = u.iter().zip(&v).map(|(a, b)| (a - b).powi(2)).sum::<f64>();
    assert!(
        diff.sqrt() <= 1e-8 * norm(&v),
        "fgmres and picard differ by {:e}",
        diff.sqrt() / norm(&v)
    );
    assert!(
        3 * report.iterations_per_solve.len() < picard.iterations_per_solve.len(),
        "fgmres {} solves, picard {}",
        report.iterations_per_solve.len(),
        picard.iterations_per_solve.len()
    );
}

#[test]
fn restarts_keep_converging() {
    // θ = 0.9999 to 1e-13 needs more than one cycle of 20 directions.
    let theta = 0.9999;
    let op = Stencil7::laplacian(N);
    let mut solver = CpuSolver::new(&op);
    let mut recovered = |u: &[f64]| -> Result<Vec<f64>> { Ok(shifted(u, theta)) };
    let mut report = FixedPointReport::default();
    let opts = options(1e-13, 500);
    let u = Outer {
        solver: &mut solver,
        op: &op,
        recovered: &mut recovered,
        constant: Vec::new(),
        opts: &opts,
        report: &mut report,
        progress: &Silent,
        start: 0,
    }
    .solve(&load(), MIN_RESTART);
    assert!(report.iterations > MIN_RESTART, "{}", report.iterations);
    let r = true_residual(&op, &load(), &u.unwrap(), theta);
    assert!(r <= 1e-13 * 1.01, "true residual {r:e}");
    assert!(
        (report.final_relative_residual - r).abs() <= 1e-15,
        "{report:?}"
    );
}

#[test]
fn the_restart_length_fits_the_memory_bound() {
    assert_eq!(restart_length(216), MAX_RESTART);
    assert_eq!(restart_length(30_000_000), MIN_RESTART);
    let n = 500_000;
    let k = restart_length(n);
    assert!(k > MIN_RESTART && k < MAX_RESTART);
    assert!(2 * 8 * n * k <= BASIS_BYTES && 2 * 8 * n * (k + 1) > BASIS_BYTES);
}

#[test]
fn budget_and_zero_load() {
    let (u, report) = run_fgmres(0.9, &options(1e-14, 3));
    assert!(matches!(u, Err(Error::MaxIterations { iterations: 3, .. })));
    assert_eq!(report.iterations, 3);

    let op = Stencil7::laplacian(N);
    let mut solver = CpuSolver::new(&op);
    let mut recovered = |u: &[f64]| -> Result<Vec<f64>> { Ok(shifted(u, 0.9)) };
    let mut report = FixedPointReport::default();
    let zero = vec![0.0; N.pow(3)];
    let u = fgmres_fixed_point(
        &mut solver,
        &op,
        &zero,
        &mut recovered,
        &options(1e-10, 10),
        &mut report,
        &Silent,
    )
    .unwrap();
    assert_eq!(u, zero);
    assert!(report.converged && report.iterations == 0);
}
