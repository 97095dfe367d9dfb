//! [`GpuBackend`]: the [`Backend`] trait on a wgpu device. Vectors are device
//! buffers for the whole solve (each up to `max_buffer_size`; kernels bind
//! them in windows of at most one storage binding, [`super::windows`],
//! recorded by [`super::record`]); each trait call records its kernel(s) and
//! submits; only `dot`, `dot2` and `download` wait for the device.
//!
//! # Scalars
//! Kernels read their scalars from the device buffer `scal` ([`SLOTS`]
//! entries) at slots named in their params. A trait call writes its `f64`
//! arguments to the host slots [`SLOT_A`], [`SLOT_B`] (`write_buffer`, ordered
//! before the submit that follows); reductions land in [`SLOT_DOT`]`..+2` and
//! are read back. The device-scalar solvers ([`super::device_krylov`]) use the
//! same kernels with slots that other kernels wrote.

use std::cell::{Cell, RefCell};
use std::sync::Arc;

use wgpu::util::DeviceExt;

use crate::backend::Backend;

use super::context::{GpuContext, Precision};
use super::kernels::Kernel;
use super::operator::GpuOperator;
use super::windows::BindingLimits;

/// Entries of the device-scalar buffer.
pub const SLOTS: u32 = 32;
/// Host-written scalar arguments of the trait calls.
pub const SLOT_A: u32 = 0;
pub const SLOT_B: u32 = 1;
/// Where `dot`/`dot2` reduce to (two slots).
pub const SLOT_DOT: u32 = 2;

/// A vector on the device: `len` entries (the buffer holds at least one).
pub struct GpuVector {
    pub(super) buf: wgpu::Buffer,
    pub(super) len: usize,
}

/// The GPU backend over one [`GpuContext`].
pub struct GpuBackend {
    pub(super) ctx: Arc<GpuContext>,
    pub(super) scal: wgpu::Buffer,
    pub(super) partials: RefCell<Option<wgpu::Buffer>>,
    /// The windows' binding size ([`super::windows`]).
    pub(super) bindings: BindingLimits,
    /// Kernels recorded so far ([`GpuBackend::dispatches`]).
    pub(super) dispatches: Cell<u64>,
    /// The steps recorded since [`GpuBackend::begin_capture`], while a
    /// capture is on.
    pub(super) capture: RefCell<Option<Vec<super::record::Step>>>,
    /// Staging buffers of [`GpuBackend::write_vector`] and
    /// [`GpuBackend::read_vector`].
    pub(super) staging: RefCell<super::staging::Staging>,
}

fn check_len(kernel: &str, n: usize, others: &[usize]) {
    for &m in others {
        assert_eq!(n, m, "gpu backend: {kernel}: vector lengths differ");
    }
}

impl GpuBackend {
    /// The backend on `ctx`.
    pub fn new(ctx: Arc<GpuContext>) -> Self {
        let bytes = ctx.bindings.max_bytes;
        Self::with_max_binding_bytes(ctx, bytes)
    }

