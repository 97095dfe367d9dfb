//! The scalar maths of the operations: values of every operation (the
//! [`Scalar`] impl for `f64`), first and second derivatives of the
//! one-operand ones, partial derivatives of the smooth two-operand ones, and
//! the power rule for exponents that do not vary.

use super::ast::{Op1, Op2, Scalar};

/// Integer exponents up to this size are evaluated by repeated
/// multiplication (exact for negative bases); others with `powf`.
pub(super) const MAX_POWI: f64 = 64.0;

/// Value and partial derivatives of `f(a, b)`: `first = [f_a, f_b]`,
/// `second = [f_aa, f_ab, f_bb]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Partials {
    pub value: f64,
    pub first: [f64; 2],
    pub second: [f64; 3],
}

impl Op1 {
    /// `g(u)`.
    pub(super) fn value(self, u: f64) -> f64 {
        match self {
            Op1::Neg => -u,
            Op1::Sin => u.sin(),
            Op1::Cos => u.cos(),
            Op1::Tan => u.tan(),
            Op1::Exp => u.exp(),
            Op1::Log => u.ln(),
            Op1::Sqrt => u.sqrt(),
            Op1::Abs => u.abs(),
            Op1::Sinh => u.sinh(),
            Op1::Cosh => u.cosh(),
            Op1::Tanh => u.tanh(),
            Op1::Atan => u.atan(),
        }
    }

    /// `[g(u), g'(u), g''(u)]`; `abs` has slope 0 at 0.
    pub(super) fn derivatives(self, u: f64) -> [f64; 3] {
        let g = self.value(u);
        let (d1, d2) = match self {
            Op1::Neg => (-1.0, 0.0),
            Op1::Sin => (u.cos(), -g),
            Op1::Cos => (-u.sin(), -g),
            Op1::Tan => (1.0 + g * g, 2.0 * g * (1.0 + g * g)),
            Op1::Exp => (g, g),
            Op1::Log => (1.0 / u, -1.0 / (u * u)),
            Op1::Sqrt => (0.5 / g, -0.25 / (g * g * g)),
            Op1::Abs => (sign(u), 0.0),
            Op1::Sinh => (u.cosh(), g),
            Op1::Cosh => (u.sinh(), g),
            Op1::Tanh => (1.0 - g * g, -2.0 * g * (1.0 - g * g)),
            Op1::Atan => {
                let d1 = 1.0 / (1.0 + u * u);
                (d1, -2.0 * u * d1 * d1)
            }
        };
        [g, d1, d2]
    }
}

impl Op2 {
    /// `a op b`; `min`/`max` return `a` on ties and when either is NaN.
    pub(super) fn value(self, a: f64, b: f64) -> f64 {
        match self {
            Op2::Add => a + b,
            Op2::Sub => a - b,
            Op2::Mul => a * b,
            Op2::Div => a / b,
            Op2::Pow => real_pow(a, b),
            Op2::Atan2 => a.atan2(b),
            Op2::Min | Op2::Max => {
                if self.picks_rhs(a, b) {
                    b
                } else {
                    a
                }
            }
        }
    }

    /// Whether `min`/`max` select their second operand (false for the others).
    pub(super) fn picks_rhs(self, a: f64, b: f64) -> bool {
        match self {
            Op2::Min => b < a,
            Op2::Max => b > a,
            _ => false,
        }
    }
}

impl Scalar for f64 {
    fn constant(value: f64) -> f64 {
        value
    }

    fn variable(x: [f64; 3], axis: usize) -> f64 {
        x[axis]
    }

    fn unary(self, op: Op1) -> f64 {
        op.value(self)
    }

    fn binary(self, op: Op2, rhs: f64) -> f64 {
        op.value(self, rhs)
    }
}

/// `a^b`: repeated multiplication for small integer `b` (any sign of `a`),
/// `powf` otherwise (NaN for negative `a`).
pub(super) fn real_pow(a: f64, b: f64) -> f64 {
    if b.fract() == 0.0 && b.abs() <= MAX_POWI {
        a.powi(b as i32)
    } else {
        a.powf(b)
    }
}

/// `[a^n, n a^(n-1), n (n-1) a^(n-2)]` for a fixed exponent `n`, with the
/// vanishing derivatives of `n = 0` and `n = 1` exactly zero (also at `a = 0`).
pub(super) fn power_rule(a: f64, n: f64) -> [f64; 3] {
    let d1 = if n == 0.0 {
        0.0
    } else {
        n * real_pow(a, n - 1.0)
    };
    let d2 = if n == 0.0 || n == 1.0 {
        0.0
    } else {
        n * (n - 1.0) * real_pow(a, n - 2.0)
    };
    [real_pow(a, n), d1, d2]
}

/// Partials of `a b`.
pub(super) fn mul_partials(a: f64, b: f64) -> Partials {
    Partials {
        value: Op2::Mul.value(a, b),
        first: [b, a],
        second: [0.0, 1.0, 0.0],
    }
}

/// Partials of `a / b`.
pub(super) fn div_partials(a: f64, b: f64) -> Partials {
    let inv = 1.0 / b;
    Partials {
        value: Op2::Div.value(a, b),
        first: [inv, -a * inv * inv],
        second: [0.0, -inv * inv, 2.0 * a * inv * inv * inv],
    }
}

/// Partials of `atan2(a, b)`, the angle of the point `(b, a)`.
pub(super) fn atan2_partials(a: f64, b: f64) -> Partials {
    let r2 = a * a + b * b;
    let r4 = r2 * r2;
    Partials {
        value: Op2::Atan2.value(a, b),
        first: [b / r2, -a / r2],
        second: [-2.0 * a * b / r4, (a * a - b * b) / r4, 2.0 * a * b / r4],
    }
}

/// Partials of `a^b = exp(b ln a)` for a varying exponent (real for `a > 0`).
pub(super) fn pow_partials(a: f64, b: f64) -> Partials {
    let value = Op2::Pow.value(a, b);
    let ln_a = a.ln();
    let p1 = a.powf(b - 1.0);
    Partials {
        value,
        first: [b * p1, value * ln_a],
        second: [
            b * (b - 1.0) * a.powf(b - 2.0),
            p1 * (1.0 + b * ln_a),
            value * ln_a * ln_a,
        ],
    }
}

/// The slope of `|u|`: ±1, and 0 at 0.
fn sign(u: f64) -> f64 {
    if u > 0.0 {
        1.0
    } else if u < 0.0 {
        -1.0
    } else {
        0.0
    }
}
