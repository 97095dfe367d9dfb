//! The master surface's triangles as patches: PN (point–normal) triangles of
//! Vlachos, Peters, Boyd and Mitchell (2001), and the ray–patch intersection.
//! With every corner normal equal to the facet's own the patch is the flat
//! facet (the default master surface, `contact.master_surface = "facets"`);
//! with the current vertex normals it is curved (`"curved"`).
//!
//! **Why curved triangles.** On the flat marching-tetrahedra facets the
//! normal jumps by O(h) across every edge, and so does the gradient of the
//! ray gap. A patch built from the corners `p_k` *and* vertex normals `n_k`
//! has, at each corner, exactly the tangent plane `⊥ n_k` — the same on
//! every patch sharing the corner — and its edge curve depends only on the
//! edge's two corners and normals, so neighbours share it (the surface is
//! watertight). The normal still jumps across an edge, but less. (What
//! stopped Newton on aligned grids, points oscillating across an edge, is
//! cured for both surfaces by keeping each point on one patch within a
//! Newton iteration, [`super::search::MasterSurface::search_near`].)
//!
//! **Which vertex normals.** The current ones, `n_v = Σ_f (q1 − q0) × (q2 − q0)`
//! over the triangles around the vertex (area-weighted,
//! [`super::surface::Surface::vertex_normals`]): they depend on the current
//! corner positions only, which the displacement's values control, and a
//! sliver weighs nothing. Two alternatives were tried and dropped: the exact
//! reference normal mapped by Nanson's formula with the displacement
//! gradient of the vertex's cell (in a sliver cut cell without the S-term
//! `∇u` turned a corner normal by 0.13 rad at the first touch of the annuli,
//! and Newton stalled), and per-triangle normals mapped by the triangle's own
//! deformation (neighbours then disagree along their edge: a crack, and a
//! kink of 0.2 rad measured at a sliver). Area-weighted normals are O(h)
//! accurate on the irregular marching-tetrahedra stars, so the patches are
//! O(h²) accurate (0.20–0.25 h² for the gap on the sphere, where the facets
//! give 0.29–0.34 h²); normals exact for a sphere (Max's weights) put large
//! weights on tiny triangles, the ones whose normals deform erratically.
//!
//! **Why PN triangles** (rather than Nagata's quadratic patches): Nagata's
//! curvature coefficient divides by `1 − (n_0·n_1)²`, singular where two
//! corner normals are parallel (every vertical edge of a plane-strain slab,
//! every flat part); the PN control points are polynomials in the corners
//! and the unit normals, smooth everywhere, so their exact first and second
//! derivatives (for the contact tangent) are well defined. The patch is the
//! cubic Bézier triangle
//! `x(λ) = Σ_{i+j+k=3} 3!/(i! j! k!) λ₀ⁱ λ₁ʲ λ₂ᵏ b_ijk`, `λ = (1 − s − t, s, t)`,
//! with the corners `b300 = p0, b030 = p1, b003 = p2`, the edge points
//! `b_(2 at i, 1 at j) = (2 p_i + p_j − w_ij n_i) / 3`, `w_ij = (p_j − p_i)·n_i`
//! (the third point of the edge, projected onto the tangent plane at `p_i`),
//! and the centre `b111 = E + (E − V)/2` with `E` the mean of the six edge
//! points and `V` the mean of the corners. It reproduces a plane exactly
//! (then `w_ij = 0` and the patch is the flat triangle, linearly
//! parametrised).
//!
//! **Ray–patch intersection.** `x(s, t) = x1 + τ d` is solved for
//! `(s, t, τ)` by Newton's method on the residual `x(s, t) − x1 − τ d` with
//! the Jacobian `[∂x/∂s, ∂x/∂t, −d]` (Cramer's rule). The same step, taken
//! twice in forward-mode numbers from the converged values, gives the exact
//! first and second derivatives of the solution (each Newton step doubles
//! the order to which the derivatives are exact), which is how
//! `enforce_gap` differentiates the gap.
//!
//! Everything here is generic over [`Real`] (plain `f64` for the search,
//! forward-mode numbers for the tangent).

