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
//! system `[[I ⊗ AᵀA, Cᵀ], [C, 0]] [b; λ] = [Aᵀ B; d]`, solved through its
//! Schur complement `C (I ⊗ (AᵀA)⁻¹) Cᵀ` in the equilibrated unknowns (each
//! constraint row normalised to unit length). It is regular when `C` has full
//! row rank and `AᵀA` is positive definite (which the acceptance check
//! ensures).
//!
//! Both systems are solved with [`REFINEMENT_STEPS`] steps of iterative
//! refinement on the residual computed from the samples,
//! `Aᵀ(B − A b) − Cᵀλ` and `d − C b`, rather than from `AᵀA`: this brings the
//! error of the normal equations, `~cond(A)²·ε`, down to that of a QR solve,
//! `~cond(A)·ε`, so that degree-p data are reproduced to round-off. (A
//! plan's later fits solve once from the moments where that is as accurate,
//! [`FitFactor::solves_from_moments`].)
//!
//! *Acceptance, decided.* `λ ≥ τ^p` is decided by a Cholesky factorisation
//! of the whitened normal matrix less `τ^p I`, which exists exactly when its
//! smallest eigenvalue exceeds `τ^p`; the eigenvalue itself is computed only
//! for a rejected fit's message.

use std::fmt;

use nalgebra::{DMatrix, DMatrixView, DMatrixViewMut, DVector, SymmetricEigen};

use super::kkt::{design_matrix, values_matrix, Design, Kkt};
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

/// The largest condition number of the equilibrated normal matrix `M̃` of a
/// fit solved from its moments, without refinement, and the largest basis
/// (degree 2) solved so. On the sphere at levels 4 and 5 Q1's stress fits
/// are below 1e2, its displacement fits and Q2's stress fits below 1e3, and
/// Q2's displacement fits (degree 3) mostly between 1e3 and 1e5. With every
/// fit from moments the patch tests with rollers and Q2 on parts with edges
/// stall near 1e-12 short of their 1e-14 fixed-point tolerance; with the
/// condition limit they converge, but degree-3 fits below it still miss a
/// quadratic field by 2.5e-10 on a Q2 sphere's Ω* (refined: below 1e-11).
const MOMENTS_CONDITION: f64 = 1e3;
const MOMENTS_MAX_TERMS: usize = 10;

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
    fit_and_factor(basis, samples, constraints, opts).map(|(a, _)| a)
}

/// [`fit_polynomial`], and the fit's [`FitFactor`] for values at the same
/// points.
pub fn fit_and_factor<const NC: usize>(
    basis: &Monomials,
    samples: &[Sample<NC>],
    constraints: Option<&LinearConstraints>,
    opts: &FitOptions,
) -> Result<(Vec<f64>, FitFactor), FitFailure> {
    check_count(basis, samples.len(), opts)?;
    let centroid = centroid(samples.iter().map(|(x, _)| *x), samples.len());
    let design = Design {
        a: design_matrix(basis, centroid, samples.iter().map(|(x, _)| *x)),
        b: values_matrix(samples),
    };
    let normal = design.a.tr_mul(&design.a);
    let factor = FitFactor::prepare(
        basis,
        centroid,
        normal,
        samples.len(),
        NC,
        constraints,
        opts,
    )?;
    let a = factor.solve(design)?;
    Ok((a, factor))
}

/// The [`FitFactor`] of a fit of `nc` components at the scaled `points`,
/// without a fit: what a plan keeps ([`super::plan`]). Its normal matrix
/// comes from one pass over the points, without the design matrix.
pub fn plan_factor(
    basis: &Monomials,
    points: &[[f64; 3]],
    nc: usize,
    constraints: Option<&LinearConstraints>,
    opts: &FitOptions,
) -> Result<FitFactor, FitFailure> {
    check_count(basis, points.len(), opts)?;
    let centroid = centroid(points.iter().copied(), points.len());
    let normal = normal_matrix(basis, centroid, points.iter().copied());
    FitFactor::prepare(basis, centroid, normal, points.len(), nc, constraints, opts)
}

/// [`FitFailure::TooFewPoints`] when `n` points cannot fit `basis`.
fn check_count(basis: &Monomials, n: usize, opts: &FitOptions) -> Result<(), FitFailure> {
    let need = (opts.min_sample_ratio * basis.len() as f64).ceil() as usize;
    match n < need {
        true => Err(FitFailure::TooFewPoints { have: n, need }),
        false => Ok(()),
    }
}

/// `AᵀA` of the sample points in the centred coordinates `ζ = ξ − ξ̄`,
/// each point's basis values evaluated once and the symmetric half summed.
fn normal_matrix(
    basis: &Monomials,
    centroid: [f64; 3],
    points: impl Iterator<Item = [f64; 3]>,
) -> DMatrix<f64> {
    let nb = basis.len();
    let mut upper = vec![0.0; nb * nb];
    let mut phi = [0.0; MAX_TERMS];
    let phi = &mut phi[..nb];
    for x in points {
        basis.values([0, 1, 2].map(|k| x[k] - centroid[k]), phi);
        for (i, &pi) in phi.iter().enumerate() {
            let row = &mut upper[i * nb..(i + 1) * nb];
            for (r, &pj) in row[i..].iter_mut().zip(&phi[i..]) {
                *r += pi * pj;
            }
        }
    }
    DMatrix::from_fn(nb, nb, |i, j| upper[i.min(j) * nb + i.max(j)])
}

