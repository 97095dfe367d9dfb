//! The hyperelastic tangent kernel (`shaders/hyper_tangent.wgsl`) on a real
//! adapter (lavapipe in CI) against its CPU mirror, in f64. Without an adapter
//! with f64 the test prints "skipped: no GPU adapter" and passes, unless
//! `CI=true` (see `cgfem_gpu::gpu::context_or_skip`). The kernel runs through
//! the same `GpuHyperBody` the Newton solves use.

use std::sync::Arc;

use cgfem_gpu::cells::{cut_rule_points, Cells};
use cgfem_gpu::element::ElementOrder;
use cgfem_gpu::geometry::Geometry;
use cgfem_gpu::gpu::{context_or_skip, PrecisionChoice};
use cgfem_gpu::grid::Grid;
use cgfem_gpu::hyper::gpu::GpuHyperBody;
use cgfem_gpu::hyper::material::Material;
use cgfem_gpu::hyper::mirror::{hyper_tangent, HyperTangentParams, InsideTangentData};
use cgfem_gpu::hyper::problem::{DirichletCondition, HyperProblem, Loads, Ramp};
use cgfem_gpu::hyper::tangent::TangentOperator;
use cgfem_gpu::spatial::Aabb;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The unit sphere on a shifted grid with a large smooth displacement.
fn sphere(level: u32, material: Material) -> (HyperProblem, Vec<f64>) {
    let g = Geometry::sphere([0.0; 3], 1.0).unwrap();
    let grid = Grid::new(&Aabb::new([-1.0; 3], [1.0; 3]), level, [0.13, 0.29, 0.41]).unwrap();
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
        u[3 * a + 1] = 0.1 * x[0] * x[2] - 0.1 * x[1];
        u[3 * a + 2] = 0.12 * x[1] * x[1];
    }
    (p, u)
}

#[test]
fn tangent_kernel_equals_its_mirror_in_f64() {
    let Some(ctx) = context_or_skip(PrecisionChoice::F64) else {
        return;
    };
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    for material in [
        Material::neo_hookean(1000.0, 0.3),
        Material::st_venant_kirchhoff(1000.0, 0.3),
        Material::linear(1000.0, 0.3),
    ] {
        for level in [3, 4] {
            let (p, u) = sphere(level, material);
            let tangent = TangentOperator::new(&p, &u).unwrap();
            let data = InsideTangentData::new(&tangent);
            let x: Vec<f64> = (0..p.ndofs()).map(|_| rng.gen_range(-1.0..1.0)).collect();
            let body = GpuHyperBody::new(ctx.clone(), &p).unwrap();
            let mut gpu = vec![f64::NAN; p.ndofs()];
            body.bind(TangentOperator::new(&p, &u).unwrap())
                .apply_inside(&x, &mut gpu);
            let prm = HyperTangentParams::new(&p, 0);
            let mut cpu = vec![0.0; p.ndofs()];
            hyper_tangent(
                &prm,
                &p.dofs.active_to_node,
                &p.dofs.node_to_active,
                &data.inside_index,
                &data.consts,
                &data.state,
                &x,
                &mut cpu,
            );
            let scale = cpu.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let diff = gpu
                .iter()
                .zip(&cpu)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            println!(
                "{:?} level {level}: {} dofs, max |gpu − mirror| / max |mirror| = {:.1e}",
                material.model,
                p.ndofs(),
                diff / scale
            );
            assert!(
                scale > 0.0 && diff <= 1e-12 * scale,
                "{diff:e} of {scale:e}"
            );
        }
    }
}
