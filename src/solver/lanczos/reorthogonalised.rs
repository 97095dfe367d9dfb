//! Lanczos with full reorthogonalisation, run until one end of the spectrum
//! of a symmetric operator has converged.
//!
//! From a unit start vector `q_0`, step `j` forms `w = Op q_j`,
//! `α_j = q_jᵀ w`, orthogonalises `w` against every `q_0 … q_j` (two
//! Gram–Schmidt passes, so the basis stays orthonormal to rounding and no
//! ghost Ritz values appear), and sets `β_j = ‖w‖`, `q_{j+1} = w / β_j`. After
//! `m` steps `Op Q_m = Q_m T_m + β_{m−1} q_m e_mᵀ` with `T_m` tridiagonal
//! (diagonal `α`, off-diagonal `β_0 … β_{m−2}`).
//!
//! A Ritz pair `(θ, s)` of `T_m` gives the Ritz vector `y = Q_m s` with residual
//! `‖Op y − θ y‖ = β_{m−1} |s_m|`, so some eigenvalue of `Op` lies within
//! `r = β_{m−1} |s_m|` of `θ`, and within `r² / gap` once the Ritz values
//! separate (`gap` the distance to the next Ritz value). The extreme Ritz values
//! move monotonically outwards and never pass the extreme eigenvalues: an
//! unconverged `θ_max` is a lower bound of `λ_max`, an unconverged `θ_min` an
//! upper bound of `λ_min`.
//!
//! Eigenvalues of `T_m` are found by bisection on Sturm counts, their
//! eigenvectors by a twisted factorisation of `T_m − θ`, both `O(m)`, so the
//! convergence test after every step costs nothing next to the step itself.

use super::tridiagonal_eigenvalue;
use crate::{Error, Result};

/// `β_j ≤ BREAKDOWN · ‖T‖` means the Krylov space is invariant: the Ritz values
/// are eigenvalues to that accuracy and no further step can add anything.
const BREAKDOWN: f64 = 1e-12;

/// Which end of the spectrum a run converges.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum End {
    Largest,
    Smallest,
}

/// An extreme Ritz value and whether it met the tolerance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ritz {
    pub value: f64,
    pub converged: bool,
}

/// The Lanczos process: the orthonormal basis and the tridiagonal so far.
pub struct Lanczos {
    basis: Vec<Vec<f64>>,
    alphas: Vec<f64>,
    betas: Vec<f64>,
    /// Running estimate of `‖T‖`: `max_j |α_j| + β_{j−1} + β_j`.
    norm: f64,
    /// The Krylov space is invariant (breakdown, or as many steps as rows).
    exhausted: bool,
}

impl Lanczos {
    /// A process on `n` rows from a deterministic start vector drawn from `seed`.
    pub fn new(n: usize, seed: u64) -> Self {
        Lanczos {
            basis: vec![start_vector(n, seed)],
            alphas: Vec::new(),
            betas: Vec::new(),
            norm: 0.0,
            exhausted: false,
        }
    }

    /// Steps taken so far (applications of the operator).
    pub fn steps(&self) -> usize {
        self.alphas.len()
    }

    /// Steps until the Ritz value at `end` is within `rel_tol |θ| + abs_tol` of
    /// an eigenvalue, the space is exhausted, or `max_steps` steps in all have
    /// been taken; `op(x, y)` sets `y = Op x`. Continues where a previous run
    /// stopped.
    pub fn run(
        &mut self,
        mut op: impl FnMut(&[f64], &mut [f64]),
        end: End,
        rel_tol: f64,
        abs_tol: f64,
        max_steps: usize,
    ) -> Result<Ritz> {
        loop {
            if self.steps() > 0 {
                let (value, error) = self.ritz_value(end);
                let converged = self.exhausted || error <= rel_tol * value.abs() + abs_tol;
                if converged || self.steps() >= max_steps {
                    return Ok(Ritz { value, converged });
                }
            }
            self.step(&mut op)?;
        }
    }

    /// The unit Ritz vector `Q_m s` of the Ritz value at `end`.
    pub fn ritz_vector(&self, end: End) -> Vec<f64> {
        let m = self.steps();
        let theta = tridiagonal_eigenvalue(&self.alphas, &self.off2(), end_index(end, m));
        let s = eigenvector(&self.alphas, &self.betas[..m - 1], theta);
        let mut y = vec![0.0; self.basis[0].len()];
        for (q, &c) in self.basis.iter().zip(&s) {
            axpy(c, q, &mut y);
        }
        let norm = dot(&y, &y).sqrt();
        y.iter_mut().for_each(|v| *v /= norm);
        y
    }

