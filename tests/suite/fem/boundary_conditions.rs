//! The boundary-condition vocabulary of a case, checked by exact solutions
//! and by equalities between two ways of writing the same problem:
//! rollers (Dirichlet conditions with `"free"` components) reproduce linear
//! (Q1) and quadratic (Q2) fields to round-off on a cut sphere octant, a
//! `region` restricts a condition to a box, `pressure = p` is the
//! traction `−p n`, and a linear and a neo-Hookean `[[body]]` with the same
//! rollers and pressure agree at small strain.

use cgfem_gpu::bodies::run::run;
use cgfem_gpu::case::Case;
use cgfem_gpu::driver::fixed_point::FixedPointReport;
use cgfem_gpu::driver::setup::Setup;
use cgfem_gpu::driver::solve::{solve, Solution};
use cgfem_gpu::progress::Silent;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::common::patch_check;
use patch_check::{energy_error, interpolant_residual, norm, SOLVER};

/// Solves a case; returns the setup, the solution and the relative energy
/// error against its exact field.
fn solve_case(text: &str) -> (Setup, Solution, f64) {
    let case = Case::from_str("bc.toml", text).unwrap();
    let setup = Setup::new(&case, None).unwrap();
    let mut report = FixedPointReport::default();
    let sol = solve(&setup, &case.spec.solver, &mut report).unwrap();
    assert!(report.converged, "fixed point did not converge");
    let e = energy_error(&setup, &sol.u);
    (setup, sol, e)
}

/// A sphere octant (radius 0.9) at a random grid offset, rollers on its three
/// planes, the exact traction on the sphere, and the field
/// `u_i = a_i x_i + b_i x_i²` (`b = 0` for Q1): the only polynomial fields of
/// degree ≤ 2 with `u_i = 0` and no tangential traction on the plane `x_i = 0`.
fn roller_octant(element: &str, level: u32, rng: &mut ChaCha8Rng) -> String {
    let quadratic = element == "q2";
    let field = [0, 1, 2].map(|i| {
        let (a, b) = (rng.gen_range(-0.01..0.01), rng.gen_range(-0.01..0.01));
        let x = ["x", "y", "z"][i];
        match quadratic {
            true => format!("({a:.8})*{x} + ({b:.8})*{x}*{x}"),
            false => format!("({a:.8})*{x}"),
        }
    });
    let offset = [0, 1, 2].map(|_| rng.gen_range(0.0..1.0));
    format!(
        r#"element = "{element}"
[geometry]
type = "intersection"
of = [
  {{ type = "sphere", center = [0, 0, 0], radius = 0.9 }},
  {{ type = "cuboid", min = [0, 0, 0], max = [2, 2, 2] }},
]
[grid]
level = {level}
offset = [{:.4}, {:.4}, {:.4}]
[material]
young = 1000.0
poisson = 0.3
[exact]
displacement = ["{}", "{}", "{}"]
[dirichlet.xmin]
value = ["exact", "free", "free"]
[dirichlet.ymin]
value = ["free", "0", "free"]
[dirichlet.zmin]
value = ["free", "free", "exact"]
[neumann.surface]
traction = "exact"
{SOLVER}"#,
        offset[0], offset[1], offset[2], field[0], field[1], field[2]
    )
}

/// Q1 at level 3 and Q2 at level 2; the long tier (`CGFEM_LONG=1`) adds Q1
/// at level 4 and Q2 at level 3 (the same random fields and offsets).
#[test]
fn rollers_reproduce_linear_and_quadratic_fields() {
    let mut rng = ChaCha8Rng::seed_from_u64(18);
    let long = std::env::var_os("CGFEM_LONG").is_some();
    for (element, level, fast) in [
        ("q1", 3, true),
        ("q1", 4, false),
        ("q2", 2, true),
        ("q2", 3, false),
    ] {
        let text = roller_octant(element, level, &mut rng);
        if !(fast || long) {
            continue;
        }
        let case = Case::from_str("rollers.toml", &text).unwrap();
        let setup = Setup::new(&case, None).unwrap();
        let residual = interpolant_residual(&setup);
        let (_, sol, e) = solve_case(&text);
        println!(
            "{element} level {level}: interpolant residual {residual:.2e}, energy error {e:.2e}"
        );
        assert!(
            residual < 1e-12,
            "{element} level {level}: residual {residual:e}"
        );
        assert!(e < 1e-10, "{element} level {level}: energy error {e:e}");
        // A roller holds its normal component only: no reaction in the others.
        for (p, r) in setup.dirichlet.iter().zip(&sol.reactions) {
            for k in (0..3).filter(|&k| p.mask[k] == 0.0) {
                assert_eq!(r[k], 0.0, "a free component has a reaction");
            }
        }
    }
}

