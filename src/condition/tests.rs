//! Tests of the condition estimate on matrices with known spectra: Dirichlet
//! Laplacians (closed-form eigenvalues), diagonal matrices, diagonally scaled
//! Laplacians, singular Neumann Laplacians and an indefinite matrix.

use std::f64::consts::PI;

use faer::sparse::{SparseColMat, Triplet};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;

fn matrix(n: usize, entries: &[(usize, usize, f64)]) -> SparseColMat<usize, f64> {
    let triplets: Vec<_> = entries
        .iter()
        .map(|&(i, j, v)| Triplet::new(i, j, v))
        .collect();
    SparseColMat::try_new_from_triplets(n, n, &triplets).unwrap()
}

fn diagonal(d: &[f64]) -> SparseColMat<usize, f64> {
    let entries: Vec<_> = d.iter().enumerate().map(|(i, &v)| (i, i, v)).collect();
    matrix(d.len(), &entries)
}

/// The graph Laplacian of an `nx × ny × nz` grid with edge weights `weight()`
/// (both triangles), plus `dirichlet` on the diagonal for every missing
/// neighbour along the directions with more than one node: `dirichlet = 1` and unit weights give the 7-point Dirichlet
/// Laplacian, `dirichlet = 0` a singular Neumann one.
fn grid_laplacian(
    dims: [usize; 3],
    dirichlet: f64,
    mut weight: impl FnMut() -> f64,
) -> SparseColMat<usize, f64> {
    let [nx, ny, nz] = dims;
    let id = |x: usize, y: usize, z: usize| x + nx * (y + ny * z);
    let n = nx * ny * nz;
    let mut diag = vec![0.0; n];
    let mut entries = Vec::new();
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let p = id(x, y, z);
                let (c, size) = ([x, y, z], dims);
                for d in (0..3).filter(|&d| size[d] > 1) {
                    let lower_missing = c[d] == 0;
                    let upper_missing = c[d] + 1 == size[d];
                    diag[p] += dirichlet * (lower_missing as u8 + upper_missing as u8) as f64;
                    if !upper_missing {
                        let mut e = c;
                        e[d] += 1;
                        let q = id(e[0], e[1], e[2]);
                        let w = weight();
                        entries.extend([(p, q, -w), (q, p, -w)]);
                        diag[p] += w;
                        diag[q] += w;
                    }
                }
            }
        }
    }
    entries.extend(diag.iter().enumerate().map(|(i, &v)| (i, i, v)));
    matrix(n, &entries)
}

/// `(λ_min, λ_max)` of the Dirichlet grid Laplacian: sums over the directions
/// with `n > 1` nodes of `4 sin²(k π / (2(n+1)))`, `k = 1 … n`.
fn dirichlet_extremes(dims: [usize; 3]) -> (f64, f64) {
    let lam = |k: usize, n: usize| 4.0 * (PI * k as f64 / (2.0 * (n + 1) as f64)).sin().powi(2);
    let dims = dims.iter().filter(|&&n| n > 1);
    let lo = dims.clone().map(|&n| lam(1, n)).sum();
    let hi = dims.map(|&n| lam(n, n)).sum();
    (lo, hi)
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

fn estimate(a: &SparseColMat<usize, f64>, jacobi: bool) -> ConditionEstimate {
    condition_number(a, jacobi, &ConditionOptions::default()).unwrap()
}

fn check_dirichlet(dims: [usize; 3]) {
    let a = grid_laplacian(dims, 1.0, || 1.0);
    let (lo, hi) = dirichlet_extremes(dims);
    for jacobi in [false, true] {
        let e = estimate(&a, jacobi);
        // The diagonal is the constant 2 per direction: Jacobi scaling divides by it.
        let scale = if jacobi {
            2.0 * dims.iter().filter(|&&n| n > 1).count() as f64
        } else {
            1.0
        };
        assert!(!e.kappa_is_lower_bound, "{e:?}");
        assert!(
            rel(e.kappa, hi / lo) < 1e-6,
            "{dims:?} {e:?} vs {}",
            hi / lo
        );
        assert!(rel(e.lambda_max, hi / scale) < 1e-8, "{e:?}");
        assert!(rel(e.lambda_min, lo / scale) < 1e-6, "{e:?}");
        assert!(e.method.contains("(cholesky)"), "{}", e.method);
    }
}

#[test]
fn laplacian_1d_matches_the_closed_form() {
    check_dirichlet([100, 1, 1]);
}

#[test]
fn laplacian_3d_matches_the_closed_form() {
    check_dirichlet([12, 10, 9]);
}

#[test]
fn diagonal_over_six_decades_has_kappa_1e6_and_1_when_scaled() {
    let d: Vec<f64> = (0..50)
        .map(|i| 10f64.powf(-3.0 + 6.0 * i as f64 / 49.0))
        .collect();
    let e = estimate(&diagonal(&d), false);
    assert!(!e.kappa_is_lower_bound, "{e:?}");
    assert!(rel(e.kappa, d[49] / d[0]) < 1e-6, "{e:?}");
    assert!(rel(e.kappa, 1e6) < 1e-6, "{e:?}");
    let s = estimate(&diagonal(&d), true);
    assert!(!s.kappa_is_lower_bound, "{s:?}");
    assert!(s.kappa >= 1.0 && s.kappa - 1.0 < 1e-14, "{s:?}");
}

/// `D L D` with `D` spanning four decades: Jacobi scaling turns it back into
/// `L / 2`, whose κ is known; unscaled it is far worse, yet resolved (the bad
/// conditioning is all in the scaling, which the factor handles exactly).
#[test]
fn jacobi_scaling_undoes_a_diagonal_scaling() {
    let n = 100;
    let d: Vec<f64> = (0..n)
        .map(|i| 10f64.powf(-4.0 * i as f64 / (n - 1) as f64))
        .collect();
    let l = grid_laplacian([n, 1, 1], 1.0, || 1.0);
    let mut entries = Vec::new();
    for j in 0..n {
        for (&i, &v) in l.row_idx_of_col_raw(j).iter().zip(l.val_of_col(j)) {
            entries.push((i, j, d[i] * v * d[j]));
        }
    }
    let a = matrix(n, &entries);
    let (lo, hi) = dirichlet_extremes([n, 1, 1]);
    let s = estimate(&a, true);
    assert!(
        !s.kappa_is_lower_bound && rel(s.kappa, hi / lo) < 1e-6,
        "{s:?}"
    );
    let p = estimate(&a, false);
    assert!(!p.kappa_is_lower_bound && p.kappa > 1e3 * s.kappa, "{p:?}");
}

fn check_singular(a: &SparseColMat<usize, f64>) {
    for jacobi in [false, true] {
        let e = estimate(a, jacobi);
        assert!(e.kappa_is_lower_bound, "{e:?}");
        assert!(e.kappa.is_finite() && e.kappa >= 1e12, "{e:?}");
        assert!(e.kappa <= 1.0 / RESOLUTION, "{e:?}");
        assert!(
            e.lambda_min > 0.0 && e.kappa == e.lambda_max / e.lambda_min,
            "{e:?}"
        );
        assert!(e.method.ends_with("lower bound)"), "{}", e.method);
    }
}

#[test]
fn singular_neumann_laplacian_1d_gives_a_lower_bound() {
    let a = grid_laplacian([200, 1, 1], 0.0, || 1.0);
    check_singular(&a);
    let e = estimate(&a, false);
    assert!(e.method.contains("cholesky failed"), "{}", e.method);
}

#[test]
fn singular_weighted_neumann_laplacian_3d_gives_a_lower_bound() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    check_singular(&grid_laplacian([9, 8, 7], 0.0, || rng.gen_range(1.0..2.0)));
}

