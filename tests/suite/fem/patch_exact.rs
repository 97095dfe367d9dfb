//! Patch tests to round-off on parts with edges and corners, with the default
//! discretisation settings (cut rules, stabilisation): Q1 with a linear field,
//! Q2 with a quadratic one, on the sphere, the half torus of `cases/`, a
//! cuboid minus a tilted cylinder, the bracket of `cases/` and three STL parts
//! of `cases/parts/` (a re-entrant cube, a plate with holes, the embossed
//! calibration cube), and the re-entrant cube notched by a tilted drilled
//! hole through its face `x = −20` (an STL leaf in a CSG tree: where the
//! hole meets a face the face is a plane leaf for Saye's rule, and where it
//! crosses the cube's edges `quadrature::mixed` gives its first-order
//! rule) and a block with that cube as a cavity (the exact rule of a mesh's
//! outside), under random
//! grid offsets and rotations of the part, with Dirichlet data on some parts
//! and the exact traction on the others. Only the solver is tightened: the
//! patch test measures the discretisation, not the stopping tolerance.
//!
//! The first placement of each part is aligned (offset 0, no rotation: the
//! planar faces lie on grid planes). Each placement first checks the discrete system itself: the interpolant
//! of the exact field satisfies it to round-off. Then it solves and checks the
//! energy error.
//!
//! The placements are solved with the multigrid preconditioner, whose
//! coarsest level is a sparse Cholesky factor: at these sizes most of the
//! system. With Jacobi the rotated STL 7/8 cube at level 2 (Q2) stalled at an
//! outer residual of 1.3e-14 (energy error 1.2e-10 at 2e-14), and the bracket
//! at level 4 needed about a thousand outer iterations. With multigrid
//! (2026-11-26) they need 132 and 17–40, in 4.5 s and 4–28 s, with energy
//! errors 6.7e-11 and 6.2e-11 / 4.0e-12.
//!
//! The STL plate with holes is 12.7 mm thick on cells of 19 mm (level 4):
//! nearly every cell is pathological and, rotated, every cell is a sliver.
//! Its outer FGMRES needs 50–110 iterations, and it reaches the tolerance
//! only because the outer loop confirms its residual estimate with the true
//! residual (`cgfem_gpu::driver::outer_krylov`): before that (2026-11-26) the
//! estimate drifted from the true residual, the rotated Q1 placements
//! stopped at energy errors of 7e-11 to 1.1e-10, and the Q2 ones were not
//! solved (aligned 7.2e-10; rotated, still 3.5e-8 after 300 s).
//!
//! `CGFEM_PATCH_CASES=N` runs N random placements per part and order besides
//! the aligned one (default 1; see [`placements`] for the fast tier).

use cgfem_gpu::case::Case;
use cgfem_gpu::driver::fixed_point::FixedPointReport;
use cgfem_gpu::driver::setup::Setup;
use cgfem_gpu::driver::solve::solve;
use cgfem_gpu::solver::Preconditioner;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::common::patch_check;
use patch_check::{energy_error, interpolant_residual, SOLVER};

/// Relative energy error the patch tests must reach.
const PATCH_TOL: f64 = 1e-10;

/// Relative residual of the exact field's interpolant in the discrete system.
const RESIDUAL_TOL: f64 = 1e-12;

/// A part: its geometry (TOML inline table), Dirichlet and exact-traction tags,
/// a length scale for the field and the material.
struct Part {
    name: &'static str,
    geometry: &'static str,
    dirichlet: &'static [&'static str],
    neumann: &'static [&'static str],
    scale: f64,
    young: f64,
    /// Levels above the test's level (the bracket's holes need a finer grid
    /// for the fixed point of its small Dirichlet part to contract, the thin
    /// plate one, at which its figures below were measured).
    extra_level: u32,
}

