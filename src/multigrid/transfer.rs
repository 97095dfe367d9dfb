//! The grid transfers of the hierarchy: trilinear prolongation `P` from a
//! coarse nodal lattice to the nested fine one, and restriction `R = Pᵀ`,
//! both matrix-free over the active nodes, three components per node.
//!
//! # Nesting
//! Fine lattice node `I = (I₀, I₁, I₂)` sits at coarse lattice coordinate
//! `I/2`. That holds for the h-step (a Q1 grid and its 2×2×2 coarsening,
//! [`crate::grid::Grid::coarsened`]) and for the p-step (the Q2 lattice of a
//! grid, `2n + 1` nodes per axis, above the Q1 lattice of the same grid). Along
//! one axis the trilinear (Q1) interpolant gives the weights
//!
//! ```text
//! w(I, i) = 1    if I = 2i,
//!           1/2  if |I − 2i| = 1,
//!           0    otherwise,
//! ```
//! and `P[(I, c), (i, c)] = w(I₀, i₀) w(I₁, i₁) w(I₂, i₂)` for each component
//! `c`: the exact interpolant of a coarse trilinear field (and of a Q1 field on
//! the Q2 lattice, since Q1 ⊂ Q2).
//!
//! # Active nodes
//! Unknowns live on active nodes only ([`crate::discrete::dofs`]). A row of `P` for
//! a fine active node keeps the coarse nodes that are active; a coarse node
//! that is not (its coarse cells all classified outside, which only happens
//! for slivers at the round-off level) contributes nothing. `R` applies the
//! same weights with the same filter from the coarse side, so `R = Pᵀ`
//! exactly whatever the classification.
//!
//! Both are gathers (every output node reads its up-to-8 or up-to-27 inputs),
//! written as explicit index loops over the lattice so that a WGSL kernel can
//! mirror them one thread per output node, with no atomics.
//!
//! # Copies
//! A fine node's copies ([`crate::cells::split`]) interpolate the coarse
//! field as the node does (the coarse levels do not split), and `R`
//! gathers their residuals with the node's weights, so `R = Pᵀ` still.

use rayon::prelude::*;

use crate::discrete::dofs::DofMap;

/// Nodes per rayon task.
const NODES_PER_TASK: usize = 256;

/// An inactive node in [`DofMap::node_to_active`].
const INACTIVE: u32 = u32::MAX;

/// One side of a transfer: a nodal lattice and its active nodes.
#[derive(Clone, Copy)]
pub struct Lattice<'a> {
    /// Nodes per axis.
    pub dims: [usize; 3],
    pub dofs: &'a DofMap,
}

impl Lattice<'_> {
    fn ijk(&self, node: usize) -> [usize; 3] {
        let m = self.dims;
        [node % m[0], (node / m[0]) % m[1], node / (m[0] * m[1])]
    }

    fn active(&self, ijk: [usize; 3]) -> u32 {
        let m = self.dims;
        self.dofs.node_to_active[ijk[0] + m[0] * (ijk[1] + m[1] * ijk[2])]
    }
}

/// The trilinear transfer between a fine lattice and the coarse one under it.
#[derive(Clone, Copy)]
pub struct Transfer<'a> {
    pub fine: Lattice<'a>,
    pub coarse: Lattice<'a>,
}

/// The coarse indices along one axis that fine index `i` interpolates from,
/// with their weights `w(i, ·)`: one at weight 1 (`i` even) or two at 1/2.
fn from_coarse(i: usize) -> ([(usize, f64); 2], usize) {
    if i.is_multiple_of(2) {
        ([(i / 2, 1.0), (0, 0.0)], 1)
    } else {
        ([(i / 2, 0.5), (i / 2 + 1, 0.5)], 2)
    }
}

