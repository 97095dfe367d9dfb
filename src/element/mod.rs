//! Finite elements on the Cartesian grid: hex8 (Q1) and hex27 (Q2).
//!
//! Owns the element order, the order-generic shape function dispatch on the
//! reference unit cube `[0,1]^3`, the tensor-product helpers shared by both
//! element families, and tensor Gauss rules on the unit cube.
//!
//! Local node numbering is tensor-lexicographic: for degree `p`, the node
//! `(a, b, c)` with `a, b, c ∈ 0..=p` (`a` along x) has index
//! `a + (p+1)·(b + (p+1)·c)` and sits at `(a/p, b/p, c/p)`. The grid numbers its
//! nodes the same way, so a cell's node `(a, b, c)` is global node
//! `(p·i + a, p·j + b, p·k + c)`.
mod hex27;
mod hex8;
pub mod reference;

use crate::quadrature::gauss::gauss_legendre_unit;
use serde::{Deserialize, Serialize};

/// Polynomial order of the Lagrange hexahedron: trilinear (8 nodes) or
/// triquadratic (27 nodes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ElementOrder {
    /// Trilinear hex8.
    Q1,
    /// Triquadratic hex27.
    Q2,
}

impl ElementOrder {
    /// Polynomial degree `p` per axis.
    pub fn degree(self) -> usize {
        match self {
            ElementOrder::Q1 => 1,
            ElementOrder::Q2 => 2,
        }
    }

    /// Nodes per axis of one cell, `p + 1`.
    pub fn nodes_per_axis(self) -> usize {
        self.degree() + 1
    }

    /// Nodes per cell, `(p + 1)^3`.
    pub fn nodes_per_cell(self) -> usize {
        let n = self.nodes_per_axis();
        n * n * n
    }

    /// Gauss points per axis of the full rule, `p + 1`: exact for the
    /// stiffness integrand `Bᵀ D B` (degree `2p` per axis) and for the mass
    /// integrand `N_a N_b` (degree `2p` per axis).
    pub fn gauss_points_per_axis(self) -> usize {
        self.degree() + 1
    }
}

/// Reference coordinates of local node `node` on the unit cube:
/// `(a/p, b/p, c/p)` with `node = a + (p+1)·(b + (p+1)·c)`.
pub fn reference_node(order: ElementOrder, node: usize) -> [f64; 3] {
    let n = order.nodes_per_axis();
    let p = order.degree() as f64;
    assert!(
        node < order.nodes_per_cell(),
        "local node {node} out of range"
    );
    let a = node % n;
    let b = (node / n) % n;
    let c = node / (n * n);
    [a as f64 / p, b as f64 / p, c as f64 / p]
}

/// Shape function values `N_a(ξ)` at reference point `xi ∈ [0,1]^3`.
///
/// `out` must hold exactly `order.nodes_per_cell()` entries.
pub fn shape_values(order: ElementOrder, xi: [f64; 3], out: &mut [f64]) {
    assert_eq!(out.len(), order.nodes_per_cell(), "shape value buffer");
    match order {
        ElementOrder::Q1 => hex8::shape_values(xi, out),
        ElementOrder::Q2 => hex27::shape_values(xi, out),
    }
}

/// Reference gradients `∇_ξ N_a(ξ)` at reference point `xi ∈ [0,1]^3`.
///
/// For a cell of size `h` the physical gradient is `∇_ξ N_a / h`.
/// `out` must hold exactly `order.nodes_per_cell()` entries.
pub fn shape_gradients(order: ElementOrder, xi: [f64; 3], out: &mut [[f64; 3]]) {
    assert_eq!(out.len(), order.nodes_per_cell(), "shape gradient buffer");
    match order {
        ElementOrder::Q1 => hex8::shape_gradients(xi, out),
        ElementOrder::Q2 => hex27::shape_gradients(xi, out),
    }
}

/// Tensor-product Gauss–Legendre rule with `n` points per axis on `[0,1]^3`.
///
/// Points are ordered x fastest, then y, then z; weights sum to 1. Exact for
/// polynomials of degree `2n − 1` in each variable.
pub fn tensor_gauss_rule(n: usize) -> Vec<([f64; 3], f64)> {
    let (x, w) = gauss_legendre_unit(n);
    let mut rule = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                rule.push(([x[i], x[j], x[k]], w[i] * w[j] * w[k]));
            }
        }
    }
    rule
}

