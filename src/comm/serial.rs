//! The one-rank transport: gathers return this rank's values, and there is
//! nobody to exchange with.

use super::Comm;

/// A run on one rank.
#[derive(Clone, Copy, Debug, Default)]
pub struct Serial;

impl Comm for Serial {
    fn rank(&self) -> usize {
        0
    }

    fn size(&self) -> usize {
        1
    }

    fn all_gather(&self, values: &[f64]) -> Vec<Vec<f64>> {
        vec![values.to_vec()]
    }

    /// # Panics
    /// When asked to send to or receive from another rank.
    fn exchange(&self, sends: &[(usize, Vec<f64>)], recvs: &[(usize, usize)]) -> Vec<Vec<f64>> {
        assert!(
            sends.is_empty() && recvs.is_empty(),
            "one rank exchanges nothing"
        );
        Vec::new()
    }
}
