//! A rank's share of the sums over the body's cells ([`CellShare`]): the
//! S-term's rigid-body fit and the report's integrals add up every cell of
//! a piece once, whichever rank holds it. One rank holds every cell
//! ([`Whole`]); a rank of several counts the cells of its brick and sums
//! over the ranks ([`crate::distributed`]).

use crate::exact::ExactSum;

/// Which cells a rank counts, and how its partial sums join the others'.
pub trait CellShare {
    /// Whether this rank counts `cell` in sums over the body.
    fn counts(&self, cell: usize) -> bool;
    /// `sums` added exactly over the ranks (the same bits however the
    /// ranks split the cells).
    fn sum_exact(&self, sums: &mut [ExactSum]);
}

/// The whole body on one rank.
#[derive(Clone, Copy, Debug, Default)]
pub struct Whole;

impl CellShare for Whole {
    fn counts(&self, _cell: usize) -> bool {
        true
    }

    fn sum_exact(&self, _sums: &mut [ExactSum]) {}
}
