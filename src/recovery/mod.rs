//! Superconvergent Patch Recovery (SPR, Zienkiewicz–Zhu) with Conjoint
//! Polynomial Enhancement (CPE) Owns the monomial basis
//! ([`Monomials`]), the per-patch least-squares fit with optional linear
//! equality constraints ([`fit_polynomial`]) and the patch recovery over the
//! grid's Q1 vertex nodes ([`recover`], [`Recovered`]).
//!
//! # The maths
//! A *patch* of ring `r` around the vertex node `x_i` is the set of cells with
//! positive volume (kind ≠ outside) whose index lies within `r` cells of the
//! node along every axis (ring 1: the up to 8 cells sharing the vertex). Its
//! *sample points* `x_s` are the quadrature points of those cells that lie in Ω
//! (Gauss points of inside cells, the cut-cell volume points of cut cells) with
//! the FE field values `σ_h(x_s)` there, both supplied by the caller
//! ([`PatchSamples`]).
//!
//! On each patch every component `c` of the field is fitted by a complete
//! polynomial of degree `p`, `σ*_{i,c}(x) = Σ_j a_{c j} φ_j(ξ)` in the scaled
//! coordinates `ξ = (x − x_i)/h`, by least squares:
//! `min Σ_s (σ*_{i,c}(x_s) − σ_{h,c}(x_s))²`, optionally subject to linear
//! equality constraints `C a = d` on the stacked coefficients of all components
//! (Lagrange multipliers, [`fit_polynomial`]). A patch with too few points, or
//! whose points do not control the polynomial on the node's cells (an
//! ill-conditioned whitened normal matrix, see [`FitOptions`]), is enlarged by
//! one ring, up to [`SprOptions::max_rings`].
//!
//! The recovered field is the CPE blend of the patch polynomials of the cell's 8
//! vertices with the trilinear hat functions `N_i^lin`:
//! `σ̂(x) = Σ_{i ∈ vertices(cell(x))} N_i^lin(x) σ*_i(x)`. It reproduces every
//! polynomial of degree `p` exactly (each `σ*_i` does and `Σ_i N_i^lin = 1`), and
//! it is defined on the whole cell box, also outside Ω (polynomial extension).

mod fit;
mod inside;
mod kkt;
mod mirror;
#[cfg(test)]
mod mirror_tests;
mod moments;
mod plan;
mod recovered;
mod regular;
mod sample_cache;
mod spr;
#[cfg(test)]
mod spr_tests;
#[cfg(test)]
mod tests;

use nalgebra::DMatrix;

pub use fit::{fit_polynomial, FitFactor, FitFailure, FitOptions, LinearConstraints};
pub use inside::InsideMoments;
pub use mirror::Mirror;
pub use plan::{plan_fits, recover_planned, FitPlans};
pub use recovered::{BlendTable, CellBlend, Recovered};
pub use spr::{recover, recover_around, Patch, PatchInfo, PatchSamples, RecoveryStats, SprOptions};

/// A sample: a point (physical, or scaled for [`fit_polynomial`]) and the `NC`
/// field components there.
pub type Sample<const NC: usize> = ([f64; 3], [f64; NC]);

/// Highest polynomial degree of a [`Monomials`] basis (165 terms).
pub const MAX_DEGREE: usize = 8;

/// The complete monomial basis of degree `p` in three variables:
/// `ξ^a η^b ζ^c` with `a + b + c ≤ p`, `(p+1)(p+2)(p+3)/6` terms (4, 10, 20 for
/// p = 1, 2, 3).
///
/// Terms are graded: by total degree, then lexicographically with higher powers
/// of `ξ` first, then of `η` (p = 2: `1, ξ, η, ζ, ξ², ξη, ξζ, η², ηζ, ζ²`).
#[derive(Clone, Debug, PartialEq)]
pub struct Monomials {
    degree: usize,
    exponents: Vec<[usize; 3]>,
    /// The Gram matrix of the terms on the box ([`Monomials::box_gram`]).
    gram: DMatrix<f64>,
    /// The terms of a change of origin ([`Monomials::for_each_shift`]):
    /// `(e, f, Π_k C(e_k, f_k), e − f)` for every pair `f ≤ e`.
    shifts: Vec<(usize, usize, u32, [usize; 3])>,
}

