//! The gradient and Hessian from automatic differentiation against central
//! finite differences, and exact values where they are known in closed form.

use super::parsed;
use crate::expr::Expr;

/// Expressions that together use every operation and function.
const EXPRESSIONS: &[&str] = &[
    "x + x^2 - 2*x*y + x^3 - 3*x*y^2 + x^2*y",
    "sin(x*y) + cos(z - x) * tan(0.3*y)",
    "exp(-x^2 - y^2) / (1 + z^2)",
    "log(1 + x^2 + y*z + 2) * sqrt(2 + x^2 + y^2 + z^2)",
    "abs(x - 2*y) + sinh(x*z) - cosh(y) * tanh(x + y + z)",
    "atan(x*y - z) + atan2(y + 2*z, x - 3)",
    "min(x^2, y + 1) * max(z, x*y) - min(y, z)^3",
    "pow(x + 2, y + 1) + (z + 3)^(x*y) + 2^(x - z)",
    "(x - 2)^3 + (y - 3)^-2 + (z + x)^4 / (x^2 + 1)^-1",
    "(x^2 + 0.5)^2.5 * (y + 2)^0.5 - (1 + z^2)^(-1.5)",
    "-(x*y*z)^2 + e^(x/3) + pi * x / (y - 2)",
    "sqrt(abs(x) + 1) * log(exp(y) + z^2) + atan2(z, y)",
];

/// Points away from the kinks of `abs`, `min`, `max` and the poles above.
const POINTS: &[[f64; 3]] = &[
    [0.3, -0.7, 0.45],
    [1.2, 0.4, -0.9],
    [-0.6, 1.1, 0.8],
    [0.85, 0.25, 1.35],
];

const H: f64 = 1e-5;

fn shifted(x: [f64; 3], axis: usize, by: f64) -> [f64; 3] {
    let mut y = x;
    y[axis] += by;
    y
}

/// Whether `a` and `b` agree to `rel` relative to `scale` (at least 1).
fn close(a: f64, b: f64, scale: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * scale.max(1.0)
}

/// Central differences of the values: the gradient.
fn fd_gradient(e: &Expr, x: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|j| (e.eval(shifted(x, j, H)) - e.eval(shifted(x, j, -H))) / (2.0 * H))
}

/// Central differences of the exact gradient: the Hessian.
fn fd_hessian(e: &Expr, x: [f64; 3]) -> [[f64; 3]; 3] {
    let grad = |y| e.eval_hessian(y).1;
    std::array::from_fn(|j| {
        let (plus, minus) = (grad(shifted(x, j, H)), grad(shifted(x, j, -H)));
        std::array::from_fn(|i| (plus[i] - minus[i]) / (2.0 * H))
    })
}

/// Second central differences of the values alone: a coarse Hessian that
/// does not trust the AD gradient.
fn fd2_hessian(e: &Expr, x: [f64; 3]) -> [[f64; 3]; 3] {
    let h = 1e-4;
    let f = |di: usize, si: f64, dj: usize, sj: f64| {
        e.eval(shifted(shifted(x, di, si * h), dj, sj * h))
    };
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            (f(i, 1.0, j, 1.0) - f(i, 1.0, j, -1.0) - f(i, -1.0, j, 1.0) + f(i, -1.0, j, -1.0))
                / (4.0 * h * h)
        })
    })
}

#[test]
fn ad_matches_finite_differences() {
    for src in EXPRESSIONS {
        let e = parsed(src);
        for &x in POINTS {
            let (value, grad, hess) = e.eval_hessian(x);
            assert!(value.is_finite(), "{src} at {x:?}: {value}");
            assert_eq!(value, e.eval(x), "{src} at {x:?}: value");
            let g_scale = grad.iter().fold(0.0f64, |m, g| m.max(g.abs()));
            let h_scale = hess.iter().flatten().fold(0.0f64, |m, g| m.max(g.abs()));
            let (fd_g, fd_h, fd2_h) = (fd_gradient(&e, x), fd_hessian(&e, x), fd2_hessian(&e, x));
            for i in 0..3 {
                assert!(
                    close(grad[i], fd_g[i], g_scale, 1e-7),
                    "{src} at {x:?}: d/dx{i} AD {} FD {}",
                    grad[i],
                    fd_g[i]
                );
                for j in 0..3 {
                    let (ad, fd, fd2) = (hess[i][j], fd_h[i][j], fd2_h[i][j]);
                    assert!(
                        close(ad, fd, h_scale, 1e-6) && close(ad, fd2, h_scale, 1e-5),
                        "{src} at {x:?}: H[{i}][{j}] AD {ad} FD {fd} FD2 {fd2}"
                    );
                    assert_eq!(ad, hess[j][i], "{src}: Hessian not symmetric");
                }
            }
        }
    }
}

