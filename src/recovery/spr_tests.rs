//! Tests of patch recovery on a sphere: polynomial reproduction, convergence on
//! the boundary, patch enlargement, typed errors and the constraint hook.

use std::sync::OnceLock;

use super::*;
use crate::cells::{cut_rule_points, CellKind, Cells};
use crate::element::{tensor_gauss_rule, ElementOrder};
use crate::error::Error;
use crate::geometry::Geometry;
use crate::grid::Grid;
use crate::recovery::recover_planned;
use crate::spatial::Aabb;

const CENTER: [f64; 3] = [0.031, -0.017, 0.009];

/// The grid of `level` over `[−half, half]³` and its cells against a sphere of
/// radius `r` about [`CENTER`], with cut rules for element `order`.
fn sphere(level: u32, half: f64, r: f64, order: ElementOrder) -> (Grid, Cells) {
    let bbox = Aabb::new([-half; 3], [half; 3]);
    let grid = Grid::new(&bbox, level, [0.0; 3]).unwrap();
    let g = Geometry::sphere(CENTER, r).unwrap();
    let cells = Cells::classify(&grid, &g, cut_rule_points(order)).unwrap();
    (grid, cells)
}

/// Samples of `f`: the `gauss³` Gauss points of inside cells, the cut-cell
/// volume points of cut cells.
fn analytic<'a, const NC: usize>(
    grid: &'a Grid,
    cells: &'a Cells,
    gauss: usize,
    f: impl Fn([f64; 3]) -> [f64; NC] + Sync + 'a,
) -> impl Fn(usize, &mut Vec<Sample<NC>>) + Sync + 'a {
    let rule = tensor_gauss_rule(gauss);
    move |c, out| match cells.kinds[c] {
        CellKind::Inside => {
            let lo = grid.cell_box(c).lo;
            for (xi, _) in &rule {
                let x = [0, 1, 2].map(|k| lo[k] + grid.h * xi[k]);
                out.push((x, f(x)));
            }
        }
        CellKind::Cut => {
            let i = cells.cut.binary_search(&c).unwrap();
            out.extend(cells.volume_points(i).iter().map(|p| (p.x, f(p.x))));
        }
        CellKind::Outside => {}
    }
}

/// The Q1 vertices of the cells for which `keep(kind)` holds.
fn vertices(grid: &Grid, cells: &Cells, keep: impl Fn(CellKind) -> bool) -> Vec<usize> {
    let mut nodes = Vec::new();
    let mut v = [0; 8];
    for (c, k) in cells.kinds.iter().enumerate() {
        if keep(*k) {
            grid.cell_nodes(ElementOrder::Q1, c, &mut v);
            nodes.extend_from_slice(&v);
        }
    }
    nodes
}

/// A fixed polynomial field of degree `p` with 3 components.
fn polynomial(p: usize, x: [f64; 3]) -> [f64; 3] {
    let [a, b, c] = x;
    let lin = [1.0 + 2.0 * a - b + 0.5 * c, -0.3 + a + 3.0 * c, 2.0 - b - c];
    if p == 1 {
        return lin;
    }
    [
        lin[0] + a * a - 2.0 * b * c + 0.7 * c * c,
        lin[1] + 3.0 * a * b - b * b,
        lin[2] + a * c + 0.4 * b * b - c * c,
    ]
}

/// Largest `|σ̂ − f|` over the boundary points of the cut cells.
fn boundary_error<const NC: usize>(
    rec: &Recovered<NC>,
    cells: &Cells,
    f: impl Fn([f64; 3]) -> [f64; NC],
) -> f64 {
    let mut err: f64 = 0.0;
    for (i, &c) in cells.cut.iter().enumerate() {
        for p in cells.surface_points(i) {
            let (got, want) = (rec.eval(c, p.x).unwrap(), f(p.x));
            for k in 0..NC {
                err = err.max((got[k] - want[k]).abs());
            }
        }
    }
    err
}

