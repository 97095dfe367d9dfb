//! Right-hand sides (DESIGN §3.1): body load `F_b`, tractions `F_N`, the
//! penalty part of the Dirichlet data `F_p = Σ_q w_q (β/h) N_qᵀ M_q g_q` and the
//! recovered-traction part `F_T = Σ_q w_q N_qᵀ M_q t̂_q` over the Dirichlet
//! points, `M_q` the diagonal mask of the components a point holds (a free
//! component is traction free).

use super::dofs::DofMap;
use super::problem::{Boundary, Problem};
use crate::cells::{CellKind, Cells};
use crate::element::{shape_values, tensor_gauss_rule};
use crate::grid::Grid;

/// A boundary quadrature point on a Dirichlet part, with its cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirichletPoint {
    pub cell: usize,
    pub tag: u16,
    pub x: [f64; 3],
    pub w: f64,
    pub n: [f64; 3],
    /// The prescribed value (0 in the free components).
    pub g: [f64; 3],
    /// 1 for a held component, 0 for a free one.
    pub mask: [f64; 3],
}

/// The Dirichlet points of the cut cells (the boundary points where a
/// Dirichlet condition applies), in cut-cell order.
pub fn dirichlet_points(cells: &Cells, problem: &Problem) -> Vec<DirichletPoint> {
    let mut out = Vec::new();
    for (i, &cell) in cells.cut.iter().enumerate() {
        for q in cells.surface_points(i) {
            if let Some(mask) = problem.dirichlet_mask(q.tag, q.x) {
                out.push(DirichletPoint {
                    cell,
                    tag: q.tag,
                    x: q.x,
                    w: q.w,
                    n: q.n,
                    g: problem.dirichlet_value(q.tag, q.x),
                    mask: mask.map(|m| if m { 1.0 } else { 0.0 }),
                });
            }
        }
    }
    out
}

/// Adds `N(x)ᵀ f` to `rhs` for a point `x` of `cell` (`f` carries the weight).
pub fn add_point_load(
    grid: &Grid,
    dofs: &DofMap,
    cell: usize,
    x: [f64; 3],
    f: [f64; 3],
    rhs: &mut [f64],
) {
    let npc = dofs.order.nodes_per_cell();
    let mut nodes = [0usize; 27];
    let mut n = [0.0; 27];
    dofs.cell_active_nodes(grid, cell, &mut nodes[..npc]);
    let x0 = grid.cell_box(cell).lo;
    let xi = [0, 1, 2].map(|a| (x[a] - x0[a]) / grid.h);
    shape_values(dofs.order, xi, &mut n[..npc]);
    for a in 0..npc {
        for c in 0..3 {
            rhs[3 * nodes[a] + c] += n[a] * f[c];
        }
    }
}

/// `F_b + F_N + F_p`: the part of the right-hand side that does not change in
/// the fixed-point loop.
pub fn fixed_rhs(
    grid: &Grid,
    cells: &Cells,
    dofs: &DofMap,
    problem: &Problem,
    beta: f64,
    dirichlet: &[DirichletPoint],
) -> Vec<f64> {
    let mut rhs = vec![0.0; dofs.ndofs()];
    if problem.has_body_load() {
        let rule = tensor_gauss_rule(dofs.order.gauss_points_per_axis() + 1);
        let vol = grid.h.powi(3);
        for (c, kind) in cells.kinds.iter().enumerate() {
            if *kind != CellKind::Inside {
                continue;
            }
            let lo = grid.cell_box(c).lo;
            for (xi, w) in &rule {
                let x = [0, 1, 2].map(|a| lo[a] + grid.h * xi[a]);
                let b = problem.body_load(x).map(|v| v * w * vol);
                add_point_load(grid, dofs, c, x, b, &mut rhs);
            }
        }
        for (i, &c) in cells.cut.iter().enumerate() {
            for q in cells.volume_points(i) {
                let b = problem.body_load(q.x).map(|v| v * q.w);
                add_point_load(grid, dofs, c, q.x, b, &mut rhs);
            }
        }
    }
    for (i, &c) in cells.cut.iter().enumerate() {
        for q in cells.surface_points(i) {
            if let Boundary::Neumann(_) = problem.boundary[q.tag as usize] {
                let t = problem.traction(q.tag, q.x, q.n).map(|v| v * q.w);
                add_point_load(grid, dofs, c, q.x, t, &mut rhs);
            }
        }
    }
    for p in dirichlet {
        let s = p.w * beta / grid.h;
        add_point_load(grid, dofs, p.cell, p.x, p.g.map(|v| v * s), &mut rhs);
    }
    rhs
}

/// `F_T = Σ_q w_q N_qᵀ t̂_q` for recovered tractions `t̂` at the Dirichlet
/// points (already masked, [`super::recovery::recovered_tractions`]).
pub fn traction_rhs(
    grid: &Grid,
    dofs: &DofMap,
    dirichlet: &[DirichletPoint],
    t_hat: &[[f64; 3]],
) -> Vec<f64> {
    let mut rhs = vec![0.0; dofs.ndofs()];
    for (p, t) in dirichlet.iter().zip(t_hat) {
        add_point_load(grid, dofs, p.cell, p.x, t.map(|v| v * p.w), &mut rhs);
    }
    rhs
}
