//! Whole vectors between the host and the device through two staging
//! buffers kept for the backend's life (one to write, one to read), grown to
//! the largest vector copied. A solve of the fixed-point loop sends its
//! right-hand side and warm start and reads its solution back every time;
//! a fresh staging buffer per copy (as [`Backend::upload`] and
//! [`Backend::download`] make) is a new mapping whose every page the host
//! touches for the first time (218 MB per vector at 27 M dofs).
//!
//! [`Backend::upload`]: crate::backend::Backend::upload
//! [`Backend::download`]: crate::backend::Backend::download

use super::backend::{GpuBackend, GpuVector};
use super::context::Precision;

/// The two staging buffers (`None` until first used).
#[derive(Default)]
pub(super) struct Staging {
    write: Option<wgpu::Buffer>,
    read: Option<wgpu::Buffer>,
}

/// `slot` holding a buffer of at least `size` bytes with `usage`.
fn grown<'a>(
    dev: &wgpu::Device,
    slot: &'a mut Option<wgpu::Buffer>,
    size: u64,
    usage: wgpu::BufferUsages,
) -> &'a wgpu::Buffer {
    if slot.as_ref().is_none_or(|b| b.size() < size) {
        *slot = Some(dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some("staging"),
            size,
            usage,
            mapped_at_creation: false,
        }));
    }
    slot.as_ref().expect("just made")
}

impl GpuBackend {
    /// Blocks until `slice` is mapped.
    pub(super) fn map_and_wait(&self, slice: wgpu::BufferSlice<'_>, mode: wgpu::MapMode) {
        slice.map_async(mode, |r| {
            r.expect("gpu backend: mapping a staging buffer failed")
        });
        self.ctx
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("gpu backend: device lost while waiting");
    }

    /// `v = data` (converted to the device precision), through the write
    /// staging buffer.
    ///
    /// # Panics
    /// If the lengths differ.
    pub fn write_vector(&self, data: &[f64], v: &mut GpuVector) {
        assert_eq!(
            data.len(),
            v.len,
            "gpu backend: write_vector: lengths differ"
        );
        if data.is_empty() {
            return;
        }
        let size = data.len() as u64 * self.ctx.precision.bytes();
        let mut staging = self.staging.borrow_mut();
        let usage = wgpu::BufferUsages::MAP_WRITE | wgpu::BufferUsages::COPY_SRC;
        let buf = grown(&self.ctx.device, &mut staging.write, size, usage);
        let slice = buf.slice(..size);
        self.map_and_wait(slice, wgpu::MapMode::Write);
        {
            let mut view = slice
                .get_mapped_range_mut()
                .expect("gpu backend: writing a mapped staging buffer failed");
            match self.ctx.precision {
                Precision::F64 => view.copy_from_slice(bytemuck::cast_slice(data)),
                Precision::F32 => {
                    let v: Vec<f32> = data.iter().map(|&x| x as f32).collect();
                    view.copy_from_slice(bytemuck::cast_slice(&v));
                }
            }
        }
        buf.unmap();
        let mut enc = self.encoder();
        enc.copy_buffer_to_buffer(buf, 0, &v.buf, 0, size);
        self.submit(enc);
    }

    /// `v = 0` on the device (nothing crosses the bus).
    pub fn clear_vector(&self, v: &mut GpuVector) {
        let mut enc = self.encoder();
        enc.clear_buffer(&v.buf, 0, None);
        self.submit(enc);
    }

    /// `out = v` (as f64), through the read staging buffer (waits).
    ///
    /// # Panics
    /// If the lengths differ.
    pub fn read_vector(&self, v: &GpuVector, out: &mut [f64]) {
        assert_eq!(out.len(), v.len, "gpu backend: read_vector: lengths differ");
        if out.is_empty() {
            return;
        }
        let size = out.len() as u64 * self.ctx.precision.bytes();
        let mut staging = self.staging.borrow_mut();
        let usage = wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST;
        let buf = grown(&self.ctx.device, &mut staging.read, size, usage);
        let mut enc = self.encoder();
        enc.copy_buffer_to_buffer(&v.buf, 0, buf, 0, size);
        self.submit(enc);
        let slice = buf.slice(..size);
        self.map_and_wait(slice, wgpu::MapMode::Read);
        {
            let view = slice
                .get_mapped_range()
                .expect("gpu backend: reading a mapped staging buffer failed");
            match self.ctx.precision {
                Precision::F64 => bytemuck::cast_slice_mut(out).copy_from_slice(&view),
                Precision::F32 => {
                    for (o, c) in out.iter_mut().zip(view.chunks_exact(4)) {
                        *o = f32::from_ne_bytes(c.try_into().expect("4 bytes")) as f64;
                    }
                }
            }
        }
        buf.unmap();
    }
}