#[test]
fn polynomials_of_the_fit_degree_are_recovered_exactly() {
    for (p, order) in [(1, ElementOrder::Q1), (2, ElementOrder::Q2)] {
        let (grid, cells) = sphere(3, 1.0, 0.9, order);
        let f = move |x| polynomial(p, x);
        let samples = analytic(&grid, &cells, p + 1, f);
        let nodes = vertices(&grid, &cells, |k| k != CellKind::Outside);
        let rec = recover(
            &grid,
            &cells.kinds,
            &nodes,
            p,
            &samples,
            &SprOptions::default(),
        )
        .unwrap();
        // Volume and boundary points of the cut cells, corners of every cell
        // with volume (outside Ω too: the polynomial extension).
        let mut points: Vec<(usize, [f64; 3])> = Vec::new();
        for (i, &c) in cells.cut.iter().enumerate() {
            points.extend(cells.volume_points(i).iter().map(|q| (c, q.x)));
            points.extend(cells.surface_points(i).iter().map(|q| (c, q.x)));
        }
        for (c, k) in cells.kinds.iter().enumerate() {
            if *k != CellKind::Outside {
                let b = grid.cell_box(c);
                points.push((c, b.lo));
                points.push((c, b.hi));
                points.push((c, [0, 1, 2].map(|i| 0.3 * b.lo[i] + 0.7 * b.hi[i])));
            }
        }
        let (mut err, mut scale): (f64, f64) = (0.0, 0.0);
        for (c, x) in points {
            let (got, want) = (rec.eval(c, x).unwrap(), f(x));
            for k in 0..3 {
                err = err.max((got[k] - want[k]).abs());
                scale = scale.max(want[k].abs());
            }
        }
        let stats = rec.stats();
        println!("p = {p}: relative error {:.2e}, {stats:?}", err / scale);
        assert!(err <= 1e-10 * scale, "p = {p}: {err:e}");
        assert_eq!(stats.patches, rec.nodes().len());
    }
}

/// A smooth, non-polynomial 2-component field (its second derivatives are
/// resolved by level 3, h = 0.25, so that the rates are asymptotic from there).
fn smooth(x: [f64; 3]) -> [f64; 2] {
    [(x[0] + 0.5 * x[1]).sin(), (0.5 * x[2] - 0.3 * x[0]).exp()]
}

/// Boundary max errors at levels 3, 4, 5 and the rates between them,
/// recovering only the patches of the cut cells' vertices.
fn boundary_rates(p: usize, order: ElementOrder) -> [f64; 2] {
    let errors = [3, 4, 5].map(|level| {
        let (grid, cells) = sphere(level, 1.0, 0.9, order);
        let samples = analytic(&grid, &cells, p + 1, smooth);
        let nodes = vertices(&grid, &cells, |k| k == CellKind::Cut);
        let rec = recover(
            &grid,
            &cells.kinds,
            &nodes,
            p,
            &samples,
            &SprOptions::default(),
        )
        .unwrap();
        println!("p = {p}, level {level}: {:?}", rec.stats());
        boundary_error(&rec, &cells, smooth)
    });
    let rates = [0, 1].map(|i| (errors[i] / errors[i + 1]).log2());
    println!("p = {p}: boundary max errors {errors:?}, rates {rates:?}");
    rates
}

#[test]
fn smooth_fields_converge_on_the_boundary() {
    let rates = boundary_rates(1, ElementOrder::Q1);
    assert!(rates.iter().all(|&r| r >= 1.8), "p = 1 rates {rates:?}");
    let rates = boundary_rates(2, ElementOrder::Q2);
    assert!(rates[0] >= 2.0 && rates[1] >= 2.7, "p = 2 rates {rates:?}");
}