const PARTS: [Part; 9] = [
    Part {
        name: "sphere",
        geometry: r#"{ type = "intersection", of = [
            { type = "sphere", center = [0.1, -0.05, 0.02], radius = 0.9 },
            { type = "half_space", point = [0, 0, 0.55], normal = [0.1, 0.2, 1] } ] }"#,
        dirichlet: &["plane"],
        neumann: &["surface"],
        scale: 1.0,
        young: 1000.0,
        extra_level: 0,
    },
    Part {
        name: "half torus",
        geometry: r#"{ type = "intersection", of = [
            { type = "torus", center = [0, 0, 0], axis = [0, 0, 1], major_radius = 1.0, minor_radius = 0.35 },
            { type = "retag", from = "plane", to = "feet", of = { type = "half_space", point = [0, 0, 0], normal = [0, -1, 0] } } ] }"#,
        dirichlet: &["feet"],
        neumann: &["surface"],
        scale: 1.0,
        young: 1000.0,
        extra_level: 0,
    },
    Part {
        name: "plate minus tilted cylinder",
        geometry: r#"{ type = "difference", of = [
            { type = "cuboid", min = [-1, -1, -0.5], max = [1, 1, 0.5] },
            { type = "rotate", axis = [1, 1, 0], angle_deg = 20, of = { type = "cylinder", start = [0, 0, -1], end = [0, 0, 1], radius = 0.35 } } ] }"#,
        dirichlet: &["xmin", "side"],
        neumann: &["xmax", "ymin", "ymax", "zmin", "zmax"],
        scale: 1.0,
        young: 1000.0,
        extra_level: 0,
    },
    Part {
        name: "bracket",
        geometry: r#"{ type = "difference", of = [
            { type = "union", of = [
                { type = "cuboid", min = [0.0, 0.0, 0.0], max = [80.0, 40.0, 10.0] },
                { type = "retag", from = "zmax", to = "load", of = { type = "cuboid", min = [0.0, 0.0, 0.0], max = [10.0, 40.0, 60.0] } } ] },
            { type = "tag", name = "bolt_holes", of = { type = "union", of = [
                { type = "cylinder", start = [50.0, 20.0, -5.0], end = [50.0, 20.0, 15.0], radius = 6.0 },
                { type = "cylinder", start = [70.0, 20.0, -5.0], end = [70.0, 20.0, 15.0], radius = 6.0 } ] } } ] }"#,
        dirichlet: &["bolt_holes", "zmin"],
        neumann: &["load", "xmin", "xmax", "ymin", "ymax", "zmax"],
        scale: 40.0,
        young: 210000.0,
        extra_level: 1,
    },
    Part {
        name: "7/8 cube (STL)",
        geometry: r#"{ type = "stl", path = "cases/parts/7_8ths_cube.stl", parts = [
            { name = "clamped", normal = { direction = [-1, 0, 0], angle_deg = 1 } } ] }"#,
        dirichlet: &["clamped"],
        neumann: &["surface"],
        scale: 20.0,
        young: 1000.0,
        extra_level: 0,
    },
    Part {
        name: "plate with holes (STL)",
        geometry: r#"{ type = "stl", path = "cases/parts/plate_holes.stl", parts = [
            { name = "clamped", plane = { point = [0, 0, 0], normal = [0, 1, 0], tolerance = 1e-6 } } ] }"#,
        dirichlet: &["clamped"],
        neumann: &["surface"],
        scale: 150.0,
        young: 210000.0,
        extra_level: 1,
    },
    Part {
        name: "xyz cube (STL)",
        geometry: r#"{ type = "stl", path = "cases/parts/20mm-xyz-cube.stl", parts = [
            { name = "clamped", normal = { direction = [0, 0, -1], angle_deg = 1 } } ] }"#,
        dirichlet: &["clamped"],
        neumann: &["surface"],
        scale: 10.0,
        young: 1000.0,
        extra_level: 0,
    },
    Part {
        name: "7/8 cube notched by a tilted drilled hole (STL and CSG)",
        geometry: r#"{ type = "difference", of = [
            { type = "stl", path = "cases/parts/7_8ths_cube.stl", parts = [
                { name = "clamped", normal = { direction = [0, 0, -1], angle_deg = 1 } } ] },
            { type = "tag", name = "hole", of = { type = "cylinder", start = [-19, -5, -30], end = [-17, -8, 30], radius = 6 } } ] }"#,
        dirichlet: &["clamped", "hole"],
        neumann: &["surface"],
        scale: 20.0,
        young: 1000.0,
        extra_level: 0,
    },
    Part {
        name: "block with an STL cavity",
        geometry: r#"{ type = "difference", of = [
            { type = "cuboid", min = [-41, -42, -43], max = [41, 42, 43] },
            { type = "rotate", axis = [0.3, -0.5, 0.8], angle_deg = 37, of = { type = "stl", path = "cases/parts/7_8ths_cube.stl", tag = "cavity" } } ] }"#,
        dirichlet: &["zmin"],
        neumann: &["cavity", "xmin", "xmax", "ymin", "ymax", "zmax"],
        scale: 40.0,
        young: 1000.0,
        extra_level: 0,
    },
];

