//! The S-stabilisation of pathological cells (paper eq. 5).
//!
//! A cut cell with volume fraction `0 < A_c < A` is pathological; Ω* is their
//! union as whole cells. On Ω*
//!
//! ```text
//! K_S = Σ_{c ∈ Ω*} (k2 E / h²) M_c,        M_c = h³ M_ref (whole-cell mass),
//! F_S = Σ_{c ∈ Ω*} (k2 E / h²) ∫_c Nᵀ S(û) dV   (Gauss rule over the whole cell),
//! ```
//! where `S` is the recovered displacement: on the patch of each vertex node
//! a complete polynomial `û` of degree p+1 (Q1: 2, 10 terms; Q2: 3, 20
//! terms, sampled at the element's Gauss points) is fitted to `u_h` by least
//! squares (SPR), with internal equilibrium `∇·σ(û) + b = 0` imposed by collocation at
//! the patch node as Lagrange-multiplier constraints, and the patch
//! polynomials are blended by CPE, `S(x) = Σ_i N_i^lin(x) û_i(x)`. `S` is a
//! polynomial in each cell, so it is defined on the part of the cell outside
//! Ω too. `F_S` is evaluated with `S + R a`, `R a` the rigid-body part of
//! `u_h − S` on Ω* (`crate::fem::rigid_resultant`): the paper's `F_S` puts a net
//! force on the body that no reaction balances; this one does not, and it
//! equals the paper's whenever `S(u_h) = u_h`. `[stabilisation] balanced =
//! false` keeps the paper's (what `reproduce` runs). Where the patch's cut cells carry Neumann points, boundary
//! equilibrium `σ(û) n = t` is collocated at the one nearest the patch node,
//! as three more constraint rows.

use std::sync::OnceLock;

use nalgebra::{DMatrix, DVector};

use super::recovery::{inside_moments, sample_positions, vertex_nodes_of};
use super::setup::Setup;
use super::share::CellShare;
use crate::discrete::field::{CellField, ShapeTable};
use crate::element::reference::vector_mass;
use crate::element::{tensor_gauss_rule, ElementOrder};
use crate::error::Result;
use crate::exact::ExactSum;
use crate::fem::problem::Boundary;
use crate::fem::rigid_resultant::RigidFit;
use crate::quadrature::saye::SurfacePoint;
use crate::recovery::{
    plan_fits, recover_planned, BlendTable, FitPlans, InsideMoments, LinearConstraints, Monomials,
    Patch, PatchSamples, Recovered, Sample, SprOptions,
};

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

/// Samples of a displacement field (`on_cell(cell)` evaluates it on one
/// cell, normally `u_h`) for the displacement fit, with the equilibrium
/// constraint.
struct DisplacementSamples<'a, F> {
    setup: &'a Setup,
    on_cell: F,
    rule: Vec<([f64; 3], f64)>,
    /// The nodal values of the field when `on_cell` evaluates `u_h`: an
    /// inside cell's moments are then one product with them.
    nodal: Option<(&'a [f64], InsideMoments)>,
}

impl<F, G> PatchSamples<3> for DisplacementSamples<'_, F>
where
    F: Fn(usize) -> G + Sync,
    G: Fn([f64; 3]) -> [f64; 3],
{
    fn samples(&self, cell: usize, out: &mut Vec<Sample<3>>) {
        let mut xs = Vec::new();
        sample_positions(self.setup, cell, &self.rule, &mut xs);
        let value = (self.on_cell)(cell);
        out.extend(xs.into_iter().map(|x| (x, value(x))));
    }

    fn moments(&self, cell: usize, basis: &Monomials, out: &mut [f64]) -> bool {
        match &self.nodal {
            Some((u, inside)) => inside_moments(self.setup, u, cell, inside, basis, out),
            None => false,
        }
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
        let mut d = DVector::from_iterator(3, b.iter().map(|v| -h2 * v));
        if let Some(q) = nearest_neumann_point(self.setup, patch) {
            let (rows, rhs) = traction_rows(self.setup, patch, basis, &q);
            c = c.resize_vertically(6, 0.0);
            d = d.resize_vertically(6, 0.0);
            for i in 0..3 {
                for j in 0..3 * nb {
                    c[(3 + i, j)] = rows[(i, j)];
                }
                d[3 + i] = rhs[i];
            }
        }
        Some(LinearConstraints { c, d })
    }
}