/// The first-order AD against the second-order one: two independent
/// evaluations of the same tree, equal bit for bit (and so both against the
/// finite differences above), also where an exponent is only locally
/// constant and at the powers' special points.
#[test]
fn gradient_equals_the_jets_bit_for_bit() {
    let special = ["x^3 + y^-2 + z^0 + x^1", "x^(2 + y - y)", "x^2 + y^1 + z^0"];
    let points = POINTS.iter().chain(&[[-2.0, -0.5, -3.0], [0.0; 3]]);
    for src in EXPRESSIONS.iter().chain(&special) {
        let e = parsed(src);
        for &x in points.clone() {
            let (value, grad, _) = e.eval_hessian(x);
            let (v1, g1) = e.eval_gradient(x);
            assert_eq!(v1.to_bits(), value.to_bits(), "{src} at {x:?}: value");
            assert_eq!(
                g1.map(f64::to_bits),
                grad.map(f64::to_bits),
                "{src} at {x:?}: gradient"
            );
        }
    }
}

#[test]
fn integer_powers_of_negative_bases_are_exact() {
    let e = parsed("x^3 + y^-2 + z^0 + x^1");
    let (value, grad, hess) = e.eval_hessian([-2.0, -0.5, -3.0]);
    assert_eq!(value, -8.0 + 4.0 + 1.0 - 2.0);
    assert_eq!(grad, [3.0 * 4.0 + 1.0, -2.0 * (-0.5f64).powi(-3), 0.0]);
    assert_eq!(hess[0][0], 6.0 * -2.0);
    assert_eq!(hess[1][1], 6.0 * (-0.5f64).powi(-4));
    assert_eq!(hess[2][2], 0.0);
}

#[test]
fn powers_at_zero_have_exact_derivatives() {
    let (value, grad, hess) = parsed("x^2 + y^1 + z^0").eval_hessian([0.0; 3]);
    assert_eq!(value, 1.0);
    assert_eq!(grad, [0.0, 1.0, 0.0]);
    assert_eq!(hess, [[2.0, 0.0, 0.0], [0.0; 3], [0.0; 3]]);
}

#[test]
fn exponent_constant_only_locally_still_uses_the_power_rule() {
    // The exponent y - y vanishes identically, so x^(y-y) = 1 even at x < 0.
    let (value, grad, hess) = parsed("x^(2 + y - y)").eval_hessian([-3.0, 1.0, 0.0]);
    assert_eq!((value, grad[0], hess[0][0]), (9.0, -6.0, 2.0));
}

#[test]
fn closed_form_derivatives() {
    let x = [0.7, -0.4, 1.3];
    let (_, grad, hess) = parsed("sin(x) * exp(y) + z^2 * x").eval_hessian(x);
    let (s, c, ey) = (x[0].sin(), x[0].cos(), x[1].exp());
    let expected_grad = [c * ey + x[2] * x[2], s * ey, 2.0 * x[2] * x[0]];
    let expected_hess = [
        [-s * ey, c * ey, 2.0 * x[2]],
        [c * ey, s * ey, 0.0],
        [2.0 * x[2], 0.0, 2.0 * x[0]],
    ];
    for i in 0..3 {
        assert!((grad[i] - expected_grad[i]).abs() < 1e-14);
        for j in 0..3 {
            assert!(
                (hess[i][j] - expected_hess[i][j]).abs() < 1e-14,
                "H[{i}][{j}]"
            );
        }
    }
}
