//! The least-squares fit of one patch: a complete polynomial per field
//! component to sample values, optionally under linear equality constraints on
//! the stacked coefficients (a small dense KKT system).
//!
//! # The maths
//! Samples come at scaled points `ξ_s = (x_s − x_node)/h`, so that the node's 8
//! cells, where CPE uses the patch polynomial, are the box `B = [−1, 1]³`; the
//! coefficients are returned in that basis.
//!
//! *Acceptance.* A fit needs [`FitOptions::min_sample_ratio`] points per
//! coefficient, and a cloud that controls every polynomial of degree `p` on
//! `B`: with `λ = min_P mean_s P(ξ_s)² / mean_B P²` (the smallest eigenvalue of
//! the normal matrix `AᵀA/n` whitened by the Gram matrix `G` of the basis under
//! the uniform probability on `B`), a sample error of RMS `ε` moves the fit by
//! at most `ε/√λ` in RMS over `B`. The fit is accepted when
//! `λ ≥ τ^p` (`τ` = [`FitOptions::stability`]): an amplification of at most
//! `τ^{−p/2}`, the per-degree form because one-sided extrapolation costs a
//! factor per degree. A rejected fit ([`FitFailure`]) makes the caller enlarge
//! the patch.
//!
//! *Solve.* The fit runs about the samples' centroid, in `ζ = ξ − ξ̄`, and maps
//! back exactly with [`Monomials::translation`], `a = T b`, so that one-sided
//! patches are solved as accurately as centred ones. With `A_{sj} = φ_j(ζ_s)`
//! and the values `B_{sc}` of component `c`, the unconstrained fit solves the
//! normal equations `AᵀA b_c = Aᵀ B_c` (one matrix for all components),
//! equilibrated as `M̃ = S AᵀA S` with `S = diag(1/√(AᵀA)_jj)`, `b = S b̃`.
//!
//! *Constraints* `C a = d` act on the stacked vector `a = (a_0, …, a_{NC−1})`
//! (component `c`'s coefficients at `c·n_b .. (c+1)·n_b`), i.e.
//! `C (I ⊗ T) b = d` on the centred ones. The constrained minimum of
//! `½ Σ_c ‖A b_c − B_c‖²` is the stationary point of the Lagrangian, the KKT
//! system `[[I ⊗ AᵀA, Cᵀ], [C, 0]] [b; λ] = [Aᵀ B; d]`, solved by LU with
//! partial pivoting in the equilibrated unknowns (each constraint row
//! normalised to unit length). It is regular when `C` has full row rank and
//! `AᵀA` is positive definite (which the acceptance check ensures).
//!
//! Both systems are solved with [`REFINEMENT_STEPS`] steps of iterative
//! refinement on the residual computed from the samples,
//! `Aᵀ(B − A b) − Cᵀλ` and `d − C b`, rather than from `AᵀA`: this brings the
//! error of the normal equations, `~cond(A)²·ε`, down to that of a QR solve,
//! `~cond(A)·ε`, so that degree-p data are reproduced to round-off.

use std::fmt;

use nalgebra::{Cholesky, DMatrix, DVector, Dyn, SymmetricEigen, LU};

use super::{Monomials, Sample};

/// Linear equality constraints `C a = d` on the stacked coefficients of all
/// components: `c` has `NC · n_b` columns and one row per constraint, `d` one
/// entry per constraint. Rows must be linearly independent.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearConstraints {
    pub c: DMatrix<f64>,
    pub d: DVector<f64>,
}

/// Acceptance thresholds of a patch fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitOptions {
    /// Least number of sample points per coefficient of one component.
    pub min_sample_ratio: f64,
    /// `τ`: a fit of degree `p` needs `λ ≥ τ^p` (see the module doc).
    pub stability: f64,
}

impl Default for FitOptions {
    /// 1.5 points per coefficient and `τ = 10⁻³`: sample errors amplified at
    /// most `10^{1.5 p}` times in RMS on the node's cells, which rejects only
    /// the degenerate tail of small or thin cut-cell clouds (`λ` reaches 1e-10
    /// there, while a full ring-1 patch of `(p+1)³` Gauss points per cell has
    /// `λ` = 0.99, 0.95, 0.76 for p = 1, 2, 3). On a sphere at levels 3–5 it
    /// enlarges 11–16 % of the cut-cell vertex patches, all to ring 2; larger
    /// `τ` enlarges more and, on smooth data, only loses accuracy (measured:
    /// `τ = 10⁻²` enlarges ~40 % and raises the boundary error of p = 3 by 3×).
    fn default() -> Self {
        FitOptions {
            min_sample_ratio: 1.5,
            stability: 1e-3,
        }
    }
}

