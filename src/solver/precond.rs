//! Preconditioners as the Krylov cycles apply them: `z = M⁻¹ r` with `M = I`
//! (no work, `r` itself is used), `M = diag(A)` (Jacobi: one
//! [`Backend::pointwise_mul`] with the inverted diagonal, set up once per solve)
//! or one built outside the solver and handed in as an [`ApplyInverse`] (the
//! multigrid V-cycle of [`crate::multigrid`], which needs the case's grids).
//!
//! # The diagonal floor
//! A cut cell whose part inside the body is a sliver of a few ulps gives its
//! nodes a diagonal entry at round-off level, which can come out zero or
//! slightly negative (`-1.6e-20` beside entries of order `1e2`). That is a
//! cut artefact, not a property of the problem: Jacobi replaces every entry
//! `d_i ≤ 0` with `|d_i| ≤ DIAGONAL_FLOOR · max_j |d_j|` by
//! `DIAGONAL_FLOOR · max_j |d_j|` and counts it
//! ([`KrylovStats::floored_diagonal_entries`](super::KrylovStats)) instead of
//! failing; the Krylov method still solves `A x = b`, with its true residual
//! checked. [`DIAGONAL_FLOOR`] is 64 ulps: round-off in summing a node's
//! element contributions is a few ulps of the largest contribution. A tiny
//! *positive* entry is used as it is: Jacobi then scales that dof exactly,
//! whereas flooring it leaves the dof unresolved by the Krylov tolerance and
//! the fixed point on the recovered terms stalls (measured: the Q1 patch test
//! of `tests/suite/fem/elasticity.rs` stalled at `ε ≈ 1e-6` when positive entries below
//! the floor were raised to it). Entries below `−DIAGONAL_FLOOR · max |d|` are
//! not floored: for CG they prove that `A` is not positive definite and are a
//! breakdown; CGS and BiCGStab use them as they are. A non-finite entry is
//! always a breakdown.

use crate::backend::Backend;
use crate::error::Result;

use super::krylov::breakdown;
use super::{KrylovMethod, KrylovOptions, Preconditioner};
use crate::error::Error;

/// A preconditioner built outside the solver: `z = M⁻¹ r` on the backend's
/// vectors. For CG, `M⁻¹` must be symmetric positive definite.
pub trait ApplyInverse<B: Backend> {
    /// `z = M⁻¹ r` (overwrites `z`).
    fn apply_inverse(&self, r: &B::Vector, z: &mut B::Vector);
}

/// An [`ApplyInverse`] that counts its applications and the seconds they
/// took (the V-cycles of a run, for its timings).
pub struct TimedInverse<'a, B: Backend> {
    inner: &'a dyn ApplyInverse<B>,
    applications: std::cell::Cell<usize>,
    seconds: std::cell::Cell<f64>,
}

impl<'a, B: Backend> TimedInverse<'a, B> {
    pub fn new(inner: &'a dyn ApplyInverse<B>) -> Self {
        TimedInverse {
            inner,
            applications: std::cell::Cell::new(0),
            seconds: std::cell::Cell::new(0.0),
        }
    }

    /// The applications so far and their seconds.
    pub fn totals(&self) -> (usize, f64) {
        (self.applications.get(), self.seconds.get())
    }
}

impl<B: Backend> ApplyInverse<B> for TimedInverse<'_, B> {
    fn apply_inverse(&self, r: &B::Vector, z: &mut B::Vector) {
        let t = std::time::Instant::now();
        self.inner.apply_inverse(r, z);
        self.seconds
            .set(self.seconds.get() + t.elapsed().as_secs_f64());
        self.applications.set(self.applications.get() + 1);
    }
}

/// `M⁻¹` on the backend: the identity, `D⁻¹` as a vector, or an
/// [`ApplyInverse`] built by the caller.
pub(crate) struct Precond<'p, B: Backend> {
    inv_diag: Option<B::Vector>,
    external: Option<&'p dyn ApplyInverse<B>>,
    floored: usize,
}

/// Relative floor of a Jacobi diagonal (see the module doc): 64 ulps of the
/// largest entry.
pub const DIAGONAL_FLOOR: f64 = 64.0 * f64::EPSILON;

/// Floors the non-positive round-off entries of the diagonal `d` in place
/// (module doc): every `d_i ≤ 0` with `|d_i| ≤ DIAGONAL_FLOOR · max |d|`
/// becomes `DIAGONAL_FLOOR · max |d|`.
/// Returns how many were floored, or the first entry that is not finite, or
/// (with `positive`) negative beyond the floor, as `(index, value)`.
pub fn floor_diagonal(d: &mut [f64], positive: bool) -> std::result::Result<usize, (usize, f64)> {
    let largest = d.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    floor_diagonal_against(d, positive, largest)
}