/// A polynomial field of `degree` (1 or 2) with random coefficients, lengths
/// scaled by `s`: `u_i = Σ c x^a y^b z^c / s^(a+b+c)` (strain of order 0.01).
fn random_field(rng: &mut ChaCha8Rng, degree: u32, s: f64) -> [String; 3] {
    let monomials: &[&str] = if degree == 1 {
        &["x", "y", "z"]
    } else {
        &["x", "y", "z", "x*x", "y*y", "z*z", "x*y", "y*z", "x*z"]
    };
    [0, 1, 2].map(|_| {
        let mut terms = vec![format!("{:.6}", rng.gen_range(-0.01..0.01) * s)];
        for m in monomials {
            let order = m.matches(['x', 'y', 'z']).count() as i32;
            let c = rng.gen_range(-0.01..0.01) / s.powi(order - 1);
            terms.push(format!("({c:.8})*{m}"));
        }
        terms.join(" + ")
    })
}

/// A placement of `part`; `aligned`: offset 0 and no rotation, so that the
/// planar faces of the part lie on grid planes.
fn patch_case(
    part: &Part,
    element: &str,
    rng: &mut ChaCha8Rng,
    level: u32,
    aligned: bool,
) -> (Case, String) {
    let degree = if element == "q1" { 1 } else { 2 };
    let field = random_field(rng, degree, part.scale);
    let mut offset = [0, 1, 2].map(|_| rng.gen_range(0.0..1.0));
    let axis = [0, 1, 2].map(|_| rng.gen_range(-1.0..1.0));
    let mut angle = rng.gen_range(0.0..360.0);
    if aligned {
        offset = [0.0; 3];
        angle = 0.0;
    }
    let mut text = format!(
        "element = \"{element}\"\n[geometry]\ntype = \"rotate\"\naxis = [{:.4}, {:.4}, {:.4}]\nangle_deg = {angle:.3}\nof = {}\n[grid]\nlevel = {level}\noffset = [{:.4}, {:.4}, {:.4}]\n[material]\nyoung = {}\npoisson = 0.3\n[exact]\ndisplacement = [\"{}\", \"{}\", \"{}\"]\n{SOLVER}",
        axis[0], axis[1], axis[2], part.geometry.replace('\n', " "), offset[0], offset[1], offset[2],
        part.young, field[0], field[1], field[2]
    );
    for tag in part.dirichlet {
        text.push_str(&format!("[dirichlet.{tag}]\nvalue = \"exact\"\n"));
    }
    for tag in part.neumann {
        text.push_str(&format!("[neumann.{tag}]\ntraction = \"exact\"\n"));
    }
    let what = format!(
        "{} {element} level {level} offset {offset:.3?} rotation {angle:.1}° about {axis:.3?}",
        part.name
    );
    (Case::from_str("patch.toml", &text).unwrap(), what)
}

/// Random placements of `part` besides the aligned one: `CGFEM_PATCH_CASES`,
/// else one — except that the fast tier leaves out the rotated Q2 placements
/// of the parts on a finer grid (the bracket and the plate with holes at
/// level 4: 60 s and 30 s of the run, where every other placement takes a
/// few seconds); the long tier (`CGFEM_LONG=1`) runs them.
fn placements(part: &Part, element: &str) -> usize {
    if let Some(n) = std::env::var("CGFEM_PATCH_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        return n;
    }
    let heavy = element == "q2" && part.extra_level > 0;
    usize::from(!heavy || std::env::var_os("CGFEM_LONG").is_some())
}