    /// One Lanczos step with full reorthogonalisation.
    fn step(&mut self, op: &mut impl FnMut(&[f64], &mut [f64])) -> Result<()> {
        let j = self.steps();
        let q = &self.basis[j];
        let mut w = vec![0.0; q.len()];
        op(q, &mut w);
        let alpha = dot(q, &w);
        for _ in 0..2 {
            for q in &self.basis {
                axpy(-dot(q, &w), q, &mut w);
            }
        }
        let beta = dot(&w, &w).sqrt();
        if !(alpha.is_finite() && beta.is_finite()) {
            return Err(Error::Breakdown {
                method: "lanczos".into(),
                iterations: j,
                what: "non-finite value (matrix or factor not finite)".into(),
            });
        }
        let previous = self.betas.last().copied().unwrap_or(0.0);
        self.norm = self.norm.max(alpha.abs() + beta + previous);
        self.alphas.push(alpha);
        self.betas.push(beta);
        if beta <= BREAKDOWN * self.norm || self.basis.len() == w.len() {
            self.exhausted = true;
        } else {
            w.iter_mut().for_each(|v| *v /= beta);
            self.basis.push(w);
        }
        Ok(())
    }

    /// The Ritz value at `end` and its error bound `min(r, r²/gap)`.
    fn ritz_value(&self, end: End) -> (f64, f64) {
        let m = self.steps();
        let off2 = self.off2();
        let theta = tridiagonal_eigenvalue(&self.alphas, &off2, end_index(end, m));
        let s = eigenvector(&self.alphas, &self.betas[..m - 1], theta);
        let r = self.betas[m - 1] * s[m - 1].abs();
        let gap = match (m, end) {
            (1, _) => 0.0,
            (_, End::Largest) => theta - tridiagonal_eigenvalue(&self.alphas, &off2, m - 2),
            (_, End::Smallest) => tridiagonal_eigenvalue(&self.alphas, &off2, 1) - theta,
        };
        let error = if gap > 0.0 { r.min(r * r / gap) } else { r };
        (theta, error)
    }

    /// Squared off-diagonal of `T_m`.
    fn off2(&self) -> Vec<f64> {
        let m = self.steps();
        self.betas[..m - 1].iter().map(|b| b * b).collect()
    }
}

/// Index (from the smallest) of the eigenvalue at `end` of an `m × m` matrix.
fn end_index(end: End, m: usize) -> usize {
    match end {
        End::Largest => m - 1,
        End::Smallest => 0,
    }
}

