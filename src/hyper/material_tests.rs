//! The materials against finite differences (P = ∂W/∂F, A = ∂P/∂F) and against
//! linear elasticity at small strain.

use nalgebra::Matrix3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::element::reference::elasticity_matrix;

const E: f64 = 1000.0;
const NU: f64 = 0.3;

fn materials() -> [Material; 3] {
    [
        Material::neo_hookean(E, NU),
        Material::st_venant_kirchhoff(E, NU),
        Material::linear(E, NU),
    ]
}

/// `I + H` with `H` random of size `scale` (det > 0 for scale < 1/3).
fn random_gradient(rng: &mut ChaCha8Rng, scale: f64) -> Matrix3<f64> {
    Matrix3::identity() + Matrix3::from_fn(|_, _| rng.gen_range(-scale..scale))
}

fn state(f: Matrix3<f64>) -> PointState {
    PointState::new(f).expect("det F > 0")
}

#[test]
fn stress_is_the_derivative_of_the_energy() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let eps = 1e-6;
    for m in materials() {
        for _ in 0..5 {
            let f = random_gradient(&mut rng, 0.3);
            let p = m.stress(&state(f));
            for k in 0..3 {
                for l in 0..3 {
                    let mut d = Matrix3::zeros();
                    d[(k, l)] = eps;
                    let fd = (m.energy(&state(f + d)) - m.energy(&state(f - d))) / (2.0 * eps);
                    let err = (fd - p[(k, l)]).abs() / p.norm();
                    assert!(err < 1e-8, "{:?} P[{k}][{l}]: {err:e}", m.model);
                }
            }
        }
    }
}

#[test]
fn tangent_equals_central_differences_of_the_stress() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let eps = 1e-6;
    for m in materials() {
        for _ in 0..5 {
            let f = random_gradient(&mut rng, 0.3);
            let a = m.tangent(&state(f));
            let mut worst = 0.0f64;
            let mut scale = 0.0f64;
            for k in 0..3 {
                for l in 0..3 {
                    let mut d = Matrix3::zeros();
                    d[(k, l)] = eps;
                    let dp = (m.stress(&state(f + d)) - m.stress(&state(f - d))) / (2.0 * eps);
                    for i in 0..3 {
                        for j in 0..3 {
                            worst = worst.max((dp[(i, j)] - a[i][j][k][l]).abs());
                            scale = scale.max(a[i][j][k][l].abs());
                        }
                    }
                }
            }
            assert!(worst / scale < 1e-6, "{:?}: {:e}", m.model, worst / scale);
            // Hyperelastic: major symmetry A_iJkL = A_kLiJ.
            for (i, j, k, l) in (0..81).map(|n| (n % 3, n / 3 % 3, n / 9 % 3, n / 27)) {
                assert!((a[i][j][k][l] - a[k][l][i][j]).abs() < 1e-12 * scale);
            }
        }
    }
}

#[test]
fn stress_vanishes_at_the_identity() {
    for m in materials() {
        let p = m.stress(&state(Matrix3::identity()));
        assert!(p.norm() < 1e-13 * E, "{:?}: {p}", m.model);
        assert_eq!(m.energy(&state(Matrix3::identity())), 0.0);
    }
}

/// Voigt order (xx, yy, zz, yz, xz, xy) with engineering shears, as `D`.
const VOIGT: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)];

#[test]
fn tangent_at_the_identity_is_linear_elasticity() {
    let d = elasticity_matrix(E, NU);
    for m in materials() {
        let s = state(Matrix3::identity());
        for (col, &(k, l)) in VOIGT.iter().enumerate() {
            // The unit engineering strain of column `col` as a symmetric dF.
            let mut df = Matrix3::zeros();
            if k == l {
                df[(k, l)] = 1.0;
            } else {
                df[(k, l)] = 0.5;
                df[(l, k)] = 0.5;
            }
            let dp = m.tangent_action(&s, &df);
            for (row, &(i, j)) in VOIGT.iter().enumerate() {
                let err = (dp[(i, j)] - d[(row, col)]).abs();
                assert!(err < 1e-12 * E, "{:?} D[{row}][{col}]", m.model);
            }
        }
    }
}

#[test]
fn small_strain_stress_is_linear_elasticity() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let d = elasticity_matrix(E, NU);
    for m in materials() {
        let h = Matrix3::from_fn(|_, _| rng.gen_range(-1.0..1.0));
        let eps = 1e-7;
        let p = m.stress(&state(Matrix3::identity() + h * eps)) / eps;
        let strain = (h + h.transpose()) * 0.5;
        let ev: Vec<f64> = VOIGT
            .iter()
            .map(|&(i, j)| {
                if i == j {
                    strain[(i, j)]
                } else {
                    2.0 * strain[(i, j)]
                }
            })
            .collect();
        for (row, &(i, j)) in VOIGT.iter().enumerate() {
            let sigma: f64 = (0..6).map(|c| d[(row, c)] * ev[c]).sum();
            // P = σ + O(ε) (the rotation part of H and quadratic terms).
            let err = (p[(i, j)] - sigma).abs();
            assert!(err < 1e-5 * E, "{:?} σ[{i}][{j}]: {err:e}", m.model);
        }
    }
}

#[test]
fn inverted_gradients_have_no_state() {
    let mut f = Matrix3::identity();
    f[(2, 2)] = -0.5;
    assert!(PointState::new(f).is_none());
    assert!(PointState::new(Matrix3::zeros()).is_none());
}

#[test]
fn the_shared_coefficient_form_is_the_tangent() {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    for m in materials() {
        let s = state(random_gradient(&mut rng, 0.3));
        let coef = m.tangent_coefficients(&s);
        for _ in 0..3 {
            let df = Matrix3::from_fn(|_, _| rng.gen_range(-1.0..1.0));
            let want = m.tangent_action(&s, &df);
            let err = (coef.apply(m.lambda, &df) - want).norm() / want.norm();
            assert!(err < 1e-14, "{:?}: {err:e}", m.model);
        }
    }
}