fn run_patch_tests(element: &str, level: u32, seed: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // The placements drawn in order (the same cases on any number of
    // threads), then solved in parallel.
    let mut cases = Vec::new();
    for part in &PARTS {
        for placement in 0..=placements(part, element) {
            let extra = part.extra_level * if element == "q1" { 1 } else { 2 };
            cases.push(patch_case(
                part,
                element,
                &mut rng,
                level + extra,
                placement == 0,
            ));
        }
    }
    let worst = cases
        .into_par_iter()
        .map(|(mut case, what)| {
            case.spec.solver.preconditioner = Preconditioner::Multigrid;
            let setup = Setup::new(&case, None).unwrap();
            let residual = interpolant_residual(&setup);
            println!("{what}: relative residual of the interpolant {residual:.2e}");
            assert!(residual < RESIDUAL_TOL, "{what}: residual {residual:.3e}");
            let mut report = FixedPointReport::default();
            let sol = solve(&setup, &case.spec.solver, &mut report)
                .unwrap_or_else(|e| panic!("{what}: {e} {:?}", report.eps_history));
            let e = energy_error(&setup, &sol.u);
            println!(
                "{what}: energy error {:.2e}, {} cut cells ({} merged), {} fixed-point iterations",
                e,
                setup.cells.cut.len(),
                setup.cells.merged.len(),
                report.iterations
            );
            assert!(report.converged, "{what}: fixed point did not converge");
            assert!(e < PATCH_TOL, "{what}: energy error {:.3e}", e);
            e
        })
        .reduce(|| 0.0, f64::max);
    println!("{element}: worst relative energy error {worst:.2e}");
}

#[test]
fn q1_reproduces_a_linear_field_on_parts_with_edges() {
    run_patch_tests("q1", 3, 11);
}

#[test]
fn q2_reproduces_a_quadratic_field_on_parts_with_edges() {
    run_patch_tests("q2", 2, 12);
}

/// A bar with a slot 0.1 wide, thinner than its cells at levels 4 and 5 (h
/// 0.25 and 0.125 unrotated), placed at random: the walls' nodes are copied,
/// each piece of a split cell carries its own flux correction, and the
/// patch test is as exact as elsewhere.
#[test]
fn q1_reproduces_a_linear_field_across_a_slot_thinner_than_a_cell() {
    let part = Part {
        name: "slotted bar",
        geometry: r#"{ type = "difference", of = [
            { type = "cuboid", min = [0, 0, 0], max = [4, 1, 1] },
            { type = "tag", name = "slot", of = { type = "cuboid", min = [1.95, -1, 0.2], max = [2.05, 2, 2] } } ] }"#,
        dirichlet: &["xmin"],
        neumann: &["xmax", "ymin", "ymax", "zmin", "zmax", "slot"],
        scale: 4.0,
        young: 1000.0,
        extra_level: 0,
    };
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    for (level, aligned) in [(4, true), (4, false), (5, false)] {
        let (mut case, what) = patch_case(&part, "q1", &mut rng, level, aligned);
        case.spec.solver.preconditioner = Preconditioner::Multigrid;
        let setup = Setup::new(&case, None).unwrap();
        assert!(setup.op.dofs.has_copies(), "{what}: no copies");
        let residual = interpolant_residual(&setup);
        assert!(residual < RESIDUAL_TOL, "{what}: residual {residual:.3e}");
        let mut report = FixedPointReport::default();
        let sol = solve(&setup, &case.spec.solver, &mut report).unwrap();
        let e = energy_error(&setup, &sol.u);
        println!("{what}: residual {residual:.2e}, energy error {e:.2e}");
        assert!(report.converged, "{what}: fixed point did not converge");
        assert!(e < PATCH_TOL, "{what}: energy error {e:.3e}");
    }
}
