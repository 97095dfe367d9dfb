//! The settings of the nonlinear solve ([`NewtonOptions`]) and when its
//! recovered terms are re-evaluated ([`RecoveryMode`]).

use crate::case::physics::RecoveryMode;
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
}

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
        }
    }
}

impl NewtonOptions {
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
