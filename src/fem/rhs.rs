//! Right-hand sides: body load `F_b`, tractions `F_N`, the
//! penalty part of the Dirichlet data `F_p = Σ_q w_q (β/h) N_qᵀ M_q g_q` and the
//! recovered-traction part `F_T = Σ_q w_q N_qᵀ M_q t̂_q` over the Dirichlet
//! points, `M_q` the diagonal mask of the components a point holds (a free
//! component is traction free).

use rayon::prelude::*;

use super::problem::{Boundary, Problem};
use crate::cells::split::SplitCell;
use crate::cells::{CellKind, Cells};
use crate::discrete::dofs::DofMap;
use crate::element::{shape_values, tensor_gauss_rule, ElementOrder};
use crate::error::Result;
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

/// Adds `N(x)ᵀ f` to `rhs` for a point `x` of `cell` (`f` carries the weight;
/// in a split cell, the shape functions of the piece `x` lies in).
pub fn add_point_load(
    grid: &Grid,
    dofs: &DofMap,
    cell: usize,
    x: [f64; 3],
    f: [f64; 3],
    rhs: &mut [f64],
) {
    let mut nodes = [0usize; 27];
    dofs.point_active_nodes(grid, cell, x, &mut nodes[..dofs.order.nodes_per_cell()]);
    add_load_on(grid, dofs.order, cell, &nodes, x, f, rhs);
}

/// Adds `N(x)ᵀ f` to `rhs` on the nodes of piece `piece` of a split cell,
/// wherever in the cell `x` lies.
pub fn add_piece_load(
    grid: &Grid,
    dofs: &DofMap,
    (cell, piece): (&SplitCell, usize),
    x: [f64; 3],
    f: [f64; 3],
    rhs: &mut [f64],
) {
    let mut nodes = [0usize; 27];
    dofs.piece_active_nodes(grid, cell, piece, &mut nodes[..dofs.order.nodes_per_cell()]);
    add_load_on(grid, dofs.order, cell.cell, &nodes, x, f, rhs);
}

/// Adds `N(x)ᵀ f` to `rhs` on the active nodes `nodes` of `cell`.
fn add_load_on(
    grid: &Grid,
    order: ElementOrder,
    cell: usize,
    nodes: &[usize; 27],
    x: [f64; 3],
    f: [f64; 3],
    rhs: &mut [f64],
) {
    let n = shape_values_at(grid, order, cell, x);
    for a in 0..order.nodes_per_cell() {
        for c in 0..3 {
            rhs[3 * nodes[a] + c] += n[a] * f[c];
        }
    }
}

/// The shape values of `cell` at the point `x` (the first `nodes_per_cell`
/// entries).
fn shape_values_at(grid: &Grid, order: ElementOrder, cell: usize, x: [f64; 3]) -> [f64; 27] {
    let mut n = [0.0; 27];
    let x0 = grid.cell_box(cell).lo;
    let xi = [0, 1, 2].map(|a| (x[a] - x0[a]) / grid.h);
    shape_values(order, xi, &mut n[..order.nodes_per_cell()]);
    n
}

/// `F_b + F_N + F_p`: the part of the right-hand side that does not change in
/// the fixed-point loop.
///
/// The body load `F_b = Σ_c Σ_q w_q N_qᵀ b(x_q)` is the costly part (a
/// second-order jet of the exact field per point where the load comes from
/// one): its element vectors are computed in parallel ([`add_cell_loads`])
/// and scattered in cell order, so the result does not depend on the thread
/// count.
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
        add_inside_body_load(grid, cells, dofs, problem, &mut rhs);
        add_cut_body_load(grid, cells, dofs, problem, &mut rhs);
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

/// The body load of the inside cells on the tensor Gauss rule of one order
/// above the element's, its shape values tabulated once for all cells.
fn add_inside_body_load(
    grid: &Grid,
    cells: &Cells,
    dofs: &DofMap,
    problem: &Problem,
    rhs: &mut [f64],
) {
    let npc = dofs.order.nodes_per_cell();
    let rule = tensor_gauss_rule(dofs.order.gauss_points_per_axis() + 1);
    let vol = grid.h.powi(3);
    let shapes: Vec<[f64; 27]> = rule
        .iter()
        .map(|(xi, _)| {
            let mut n = [0.0; 27];
            shape_values(dofs.order, *xi, &mut n[..npc]);
            n
        })
        .collect();
    let inside: Vec<usize> = (0..cells.kinds.len())
        .filter(|&c| cells.kinds[c] == CellKind::Inside)
        .collect();
    let cell_of = |c: usize| c;
    add_cell_loads(grid, dofs, &inside, &cell_of, rhs, |group, fes| {
        let xs = grid.rule_points(group, &rule);
        let mut loads = vec![[0.0; 3]; xs.len()];
        problem.body_loads(&xs, &mut loads);
        for (fe, loads) in fes.iter_mut().zip(loads.chunks(rule.len())) {
            for (((_, w), n), b) in rule.iter().zip(&shapes).zip(loads) {
                let b = b.map(|v| v * w * vol);
                for a in 0..npc {
                    for d in 0..3 {
                        fe[3 * a + d] += n[a] * b[d];
                    }
                }
            }
        }
        Ok(())
    })
    .expect("a body load is infallible");
}

