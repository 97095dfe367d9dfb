//! The Cartesian grid at level L: geometry of cells and nodes,
//! their indexing, and the memory estimate that guards large levels.
//!
//! The longest side of the box is split into `2^L` cubic cells of size `h`; the
//! other sides get `ceil(side / h)` cells (the box grows to fit). An offset
//! `o ∈ [0, 1)^3` (in cells) shifts the grid origin to `lo − o h` and adds the
//! cells needed to still cover the box. Cells are numbered `i + nx (j + ny k)`;
//! the nodes of order `p` (1 for Q1, 2 for Q2) form a `(p n + 1)^3` lattice
//! numbered the same way, so cell `(i, j, k)`'s local node `(a, b, c)` is global
//! node `(p i + a, p j + b, p k + c)`.

use crate::element::ElementOrder;
use crate::error::{Error, Result};
use crate::spatial::Aabb;

/// Highest level accepted at all (the memory budget usually stops earlier).
pub const MAX_LEVEL: u32 = 12;

/// The cells `lo ≤ ijk < hi` of a grid: a rank's brick, or the window of
/// cells it classifies (its brick and ghost layers).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CellBox {
    pub lo: [usize; 3],
    pub hi: [usize; 3],
}

impl CellBox {
    /// Whether cell `ijk` lies in the box.
    pub fn contains(&self, ijk: [usize; 3]) -> bool {
        (0..3).all(|a| self.lo[a] <= ijk[a] && ijk[a] < self.hi[a])
    }

    /// The box grown by `layers` cells on every side, within `0..n`.
    pub fn grown(&self, layers: usize, n: [usize; 3]) -> CellBox {
        CellBox {
            lo: self.lo.map(|v| v.saturating_sub(layers)),
            hi: [0, 1, 2].map(|a| (self.hi[a] + layers).min(n[a])),
        }
    }

    /// Whether the two boxes share a cell.
    pub fn meets(&self, other: &CellBox) -> bool {
        (0..3).all(|a| self.lo[a].max(other.lo[a]) < self.hi[a].min(other.hi[a]))
    }

    /// Number of cells in the box.
    pub fn num_cells(&self) -> usize {
        (0..3).map(|a| self.hi[a] - self.lo[a]).product()
    }
}

/// A regular grid of cubic cells.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    pub origin: [f64; 3],
    pub h: f64,
    pub n: [usize; 3],
    pub level: u32,
}

impl Grid {
    /// The grid of `level` over `bbox`, shifted by `offset` cells.
    pub fn new(bbox: &Aabb, level: u32, offset: [f64; 3]) -> Result<Grid> {
        let bad = |what: &str, reason: String| Error::InvalidGrid {
            what: what.into(),
            reason,
        };
        if !bbox.is_finite() || (0..3).any(|i| bbox.hi[i] <= bbox.lo[i]) {
            return Err(bad(
                "box",
                format!(
                    "needs finite corners with max > min, got {:?}..{:?}",
                    bbox.lo, bbox.hi
                ),
            ));
        }
        if level > MAX_LEVEL {
            return Err(bad(
                "level",
                format!("{level} is above the maximum {MAX_LEVEL}"),
            ));
        }
        if offset.iter().any(|o| !(0.0..1.0).contains(o)) {
            return Err(bad(
                "offset",
                format!("components must lie in [0, 1), got {offset:?}"),
            ));
        }
        let side = [0, 1, 2].map(|i| bbox.hi[i] - bbox.lo[i]);
        let longest = side.iter().copied().fold(0.0, f64::max);
        let h = longest / (1u64 << level) as f64;
        let origin = [0, 1, 2].map(|i| bbox.lo[i] - offset[i] * h);
        let extents_finite = (0..3).all(|i| (bbox.hi[i] - origin[i]).is_finite());
        if !(h.is_finite() && h > 0.0 && extents_finite) {
            return Err(bad(
                "box",
                format!(
                    "{:?}..{:?} at level {level} gives cells of size {h:e}, \
                     beyond floating-point range",
                    bbox.lo, bbox.hi
                ),
            ));
        }
        let n = [0, 1, 2].map(|i| {
            let cells = (bbox.hi[i] - origin[i]) / h;
            // Round-off must not add a sliver cell to an exact fit.
            (cells - 1e-9).ceil().max(1.0) as usize
        });
        Ok(Grid {
            origin,
            h,
            n,
            level,
        })
    }

    pub fn num_cells(&self) -> usize {
        self.n[0] * self.n[1] * self.n[2]
    }

    /// All the grid's cells as a box.
    pub fn all_cells(&self) -> CellBox {
        CellBox {
            lo: [0; 3],
            hi: self.n,
        }
    }

    pub fn cell_index(&self, ijk: [usize; 3]) -> usize {
        ijk[0] + self.n[0] * (ijk[1] + self.n[1] * ijk[2])
    }

    pub fn cell_ijk(&self, c: usize) -> [usize; 3] {
        [
            c % self.n[0],
            (c / self.n[0]) % self.n[1],
            c / (self.n[0] * self.n[1]),
        ]
    }

