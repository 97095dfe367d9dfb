//! One symmetric V-cycle as the preconditioner `z = M⁻¹ r` of a Krylov
//! solve, written once over [`CycleOps`] (the level operators, smoothers,
//! transfers and coarse solve of one backend): [`Multigrid`] runs it on the
//! CPU over a [`Hierarchy`], `crate::gpu::multigrid` on the device. On level
//! `i` with right-hand side `b`:
//!
//! ```text
//! x = S(b, 0)                    Chebyshev from zero (pre-smoothing)
//! b_{i+1} = Pᵀ (b − A_i x)       restriction of the residual
//! x_{i+1} = V_{i+1}(b_{i+1})     (coarsest: x = A⁻¹ b, the direct solve)
//! x = x + P x_{i+1}              prolongation of the correction
//! x = S(b, x)                    the same Chebyshev step (post-smoothing)
//! ```
//! With the smoothing step `x ← x + N (b − A x)`, `N` symmetric, the
//! cycle's error propagator is `(I − N A)(I − P A_c⁻¹ Pᵀ A)(I − N A)`, so
//! `M⁻¹` is symmetric; it is positive definite when `‖I − N A‖_A ≤ 1`,
//! which the Chebyshev interval guarantees ([`super::smoother`]).
//!
//! All vectors of the cycle are allocated once with the preconditioner
//! ([`LevelWork`]); a cycle allocates nothing.

use std::sync::Mutex;

use faer::dyn_stack::MemBuffer;

use super::smoother::Chebyshev;
use super::smoother::{chebyshev_coefficients, chebyshev_update, rsub_assign, sub_assign};
use super::Hierarchy;
use crate::backend::{CpuBackend, LinearOperator};
use crate::fem::operator::ElasticOperator;
use crate::solver::ApplyInverse;

/// What a V-cycle does on one backend's vectors, level by level (level 0:
/// the solve's operator; the last level: the coarsest, solved directly).
pub trait CycleOps {
    type Vector;
    /// Levels, the coarsest included.
    fn num_levels(&self) -> usize;
    /// Unknowns of `level`.
    fn nrows(&self, level: usize) -> usize;
    /// A vector of `n` zeros.
    fn zeros(&self, n: usize) -> Self::Vector;
    /// `y = A_level x`.
    fn apply(&self, level: usize, x: &Self::Vector, y: &mut Self::Vector);
    /// `z = B⁻¹ r` of the smoother of `level` ([`super::blocks`]).
    fn precondition(&self, level: usize, r: &Self::Vector, z: &mut Self::Vector);
    /// The Chebyshev interval `[a, b]` and degree of the smoother of `level`.
    fn chebyshev(&self, level: usize) -> (f64, f64, usize);
    /// `d = a d + c z`, then `x = x + d`, entry by entry: update `step` of
    /// `level`'s smoothing step, `coef = (a, c)` its
    /// [`chebyshev_coefficients`].
    fn chebyshev_update(
        &self,
        level: usize,
        step: usize,
        coef: (f64, f64),
        z: &Self::Vector,
        d: &mut Self::Vector,
        x: &mut Self::Vector,
    );
    /// `r = r − v` on `level`.
    fn sub_assign(&self, level: usize, r: &mut Self::Vector, v: &Self::Vector);
    /// `r = b − r` on `level`.
    fn rsub_assign(&self, level: usize, r: &mut Self::Vector, b: &Self::Vector);
    /// `dst = src`.
    fn copy(&self, src: &Self::Vector, dst: &mut Self::Vector);
    /// `x = 0`.
    fn fill_zero(&self, x: &mut Self::Vector);
    /// `coarse = Pᵀ fine` from `level` to `level + 1` (overwrites).
    fn restrict(&self, level: usize, fine: &Self::Vector, coarse: &mut Self::Vector);
    /// `fine = fine + P coarse` from `level + 1` to `level`.
    fn prolong_add(&self, level: usize, coarse: &Self::Vector, fine: &mut Self::Vector);
    /// `x = A⁻¹ b` on the coarsest level.
    fn coarse_solve(&self, b: &Self::Vector, x: &mut Self::Vector);
}

/// The vectors of one smoothed level: the smoother's residual, `B⁻¹` of it,
/// update and `A d`, and the right-hand side and solution of the level
/// below.
pub struct LevelWork<V> {
    r: V,
    z: V,
    d: V,
    ad: V,
    b_coarse: V,
    x_coarse: V,
}

impl<V> LevelWork<V> {
    /// The work of every smoothed level of `ops`, finest first.
    pub fn all<O: CycleOps<Vector = V>>(ops: &O) -> Vec<LevelWork<V>> {
        (0..ops.num_levels() - 1)
            .map(|i| {
                let (n, nc) = (ops.nrows(i), ops.nrows(i + 1));
                LevelWork {
                    r: ops.zeros(n),
                    z: ops.zeros(n),
                    d: ops.zeros(n),
                    ad: ops.zeros(n),
                    b_coarse: ops.zeros(nc),
                    x_coarse: ops.zeros(nc),
                }
            })
            .collect()
    }
}

