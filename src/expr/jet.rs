//! Second-order forward-mode automatic differentiation: the jet of a scalar
//! field at a point (value, gradient, Hessian) and its arithmetic.
//!
//! For `h = g(u)`: `∇h = g'(u) ∇u` and `∇²h = g''(u) ∇u ∇uᵀ + g'(u) ∇²u`.
//! For `h = f(u, v)`: `∇h = f_u ∇u + f_v ∇v` and
//! `∇²h = f_u ∇²u + f_v ∇²v + f_uu ∇u∇uᵀ + f_vv ∇v∇vᵀ + f_uv (∇u∇vᵀ + ∇v∇uᵀ)`.
//! Sums, differences, `min` and `max` are done componentwise or by selection;
//! a power whose exponent has zero gradient and Hessian at the point uses the
//! power rule, which is exact for negative bases and integer exponents.

use super::ast::{Op1, Op2, Scalar};
use super::functions::{
    atan2_partials, div_partials, mul_partials, pow_partials, power_rule, Partials,
};

/// A 3×3 matrix, row major.
pub(super) type Mat3 = [[f64; 3]; 3];

/// Value, gradient and Hessian of a scalar field at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Jet {
    pub value: f64,
    pub grad: [f64; 3],
    pub hess: Mat3,
}

impl Jet {
    /// Combines the components of two jets pairwise with `f` (for linear `f`).
    fn zip(self, other: Jet, f: impl Fn(f64, f64) -> f64) -> Jet {
        Jet {
            value: f(self.value, other.value),
            grad: std::array::from_fn(|i| f(self.grad[i], other.grad[i])),
            hess: symmetric(|i, j| f(self.hess[i][j], other.hess[i][j])),
        }
    }

    /// Whether gradient and Hessian vanish.
    fn is_locally_constant(&self) -> bool {
        self.grad
            .iter()
            .chain(self.hess.iter().flatten())
            .all(|&d| d == 0.0)
    }

    /// `g(self)` from `[g, g', g'']` at the value of `self`.
    fn chain(self, [g, d1, d2]: [f64; 3]) -> Jet {
        let (u, h) = (self.grad, self.hess);
        Jet {
            value: g,
            grad: u.map(|ui| d1 * ui),
            hess: symmetric(|i, j| d2 * (u[i] * u[j]) + d1 * h[i][j]),
        }
    }

    /// `f(self, other)` from the partials of `f` at their values.
    fn bivariate(self, other: Jet, p: Partials) -> Jet {
        let (u, v) = (self.grad, other.grad);
        let ([fu, fv], [fuu, fuv, fvv]) = (p.first, p.second);
        let hess = |i: usize, j: usize| {
            fu * self.hess[i][j]
                + fv * other.hess[i][j]
                + fuu * (u[i] * u[j])
                + fvv * (v[i] * v[j])
                + fuv * (u[i] * v[j] + v[i] * u[j])
        };
        Jet {
            value: p.value,
            grad: std::array::from_fn(|i| fu * u[i] + fv * v[i]),
            hess: symmetric(hess),
        }
    }
}

/// The symmetric matrix with `m[i][j] = m[j][i] = f(i, j)` for `i ≤ j`: six
/// evaluations instead of nine. Every Hessian formula above is symmetric in
/// `i`, `j` to the bit (products and sums commute in floating point, and the
/// operands' Hessians are symmetric), so mirroring changes no value.
fn symmetric(f: impl Fn(usize, usize) -> f64) -> Mat3 {
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in i..3 {
            m[i][j] = f(i, j);
            m[j][i] = m[i][j];
        }
    }
    m
}

impl Scalar for Jet {
    fn constant(value: f64) -> Jet {
        Jet {
            value,
            grad: [0.0; 3],
            hess: [[0.0; 3]; 3],
        }
    }

    fn variable(x: [f64; 3], axis: usize) -> Jet {
        let mut jet = Jet::constant(x[axis]);
        jet.grad[axis] = 1.0;
        jet
    }

    fn unary(self, op: Op1) -> Jet {
        self.chain(op.derivatives(self.value))
    }

    fn binary(self, op: Op2, rhs: Jet) -> Jet {
        let (a, b) = (self.value, rhs.value);
        match op {
            Op2::Add => self.zip(rhs, |p, q| p + q),
            Op2::Sub => self.zip(rhs, |p, q| p - q),
            Op2::Min | Op2::Max if op.picks_rhs(a, b) => rhs,
            Op2::Min | Op2::Max => self,
            Op2::Pow if rhs.is_locally_constant() => self.chain(power_rule(a, b)),
            Op2::Pow => self.bivariate(rhs, pow_partials(a, b)),
            Op2::Mul => self.bivariate(rhs, mul_partials(a, b)),
            Op2::Div => self.bivariate(rhs, div_partials(a, b)),
            Op2::Atan2 => self.bivariate(rhs, atan2_partials(a, b)),
        }
    }
}
