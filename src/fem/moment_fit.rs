//! Moment-fitted Gauss weights: what a cut cell stores instead of its dense
//! matrix, and the dense matrix (and its diagonal) rebuilt from them.
//!
//! # The identity
//! Let `p` be the element degree and `Q_k` the tensor polynomials of degree
//! `≤ k` in each of `ξ_x, ξ_y, ξ_z` separately. Every entry of a cut cell's
//! matrix
//!
//! ```text
//! K_cut = Σ_s w_s B(ξ_s)ᵀ D B(ξ_s) + Σ_{Dirichlet s} w_s (β/h) N(ξ_s)ᵀN(ξ_s) ⊗ I₃
//! ```
//! is a rule `Σ_s w_s f(ξ_s)` applied to a product of two shape functions or
//! of two of their derivatives, `∂N_a ∂N_b` or `N_a N_b`, each in `Q_{2p}`
//! (a shape function has degree `p` per axis, a derivative `≤ p`).
//!
//! Take the `n = 2p + 1` Gauss points `t_i` of `[0, 1]`, the tensor points
//! `ξ_q = (t_i, t_j, t_k)` and their Lagrange polynomials
//! `L_q(ξ) = ℓ_i(ξ_x) ℓ_j(ξ_y) ℓ_k(ξ_z)`, `ℓ_i(t_r) = δ_ir`. They are `n³`
//! polynomials of `Q_{2p}` with `L_q(ξ_r) = δ_qr`, hence a basis of `Q_{2p}`
//! (of dimension `n³`), and every `f ∈ Q_{2p}` is its own interpolant,
//! `f = Σ_q f(ξ_q) L_q`. So for any rule `(ξ_s, w_s)`
//!
//! ```text
//! Σ_s w_s f(ξ_s) = Σ_q f(ξ_q) Σ_s w_s L_q(ξ_s) = Σ_q W_q f(ξ_q),   W_q = Σ_s w_s L_q(ξ_s),
//! ```
//! exactly, for every `f ∈ Q_{2p}`. Applied entry by entry,
//!
//! ```text
//! K_cut = Σ_q W_q B(ξ_q)ᵀ D B(ξ_q) + Σ_q M_q N(ξ_q)ᵀN(ξ_q) ⊗ I₃,
//! W_q = Σ_{volume s} w_s L_q(ξ_s),   M_q = (β/h) Σ_{Dirichlet s} w_s L_q(ξ_s),
//! ```
//! with no approximation: the two sides differ by round-off only (the `L_q`
//! are bounded on the cell, all points lie in it). The S-term of a
//! pathological cell, `(k2 E/h²) h³ M_ref`, is the whole-cell mass integrated
//! by the full `n`-point Gauss rule, exact on `Q_{2p}`, at the same points: it
//! adds `(k2 E/h²) h³ w^G_q` to `M_q` ([`CutWeights::add_cell_mass`]).
//!
//! A cut cell thus stores `2 n³` numbers (54 for Q1, 250 for Q2) instead of
//! `(3 (p+1)³)²` (576, 6561). The apply evaluates the sums at the points
//! ([`super::cut_apply`]); [`FitBasis::expand`] rebuilds the dense matrix for
//! the assembly, the GPU upload and the tests.

use crate::element::{shape_gradients, shape_values, ElementOrder};
use crate::quadrature::gauss::gauss_legendre_unit;

/// The fitting points of an order on the unit cube: the `2p + 1` Gauss points
/// per axis, and the shape functions and gradients of the element there.
#[derive(Clone, Debug)]
pub struct FitBasis {
    pub order: ElementOrder,
    /// The 1D Gauss points and weights on `[0, 1]`.
    pub points: Vec<f64>,
    pub weights: Vec<f64>,
    /// `N_a(ξ_q)`, `nodes_per_cell` per point, points x fastest.
    values: Vec<f64>,
    /// `∇_ξ N_a(ξ_q)`, likewise.
    gradients: Vec<[f64; 3]>,
}

impl FitBasis {
    pub fn new(order: ElementOrder) -> FitBasis {
        let (points, weights) = gauss_legendre_unit(2 * order.degree() + 1);
        let npc = order.nodes_per_cell();
        let n = points.len();
        let mut values = vec![0.0; n * n * n * npc];
        let mut gradients = vec![[0.0; 3]; n * n * n * npc];
        for q in 0..n * n * n {
            let xi = [q % n, (q / n) % n, q / (n * n)].map(|i| points[i]);
            shape_values(order, xi, &mut values[q * npc..(q + 1) * npc]);
            shape_gradients(order, xi, &mut gradients[q * npc..(q + 1) * npc]);
        }
        FitBasis {
            order,
            points,
            weights,
            values,
            gradients,
        }
    }

    /// Points per axis, `2p + 1`.
    pub fn points_per_axis(&self) -> usize {
        self.points.len()
    }

    /// Points per cell, `(2p + 1)³`.
    pub fn num_points(&self) -> usize {
        self.points.len().pow(3)
    }

