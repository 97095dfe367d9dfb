//! `cgfem-gpu reproduce`: the paper's results regenerated beside the paper's
//! figures, each as `DIR/<what>.json` (rows), `DIR/<what>.md` and
//! `DIR/<what>.svg`.
//!
//! - [`table1()`]: κ of the sphere with and without the S-term (Table 1);
//! - [`fig3()`]: energy-norm convergence of the sphere with and without it (Figure 3);
//! - [`cut_sweep()`]: κ and Krylov iterations over random grid offsets;
//! - [`table2()`]: accumulated Krylov iterations of the contact problem
//!   (Problem 2) with and without the S-term (Table 2).
//!
//! The first three run the paper's Problem 1 through one routine,
//! [`run_sphere`], with the paper's settings whatever the case file says
//! (its fixed point, CGS with Jacobi, its k2 and A); [`table2()`] runs the multi-body solve of [`crate::bodies`].

pub mod cut_sweep;
pub mod fig3;
pub mod table1;
pub mod table2;

use std::path::Path;

use crate::case::physics::OuterMethod;
use crate::case::Case;
use crate::condition::{condition_number, ConditionEstimate, ConditionOptions};
use crate::discrete::field::error_norms;
use crate::driver::fixed_point::FixedPointReport;
use crate::driver::linear::{CpuSolver, LinearSolver};
use crate::driver::setup::Setup;
use crate::driver::solve::solve;
use crate::element::ElementOrder;
use crate::error::{Error, Result};
use crate::output::write_atomic;
use crate::progress::{Event, Phase, Progress};
use crate::solver::{KrylovMethod, Preconditioner};

pub use cut_sweep::{cut_sweep, CutSweepOptions};
pub use fig3::{fig3, Fig3Curves};
pub use table1::table1;
pub use table2::table2;

/// One run of the sphere: the stabilisation, the grid, the solver variant.
#[derive(Clone, Debug)]
pub struct RunConfig {
    pub level: u32,
    /// `k2` of the S-term (0: off) and the pathological threshold `A`.
    pub k2: f64,
    pub a: f64,
    /// Grid offset in cells.
    pub offset: [f64; 3],
    /// Overrides the case's Krylov method and preconditioner.
    pub method: Option<KrylovMethod>,
    pub preconditioner: Option<Preconditioner>,
    /// Overrides the case's per-solve Krylov budget.
    pub max_iterations: Option<usize>,
    /// Estimate κ (plain and Jacobi-scaled) of the assembled operator.
    pub condition: bool,
    /// Solve (and measure the error) at all.
    pub solve: bool,
    /// Only the first solve `A U_0 = F` (no fixed-point loop, no error norm):
    /// the matrix's own difficulty for the Krylov method.
    pub first_solve_only: bool,
}

impl RunConfig {
    /// The case's own settings at `level`, with the S-term as given.
    pub fn new(level: u32, k2: f64, a: f64) -> Self {
        RunConfig {
            level,
            k2,
            a,
            offset: [0.0; 3],
            method: None,
            preconditioner: None,
            max_iterations: None,
            condition: false,
            solve: true,
            first_solve_only: false,
        }
    }
}

/// What a run measured.
#[derive(Clone, Debug)]
pub struct RunOutcome {
    pub h: f64,
    pub dofs: usize,
    pub pathological: usize,
    pub kappa: Option<ConditionEstimate>,
    pub kappa_jacobi: Option<ConditionEstimate>,
    /// Krylov iterations accumulated over the fixed-point loop.
    pub krylov_iterations: usize,
    /// Iterations of the first solve (`A U_0 = F`, nothing recovered yet):
    /// the matrix's own difficulty, free of the fixed-point loop.
    pub first_solve_iterations: usize,
    /// Did every solve and the loop converge?
    pub converged: bool,
    /// The solver's failure, if any.
    pub failure: Option<String>,
    /// `‖u − u_h‖_E` when the solve converged.
    pub energy_error: Option<f64>,
}

