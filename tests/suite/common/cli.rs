//! Running the binary on case text: a scratch folder per test, the case
//! written into it, `run` with `--out` there, and what came back.

use std::path::PathBuf;
use std::process::{Command, Output};

/// The `cgfem-gpu` binary under test.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"))
}

/// An empty scratch folder for the test `name`.
pub fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cgfem-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `run` on `text` (written into the scratch folder `name`) with the
/// `extra` arguments; returns what the process gave and the output folder.
pub fn run_output(name: &str, text: &str, extra: &[&str]) -> (Output, PathBuf) {
    let dir = scratch(name);
    let case = dir.join(format!("{name}.toml"));
    std::fs::write(&case, text).unwrap();
    let out = dir.join("out");
    let o = bin()
        .arg("run")
        .arg(&case)
        .arg("--out")
        .arg(&out)
        .args(extra)
        .output()
        .unwrap();
    (o, out)
}

/// Runs `run` on `text`; returns (exit code, stderr, output folder).
pub fn run_case(name: &str, text: &str, extra: &[&str]) -> (i32, String, PathBuf) {
    let (o, out) = run_output(name, text, extra);
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stderr).into_owned(),
        out,
    )
}