/// A unit vector with entries uniform in `(−1, 1)`, none zero, from SplitMix64.
fn start_vector(n: usize, seed: u64) -> Vec<f64> {
    let mut state = seed;
    let mut v: Vec<f64> = (0..n)
        .map(|_| {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            // (k + 1/2) / 2⁵³ ∈ (0, 1), so 2u − 1 is never zero.
            2.0 * (((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64) - 1.0
        })
        .collect();
    let norm = dot(&v, &v).sqrt();
    v.iter_mut().for_each(|x| *x /= norm);
    v
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `y += c x`.
fn axpy(c: f64, x: &[f64], y: &mut [f64]) {
    y.iter_mut().zip(x).for_each(|(yi, xi)| *yi += c * xi);
}

/// The unit eigenvector of the tridiagonal (diagonal `d`, off-diagonal `e`,
/// all nonzero) for its eigenvalue `theta`, by the twisted factorisation of
/// `T − θ` (Dhillon–Parlett): the top-down pivots
/// `p_k = d_k − θ − e²_{k−1} / p_{k−1}`, the bottom-up ones
/// `q_k = d_k − θ − e²_k / q_{k+1}`, the twist `r` minimising
/// `|γ_k| = |p_k + q_k − (d_k − θ)|`, and from `s_r = 1` outwards
/// `s_k = −e_k s_{k+1} / p_k` above and `s_k = −e_{k−1} s_{k−1} / q_k` below.
/// Each multiplier is a ratio of a stable factorisation, so the vector is
/// accurate wherever the eigenvector lives.
fn eigenvector(diag: &[f64], off: &[f64], theta: f64) -> Vec<f64> {
    let m = diag.len();
    let pivmin = f64::MIN_POSITIVE * off.iter().fold(1.0f64, |a, &e| a.max(e * e));
    let guard = |v: f64| if v.abs() < pivmin { -pivmin } else { v };
    let mut p = vec![0.0; m];
    let mut q = vec![0.0; m];
    for k in 0..m {
        let coupling = if k == 0 {
            0.0
        } else {
            off[k - 1] * off[k - 1] / p[k - 1]
        };
        p[k] = guard(diag[k] - theta - coupling);
    }
    for k in (0..m).rev() {
        let coupling = if k + 1 == m {
            0.0
        } else {
            off[k] * off[k] / q[k + 1]
        };
        q[k] = guard(diag[k] - theta - coupling);
    }
    let gamma = |k: usize| (p[k] + q[k] - (diag[k] - theta)).abs();
    let r = (0..m).fold(0, |best, k| if gamma(k) < gamma(best) { k } else { best });
    let mut s = vec![0.0; m];
    s[r] = 1.0;
    for k in (0..r).rev() {
        s[k] = -off[k] * s[k + 1] / p[k];
    }
    for k in r + 1..m {
        s[k] = -off[k - 1] * s[k - 1] / q[k];
    }
    let norm = dot(&s, &s).sqrt();
    s.iter_mut().for_each(|v| *v /= norm);
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A random-looking symmetric tridiagonal with a wide spread of entries.
    fn tridiagonal(m: usize) -> (Vec<f64>, Vec<f64>) {
        let v = start_vector(2 * m, 7);
        let diag = (0..m).map(|i| 10f64.powf(3.0 * v[i])).collect();
        let off = (0..m - 1).map(|i| 0.1 + v[m + i].abs()).collect();
        (diag, off)
    }

    #[test]
    fn extreme_eigenvectors_satisfy_the_eigen_equation() {
        for m in [1, 2, 5, 40, 120] {
            let (diag, off) = tridiagonal(m);
            let off2: Vec<f64> = off.iter().map(|e| e * e).collect();
            let norm = diag.iter().fold(0.0f64, |a, d| a.max(d.abs())) + 2.0;
            for k in [0, m - 1] {
                let theta = tridiagonal_eigenvalue(&diag, &off2, k);
                let s = eigenvector(&diag, &off, theta);
                assert!((dot(&s, &s) - 1.0).abs() < 1e-12);
                for i in 0..m {
                    let mut ts = diag[i] * s[i];
                    if i > 0 {
                        ts += off[i - 1] * s[i - 1];
                    }
                    if i + 1 < m {
                        ts += off[i] * s[i + 1];
                    }
                    assert!(
                        (ts - theta * s[i]).abs() < 1e-10 * norm,
                        "m {m} k {k} row {i}"
                    );
                }
            }
        }
    }

    #[test]
    fn lanczos_on_a_diagonal_operator_finds_both_ends() {
        let d: Vec<f64> = (0..60).map(|i| 1.0 + i as f64 * i as f64).collect();
        let mut lanczos = Lanczos::new(d.len(), 3);
        let op = |x: &[f64], y: &mut [f64]| {
            y.iter_mut()
                .zip(x)
                .zip(&d)
                .for_each(|((y, x), d)| *y = d * x)
        };
        let top = lanczos.run(op, End::Largest, 1e-10, 0.0, 60).unwrap();
        assert!(
            top.converged && (top.value - 3482.0).abs() < 1e-6,
            "{top:?}"
        );
        let bottom = lanczos.run(op, End::Smallest, 1e-10, 0.0, 60).unwrap();
        assert!(
            bottom.converged && (bottom.value - 1.0).abs() < 1e-8,
            "{bottom:?}"
        );
        let y = lanczos.ritz_vector(End::Smallest);
        assert!((y[0].abs() - 1.0).abs() < 1e-8, "{}", y[0]);
    }

    #[test]
    fn start_vectors_are_unit_and_seeded() {
        let a = start_vector(1000, 1);
        assert!((dot(&a, &a) - 1.0).abs() < 1e-14);
        assert!(a.iter().all(|&v| v != 0.0));
        assert_eq!(a, start_vector(1000, 1));
        assert_ne!(a, start_vector(1000, 2));
    }
}
