//! The Lanczos process, in its three uses, and the eigenvalues of its
//! tridiagonal:
//!
//! - CG's own: the cheap condition number estimate from the tridiagonal that
//!   a CG solve builds implicitly ([`lanczos_extreme_eigenvalues`], below);
//! - the three-term recurrence in a preconditioner's inner product for the
//!   largest eigenvalue of `B⁻¹A` ([`largest_eigenvalue`], the Chebyshev
//!   smoothers' bound);
//! - with full reorthogonalisation and Ritz vectors, for condition numbers
//!   ([`reorthogonalised`]).
//!
//! All three find the tridiagonal's eigenvalues by bisection on Sturm counts
//! ([`tridiagonal_eigenvalue`]).
//!
//! ## CG's tridiagonal
//!
//! CG with coefficients `α_0 … α_{m−1}`, `β_0 … β_{m−2}` is the Lanczos process
//! on `A` (on `M⁻¹A` when preconditioned) started from `r_0`; its tridiagonal is
//!
//! ```text
//! T_kk      = 1/α_k + β_{k−1}/α_{k−1}     (the second term absent for k = 0)
//! T_{k,k+1} = √β_k / α_k
//! ```
//!
//! The eigenvalues of `T` (Ritz values) lie inside the spectrum of `A` and their
//! extremes converge first, so `λ_max(T)/λ_min(T)` is a lower bound of `κ(A)`
//! that is sharp once CG has run long enough. They are found by bisection on
//! Sturm counts, `O(m)` per step, so long solves cost nothing noticeable.

pub mod reorthogonalised;

/// Bisection steps at most; about 55 are needed, since the bracket starts at
/// most `2‖T‖` wide and stops at `2ε‖T‖`.
const MAX_BISECTIONS: usize = 200;

/// `(λ_min, λ_max)` of the Lanczos tridiagonal built from CG's `alphas` and
/// `betas` (the first `alphas.len() − 1` of `betas` are used).
///
/// # Panics
/// If `alphas` is empty, `betas` is too short, or a coefficient is not finite.
pub fn lanczos_extreme_eigenvalues(alphas: &[f64], betas: &[f64]) -> (f64, f64) {
    let (diag, off2) = lanczos_tridiagonal(alphas, betas);
    let m = diag.len();
    (
        tridiagonal_eigenvalue(&diag, &off2, 0),
        tridiagonal_eigenvalue(&diag, &off2, m - 1),
    )
}

/// The diagonal and the squared off-diagonal of the Lanczos tridiagonal.
fn lanczos_tridiagonal(alphas: &[f64], betas: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let m = alphas.len();
    assert!(m > 0, "lanczos: no CG coefficients");
    assert!(
        betas.len() + 1 >= m,
        "lanczos: need {} betas, got {}",
        m - 1,
        betas.len()
    );
    assert!(
        alphas.iter().chain(&betas[..m - 1]).all(|v| v.is_finite()),
        "lanczos: non-finite CG coefficient"
    );
    let diag = (0..m)
        .map(|k| match k {
            0 => 1.0 / alphas[0],
            _ => 1.0 / alphas[k] + betas[k - 1] / alphas[k - 1],
        })
        .collect();
    let off2 = (0..m - 1)
        .map(|k| betas[k] / (alphas[k] * alphas[k]))
        .collect();
    (diag, off2)
}

/// Number of eigenvalues below `x` of the symmetric tridiagonal with diagonal
/// `diag` and squared off-diagonal `off2` (Sturm sequence / LDLᵀ inertia:
/// `q_0 = d_0 − x`, `q_k = d_k − x − e²_{k−1} / q_{k−1}`, count `q_k < 0`).
fn sturm_count(diag: &[f64], off2: &[f64], x: f64, pivmin: f64) -> usize {
    let mut count = 0;
    let mut q = 1.0;
    for (k, &d) in diag.iter().enumerate() {
        let coupling = if k == 0 { 0.0 } else { off2[k - 1] / q };
        q = d - x - coupling;
        if q.abs() < pivmin {
            q = -pivmin;
        }
        if q < 0.0 {
            count += 1;
        }
    }
    count
}

