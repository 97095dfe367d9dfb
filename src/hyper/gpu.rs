//! The hyperelastic tangent of one body on a device, for the Newton solves
//! of large-deformation runs: `K_T x = hyper_tangent(x) + cut(x)`,
//! the inside cells by the kernel `shaders/hyper_tangent.wgsl` (CPU mirror
//! [`crate::hyper::mirror::hyper_tangent`]) and the cut cells, the Dirichlet
//! penalty and whatever else [`TangentOperator::add_cut_cells`] carries on the
//! CPU. The Krylov iterations stay on the host: each apply writes `x` to the
//! device, runs the kernel and reads `y` back.
//!
//! The kernel comes from the device's registry ([`Kernel::HyperTangent`]).
//! [`GpuHyperBody`] holds what does not change during a run (the node maps, `x`, `y` and the read-back buffer); [`GpuHyperBody::bind`]
//! uploads one tangent's point data ([`InsideTangentData`], 28 reals per
//! inside point) for the applies of one Newton iteration. f64 only (the
//! tangent coefficients span many orders of magnitude near inversion). The
//! kernel binds each array whole: an array beyond one storage binding is
//! refused with [`Error::DeviceTooSmall`] (exit code 2).

use std::sync::Arc;

use wgpu::util::DeviceExt;

use super::mirror::{HyperTangentParams, InsideTangentData, STATE_STRIDE, WORKGROUP};
use super::problem::HyperProblem;
use super::tangent::TangentOperator;
use crate::backend::LinearOperator;
use crate::element::ElementOrder;
use crate::error::{Error, Result};
use crate::gpu::kernels::{grid_2d, Kernel};
use crate::gpu::{GpuContext, Precision};

/// One body's device side of the tangent.
pub struct GpuHyperBody {
    ctx: Arc<GpuContext>,
    groups: (u32, u32),
    params: wgpu::Buffer,
    active_to_node: wgpu::Buffer,
    node_to_active: wgpu::Buffer,
    x: wgpu::Buffer,
    y: wgpu::Buffer,
    staging: wgpu::Buffer,
}

/// A storage buffer holding `bytes` (read-only in the kernel).
fn storage(ctx: &GpuContext, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    ctx.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytes,
            usage: wgpu::BufferUsages::STORAGE,
        })
}

/// [`Error::DeviceTooSmall`] unless an array of `bytes` fits one binding.
fn check_binding(ctx: &GpuContext, what: &str, bytes: usize) -> Result<()> {
    let max = ctx.bindings.max_bytes;
    if bytes as u64 > max {
        return Err(Error::DeviceTooSmall {
            what: format!(
                "the hyperelastic tangent's {what} ({bytes} bytes) exceeds one storage binding \
                 of {} ({max} bytes); use a lower level or --backend cpu",
                ctx.adapter.name
            ),
        });
    }
    Ok(())
}

