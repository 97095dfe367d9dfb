//! [`GpuOperator`]: an [`ElasticOperator`] resident on the device. A Q1
//! operator that fits single bindings runs on its plan ([`Q1Device`]: the
//! interior stencil and the cut cells' factored forms); anything else (Q2, arrays
//! beyond one binding) on the node-centred gather of `apply.wgsl` over the
//! index maps (active ↔ lattice node, cell slots), the shared inside matrix
//! and the cut cells' own matrices, described below.
//!
//! # Arrays over several bindings
//! One storage binding holds at most `max_storage_buffer_binding_size` bytes
//! (128 MiB on lavapipe).
//! - The own matrices (`ne² · 8` bytes per cut cell, 4608 B for Q1) are
//!   uploaded in chunks of whole matrices, one buffer each; `apply` runs once
//!   per chunk: the first pass overwrites `y` with the inside cells and its
//!   chunk, later passes add theirs.
//! - The vectors and index maps are bound in apply windows
//!   ([`super::windows::apply_windows`]): the active nodes a window writes,
//!   with the cell layers and nodes (a halo of one cell layer) it reads. A
//!   window runs the passes of the chunks its cells refer to.
//!
//! Each invocation still writes only its own node: no atomics, and split or
//! not, every entry of `y` is summed in the same order.

use crate::backend::LinearOperator;
use crate::error::Result;
use crate::fem::operator::ElasticOperator;

use super::backend::GpuBackend;
use super::kernels::{grid_2d, ApplyParams, Kernel, APPLY_WG};
use super::q1_operator::Q1Device;
use super::record::{whole, window, Prepared};
use super::windows::{apply_windows, own_slots, ApplyWindow, Lattice};

/// One buffer of own matrices: slots `[lo, hi)`.
struct OwnChunk {
    buf: wgpu::Buffer,
    lo: u32,
    hi: u32,
}

/// An apply window and the own-matrix chunks its cells refer to (at least
/// one: the first pass also adds the inside cells).
struct Window {
    ranges: ApplyWindow,
    chunks: Vec<usize>,
}

/// The elasticity operator on the device; borrows the host operator for its
/// diagonal and its shape.
pub struct GpuOperator<'o> {
    host: &'o ElasticOperator,
    path: Path,
}

/// How the device applies the operator.
enum Path {
    /// The Q1 plan ([`Q1Device`]).
    Q1(Q1Device),
    /// The node-centred gather of `apply.wgsl`, any order, any size.
    Generic(Generic),
}

/// The data of the node-centred gather.
struct Generic {
    active_to_node: wgpu::Buffer,
    node_to_active: wgpu::Buffer,
    slots: wgpu::Buffer,
    k_inside: wgpu::Buffer,
    own: Vec<OwnChunk>,
    windows: Vec<Window>,
    params: ApplyParams,
}

/// The own matrices `own` (`ne2` entries each, borrowed or owned) in chunks
/// of at most `max_entries` entries (at least one matrix, at least one chunk).
fn own_chunks(
    be: &GpuBackend,
    own: impl AsRef<[f64]>,
    ne2: usize,
    max_entries: u64,
) -> Vec<OwnChunk> {
    let own = own.as_ref();
    let per_chunk = ((max_entries as usize) / ne2).max(1);
    let count = own.len() / ne2;
    let mut chunks = Vec::new();
    let mut lo = 0;
    while lo < count || chunks.is_empty() {
        let hi = (lo + per_chunk).min(count);
        let bytes = be.to_bytes(&own[lo * ne2..hi * ne2]);
        chunks.push(OwnChunk {
            buf: be.buffer_init("own matrices", &bytes),
            lo: lo as u32,
            hi: hi as u32,
        });
        lo = hi.max(lo + 1);
    }
    chunks
}

impl<'o> GpuOperator<'o> {
    /// Uploads `op` to the device of `be`: the Q1 plan where it applies
    /// ([`Q1Device::new`]), else the node-centred gather.
    /// [`crate::error::Error::DeviceTooSmall`] when an array exceeds the
    /// largest buffer or an apply window's halo exceeds one binding.
    pub fn new(be: &GpuBackend, op: &'o ElasticOperator) -> Result<Self> {
        if let Some(q1) = Q1Device::new(be, op) {
            return Ok(GpuOperator {
                host: op,
                path: Path::Q1(q1),
            });
        }
        Self::new_gather(be, op)
    }

    /// The node-centred gather, whatever the order (the bench compares it
    /// with the Q1 plan).
    pub fn new_gather(be: &GpuBackend, op: &'o ElasticOperator) -> Result<Self> {
        let entries = be.bindings().max_bytes / be.precision().bytes();
        Self::with_chunk_entries(be, op, entries)
    }