/// The Neumann surface point of the patch's cut cells nearest to the patch
/// node, if any: boundary equilibrium is collocated there (one point keeps
/// the small KKT system well posed however many points the patch holds).
fn nearest_neumann_point(setup: &Setup, patch: &Patch<'_>) -> Option<SurfacePoint> {
    let dist2 = |x: [f64; 3]| {
        (0..3)
            .map(|a| (x[a] - patch.center[a]).powi(2))
            .sum::<f64>()
    };
    patch
        .cells
        .iter()
        .filter_map(|&c| setup.cells.cut_position(c))
        .flat_map(|i| setup.cells.surface_points(i))
        .filter(|q| matches!(setup.problem.boundary[q.tag as usize], Boundary::Neumann(_)))
        .min_by(|a, b| dist2(a.x).total_cmp(&dist2(b.x)))
        .copied()
}

/// `h σ(û)(x_q) n_q = h t(x_q)`: three rows on the stacked coefficients, from
/// `(σ n)_i = λ n_i ∂_c û_c + μ (∂_i û_k + ∂_k û_i) n_k` and `∂/∂x = h⁻¹ ∂/∂ξ`.
fn traction_rows(
    setup: &Setup,
    patch: &Patch<'_>,
    basis: &Monomials,
    q: &SurfacePoint,
) -> (DMatrix<f64>, [f64; 3]) {
    let (lambda, mu) = (setup.problem.lambda, setup.problem.mu);
    let nb = basis.len();
    let xi = patch.scaled(q.x);
    let n = q.n;
    let mut rows = DMatrix::zeros(3, 3 * nb);
    for (j, e) in basis.exponents().iter().enumerate() {
        let g = monomial_gradient(*e, xi);
        let gn: f64 = (0..3).map(|k| g[k] * n[k]).sum();
        for i in 0..3 {
            for c in 0..3 {
                let mut v = lambda * n[i] * g[c] + mu * g[i] * n[c];
                if i == c {
                    v += mu * gn;
                }
                rows[(i, c * nb + j)] += v;
            }
        }
    }
    let t = setup.problem.traction(q.tag, q.x, n);
    (rows, t.map(|v| patch.h * v))
}

