//! One symmetric V-cycle of the [`Hierarchy`] as the preconditioner
//! `z = M⁻¹ r` of a Krylov solve. On level `i` with right-hand side `b`:
//!
//! ```text
//! x = S(b, 0)                    Chebyshev from zero (pre-smoothing)
//! b_{i+1} = Pᵀ (b − A_i x)       restriction of the residual
//! x_{i+1} = V_{i+1}(b_{i+1})     (coarsest: x = A⁻¹ b by Cholesky)
//! x = x + P x_{i+1}              prolongation of the correction
//! x = S(b, x)                    the same Chebyshev step (post-smoothing)
//! ```
//! With the smoothing step `x ← x + N (b − A x)`, `N` symmetric, the
//! cycle's error propagator is `(I − N A)(I − P A_c⁻¹ Pᵀ A)(I − N A)`, so
//! `M⁻¹` is symmetric; it is positive definite when `‖I − N A‖_A ≤ 1`,
//! which the Chebyshev interval guarantees ([`super::smoother`]).
//!
//! All vectors of the cycle are allocated once with the preconditioner; a
//! cycle allocates nothing.

use std::sync::Mutex;

use faer::dyn_stack::MemBuffer;

use super::smoother::Work;
use super::Hierarchy;
use crate::backend::{CpuBackend, LinearOperator};
use crate::fem::operator::ElasticOperator;
use crate::solver::ApplyInverse;

/// The V-cycle of a hierarchy over the solve's operator `fine`.
pub struct Multigrid<'a> {
    fine: &'a ElasticOperator,
    hierarchy: &'a Hierarchy,
    scratch: Mutex<Scratch>,
}

/// The cycle's vectors: per smoothed level its smoother's work and the
/// right-hand side and solution of the level below; the Cholesky scratch.
struct Scratch {
    levels: Vec<LevelScratch>,
    direct: MemBuffer,
}

struct LevelScratch {
    work: Work,
    b_coarse: Vec<f64>,
    x_coarse: Vec<f64>,
}

impl<'a> Multigrid<'a> {
    /// The preconditioner of `fine` (the operator `hierarchy` was built for).
    pub fn new(fine: &'a ElasticOperator, hierarchy: &'a Hierarchy) -> Multigrid<'a> {
        let n = |i: usize| hierarchy.level(fine, i).nrows();
        let levels = (0..hierarchy.num_levels() - 1)
            .map(|i| LevelScratch {
                work: Work::new(n(i)),
                b_coarse: vec![0.0; n(i + 1)],
                x_coarse: vec![0.0; n(i + 1)],
            })
            .collect();
        Multigrid {
            fine,
            hierarchy,
            scratch: Mutex::new(Scratch {
                levels,
                direct: hierarchy.direct.solve_scratch(),
            }),
        }
    }

    /// `z = M⁻¹ r`: one V-cycle from `x = 0` on the level-0 system `A z = r`.
    ///
    /// # Panics
    /// If `r` or `z` do not have the size of the operator.
    pub fn apply(&self, r: &[f64], z: &mut [f64]) {
        let n = self.fine.nrows();
        assert!(r.len() == n && z.len() == n, "multigrid: vectors of {n}");
        let mut guard = self.scratch.lock().unwrap_or_else(|e| e.into_inner());
        let Scratch { levels, direct } = &mut *guard;
        self.vcycle(0, r, z, levels, direct);
    }

    /// The V-cycle on level `i` (module doc): `x ≈ A_i⁻¹ b`.
    fn vcycle(
        &self,
        i: usize,
        b: &[f64],
        x: &mut [f64],
        scratch: &mut [LevelScratch],
        direct: &mut MemBuffer,
    ) {
        let h = self.hierarchy;
        let Some((s, below)) = scratch.split_first_mut() else {
            x.copy_from_slice(b);
            h.direct.solve_in_place_with(x, direct);
            return;
        };
        let op = h.level(self.fine, i);
        let smoother = &h.smoothers[i];
        let transfer = h.transfer(self.fine, i);
        smoother.smooth(op, b, x, true, &mut s.work);
        smoother.residual(op, b, x, &mut s.work);
        transfer.restrict(s.work.residual(), &mut s.b_coarse);
        self.vcycle(i + 1, &s.b_coarse, &mut s.x_coarse, below, direct);
        transfer.prolong_add(&s.x_coarse, x);
        smoother.smooth(op, b, x, false, &mut s.work);
    }
}

impl ApplyInverse<CpuBackend> for Multigrid<'_> {
    fn apply_inverse(&self, r: &Vec<f64>, z: &mut Vec<f64>) {
        self.apply(r, z);
    }
}