/// Why a patch fit was rejected.
#[derive(Clone, Debug, PartialEq)]
pub enum FitFailure {
    TooFewPoints {
        have: usize,
        need: usize,
    },
    /// `λ < τ^p` (see the module doc).
    Unstable {
        lambda: f64,
        min: f64,
    },
    BadConstraints {
        reason: String,
    },
    /// The normal or KKT matrix is singular to working precision.
    Singular,
    NonFinite,
}

impl fmt::Display for FitFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FitFailure::TooFewPoints { have, need } => {
                write!(f, "{have} sample points, need at least {need}")
            }
            FitFailure::Unstable { lambda, min } => write!(
                f,
                "sample cloud too thin for the degree (stability {lambda:.2e} < {min:.2e})"
            ),
            FitFailure::BadConstraints { reason } => write!(f, "bad constraints: {reason}"),
            FitFailure::Singular => write!(f, "singular system (dependent constraints?)"),
            FitFailure::NonFinite => write!(f, "non-finite coefficients (non-finite samples?)"),
        }
    }
}

/// Steps of iterative refinement after the first solve.
const REFINEMENT_STEPS: usize = 2;

/// Fits a complete polynomial of `basis` to each of the `NC` components of the
/// `samples` (scaled point `ξ_s`, values `B_s`), under `constraints` if given.
/// Returns the stacked coefficients (component `c`, term `j` at
/// `c · basis.len() + j`).
pub fn fit_polynomial<const NC: usize>(
    basis: &Monomials,
    samples: &[Sample<NC>],
    constraints: Option<&LinearConstraints>,
    opts: &FitOptions,
) -> Result<Vec<f64>, FitFailure> {
    let nb = basis.len();
    let need = (opts.min_sample_ratio * nb as f64).ceil() as usize;
    if samples.len() < need {
        return Err(FitFailure::TooFewPoints {
            have: samples.len(),
            need,
        });
    }
    if let Some(k) = constraints {
        check_shape(k, NC * nb)?;
    }
    let (centroid, samples) = centered(samples);
    let samples = &samples[..];
    let shift = basis.translation(centroid);
    let design = Design::new(basis, samples);
    let mut m = design.normal_matrix();
    let lambda = stability(
        &m,
        samples.len(),
        &(shift.transpose() * box_gram(basis) * &shift),
    );
    let min = opts.stability.powi(basis.degree().max(1) as i32);
    if lambda.is_nan() || lambda < min {
        return Err(FitFailure::Unstable { lambda, min });
    }
    let s = equilibrate(&mut m);
    let constraints = constraints.map(|k| LinearConstraints {
        c: shifted_constraints(&k.c, &shift),
        d: k.d.clone(),
    });
    let kkt = Kkt::new(&m, &s, NC, constraints.as_ref())?;
    let first = kkt.residual_at_zero(&design);
    let rhs = first.amax();
    let mut x = kkt.solve(&first).ok_or(FitFailure::Singular)?;
    for _ in 0..REFINEMENT_STEPS {
        let res = kkt.residual(&design, &x);
        x += kkt.solve(&res).ok_or(FitFailure::Singular)?;
    }
    // A near-singular KKT matrix (dependent or inconsistent rows) shows up as a
    // residual far above round-off (the normal matrix alone is checked by
    // `stability` above).
    if kkt.c.nrows() > 0 {
        let res = kkt.residual(&design, &x).amax();
        if res.is_nan() || res > 1e-9 * (1.0 + rhs) {
            return Err(FitFailure::Singular);
        }
    }
    let centred = DMatrix::from_fn(nb, NC, |j, c| s[j] * x[c * nb + j]);
    let a = (shift * centred).as_slice().to_vec();
    if a.iter().any(|v| !v.is_finite()) {
        return Err(FitFailure::NonFinite);
    }
    Ok(a)
}

/// The centroid `ξ̄` of the sample points and the samples at `ξ − ξ̄`.
fn centered<const NC: usize>(samples: &[Sample<NC>]) -> ([f64; 3], Vec<Sample<NC>>) {
    let mut c = [0.0; 3];
    for (x, _) in samples {
        for k in 0..3 {
            c[k] += x[k] / samples.len() as f64;
        }
    }
    let shifted = samples
        .iter()
        .map(|(x, v)| ([0, 1, 2].map(|k| x[k] - c[k]), *v))
        .collect();
    (c, shifted)
}