/// A cuboid in uniaxial stress along y, `u = ε(−ν x, y, −ν z)`: no traction
/// on the x and z faces. `xmin` is clamped only where `y ≤ 0`, with a value
/// that is wrong where `y > 0`; `region` must keep it there.
fn clamped_half_face(region: bool) -> String {
    let region = match region {
        true => "region = { max = [inf, 0.0, inf] }",
        false => "",
    };
    format!(
        r#"[geometry]
type = "cuboid"
min = [-1, -1, -0.5]
max = [1, 1, 0.5]
[grid]
level = 3
offset = [0.37, 0.21, 0.64]
[material]
young = 1000.0
poisson = 0.3
[exact]
displacement = ["-0.003*x", "0.01*y", "-0.003*z"]
[dirichlet.xmin]
value = ["-0.003*x", "0.01*y + 0.5*max(y, 0)", "-0.003*z"]
{region}
[neumann.ymin]
traction = "exact"
[neumann.ymax]
traction = "exact"
{SOLVER}"#
    )
}

#[test]
fn a_region_restricts_a_dirichlet_condition() {
    let (_, _, restricted) = solve_case(&clamped_half_face(true));
    let (_, _, whole) = solve_case(&clamped_half_face(false));
    println!("energy error with the region {restricted:.2e}, without {whole:.2e}");
    assert!(restricted < 1e-10, "with the region: {restricted:e}");
    assert!(whole > 1e-2, "the wrong values were not applied: {whole:e}");
}

/// A sphere octant with rollers, loaded on the sphere by `load`; the exact
/// field is hydrostatic compression under p = 100, `u = −p (1 − 2ν) / E x`.
fn pressurised_octant(load: &str) -> String {
    format!(
        r#"[geometry]
type = "intersection"
of = [
  {{ type = "sphere", center = [0, 0, 0], radius = 1.0 }},
  {{ type = "cuboid", min = [0, 0, 0], max = [2, 2, 2] }},
]
[grid]
level = 3
offset = [0.3, 0.6, 0.45]
[material]
young = 1000.0
poisson = 0.3
[exact]
displacement = ["-0.04*x", "-0.04*y", "-0.04*z"]
[dirichlet.xmin]
value = ["0", "free", "free"]
[dirichlet.ymin]
value = ["free", "0", "free"]
[dirichlet.zmin]
value = ["free", "free", "0"]
[neumann.surface]
{load}
{SOLVER}"#
    )
}

#[test]
fn a_pressure_is_the_normal_traction() {
    // External pressure p = 100 on the sphere: the exact field's traction is
    // −p n, with the same flux correction (its stress is −p I).
    let (_, by_pressure, e) = solve_case(&pressurised_octant("pressure = \"100\""));
    let (_, by_traction, _) = solve_case(&pressurised_octant("traction = \"exact\""));
    let diff: Vec<f64> = by_pressure
        .u
        .iter()
        .zip(&by_traction.u)
        .map(|(a, b)| a - b)
        .collect();
    let rel = norm(&diff) / norm(&by_traction.u);
    println!("pressure against the exact traction: {rel:.2e}; energy error {e:.2e}");
    assert!(rel < 1e-10, "pressure and traction differ by {rel:e}");
    assert!(e < 1e-10, "hydrostatic compression: energy error {e:e}");
}

/// The shell octant of `cases/shell_pressure.toml` as one `[[body]]` of
/// `model`, rollers on its planes and an inner pressure `p = 0.001` (strains
/// of order p/E = 1e-6).
fn shell_body(model: &str) -> String {
    format!(
        r#"[[body]]
name = "shell"
geometry = {{ type = "intersection", of = [
  {{ type = "shell", center = [0, 0, 0], inner_radius = 0.5, outer_radius = 1.0 }},
  {{ type = "cuboid", min = [0, 0, 0], max = [2, 2, 2] }} ] }}
grid = {{ level = 3, offset = [0.3, 0.6, 0.45] }}
material = {{ model = "{model}", young = 1000.0, poisson = 0.3 }}
neumann.inner = {{ pressure = "0.001" }}
dirichlet.xmin = {{ value = ["0", "free", "free"] }}
dirichlet.ymin = {{ value = ["free", "0", "free"] }}
dirichlet.zmin = {{ value = ["free", "free", "0"] }}
"#
    )
}

