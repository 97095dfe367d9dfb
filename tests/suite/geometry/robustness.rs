//! Robustness of classification and cut-cell quadrature over seeded random
//! placements (300; 10 000 in the long tier, `CGFEM_LONG=1`): spheres, shells, tori and a CSG part (a block with a
//! through hole), with grid offsets and radii drawn at random, plus placements
//! that are degenerate on purpose (boundaries on grid planes, spheres tangent to
//! grid planes and through grid nodes). No NaN, no panic, no negative weight,
//! fractions in [0, 1], and the total volume equal to the exact volume within
//! the rule's error.

use cgfem_gpu::cells::Cells;
use cgfem_gpu::geometry::Geometry;
use cgfem_gpu::grid::Grid;
use cgfem_gpu::spatial::Aabb;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::f64::consts::PI;

/// A solid with its exact volume and an optional explicit grid box.
struct Case {
    name: &'static str,
    geometry: Geometry,
    volume: f64,
    grid_box: Option<Aabb>,
}

fn random_case(rng: &mut ChaCha8Rng, k: usize) -> Case {
    let c = [0, 1, 2].map(|_| rng.gen_range(-0.5..0.5));
    match k % 6 {
        0 => {
            let r = rng.gen_range(0.2..1.5);
            Case {
                name: "sphere",
                geometry: Geometry::sphere(c, r).unwrap(),
                volume: 4.0 / 3.0 * PI * r.powi(3),
                grid_box: None,
            }
        }
        1 => {
            let r_out = rng.gen_range(0.5..1.5);
            let r_in = r_out * rng.gen_range(0.3..0.7);
            Case {
                name: "shell",
                geometry: Geometry::shell(c, r_in, r_out).unwrap(),
                volume: 4.0 / 3.0 * PI * (r_out.powi(3) - r_in.powi(3)),
                grid_box: None,
            }
        }
        2 => {
            let big_r = rng.gen_range(0.5..1.0);
            let r = big_r * rng.gen_range(0.3..0.6);
            let axis = [0, 1, 2].map(|_| rng.gen_range(-1.0..1.0));
            let axis = if axis.iter().all(|a: &f64| a.abs() < 1e-3) {
                [0.0, 0.0, 1.0]
            } else {
                axis
            };
            Case {
                name: "torus",
                geometry: Geometry::torus(c, axis, big_r, r).unwrap(),
                volume: 2.0 * PI * PI * big_r * r * r,
                grid_box: None,
            }
        }
        3 => {
            // Block [-a, a]^3 with a hole of radius ρ along z, rotated.
            let a = rng.gen_range(0.4..1.0);
            let rho = a * rng.gen_range(0.2..0.8);
            let hole = Geometry::cylinder([0.0, 0.0, -2.0 * a], [0.0, 0.0, 2.0 * a], rho).unwrap();
            let part = Geometry::cuboid([-a; 3], [a; 3])
                .unwrap()
                .difference(hole)
                .unwrap();
            let axis = [0, 1, 2].map(|_| rng.gen_range(-1.0..1.0));
            let angle = rng.gen_range(0.0..PI);
            let axis = if axis.iter().all(|v: &f64| v.abs() < 1e-3) {
                [1.0, 0.0, 0.0]
            } else {
                axis
            };
            Case {
                name: "block with hole",
                geometry: part.rotate(axis, angle).unwrap().translate(c).unwrap(),
                volume: 8.0 * a.powi(3) - PI * rho * rho * 2.0 * a,
                grid_box: None,
            }
        }
        4 => {
            // Degenerate on purpose: a sphere of radius m·h about a grid node
            // (tangent to grid planes, through grid nodes) on [-1, 1]^3, level 3.
            let m = rng.gen_range(1..=4) as f64;
            let node = [0, 1, 2].map(|_| rng.gen_range(-1..=1) as f64 * 0.25);
            Case {
                name: "tangent sphere",
                geometry: Geometry::sphere(node, 0.25 * m).unwrap(),
                volume: 4.0 / 3.0 * PI * (0.25 * m).powi(3),
                grid_box: Some(Aabb::new([-2.0; 3], [2.0; 3])),
            }
        }
        _ => {
            // Degenerate on purpose: a box whose faces lie on grid planes.
            let lo = [0, 1, 2].map(|_| rng.gen_range(-4..0) as f64 * 0.25);
            let hi = [0, 1, 2].map(|_| rng.gen_range(1..=4) as f64 * 0.25);
            let v = (0..3).map(|i| hi[i] - lo[i]).product();
            Case {
                name: "aligned box",
                geometry: Geometry::cuboid(lo, hi).unwrap(),
                volume: v,
                grid_box: Some(Aabb::new([-1.0; 3], [1.0; 3])),
            }
        }
    }
}

/// Placements drawn: 300, or 10 000 in the long tier (`CGFEM_LONG=1`).
fn placements() -> usize {
    match std::env::var_os("CGFEM_LONG") {
        Some(_) => 10_000,
        None => 300,
    }
}

#[test]
fn random_placements() {
    let worst: Vec<(&str, f64)> = (0..placements())
        .into_par_iter()
        .map(|k| {
            // One stream per placement: the same placements on any number of
            // threads, and the first ones the same in both tiers.
            let mut rng = ChaCha8Rng::seed_from_u64(20261121);
            rng.set_stream(k as u64);
            placement(&mut rng, k)
        })
        .collect();
    let mut by_name: std::collections::BTreeMap<&str, f64> = Default::default();
    for (name, err) in worst {
        let e = by_name.entry(name).or_default();
        *e = e.max(err);
    }
    println!("worst relative volume errors: {by_name:?}");
}

/// Placement `k` drawn from `rng`, checked; its name and volume error.
fn placement(rng: &mut ChaCha8Rng, k: usize) -> (&'static str, f64) {
    let case = random_case(rng, k);
    let degenerate = case.grid_box.is_some();
    let level = if degenerate { 3 } else { rng.gen_range(2..=3) };
    let offset = if degenerate && rng.gen_bool(0.5) {
        [0.0; 3]
    } else {
        [0, 1, 2].map(|_| rng.gen_range(0.0..1.0))
    };
    let bbox = case.grid_box.unwrap_or(case.geometry.bounding_box());
    let grid = Grid::new(&bbox, level, offset).unwrap();
    let q = 2 + k % 2;
    let cells = Cells::classify(&grid, &case.geometry, q).unwrap();
    for p in &cells.volume {
        assert!(
            p.w.is_finite() && p.w > 0.0,
            "{}: weight {}",
            case.name,
            p.w
        );
        assert!(p.x.iter().all(|v| v.is_finite()));
    }
    for p in &cells.surface {
        assert!(
            p.w.is_finite() && p.w >= 0.0,
            "{}: surface weight {}",
            case.name,
            p.w
        );
        let n2: f64 = p.n.iter().map(|v| v * v).sum();
        assert!((n2 - 1.0).abs() < 1e-12, "{}: normal {:?}", case.name, p.n);
    }
    assert!(cells.fraction.iter().all(|f| (0.0..=1.0).contains(f)));
    let err = (cells.volume(&grid) - case.volume).abs() / case.volume;
    // The rule's error at 4 cells across is ~1e-3; aligned boxes are exact.
    let tol = if case.name == "aligned box" {
        1e-12
    } else {
        2e-2
    };
    assert!(err < tol, "case {k} {}: volume error {err:.3e}", case.name);
    (case.name, err)
}
