//! Reference element matrices on the unit cube `[0,1]^3` for isotropic linear
//! elasticity, and the pointwise ingredients (`B`, `D`) reused by cut-cell
//! integration.
//!
//! Degrees of freedom are node-major: `dof = 3·node + component`. Strains and
//! stresses use Voigt order `(xx, yy, zz, yz, xz, xy)` with engineering shear
//! strains `γ_ij = 2 ε_ij`, so that `ε : σ = ε_vᵀ D ε_v`.
//!
//! For a cube cell of size `h` with origin `x0`, a physical point `x` maps to
//! `ξ = (x − x0)/h`, `∇_x N = ∇_ξ N / h` and `dV = h³ dξ`, hence
//! `K_cell = h · K_ref` and `M_cell = h³ · M_ref`.
use super::{shape_gradients, shape_values, tensor_gauss_rule, ElementOrder};
use nalgebra::{DMatrix, Matrix6};

/// Most nodes of any supported element (Q2), for stack buffers.
const MAX_NODES: usize = 27;

/// Lamé parameters `(λ, μ)` from Young's modulus `E` and Poisson's ratio `ν`:
/// `λ = E ν / ((1 + ν)(1 − 2ν))`, `μ = E / (2(1 + ν))`.
pub fn lame(young: f64, poisson: f64) -> (f64, f64) {
    let lambda = young * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson));
    let mu = young / (2.0 * (1.0 + poisson));
    (lambda, mu)
}

/// Isotropic elasticity matrix `D` in Voigt order `(xx, yy, zz, yz, xz, xy)`
/// with engineering shear strains: `σ_v = D ε_v`, i.e.
/// `σ = λ tr(ε) I + 2 μ ε`. The normal block is `λ + 2μ` on the diagonal and
/// `λ` off it; the shear block is `μ I`.
pub fn elasticity_matrix(young: f64, poisson: f64) -> Matrix6<f64> {
    let (lambda, mu) = lame(young, poisson);
    let mut d = Matrix6::zeros();
    for i in 0..3 {
        for j in 0..3 {
            d[(i, j)] = lambda;
        }
        d[(i, i)] = lambda + 2.0 * mu;
        d[(i + 3, i + 3)] = mu;
    }
    d
}

/// Strain–displacement matrix `B` (6 × 3n) at reference point `xi` of a cell of
/// size `h = 1 / inv_h`, so that `ε_v = B U` for node-major nodal
/// displacements `U`. With `g = ∇_ξ N_a / h`, the columns of node `a` are
///
/// ```text
/// xx: [g_x, 0,   0  ]    yz: [0,   g_z, g_y]
/// yy: [0,   g_y, 0  ]    xz: [g_z, 0,   g_x]
/// zz: [0,   0,   g_z]    xy: [g_y, g_x, 0  ]
/// ```
///
/// For a physical point `x` in a cell with origin `x0` use `xi = (x − x0)/h`.
/// `out` must be `6 × 3·order.nodes_per_cell()`; every entry is overwritten.
pub fn strain_displacement(order: ElementOrder, xi: [f64; 3], inv_h: f64, out: &mut DMatrix<f64>) {
    let n = order.nodes_per_cell();
    assert_eq!(out.shape(), (6, 3 * n), "B matrix shape");
    let mut grads = [[0.0; 3]; MAX_NODES];
    shape_gradients(order, xi, &mut grads[..n]);
    for a in 0..n {
        let g = grads[a].map(|v| v * inv_h);
        let rows = [
            [g[0], 0.0, 0.0],
            [0.0, g[1], 0.0],
            [0.0, 0.0, g[2]],
            [0.0, g[2], g[1]],
            [g[2], 0.0, g[0]],
            [g[1], g[0], 0.0],
        ];
        for r in 0..6 {
            for c in 0..3 {
                out[(r, 3 * a + c)] = rows[r][c];
            }
        }
    }
}

/// Accumulates `K += w Bᵀ D B` without allocating: for each column `j`,
/// `(D B)_j` is formed on the stack and dotted with every column of `B`.
pub fn add_btdb(k: &mut DMatrix<f64>, b: &DMatrix<f64>, d: &Matrix6<f64>, weight: f64) {
    let ndof = b.ncols();
    assert_eq!(b.nrows(), 6, "B must have 6 rows");
    assert_eq!(k.shape(), (ndof, ndof), "K shape must match B");
    for j in 0..ndof {
        let mut db = [0.0; 6];
        for r in 0..6 {
            for s in 0..6 {
                db[r] += d[(r, s)] * b[(s, j)];
            }
        }
        for i in 0..ndof {
            let mut sum = 0.0;
            for r in 0..6 {
                sum += b[(r, i)] * db[r];
            }
            k[(i, j)] += weight * sum;
        }
    }
}

