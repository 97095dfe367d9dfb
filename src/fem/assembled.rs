//! The assembled operator: the CSC matrix of
//! [`super::operator::ElasticOperator::assemble`], applied with faer's
//! sparse × dense product (the reference the matrix-free applies are
//! measured and tested against).

use crate::backend::LinearOperator;

/// The assembled operator, applied with faer's sparse × dense product.
pub struct AssembledOperator(pub faer::sparse::SparseColMat<usize, f64>);

impl LinearOperator for AssembledOperator {
    fn nrows(&self) -> usize {
        self.0.nrows()
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let n = self.0.nrows();
        let xs = faer::MatRef::from_column_major_slice(x, n, 1);
        let ys = faer::MatMut::from_column_major_slice_mut(y, n, 1);
        // A is symmetric: Aᵀ x, computed column by column, is A x.
        faer::sparse::linalg::matmul::sparse_dense_matmul(
            ys,
            faer::Accum::Replace,
            self.0.as_ref(),
            xs,
            1.0,
            faer::Par::Seq,
        );
    }

    fn diagonal(&self) -> Vec<f64> {
        let a = self.0.as_ref();
        (0..a.ncols())
            .map(|j| {
                let rows = a.row_idx_of_col_raw(j);
                let vals = a.val_of_col(j);
                rows.iter()
                    .zip(vals)
                    .filter(|(r, _)| **r == j)
                    .map(|(_, v)| *v)
                    .sum()
            })
            .collect()
    }
}
