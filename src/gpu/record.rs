//! How the backend records one kernel: a bind group (params at binding 0,
//! then the buffers, each whole or as a window, [`super::windows`]) and a
//! dispatch, in 2D past `max_compute_workgroups_per_dimension`; element-wise
//! kernels and reductions loop over the vector windows.

use std::num::NonZeroU64;
use std::ops::Range;

use wgpu::util::DeviceExt;

use super::backend::{storage_usage, GpuBackend};
use super::kernels::{grid_2d, reduction_groups, DirectionParams, Kernel, RedParams};
use super::kernels::{ScalParams, UpdateParams};
use super::kernels::{VecParams, WG};
use super::windows::{vector_windows, REDUCTION_CHUNK};

/// A whole buffer as a binding.
pub(super) fn whole(b: &wgpu::Buffer) -> wgpu::BindingResource<'_> {
    b.as_entire_binding()
}

/// Entries `r` of `b` (entries of `bytes` bytes) as a binding.
pub(super) fn window(b: &wgpu::Buffer, r: Range<u64>, bytes: u64) -> wgpu::BindingResource<'_> {
    wgpu::BindingResource::Buffer(wgpu::BufferBinding {
        buffer: b,
        offset: r.start * bytes,
        size: NonZeroU64::new((r.end - r.start).max(1) * bytes),
    })
}

/// A recorded step that can be recorded again: a prepared dispatch, or a
/// buffer cleared ([`GpuBackend::begin_capture`]).
pub(super) enum Step {
    Dispatch(Prepared),
    Clear(wgpu::Buffer),
}

/// A dispatch made once and recorded many times ([`GpuBackend::prepare`]).
#[derive(Clone)]
pub(super) struct Prepared {
    kernel: Kernel,
    bind: wgpu::BindGroup,
    groups: (u32, u32),
}

impl GpuBackend {
    /// Records `kernel` with `params` at binding 0 and `binds` at 1, 2, …
    /// over `groups` workgroups.
    pub(super) fn record(
        &self,
        enc: &mut wgpu::CommandEncoder,
        kernel: Kernel,
        params: &[u8],
        binds: &[wgpu::BindingResource<'_>],
        groups: (u32, u32),
    ) {
        let prepared = self.prepare(kernel, params, binds, groups);
        self.record_prepared(enc, &prepared);
    }

    /// `kernel`'s dispatch made ready to record any number of times: its
    /// params in a uniform buffer and its bind group.
    pub(super) fn prepare(
        &self,
        kernel: Kernel,
        params: &[u8],
        binds: &[wgpu::BindingResource<'_>],
        groups: (u32, u32),
    ) -> Prepared {
        let dev = &self.ctx.device;
        let uniform = dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("params"),
            contents: params,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let (_, layout) = self.ctx.pipelines.get(kernel);
        let mut entries = vec![wgpu::BindGroupEntry {
            binding: 0,
            resource: uniform.as_entire_binding(),
        }];
        for (i, b) in binds.iter().enumerate() {
            entries.push(wgpu::BindGroupEntry {
                binding: i as u32 + 1,
                resource: b.clone(),
            });
        }
        let bind = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(kernel.name()),
            layout,
            entries: &entries,
        });
        Prepared {
            kernel,
            bind,
            groups,
        }
    }

    /// Keeps every step recorded from now until [`GpuBackend::end_capture`]
    /// (a Krylov iteration or a V-cycle, replayed by the next ones).
    pub(super) fn begin_capture(&self) {
        *self.capture.borrow_mut() = Some(Vec::new());
    }

    /// The steps recorded since [`GpuBackend::begin_capture`].
    pub(super) fn end_capture(&self) -> Vec<Step> {
        self.capture.take().unwrap_or_default()
    }

    /// Records captured steps again.
    pub(super) fn replay(&self, enc: &mut wgpu::CommandEncoder, steps: &[Step]) {
        for step in steps {
            match step {
                Step::Dispatch(p) => self.record_prepared(enc, p),
                Step::Clear(b) => self.record_clear(enc, b),
            }
        }
    }

    /// Records zeroing `buf` (and keeps it while a capture is on).
    pub(super) fn record_clear(&self, enc: &mut wgpu::CommandEncoder, buf: &wgpu::Buffer) {
        enc.clear_buffer(buf, 0, None);
        if let Some(capture) = self.capture.borrow_mut().as_mut() {
            capture.push(Step::Clear(buf.clone()));
        }
    }

