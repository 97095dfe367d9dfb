//! Measuring: wall time per call, the process's peak resident memory, and the
//! STREAM-like triad that is the bandwidth reference.

use std::time::Instant;

use rayon::prelude::*;

/// Seconds per call of `f`: the fastest of several repetitions, after one
/// warm-up call, repeating until `budget` seconds are spent (at least 3 and at
/// most 200 calls). The minimum is the least noisy estimate on a shared machine.
pub fn seconds_per_call(budget: f64, mut f: impl FnMut()) -> f64 {
    f();
    let started = Instant::now();
    let mut best = f64::INFINITY;
    for k in 0..200 {
        let t = Instant::now();
        f();
        best = best.min(t.elapsed().as_secs_f64());
        if k >= 2 && started.elapsed().as_secs_f64() > budget {
            break;
        }
    }
    best
}

pub use crate::grid::peak_resident_bytes;

/// Resets the peak resident memory to the current one (Linux: writing `5` to
/// `/proc/self/clear_refs`), so that the next [`peak_resident_bytes`] is the
/// peak of what runs in between. Returns whether the kernel allowed it.
pub fn reset_peak_resident() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// Bytes a triad moves per entry: read `b`, `c`, write `a` (as STREAM counts).
pub const TRIAD_BYTES_PER_ENTRY: f64 = 24.0;

/// Entries of each triad array: 3 × 64 MiB, far beyond any cache.
pub const TRIAD_LEN: usize = 1 << 23;

/// The STREAM triad `a = b + s c` in parallel (in the current rayon pool):
/// seconds per triad over [`TRIAD_LEN`] entries.
pub fn triad_seconds(budget: f64) -> f64 {
    const BLOCK: usize = 1 << 14;
    let mut a = vec![0.0; TRIAD_LEN];
    let b = vec![1.0; TRIAD_LEN];
    let c = vec![2.0; TRIAD_LEN];
    // First touch in parallel, so that pages sit near the threads using them.
    a.par_chunks_mut(BLOCK).for_each(|ac| ac.fill(0.0));
    let s = 3.0;
    seconds_per_call(budget, || {
        a.par_chunks_mut(BLOCK)
            .zip(b.par_chunks(BLOCK))
            .zip(c.par_chunks(BLOCK))
            .for_each(|((ac, bc), cc)| {
                for ((ai, bi), ci) in ac.iter_mut().zip(bc).zip(cc) {
                    *ai = bi + s * ci;
                }
            });
    })
}
