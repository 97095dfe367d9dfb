//! Number types the level sets are evaluated with: plain `f64`, intervals (for
//! sign and monotonicity bounds over a box) and forward-mode duals (gradients).
//! Each leaf surface is written once, generically over [`Scalar`].

use std::ops::{Add, Mul, Neg, Sub};

use super::voxels::Voxels;
use crate::mesh::MeshSolid;
use crate::spatial::Aabb;

/// Arithmetic a level set needs: ring operations and constants.
pub trait Scalar:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self>
{
    /// A constant.
    fn cst(v: f64) -> Self;
    /// Multiplication by a constant.
    fn scale(self, s: f64) -> Self;
    /// `self * self` (tighter than a product for intervals).
    fn sqr(self) -> Self {
        self * self
    }
    /// The range of the value part: `(v, v)` for a point, `(lo, hi)` for an
    /// interval.
    fn range(&self) -> (f64, f64);
    /// The value part restricted to `[lo, hi]` (a point is left as it is).
    fn restrict(self, lo: f64, hi: f64) -> Self;
    /// An enclosure of both (a point keeps `self`: a point lies in one
    /// piece of a piecewise function).
    fn hull(self, o: Self) -> Self;
    /// A voxel image's level set at the padded voxel coordinates `u`
    /// ([`Voxels::piecewise`], the trilinear polynomial of each voxel cell
    /// met; [`f64`] and [`Interval`] take shortcuts).
    fn voxel(img: &Voxels, u: [Self; 3]) -> Self {
        img.piecewise(u)
    }
    /// Its partial derivatives `∂ψ/∂u_a` at `u` (each met cell's, hulled).
    fn voxel_slopes(img: &Voxels, u: [Self; 3]) -> [Self; 3] {
        img.piecewise_slopes(u)
    }
}

/// Scalars that also have min and max, for CSG (union = min, intersection = max).
pub trait Lattice: Scalar {
    fn min(self, o: Self) -> Self;
    fn max(self, o: Self) -> Self;
    /// The level set `½ − w` of a mesh solid ([`MeshSolid::phi`]) at `x`: the
    /// value at a point; over a box, the value at its centre when no triangle
    /// meets the box (exact for a closed mesh, whose `w` is constant off the
    /// surface) and `[−½, ½]` otherwise; for a dual, the value with a zero
    /// gradient (exact off the surface of a closed mesh).
    fn mesh_level_set(mesh: &MeshSolid, x: [Self; 3]) -> Self;
}

impl Scalar for f64 {
    fn cst(v: f64) -> Self {
        v
    }
    fn scale(self, s: f64) -> Self {
        self * s
    }
    fn range(&self) -> (f64, f64) {
        (*self, *self)
    }
    fn restrict(self, _lo: f64, _hi: f64) -> Self {
        self
    }
    fn hull(self, _o: Self) -> Self {
        self
    }
    fn voxel(img: &Voxels, u: [Self; 3]) -> Self {
        img.value(u)
    }
    fn voxel_slopes(img: &Voxels, u: [Self; 3]) -> [Self; 3] {
        img.slope_range(u.map(|x| (x, x))).map(|i| i.lo)
    }
}

impl Lattice for f64 {
    fn min(self, o: Self) -> Self {
        f64::min(self, o)
    }
    fn max(self, o: Self) -> Self {
        f64::max(self, o)
    }
    fn mesh_level_set(mesh: &MeshSolid, x: [Self; 3]) -> Self {
        mesh.phi(x)
    }
}

/// A closed interval `[lo, hi]` (no directed rounding: bounds are exact up to a
/// few ulps, which is all the cut-cell classification needs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    pub lo: f64,
    pub hi: f64,
}

/// A box as intervals, one per axis.
pub fn box_intervals(b: &Aabb) -> [Interval; 3] {
    [0, 1, 2].map(|i| Interval::new(b.lo[i], b.hi[i]))
}

