//! The hyperelastic tangent kernel (`shaders/hyper_tangent.wgsl`) on a real
//! adapter (lavapipe in CI) against its CPU mirror, in f64. Without an adapter
//! with f64 the test prints "skipped: no GPU adapter" and passes, unless
//! `CI=true` (see `cgfem_gpu::gpu::context_or_skip`).

use std::sync::Arc;

use cgfem_gpu::cells::{cut_rule_points, Cells};
use cgfem_gpu::element::ElementOrder;
use cgfem_gpu::geometry::{Aabb, Geometry};
use cgfem_gpu::gpu::{context_or_skip, GpuContext, PrecisionChoice};
use cgfem_gpu::grid::Grid;
use cgfem_gpu::hyper::material::Material;
use cgfem_gpu::hyper::mirror::{
    hyper_tangent, source, HyperTangentParams, InsideTangentData, WORKGROUP,
};
use cgfem_gpu::hyper::problem::{DirichletCondition, HyperProblem, Loads};
use cgfem_gpu::hyper::tangent::TangentOperator;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use wgpu::util::DeviceExt;

/// The unit sphere on a shifted grid with a large smooth displacement.
fn sphere(level: u32, material: Material) -> (HyperProblem, Vec<f64>) {
    let g = Geometry::sphere([0.0; 3], 1.0).unwrap();
    let grid = Grid::new(&Aabb::new([-1.0; 3], [1.0; 3]), level, [0.13, 0.29, 0.41]).unwrap();
    let cells = Cells::classify(&grid, &g, cut_rule_points(ElementOrder::Q1)).unwrap();
    let dirichlet = [DirichletCondition {
        tag: 0,
        components: [true; 3],
        value: Arc::new(|_| [0.0; 3]),
    }];
    let p = HyperProblem::new(&grid, &cells, material, 3e4, &dirichlet, &Loads::default()).unwrap();
    let mut u = vec![0.0; p.ndofs()];
    for (a, &node) in p.dofs.active_to_node.iter().enumerate() {
        let x = p.grid.node_position(ElementOrder::Q1, node as usize);
        u[3 * a] = 0.15 * (x[0] + x[1]).sin();
        u[3 * a + 1] = 0.1 * x[0] * x[2] - 0.1 * x[1];
        u[3 * a + 2] = 0.12 * x[1] * x[1];
    }
    (p, u)
}

fn storage(ctx: &GpuContext, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    ctx.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        })
}

/// Runs the kernel once (f64) and reads `y` back.
fn run_kernel(
    ctx: &GpuContext,
    prm: &HyperTangentParams,
    p: &HyperProblem,
    data: &InsideTangentData,
    x: &[f64],
) -> Vec<f64> {
    let dev = &ctx.device;
    let module = dev.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("hyper_tangent"),
        source: wgpu::ShaderSource::Wgsl(source(ctx.precision).into()),
    });
    let pipeline = dev.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("hyper_tangent"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let uniform = dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("params"),
        contents: bytemuck::bytes_of(prm),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let size = 8 * x.len() as u64;
    let y = dev.create_buffer(&wgpu::BufferDescriptor {
        label: Some("y"),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let buffers = [
        storage(
            ctx,
            "active_to_node",
            bytemuck::cast_slice(&p.dofs.active_to_node),
        ),
        storage(
            ctx,
            "node_to_active",
            bytemuck::cast_slice(&p.dofs.node_to_active),
        ),
        storage(
            ctx,
            "inside_index",
            bytemuck::cast_slice(&data.inside_index),
        ),
        storage(ctx, "consts", bytemuck::cast_slice(&data.consts)),
        storage(ctx, "state", bytemuck::cast_slice(&data.state)),
        storage(ctx, "x", bytemuck::cast_slice(x)),
    ];
    let mut entries = vec![wgpu::BindGroupEntry {
        binding: 0,
        resource: uniform.as_entire_binding(),
    }];
    for (i, b) in buffers.iter().chain([&y]).enumerate() {
        entries.push(wgpu::BindGroupEntry {
            binding: i as u32 + 1,
            resource: b.as_entire_binding(),
        });
    }
    let bind = dev.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("hyper_tangent"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    });
    let staging = dev.create_buffer(&wgpu::BufferDescriptor {
        label: Some("staging"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut enc = dev.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("hyper_tangent"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(prm.n_active.div_ceil(WORKGROUP), 1, 1);
    }
    enc.copy_buffer_to_buffer(&y, 0, &staging, 0, size);
    ctx.queue.submit([enc.finish()]);
    let slice = staging.slice(..);
    slice.map_async(wgpu::MapMode::Read, |r| {
        r.expect("mapping the staging buffer")
    });
    dev.poll(wgpu::PollType::wait_indefinitely())
        .expect("device lost");
    let bytes = slice
        .get_mapped_range()
        .expect("reading the staging buffer");
    let out = bytemuck::pod_collect_to_vec::<u8, f64>(&bytes);
    drop(bytes);
    staging.unmap();
    out
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
    ] {
        for level in [3, 4] {
            let (p, u) = sphere(level, material);
            let tangent = TangentOperator::new(&p, &u).unwrap();
            let data = InsideTangentData::new(&tangent);
            let x: Vec<f64> = (0..p.ndofs()).map(|_| rng.gen_range(-1.0..1.0)).collect();
            let n_active = p.dofs.num_active() as u32;
            let prm = HyperTangentParams {
                n_active,
                stride: n_active.div_ceil(WORKGROUP) * WORKGROUP,
                ncx: p.grid.n[0] as u32,
                ncy: p.grid.n[1] as u32,
                ncz: p.grid.n[2] as u32,
                ..Default::default()
            };
            let gpu = run_kernel(&ctx, &prm, &p, &data, &x);
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