#[test]
fn small_cut_patches_are_enlarged_and_stay_exact() {
    let (grid, cells) = sphere(4, 1.0, 0.9, ElementOrder::Q1);
    let f = |x| polynomial(1, x);
    let samples = analytic(&grid, &cells, 2, f);
    let nodes = vertices(&grid, &cells, |k| k == CellKind::Cut);
    let rec = recover(
        &grid,
        &cells.kinds,
        &nodes,
        1,
        &samples,
        &SprOptions::default(),
    )
    .unwrap();
    let stats = rec.stats();
    println!("{stats:?}");
    assert!(
        stats.enlarged > 0 && stats.per_ring[0] > stats.enlarged,
        "{stats:?}"
    );
    for &node in rec.nodes() {
        let ring1 = ring1_cells(&grid, node);
        let volume: f64 = ring1.iter().map(|&c| cell_fraction(&cells, c)).sum();
        let info = rec.patch(node).unwrap();
        if info.ring == 1 {
            continue;
        }
        // Enlarged patches are those whose 8 cells hold little of Ω ...
        assert!(volume < 4.0, "node {node}: volume {volume} h³ in ring 1");
        // ... and their fits are still exact, on and off the patch.
        let x0 = grid.node_position(ElementOrder::Q1, node);
        for d in [[0.0; 3], [0.5, -0.5, 0.25], [-1.5, 1.0, 2.0]] {
            let x = [0, 1, 2].map(|k| x0[k] + d[k] * grid.h);
            let (got, want) = (rec.eval_node_polynomial(node, x).unwrap(), f(x));
            for k in 0..3 {
                assert!((got[k] - want[k]).abs() < 1e-11, "node {node}");
            }
        }
    }
    // The node whose 8 cells hold the least of Ω was enlarged.
    let thinnest = *rec
        .nodes()
        .iter()
        .min_by(|&&a, &&b| {
            let v = |n| -> f64 {
                let cs = ring1_cells(&grid, n);
                cs.iter().map(|&c| cell_fraction(&cells, c)).sum()
            };
            v(a).total_cmp(&v(b))
        })
        .unwrap();
    assert!(rec.patch(thinnest).unwrap().ring > 1);
}

/// Reusing the fits an earlier recovery accepted and factored (solving from
/// the cells' moments) gives the same patches and the same coefficients to
/// round-off for another field, constrained fits included; the planning
/// recovery itself is the plain one, bit for bit.
#[test]
fn fit_plans_reproduce_the_recovery_to_round_off() {
    let (grid, cells) = sphere(4, 1.0, 0.9, ElementOrder::Q1);
    let nodes = vertices(&grid, &cells, |k| k == CellKind::Cut);
    let opts = SprOptions::default();
    let linear = analytic(&grid, &cells, 2, |x| {
        let [a, b, _] = polynomial(1, x);
        [a, b]
    });
    let plans = OnceLock::new();
    let planning =
        recover_planned(&grid, &cells.kinds, &nodes, 1, &linear, &opts, Some(&plans)).unwrap();
    let first = recover(&grid, &cells.kinds, &nodes, 1, &linear, &opts).unwrap();
    let rings = plans.get().unwrap().rings();
    assert_eq!(rings, first.rings());
    assert!(rings.iter().any(|&r| r > 1), "no patch was enlarged");
    let field = analytic(&grid, &cells, 2, smooth);
    let plain = recover(&grid, &cells.kinds, &nodes, 1, &field, &opts).unwrap();
    let planned =
        recover_planned(&grid, &cells.kinds, &nodes, 1, &field, &opts, Some(&plans)).unwrap();
    for &node in plain.nodes() {
        assert_eq!(plain.patch(node), planned.patch(node), "node {node}");
        assert_eq!(
            first.coefficients(node).unwrap(),
            planning.coefficients(node).unwrap()
        );
        assert_close(
            plain.coefficients(node).unwrap(),
            planned.coefficients(node).unwrap(),
        );
    }
    let pinned = PinnedAtNode {
        grid: &grid,
        cells: &cells,
    };
    let constrained_plans = OnceLock::new();
    let constrained = recover(&grid, &cells.kinds, &nodes, 1, &pinned, &opts).unwrap();
    let again = || {
        let p = Some(&constrained_plans);
        recover_planned(&grid, &cells.kinds, &nodes, 1, &pinned, &opts, p).unwrap()
    };
    let (planning, planned) = (again(), again());
    for &node in constrained.nodes() {
        let want = constrained.coefficients(node).unwrap();
        assert_eq!(want, planning.coefficients(node).unwrap());
        assert_close(want, planned.coefficients(node).unwrap());
    }
}

#[test]
fn regular_patches_share_one_factor_and_equal_their_own_fits() {
    for (p, gauss) in [(1, 2), (2, 3)] {
        let (grid, cells) = sphere(4, 1.0, 0.9, ElementOrder::Q1);
        let nodes = vertices(&grid, &cells, |k| k != CellKind::Outside);
        let field = analytic(&grid, &cells, gauss, smooth);
        let opts = SprOptions::default();
        let rec = recover(&grid, &cells.kinds, &nodes, p, &field, &opts).unwrap();
        let mut regular = 0;
        for &node in rec.nodes() {
            let ring = ring1_cells(&grid, node);
            if ring.len() < 8 || ring.iter().any(|&c| cells.kinds[c] != CellKind::Inside) {
                continue;
            }
            regular += 1;
            let centre = grid.node_position(ElementOrder::Q1, node);
            let mut samples = Vec::new();
            ring.iter().for_each(|&c| field(c, &mut samples));
            for (x, _) in samples.iter_mut() {
                *x = [0, 1, 2].map(|k| (x[k] - centre[k]) / grid.h);
            }
            let own = fit_polynomial(&Monomials::new(p), &samples, None, &opts.fit).unwrap();
            assert_close(&own, rec.coefficients(node).unwrap());
        }
        assert!(regular > 100, "{regular} regular patches");
    }
}

