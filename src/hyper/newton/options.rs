//! The settings of the nonlinear solve ([`NewtonOptions`]), when its
//! recovered terms are re-evaluated ([`RecoveryMode`]) and how tightly its
//! linear solves are converged ([`Forcing`], [`NewtonOptions::krylov_tol`]).

use crate::case::physics::{Forcing, RecoveryMode};
use crate::error::{Error, Result};
use crate::solver::{KrylovMethod, KrylovOptions, Preconditioner};

/// Settings of the nonlinear solve.
#[derive(Clone, Debug, PartialEq)]
pub struct NewtonOptions {
    /// Number of nominal load steps (≥ 1).
    pub steps: usize,
    /// Newton iterations allowed per step.
    pub max_iterations: usize,
    /// Relative residual tolerance (see the module doc).
    pub residual_tol: f64,
    /// Relative energy-norm tolerance of the increment.
    pub energy_tol: f64,
    /// Halvings allowed per increment before the solve fails.
    pub max_cuts: usize,
    /// Backtracking halvings per line search.
    pub max_backtracks: usize,
    /// `false`: take the full Newton step (`α = 1`) without checking that the
    /// residual decreases.
    pub line_search: bool,
    /// The inner linear solves.
    pub krylov: KrylovOptions,
    /// Tolerance of `ε_k` between fixed-point passes (recovered terms only).
    pub fixed_point_tol: f64,
    /// Newton passes allowed per step when the problem has recovered terms.
    pub max_fixed_point: usize,
    /// How recovered terms are brought up to date (module doc).
    pub recovery: RecoveryMode,
    /// How tightly each iteration's linear solve is converged.
    pub forcing: Forcing,
}

/// The loosest relative tolerance of an adaptive linear solve whose `Δu`
/// updates the iterate. Looser (1e-2) moved the partial-slip steps of
/// `cases/mindlin.toml` by 0.3 % and a step of the annuli on a curved master
/// by 7e-4: where the contact state depends on the path, the first
/// iterations must follow the exact Newton path closely enough.
pub const LOOSEST_FORCING: f64 = 1e-4;

/// The tolerance of a solve at a state that already passes `residual_tol`,
/// whose `Δu` first only decides the energy test.
pub const CHECK_FORCING: f64 = 1e-2;

/// The library's defaults, which the unit tests build on: Jacobi, exact
/// solves to 1e-10 ([`Forcing::Fixed`]). A case file's `[newton]` and
/// `[solver]` have their own defaults (`crate::case::physics`: multigrid,
/// adaptive forcing).
impl Default for NewtonOptions {
    fn default() -> Self {
        NewtonOptions {
            steps: 1,
            max_iterations: 25,
            residual_tol: 1e-8,
            energy_tol: 1e-12,
            max_cuts: 5,
            max_backtracks: 10,
            line_search: true,
            krylov: KrylovOptions {
                method: KrylovMethod::BiCgStab,
                preconditioner: Preconditioner::Jacobi,
                rel_tol: 1e-10,
                max_iterations: 20_000,
            },
            fixed_point_tol: 1e-6,
            max_fixed_point: 30,
            recovery: RecoveryMode::Passes,
            forcing: Forcing::Fixed,
        }
    }
}

impl NewtonOptions {
    /// The relative tolerance of the linear solve whose `Δu` updates an
    /// iterate whose residual is `relative_residual` of the step's
    /// reference: [`Forcing::Adaptive`], `η = ‖R_k‖/‖R_0‖` held between
    /// `krylov.rel_tol` and [`LOOSEST_FORCING`], which keeps Newton
    /// quadratic (the solve's error is of the order of the
    /// linearisation's); [`Forcing::Fixed`], `krylov.rel_tol`.
    pub fn krylov_tol(&self, relative_residual: f64) -> f64 {
        let floor = self.krylov.rel_tol;
        match self.forcing {
            Forcing::Fixed => floor,
            Forcing::Adaptive => relative_residual.min(LOOSEST_FORCING).max(floor),
        }
    }

    /// [`Forcing::Adaptive`] at an iterate whose residual already passes
    /// `residual_tol`: the tolerance of a first solve that only feeds the
    /// energy test, which needs `Δu` to a few digits ([`CHECK_FORCING`]);
    /// `None` otherwise.
    pub fn check_tol(&self, relative_residual: f64) -> Option<f64> {
        (self.forcing == Forcing::Adaptive && relative_residual <= self.residual_tol)
            .then(|| CHECK_FORCING.max(self.krylov.rel_tol))
    }

    /// Checks the ranges (a step count of zero is bad input).
    pub fn validate(&self) -> Result<()> {
        let bad = |what: &str, reason: String| {
            Err(Error::InvalidSolverOptions {
                what: what.into(),
                reason,
            })
        };
        if self.steps == 0 {
            return bad("steps", "must be at least 1".into());
        }
        if self.max_iterations == 0 {
            return bad("max_iterations", "must be at least 1".into());
        }
        if self.max_fixed_point == 0 {
            return bad("max_fixed_point", "must be at least 1".into());
        }
        for (name, v) in [
            ("residual_tol", self.residual_tol),
            ("energy_tol", self.energy_tol),
            ("fixed_point_tol", self.fixed_point_tol),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return bad(name, format!("must be finite and positive, got {v}"));
            }
        }
        self.krylov.validate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Adaptive: the relative residual, held in `[rel_tol, 1e-4]`, with a
    /// 1e-2 check once the residual passes `residual_tol`; fixed: `rel_tol`
    /// always, and no check.
    #[test]
    fn the_krylov_tolerance_follows_the_residual() {
        let mut opts = NewtonOptions {
            forcing: Forcing::Adaptive,
            residual_tol: 1e-8,
            ..NewtonOptions::default()
        };
        opts.krylov.rel_tol = 1e-9;
        assert_eq!(opts.krylov_tol(1.0), 1e-4);
        assert_eq!(opts.krylov_tol(3e-5), 3e-5);
        assert_eq!(opts.krylov_tol(2e-8), 2e-8);
        assert_eq!(opts.krylov_tol(1e-13), 1e-9);
        assert_eq!(opts.check_tol(2e-8), None);
        assert_eq!(opts.check_tol(1e-8), Some(1e-2));
        assert_eq!(opts.check_tol(1e-13), Some(1e-2));
        opts.krylov.rel_tol = 0.5;
        assert_eq!(opts.krylov_tol(3e-5), 0.5);
        assert_eq!(opts.check_tol(1e-13), Some(0.5));
        opts.forcing = Forcing::Fixed;
        opts.krylov.rel_tol = 1e-9;
        for r in [1.0, 3e-4, 1e-13] {
            assert_eq!(opts.krylov_tol(r), 1e-9);
            assert_eq!(opts.check_tol(r), None);
        }
    }
}
