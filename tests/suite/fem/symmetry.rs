//! Symmetry planes: a quarter model with `symmetry` planes equals the full
//! model. A plate with a central hole, pulled by ±δ on its two ends, against
//! its quarter `x ≥ 0, y ≥ 0` pulled on one end, on the same grid (the
//! planes x = 0 and y = 0 are planes of nodes of both): the displacements
//! at every node of the quarter and the end's reaction (half of the full
//! one) agree to 1e-8 relative, with the S-term off (`k2 = 0`) and with the
//! default S-term. With the S-term the quarter's patches continue across the
//! planes (mirrored, `recovery::mirror_tests`), and the full model's cut
//! cells sample mirror-image points on the two sides of each plane
//! (`Cells::fit_points`).

use std::collections::HashMap;

use cgfem_gpu::bodies::run::{run, RunOutcome};
use cgfem_gpu::case::Case;
use cgfem_gpu::element::ElementOrder;
use cgfem_gpu::progress::Silent;

/// The plate: 2 × 2 × 0.25, a hole of radius 0.3 through its centre.
const PLATE: &str = r#"{ type = "difference", of = [
  { type = "cuboid", min = [-1, -1, -0.125], max = [1, 1, 0.125] },
  { type = "retag", from = "side", to = "hole", of = { type = "cylinder", start = [0, 0, -1], end = [0, 0, 1], radius = 0.3 } } ] }"#;

/// Settings shared by both models: one load step of a linear body, tight
/// tolerances, the S-term's weight `k2` (`None`: the default).
fn settings(k2: Option<f64>) -> String {
    let stabilisation = k2.map_or(String::new(), |k2| format!("[stabilisation]\nk2 = {k2}\n"));
    format!(
        "[load]\nsteps = 1\n[newton]\nrel_tol = 1e-12\nenergy_tol = 1e-24\nfixed_point_tol = 1e-12\n\
         [solver]\nmethod = \"cg\"\nrel_tol = 1e-13\n{stabilisation}"
    )
}