/// `got` equals `want` to 1e-12 of the largest coefficient.
fn assert_close(want: &[f64], got: &[f64]) {
    let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let worst = want
        .iter()
        .zip(got)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(worst <= 1e-12 * scale, "{worst:e} of {scale:e}");
}

/// The (up to 8) cells sharing the vertex `node`.
fn ring1_cells(grid: &Grid, node: usize) -> Vec<usize> {
    let m = grid.nodes_per_axis(ElementOrder::Q1);
    let v = [node % m[0], (node / m[0]) % m[1], node / (m[0] * m[1])];
    let mut out = Vec::new();
    for k in v[2].saturating_sub(1)..(v[2] + 1).min(grid.n[2]) {
        for j in v[1].saturating_sub(1)..(v[1] + 1).min(grid.n[1]) {
            for i in v[0].saturating_sub(1)..(v[0] + 1).min(grid.n[0]) {
                out.push(grid.cell_index([i, j, k]));
            }
        }
    }
    out
}

/// `|c ∩ Ω| / h³`.
fn cell_fraction(cells: &Cells, c: usize) -> f64 {
    match cells.kinds[c] {
        CellKind::Inside => 1.0,
        CellKind::Outside => 0.0,
        CellKind::Cut => cells.fraction[cells.cut.binary_search(&c).unwrap()],
    }
}

#[test]
fn unfittable_and_unknown_nodes_are_typed_errors() {
    // A small ball in a big box: the box corner is more than 3 rings away.
    let (grid, cells) = sphere(3, 2.0, 0.5, ElementOrder::Q1);
    let samples = analytic(&grid, &cells, 2, |x| [x[0]]);
    let opts = SprOptions::default();
    let cut_nodes = vertices(&grid, &cells, |k| k == CellKind::Cut);
    let mut nodes = cut_nodes.clone();
    nodes.push(0);
    match recover(&grid, &cells.kinds, &nodes, 1, &samples, &opts) {
        Err(e @ Error::Recovery { node: 0, .. }) => {
            assert_eq!(e.exit_code(), 3);
            assert!(e.to_string().contains("3 ring"), "{e}");
        }
        other => panic!("expected a recovery error at node 0, got {other:?}"),
    }
    let bad = grid.num_nodes(ElementOrder::Q1);
    assert!(matches!(
        recover(&grid, &cells.kinds, &[bad], 1, &samples, &opts),
        Err(Error::Recovery { node, .. }) if node == bad
    ));
    // Evaluating on a cell whose vertices were not all recovered.
    let rec = recover(&grid, &cells.kinds, &cut_nodes[..8], 1, &samples, &opts).unwrap();
    assert!(rec
        .eval(cells.cut[0], grid.cell_box(cells.cut[0]).lo)
        .is_ok());
    let far = cells.cut[cells.cut.len() - 1];
    assert!(matches!(
        rec.eval(far, grid.cell_box(far).lo),
        Err(Error::Recovery { .. })
    ));
    assert!(rec.patch(0).is_none());
}

/// Samples of a smooth field whose patch fits must match it at the vertex.
struct PinnedAtNode<'a> {
    grid: &'a Grid,
    cells: &'a Cells,
}

impl PatchSamples<2> for PinnedAtNode<'_> {
    fn samples(&self, cell: usize, out: &mut Vec<([f64; 3], [f64; 2])>) {
        analytic(self.grid, self.cells, 2, smooth)(cell, out)
    }

    /// `σ*_c(x_node) = f_c(x_node)`: row `c` picks the constant term of
    /// component `c` (the basis is 1 at `ξ = 0` only for the constant).
    fn constraints(&self, patch: &Patch<'_>, basis: &Monomials) -> Option<LinearConstraints> {
        let nb = basis.len();
        let mut phi = vec![0.0; nb];
        basis.values(patch.scaled(patch.center), &mut phi);
        let want = smooth(patch.center);
        let mut k = LinearConstraints {
            c: nalgebra::DMatrix::zeros(2, 2 * nb),
            d: nalgebra::DVector::from_row_slice(&want),
        };
        for c in 0..2 {
            for j in 0..nb {
                k.c[(c, c * nb + j)] = phi[j];
            }
        }
        Some(k)
    }
}

