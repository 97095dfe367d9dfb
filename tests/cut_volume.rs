//! Volume of parts with edges by the cut-cell rules against the exact value,
//! level by level: the cuboid minus a tilted cylinder (`4 − π r²/cos θ`, the
//! cylinder crosses the slab whole) and the bracket of `cases/`
//! (`52000 − 720π` mm³), under a random rotation and grid offset. The error
//! must converge at 2nd order or better with the Q1 rules and 3rd order or
//! better with the Q2 rules (the rates the elements need).
//!
//! Measured (this test's output, levels 2–5 for the plate, 3–5 for the
//! bracket): the errors sit at 1e-7–1e-6 (Q1 rules) and 1e-11–1e-9 (Q2 rules)
//! from the coarsest level on, a floor that hides the asymptotic rate (Saye's
//! rules before the edge splitting of `quadrature::saye`: 1e-3 → 3e-5 and
//! 7e-5 → 1e-6 on the plate). The fitted rate is therefore *not* the 2 (Q1)
//! and 3 (Q2) that issue 15 asks for; it is printed, and the test holds every
//! level below `1e-5` (Q1 rules) and `1e-8` (Q2 rules), which the rules
//! without edge splitting miss by one to three orders of magnitude.
//!
//! `CGFEM_VOLUME_LEVELS=N` adds levels up to N (default: 2–5 for the plate,
//! 3–5 for the bracket).

use cgfem_gpu::case::Case;
use cgfem_gpu::grid::Grid;

const PLATE: &str = r#"type = "rotate"
axis = [0.3, -0.5, 0.8]
angle_deg = 37
of = { type = "difference", of = [ { type = "cuboid", min = [-1, -1, -0.5], max = [1, 1, 0.5] }, { type = "rotate", axis = [1, 1, 0], angle_deg = 20, of = { type = "cylinder", start = [0, 0, -1], end = [0, 0, 1], radius = 0.35 } } ] }"#;

const BRACKET: &str = r#"type = "rotate"
axis = [-0.2, 0.9, 0.4]
angle_deg = 23
of = { type = "difference", of = [ { type = "union", of = [ { type = "cuboid", min = [0.0, 0.0, 0.0], max = [80.0, 40.0, 10.0] }, { type = "cuboid", min = [0.0, 0.0, 0.0], max = [10.0, 40.0, 60.0] } ] }, { type = "union", of = [ { type = "cylinder", start = [50.0, 20.0, -5.0], end = [50.0, 20.0, 15.0], radius = 6.0 }, { type = "cylinder", start = [70.0, 20.0, -5.0], end = [70.0, 20.0, 15.0], radius = 6.0 } ] } ] }"#;

fn max_level(default: u32) -> u32 {
    std::env::var("CGFEM_VOLUME_LEVELS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Relative volume errors at `levels` with the rules of `element`.
fn volume_errors(geometry: &str, exact: f64, element: &str, levels: &[u32]) -> Vec<f64> {
    levels
        .iter()
        .map(|&level| {
            let text = format!(
                "element = \"{element}\"\n[geometry]\n{geometry}\n[grid]\nlevel = {level}\noffset = [0.37, 0.61, 0.13]\n[material]\nyoung = 1\npoisson = 0.3\n"
            );
            let case = Case::from_str("volume.toml", &text).unwrap();
            let grid: Grid = case.grid(None).unwrap();
            let cells = case.classify(&grid).unwrap();
            let err = (cells.volume(&grid) - exact).abs() / exact;
            println!("{element} level {level}: relative volume error {err:.3e}");
            err
        })
        .collect()
}

/// The least-squares slope of `−log2(error)` against the level.
fn rate(levels: &[u32], errors: &[f64]) -> f64 {
    let n = levels.len() as f64;
    let xs: Vec<f64> = levels.iter().map(|&l| l as f64).collect();
    let ys: Vec<f64> = errors.iter().map(|e| -e.log2()).collect();
    let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
    sxy / sxx
}

fn check(name: &str, geometry: &str, exact: f64, first: u32) {
    let levels: Vec<u32> = (first..=max_level(5)).collect();
    let mut failed = Vec::new();
    for (element, bound) in [("q1", 1e-5), ("q2", 1e-8)] {
        let errors = volume_errors(geometry, exact, element, &levels);
        let r = rate(&levels, &errors);
        println!("{name} {element}: fitted rate {r:.2} over levels {levels:?}");
        for (&level, e) in levels.iter().zip(&errors) {
            if *e > bound {
                failed.push(format!("{element} level {level}: {e:.3e} > {bound:.1e}"));
            }
        }
    }
    assert!(failed.is_empty(), "{name}: {failed:?}");
}

#[test]
fn plate_minus_tilted_cylinder_volume_converges() {
    let (r, theta) = (0.35f64, 20f64.to_radians());
    check(
        "plate",
        PLATE,
        4.0 - std::f64::consts::PI * r * r / theta.cos(),
        2,
    );
}

#[test]
fn bracket_volume_converges() {
    check(
        "bracket",
        BRACKET,
        52000.0 - 720.0 * std::f64::consts::PI,
        3,
    );
}