use std::ops::{Add, Mul, Sub};

use super::enforce_dual::HyperDual;

/// The arithmetic the patch needs.
pub trait Real:
    Copy + std::fmt::Debug + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self>
{
    fn cst(v: f64) -> Self;
    fn scale(self, s: f64) -> Self;
    fn recip(self) -> Self;
    fn sqrt(self) -> Self;
    fn value(self) -> f64;
}

impl Real for f64 {
    fn cst(v: f64) -> Self {
        v
    }
    fn scale(self, s: f64) -> Self {
        self * s
    }
    fn recip(self) -> Self {
        1.0 / self
    }
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    fn value(self) -> f64 {
        self
    }
}

impl<const N: usize, const H: usize> Real for HyperDual<N, H> {
    fn cst(v: f64) -> Self {
        HyperDual::cst(v)
    }
    fn scale(self, s: f64) -> Self {
        HyperDual::scale(self, s)
    }
    fn recip(self) -> Self {
        HyperDual::recip(self)
    }
    fn sqrt(self) -> Self {
        HyperDual::sqrt(self)
    }
    fn value(self) -> f64 {
        self.v
    }
}

/// A 3-vector of [`Real`]s.
pub type Vec3<S> = [S; 3];

pub fn dot<S: Real>(a: &Vec3<S>, b: &Vec3<S>) -> S {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn cross<S: Real>(a: &Vec3<S>, b: &Vec3<S>) -> Vec3<S> {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub fn sub<S: Real>(a: &Vec3<S>, b: &Vec3<S>) -> Vec3<S> {
    [0, 1, 2].map(|i| a[i] - b[i])
}

/// `a / |a|`.
pub fn unit<S: Real>(a: &Vec3<S>) -> Vec3<S> {
    let inverse = dot(a, a).sqrt().recip();
    a.map(|c| c * inverse)
}

/// `cof(F) N = J F⁻ᵀ N`: the rows of `cof(F)` are `F₂×F₃, F₃×F₁, F₁×F₂`
/// for the rows `Fᵢ` of `F` (Nanson's formula without the inverse).
pub fn cofactor_times<S: Real>(rows: &[Vec3<S>; 3], n: [f64; 3]) -> Vec3<S> {
    let cof = [
        cross(&rows[1], &rows[2]),
        cross(&rows[2], &rows[0]),
        cross(&rows[0], &rows[1]),
    ];
    cof.map(|r| r[0].scale(n[0]) + r[1].scale(n[1]) + r[2].scale(n[2]))
}

/// Exponents `(i, j, k)` of the ten control points, and their multinomial
/// coefficients `3!/(i! j! k!)`.
const EXPONENTS: [([usize; 3], f64); 10] = [
    ([3, 0, 0], 1.0),
    ([0, 3, 0], 1.0),
    ([0, 0, 3], 1.0),
    ([2, 1, 0], 3.0),
    ([1, 2, 0], 3.0),
    ([0, 2, 1], 3.0),
    ([0, 1, 2], 3.0),
    ([1, 0, 2], 3.0),
    ([2, 0, 1], 3.0),
    ([1, 1, 1], 6.0),
];

/// A PN triangle: its ten control points in the order of `EXPONENTS`.
#[derive(Clone, Copy, Debug)]
pub struct Patch<S> {
    control: [Vec3<S>; 10],
}

impl<S: Real> Patch<S> {
    /// The patch of the corners `p` (counter-clockwise seen from outside)
    /// with outward normals `n` there (any positive length; normalised here).
    pub fn new(p: &[Vec3<S>; 3], n: &[Vec3<S>; 3]) -> Patch<S> {
        let n = n.each_ref().map(unit);
        let edge = |i: usize, j: usize| {
            let w = dot(&sub(&p[j], &p[i]), &n[i]);
            [0, 1, 2].map(|c| (p[i][c].scale(2.0) + p[j][c] - w * n[i][c]).scale(1.0 / 3.0))
        };
        let edges = [
            edge(0, 1),
            edge(1, 0),
            edge(1, 2),
            edge(2, 1),
            edge(2, 0),
            edge(0, 2),
        ];
        let centre = [0, 1, 2].map(|c| {
            let e = edges.iter().fold(S::cst(0.0), |acc, x| acc + x[c]);
            let v = p[0][c] + p[1][c] + p[2][c];
            e.scale(0.25) - v.scale(1.0 / 6.0)
        });
        let control = [
            p[0], p[1], p[2], edges[0], edges[1], edges[2], edges[3], edges[4], edges[5], centre,
        ];
        Patch { control }
    }

    /// The point `x(s, t)` and its tangents `∂x/∂s`, `∂x/∂t`.
    pub fn eval(&self, s: S, t: S) -> (Vec3<S>, Vec3<S>, Vec3<S>) {
        let l = [S::cst(1.0) - s - t, s, t];
        let pow = |x: S, e: usize| (0..e).fold(S::cst(1.0), |acc, _| acc * x);
        let zero = [S::cst(0.0); 3];
        let (mut x, mut dl) = (zero, [zero; 3]);
        for (b, &(e, c)) in self.control.iter().zip(&EXPONENTS) {
            let terms = [0, 1, 2].map(|a| pow(l[a], e[a]));
            let basis = (terms[0] * terms[1] * terms[2]).scale(c);
            (0..3).for_each(|i| x[i] = x[i] + basis * b[i]);
            // ∂/∂λ_a of the basis function.
            for a in 0..3 {
                if e[a] == 0 {
                    continue;
                }
                let others = (0..3)
                    .filter(|&o| o != a)
                    .fold(S::cst(1.0), |acc, o| acc * terms[o]);
                let d = (pow(l[a], e[a] - 1) * others).scale(c * e[a] as f64);
                (0..3).for_each(|i| dl[a][i] = dl[a][i] + d * b[i]);
            }
        }
        let ds = sub(&dl[1], &dl[0]);
        let dt = sub(&dl[2], &dl[0]);
        (x, ds, dt)
    }

    /// One Newton step for `x(s, t) = x1 + τ d` from `z = (s, t, τ)`.
    pub fn newton_step(&self, x1: &Vec3<S>, d: &Vec3<S>, z: [S; 3]) -> [S; 3] {
        let (x, xs, xt) = self.eval(z[0], z[1]);
        let r = [0, 1, 2].map(|i| x[i] - x1[i] - z[2] * d[i]);
        let minus_d = d.map(|c| c.scale(-1.0));
        // Solve [xs xt −d] δ = r by Cramer's rule.
        let xt_d = cross(&xt, &minus_d);
        let inverse = dot(&xs, &xt_d).recip();
        let ds = dot(&r, &xt_d) * inverse;
        let dt = dot(&xs, &cross(&r, &minus_d)) * inverse;
        let dtau = dot(&xs, &cross(&xt, &r)) * inverse;
        [z[0] - ds, z[1] - dt, z[2] - dtau]
    }
}

fn norm_inf(x: &[f64; 3]) -> f64 {
    x.iter().fold(0.0, |m, c| m.max(c.abs()))
}

/// Most Newton iterations of a ray–patch intersection.
const MAX_NEWTON: usize = 30;

impl Patch<f64> {
    /// The outward unit normal at `(s, t)`.
    pub fn normal(&self, s: f64, t: f64) -> [f64; 3] {
        let (_, xs, xt) = self.eval(s, t);
        unit(&cross(&xs, &xt))
    }

    /// The intersection of the line `x1 + τ d` with the patch's surface
    /// (extended beyond the triangle), by Newton's method from `start`:
    /// `(s, t, τ)`, or `None` when it does not converge (a step moving the
    /// point by more than 10⁻¹⁴ of the patch size plus the coordinates'
    /// magnitude after [`MAX_NEWTON`] steps).
    pub fn intersect(&self, x1: [f64; 3], d: [f64; 3], start: [f64; 3]) -> Option<[f64; 3]> {
        let size = self.control[..3]
            .iter()
            .map(|p| dot(&sub(p, &self.control[0]), &sub(p, &self.control[0])))
            .fold(0.0, f64::max)
            .sqrt();
        let mut z = start;
        let mut at_z = self.eval(z[0], z[1]).0;
        for _ in 0..MAX_NEWTON {
            let next = self.newton_step(&x1, &d, z);
            if next.iter().any(|c| !c.is_finite()) {
                return None;
            }
            let at_next = self.eval(next[0], next[1]).0;
            let step = sub(&at_next, &at_z);
            let moved = dot(&step, &step).sqrt() + (next[2] - z[2]).abs();
            (z, at_z) = (next, at_next);
            if moved <= 1e-14 * (size + z[2].abs() + norm_inf(&x1)) {
                return Some(z);
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flat_triangle_is_its_own_patch() {
        let p = [[0.0, 0.0, 0.1], [1.0, 0.2, 0.1], [0.3, 0.9, 0.1]];
        let n = [[0.0, 0.0, 2.0]; 3];
        let patch = Patch::new(&p, &n);
        for (s, t) in [(0.2, 0.3), (0.0, 1.0), (0.5, 0.5), (0.1, 0.05)] {
            let (x, _, _) = patch.eval(s, t);
            let flat = [0, 1, 2].map(|i| (1.0 - s - t) * p[0][i] + s * p[1][i] + t * p[2][i]);
            assert!((0..3).all(|i| (x[i] - flat[i]).abs() < 1e-15), "{x:?}");
        }
        let z = patch.intersect([0.4, 0.3, 0.5], [0.0, 0.0, -1.0], [0.3, 0.3, 0.0]);
        assert!((z.unwrap()[2] - 0.4).abs() < 1e-15);
    }

    #[test]
    fn corners_and_corner_tangent_planes_are_interpolated() {
        // Three points of the unit sphere with its normals.
        let p = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]].map(|v: [f64; 3]| {
            let w = [v[0] + 0.3, v[1] + 0.3, v[2] + 0.3];
            unit(&w)
        });
        let patch = Patch::new(&p, &p);
        for (k, (s, t)) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)].into_iter().enumerate() {
            let (x, xs, xt) = patch.eval(s, t);
            assert!((0..3).all(|i| (x[i] - p[k][i]).abs() < 1e-15));
            assert!(dot(&xs, &p[k]).abs() < 1e-15 && dot(&xt, &p[k]).abs() < 1e-15);
        }
    }

    #[test]
    fn tangents_match_differences() {
        let p = [[0.0, 0.0, 0.0], [1.0, 0.1, 0.2], [0.2, 1.0, -0.1]];
        let n = [[0.1, -0.2, 1.0], [-0.3, 0.0, 1.0], [0.0, -0.4, 1.0]];
        let patch = Patch::new(&p, &n);
        let (s, t, e) = (0.3, 0.25, 1e-6);
        let (_, xs, xt) = patch.eval(s, t);
        let fd = |ds: f64, dt: f64| {
            let (a, _, _) = patch.eval(s + ds, t + dt);
            let (b, _, _) = patch.eval(s - ds, t - dt);
            [0, 1, 2].map(|i| (a[i] - b[i]) / (2.0 * e))
        };
        let (fs, ft) = (fd(e, 0.0), fd(0.0, e));
        assert!((0..3).all(|i| (fs[i] - xs[i]).abs() < 1e-9 && (ft[i] - xt[i]).abs() < 1e-9));
    }
}
