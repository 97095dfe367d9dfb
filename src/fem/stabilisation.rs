//! The S-stabilisation of pathological cells (paper eq. 5, DESIGN §3.2, §5.2).
//!
//! A cut cell with volume fraction `0 < A_c < A` is pathological; Ω* is their
//! union as whole cells. On Ω*
//!
//! ```text
//! K_S = Σ_{c ∈ Ω*} (k2 E / h²) M_c,        M_c = h³ M_ref (whole-cell mass),
//! F_S = Σ_{c ∈ Ω*} (k2 E / h²) ∫_c Nᵀ S(û) dV   (Gauss rule over the whole cell),
//! ```
//! where `S` is the recovered displacement: on the patch of each vertex node
//! a complete polynomial `û` of degree p+1 is fitted to `u_h` by least squares
//! (SPR), with internal equilibrium `∇·σ(û) + b = 0` imposed by collocation at
//! the patch node as Lagrange-multiplier constraints, and the patch
//! polynomials are blended by CPE, `S(x) = Σ_i N_i^lin(x) û_i(x)`. `S` is a
//! polynomial in each cell, so it is defined on the part of the cell outside
//! Ω too. Neumann-point equilibrium (`σ(û) n = t`) is not imposed yet.

use nalgebra::{DMatrix, DVector};

use super::field::value_and_gradient;
use super::recovery::{sample_positions, vertex_nodes_of};
use super::rhs::add_point_load;
use super::setup::Setup;
use crate::cells::Cells;
use crate::element::reference::vector_mass;
use crate::element::{tensor_gauss_rule, ElementOrder};
use crate::error::Result;
use crate::recovery::{
    recover, LinearConstraints, Monomials, Patch, PatchSamples, Recovered, Sample, SprOptions,
};

/// Pathological cells: cut cells with `0 < A_c < a`, ascending.
pub fn pathological_cells(cells: &Cells, a: f64) -> Vec<usize> {
    cells
        .cut
        .iter()
        .zip(&cells.fraction)
        .filter(|(_, &f)| f > 0.0 && f < a)
        .map(|(&c, _)| c)
        .collect()
}

/// `K_S` of one cell, row-major: `(k2 E / h²) h³ M_ref`.
pub fn cell_s_matrix(order: ElementOrder, factor: f64, h: f64) -> Vec<f64> {
    let m = vector_mass(order) * (factor * h.powi(3));
    let mut out = Vec::with_capacity(m.nrows() * m.ncols());
    for i in 0..m.nrows() {
        for j in 0..m.ncols() {
            out.push(m[(i, j)]);
        }
    }
    out
}

/// Samples of a displacement field (`value(cell, x)`, normally `u_h`) for the
/// displacement fit, with the equilibrium constraint.
struct DisplacementSamples<'a, F> {
    setup: &'a Setup,
    value: F,
    rule: Vec<([f64; 3], f64)>,
}

impl<F> PatchSamples<3> for DisplacementSamples<'_, F>
where
    F: Fn(usize, [f64; 3]) -> [f64; 3] + Sync,
{
    fn samples(&self, cell: usize, out: &mut Vec<Sample<3>>) {
        let mut xs = Vec::new();
        sample_positions(self.setup, cell, &self.rule, &mut xs);
        out.extend(xs.into_iter().map(|x| (x, (self.value)(cell, x))));
    }

    /// `h² (∇·σ(û))(x_node) = −h² b(x_node)`: three rows on the stacked
    /// coefficients (component `c`, term `j` at `c n_b + j`), from
    /// `∇·σ(û)_i = μ Δû_i + (λ + μ) ∂_i(∇·û)` and `∂²/∂x_k∂x_l = h⁻² ∂²/∂ξ_k∂ξ_l`.
    fn constraints(&self, patch: &Patch<'_>, basis: &Monomials) -> Option<LinearConstraints> {
        let (lambda, mu) = (self.setup.problem.lambda, self.setup.problem.mu);
        let nb = basis.len();
        let mut c = DMatrix::zeros(3, 3 * nb);
        for (j, e) in basis.exponents().iter().enumerate() {
            let d2 = |k: usize, l: usize| second_derivative_at_origin(*e, k, l);
            for i in 0..3 {
                for k in 0..3 {
                    c[(i, i * nb + j)] += mu * d2(k, k);
                    c[(i, k * nb + j)] += (lambda + mu) * d2(i, k);
                }
            }
        }
        let b = self.setup.problem.body_load(patch.center);
        let h2 = patch.h * patch.h;
        let d = DVector::from_iterator(3, b.iter().map(|v| -h2 * v));
        Some(LinearConstraints { c, d })
    }
}

/// `∂²(ξ^e)/∂ξ_k∂ξ_l` at ξ = 0 (nonzero only for the quadratic monomials).
fn second_derivative_at_origin(e: [usize; 3], k: usize, l: usize) -> f64 {
    let mut want = [0usize; 3];
    want[k] += 1;
    want[l] += 1;
    if e != want {
        return 0.0;
    }
    if k == l {
        2.0
    } else {
        1.0
    }
}

/// The displacement recovery `S` of `u_h` on the patches of the vertex nodes
/// of Ω*.
pub fn recover_displacement(
    setup: &Setup,
    u: &[f64],
    omega_star: &[usize],
) -> Result<Recovered<3>> {
    let (grid, dofs) = (&setup.grid, &setup.op.dofs);
    recover_displacement_of(setup, omega_star, |cell, x| {
        value_and_gradient(grid, dofs, u, cell, x).0
    })
}

/// The displacement recovery `S` of any field sampled as `value(cell, x)` at
/// the SPR sample points of the patches of the vertex nodes of Ω* (the
/// solver passes `u_h`; tests pass an exact field to check reproduction).
pub fn recover_displacement_of<F>(
    setup: &Setup,
    omega_star: &[usize],
    value: F,
) -> Result<Recovered<3>>
where
    F: Fn(usize, [f64; 3]) -> [f64; 3] + Sync,
{
    let nodes = vertex_nodes_of(setup, omega_star);
    let samples = DisplacementSamples {
        setup,
        value,
        rule: tensor_gauss_rule(setup.op.dofs.order.gauss_points_per_axis()),
    };
    let degree = setup.op.dofs.order.degree() + 1;
    recover(
        &setup.grid,
        &setup.cells.kinds,
        &nodes,
        degree,
        &samples,
        &SprOptions::default(),
    )
}

/// `F_S = (k2 E / h²) Σ_{c ∈ Ω*} ∫_c Nᵀ S dV`, Gauss rule of one point more
/// per direction than the element's over the whole cell.
pub fn s_rhs(
    setup: &Setup,
    omega_star: &[usize],
    s: &Recovered<3>,
    factor: f64,
) -> Result<Vec<f64>> {
    let grid = &setup.grid;
    let mut rhs = vec![0.0; setup.op.dofs.ndofs()];
    let rule = tensor_gauss_rule(setup.op.dofs.order.gauss_points_per_axis() + 1);
    let vol = grid.h.powi(3);
    for &c in omega_star {
        let lo = grid.cell_box(c).lo;
        for (xi, w) in &rule {
            let x = [0, 1, 2].map(|a| lo[a] + grid.h * xi[a]);
            let v = s.eval(c, x)?;
            add_point_load(
                grid,
                &setup.op.dofs,
                c,
                x,
                v.map(|s| s * factor * w * vol),
                &mut rhs,
            );
        }
    }
    Ok(rhs)
}
