//! `cgfem-gpu reproduce table2`: the paper's Table 2 (accumulated Krylov
//! iterations of the contact problem, Problem 2, with and without the
//! S-term) side by side with ours, as `table2.json` (rows, each with its
//! load-step history), `table2.md` and `table2.svg`.
//!
//! Runs `cases/annuli_contact.toml` (two plane-strain rings, 5 load steps)
//! at each level twice: without the S-term (`k2 = 0`) and with it
//! (`k2 = 0.01`, `A = 1 %`, the first configuration of Table 1; the paper
//! does not give Problem 2's). Both runs carry the case's recovered contact
//! traction, and the recovered terms are evaluated once per load step, at
//! its start, and held for its Newton solve ([`RecoveryMode::Step`]: "the
//! S-stabilisation recovered from the current configuration at each step"),
//! so each step is one Newton loop and the S-term adds no Newton
//! work of its own. (Refreshed after every Newton update,
//! [`RecoveryMode::Embedded`], the lagged terms add Newton iterations; in
//! passes, whole Newton solves.) With each of the given Krylov methods
//! (CGS, the paper's, and BiCGStab, the case's own) and preconditioners.
//! The accumulated iterations are every Krylov iteration of the run: all linear solves of all Newton iterations of all fixed-point
//! passes of all step attempts (failed attempts and failed solves included:
//! they were spent).
//!
//! Preconditioners: the bodies' multigrid ([`crate::bodies::multigrid`],
//! the default) and Jacobi. Unpreconditioned CGS (what the paper's Matlab
//! `cgs` call would run) does not converge on these rings here, with or
//! without the S-term, already at level 3: the Dirichlet and contact
//! penalties (`30 E/h`) sit beside entries of order `E h`, and CGS diverges
//! (the case's 20 000-iteration budget ends with a true relative residual
//! of ~1e10). With Jacobi, CGS still diverges on some tangents (from level
//! 4), which the load-step cutting absorbs or not (at level 5 it does not);
//! BiCGStab does not. With the multigrid V-cycle both converge at every
//! level, with the same contact forces.

use std::path::Path;
use std::time::Instant;

use serde::Serialize;

use super::{write_outputs, Runs};
use crate::bodies::run::run_setup;
use crate::bodies::setup::BodiesSetup;
use crate::case::physics::RecoveryMode;
use crate::case::Case;
use crate::error::Result;
use crate::fem::level::pathological_cells;
use crate::plot::{Chart, Series};
use crate::progress::{Progress, Silent};
use crate::report::newton::LoadStepRow;
use crate::solver::{KrylovMethod, Preconditioner};

/// `k2` of the stabilised runs.
pub const K2: f64 = 0.01;
/// `A` of both runs (Ω* is counted for the unstabilised run too).
pub const A: f64 = 0.01;

/// One run of `table2.json`.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Table2Row {
    pub level: u32,
    /// `k2` of the run (0: without the S-term).
    pub k2: f64,
    #[serde(rename = "A")]
    pub a: f64,
    pub method: String,
    pub preconditioner: String,
    pub dofs: usize,
    /// Ω* cells over both bodies (with `A`, whether or not the S-term is on).
    pub pathological: usize,
    /// Did all 5 load steps converge?
    pub converged: bool,
    pub failure: Option<String>,
    /// Krylov iterations of the whole run (every attempt, pass and solve).
    pub krylov_iterations: usize,
    /// Newton iterations of the whole run (every attempt and pass).
    pub newton_iterations: usize,
    /// Linear solves of the whole run (the last of each pass checks convergence).
    pub solves: usize,
    /// Converged load steps.
    pub load_steps: usize,
    /// Step attempts that failed (each followed by a cut).
    pub failed_attempts: usize,
    /// Fixed-point passes of all attempts (one per attempt without S).
    pub passes: usize,
    /// Solve time in seconds (set-up excluded).
    pub seconds: f64,
    /// The paper's accumulated CGS iterations at this level, with or without S.
    pub paper_iterations: Option<usize>,
    /// Every step attempt, as in the run's report.
    pub steps: Vec<LoadStepRow>,
}