/// The fine indices `< m` along one axis that coarse index `i` feeds, with
/// their weights `w(·, i)`: `2i − 1`, `2i`, `2i + 1` at 1/2, 1, 1/2.
fn to_fine(i: usize, m: usize) -> ([(usize, f64); 3], usize) {
    let mut out = [(0, 0.0); 3];
    let mut n = 0;
    let candidates = [(2 * i).checked_sub(1), Some(2 * i), Some(2 * i + 1)];
    for (f, w) in candidates.into_iter().zip([0.5, 1.0, 0.5]) {
        if let Some(f) = f.filter(|&f| f < m) {
            out[n] = (f, w);
            n += 1;
        }
    }
    (out, n)
}

impl Transfer<'_> {
    /// `xf = xf + P xc`.
    pub fn prolong_add(&self, xc: &[f64], xf: &mut [f64]) {
        assert_eq!(xc.len(), self.coarse.dofs.ndofs(), "prolong: coarse size");
        assert_eq!(xf.len(), self.fine.dofs.ndofs(), "prolong: fine size");
        xf.par_chunks_mut(3)
            .enumerate()
            .with_min_len(NODES_PER_TASK)
            .for_each(|(a, yn)| {
                let node = self.fine.dofs.active_to_node[a] as usize;
                self.for_coarse_of(node, |c, w| {
                    for (y, x) in yn.iter_mut().zip(&xc[3 * c..3 * c + 3]) {
                        *y += w * x;
                    }
                });
            });
    }

    /// `xc = Pᵀ xf` (overwrites `xc`).
    pub fn restrict(&self, xf: &[f64], xc: &mut [f64]) {
        assert_eq!(xc.len(), self.coarse.dofs.ndofs(), "restrict: coarse size");
        assert_eq!(xf.len(), self.fine.dofs.ndofs(), "restrict: fine size");
        let m = self.fine.dims;
        xc.par_chunks_mut(3)
            .enumerate()
            .with_min_len(NODES_PER_TASK)
            .for_each(|(a, yn)| {
                yn.fill(0.0);
                let node = self.coarse.dofs.active_to_node[a] as usize;
                let [i, j, k] = self.coarse.ijk(node);
                let (wi, ni) = to_fine(i, m[0]);
                let (wj, nj) = to_fine(j, m[1]);
                let (wk, nk) = to_fine(k, m[2]);
                for &(fk, vk) in &wk[..nk] {
                    for &(fj, vj) in &wj[..nj] {
                        for &(fi, vi) in &wi[..ni] {
                            let f = self.fine.active([fi, fj, fk]);
                            if f == INACTIVE {
                                continue;
                            }
                            let (w, f) = (vi * vj * vk, 3 * f as usize);
                            for (y, x) in yn.iter_mut().zip(&xf[f..f + 3]) {
                                *y += w * x;
                            }
                        }
                    }
                }
            });
        self.restrict_copies(xf, xc);
    }

    /// `xc += P_copiesᵀ xf`: the copies' part of `R`, scattered (they are
    /// few, and only the CPU splits cells).
    fn restrict_copies(&self, xf: &[f64], xc: &mut [f64]) {
        for (a, node) in self.fine.dofs.copies() {
            self.for_coarse_of(node, |c, w| {
                for d in 0..3 {
                    xc[3 * c + d] += w * xf[3 * a + d];
                }
            });
        }
    }

    /// Calls `f(c, w)` for the active coarse nodes `c` that fine lattice
    /// node `node` interpolates from, with their weights `w`: row `node` of
    /// `P`.
    fn for_coarse_of(&self, node: usize, mut f: impl FnMut(usize, f64)) {
        let [i, j, k] = self.fine.ijk(node);
        let (wi, ni) = from_coarse(i);
        let (wj, nj) = from_coarse(j);
        let (wk, nk) = from_coarse(k);
        for &(ck, vk) in &wk[..nk] {
            for &(cj, vj) in &wj[..nj] {
                for &(ci, vi) in &wi[..ni] {
                    let c = self.coarse.active([ci, cj, ck]);
                    if c != INACTIVE {
                        f(c as usize, vi * vj * vk);
                    }
                }
            }
        }
    }
}
