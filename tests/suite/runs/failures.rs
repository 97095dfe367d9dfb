//! Every way a run can fail in its solver (exit code 3), walked through the
//! binary: each exits 3, names the failure on stderr, and still writes
//! `report.json`, which parses, says `"status": "failed"` and names the
//! failure in `failure`, and lists no ParaView file, none of which is left in
//! the output folder. The triggers are case keys and `--set`, on grids of
//! level 3 at most:
//!
//! - linear path: a Krylov solve out of its budget (`solver.max_iterations`),
//!   the fixed point out of its budget (`solver.max_fixed_point`, FGMRES and
//!   Picard), a breakdown (the condition estimate's Lanczos on an operator
//!   whose entries overflow its products, `material.young = 1e300`), the
//!   stress recovery failing in the solve (a fin one cell thick, clamped, at
//!   level 2) and in the output, after the solve converged (the same fin
//!   loaded but not clamped: the solve recovers only at the clamped wall,
//!   the output everywhere), for each ParaView selection that recovers;
//! - Newton path (one neo-Hookean body): a load step out of Newton
//!   iterations (`newton.max_iterations`), a load step whose tangent solve
//!   fails (`solver.max_iterations`), and a load step whose recovered terms
//!   fail (the fin's S-term), each with `newton.max_cuts = 0` or failing
//!   at the first step, so that no step converged.
//!
//! Paths without a trigger from input, whose report is written by the same
//! code as the walked ones (the linear path's one failure branch in
//! `src/run/linear.rs`; on the Newton path `src/run/newton.rs`'s
//! set-up branch and the run's outcome):
//!
//! - a breakdown of the linear Krylov solve itself (CG's `p·Ap ≤ 0`, a
//!   vanishing bi-orthogonality before any progress, a non-finite value): the
//!   operator of a case that passes its checks is symmetric positive
//!   definite, and the inputs whose scale could make its products overflow
//!   or vanish are refused (`k1 E` overflowing, non-finite data, exit 2) or
//!   fail first in the recovery (`material.young` of 1e±200 and beyond);
//! - the set-up of a preconditioner: Jacobi's diagonal check and the
//!   multigrid's (the smoothers' diagonals and λ_max estimates, the coarsest
//!   level's Cholesky "non-positive pivot"), on the linear path and for the
//!   Newton path's per-body multigrid: a negative stiffness is refused at
//!   set-up (exit 2), non-finite entries by the overflow checks, and the
//!   coarsest factor's diagonal shifts (up to 1e-4 of the diagonal) factor
//!   every operator that is positive definite in exact arithmetic. The
//!   Newton path's Jacobi is set up inside the tangent solve, so its failure
//!   would be the walked "linear solve" step failure;
//! - the GPU backend's solves: no adapter is assumed here (`--backend cpu`);
//!   their failures return through the same closure as the CPU's.

use std::path::Path;

use serde_json::Value;

use crate::common;
use common::cli::run_case;
use common::{with_physics, SPHERE};

/// A fin one cell thick at level 2, loaded on `loaded`, clamped on
/// `clamped`, without the S-term unless `k2` is given, in `model`.
fn fin(clamped: &str, loaded: &str, model: &str, k2: f64) -> String {
    format!(
        r#"[geometry]
type = "union"
of = [
  {{ type = "cuboid", min = [0, 0, 0], max = [1, 1, 1] }},
  {{ type = "tag", name = "fin", of = {{ type = "cuboid", min = [0.9, 0.3, 0.47], max = [8, 0.7, 0.53] }} }},
]
[material]
model = "{model}"
young = 1000.0
poisson = 0.3
[dirichlet.{clamped}]
value = ["0", "0", "0"]
[neumann.{loaded}]
traction = ["0", "0", "-1"]
[stabilisation]
k2 = {k2}
"#
    )
}

/// A neo-Hookean unit cube, clamped on one face and stretched by a fifth on
/// the opposite one: one load step.
const STRETCHED_CUBE: &str = r#"[geometry]
type = "cuboid"
min = [0, 0, 0]
max = [1, 1, 1]
[material]
model = "neo_hookean"
young = 1000.0
poisson = 0.3
[dirichlet.xmin]
value = ["0", "0", "0"]
[dirichlet.xmax]
value = ["0.2", "0", "0"]
"#;

/// Whether `name` is a ParaView file.
fn is_paraview(name: &str) -> bool {
    [".vtu", ".vtp", ".pvd"].iter().any(|e| name.ends_with(e))
}

/// The ParaView files in `out`.
fn paraview_files(out: &Path) -> Vec<String> {
    std::fs::read_dir(out)
        .map(|d| {
            d.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .filter(|n| is_paraview(n))
                .collect()
        })
        .unwrap_or_default()
}

