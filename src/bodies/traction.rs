//! The recovered Cauchy stress of a hyperelastic body (the SPR recovery on the
//! reference configuration) and from it the recovered normal traction
//! `T̂_N = n1 · σ̂ n1` of contact.
//!
//! **Samples.** At the Gauss points of an inside cell (Q1: 2×2×2, Q2:
//! 3×3×3) and at most twice as many points of a cut cell
//! ([`Cells::fit_points`], strided: fewer than the linear recovery of
//! [`crate::driver::recovery::sample_positions`] takes) the Cauchy stress of the
//! current state, `σ = P Fᵀ / J`, stored as Voigt `(xx, yy, zz, yz, xz, xy)`
//! at the point's **reference** position `X`.
//!
//! **Fit.** The generic SPR of [`crate::recovery::recover`] (degree p of the
//! element, on the vertex patches, enlarged ring by ring where a patch is thin) on the
//! patches of the vertex nodes of the requested cells; `σ̂(X)` is its CPE
//! blend in the cell holding `X`. A patch that reaches past a symmetry plane
//! of the body takes the mirror image of its samples there (the shears with
//! one index along the plane's normal change sign). Recovering on the reference grid keeps the
//! patches the grid's, whatever the deformation; `σ̂` is still the current
//! (Cauchy) stress, a function of the reference point.
//!
//! **Traction.** With `n1` the current unit normal of a slave point,
//! `T̂_N = n1 · σ̂(X) n1` (negative in compression).

use nalgebra::Matrix3;

use crate::cells::pieces::Pieces;
use crate::cells::{CellKind, Cells};
use crate::driver::recovery::voigt_times;
use crate::element::{shape_gradients, tensor_gauss_rule, ElementOrder};
use crate::error::Result;
use crate::grid::Grid;
use crate::hyper::material::PointState;
use crate::hyper::problem::{CellBuffer, HyperProblem, QuadPoint, MAX_NODES};
use crate::hyper::residual::deformation_gradient;
use crate::recovery::{recover, Mirror, PatchSamples, Recovered, Sample, SprOptions};

/// Sample points of a cut cell: at most twice the inside cell's Gauss
/// points (Q1: 16, Q2: 54). The recovered contact pressure at coarse levels
/// moves with the choice of points: with every point (up to
/// [`crate::cells::MAX_FIT_POINTS`]) the earlier Hertz case (ball's grid
/// offset, rollers) at level 2 gave a recovered Q1 peak +14% from Hertz's
/// against −0.5% with these, so the traction keeps them. They are not
/// mirror symmetric, but across a symmetry plane the patches take the
/// mirror image of the body's own samples, so a half (quarter) model is
/// still symmetric.
fn cut_cell_samples(order: ElementOrder) -> usize {
    2 * order.gauss_points_per_axis().pow(3)
}

/// What the stress recovery of one body needs from its cell classification:
/// the cell kinds, per cut cell its sample points (reference coordinates in
/// the cell and position, [`Cells::fit_points`]), and the body's symmetry
/// planes, across which the patches continue.
#[derive(Clone, Debug)]
pub struct StressSampler {
    kinds: Vec<CellKind>,
    /// The body's piece of each cell (a patch keeps to its node's piece).
    pieces: Vec<u32>,
    cut_samples: Vec<Vec<([f64; 3], [f64; 3])>>,
    mirror: Mirror,
}

impl StressSampler {
    /// The sampler of a body of elements `order` on `grid` classified as
    /// `cells`, with the symmetry planes `mirror` (faces of the grid box).
    pub fn new(grid: &Grid, cells: &Cells, order: ElementOrder, mirror: Mirror) -> StressSampler {
        let inv_h = 1.0 / grid.h;
        let cut_samples = cells
            .cut
            .iter()
            .enumerate()
            .map(|(i, &c)| {
                let lo = grid.cell_box(c).lo;
                cells
                    .fit_points(i, cut_cell_samples(order))
                    .into_iter()
                    .map(|x| ([0, 1, 2].map(|a| (x[a] - lo[a]) * inv_h), x))
                    .collect()
            })
            .collect();
        StressSampler {
            kinds: cells.kinds.clone(),
            pieces: Pieces::new(grid, cells).of_cell,
            cut_samples,
            mirror,
        }
    }

