//! The stress and body load derived from exact displacement fields, checked
//! against fields whose derivatives are known by hand.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::parsed;
use crate::expr::{body_load_from_displacement, stress_from_displacement, VectorExpr};

const YOUNG: f64 = 1000.0;
const POISSON: f64 = 0.3;

/// Lamé's `(λ, μ)` of Young's modulus and Poisson's ratio.
fn lame(young: f64, poisson: f64) -> (f64, f64) {
    let lambda = young * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson));
    (lambda, young / (2.0 * (1.0 + poisson)))
}

fn field(components: [&str; 3]) -> VectorExpr {
    VectorExpr(components.map(parsed))
}

/// The manufactured field of the paper: `∇·u = −2y`, `Δu = (2 + 2y, −2x, 0)`,
/// so `b = −μ Δu − (λ + μ) ∇(∇·u) = (−2μ(1 + y), 2μx + 2(λ + μ), 0)`.
fn paper_field() -> VectorExpr {
    field([
        "x + x^2 - 2*x*y + x^3 - 3*x*y^2 + x^2*y",
        "-y - 2*x*y - 3*x^2*y + y^3 - x*y^2",
        "0",
    ])
}

fn random_points(count: usize) -> Vec<[f64; 3]> {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    (0..count)
        .map(|_| std::array::from_fn(|_| rng.gen_range(-2.0..2.0)))
        .collect()
}

fn norm(v: [f64; 3]) -> f64 {
    v.iter().map(|c| c * c).sum::<f64>().sqrt()
}

#[test]
fn paper_field_divergence_is_minus_two_y() {
    let u = paper_field();
    for x in random_points(20) {
        let g = u.displacement_gradient(x);
        let div = g[0][0] + g[1][1] + g[2][2];
        assert!((div + 2.0 * x[1]).abs() < 1e-12, "{div} at {x:?}");
        assert_eq!(g[2], [0.0; 3]);
    }
}

#[test]
fn paper_field_body_load() {
    let (lambda, mu) = lame(YOUNG, POISSON);
    assert!((mu - 5000.0 / 13.0).abs() < 1e-12 && (lambda - 7500.0 / 13.0).abs() < 1e-12);
    let u = paper_field();
    for x in random_points(50) {
        let b = body_load_from_displacement(&u, lambda, mu, x);
        let expected = [
            -10000.0 * (1.0 + x[1]) / 13.0,
            (10000.0 * x[0] + 25000.0) / 13.0,
            0.0,
        ];
        let error = norm(std::array::from_fn(|i| b[i] - expected[i]));
        assert!(
            error <= 1e-10 * norm(expected),
            "at {x:?}: {b:?} vs {expected:?}"
        );
    }
}

#[test]
fn stress_of_a_linear_field() {
    // u = (a x + b y, c x, d z): ε = [[a, (b+c)/2, 0], [(b+c)/2, 0, 0], [0, 0, d]].
    let (a, b, c, d) = (0.01, -0.02, 0.03, 0.005);
    let u = field(["0.01*x - 0.02*y", "0.03*x", "0.005*z"]);
    let (lambda, mu) = lame(YOUNG, POISSON);
    let x = [0.3, -1.2, 2.0];
    let sigma = stress_from_displacement(&u, lambda, mu, x);
    let trace = a + d;
    let expected = [
        [lambda * trace + 2.0 * mu * a, mu * (b + c), 0.0],
        [mu * (b + c), lambda * trace, 0.0],
        [0.0, 0.0, lambda * trace + 2.0 * mu * d],
    ];
    for i in 0..3 {
        for j in 0..3 {
            let error = (sigma[i][j] - expected[i][j]).abs();
            assert!(error < 1e-12, "σ[{i}][{j}] = {}", sigma[i][j]);
        }
    }
    assert_eq!(body_load_from_displacement(&u, lambda, mu, x), [0.0; 3]);
}

/// `∇·σ` at `x` by central differences of the exact stress.
fn fd_div_stress(u: &VectorExpr, lambda: f64, mu: f64, x: [f64; 3]) -> [f64; 3] {
    let h = 1e-5;
    let stress = |j: usize, by: f64| {
        let mut y = x;
        y[j] += by;
        stress_from_displacement(u, lambda, mu, y)
    };
    std::array::from_fn(|i| {
        (0..3)
            .map(|j| (stress(j, h)[i][j] - stress(j, -h)[i][j]) / (2.0 * h))
            .sum()
    })
}

#[test]
fn body_load_is_minus_divergence_of_stress() {
    let u = field(["sin(x) * y^2", "exp(0.3*z) * x", "x*y*z + cos(y)"]);
    let (lambda, mu) = lame(YOUNG, POISSON);
    for x in random_points(5) {
        let b = body_load_from_displacement(&u, lambda, mu, x);
        let div_sigma = fd_div_stress(&u, lambda, mu, x);
        let scale = norm(b).max(1.0);
        for i in 0..3 {
            assert!(
                (b[i] + div_sigma[i]).abs() < 1e-6 * scale,
                "{b:?} vs {div_sigma:?}"
            );
        }
    }
}

#[test]
fn vector_evaluates_componentwise() {
    let u = paper_field();
    let x = [0.5, 2.0, -1.0];
    let v = u.eval(x);
    assert_eq!(v[0], u.0[0].eval(x));
    assert!((v[0] - (0.5 + 0.25 - 2.0 + 0.125 - 6.0 + 0.5)).abs() < 1e-14);
    assert!((v[1] - (-2.0 - 2.0 - 1.5 + 8.0 - 2.0)).abs() < 1e-14);
    assert_eq!(v[2], 0.0);
}