/// The largest basis [`normal_matrix`] takes (degree 3).
const MAX_TERMS: usize = 20;

/// The half of a patch fit that depends on the sample points and the
/// constraints only, never on the values: the points' centroid, the shift
/// back to the node's basis and the factored (KKT) system. A fixed-point loop
/// recovers a new field on the same patches at every iteration; with the
/// factor it skips the acceptance check and the factorisation and solves
/// from the moments of the values ([`FitFactor::fit_moments`]).
#[derive(Clone)]
pub struct FitFactor {
    /// The condition number of the equilibrated normal matrix.
    pub(super) condition: f64,
    centroid: [f64; 3],
    shift: DMatrix<f64>,
    kkt: Kkt,
}

impl FitFactor {
    /// Checks and factors the fit of `nc` components with the normal matrix
    /// `normal = AᵀA` of `n` samples in the coordinates centred at
    /// `centroid`.
    fn prepare(
        basis: &Monomials,
        centroid: [f64; 3],
        normal: DMatrix<f64>,
        n: usize,
        nc: usize,
        constraints: Option<&LinearConstraints>,
        opts: &FitOptions,
    ) -> Result<FitFactor, FitFailure> {
        let nb = basis.len();
        if let Some(k) = constraints {
            check_shape(k, nc * nb)?;
        }
        let shift = basis.translation(centroid);
        let min = opts.stability.powi(basis.degree().max(1) as i32);
        let gram = shift.transpose() * basis.box_gram() * &shift;
        stable(&normal, n, &gram, min)?;
        let mut m = normal;
        let s = equilibrate(&mut m);
        let eigenvalues = m.symmetric_eigenvalues();
        let condition = eigenvalues.max() / eigenvalues.min();
        let constraints = constraints.map(|k| LinearConstraints {
            c: shifted_constraints(&k.c, &shift),
            d: k.d.clone(),
        });
        let kkt = Kkt::new(&m, &s, nc, constraints.as_ref())?;
        Ok(FitFactor {
            condition,
            centroid,
            shift,
            kkt,
        })
    }

    /// The centroid `ξ̄` of the sample points, the origin of the centred
    /// coordinates `ζ = ξ − ξ̄` the factor solves in.
    pub(super) fn centroid(&self) -> [f64; 3] {
        self.centroid
    }

    /// The fit of `samples` at the points this factor was made for (same
    /// points, same order; `NC` its number of components): what
    /// [`fit_polynomial`] returns, bit for bit.
    ///
    /// # Panics
    /// When the number of components differs from the factor's.
    pub(super) fn fit<const NC: usize>(
        &self,
        basis: &Monomials,
        samples: &[Sample<NC>],
    ) -> Result<Vec<f64>, FitFailure> {
        assert_eq!(
            NC * basis.len(),
            self.kkt.c.ncols(),
            "components of a fit factor"
        );
        let design = Design {
            a: design_matrix(basis, self.centroid, samples.iter().map(|(x, _)| *x)),
            b: values_matrix(samples),
        };
        self.solve(design)
    }

    /// Whether a solve from the moments ([`FitFactor::fit_moments`]) is as
    /// accurate as the refined one: the normal equations lose
    /// `cond(M̃)·ε` of the coefficients, so a fit whose equilibrated normal
    /// matrix has a condition number above [`MOMENTS_CONDITION`], or whose
    /// basis is larger than [`MOMENTS_MAX_TERMS`], is refined on its samples
    /// ([`FitFactor::fit`]).
    pub(super) fn solves_from_moments(&self) -> bool {
        self.condition <= MOMENTS_CONDITION && self.shift.nrows() <= MOMENTS_MAX_TERMS
    }

    /// The fit from the moments of its values in the centred coordinates,
    /// `atb[j·nc + c] = Σ_s φ_j(ζ_s) v_{s,c}` (`Aᵀ B`), for values at the
    /// points this factor was made for: one solve of the factored system,
    /// without the refinement of [`fit_polynomial`] (which needs every
    /// sample) and without its check of the constrained residual (the
    /// factor passed it when it was made).
    ///
    /// # Panics
    /// When `nc` is not the factor's number of components.
    pub(super) fn fit_moments(&self, atb: &[f64], nc: usize) -> Result<Vec<f64>, FitFailure> {
        let mut a = vec![0.0; nc * self.shift.nrows()];
        self.fit_moments_into(atb, nc, &mut a, &mut Vec::new())?;
        Ok(a)
    }