/// The paper's Table 2 (CGS), with (`true`) or without the S-term.
pub fn paper_iterations(level: u32, stabilised: bool) -> Option<usize> {
    match (level, stabilised) {
        (3, true) => Some(1223),
        (4, true) => Some(2171),
        (5, true) => Some(4296),
        (3, false) => Some(1161),
        (4, false) => Some(2276),
        (5, false) => Some(5698),
        _ => None,
    }
}

/// Runs `case` (the annuli) at `levels` without and with the S-term and
/// writes the files; each run is reported to `progress` ([`crate::progress::Phase::Runs`]).
pub fn table2(
    case: &Case,
    levels: &[u32],
    solvers: &[(KrylovMethod, Preconditioner)],
    out: &Path,
    progress: &dyn Progress,
) -> Result<Vec<Table2Row>> {
    let runs = Runs::start(progress, 2 * levels.len() * solvers.len());
    let mut rows = Vec::new();
    for (&solver, &level) in solvers
        .iter()
        .flat_map(|m| levels.iter().map(move |l| (m, l)))
    {
        for k2 in [0.0, K2] {
            let row = run(case, level, k2, solver)?;
            runs.done(format!(
                "table2 {} level {level}, k2 = {k2}: {} Krylov, {} Newton iterations, {} passes, {}",
                row.solver(),
                row.krylov_iterations,
                row.newton_iterations,
                row.passes,
                if row.converged { "converged" } else { "failed" }
            ));
            rows.push(row);
        }
    }
    runs.finish();
    let json = serde_json::json!({ "rows": rows });
    write_outputs(
        out,
        "table2",
        &json,
        &markdown(&rows),
        &chart(&rows).to_svg()?,
    )?;
    Ok(rows)
}

/// One run at `level` with the S-term weight `k2` and the Krylov method and
/// preconditioner `solver`; a failed solve is a measurement (the row says
/// so), a failed set-up an error.
fn run(
    case: &Case,
    level: u32,
    k2: f64,
    (method, preconditioner): (KrylovMethod, Preconditioner),
) -> Result<Table2Row> {
    let mut case = case.clone();
    case.spec.stabilisation.k2 = k2;
    case.spec.stabilisation.a = Some(A);
    case.spec.solver.method = method;
    case.spec.solver.preconditioner = preconditioner;
    case.spec.newton.recovery = RecoveryMode::Step;
    let setup = BodiesSetup::new(&case, Some(level), &Silent)?;
    let pathological = setup
        .bodies
        .iter()
        .map(|b| pathological_cells(&b.cells, A).len())
        .sum();
    let t = Instant::now();
    let outcome = run_setup(&case, setup, None, &Silent)?;
    let seconds = t.elapsed().as_secs_f64();
    let sol = &outcome.solution;
    let steps = outcome
        .report
        .load
        .map(|l| l.load_steps)
        .unwrap_or_default();
    Ok(Table2Row {
        level,
        k2,
        a: A,
        method: case.spec.solver.method.name().into(),
        preconditioner: format!("{:?}", case.spec.solver.preconditioner).to_lowercase(),
        dofs: outcome.report.dofs,
        pathological,
        converged: outcome.result.is_ok(),
        failure: outcome.result.err().map(|e| e.to_string()),
        krylov_iterations: sol.krylov_iterations(),
        newton_iterations: sol.attempts.iter().map(|a| a.alphas.len()).sum(),
        solves: sol.attempts.iter().map(|a| a.krylov_iterations.len()).sum(),
        load_steps: sol.converged_steps,
        failed_attempts: sol.attempts.iter().filter(|a| !a.converged).count(),
        passes: sol.attempts.iter().map(|a| a.passes.len()).sum(),
        seconds,
        paper_iterations: paper_iterations(level, k2 > 0.0),
        steps,
    })
}

impl Table2Row {
    /// `method + preconditioner`, e.g. `cgs + jacobi`.
    pub fn solver(&self) -> String {
        format!("{} + {}", self.method, self.preconditioner)
    }
}

/// The run of `rows` with `solver` at `level` with (`true`) or without the S-term.
fn find<'r>(
    rows: &'r [Table2Row],
    solver: &str,
    level: u32,
    stabilised: bool,
) -> Option<&'r Table2Row> {
    rows.iter()
        .find(|r| r.solver() == solver && r.level == level && (r.k2 > 0.0) == stabilised)
}

