//! Vector fields of expressions, and the quantities of isotropic linear
//! elasticity derived exactly from a displacement field `u`.
//!
//! With `ε = (∇u + ∇uᵀ)/2` and `σ = λ tr(ε) I + 2μ ε`, the body load that makes
//! `u` an equilibrium solution is `b = −∇·σ`; for constant `λ`, `μ`
//! ```text
//! b_i = −(μ Δu_i + (λ + μ) ∂_i(∇·u)),   ∂_i(∇·u) = Σ_j ∂²u_j/∂x_i∂x_j,
//! ```
//! which takes the Hessians of the components, computed by automatic
//! differentiation ([`super::Expr::eval_hessian`] at one point,
//! [`VectorTape`] over many).

use serde::Deserialize;

use super::jet::Mat3;
use super::lanes::{Workspace, LANES};
use super::tape::{Order, Plan, Tape, HESSIAN};
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

    /// The field compiled for evaluation over many points.
    pub fn tape(&self) -> VectorTape {
        let tape = Tape::compile(&self.0.each_ref().map(|e| &e.root));
        VectorTape {
            operations: tape.operations(),
            plans: [Order::Value, Order::Gradient, Order::Hessian].map(|o| tape.plan(o)),
        }
    }
}

/// A [`VectorExpr`] compiled once into a tape (common subexpressions of the
/// three components shared, constants folded) and evaluated in batches of
/// points: the values, gradients and body loads of [`VectorExpr`] and
/// [`body_load_from_displacement`], equal to theirs bit for bit wherever
/// those are finite (but for the sign of a zero), at a fraction of the cost
/// per point.
#[derive(Clone, Debug, PartialEq)]
pub struct VectorTape {
    operations: usize,
    /// Per [`Order`].
    plans: [Plan; 3],
}

impl VectorTape {
    /// How many operations one evaluation performs at each point.
    pub fn operations(&self) -> usize {
        self.operations
    }

    /// Runs the plan of `order` over `xs` a batch at a time; `read(offset,
    /// plan, ws)` reads the outputs of the batch starting at `xs[offset]`.
    fn batches(
        &self,
        order: Order,
        xs: &[[f64; 3]],
        mut read: impl FnMut(usize, &Plan, &Workspace),
    ) {
        let plan = &self.plans[order as usize];
        let mut ws = plan.workspace();
        for (b, batch) in xs.chunks(LANES).enumerate() {
            plan.run(&mut ws, batch);
            read(b * LANES, plan, &ws);
        }
    }

    /// The vectors at `xs`, into `out` (as long).
    pub fn values(&self, xs: &[[f64; 3]], out: &mut [[f64; 3]]) {
        assert_eq!(xs.len(), out.len());
        self.batches(Order::Value, xs, |offset, plan, ws| {
            let n = LANES.min(xs.len() - offset);
            for i in 0..3 {
                let lane = plan.lane(ws, i, 0);
                for (o, v) in out[offset..offset + n].iter_mut().zip(lane) {
                    o[i] = *v;
                }
            }
        });
    }

    /// The vectors and their gradients `G[i][j] = ∂u_i/∂x_j` at `xs`, into
    /// `values` and `gradients` (as long).
    pub fn values_and_gradients(
        &self,
        xs: &[[f64; 3]],
        values: &mut [[f64; 3]],
        gradients: &mut [[[f64; 3]; 3]],
    ) {
        assert!(xs.len() == values.len() && xs.len() == gradients.len());
        self.batches(Order::Gradient, xs, |offset, plan, ws| {
            let range = offset..offset + LANES.min(xs.len() - offset);
            for i in 0..3 {
                let lane = plan.lane(ws, i, 0);
                for (o, v) in values[range.clone()].iter_mut().zip(lane) {
                    o[i] = *v;
                }
                for j in 0..3 {
                    let lane = plan.lane(ws, i, 1 + j);
                    for (g, v) in gradients[range.clone()].iter_mut().zip(lane) {
                        g[i][j] = *v;
                    }
                }
            }
        });
    }

    /// The body loads [`body_load_from_displacement`] of the field at `xs`,
    /// into `out` (as long).
    pub fn body_loads(&self, lambda: f64, mu: f64, xs: &[[f64; 3]], out: &mut [[f64; 3]]) {
        assert_eq!(xs.len(), out.len());
        self.batches(Order::Hessian, xs, |offset, plan, ws| {
            let n = LANES.min(xs.len() - offset);
            for (l, o) in out[offset..offset + n].iter_mut().enumerate() {
                let hess = std::array::from_fn(|i| {
                    let mut h = [[0.0; 3]; 3];
                    for (k, &(a, b)) in HESSIAN.iter().enumerate() {
                        h[a][b] = plan.lane(ws, i, 4 + k)[l];
                        h[b][a] = h[a][b];
                    }
                    h
                });
                *o = body_load_of(&hess, lambda, mu);
            }
        });
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
    body_load_of(&u.hessians(x), lambda, mu)
}

/// `−(μ Δu + (λ + μ) ∇(∇·u))` from the Hessians of the components of `u`.
fn body_load_of(hess: &[Mat3; 3], lambda: f64, mu: f64) -> [f64; 3] {
    std::array::from_fn(|i| {
        let laplacian: f64 = (0..3).map(|j| hess[i][j][j]).sum();
        let grad_div: f64 = (0..3).map(|j| hess[j][i][j]).sum();
        -(mu * laplacian + (lambda + mu) * grad_div)
    })
}