    /// The node-centred gather, with own-matrix chunks of at most
    /// `max_entries` entries (tests force it, and several chunks, with it).
    pub fn with_chunk_entries(
        be: &GpuBackend,
        op: &'o ElasticOperator,
        max_entries: u64,
    ) -> Result<Self> {
        let ctx = be.context();
        let ne = op.dofs_per_cell();
        let (a2n, n2a) = (&op.dofs.active_to_node, &op.dofs.node_to_active);
        ctx.check_vector_len(op.nrows())?;
        ctx.check_buffer("the lattice node map", 4 * n2a.len() as u64)?;
        let n = op.grid.n;
        let lattice = Lattice {
            cells: n.map(|c| c as u32),
            degree: op.dofs.order.degree() as u32,
        };
        let ranges = apply_windows(a2n, lattice, be.precision().bytes(), be.bindings())?;
        let own = own_chunks(be, op.own_matrices(), ne * ne, max_entries);
        let own_count = own.last().map_or(0, |c| c.hi);
        let windows = ranges
            .into_iter()
            .map(|ranges| {
                let used = own_slots(op.cell_slots(), &ranges.cells, own_count);
                let mut chunks: Vec<usize> = (0..own.len())
                    .filter(|&c| own[c].lo < used.end && used.start < own[c].hi)
                    .collect();
                if chunks.is_empty() {
                    chunks.push(0);
                }
                Window { ranges, chunks }
            })
            .collect();
        let u32s = |label: &str, v: &[u32]| be.buffer_init(label, bytemuck::cast_slice(v));
        let params = ApplyParams {
            ncx: n[0] as u32,
            ncy: n[1] as u32,
            ncz: n[2] as u32,
            degree: lattice.degree,
            ne: ne as u32,
            ..Default::default()
        };
        let generic = Generic {
            active_to_node: u32s("active_to_node", a2n),
            node_to_active: u32s("node_to_active", n2a),
            slots: u32s("slots", op.cell_slots()),
            k_inside: be.buffer_init("k_inside", &be.to_bytes(op.inside_matrix())),
            own,
            windows,
            params,
        };
        Ok(GpuOperator {
            host: op,
            path: Path::Generic(generic),
        })
    }

    /// Rows (= dofs).
    pub fn nrows(&self) -> usize {
        self.host.nrows()
    }

    /// Number of own-matrix chunks of the gather (0 on the Q1 plan).
    pub fn chunks(&self) -> usize {
        match &self.path {
            Path::Generic(g) => g.own.len(),
            Path::Q1(_) => 0,
        }
    }

    /// Number of apply windows of the gather (1 on the Q1 plan).
    pub fn windows(&self) -> usize {
        match &self.path {
            Path::Generic(g) => g.windows.len(),
            Path::Q1(_) => 1,
        }
    }

    /// The Q1 plan, where the operator runs on it.
    pub fn q1(&self) -> Option<&Q1Device> {
        match &self.path {
            Path::Q1(q1) => Some(q1),
            Path::Generic(_) => None,
        }
    }

    /// The host operator this was uploaded from.
    pub fn host(&self) -> &'o ElasticOperator {
        self.host
    }

    /// The diagonal, computed by the host operator.
    pub fn host_diagonal(&self) -> Vec<f64> {
        self.host.diagonal()
    }

    /// Records `y = A x`: the Q1 plan's two kernels, or per window one
    /// `apply` pass per own-matrix chunk its cells refer to.
    pub(super) fn record_apply(
        &self,
        be: &GpuBackend,
        enc: &mut wgpu::CommandEncoder,
        x: &wgpu::Buffer,
        y: &wgpu::Buffer,
    ) {
        for p in self.prepare_apply(be, x, y) {
            be.record_prepared(enc, &p);
        }
    }

    /// [`GpuOperator::record_apply`]'s dispatches, prepared.
    pub(super) fn prepare_apply(
        &self,
        be: &GpuBackend,
        x: &wgpu::Buffer,
        y: &wgpu::Buffer,
    ) -> Vec<Prepared> {
        match &self.path {
            Path::Q1(q1) => q1.prepare(be, x, y).into(),
            Path::Generic(g) => g.prepare(be, x, y),
        }
    }
}

impl Generic {
    fn prepare(&self, be: &GpuBackend, x: &wgpu::Buffer, y: &wgpu::Buffer) -> Vec<Prepared> {
        let mut out = Vec::new();
        let max_dim = be.context().limits.max_compute_workgroups_per_dimension;
        let bytes = be.precision().bytes();
        let u64s = |r: &std::ops::Range<u32>, k: u64| k * r.start as u64..k * r.end as u64;
        for Window { ranges: w, chunks } in &self.windows {
            let nodes = w.nodes.end - w.nodes.start;
            let (gx, gy, stride) = grid_2d(nodes, APPLY_WG, max_dim);
            for (i, &c) in chunks.iter().enumerate() {
                let chunk = &self.own[c];
                let p = ApplyParams {
                    n_active: nodes,
                    stride,
                    own_lo: chunk.lo,
                    own_hi: chunk.hi,
                    first: u32::from(i == 0),
                    x_base: w.x.start,
                    lattice_base: w.lattice.start,
                    cell_base: w.cells.start,
                    ..self.params
                };
                let binds = [
                    window(&self.active_to_node, u64s(&w.nodes, 1), 4),
                    window(&self.node_to_active, u64s(&w.lattice, 1), 4),
                    window(&self.slots, u64s(&w.cells, 1), 4),
                    whole(&self.k_inside),
                    whole(&chunk.buf),
                    window(x, u64s(&w.x, 3), bytes),
                    window(y, u64s(&w.nodes, 3), bytes),
                ];
                let bytes = bytemuck::bytes_of(&p);
                out.push(be.prepare(Kernel::Apply, bytes, &binds, (gx, gy)));
            }
        }
        out
    }
}
