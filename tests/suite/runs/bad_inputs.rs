//! End-to-end: one test per class of bad input of docs/method.md (*Bad input and exit codes*), run with the
//! binary. Each must exit with code 2, name the file, the key and the reason
//! on stderr, write nothing into the `--out` folder, create no `--out` folder
//! that did not exist, and never touch files already there.

use std::path::{Path, PathBuf};
use std::process::Command;

/// A small valid case: the paper's sphere at level 2.
const GOOD: &str = r#"
[geometry]
type = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0

[grid]
level = 2

[material]
young = 1000.0
poisson = 0.3

[exact]
displacement = ["x + x^2 - 2*x*y", "-y - 2*x*y", "0.1*z"]

[dirichlet.surface]
value = "exact"

[solver]
method = "cg"
preconditioner = "jacobi"
"#;

/// A scratch folder holding the case `<name>.toml` and an `--out` folder
/// with one unrelated file in it.
fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cgfem-bad-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(d.join("out")).unwrap();
    std::fs::write(d.join("out").join("keep.txt"), "not ours").unwrap();
    d
}

/// Runs `run <name>.toml --out out [extra]` on `text` (no file when `None`);
/// asserts the contract and returns stderr.
fn bad(name: &str, text: Option<&str>, extra: &[&str], needles: &[&str]) -> String {
    let dir = scratch(name);
    let case = dir.join(format!("{name}.toml"));
    if let Some(text) = text {
        std::fs::write(&case, text).unwrap();
    }
    let mut stderr = String::new();
    for out in [dir.join("out"), dir.join("new")] {
        let o = Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"))
            .arg("run")
            .arg(&case)
            .arg("--out")
            .arg(&out)
            .args(extra)
            .output()
            .unwrap();
        stderr = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(2), "{name}: {stderr}");
        assert!(!stderr.contains("panicked"), "{name}: {stderr}");
        assert!(
            stderr.contains(&format!("{name}.toml")),
            "{name}: the file is not named in {stderr}"
        );
        for n in needles {
            assert!(stderr.contains(n), "{name}: '{n}' not in {stderr}");
        }
    }
    assert_untouched(&dir.join("out"));
    assert!(!dir.join("new").exists(), "{name}: created --out");
    std::fs::remove_dir_all(&dir).unwrap();
    stderr
}

fn assert_untouched(out: &Path) {
    let names: Vec<String> = std::fs::read_dir(out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, ["keep.txt"], "{}", out.display());
    assert_eq!(
        std::fs::read_to_string(out.join("keep.txt")).unwrap(),
        "not ours"
    );
}

fn edit(from: &str, to: &str) -> String {
    assert!(GOOD.contains(from), "{from}");
    GOOD.replacen(from, to, 1)
}