/// [`floor_diagonal`] against `largest`, the largest `|d_i|` of the whole
/// diagonal (`d` may be one rank's share of it).
pub fn floor_diagonal_against(
    d: &mut [f64],
    positive: bool,
    largest: f64,
) -> std::result::Result<usize, (usize, f64)> {
    if let Some((i, &v)) = d.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err((i, v));
    }
    let floor = DIAGONAL_FLOOR * largest;
    if floor == 0.0 {
        // All zero (or empty): nothing to scale against.
        return match d.first() {
            Some(&v) => Err((0, v)),
            None => Ok(0),
        };
    }
    let mut floored = 0;
    for (i, v) in d.iter_mut().enumerate() {
        if *v <= 0.0 && -*v <= floor {
            *v = floor;
            floored += 1;
        } else if positive && *v < 0.0 {
            return Err((i, *v));
        }
    }
    Ok(floored)
}

impl<'p, B: Backend> Precond<'p, B> {
    /// The preconditioner asked for in `opts`. For Jacobi, `diag` (or, when
    /// `None`, [`Backend::diagonal`] of `op`) is downloaded once, checked
    /// (finite; for CG, which needs `M` SPD, not negative beyond the floor),
    /// floored (module doc), inverted and uploaded; `auto` given no hierarchy
    /// is Jacobi. Multigrid cannot be built from the operator alone:
    /// [`Error::InvalidSolverOptions`] (build it with [`crate::multigrid`]
    /// and pass it to [`Precond::external`]).
    pub(crate) fn new(
        be: &B,
        op: &B::Operator<'_>,
        diag: Option<&B::Vector>,
        opts: &KrylovOptions,
    ) -> Result<Self> {
        match opts.preconditioner {
            Preconditioner::None => return Ok(Precond::external_or_none(None)),
            Preconditioner::Jacobi | Preconditioner::Auto => {}
            Preconditioner::Multigrid => {
                return Err(Error::InvalidSolverOptions {
                    what: "preconditioner".into(),
                    reason: "multigrid needs the case's grid hierarchy: it is built with \
                             the set-up (crate::multigrid) and handed to the solve"
                        .into(),
                })
            }
        }
        let d = match diag {
            Some(d) => be.download(d),
            None => be.download(&be.diagonal(op)),
        };
        assert_eq!(
            d.len(),
            be.nrows(op),
            "solve: diag must have the rows of the operator"
        );
        let spd = opts.method == KrylovMethod::Cg;
        let mut d = d;
        let floored = match floor_diagonal(&mut d, spd) {
            Ok(n) => n,
            Err((i, v)) => {
                let what = format!("Jacobi preconditioner: diagonal entry {i} of A is {v:e}");
                return Err(breakdown(opts.method, 0, what));
            }
        };
        if floored > 0 {
            tracing::debug!(
                floored,
                "Jacobi: diagonal entries at round-off level floored"
            );
        }
        let inv: Vec<f64> = d.iter().map(|v| 1.0 / v).collect();
        Ok(Precond {
            inv_diag: Some(be.upload(&inv)),
            external: None,
            floored,
        })
    }

    /// `M⁻¹` applied by `pre`.
    pub(crate) fn external(pre: &'p dyn ApplyInverse<B>) -> Self {
        Precond::external_or_none(Some(pre))
    }

    fn external_or_none(external: Option<&'p dyn ApplyInverse<B>>) -> Self {
        Precond {
            inv_diag: None,
            external,
            floored: 0,
        }
    }

    /// Diagonal entries Jacobi floored (0 without a preconditioner).
    pub(crate) fn floored(&self) -> usize {
        self.floored
    }

    /// `D⁻¹` for Jacobi, `None` for `M = I` (for kernels that fuse it).
    pub(crate) fn inverse_diagonal(&self) -> Option<&B::Vector> {
        self.inv_diag.as_ref()
    }

    /// Whether `M = I` (no work, no scratch).
    fn is_identity(&self) -> bool {
        self.inv_diag.is_none() && self.external.is_none()
    }

    /// Scratch space for [`Precond::apply`]: `n` entries, or none for `M = I`.
    pub fn scratch(&self, be: &B, n: usize) -> B::Vector {
        be.zeros(if self.is_identity() { 0 } else { n })
    }

    /// `M⁻¹ r`: `r` itself for `M = I`, else written to `z` (from
    /// [`Precond::scratch`]) and returned.
    pub fn apply<'a>(&self, be: &B, r: &'a B::Vector, z: &'a mut B::Vector) -> &'a B::Vector {
        match (&self.inv_diag, self.external) {
            (Some(inv), _) => {
                be.pointwise_mul(inv, r, z);
                z
            }
            (None, Some(pre)) => {
                pre.apply_inverse(r, z);
                z
            }
            (None, None) => r,
        }
    }
}
