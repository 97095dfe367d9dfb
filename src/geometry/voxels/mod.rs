//! Voxel images as level sets: the trilinear interpolant of an image's
//! values minus an iso-value, its exact range over a box, and the min/max
//! pyramid that bounds it over large boxes.
//!
//! The image's sample `(i, j, k)` sits at the local point
//! `(i dx, j dy, k dz)` (sample-centred, as NRRD's `space origin` means it);
//! the leaf's frame places it. The level set at the samples is
//! `ψ = κ (t − v)` when the solid is where the value `v` is above the
//! threshold `t`, `κ (v − t)` when it is below, so ψ is negative inside as
//! for every leaf; `κ > 0` makes `|∇ψ| ≈ 1` on the zero set on average
//! (the mean over the voxel cells the surface crosses), which moves no
//! boundary. The image is padded by one layer of samples on every side
//! whose value is *outside* (`ψ = ψ_out > 0`), and ψ is `ψ_out` beyond the
//! padding: a body that touches the image's edge is closed there, within
//! one voxel.
//!
//! Between samples ψ is trilinear in each voxel cell: continuous, with a
//! gradient that jumps across the cells' faces. Over a box the range of a
//! multilinear function is attained at the corners of the box's pieces, so
//! [`Voxels::range`] is exact for boxes of a few voxels, and bounded by the
//! min/max of the samples the box touches (a pyramid of block min/max) for
//! larger ones; [`Voxels::slope_range`] gives the cells' gradients' exact
//! ranges the same way. A [`super::scalar::Dual`] takes the chain rule on
//! those (tight where the cells' polynomials in dual form are not); other
//! scalars evaluate each cell's polynomial on the part of the box in it and
//! take the hull ([`Voxels::piecewise`]): a [`super::scalar::Dual2`]'s
//! Hessian is the cells' (the gradient's jumps across faces are not in it,
//! so no second-order bound is built on it; see
//! [`super::surface::Leaf::bounds`]).

mod cells;
mod smooth;

pub use smooth::gaussian;

use super::scalar::{Interval, Scalar};
use crate::error::{Error, Result};
use smooth::mean_slope;

/// Which side of the threshold is material.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Inside {
    /// Values above the threshold (bright material on a dark background).
    Above,
    /// Values below the threshold.
    Below,
}

/// Largest number of breakpoint tuples [`Voxels::range`] evaluates exactly
/// before it falls back on the pyramid.
const EXACT_POINTS: usize = 512;

/// A voxel image as a level set (see the module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct Voxels {
    /// Padded sample counts: the image's plus two on each axis.
    n: [usize; 3],
    spacing: [f64; 3],
    /// ψ at the padded samples, x fastest.
    phi: Vec<f64>,
    /// ψ beyond the image.
    outside: f64,
    /// κ: ψ per unit of image value.
    scale: f64,
    /// `pyramid[k − 1]`: min/max of ψ over the samples
    /// `b 2ᵏ ..= (b + 1) 2ᵏ` per axis.
    pyramid: Vec<Block>,
    /// The largest `|ψ(s + e_a) − ψ(s)|` along each axis.
    slopes: [f64; 3],
}

/// One level of the min/max pyramid.
#[derive(Clone, Debug, PartialEq)]
struct Block {
    n: [usize; 3],
    lo: Vec<f64>,
    hi: Vec<f64>,
}

fn checked_len(size: [usize; 3]) -> Option<usize> {
    size[0].checked_mul(size[1])?.checked_mul(size[2])
}

