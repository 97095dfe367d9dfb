//! End-to-end runs of the binary: a good case writes its report; each class of
//! bad input exits with code 2, names the file, key and reason, and leaves no
//! output behind (solver failures, exit code 3: [`super::failures`]).

use std::path::Path;

use crate::common;
use common::cli::run_case;
use common::{with_physics, SPHERE};

fn assert_no_output(out: &Path) {
    assert!(
        !out.join("report.json").exists(),
        "a report was left in {}",
        out.display()
    );
}

#[test]
fn a_good_case_writes_its_report() {
    let (code, err, out) = run_case("good", &with_physics(SPHERE), &["--level", "3"]);
    assert_eq!(code, 0, "{err}");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["bodies"][0]["level"], 3);
    assert_eq!(report["bodies"][0]["element"], "q1");
    assert_eq!(report["status"], "ok");
    assert_eq!(report["krylov"]["method"], "cg");
    assert!(report["fixed_point"]["converged"].as_bool().unwrap());
    let e = report["bodies"][0]["error"]["energy_relative"]
        .as_f64()
        .unwrap();
    assert!(e > 0.05 && e < 0.3, "energy error {e}");
    // The reaction balances the body load: ∫∂Ω λ = −∫Ω b = (10000, −25000, 0) V / 13.
    let v = 4.0 / 3.0 * std::f64::consts::PI;
    let row = &report["reactions"][0];
    assert_eq!(
        (&row["body"], &row["part"], &row["step"]),
        (&"body".into(), &"surface".into(), &1.into())
    );
    let rx = row["force"][0].as_f64().unwrap();
    assert!(
        (rx - 10000.0 * v / 13.0).abs() < 0.02 * 10000.0 * v / 13.0,
        "reaction {rx}"
    );
    // Appended raw binary: the XML is text, the data after it is not.
    let vtu = std::fs::read(out.join("solution.vtu")).unwrap();
    let vtu = String::from_utf8_lossy(&vtu);
    assert!(vtu.contains("Name=\"displacement\"") && vtu.contains("Name=\"von_mises\""));
    assert!(vtu.trim_end().ends_with("</VTKFile>"));
    let v = report["bodies"][0]["domain"]["volume"].as_f64().unwrap();
    assert!((v - 4.0 / 3.0 * std::f64::consts::PI).abs() < 1e-4);
    let c = &report["bodies"][0]["cells"];
    let total =
        c["inside"].as_u64().unwrap() + c["cut"].as_u64().unwrap() + c["outside"].as_u64().unwrap();
    assert_eq!(total, 8 * 8 * 8);
}

#[test]
fn set_overrides_any_key() {
    let (code, err, out) = run_case(
        "set",
        &with_physics(SPHERE),
        &[
            "--level",
            "2",
            "--set",
            "solver.method=cgs",
            "--set",
            "stabilisation.k1=50",
        ],
    );
    assert_eq!(code, 0, "{err}");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["krylov"]["method"], "cgs");
    assert_eq!(report["stabilisation"]["k1"], 50.0);
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
            "poisson_half",
            with_physics(SPHERE).replace("poisson = 0.3", "poisson = 0.5"),
            &[],
            &["material.poisson"],
        ),
        (
            "young_negative",
            with_physics(SPHERE).replace("young = 1000.0", "young = 0"),
            &[],
            &["material.young"],
        ),
        (
            "bad_expression",
            with_physics(SPHERE).replace("\"0\"]", "\"0 +* 1\"]"),
            &[],
            &["exact.displacement[2]", "cannot parse"],
        ),
        (
            "unknown_variable",
            with_physics(SPHERE).replace("\"0\"]", "\"w\"]"),
            &[],
            &["exact.displacement[2]", "unknown variable 'w'"],
        ),
        (
            "unknown_tag",
            with_physics(SPHERE).replace("[dirichlet.surface]", "[dirichlet.outer]"),
            &[],
            &["dirichlet.outer", "surface"],
        ),
        (
            "misspelled_physics",
            with_physics(SPHERE).replace("[material]", "[materail]"),
            &[],
            &["materail"],
        ),
        (
            "bad_offset",
            format!("{SPHERE}[grid]\noffset = [1.5, 0, 0]\n"),
            &[],
            &["grid.offset"],
        ),
    ];
    for (name, text, extra, needles) in cases {
        let text = if text.contains("young") {
            text.clone()
        } else {
            with_physics(text)
        };
        let (code, err, out) = run_case(name, &text, extra);
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