    /// `σ̂` of `body` at its displacement `u` (the body's own dofs), on the
    /// patches of the vertex nodes of `cells` (cells of the body's grid).
    pub fn recover(&self, body: &HyperProblem, u: &[f64], cells: &[usize]) -> Result<Recovered<6>> {
        let nodes = vertex_nodes(&body.grid, cells);
        let samples = CauchySamples {
            body,
            u,
            sampler: self,
            gauss: tensor_gauss_rule(body.order().gauss_points_per_axis())
                .iter()
                .map(|(xi, _)| *xi)
                .collect(),
        };
        recover(
            &body.grid,
            &self.kinds,
            &nodes,
            body.order().degree(),
            &samples,
            &SprOptions {
                mirror: self.mirror,
                pieces: Some(&self.pieces),
                ..SprOptions::default()
            },
        )
    }
}

/// The Q1 vertex nodes of `cells`, ascending and distinct.
fn vertex_nodes(grid: &Grid, cells: &[usize]) -> Vec<usize> {
    let mut nodes = Vec::with_capacity(8 * cells.len());
    let mut v = [0usize; 8];
    for &c in cells {
        grid.cell_nodes(ElementOrder::Q1, c, &mut v);
        nodes.extend_from_slice(&v);
    }
    nodes.sort_unstable();
    nodes.dedup();
    nodes
}

/// The Cauchy stress samples of one body state.
struct CauchySamples<'a> {
    body: &'a HyperProblem,
    u: &'a [f64],
    sampler: &'a StressSampler,
    /// Reference coordinates of the inside rule, in the order of
    /// [`HyperProblem::inside_rule`].
    gauss: Vec<[f64; 3]>,
}

impl PatchSamples<6> for CauchySamples<'_> {
    fn samples(&self, cell: usize, out: &mut Vec<Sample<6>>) {
        let body = self.body;
        let Ok(k) = body.cells.binary_search(&cell) else {
            return;
        };
        let mut buffer: CellBuffer = [[0.0; 3]; MAX_NODES];
        let ue = body.gather(k, self.u, &mut buffer);
        let mut push = |point: &QuadPoint, x: [f64; 3]| {
            let f = deformation_gradient(ue, point);
            if let Some(s) = PointState::new(f) {
                out.push((x, cauchy_voigt(&f, &body.material.stress(&s))));
            }
        };
        match body.cut_index[k] {
            None => {
                let (lo, h) = (body.grid.cell_box(cell).lo, body.grid.h);
                for (point, xi) in body.points(k).zip(&self.gauss) {
                    push(&point, [0, 1, 2].map(|a| lo[a] + h * xi[a]));
                }
            }
            Some(i) => {
                let inv_h = 1.0 / body.grid.h;
                let mut grads = [[0.0; 3]; MAX_NODES];
                let grads = &mut grads[..ue.len()];
                for &(xi, x) in &self.sampler.cut_samples[i] {
                    shape_gradients(body.order(), xi, grads);
                    grads.iter_mut().for_each(|g| *g = g.map(|v| v * inv_h));
                    // A sample, not a quadrature point: no weight.
                    push(&QuadPoint { grads, w: 0.0 }, x);
                }
            }
        }
    }

    fn reflected(&self, axis: usize, value: [f64; 6]) -> Option<[f64; 6]> {
        Some(reflected_voigt(axis, value))
    }
}

/// A Voigt stress seen in the mirror across a plane normal to `axis`:
/// `M σ M` with `M = I − 2 e_axis e_axisᵀ` flips the sign of the two shear
/// components with one index along `axis`.
fn reflected_voigt(axis: usize, mut value: [f64; 6]) -> [f64; 6] {
    // Voigt (xx, yy, zz, yz, xz, xy): the shears with an index `axis`.
    const SHEARS: [[usize; 2]; 3] = [[4, 5], [3, 5], [3, 4]];
    for k in SHEARS[axis] {
        value[k] = -value[k];
    }
    value
}

/// `σ = P Fᵀ / J` in Voigt order `(xx, yy, zz, yz, xz, xy)`.
pub fn cauchy_voigt(f: &Matrix3<f64>, p: &Matrix3<f64>) -> [f64; 6] {
    let s = p * f.transpose() / f.determinant();
    [
        s[(0, 0)],
        s[(1, 1)],
        s[(2, 2)],
        0.5 * (s[(1, 2)] + s[(2, 1)]),
        0.5 * (s[(0, 2)] + s[(2, 0)]),
        0.5 * (s[(0, 1)] + s[(1, 0)]),
    ]
}

