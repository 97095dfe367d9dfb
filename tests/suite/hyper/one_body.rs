//! Large-deformation hyperelasticity of one body (without contact), Q1 and
//! Q2: the tangent against finite differences of the residual, against the
//! linear operator at u = 0 and against its own assembly; the residual
//! against the energy. The Newton solves are in `one_body/newton.rs`, the
//! patch test in `one_body/patch.rs`.

mod newton;
mod patch;
mod recovered;

use std::sync::Arc;

use cgfem_gpu::backend::LinearOperator;
use cgfem_gpu::cells::{cut_rule_points, Cells};
use cgfem_gpu::element::ElementOrder;
use cgfem_gpu::fem::operator::{AssembledOperator, ElasticOperator, OperatorParams};
use cgfem_gpu::geometry::Geometry;
use cgfem_gpu::grid::Grid;
use cgfem_gpu::hyper::material::Material;
use cgfem_gpu::hyper::problem::{DirichletCondition, HyperProblem, Loads, Ramp};
use cgfem_gpu::hyper::residual::{energy, residual};
use cgfem_gpu::hyper::tangent::TangentOperator;
use cgfem_gpu::spatial::Aabb;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const E: f64 = 1000.0;
const NU: f64 = 0.3;
const BETA: f64 = 30.0 * E;

/// The elements and the sphere's level each is tested on.
const ELEMENTS: [(ElementOrder, u32); 2] = [(ElementOrder::Q1, 3), (ElementOrder::Q2, 2)];

/// The unit sphere on a shifted grid (every kind of cut), fixed on its surface
/// to a non-trivial field, with a body load.
fn sphere(order: ElementOrder, level: u32, material: Material) -> HyperProblem {
    let g = Geometry::sphere([0.0; 3], 1.0).unwrap();
    let grid = Grid::new(&Aabb::new([-1.0; 3], [1.0; 3]), level, [0.13, 0.29, 0.41]).unwrap();
    let cells = Cells::classify(&grid, &g, cut_rule_points(order)).unwrap();
    let dirichlet = [DirichletCondition {
        tag: 0,
        components: [true; 3],
        value: Arc::new(|x: [f64; 3]| [0.1 * x[0] * x[1], -0.05 * x[2] * x[2], 0.08 * x[0]]),
        ramps: [Ramp::LINEAR; 3],
    }];
    let loads = Loads {
        body: Some(Arc::new(|x: [f64; 3]| [10.0, -20.0 * x[0], 5.0])),
        tractions: Vec::new(),
    };
    HyperProblem::new(&grid, &cells, order, material, BETA, &dirichlet, &loads).unwrap()
}

/// A smooth large displacement (|∇u| up to ~0.3) plus a little noise.
fn nontrivial_u(p: &HyperProblem, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let mut u = vec![0.0; p.ndofs()];
    for (a, &node) in p.dofs.active_to_node.iter().enumerate() {
        let x = p.grid.node_position(p.order(), node as usize);
        let smooth = [
            0.15 * (x[0] + x[1]).sin(),
            0.1 * x[0] * x[2] - 0.1 * x[1],
            0.12 * x[1] * x[1],
        ];
        for i in 0..3 {
            u[3 * a + i] = smooth[i] + rng.gen_range(-0.005..0.005);
        }
    }
    u
}

