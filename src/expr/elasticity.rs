//! Vector fields of expressions, and the quantities of isotropic linear
//! elasticity derived exactly from a displacement field `u`.
//!
//! With `ε = (∇u + ∇uᵀ)/2` and `σ = λ tr(ε) I + 2μ ε`, the body load that makes
//! `u` an equilibrium solution is `b = −∇·σ`; for constant `λ`, `μ`
//! ```text
//! b_i = −(μ Δu_i + (λ + μ) ∂_i(∇·u)),   ∂_i(∇·u) = Σ_j ∂²u_j/∂x_i∂x_j,
//! ```
//! which takes the Hessians of the components, computed by automatic
//! differentiation ([`super::Expr::eval_hessian`]).

use serde::Deserialize;

use super::jet::Mat3;
use super::Expr;

/// Three expressions: a vector field such as a displacement or a load.
/// Deserialises from an array of exactly three strings or numbers.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(try_from = "Vec<Expr>")]
pub struct VectorExpr(pub [Expr; 3]);

impl TryFrom<Vec<Expr>> for VectorExpr {
    type Error = String;

    fn try_from(components: Vec<Expr>) -> Result<VectorExpr, String> {
        let count = components.len();
        <[Expr; 3]>::try_from(components)
            .map(VectorExpr)
            .map_err(|_| format!("a vector needs 3 components, got {count}"))
    }
}

impl VectorExpr {
    /// The vector at `x`.
    pub fn eval(&self, x: [f64; 3]) -> [f64; 3] {
        self.0.each_ref().map(|e| e.eval(x))
    }

    /// The vector and its gradient `G[i][j] = ∂u_i/∂x_j` at `x`, in one
    /// first-order AD pass per component.
    pub fn value_and_gradient(&self, x: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        let parts = self.0.each_ref().map(|e| e.eval_gradient(x));
        (parts.map(|p| p.0), parts.map(|p| p.1))
    }

    /// The gradient `G[i][j] = ∂u_i/∂x_j` at `x`.
    pub fn displacement_gradient(&self, x: [f64; 3]) -> [[f64; 3]; 3] {
        self.0.each_ref().map(|e| e.eval_gradient(x).1)
    }

    /// The Hessians of the components at `x`.
    fn hessians(&self, x: [f64; 3]) -> [Mat3; 3] {
        self.0.each_ref().map(|e| e.eval_hessian(x).2)
    }
}

/// The stress `σ = λ tr(ε) I + 2μ ε`, `ε = (∇u + ∇uᵀ)/2`, of the displacement
/// `u` at `x`.
pub fn stress_from_displacement(
    u: &VectorExpr,
    lambda: f64,
    mu: f64,
    x: [f64; 3],
) -> [[f64; 3]; 3] {
    let g = u.displacement_gradient(x);
    let trace = g[0][0] + g[1][1] + g[2][2];
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let diagonal = if i == j { lambda * trace } else { 0.0 };
            diagonal + mu * (g[i][j] + g[j][i])
        })
    })
}

/// The body load `b = −∇·σ(u) = −(μ Δu + (λ + μ) ∇(∇·u))` for which the
/// displacement `u` is in equilibrium, at `x` (isotropic, constant `λ`, `μ`).
pub fn body_load_from_displacement(u: &VectorExpr, lambda: f64, mu: f64, x: [f64; 3]) -> [f64; 3] {
    let hess = u.hessians(x);
    std::array::from_fn(|i| {
        let laplacian: f64 = (0..3).map(|j| hess[i][j][j]).sum();
        let grad_div: f64 = (0..3).map(|j| hess[j][i][j]).sum();
        -(mu * laplacian + (lambda + mu) * grad_div)
    })
}
