//! [`Q1Device`]: a Q1 operator's plan on the device, the GPU twin of the
//! CPU's fast apply ([`crate::fem::fast_apply`], whose plan it uploads):
//! 1. `q1_cells`: `z_c = K_c x_c` for the cut cells (from their factored
//!    forms, [`crate::fem::q1_forms`], 114 numbers stored entry-major so a
//!    warp's reads are contiguous; stabilisation included, partial-mask
//!    penalties beside them) and the rim cells (the whole cell's form, shared,
//!    stored after them);
//! 2. `q1_nodes`: the interior nodes in segments of up to [`SEG`] nodes of
//!    one run, the 27-point stencil (coefficients in a uniform, terms
//!    unrolled) over the segment's 9 neighbour rows of `x`; the boundary
//!    nodes the sum of their cells' triples of `z`.
//!
//! Two dispatches per apply, no atomics, no per-node index lookups in the
//! interior. The plan needs every array in one storage binding; otherwise
//! [`Q1Device::new`] declines and the operator runs on the node-centred
//! gather ([`super::operator`]).

use rayon::prelude::*;
use wgpu::util::DeviceExt;

use crate::backend::LinearOperator;
use crate::fem::operator::ElasticOperator;
use crate::fem::stencil::{Run, Stencil};

use super::backend::{GpuBackend, GpuVector};
use super::kernels::{grid_2d, Kernel, Q1Params, APPLY_WG};
use super::q1_terms::{NO_PARTIAL, PARTIAL_LEN, SEG, SEGMENT_WORDS, STENCIL_LEN};
use super::record::{whole, Prepared};
use crate::fem::q1_forms::FORM_LEN;

/// One of the plan's two kernels (the bench times them apart).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Q1Kernel {
    /// `q1_cells`: the cut and rim cells' products into `z`.
    Cells,
    /// `q1_nodes`: the interior stencil and the boundary gather into `y`.
    Nodes,
}

impl GpuBackend {
    /// Runs one kernel of `q1`'s apply, submitted (`Nodes` reads the `z`
    /// that the last `Cells` left).
    pub fn apply_q1_kernel(&self, q1: &Q1Device, kernel: Q1Kernel, x: &GpuVector, y: &GpuVector) {
        let mut enc = self.encoder();
        q1.record_kernel(self, &mut enc, kernel, &x.buf, &y.buf, None);
        self.submit(enc);
    }
}

/// A Q1 operator's plan on the device.
pub struct Q1Device {
    stencil: wgpu::Buffer,
    segments: wgpu::Buffer,
    boundary: wgpu::Buffer,
    links: wgpu::Buffer,
    cell_nodes: wgpu::Buffer,
    partial_of: wgpu::Buffer,
    k_cells: wgpu::Buffer,
    z: wgpu::Buffer,
    params: Q1Params,
    num_active: usize,
    /// Cut cells with a partial-mask penalty.
    num_partial: usize,
}

/// The runs cut into segments of at most [`SEG`] nodes, [`SEGMENT_WORDS`]
/// words each: start, length, the 9 row bases of its first node, padding.
pub fn segments(runs: &[Run]) -> Vec<u32> {
    let mut out = Vec::new();
    for run in runs {
        let mut t0 = 0;
        while t0 < run.len {
            let len = (run.len - t0).min(SEG as u32);
            out.extend([run.start + t0, len]);
            out.extend(run.bases.map(|b| b + t0));
            out.push(0);
            t0 += len;
        }
    }
    out
}

/// `q1_cells`' cell data: the cut cells' factored forms stored entry-major
/// (entry `k` of slot `s` at `k · count + s`), the whole cell's form, λ and
/// μ, then the partial-mask penalties' masses ([`PARTIAL_LEN`] numbers per
/// cell that has one); and per cut cell the index of its penalty, or
/// [`NO_PARTIAL`]. `None` where the cut cells have no factored forms (Q2).
pub fn cell_forms(op: &ElasticOperator) -> Option<(Vec<f64>, Vec<u32>)> {
    let (forms, partial) = op.q1_cut_data()?;
    let (_, _, inside) = op.fast_apply().q1()?;
    let count = op.own_cells().len();
    let mut out = vec![0.0; FORM_LEN * count];
    let per_slot: Vec<[f64; FORM_LEN]> =
        (0..count).into_par_iter().map(|s| forms.form(s)).collect();
    out.par_chunks_mut(count.max(1))
        .enumerate()
        .for_each(|(k, row)| {
            for (s, v) in row.iter_mut().enumerate() {
                *v = per_slot[s][k];
            }
        });
    out.extend(inside.form(0));
    let (lambda, mu) = forms.lame();
    out.extend([lambda, mu]);
    let mut partial_of = vec![NO_PARTIAL; count.max(1)];
    let mut n_partial = 0;
    for (s, of) in partial_of.iter_mut().enumerate().take(count) {
        let Some(masses) = partial.masses_of(s) else {
            continue;
        };
        for m in masses {
            for a in 0..8 {
                out.extend((a..8).map(|b| m[8 * a + b]));
            }
        }
        *of = n_partial;
        n_partial += 1;
    }
    Some((out, partial_of))
}

