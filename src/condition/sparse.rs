//! The sparse-matrix side of the condition estimate: `A x`, the Jacobi scaling
//! `D^-1/2 A D^-1/2`, the sparse Cholesky factor `A = L Lᵀ` (faer, AMD
//! ordering, sequential so that results are reproducible) and the Rayleigh quotient `zᵀ A z` with
//! its rounding level.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltError;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, LltRef, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::linalg::matmul::sparse_dense_matmul;
use faer::sparse::SparseColMat;
use faer::{Accum, Conj, MatMut, MatRef, Par, Side};

use crate::solver::floor_diagonal;
use crate::{Error, Result};

/// `y = A x` (column by column; `A` is square).
pub(super) fn matvec(a: &SparseColMat<usize, f64>, x: &[f64], y: &mut [f64]) {
    let n = a.nrows();
    sparse_dense_matmul(
        MatMut::from_column_major_slice_mut(y, n, 1),
        Accum::Replace,
        a.as_ref(),
        MatRef::from_column_major_slice(x, n, 1),
        1.0,
        Par::Seq,
    );
}

/// The diagonal of `A` (zero where no entry is stored).
fn diagonal(a: &SparseColMat<usize, f64>) -> Vec<f64> {
    (0..a.ncols())
        .map(|j| {
            a.row_idx_of_col_raw(j)
                .iter()
                .zip(a.val_of_col(j))
                .filter(|(&i, _)| i == j)
                .map(|(_, &v)| v)
                .sum()
        })
        .collect()
}

/// `S = D^-1/2 A D^-1/2`, `S_ij = A_ij / √(d_i d_j)`, on the sparsity of `A`
/// (so `S_ii = 1` exactly: `√(d²) = d` in IEEE arithmetic), with `d` the
/// diagonal floored as the Jacobi preconditioner floors it
/// ([`crate::solver::floor_diagonal`]: entries at round-off level are cut
/// artefacts); also returns how many entries were floored.
///
/// # Errors
/// [`Error::Breakdown`] when a diagonal entry is not finite or is negative
/// beyond the floor (`A` is then not positive definite).
pub(super) fn jacobi_scaled(
    a: &SparseColMat<usize, f64>,
) -> Result<(SparseColMat<usize, f64>, usize)> {
    let mut d = diagonal(a);
    let floored = floor_diagonal(&mut d, true).map_err(|(i, v)| Error::Breakdown {
        method: "jacobi scaling".into(),
        iterations: 0,
        what: format!("diagonal entry {i} is {v:e}, not positive"),
    })?;
    let mut s = a.clone();
    for j in 0..a.ncols() {
        let rows = a.row_idx_of_col_raw(j);
        for (v, &i) in s.val_of_col_mut(j).iter_mut().zip(rows) {
            *v /= (d[i] * d[j]).sqrt();
        }
    }
    Ok((s, floored))
}

/// The sparse Cholesky factor of a symmetric matrix (its lower triangle read).
pub(crate) struct Cholesky {
    symbolic: SymbolicCholesky<usize>,
    values: Vec<f64>,
    par: Par,
}

impl Cholesky {
    /// Factors `A` sequentially; `Err` says why it failed (a non-positive
    /// pivot: `A` is not numerically positive definite; or out of memory).
    pub fn new(a: &SparseColMat<usize, f64>) -> std::result::Result<Self, String> {
        Cholesky::with_par(a, Par::Seq, usize::MAX)
    }

    /// Factors `A` with the parallelism `par` (also used by the solves),
    /// refusing when the factor would take more than `max_bytes`.
    pub fn with_par(
        a: &SparseColMat<usize, f64>,
        par: Par,
        max_bytes: usize,
    ) -> std::result::Result<Self, String> {
        Cholesky::with_ordering(a, SymmetricOrdering::Amd, par, max_bytes)
    }

    /// [`Cholesky::with_par`] with the fill-reducing `ordering` given.
    pub fn with_ordering(
        a: &SparseColMat<usize, f64>,
        ordering: SymmetricOrdering<'_, usize>,
        par: Par,
        max_bytes: usize,
    ) -> std::result::Result<Self, String> {
        let symbolic =
            factorize_symbolic_cholesky(a.symbolic(), Side::Lower, ordering, Default::default())
                .map_err(|e| format!("{e:?}"))?;
        let bytes = 8 * symbolic.len_val();
        if bytes > max_bytes {
            return Err(format!(
                "the factor needs {:.1} GB, over the limit of {:.1} GB",
                bytes as f64 / 1e9,
                max_bytes as f64 / 1e9
            ));
        }
        let mut values = Vec::new();
        values
            .try_reserve_exact(symbolic.len_val())
            .map_err(|e| format!("the factor ({bytes} bytes): {e}"))?;
        values.resize(symbolic.len_val(), 0.0);
        let req = symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default());
        let mut mem = MemBuffer::try_new(req).map_err(|e| format!("{e:?}"))?;
        symbolic
            .factorize_numeric_llt(
                &mut values,
                a.as_ref(),
                Side::Lower,
                Default::default(),
                par,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .map_err(|LltError::NonPositivePivot { index }| {
                format!("non-positive pivot {index} of {}", a.nrows())
            })?;
        Ok(Cholesky {
            symbolic,
            values,
            par,
        })
    }

    /// Entries of the factor `L`.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// `x ← A⁻¹ x`.
    pub fn solve_in_place(&self, x: &mut [f64]) {
        self.solve_in_place_with(x, &mut self.solve_scratch());
    }

    /// The scratch of [`Self::solve_in_place_with`], for repeated solves.
    pub fn solve_scratch(&self) -> MemBuffer {
        MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(1, self.par))
    }

    /// `x ← A⁻¹ x` with the scratch `mem` of [`Self::solve_scratch`] (no
    /// allocation).
    pub fn solve_in_place_with(&self, x: &mut [f64], mem: &mut MemBuffer) {
        let n = x.len();
        LltRef::new(&self.symbolic, &self.values).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(x, n, 1),
            self.par,
            MemStack::new(mem),
        );
    }
}

/// A computed Rayleigh quotient and the size of its rounding error.
#[derive(Clone, Copy, Debug)]
pub(super) struct Rayleigh {
    pub value: f64,
    pub noise: f64,
}

/// `zᵀ A z` for a unit `z`, with the rounding level `(k + √n) ε |z|ᵀ|A||z|`
/// (`k` the most entries in a column: `k ε` bounds each computed entry of
/// `A z`, and `√n ε` is the realistic error of the `n`-term sum).
pub(super) fn rayleigh(a: &SparseColMat<usize, f64>, z: &[f64]) -> Rayleigh {
    let (mut value, mut magnitude, mut k) = (0.0, 0.0, 0usize);
    for j in 0..a.ncols() {
        let rows = a.row_idx_of_col_raw(j);
        let vals = a.val_of_col(j);
        let az: f64 = rows.iter().zip(vals).map(|(&i, v)| v * z[i]).sum();
        let abs: f64 = rows.iter().zip(vals).map(|(&i, v)| (v * z[i]).abs()).sum();
        value += z[j] * az;
        magnitude += z[j].abs() * abs;
        k = k.max(rows.len());
    }
    let noise = (k as f64 + (z.len() as f64).sqrt()) * f64::EPSILON * magnitude;
    Rayleigh { value, noise }
}