/// The V-cycle on `level` (module doc): `x ≈ A_level⁻¹ b`; `work` holds the
/// vectors of `level` and the levels below.
pub fn vcycle<O: CycleOps>(
    ops: &O,
    level: usize,
    b: &O::Vector,
    x: &mut O::Vector,
    work: &mut [LevelWork<O::Vector>],
) {
    let Some((w, below)) = work.split_first_mut() else {
        ops.coarse_solve(b, x);
        return;
    };
    smooth(ops, level, b, x, true, w);
    ops.apply(level, x, &mut w.r);
    ops.rsub_assign(level, &mut w.r, b);
    ops.restrict(level, &w.r, &mut w.b_coarse);
    vcycle(ops, level + 1, &w.b_coarse, &mut w.x_coarse, below);
    ops.prolong_add(level, &w.x_coarse, x);
    smooth(ops, level, b, x, false, w);
}

/// One Chebyshev smoothing step on `A x = b` of `level` ([`super::smoother`]
/// gives the recurrence, [`chebyshev_coefficients`] its coefficients), from
/// `x = 0` when `zero_start` (saving the residual's apply), else from the `x`
/// given.
fn smooth<O: CycleOps>(
    ops: &O,
    level: usize,
    b: &O::Vector,
    x: &mut O::Vector,
    zero_start: bool,
    w: &mut LevelWork<O::Vector>,
) {
    let (lo, hi, degree) = ops.chebyshev(level);
    if zero_start {
        ops.copy(b, &mut w.r);
        ops.fill_zero(x);
    } else {
        ops.apply(level, x, &mut w.r);
        ops.rsub_assign(level, &mut w.r, b);
    }
    ops.fill_zero(&mut w.d);
    for (step, coef) in chebyshev_coefficients(lo, hi, degree)
        .into_iter()
        .enumerate()
    {
        if step > 0 {
            ops.apply(level, &w.d, &mut w.ad);
            ops.sub_assign(level, &mut w.r, &w.ad);
        }
        ops.precondition(level, &w.r, &mut w.z);
        ops.chebyshev_update(level, step, coef, &w.z, &mut w.d, x);
    }
}

/// The V-cycle of a hierarchy over the solve's operator `fine`, on the CPU.
pub struct Multigrid<'a> {
    levels: OnHost<CpuLevels<'a>>,
    work: Mutex<CpuWork>,
}

/// The cycle's vectors on the CPU, with level 0's right-hand side and
/// solution for the callers that hand in slices ([`Multigrid::apply`]).
struct CpuWork {
    levels: Vec<LevelWork<Vec<f64>>>,
    b: Vec<f64>,
    x: Vec<f64>,
}

/// The CPU's [`HostLevels`]: the hierarchy's operators, smoothers, transfers
/// and Cholesky factor, with the factor's solve scratch.
struct CpuLevels<'a> {
    fine: &'a ElasticOperator,
    hierarchy: &'a Hierarchy,
    direct: Mutex<MemBuffer>,
}

impl<'a> Multigrid<'a> {
    /// The preconditioner of `fine` (the operator `hierarchy` was built for).
    pub fn new(fine: &'a ElasticOperator, hierarchy: &'a Hierarchy) -> Multigrid<'a> {
        let levels = OnHost(CpuLevels {
            fine,
            hierarchy,
            direct: Mutex::new(hierarchy.direct.solve_scratch()),
        });
        let n = fine.nrows();
        let work = Mutex::new(CpuWork {
            levels: LevelWork::all(&levels),
            b: vec![0.0; n],
            x: vec![0.0; n],
        });
        Multigrid { levels, work }
    }

    /// `z = M⁻¹ r`: one V-cycle from `x = 0` on the level-0 system `A z = r`.
    ///
    /// # Panics
    /// If `r` or `z` do not have the size of the operator.
    pub fn apply(&self, r: &[f64], z: &mut [f64]) {
        let n = self.levels.0.fine.nrows();
        assert!(r.len() == n && z.len() == n, "multigrid: vectors of {n}");
        let mut guard = self.work.lock().unwrap_or_else(|e| e.into_inner());
        let CpuWork { levels, b, x } = &mut *guard;
        b.copy_from_slice(r);
        vcycle(&self.levels, 0, b, x, levels);
        z.copy_from_slice(x);
    }
}

impl ApplyInverse<CpuBackend> for Multigrid<'_> {
    /// [`Multigrid::apply`] on whole vectors: the cycle runs on `r` and `z`
    /// themselves, without the copies a slice needs.
    fn apply_inverse(&self, r: &Vec<f64>, z: &mut Vec<f64>) {
        let n = self.levels.0.fine.nrows();
        assert!(r.len() == n && z.len() == n, "multigrid: vectors of {n}");
        let mut guard = self.work.lock().unwrap_or_else(|e| e.into_inner());
        vcycle(&self.levels, 0, r, z, &mut guard.levels);
    }
}

