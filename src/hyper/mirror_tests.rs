//! Tests that need no GPU: the mirror plus the CPU's cut cells is the
//! tangent. The kernel's validation and its params layout are checked with
//! every kernel of the registry (`crate::gpu`'s tests).

use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::backend::LinearOperator;
use crate::cells::{cut_rule_points, Cells};
use crate::element::ElementOrder;
use crate::geometry::Geometry;
use crate::grid::Grid;
use crate::hyper::material::Material;
use crate::hyper::problem::{DirichletCondition, HyperProblem, Loads, Ramp};
use crate::spatial::Aabb;

/// The unit sphere on a shifted level-3 grid at a large smooth displacement.
fn sphere_tangent_inputs(material: Material) -> (HyperProblem, Vec<f64>) {
    let g = Geometry::sphere([0.0; 3], 1.0).unwrap();
    let grid = Grid::new(&Aabb::new([-1.0; 3], [1.0; 3]), 3, [0.13, 0.29, 0.41]).unwrap();
    let cells = Cells::classify(&grid, &g, cut_rule_points(ElementOrder::Q1)).unwrap();
    let dirichlet = [DirichletCondition {
        tag: 0,
        components: [true; 3],
        value: Arc::new(|_| [0.0; 3]),
        ramps: [Ramp::LINEAR; 3],
    }];
    let p = HyperProblem::new(
        &grid,
        &cells,
        ElementOrder::Q1,
        material,
        3e4,
        &dirichlet,
        &Loads::default(),
    )
    .unwrap();
    let mut u = vec![0.0; p.ndofs()];
    for (a, &node) in p.dofs.active_to_node.iter().enumerate() {
        let x = p.grid.node_position(ElementOrder::Q1, node as usize);
        u[3 * a] = 0.15 * (x[0] + x[1]).sin();
        u[3 * a + 1] = 0.1 * x[0] * x[2];
        u[3 * a + 2] = 0.12 * x[1] * x[1];
    }
    (p, u)
}

#[test]
fn mirror_plus_cut_cells_is_the_tangent() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    for material in [
        Material::neo_hookean(1000.0, 0.3),
        Material::st_venant_kirchhoff(1000.0, 0.3),
    ] {
        let (p, u) = sphere_tangent_inputs(material);
        let tangent = TangentOperator::new(&p, &u).unwrap();
        let data = InsideTangentData::new(&tangent);
        let x: Vec<f64> = (0..p.ndofs()).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let prm = HyperTangentParams::new(&p, 0);
        let mut y = vec![f64::NAN; p.ndofs()];
        hyper_tangent(
            &prm,
            &p.dofs.active_to_node,
            &p.dofs.node_to_active,
            &data.inside_index,
            &data.consts,
            &data.state,
            &x,
            &mut y,
        );
        tangent.add_cut_cells(&x, &mut y);
        let mut want = vec![0.0; p.ndofs()];
        tangent.apply(&x, &mut want);
        let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let diff = y
            .iter()
            .zip(&want)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(
            diff <= 1e-12 * scale,
            "{:?}: {diff:e} of {scale:e}",
            material.model
        );
    }
}