/// `n · σ n` for a Voigt stress.
pub fn normal_traction(sigma: &[f64; 6], n: [f64; 3]) -> f64 {
    let t = voigt_times(sigma, n);
    (0..3).map(|i| n[i] * t[i]).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cells::cut_rule_points;
    use crate::geometry::Geometry;
    use crate::hyper::material::Material;
    use crate::hyper::problem::Loads;
    use crate::spatial::Aabb;

    /// Patch test: under a homogeneous deformation `x = F0 X` of a ball the
    /// FE stress is the same constant at every point, SPR reproduces it, and
    /// `T̂_N` at every boundary point is the closed-form neo-Hookean
    /// `n1 · σ n1`, `σ = μ/J (B − I) + λ ln J / J I`, `n1 ∝ cof(F0) N`; for
    /// Q1 and Q2 elements.
    #[test]
    fn a_homogeneous_deformation_is_recovered_exactly() {
        for order in [ElementOrder::Q1, ElementOrder::Q2] {
            let level = if order == ElementOrder::Q1 { 3 } else { 2 };
            homogeneous_deformation_recovered(order, level);
        }
    }

    fn homogeneous_deformation_recovered(order: ElementOrder, level: u32) {
        let geometry = Geometry::sphere([0.0; 3], 1.0).unwrap();
        let bbox = Aabb::new([-1.0; 3], [1.0; 3]);
        let grid = Grid::new(&bbox, level, [0.13, 0.31, 0.07]).unwrap();
        let cells = Cells::classify(&grid, &geometry, cut_rule_points(order)).unwrap();
        let material = Material::neo_hookean(1000.0, 0.3);
        let body =
            HyperProblem::new(&grid, &cells, order, material, 0.0, &[], &Loads::default()).unwrap();
        let f0 = Matrix3::new(1.1, 0.05, -0.03, 0.02, 0.92, 0.04, -0.01, 0.06, 1.05);
        let u: Vec<f64> = body
            .dofs
            .active_to_node
            .iter()
            .flat_map(|&n| {
                let x = grid.node_position(order, n as usize);
                let d = (f0 - Matrix3::identity()) * nalgebra::Vector3::from(x);
                [d[0], d[1], d[2]]
            })
            .collect();
        let sigma = StressSampler::new(&grid, &cells, order, Mirror::none())
            .recover(&body, &u, &cells.cut)
            .unwrap();
        let j = f0.determinant();
        let exact = (f0 * f0.transpose() - Matrix3::identity()) * (material.mu / j)
            + Matrix3::identity() * (material.lambda * j.ln() / j);
        let cof = f0.try_inverse().unwrap().transpose() * j;
        let mut checked = 0;
        for (i, &c) in cells.cut.iter().enumerate() {
            for p in cells.surface_points(i) {
                let n1 = (cof * nalgebra::Vector3::from(p.n)).normalize();
                let t_hat = normal_traction(&sigma.eval(c, p.x).unwrap(), n1.into());
                let t = n1.dot(&(exact * n1));
                assert!(
                    (t_hat - t).abs() < 1e-10 * exact.norm(),
                    "{order:?}: {t_hat} vs {t}"
                );
                checked += 1;
            }
        }
        assert!(checked > 1000, "{order:?}: {checked} boundary points");
    }

    /// The mirror image of a deformation, `M F M`, has the Cauchy stress
    /// `M σ M`: [`reflected_voigt`] against the matrix product.
    #[test]
    fn a_reflected_stress_is_the_stress_of_the_reflected_deformation() {
        let material = Material::neo_hookean(1000.0, 0.3);
        let f = Matrix3::new(1.1, 0.05, -0.03, 0.02, 0.92, 0.04, -0.01, 0.06, 1.05);
        let stress =
            |f: &Matrix3<f64>| cauchy_voigt(f, &material.stress(&PointState::new(*f).unwrap()));
        for axis in 0..3 {
            let mut m = Matrix3::identity();
            m[(axis, axis)] = -1.0;
            let mirrored = stress(&(m * f * m));
            let reflected = reflected_voigt(axis, stress(&f));
            for k in 0..6 {
                assert!(
                    (mirrored[k] - reflected[k]).abs() < 1e-12 * 1000.0,
                    "axis {axis}, {k}"
                );
            }
            assert!(
                reflected != stress(&f),
                "axis {axis}: the shears are not zero"
            );
        }
    }
}
