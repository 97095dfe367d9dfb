//! What a nonlinear solve leaves behind: every load-step attempt with its
//! Newton, energy and Krylov histories ([`StepReport`], [`PassReport`]),
//! and the last converged state ([`HyperSolution`]).

use super::NonlinearProblem;

/// One attempt at a load step, converged or not.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepReport {
    /// Load factor at the start and at the end of the step.
    pub from: f64,
    pub to: f64,
    /// Halvings of the nominal increment at this attempt.
    pub cuts: usize,
    pub converged: bool,
    /// `‖R(u_k)‖ / ‖R(u_0)‖`, from `k = 0` (= 1).
    pub residuals: Vec<f64>,
    /// `|Δu_k · R(u_k)| / |Δu_0 · R(u_0)|` per linear solve.
    pub energies: Vec<f64>,
    /// Line-search step length per update `u_k → u_{k+1}`.
    pub alphas: Vec<f64>,
    /// Krylov iterations per linear solve (a failed solve's included, as
    /// the last entry of a failed attempt).
    pub krylov_iterations: Vec<usize>,
    /// The Newton passes of the fixed point on recovered terms (one pass
    /// without such terms); the histories above are theirs, concatenated.
    pub passes: Vec<PassReport>,
    /// Why the attempt failed.
    pub failure: Option<String>,
}

/// One Newton pass of a step (see the module doc, *Recovered terms*).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct PassReport {
    /// Newton updates of the pass (its entries of `alphas`).
    pub newton_iterations: usize,
    /// Krylov iterations of the pass, summed.
    pub krylov_iterations: usize,
    /// `ε_k` after the pass (`None` without recovered terms).
    pub change: Option<f64>,
}

/// The state of a nonlinear solve: the last converged displacement and load
/// factor, and every step attempt.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HyperSolution {
    pub u: Vec<f64>,
    pub load_factor: f64,
    /// Converged steps so far.
    pub converged_steps: usize,
    pub attempts: Vec<StepReport>,
}

impl HyperSolution {
    /// The undeformed start of `problem`.
    pub fn zero(problem: &dyn NonlinearProblem) -> HyperSolution {
        HyperSolution {
            u: vec![0.0; problem.ndofs()],
            ..HyperSolution::default()
        }
    }

    /// Newton iterations of the converged steps.
    pub fn newton_iterations(&self) -> usize {
        self.attempts
            .iter()
            .filter(|a| a.converged)
            .map(|a| a.alphas.len())
            .sum()
    }

    /// Krylov iterations of every attempt (failed ones included: they were spent).
    pub fn krylov_iterations(&self) -> usize {
        self.attempts
            .iter()
            .flat_map(|a| &a.krylov_iterations)
            .sum()
    }
}
