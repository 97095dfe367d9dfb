//! The large-deformation patch test, Q1 and Q2: a box cut out of a shifted
//! grid (every face cuts cells) under the homogeneous deformation
//! `x = F0 X`. Its first Piola–Kirchhoff stress `P0 = P(F0)` is constant,
//! so the body is in equilibrium with the traction `P0 N` on every face.
//! The three min faces also hold their normal component by the penalty, at
//! the exact value, which removes the rigid motions; with the traction
//! applied there too the exact field zeroes the penalty's residual, so it is
//! the discrete solution of any mesh whose element holds linear fields. The
//! S-term is on (a linear field is its own recovery), so the recovered passes
//! are tested as well. Newton reaches `F0` in load steps; the nodal values
//! must equal `(F0 − I) X` to round-off.

use std::sync::Arc;

use cgfem_gpu::cells::{cut_rule_points, Cells};
use cgfem_gpu::element::ElementOrder;
use cgfem_gpu::geometry::Geometry;
use cgfem_gpu::grid::Grid;
use cgfem_gpu::hyper::material::{Material, PointState};
use cgfem_gpu::hyper::newton::{solve_load_steps, CpuTangentSolver, HyperSolution, NewtonOptions};
use cgfem_gpu::hyper::problem::{DirichletCondition, HyperProblem, Loads, Ramp, TractionLoad};
use cgfem_gpu::progress::Silent;
use cgfem_gpu::solver::{KrylovMethod, KrylovOptions, Preconditioner};
use cgfem_gpu::spatial::Aabb;
use nalgebra::{Matrix3, Vector3};

use super::{BETA, E, NU};

/// A stretch with shear: `det F0 = 1.09`, principal stretches 0.86–1.3.
fn f0() -> Matrix3<f64> {
    Matrix3::new(1.25, 0.12, -0.05, 0.04, 0.9, 0.08, -0.06, 0.03, 0.97)
}

/// The box `[0, 1.6] × [0, 1] × [0, 0.9]` on its own bounding box at
/// `level`, shifted so that every face cuts cells, none of them below 30 %
/// of its volume.
fn patch_box(order: ElementOrder, level: u32, material: Material) -> HyperProblem {
    let hi = [1.6, 1.0, 0.9];
    let g = Geometry::cuboid([0.0; 3], hi).unwrap();
    let grid = Grid::new(&Aabb::new([0.0; 3], hi), level, [0.31, 0.4, 0.23]).unwrap();
    let cells = Cells::classify(&grid, &g, cut_rule_points(order)).unwrap();
    let f = f0();
    let exact = move |x: [f64; 3]| {
        let d = (f - Matrix3::identity()) * Vector3::from(x);
        [d[0], d[1], d[2]]
    };
    let dirichlet: Vec<DirichletCondition> = ["xmin", "ymin", "zmin"]
        .iter()
        .enumerate()
        .map(|(axis, name)| {
            let mut components = [false; 3];
            components[axis] = true;
            DirichletCondition {
                tag: g.tag_id(name).unwrap(),
                components,
                value: Arc::new(exact),
                ramps: [Ramp::LINEAR; 3],
            }
        })
        .collect();
    let p0 = material.stress(&PointState::new(f).unwrap());
    let traction = move |_: [f64; 3], n: [f64; 3]| {
        let t = p0 * Vector3::from(n);
        [t[0], t[1], t[2]]
    };
    let tractions = ["xmin", "xmax", "ymin", "ymax", "zmin", "zmax"]
        .iter()
        .map(|name| TractionLoad {
            tag: g.tag_id(name).unwrap(),
            field: Arc::new(traction),
            ramps: [Ramp::LINEAR; 3],
        })
        .collect();
    let loads = Loads {
        body: None,
        tractions,
    };
    HyperProblem::new(&grid, &cells, order, material, BETA, &dirichlet, &loads).unwrap()
}

fn tight_options() -> NewtonOptions {
    NewtonOptions {
        steps: 1,
        residual_tol: 1e-12,
        energy_tol: 1e-24,
        krylov: KrylovOptions {
            method: KrylovMethod::Cg,
            preconditioner: Preconditioner::Jacobi,
            rel_tol: 1e-13,
            max_iterations: 50_000,
        },
        ..NewtonOptions::default()
    }
}

/// `max_a |u_a − (F0 − I) X_a| / max_a |(F0 − I) X_a|` of the Newton
/// solution.
fn patch_error(order: ElementOrder, level: u32, material: Material) -> f64 {
    let p = patch_box(order, level, material);
    let start = std::time::Instant::now();
    let mut solution = HyperSolution::zero(&p);
    let mut solver = CpuTangentSolver::default();
    solve_load_steps(&p, &tight_options(), &mut solver, &Silent, &mut solution).unwrap();
    assert_eq!(solution.load_factor, 1.0);
    let (mut err, mut scale) = (0.0f64, 0.0f64);
    let f = f0() - Matrix3::identity();
    for (a, &node) in p.dofs.active_to_node.iter().enumerate() {
        let x = p.grid.node_position(order, node as usize);
        let d = f * Vector3::from(x);
        for i in 0..3 {
            err = err.max((solution.u[3 * a + i] - d[i]).abs());
            scale = scale.max(d[i].abs());
        }
    }
    println!(
        "{order:?} level {level}, {:?}: {} dofs, error {:.2e}, {} Krylov iterations, {:.1} s",
        material.model,
        p.ndofs(),
        err / scale,
        solution
            .attempts
            .iter()
            .flat_map(|a| &a.krylov_iterations)
            .sum::<usize>(),
        start.elapsed().as_secs_f64()
    );
    err / scale
}

#[test]
fn a_homogeneous_large_deformation_is_exact_with_q1_and_q2() {
    for material in [
        Material::neo_hookean(E, NU),
        Material::st_venant_kirchhoff(E, NU),
    ] {
        for (order, level) in [(ElementOrder::Q1, 3), (ElementOrder::Q2, 2)] {
            let err = patch_error(order, level, material);
            assert!(err < 1e-10, "{order:?} {:?}: {err:e}", material.model);
        }
    }
}
