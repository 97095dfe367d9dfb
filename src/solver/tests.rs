//! Tests of the Krylov solvers on the CPU backend with the operators of
//! [`super::test_operators`].

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::test_operators::{laplacian_extreme_eigenvalues, Faulty, Scaled, Stencil7};
use super::*;
use crate::backend::{CpuBackend, LinearOperator};

const METHODS: [KrylovMethod; 3] = [KrylovMethod::Cg, KrylovMethod::Cgs, KrylovMethod::BiCgStab];
const PRECONDITIONERS: [Preconditioner; 2] = [Preconditioner::None, Preconditioner::Jacobi];

fn random(n: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect()
}

fn options(method: KrylovMethod, pre: Preconditioner, rel_tol: f64) -> KrylovOptions {
    KrylovOptions {
        method,
        preconditioner: pre,
        rel_tol,
        max_iterations: 2000,
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|a| a * a).sum::<f64>().sqrt()
}

fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    norm(&d) / norm(b)
}

/// `b = A x*` for a random `x*`: returns `(x*, b)`.
fn manufactured(op: &dyn LinearOperator, seed: u64) -> (Vec<f64>, Vec<f64>) {
    let xs = random(op.nrows(), seed);
    let mut b = vec![0.0; op.nrows()];
    op.apply(&xs, &mut b);
    (xs, b)
}

/// Solves `op x = b` from `x = 0`.
fn run(
    op: &dyn LinearOperator,
    b: &[f64],
    opts: &KrylovOptions,
) -> (Vec<f64>, Result<KrylovStats>) {
    let mut x = vec![0.0; b.len()];
    let res = solve(&CpuBackend::new(), op, None, &b.to_vec(), &mut x, opts);
    (x, res)
}

/// Iterations of a solve whether it converged or ran out of its budget.
fn iterations(res: &Result<KrylovStats>) -> usize {
    match res {
        Ok(stats) => stats.iterations,
        Err(Error::MaxIterations { iterations, .. }) => *iterations,
        Err(e) => panic!("unexpected error: {e}"),
    }
}

/// Solves with a manufactured solution and checks the solution and residuals.
fn check_manufactured(op: &dyn LinearOperator, method: KrylovMethod, pre: Preconditioner) {
    let tol = 1e-10;
    let (xs, b) = manufactured(op, 11);
    let (x, res) = run(op, &b, &options(method, pre, tol));
    let stats = res.unwrap_or_else(|e| panic!("{method}/{pre:?}: {e}"));
    let err = rel_diff(&x, &xs);
    assert!(stats.iterations > 0, "{method}/{pre:?}: no iterations");
    assert!(
        stats.true_relative_residual <= tol,
        "{method}/{pre:?}: {stats:?}"
    );
    assert!(
        stats.relative_residual <= 10.0 * tol,
        "{method}/{pre:?}: {stats:?}"
    );
    assert!(err <= 1e-8, "{method}/{pre:?}: solution error {err:e}");
    let mut r = vec![0.0; b.len()];
    op.apply(&x, &mut r);
    let true_rel = rel_diff(&r, &b);
    assert!((true_rel - stats.true_relative_residual).abs() <= 1e-3 * true_rel);
}

/// `D A D` with `D` random in `[0.5, 2]`: a non-constant diagonal, so that
/// Jacobi is not a mere multiple of the identity.
fn mildly_scaled(inner: Stencil7) -> Scaled<Stencil7> {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let d = (0..inner.nrows())
        .map(|_| rng.gen_range(0.5..2.0))
        .collect();
    Scaled { inner, d }
}

#[test]
fn every_method_and_preconditioner_solves_the_laplacian() {
    let plain = Stencil7::laplacian(10);
    let scaled = mildly_scaled(Stencil7::laplacian(10));
    for method in METHODS {
        for pre in PRECONDITIONERS {
            check_manufactured(&plain, method, pre);
            check_manufactured(&scaled, method, pre);
        }
    }
}

#[test]
fn cgs_and_bicgstab_solve_convection_diffusion() {
    let plain = Stencil7::convection_diffusion(10, [1.0, 0.5, 0.25]);
    let scaled = mildly_scaled(Stencil7::convection_diffusion(10, [1.0, 0.5, 0.25]));
    for method in [KrylovMethod::Cgs, KrylovMethod::BiCgStab] {
        for pre in PRECONDITIONERS {
            check_manufactured(&plain, method, pre);
            check_manufactured(&scaled, method, pre);
        }
    }
}

#[test]
fn cg_iterations_within_the_condition_number_bound() {
    let (n, tol) = (20, 1e-10);
    let op = Stencil7::laplacian(n);
    let (_, b) = manufactured(&op, 12);
    let (_, res) = run(
        &op,
        &b,
        &options(KrylovMethod::Cg, Preconditioner::None, tol),
    );
    let stats = res.unwrap();
    let (lmin, lmax) = laplacian_extreme_eigenvalues(n);
    let bound = 0.5 * (lmax / lmin).sqrt() * (2.0 / tol).ln() + 1.0;
    assert!(
        stats.iterations as f64 <= bound,
        "{} > {bound}",
        stats.iterations
    );
    assert!(stats.iterations >= 10, "suspiciously few iterations");
}