impl Interval {
    pub fn new(lo: f64, hi: f64) -> Self {
        Interval { lo, hi }
    }
    /// True when every value is `< 0` or every value is `> 0`.
    pub fn strictly_signed(&self) -> bool {
        self.hi < 0.0 || self.lo > 0.0
    }
    /// True when zero lies strictly inside, so the function changes sign.
    pub fn straddles_zero(&self) -> bool {
        self.lo < 0.0 && self.hi > 0.0
    }
    pub fn mid(&self) -> f64 {
        0.5 * (self.lo + self.hi)
    }
}

impl Add for Interval {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Interval::new(self.lo + o.lo, self.hi + o.hi)
    }
}

impl Sub for Interval {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Interval::new(self.lo - o.hi, self.hi - o.lo)
    }
}

impl Neg for Interval {
    type Output = Self;
    fn neg(self) -> Self {
        Interval::new(-self.hi, -self.lo)
    }
}

impl Mul for Interval {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        let p = [
            self.lo * o.lo,
            self.lo * o.hi,
            self.hi * o.lo,
            self.hi * o.hi,
        ];
        Interval::new(
            p.iter().copied().fold(f64::INFINITY, f64::min),
            p.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        )
    }
}

impl Scalar for Interval {
    fn cst(v: f64) -> Self {
        Interval::new(v, v)
    }
    fn scale(self, s: f64) -> Self {
        if s >= 0.0 {
            Interval::new(self.lo * s, self.hi * s)
        } else {
            Interval::new(self.hi * s, self.lo * s)
        }
    }
    fn range(&self) -> (f64, f64) {
        (self.lo, self.hi)
    }
    fn restrict(self, lo: f64, hi: f64) -> Self {
        Interval::new(self.lo.max(lo), self.hi.min(hi))
    }
    fn hull(self, o: Self) -> Self {
        Interval::new(self.lo.min(o.lo), self.hi.max(o.hi))
    }
    fn voxel(img: &Voxels, u: [Self; 3]) -> Self {
        img.range(u.map(|i| (i.lo, i.hi)))
    }
    fn voxel_slopes(img: &Voxels, u: [Self; 3]) -> [Self; 3] {
        img.slope_range(u.map(|i| (i.lo, i.hi)))
    }
    fn sqr(self) -> Self {
        if self.lo >= 0.0 {
            Interval::new(self.lo * self.lo, self.hi * self.hi)
        } else if self.hi <= 0.0 {
            Interval::new(self.hi * self.hi, self.lo * self.lo)
        } else {
            Interval::new(0.0, f64::max(self.lo * self.lo, self.hi * self.hi))
        }
    }
}

impl Lattice for Interval {
    fn min(self, o: Self) -> Self {
        Interval::new(self.lo.min(o.lo), self.hi.min(o.hi))
    }
    fn max(self, o: Self) -> Self {
        Interval::new(self.lo.max(o.lo), self.hi.max(o.hi))
    }
    fn mesh_level_set(mesh: &MeshSolid, x: [Self; 3]) -> Self {
        let b = Aabb::new(x.map(|i| i.lo), x.map(|i| i.hi));
        if mesh.crosses(&b) {
            Interval::new(-0.5, 0.5)
        } else {
            let v = mesh.phi(x.map(|i| i.mid()));
            Interval::new(v, v)
        }
    }
}

/// Forward-mode dual number: a value and its gradient in 3D.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dual<T> {
    pub v: T,
    pub d: [T; 3],
}

impl<T: Scalar> Dual<T> {
    /// The independent variable along `axis` with value `v`.
    pub fn var(v: T, axis: usize) -> Self {
        let mut d = [T::cst(0.0); 3];
        d[axis] = T::cst(1.0);
        Dual { v, d }
    }
}

impl<T: Scalar> Add for Dual<T> {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Dual {
            v: self.v + o.v,
            d: [self.d[0] + o.d[0], self.d[1] + o.d[1], self.d[2] + o.d[2]],
        }
    }
}

impl<T: Scalar> Sub for Dual<T> {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Dual {
            v: self.v - o.v,
            d: [self.d[0] - o.d[0], self.d[1] - o.d[1], self.d[2] - o.d[2]],
        }
    }
}

