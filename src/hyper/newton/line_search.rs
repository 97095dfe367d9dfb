//! The backtracking line search on `‖R‖` of a Newton update, with the
//! non-monotone fallback (module doc of [`super`], *Newton–Raphson*).

use super::{norm, NonlinearProblem};

/// Newton iterations of one solve that may take a step without a decrease of
/// `‖R‖` (module doc, *Newton–Raphson*).
pub(super) const NON_MONOTONE_STEPS: usize = 3;

/// A point of the line search: `α`, `R(u + α du)`, and whether it passed
/// the Armijo test.
pub(super) struct Trial {
    pub alpha: f64,
    pub residual: Vec<f64>,
    pub decreased: bool,
}

/// Backtracking on `‖R‖`: the first `α = 2^-j` with
/// `‖R(u + α du)‖ ≤ (1 − 10⁻⁴ α) ‖R(u)‖`; if none passes, the trial with
/// the smallest `‖R‖` (`decreased = false`). Without backtracking (`None`)
/// the full step is taken wherever `R` is defined. `None` when `R` is
/// undefined (an inverted element) at every trial.
pub(super) fn line_search(
    p: &dyn NonlinearProblem,
    t: f64,
    u: &[f64],
    du: &[f64],
    r: &[f64],
    max_backtracks: Option<usize>,
) -> Option<Trial> {
    let r_norm = norm(r);
    let mut alpha = 1.0;
    let mut best: Option<(f64, Trial)> = None;
    for _ in 0..=max_backtracks.unwrap_or(0) {
        let trial: Vec<f64> = u.iter().zip(du).map(|(x, d)| x + alpha * d).collect();
        if let Some(residual) = p.residual(&trial, t) {
            let size = norm(&residual);
            if max_backtracks.is_none() || size <= (1.0 - 1e-4 * alpha) * r_norm {
                return Some(Trial {
                    alpha,
                    residual,
                    decreased: true,
                });
            }
            if best.as_ref().is_none_or(|(b, _)| size < *b) {
                let trial = Trial {
                    alpha,
                    residual,
                    decreased: false,
                };
                best = Some((size, trial));
            }
        }
        alpha *= 0.5;
    }
    best.map(|(_, trial)| trial)
}
