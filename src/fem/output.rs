//! `solution.vtu`: the cells of the body (inside and cut) as hexahedra on
//! their vertex nodes, with the displacement, the SPR-recovered stress and its
//! von Mises value at the vertices (plus the exact displacement when the case
//! has one), and the cell class and volume fraction per cell.

use std::path::Path;

use super::recovery::{recover_stress, vertex_nodes_of};
use super::setup::Setup;
use crate::cells::CellKind;
use crate::element::ElementOrder;
use crate::error::Result;
use crate::vtu::{write_vtu, DataArray, VtuCell, VtuEncoding, VtuMesh};

/// Von Mises stress of a Voigt stress (xx, yy, zz, yz, xz, xy).
pub fn von_mises(s: &[f64; 6]) -> f64 {
    let d = (s[0] - s[1]).powi(2) + (s[1] - s[2]).powi(2) + (s[2] - s[0]).powi(2);
    (0.5 * d + 3.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5])).sqrt()
}

/// Writes the solution `u` of `setup` to `path`.
pub fn write_solution(setup: &Setup, u: &[f64], path: &Path) -> Result<()> {
    let grid = &setup.grid;
    let body: Vec<usize> = (0..grid.num_cells())
        .filter(|&c| setup.cells.kinds[c] != CellKind::Outside)
        .collect();
    let vertices = vertex_nodes_of(setup, &body);
    let mut point_of = std::collections::HashMap::with_capacity(vertices.len());
    for (i, &v) in vertices.iter().enumerate() {
        point_of.insert(v, i);
    }
    let points: Vec<[f64; 3]> = vertices
        .iter()
        .map(|&v| grid.node_position(ElementOrder::Q1, v))
        .collect();
    let mut lex = [0usize; 8];
    let cells: Vec<VtuCell> = body
        .iter()
        .map(|&c| {
            grid.cell_nodes(ElementOrder::Q1, c, &mut lex);
            VtuCell::hex8_from_lexicographic(lex.map(|v| point_of[&v]))
        })
        .collect();
    // Vertex values: a Q1 vertex is also a Q2 node, so u there is a nodal value.
    let dofs = &setup.op.dofs;
    let p = dofs.order.degree();
    let m1 = grid.nodes_per_axis(ElementOrder::Q1);
    let mp = grid.nodes_per_axis(dofs.order);
    let displacement: Vec<[f64; 3]> = vertices
        .iter()
        .map(|&v| {
            let ijk = [v % m1[0], (v / m1[0]) % m1[1], v / (m1[0] * m1[1])];
            let node = p * ijk[0] + mp[0] * (p * ijk[1] + mp[1] * p * ijk[2]);
            let a = dofs.node_to_active[node] as usize;
            [u[3 * a], u[3 * a + 1], u[3 * a + 2]]
        })
        .collect();
    let sigma = recover_stress(setup, u, &vertices)?;
    let stress: Vec<[f64; 6]> = vertices
        .iter()
        .zip(&points)
        .map(|(&v, &x)| sigma.eval_node_polynomial(v, x))
        .collect::<Result<_>>()?;
    let mises: Vec<f64> = stress.iter().map(von_mises).collect();
    let mut point_data = vec![
        DataArray::vectors("displacement", &displacement),
        DataArray::sym_tensors("stress", &stress),
        DataArray::scalars_f64("von_mises", mises),
    ];
    if let Some(exact) = &setup.problem.exact {
        let ue: Vec<[f64; 3]> = points.iter().map(|&x| exact.eval(x)).collect();
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
    let mesh = VtuMesh { points, cells };
    write_vtu(path, &mesh, &point_data, &cell_data, VtuEncoding::Binary)
}