impl Monomials {
    /// The complete basis of `degree`.
    ///
    /// # Panics
    /// When `degree > MAX_DEGREE`.
    pub fn new(degree: usize) -> Monomials {
        assert!(
            degree <= MAX_DEGREE,
            "monomial degree {degree} > {MAX_DEGREE}"
        );
        let mut exponents = Vec::new();
        for total in 0..=degree {
            for a in (0..=total).rev() {
                for b in (0..=total - a).rev() {
                    exponents.push([a, b, total - a - b]);
                }
            }
        }
        let mut shifts = Vec::new();
        for (i, e) in exponents.iter().enumerate() {
            for (j, f) in exponents.iter().enumerate() {
                if (0..3).all(|k| f[k] <= e[k]) {
                    let binom = (0..3).map(|k| binomial(e[k], f[k])).product::<f64>();
                    shifts.push((i, j, binom as u32, [0, 1, 2].map(|k| e[k] - f[k])));
                }
            }
        }
        let gram = box_gram(&exponents);
        Monomials {
            degree,
            exponents,
            gram,
            shifts,
        }
    }

    /// `G_ef = ∫ φ_e φ_f dμ` for the uniform probability `μ` on `[−1, 1]³`,
    /// the reference of a fit's stability ([`FitOptions`]).
    pub fn box_gram(&self) -> &DMatrix<f64> {
        &self.gram
    }

    pub fn degree(&self) -> usize {
        self.degree
    }

    /// Number of terms, `(p+1)(p+2)(p+3)/6`.
    pub fn len(&self) -> usize {
        self.exponents.len()
    }

    /// Always false: the constant is a term of every degree.
    pub fn is_empty(&self) -> bool {
        self.exponents.is_empty()
    }

    /// The exponents `[a, b, c]` of each term, in basis order.
    pub fn exponents(&self) -> &[[usize; 3]] {
        &self.exponents
    }

    /// The change of coefficients under a shift of the origin by `t`:
    /// `φ_e(ξ − t) = Σ_f T_fe φ_f(ξ)`, so a polynomial with coefficients `b` in
    /// `ξ − t` has coefficients `T b` in `ξ`. By the binomial theorem per axis,
    /// `T_fe = Π_k C(e_k, f_k) (−t_k)^{e_k − f_k}` for `f ≤ e` componentwise,
    /// else 0 (upper triangular in the graded order, unit diagonal).
    pub fn translation(&self, t: [f64; 3]) -> DMatrix<f64> {
        let n = self.len();
        let pw = self.powers(t.map(|v| -v));
        DMatrix::from_fn(n, n, |f, e| {
            let (f, e) = (self.exponents[f], self.exponents[e]);
            let mut v = 1.0;
            for k in 0..3 {
                if f[k] > e[k] {
                    return 0.0;
                }
                v *= binomial(e[k], f[k]) * pw[e[k] - f[k]][k];
            }
            v
        })
    }

    /// The change of origin `φ_e(ξ + t) = Σ_{f ≤ e} w_ef(t) φ_f(ξ)`, with
    /// `w_ef(t) = Π_k C(e_k, f_k) t_k^{e_k − f_k}` (the binomial theorem per
    /// axis): calls `term(e, f, w_ef)` for every pair `f ≤ e`. Moments move
    /// with it (`Σ_s φ_e(ξ_s + t) v_s = Σ_f w_ef Σ_s φ_f(ξ_s) v_s`), and so
    /// do coefficients (`Σ_e a_e φ_e(ξ + t) = Σ_f (Σ_e w_ef a_e) φ_f(ξ)`).
    pub fn for_each_shift(&self, t: [f64; 3], mut term: impl FnMut(usize, usize, f64)) {
        let pw = self.powers(t);
        for &(e, f, binom, d) in &self.shifts {
            term(e, f, binom as f64 * pw[d[0]][0] * pw[d[1]][1] * pw[d[2]][2]);
        }
    }