/// The `k`-th smallest eigenvalue (from 0) of the symmetric tridiagonal with
/// diagonal `diag` and squared off-diagonal `off2`, by bisection inside the Gershgorin
/// interval, to an absolute accuracy of about `ε ‖T‖` (so `λ_min` to a relative
/// accuracy of about `ε κ`).
pub fn tridiagonal_eigenvalue(diag: &[f64], off2: &[f64], k: usize) -> f64 {
    let m = diag.len();
    let off = |i: usize| off2.get(i).map_or(0.0, |e2| e2.sqrt());
    let radius = |i: usize| off(i) + if i == 0 { 0.0 } else { off(i - 1) };
    let mut lo = (0..m)
        .map(|i| diag[i] - radius(i))
        .fold(f64::INFINITY, f64::min);
    let mut hi = (0..m)
        .map(|i| diag[i] + radius(i))
        .fold(f64::NEG_INFINITY, f64::max);
    let scale = lo.abs().max(hi.abs()).max(f64::MIN_POSITIVE);
    let pivmin = f64::MIN_POSITIVE * off2.iter().fold(1.0f64, |a, &e2| a.max(e2));
    (lo, hi) = (lo - f64::EPSILON * scale, hi + f64::EPSILON * scale);
    for _ in 0..MAX_BISECTIONS {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi || hi - lo <= 2.0 * f64::EPSILON * scale {
            break;
        }
        if sturm_count(diag, off2, mid, pivmin) > k {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    0.5 * (lo + hi)
}

/// What the Lanczos process of [`largest_eigenvalue`] needs of `B⁻¹A`: the
/// operator, the preconditioner and the inner product over the whole
/// problem. On one rank of several each is that rank's share, collective,
/// and the vectors keep their ghost entries at zero.
pub struct PreconditionedOperator<'a> {
    /// `y = A x`.
    pub apply: &'a dyn Fn(&[f64], &mut [f64]),
    /// `z = B⁻¹ r`.
    pub pre: &'a dyn Fn(&[f64], &mut [f64]),
    /// The inner product `a · b`.
    pub dot: &'a dyn Fn(&[f64], &[f64]) -> f64,
}

/// The largest Ritz value of `steps` Lanczos steps on `B⁻¹A` in the `B`
/// inner product (`ops`) from the start vector `p` (every entry non-zero),
/// without reorthogonalisation (the extreme Ritz value converges first).
/// With the Lanczos vectors `q_k` and `p_k = B q_k`:
///
/// ```text
/// z = B⁻¹ v;  β = √(v·z);  q₀ = z/β;  p₀ = v/β;  β₀ = 0
/// w = A q_k − β_k p_{k−1};  α_k = w·q_k;  w = w − α_k p_k
/// z = B⁻¹ w;  β_{k+1} = √(w·z);  q_{k+1} = z/β_{k+1};  p_{k+1} = w/β_{k+1}
/// ```
/// and the top eigenvalue of the tridiagonal `(α, β)`
/// ([`tridiagonal_eigenvalue`]). Unlike [`reorthogonalised`], which keeps the
/// whole basis (full reorthogonalisation, Ritz vectors) for condition
/// numbers, the three-term recurrence holds a few vectors: what a smoother's
/// bound needs at every level of a multigrid hierarchy. `steps` is at most
/// the problem's size.
pub fn largest_eigenvalue(ops: &PreconditionedOperator, mut p: Vec<f64>, steps: usize) -> f64 {
    let n = p.len();
    let mut q = vec![0.0; n];
    (ops.pre)(&p, &mut q);
    let norm = (ops.dot)(&p, &q).sqrt();
    scale(&mut p, 1.0 / norm);
    scale(&mut q, 1.0 / norm);
    let (mut p_prev, mut w, mut z) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let (mut diag, mut off2) = (Vec::new(), Vec::new());
    let mut beta = 0.0;
    for _ in 0..steps {
        (ops.apply)(&q, &mut w);
        for i in 0..n {
            w[i] -= beta * p_prev[i];
        }
        let alpha = (ops.dot)(&w, &q);
        for i in 0..n {
            w[i] -= alpha * p[i];
        }
        diag.push(alpha);
        (ops.pre)(&w, &mut z);
        beta = (ops.dot)(&w, &z).max(0.0).sqrt();
        if beta.is_nan() || beta <= 1e-12 * alpha.abs() {
            break;
        }
        off2.push(beta * beta);
        std::mem::swap(&mut p_prev, &mut p);
        for i in 0..n {
            p[i] = w[i] / beta;
            q[i] = z[i] / beta;
        }
    }
    off2.truncate(diag.len() - 1);
    tridiagonal_eigenvalue(&diag, &off2, diag.len() - 1)
}

/// `v = s v`.
fn scale(v: &mut [f64], s: f64) {
    for x in v.iter_mut() {
        *x *= s;
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::DMatrix;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;

    /// Dense symmetric eigenvalues of the tridiagonal, sorted (the reference).
    fn dense_eigenvalues(diag: &[f64], off2: &[f64]) -> Vec<f64> {
        let m = diag.len();
        let t = DMatrix::from_fn(m, m, |i, j| match i.abs_diff(j) {
            0 => diag[i],
            1 => off2[i.min(j)].sqrt(),
            _ => 0.0,
        });
        let mut ev: Vec<f64> = t.symmetric_eigen().eigenvalues.iter().copied().collect();
        ev.sort_by(f64::total_cmp);
        ev
    }

    #[test]
    fn bisection_matches_dense_symmetric_eigen() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for m in [1, 2, 5, 40] {
            let alphas: Vec<f64> = (0..m).map(|_| rng.gen_range(0.05..2.0)).collect();
            let betas: Vec<f64> = (0..m).map(|_| rng.gen_range(0.01..0.9)).collect();
            let (diag, off2) = lanczos_tridiagonal(&alphas, &betas);
            let dense = dense_eigenvalues(&diag, &off2);
            let (lo, hi) = lanczos_extreme_eigenvalues(&alphas, &betas);
            let tol = 1e-12 * dense[m - 1].abs();
            assert!(
                (lo - dense[0]).abs() <= tol,
                "m {m}: λmin {lo} vs {}",
                dense[0]
            );
            assert!(
                (hi - dense[m - 1]).abs() <= tol,
                "m {m}: λmax {hi} vs {}",
                dense[m - 1]
            );
            for (k, &want) in dense.iter().enumerate() {
                let got = tridiagonal_eigenvalue(&diag, &off2, k);
                assert!((got - want).abs() <= tol, "m {m}: λ_{k} {got} vs {want}");
            }
        }
    }

    #[test]
    fn tridiagonal_entries_follow_the_cg_formulas() {
        let (diag, off2) = lanczos_tridiagonal(&[0.5, 0.25], &[0.16]);
        assert_eq!(diag, vec![2.0, 4.0 + 0.16 / 0.5]);
        assert!((off2[0] - 0.16 / 0.25).abs() < 1e-15);
    }

    #[test]
    #[should_panic(expected = "no CG coefficients")]
    fn empty_coefficients_panic() {
        lanczos_extreme_eigenvalues(&[], &[]);
    }
}
