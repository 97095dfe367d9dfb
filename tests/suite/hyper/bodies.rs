//! Multi-body runs (without contact): the CLI on two boxes apart,
//! each stretched by prescribed displacements — exit codes, the ParaView
//! series, the report's keys — each body's result against the same body
//! solved alone through `HyperProblem`, `--level`, the bad-input classes of a
//! multi-body case and a failing load step.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Arc;

use cgfem_gpu::bodies::run::run;
use cgfem_gpu::case::Case;
use cgfem_gpu::cells::{cut_rule_points, Cells};
use cgfem_gpu::element::ElementOrder;
use cgfem_gpu::geometry::Geometry;
use cgfem_gpu::grid::Grid;
use cgfem_gpu::hyper::material::Material;
use cgfem_gpu::hyper::newton::{solve_load_steps, CpuTangentSolver, HyperSolution};
use cgfem_gpu::hyper::problem::{
    Conditions, DirichletCondition, HyperProblem, Loads, Ramp, Region, VectorField,
};
use cgfem_gpu::progress::Silent;
use cgfem_gpu::solver::Preconditioner;
use cgfem_gpu::spatial::Aabb;
use serde_json::Value;

#[cfg(unix)]
use crate::common::sigint;

mod coupling;

/// Two boxes 1 apart: `left` stretched by 0.5 along x (neo-Hookean), `right`
/// pushed by −0.3 on the lower half of its xmax face (St Venant–Kirchhoff);
/// rollers on the min faces. `XMAX` is replaced by left's prescribed value.
const TWO: &str = r#"
name = "two_boxes"
[load]
steps = 2
[newton]
rel_tol = 1e-11
energy_tol = 1e-22
[solver]
method = "cg"
rel_tol = 1e-12
[[body]]
name = "left"
geometry = { type = "cuboid", min = [0, 0, 0], max = [2, 1, 1] }
grid = { level = 2 }
material = { model = "neo_hookean", young = 1000.0, poisson = 0.3 }
dirichlet.xmin = { value = ["0", "free", "free"] }
dirichlet.ymin = { value = ["free", "0", "free"] }
dirichlet.zmin = { value = ["free", "free", "0"] }
dirichlet.xmax = { value = ["XMAX", "free", "free"] }
[[body]]
name = "right"
geometry = { type = "cuboid", min = [3, 0, 0], max = [5, 1, 1] }
grid = { level = 3 }
material = { model = "st_venant_kirchhoff", young = 500.0, poisson = 0.25 }
dirichlet.xmin = { value = ["0", "free", "free"] }
dirichlet.ymin = { value = ["free", "0", "free"] }
dirichlet.zmin = { value = ["free", "free", "0"] }
dirichlet.xmax = { value = ["-0.3", "free", "free"], region = { max = [inf, 0.5, inf] } }
"#;

fn case_text(xmax: &str) -> String {
    TWO.replace("XMAX", xmax)
}