/// Tensor-product values `N_{a,b,c} = φ_a(ξ_x) φ_b(ξ_y) φ_c(ξ_z)` from the 1D
/// basis values `phi[axis][a]`, in lexicographic node order.
fn tensor_values(phi: [&[f64]; 3], out: &mut [f64]) {
    let n = phi[0].len();
    for c in 0..n {
        for b in 0..n {
            for a in 0..n {
                out[a + n * (b + n * c)] = phi[0][a] * phi[1][b] * phi[2][c];
            }
        }
    }
}

/// Tensor-product gradients
/// `∇N_{a,b,c} = (φ'_a φ_b φ_c, φ_a φ'_b φ_c, φ_a φ_b φ'_c)` from the 1D basis
/// values `phi[axis][a]` and derivatives `dphi[axis][a]`.
fn tensor_gradients(phi: [&[f64]; 3], dphi: [&[f64]; 3], out: &mut [[f64; 3]]) {
    let n = phi[0].len();
    for c in 0..n {
        for b in 0..n {
            for a in 0..n {
                out[a + n * (b + n * c)] = [
                    dphi[0][a] * phi[1][b] * phi[2][c],
                    phi[0][a] * dphi[1][b] * phi[2][c],
                    phi[0][a] * phi[1][b] * dphi[2][c],
                ];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const ORDERS: [ElementOrder; 2] = [ElementOrder::Q1, ElementOrder::Q2];

    fn sample_points(count: usize) -> Vec<[f64; 3]> {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut points = Vec::with_capacity(count);
        for _ in 0..count {
            points.push([rng.gen(), rng.gen(), rng.gen()]);
        }
        points
    }

    fn values(order: ElementOrder, xi: [f64; 3]) -> Vec<f64> {
        let mut out = vec![0.0; order.nodes_per_cell()];
        shape_values(order, xi, &mut out);
        out
    }

    fn gradients(order: ElementOrder, xi: [f64; 3]) -> Vec<[f64; 3]> {
        let mut out = vec![[0.0; 3]; order.nodes_per_cell()];
        shape_gradients(order, xi, &mut out);
        out
    }

    /// Interpolates `f` at the nodes and returns the FE value and gradient at `xi`.
    fn interpolate(
        order: ElementOrder,
        f: impl Fn([f64; 3]) -> f64,
        xi: [f64; 3],
    ) -> (f64, [f64; 3]) {
        let n = values(order, xi);
        let g = gradients(order, xi);
        let mut u = 0.0;
        let mut du = [0.0; 3];
        for a in 0..order.nodes_per_cell() {
            let fa = f(reference_node(order, a));
            u += n[a] * fa;
            for d in 0..3 {
                du[d] += g[a][d] * fa;
            }
        }
        (u, du)
    }

    #[test]
    fn order_properties() {
        let q1 = ElementOrder::Q1;
        let q2 = ElementOrder::Q2;
        assert_eq!((q1.degree(), q2.degree()), (1, 2));
        assert_eq!((q1.nodes_per_axis(), q2.nodes_per_axis()), (2, 3));
        assert_eq!((q1.nodes_per_cell(), q2.nodes_per_cell()), (8, 27));
        assert_eq!(
            (q1.gauss_points_per_axis(), q2.gauss_points_per_axis()),
            (2, 3)
        );
    }

    #[test]
    fn order_serde_names_are_lowercase() {
        assert_eq!(serde_json::to_string(&ElementOrder::Q1).unwrap(), "\"q1\"");
        assert_eq!(serde_json::to_string(&ElementOrder::Q2).unwrap(), "\"q2\"");
        let q2: ElementOrder = serde_json::from_str("\"q2\"").unwrap();
        assert_eq!(q2, ElementOrder::Q2);
        assert!(serde_json::from_str::<ElementOrder>("\"Q3\"").is_err());
    }

    #[test]
    fn reference_nodes_are_lexicographic() {
        assert_eq!(reference_node(ElementOrder::Q1, 1), [1.0, 0.0, 0.0]);
        assert_eq!(reference_node(ElementOrder::Q1, 6), [0.0, 1.0, 1.0]);
        assert_eq!(reference_node(ElementOrder::Q2, 1), [0.5, 0.0, 0.0]);
        assert_eq!(reference_node(ElementOrder::Q2, 3), [0.0, 0.5, 0.0]);
        assert_eq!(reference_node(ElementOrder::Q2, 13), [0.5, 0.5, 0.5]);
        assert_eq!(reference_node(ElementOrder::Q2, 26), [1.0, 1.0, 1.0]);
    }

    #[test]
    fn partition_of_unity() {
        for order in ORDERS {
            for xi in sample_points(50) {
                let sum: f64 = values(order, xi).iter().sum();
                assert!((sum - 1.0).abs() < 1e-14, "{order:?} sum {sum}");
                let g = gradients(order, xi);
                for d in 0..3 {
                    let gsum: f64 = g.iter().map(|g| g[d]).sum();
                    assert!(gsum.abs() < 1e-12, "{order:?} gradient sum {gsum}");
                }
            }
        }
    }

    #[test]
    fn kronecker_delta_at_nodes() {
        for order in ORDERS {
            for b in 0..order.nodes_per_cell() {
                let n = values(order, reference_node(order, b));
                for (a, &na) in n.iter().enumerate() {
                    let expected = if a == b { 1.0 } else { 0.0 };
                    assert!(
                        (na - expected).abs() < 1e-14,
                        "{order:?} N_{a}(x_{b}) = {na}"
                    );
                }
            }
        }
    }

    #[test]
    fn gradients_match_central_differences() {
        let step = 1e-5;
        for order in ORDERS {
            for xi in sample_points(20) {
                let g = gradients(order, xi);
                for d in 0..3 {
                    let mut plus = xi;
                    let mut minus = xi;
                    plus[d] += step;
                    minus[d] -= step;
                    let np = values(order, plus);
                    let nm = values(order, minus);
                    for a in 0..order.nodes_per_cell() {
                        let fd = (np[a] - nm[a]) / (2.0 * step);
                        assert!(
                            (fd - g[a][d]).abs() < 1e-7,
                            "{order:?} node {a} dir {d}: {fd} vs {}",
                            g[a][d]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn q1_reproduces_linear_fields() {
        let f = |x: [f64; 3]| 0.3 - 1.2 * x[0] + 2.5 * x[1] + 0.7 * x[2];
        for xi in sample_points(20) {
            let (u, du) = interpolate(ElementOrder::Q1, f, xi);
            assert!((u - f(xi)).abs() < 1e-13);
            let exact = [-1.2, 2.5, 0.7];
            for d in 0..3 {
                assert!((du[d] - exact[d]).abs() < 1e-12);
            }
        }
        // A quadratic is not reproduced: the test above can fail.
        let (u, _) = interpolate(ElementOrder::Q1, |x| x[0] * x[0], [0.5; 3]);
        assert!((u - 0.25).abs() > 0.1);
    }

    #[test]
    fn q2_reproduces_quadratic_fields() {
        let f = |x: [f64; 3]| {
            1.0 + x[0] - 2.0 * x[1] + 0.5 * x[2] + 3.0 * x[0] * x[0] - x[1] * x[1]
                + 0.25 * x[2] * x[2]
                + 1.5 * x[0] * x[1]
                - 0.75 * x[1] * x[2]
                + 2.0 * x[0] * x[2]
        };
        let grad = |x: [f64; 3]| {
            [
                1.0 + 6.0 * x[0] + 1.5 * x[1] + 2.0 * x[2],
                -2.0 - 2.0 * x[1] + 1.5 * x[0] - 0.75 * x[2],
                0.5 + 0.5 * x[2] - 0.75 * x[1] + 2.0 * x[0],
            ]
        };
        for xi in sample_points(20) {
            let (u, du) = interpolate(ElementOrder::Q2, f, xi);
            assert!((u - f(xi)).abs() < 1e-13);
            let exact = grad(xi);
            for d in 0..3 {
                assert!((du[d] - exact[d]).abs() < 1e-12);
            }
        }
        let (u, _) = interpolate(ElementOrder::Q2, |x| x[0].powi(3), [0.25; 3]);
        assert!((u - 0.25f64.powi(3)).abs() > 1e-3);
    }

    #[test]
    fn tensor_gauss_rule_integrates_monomials() {
        for n in 1..=4 {
            let rule = tensor_gauss_rule(n);
            assert_eq!(rule.len(), n * n * n);
            let total: f64 = rule.iter().map(|(_, w)| w).sum();
            assert!((total - 1.0).abs() < 1e-14);
            for (i, j, k) in [(0, 0, 0), (2 * n - 1, 0, 1), (1, 2 * n - 1, 2 * n - 1)] {
                let q: f64 = rule
                    .iter()
                    .map(|(x, w)| {
                        w * x[0].powi(i as i32) * x[1].powi(j as i32) * x[2].powi(k as i32)
                    })
                    .sum();
                let exact = 1.0 / ((i + 1) * (j + 1) * (k + 1)) as f64;
                assert!((q - exact).abs() < 1e-14, "n={n} ({i},{j},{k})");
            }
        }
    }
}
