//! Condition numbers of the assembled stiffness matrix:
//! `κ(A) = λ_max / λ_min` on the active dofs, and the Jacobi-scaled
//! `κ(D^-1/2 A D^-1/2)`, `D = diag(A)`.
//!
//! - `λ_max`: Lanczos on `A` with full reorthogonalisation from a seeded start
//!   vector, until the top Ritz value is within `rel_tol_max` of an eigenvalue.
//! - `λ_min`: Lanczos on `A⁻¹` (shift-invert at zero), each step a solve with
//!   the sparse Cholesky factor `A = L Lᵀ`: its top Ritz value `θ` converges
//!   to `1/λ_min` (the well separated end of the spectrum of `A⁻¹`), within
//!   `rel_tol_min`.
//! - Trust in the factor: `1/θ` is the smallest eigenvalue of `L Lᵀ = A + ΔA`,
//!   not of `A`. Its Ritz vector, refined by two more solves, gives the Rayleigh
//!   quotient `ρ = zᵀ A z` computed with `A` itself. `λ_min = 1/θ` is accepted
//!   when `ρ` agrees with it to [`AGREEMENT`] and the rounding level of `ρ`
//!   resolves it, and `1/θ > RESOLUTION · λ_max`.
//! - Otherwise (the factorisation failed: `A` is not numerically positive
//!   definite; or `λ_min` is not resolved) the estimate is a **lower bound**:
//!   the plain Lanczos run goes on to converge its smallest Ritz value
//!   `θ_min ≥ λ_min`, and `κ ≥ λ_max / max(min(θ_min, ρ + rounding),
//!   RESOLUTION · λ_max)`, at most `1/RESOLUTION`.
//!
//! Ritz values lie inside the spectrum, so an unconverged run also gives a lower
//! bound (`θ_max ≤ λ_max`, `1/θ ≥ λ_min`); it is flagged the same way. The
//! Krylov bases are stored: memory is `n × steps` doubles per run.

pub(crate) mod sparse;
#[cfg(test)]
mod tests;

use faer::sparse::SparseColMat;
use serde::Serialize;

use crate::solver::lanczos::reorthogonalised::{End, Lanczos};
use crate::{Error, Result};
use sparse::Cholesky;

/// `λ_min ≤ RESOLUTION · λ_max` is below what f64 resolves (`ε ≈ 2.2e-16`):
/// the matrix is singular to working precision and `κ ≥ 1/RESOLUTION` is all
/// that can be said.
pub const RESOLUTION: f64 = 1e-16;
/// Relative agreement required between the shift-invert `λ_min` and the
/// Rayleigh quotient of `A` at its eigenvector (and bound on the rounding level
/// of that quotient relative to `λ_min`).
pub const AGREEMENT: f64 = 1e-2;
/// Inverse-iteration solves that refine the shift-invert Ritz vector before the
/// Rayleigh check (each damps the other eigencomponents by `λ_min / λ_i`).
const REFINEMENTS: usize = 2;

/// Options of [`condition_number`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConditionOptions {
    /// Lanczos steps at most per run (on `A`, on `A⁻¹`).
    pub max_steps: usize,
    /// Relative accuracy of `λ_max`.
    pub rel_tol_max: f64,
    /// Relative accuracy of `λ_min`.
    pub rel_tol_min: f64,
    /// Seed of the Lanczos start vector.
    pub seed: u64,
}

impl Default for ConditionOptions {
    fn default() -> Self {
        ConditionOptions {
            max_steps: 300,
            rel_tol_max: 1e-8,
            rel_tol_min: 1e-6,
            seed: 0x5EED,
        }
    }
}

impl ConditionOptions {
    /// `max_steps ≥ 1`, tolerances in `(0, 1)`.
    pub fn validate(&self) -> Result<()> {
        let invalid = |what: &str, reason: &str| {
            Err(Error::InvalidSolverOptions {
                what: what.into(),
                reason: reason.into(),
            })
        };
        if self.max_steps == 0 {
            return invalid("condition max_steps", "must be at least 1");
        }
        for (what, tol) in [
            ("condition rel_tol_max", self.rel_tol_max),
            ("condition rel_tol_min", self.rel_tol_min),
        ] {
            if !(tol > 0.0 && tol < 1.0) {
                return invalid(what, &format!("{tol} is not in (0, 1)"));
            }
        }
        Ok(())
    }
}

/// The estimate. `kappa = lambda_max / lambda_min` (at least 1). With
/// `kappa_is_lower_bound`, `lambda_min` is an upper bound of the true `λ_min`
/// (and `lambda_max` a lower bound of `λ_max`), so `kappa` is a lower bound;
/// `method` says why.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ConditionEstimate {
    pub lambda_max: f64,
    pub lambda_min: f64,
    pub kappa: f64,
    pub kappa_is_lower_bound: bool,
    pub method: String,
    /// Lanczos steps in all (products with `A` plus solves with `L Lᵀ`).
    pub lanczos_steps: usize,
}