    /// Bytes of the tables.
    pub fn bytes(&self) -> usize {
        8 * (self.points.len() + self.weights.len() + self.values.len()) + 24 * self.gradients.len()
    }

    /// `N_a(ξ_q)` and `∇_ξ N_a(ξ_q)` for every node `a`.
    pub fn point(&self, q: usize) -> (&[f64], &[[f64; 3]]) {
        let npc = self.order.nodes_per_cell();
        (
            &self.values[q * npc..(q + 1) * npc],
            &self.gradients[q * npc..(q + 1) * npc],
        )
    }

    /// `out[q] += w L_q(ξ)` for every fitting point `q`.
    pub fn add_point(&self, xi: [f64; 3], w: f64, out: &mut [f64]) {
        let n = self.points.len();
        let l = xi.map(|t| lagrange(&self.points, t));
        for k in 0..n {
            for j in 0..n {
                let wjk = w * l[1][j] * l[2][k];
                for i in 0..n {
                    out[i + n * (j + n * k)] += wjk * l[0][i];
                }
            }
        }
    }

    /// `out[q] += factor w^G_q`: the full-cell Gauss weights (unit cube).
    pub fn add_cell_rule(&self, factor: f64, out: &mut [f64]) {
        let n = self.points.len();
        let w = &self.weights;
        for (q, o) in out.iter_mut().enumerate() {
            *o += factor * w[q % n] * w[(q / n) % n] * w[q / (n * n)];
        }
    }

    /// The dense cell matrix (row-major `ne × ne`, `ne = 3 nodes_per_cell`) of
    /// stiffness weights `w` and mass weights `m` (see the module doc), for
    /// Lamé parameters `(λ, μ)` and cell size `1 / inv_h`:
    /// `K[3a+i, 3b+j] = λ A_ij[a,b] + μ A_ji[a,b] + δ_ij (μ Σ_d A_dd[a,b] + Σ_q m_q N_a N_b)`
    /// with `A_de[a,b] = Σ_q w_q ∂_d N_a ∂_e N_b` (physical gradients).
    pub fn expand(&self, w: &[f64], m: &[f64], (lambda, mu): (f64, f64), inv_h: f64) -> Vec<f64> {
        let npc = self.order.nodes_per_cell();
        let ne = 3 * npc;
        let mut a = vec![[[0.0; 3]; 3]; npc * npc];
        let mut mass = vec![0.0; npc * npc];
        let s = inv_h * inv_h;
        for q in 0..self.num_points() {
            let g = &self.gradients[q * npc..(q + 1) * npc];
            let v = &self.values[q * npc..(q + 1) * npc];
            for (ab, (aab, mab)) in a.iter_mut().zip(mass.iter_mut()).enumerate() {
                let (ga, gb) = (g[ab / npc], g[ab % npc]);
                for d in 0..3 {
                    for e in 0..3 {
                        aab[d][e] += w[q] * s * ga[d] * gb[e];
                    }
                }
                *mab += m[q] * v[ab / npc] * v[ab % npc];
            }
        }
        let mut k = vec![0.0; ne * ne];
        for (ab, (aab, mab)) in a.iter().zip(&mass).enumerate() {
            let (na, nb) = (ab / npc, ab % npc);
            let lap = aab[0][0] + aab[1][1] + aab[2][2];
            for i in 0..3 {
                for j in 0..3 {
                    let diag = if i == j { mu * lap + mab } else { 0.0 };
                    k[(3 * na + i) * ne + 3 * nb + j] = lambda * aab[i][j] + mu * aab[j][i] + diag;
                }
            }
        }
        k
    }

    /// The diagonal of [`FitBasis::expand`]'s matrix:
    /// `K[3a+i, 3a+i] = Σ_q w_q ((λ + μ) (∂_i N_a)² + μ |∇N_a|²) + m_q N_a²`.
    pub fn diagonal(&self, w: &[f64], m: &[f64], (lambda, mu): (f64, f64), inv_h: f64) -> Vec<f64> {
        let npc = self.order.nodes_per_cell();
        let mut d = vec![0.0; 3 * npc];
        let s = inv_h * inv_h;
        for q in 0..self.num_points() {
            let g = &self.gradients[q * npc..(q + 1) * npc];
            let v = &self.values[q * npc..(q + 1) * npc];
            for a in 0..npc {
                let norm2 = g[a].iter().map(|x| x * x).sum::<f64>();
                for i in 0..3 {
                    let stiff = (lambda + mu) * g[a][i] * g[a][i] + mu * norm2;
                    d[3 * a + i] += w[q] * s * stiff + m[q] * v[a] * v[a];
                }
            }
        }
        d
    }
}

/// The most 1D nodes of a Lagrange basis here: the fitting points of Q2
/// (3 or 5 per axis).
pub const MAX_LAGRANGE_NODES: usize = 5;

/// The values of a 1D Lagrange basis, on the stack: entry `i` for node `i`,
/// zeros past the basis' nodes.
pub type Lagrange1d = [f64; MAX_LAGRANGE_NODES];

