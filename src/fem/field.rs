//! The discrete displacement field: values, gradients and stresses of `u_h` at
//! points of a cell, the nodal interpolant of a given field, and the error
//! norms against an exact field (DESIGN §4):
//! `‖e‖_E² = ∫_Ω ε(e) : σ(e)`, `‖e‖_L2² = ∫_Ω |e|²`, with `e = u − u_h`.

use rayon::prelude::*;

use super::dofs::DofMap;
use crate::cells::{CellKind, Cells};
use crate::element::{shape_gradients, shape_values, tensor_gauss_rule};
use crate::expr::VectorExpr;
use crate::grid::Grid;

/// `u_h(x)` and `∇u_h(x)` (`g[i][j] = ∂u_i/∂x_j`) at a point of `cell`.
pub fn value_and_gradient(
    grid: &Grid,
    dofs: &DofMap,
    u: &[f64],
    cell: usize,
    x: [f64; 3],
) -> ([f64; 3], [[f64; 3]; 3]) {
    let npc = dofs.order.nodes_per_cell();
    let mut nodes = [0usize; 27];
    let mut n = [0.0; 27];
    let mut dn = [[0.0; 3]; 27];
    dofs.cell_active_nodes(grid, cell, &mut nodes[..npc]);
    let x0 = grid.cell_box(cell).lo;
    let xi = [0, 1, 2].map(|a| (x[a] - x0[a]) / grid.h);
    shape_values(dofs.order, xi, &mut n[..npc]);
    shape_gradients(dofs.order, xi, &mut dn[..npc]);
    let mut val = [0.0; 3];
    let mut grad = [[0.0; 3]; 3];
    for a in 0..npc {
        for i in 0..3 {
            let ui = u[3 * nodes[a] + i];
            val[i] += n[a] * ui;
            for j in 0..3 {
                grad[i][j] += dn[a][j] / grid.h * ui;
            }
        }
    }
    (val, grad)
}

/// Stress `σ = λ tr(ε) I + 2μ ε` of a displacement gradient, in Voigt order
/// (xx, yy, zz, yz, xz, xy).
pub fn stress_voigt(g: &[[f64; 3]; 3], lambda: f64, mu: f64) -> [f64; 6] {
    let tr = g[0][0] + g[1][1] + g[2][2];
    [
        lambda * tr + 2.0 * mu * g[0][0],
        lambda * tr + 2.0 * mu * g[1][1],
        lambda * tr + 2.0 * mu * g[2][2],
        mu * (g[1][2] + g[2][1]),
        mu * (g[0][2] + g[2][0]),
        mu * (g[0][1] + g[1][0]),
    ]
}

/// `ε(e) : σ(e)` for a displacement-gradient error `g`.
fn energy_density(g: &[[f64; 3]; 3], lambda: f64, mu: f64) -> f64 {
    let s = stress_voigt(g, lambda, mu);
    s[0] * g[0][0]
        + s[1] * g[1][1]
        + s[2] * g[2][2]
        + s[3] * (g[1][2] + g[2][1])
        + s[4] * (g[0][2] + g[2][0])
        + s[5] * (g[0][1] + g[1][0])
}

/// The nodal interpolant of `u` on the active nodes.
pub fn interpolate(grid: &Grid, dofs: &DofMap, u: &VectorExpr) -> Vec<f64> {
    let mut out = vec![0.0; dofs.ndofs()];
    out.par_chunks_mut(3).enumerate().for_each(|(a, o)| {
        let x = grid.node_position(dofs.order, dofs.active_to_node[a] as usize);
        o.copy_from_slice(&u.eval(x));
    });
    out
}

/// Errors of `u_h` against the exact field.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ErrorNorms {
    /// `‖u − u_h‖_E`.
    pub energy: f64,
    /// `‖u − u_h‖_E / ‖u‖_E`.
    pub energy_relative: f64,
    /// `‖u − u_h‖_L2`.
    pub l2: f64,
    /// `‖u − u_h‖_L2 / ‖u‖_L2`.
    pub l2_relative: f64,
}

/// Energy and L2 errors, integrated with one Gauss point per direction more
/// than the element's on inside cells and with the cut-cell rules on cut cells.
pub fn error_norms(
    grid: &Grid,
    cells: &Cells,
    dofs: &DofMap,
    u_h: &[f64],
    exact: &VectorExpr,
    lambda: f64,
    mu: f64,
) -> ErrorNorms {
    let rule = tensor_gauss_rule(dofs.order.gauss_points_per_axis() + 1);
    let vol = grid.h.powi(3);
    let point = |cell: usize, x: [f64; 3], w: f64| -> [f64; 4] {
        let (v, g) = value_and_gradient(grid, dofs, u_h, cell, x);
        let ue = exact.eval(x);
        let ge = exact.displacement_gradient(x);
        let mut e = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                e[i][j] = ge[i][j] - g[i][j];
            }
        }
        let el2: f64 = (0..3).map(|i| (ue[i] - v[i]).powi(2)).sum();
        let ul2: f64 = (0..3).map(|i| ue[i].powi(2)).sum();
        [
            w * energy_density(&e, lambda, mu),
            w * energy_density(&ge, lambda, mu),
            w * el2,
            w * ul2,
        ]
    };
    let add = |a: [f64; 4], b: [f64; 4]| [a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]];
    let inside: [f64; 4] = (0..grid.num_cells())
        .into_par_iter()
        .filter(|&c| cells.kinds[c] == CellKind::Inside)
        .map(|c| {
            let lo = grid.cell_box(c).lo;
            rule.iter().fold([0.0; 4], |acc, (xi, w)| {
                let x = [0, 1, 2].map(|a| lo[a] + grid.h * xi[a]);
                add(acc, point(c, x, w * vol))
            })
        })
        .reduce(|| [0.0; 4], add);
    let cut: [f64; 4] = (0..cells.cut.len())
        .into_par_iter()
        .map(|i| {
            cells
                .volume_points(i)
                .iter()
                .fold([0.0; 4], |acc, q| add(acc, point(cells.cut[i], q.x, q.w)))
        })
        .reduce(|| [0.0; 4], add);
    let s = add(inside, cut);
    ErrorNorms {
        energy: s[0].max(0.0).sqrt(),
        energy_relative: (s[0] / s[1]).max(0.0).sqrt(),
        l2: s[2].sqrt(),
        l2_relative: (s[2] / s[3]).sqrt(),
    }
}