/// Reference stiffness `K_ref = ∫_{[0,1]^3} Bᵀ D B dξ` (with `inv_h = 1`),
/// integrated exactly by the order's full tensor Gauss rule. A cube cell of
/// size `h` has element stiffness `h · K_ref`.
pub fn reference_stiffness(order: ElementOrder, young: f64, poisson: f64) -> DMatrix<f64> {
    let ndof = 3 * order.nodes_per_cell();
    let d = elasticity_matrix(young, poisson);
    let mut k = DMatrix::zeros(ndof, ndof);
    let mut b = DMatrix::zeros(6, ndof);
    for (xi, w) in tensor_gauss_rule(order.gauss_points_per_axis()) {
        strain_displacement(order, xi, 1.0, &mut b);
        add_btdb(&mut k, &b, &d, w);
    }
    k
}

/// Scalar reference mass `M_ab = ∫_{[0,1]^3} N_a N_b dξ` (n × n), exact with
/// the full Gauss rule. A cube cell of size `h` has mass `h³ · M_ref`. It is
/// the tensor product of the 1D mass matrices, and its entries sum to 1.
pub fn reference_mass(order: ElementOrder) -> DMatrix<f64> {
    reference_box_mass(order, [0.0; 3], [1.0; 3])
}

/// The scalar mass of the cell's shape functions over the box `[lo, hi] ⊂
/// [0,1]³` of reference coordinates, `∫_box N_a N_b dξ`: the full Gauss rule
/// mapped onto the box, exact (the products are of degree `2p` per axis).
/// Its entries sum to the box's volume.
pub fn reference_box_mass(order: ElementOrder, lo: [f64; 3], hi: [f64; 3]) -> DMatrix<f64> {
    let n = order.nodes_per_cell();
    let mut m = DMatrix::zeros(n, n);
    let mut values = [0.0; MAX_NODES];
    let size = [0, 1, 2].map(|a| hi[a] - lo[a]);
    let volume = size[0] * size[1] * size[2];
    for (xi, w) in tensor_gauss_rule(order.gauss_points_per_axis()) {
        let x = [0, 1, 2].map(|a| lo[a] + size[a] * xi[a]);
        shape_values(order, x, &mut values[..n]);
        for j in 0..n {
            for i in 0..n {
                m[(i, j)] += w * volume * values[i] * values[j];
            }
        }
    }
    m
}

