//! The assembled operator applied by a plain row-parallel CSR product (rayon),
//! the thread-for-thread counterpart of the matrix-free apply (faer's sparse ×
//! dense product runs on one thread for a single vector).
//!
//! The operator is symmetric, so the CSC matrix of
//! [`crate::fem::operator::ElasticOperator::assemble`] read by columns is its
//! CSR form: `y_i = Σ_{k ∈ col i} v_k x_{r_k}`.

use rayon::prelude::*;

use crate::backend::LinearOperator;
use crate::fem::operator::AssembledOperator;

/// Rows per rayon task.
const ROWS_PER_TASK: usize = 1024;

/// A symmetric sparse matrix applied row by row in parallel.
pub struct RayonCsr<'a>(pub &'a AssembledOperator);

impl LinearOperator for RayonCsr<'_> {
    fn nrows(&self) -> usize {
        self.0.nrows()
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let a = self.0 .0.as_ref();
        y.par_chunks_mut(ROWS_PER_TASK)
            .enumerate()
            .for_each(|(t, yc)| {
                for (k, yi) in yc.iter_mut().enumerate() {
                    let i = t * ROWS_PER_TASK + k;
                    let rows = a.row_idx_of_col_raw(i);
                    let vals = a.val_of_col(i);
                    *yi = rows.iter().zip(vals).map(|(&r, v)| v * x[r]).sum();
                }
            });
    }

    fn diagonal(&self) -> Vec<f64> {
        self.0.diagonal()
    }
}

/// Bytes of an assembled matrix: values and row indices (8 bytes each) per
/// nonzero, and the column pointers.
pub fn csr_bytes(a: &AssembledOperator) -> usize {
    16 * a.0.compute_nnz() + 8 * (a.0.ncols() + 1)
}
