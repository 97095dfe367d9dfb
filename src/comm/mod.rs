//! How the ranks of a distributed run talk: the [`Comm`] trait that the
//! distributed linear algebra ([`crate::distributed`]) is written against,
//! and its transports: [`Serial`] (one rank), [`threads`] (ranks as threads
//! of one process, for tests and for checking a decomposition without MPI)
//! and, with the `mpi` feature, MPI through the `mpi` crate (`mpi` module).
//!
//! Every operation is collective in the MPI sense: the ranks that take part
//! call it in the same order. Reductions are summed in rank order after a
//! gather, so every rank gets the same bits and a run is reproducible at a
//! given rank count.

mod serial;
pub mod threads;

#[cfg(feature = "mpi")]
pub mod mpi;

pub use serial::Serial;

use crate::error::{Error, Result};
use crate::exact::{ExactSum, WORDS};

/// The messages of a distributed run.
pub trait Comm {
    /// This rank, `0..size()`.
    fn rank(&self) -> usize;
    /// Number of ranks.
    fn size(&self) -> usize;
    /// Every rank's `values`, in rank order (lengths may differ).
    fn all_gather(&self, values: &[f64]) -> Vec<Vec<f64>>;
    /// Point to point: sends `sends[i].1` to rank `sends[i].0` and returns
    /// what each rank `recvs[i].0` sends here, `recvs[i].1` numbers long, in
    /// the order of `recvs`. Every rank named in `recvs` names this rank in
    /// its `sends`, with that many numbers.
    fn exchange(&self, sends: &[(usize, Vec<f64>)], recvs: &[(usize, usize)]) -> Vec<Vec<f64>>;

    /// `values` summed entry by entry over the ranks, in rank order (the
    /// same bits on every rank).
    fn sum(&self, values: &mut [f64]) {
        let all = self.all_gather(values);
        for (i, v) in values.iter_mut().enumerate() {
            *v = all.iter().map(|r| r[i]).fold(0.0, |a, b| a + b);
        }
    }

    /// The largest of every rank's `value` (the same on every rank).
    fn max(&self, value: f64) -> f64 {
        let all = self.all_gather(&[value]);
        all.iter().map(|r| r[0]).fold(f64::NEG_INFINITY, f64::max)
    }

    /// `sums` added entry by entry over the ranks, exactly: the result
    /// depends only on the terms, not on how the ranks split them. By
    /// default each rank's accumulators are gathered and merged in rank
    /// order; MPI adds their integers in one all-reduce.
    fn sum_exact(&self, sums: &mut [ExactSum]) {
        let words: Vec<f64> = sums.iter().flat_map(ExactSum::to_words).collect();
        let all = self.all_gather(&words);
        for (i, s) in sums.iter_mut().enumerate() {
            let mut total = ExactSum::new();
            for rank in &all {
                total.merge(&ExactSum::from_words(&rank[i * WORDS..(i + 1) * WORDS]));
            }
            *s = total;
        }
    }
}

/// `local` where every rank succeeded; otherwise this rank's error, or one
/// saying that another rank failed. Collective: every rank calls it where a
/// rank's own step may fail, so that none waits for a rank that gave up.
pub fn agree<T>(comm: &dyn Comm, local: Result<T>) -> Result<T> {
    let mut failed = [f64::from(u8::from(local.is_err()))];
    comm.sum(&mut failed);
    match (local, failed[0] > 0.0) {
        (Ok(v), false) => Ok(v),
        (Err(e), _) => Err(e),
        (Ok(_), true) => Err(Error::Distributed {
            what: "another rank failed; its error is in its own output".into(),
        }),
    }
}