    /// The backend on `ctx`, splitting arrays into windows of at most
    /// `bytes` bytes (clamped to `[BindingLimits::smallest(), the
    /// context's]`): tests split small problems with it.
    pub fn with_max_binding_bytes(ctx: Arc<GpuContext>, bytes: u64) -> Self {
        let bindings = BindingLimits {
            max_bytes: bytes.clamp(BindingLimits::smallest(), ctx.bindings.max_bytes),
            ..ctx.bindings
        };
        let scal = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("scal"),
            size: SLOTS as u64 * ctx.precision.bytes(),
            usage: storage_usage(),
            mapped_at_creation: false,
        });
        GpuBackend {
            ctx,
            scal,
            partials: RefCell::new(None),
            bindings,
            dispatches: Cell::new(0),
            capture: RefCell::new(None),
            staging: RefCell::default(),
        }
    }

    /// The context (device, adapter, precision).
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// The binding size and alignment its windows use.
    pub fn bindings(&self) -> BindingLimits {
        self.bindings
    }

    /// The device precision.
    pub fn precision(&self) -> Precision {
        self.ctx.precision
    }

    /// Kernel dispatches recorded since the backend was made (the bench
    /// counts them per Krylov iteration).
    pub fn dispatches(&self) -> u64 {
        self.dispatches.get()
    }

    /// CG's step in one sweep (`cg_update`): `x += α p`, `r −= α q`, `z = d ∘ r`
    /// (with `d`; else `z` is `r` and untouched), and `(r · r, r · z)`, read
    /// back; `None`, doing nothing, where the vectors span several windows.
    #[allow(clippy::too_many_arguments)]
    pub fn cg_update(
        &self,
        alpha: f64,
        p: &GpuVector,
        q: &GpuVector,
        d: Option<&GpuVector>,
        x: &mut GpuVector,
        r: &mut GpuVector,
        z: &mut GpuVector,
    ) -> Option<(f64, f64)> {
        check_len("cg_update", x.len, &[p.len, q.len, r.len]);
        self.write_slots(SLOT_A, &[alpha, -alpha]);
        let mut enc = self.encoder();
        let bufs = [&p.buf, &q.buf, &x.buf, &r.buf, &z.buf];
        let d = d.map(|d| &d.buf);
        let slots = (SLOT_A, SLOT_B);
        if !self.record_cg_update(&mut enc, x.len, bufs, d, slots, SLOT_DOT) {
            return None;
        }
        self.submit(enc);
        let s = self.read_slots(SLOT_DOT, 2);
        Some((s[0], s[1]))
    }

    /// Blocks until every submitted command has run (for timing).
    pub fn finish(&self) {
        // A lost device shows in the next read-back, which reports it.
        let _ = self.ctx.device.poll(wgpu::PollType::wait_indefinitely());
    }

    /// `data` converted to the device precision, as bytes.
    pub(super) fn to_bytes(&self, data: &[f64]) -> Vec<u8> {
        match self.ctx.precision {
            Precision::F64 => bytemuck::cast_slice(data).to_vec(),
            Precision::F32 => {
                let v: Vec<f32> = data.iter().map(|&x| x as f32).collect();
                bytemuck::cast_slice(&v).to_vec()
            }
        }
    }

    /// A storage buffer holding `bytes` (at least 4 bytes).
    pub(super) fn buffer_init(&self, label: &str, bytes: &[u8]) -> wgpu::Buffer {
        let pad = [0u8; 8];
        let contents = if bytes.is_empty() { &pad[..] } else { bytes };
        self.ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: storage_usage(),
            })
    }

    /// Writes host scalars into consecutive slots from `slot`.
    pub fn write_slots(&self, slot: u32, values: &[f64]) {
        let offset = slot as u64 * self.ctx.precision.bytes();
        self.ctx
            .queue
            .write_buffer(&self.scal, offset, &self.to_bytes(values));
    }

    /// Reads `count` slots from `slot` (waits for the device).
    pub fn read_slots(&self, slot: u32, count: u32) -> Vec<f64> {
        let b = self.ctx.precision.bytes();
        self.read_buffer(&self.scal, slot as u64 * b, count as usize)
    }

    /// `count` entries of `buf` from byte `offset`, as f64 (waits).
    fn read_buffer(&self, buf: &wgpu::Buffer, offset: u64, count: usize) -> Vec<f64> {
        if count == 0 {
            return Vec::new();
        }
        let size = count as u64 * self.ctx.precision.bytes();
        let staging = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("staging"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self.encoder();
        enc.copy_buffer_to_buffer(buf, offset, &staging, 0, size);
        self.ctx.queue.submit([enc.finish()]);
        let slice = staging.slice(..);
        self.map_and_wait(slice, wgpu::MapMode::Read);
        let data = slice
            .get_mapped_range()
            .expect("gpu backend: reading a mapped staging buffer failed");
        let out = match self.ctx.precision {
            Precision::F64 => bytemuck::pod_collect_to_vec::<u8, f64>(&data),
            Precision::F32 => bytemuck::pod_collect_to_vec::<u8, f32>(&data)
                .into_iter()
                .map(|x| x as f64)
                .collect(),
        };
        drop(data);
        staging.unmap();
        out
    }

    pub(super) fn encoder(&self) -> wgpu::CommandEncoder {
        self.ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None })
    }

    pub(super) fn submit(&self, enc: wgpu::CommandEncoder) {
        self.ctx.queue.submit([enc.finish()]);
    }

    /// One element-wise kernel with host scalars `a`, `b`, submitted.
    pub(super) fn vec_call(
        &self,
        kernel: Kernel,
        n: usize,
        scalars: &[f64],
        bufs: &[&wgpu::Buffer],
    ) {
        if n == 0 {
            return;
        }
        if !scalars.is_empty() {
            self.write_slots(SLOT_A, scalars);
        }
        let mut enc = self.encoder();
        self.record_vec(&mut enc, kernel, n, (SLOT_A, SLOT_B), bufs);
        self.submit(enc);
    }
}

/// Usage of every storage buffer of the backend.
pub(super) fn storage_usage() -> wgpu::BufferUsages {
    wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST
}

impl Backend for GpuBackend {
    type Vector = GpuVector;
    type Operator<'o> = GpuOperator<'o>;

    fn name(&self) -> String {
        format!("gpu:{}", self.ctx.adapter.name)
    }

    fn len(&self, v: &GpuVector) -> usize {
        v.len
    }

    fn nrows(&self, op: &GpuOperator<'_>) -> usize {
        op.nrows()
    }

