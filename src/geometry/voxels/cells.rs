//! The voxel cells' polynomials over a box: ψ and its slopes in any scalar
//! (each met cell's polynomial on the box's piece in it, hulled), and the
//! exact ranges of the slopes.

use super::Voxels;
use crate::geometry::scalar::{Interval, Scalar};

impl Voxels {
    /// ψ at `u` in any scalar: each met cell's trilinear polynomial on the
    /// part of `u` in it, and ψ_out beyond the image, hulled.
    pub fn piecewise<T: Scalar>(&self, u: [T; 3]) -> T {
        self.hull_over_cells(
            u,
            T::cst(self.outside),
            |c, t| self.cell_polynomial(c, t),
            T::hull,
        )
    }

    /// `∂ψ/∂u_a` at `u` in any scalar: each met cell's bilinear slope
    /// polynomials on the part of `u` in it, and 0 beyond the image,
    /// hulled.
    pub fn piecewise_slopes<T: Scalar>(&self, u: [T; 3]) -> [T; 3] {
        let slopes = |c: [usize; 3], t: [T; 3]| {
            [0, 1, 2].map(|a| {
                let (b, d) = ((a + 1) % 3, (a + 2) % 3);
                let [d00, d10, d01, d11] = self.slope_differences(c, a);
                let e0 = t[b].scale(d10 - d00) + T::cst(d00);
                let e1 = t[b].scale(d11 - d01) + T::cst(d01);
                e0 + t[d] * (e1 - e0)
            })
        };
        let hull = |x: [T; 3], y: [T; 3]| [0, 1, 2].map(|a| x[a].hull(y[a]));
        self.hull_over_cells(u, [T::cst(0.0); 3], slopes, hull)
    }

    /// `eval(c, t)` of every cell `c` that `u` meets, with `t` the part of
    /// `u` in it as offsets in [0, 1], and `beyond` where `u` reaches past
    /// the image, hulled.
    fn hull_over_cells<T: Scalar, V>(
        &self,
        u: [T; 3],
        beyond: V,
        eval: impl Fn([usize; 3], [T; 3]) -> V,
        hull: impl Fn(V, V) -> V,
    ) -> V {
        let (cells, reaches_beyond) = self.cells_met(u.map(|x| x.range()));
        let mut acc = reaches_beyond.then_some(beyond);
        if let Some(cells) = cells {
            for_each_cell(cells, |c| {
                let t = [0, 1, 2].map(|a| {
                    let lo = c[a] as f64;
                    u[a].restrict(lo, lo + 1.0) - T::cst(lo)
                });
                let v = eval(c, t);
                acc = Some(match acc.take() {
                    Some(a) => hull(a, v),
                    None => v,
                });
            });
        }
        acc.expect("a box meets a cell or reaches beyond the image")
    }

    /// The sample differences along `a` at the four edges of cell `c`
    /// along `a`: `[d00, d10, d01, d11]`, the second index along `a + 1`,
    /// the third along `a + 2` (mod 3).
    fn slope_differences(&self, c: [usize; 3], a: usize) -> [f64; 4] {
        let (b, d) = ((a + 1) % 3, (a + 2) % 3);
        [(0, 0), (1, 0), (0, 1), (1, 1)].map(|(sb, sd)| {
            let mut p = c;
            p[b] += sb;
            p[d] += sd;
            let mut q = p;
            q[a] += 1;
            self.at(q[0], q[1], q[2]) - self.at(p[0], p[1], p[2])
        })
    }

    /// The trilinear polynomial of cell `c` at the offsets `t`.
    fn cell_polynomial<T: Scalar>(&self, c: [usize; 3], t: [T; 3]) -> T {
        let [i, j, k] = c;
        let edge = |j: usize, k: usize| {
            let a = self.at(i, j, k);
            t[0].scale(self.at(i + 1, j, k) - a) + T::cst(a)
        };
        let face = |k: usize| {
            let (a, b) = (edge(j, k), edge(j + 1, k));
            a + t[1] * (b - a)
        };
        let (a, b) = (face(k), face(k + 1));
        a + t[2] * (b - a)
    }

    /// The exact range of each `∂ψ/∂u_a` over the box `r` (voxel
    /// coordinates): in each cell met, `∂ψ/∂u_a` is the bilinear
    /// interpolant of the sample differences along `a` in the other two
    /// coordinates, whose extremes are at the corners of the box's piece.
    /// Beyond the image ψ is constant (a zero slope).
    pub fn slope_range(&self, r: [(f64, f64); 3]) -> [Interval; 3] {
        let (cells, beyond) = self.cells_met(r);
        let start = if beyond {
            Interval::cst(0.0)
        } else {
            Interval::new(f64::INFINITY, f64::NEG_INFINITY)
        };
        let mut out = [start; 3];
        let Some(cells) = cells else {
            return out;
        };
        for_each_cell(cells, |c| {
            // The box's piece in this cell, as offsets in [0, 1].
            let t = [0, 1, 2].map(|a| {
                let lo = c[a] as f64;
                ((r[a].0 - lo).clamp(0.0, 1.0), (r[a].1 - lo).clamp(0.0, 1.0))
            });
            for (a, o) in out.iter_mut().enumerate() {
                let (b, d) = ((a + 1) % 3, (a + 2) % 3);
                let [d00, d10, d01, d11] = self.slope_differences(c, a);
                for tb in [t[b].0, t[b].1] {
                    for td in [t[d].0, t[d].1] {
                        let e0 = d00 + (d10 - d00) * tb;
                        let e1 = d01 + (d11 - d01) * tb;
                        let v = e0 + (e1 - e0) * td;
                        *o = Interval::new(o.lo.min(v), o.hi.max(v));
                    }
                }
            }
        });
        out
    }
}

/// Calls `f` on every cell `[i, j, k]` of the inclusive index ranges `cells`.
fn for_each_cell(cells: [(usize, usize); 3], mut f: impl FnMut([usize; 3])) {
    for k in cells[2].0..=cells[2].1 {
        for j in cells[1].0..=cells[1].1 {
            for i in cells[0].0..=cells[0].1 {
                f([i, j, k]);
            }
        }
    }
}