/// Runs the sphere `case` as configured. Krylov failures are measurements here
/// (the outcome says so); set-up failures are errors.
pub fn run_sphere(case: &Case, cfg: &RunConfig) -> Result<RunOutcome> {
    let mut case = case.clone();
    // The paper's loop: its accumulated iterations are what is reproduced.
    case.spec.solver.outer = OuterMethod::Picard;
    // The paper's S-term, whose right-hand side is not balanced.
    case.spec.stabilisation.balanced = Some(false);
    case.spec.stabilisation.k2 = cfg.k2;
    case.spec.stabilisation.a = Some(cfg.a);
    // The paper's solver: CGS with Jacobi (CG on Q2, where CGS diverges even
    // with the S-term), at most 50 outer iterations.
    case.spec.solver.method = match case.body().spec.element {
        ElementOrder::Q1 => KrylovMethod::Cgs,
        ElementOrder::Q2 => KrylovMethod::Cg,
    };
    case.spec.solver.preconditioner = Preconditioner::Jacobi;
    case.spec.solver.max_fixed_point = 50;
    case.bodies[0].spec.grid.offset = cfg.offset;
    if let Some(m) = cfg.method {
        case.spec.solver.method = m;
    }
    if let Some(p) = cfg.preconditioner {
        case.spec.solver.preconditioner = p;
    }
    if let Some(m) = cfg.max_iterations {
        case.spec.solver.max_iterations = m;
    }
    let setup = Setup::new(&case, Some(cfg.level))?;
    let mut out = RunOutcome {
        h: setup.grid.h,
        dofs: setup.op.dofs.ndofs(),
        pathological: setup.omega_star.len(),
        kappa: None,
        kappa_jacobi: None,
        krylov_iterations: 0,
        first_solve_iterations: 0,
        converged: false,
        failure: None,
        energy_error: None,
    };
    if cfg.condition {
        let matrix = setup.op.assemble();
        let opts = ConditionOptions::default();
        out.kappa = Some(condition_number(&matrix, false, &opts)?);
        out.kappa_jacobi = Some(condition_number(&matrix, true, &opts)?);
    }
    if !cfg.solve {
        return Ok(out);
    }
    if cfg.first_solve_only {
        let opts = crate::driver::solve::fixed_point_options(&case.spec.solver).krylov;
        let mut u = vec![0.0; setup.fixed_rhs.len()];
        match CpuSolver::for_setup(&setup).solve(&setup.fixed_rhs, &mut u, &opts) {
            Ok(stats) => {
                out.first_solve_iterations = stats.iterations;
                out.krylov_iterations = stats.iterations;
                out.converged = true;
            }
            Err(e) => {
                if let Error::MaxIterations { iterations, .. }
                | Error::Breakdown { iterations, .. } = &e
                {
                    out.first_solve_iterations = *iterations;
                    out.krylov_iterations = *iterations;
                    out.failure = Some(e.to_string());
                } else {
                    return Err(e);
                }
            }
        }
        return Ok(out);
    }
    let mut report = FixedPointReport::default();
    let result = solve(&setup, &case.spec.solver, &mut report);
    out.krylov_iterations = report.total_iterations;
    out.first_solve_iterations = report.iterations_per_solve.first().copied().unwrap_or(0);
    match result {
        Ok(solution) => {
            out.converged = report.converged || report.iterations == 0;
            if let Some(exact) = &setup.problem.exact {
                let e = error_norms(
                    &setup.grid,
                    &setup.cells,
                    &setup.op.dofs,
                    &solution.u,
                    exact,
                    setup.problem.lambda,
                    setup.problem.mu,
                );
                out.energy_error = Some(e.energy);
            }
        }
        Err(e @ (Error::MaxIterations { .. } | Error::Breakdown { .. })) => {
            out.failure = Some(e.to_string());
        }
        Err(e) => return Err(e),
    }
    Ok(out)
}

/// The runs of one result as a [`Phase::Runs`] of `progress`: started with
/// their count, each reported with a summary line, then finished.
pub struct Runs<'a> {
    progress: &'a dyn Progress,
}

impl<'a> Runs<'a> {
    /// Starts the phase of `total` runs.
    pub fn start(progress: &'a dyn Progress, total: usize) -> Self {
        progress.event(&Event::Start {
            phase: Phase::Runs,
            total: Some(total as u64),
        });
        Runs { progress }
    }

    /// One run ended; `summary` says what it measured.
    pub fn done(&self, summary: String) {
        self.progress.event(&Event::RunDone { summary });
        self.progress.event(&Event::Advance {
            phase: Phase::Runs,
            steps: 1,
        });
    }

    /// Every run ended.
    pub fn finish(&self) {
        self.progress.event(&Event::Finish { phase: Phase::Runs });
    }
}

/// The observed rate `log(e_c/e_f) / log(h_c/h_f)` between two runs.
pub fn rate(coarse: (f64, f64), fine: (f64, f64)) -> f64 {
    (coarse.1 / fine.1).ln() / (coarse.0 / fine.0).ln()
}

/// The median of `v` (the mean of the middle two for even lengths); NaN if empty.
pub fn median(v: &[f64]) -> f64 {
    let mut s: Vec<f64> = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    match s.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => s[n / 2],
        n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

/// Writes `DIR/<name>.json`, `.md` and `.svg`, each atomically.
fn write_outputs(
    out: &Path,
    name: &str,
    json: &serde_json::Value,
    md: &str,
    svg: &str,
) -> Result<()> {
    std::fs::create_dir_all(out).map_err(|e| Error::Io {
        path: out.display().to_string(),
        reason: e.to_string(),
    })?;
    let text = serde_json::to_string_pretty(json).map_err(|e| Error::Io {
        path: out.join(format!("{name}.json")).display().to_string(),
        reason: e.to_string(),
    })?;
    write_atomic(&out.join(format!("{name}.json")), text.as_bytes())?;
    write_atomic(&out.join(format!("{name}.md")), md.as_bytes())?;
    write_atomic(&out.join(format!("{name}.svg")), svg.as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_and_rate() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert!(median(&[]).is_nan());
        assert!((rate((0.2, 0.04), (0.1, 0.01)) - 2.0).abs() < 1e-14);
    }
}
