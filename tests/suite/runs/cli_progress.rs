//! The run's user experience: plain progress lines when stderr is not a
//! terminal, `--quiet`, `RUST_LOG`, `--plots`, and Ctrl-C (SIGINT), which
//! stops the run at an iteration boundary with exit code 130 and a report
//! marked interrupted.

use std::path::PathBuf;
use std::process::Command;

use crate::common;
#[cfg(unix)]
use crate::common::sigint;
use common::{with_physics, SPHERE};

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"));
    c.env_remove("RUST_LOG").env("CGFEM_BACKEND", "cpu");
    c
}

/// A scratch folder holding the sphere case; returns (case file, output folder).
fn scratch(name: &str) -> (PathBuf, PathBuf) {
    let d = std::env::temp_dir().join(format!("cgfem-ux-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let case = d.join("sphere.toml");
    std::fs::write(
        &case,
        format!("name = \"sphere\"\n{}", with_physics(SPHERE)),
    )
    .unwrap();
    (case, d.join("out"))
}

/// Runs `run` to the end; returns (exit code, stderr, output folder).
fn run(name: &str, extra: &[&str], env: &[(&str, &str)]) -> (i32, String, PathBuf) {
    let (case, out) = scratch(name);
    let o = bin()
        .arg("run")
        .arg(&case)
        .arg("--out")
        .arg(&out)
        .args(["--level", "2"])
        .args(extra)
        .envs(env.iter().copied())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    (o.status.code().unwrap_or(-1), err, out)
}

fn report(out: &std::path::Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap()
}

#[test]
fn a_piped_run_prints_one_plain_line_per_step() {
    let (code, err, out) = run("plain", &[], &[]);
    assert_eq!(code, 0, "{err}");
    let iterations = report(&out)["fixed_point"]["iterations"].as_u64().unwrap();
    assert!(err.contains("quadrature: done in"), "{err}");
    assert!(err.contains("solve 0: "), "{err}");
    let lines = err
        .lines()
        .filter(|l| l.starts_with("fixed-point iteration ") && l.contains("ε = "))
        .count();
    assert_eq!(lines as u64, iterations, "{err}");
    // No terminal escapes when stderr is not a terminal.
    assert!(!err.contains('\u{1b}'), "{err}");
}

#[test]
fn quiet_silences_the_progress() {
    let (code, err, out) = run("quiet", &["--quiet"], &[]);
    assert_eq!(code, 0, "{err}");
    assert!(err.is_empty(), "{err}");
    assert_eq!(report(&out)["status"], "ok");
}

#[test]
fn rust_log_shows_the_library_phases() {
    let (code, err, _) = run("log", &["-q"], &[("RUST_LOG", "cgfem_gpu=info")]);
    assert_eq!(code, 0, "{err}");
    for text in [
        "classified the cells",
        "assembled the operator",
        "fixed-point iteration",
        "recovered the tractions",
    ] {
        assert!(err.contains(text), "{text} missing: {err}");
    }
}

#[test]
fn plots_writes_the_residual_chart() {
    let (code, err, out) = run("plots", &["--plots", "-q"], &[]);
    assert_eq!(code, 0, "{err}");
    let svg = std::fs::read_to_string(out.join("residuals.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    for text in [
        "sphere: fixed-point convergence",
        "ε = ‖ΔU‖/‖U‖",
        "Krylov iterations per solve",
    ] {
        assert!(svg.contains(text), "{text} missing");
    }
    let (code, err, out) = run("no-plots", &["-q"], &[]);
    assert_eq!(code, 0, "{err}");
    assert!(!out.join("residuals.svg").exists());
}

/// SIGINT after the initial solve: the loop stops at the next iteration
/// boundary. (With `Tol` = 1e-300 the loop only ends when ε reaches 0, after
/// about 8 iterations: 0.4 s at level 4 here, several seconds at level 5,
/// which leaves the signal ample time even on a fast machine.)
#[cfg(unix)]
#[test]
fn ctrl_c_stops_the_run_with_code_130_and_an_interrupted_report() {
    let (case, out) = scratch("sigint");
    let mut cmd = bin();
    cmd.arg("run")
        .arg(&case)
        .arg("--out")
        .arg(&out)
        .args(["--level", "5", "--plots"])
        .args(["--set", "solver.fixed_point_tol=1e-300"])
        .args(["--set", "solver.max_fixed_point=100000"]);
    let (code, seen) = sigint::interrupt_after(cmd, "solve 0:");
    assert_eq!(code, Some(130), "{seen}");
    assert!(seen.contains("report (marked interrupted)"), "{seen}");
    let r = report(&out);
    assert_eq!(r["status"], "interrupted");
    assert!(r["failure"].as_str().unwrap().contains("interrupted"));
    assert!(!r["fixed_point"]["converged"].as_bool().unwrap());
    // The loop stopped at an iteration boundary: one ε per outer iteration,
    // one inner solve each (the default outer FGMRES; the paper's loop has
    // an initial solve besides).
    assert_eq!(r["fixed_point"]["method"], "fgmres");
    let solves = r["krylov"]["iterations_per_solve"]
        .as_array()
        .unwrap()
        .len();
    let iterations = r["fixed_point"]["iterations"].as_u64().unwrap() as usize;
    assert!(solves >= 1, "{r}");
    assert_eq!(solves, iterations, "{r}");
    assert_eq!(
        r["fixed_point"]["eps_history"].as_array().unwrap().len(),
        iterations
    );
    assert!(!out.join("solution.vtu").exists());
    assert!(out.join("residuals.svg").exists());
    // Only finished files: no temporaries of write_atomic are left.
    for e in std::fs::read_dir(&out).unwrap() {
        let name = e.unwrap().file_name().into_string().unwrap();
        assert!(!name.starts_with('.'), "{name}");
    }
}
