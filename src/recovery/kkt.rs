//! The least-squares system of one patch fit ([`super::fit`]): the samples as
//! dense matrices ([`Design`]) and the factored KKT system ([`Kkt`]) with its
//! residual on the samples, which the iterative refinement reads.

use nalgebra::{Cholesky, DMatrix, DMatrixViewMut, DVector, Dyn};

use super::fit::{FitFailure, LinearConstraints};
use super::{Monomials, Sample};

/// The samples of one fit as dense matrices: the design matrix
/// `A_{sj} = φ_j(ζ_s)` (`n_s × n_b`) and the values `B_{sc}` (`n_s × NC`),
/// evaluated once per fit and read by the normal matrix and every refinement
/// residual. Column-major, so that `AᵀA`, `Aᵀ R` and `A X` are products of
/// contiguous columns.
pub(super) struct Design {
    pub(super) a: DMatrix<f64>,
    pub(super) b: DMatrix<f64>,
}

/// The design matrix `A_{sj} = φ_j(ζ_s)` at the points `ζ = ξ − ξ̄` about
/// `centroid` (column-major, `n_s × n_b`).
pub(super) fn design_matrix(
    basis: &Monomials,
    centroid: [f64; 3],
    points: impl ExactSizeIterator<Item = [f64; 3]>,
) -> DMatrix<f64> {
    let nb = basis.len();
    let mut a = DMatrix::zeros(points.len(), nb);
    let mut row = vec![0.0; nb];
    for (s, x) in points.enumerate() {
        basis.values([0, 1, 2].map(|k| x[k] - centroid[k]), &mut row);
        for (j, &v) in row.iter().enumerate() {
            a[(s, j)] = v;
        }
    }
    a
}

/// The values `B_{sc}` of the samples (`n_s × NC`).
pub(super) fn values_matrix<const NC: usize>(samples: &[Sample<NC>]) -> DMatrix<f64> {
    DMatrix::from_fn(samples.len(), NC, |s, c| samples[s].1[c])
}

/// The factored (KKT) system of one fit in the equilibrated unknowns
/// `x = [ã; λ]`, `ã = S⁻¹ a` stacked over components, solved by its Schur
/// complement: `M̃ = L Lᵀ` is shared by the components, and with
/// `y = (I ⊗ M̃⁻¹) r₁` the multipliers solve
/// `(C̃ (I ⊗ M̃⁻¹) C̃ᵀ) λ = C̃ y − r₂`, then `ã = y − (I ⊗ M̃⁻¹) C̃ᵀ λ`. It keeps
/// `n_b² + m²` numbers instead of the `(NC n_b + m)²` of the whole matrix's
/// LU, which matters when the fits are kept ([`super::fit::FitFactor`]); the iterative
/// refinement on the samples' residual makes up for the Schur complement's
/// weaker conditioning.
#[derive(Clone)]
pub(super) struct Kkt {
    pub(super) s: Vec<f64>,
    /// Constraints in the equilibrated unknowns, rows normalised: `C (I ⊗ S)`.
    pub(super) c: DMatrix<f64>,
    d: DVector<f64>,
    normal: Cholesky<f64, Dyn>,
    /// `C̃ (I ⊗ M̃⁻¹) C̃ᵀ` factored; `None` without constraints.
    schur: Option<Cholesky<f64, Dyn>>,
}

impl Kkt {
    pub(super) fn new(
        m: &DMatrix<f64>,
        s: &[f64],
        nc: usize,
        constraints: Option<&LinearConstraints>,
    ) -> Result<Kkt, FitFailure> {
        let n = m.nrows() * nc;
        let (c, d) = match constraints {
            None => (DMatrix::zeros(0, n), DVector::zeros(0)),
            Some(k) => scaled_constraints(k, s, n)?,
        };
        let normal = m.clone().cholesky().ok_or(FitFailure::Singular)?;
        let schur = if c.nrows() == 0 {
            None
        } else {
            let w = DMatrix::from_columns(
                &c.row_iter()
                    .map(|row| block_solve(&normal, &row.transpose()))
                    .collect::<Vec<_>>(),
            );
            let schur = &c * w;
            Some(schur.cholesky().ok_or(FitFailure::Singular)?)
        };
        Ok(Kkt {
            s: s.to_vec(),
            c,
            d,
            normal,
            schur,
        })
    }

    /// Unknowns: `NC · n_b` coefficients and one multiplier per constraint.
    fn size(&self) -> usize {
        self.c.ncols() + self.c.nrows()
    }

    /// `[S Aᵀ(B − A S ã) − C̃ᵀλ; d̃ − C̃ ã]` at `x = [ã; λ]`: the
    /// residual from the samples, not from `AᵀA`.
    pub(super) fn residual(&self, design: &Design, x: &DVector<f64>) -> DVector<f64> {
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

    /// The right-hand side `[S Aᵀ B; d]` from the moments `Aᵀ B` given as
    /// `atb[j·nc + c]` (term `j`, component `c`).
    pub(super) fn rhs_from_moments(&self, atb: &[f64], nc: usize) -> DVector<f64> {
        let nb = self.s.len();
        let n = self.c.ncols();
        let mut res = DVector::zeros(self.size());
        for c in 0..nc {
            for j in 0..nb {
                res[c * nb + j] = self.s[j] * atb[j * nc + c];
            }
        }
        res.rows_mut(n, self.c.nrows()).copy_from(&self.d);
        res
    }

    /// [`Kkt::residual`] at `x = 0`: `[S Aᵀ B; d̃]`.
    pub(super) fn residual_at_zero(&self, design: &Design) -> DVector<f64> {
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

    /// `Y ← M̃⁻¹ Y` for the columns of `y` (`n_b × NC`): the solve of an
    /// unconstrained fit, one column per component.
    pub(super) fn solve_normal_in_place(&self, y: &mut DMatrixViewMut<f64>) {
        self.normal.solve_mut(y);
    }

    /// The correction `K⁻¹ r`, by the Schur complement (struct doc), the
    /// component blocks solved in place as the columns of `n_b × NC`
    /// matrices.
    pub(super) fn solve(&self, r: &DVector<f64>) -> DVector<f64> {
        let (n, rows) = (self.c.ncols(), self.c.nrows());
        let nb = self.s.len();
        let mut out = r.clone();
        self.normal
            .solve_mut(&mut out.rows_mut(0, n).reshape_generic(Dyn(nb), Dyn(n / nb)));
        let Some(schur) = &self.schur else {
            return out;
        };
        let mut lambda = &self.c * out.rows(0, n) - r.rows(n, rows);
        schur.solve_mut(&mut lambda);
        let mut w = self.c.tr_mul(&lambda);
        self.normal
            .solve_mut(&mut w.rows_mut(0, n).reshape_generic(Dyn(nb), Dyn(n / nb)));
        for i in 0..n {
            out[i] -= w[i];
        }
        out.rows_mut(n, rows).copy_from(&lambda);
        out
    }
}

/// `(I ⊗ M̃⁻¹) v` for `v` stacked by component (`NC` blocks of `n_b`).
fn block_solve(normal: &Cholesky<f64, Dyn>, v: &DVector<f64>) -> DVector<f64> {
    let nb = normal.l_dirty().nrows();
    // Stacked components are the columns of an `n_b × NC` matrix.
    let rhs = DMatrix::from_column_slice(nb, v.len() / nb, v.as_slice());
    DVector::from_column_slice(normal.solve(&rhs).as_slice())
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