    /// The box of the cells `lo ≤ ijk < hi` (a single cell when `hi = lo + 1`).
    pub fn block_box(&self, lo: [usize; 3], hi: [usize; 3]) -> Aabb {
        Aabb::new(
            [0, 1, 2].map(|i| self.origin[i] + lo[i] as f64 * self.h),
            [0, 1, 2].map(|i| self.origin[i] + hi[i] as f64 * self.h),
        )
    }

    pub fn cell_box(&self, c: usize) -> Aabb {
        let ijk = self.cell_ijk(c);
        self.block_box(ijk, ijk.map(|v| v + 1))
    }

    /// The physical points of a reference rule (`ξ ∈ [0, 1]³`) in each of
    /// `cells`, cell by cell.
    pub fn rule_points(&self, cells: &[usize], rule: &[([f64; 3], f64)]) -> Vec<[f64; 3]> {
        cells
            .iter()
            .flat_map(|&c| {
                let lo = self.cell_box(c).lo;
                rule.iter()
                    .map(move |(xi, _)| [0, 1, 2].map(|a| lo[a] + self.h * xi[a]))
            })
            .collect()
    }

    /// The whole grid's box.
    pub fn bounding_box(&self) -> Aabb {
        self.block_box([0; 3], self.n)
    }

    /// Nodes per axis for an element order.
    pub fn nodes_per_axis(&self, order: ElementOrder) -> [usize; 3] {
        let p = order.degree();
        self.n.map(|n| p * n + 1)
    }

    pub fn num_nodes(&self, order: ElementOrder) -> usize {
        self.nodes_per_axis(order).iter().product()
    }

    /// Global indices of a cell's nodes, in the element's local order.
    pub fn cell_nodes(&self, order: ElementOrder, c: usize, out: &mut [usize]) {
        let p = order.degree();
        let m = self.nodes_per_axis(order);
        let [i, j, k] = self.cell_ijk(c);
        let mut l = 0;
        for cc in 0..=p {
            for b in 0..=p {
                for a in 0..=p {
                    out[l] = (p * i + a) + m[0] * ((p * j + b) + m[1] * (p * k + cc));
                    l += 1;
                }
            }
        }
    }

    /// The Q1 vertex node at the place of `node` (a node of `order`), when
    /// that node is a cell vertex.
    pub fn vertex_of(&self, order: ElementOrder, node: usize) -> Option<usize> {
        let p = order.degree();
        let m = self.nodes_per_axis(order);
        let ijk = [node % m[0], (node / m[0]) % m[1], node / (m[0] * m[1])];
        if ijk.iter().any(|i| i % p != 0) {
            return None;
        }
        let v = self.nodes_per_axis(ElementOrder::Q1);
        Some(ijk[0] / p + v[0] * (ijk[1] / p + v[1] * (ijk[2] / p)))
    }

    /// Position of a node.
    pub fn node_position(&self, order: ElementOrder, node: usize) -> [f64; 3] {
        let p = order.degree() as f64;
        let m = self.nodes_per_axis(order);
        let ijk = [node % m[0], (node / m[0]) % m[1], node / (m[0] * m[1])];
        [0, 1, 2].map(|i| self.origin[i] + ijk[i] as f64 * self.h / p)
    }

    /// Rough peak memory of a solve on this grid: the cell classes, the dof
    /// maps and a dozen solver vectors of three f64 per node, and the cut-cell
    /// rules (about `6 · 4^L` cut cells of ~100 points of 64 bytes).
    pub fn estimated_bytes(&self, order: ElementOrder) -> u64 {
        let cells = self.num_cells() as u64;
        let nodes = self.num_nodes(order) as u64;
        let cut = 6 * 4u64.pow(self.level);
        cells + nodes * (4 + 12 * 3 * 8) + cut * 100 * 64
    }

    /// An error naming the largest level that fits when the estimate exceeds
    /// `budget_bytes`.
    pub fn check_memory(&self, order: ElementOrder, budget_bytes: u64) -> Result<()> {
        let needed = self.estimated_bytes(order);
        if needed <= budget_bytes {
            return Ok(());
        }
        let mut max_level = 0;
        for l in 0..self.level {
            let g = self.at_level(l);
            if g.estimated_bytes(order) <= budget_bytes {
                max_level = l;
            }
        }
        Err(Error::MemoryBudget {
            level: self.level,
            needed_bytes: needed,
            budget_bytes,
            max_level,
        })
    }

    /// The grid one level down with the same origin: cells of size `2h`,
    /// `⌈n/2⌉` per axis, so that cell `(i, j, k)` of this grid lies in cell
    /// `(i/2, j/2, k/2)` of the coarse one and node `I` of this grid sits at
    /// node `I/2` (the nested hierarchy of [`crate::multigrid`]); `None` at
    /// level 0.
    pub fn coarsened(&self) -> Option<Grid> {
        self.level.checked_sub(1).map(|l| self.at_level(l))
    }