/// `κ(A)`, or `κ(D^-1/2 A D^-1/2)` with `jacobi_scaled`, of the symmetric
/// matrix `a` (full storage); see the module doc.
///
/// # Errors
/// [`Error::InvalidSolverOptions`] for bad `opts`; [`Error::Breakdown`] when
/// `a` is not square or empty, has a non-finite entry, has a diagonal entry
/// negative beyond round-off (with `jacobi_scaled`; entries at round-off level
/// are floored as the Jacobi preconditioner floors them, and `method` says how
/// many) or no positive eigenvalue.
pub fn condition_number(
    a: &SparseColMat<usize, f64>,
    jacobi_scaled: bool,
    opts: &ConditionOptions,
) -> Result<ConditionEstimate> {
    opts.validate()?;
    check_matrix(a)?;
    let scaled;
    let mut floored = 0;
    let a = if jacobi_scaled {
        (scaled, floored) = sparse::jacobi_scaled(a)?;
        &scaled
    } else {
        a
    };
    let mut plain = Lanczos::new(a.nrows(), opts.seed);
    let matvec = |x: &[f64], y: &mut [f64]| sparse::matvec(a, x, y);
    let top = plain.run(matvec, End::Largest, opts.rel_tol_max, 0.0, opts.max_steps)?;
    let lambda_max = top.value;
    if lambda_max <= 0.0 || lambda_max.is_nan() {
        return Err(breakdown(format!(
            "largest eigenvalue {lambda_max:e} is not positive"
        )));
    }
    let (bottom, inverse_steps) = shift_invert(a, lambda_max, opts)?;
    let (lambda_min, lower_bound, note) = match bottom {
        Bottom::Resolved { value, converged } => {
            let converged = converged && top.converged;
            let note = match converged {
                true => "cholesky".to_string(),
                false => format!("not converged in {} steps: lower bound", opts.max_steps),
            };
            (value, !converged, note)
        }
        Bottom::Unresolved { upper, why } => {
            let floor = RESOLUTION * lambda_max;
            let low = plain.run(
                matvec,
                End::Smallest,
                opts.rel_tol_min,
                floor,
                opts.max_steps,
            )?;
            (
                low.value.min(upper).max(floor),
                true,
                format!("{why}: lower bound"),
            )
        }
    };
    Ok(ConditionEstimate {
        lambda_max,
        lambda_min,
        kappa: (lambda_max / lambda_min).max(1.0),
        kappa_is_lower_bound: lower_bound,
        method: format!(
            "lanczos{} + shift-invert lanczos ({note})",
            match (jacobi_scaled, floored) {
                (false, _) => String::new(),
                (true, 0) => " on D^-1/2 A D^-1/2".into(),
                (true, n) => format!(" on D^-1/2 A D^-1/2 ({n} diagonal entries floored)"),
            }
        ),
        lanczos_steps: plain.steps() + inverse_steps,
    })
}

/// What the shift-invert run says about `λ_min`.
enum Bottom {
    /// `λ_min = value`, trusted (see the module doc).
    Resolved { value: f64, converged: bool },
    /// `λ_min` not resolved: `upper` bounds it from above (∞ when nothing is
    /// known), `why` says why.
    Unresolved { upper: f64, why: String },
}

/// `λ_min` by Lanczos on `A⁻¹` and the Rayleigh check; also the steps taken.
fn shift_invert(
    a: &SparseColMat<usize, f64>,
    lambda_max: f64,
    opts: &ConditionOptions,
) -> Result<(Bottom, usize)> {
    let chol = match Cholesky::new(a) {
        Ok(chol) => chol,
        Err(reason) => {
            let why = format!("cholesky failed: {reason}");
            let upper = f64::INFINITY;
            return Ok((Bottom::Unresolved { upper, why }, 0));
        }
    };
    let solve = |x: &[f64], y: &mut [f64]| {
        y.copy_from_slice(x);
        chol.solve_in_place(y);
    };
    let mut inverse = Lanczos::new(a.nrows(), opts.seed);
    let top = inverse.run(solve, End::Largest, opts.rel_tol_min, 0.0, opts.max_steps)?;
    let mu = 1.0 / top.value;
    let mut z = inverse.ritz_vector(End::Largest);
    for _ in 0..REFINEMENTS {
        chol.solve_in_place(&mut z);
        let norm = z.iter().map(|v| v * v).sum::<f64>().sqrt();
        z.iter_mut().for_each(|v| *v /= norm);
    }
    let rho = sparse::rayleigh(a, &z);
    let resolved = mu.is_finite()
        && mu > RESOLUTION * lambda_max
        && rho.noise <= AGREEMENT * mu
        && (rho.value - mu).abs() <= AGREEMENT * mu;
    let bottom = match resolved {
        true => Bottom::Resolved {
            value: mu,
            converged: top.converged,
        },
        false => Bottom::Unresolved {
            upper: rho.value + rho.noise,
            why: format!("λ_min ≈ {mu:.3e} not resolved by the cholesky factor"),
        },
    };
    Ok((bottom, inverse.steps()))
}

/// `a` square, non-empty, with finite entries.
fn check_matrix(a: &SparseColMat<usize, f64>) -> Result<()> {
    let (n, m) = (a.nrows(), a.ncols());
    if n != m || n == 0 {
        return Err(breakdown(format!(
            "matrix is {n}×{m}, not square and non-empty"
        )));
    }
    if (0..n).any(|j| a.val_of_col(j).iter().any(|v| !v.is_finite())) {
        return Err(breakdown("matrix has a non-finite entry".into()));
    }
    Ok(())
}

fn breakdown(what: String) -> Error {
    Error::Breakdown {
        method: "condition number".into(),
        iterations: 0,
        what,
    }
}