fn random_vector(n: usize, rng: &mut ChaCha8Rng) -> Vec<f64> {
    (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect()
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn relative_difference(a: &[f64], b: &[f64]) -> f64 {
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    norm(&d) / norm(b)
}

fn materials() -> [Material; 3] {
    [
        Material::neo_hookean(E, NU),
        Material::st_venant_kirchhoff(E, NU),
        Material::linear(E, NU),
    ]
}

/// Every material with every element of [`ELEMENTS`].
fn materials_and_elements() -> impl Iterator<Item = (Material, (ElementOrder, u32))> {
    materials()
        .into_iter()
        .flat_map(|m| ELEMENTS.into_iter().map(move |e| (m, e)))
}

#[test]
fn tangent_equals_central_differences_of_the_residual() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for (material, (order, level)) in materials_and_elements() {
        let p = sphere(order, level, material);
        let t = 0.7;
        let u = nontrivial_u(&p, &mut rng);
        let v = random_vector(p.ndofs(), &mut rng);
        let k = TangentOperator::new(&p, &u).expect("det F > 0");
        let mut kv = vec![0.0; p.ndofs()];
        k.apply(&v, &mut kv);
        let eps = 1e-6;
        let shifted = |s: f64| -> Vec<f64> {
            let w: Vec<f64> = u.iter().zip(&v).map(|(a, b)| a + s * b).collect();
            residual(&p, &w, t).expect("det F > 0")
        };
        let (rp, rm) = (shifted(eps), shifted(-eps));
        let fd: Vec<f64> = rp
            .iter()
            .zip(&rm)
            .map(|(a, b)| (a - b) / (2.0 * eps))
            .collect();
        let err = relative_difference(&kv, &fd);
        println!(
            "{order:?} {:?}: ‖K_T v − FD‖ / ‖FD‖ = {err:.2e}",
            material.model
        );
        assert!(err < 1e-6, "{order:?} {:?}: {err:e}", material.model);
    }
}

#[test]
fn residual_is_the_gradient_of_the_energy() {
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    for (material, order) in materials_and_elements().map(|(m, (o, _))| (m, o)) {
        let p = sphere(order, 2, material);
        let t = 0.4;
        let u = nontrivial_u(&p, &mut rng);
        let v = random_vector(p.ndofs(), &mut rng);
        let r = residual(&p, &u, t).unwrap();
        let eps = 1e-6;
        let shifted = |s: f64| {
            let w: Vec<f64> = u.iter().zip(&v).map(|(a, b)| a + s * b).collect();
            energy(&p, &w, t).unwrap()
        };
        let fd = (shifted(eps) - shifted(-eps)) / (2.0 * eps);
        let exact: f64 = r.iter().zip(&v).map(|(a, b)| a * b).sum();
        let err = (fd - exact).abs() / exact.abs();
        assert!(err < 1e-6, "{order:?} {:?}: {err:e}", material.model);
    }
}

#[test]
fn tangent_at_zero_is_the_linear_operator() {
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    for (material, (order, level)) in materials_and_elements() {
        let g = Geometry::sphere([0.0; 3], 1.0).unwrap();
        let bbox = Aabb::new([-1.0; 3], [1.0; 3]);
        let grid = Grid::new(&bbox, level, [0.13, 0.29, 0.41]).unwrap();
        let cells = Cells::classify(&grid, &g, cut_rule_points(order)).unwrap();
        let params = OperatorParams {
            young: E,
            poisson: NU,
            beta: BETA,
            dirichlet: &|_, _| Some([true; 3]),
        };
        let linear = ElasticOperator::new(&grid, &cells, order, &params);
        let p = sphere(order, level, material);
        assert_eq!(p.ndofs(), linear.nrows());
        let k = TangentOperator::new(&p, &vec![0.0; p.ndofs()]).unwrap();
        for _ in 0..2 {
            let v = random_vector(p.ndofs(), &mut rng);
            let (mut a, mut b) = (vec![0.0; p.ndofs()], vec![0.0; p.ndofs()]);
            k.apply(&v, &mut a);
            linear.apply(&v, &mut b);
            let err = relative_difference(&a, &b);
            assert!(err < 1e-12, "{order:?} {:?}: {err:e}", material.model);
        }
        let err = relative_difference(&k.diagonal(), &linear.diagonal());
        assert!(
            err < 1e-12,
            "{order:?} {:?} diagonal: {err:e}",
            material.model
        );
    }
}

#[test]
fn matrix_free_tangent_equals_the_assembled_one() {
    let mut rng = ChaCha8Rng::seed_from_u64(14);
    for (material, (order, level)) in materials_and_elements() {
        let p = sphere(order, level, material);
        let u = nontrivial_u(&p, &mut rng);
        let k = TangentOperator::new(&p, &u).unwrap();
        let assembled = AssembledOperator(k.assemble());
        for _ in 0..2 {
            let v = random_vector(p.ndofs(), &mut rng);
            let (mut a, mut b) = (vec![0.0; p.ndofs()], vec![0.0; p.ndofs()]);
            k.apply(&v, &mut a);
            assembled.apply(&v, &mut b);
            let err = relative_difference(&a, &b);
            assert!(err < 1e-12, "{order:?} {:?}: {err:e}", material.model);
        }
        let err = relative_difference(&k.diagonal(), &assembled.diagonal());
        assert!(
            err < 1e-13,
            "{order:?} {:?} diagonal: {err:e}",
            material.model
        );
        // Hyperelastic: K_T is symmetric, x·K y = y·K x.
        let x = random_vector(p.ndofs(), &mut rng);
        let y = random_vector(p.ndofs(), &mut rng);
        let (mut kx, mut ky) = (vec![0.0; p.ndofs()], vec![0.0; p.ndofs()]);
        k.apply(&x, &mut kx);
        k.apply(&y, &mut ky);
        let (xky, ykx): (f64, f64) = (
            x.iter().zip(&ky).map(|(a, b)| a * b).sum(),
            y.iter().zip(&kx).map(|(a, b)| a * b).sum(),
        );
        assert!((xky - ykx).abs() < 1e-12 * xky.abs().max(ykx.abs()));
    }
}

#[test]
fn inverted_states_have_no_residual() {
    let p = sphere(ElementOrder::Q1, 2, Material::neo_hookean(E, NU));
    // u = −2 X everywhere: F = −I, det F = −1.
    let mut u = vec![0.0; p.ndofs()];
    for (a, &node) in p.dofs.active_to_node.iter().enumerate() {
        let x = p.grid.node_position(ElementOrder::Q1, node as usize);
        for i in 0..3 {
            u[3 * a + i] = -2.0 * x[i];
        }
    }
    assert!(residual(&p, &u, 1.0).is_none());
    assert!(energy(&p, &u, 1.0).is_none());
    assert!(TangentOperator::new(&p, &u).is_none());
}
