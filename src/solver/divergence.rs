//! The divergence guard of the non-symmetric Krylov methods: CGS squares the
//! BiCG residual polynomial, so on a badly conditioned non-symmetric tangent
//! its residual can grow without bound (the annuli at level 5: 20 000
//! iterations, true residual 1e20). A cycle keeps the iterate with the
//! smallest residual it has seen, saving it whenever the residual falls below
//! half of the saved one; when the residual grows [`GROWTH`] times above the
//! saved one the cycle puts the saved iterate back and ends, and the driver
//! ([`super::drive`]) restarts from its true residual with a fresh shadow
//! residual, within the same iteration budget. Counted in
//! [`super::KrylovStats::divergence_restarts`].

use crate::backend::Backend;

use super::KrylovStats;

/// `‖r‖ / ‖r_saved‖` above which a cycle has diverged.
pub const GROWTH: f64 = 1e8;

/// `‖r‖ / ‖r_saved‖` below which the iterate is saved.
const SAVE_BELOW: f64 = 0.5;

/// What a cycle does with its iterate after an iteration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Guard {
    /// Nothing.
    Go,
    /// Save `x` (the residual fell well below the saved one).
    Save,
    /// Put the saved `x` back and end the cycle.
    Restore,
}

/// The residual of the saved iterate.
#[derive(Clone, Copy, Debug)]
struct DivergenceGuard {
    saved_rr: f64,
}

impl DivergenceGuard {
    /// A guard whose saved iterate is the cycle's start, residual `‖r‖² = rr`.
    fn new(rr: f64) -> DivergenceGuard {
        DivergenceGuard { saved_rr: rr }
    }

    /// What to do after an iteration with residual `‖r‖² = rr`.
    fn observe(&mut self, rr: f64) -> Guard {
        if rr > GROWTH * GROWTH * self.saved_rr {
            Guard::Restore
        } else if rr < SAVE_BELOW * SAVE_BELOW * self.saved_rr {
            self.saved_rr = rr;
            Guard::Save
        } else {
            Guard::Go
        }
    }
}

/// The saved iterate of a CGS or BiCGStab cycle and its [`DivergenceGuard`].
pub(crate) struct SavedIterate<V> {
    x: V,
    guard: DivergenceGuard,
}

impl<V> SavedIterate<V> {
    /// Saves the cycle's starting `x`, of true residual `r`.
    pub fn start<B: Backend<Vector = V>>(be: &B, x: &V, r: &V) -> SavedIterate<V> {
        let mut saved = be.zeros(be.len(x));
        be.copy(x, &mut saved);
        SavedIterate {
            x: saved,
            guard: DivergenceGuard::new(be.dot(r, r)),
        }
    }

    /// After an iteration with `‖r‖² = rr`: saves `x`, or puts the saved
    /// one back and says that the cycle ends.
    pub fn diverged<B: Backend<Vector = V>>(
        &mut self,
        be: &B,
        x: &mut V,
        rr: f64,
        stats: &mut KrylovStats,
    ) -> bool {
        match self.guard.observe(rr) {
            Guard::Go => false,
            Guard::Save => {
                be.copy(x, &mut self.x);
                false
            }
            Guard::Restore => {
                be.copy(&self.x, x);
                stats.divergence_restarts += 1;
                true
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn saves_on_halving_and_restores_on_growth() {
        let mut g = DivergenceGuard::new(1.0);
        assert_eq!(g.observe(0.5), Guard::Go);
        assert_eq!(g.observe(0.2), Guard::Save);
        let limit = 0.2 * GROWTH * GROWTH;
        assert_eq!(g.observe(0.99 * limit), Guard::Go);
        assert_eq!(g.observe(1.01 * limit), Guard::Restore);
    }
}
