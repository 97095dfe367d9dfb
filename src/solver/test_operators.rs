//! Test operators for the Krylov solvers: 7-point stencils on an `n × n × n`
//! grid of interior nodes with homogeneous Dirichlet conditions (the Laplacian,
//! SPD with eigenvalues known in closed form, and an upwind
//! convection–diffusion operator, non-symmetric), a diagonally scaled operator
//! `D A D`, and a wrapper that corrupts chosen applications.

use std::cell::Cell;
use std::f64::consts::PI;
use std::ops::Range;

use crate::backend::LinearOperator;

/// `y_ijk = c x_ijk + Σ_d (lower_d x_{ijk − e_d} + upper_d x_{ijk + e_d})`,
/// neighbours outside the grid being zero (Dirichlet), scaled by `h²`.
pub struct Stencil7 {
    pub n: usize,
    pub center: f64,
    pub lower: [f64; 3],
    pub upper: [f64; 3],
}

impl Stencil7 {
    /// `−Δ` (times `h²`): 6 on the diagonal, −1 to each neighbour.
    pub fn laplacian(n: usize) -> Self {
        Stencil7 {
            n,
            center: 6.0,
            lower: [-1.0; 3],
            upper: [-1.0; 3],
        }
    }

    /// `−Δ u + c·∇u` (times `h²`) with upwind differences for `c ≥ 0`;
    /// `hc[d] = h c_d` is the cell Péclet number times 2.
    pub fn convection_diffusion(n: usize, hc: [f64; 3]) -> Self {
        Stencil7 {
            n,
            center: 6.0 + hc.iter().sum::<f64>(),
            lower: hc.map(|v| -1.0 - v),
            upper: [-1.0; 3],
        }
    }

    /// `−A`: negative definite when `A` is the Laplacian.
    pub fn negated(self) -> Self {
        Stencil7 {
            n: self.n,
            center: -self.center,
            lower: self.lower.map(|v| -v),
            upper: self.upper.map(|v| -v),
        }
    }
}

/// `(λ_min, λ_max)` of [`Stencil7::laplacian`]`(n)`: the eigenvalues are
/// `Σ_d 4 sin²(π i_d / (2(n+1)))`, `i_d = 1..n`.
pub fn laplacian_extreme_eigenvalues(n: usize) -> (f64, f64) {
    let lam = |i: usize| 4.0 * (PI * i as f64 / (2.0 * (n + 1) as f64)).sin().powi(2);
    (3.0 * lam(1), 3.0 * lam(n))
}

impl LinearOperator for Stencil7 {
    fn nrows(&self) -> usize {
        self.n.pow(3)
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let n = self.n;
        let stride = [1, n, n * n];
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let idx = i + n * (j + n * k);
                    let mut acc = self.center * x[idx];
                    for (d, &c) in [i, j, k].iter().enumerate() {
                        if c > 0 {
                            acc += self.lower[d] * x[idx - stride[d]];
                        }
                        if c + 1 < n {
                            acc += self.upper[d] * x[idx + stride[d]];
                        }
                    }
                    y[idx] = acc;
                }
            }
        }
    }

    fn diagonal(&self) -> Vec<f64> {
        vec![self.center; self.nrows()]
    }
}

/// `D A D` with `D = diag(d)`: badly scaled when `d` spans decades.
pub struct Scaled<O> {
    pub inner: O,
    pub d: Vec<f64>,
}

impl<O: LinearOperator> LinearOperator for Scaled<O> {
    fn nrows(&self) -> usize {
        self.inner.nrows()
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let dx: Vec<f64> = x.iter().zip(&self.d).map(|(a, b)| a * b).collect();
        self.inner.apply(&dx, y);
        y.iter_mut().zip(&self.d).for_each(|(yi, di)| *yi *= di);
    }

    fn diagonal(&self) -> Vec<f64> {
        let a = self.inner.diagonal();
        a.iter().zip(&self.d).map(|(a, d)| a * d * d).collect()
    }
}

/// Multiplies the result of the applications numbered `bad` (from 0) by
/// `factor`: NaN for a poisoned operator, `1 + δ` for an inexact one.
pub struct Faulty<O> {
    pub inner: O,
    pub bad: Range<usize>,
    pub factor: f64,
    pub calls: Cell<usize>,
}

impl<O> Faulty<O> {
    pub fn new(inner: O, bad: Range<usize>, factor: f64) -> Self {
        Faulty {
            inner,
            bad,
            factor,
            calls: Cell::new(0),
        }
    }
}

impl<O: LinearOperator> LinearOperator for Faulty<O> {
    fn nrows(&self) -> usize {
        self.inner.nrows()
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.inner.apply(x, y);
        let call = self.calls.replace(self.calls.get() + 1);
        if self.bad.contains(&call) {
            y.iter_mut().for_each(|v| *v *= self.factor);
        }
    }

    fn diagonal(&self) -> Vec<f64> {
        self.inner.diagonal()
    }
}