impl Voxels {
    /// The level set of the image `values` (`size` samples, x fastest, with
    /// `spacing` between samples) at the iso-value `threshold`. An error
    /// when a size is below 2, the values do not match the size or are not
    /// finite, the spacing is not positive, or the threshold does not lie
    /// strictly between the smallest and the largest value (the solid would
    /// be empty, or the whole box).
    pub fn new(
        size: [usize; 3],
        values: &[f64],
        spacing: [f64; 3],
        threshold: f64,
        inside: Inside,
    ) -> Result<Voxels> {
        let bad = |reason: String| Error::InvalidGeometry {
            what: "image".into(),
            reason,
        };
        if size.iter().any(|&s| s < 2) {
            return Err(bad(format!(
                "needs at least 2 samples per axis, got {size:?}"
            )));
        }
        if checked_len(size) != Some(values.len()) {
            return Err(bad(format!("{} values for {size:?} samples", values.len())));
        }
        if !spacing.iter().all(|s| s.is_finite() && *s > 0.0) {
            return Err(bad(format!("spacing must be positive, got {spacing:?}")));
        }
        if let Some(v) = values.iter().find(|v| !v.is_finite()) {
            return Err(bad(format!("holds the value {v}, which is not finite")));
        }
        let (vmin, vmax) = values
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        if !(threshold > vmin && threshold < vmax) {
            let what = match (threshold <= vmin, inside) {
                (true, Inside::Above) | (false, Inside::Below) => "the whole image",
                _ => "empty",
            };
            return Err(bad(format!(
                "threshold {threshold} is outside the values' range ({vmin}, {vmax}): the solid would be {what}"
            )));
        }
        let sign = match inside {
            Inside::Above => -1.0,
            Inside::Below => 1.0,
        };
        let raw = |v: f64| sign * (v - threshold);
        let scale = 1.0 / mean_slope(size, values, spacing, threshold);
        let n = size.map(|s| s + 2);
        let outside = (scale * (vmax - vmin)).max(spacing.iter().copied().fold(0.0, f64::max));
        let mut phi = vec![outside; n[0] * n[1] * n[2]];
        for k in 0..size[2] {
            for j in 0..size[1] {
                for i in 0..size[0] {
                    let v = values[i + size[0] * (j + size[1] * k)];
                    phi[(i + 1) + n[0] * ((j + 1) + n[1] * (k + 1))] = scale * raw(v);
                }
            }
        }
        let mut slopes = [0.0f64; 3];
        for k in 0..n[2] {
            for j in 0..n[1] {
                for i in 0..n[0] {
                    let s = [i, j, k];
                    let here = phi[i + n[0] * (j + n[1] * k)];
                    for a in 0..3 {
                        if s[a] + 1 < n[a] {
                            let mut t = s;
                            t[a] += 1;
                            let d = (phi[t[0] + n[0] * (t[1] + n[1] * t[2])] - here).abs();
                            slopes[a] = slopes[a].max(d);
                        }
                    }
                }
            }
        }
        let mut v = Voxels {
            n,
            spacing,
            phi,
            outside,
            scale,
            pyramid: Vec::new(),
            slopes,
        };
        v.build_pyramid();
        Ok(v)
    }

    fn build_pyramid(&mut self) {
        let n = self.n;
        let mut k = 1;
        loop {
            let nb = n.map(|m| ((m - 1) >> k) + 1);
            let len = nb[0] * nb[1] * nb[2];
            let (mut lo, mut hi) = (vec![f64::INFINITY; len], vec![f64::NEG_INFINITY; len]);
            for c in 0..nb[2] {
                for b in 0..nb[1] {
                    for a in 0..nb[0] {
                        let blk = [a, b, c];
                        let (l, h) = if k == 1 {
                            let r = blk.map(|x| (2 * x, 2 * x + 2));
                            self.node_range(r)
                        } else {
                            self.block_range(k - 1, blk.map(|x| (2 * x, 2 * x + 1)))
                        };
                        let at = a + nb[0] * (b + nb[1] * c);
                        lo[at] = l;
                        hi[at] = h;
                    }
                }
            }
            self.pyramid.push(Block { n: nb, lo, hi });
            if nb.iter().all(|&m| m <= 1) {
                break;
            }
            k += 1;
        }
    }