/// The body load of the cut cells on their volume points; a split cell's
/// point by point, each on its piece.
fn add_cut_body_load(
    grid: &Grid,
    cells: &Cells,
    dofs: &DofMap,
    problem: &Problem,
    rhs: &mut [f64],
) {
    let (cut, split): (Vec<usize>, Vec<usize>) =
        (0..cells.cut.len()).partition(|&i| dofs.split.cell(cells.cut[i]).is_none());
    for i in split {
        let points = cells.volume_points(i);
        let xs: Vec<[f64; 3]> = points.iter().map(|q| q.x).collect();
        let mut loads = vec![[0.0; 3]; xs.len()];
        problem.body_loads(&xs, &mut loads);
        for (q, b) in points.iter().zip(loads) {
            add_point_load(grid, dofs, cells.cut[i], q.x, b.map(|v| v * q.w), rhs);
        }
    }
    let cell_of = |i: usize| cells.cut[i];
    add_cell_loads(grid, dofs, &cut, &cell_of, rhs, |group, fes| {
        let points = |i: usize| cells.volume_points(i).iter();
        let xs: Vec<[f64; 3]> = group.iter().flat_map(|&i| points(i).map(|q| q.x)).collect();
        let mut loads = vec![[0.0; 3]; xs.len()];
        problem.body_loads(&xs, &mut loads);
        let mut loads = loads.iter();
        for (&i, fe) in group.iter().zip(fes) {
            for (q, b) in points(i).zip(&mut loads) {
                let b = b.map(|v| v * q.w);
                add_element_point_load(grid, dofs.order, cells.cut[i], q.x, b, fe);
            }
        }
        Ok(())
    })
    .expect("a body load is infallible");
}

/// Cells scattered per block by [`add_cell_loads`]: a few MiB of element
/// vectors held at a time.
const LOAD_BLOCK: usize = 4096;

/// Cells whose element vectors one call of [`add_cell_loads`]'s `element`
/// computes: enough points for batched evaluations of expressions.
const LOAD_GROUP: usize = 16;

/// One cell's load vector, node-major (`3 a + d`), room for a Q2 cell.
pub type ElementLoad = [f64; 81];

/// Adds the element load vectors of `items` to `rhs`: `element(group, fes)`
/// accumulates the vector of the cell `cell_of(group[k])` into `fes[k]`
/// (zeroed before the call), for groups of up to [`LOAD_GROUP`] consecutive
/// items. The vectors of a block of items are computed in parallel, then
/// scattered in item order, so that the sum does not depend on the thread
/// count. An error of an element stops the sum and is returned (`rhs` is
/// then partly summed).
pub fn add_cell_loads<F>(
    grid: &Grid,
    dofs: &DofMap,
    items: &[usize],
    cell_of: &(dyn Fn(usize) -> usize + Sync),
    rhs: &mut [f64],
    element: F,
) -> Result<()>
where
    F: Fn(&[usize], &mut [ElementLoad]) -> Result<()> + Sync,
{
    let npc = dofs.order.nodes_per_cell();
    let mut block = vec![[0.0; 81]; LOAD_BLOCK.min(items.len())];
    let mut nodes = [0usize; 27];
    for chunk in items.chunks(LOAD_BLOCK) {
        block[..chunk.len()]
            .par_chunks_mut(LOAD_GROUP)
            .zip(chunk.par_chunks(LOAD_GROUP))
            .try_for_each(|(fes, group)| {
                fes.fill([0.0; 81]);
                element(group, fes)
            })?;
        for (fe, &item) in block.iter().zip(chunk) {
            dofs.cell_active_nodes(grid, cell_of(item), &mut nodes[..npc]);
            for a in 0..npc {
                for d in 0..3 {
                    rhs[3 * nodes[a] + d] += fe[3 * a + d];
                }
            }
        }
    }
    Ok(())
}

/// The `element` of [`add_cell_loads`] that computes each item's vector
/// with `one(item, fe)`.
pub fn per_item<F>(one: F) -> impl Fn(&[usize], &mut [ElementLoad]) -> Result<()> + Sync
where
    F: Fn(usize, &mut ElementLoad) -> Result<()> + Sync,
{
    move |group, fes| group.iter().zip(fes).try_for_each(|(&i, fe)| one(i, fe))
}

/// Adds `N(x)ᵀ f` to the element vector `fe` of `cell` (node-major).
pub fn add_element_point_load(
    grid: &Grid,
    order: ElementOrder,
    cell: usize,
    x: [f64; 3],
    f: [f64; 3],
    fe: &mut ElementLoad,
) {
    let n = shape_values_at(grid, order, cell, x);
    for a in 0..order.nodes_per_cell() {
        for d in 0..3 {
            fe[3 * a + d] += n[a] * f[d];
        }
    }
}

/// `F_T = Σ_q w_q N_qᵀ t̂_q` for recovered tractions `t̂` at the Dirichlet
/// points (already masked, [`crate::driver::recovery::recovered_tractions`]).
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