impl<T: Scalar> Neg for Dual<T> {
    type Output = Self;
    fn neg(self) -> Self {
        Dual {
            v: -self.v,
            d: [-self.d[0], -self.d[1], -self.d[2]],
        }
    }
}

impl<T: Scalar> Mul for Dual<T> {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        let mut d = [T::cst(0.0); 3];
        for (i, di) in d.iter_mut().enumerate() {
            *di = self.v * o.d[i] + self.d[i] * o.v;
        }
        Dual { v: self.v * o.v, d }
    }
}

impl<T: Scalar> Scalar for Dual<T> {
    fn cst(v: f64) -> Self {
        Dual {
            v: T::cst(v),
            d: [T::cst(0.0); 3],
        }
    }
    fn scale(self, s: f64) -> Self {
        Dual {
            v: self.v.scale(s),
            d: [self.d[0].scale(s), self.d[1].scale(s), self.d[2].scale(s)],
        }
    }
    fn sqr(self) -> Self {
        let mut d = [T::cst(0.0); 3];
        for (i, di) in d.iter_mut().enumerate() {
            *di = (self.v * self.d[i]).scale(2.0);
        }
        Dual { v: self.v.sqr(), d }
    }
    fn range(&self) -> (f64, f64) {
        self.v.range()
    }
    fn restrict(self, lo: f64, hi: f64) -> Self {
        Dual {
            v: self.v.restrict(lo, hi),
            d: self.d,
        }
    }
    fn hull(self, o: Self) -> Self {
        Dual {
            v: self.v.hull(o.v),
            d: [0, 1, 2].map(|i| self.d[i].hull(o.d[i])),
        }
    }
    /// The chain rule on the value's own voxel and slope enclosures (tight
    /// for intervals, where the cells' polynomials in dual form are not).
    fn voxel(img: &Voxels, u: [Self; 3]) -> Self {
        let uv = u.map(|x| x.v);
        let s = T::voxel_slopes(img, uv);
        let mut d = [T::cst(0.0); 3];
        for (j, dj) in d.iter_mut().enumerate() {
            *dj = s[0] * u[0].d[j] + s[1] * u[1].d[j] + s[2] * u[2].d[j];
        }
        Dual {
            v: T::voxel(img, uv),
            d,
        }
    }
}

/// Gradients of min/max follow the branch taken (one-sided at ties).
impl Lattice for Dual<f64> {
    fn min(self, o: Self) -> Self {
        if o.v < self.v {
            o
        } else {
            self
        }
    }
    fn max(self, o: Self) -> Self {
        if o.v > self.v {
            o
        } else {
            self
        }
    }
    fn mesh_level_set(mesh: &MeshSolid, x: [Self; 3]) -> Self {
        Dual {
            v: mesh.phi(x.map(|d| d.v)),
            d: [0.0; 3],
        }
    }
}

/// Second-order forward-mode number: value, gradient and Hessian in 3D.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dual2<T> {
    pub v: T,
    pub d: [T; 3],
    pub h: [[T; 3]; 3],
}

impl<T: Scalar> Dual2<T> {
    /// The independent variable along `axis` with value `v`.
    pub fn var(v: T, axis: usize) -> Self {
        let mut x = Self::cst(0.0);
        x.v = v;
        x.d[axis] = T::cst(1.0);
        x
    }

    fn map2(self, o: Self, f: impl Fn(T, T) -> T) -> Self {
        let mut r = self;
        r.v = f(self.v, o.v);
        for i in 0..3 {
            r.d[i] = f(self.d[i], o.d[i]);
            for j in 0..3 {
                r.h[i][j] = f(self.h[i][j], o.h[i][j]);
            }
        }
        r
    }
}

impl<T: Scalar> Add for Dual2<T> {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        self.map2(o, |a, b| a + b)
    }
}

impl<T: Scalar> Sub for Dual2<T> {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        self.map2(o, |a, b| a - b)
    }
}

impl<T: Scalar> Neg for Dual2<T> {
    type Output = Self;
    fn neg(self) -> Self {
        self.scale(-1.0)
    }
}