#[test]
fn lanczos_estimate_from_cg_matches_exact_extreme_eigenvalues() {
    let n = 16;
    let op = Stencil7::laplacian(n);
    let (_, b) = manufactured(&op, 13);
    let (_, res) = run(
        &op,
        &b,
        &options(KrylovMethod::Cg, Preconditioner::None, 1e-12),
    );
    let (alphas, betas) = res.unwrap().lanczos.expect("CG records its coefficients");
    let (est_min, est_max) = lanczos_extreme_eigenvalues(&alphas, &betas);
    let (lmin, lmax) = laplacian_extreme_eigenvalues(n);
    assert!(
        (est_min / lmin - 1.0).abs() <= 0.01,
        "λmin {est_min} vs {lmin}"
    );
    assert!(
        (est_max / lmax - 1.0).abs() <= 0.01,
        "λmax {est_max} vs {lmax}"
    );
    // Ritz values lie inside the spectrum.
    assert!(est_min >= lmin * (1.0 - 1e-8) && est_max <= lmax * (1.0 + 1e-8));
}

#[test]
fn jacobi_at_least_halves_cg_iterations_on_a_badly_scaled_matrix() {
    let n = 10;
    let mut rng = ChaCha8Rng::seed_from_u64(14);
    let d: Vec<f64> = (0..n * n * n)
        .map(|_| 10f64.powf(rng.gen_range(-3.0..=3.0)))
        .collect();
    let op = Scaled {
        inner: Stencil7::laplacian(n),
        d,
    };
    let (_, b) = manufactured(&op, 15);
    let tol = 1e-8;
    let (_, plain) = run(
        &op,
        &b,
        &options(KrylovMethod::Cg, Preconditioner::None, tol),
    );
    let (_, jacobi) = run(
        &op,
        &b,
        &options(KrylovMethod::Cg, Preconditioner::Jacobi, tol),
    );
    let (plain, jacobi) = (iterations(&plain), jacobi.unwrap().iterations);
    assert!(
        2 * jacobi <= plain,
        "jacobi {jacobi} vs plain {plain} iterations"
    );
}

#[test]
fn explicit_diagonal_gives_the_same_result_as_the_computed_one() {
    let op = Stencil7::convection_diffusion(6, [0.5, 0.5, 0.5]);
    let (_, b) = manufactured(&op, 16);
    let opts = options(KrylovMethod::Cgs, Preconditioner::Jacobi, 1e-10);
    let (x_computed, res) = run(&op, &b, &opts);
    let be = CpuBackend::new();
    let mut x = vec![0.0; b.len()];
    let stats = solve(&be, &op, Some(&op.diagonal()), &b, &mut x, &opts).unwrap();
    assert_eq!(res.unwrap(), stats);
    assert_eq!(x, x_computed);
}

#[test]
fn max_iterations_is_a_typed_error_with_exit_code_3() {
    let op = Stencil7::laplacian(8);
    let (_, b) = manufactured(&op, 17);
    for method in METHODS {
        let opts = KrylovOptions {
            max_iterations: 5,
            ..options(method, Preconditioner::None, 1e-12)
        };
        match run(&op, &b, &opts).1 {
            Err(e @ Error::MaxIterations { .. }) => {
                assert_eq!(e.exit_code(), 3);
                let Error::MaxIterations {
                    method: m,
                    iterations,
                    residual,
                } = e
                else {
                    unreachable!()
                };
                assert_eq!((m.as_str(), iterations), (method.name(), 5));
                assert!(residual > 1e-12 && residual < 1.0, "{method}: {residual}");
            }
            other => panic!("{method}: expected MaxIterations, got {other:?}"),
        }
    }
}

#[test]
fn zero_rhs_returns_zero_in_zero_iterations() {
    let op = Stencil7::laplacian(5);
    let be = CpuBackend::new();
    for method in METHODS {
        let mut x = vec![1.0; op.nrows()];
        let b = vec![0.0; op.nrows()];
        let opts = options(method, Preconditioner::Jacobi, 1e-10);
        let stats = solve(&be, &op, None, &b, &mut x, &opts).unwrap();
        assert_eq!(stats.iterations, 0);
        assert!(x.iter().all(|&v| v == 0.0), "{method}: x not reset to 0");
    }
}

#[test]
fn warm_start_at_the_solution_takes_zero_iterations() {
    let op = Stencil7::laplacian(6);
    let (xs, b) = manufactured(&op, 18);
    for method in METHODS {
        let mut x = xs.clone();
        let opts = options(method, Preconditioner::None, 1e-10);
        let stats = solve(&CpuBackend::new(), &op, None, &b, &mut x, &opts).unwrap();
        assert_eq!(stats.iterations, 0, "{method}");
        assert_eq!(x, xs);
        assert!(stats.true_relative_residual <= 1e-14);
    }
}

