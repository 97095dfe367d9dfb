//! The level sets Saye's algorithm ([`super::saye`]) works with below the
//! top box: a leaf of the CSG tree with some coordinates pinned (its
//! restriction to a face of a box), optionally restricted to a plane leaf (an
//! edge function), with its value, gradient and interval bounds.

use crate::geometry::scalar::{box_intervals, Dual, Interval, Scalar};
use crate::geometry::Geometry;
use crate::spatial::Aabb;

/// A leaf level set with some coordinates pinned (its restriction to a face),
/// and optionally restricted to a plane leaf: `x_k` replaced by the plane's
/// root along `k` (an *edge function*, whose zero set is the projection along
/// `k` of the edge where the plane meets this leaf).
#[derive(Clone, Copy, Debug)]
pub(super) struct Restricted {
    pub leaf: usize,
    pub(super) pinned: [Option<f64>; 3],
    /// `(k, plane leaf, 1 / ∂ψ_P/∂x_k)`.
    pub(super) on_plane: Option<(usize, usize, f64)>,
}

impl Restricted {
    fn apply<T: Scalar>(&self, g: &Geometry, mut x: [T; 3]) -> [T; 3] {
        for (xi, p) in x.iter_mut().zip(self.pinned) {
            if let Some(v) = p {
                *xi = T::cst(v);
            }
        }
        if let Some((k, plane, inv)) = self.on_plane {
            // ψ_P is linear: its root along k is x_k = −ψ_P(x with x_k = 0) / a_k.
            let mut y = x;
            y[k] = T::cst(0.0);
            x[k] = g.leaves()[plane].eval(y).scale(-inv);
        }
        x
    }

    pub(super) fn value_grad(&self, g: &Geometry, x: [f64; 3]) -> (f64, [f64; 3]) {
        let d = self.apply(
            g,
            [Dual::var(x[0], 0), Dual::var(x[1], 1), Dual::var(x[2], 2)],
        );
        let v = g.leaves()[self.leaf].eval(d);
        (v.v, v.d)
    }

    /// The surface this function restricts: its leaf, and the plane leaf of an
    /// edge function.
    pub(super) fn surface(&self) -> (usize, Option<usize>) {
        (self.leaf, self.on_plane.map(|(_, p, _)| p))
    }

    /// The edge function of this leaf on the plane leaf `plane` along `k`,
    /// when the plane is strictly monotone along `k` (`bd`: its bounds).
    pub(super) fn on_plane(
        &self,
        plane: usize,
        bd: &Dual<Interval>,
        k: usize,
    ) -> Option<Restricted> {
        let a = bd.d[k];
        if !a.strictly_signed() || self.on_plane.is_some() {
            return None;
        }
        Some(Restricted {
            on_plane: Some((k, plane, 1.0 / a.mid())),
            ..*self
        })
    }

    /// The box with the pinned axes collapsed onto their pins.
    fn pinned_box(&self, b: &Aabb) -> Aabb {
        let mut pb = *b;
        for (i, p) in self.pinned.iter().enumerate() {
            if let Some(v) = p {
                pb.lo[i] = *v;
                pb.hi[i] = *v;
            }
        }
        pb
    }

    /// Interval bounds of ψ and ∇ψ over the box (pinned axes at their pins),
    /// or `None` when ψ keeps one strict sign there (`keep_touching`: also
    /// keep a ψ whose bounds only touch zero).
    pub(super) fn bounds_if_active(
        &self,
        g: &Geometry,
        b: &Aabb,
        keep_touching: bool,
    ) -> Option<Dual<Interval>> {
        let pb = self.pinned_box(b);
        let leaf = &g.leaves()[self.leaf];
        let active = |v: Interval| {
            if keep_touching {
                v.lo <= 0.0 && v.hi >= 0.0
            } else {
                v.straddles_zero()
            }
        };
        if self.on_plane.is_some() {
            let x = [0, 1, 2].map(|i| Dual::var(Interval::new(pb.lo[i], pb.hi[i]), i));
            let bd = leaf.eval(self.apply(g, x));
            return active(bd.v).then_some(bd);
        }
        // The natural extension is cheap and usually decides far-away leaves.
        if !active(leaf.eval(box_intervals(&pb))) {
            return None;
        }
        let bd = leaf.bounds(&pb);
        active(bd.v).then_some(bd)
    }

    pub(super) fn pinned_at(&self, axis: usize, v: f64) -> Restricted {
        let mut r = *self;
        r.pinned[axis] = Some(v);
        r
    }
}