#[test]
fn indefinite_matrix_gives_a_lower_bound_not_a_number() {
    let e = estimate(&diagonal(&[-1.0, 1.0, 2.0, 3.0]), false);
    assert!(e.kappa_is_lower_bound && e.kappa.is_finite(), "{e:?}");
    assert!(e.method.contains("cholesky failed"), "{}", e.method);
}

#[test]
fn too_few_steps_give_a_flagged_lower_bound() {
    let dims = [12, 10, 9];
    let a = grid_laplacian(dims, 1.0, || 1.0);
    let (lo, hi) = dirichlet_extremes(dims);
    let opts = ConditionOptions {
        max_steps: 5,
        ..Default::default()
    };
    let e = condition_number(&a, false, &opts).unwrap();
    assert!(e.kappa_is_lower_bound, "{e:?}");
    assert!(e.kappa < hi / lo && e.kappa > 0.5 * hi / lo, "{e:?}");
    assert!(
        e.method.contains("not converged in 5 steps"),
        "{}",
        e.method
    );
    assert_eq!(e.lanczos_steps, 10);
}

#[test]
fn estimates_are_deterministic() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let a = grid_laplacian([10, 9, 8], 1.0, || rng.gen_range(1.0..2.0));
    for jacobi in [false, true] {
        let first = estimate(&a, jacobi);
        assert_eq!(first, estimate(&a, jacobi));
    }
}

#[test]
fn bad_input_is_an_error() {
    let a = diagonal(&[1.0, 2.0]);
    for opts in [
        ConditionOptions {
            max_steps: 0,
            ..Default::default()
        },
        ConditionOptions {
            rel_tol_min: f64::NAN,
            ..Default::default()
        },
        ConditionOptions {
            rel_tol_max: 1.0,
            ..Default::default()
        },
    ] {
        let err = condition_number(&a, false, &opts).unwrap_err();
        assert!(matches!(err, Error::InvalidSolverOptions { .. }), "{err}");
    }
    let opts = ConditionOptions::default();
    // A zero diagonal entry (a cut artefact) is floored for the scaling, as
    // Jacobi floors it: κ is then a flagged lower bound, and says so.
    let e = condition_number(&diagonal(&[1.0, 0.0, 2.0]), true, &opts).unwrap();
    assert!(e.kappa_is_lower_bound && e.kappa >= 1e15, "{e:?}");
    assert!(
        e.method.contains("1 diagonal entries floored"),
        "{}",
        e.method
    );
    let bad = [
        (diagonal(&[1.0, -1.0, 2.0]), true),
        (diagonal(&[1.0, f64::NAN]), false),
        (diagonal(&[-1.0, -2.0]), false),
        (matrix(0, &[]), false),
    ];
    for (a, jacobi) in bad {
        let err = condition_number(&a, jacobi, &opts).unwrap_err();
        assert!(matches!(err, Error::Breakdown { .. }), "{err}");
    }
}
