//! The rigid-body part of the S-term's residual, removed so that the S-term
//! puts no net force or moment on the body.
//!
//! The S-term adds `K_S U − F_S(U)`, tested with `v`,
//!
//! ```text
//! (k2 E / h²) ∫_{Ω*} v · (u_h − S(u_h)) dV,
//! ```
//! to the equations. For a rigid motion `v = R(x) a` (`R` the 3 × 6 matrix of
//! the three translations and three rotations) the strain energy and the
//! loads cancel against the reactions, so this integral is the net force and
//! moment that the S-term exerts on the body. It vanishes when `S(u_h) = u_h`
//! (the polynomial fields of the patch tests) but not in general: on a coarse
//! bracket it is up to 46 % of the applied load, and the reaction of the
//! clamped part then misses the load by that much (measured in
//! `tests/suite/runs/robustness_runs.rs`).
//!
//! The cure keeps `A` (and so the conditioning the S-term exists for) and
//! consistency: `F_S` is evaluated with `S(u_h) + R(x) a` instead of
//! `S(u_h)`, where `R a` is the `L²(Ω*)` projection of `u_h − S(u_h)` onto
//! the rigid motions,
//!
//! ```text
//! G a = m,   G = ∫_{Ω*} Rᵀ R dV,   m = ∫_{Ω*} Rᵀ (u_h − S(u_h)) dV,
//! ```
//! so that `∫_{Ω*} Rᵀ (u_h − S − R a) = 0`: the S-term's residual is
//! self-equilibrated. Both integrals use the whole-cell Gauss rule of `F_S`,
//! which integrates `v · u_h` and `v · R a` exactly for the element's `v`, so
//! the balance holds to round-off. When `S(u_h) = u_h`, `a = 0` and nothing
//! changes. The projection is over the whole of Ω* of each piece of the body
//! (`crate::cells::pieces`): pieces that share no node are balanced apart.
//!
//! The price is in the outer iteration: the S-term no longer resists a
//! common rigid motion of the pathological cells' nodes against the smooth
//! extension, six modes that the outer Krylov method must find. Measured on
//! rotated coarse brackets (`tests/suite/runs/robustness_runs.rs`, seed 20261123):
//! - one projection per cell (each cell's residual self-equilibrated) takes
//!   that resistance from every cell's six modes: 37 of 120 runs then missed
//!   the 50 outer iterations (none with the paper's `F_S`);
//! - one projection over Ω* with the FGMRES restarted every 10 directions:
//!   13 of 120; restarted every 20: none, in at most 41 iterations (the
//!   cycle is now longer where memory allows, `crate::driver::outer_krylov`);
//! - a level-6 bracket at half scale (1 991 pathological cells): 56 outer
//!   iterations with the paper's `F_S`, 95 with this one (its reaction
//!   differs by 1.9 %), hence the default budget of 200.

use nalgebra::{Matrix6, Vector6};

use crate::exact::ExactSum;

/// Accumulates `G` and `m` of the projection, with the rotations about the
/// point `x0` scaled by `1/len` (the centroid of Ω* and the cell size keep
/// `G` well conditioned). The cells' contributions are added exactly
/// ([`ExactSum`]), so the fit does not depend on the order of the cells or
/// on how ranks share them.
pub struct RigidFit {
    x0: [f64; 3],
    len: f64,
    /// `G` (row by row) then `m`.
    sums: Vec<ExactSum>,
}

impl RigidFit {
    /// Numbers in `G` and `m`.
    pub const SUMS: usize = 36 + 6;

    /// An empty fit about `x0` with length scale `len`.
    pub fn about(x0: [f64; 3], len: f64) -> RigidFit {
        RigidFit {
            x0,
            len,
            sums: vec![ExactSum::new(); Self::SUMS],
        }
    }

    /// `R(x)`: column `k < 3` the translation `e_k`, column `3 + k` the
    /// rotation `e_k × (x − x0) / len`.
    pub fn basis(&self, x: [f64; 3]) -> [[f64; 6]; 3] {
        let r = [0, 1, 2].map(|a| (x[a] - self.x0[a]) / self.len);
        [
            [1.0, 0.0, 0.0, 0.0, r[2], -r[1]],
            [0.0, 1.0, 0.0, -r[2], 0.0, r[0]],
            [0.0, 0.0, 1.0, r[1], -r[0], 0.0],
        ]
    }

    /// Adds the points of one cell, each `(x, w, d)`: the point `x` of
    /// weight `w` with the value `d` (`u_h − S` there). The cell's sums are
    /// taken in the order given, then added to the fit exactly.
    pub fn add_cell(&mut self, points: &[([f64; 3], f64, [f64; 3])]) {
        let mut cell = [0.0; Self::SUMS];
        for &(x, w, d) in points {
            let r = self.basis(x);
            for i in 0..6 {
                for j in 0..6 {
                    cell[6 * i + j] += w * (0..3).map(|c| r[c][i] * r[c][j]).sum::<f64>();
                }
                cell[36 + i] += w * (0..3).map(|c| r[c][i] * d[c]).sum::<f64>();
            }
        }
        for (sum, v) in self.sums.iter_mut().zip(cell) {
            sum.add(v);
        }
    }

    /// The exact sums of `G` and `m`, [`RigidFit::SUMS`] of them (for
    /// adding up the fits of several ranks).
    pub fn sums(&self) -> &[ExactSum] {
        &self.sums
    }

    /// Replaces the sums by `sums` (as [`RigidFit::sums`] gives them).
    pub fn set_sums(&mut self, sums: &[ExactSum]) {
        self.sums.clone_from_slice(sums);
    }

    /// The coefficients `a = G⁻¹ m` (zero when `G` is singular: no points).
    pub fn solve(&self) -> [f64; 6] {
        let g = Matrix6::from_fn(|i, j| self.sums[6 * i + j].value());
        let m = Vector6::from_fn(|i, _| self.sums[36 + i].value());
        match g.cholesky() {
            Some(ch) => {
                let a = ch.solve(&m);
                [0, 1, 2, 3, 4, 5].map(|i| a[i])
            }
            None => [0.0; 6],
        }
    }

    /// `R(x) a`.
    pub fn value(&self, x: [f64; 3], a: &[f64; 6]) -> [f64; 3] {
        let r = self.basis(x);
        [0, 1, 2].map(|c| (0..6).map(|k| r[c][k] * a[k]).sum())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rigid field is projected onto itself; `u − R a` then has no
    /// moments against the rigid basis.
    #[test]
    fn projects_a_rigid_motion_onto_itself() {
        let pts: Vec<([f64; 3], f64)> = (0..40)
            .map(|i| {
                let t = i as f64;
                (
                    [t.sin() * 3.0, (1.3 * t).cos(), 0.1 * t],
                    0.5 + (t * 0.7).sin().abs(),
                )
            })
            .collect();
        let mut fit = RigidFit::about([0.5, 0.0, 2.0], 3.0);
        let a_true = [0.3, -1.2, 2.0, 0.7, -0.4, 1.1];
        let points: Vec<_> = pts
            .iter()
            .map(|&(x, w)| (x, w, fit.value(x, &a_true)))
            .collect();
        // In two "cells", one of them empty.
        fit.add_cell(&points[..17]);
        fit.add_cell(&[]);
        fit.add_cell(&points[17..]);
        let a = fit.solve();
        for k in 0..6 {
            assert!((a[k] - a_true[k]).abs() < 1e-12, "{a:?}");
        }
    }
}