/// Vector reference mass (3n × 3n): `M_(3a+c, 3b+e) = δ_ce M_ab`, the scalar
/// mass repeated on each displacement component.
pub fn vector_mass(order: ElementOrder) -> DMatrix<f64> {
    let scalar = reference_mass(order);
    let n = scalar.nrows();
    let mut m = DMatrix::zeros(3 * n, 3 * n);
    for j in 0..n {
        for i in 0..n {
            for c in 0..3 {
                m[(3 * i + c, 3 * j + c)] = scalar[(i, j)];
            }
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::reference_node;
    use nalgebra::{DVector, Matrix3, Vector6};

    const ORDERS: [ElementOrder; 2] = [ElementOrder::Q1, ElementOrder::Q2];
    const YOUNG: f64 = 2.5;
    const POISSON: f64 = 0.3;

    /// A fixed non-symmetric displacement gradient.
    fn gradient() -> Matrix3<f64> {
        Matrix3::new(0.3, -0.7, 0.2, 0.5, 0.1, -0.4, 0.9, 0.6, -0.2)
    }

    /// Node-major nodal values of `u(x) = u0 + G x` at `x = x0 + h ξ_node`.
    fn nodal_field(
        order: ElementOrder,
        u0: [f64; 3],
        g: &Matrix3<f64>,
        x0: [f64; 3],
        h: f64,
    ) -> DVector<f64> {
        let n = order.nodes_per_cell();
        let mut u = DVector::zeros(3 * n);
        for a in 0..n {
            let xi = reference_node(order, a);
            for i in 0..3 {
                u[3 * a + i] = u0[i];
                for j in 0..3 {
                    u[3 * a + i] += g[(i, j)] * (x0[j] + h * xi[j]);
                }
            }
        }
        u
    }

    /// Voigt strain `(xx, yy, zz, 2yz, 2xz, 2xy)` of `sym(G)`.
    fn voigt_strain(g: &Matrix3<f64>) -> Vector6<f64> {
        let e = (g + g.transpose()) * 0.5;
        Vector6::new(
            e[(0, 0)],
            e[(1, 1)],
            e[(2, 2)],
            2.0 * e[(1, 2)],
            2.0 * e[(0, 2)],
            2.0 * e[(0, 1)],
        )
    }

    fn rigid_body_modes(order: ElementOrder) -> Vec<DVector<f64>> {
        let mut modes = Vec::new();
        for c in 0..3 {
            let mut t = [0.0; 3];
            t[c] = 1.0;
            modes.push(nodal_field(order, t, &Matrix3::zeros(), [0.0; 3], 1.0));
        }
        for (i, j) in [(0, 1), (1, 2), (0, 2)] {
            let mut w = Matrix3::zeros();
            w[(i, j)] = 1.0;
            w[(j, i)] = -1.0;
            modes.push(nodal_field(order, [0.0; 3], &w, [0.0; 3], 1.0));
        }
        modes
    }

    #[test]
    fn lame_parameters() {
        let (lambda, mu) = lame(1.0, 0.25);
        assert!((lambda - 0.4).abs() < 1e-15 && (mu - 0.4).abs() < 1e-15);
        let (lambda, mu) = lame(3.0, 0.0);
        assert!(lambda.abs() < 1e-15 && (mu - 1.5).abs() < 1e-15);
    }

    #[test]
    fn elasticity_matrix_gives_hooke_stress() {
        let (lambda, mu) = lame(YOUNG, POISSON);
        let g = gradient();
        let e = (g + g.transpose()) * 0.5;
        let sigma = Matrix3::identity() * (lambda * e.trace()) + e * (2.0 * mu);
        let sv = elasticity_matrix(YOUNG, POISSON) * voigt_strain(&g);
        let expected = [
            sigma[(0, 0)],
            sigma[(1, 1)],
            sigma[(2, 2)],
            sigma[(1, 2)],
            sigma[(0, 2)],
            sigma[(0, 1)],
        ];
        for r in 0..6 {
            assert!((sv[r] - expected[r]).abs() < 1e-14, "row {r}");
        }
    }

    #[test]
    fn strain_displacement_recovers_uniform_strain_in_physical_cell() {
        let (x0, h) = ([1.0, -2.0, 0.5], 0.3);
        let g = gradient();
        let expected = voigt_strain(&g);
        for order in ORDERS {
            let u = nodal_field(order, [0.1, 0.2, 0.3], &g, x0, h);
            let mut b = DMatrix::zeros(6, 3 * order.nodes_per_cell());
            for xi in [[0.1, 0.7, 0.3], [0.5, 0.5, 0.5], [0.95, 0.05, 0.6]] {
                strain_displacement(order, xi, 1.0 / h, &mut b);
                let strain = &b * &u;
                for r in 0..6 {
                    assert!((strain[r] - expected[r]).abs() < 1e-12, "{order:?} row {r}");
                }
            }
        }
    }

    #[test]
    fn add_btdb_matches_dense_product() {
        let order = ElementOrder::Q1;
        let d = elasticity_matrix(YOUNG, POISSON);
        let mut b = DMatrix::zeros(6, 24);
        strain_displacement(order, [0.2, 0.4, 0.8], 2.0, &mut b);
        let mut k = DMatrix::from_element(24, 24, 1.0);
        add_btdb(&mut k, &b, &d, 0.5);
        let expected = DMatrix::from_element(24, 24, 1.0) + b.transpose() * d * &b * 0.5;
        assert!((k - expected).amax() < 1e-13);
    }

    #[test]
    fn stiffness_is_symmetric() {
        for order in ORDERS {
            let k = reference_stiffness(order, YOUNG, POISSON);
            assert!((&k - k.transpose()).amax() <= 1e-14 * k.amax(), "{order:?}");
        }
    }

    #[test]
    fn stiffness_kernel_is_the_rigid_body_modes() {
        for order in ORDERS {
            let k = reference_stiffness(order, YOUNG, POISSON);
            for mode in rigid_body_modes(order) {
                let residual = (&k * &mode).norm();
                assert!(
                    residual <= 1e-12 * k.norm() * mode.norm(),
                    "{order:?}: {residual}"
                );
            }
            let mut eig: Vec<f64> = k.symmetric_eigen().eigenvalues.iter().copied().collect();
            eig.sort_by(f64::total_cmp);
            let max = eig[eig.len() - 1];
            for (i, &e) in eig.iter().enumerate() {
                if i < 6 {
                    assert!(e.abs() < 1e-12 * max, "{order:?} eigenvalue {i}: {e}");
                } else {
                    assert!(e > 1e-3 * max, "{order:?} eigenvalue {i}: {e}");
                }
            }
        }
    }

    #[test]
    fn uniform_strain_energy_is_exact() {
        let (lambda, mu) = lame(YOUNG, POISSON);
        let g = gradient();
        let e = (g + g.transpose()) * 0.5;
        let sigma = Matrix3::identity() * (lambda * e.trace()) + e * (2.0 * mu);
        let exact = 0.5 * e.component_mul(&sigma).sum();
        for order in ORDERS {
            let k = reference_stiffness(order, YOUNG, POISSON);
            let u = nodal_field(order, [0.0; 3], &g, [0.0; 3], 1.0);
            let energy = 0.5 * u.dot(&(&k * &u));
            assert!(
                (energy - exact).abs() <= 1e-12 * exact,
                "{order:?}: {energy} vs {exact}"
            );
        }
    }

    #[test]
    fn cell_stiffness_scales_with_h() {
        let h = 0.25;
        let d = elasticity_matrix(YOUNG, POISSON);
        for order in ORDERS {
            let ndof = 3 * order.nodes_per_cell();
            let mut k = DMatrix::zeros(ndof, ndof);
            let mut b = DMatrix::zeros(6, ndof);
            for (xi, w) in tensor_gauss_rule(order.gauss_points_per_axis()) {
                strain_displacement(order, xi, 1.0 / h, &mut b);
                add_btdb(&mut k, &b, &d, w * h * h * h);
            }
            let k_ref = reference_stiffness(order, YOUNG, POISSON);
            assert!((k - k_ref * h).amax() < 1e-13, "{order:?}");
        }
    }

    /// `M_1d ⊗ M_1d ⊗ M_1d` in lexicographic node order.
    fn tensorised(m1: &[&[f64]]) -> DMatrix<f64> {
        let p = m1.len();
        let n = p * p * p;
        DMatrix::from_fn(n, n, |i, j| {
            let (ia, ib, ic) = (i % p, (i / p) % p, i / (p * p));
            let (ja, jb, jc) = (j % p, (j / p) % p, j / (p * p));
            m1[ia][ja] * m1[ib][jb] * m1[ic][jc]
        })
    }

    #[test]
    fn mass_entries_sum_to_volume() {
        for order in ORDERS {
            assert!(
                (reference_mass(order).sum() - 1.0).abs() < 1e-13,
                "{order:?}"
            );
            assert!((vector_mass(order).sum() - 3.0).abs() < 1e-13, "{order:?}");
        }
    }

    #[test]
    fn q1_mass_is_tensorised_closed_form() {
        let m1: [&[f64]; 2] = [&[1.0 / 3.0, 1.0 / 6.0], &[1.0 / 6.0, 1.0 / 3.0]];
        let m = reference_mass(ElementOrder::Q1);
        assert!((m - tensorised(&m1)).amax() < 1e-15);
    }

    #[test]
    fn q2_mass_is_tensorised_closed_form() {
        // 1D quadratic mass on [0,1] with nodes 0, ½, 1: [[4,2,−1],[2,16,2],[−1,2,4]]/30.
        let r0 = [4.0 / 30.0, 2.0 / 30.0, -1.0 / 30.0];
        let r1 = [2.0 / 30.0, 16.0 / 30.0, 2.0 / 30.0];
        let r2 = [-1.0 / 30.0, 2.0 / 30.0, 4.0 / 30.0];
        let m = reference_mass(ElementOrder::Q2);
        assert!((m - tensorised(&[&r0, &r1, &r2])).amax() < 1e-15);
    }

    #[test]
    fn vector_mass_is_block_identity() {
        let order = ElementOrder::Q2;
        let (scalar, vector) = (reference_mass(order), vector_mass(order));
        for j in 0..27 {
            for i in 0..27 {
                for c in 0..3 {
                    for e in 0..3 {
                        let expected = if c == e { scalar[(i, j)] } else { 0.0 };
                        assert_eq!(vector[(3 * i + c, 3 * j + e)], expected);
                    }
                }
            }
        }
    }
}
