//! One case model: a one-body case written in the shorthand (its body's keys
//! at the top level) and the same body written as `[[body]]` are one case —
//! the same path, the same report, the same answers (to the last bits of
//! parallel sums) — and what takes a case to the Newton path is named in its
//! report.

use std::process::Command;

use cgfem_gpu::case::{Case, Model, SolutionPath};
use serde_json::Value;

/// The keys of the whole run; every other top-level key is the body's.
const CASE_KEYS: [&str; 4] = ["name", "solver", "stabilisation", "load"];

/// `text` (a shorthand case) with its body's keys moved under `[[body]]`,
/// the body named `name`.
fn as_body_list(text: &str, name: &str) -> String {
    let mut top: toml::Table = text.parse().unwrap();
    let mut body = toml::Table::new();
    body.insert("name".into(), toml::Value::String(name.into()));
    let keys: Vec<String> = top
        .keys()
        .filter(|k| !CASE_KEYS.contains(&k.as_str()))
        .cloned()
        .collect();
    for k in keys {
        body.insert(k.clone(), top.remove(&k).unwrap());
    }
    top.insert(
        "body".into(),
        toml::Value::Array(vec![toml::Value::Table(body)]),
    );
    toml::to_string(&top).unwrap()
}

/// Runs case `text` (written to `file` in a scratch folder) at level 3 and
/// returns its report.
fn run(file: &str, text: &str) -> Value {
    let dir = std::env::temp_dir().join(format!("cgfem-case-model-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(file);
    std::fs::write(&path, text).unwrap();
    let out = dir.join(format!("{file}.out"));
    let o = Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"))
        .args(["-q", "run", path.to_str().unwrap(), "--level", "3"])
        .args(["--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report = serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap());
    std::fs::remove_dir_all(&out).unwrap();
    report.unwrap()
}

/// `a` and `b` have the same structure, strings and integers, and numbers
/// equal to 1e-12 relative.
fn same(a: &Value, b: &Value, at: &str) {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            assert_eq!(
                x.keys().collect::<Vec<_>>(),
                y.keys().collect::<Vec<_>>(),
                "{at}"
            );
            for (k, v) in x {
                same(v, &y[k], &format!("{at}.{k}"));
            }
        }
        (Value::Array(x), Value::Array(y)) => {
            assert_eq!(x.len(), y.len(), "{at}");
            for (i, (v, w)) in x.iter().zip(y).enumerate() {
                same(v, w, &format!("{at}[{i}]"));
            }
        }
        (Value::Number(x), Value::Number(y)) if x.is_f64() || y.is_f64() => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            assert!(
                (x - y).abs() <= 1e-12 * x.abs().max(y.abs()),
                "{at}: {x} against {y}"
            );
        }
        _ => assert_eq!(a, b, "{at}"),
    }
}

fn case_file(name: &str) -> String {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases");
    std::fs::read_to_string(dir.join(name)).unwrap()
}

#[test]
fn the_shorthand_and_a_body_list_are_one_case() {
    for (file, exact) in [("plate_with_hole.toml", false), ("sphere.toml", true)] {
        let short = case_file(file);
        let listed = as_body_list(&short, "body");
        let (a, b) = (run("short.toml", &short), run("listed.toml", &listed));
        assert_eq!(a["path"], "linear", "{file}");
        assert_eq!(b["path"], "linear", "{file}");
        // Every answer: the bodies' rows (grid, cells, domain, errors), the
        // fixed point's history and the reactions, to 1e-12 relative (the
        // error norms are parallel sums, whose last bits vary run to run).
        for key in ["bodies", "fixed_point", "reactions", "dofs"] {
            same(&a[key], &b[key], &format!("{file}: {key}"));
        }
        assert_eq!(
            a["krylov"]["iterations_per_solve"],
            b["krylov"]["iterations_per_solve"]
        );
        assert_eq!(a["bodies"][0]["error"].is_object(), exact, "{file}");
        assert!(!a["reactions"].as_array().unwrap().is_empty(), "{file}");
    }
}

#[test]
fn the_path_and_its_reason_come_from_the_case() {
    let plate = case_file("plate_with_hole.toml");
    let parse = |text: &str| Case::from_str("probe.toml", text).unwrap();
    let linear = parse(&plate);
    assert_eq!(linear.path, SolutionPath::Linear);
    assert!(linear.shorthand && linear.bodies[0].model == Model::Linear);
    // A hyperelastic model, or load steps, take the same body to Newton.
    let neo = plate.replace("poisson = 0.3", "poisson = 0.3\nmodel = \"neo_hookean\"");
    assert_eq!(
        parse(&neo).path,
        SolutionPath::Newton("body 'body' is NeoHookean".into())
    );
    let stepped = format!("{plate}\n[load]\nsteps = 2\n");
    assert_eq!(
        parse(&stepped).path,
        SolutionPath::Newton("it sets `load`".into())
    );
    // A key of the linear path on the Newton path is an error naming it.
    let exact =
        format!("{plate}\n[exact]\ndisplacement = [\"0\", \"0\", \"0\"]\n[load]\nsteps = 2\n");
    match Case::from_str("plate.toml", &exact) {
        Err(cgfem_gpu::Error::CaseFile { key, reason, .. }) => {
            assert_eq!(key, "exact");
            assert!(reason.contains("it sets `load`"), "{reason}");
        }
        other => panic!("expected a case-file error, got {other:?}"),
    }
}
