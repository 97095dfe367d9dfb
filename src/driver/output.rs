//! `solution.vtu`: the cells of the body (inside and cut) as hexahedra on
//! their element nodes (Q1: `VTK_HEXAHEDRON` on the vertices; Q2:
//! `VTK_TRIQUADRATIC_HEXAHEDRON` on the 27 nodes, so ParaView interpolates
//! the quadratic field), with the displacement, the SPR-recovered stress (the
//! CPE blend `σ̂` at the node) and its von Mises value at the nodes (plus the
//! exact displacement when the case has one), the level set φ of the solid
//! at the nodes (`level_set`, negative inside: ParaView's *Clip* by this
//! scalar at 0, inverted, cuts the cut cells down to the body), and the cell
//! class and volume fraction per cell.

use std::path::Path;

use rayon::prelude::*;

use super::recovery::{recover_stress, vertex_nodes_of};
use super::setup::Setup;
use crate::cells::CellKind;
use crate::element::ElementOrder;
use crate::error::Result;
use crate::geometry::Geometry;
use crate::grid::Grid;
use crate::vtu::{write_vtu, DataArray, VtuCell, VtuEncoding, VtuMesh};

/// Von Mises stress of a Voigt stress (xx, yy, zz, yz, xz, xy).
pub fn von_mises(s: &[f64; 6]) -> f64 {
    let d = (s[0] - s[1]).powi(2) + (s[1] - s[2]).powi(2) + (s[2] - s[0]).powi(2);
    (0.5 * d + 3.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5])).sqrt()
}

/// The point data `level_set`: φ of `geometry` at `points` (negative inside).
pub(crate) fn level_set(geometry: &Geometry, points: &[[f64; 3]]) -> DataArray {
    DataArray::scalars_f64(
        "level_set",
        points.par_iter().map(|&x| geometry.phi(x)).collect(),
    )
}

/// The element nodes of the body cells, as VTU points: each node once (in
/// order of first appearance), with one cell holding it, and the cells on
/// those points.
pub(crate) struct BodyMesh {
    pub nodes: Vec<usize>,
    pub node_cell: Vec<usize>,
    pub cells: Vec<VtuCell>,
}

/// The [`BodyMesh`] of the cells `body` of `grid` for elements of `order`.
pub(crate) fn body_mesh(grid: &Grid, order: ElementOrder, body: &[usize]) -> BodyMesh {
    let npe = order.nodes_per_cell();
    // The point of each grid node, `usize::MAX` until it is met: one word per
    // grid node, as the dof map's own node table.
    let mut point_of = vec![usize::MAX; grid.num_nodes(order)];
    let (mut nodes, mut node_cell) = (Vec::new(), Vec::new());
    let mut local = vec![0usize; npe];
    let mut cells = Vec::with_capacity(body.len());
    for &c in body {
        grid.cell_nodes(order, c, &mut local);
        for n in local.iter_mut() {
            if point_of[*n] == usize::MAX {
                point_of[*n] = nodes.len();
                nodes.push(*n);
                node_cell.push(c);
            }
            *n = point_of[*n];
        }
        cells.push(match order {
            ElementOrder::Q1 => VtuCell::hex8_from_lexicographic(std::array::from_fn(|i| local[i])),
            ElementOrder::Q2 => {
                VtuCell::hex27_from_lexicographic(std::array::from_fn(|i| local[i]))
            }
        });
    }
    BodyMesh {
        nodes,
        node_cell,
        cells,
    }
}

/// Writes the solution `u` of `setup` (whose solid is `geometry`) to `path`.
pub fn write_solution(setup: &Setup, geometry: &Geometry, u: &[f64], path: &Path) -> Result<()> {
    let grid = &setup.grid;
    let dofs = &setup.op.dofs;
    let body: Vec<usize> = (0..grid.num_cells())
        .filter(|&c| setup.cells.kinds[c] != CellKind::Outside)
        .collect();
    let mesh = body_mesh(grid, dofs.order, &body);
    let points: Vec<[f64; 3]> = mesh
        .nodes
        .iter()
        .map(|&n| grid.node_position(dofs.order, n))
        .collect();
    // Every node of a body cell is active, so u there is a nodal value.
    let displacement: Vec<[f64; 3]> = mesh
        .nodes
        .iter()
        .map(|&n| {
            let a = dofs.node_to_active[n] as usize;
            [u[3 * a], u[3 * a + 1], u[3 * a + 2]]
        })
        .collect();
    let sigma = recover_stress(setup, u, &vertex_nodes_of(setup, &body), None)?;
    let stress: Vec<[f64; 6]> = mesh
        .node_cell
        .par_iter()
        .zip(&points)
        .map(|(&c, &x)| sigma.eval(c, x))
        .collect::<Result<_>>()?;
    let mises: Vec<f64> = stress.par_iter().map(von_mises).collect();
    let mut point_data = vec![
        DataArray::vectors("displacement", &displacement),
        DataArray::sym_tensors("stress", &stress),
        DataArray::scalars_f64("von_mises", mises),
        level_set(geometry, &points),
    ];
    if let Some(exact) = &setup.problem.exact {
        let ue: Vec<[f64; 3]> = points.par_iter().map(|&x| exact.eval(x)).collect();
        point_data.push(DataArray::vectors("exact_displacement", &ue));
    }
    let mut fraction = vec![1.0; body.len()];
    for (i, &c) in setup.cells.cut.iter().enumerate() {
        if let Ok(k) = body.binary_search(&c) {
            fraction[k] = setup.cells.fraction[i];
        }
    }
    let class: Vec<u8> = body.iter().map(|&c| setup.cells.kinds[c] as u8).collect();
    let cell_data = vec![
        DataArray::scalars_u8("cell_class", class),
        DataArray::scalars_f64("volume_fraction", fraction),
    ];
    let mesh = VtuMesh {
        points,
        cells: mesh.cells,
    };
    write_vtu(path, &mesh, &point_data, &cell_data, VtuEncoding::Binary)
}
