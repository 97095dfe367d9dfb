//! Arrays larger than one storage binding (128 MiB on lavapipe):
//! every kernel runs over *windows*, sub-ranges of its buffers bound at an
//! offset that is a multiple of `min_storage_buffer_offset_alignment`, each at
//! most one binding long. A buffer itself may be as large as
//! `max_buffer_size`.
//!
//! # Vector windows
//! Element-wise kernels and the first pass of `dot`/`dot2` run over
//! `[k W, min((k + 1) W, n))` with `W` a multiple of `WG · PER` entries (one
//! reduction workgroup's chunk). Window `k` then holds exactly the reduction
//! groups `k W / (WG · PER) …` of the unsplit run, which write their partial
//! sums at that offset: split or not, every partial sum, and so every dot
//! product, is bitwise the same.
//!
//! # Apply windows
//! `apply` gathers, for the active nodes `[a₀, a₁)` of its window, from the
//! cells around each node: it reads `slots` of those cells, `node_to_active`
//! of their nodes and `x` at the active indices of those nodes. Lattice nodes
//! are numbered x fastest, then y, then z, and active indices follow the
//! lattice order, so a window's nodes lie in the z-planes `k_f … k_l` of its
//! first and last node, and all it reads lies in
//! - cells of the cell layers `⌊(k_f − 1)/p⌋ … ⌊k_l/p⌋`,
//! - lattice nodes of the node planes `p ⌊(k_f − 1)/p⌋ … p (⌊k_l/p⌋ + 1)`
//!   (one cell layer of nodes either side: the halo),
//! - `x` at the active nodes of those planes (a range, by the ordering).
//!
//! Each of the five ranges (`y`, `active_to_node`, `x`, `node_to_active`,
//! `slots`) is bound as a window starting at a multiple of the alignment, and
//! `apply` subtracts the window's base from each index. Windows are made as
//! long as all five fit one binding; at least the halo planes must fit, else
//! [`Error::DeviceTooSmall`].

use std::ops::Range;

use crate::error::{Error, Result};

use super::kernels::{PER, WG};

/// What windows may be bound: the largest binding and the offset alignment,
/// in bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BindingLimits {
    pub max_bytes: u64,
    pub align: u64,
}

/// Entries of one reduction workgroup's chunk: vector windows are multiples.
pub const REDUCTION_CHUNK: u64 = (WG * PER) as u64;

impl BindingLimits {
    /// Entries per vector window for entries of `real_bytes` bytes: the
    /// largest multiple of [`REDUCTION_CHUNK`] that fits one binding (at
    /// least one chunk; [`BindingLimits::smallest`] makes sure it fits).
    pub fn vector_window(&self, real_bytes: u64) -> usize {
        let chunks = (self.max_bytes / (REDUCTION_CHUNK * real_bytes)).max(1);
        (chunks * REDUCTION_CHUNK) as usize
    }

    /// The smallest binding the windows accept: one reduction chunk of f64.
    pub fn smallest() -> u64 {
        REDUCTION_CHUNK * 8
    }

    /// Indices whose offsets (as u32, f32 or f64 arrays, and ×3 for the
    /// per-node vector entries) are multiples of the alignment: a multiple of
    /// this granule.
    fn granule(&self) -> u32 {
        (self.align / 4).max(1) as u32
    }
}

/// The windows `[k W, min((k + 1) W, n))` of a vector of `n` entries.
pub fn vector_windows(n: usize, window: usize) -> impl Iterator<Item = Range<usize>> {
    (0..n.div_ceil(window)).map(move |k| k * window..(k * window + window).min(n))
}

/// The ranges one `apply` window binds (node, lattice-node and cell indices;
/// `y` and `x` hold three entries per node).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ApplyWindow {
    /// Active nodes written (`y`, `active_to_node`).
    pub nodes: Range<u32>,
    /// Active nodes read (`x`).
    pub x: Range<u32>,
    /// Lattice nodes read (`node_to_active`).
    pub lattice: Range<u32>,
    /// Cells read (`slots`).
    pub cells: Range<u32>,
}

/// The Cartesian lattice of an operator: cells per axis and element degree.
#[derive(Clone, Copy, Debug)]
pub struct Lattice {
    pub cells: [u32; 3],
    pub degree: u32,
}