    /// The grid with each cell split in 2×2×2 (the Q2 node lattice's
    /// cells): same origin, half the spacing.
    pub fn refined(&self) -> Grid {
        Grid {
            origin: self.origin,
            h: 0.5 * self.h,
            n: self.n.map(|n| 2 * n),
            level: self.level + 1,
        }
    }

    /// The same box at another level (cell counts scaled by powers of two).
    fn at_level(&self, level: u32) -> Grid {
        let scale = 2f64.powi(self.level as i32 - level as i32);
        Grid {
            origin: self.origin,
            h: self.h * scale,
            n: self.n.map(|n| ((n as f64 / scale).ceil() as usize).max(1)),
            level,
        }
    }
}

/// Peak resident memory of the process in bytes (`VmHWM` of
/// `/proc/self/status`), or 0 where that is not available.
pub fn peak_resident_bytes() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        .map_or(0, |kb| kb * 1024)
}

/// Physical memory of this machine (Linux `/proc/meminfo`), or 16 GiB when it
/// cannot be read: the default memory budget.
pub fn machine_memory_bytes() -> u64 {
    let text = std::fs::read_to_string("/proc/meminfo").unwrap_or_default();
    text.lines()
        .find_map(|l| l.strip_prefix("MemTotal:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        .map(|kb| kb * 1024)
        .unwrap_or(16 << 30)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_boxes_beyond_floating_point_range() {
        // The offset pushes the origin past the largest float.
        let b = Aabb::new([-1.0, -1.7e308, -1.0], [1.0, 1.0, 1.0]);
        let e = Grid::new(&b, 0, [0.5; 3]).unwrap_err();
        assert!(
            matches!(e, Error::InvalidGrid { ref what, .. } if what == "box"),
            "{e}"
        );
        // Cells smaller than the smallest float.
        let b = Aabb::new([0.0; 3], [5e-324; 3]);
        assert!(Grid::new(&b, 3, [0.0; 3]).is_err());
        assert!(Grid::new(&b, 0, [0.0; 3]).is_ok());
    }

    #[test]
    fn level_splits_the_longest_side() {
        let b = Aabb::new([-1.0, -1.0, -0.5], [1.0, 1.0, 0.5]);
        let g = Grid::new(&b, 4, [0.0; 3]).unwrap();
        assert_eq!(g.n, [16, 16, 8]);
        assert_eq!(g.h, 0.125);
        let g = Grid::new(&b, 4, [0.5, 0.0, 0.25]).unwrap();
        assert_eq!(g.n, [17, 16, 9]);
        assert!(g.bounding_box().lo[0] < -1.0 && g.bounding_box().hi[2] >= 0.5);
    }

    #[test]
    fn indices_round_trip_and_cell_nodes_are_lexicographic() {
        let g = Grid::new(&Aabb::new([0.0; 3], [3.0, 2.0, 1.0]), 2, [0.0; 3]).unwrap();
        assert_eq!(g.n, [4, 3, 2]);
        for c in 0..g.num_cells() {
            assert_eq!(g.cell_index(g.cell_ijk(c)), c);
        }
        let c = g.cell_index([1, 2, 1]);
        for order in [ElementOrder::Q1, ElementOrder::Q2] {
            let mut nodes = vec![0; order.nodes_per_cell()];
            g.cell_nodes(order, c, &mut nodes);
            let b = g.cell_box(c);
            let first = g.node_position(order, nodes[0]);
            let last = g.node_position(order, nodes[nodes.len() - 1]);
            for i in 0..3 {
                assert!((first[i] - b.lo[i]).abs() < 1e-15 && (last[i] - b.hi[i]).abs() < 1e-15);
            }
            assert!(nodes.windows(2).all(|w| w[0] < w[1]));
        }
    }

    #[test]
    fn bad_grids_are_typed_errors() {
        let b = Aabb::new([0.0; 3], [1.0; 3]);
        assert!(matches!(
            Grid::new(&b, 13, [0.0; 3]),
            Err(Error::InvalidGrid { .. })
        ));
        assert!(matches!(
            Grid::new(&b, 3, [1.0, 0.0, 0.0]),
            Err(Error::InvalidGrid { .. })
        ));
        assert!(matches!(
            Grid::new(&Aabb::EVERYTHING, 3, [0.0; 3]),
            Err(Error::InvalidGrid { .. })
        ));
        let g = Grid::new(&b, 9, [0.0; 3]).unwrap();
        match g.check_memory(ElementOrder::Q1, 1 << 30) {
            Err(Error::MemoryBudget { max_level, .. }) => {
                assert!(max_level < 9);
                let ok = Grid::new(&b, max_level, [0.0; 3]).unwrap();
                assert!(ok.check_memory(ElementOrder::Q1, 1 << 30).is_ok());
                let over = Grid::new(&b, max_level + 1, [0.0; 3]).unwrap();
                assert!(over.check_memory(ElementOrder::Q1, 1 << 30).is_err());
            }
            other => panic!("expected a memory error, got {other:?}"),
        }
    }
}
