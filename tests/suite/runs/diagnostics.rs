//! What a run uses by default and what it declines to report: the paper's
//! stabilised method is on unless a case switches it off; a Jacobi diagonal
//! entry at round-off level (a cut artefact) is floored and counted instead
//! of ending the solve, while a genuinely negative one is still a breakdown;
//! the interpolant's error is `null`, with the reason, where the exact field
//! is singular at an active node outside the body.

use cgfem_gpu::backend::{CpuBackend, LinearOperator};
use cgfem_gpu::solver::{
    floor_diagonal, solve, KrylovMethod, KrylovOptions, Preconditioner, DIAGONAL_FLOOR,
};
use cgfem_gpu::Error;
use serde_json::Value;

use crate::common;
use common::cli::run_output;
use common::{with_physics, SPHERE};

/// Runs `cgfem-gpu run` on `text` with `extra` arguments on the CPU,
/// quietly; returns the exit code, stdout, stderr and the report.
fn run(name: &str, text: &str, extra: &[&str]) -> (i32, String, String, Value) {
    let args = [&["--backend", "cpu", "--quiet"], extra].concat();
    let (o, out) = run_output(&format!("diag-{name}"), text, &args);
    let report = serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
        report,
    )
}

#[test]
fn the_stabilised_method_is_the_default_and_k2_zero_switches_it_off() {
    // Q1: k2 = 0.01, A = 5%.
    let (code, _, err, r) = run("q1", &with_physics(SPHERE), &["--level", "3"]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(r["stabilisation"]["k2"], 0.01);
    assert_eq!(r["stabilisation"]["A"], 0.05);
    let pathological = r["bodies"][0]["cells"]["pathological"].as_u64().unwrap();
    assert!(pathological > 0, "no cell below 5% at level 3");
    assert_eq!(r["krylov"]["floored_diagonal_entries"], 0);
    let e = r["bodies"][0]["interpolant_error"]["energy_relative"]
        .as_f64()
        .unwrap();
    assert!(e > 0.0 && e.is_finite());
    assert!(r.get("interpolant_error_note").is_none());
    // Without the S-term: the same Ω* is counted, k2 = 0 is reported.
    let (code, _, err, r) = run(
        "q1_off",
        &with_physics(SPHERE),
        &["--level", "3", "--set", "stabilisation.k2=0"],
    );
    assert_eq!(code, 0, "{err}");
    assert_eq!(r["stabilisation"]["k2"], 0.0);
    assert_eq!(
        r["bodies"][0]["cells"]["pathological"].as_u64().unwrap(),
        pathological
    );
    // Q2: A = 20%.
    let (code, _, err, r) = run(
        "q2",
        &with_physics(SPHERE),
        &["--level", "2", "--set", "element=q2"],
    );
    assert_eq!(code, 0, "{err}");
    assert_eq!(r["stabilisation"]["k2"], 0.01);
    assert_eq!(r["stabilisation"]["A"], 0.2);
}

/// `−u'' ` on `n` nodes (2 on the diagonal, −1 beside it) plus one decoupled
/// dof whose diagonal entry is `last`.
struct Chain {
    n: usize,
    last: f64,
}

impl LinearOperator for Chain {
    fn nrows(&self) -> usize {
        self.n + 1
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        for i in 0..self.n {
            let left = if i > 0 { x[i - 1] } else { 0.0 };
            let right = if i + 1 < self.n { x[i + 1] } else { 0.0 };
            y[i] = 2.0 * x[i] - left - right;
        }
        y[self.n] = self.last * x[self.n];
    }
    fn diagonal(&self) -> Vec<f64> {
        let mut d = vec![2.0; self.n];
        d.push(self.last);
        d
    }
}

fn solve_chain(last: f64, method: KrylovMethod) -> cgfem_gpu::Result<usize> {
    let op = Chain { n: 30, last };
    let mut b: Vec<f64> = (0..30).map(|i| (i as f64 * 0.3).sin()).collect();
    b.push(0.0);
    let mut x = vec![0.0; 31];
    let opts = KrylovOptions {
        method,
        preconditioner: Preconditioner::Jacobi,
        rel_tol: 1e-10,
        max_iterations: 500,
    };
    let stats = solve(&CpuBackend::new(), &op, None, &b, &mut x, &opts)?;
    assert!(stats.true_relative_residual <= 1e-10, "{stats:?}");
    assert_eq!(x[30], 0.0);
    Ok(stats.floored_diagonal_entries)
}

#[test]
fn a_round_off_diagonal_is_floored_and_a_negative_one_is_still_a_breakdown() {
    // Zero and negative round-off entries are floored; a tiny positive one
    // is kept (Jacobi scales it exactly); −1 is beyond the floor.
    let mut d = vec![4.0, 1e-20, -3e-19, 0.0, 2.0, -1.0];
    assert_eq!(floor_diagonal(&mut d, false), Ok(2));
    let floor = DIAGONAL_FLOOR * 4.0;
    assert_eq!(d, vec![4.0, 1e-20, floor, floor, 2.0, -1.0]);
    // Negative beyond the floor: refused where M must be SPD.
    let mut d = vec![4.0, 1e-20, -1.0];
    assert_eq!(floor_diagonal(&mut d, true), Err((2, -1.0)));
    let mut d = vec![4.0, f64::NAN];
    assert!(floor_diagonal(&mut d, false).is_err());
    // An active dof without stiffness (−1.6e-20, as a sliver cut gives)
    // no longer ends the solve: it is floored, counted, and A x = b solved.
    for method in [KrylovMethod::Cg, KrylovMethod::Cgs, KrylovMethod::BiCgStab] {
        assert_eq!(solve_chain(-1.6e-20, method).unwrap(), 1, "{method}");
        assert_eq!(solve_chain(0.5, method).unwrap(), 0, "{method}");
    }
    // A diagonal entry of −1e-3 proves A indefinite: CG with Jacobi refuses.
    let err = solve_chain(-1e-3, KrylovMethod::Cg).unwrap_err();
    assert_eq!(err.exit_code(), 3);
    assert!(
        matches!(&err, Error::Breakdown { what, .. } if what.contains("Jacobi")),
        "{err}"
    );
}

/// A thick shell (radii 0.5 and 1) under internal pressure against Lamé's
/// field, singular at the centre, on a level-2 grid whose box is `bx`.
fn shell(center: [f64; 3], bx: f64) -> String {
    let [cx, cy, cz] = center;
    let r = format!("((x - {cx})^2 + (y - {cy})^2 + (z - {cz})^2)");
    let u = |c: &str, x0: f64| {
        format!("\"(100*0.125*0.4/(1000*0.875) + 100*0.125*1.3/(2*1000*0.875) / {r}^1.5) * ({c} - {x0})\"")
    };
    let t = |c: &str, x0: f64| format!("\"100*({c} - {x0})/sqrt({r})\"");
    format!(
        "[geometry]\ntype = \"shell\"\ncenter = [{cx}, {cy}, {cz}]\ninner_radius = 0.5\nouter_radius = 1.0\n\
         [grid]\nlevel = 2\nbox_min = [-{bx}, -{bx}, -{bx}]\nbox_max = [{bx}, {bx}, {bx}]\n\
         [material]\nyoung = 1000.0\npoisson = 0.3\n\
         [exact]\ndisplacement = [{}, {}, {}]\n\
         [body_load]\nvalue = [\"0\", \"0\", \"0\"]\n\
         [neumann.inner]\ntraction = [{}, {}, {}]\n\
         [dirichlet.outer]\nvalue = \"exact\"\n\
         [solver]\nmethod = \"cg\"\npreconditioner = \"jacobi\"\n",
        u("x", cx),
        u("y", cy),
        u("z", cz),
        t("x", cx),
        t("y", cy),
        t("z", cz),
    )
}

#[test]
fn the_interpolant_error_is_null_where_the_exact_field_is_singular() {
    // The centre on a grid node (h = 0.5: the node's cells reach the shell,
    // so it is active): the exact field is 0/0 there. Then the centre 1e-9
    // off a node (h = 0.625): finite, but 1e17 times the field on the body.
    for (name, center, bx) in [
        ("on_node", [0.0, 0.0, 0.0], 1.0),
        ("near_node", [0.0, 0.0, 1e-9], 1.25),
    ] {
        let (code, out, err, r) = run(name, &shell(center, bx), &[]);
        assert_eq!(code, 0, "{name}: {err}");
        let body = r["bodies"][0].as_object().unwrap();
        assert!(body.contains_key("interpolant_error"), "{name}");
        assert!(r["bodies"][0]["interpolant_error"].is_null(), "{name}: {r}");
        let note = r["bodies"][0]["interpolant_error_note"].as_str().unwrap();
        assert!(
            note.contains("singular at the active node"),
            "{name}: {note}"
        );
        // The solution's own error is measured on the body: finite.
        let e = r["bodies"][0]["error"]["energy_relative"].as_f64().unwrap();
        assert!(e.is_finite() && e > 0.0, "{name}: {e}");
        // No number for the interpolant in the summary, the reason instead.
        assert!(!out.contains("; interpolant "), "{name}: {out}");
        assert!(
            out.contains("interpolant error not reported"),
            "{name}: {out}"
        );
    }
}
