//! Patches across a mirror face: on the half of a grid, with its low x face a
//! symmetry plane, the recovery of a mirror-symmetric field equals the full
//! grid's recovery node for node; without the mirror the patches at the face
//! are one-sided and differ.

use super::*;
use crate::cells::CellKind;
use crate::element::{tensor_gauss_rule, ElementOrder};
use crate::grid::Grid;
use crate::spatial::Aabb;

/// A vector field symmetric about x = 0 (`u_x` odd in x, `u_y`, `u_z` even),
/// outside the quadratic fit space.
fn field(x: [f64; 3]) -> [f64; 3] {
    [
        x[0] * (1.0 + x[1] * x[1]) + x[0].powi(3) * x[2],
        1.0 + x[0] * x[0] * x[1] + x[2].powi(3),
        x[0] * x[0] * x[1].sin() + x[2].cos() + x[0].powi(4),
    ]
}

/// The field at the 2×2×2 Gauss points of every cell of `grid`; a vector.
struct Gauss<'a> {
    grid: &'a Grid,
}

impl PatchSamples<3> for Gauss<'_> {
    fn samples(&self, cell: usize, out: &mut Vec<Sample<3>>) {
        let lo = self.grid.cell_box(cell).lo;
        for (xi, _) in tensor_gauss_rule(2) {
            let x = [0, 1, 2].map(|a| lo[a] + self.grid.h * xi[a]);
            out.push((x, field(x)));
        }
    }

    fn reflected(&self, axis: usize, mut value: [f64; 3]) -> Option<[f64; 3]> {
        value[axis] = -value[axis];
        Some(value)
    }
}

/// The recovery on `grid` (every cell inside) at every Q1 node.
fn recovered(grid: &Grid, mirror: Mirror) -> Recovered<3> {
    let kinds = vec![CellKind::Inside; grid.num_cells()];
    let nodes: Vec<usize> = (0..grid.num_nodes(ElementOrder::Q1)).collect();
    let opts = SprOptions {
        mirror,
        ..SprOptions::default()
    };
    recover(grid, &kinds, &nodes, 2, &Gauss { grid }, &opts).unwrap()
}

/// The largest difference between the half grid's node polynomials and the
/// full grid's at the same nodes, at points around each node.
fn largest_difference(mirror: Mirror) -> f64 {
    let full = Grid::new(&Aabb::new([-1.0, -0.5, -0.5], [1.0, 0.5, 0.5]), 3, [0.0; 3]).unwrap();
    let half = Grid::new(&Aabb::new([0.0, -0.5, -0.5], [1.0, 0.5, 0.5]), 2, [0.0; 3]).unwrap();
    assert_eq!((full.h, full.n, half.n), (0.25, [8, 4, 4], [4, 4, 4]));
    let (rf, rh) = (recovered(&full, Mirror::none()), recovered(&half, mirror));
    let (mf, mh) = (
        full.nodes_per_axis(ElementOrder::Q1),
        half.nodes_per_axis(ElementOrder::Q1),
    );
    let mut worst = 0.0f64;
    for node in 0..half.num_nodes(ElementOrder::Q1) {
        let ijk = [node % mh[0], (node / mh[0]) % mh[1], node / (mh[0] * mh[1])];
        let twin = (ijk[0] + 4) + mf[0] * (ijk[1] + mf[1] * ijk[2]);
        let x = half.node_position(ElementOrder::Q1, node);
        assert_eq!(x, full.node_position(ElementOrder::Q1, twin));
        for d in [[0.1, 0.05, -0.1], [0.2, -0.15, 0.05]] {
            let p = [0, 1, 2].map(|a| x[a] + d[a]);
            let (a, b) = (
                rh.eval_node_polynomial(node, p).unwrap(),
                rf.eval_node_polynomial(twin, p).unwrap(),
            );
            for c in 0..3 {
                worst = worst.max((a[c] - b[c]).abs());
            }
        }
    }
    worst
}

#[test]
fn a_mirrored_patch_is_the_full_grids_patch() {
    let mut mirror = Mirror::none();
    mirror.faces[0][0] = true;
    let with = largest_difference(mirror);
    let without = largest_difference(Mirror::none());
    println!("half grid against full grid: {with:.2e} with the mirror, {without:.2e} without");
    assert!(with < 1e-12, "with the mirror: {with:e}");
    assert!(
        without > 1e-4,
        "without the mirror the patches at x = 0 are one-sided: {without:e}"
    );
}

/// The later recoveries of fit plans, from the cells' moments, reflect the
/// moments of the cells seen across the mirror face as the plain recovery
/// reflects their samples: the same coefficients to round-off.
#[test]
fn planned_recoveries_reflect_the_moments_across_the_mirror() {
    let half = Grid::new(&Aabb::new([0.0, -0.5, -0.5], [1.0, 0.5, 0.5]), 2, [0.0; 3]).unwrap();
    let kinds = vec![CellKind::Inside; half.num_cells()];
    let nodes: Vec<usize> = (0..half.num_nodes(ElementOrder::Q1)).collect();
    let mut mirror = Mirror::none();
    mirror.faces[0][0] = true;
    let opts = SprOptions {
        mirror,
        ..SprOptions::default()
    };
    let samples = Gauss { grid: &half };
    let plans = std::sync::OnceLock::new();
    let recover_again =
        || recover_planned(&half, &kinds, &nodes, 2, &samples, &opts, Some(&plans)).unwrap();
    recover_again();
    let mirrored = plans.get().unwrap().plans.iter();
    assert!(mirrored.flat_map(|p| &p.cells).any(|&(_, mask)| mask != 0));
    let (planned, plain) = (
        recover_again(),
        recover(&half, &kinds, &nodes, 2, &samples, &opts).unwrap(),
    );
    for &node in &nodes {
        let (a, b) = (
            planned.coefficients(node).unwrap(),
            plain.coefficients(node).unwrap(),
        );
        let scale = b.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        for (x, y) in a.iter().zip(b) {
            assert!(
                (x - y).abs() < 1e-12 * scale,
                "node {node}: {x} against {y}"
            );
        }
    }
}
