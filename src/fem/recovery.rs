//! Stress recovery (DESIGN §5.1) for the fixed-point loop and the output: SPR
//! of degree p of the FE stress on the patches of Q1 vertex nodes, sampled at
//! the Gauss points of inside cells and at up to twice as many of the cut-cell
//! volume points in cut cells, blended by CPE; the recovered traction `t̂ = σ̂ n` at the Dirichlet points, and the
//! reactions `λ_q = t̂_q − (β/h)(u_h(x_q) − g_q)`.

use super::field::{stress_voigt, value_and_gradient};
use super::rhs::DirichletPoint;
use super::setup::Setup;
use crate::cells::CellKind;
use crate::element::{tensor_gauss_rule, ElementOrder};
use crate::error::Result;
use crate::recovery::{recover, Recovered, SprOptions};

/// The Q1 vertex nodes of the cells holding Dirichlet points (the patches the
/// traction needs), ascending.
pub fn traction_patch_nodes(setup: &Setup) -> Vec<usize> {
    let mut cells: Vec<usize> = setup.dirichlet.iter().map(|p| p.cell).collect();
    cells.sort_unstable();
    cells.dedup();
    vertex_nodes_of(setup, &cells)
}

/// The Q1 vertex nodes of the given cells, ascending and distinct.
pub fn vertex_nodes_of(setup: &Setup, cells: &[usize]) -> Vec<usize> {
    let mut nodes = Vec::with_capacity(8 * cells.len());
    let mut v = [0usize; 8];
    for &c in cells {
        setup.grid.cell_nodes(ElementOrder::Q1, c, &mut v);
        nodes.extend_from_slice(&v);
    }
    nodes.sort_unstable();
    nodes.dedup();
    nodes
}

/// SPR of the stress of `u` on the patches of `nodes`.
pub fn recover_stress(setup: &Setup, u: &[f64], nodes: &[usize]) -> Result<Recovered<6>> {
    let grid = &setup.grid;
    let cells = &setup.cells;
    let dofs = &setup.op.dofs;
    let (lambda, mu) = (setup.problem.lambda, setup.problem.mu);
    let rule = tensor_gauss_rule(dofs.order.gauss_points_per_axis());
    let max_cut_samples = 2 * rule.len();
    let mut cut_index = std::collections::HashMap::with_capacity(cells.cut.len());
    for (i, &c) in cells.cut.iter().enumerate() {
        cut_index.insert(c, i);
    }
    let stress = |cell: usize, x: [f64; 3]| {
        let (_, g) = value_and_gradient(grid, dofs, u, cell, x);
        stress_voigt(&g, lambda, mu)
    };
    let samples = |cell: usize, out: &mut Vec<([f64; 3], [f64; 6])>| match cells.kinds[cell] {
        CellKind::Inside => {
            let lo = grid.cell_box(cell).lo;
            for (xi, _) in &rule {
                let x = [0, 1, 2].map(|a| lo[a] + grid.h * xi[a]);
                out.push((x, stress(cell, x)));
            }
        }
        CellKind::Cut => {
            // At most `max_cut_samples` points, evenly strided through the
            // sweep order of the rule: enough for a least-squares fit, and the
            // cost no longer grows with the accuracy of the cut-cell rule.
            let pts = cells.volume_points(cut_index[&cell]);
            let stride = pts.len().div_ceil(max_cut_samples).max(1);
            for q in pts.iter().step_by(stride) {
                out.push((q.x, stress(cell, q.x)));
            }
        }
        CellKind::Outside => {}
    };
    recover(
        grid,
        &cells.kinds,
        nodes,
        dofs.order.degree(),
        &samples,
        &SprOptions::default(),
    )
}

/// `t̂ = σ̂ n` at the Dirichlet points.
pub fn recovered_tractions(
    points: &[DirichletPoint],
    sigma: &Recovered<6>,
) -> Result<Vec<[f64; 3]>> {
    points
        .iter()
        .map(|p| {
            let s = sigma.eval(p.cell, p.x)?;
            Ok(voigt_times(&s, p.n))
        })
        .collect()
}

/// `σ n` for a Voigt stress (xx, yy, zz, yz, xz, xy).
pub fn voigt_times(s: &[f64; 6], n: [f64; 3]) -> [f64; 3] {
    [
        s[0] * n[0] + s[5] * n[1] + s[4] * n[2],
        s[5] * n[0] + s[1] * n[1] + s[3] * n[2],
        s[4] * n[0] + s[3] * n[1] + s[2] * n[2],
    ]
}

/// `λ_q = t̂_q − (β/h)(u_h(x_q) − g_q)` at each Dirichlet point.
pub fn reactions(setup: &Setup, u: &[f64], t_hat: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let k = setup.beta / setup.grid.h;
    setup
        .dirichlet
        .iter()
        .zip(t_hat)
        .map(|(p, t)| {
            let (v, _) = value_and_gradient(&setup.grid, &setup.op.dofs, u, p.cell, p.x);
            [0, 1, 2].map(|i| t[i] - k * (v[i] - p.g[i]))
        })
        .collect()
}
