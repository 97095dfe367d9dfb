//! First-order forward-mode automatic differentiation: the value and gradient
//! of a scalar field at a point, for the many callers that need no Hessian
//! (displacement gradients, stresses, tractions, error norms).
//!
//! The arithmetic is [`super::jet`]'s without the second-order terms, written
//! with the same operations in the same order, so value and gradient equal the
//! jet's bit for bit: `∇g(u) = g'(u) ∇u`, `∇f(u, v) = f_u ∇u + f_v ∇v`. The one
//! difference: a power whose exponent has a zero gradient at the point uses
//! the power rule here, where the jet also asks for a zero Hessian (the two
//! gradients agree wherever the function is differentiable).

use super::ast::{Op1, Op2, Scalar};
use super::functions::{
    atan2_partials, div_partials, mul_partials, pow_partials, power_rule, Partials,
};

/// Value and gradient of a scalar field at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Dual {
    pub value: f64,
    pub grad: [f64; 3],
}

impl Dual {
    /// `g(self)` from `[g, g', g'']` at the value of `self` (`g''` unused).
    fn chain(self, [g, d1, _]: [f64; 3]) -> Dual {
        Dual {
            value: g,
            grad: self.grad.map(|ui| d1 * ui),
        }
    }

    /// `f(self, other)` from the partials of `f` at their values.
    fn bivariate(self, other: Dual, p: Partials) -> Dual {
        let [fu, fv] = p.first;
        Dual {
            value: p.value,
            grad: std::array::from_fn(|i| fu * self.grad[i] + fv * other.grad[i]),
        }
    }
}

impl Scalar for Dual {
    fn constant(value: f64) -> Dual {
        Dual {
            value,
            grad: [0.0; 3],
        }
    }

    fn variable(x: [f64; 3], axis: usize) -> Dual {
        let mut dual = Dual::constant(x[axis]);
        dual.grad[axis] = 1.0;
        dual
    }

    fn unary(self, op: Op1) -> Dual {
        self.chain(op.derivatives(self.value))
    }

    fn binary(self, op: Op2, rhs: Dual) -> Dual {
        let (a, b) = (self.value, rhs.value);
        let add = |f: fn(f64, f64) -> f64| Dual {
            value: f(a, b),
            grad: std::array::from_fn(|i| f(self.grad[i], rhs.grad[i])),
        };
        match op {
            Op2::Add => add(|p, q| p + q),
            Op2::Sub => add(|p, q| p - q),
            Op2::Min | Op2::Max if op.picks_rhs(a, b) => rhs,
            Op2::Min | Op2::Max => self,
            Op2::Pow if rhs.grad == [0.0; 3] => self.chain(power_rule(a, b)),
            Op2::Pow => self.bivariate(rhs, pow_partials(a, b)),
            Op2::Mul => self.bivariate(rhs, mul_partials(a, b)),
            Op2::Div => self.bivariate(rhs, div_partials(a, b)),
            Op2::Atan2 => self.bivariate(rhs, atan2_partials(a, b)),
        }
    }
}
