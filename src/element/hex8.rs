//! Trilinear hexahedron (Q1, 8 nodes) on the reference unit cube `[0,1]^3`:
//! the 1D linear Lagrange basis and its tensor-product shape functions.
//!
//! 1D basis on nodes `t = 0, 1`: `φ_0(t) = 1 − t`, `φ_1(t) = t`, with
//! derivatives `φ_0' = −1`, `φ_1' = 1`. The shape function of local node
//! `(a, b, c)` is `N = φ_a(ξ_x) φ_b(ξ_y) φ_c(ξ_z)`.
use super::{tensor_gradients, tensor_values};

/// Linear Lagrange basis `[1 − t, t]` on `[0, 1]`.
fn basis_1d(t: f64) -> [f64; 2] {
    [1.0 - t, t]
}

/// Derivatives `[−1, 1]` of the linear basis (independent of `t`).
fn derivative_1d(_t: f64) -> [f64; 2] {
    [-1.0, 1.0]
}

/// The 8 trilinear shape function values at `xi`, lexicographic node order.
pub(super) fn shape_values(xi: [f64; 3], out: &mut [f64]) {
    let phi = xi.map(basis_1d);
    tensor_values([&phi[0], &phi[1], &phi[2]], out);
}

/// The 8 trilinear shape function reference gradients at `xi`.
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
        assert_eq!(basis_1d(0.0), [1.0, 0.0]);
        assert_eq!(basis_1d(1.0), [0.0, 1.0]);
        for i in 0..=10 {
            let t = i as f64 / 10.0;
            let phi = basis_1d(t);
            assert!((phi[0] + phi[1] - 1.0).abs() < 1e-15);
        }
    }

    #[test]
    fn derivative_matches_central_differences() {
        let step = 1e-6;
        for t in [0.1, 0.37, 0.9] {
            let (p, m) = (basis_1d(t + step), basis_1d(t - step));
            let d = derivative_1d(t);
            for a in 0..2 {
                assert!(((p[a] - m[a]) / (2.0 * step) - d[a]).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn corner_node_shape_function() {
        let mut n = [0.0; 8];
        shape_values([0.25, 0.5, 0.75], &mut n);
        // Node 5 = (1, 0, 1): ξ_x (1 − ξ_y) ξ_z.
        assert!((n[5] - 0.25 * 0.5 * 0.75).abs() < 1e-15);
        let mut g = [[0.0; 3]; 8];
        shape_gradients([0.25, 0.5, 0.75], &mut g);
        let expected = [0.5 * 0.75, -0.25 * 0.75, 0.25 * 0.5];
        for d in 0..3 {
            assert!((g[5][d] - expected[d]).abs() < 1e-15);
        }
    }
}