impl Lattice {
    /// Lattice nodes per axis.
    fn nodes(&self) -> [u32; 3] {
        self.cells.map(|c| self.degree * c + 1)
    }

    /// The window of the active nodes `[a0, a1)` (before alignment).
    fn window(&self, active_to_node: &[u32], a0: u32, a1: u32) -> ApplyWindow {
        let [m0, m1, _] = self.nodes();
        let plane = m0 * m1;
        let p = self.degree;
        let kf = active_to_node[a0 as usize] / plane;
        let kl = active_to_node[a1 as usize - 1] / plane;
        let (layer_lo, layer_hi) = (kf.saturating_sub(1) / p, (kl / p).min(self.cells[2] - 1));
        let layer = self.cells[0] * self.cells[1];
        let lattice = p * layer_lo * plane..(p * (layer_hi + 1) + 1) * plane;
        let first = |bound: u32| active_to_node.partition_point(|&n| n < bound) as u32;
        ApplyWindow {
            nodes: a0..a1,
            x: first(lattice.start)..first(lattice.end),
            lattice,
            cells: layer_lo * layer..(layer_hi + 1) * layer,
        }
    }
}

/// `r` with its start rounded down to a multiple of `g`.
fn aligned(r: Range<u32>, g: u32) -> Range<u32> {
    r.start / g * g..r.end
}

impl ApplyWindow {
    /// The window with every start rounded down to the alignment granule.
    fn aligned(self, g: u32) -> ApplyWindow {
        ApplyWindow {
            nodes: self.nodes,
            x: aligned(self.x, g),
            lattice: aligned(self.lattice, g),
            cells: aligned(self.cells, g),
        }
    }

    /// The largest of its five bindings, in bytes.
    fn max_bytes(&self, real_bytes: u64) -> u64 {
        let len = |r: &Range<u32>| (r.end - r.start) as u64;
        (3 * real_bytes * len(&self.nodes).max(len(&self.x)))
            .max(4 * len(&self.lattice).max(len(&self.cells)))
    }
}

/// Splits the active nodes (`active_to_node`, increasing) into apply windows
/// that each fit `limits`; one window when everything fits.
pub fn apply_windows(
    active_to_node: &[u32],
    lattice: Lattice,
    real_bytes: u64,
    limits: BindingLimits,
) -> Result<Vec<ApplyWindow>> {
    assert!(
        active_to_node.windows(2).all(|w| w[0] < w[1]),
        "apply windows: active nodes must follow the lattice order"
    );
    let n = active_to_node.len() as u32;
    let g = limits.granule();
    let fits = |a0: u32, a1: u32| {
        let w = lattice.window(active_to_node, a0, a1).aligned(g);
        (w.max_bytes(real_bytes) <= limits.max_bytes).then_some(w)
    };
    let mut out = Vec::new();
    let mut a0 = 0;
    while a0 < n {
        let end = |k: u32| (a0 + k * g).min(n);
        let Some(mut best) = fits(a0, end(1)) else {
            return Err(Error::DeviceTooSmall {
                what: format!(
                    "the apply window of active node {a0} (its cell layers and \
                     their neighbours) exceeds one storage binding of {} bytes",
                    limits.max_bytes
                ),
            });
        };
        // Largest k with a fitting window: sizes grow with a1.
        let (mut lo, mut hi) = (1, (n - a0).div_ceil(g));
        while lo < hi {
            let mid = lo + (hi - lo).div_ceil(2);
            match fits(a0, end(mid)) {
                Some(w) => (lo, best) = (mid, w),
                None => hi = mid - 1,
            }
        }
        a0 = best.nodes.end;
        out.push(best);
    }
    Ok(out)
}

/// The own-matrix slots `[lo, hi)` that `slots[cells]` refers to (empty when
/// none).
pub fn own_slots(slots: &[u32], cells: &Range<u32>, own_count: u32) -> Range<u32> {
    let own = slots[cells.start as usize..cells.end as usize]
        .iter()
        .copied()
        .filter(|&s| s < own_count);
    let (lo, hi) = own.fold((u32::MAX, 0), |(lo, hi), s| (lo.min(s), hi.max(s + 1)));
    if lo >= hi {
        0..0
    } else {
        lo..hi
    }
}