impl GpuHyperBody {
    /// The device side of `problem`'s tangent on `ctx` (which must run f64).
    pub fn new(ctx: Arc<GpuContext>, problem: &HyperProblem) -> Result<GpuHyperBody> {
        if problem.order() != ElementOrder::Q1 {
            return Err(Error::UnsupportedOnBackend {
                backend: "gpu".into(),
                what: format!(
                    "the large-deformation tangent of {:?} elements (its kernel is Q1)",
                    problem.order()
                ),
                hint: "run this case with --backend cpu".into(),
            });
        }
        if ctx.precision != Precision::F64 {
            return Err(Error::Gpu {
                what: format!(
                    "the large-deformation tangent needs f64, which {} was not opened with",
                    ctx.adapter.name
                ),
            });
        }
        let n_active = problem.dofs.num_active() as u32;
        let vector_bytes = 8 * problem.ndofs();
        check_binding(&ctx, "vector", vector_bytes)?;
        let inside = problem.cut_index.iter().filter(|c| c.is_none()).count();
        let state_bytes = 8 * inside * problem.inside_rule.len() * STATE_STRIDE;
        check_binding(&ctx, "point data", state_bytes)?;
        check_binding(&ctx, "cell map", 4 * problem.grid.num_cells())?;
        let max_dim = ctx.limits.max_compute_workgroups_per_dimension;
        let (gx, gy, stride) = grid_2d(n_active, WORKGROUP, max_dim);
        let prm = HyperTangentParams::new(problem, stride);
        let dev = &ctx.device;
        let params = dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("hyper_tangent params"),
            contents: bytemuck::bytes_of(&prm),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let vector = |label: &str, usage: wgpu::BufferUsages| {
            dev.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: vector_bytes.max(8) as u64,
                usage,
                mapped_at_creation: false,
            })
        };
        use wgpu::BufferUsages as U;
        Ok(GpuHyperBody {
            groups: (gx, gy),
            params,
            active_to_node: storage(
                &ctx,
                "active_to_node",
                bytemuck::cast_slice(&problem.dofs.active_to_node),
            ),
            node_to_active: storage(
                &ctx,
                "node_to_active",
                bytemuck::cast_slice(&problem.dofs.node_to_active),
            ),
            x: vector("x", U::STORAGE | U::COPY_DST),
            y: vector("y", U::STORAGE | U::COPY_SRC),
            staging: vector("y read-back", U::MAP_READ | U::COPY_DST),
            ctx,
        })
    }

    /// The adapter's name.
    pub fn adapter(&self) -> &str {
        &self.ctx.adapter.name
    }

    /// `tangent` with its inside cells on the device (its point data uploaded).
    /// (The sizes were checked by [`GpuHyperBody::new`].)
    pub fn bind<'a>(&'a self, tangent: TangentOperator<'a>) -> GpuTangent<'a> {
        let data = InsideTangentData::new(&tangent);
        let ctx = &self.ctx;
        let buffers = [
            storage(
                ctx,
                "inside_index",
                bytemuck::cast_slice(&data.inside_index),
            ),
            storage(ctx, "consts", bytemuck::cast_slice(&data.consts)),
            // An empty array cannot be bound: one zero stands in for no inside cell.
            storage(
                ctx,
                "state",
                bytemuck::cast_slice(if data.state.is_empty() {
                    &[0.0][..]
                } else {
                    &data.state
                }),
            ),
        ];
        let resources = [
            &self.params,
            &self.active_to_node,
            &self.node_to_active,
            &buffers[0],
            &buffers[1],
            &buffers[2],
            &self.x,
            &self.y,
        ];
        let entries: Vec<wgpu::BindGroupEntry> = resources
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        let (_, layout) = ctx.pipelines.get(Kernel::HyperTangent);
        let bind = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hyper_tangent"),
            layout,
            entries: &entries,
        });
        GpuTangent {
            body: self,
            tangent,
            bind,
        }
    }

    /// `y = hyper_tangent(x)` on the device with the point data of `bind`.
    fn run_kernel(&self, bind: &wgpu::BindGroup, x: &[f64], y: &mut [f64]) {
        if x.is_empty() {
            return;
        }
        let (dev, queue) = (&self.ctx.device, &self.ctx.queue);
        queue.write_buffer(&self.x, 0, bytemuck::cast_slice(x));
        let mut enc = dev.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("hyper_tangent"),
        });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("hyper_tangent"),
                timestamp_writes: None,
            });
            pass.set_pipeline(self.ctx.pipelines.get(Kernel::HyperTangent).0);
            pass.set_bind_group(0, bind, &[]);
            pass.dispatch_workgroups(self.groups.0, self.groups.1, 1);
        }
        let bytes = 8 * x.len() as u64;
        enc.copy_buffer_to_buffer(&self.y, 0, &self.staging, 0, bytes);
        queue.submit([enc.finish()]);
        let slice = self.staging.slice(..bytes);
        // Device loss is fatal here as in the rest of the GPU backend.
        slice.map_async(wgpu::MapMode::Read, |r| {
            r.expect("hyper tangent: mapping the read-back buffer failed")
        });
        dev.poll(wgpu::PollType::wait_indefinitely())
            .expect("hyper tangent: device lost while waiting");
        {
            let view = slice
                .get_mapped_range()
                .expect("hyper tangent: reading the mapped read-back buffer failed");
            y.copy_from_slice(bytemuck::cast_slice(&view));
        }
        self.staging.unmap();
    }
}

/// `K_T` of one body at one linearisation point, inside cells on the device.
pub struct GpuTangent<'a> {
    body: &'a GpuHyperBody,
    tangent: TangentOperator<'a>,
    bind: wgpu::BindGroup,
}

impl GpuTangent<'_> {
    /// `y = hyper_tangent(x)`: the kernel alone, the inside cells' part
    /// (what its CPU mirror computes).
    pub fn apply_inside(&self, x: &[f64], y: &mut [f64]) {
        self.body.run_kernel(&self.bind, x, y);
    }
}

impl LinearOperator for GpuTangent<'_> {
    fn nrows(&self) -> usize {
        self.tangent.nrows()
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.apply_inside(x, y);
        self.tangent.add_cut_cells(x, y);
    }

    fn diagonal(&self) -> Vec<f64> {
        self.tangent.diagonal()
    }
}