#[test]
fn the_good_case_runs_and_keeps_other_files() {
    let dir = scratch("good");
    let case = dir.join("good.toml");
    std::fs::write(&case, GOOD).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"))
        .arg("run")
        .arg(&case)
        .arg("--out")
        .arg(dir.join("out"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut names: Vec<String> = std::fs::read_dir(dir.join("out"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "keep.txt",
            "report.json",
            "solution.pvd",
            "solution.vtu",
            "surface.vtp"
        ]
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn missing_file() {
    bad("missing", None, &[], &["No such file"]);
}

#[test]
fn toml_syntax_error() {
    bad(
        "syntax",
        Some(&edit("radius = 1.0", "radius = = 1.0")),
        &[],
        &["line 5, column 10", "invalid TOML"],
    );
}

#[test]
fn unknown_key() {
    bad(
        "unknown_key",
        Some(&edit("level = 2", "levle = 2")),
        &[],
        &["grid.levle", "unknown field"],
    );
}

#[test]
fn wrong_type() {
    bad(
        "wrong_type",
        Some(&edit("young = 1000.0", "young = \"steel\"")),
        &[],
        &["material.young", "invalid type"],
    );
    bad(
        "wrong_type_geometry",
        Some(&edit("type = \"sphere\"", "type = \"ball\"")),
        &[],
        &["geometry", "unknown variant `ball`"],
    );
}

#[test]
fn out_of_range_values() {
    let cases = [
        ("young = 1000.0", "young = -1000.0", "material.young"),
        ("poisson = 0.3", "poisson = 0.5", "material.poisson"),
        ("radius = 1.0", "radius = -1.0", "geometry"),
        (
            "level = 2",
            "level = 2\noffset = [1.5, 0, 0]",
            "grid.offset",
        ),
        (
            "method = \"cg\"",
            "method = \"cg\"\nrel_tol = 2.0",
            "solver.rel_tol",
        ),
        (
            "[geometry]",
            "name = \"../escape\"\n[geometry]",
            "name: \"../escape\" is not a plain folder name",
        ),
    ];
    for (i, (from, to, key)) in cases.iter().enumerate() {
        bad(&format!("range{i}"), Some(&edit(from, to)), &[], &[key]);
    }
}

#[test]
fn bad_expression() {
    bad(
        "bad_expression",
        Some(&edit("\"0.1*z\"", "\"0.1*z +* 2\"")),
        &[],
        &["exact.displacement[2]", "cannot parse"],
    );
}

#[test]
fn loads_that_are_not_finite() {
    let text = format!("{GOOD}[body_load]\nvalue = [\"log(x)\", \"0\", \"0\"]\n");
    bad(
        "nan_load",
        Some(&text),
        &[],
        &["body_load.value", "not finite"],
    );
}

#[test]
fn unknown_tags() {
    let e = bad(
        "dirichlet_tag",
        Some(&edit("[dirichlet.surface]", "[dirichlet.top]")),
        &[],
        &["dirichlet.top"],
    );
    assert!(e.contains("known: surface"), "{e}");
    let text = format!("{GOOD}[neumann.side]\ntraction = [\"1\", \"0\", \"0\"]\n");
    bad(
        "neumann_tag",
        Some(&text),
        &[],
        &["neumann.side", "surface"],
    );
}

#[test]
fn level_too_large_for_memory() {
    bad(
        "memory",
        Some(GOOD),
        &["--level", "12"],
        &["grid.level", "largest level that fits"],
    );
}

#[test]
fn empty_domain() {
    let text = edit(
        "level = 2",
        "level = 2\nbox_min = [5, 5, 5]\nbox_max = [6, 6, 6]",
    );
    bad(
        "outside",
        Some(&text),
        &[],
        &["grid.box_min", "outside the grid box"],
    );
    let text = edit(
        "type = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0",
        "type = \"difference\"\nof = [{ type = \"sphere\", center = [0, 0, 0], radius = 1 }, \
         { type = \"sphere\", center = [0, 0, 0], radius = 2 }]",
    );
    bad(
        "empty_csg",
        Some(&text),
        &[],
        &["geometry", "empty geometry"],
    );
}

#[test]
fn bad_set_overrides() {
    let cases: [(&[&str], &[&str]); 4] = [
        (
            &["--set", "solver.method"],
            &["--set solver.method", "key=value"],
        ),
        (
            &["--set", "grid.level=high"],
            &["grid.level", "invalid type"],
        ),
        (
            &["--set", "material.young.x=1"],
            &["--set material.young.x=1", "not a table"],
        ),
        (
            &["--set", "solver.methd=cg"],
            &["solver.methd", "unknown field"],
        ),
    ];
    for (i, (extra, needles)) in cases.iter().enumerate() {
        bad(&format!("set{i}"), Some(GOOD), extra, needles);
    }
    // A key deep enough to overflow a recursive deserialiser's stack.
    let deep = format!("--set=geometry{}.type=sphere", ".of".repeat(20_000));
    bad(
        "set_deep",
        Some(GOOD),
        &[&deep],
        &["--set geometry.of.of", "parts"],
    );
}

#[test]
fn out_is_a_file() {
    let dir = scratch("out_file");
    let case = dir.join("out_file.toml");
    std::fs::write(&case, GOOD).unwrap();
    let out = dir.join("out").join("keep.txt");
    let o = Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"))
        .arg("run")
        .arg(&case)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("keep.txt") && stderr.contains("--out"),
        "{stderr}"
    );
    assert_untouched(&dir.join("out"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The multigrid preconditioner runs on the GPU in f64 (its V-cycle on the
/// device): `--backend gpu` solves with it; an f32 device is refused with
/// exit code 2 before anything is written, naming the preconditioner and
/// the way out.
#[test]
fn multigrid_on_the_gpu_backend() {
    use cgfem_gpu::gpu::{context_or_skip, PrecisionChoice};
    if context_or_skip(PrecisionChoice::F64).is_none() {
        return;
    }
    let dir = scratch("mg_gpu");
    let case = dir.join("mg_gpu.toml");
    std::fs::write(&case, edit("\"jacobi\"", "\"multigrid\"")).unwrap();
    let run = |precision: &str, out: &str| {
        Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"))
            .arg("run")
            .arg(&case)
            .args(["--backend", "gpu", "--precision", precision, "--out"])
            .arg(dir.join(out))
            .output()
            .unwrap()
    };
    let o = run("f32", "out");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("multigrid") && stderr.contains("--precision f64"),
        "{stderr}"
    );
    assert_untouched(&dir.join("out"));
    let o = run("f64", "f64");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    let report = std::fs::read_to_string(dir.join("f64").join("report.json")).unwrap();
    assert!(
        report.contains("\"multigrid\"") && report.contains("\"backend\": \"gpu\""),
        "{report}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A hierarchy whose level vectors exceed one storage binding (lowered with
/// `CGFEM_MAX_BINDING_BYTES`) and an explicit `"multigrid"`: exit code 2
/// naming the binding. (`"auto"` takes Jacobi on the GPU instead:
/// `gpu::multigrid_tests` in the library.)
#[test]
fn multigrid_beyond_one_binding_on_the_gpu() {
    use cgfem_gpu::gpu::{context_or_skip, PrecisionChoice};
    if context_or_skip(PrecisionChoice::F64).is_none() {
        return;
    }
    let dir = scratch("mg_binding");
    let case = dir.join("mg.toml");
    std::fs::write(&case, edit("\"jacobi\"", "\"multigrid\"")).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"))
        .arg("run")
        .arg(&case)
        .args([
            "--level",
            "4",
            "--backend",
            "gpu",
            "--precision",
            "f64",
            "--out",
        ])
        .arg(dir.join("out"))
        .env("CGFEM_MAX_BINDING_BYTES", "65536")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("exceeds one storage binding"), "{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An `stl` geometry on `path`, the rest as [`GOOD`].
fn stl_case(path: &Path) -> String {
    format!(
        "[geometry]\ntype = \"stl\"\npath = \"{}\"\n[grid]\nlevel = 2\n[material]\nyoung = 1000.0\npoisson = 0.3\n",
        path.display()
    )
}

#[test]
fn stl_files_that_are_not_solids() {
    let dir = std::env::temp_dir().join(format!("cgfem-bad-stl-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let part = |name: &str| {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("cases/parts")
            .join(name)
    };
    let plate = std::fs::read(part("plate_holes.stl")).unwrap();
    let random: Vec<u8> = (0..5000u32)
        .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
        .collect();
    let files: [(&str, Option<Vec<u8>>, &str); 5] = [
        ("empty.stl", Some(Vec::new()), "the file is empty"),
        (
            "truncated.stl",
            Some(plate[..plate.len() - 30].to_vec()),
            "truncated?",
        ),
        ("random.stl", Some(random), "not an STL file"),
        ("absent.stl", None, "No such file"),
        (
            "soup.stl",
            Some(std::fs::read(part("soup.stl")).unwrap()),
            "not a solid",
        ),
    ];
    for (name, bytes, reason) in files {
        let path = dir.join(name);
        if let Some(b) = bytes {
            std::fs::write(&path, b).unwrap();
        }
        let stderr = bad(
            "stl",
            Some(&stl_case(&path)),
            &[],
            &[name, "geometry.path", reason],
        );
        println!("{stderr}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
