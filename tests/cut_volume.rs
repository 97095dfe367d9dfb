//! Volume of parts with edges by the cut-cell rules against the exact value,
//! level by level: the cuboid minus a tilted cylinder (`4 − π r²/cos θ`, the
//! cylinder crosses the slab whole) and the bracket of `cases/`
//! (`52000 − 720π` mm³), under a random rotation and grid offset. The error
//! must converge at 2nd order or better with the Q1 rules and 3rd order or
//! better with the Q2 rules (the rates the elements need).
//!
//! Measured (`CGFEM_VOLUME_LEVELS=7 cargo test --release --test cut_volume
//! -- --nocapture`, relative errors):
//!
//! | part, rules | L2 | L3 | L4 | L5 | L6 | L7 |
//! |---|---|---|---|---|---|---|
//! | plate, Q1 | 6.4e-7 | 6.1e-7 | 9.7e-7 | 1.4e-6 | 1.0e-7 | 6.5e-9 |
//! | plate, Q2 | 1.5e-10 | 2.9e-10 | 1.2e-9 | 2.4e-10 | 1.1e-12 | 2.4e-15 |
//! | bracket, Q1 | | 1.0e-7 | 4.5e-7 | 1.9e-7 | 4.8e-7 | 4.0e-8 |
//! | bracket, Q2 | | 9.2e-12 | 1.4e-10 | 2.6e-10 | 1.1e-10 | 1.5e-13 |
//!
//! The errors sit on a plateau up to level 5 (plate) or 6 (bracket) and then
//! fall at the rules' asymptotic rate (Q1 rules: 3.7 and 4.0 from level 5 to
//! 7 on the plate, 3.6 from 6 to 7 on the bracket; Q2 rules: to round-off).
//! The plateau is a quadrature-order error in cells cut by a cylinder alone,
//! not at the edges: the height functions' branch points stay a fixed
//! distance (`≈ Q² R / 2`) outside the boxes while the cells are not small
//! against the cylinder's radius (`docs/volume-floor-findings.md`). Issue 15
//! asks for the rates from the coarsest level; that is not met (a prototype,
//! described in `docs/volume-floor-findings.md`, met it at +31% wall time on
//! the level-6 sphere).
//! The test holds every level below `1e-5` (Q1 rules) and `1e-8` (Q2 rules),
//! which Saye's rules without edge splitting miss by one to three orders of
//! magnitude, and with `CGFEM_VOLUME_LEVELS ≥ 7` the rate between the two
//! finest levels: at least 2 (Q1 rules) and 3 (Q2 rules), or an error at
//! round-off (`1e-13`).
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

/// A relative volume error at round-off: no rate is asked of it.
const ROUND_OFF: f64 = 1e-13;

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
    for (element, bound, min_rate) in [("q1", 1e-5, 2.0), ("q2", 1e-8, 3.0)] {
        let errors = volume_errors(geometry, exact, element, &levels);
        let r = rate(&levels, &errors);
        println!("{name} {element}: fitted rate {r:.2} over levels {levels:?}");
        for (&level, e) in levels.iter().zip(&errors) {
            if *e > bound {
                failed.push(format!("{element} level {level}: {e:.3e} > {bound:.1e}"));
            }
        }
        let finest = levels.len() - 1;
        if levels[finest] >= 7 && errors[finest] > ROUND_OFF {
            let last = (errors[finest - 1] / errors[finest]).log2();
            println!("{name} {element}: rate {last:.2} between the two finest levels");
            if last < min_rate {
                failed.push(format!("{element}: asymptotic rate {last:.2} < {min_rate}"));
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