/// `C (I ⊗ T)`: constraints on the stacked coefficients in `ξ − ξ̄` from those
/// in `ξ` (a column block of `C` per component).
fn shifted_constraints(c: &DMatrix<f64>, t: &DMatrix<f64>) -> DMatrix<f64> {
    let nb = t.nrows();
    let mut out = c.clone();
    for k in 0..c.ncols() / nb {
        let block = c.columns(k * nb, nb) * t;
        out.columns_mut(k * nb, nb).copy_from(&block);
    }
    out
}

/// The samples of one fit as dense matrices: the design matrix
/// `A_{sj} = φ_j(ζ_s)` (`n_s × n_b`) and the values `B_{sc}` (`n_s × NC`),
/// evaluated once per fit and read by the normal matrix and every refinement
/// residual. Column-major, so that `AᵀA`, `Aᵀ R` and `A X` are products of
/// contiguous columns.
struct Design {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
}

impl Design {
    fn new<const NC: usize>(basis: &Monomials, samples: &[Sample<NC>]) -> Design {
        let nb = basis.len();
        let mut a = DMatrix::zeros(samples.len(), nb);
        let mut row = vec![0.0; nb];
        for (s, (x, _)) in samples.iter().enumerate() {
            basis.values(*x, &mut row);
            for (j, &v) in row.iter().enumerate() {
                a[(s, j)] = v;
            }
        }
        let b = DMatrix::from_fn(samples.len(), NC, |s, c| samples[s].1[c]);
        Design { a, b }
    }

    /// `AᵀA` (`n_b × n_b`).
    fn normal_matrix(&self) -> DMatrix<f64> {
        self.a.tr_mul(&self.a)
    }
}

/// Scales `m ← S m S` with `S = diag(1/√m_jj)` (0 for a zero column); returns
/// `S`'s diagonal.
fn equilibrate(m: &mut DMatrix<f64>) -> Vec<f64> {
    let nb = m.nrows();
    let s: Vec<f64> = (0..nb)
        .map(|j| {
            let d = m[(j, j)];
            if d > 0.0 {
                1.0 / d.sqrt()
            } else {
                0.0
            }
        })
        .collect();
    for a in 0..nb {
        for b in 0..nb {
            m[(a, b)] *= s[a] * s[b];
        }
    }
    s
}

/// `λ = λ_min(L⁻¹ (M/n) L⁻ᵀ)` for the normal matrix `M` of `n` samples and the
/// Gram matrix `G = L Lᵀ` of the box, both in the same basis (≤ 0 when the
/// cloud does not determine the polynomial).
fn stability(m: &DMatrix<f64>, n: usize, gram: &DMatrix<f64>) -> f64 {
    let l = gram
        .clone()
        .cholesky()
        .expect("a Gram matrix of independent monomials is positive definite")
        .l();
    let scaled = m / n as f64;
    let Some(half) = l.solve_lower_triangular(&scaled) else {
        return 0.0;
    };
    let Some(w) = l.solve_lower_triangular(&half.transpose()) else {
        return 0.0;
    };
    SymmetricEigen::new((&w + w.transpose()) * 0.5)
        .eigenvalues
        .min()
}

