//! Symmetry planes: a part named in `symmetry` must be a plane of grid
//! nodes normal to an axis, else the run is refused naming the key.

use cgfem_gpu::bodies::run::run;
use cgfem_gpu::case::Case;
use cgfem_gpu::progress::Silent;

/// The plate: 2 × 2 × 0.25, a hole of radius 0.3 through its centre.
const PLATE: &str = r#"{ type = "difference", of = [
  { type = "cuboid", min = [-1, -1, -0.125], max = [1, 1, 0.125] },
  { type = "retag", from = "side", to = "hole", of = { type = "cylinder", start = [0, 0, -1], end = [0, 0, 1], radius = 0.3 } } ] }"#;

/// Settings shared by both models: one load step of a linear body, tight
/// tolerances, the S-term's weight `k2`.
fn settings(k2: f64) -> String {
    format!(
        "[load]\nsteps = 1\n[newton]\nrel_tol = 1e-12\nenergy_tol = 1e-24\nfixed_point_tol = 1e-12\n\
         [solver]\nmethod = \"cg\"\nrel_tol = 1e-13\n[stabilisation]\nk2 = {k2}\n"
    )
}

fn full(level: u32, k2: f64) -> String {
    format!(
        r#"{}
[[body]]
name = "plate"
geometry = {PLATE}
grid = {{ level = {level} }}
material = {{ model = "linear", young = 1000.0, poisson = 0.3 }}
dirichlet.xmin = {{ value = ["-0.01", "0", "0"] }}
dirichlet.xmax = {{ value = ["0.01", "0", "0"] }}
"#,
        settings(k2)
    )
}

fn quarter(level: u32, k2: f64) -> String {
    format!(
        r#"{}
[[body]]
name = "plate"
geometry = {{ type = "intersection", of = [
  {PLATE},
  {{ type = "tag", name = "cut_x", of = {{ type = "half_space", point = [0, 0, 0], normal = [-1, 0, 0] }} }},
  {{ type = "tag", name = "cut_y", of = {{ type = "half_space", point = [0, 0, 0], normal = [0, -1, 0] }} }} ] }}
grid = {{ level = {}, box_min = [0, 0, -0.125], box_max = [1, 1, 0.125] }}
material = {{ model = "linear", young = 1000.0, poisson = 0.3 }}
symmetry = ["cut_x", "cut_y"]
dirichlet.xmax = {{ value = ["0.01", "0", "0"] }}
"#,
        settings(k2),
        level - 1
    )
}

#[test]
fn a_symmetry_part_must_be_a_plane_of_nodes() {
    // The plate's hole is not a plane.
    let text = full(3, 0.0).replace("dirichlet.xmin", "symmetry = [\"hole\"]\ndirichlet.xmin");
    let case = Case::from_str("full.toml", &text).unwrap();
    match run(&case, None, None, &Silent) {
        Err(cgfem_gpu::Error::CaseFile { key, reason, .. }) => {
            assert_eq!(key, "body[0].symmetry");
            assert!(reason.contains("not a plane"), "{reason}");
        }
        Err(e) => panic!("expected a case-file error, got {e}"),
        Ok(_) => panic!("accepted a curved symmetry part"),
    }
    // A plane between the nodes: the quarter's cut moved by a third of a cell.
    let text = quarter(3, 0.0).replace(
        "point = [0, 0, 0], normal = [-1",
        "point = [0.08, 0, 0], normal = [-1",
    );
    let case = Case::from_str("quarter.toml", &text).unwrap();
    match run(&case, None, None, &Silent) {
        Err(cgfem_gpu::Error::CaseFile { key, reason, .. }) => {
            assert_eq!(key, "body[0].symmetry");
            assert!(reason.contains("plane of grid nodes"), "{reason}");
        }
        Err(e) => panic!("expected a case-file error, got {e}"),
        Ok(_) => panic!("accepted a symmetry plane between the nodes"),
    }
}