#[test]
fn patch_constraints_reach_the_fit() {
    let (grid, cells) = sphere(3, 1.0, 0.9, ElementOrder::Q1);
    let nodes = vertices(&grid, &cells, |k| k == CellKind::Cut);
    let opts = SprOptions::default();
    let pinned = recover(
        &grid,
        &cells.kinds,
        &nodes,
        1,
        &PinnedAtNode {
            grid: &grid,
            cells: &cells,
        },
        &opts,
    )
    .unwrap();
    let free = recover(
        &grid,
        &cells.kinds,
        &nodes,
        1,
        &analytic(&grid, &cells, 2, smooth),
        &opts,
    )
    .unwrap();
    let mut moved: f64 = 0.0;
    for &node in pinned.nodes() {
        let x = grid.node_position(ElementOrder::Q1, node);
        let (got, want) = (pinned.eval_node_polynomial(node, x).unwrap(), smooth(x));
        let loose = free.eval_node_polynomial(node, x).unwrap();
        for c in 0..2 {
            assert!((got[c] - want[c]).abs() < 1e-12, "node {node}");
            moved = moved.max((loose[c] - want[c]).abs());
        }
    }
    assert!(moved > 1e-6, "the free fits already matched: {moved:e}");
}

/// Plans made from the sample positions alone ([`plan_fits`], zero values)
/// are those a searched recovery keeps, and a recovery from them equals the
/// searched one to round-off.
#[test]
fn plans_from_positions_alone_equal_the_searched_ones() {
    let (grid, cells) = sphere(4, 1.0, 0.9, ElementOrder::Q1);
    let nodes = vertices(&grid, &cells, |k| k == CellKind::Cut);
    let opts = SprOptions::default();
    let zero = analytic(&grid, &cells, 2, |_| [0.0; 2]);
    let plans = OnceLock::new();
    plan_fits(&grid, &cells.kinds, &nodes, 1, &zero, &opts, &plans).unwrap();
    let field = analytic(&grid, &cells, 2, smooth);
    let plain = recover(&grid, &cells.kinds, &nodes, 1, &field, &opts).unwrap();
    assert_eq!(plans.get().unwrap().rings(), plain.rings());
    let planned =
        recover_planned(&grid, &cells.kinds, &nodes, 1, &field, &opts, Some(&plans)).unwrap();
    for &node in plain.nodes() {
        assert_close(
            plain.coefficients(node).unwrap(),
            planned.coefficients(node).unwrap(),
        );
    }
}

/// The blend tabulated at fixed points of a cell ([`BlendTable`]) equals the
/// cell's blend evaluated there, on cut and inside cells.
#[test]
fn a_tabulated_blend_equals_the_cell_blend() {
    let (grid, cells) = sphere(3, 1.0, 0.9, ElementOrder::Q1);
    let nodes = vertices(&grid, &cells, |k| k != CellKind::Outside);
    let field = analytic(&grid, &cells, 2, smooth);
    let rec = recover(
        &grid,
        &cells.kinds,
        &nodes,
        1,
        &field,
        &SprOptions::default(),
    )
    .unwrap();
    let points = [
        [0.1, 0.5, 0.9],
        [0.0, 0.0, 0.0],
        [1.0, 0.3, 0.7],
        [0.62, 0.21, 0.44],
    ];
    let table = BlendTable::new(rec.basis(), &points);
    let mut tabulated = [0.0; 2 * 4];
    for c in (0..grid.num_cells()).filter(|&c| cells.kinds[c] != CellKind::Outside) {
        rec.blend_at_table(c, &table, &mut tabulated).unwrap();
        let blend = rec.cell_blend(c).unwrap();
        let lo = grid.cell_box(c).lo;
        for (r, xi) in points.iter().enumerate() {
            let want = blend.eval([0, 1, 2].map(|a| lo[a] + grid.h * xi[a]));
            let got = [tabulated[r], tabulated[4 + r]];
            assert_close(&want, &got);
        }
    }
}
