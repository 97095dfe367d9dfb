//! Leaf surfaces of the CSG tree: smooth level sets in a local frame.
//!
//! Each leaf is a polynomial level set ψ (negative inside) scaled so that
//! `|∇ψ| = 1` on its zero set (or close to it, for the torus), placed by a rigid
//! frame. Polynomials keep interval bounds tight and roots well behaved, which is
//! what the cut-cell quadrature relies on. A voxel image is a leaf too: its ψ
//! is the trilinear interpolant of the image ([`Voxels`]).

use std::sync::Arc;

use super::scalar::{Dual, Dual2, Interval, Scalar};
use super::voxels::Voxels;
use crate::spatial::vec3::{cross, normalize};
use crate::spatial::Aabb;

/// The shape of a leaf in its local frame.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// `ψ = n·x − d` with `n` a unit vector: the half-space `n·x ≤ d`.
    Plane { normal: [f64; 3], offset: f64 },
    /// Ball of radius `r` about the origin: `ψ = (|x|² − r²) / (2r)`.
    Sphere { r: f64 },
    /// Infinite solid cylinder of radius `r` about the local z axis:
    /// `ψ = (x² + y² − r²) / (2r)`.
    Cylinder { r: f64 },
    /// Solid torus about the local z axis, major radius `big_r`, tube radius `r`:
    /// `ψ = ((|x|² + R² − r²)² − 4R²(x² + y²)) / (8R²r)`.
    Torus { big_r: f64, r: f64 },
    /// A voxel image: ψ is its trilinear interpolant minus the threshold,
    /// scaled ([`Voxels`]); the local origin is its first sample.
    Image(Arc<Voxels>),
}

/// A rigid placement: local coordinates are `Qᵀ (x − t)`, `Q` orthogonal
/// (stored by columns: `q[c]` is the image of local axis `c`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub q: [[f64; 3]; 3],
    pub t: [f64; 3],
}

impl Frame {
    pub const IDENTITY: Frame = Frame {
        q: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        t: [0.0; 3],
    };