    /// Moments moved by [`Monomials::for_each_shift`]: `to[e] += Σ_f w_ef(t)
    /// from[f]`, each of `to` and `from` holding `NC` components per term
    /// (term `j`, component `c` at `j·NC + c`). The same sums, in the same
    /// order, as a `for_each_shift` that adds `w · from[f·NC + c]` to
    /// `to[e·NC + c]`.
    ///
    /// # Panics
    /// When `to` or `from` holds fewer than [`Monomials::len`] terms.
    pub fn shift_moments<const NC: usize>(&self, t: [f64; 3], from: &[f64], to: &mut [f64]) {
        let pw = self.powers(t);
        let (from, to) = (from.as_chunks::<NC>().0, to.as_chunks_mut::<NC>().0);
        for &(e, f, binom, d) in &self.shifts {
            let w = binom as f64 * pw[d[0]][0] * pw[d[1]][1] * pw[d[2]][2];
            let (a, b) = (&mut to[e], &from[f]);
            for c in 0..NC {
                a[c] += w * b[c];
            }
        }
    }

    /// Powers `ξ_k^e` for `e ≤ p`, per axis.
    fn powers(&self, xi: [f64; 3]) -> [[f64; 3]; MAX_DEGREE + 1] {
        let mut pw = [[1.0; 3]; MAX_DEGREE + 1];
        for e in 1..=self.degree {
            for k in 0..3 {
                pw[e][k] = pw[e - 1][k] * xi[k];
            }
        }
        pw
    }

    /// Basis values `φ_j(ξ)`; `out` must hold [`Monomials::len`] entries.
    pub fn values(&self, xi: [f64; 3], out: &mut [f64]) {
        assert_eq!(out.len(), self.len(), "monomial value buffer");
        let pw = self.powers(xi);
        for (o, e) in out.iter_mut().zip(&self.exponents) {
            *o = pw[e[0]][0] * pw[e[1]][1] * pw[e[2]][2];
        }
    }

    /// Basis gradients `∇_ξ φ_j(ξ)`, e.g. `∂_ξ ξ^a η^b ζ^c = a ξ^{a−1} η^b ζ^c`.
    /// With `ξ = (x − x_i)/h` the physical gradient is `∇_ξ φ_j / h`.
    pub fn gradients(&self, xi: [f64; 3], out: &mut [[f64; 3]]) {
        assert_eq!(out.len(), self.len(), "monomial gradient buffer");
        let pw = self.powers(xi);
        for (o, e) in out.iter_mut().zip(&self.exponents) {
            for k in 0..3 {
                if e[k] == 0 {
                    o[k] = 0.0;
                    continue;
                }
                let mut g = e[k] as f64;
                for m in 0..3 {
                    g *= pw[if m == k { e[m] - 1 } else { e[m] }][m];
                }
                o[k] = g;
            }
        }
    }
}

/// `C(n, k)` as a float.
fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

/// `G_ef = ∫ φ_e φ_f dμ` for the uniform probability `μ` on `[−1, 1]³`: per
/// axis the moment of `t^k` is `1/(k+1)` for even `k`, 0 for odd `k`.
fn box_gram(e: &[[usize; 3]]) -> DMatrix<f64> {
    let moment = |k: usize| {
        if k.is_multiple_of(2) {
            1.0 / (k + 1) as f64
        } else {
            0.0
        }
    };
    DMatrix::from_fn(e.len(), e.len(), |a, b| {
        (0..3).map(|k| moment(e[a][k] + e[b][k])).product()
    })
}