/// Runs `text` with `extra` and checks the failed run: exit code 3, each of
/// `needles` on stderr and in the report's `failure`, the report marked
/// failed, no ParaView file listed or left. Returns the report.
fn assert_failed(name: &str, text: &str, extra: &[&str], needles: &[&str]) -> Value {
    let (code, err, out) = run_case(name, text, extra);
    assert_eq!(code, 3, "{name}: exit {code}, stderr {err}");
    assert!(!err.contains("panicked"), "{name}: {err}");
    assert!(err.contains("report (marked failed)"), "{name}: {err}");
    let bytes = std::fs::read(out.join("report.json"))
        .unwrap_or_else(|e| panic!("{name}: no report.json ({e}); stderr {err}"));
    let report: Value = serde_json::from_slice(&bytes)
        .unwrap_or_else(|e| panic!("{name}: report.json does not parse: {e}"));
    assert_eq!(report["status"], "failed", "{name}");
    let failure = report["failure"].as_str().unwrap_or_default();
    for n in needles {
        assert!(err.contains(n), "{name}: '{n}' not on stderr: {err}");
        assert!(
            failure.contains(n),
            "{name}: '{n}' not in failure: {failure}"
        );
    }
    let listed = report["outputs"].as_array().expect("outputs");
    assert!(
        listed.iter().all(|f| !is_paraview(f.as_str().unwrap())),
        "{name}: listed {listed:?}"
    );
    assert_eq!(paraview_files(&out), Vec::<String>::new(), "{name}");
    report
}

#[test]
fn a_krylov_solve_out_of_its_budget_reports_the_failure() {
    assert_failed(
        "krylov_budget",
        &with_physics(SPHERE),
        &["--level", "3", "--set", "solver.max_iterations=3"],
        &["did not converge", "3 iterations"],
    );
}

#[test]
fn a_fixed_point_out_of_its_budget_reports_the_failure() {
    for (outer, needle) in [
        (
            "fgmres",
            "fixed point (fgmres) did not converge in 1 iterations",
        ),
        ("picard", "fixed point did not converge in 1 iterations"),
    ] {
        let report = assert_failed(
            &format!("fixed_point_{outer}"),
            &with_physics(SPHERE),
            &[
                "--level",
                "2",
                "--backend",
                "cpu",
                "--set",
                "solver.max_fixed_point=1",
                "--set",
                &format!("solver.outer=\"{outer}\""),
            ],
            &[needle],
        );
        assert_eq!(report["fixed_point"]["converged"], false, "{outer}");
    }
}

#[test]
fn a_breakdown_reports_the_failure() {
    assert_failed(
        "breakdown",
        &with_physics(SPHERE),
        &[
            "--level",
            "2",
            "--backend",
            "cpu",
            "--condition",
            "--set",
            "material.young=1e300",
        ],
        &["broke down"],
    );
}

#[test]
fn a_recovery_failing_in_the_solve_reports_the_failure() {
    let report = assert_failed(
        "recovery_solve",
        &fin("fin", "xmax", "linear", 0.0),
        &["--level", "2", "--backend", "cpu"],
        &["patch recovery at node", "too coarse"],
    );
    assert_eq!(report["fixed_point"]["converged"], false);
}

#[test]
fn a_recovery_failing_in_the_output_reports_the_failure() {
    for output in ["all", "volume", "surface"] {
        let report = assert_failed(
            &format!("recovery_output_{output}"),
            &fin("xmin", "fin", "linear", 0.0),
            &["--level", "2", "--backend", "cpu", "--output", output],
            &["patch recovery at node", "too coarse"],
        );
        // The solve converged: only the output's recovery failed.
        assert_eq!(report["fixed_point"]["converged"], true, "{output}");
    }
}

#[test]
fn a_newton_step_out_of_iterations_reports_the_failure() {
    let report = assert_failed(
        "newton_iterations",
        STRETCHED_CUBE,
        &[
            "--level",
            "2",
            "--set",
            "newton.max_iterations=1",
            "--set",
            "newton.max_cuts=0",
        ],
        &["load step 1", "no convergence in 1 Newton iterations"],
    );
    assert_eq!(report["converged_steps"], 0);
}

#[test]
fn a_newton_step_whose_linear_solve_fails_reports_the_failure() {
    assert_failed(
        "newton_linear_solve",
        STRETCHED_CUBE,
        &[
            "--level",
            "2",
            "--set",
            "solver.max_iterations=1",
            "--set",
            "newton.max_cuts=0",
        ],
        &[
            "load step 1",
            "linear solve",
            "did not converge in 1 iterations",
        ],
    );
}

#[test]
fn a_newton_step_whose_recovery_fails_reports_the_failure() {
    let report = assert_failed(
        "newton_recovery",
        &fin("xmin", "fin", "neo_hookean", 0.01),
        &["--level", "2"],
        &["load step 1", "recovery: patch recovery at node"],
    );
    assert_eq!(report["converged_steps"], 0);
}