/// `∇_ξ ξ^e` at `xi`.
fn monomial_gradient(e: [usize; 3], xi: [f64; 3]) -> [f64; 3] {
    let pow = |a: usize, p: usize| xi[a].powi(p as i32);
    [0, 1, 2].map(|k| {
        if e[k] == 0 {
            return 0.0;
        }
        let mut v = e[k] as f64 * pow(k, e[k] - 1);
        for a in (0..3).filter(|&a| a != k) {
            v *= pow(a, e[a]);
        }
        v
    })
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
/// of Ω*, reusing the fits of an earlier recovery on the same patches when
/// `plans` holds them (see [`crate::recovery::recover_planned`]).
pub fn recover_displacement(
    setup: &Setup,
    u: &[f64],
    omega_star: &[usize],
    plans: Option<&OnceLock<FitPlans>>,
) -> Result<Recovered<3>> {
    let (grid, dofs) = (&setup.grid, &setup.op.dofs);
    let on_cell = |cell| {
        let field = CellField::new(grid, dofs, u, cell);
        move |x| field.value(x)
    };
    let (nodes, samples, degree) = displacement_fits(setup, omega_star, on_cell, Some(u));
    let opts = displacement_options(setup);
    let kinds = &setup.cells.kinds;
    recover_planned(grid, kinds, &nodes, degree, &samples, &opts, plans)
}

/// The displacement recovery `S` of any field at the SPR sample points of
/// the patches of the vertex nodes of Ω*, `on_cell(cell)` evaluating it on
/// one cell (the solver passes `u_h`, gathered once per cell; tests pass an
/// exact field to check reproduction).
pub fn recover_displacement_of<F, G>(
    setup: &Setup,
    omega_star: &[usize],
    on_cell: F,
    plans: Option<&OnceLock<FitPlans>>,
) -> Result<Recovered<3>>
where
    F: Fn(usize) -> G + Sync,
    G: Fn([f64; 3]) -> [f64; 3],
{
    let (nodes, samples, degree) = displacement_fits(setup, omega_star, on_cell, None);
    let opts = displacement_options(setup);
    let (grid, kinds) = (&setup.grid, &setup.cells.kinds);
    recover_planned(grid, kinds, &nodes, degree, &samples, &opts, plans)
}

/// Makes the fit plans of [`recover_displacement`] on Ω* in `plans`, from
/// the sample positions and the constraints alone.
pub fn plan_displacement(
    setup: &Setup,
    omega_star: &[usize],
    plans: &OnceLock<FitPlans>,
) -> Result<()> {
    let zero = |_| |_| [0.0; 3];
    let (nodes, samples, degree) = displacement_fits(setup, omega_star, zero, None);
    let opts = displacement_options(setup);
    let (grid, kinds) = (&setup.grid, &setup.cells.kinds);
    plan_fits(grid, kinds, &nodes, degree, &samples, &opts, plans)
}

/// The nodes, samples and degree of the displacement fits on Ω*; `nodal`:
/// the field's nodal values when `on_cell` evaluates `u_h`.
fn displacement_fits<'a, F>(
    setup: &'a Setup,
    omega_star: &[usize],
    on_cell: F,
    nodal: Option<&'a [f64]>,
) -> (Vec<usize>, DisplacementSamples<'a, F>, usize) {
    let order = setup.op.dofs.order;
    let rule = tensor_gauss_rule(order.gauss_points_per_axis());
    let degree = order.degree() + 1;
    let nodal = nodal.map(|u| {
        let shapes = ShapeTable::new(order, &rule, setup.grid.h);
        let xi: Vec<[f64; 3]> = rule.iter().map(|(x, _)| *x).collect();
        // Component `c` of the unit nodal value `k = 3a + i` at point `q`.
        let unit = |q: usize, c: usize, k: usize| match k % 3 == c {
            true => shapes.values(q)[k / 3],
            false => 0.0,
        };
        let cols = 3 * order.nodes_per_cell();
        (u, InsideMoments::new(degree, &xi, 3, cols, unit))
    });
    let samples = DisplacementSamples {
        setup,
        on_cell,
        rule,
        nodal,
    };
    (vertex_nodes_of(setup, omega_star), samples, degree)
}

/// The displacement fits' options: patches keep to their node's piece.
fn displacement_options(setup: &Setup) -> SprOptions<'_> {
    SprOptions {
        pieces: Some(&setup.pieces.of_cell),
        ..SprOptions::default()
    }
}