    /// A frame at `origin` whose local z axis is the unit vector `axis`.
    pub fn with_z_axis(origin: [f64; 3], axis: [f64; 3]) -> Frame {
        let a = axis;
        // Any vector not parallel to a, then Gram–Schmidt.
        let helper = if a[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let e1 = normalize(cross(helper, a));
        let e2 = cross(a, e1);
        Frame {
            q: [e1, e2, a],
            t: origin,
        }
    }

    /// Local coordinates of the global point `x`.
    pub fn to_local<T: Scalar>(&self, x: [T; 3]) -> [T; 3] {
        let d = [
            x[0] - T::cst(self.t[0]),
            x[1] - T::cst(self.t[1]),
            x[2] - T::cst(self.t[2]),
        ];
        let mut out = [T::cst(0.0); 3];
        for (c, o) in out.iter_mut().enumerate() {
            *o = d[0].scale(self.q[c][0]) + d[1].scale(self.q[c][1]) + d[2].scale(self.q[c][2]);
        }
        out
    }

    /// The frame after the global motion `x ↦ R x + s` (R by columns).
    pub fn moved(&self, r: &[[f64; 3]; 3], s: [f64; 3]) -> Frame {
        let apply = |v: [f64; 3]| -> [f64; 3] {
            let mut o = [0.0; 3];
            for (c, rc) in r.iter().enumerate() {
                for i in 0..3 {
                    o[i] += rc[i] * v[c];
                }
            }
            o
        };
        let t = apply(self.t);
        Frame {
            q: [apply(self.q[0]), apply(self.q[1]), apply(self.q[2])],
            t: [t[0] + s[0], t[1] + s[1], t[2] + s[2]],
        }
    }
}

/// A leaf of the CSG tree: a shape, its placement and its boundary tag.
#[derive(Clone, Debug, PartialEq)]
pub struct Leaf {
    pub shape: Shape,
    pub frame: Frame,
    /// Index into the geometry's tag names.
    pub tag: u16,
}

impl Leaf {
    /// ψ at the global point `x`, in any scalar type.
    pub fn eval<T: Scalar>(&self, x: [T; 3]) -> T {
        let p = self.frame.to_local(x);
        match &self.shape {
            Shape::Image(img) => T::voxel(img, img.coords(p)),
            &Shape::Plane { normal, offset } => {
                p[0].scale(normal[0]) + p[1].scale(normal[1]) + p[2].scale(normal[2])
                    - T::cst(offset)
            }
            &Shape::Sphere { r } => {
                (p[0].sqr() + p[1].sqr() + p[2].sqr() - T::cst(r * r)).scale(0.5 / r)
            }
            &Shape::Cylinder { r } => (p[0].sqr() + p[1].sqr() - T::cst(r * r)).scale(0.5 / r),
            &Shape::Torus { big_r, r } => {
                let rho2 = p[0].sqr() + p[1].sqr();
                let s = rho2 + p[2].sqr() + T::cst(big_r * big_r - r * r);
                (s.sqr() - rho2.scale(4.0 * big_r * big_r)).scale(1.0 / (8.0 * big_r * big_r * r))
            }
        }
    }
}

impl Leaf {
    /// Enclosures of ψ and ∇ψ over the box `b` (degenerate axes allowed): the
    /// natural interval extension intersected with the mean-value forms
    /// `ψ(c) + ∇ψ(B)·(B − c)` and `∇ψ(c) + ∇²ψ(B)(B − c)`, which are tight to
    /// second order in the box size where the natural extension is not.
    /// An image leaf's ψ is only piecewise smooth: it gets the exact range
    /// and the hull of its cells' gradients ([`Leaf::image_bounds`]).
    pub fn bounds(&self, b: &Aabb) -> Dual<Interval> {
        if let Shape::Image(img) = &self.shape {
            return self.image_bounds(img, b);
        }
        if let Shape::Plane { .. } = self.shape {
            // Linear: the first-order extension is already exact.
            let x = [0, 1, 2].map(|i| Dual::var(Interval::new(b.lo[i], b.hi[i]), i));
            return self.eval(x);
        }
        let x = [0, 1, 2].map(|i| Dual2::var(Interval::new(b.lo[i], b.hi[i]), i));
        let nat = self.eval(x);
        let c = [0, 1, 2].map(|i| 0.5 * (b.lo[i] + b.hi[i]));
        let at_c = self.eval([Dual::var(c[0], 0), Dual::var(c[1], 1), Dual::var(c[2], 2)]);
        let dx = [0, 1, 2].map(|i| Interval::new(b.lo[i] - c[i], b.hi[i] - c[i]));
        let mut v = Interval::cst(at_c.v);
        let mut d = [0, 1, 2].map(|k| Interval::cst(at_c.d[k]));
        for j in 0..3 {
            v = v + nat.d[j] * dx[j];
            for (k, dk) in d.iter_mut().enumerate() {
                *dk = *dk + nat.h[k][j] * dx[j];
            }
        }
        Dual {
            v: nat.v.meet(v),
            d: [0, 1, 2].map(|k| nat.d[k].meet(d[k])),
        }
    }
}

/// Most voxel cells a box may meet for [`Leaf::image_bounds`] to hull
/// their gradients; beyond, the largest sample differences bound them.
const IMAGE_GRADIENT_CELLS: usize = 512;

impl Leaf {
    /// ψ's exact range over the box ([`Voxels::range`]) and an enclosure of
    /// its gradient: the exact ranges of the voxel cells' gradients over
    /// the box ([`Voxels::slope_range`]), or for a box that meets many
    /// cells the largest sample differences.
    fn image_bounds(&self, img: &Voxels, b: &Aabb) -> Dual<Interval> {
        let local = self.frame.to_local(super::scalar::box_intervals(b));
        let u = img.coords(local);
        let v = Interval::voxel(img, u);
        let r = u.map(|i| (i.lo, i.hi));
        let (h, q) = (img.spacing(), self.frame.q);
        let slopes = if img.cell_count(r) <= IMAGE_GRADIENT_CELLS {
            img.slope_range(r)
        } else {
            img.slope_bounds().map(|m| Interval::new(-m, m))
        };
        // ∂ψ/∂x_j = Σ_c ∂ψ/∂u_c (1 / spacing_c) q[c][j].
        let d = [0, 1, 2].map(|j| {
            (0..3).fold(Interval::cst(0.0), |acc, c| {
                acc + slopes[c].scale(q[c][j] / h[c])
            })
        });
        Dual { v, d }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::scalar::Dual;
    use crate::spatial::vec3::norm;

    fn grad(leaf: &Leaf, x: [f64; 3]) -> [f64; 3] {
        leaf.eval([Dual::var(x[0], 0), Dual::var(x[1], 1), Dual::var(x[2], 2)])
            .d
    }

    #[test]
    fn unit_gradient_on_the_zero_set() {
        let axis = normalize([1.0, 2.0, -0.5]);
        let f = Frame::with_z_axis([0.1, -0.2, 0.3], axis);
        let leaves = [
            Shape::Sphere { r: 0.7 },
            Shape::Cylinder { r: 0.4 },
            Shape::Plane {
                normal: normalize([1.0, 1.0, 0.0]),
                offset: 0.2,
            },
        ];
        for shape in leaves {
            let leaf = Leaf {
                shape: shape.clone(),
                frame: f,
                tag: 0,
            };
            // A point on the zero set: walk along the gradient with Newton.
            let mut x = [0.5, 0.4, -0.3];
            for _ in 0..50 {
                let v = leaf.eval(x);
                let g = grad(&leaf, x);
                let g2 = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
                for i in 0..3 {
                    x[i] -= v * g[i] / g2;
                }
            }
            assert!(leaf.eval(x).abs() < 1e-14);
            assert!((norm(grad(&leaf, x)) - 1.0).abs() < 1e-12, "{shape:?}");
        }
    }

    #[test]
    fn torus_zero_set_is_the_tube() {
        let leaf = Leaf {
            shape: Shape::Torus {
                big_r: 1.0,
                r: 0.25,
            },
            frame: Frame::IDENTITY,
            tag: 0,
        };
        for k in 0..16 {
            let a = k as f64 * 0.4;
            let b = k as f64 * 1.3;
            let x = [
                (1.0 + 0.25 * b.cos()) * a.cos(),
                (1.0 + 0.25 * b.cos()) * a.sin(),
                0.25 * b.sin(),
            ];
            assert!(leaf.eval(x).abs() < 1e-14);
        }
        assert!(leaf.eval([1.0, 0.0, 0.0]) < 0.0);
        assert!(leaf.eval([0.0, 0.0, 0.0]) > 0.0);
    }
}