#[test]
fn a_linear_and_a_neo_hookean_body_agree_at_small_strain() {
    let solve = |model: &str| {
        let case = Case::from_str_with("shell.toml", &shell_body(model), &[]).unwrap();
        let outcome = run(&case, None, None, &Silent).unwrap();
        outcome.result.unwrap();
        outcome.solution
    };
    let (linear, neo) = (solve("linear"), solve("neo_hookean"));
    let diff: Vec<f64> = linear.u.iter().zip(&neo.u).map(|(a, b)| a - b).collect();
    let rel = norm(&diff) / norm(&linear.u);
    let strain = norm(&linear.u) / (linear.u.len() as f64).sqrt();
    println!(
        "linear against neo-Hookean: {rel:.2e} (rms displacement {strain:.1e}); \
         Newton iterations {} and {}",
        linear.newton_iterations(),
        neo.newton_iterations()
    );
    assert!(rel < 1e-5, "the models differ by {rel:e}");
    // The linear body's tangent is constant: one Newton iteration per pass.
    assert!(linear.newton_iterations() <= neo.newton_iterations());
}

/// A linear bar on `[0, 1] × [0, 0.5]²`, clamped on `xmin`, loaded on
/// `xmax` by `load` (a `neumann` or `dirichlet` entry), in 4 load steps.
fn ramped_bar(load: &str) -> String {
    format!(
        r#"[load]
steps = 4
[[body]]
name = "bar"
geometry = {{ type = "cuboid", min = [0, 0, 0], max = [1, 0.5, 0.5] }}
grid = {{ level = 3, offset = [0.3, 0.6, 0.45] }}
material = {{ model = "linear", young = 1000.0, poisson = 0.3 }}
dirichlet.xmin = {{ value = ["0", "0", "0"] }}
{load}
"#
    )
}

/// The x-reaction of the clamped face per converged step.
fn clamp_reactions(text: &str) -> Vec<f64> {
    let case = Case::from_str_with("bar.toml", text, &[]).unwrap();
    let outcome = run(&case, None, None, &Silent).unwrap();
    outcome.result.unwrap();
    let rows = outcome.report.reactions.iter().filter(|r| r.part == "xmin");
    rows.map(|r| r.force[0]).collect()
}

#[test]
fn a_ramp_holds_a_load_back_until_its_start() {
    // A traction of 8 on the 0.5 × 0.5 end: resultant 2. With ramp
    // [0.5, 1] steps 1 and 2 (t = 0.25, 0.5) carry nothing and steps 3 and 4
    // half and all of it; the clamp balances it (linear body: exactly, to
    // the solver's tolerance).
    let traction = clamp_reactions(&ramped_bar(
        r#"neumann.xmax = { traction = ["8", "0", "0"], ramp = [0.5, 1] }"#,
    ));
    println!("traction ramp [0.5, 1]: clamp reactions {traction:?}");
    let expected = [0.0, 0.0, -1.0, -2.0];
    for (r, e) in traction.iter().zip(expected) {
        assert!((r - e).abs() < 1e-6, "{traction:?}");
    }
    // A prescribed displacement on one component only: ramp [0, 0.5] on
    // u_x reaches its value at step 2 and holds it.
    let pulled = clamp_reactions(&ramped_bar(
        r#"dirichlet.xmax = { value = ["0.001", "free", "free"], ramp = [0, 0.5] }"#,
    ));
    println!("displacement ramp [0, 0.5]: clamp reactions {pulled:?}");
    assert!(pulled[0] < 0.0 && (pulled[1] / pulled[0] - 2.0).abs() < 1e-6);
    assert!((pulled[2] - pulled[1]).abs() < 1e-9 * pulled[1].abs());
    assert!((pulled[3] - pulled[1]).abs() < 1e-9 * pulled[1].abs());
}