    /// [`FitFactor::fit_moments`] into `out` (`nc · n_b` coefficients), with
    /// `scratch` (any length; resized) as its work space. An unconstrained
    /// fit solves the components as the columns of one `n_b × nc`
    /// right-hand side in place, and allocates nothing once `scratch` has
    /// grown to `2 · nc · n_b`.
    ///
    /// # Panics
    /// When `nc` is not the factor's number of components.
    pub(super) fn fit_moments_into(
        &self,
        atb: &[f64],
        nc: usize,
        out: &mut [f64],
        scratch: &mut Vec<f64>,
    ) -> Result<(), FitFailure> {
        let nb = self.shift.nrows();
        assert_eq!(nc * nb, self.kkt.c.ncols(), "components of a fit factor");
        scratch.resize(2 * nb * nc, 0.0);
        let (y, centred) = scratch.split_at_mut(nb * nc);
        if self.kkt.c.nrows() > 0 {
            let x = self.kkt.solve(&self.kkt.rhs_from_moments(atb, nc));
            return self.in_node_basis(x.as_slice(), nc, out, centred);
        }
        let s = &self.kkt.s;
        for (c, column) in y.chunks_exact_mut(nb).enumerate() {
            for (j, v) in column.iter_mut().enumerate() {
                *v = s[j] * atb[j * nc + c];
            }
        }
        self.kkt
            .solve_normal_in_place(&mut DMatrixViewMut::from_slice(y, nb, nc));
        self.in_node_basis(y, nc, out, centred)
    }

    /// The constrained least-squares solve with iterative refinement, mapped
    /// back to the node's basis.
    fn solve(&self, design: Design) -> Result<Vec<f64>, FitFailure> {
        let kkt = &self.kkt;
        let nc = design.b.ncols();
        let first = kkt.residual_at_zero(&design);
        let rhs = first.amax();
        let mut x = kkt.solve(&first);
        for _ in 0..REFINEMENT_STEPS {
            let res = kkt.residual(&design, &x);
            x += kkt.solve(&res);
        }
        // A near-singular KKT matrix (dependent or inconsistent rows) shows up
        // as a residual far above round-off (the normal matrix alone is
        // checked by `stable` in `prepare`).
        if kkt.c.nrows() > 0 {
            let res = kkt.residual(&design, &x).amax();
            if res.is_nan() || res > 1e-9 * (1.0 + rhs) {
                return Err(FitFailure::Singular);
            }
        }
        let mut a = vec![0.0; nc * self.shift.nrows()];
        let mut centred = vec![0.0; a.len()];
        self.in_node_basis(x.as_slice(), nc, &mut a, &mut centred)?;
        Ok(a)
    }

    /// The node-basis coefficients `a = T S x` of the solution `x` of the
    /// equilibrated system (component `c`, term `j` at `c·n_b + j`, in `x`
    /// and in `out`).
    fn in_node_basis(
        &self,
        x: &[f64],
        nc: usize,
        out: &mut [f64],
        centred: &mut [f64],
    ) -> Result<(), FitFailure> {
        let nb = self.shift.nrows();
        for (column, xc) in centred.chunks_exact_mut(nb).zip(x.chunks_exact(nb)) {
            for ((v, xj), sj) in column.iter_mut().zip(xc).zip(&self.kkt.s) {
                *v = sj * xj;
            }
        }
        let centred = DMatrixView::from_slice(centred, nb, nc);
        let mut a = DMatrixViewMut::from_slice(out, nb, nc);
        a.gemm(1.0, &self.shift, &centred, 0.0);
        if out.iter().any(|v| !v.is_finite()) {
            return Err(FitFailure::NonFinite);
        }
        Ok(())
    }
}

/// The centroid `ξ̄` of the `n` sample points.
fn centroid(points: impl Iterator<Item = [f64; 3]>, n: usize) -> [f64; 3] {
    let mut c = [0.0; 3];
    for x in points {
        for k in 0..3 {
            c[k] += x[k] / n as f64;
        }
    }
    c
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

/// Whether the cloud of `n` samples with normal matrix `M` controls the
/// polynomial on the box: `λ = λ_min(L⁻¹ (M/n) L⁻ᵀ) ≥ min`, with the Gram
/// matrix `G = L Lᵀ` of the box in the same basis. Decided by a Cholesky
/// factorisation of `L⁻¹ (M/n) L⁻ᵀ − min I` (it exists exactly when every
/// eigenvalue exceeds `min`); `λ` itself is computed only for the error.
fn stable(m: &DMatrix<f64>, n: usize, gram: &DMatrix<f64>, min: f64) -> Result<(), FitFailure> {
    let l = gram
        .clone()
        .cholesky()
        .expect("a Gram matrix of independent monomials is positive definite")
        .l();
    let scaled = m / n as f64;
    let whitened = l.solve_lower_triangular(&scaled).and_then(|half| {
        let w = l.solve_lower_triangular(&half.transpose())?;
        Some((&w + w.transpose()) * 0.5)
    });
    let Some(w) = whitened else {
        return Err(FitFailure::Unstable { lambda: 0.0, min });
    };
    let shifted = &w - DMatrix::identity(w.nrows(), w.ncols()) * min;
    if shifted.cholesky().is_some() {
        return Ok(());
    }
    let lambda = SymmetricEigen::new(w).eigenvalues.min();
    Err(FitFailure::Unstable { lambda, min })
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
