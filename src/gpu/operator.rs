//! [`GpuOperator`]: an [`ElasticOperator`] resident on the device — the index
//! maps (active ↔ lattice node, cell slots), the shared inside matrix and the
//! cut cells' own matrices — applied by `apply.wgsl`.
//!
//! # Own matrices over several bindings
//! One storage binding holds at most `max_storage_buffer_binding_size` bytes
//! (128 MiB on lavapipe); the own matrices (`ne² · 8` bytes per cut cell,
//! 4608 B for Q1) can exceed it at fine levels. They are uploaded in chunks
//! of whole matrices, one buffer each, and `apply` runs once per chunk: the
//! first pass overwrites `y` with the inside cells and chunk 0, later passes add
//! their chunk. Each invocation still writes only its own node: no atomics.

use crate::backend::LinearOperator;
use crate::fem::operator::ElasticOperator;

use super::backend::GpuBackend;
use super::kernels::{grid_2d, ApplyParams, Kernel, APPLY_WG};

/// One buffer of own matrices: slots `[lo, hi)`.
struct OwnChunk {
    buf: wgpu::Buffer,
    lo: u32,
    hi: u32,
}

/// The elasticity operator on the device; borrows the host operator for its
/// diagonal and its shape.
pub struct GpuOperator<'o> {
    host: &'o ElasticOperator,
    active_to_node: wgpu::Buffer,
    node_to_active: wgpu::Buffer,
    slots: wgpu::Buffer,
    k_inside: wgpu::Buffer,
    own: Vec<OwnChunk>,
    params: ApplyParams,
}

impl<'o> GpuOperator<'o> {
    /// Uploads `op` to the device of `be`.
    pub fn new(be: &GpuBackend, op: &'o ElasticOperator) -> Self {
        Self::with_chunk_entries(be, op, be.context().max_binding_entries())
    }

    /// Like [`GpuOperator::new`] with own-matrix chunks of at most
    /// `max_entries` entries (tests force several chunks with it).
    pub fn with_chunk_entries(be: &GpuBackend, op: &'o ElasticOperator, max_entries: u64) -> Self {
        let ne = op.dofs_per_cell();
        let ne2 = ne * ne;
        let per_chunk = ((max_entries as usize) / ne2).max(1);
        let own_all = op.own_matrices();
        let count = own_all.len() / ne2;
        let mut own = Vec::new();
        let mut lo = 0;
        while lo < count || own.is_empty() {
            let hi = (lo + per_chunk).min(count);
            let bytes = be.to_bytes(&own_all[lo * ne2..hi * ne2]);
            own.push(OwnChunk {
                buf: be.buffer_init("own matrices", &bytes),
                lo: lo as u32,
                hi: hi as u32,
            });
            lo = hi.max(lo + 1);
        }
        let u32s = |label: &str, v: &[u32]| be.buffer_init(label, bytemuck::cast_slice(v));
        let n = op.grid.n;
        let params = ApplyParams {
            n_active: op.dofs.num_active() as u32,
            stride: 0,
            ncx: n[0] as u32,
            ncy: n[1] as u32,
            ncz: n[2] as u32,
            degree: op.dofs.order.degree() as u32,
            ne: ne as u32,
            own_lo: 0,
            own_hi: 0,
            first: 1,
            pad0: 0,
            pad1: 0,
        };
        GpuOperator {
            host: op,
            active_to_node: u32s("active_to_node", &op.dofs.active_to_node),
            node_to_active: u32s("node_to_active", &op.dofs.node_to_active),
            slots: u32s("slots", op.cell_slots()),
            k_inside: be.buffer_init("k_inside", &be.to_bytes(op.inside_matrix())),
            own,
            params,
        }
    }

    /// Rows (= dofs).
    pub fn nrows(&self) -> usize {
        self.host.nrows()
    }

    /// Number of own-matrix chunks (= `apply` passes).
    pub fn chunks(&self) -> usize {
        self.own.len()
    }

    /// The host operator this was uploaded from.
    pub fn host(&self) -> &'o ElasticOperator {
        self.host
    }

    /// The diagonal, computed by the host operator.
    pub fn host_diagonal(&self) -> Vec<f64> {
        self.host.diagonal()
    }

    /// Records `y = A x`: one `apply` pass per own-matrix chunk.
    pub(super) fn record_apply(
        &self,
        be: &GpuBackend,
        enc: &mut wgpu::CommandEncoder,
        x: &wgpu::Buffer,
        y: &wgpu::Buffer,
    ) {
        let n = self.params.n_active;
        if n == 0 {
            return;
        }
        let max_dim = be.context().limits.max_compute_workgroups_per_dimension;
        let (gx, gy, stride) = grid_2d(n, APPLY_WG, max_dim);
        for (i, chunk) in self.own.iter().enumerate() {
            let p = ApplyParams {
                stride,
                own_lo: chunk.lo,
                own_hi: chunk.hi,
                first: u32::from(i == 0),
                ..self.params
            };
            let bufs = [
                &self.active_to_node,
                &self.node_to_active,
                &self.slots,
                &self.k_inside,
                &chunk.buf,
                x,
                y,
            ];
            be.record(enc, Kernel::Apply, bytemuck::bytes_of(&p), &bufs, (gx, gy));
        }
    }
}