    /// Min/max of ψ at the samples `r[a].0 ..= r[a].1` (clamped to the image).
    fn node_range(&self, r: [(usize, usize); 3]) -> (f64, f64) {
        let n = self.n;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for k in r[2].0..=r[2].1.min(n[2] - 1) {
            for j in r[1].0..=r[1].1.min(n[1] - 1) {
                for i in r[0].0..=r[0].1.min(n[0] - 1) {
                    let v = self.phi[i + n[0] * (j + n[1] * k)];
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
        }
        (lo, hi)
    }

    /// Min/max over the blocks `r` of pyramid level `k` (clamped).
    fn block_range(&self, k: usize, r: [(usize, usize); 3]) -> (f64, f64) {
        let b = &self.pyramid[k - 1];
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for z in r[2].0..=r[2].1.min(b.n[2] - 1) {
            for y in r[1].0..=r[1].1.min(b.n[1] - 1) {
                for x in r[0].0..=r[0].1.min(b.n[0] - 1) {
                    let at = x + b.n[0] * (y + b.n[1] * z);
                    lo = lo.min(b.lo[at]);
                    hi = hi.max(b.hi[at]);
                }
            }
        }
        (lo, hi)
    }

    /// The image's sample counts (without the padding).
    pub fn size(&self) -> [usize; 3] {
        self.n.map(|m| m - 2)
    }

    /// The distance between samples along each axis.
    pub fn spacing(&self) -> [f64; 3] {
        self.spacing
    }

    /// κ: ψ per unit of image value.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// The padded voxel coordinates of the local point `p`.
    pub fn coords<T: Scalar>(&self, p: [T; 3]) -> [T; 3] {
        [0, 1, 2].map(|a| p[a].scale(1.0 / self.spacing[a]) + T::cst(1.0))
    }

    /// A box (local coordinates) around the samples where ψ < 0, one
    /// voxel wider on each side (the padding's ramp is in it).
    pub fn material_box(&self) -> ([f64; 3], [f64; 3]) {
        let n = self.n;
        let (mut lo, mut hi) = ([usize::MAX; 3], [0usize; 3]);
        for k in 0..n[2] {
            for j in 0..n[1] {
                for i in 0..n[0] {
                    if self.phi[i + n[0] * (j + n[1] * k)] < 0.0 {
                        for (a, s) in [i, j, k].into_iter().enumerate() {
                            lo[a] = lo[a].min(s);
                            hi[a] = hi[a].max(s);
                        }
                    }
                }
            }
        }
        // Padded index s is at the local coordinate (s − 1) spacing.
        (
            [0, 1, 2].map(|a| (lo[a] as f64 - 2.0) * self.spacing[a]),
            [0, 1, 2].map(|a| hi[a] as f64 * self.spacing[a]),
        )
    }

    pub(super) fn at(&self, i: usize, j: usize, k: usize) -> f64 {
        self.phi[i + self.n[0] * (j + self.n[1] * k)]
    }

    /// The cell holding `u` on one axis (the lower one on a face) and the
    /// offset in it.
    fn cell_of(&self, a: usize, u: f64) -> (usize, f64) {
        let c = (u.floor() as usize).min(self.n[a] - 2);
        (c, u - c as f64)
    }

    /// ψ at the padded voxel coordinates `u`.
    pub fn value(&self, u: [f64; 3]) -> f64 {
        if (0..3).any(|a| !(u[a] >= 0.0 && u[a] <= (self.n[a] - 1) as f64)) {
            return self.outside;
        }
        let (i, t0) = self.cell_of(0, u[0]);
        let (j, t1) = self.cell_of(1, u[1]);
        let (k, t2) = self.cell_of(2, u[2]);
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let face = |k: usize| {
            lerp(
                lerp(self.at(i, j, k), self.at(i + 1, j, k), t0),
                lerp(self.at(i, j + 1, k), self.at(i + 1, j + 1, k), t0),
                t1,
            )
        };
        lerp(face(k), face(k + 1), t2)
    }

    /// The cells met by the box `r` of voxel coordinates per axis (`None`
    /// when the box misses the padded image on some axis), and whether the
    /// box reaches beyond it.
    pub(super) fn cells_met(&self, r: [(f64, f64); 3]) -> (Option<[(usize, usize); 3]>, bool) {
        let top = |a: usize| (self.n[a] - 1) as f64;
        let beyond = (0..3).any(|a| !(r[a].0 >= 0.0 && r[a].1 <= top(a)));
        if (0..3).any(|a| !(r[a].1 >= 0.0 && r[a].0 <= top(a))) {
            return (None, true);
        }
        let cells = [0, 1, 2].map(|a| {
            let lo = r[a].0.max(0.0);
            let hi = r[a].1.min(top(a));
            (self.cell_of(a, lo).0, self.cell_of(a, hi).0)
        });
        (Some(cells), beyond)
    }

    /// The number of voxel cells the box `r` meets.
    pub fn cell_count(&self, r: [(f64, f64); 3]) -> usize {
        match self.cells_met(r).0 {
            Some(c) => (0..3).map(|a| c[a].1 - c[a].0 + 1).product(),
            None => 0,
        }
    }

    /// The exact range of ψ over the box `r` (voxel coordinates), or an
    /// enclosure from the pyramid when the box spans many cells.
    pub fn range(&self, r: [(f64, f64); 3]) -> Interval {
        let (cells, beyond) = self.cells_met(r);
        let mut out = if beyond {
            Interval::new(self.outside, self.outside)
        } else {
            Interval::new(f64::INFINITY, f64::NEG_INFINITY)
        };
        let Some(cells) = cells else {
            return out;
        };
        let top = |a: usize| (self.n[a] - 1) as f64;
        let clamped = [0, 1, 2].map(|a| (r[a].0.max(0.0), r[a].1.min(top(a))));
        // Per axis: the box's ends and the sample planes between them.
        let breaks = clamped.map(|(lo, hi)| {
            let mut b = vec![lo];
            let mut s = lo.floor() + 1.0;
            while s < hi && b.len() <= EXACT_POINTS {
                b.push(s);
                s += 1.0;
            }
            b.push(hi);
            b
        });
        let points = breaks.iter().map(Vec::len).product::<usize>();
        if points <= EXACT_POINTS {
            for &z in &breaks[2] {
                for &y in &breaks[1] {
                    for &x in &breaks[0] {
                        let v = self.value([x, y, z]);
                        out = Interval::new(out.lo.min(v), out.hi.max(v));
                    }
                }
            }
            return out;
        }
        // The samples of the cells met: a pyramid level with a few blocks.
        let nodes = cells.map(|(a, b)| (a, b + 1));
        let mut k = 0;
        while k < self.pyramid.len() && nodes.iter().any(|&(a, b)| (b >> k) - (a >> k) >= 4) {
            k += 1;
        }
        let (lo, hi) = if k == 0 {
            self.node_range(nodes)
        } else {
            self.block_range(k, nodes.map(|(a, b)| (a >> k, b >> k)))
        };
        Interval::new(out.lo.min(lo), out.hi.max(hi))
    }

    /// Bounds of `∂ψ/∂u_a` anywhere: the largest sample difference.
    pub fn slope_bounds(&self) -> [f64; 3] {
        self.slopes
    }
}

#[cfg(test)]
mod tests;
