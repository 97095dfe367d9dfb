//! Triquadratic hexahedron (Q2, 27 nodes) on the reference unit cube
//! `[0,1]^3`: the 1D quadratic Lagrange basis and its tensor-product shape
//! functions.
//!
//! 1D basis on nodes `t = 0, ½, 1`:
//! `φ_0(t) = (1 − t)(1 − 2t)`, `φ_1(t) = 4t(1 − t)`, `φ_2(t) = t(2t − 1)`,
//! with derivatives `φ_0' = 4t − 3`, `φ_1' = 4 − 8t`, `φ_2' = 4t − 1`.
//! The shape function of local node `(a, b, c)` is
//! `N = φ_a(ξ_x) φ_b(ξ_y) φ_c(ξ_z)`.
use super::{tensor_gradients, tensor_values};

/// Quadratic Lagrange basis on the nodes `0, ½, 1`.
fn basis_1d(t: f64) -> [f64; 3] {
    [
        (1.0 - t) * (1.0 - 2.0 * t),
        4.0 * t * (1.0 - t),
        t * (2.0 * t - 1.0),
    ]
}

/// Derivatives of the quadratic basis: `[4t − 3, 4 − 8t, 4t − 1]`.
fn derivative_1d(t: f64) -> [f64; 3] {
    [4.0 * t - 3.0, 4.0 - 8.0 * t, 4.0 * t - 1.0]
}

/// The 27 triquadratic shape function values at `xi`, lexicographic order.
pub(super) fn shape_values(xi: [f64; 3], out: &mut [f64]) {
    let phi = xi.map(basis_1d);
    tensor_values([&phi[0], &phi[1], &phi[2]], out);
}

/// The 27 triquadratic shape function reference gradients at `xi`.
pub(super) fn shape_gradients(xi: [f64; 3], out: &mut [[f64; 3]]) {
    let phi = xi.map(basis_1d);
    let dphi = xi.map(derivative_1d);
    tensor_gradients(
        [&phi[0], &phi[1], &phi[2]],
        [&dphi[0], &dphi[1], &dphi[2]],
        out,
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basis_is_nodal_and_sums_to_one() {
        let nodes = [0.0, 0.5, 1.0];
        for (b, &t) in nodes.iter().enumerate() {
            let phi = basis_1d(t);
            for (a, &value) in phi.iter().enumerate() {
                let expected = if a == b { 1.0 } else { 0.0 };
                assert!((value - expected).abs() < 1e-15);
            }
        }
        for i in 0..=10 {
            let phi = basis_1d(i as f64 / 10.0);
            assert!((phi[0] + phi[1] + phi[2] - 1.0).abs() < 1e-15);
        }
    }

    #[test]
    fn derivative_matches_central_differences() {
        let step = 1e-6;
        for t in [0.1, 0.37, 0.9] {
            let (p, m) = (basis_1d(t + step), basis_1d(t - step));
            let d = derivative_1d(t);
            for a in 0..3 {
                assert!(((p[a] - m[a]) / (2.0 * step) - d[a]).abs() < 1e-8);
            }
        }
    }

    #[test]
    fn centre_node_is_the_cubic_bubble() {
        // Node 13 = (1, 1, 1): 64 ξ_x(1 − ξ_x) ξ_y(1 − ξ_y) ξ_z(1 − ξ_z).
        let xi = [0.2, 0.6, 0.9];
        let mut n = [0.0; 27];
        shape_values(xi, &mut n);
        let bubble = 64.0 * 0.2 * 0.8 * 0.6 * 0.4 * 0.9 * 0.1;
        assert!((n[13] - bubble).abs() < 1e-14);
        let mut g = [[0.0; 3]; 27];
        shape_gradients(xi, &mut g);
        let dx = 64.0 * (1.0 - 2.0 * 0.2) * 0.6 * 0.4 * 0.9 * 0.1;
        assert!((g[13][0] - dx).abs() < 1e-14);
    }
}