/// The 1D Lagrange basis of `nodes` at `t`: `ℓ_i(t) = Π_{r≠i} (t − t_r)/(t_i − t_r)`.
///
/// # Panics
/// With more than [`MAX_LAGRANGE_NODES`] nodes.
pub fn lagrange(nodes: &[f64], t: f64) -> Lagrange1d {
    let mut out = [0.0; MAX_LAGRANGE_NODES];
    for (i, o) in out[..nodes.len()].iter_mut().enumerate() {
        *o = nodes
            .iter()
            .enumerate()
            .filter(|(r, _)| *r != i)
            .map(|(_, tr)| (t - tr) / (nodes[i] - tr))
            .product();
    }
    out
}

/// Derivatives `ℓ_i'(t)` of the 1D Lagrange basis of `nodes` (product rule).
///
/// # Panics
/// With more than [`MAX_LAGRANGE_NODES`] nodes.
pub fn lagrange_derivative(nodes: &[f64], t: f64) -> Lagrange1d {
    let n = nodes.len();
    let mut out = [0.0; MAX_LAGRANGE_NODES];
    for (i, o) in out[..n].iter_mut().enumerate() {
        *o = (0..n)
            .filter(|&k| k != i)
            .map(|k| {
                let others: f64 = (0..n)
                    .filter(|&r| r != i && r != k)
                    .map(|r| (t - nodes[r]) / (nodes[i] - nodes[r]))
                    .product();
                others / (nodes[i] - nodes[k])
            })
            .sum();
    }
    out
}

/// The weights of every cut cell, `2 n³` per cell in slot order: the
/// stiffness weights `W_q`, then the mass weights `M_q`.
#[derive(Clone, Debug)]
pub struct CutWeights {
    /// Points per cell, `n³`.
    pub nq: usize,
    pub data: Vec<f64>,
}

impl CutWeights {
    /// Number of cells.
    pub fn len(&self) -> usize {
        self.data.len() / (2 * self.nq)
    }

    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// The stiffness and mass weights of cell `s`.
    pub fn cell(&self, s: usize) -> (&[f64], &[f64]) {
        self.data[2 * self.nq * s..2 * self.nq * (s + 1)].split_at(self.nq)
    }

    /// Adds `factor · h³ M_ref` (the whole-cell vector mass) to cell `s`.
    pub fn add_cell_mass(&mut self, basis: &FitBasis, s: usize, factor_h3: f64) {
        let nq = self.nq;
        basis.add_cell_rule(factor_h3, &mut self.data[2 * nq * s + nq..2 * nq * (s + 1)]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// `Σ_q W_q f(ξ_q) = Σ_s w_s f(ξ_s)` for a random `f ∈ Q_{2p}` and a
    /// random rule; and not for a monomial of degree `2p + 1`.
    #[test]
    fn fitted_weights_integrate_the_tensor_space_exactly() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for order in [ElementOrder::Q1, ElementOrder::Q2] {
            let basis = FitBasis::new(order);
            let n = basis.points_per_axis();
            let coef: Vec<f64> = (0..n * n * n).map(|_| rng.gen_range(-1.0..1.0)).collect();
            let f = |x: [f64; 3]| -> f64 {
                (0..n * n * n)
                    .map(|e| {
                        let [i, j, k] = [e % n, (e / n) % n, e / (n * n)];
                        coef[e] * x[0].powi(i as i32) * x[1].powi(j as i32) * x[2].powi(k as i32)
                    })
                    .sum()
            };
            let high = |x: [f64; 3]| x[0].powi(n as i32) * x[1];
            let rule: Vec<([f64; 3], f64)> = (0..40)
                .map(|_| ([0; 3].map(|_| rng.gen::<f64>()), rng.gen::<f64>()))
                .collect();
            let mut w = vec![0.0; basis.num_points()];
            for &(x, ws) in &rule {
                basis.add_point(x, ws, &mut w);
            }
            let at = |q: usize| [q % n, (q / n) % n, q / (n * n)].map(|i| basis.points[i]);
            for (g, tol) in [(&f as &dyn Fn([f64; 3]) -> f64, 1e-13), (&high, -1.0)] {
                let direct: f64 = rule.iter().map(|&(x, ws)| ws * g(x)).sum();
                let fitted: f64 = (0..w.len()).map(|q| w[q] * g(at(q))).sum();
                let err = (direct - fitted).abs() / direct.abs();
                if tol > 0.0 {
                    assert!(err < tol, "{order:?}: {err:e}");
                } else {
                    assert!(err > 1e-6, "{order:?}: degree 2p+1 integrated exactly");
                }
            }
        }
    }

    #[test]
    fn lagrange_derivative_matches_differences() {
        let nodes = [0.1, 0.4, 0.55, 0.9];
        let (t, step) = (0.33, 1e-6);
        let d = lagrange_derivative(&nodes, t);
        let (p, m) = (lagrange(&nodes, t + step), lagrange(&nodes, t - step));
        for i in 0..4 {
            assert!(((p[i] - m[i]) / (2.0 * step) - d[i]).abs() < 1e-8);
        }
    }
}