    /// Records a prepared dispatch (and keeps it while a capture is on).
    pub(super) fn record_prepared(&self, enc: &mut wgpu::CommandEncoder, p: &Prepared) {
        self.dispatches.set(self.dispatches.get() + 1);
        if let Some(capture) = self.capture.borrow_mut().as_mut() {
            capture.push(Step::Dispatch(p.clone()));
        }
        let (pipeline, _) = self.ctx.pipelines.get(p.kernel);
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(p.kernel.name()),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &p.bind, &[]);
        pass.dispatch_workgroups(p.groups.0, p.groups.1, 1);
    }

    /// Runs a one-invocation kernel (`scalar_ratio`, `krylov_check`) on the
    /// device scalars, submitted.
    pub fn scalar_kernel(&self, kernel: Kernel, p: &ScalParams) {
        let mut enc = self.encoder();
        self.record_scalar(&mut enc, kernel, p);
        self.submit(enc);
    }

    /// Records a one-invocation kernel on the device scalars.
    pub(super) fn record_scalar(
        &self,
        enc: &mut wgpu::CommandEncoder,
        kernel: Kernel,
        p: &ScalParams,
    ) {
        let binds = [whole(&self.scal)];
        self.record(enc, kernel, bytemuck::bytes_of(p), &binds, (1, 1));
    }

    pub(super) fn max_dim(&self) -> u32 {
        self.ctx.limits.max_compute_workgroups_per_dimension
    }

    /// Entries per vector window.
    pub(super) fn vector_window(&self) -> usize {
        self.bindings.vector_window(self.ctx.precision.bytes())
    }

    /// `bufs` bound over the entries `r`: the vectors as windows, the device
    /// scalars (first, when `kernel` reads them) whole.
    fn vector_binds<'b>(
        &self,
        kernel: Kernel,
        bufs: &[&'b wgpu::Buffer],
        r: &Range<usize>,
    ) -> Vec<wgpu::BindingResource<'b>> {
        let bytes = self.ctx.precision.bytes();
        let entries = r.start as u64..r.end as u64;
        bufs.iter()
            .enumerate()
            .map(|(i, b)| match i == 0 && kernel.scalars_first() {
                true => whole(b),
                false => window(b, entries.clone(), bytes),
            })
            .collect()
    }

    /// Records an element-wise kernel over `n` entries with scalar slots
    /// `ia`, `ib`, window by window (nothing for `n = 0`).
    pub(super) fn record_vec(
        &self,
        enc: &mut wgpu::CommandEncoder,
        kernel: Kernel,
        n: usize,
        slots: (u32, u32),
        bufs: &[&wgpu::Buffer],
    ) {
        for p in self.prepare_vec(kernel, n, slots, bufs) {
            self.record_prepared(enc, &p);
        }
    }

    /// [`GpuBackend::record_vec`]'s dispatches (one per window), prepared.
    pub(super) fn prepare_vec(
        &self,
        kernel: Kernel,
        n: usize,
        (ia, ib): (u32, u32),
        bufs: &[&wgpu::Buffer],
    ) -> Vec<Prepared> {
        let mut out = Vec::new();
        for r in vector_windows(n, self.vector_window()) {
            let len = (r.end - r.start) as u32;
            let (x, y, stride) = grid_2d(len, WG, self.max_dim());
            let p = VecParams {
                n: len,
                ia,
                ib,
                stride,
            };
            let binds = self.vector_binds(kernel, bufs, &r);
            out.push(self.prepare(kernel, bytemuck::bytes_of(&p), &binds, (x, y)));
        }
        out
    }

    /// Records `dot` (`vecs = [x, y]`) or `dot2` (`[x, y, z]`) over `n`
    /// entries, window by window, and the second pass into slots
    /// `out..out + comps`.
    pub(super) fn record_dot(
        &self,
        enc: &mut wgpu::CommandEncoder,
        n: usize,
        vecs: &[&wgpu::Buffer],
        out: u32,
    ) {
        let comps = vecs.len() as u32 - 1;
        let total = reduction_groups(n as u32);
        if total == 0 {
            self.write_slots(out, &vec![0.0; comps as usize]);
            return;
        }
        let partials = self.partials(total * comps);
        let kernel = if comps == 1 {
            Kernel::Dot
        } else {
            Kernel::Dot2
        };
        for r in vector_windows(n, self.vector_window()) {
            let groups = reduction_groups((r.end - r.start) as u32);
            let (x, y, _) = grid_2d(groups, 1, self.max_dim());
            let first = RedParams {
                n: (r.end - r.start) as u32,
                out,
                groups,
                comps,
                base: (r.start as u64 / REDUCTION_CHUNK) as u32,
                total,
                ..Default::default()
            };
            let mut binds = self.vector_binds(kernel, vecs, &r);
            binds.push(whole(&partials));
            self.record(enc, kernel, bytemuck::bytes_of(&first), &binds, (x, y));
        }
        self.record_reduce(enc, &partials, total, comps, out);
    }

    /// Records the second pass of a reduction: `comps` components of `total`
    /// partials each into slots `out..`.
    fn record_reduce(
        &self,
        enc: &mut wgpu::CommandEncoder,
        partials: &wgpu::Buffer,
        total: u32,
        comps: u32,
        out: u32,
    ) {
        let second = RedParams {
            n: total,
            out,
            groups: 1,
            comps,
            ..Default::default()
        };
        let binds = [whole(partials), whole(&self.scal)];
        self.record(
            enc,
            Kernel::Reduce,
            bytemuck::bytes_of(&second),
            &binds,
            (1, 1),
        );
    }

    /// Records `cg_update` over `n` entries (`x += α p`, `r −= α q`,
    /// `z = d ∘ r` where `d` is given; α, −α in slots `ia`, `ib`)
    /// and the reduction of `(r · r, r · z)` into slots `out`, `out + 1`:
    /// two dispatches for the four of the step taken apart. Returns `false`,
    /// recording nothing, when the vectors span several windows (the caller
    /// then records the steps apart).
    pub(super) fn record_cg_update(
        &self,
        enc: &mut wgpu::CommandEncoder,
        n: usize,
        bufs: [&wgpu::Buffer; 5],
        d: Option<&wgpu::Buffer>,
        (ia, ib): (u32, u32),
        out: u32,
    ) -> bool {
        if n == 0 || n > self.vector_window() {
            return false;
        }
        let groups = reduction_groups(n as u32);
        let partials = self.partials(2 * groups);
        let prm = UpdateParams {
            ia,
            ib,
            ..Default::default()
        };
        self.record_cg_step(enc, n, bufs, d, prm, &partials);
        self.record_reduce(enc, &partials, groups, 2, out);
        true
    }

    /// Records one `cg_update` over `n` entries (one window) with `prm`'s
    /// slots, `terms` and `base` (its `n`, `groups` and `precond` filled in
    /// here), its partials in `partials`.
    pub(super) fn record_cg_step(
        &self,
        enc: &mut wgpu::CommandEncoder,
        n: usize,
        bufs: [&wgpu::Buffer; 5],
        d: Option<&wgpu::Buffer>,
        prm: UpdateParams,
        partials: &wgpu::Buffer,
    ) {
        let prepared = self.prepare_cg_step(n, bufs, d, prm, partials);
        self.record_prepared(enc, &prepared);
    }

    /// [`GpuBackend::record_cg_step`]'s dispatch, prepared.
    pub(super) fn prepare_cg_step(
        &self,
        n: usize,
        [p, q, x, r, z]: [&wgpu::Buffer; 5],
        d: Option<&wgpu::Buffer>,
        prm: UpdateParams,
        partials: &wgpu::Buffer,
    ) -> Prepared {
        let groups = reduction_groups(n as u32);
        let prm = UpdateParams {
            n: n as u32,
            groups,
            precond: u32::from(d.is_some()),
            ..prm
        };
        // Without a preconditioner `d` is not read (`p` stands in).
        let d = d.unwrap_or(p);
        let (gx, gy, _) = grid_2d(groups, 1, self.max_dim());
        let binds = [
            whole(&self.scal),
            whole(p),
            whole(q),
            whole(d),
            whole(x),
            whole(r),
            whole(z),
            whole(partials),
        ];
        let bytes = bytemuck::bytes_of(&prm);
        self.prepare(Kernel::CgUpdate, bytes, &binds, (gx, gy))
    }

    /// `cg_direction`'s dispatch over `n` entries (one window), prepared:
    /// `p = z + β p` from the partials `cg_update` left in `partials`, and
    /// the check.
    pub(super) fn prepare_cg_direction(
        &self,
        n: usize,
        prm: DirectionParams,
        partials: &wgpu::Buffer,
        [z, p]: [&wgpu::Buffer; 2],
    ) -> Prepared {
        let groups = reduction_groups(n as u32);
        let prm = DirectionParams {
            n: n as u32,
            groups,
            ..prm
        };
        let (gx, gy, _) = grid_2d(groups, 1, self.max_dim());
        let binds = [whole(&self.scal), whole(partials), whole(z), whole(p)];
        let bytes = bytemuck::bytes_of(&prm);
        self.prepare(Kernel::CgDirection, bytes, &binds, (gx, gy))
    }

    /// The partial-sums buffer, grown to at least `entries`.
    pub(super) fn partials(&self, entries: u32) -> wgpu::Buffer {
        let bytes = entries as u64 * self.ctx.precision.bytes();
        let mut cache = self.partials.borrow_mut();
        match &*cache {
            Some(b) if b.size() >= bytes => b.clone(),
            _ => {
                let b = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("partials"),
                    size: bytes.next_power_of_two(),
                    usage: storage_usage(),
                    mapped_at_creation: false,
                });
                *cache = Some(b.clone());
                b
            }
        }
    }
}