/// `(ab)'' = a b'' + b a'' + a'⊗b' + b'⊗a'`.
impl<T: Scalar> Mul for Dual2<T> {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        let mut r = Self::cst(0.0);
        r.v = self.v * o.v;
        for i in 0..3 {
            r.d[i] = self.v * o.d[i] + self.d[i] * o.v;
            for j in 0..3 {
                r.h[i][j] = self.v * o.h[i][j]
                    + self.h[i][j] * o.v
                    + self.d[i] * o.d[j]
                    + self.d[j] * o.d[i];
            }
        }
        r
    }
}

impl<T: Scalar> Scalar for Dual2<T> {
    fn cst(v: f64) -> Self {
        let z = T::cst(0.0);
        Dual2 {
            v: T::cst(v),
            d: [z; 3],
            h: [[z; 3]; 3],
        }
    }
    fn scale(self, s: f64) -> Self {
        let mut r = self;
        r.v = self.v.scale(s);
        for i in 0..3 {
            r.d[i] = self.d[i].scale(s);
            for j in 0..3 {
                r.h[i][j] = self.h[i][j].scale(s);
            }
        }
        r
    }
    fn sqr(self) -> Self {
        let mut r = self * self;
        r.v = self.v.sqr();
        for i in 0..3 {
            r.h[i][i] = (self.v * self.h[i][i]).scale(2.0) + self.d[i].sqr().scale(2.0);
        }
        r
    }
    fn range(&self) -> (f64, f64) {
        self.v.range()
    }
    fn restrict(self, lo: f64, hi: f64) -> Self {
        let mut r = self;
        r.v = self.v.restrict(lo, hi);
        r
    }
    fn hull(self, o: Self) -> Self {
        self.map2(o, |a, b| a.hull(b))
    }
}

impl Interval {
    /// `self ∩ o` (the tighter of two enclosures of the same set).
    pub fn meet(self, o: Interval) -> Interval {
        Interval::new(self.lo.max(o.lo), self.hi.min(o.hi))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interval_encloses_samples() {
        let a = Interval::new(-1.5, 0.5);
        let b = Interval::new(0.25, 2.0);
        let f = |x: Interval, y: Interval| (x * y - x.sqr()).scale(-2.0) + y;
        let r = f(a, b);
        for i in 0..=20 {
            for j in 0..=20 {
                let x = a.lo + (a.hi - a.lo) * i as f64 / 20.0;
                let y = b.lo + (b.hi - b.lo) * j as f64 / 20.0;
                let v = -2.0 * (x * y - x * x) + y;
                assert!(v >= r.lo - 1e-14 && v <= r.hi + 1e-14, "{v} not in {r:?}");
            }
        }
        assert_eq!(a.sqr(), Interval::new(0.0, 2.25));
    }

    #[test]
    fn dual2_hessian_matches_analytic() {
        let x = [Dual2::var(0.3, 0), Dual2::var(-0.7, 1), Dual2::var(1.1, 2)];
        // f = (x y)^2 + 3 z x: H = [[2y², 4xy, 3], [4xy, 2x², 0], [3, 0, 0]].
        let f = (x[0] * x[1]).sqr() + (x[2] * x[0]).scale(3.0);
        let h = [[0.98, -0.84, 3.0], [-0.84, 0.18, 0.0], [3.0, 0.0, 0.0]];
        for i in 0..3 {
            for j in 0..3 {
                assert!((f.h[i][j] - h[i][j]).abs() < 1e-14, "{i}{j}: {}", f.h[i][j]);
            }
        }
    }

    #[test]
    fn dual_gradient_matches_analytic() {
        let x = [Dual::var(0.3, 0), Dual::var(-0.7, 1), Dual::var(1.1, 2)];
        let f = (x[0] * x[1]).sqr() + x[2].scale(3.0) - x[0];
        let g = [2.0 * 0.3 * 0.49 - 1.0, 2.0 * 0.09 * -0.7, 3.0];
        for i in 0..3 {
            assert!((f.d[i] - g[i]).abs() < 1e-15);
        }
    }
}
