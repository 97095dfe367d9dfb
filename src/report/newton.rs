//! The Newton path's part of a report: the load steps with their Newton
//! histories, and the reaction rows (which the linear path writes too, as
//! one step).

use serde::Serialize;

/// The load steps of a Newton run (flattened into the report).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct LoadReport {
    /// Nominal load steps, and the converged ones.
    pub steps: usize,
    pub converged_steps: usize,
    /// The last converged load factor.
    pub load_factor: f64,
    pub load_steps: Vec<LoadStepRow>,
}

/// `newton` of a load step: its iterations and histories.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct NewtonHistory {
    /// Newton updates made.
    pub iterations: usize,
    /// `‖R_k‖ / ‖R_0‖`, from `k = 0`.
    pub residual_history: Vec<f64>,
    /// `|Δu_k · R_k| / |Δu_0 · R_0|` per linear solve.
    pub energy_history: Vec<f64>,
    /// Line-search step length per update.
    pub line_search: Vec<f64>,
    /// The estimated order `q` of the last iterations of the first pass, and `C` of
    /// `δ_n = C δ_{n−1}²`, from the corrections' energy norms
    /// (see [`crate::hyper::convergence`]); absent with fewer than three
    /// corrections above round-off.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub convergence_order: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub quadratic_constant: Option<f64>,
}

/// One attempt at a load step (failed attempts are followed by a cut one).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct LoadStepRow {
    /// The load step (from 1) this attempt tried to reach.
    pub step: usize,
    pub load_factor: f64,
    pub converged: bool,
    /// Halvings of the nominal increment at this attempt.
    pub cuts: usize,
    pub newton: NewtonHistory,
    /// Krylov iterations per linear solve.
    pub krylov_iterations: Vec<usize>,
    /// The Newton passes of the fixed point on recovered terms (one without).
    pub passes: Vec<crate::hyper::newton::PassReport>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub failure: Option<String>,
}

/// `reactions {body, part, step, force}`: the resultant of a Dirichlet part
/// at a converged load step.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ReactionRow {
    pub body: String,
    /// The boundary part's tag.
    pub part: String,
    pub step: usize,
    /// The force the prescribed displacement exerts on the body.
    pub force: [f64; 3],
}
