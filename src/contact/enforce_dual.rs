//! Second-order forward-mode numbers in `N` variables (value, gradient and
//! Hessian), for the exact first and second derivatives of the contact gap
//! with respect to the few kinematic quantities it depends on (see
//! [`super::enforce_gap`]).
//!
//! Rules: `(a ± b)'' = a'' ± b''`,
//! `(ab)'' = a b'' + b a'' + a'⊗b' + b'⊗a'` and, for a scalar function `f`,
//! `f(a)'' = f'(a) a'' + f''(a) a'⊗a'` (used for `1/a` and `√a`).
//!
//! The Hessian is `H × H`: `H = N` carries it, `H = 0` drops it (first
//! order, for a residual without its tangent). Values and gradients never
//! read the Hessian, so they are the same to the bit either way.

use std::ops::{Add, Mul, Sub};

/// A value with its gradient in `N` variables and its Hessian (`H = N`) or
/// none (`H = 0`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HyperDual<const N: usize, const H: usize> {
    pub v: f64,
    pub g: [f64; N],
    pub h: [[f64; H]; H],
}

impl<const N: usize, const H: usize> HyperDual<N, H> {
    /// A constant.
    pub fn cst(v: f64) -> Self {
        const { assert!(H == N || H == 0, "a Hessian is N × N or absent") };
        HyperDual {
            v,
            g: [0.0; N],
            h: [[0.0; H]; H],
        }
    }

    /// Variable number `i` with value `v`.
    pub fn var(v: f64, i: usize) -> Self {
        let mut x = Self::cst(v);
        x.g[i] = 1.0;
        x
    }

    /// `s · self` for a constant `s`.
    pub fn scale(mut self, s: f64) -> Self {
        self.v *= s;
        self.g.iter_mut().for_each(|g| *g *= s);
        self.h.iter_mut().flatten().for_each(|h| *h *= s);
        self
    }

    /// `f(self)` from `f`, `f'` and `f''` at `self.v`.
    fn chain(self, f: f64, df: f64, ddf: f64) -> Self {
        let mut r = Self::cst(f);
        for i in 0..N {
            r.g[i] = df * self.g[i];
        }
        for i in 0..H {
            for j in 0..H {
                r.h[i][j] = df * self.h[i][j] + ddf * self.g[i] * self.g[j];
            }
        }
        r
    }

    /// `1 / self`.
    pub fn recip(self) -> Self {
        let r = 1.0 / self.v;
        self.chain(r, -r * r, 2.0 * r * r * r)
    }

    /// `√self` (for `self.v > 0`).
    pub fn sqrt(self) -> Self {
        let s = self.v.sqrt();
        self.chain(s, 0.5 / s, -0.25 / (s * self.v))
    }

    /// `q(z(y))` by the chain rule to second order, for an outer number `q`
    /// in `K` inner variables `z` and each `z_r` given by its offset in
    /// `y` and its derivatives in the `B` variables of `y` from there:
    /// `∇q = Σ_r q_r ∇z_r`,
    /// `∇²q = Σ_rs q_rs ∇z_r ⊗ ∇z_s + Σ_r q_r ∇²z_r`.
    /// With a Hessian (`H = N`) `q` and the `z_r` carry theirs.
    pub fn compose<const K: usize, const HK: usize, const B: usize, const HB: usize>(
        q: &HyperDual<K, HK>,
        z: &[(usize, HyperDual<B, HB>); K],
    ) -> Self {
        const {
            assert!(
                H == 0 || (HK == K && HB == B),
                "second order needs inner Hessians"
            )
        };
        // A block may run past the end of `y`: its entries there are zero.
        let len = |offset: usize| B.min(N.saturating_sub(offset));
        let hessian_len = |offset: usize| B.min(H.saturating_sub(offset));
        let mut out = Self::cst(q.v);
        for (&(offset, ref zr), &qr) in z.iter().zip(&q.g) {
            for a in 0..len(offset) {
                out.g[offset + a] += qr * zr.g[a];
            }
            for a in 0..hessian_len(offset) {
                for b in 0..hessian_len(offset) {
                    out.h[offset + a][offset + b] += qr * zr.h[a][b];
                }
            }
        }
        for (&(oa, ref za), row) in z.iter().zip(&q.h) {
            for (&(ob, ref zb), &w) in z.iter().zip(row) {
                if w == 0.0 {
                    continue;
                }
                for a in 0..hessian_len(oa) {
                    let wa = w * za.g[a];
                    for b in 0..hessian_len(ob) {
                        out.h[oa + a][ob + b] += wa * zb.g[b];
                    }
                }
            }
        }
        out
    }

