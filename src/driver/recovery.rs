//! Stress recovery for the fixed-point loop and the output: SPR
//! of degree p of the FE stress on the patches of Q1 vertex nodes, sampled at
//! [`sample_positions`], blended by CPE (both orders use the vertex patches of
//! the cell grid: Q1 fits {1, x, y, z} to the 2×2×2 Gauss points of the
//! patch's cells, Q2 the complete quadratic, 10 terms, to the 3×3×3 ones); the recovered traction `t̂ = σ̂ n` at the Dirichlet points, and the
//! reactions `λ_q = t̂_q − (β/h)(u_h(x_q) − g_q)`.

use std::sync::OnceLock;

use rayon::prelude::*;

use super::setup::Setup;
use crate::cells::CellKind;
use crate::discrete::field::{stress_voigt, value_and_gradient, CellField, ShapeTable};
use crate::element::{tensor_gauss_rule, ElementOrder};
use crate::error::Result;
use crate::fem::rhs::DirichletPoint;
use crate::recovery::{recover_around, recover_planned, FitPlans, Recovered, Sample, SprOptions};

/// The Q1 vertex nodes of the cells holding Dirichlet points and of the cells
/// whose flux correction uses the recovered stress (the patches the traction
/// needs), ascending.
pub fn traction_patch_nodes(setup: &Setup) -> Vec<usize> {
    let mut cells: Vec<usize> = setup.dirichlet.iter().map(|p| p.cell).collect();
    cells.extend(setup.flux.recovered_cells().map(|i| setup.cells.cut[i]));
    cells.sort_unstable();
    cells.dedup();
    vertex_nodes_of(setup, &cells)
}

/// The Q1 vertex nodes of the given cells, ascending and distinct.
pub fn vertex_nodes_of(setup: &Setup, cells: &[usize]) -> Vec<usize> {
    let grid = &setup.grid;
    let mut v = [0usize; 8];
    // Few cells: sort their nodes; many: mark them on the lattice.
    if 8 * cells.len() < grid.num_nodes(ElementOrder::Q1) / 8 {
        let mut nodes = Vec::with_capacity(8 * cells.len());
        for &c in cells {
            grid.cell_nodes(ElementOrder::Q1, c, &mut v);
            nodes.extend_from_slice(&v);
        }
        nodes.sort_unstable();
        nodes.dedup();
        return nodes;
    }
    let mut marked = vec![false; grid.num_nodes(ElementOrder::Q1)];
    for &c in cells {
        grid.cell_nodes(ElementOrder::Q1, c, &mut v);
        v.iter().for_each(|&n| marked[n] = true);
    }
    (0..marked.len()).filter(|&n| marked[n]).collect()
}

/// The SPR sample points of a cell (stress and displacement recovery alike):
/// the Gauss points `rule` of an inside cell; in a cut cell its base rule's
/// points, at most [`crate::cells::MAX_FIT_POINTS`]
/// ([`crate::cells::Cells::fit_points`]).
pub fn sample_positions(
    setup: &Setup,
    cell: usize,
    rule: &[([f64; 3], f64)],
    out: &mut Vec<[f64; 3]>,
) {
    let grid = &setup.grid;
    match setup.cells.kinds[cell] {
        CellKind::Inside => {
            let lo = grid.cell_box(cell).lo;
            out.extend(
                rule.iter()
                    .map(|(xi, _)| [0, 1, 2].map(|a| lo[a] + grid.h * xi[a])),
            );
        }
        CellKind::Cut => {
            let i = setup
                .cells
                .cut_position(cell)
                .expect("a cut cell is in the cut list");
            out.extend(setup.cells.fit_points(i, crate::cells::MAX_FIT_POINTS));
        }
        CellKind::Outside => {}
    }
}

/// SPR of the stress of `u` on the patches of `nodes`, reusing the fits of
/// an earlier recovery on the same patches when `plans` holds them (see
/// [`crate::recovery::recover_planned`]).
pub fn recover_stress(
    setup: &Setup,
    u: &[f64],
    nodes: &[usize],
    plans: Option<&OnceLock<FitPlans>>,
) -> Result<Recovered<6>> {
    recover_planned(
        &setup.grid,
        &setup.cells.kinds,
        nodes,
        setup.op.dofs.order.degree(),
        &stress_samples(setup, u),
        &stress_options(setup),
        plans,
    )
}