/// The stencil values in the uniform's order (`81 · 3`, zero-padded to
/// [`STENCIL_LEN`]).
fn stencil_values(stencil: &Stencil) -> Vec<f64> {
    let mut v: Vec<f64> = stencil.values().iter().flatten().copied().collect();
    v.resize(STENCIL_LEN, 0.0);
    v
}

/// What the plan uploads, on the host, in binding order (the tests hand it
/// to the mirrors).
pub struct Q1Arrays {
    pub params: Q1Params,
    pub stencil: Vec<f64>,
    pub segments: Vec<u32>,
    pub boundary: Vec<u32>,
    pub links: Vec<u32>,
    pub cell_nodes: Vec<u32>,
    /// [`cell_forms`]: the forms, λ and μ, the partial-mask penalties.
    pub k_cells: Vec<f64>,
    /// [`cell_forms`]: per cut cell, its partial-mask penalty's index.
    pub partial_of: Vec<u32>,
}

impl Q1Arrays {
    /// The arrays of `op`'s plan, or `None` where it is not Q1's.
    pub fn new(op: &ElasticOperator) -> Option<Q1Arrays> {
        let plan = op.fast_apply();
        let (stencil, runs, _) = plan.q1()?;
        let (k_cells, partial_of) = cell_forms(op)?;
        let cell_nodes = plan.cell_nodes().to_vec();
        let segments = segments(runs);
        let params = Q1Params {
            n_segments: (segments.len() / SEGMENT_WORDS) as u32,
            n_boundary: plan.boundary().len() as u32,
            n_cut: op.own_cells().len() as u32,
            n_cells: (cell_nodes.len() / 8) as u32,
            ..Default::default()
        };
        Some(Q1Arrays {
            params,
            stencil: stencil_values(stencil),
            segments,
            boundary: plan.boundary().to_vec(),
            links: plan.links().iter().flatten().copied().collect(),
            cell_nodes,
            k_cells,
            partial_of,
        })
    }

    /// Entries of `z`: 24 per cell and the zero triple.
    pub fn z_len(&self) -> usize {
        24 * self.params.n_cells as usize + 3
    }
}