fn markdown(rows: &[Table2Row]) -> String {
    let mut s = String::from(
        "# Table 2: accumulated Krylov iterations of the contact problem (Problem 2)\n\n\
         Two plane-strain rings in contact (cases/annuli_contact.toml), 5 load steps,\n\
         per Krylov method and preconditioner. Accumulated iterations: every Krylov iteration of\n\
         the run (all attempts, fixed-point passes and Newton solves, failed ones\n\
         included). The paper's column is its CGS count.\n",
    );
    s += &format!("With S: k2 = {K2}, A = {A}. Ω*: pathological cells of both bodies.\n\n");
    s += "| solver | level | S-term | Ω* cells | converged | Krylov iterations | per solve | Newton iterations | load steps (failed attempts) | passes | seconds | paper (CGS) |\n";
    s += "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for r in rows {
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {:.0} | {} | {} ({}) | {} | {:.1} | {} |\n",
            r.solver(),
            r.level,
            if r.k2 > 0.0 { "with" } else { "without" },
            r.pathological,
            if r.converged { "yes" } else { "no" },
            r.krylov_iterations,
            r.krylov_iterations as f64 / r.solves.max(1) as f64,
            r.newton_iterations,
            r.load_steps,
            r.failed_attempts,
            r.passes,
            r.seconds,
            r.paper_iterations
                .map_or_else(|| "–".into(), |p| p.to_string())
        );
    }
    s += "\n## Without / with the S-term\n\n";
    s += "| solver | level | ours: without / with | both converged | paper (CGS): without / with |\n";
    s += "|---|---|---|---|---|\n";
    let mut runs: Vec<(String, u32)> = rows.iter().map(|r| (r.solver(), r.level)).collect();
    runs.dedup();
    for (solver, level) in runs {
        let pair = (
            find(rows, &solver, level, true),
            find(rows, &solver, level, false),
        );
        if let (Some(w), Some(o)) = pair {
            let paper = match (
                paper_iterations(level, false),
                paper_iterations(level, true),
            ) {
                (Some(a), Some(b)) => format!("{:.2}", a as f64 / b as f64),
                _ => "–".into(),
            };
            s += &format!(
                "| {solver} | {level} | {:.2} | {} | {paper} |\n",
                o.krylov_iterations as f64 / w.krylov_iterations as f64,
                if w.converged && o.converged {
                    "yes"
                } else {
                    "no"
                }
            );
        }
    }
    s += "\nA ratio above 1 means the S-term lowered the accumulated iterations\n\
          (meaningful only where both runs converged).\n\
          Both runs recover the contact traction, and the S run its displacement,\n\
          once per load step, at its start, held for the step's Newton solve.\n\
          Failed runs are listed with their iterations up to the failure.\n";
    for r in rows.iter().filter(|r| !r.converged) {
        s += &format!(
            "\n{} level {}, k2 = {}: {}\n",
            r.solver(),
            r.level,
            r.k2,
            r.failure.as_deref().unwrap_or("")
        );
    }
    s
}

/// Accumulated iterations against the level: ours per solver and the
/// paper's (CGS), with and without the S-term.
fn chart(rows: &[Table2Row]) -> Chart {
    let mut solvers: Vec<String> = rows.iter().map(Table2Row::solver).collect();
    solvers.sort();
    solvers.dedup();
    let mut series = Vec::new();
    for (stabilised, name) in [(true, "with S"), (false, "without S")] {
        let pick = |r: &&Table2Row| (r.k2 > 0.0) == stabilised;
        for solver in &solvers {
            series.push(Series {
                label: format!("ours, {solver}, {name}"),
                points: rows
                    .iter()
                    .filter(pick)
                    .filter(|r| &r.solver() == solver)
                    .map(|r| (r.level as f64, r.krylov_iterations as f64))
                    .collect(),
                reference: false,
            });
        }
        let mut levels: Vec<u32> = rows.iter().map(|r| r.level).collect();
        levels.sort_unstable();
        levels.dedup();
        series.push(Series {
            label: format!("paper (CGS), {name}"),
            points: levels
                .iter()
                .filter_map(|&l| paper_iterations(l, stabilised).map(|p| (l as f64, p as f64)))
                .collect(),
            reference: true,
        });
    }
    Chart {
        title: "Table 2: accumulated Krylov iterations, contact of two rings".into(),
        x_label: "level".into(),
        y_label: "Krylov iterations".into(),
        x_log: false,
        series,
    }
}