/// [`recover_stress`] on `nodes` without plans, taking the fits of the
/// nodes that `known` (a stress recovery of the same `u`) holds from it.
pub fn recover_stress_around(
    setup: &Setup,
    u: &[f64],
    nodes: &[usize],
    known: Option<&Recovered<6>>,
) -> Result<Recovered<6>> {
    recover_around(
        &setup.grid,
        &setup.cells.kinds,
        nodes,
        setup.op.dofs.order.degree(),
        &stress_samples(setup, u),
        &stress_options(setup),
        known,
    )
}

/// The stress of `u` at the [`sample_positions`] of a cell.
fn stress_samples<'a>(
    setup: &'a Setup,
    u: &'a [f64],
) -> impl Fn(usize, &mut Vec<Sample<6>>) + Sync + 'a {
    let (lambda, mu) = (setup.problem.lambda, setup.problem.mu);
    let order = setup.op.dofs.order;
    let rule = tensor_gauss_rule(order.gauss_points_per_axis());
    // An inside cell's samples are the rule's points: their shape functions
    // are the same in every inside cell.
    let table = ShapeTable::new(order, &rule, setup.grid.h);
    move |cell: usize, out: &mut Vec<Sample<6>>| {
        let mut xs = Vec::new();
        sample_positions(setup, cell, &rule, &mut xs);
        let field = CellField::new(&setup.grid, &setup.op.dofs, u, cell);
        let inside = setup.cells.kinds[cell] == CellKind::Inside;
        out.extend(xs.into_iter().enumerate().map(|(q, x)| {
            let (_, g) = match inside {
                true => field.at_tabulated(&table, q),
                false => field.value_and_gradient(x),
            };
            (x, stress_voigt(&g, lambda, mu))
        }));
    }
}

/// The stress recovery's options: patches keep to their node's piece.
fn stress_options(setup: &Setup) -> SprOptions<'_> {
    SprOptions {
        pieces: Some(&setup.pieces.of_cell),
        ..SprOptions::default()
    }
}

/// `t̂ = M σ̂ n` at the Dirichlet points (`M` the mask of the held components),
/// the blend of each run of points in one cell prepared once.
pub fn recovered_tractions(
    points: &[DirichletPoint],
    sigma: &Recovered<6>,
) -> Result<Vec<[f64; 3]>> {
    let runs: Vec<&[DirichletPoint]> = points.chunk_by(|a, b| a.cell == b.cell).collect();
    let per_run: Vec<Vec<[f64; 3]>> = runs
        .par_iter()
        .map(|run| {
            let blend = sigma.cell_blend(run[0].cell)?;
            Ok(run
                .iter()
                .map(|p| {
                    let t = voigt_times(&blend.eval(p.x), p.n);
                    [0, 1, 2].map(|i| p.mask[i] * t[i])
                })
                .collect())
        })
        .collect::<Result<_>>()?;
    Ok(per_run.concat())
}

/// `σ n` for a Voigt stress (xx, yy, zz, yz, xz, xy).
pub fn voigt_times(s: &[f64; 6], n: [f64; 3]) -> [f64; 3] {
    [
        s[0] * n[0] + s[5] * n[1] + s[4] * n[2],
        s[5] * n[0] + s[1] * n[1] + s[3] * n[2],
        s[4] * n[0] + s[3] * n[1] + s[2] * n[2],
    ]
}

/// `λ_q = t̂_q − (β/h) M_q (u_h(x_q) − g_q)` at each Dirichlet point.
pub fn reactions(setup: &Setup, u: &[f64], t_hat: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let k = setup.beta / setup.grid.h;
    setup
        .dirichlet
        .iter()
        .zip(t_hat)
        .map(|(p, t)| {
            let (v, _) = value_and_gradient(&setup.grid, &setup.op.dofs, u, p.cell, p.x);
            [0, 1, 2].map(|i| t[i] - k * p.mask[i] * (v[i] - p.g[i]))
        })
        .collect()
}