impl Q1Device {
    /// The plan of `op` on the device of `be`, or `None` where it does not
    /// apply: not Q1 (no fast plan), or an array (the vectors included)
    /// larger than one storage binding.
    pub fn new(be: &GpuBackend, op: &ElasticOperator) -> Option<Q1Device> {
        let a = Q1Arrays::new(op)?;
        let bytes = be.precision().bytes();
        let sizes = [
            op.nrows() as u64 * bytes,
            a.z_len() as u64 * bytes,
            a.k_cells.len() as u64 * bytes,
            4 * a.segments.len() as u64,
            4 * a.links.len() as u64,
            4 * a.cell_nodes.len() as u64,
            4 * a.partial_of.len() as u64,
            4 * a.boundary.len() as u64,
        ];
        if sizes.iter().any(|&s| s > be.bindings().max_bytes) {
            return None;
        }
        let u32s = |label: &str, v: &[u32]| be.buffer_init(label, bytemuck::cast_slice(v));
        let stencil = be
            .context()
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("stencil"),
                contents: &be.to_bytes(&a.stencil),
                usage: wgpu::BufferUsages::UNIFORM,
            });
        Some(Q1Device {
            stencil,
            segments: u32s("segments", &a.segments),
            boundary: u32s("boundary", &a.boundary),
            links: u32s("links", &a.links),
            cell_nodes: u32s("cell nodes", &a.cell_nodes),
            partial_of: u32s("partial penalties", &a.partial_of),
            k_cells: be.buffer_init("cell forms", &be.to_bytes(&a.k_cells)),
            z: be.buffer_init("z", &be.to_bytes(&vec![0.0; a.z_len()])),
            params: a.params,
            num_active: op.dofs.num_active(),
            num_partial: a.partial_of.iter().filter(|&&p| p != NO_PARTIAL).count(),
        })
    }

    /// The counts: segments, boundary nodes, cut cells, cut + rim cells.
    pub fn params(&self) -> Q1Params {
        self.params
    }

    /// Bytes one apply moves to and from device memory, modelled: `x` read
    /// and `y` written once per active node (the re-reads of a neighbour
    /// row by nearby segments and the cells' gathers of `x` hit the
    /// caches), the segment table, the cut cells' forms and penalty
    /// indices, the partial-mask penalties, each cell's node indices and
    /// product `z` (written, then read by the boundary nodes), and the
    /// boundary nodes' indices and links.
    pub fn modelled_traffic(&self, bytes: u64) -> u64 {
        let p = &self.params;
        let vectors = 2 * 3 * self.num_active as u64 * bytes;
        let segments = 4 * SEGMENT_WORDS as u64 * p.n_segments as u64;
        let cut = (FORM_LEN as u64 * bytes + 4) * p.n_cut as u64
            + PARTIAL_LEN as u64 * bytes * self.num_partial as u64;
        let cells = (32 + 2 * 24 * bytes) * p.n_cells as u64;
        let boundary = (4 + 32) * p.n_boundary as u64;
        vectors + segments + cut + cells + boundary
    }

    /// `y = A x`'s dispatches, prepared: `q1_cells`, then `q1_nodes`.
    pub(super) fn prepare(
        &self,
        be: &GpuBackend,
        x: &wgpu::Buffer,
        y: &wgpu::Buffer,
    ) -> [Prepared; 2] {
        [
            self.prepare_kernel(be, Q1Kernel::Cells, x, y, None),
            self.prepare_kernel(be, Q1Kernel::Nodes, x, y, None),
        ]
    }

    /// Workgroups of `q1_nodes`: one per segment, then one per [`SEG`]
    /// boundary nodes (the number of partials of [`Q1Device::record_dot`]).
    pub fn node_groups(&self) -> u32 {
        self.params.n_segments + self.params.n_boundary.div_ceil(SEG as u32)
    }

    /// The dispatches of `y = A x` as [`Q1Device::prepare`] makes them,
    /// prepared, `q1_nodes`' dot variant writing `x · y`'s per-workgroup sums
    /// to `partials[..node_groups()]` (CG's `p · Ap`).
    pub(super) fn prepare_dot(
        &self,
        be: &GpuBackend,
        x: &wgpu::Buffer,
        y: &wgpu::Buffer,
        partials: &wgpu::Buffer,
    ) -> [Prepared; 2] {
        [
            self.prepare_kernel(be, Q1Kernel::Cells, x, y, None),
            self.prepare_kernel(be, Q1Kernel::Nodes, x, y, Some(partials)),
        ]
    }

    /// Records one of the plan's kernels; `q1_nodes` writes its partials of
    /// `x · y` to `dot` where given.
    fn record_kernel(
        &self,
        be: &GpuBackend,
        enc: &mut wgpu::CommandEncoder,
        kernel: Q1Kernel,
        x: &wgpu::Buffer,
        y: &wgpu::Buffer,
        dot: Option<&wgpu::Buffer>,
    ) {
        let prepared = self.prepare_kernel(be, kernel, x, y, dot);
        be.record_prepared(enc, &prepared);
    }

    /// One of the plan's kernels, prepared ([`Q1Device::record_kernel`]).
    fn prepare_kernel(
        &self,
        be: &GpuBackend,
        kernel: Q1Kernel,
        x: &wgpu::Buffer,
        y: &wgpu::Buffer,
        dot: Option<&wgpu::Buffer>,
    ) -> Prepared {
        let p = self.params;
        // The plain `q1_nodes` declares the partials but does not write them.
        let spare = be.partials(1);
        let (id, binds, (gx, gy, stride)) = match kernel {
            Q1Kernel::Cells => (
                Kernel::Q1Cells,
                vec![
                    whole(&self.cell_nodes),
                    whole(&self.partial_of),
                    whole(&self.k_cells),
                    whole(x),
                    whole(&self.z),
                ],
                grid_2d(p.n_cells, APPLY_WG, be.max_dim()),
            ),
            Q1Kernel::Nodes => {
                let mut binds = vec![
                    whole(&self.stencil),
                    whole(&self.segments),
                    whole(&self.boundary),
                    whole(&self.links),
                    whole(&self.z),
                    whole(x),
                    whole(y),
                ];
                binds.push(whole(dot.unwrap_or(&spare)));
                let id = match dot {
                    Some(_) => Kernel::Q1NodesDot,
                    None => Kernel::Q1Nodes,
                };
                (id, binds, grid_2d(self.node_groups(), 1, be.max_dim()))
            }
        };
        let prm = Q1Params { stride, ..p };
        be.prepare(id, bytemuck::bytes_of(&prm), &binds, (gx, gy))
    }
}