    /// A number in `B` variables placed at `offset` among `N`.
    pub fn embed<const B: usize, const HB: usize>(offset: usize, x: &HyperDual<B, HB>) -> Self {
        const { assert!(H == 0 || HB == B, "second order needs the block's Hessian") };
        let mut out = Self::cst(x.v);
        out.g[offset..offset + B].copy_from_slice(&x.g);
        for a in 0..B.min(H) {
            for b in 0..B.min(H) {
                out.h[offset + a][offset + b] = x.h[a][b];
            }
        }
        out
    }

    fn zip(self, o: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        let mut r = self;
        r.v = f(self.v, o.v);
        for i in 0..N {
            r.g[i] = f(self.g[i], o.g[i]);
        }
        for i in 0..H {
            for j in 0..H {
                r.h[i][j] = f(self.h[i][j], o.h[i][j]);
            }
        }
        r
    }
}

impl<const N: usize, const H: usize> Add for HyperDual<N, H> {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        self.zip(o, |a, b| a + b)
    }
}

impl<const N: usize, const H: usize> Sub for HyperDual<N, H> {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        self.zip(o, |a, b| a - b)
    }
}

impl<const N: usize, const H: usize> Mul for HyperDual<N, H> {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        let mut r = Self::cst(self.v * o.v);
        for i in 0..N {
            r.g[i] = self.v * o.g[i] + self.g[i] * o.v;
        }
        for i in 0..H {
            for j in 0..H {
                r.h[i][j] = self.v * o.h[i][j]
                    + self.h[i][j] * o.v
                    + self.g[i] * o.g[j]
                    + self.g[j] * o.g[i];
            }
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivatives_of_a_rational_root_are_exact() {
        // f(x, y) = √x · y / (x + y) at (4, 1).
        let (x, y) = (
            HyperDual::<2, 2>::var(4.0, 0),
            HyperDual::<2, 2>::var(1.0, 1),
        );
        let f = x.sqrt() * y * (x + y).recip();
        let (xv, yv) = (4.0f64, 1.0f64);
        let s = xv + yv;
        assert!((f.v - 2.0 / 5.0).abs() < 1e-15);
        // ∂f/∂x = y (1/(2√x) / s − √x / s²), ∂f/∂y = √x (1/s − y/s²).
        let fx = yv * (0.5 / xv.sqrt() / s - xv.sqrt() / (s * s));
        let fy = xv.sqrt() * (1.0 / s - yv / (s * s));
        assert!((f.g[0] - fx).abs() < 1e-15 && (f.g[1] - fy).abs() < 1e-15);
        // ∂²f/∂y² = √x (−2/s² + 2y/s³).
        let fyy = xv.sqrt() * (-2.0 / (s * s) + 2.0 * yv / (s * s * s));
        assert!((f.h[1][1] - fyy).abs() < 1e-15);
        assert!((f.h[0][1] - f.h[1][0]).abs() < 1e-16);
        // ∂²f/∂x² against a central difference of ∂f/∂x.
        let dfx = |x: f64| yv * (0.5 / x.sqrt() / (x + yv) - x.sqrt() / ((x + yv) * (x + yv)));
        let fxx = (dfx(4.0 + 1e-5) - dfx(4.0 - 1e-5)) / 2e-5;
        assert!((f.h[0][0] - fxx).abs() < 1e-9, "{} vs {fxx}", f.h[0][0]);
    }
}
