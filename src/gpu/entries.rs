//! A vector's entries at given indices between the host and the device,
//! for the ghost exchange of a rank ([`crate::distributed`]): the entries
//! its neighbours ask for are gathered on the device into a small buffer
//! and read back (`gather_entries`); the ghosts it receives are uploaded in
//! a small buffer and scattered (`scatter_entries`). Only those entries
//! cross the bus, not the vector. A vector that spans several binding
//! windows goes through the host whole instead.

use super::backend::{GpuBackend, GpuVector};
use super::kernels::{grid_2d, GatherParams, Kernel, WG};
use super::record::whole;
use crate::backend::Backend;

impl GpuBackend {
    /// Whether `v` fits one binding (the entry kernels bind it whole).
    fn in_one_binding(&self, v: &GpuVector) -> bool {
        v.len <= self.vector_window()
    }

    /// The indices as a device buffer of `u32`.
    fn indices(&self, idx: &[usize]) -> wgpu::Buffer {
        let idx: Vec<u32> = idx.iter().map(|&i| i as u32).collect();
        self.buffer_init("entries", bytemuck::cast_slice(&idx))
    }

    /// Records and submits `kernel` (`gather_entries`, `scatter_entries`)
    /// over `n` entries.
    fn entries_call(&self, kernel: Kernel, n: usize, binds: &[wgpu::BindingResource<'_>]) {
        let (x, y, stride) = grid_2d(n as u32, WG, self.max_dim());
        let prm = GatherParams {
            n: n as u32,
            stride,
            ..Default::default()
        };
        let mut enc = self.encoder();
        self.record(&mut enc, kernel, bytemuck::bytes_of(&prm), binds, (x, y));
        self.submit(enc);
    }

    /// `v[idx[k]]` for every `k`, gathered on the device and read back.
    pub(super) fn read_entries_on_device(&self, v: &GpuVector, idx: &[usize]) -> Vec<f64> {
        if idx.is_empty() {
            return Vec::new();
        }
        if !self.in_one_binding(v) {
            let host = self.download(v);
            return idx.iter().map(|&i| host[i]).collect();
        }
        let out = self.zeros(idx.len());
        let at = self.indices(idx);
        let binds = [whole(&v.buf), whole(&out.buf), whole(&at)];
        self.entries_call(Kernel::GatherEntries, idx.len(), &binds);
        self.download(&out)
    }

    /// `v[idx[k]] = values[k]` for every `k` (distinct indices), uploaded
    /// and scattered on the device.
    pub(super) fn write_entries_on_device(&self, values: &[f64], idx: &[usize], v: &mut GpuVector) {
        if idx.is_empty() {
            return;
        }
        if !self.in_one_binding(v) {
            let mut host = self.download(v);
            for (&i, &x) in idx.iter().zip(values) {
                host[i] = x;
            }
            *v = self.upload(&host);
            return;
        }
        let src = self.upload(values);
        let at = self.indices(idx);
        let binds = [whole(&src.buf), whole(&v.buf), whole(&at)];
        self.entries_call(Kernel::ScatterEntries, idx.len(), &binds);
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::super::context::PrecisionChoice;
    use super::super::mirror::{gather_entries, scatter_entries};
    use super::*;

    /// The device's gather and scatter equal their mirrors bit for bit, on a
    /// vector in one binding and on one that spans windows (the host path).
    #[test]
    fn entry_kernels_match_their_mirrors() {
        let Some(ctx) = super::super::context_or_skip(PrecisionChoice::F64) else {
            return;
        };
        let n = 3000;
        let v: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let idx: Vec<usize> = (0..n).filter(|i| i % 7 == 3 || i % 11 == 0).rev().collect();
        let at: Vec<u32> = idx.iter().map(|&i| i as u32).collect();
        let values: Vec<f64> = idx.iter().map(|&i| -(i as f64)).collect();
        let prm = GatherParams {
            n: idx.len() as u32,
            ..Default::default()
        };
        let mut read = vec![0.0; idx.len()];
        gather_entries(&prm, &v, &mut read, &at);
        let mut written = v.clone();
        scatter_entries(&prm, &values, &mut written, &at);
        for (be, device) in [
            (GpuBackend::new(Arc::clone(&ctx)), true),
            (
                GpuBackend::with_max_binding_bytes(Arc::clone(&ctx), 8 * 1024),
                false,
            ),
        ] {
            let mut dv = be.upload(&v);
            assert_eq!(be.in_one_binding(&dv), device);
            assert_eq!(be.read_entries(&dv, &idx), read);
            be.write_entries(&values, &idx, &mut dv);
            assert_eq!(be.download(&dv), written);
        }
    }
}