#[test]
fn residual_history_starts_at_one_and_ends_at_the_reported_residual() {
    let op = Stencil7::laplacian(8);
    let (_, b) = manufactured(&op, 19);
    for method in METHODS {
        let (_, res) = run(&op, &b, &options(method, Preconditioner::None, 1e-9));
        let s = res.unwrap();
        assert_eq!(s.restarts, 0, "{method}");
        assert_eq!(s.residual_history.len(), s.iterations + 1, "{method}");
        assert!((s.residual_history[0] - 1.0).abs() < 1e-14, "{method}");
        assert_eq!(*s.residual_history.last().unwrap(), s.relative_residual);
        assert_eq!(s.lanczos.is_some(), method == KrylovMethod::Cg);
    }
}

#[test]
fn drifted_recursive_residual_triggers_a_restart_from_the_true_one() {
    // Applications 1..4 are 1e-4 too large, as an inexact (f32) operator would
    // be: the recursive residual then drifts away from the true one.
    let tol = 1e-10;
    for method in METHODS {
        let op = Faulty::new(Stencil7::laplacian(8), 1..4, 1.0 + 1e-4);
        let (xs, b) = manufactured(&op.inner, 20);
        let (x, res) = run(&op, &b, &options(method, Preconditioner::None, tol));
        let stats = res.unwrap_or_else(|e| panic!("{method}: {e}"));
        assert!(stats.restarts >= 1, "{method}: no restart: {stats:?}");
        assert!(stats.true_relative_residual <= tol, "{method}: {stats:?}");
        assert!(rel_diff(&x, &xs) <= 1e-8, "{method}");
    }
}

#[test]
fn cg_on_a_negative_definite_operator_breaks_down() {
    let op = Stencil7::laplacian(5).negated();
    let (_, b) = manufactured(&op, 21);
    let err = run(
        &op,
        &b,
        &options(KrylovMethod::Cg, Preconditioner::None, 1e-8),
    )
    .1
    .unwrap_err();
    assert_eq!(err.exit_code(), 3);
    assert!(
        matches!(&err, Error::Breakdown { what, iterations: 0, .. } if what.contains("p·Ap")),
        "{err}"
    );
    // Jacobi with a negative diagonal is refused before iterating.
    let err = run(
        &op,
        &b,
        &options(KrylovMethod::Cg, Preconditioner::Jacobi, 1e-8),
    )
    .1
    .unwrap_err();
    assert!(
        matches!(&err, Error::Breakdown { what, .. } if what.contains("Jacobi")),
        "{err}"
    );
}

#[test]
fn non_finite_values_are_breakdowns() {
    let lap = Stencil7::laplacian(5);
    let (_, b) = manufactured(&lap, 22);
    for method in METHODS {
        let opts = options(method, Preconditioner::None, 1e-10);
        let mut bad_b = b.clone();
        bad_b[7] = f64::NAN;
        let err = run(&lap, &bad_b, &opts).1.unwrap_err();
        assert!(
            matches!(err, Error::Breakdown { iterations: 0, .. }),
            "{method}: {err}"
        );
        // The operator returns NaN from its fourth application on.
        let op = Faulty::new(Stencil7::laplacian(5), 3..usize::MAX, f64::NAN);
        let err = run(&op, &b, &opts).1.unwrap_err();
        assert_eq!(err.exit_code(), 3);
        assert!(
            matches!(&err, Error::Breakdown { what, .. } if what.contains("not finite")),
            "{method}: {err}"
        );
    }
}

#[test]
fn options_deserialize_from_lowercase_names_and_are_validated() {
    let opts: KrylovOptions = serde_json::from_str(
        r#"{"method": "bicgstab", "preconditioner": "jacobi", "rel_tol": 1e-6}"#,
    )
    .unwrap();
    assert_eq!(opts.method, KrylovMethod::BiCgStab);
    assert_eq!(opts.preconditioner, Preconditioner::Jacobi);
    assert_eq!(opts.max_iterations, KrylovOptions::default().max_iterations);
    for (name, method) in [("cg", KrylovMethod::Cg), ("cgs", KrylovMethod::Cgs)] {
        let parsed: KrylovMethod = serde_json::from_str(&format!("\"{name}\"")).unwrap();
        assert_eq!((parsed, method.name()), (method, name));
    }
    let none: Preconditioner = serde_json::from_str("\"none\"").unwrap();
    assert_eq!(none, Preconditioner::None);
    assert!(serde_json::from_str::<KrylovMethod>("\"gmres\"").is_err());
    assert_eq!(KrylovOptions::default().method, KrylovMethod::Cgs);

    let op = Stencil7::laplacian(3);
    let (_, b) = manufactured(&op, 23);
    for rel_tol in [0.0, -1.0, f64::NAN] {
        let err = run(
            &op,
            &b,
            &KrylovOptions {
                rel_tol,
                ..opts.clone()
            },
        )
        .1
        .unwrap_err();
        assert!(matches!(err, Error::InvalidSolverOptions { .. }), "{err}");
        assert_eq!(err.exit_code(), 2);
    }
}