impl HostLevels for CpuLevels<'_> {
    fn num_levels(&self) -> usize {
        self.hierarchy.num_levels()
    }

    fn nrows(&self, level: usize) -> usize {
        self.hierarchy.level(self.fine, level).nrows()
    }

    fn smoother(&self, level: usize) -> &Chebyshev {
        &self.hierarchy.smoothers[level]
    }

    fn apply(&self, level: usize, x: &[f64], y: &mut [f64]) {
        self.hierarchy.level(self.fine, level).apply(x, y);
    }

    fn precondition(&self, level: usize, r: &[f64], z: &mut [f64]) {
        self.hierarchy.smoothers[level].pre.apply(r, z);
    }

    fn restrict(&self, level: usize, fine: &[f64], coarse: &mut [f64]) {
        self.hierarchy
            .transfer(self.fine, level)
            .restrict(fine, coarse);
    }

    fn prolong_add(&self, level: usize, coarse: &[f64], fine: &mut [f64]) {
        self.hierarchy
            .transfer(self.fine, level)
            .prolong_add(coarse, fine);
    }

    fn coarse_solve(&self, b: &[f64], x: &mut [f64]) {
        x.copy_from_slice(b);
        let mut scratch = self.direct.lock().unwrap_or_else(|e| e.into_inner());
        self.hierarchy.direct.solve_in_place_with(x, &mut scratch);
    }
}

/// Levels whose vectors are host vectors: one process's hierarchy
/// ([`Multigrid`]) or one rank's share of it
/// (`crate::distributed::multigrid`). Their operators, smoothers'
/// preconditioners, transfers and coarse solve differ; the cycle's vector
/// steps are the host's, written once ([`OnHost`]).
pub trait HostLevels {
    /// Levels, the coarsest included.
    fn num_levels(&self) -> usize;
    /// Unknowns of `level`.
    fn nrows(&self, level: usize) -> usize;
    /// The smoother of `level` (all but the coarsest).
    fn smoother(&self, level: usize) -> &Chebyshev;
    /// `y = A_level x`.
    fn apply(&self, level: usize, x: &[f64], y: &mut [f64]);
    /// `z = B⁻¹ r` of the smoother of `level`.
    fn precondition(&self, level: usize, r: &[f64], z: &mut [f64]);
    /// `coarse = Pᵀ fine` from `level` to `level + 1`.
    fn restrict(&self, level: usize, fine: &[f64], coarse: &mut [f64]);
    /// `fine = fine + P coarse` from `level + 1` to `level`.
    fn prolong_add(&self, level: usize, coarse: &[f64], fine: &mut [f64]);
    /// `x = A⁻¹ b` on the coarsest level.
    fn coarse_solve(&self, b: &[f64], x: &mut [f64]);
}

/// The [`CycleOps`] of host levels.
pub struct OnHost<L>(pub L);

impl<L: HostLevels> CycleOps for OnHost<L> {
    type Vector = Vec<f64>;

    fn num_levels(&self) -> usize {
        self.0.num_levels()
    }

    fn nrows(&self, level: usize) -> usize {
        self.0.nrows(level)
    }

    fn zeros(&self, n: usize) -> Vec<f64> {
        vec![0.0; n]
    }

    fn apply(&self, level: usize, x: &Vec<f64>, y: &mut Vec<f64>) {
        self.0.apply(level, x, y);
    }

    fn precondition(&self, level: usize, r: &Vec<f64>, z: &mut Vec<f64>) {
        self.0.precondition(level, r, z);
    }

    fn chebyshev(&self, level: usize) -> (f64, f64, usize) {
        let s = self.0.smoother(level);
        (s.lo, s.hi, s.degree)
    }

    fn chebyshev_update(
        &self,
        _level: usize,
        _step: usize,
        (a, c): (f64, f64),
        z: &Vec<f64>,
        d: &mut Vec<f64>,
        x: &mut Vec<f64>,
    ) {
        chebyshev_update(a, c, z, d, x);
    }

    fn sub_assign(&self, _level: usize, r: &mut Vec<f64>, v: &Vec<f64>) {
        sub_assign(r, v);
    }

    fn rsub_assign(&self, _level: usize, r: &mut Vec<f64>, b: &Vec<f64>) {
        rsub_assign(r, b);
    }

    fn copy(&self, src: &Vec<f64>, dst: &mut Vec<f64>) {
        dst.copy_from_slice(src);
    }

    fn fill_zero(&self, x: &mut Vec<f64>) {
        x.fill(0.0);
    }

    fn restrict(&self, level: usize, fine: &Vec<f64>, coarse: &mut Vec<f64>) {
        self.0.restrict(level, fine, coarse);
    }

    fn prolong_add(&self, level: usize, coarse: &Vec<f64>, fine: &mut Vec<f64>) {
        self.0.prolong_add(level, coarse, fine);
    }

    fn coarse_solve(&self, b: &Vec<f64>, x: &mut Vec<f64>) {
        self.0.coarse_solve(b, x);
    }
}