/// A scratch folder with `<name>.toml` holding `text`.
fn scratch(name: &str, text: &str) -> (PathBuf, PathBuf) {
    let d = std::env::temp_dir().join(format!("cgfem-bodies-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let case = d.join(format!("{name}.toml"));
    std::fs::write(&case, text).unwrap();
    (d, case)
}

fn cli(case: &Path, out: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"))
        .arg("run")
        .arg(case)
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

fn report(out: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap()
}

#[test]
fn two_bodies_apart_run_from_the_command_line() {
    let (dir, case) = scratch("two", &case_text("0.5"));
    let out = dir.join("out");
    let o = cli(&case, &out, &["--level", "2"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let pvd = std::fs::read_to_string(out.join("solution.pvd")).unwrap();
    // Two bodies, two steps: a volume and a surface each (no contact pair).
    assert_eq!(pvd.matches("<DataSet ").count(), 2 * 2 * 2, "{pvd}");
    for (file, part, t) in [
        ("left_2.vtu", 0, "1.0"),
        ("right_1.vtu", 1, "0.5"),
        ("left_surface_1.vtp", 2, "0.5"),
        ("right_surface_2.vtp", 3, "1.0"),
    ] {
        let entry = format!("timestep=\"{t}\" group=\"\" part=\"{part}\" file=\"{file}\"");
        assert!(pvd.contains(&entry), "{entry} in {pvd}");
        assert!(out.join(file).is_file());
    }
    let r = report(&out);
    assert_eq!(r["status"], "ok");
    assert_eq!(r["contact"], Value::Array(vec![]));
    assert_eq!(r["converged_steps"], 2);
    let levels: Vec<&Value> = r["bodies"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| &b["level"])
        .collect();
    assert_eq!(levels, [2, 2]);
    let steps = r["load_steps"].as_array().unwrap();
    assert_eq!(steps.len(), 2);
    for (k, s) in steps.iter().enumerate() {
        assert_eq!(s["step"], k + 1);
        assert_eq!(s["load_factor"], 0.5 * (k + 1) as f64);
        assert_eq!(s["cuts"], 0);
        let newton = &s["newton"];
        let n = newton["iterations"].as_u64().unwrap() as usize;
        assert!(n >= 2, "{s}");
        assert_eq!(newton["residual_history"].as_array().unwrap().len(), n + 1);
        assert_eq!(newton["energy_history"].as_array().unwrap().len(), n + 1);
        assert_eq!(s["krylov_iterations"].as_array().unwrap().len(), n + 1);
    }
    // Without line search every update is a full step.
    let o = cli(&case, &out, &["--set", "newton.line_search=false"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for s in report(&out)["load_steps"].as_array().unwrap() {
        let alphas = s["newton"]["line_search"].as_array().unwrap();
        assert!(!alphas.is_empty() && alphas.iter().all(|a| a == 1.0), "{s}");
    }
    // --level 1 changes every body's grid.
    let o = cli(&case, &out, &["--level", "1"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = report(&out);
    for b in r["bodies"].as_array().unwrap() {
        assert_eq!(
            (b["level"].as_u64(), b["h"].as_f64()),
            (Some(1), Some(1.0)),
            "{b}"
        );
    }
}

/// Rollers on the min faces and `u_x = g` on xmax (where `region` holds).
fn alone(
    min: [f64; 3],
    material: Material,
    young: f64,
    g: f64,
    region: Option<Region>,
) -> HyperProblem {
    let level = 2;
    let max = [min[0] + 2.0, 1.0, 1.0];
    let geometry = Geometry::cuboid(min, max).unwrap();
    let grid = Grid::new(&Aabb::new(min, max), level, [0.0; 3]).unwrap();
    let cells = Cells::classify(&grid, &geometry, cut_rule_points(ElementOrder::Q1)).unwrap();
    let roller = |name: &str, axis: usize, value: f64| {
        let mut components = [false; 3];
        components[axis] = true;
        let mut v = [0.0; 3];
        v[axis] = value;
        let value: VectorField = Arc::new(move |_| v);
        DirichletCondition {
            tag: geometry.tag_id(name).unwrap(),
            components,
            value,
            ramps: [Ramp::LINEAR; 3],
        }
    };
    let dirichlet = [
        roller("xmin", 0, 0.0),
        roller("ymin", 1, 0.0),
        roller("zmin", 2, 0.0),
        roller("xmax", 0, g),
    ];
    let regions = [None, None, None, region];
    let beta = 30.0 * young;
    let conditions = Conditions {
        dirichlet: &dirichlet,
        regions: &regions,
        loads: &Loads::default(),
    };
    HyperProblem::new_restricted(&grid, &cells, ElementOrder::Q1, material, beta, &conditions)
        .unwrap()
}

#[test]
fn each_body_equals_its_solve_alone() {
    let case = Case::from_str_with("two.toml", &case_text("0.5"), &[]).unwrap();
    let outcome = run(&case, Some(2), None, &Silent).unwrap();
    outcome.result.unwrap();
    let lower_half: Region = Arc::new(|x| x[1] <= 0.5);
    let bodies = [
        alone(
            [0.0; 3],
            Material::neo_hookean(1000.0, 0.3),
            1000.0,
            0.5,
            None,
        ),
        alone(
            [3.0, 0.0, 0.0],
            Material::st_venant_kirchhoff(500.0, 0.25),
            500.0,
            -0.3,
            Some(lower_half),
        ),
    ];
    for (b, p) in bodies.iter().enumerate() {
        let mut solution = HyperSolution::zero(p);
        // Alone, with Jacobi (the stacked run used the case's multigrid).
        let mut opts = outcome.setup.newton.clone();
        opts.krylov.preconditioner = Preconditioner::Jacobi;
        solve_load_steps(
            p,
            &opts,
            &mut CpuTangentSolver::default(),
            &Silent,
            &mut solution,
        )
        .unwrap();
        let stacked = outcome.setup.problem.part(b, &outcome.solution.u);
        let diff = stacked
            .iter()
            .zip(&solution.u)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt();
        let norm = solution.u.iter().map(|a| a * a).sum::<f64>().sqrt();
        println!(
            "body {b}: ‖u_stacked − u_alone‖ / ‖u_alone‖ = {:.2e}",
            diff / norm
        );
        assert!(
            norm > 0.1 && diff <= 1e-10 * norm,
            "body {b}: {diff:e} of {norm:e}"
        );
    }
}

/// Runs a bad case into a folder that does not exist: exit 2, the key named,
/// nothing created.
fn refused(name: &str, text: &str, extra: &[&str], key: &str) {
    let (dir, case) = scratch(name, text);
    let out = dir.join("out");
    let o = cli(&case, &out, extra);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{name}: {stderr}");
    assert!(stderr.contains(key), "{name}: '{key}' not in {stderr}");
    assert!(!out.exists(), "{name}: wrote {}", out.display());
}

#[test]
fn bad_multi_body_inputs_exit_2_naming_the_key() {
    let good = case_text("0.5");
    refused("steps", &good, &["--set", "load.steps=0"], "load.steps");
    let pair = format!("{good}\n[[contact]]\nslave = \"left.xmax\"\nmaster = \"right.top\"\n");
    refused("tag", &pair, &[], "contact[0].master");
    // A master part on an STL surface is accepted: its master surface is the
    // part's own triangles (the runs: tests/suite/contact/stl_master.rs).
    let stl = format!("{}/cases/parts/7_8ths_cube.stl", env!("CARGO_MANIFEST_DIR"));
    let parts = ["xmin", "ymin", "zmin", "xmax"]
        .iter()
        .zip([[-1, 0, 0], [0, -1, 0], [0, 0, -1], [1, 0, 0]])
        .map(|(n, d)| {
            format!("{{ name = \"{n}\", normal = {{ direction = {d:?}, angle_deg = 1 }} }}")
        })
        .collect::<Vec<_>>()
        .join(", ");
    let stl_right = good.replace(
        r#"geometry = { type = "cuboid", min = [3, 0, 0], max = [5, 1, 1] }"#,
        &format!(r#"geometry = {{ type = "translate", by = [4, 0.5, 0.5], of = {{ type = "stl", path = "{stl}", scale = 0.025, parts = [{parts}] }} }}"#),
    );
    let stl_master =
        format!("{stl_right}\n[[contact]]\nslave = \"left.xmax\"\nmaster = \"right.xmin\"\n");
    Case::from_str_with("stl-master.toml", &stl_master, &[]).unwrap();
    let overlapping = good.replace(
        "min = [3, 0, 0], max = [5, 1, 1]",
        "min = [1, 0, 0], max = [3, 1, 1]",
    );
    refused("overlap", &overlapping, &[], "body[1].geometry");
    let offset = SLAB.replace("level = 3 }", "level = 3, offset = [0, 0, 0.5] }");
    refused("slab-offset", &offset, &[], "body[0].grid.offset");
    let thin = SLAB.replace("min = [0, 0, -1]", "min = [0, 0, 0.5]");
    refused("slab-thin", &thin, &[], "body[0].plane_strain");
}

#[test]
fn a_failing_load_step_exits_3_and_keeps_the_last_converged_step() {
    let (dir, case) = scratch("fail", &case_text("-1.8"));
    let out = dir.join("out");
    let o = cli(
        &case,
        &out,
        &[
            "--set",
            "newton.max_cuts=0",
            "--set",
            "newton.max_iterations=8",
        ],
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{stderr}");
    assert!(stderr.contains("load step 2"), "{stderr}");
    let r = report(&out);
    assert_eq!(r["status"], "failed");
    assert_eq!(r["converged_steps"], 1);
    let steps = r["load_steps"].as_array().unwrap();
    assert_eq!(
        (
            steps[0]["converged"].as_bool(),
            steps[1]["converged"].as_bool()
        ),
        (Some(true), Some(false))
    );
    assert!(steps[1]["failure"].is_string());
    let pvd = std::fs::read_to_string(out.join("solution.pvd")).unwrap();
    assert_eq!(pvd.matches("<DataSet ").count(), 2 * 2, "{pvd}");
    assert!(out.join("left_1.vtu").is_file() && !out.join("left_2.vtu").exists());
    assert!(out.join("left_surface_1.vtp").is_file());
}

/// A plane-strain neo-Hookean block stretched along x with free y faces.
const SLAB: &str = r#"
[load]
steps = 2
[newton]
rel_tol = 1e-11
energy_tol = 1e-22
[solver]
method = "cg"
rel_tol = 1e-12
[[body]]
name = "slab"
plane_strain = true
geometry = { type = "cuboid", min = [0, 0, -1], max = [2, 1, 1] }
grid = { level = 3 }
material = { model = "neo_hookean", young = 1000.0, poisson = 0.3 }
dirichlet.xmin = { value = ["0", "free", "free"] }
dirichlet.ymin = { value = ["free", "0", "free"] }
dirichlet.xmax = { value = ["0.4", "free", "free"] }
"#;

/// `λ2` of the plane-strain uniaxial state `F = diag(l1, λ2, 1)`, `P22 = 0`:
/// `μ (λ2² − 1) + λ ln(l1 λ2) = 0`.
fn plane_strain_lateral_stretch(m: &Material, l1: f64) -> f64 {
    let f = |l2: f64| m.mu * (l2 * l2 - 1.0) + m.lambda * (l1 * l2).ln();
    let (mut a, mut b) = (1e-3, 2.0);
    for _ in 0..200 {
        let c = 0.5 * (a + b);
        if f(c) > 0.0 {
            b = c;
        } else {
            a = c;
        }
    }
    0.5 * (a + b)
}

#[test]
fn a_plane_strain_slab_is_one_cell_thick_with_uz_held() {
    use cgfem_gpu::hyper::residual::point_fields;
    let case = Case::from_str_with("slab.toml", SLAB, &[]).unwrap();
    for level in [2, 3] {
        let grid = &case.grids(Some(level)).unwrap()[0];
        let h = 2.0 / (1 << level) as f64;
        assert_eq!(grid.n[2], 1);
        assert_eq!((grid.origin[2], grid.h), (-0.5 * h, h));
    }
    let outcome = run(&case, None, None, &Silent).unwrap();
    outcome.result.unwrap();
    let p = &outcome.setup.problem;
    assert_eq!(outcome.report.held_dofs, outcome.report.dofs / 3);
    let u = &outcome.solution.u;
    assert!(u.iter().skip(2).step_by(3).all(|&uz| uz == 0.0));
    let m = Material::neo_hookean(1000.0, 0.3);
    let fields = point_fields(&p.bodies[0], u).unwrap();
    let l1 = fields[0][0].0[(0, 0)];
    let l2 = plane_strain_lateral_stretch(&m, l1);
    let mut worst = 0.0f64;
    for (f, _) in fields.iter().flatten() {
        let exact = [[l1, 0.0, 0.0], [0.0, l2, 0.0], [0.0, 0.0, 1.0]];
        for i in 0..3 {
            for j in 0..3 {
                worst = worst.max((f[(i, j)] - exact[i][j]).abs());
            }
        }
    }
    println!("plane strain: λ1 = {l1:.6}, λ2 = {l2:.6}, max |F − F_exact| = {worst:.1e}");
    assert!(l1 > 1.15 && l1 < 1.2, "{l1}");
    assert!(worst < 1e-6, "{worst:e}");
}

/// SIGINT after the first converged load step (of 1000): the run stops at a
/// Newton iteration boundary with code 130, the report marked interrupted and
/// every converged step's files in the series.
#[cfg(unix)]
#[test]
fn ctrl_c_stops_at_a_newton_boundary_with_code_130() {
    let (dir, case) = scratch("sigint", &case_text("0.5"));
    let out = dir.join("out");
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"));
    cmd.arg("run")
        .arg(&case)
        .arg("--out")
        .arg(&out)
        .args(["--set", "load.steps=1000"]);
    let (code, seen) = sigint::interrupt_after(cmd, "load step 1 converged");
    assert_eq!(code, Some(130), "{seen}");
    let r = report(&out);
    assert_eq!(r["status"], "interrupted");
    let converged = r["converged_steps"].as_u64().unwrap() as usize;
    assert!((1..1000).contains(&converged), "{converged}");
    let pvd = std::fs::read_to_string(out.join("solution.pvd")).unwrap();
    assert_eq!(pvd.matches("<DataSet ").count(), 2 * 2 * converged);
    let last = r["load_steps"].as_array().unwrap().last().unwrap().clone();
    assert_eq!(last["converged"], false, "{last}");
}
