//! End-to-end runs of the binary: a good case writes its report; each class of
//! bad input exits with code 2, names the file, key and reason, and leaves no
//! output behind.

use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"))
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cgfem-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `run` on `text`; returns (exit code, stderr, output folder).
fn run_case(name: &str, text: &str, extra: &[&str]) -> (i32, String, PathBuf) {
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
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stderr).into_owned(),
        out,
    )
}

fn assert_no_output(out: &Path) {
    assert!(
        !out.join("report.json").exists(),
        "a report was left in {}",
        out.display()
    );
}

const SPHERE: &str = "[geometry]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\n";

#[test]
fn a_good_case_writes_its_report() {
    let (code, err, out) = run_case("good", SPHERE, &["--level", "4"]);
    assert_eq!(code, 0, "{err}");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["level"], 4);
    assert_eq!(report["element"], "q1");
    let v = report["domain"]["volume"].as_f64().unwrap();
    assert!((v - 4.0 / 3.0 * std::f64::consts::PI).abs() < 1e-5);
    let c = &report["cells"];
    let total =
        c["inside"].as_u64().unwrap() + c["cut"].as_u64().unwrap() + c["outside"].as_u64().unwrap();
    assert_eq!(total, 16 * 16 * 16);
}

#[test]
fn bad_inputs_exit_2_and_name_the_key() {
    let cases: &[(&str, String, &[&str], &[&str])] = &[
        (
            "negative_radius",
            SPHERE.replace("radius = 1", "radius = -1"),
            &[],
            &["geometry", "radius"],
        ),
        ("misspelled_key", SPHERE.replace("center", "centre"), &[], &["geometry", "centre"]),
        ("malformed", "[geometry\ntype = ".to_string(), &[], &["malformed.toml"]),
        (
            "empty_csg",
            "[geometry]\ntype = \"intersection\"\nof = [{ type = \"sphere\", center = [0,0,0], radius = 1 }, { type = \"sphere\", center = [1.9,1.9,0], radius = 1 }]\n".into(),
            &[],
            &["empty geometry"],
        ),
        (
            "outside_grid",
            format!("{SPHERE}[grid]\nbox_min = [5, 5, 5]\nbox_max = [6, 6, 6]\n"),
            &[],
            &["outside the grid box"],
        ),
        ("level_over_budget", SPHERE.to_string(), &["--level", "12"], &["largest level that fits"]),
        ("level_too_high", SPHERE.to_string(), &["--level", "40"], &["grid.level"]),
        (
            "bad_offset",
            format!("{SPHERE}[grid]\noffset = [1.5, 0, 0]\n"),
            &[],
            &["grid.offset"],
        ),
    ];
    for (name, text, extra, needles) in cases {
        let (code, err, out) = run_case(name, text, extra);
        assert_eq!(code, 2, "{name}: exit {code}, stderr {err}");
        assert!(
            err.contains(&format!("{name}.toml")),
            "{name}: file not named in {err}"
        );
        for n in *needles {
            assert!(err.contains(n), "{name}: '{n}' not in {err}");
        }
        assert!(!err.contains("panicked"), "{name}: {err}");
        assert_no_output(&out);
    }
}