/// `G_ef = ∫ φ_e φ_f dμ` for the uniform probability `μ` on `[−1, 1]³`: per
/// axis the moment of `t^k` is `1/(k+1)` for even `k`, 0 for odd `k`.
fn box_gram(basis: &Monomials) -> DMatrix<f64> {
    let e = basis.exponents();
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

/// The factored (KKT) system of one fit in the equilibrated unknowns
/// `x = [ã; λ]`, `ã = S⁻¹ a` stacked over components.
struct Kkt {
    s: Vec<f64>,
    /// Constraints in the equilibrated unknowns, rows normalised: `C (I ⊗ S)`.
    c: DMatrix<f64>,
    d: DVector<f64>,
    factor: Factor,
}

enum Factor {
    /// No constraints: `M̃`, shared by the components.
    Normal(Cholesky<f64, Dyn>),
    /// `[[I ⊗ M̃, C̃ᵀ], [C̃, 0]]`.
    Full(LU<f64, Dyn, Dyn>),
}

impl Kkt {
    fn new(
        m: &DMatrix<f64>,
        s: &[f64],
        nc: usize,
        constraints: Option<&LinearConstraints>,
    ) -> Result<Kkt, FitFailure> {
        let nb = m.nrows();
        let n = nb * nc;
        let (c, d) = match constraints {
            None => (DMatrix::zeros(0, n), DVector::zeros(0)),
            Some(k) => scaled_constraints(k, s, n)?,
        };
        let factor = if c.nrows() == 0 {
            let chol = m.clone().cholesky().ok_or(FitFailure::Singular)?;
            Factor::Normal(chol)
        } else {
            let rows = c.nrows();
            let mut kkt = DMatrix::zeros(n + rows, n + rows);
            for k in 0..nc {
                kkt.view_mut((k * nb, k * nb), (nb, nb)).copy_from(m);
            }
            kkt.view_mut((n, 0), (rows, n)).copy_from(&c);
            kkt.view_mut((0, n), (n, rows)).copy_from(&c.transpose());
            Factor::Full(kkt.lu())
        };
        Ok(Kkt {
            s: s.to_vec(),
            c,
            d,
            factor,
        })
    }

    /// Unknowns: `NC · n_b` coefficients and one multiplier per constraint.
    fn size(&self) -> usize {
        self.c.ncols() + self.c.nrows()
    }

    /// `[S Aᵀ(B − A S ã) − C̃ᵀλ; d̃ − C̃ ã]` at `x = [ã; λ]`: the
    /// residual from the samples, not from `AᵀA`.
    fn residual(&self, design: &Design, x: &DVector<f64>) -> DVector<f64> {
        let nb = self.s.len();
        let nc = design.b.ncols();
        let n = nb * nc;
        let coeffs = DMatrix::from_fn(nb, nc, |j, c| self.s[j] * x[c * nb + j]);
        let mut r = design.b.clone();
        r.gemm(-1.0, &design.a, &coeffs, 1.0);
        let lambda = x.rows(n, self.c.nrows());
        let mut res = self.scaled_top(design, &r);
        let top = self.c.tr_mul(&lambda);
        for i in 0..n {
            res[i] -= top[i];
        }
        let bottom = &self.d - &self.c * x.rows(0, n);
        res.rows_mut(n, self.c.nrows()).copy_from(&bottom);
        res
    }

    /// [`Kkt::residual`] at `x = 0`: `[S Aᵀ B; d̃]`.
    fn residual_at_zero(&self, design: &Design) -> DVector<f64> {
        let n = self.c.ncols();
        let mut res = self.scaled_top(design, &design.b);
        res.rows_mut(n, self.c.nrows()).copy_from(&self.d);
        res
    }

    /// `S Aᵀ R` stacked by component (`R`: `n_s × NC`), in a vector of
    /// [`Kkt::size`] whose multiplier rows are zero.
    fn scaled_top(&self, design: &Design, r: &DMatrix<f64>) -> DVector<f64> {
        let nb = self.s.len();
        let atr = design.a.tr_mul(r);
        let mut res = DVector::zeros(self.size());
        for (i, v) in atr.iter().enumerate() {
            res[i] = self.s[i % nb] * v;
        }
        res
    }

    /// The correction `K⁻¹ r`.
    fn solve(&self, r: &DVector<f64>) -> Option<DVector<f64>> {
        match &self.factor {
            Factor::Normal(chol) => {
                let nb = chol.l_dirty().nrows();
                // Stacked components are the columns of an `n_b × NC` matrix.
                let rhs = DMatrix::from_column_slice(nb, r.len() / nb, r.as_slice());
                let x = chol.solve(&rhs);
                Some(DVector::from_column_slice(x.as_slice()))
            }
            Factor::Full(lu) => lu.solve(r),
        }
    }
}

/// Checks that `k` has `n` columns and one right-hand side per row.
fn check_shape(k: &LinearConstraints, n: usize) -> Result<(), FitFailure> {
    let rows = k.c.nrows();
    if k.c.ncols() == n && k.d.len() == rows {
        return Ok(());
    }
    Err(FitFailure::BadConstraints {
        reason: format!(
            "C is {rows}×{} and d has {} entries, expected {rows}×{n} and {rows}",
            k.c.ncols(),
            k.d.len()
        ),
    })
}

/// `C (I ⊗ S)` and `d` with each row scaled to unit length.
fn scaled_constraints(
    k: &LinearConstraints,
    s: &[f64],
    n: usize,
) -> Result<(DMatrix<f64>, DVector<f64>), FitFailure> {
    let rows = k.c.nrows();
    let nb = s.len();
    let mut c = DMatrix::from_fn(rows, n, |i, j| k.c[(i, j)] * s[j % nb]);
    let mut d = k.d.clone();
    for i in 0..rows {
        let norm = c.row(i).norm();
        if norm.is_nan() || norm <= 0.0 {
            return Err(FitFailure::BadConstraints {
                reason: format!("constraint row {i} is zero on the patch's basis"),
            });
        }
        c.row_mut(i).scale_mut(1.0 / norm);
        d[i] /= norm;
    }
    Ok((c, d))
}