    fn zeros(&self, n: usize) -> GpuVector {
        let size = n.max(1) as u64 * self.ctx.precision.bytes();
        // Buffers are zero-initialised by wgpu.
        let buf = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("vector"),
            size,
            usage: storage_usage(),
            mapped_at_creation: false,
        });
        GpuVector { buf, len: n }
    }

    fn upload(&self, data: &[f64]) -> GpuVector {
        GpuVector {
            buf: self.buffer_init("vector", &self.to_bytes(data)),
            len: data.len(),
        }
    }

    fn download(&self, v: &GpuVector) -> Vec<f64> {
        self.read_buffer(&v.buf, 0, v.len)
    }

    /// Gathered on the device ([`super::entries`]).
    fn read_entries(&self, v: &GpuVector, idx: &[usize]) -> Vec<f64> {
        self.read_entries_on_device(v, idx)
    }

    /// Scattered on the device ([`super::entries`]).
    fn write_entries(&self, values: &[f64], idx: &[usize], v: &mut GpuVector) {
        self.write_entries_on_device(values, idx, v);
    }

    fn apply(&self, op: &GpuOperator<'_>, x: &GpuVector, y: &mut GpuVector) {
        check_len("apply", op.nrows(), &[x.len, y.len]);
        let mut enc = self.encoder();
        op.record_apply(self, &mut enc, &x.buf, &y.buf);
        self.submit(enc);
    }

    fn diagonal(&self, op: &GpuOperator<'_>) -> GpuVector {
        self.upload(&op.host_diagonal())
    }

    fn copy(&self, src: &GpuVector, dst: &mut GpuVector) {
        check_len("copy", src.len, &[dst.len]);
        self.vec_call(Kernel::Copy, src.len, &[], &[&src.buf, &dst.buf]);
    }

    fn scale(&self, a: f64, x: &mut GpuVector) {
        self.vec_call(Kernel::Scale, x.len, &[a], &[&self.scal, &x.buf]);
    }

    fn axpy(&self, a: f64, x: &GpuVector, y: &mut GpuVector) {
        check_len("axpy", x.len, &[y.len]);
        self.vec_call(Kernel::Axpy, x.len, &[a], &[&self.scal, &x.buf, &y.buf]);
    }

    fn xpay(&self, x: &GpuVector, a: f64, y: &mut GpuVector) {
        check_len("xpay", x.len, &[y.len]);
        self.vec_call(Kernel::Xpay, x.len, &[a], &[&self.scal, &x.buf, &y.buf]);
    }

    fn axpy2(&self, a: f64, u: &GpuVector, b: f64, w: &GpuVector, y: &mut GpuVector) {
        check_len("axpy2", y.len, &[u.len, w.len]);
        let bufs = [&self.scal, &u.buf, &w.buf, &y.buf];
        self.vec_call(Kernel::Axpy2, y.len, &[a, b], &bufs);
    }

    fn pointwise_mul(&self, x: &GpuVector, y: &GpuVector, z: &mut GpuVector) {
        check_len("pointwise_mul", z.len, &[x.len, y.len]);
        let bufs = [&x.buf, &y.buf, &z.buf];
        self.vec_call(Kernel::PointwiseMul, z.len, &[], &bufs);
    }

    fn dot(&self, x: &GpuVector, y: &GpuVector) -> f64 {
        check_len("dot", x.len, &[y.len]);
        let mut enc = self.encoder();
        self.record_dot(&mut enc, x.len, &[&x.buf, &y.buf], SLOT_DOT);
        self.submit(enc);
        self.read_slots(SLOT_DOT, 1)[0]
    }

    fn dot2(&self, x: &GpuVector, y: &GpuVector, z: &GpuVector) -> (f64, f64) {
        check_len("dot2", x.len, &[y.len, z.len]);
        let mut enc = self.encoder();
        self.record_dot(&mut enc, x.len, &[&x.buf, &y.buf, &z.buf], SLOT_DOT);
        self.submit(enc);
        let s = self.read_slots(SLOT_DOT, 2);
        (s[0], s[1])
    }

    fn cgs_update_up(
        &self,
        beta: f64,
        r: &GpuVector,
        q: &GpuVector,
        u: &mut GpuVector,
        p: &mut GpuVector,
    ) {
        check_len("cgs_update_up", r.len, &[q.len, u.len, p.len]);
        let bufs = [&self.scal, &r.buf, &q.buf, &u.buf, &p.buf];
        self.vec_call(Kernel::CgsUpdateUp, r.len, &[beta], &bufs);
    }

    fn cgs_update_qu(&self, alpha: f64, v: &GpuVector, q: &mut GpuVector, u: &mut GpuVector) {
        check_len("cgs_update_qu", v.len, &[q.len, u.len]);
        let bufs = [&self.scal, &v.buf, &q.buf, &u.buf];
        self.vec_call(Kernel::CgsUpdateQu, v.len, &[alpha], &bufs);
    }

    fn bicgstab_update_p(
        &self,
        beta: f64,
        omega: f64,
        r: &GpuVector,
        v: &GpuVector,
        p: &mut GpuVector,
    ) {
        check_len("bicgstab_update_p", p.len, &[r.len, v.len]);
        let bufs = [&self.scal, &r.buf, &v.buf, &p.buf];
        self.vec_call(Kernel::BicgstabUpdateP, p.len, &[beta, omega], &bufs);
    }
}