fn full(level: u32, k2: Option<f64>) -> String {
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

fn quarter(level: u32, k2: Option<f64>) -> String {
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

fn solve(name: &str, text: &str) -> RunOutcome {
    let case = Case::from_str(name, text).unwrap();
    let outcome = run(&case, None, None, &Silent).unwrap();
    if let Err(e) = &outcome.result {
        panic!("{name}: {e}");
    }
    outcome
}

/// Node positions in cells from the origin of the full model's grid.
fn key(x: [f64; 3], origin: [f64; 3], h: f64) -> [i64; 3] {
    [0, 1, 2].map(|a| ((x[a] - origin[a]) / h).round() as i64)
}

/// The largest difference of the quarter's nodal displacements from the full
/// model's at the same points, relative to the largest displacement; and
/// the end's x-reaction of each.
fn compare(level: u32, k2: Option<f64>) -> (f64, f64, f64) {
    let f = solve("full.toml", &full(level, k2));
    let q = solve("quarter.toml", &quarter(level, k2));
    let (gf, gq) = (&f.setup.bodies[0].grid, &q.setup.bodies[0].grid);
    assert_eq!(gf.h, gq.h, "the two grids have one cell size");
    let origin = gf.origin;
    let mut by_point = HashMap::new();
    let df = &f.setup.problem.bodies[0].dofs;
    for (a, &n) in df.active_to_node.iter().enumerate() {
        let x = gf.node_position(ElementOrder::Q1, n as usize);
        by_point.insert(key(x, origin, gf.h), a);
    }
    let (uf, uq) = (&f.solution.u, &q.solution.u);
    let scale = uf.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut worst = 0.0f64;
    let dq = &q.setup.problem.bodies[0].dofs;
    for (a, &n) in dq.active_to_node.iter().enumerate() {
        let x = gq.node_position(ElementOrder::Q1, n as usize);
        let b = by_point[&key(x, origin, gf.h)];
        for c in 0..3 {
            let d = (uq[3 * a + c] - uf[3 * b + c]).abs();
            worst = worst.max(d);
        }
    }
    let reaction = |o: &RunOutcome| {
        let row = o.report.reactions.iter().find(|r| r.part == "xmax");
        row.expect("a reaction on xmax").force[0]
    };
    (worst / scale, reaction(&f), reaction(&q))
}

#[test]
fn a_quarter_model_with_symmetry_planes_equals_the_full_model() {
    for (level, k2) in [(3, Some(0.0)), (4, Some(0.0)), (3, None), (4, None)] {
        let (du, rf, rq) = compare(level, k2);
        let dr = (rf - 2.0 * rq).abs() / rf.abs();
        println!(
            "level {level}, k2 = {k2:?}: displacements differ by {du:.2e}, \
             xmax reactions {rf:.9e} (full) and 2 × {rq:.9e} (quarter), {dr:.2e}"
        );
        assert!(
            du < 1e-8,
            "level {level}, k2 = {k2:?}: displacements differ by {du:e}"
        );
        assert!(
            dr < 1e-8,
            "level {level}, k2 = {k2:?}: reactions differ by {dr:e}"
        );
    }
}

#[test]
fn a_symmetry_part_must_be_a_plane_of_nodes() {
    // The plate's hole is not a plane.
    let text =
        full(3, Some(0.0)).replace("dirichlet.xmin", "symmetry = [\"hole\"]\ndirichlet.xmin");
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
    let text = quarter(3, Some(0.0)).replace(
        "point = [0, 0, 0], normal = [-1",
        "point = [0.08, 0, 0], normal = [-1",
    );
    let case = Case::from_str("quarter.toml", &text).unwrap();
    match run(&case, None, None, &Silent) {
        Err(cgfem_gpu::Error::CaseFile { key, reason, .. }) => {
            assert_eq!(key, "body[0].symmetry");
            assert!(reason.contains("face of the grid box"), "{reason}");
        }
        Err(e) => panic!("expected a case-file error, got {e}"),
        Ok(_) => panic!("accepted a symmetry plane between the nodes"),
    }
}

/// An eighth of a square bar (1.4 × 1.4, length 2; its sides cut the
/// cells) held only by its three symmetry planes x = 0, y = 0, z = 0 and
/// pulled by the traction `E ε` on its end: uniaxial stress,
/// `u = ε (x, −ν y, −ν z)`, which Q1 represents exactly and which flat cuts
/// integrate exactly. (A round bar's traction-free side is integrated to
/// the rules' order only: `docs/cut-cell-consistency.md`.)
fn eighth_bar(preconditioner: &str) -> String {
    format!(
        r#"{}
[[body]]
name = "bar"
geometry = {{ type = "cuboid", min = [0, 0, 0], max = [1, 0.7, 0.7] }}
grid = {{ level = 3, box_min = [0, 0, 0], box_max = [1, 1, 1] }}
material = {{ model = "linear", young = 1000.0, poisson = 0.3 }}
symmetry = ["xmin", "ymin", "zmin"]
neumann.xmax = {{ traction = ["10", "0", "0"] }}
"#,
        settings(Some(0.0)).replace(
            "method = \"cg\"",
            &format!("method = \"cg\"\npreconditioner = \"{preconditioner}\"")
        )
    )
}

/// The bar with each preconditioner: the exact field to round-off, and
/// multigrid in fewer Krylov iterations than Jacobi (its levels hold the
/// planes' normal components too: without them every level of this bar is
/// singular, and CG took 487 iterations against Jacobi's 213).
#[test]
fn a_body_held_only_by_symmetry_planes_solves_exactly_with_either_preconditioner() {
    let mut iterations = Vec::new();
    for preconditioner in ["multigrid", "jacobi"] {
        let o = solve("bar.toml", &eighth_bar(preconditioner));
        let grid = &o.setup.bodies[0].grid;
        let dofs = &o.setup.problem.bodies[0].dofs;
        let (eps, nu) = (0.01, 0.3);
        let mut worst = 0.0f64;
        for (a, &n) in dofs.active_to_node.iter().enumerate() {
            let x = grid.node_position(ElementOrder::Q1, n as usize);
            let exact = [eps * x[0], -nu * eps * x[1], -nu * eps * x[2]];
            for (c, e) in exact.iter().enumerate() {
                worst = worst.max((o.solution.u[3 * a + c] - e).abs());
            }
        }
        let krylov: usize = o
            .solution
            .attempts
            .iter()
            .flat_map(|a| &a.krylov_iterations)
            .sum();
        println!("{preconditioner}: largest nodal error {worst:.2e} of ε = {eps}, {krylov} Krylov iterations");
        assert!(
            worst < 1e-9 * eps,
            "{preconditioner}: nodal error {worst:e}"
        );
        iterations.push(krylov);
    }
    assert!(
        iterations[0] < iterations[1],
        "multigrid took {} Krylov iterations, Jacobi {}",
        iterations[0],
        iterations[1]
    );
}