/// `F_S = (k2 E / h²) Σ_{c ∈ Ω*} ∫_c Nᵀ (S + R a) dV`, Gauss rule of one
/// point more per direction than the element's over the whole cell, where
/// `R a` is the rigid-body part of `u_h − S` on Ω* (see [`RigidFit`]) when
/// `balanced` (the S-term then puts no net force or moment on any piece of
/// the body), and
/// zero otherwise (the paper's `F_S`). The fit of each piece adds up the
/// cells that `share` counts, summed over the ranks.
pub fn s_rhs(
    setup: &Setup,
    omega_star: &[usize],
    u: &[f64],
    s: &Recovered<3>,
    factor: f64,
    balanced: bool,
    share: &dyn CellShare,
) -> Result<Vec<f64>> {
    let (grid, dofs) = (&setup.grid, &setup.op.dofs);
    let rule = tensor_gauss_rule(dofs.order.gauss_points_per_axis() + 1);
    let vol = grid.h.powi(3);
    let nq = rule.len();
    // The rule's points are the same in every cell: the blend of `S` and
    // the shape functions are tabulated there once (Ω* holds no split cell).
    let xis: Vec<[f64; 3]> = rule.iter().map(|(xi, _)| *xi).collect();
    let table = BlendTable::new(s.basis(), &xis);
    let shapes = ShapeTable::new(dofs.order, &rule, grid.h);
    let npc = dofs.order.nodes_per_cell();
    // One projection per piece of the body: the pieces share no node, so
    // each must be balanced on its own.
    let of_cell = &setup.pieces.of_cell;
    let mut fits = piece_fits(setup, omega_star, share);
    // `S` at each cell's points, by component (`[c · nq + q]`).
    let mut blended = vec![0.0; omega_star.len() * 3 * nq];
    let mut points = Vec::with_capacity(nq);
    for (&c, sx) in omega_star.iter().zip(blended.chunks_exact_mut(3 * nq)) {
        s.blend_at_table(c, &table, sx)?;
        if !share.counts(c) {
            continue;
        }
        let lo = grid.cell_box(c).lo;
        let field = CellField::new(grid, dofs, u, c);
        points.clear();
        for (q, (xi, w)) in rule.iter().enumerate() {
            let x = [0, 1, 2].map(|a| lo[a] + grid.h * xi[a]);
            let ux = field.at_tabulated(&shapes, q).0;
            points.push((x, w * vol, [0, 1, 2].map(|a| ux[a] - sx[a * nq + q])));
        }
        fits[of_cell[c] as usize].add_cell(&points);
    }
    let mut sums: Vec<ExactSum> = fits.iter().flat_map(|f| f.sums().to_vec()).collect();
    share.sum_exact(&mut sums);
    for (fit, s) in fits.iter_mut().zip(sums.chunks_exact(RigidFit::SUMS)) {
        fit.set_sums(s);
    }
    let a: Vec<[f64; 6]> = match balanced {
        true => fits.iter().map(RigidFit::solve).collect(),
        false => vec![[0.0; 6]; fits.len()],
    };
    let mut rhs = vec![0.0; dofs.ndofs()];
    let mut nodes = [0usize; 27];
    for (&c, sx) in omega_star.iter().zip(blended.chunks_exact(3 * nq)) {
        let piece = of_cell[c] as usize;
        let lo = grid.cell_box(c).lo;
        let mut fe = [[0.0; 3]; 27];
        for (q, (xi, w)) in rule.iter().enumerate() {
            let x = [0, 1, 2].map(|a| lo[a] + grid.h * xi[a]);
            let r = fits[piece].value(x, &a[piece]);
            let v = [0, 1, 2].map(|k| (sx[k * nq + q] + r[k]) * factor * w * vol);
            for (f, n) in fe.iter_mut().zip(&shapes.values(q)[..npc]) {
                for k in 0..3 {
                    f[k] += n * v[k];
                }
            }
        }
        dofs.cell_active_nodes(grid, c, &mut nodes[..npc]);
        for (f, &node) in fe.iter().zip(&nodes[..npc]) {
            for k in 0..3 {
                rhs[3 * node + k] += f[k];
            }
        }
    }
    Ok(rhs)
}

/// An empty rigid-body fit per piece, about the mean of the centres of the
/// piece's cells of Ω* (summed over the ranks).
fn piece_fits(setup: &Setup, omega_star: &[usize], share: &dyn CellShare) -> Vec<RigidFit> {
    let (grid, of_cell) = (&setup.grid, &setup.pieces.of_cell);
    // Per piece: the sum of the centres, and the count.
    let mut sums = vec![ExactSum::new(); 4 * setup.pieces.count];
    for &c in omega_star.iter().filter(|&&c| share.counts(c)) {
        let lo = grid.cell_box(c).lo;
        let p = 4 * of_cell[c] as usize;
        for a in 0..3 {
            sums[p + a].add(lo[a] + 0.5 * grid.h);
        }
        sums[p + 3].add(1.0);
    }
    share.sum_exact(&mut sums);
    let sums: Vec<f64> = sums.iter().map(ExactSum::value).collect();
    sums.chunks_exact(4)
        .map(|s| {
            let x0 = [0, 1, 2].map(|a| if s[3] > 0.0 { s[a] / s[3] } else { 0.0 });
            RigidFit::about(x0, grid.h)
        })
        .collect()
}
