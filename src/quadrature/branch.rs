//! Points per segment in the lower dimensions of a volume sweep, raised where
//! the height function's branch point is close to the box.
//!
//! # Why
//! Saye's lower-dimensional integrands are built from height functions, which
//! have square-root branch points where the surface turns parallel to the
//! height direction `k`. The height-direction test only guarantees that they
//! lie outside the box: on a surface of curvature radius `R` a box whose axis
//! has [`super::saye`]'s quality `Q = min |∂ψ/∂x_k| / max |∇ψ|` has its branch
//! point at about `Q² R / 2` beyond it. A `q`-point Gauss rule on a segment of
//! length `s` with a singularity at distance `d s` beyond its end converges
//! like `E(d)^(−2q)`, `E(t) = 1 + 2t + 2√(t + t²)` (the Bernstein ellipse
//! through the singularity). While `s` is not small against `Q² R / 2`, that
//! is, while the cells are not small against the curvature radius, the error
//! per box does not fall with `h`: the relative volume error of a part with a
//! hole of radius 0.35 sits at 1e-6 (q = 2) from level 2 to level 5 before it
//! converges at 4th order (`docs/volume-floor-findings.md`).
//!
//! # The rule
//! From the interval bounds of `∇ψ` over the box (size `s`, the cell's edge
//! `h`) take, per curved leaf, the curvature radius in box lengths
//! `ρ = max |∇ψ| / width(∇ψ)` and the branch distance in box lengths
//! `δ = min |∂ψ/∂x_k|² / (2 max |∇ψ| width(∇ψ))`. The lower dimensions get
//!
//! ```text
//! n = ⌈ q ln E(ρ s / h) / ln E(δ) ⌉,   q ≤ n ≤ MAX_POINTS,
//! ```
//!
//! the accuracy `E(ρ s/h)^(−2q)` the base rule has on a well-oriented cell
//! whose branch point lies a curvature radius away (`ρ s / h` cells). That
//! reference tightens as `h` falls, so the per-cell error follows the base
//! rule's asymptotic rate from the coarsest level instead of a plateau.
//! Planes (constant gradient) keep `q`; the top sweep direction always keeps
//! `q` (its integrand is the polynomial one). A well-oriented box takes
//! `q + 1` from about level 5 on (`Q ≈ 1` puts its branch point at `ρ/2`, not
//! `ρ`): relaxing the reference to `ρ s / 2h` keeps `q` there but brings back
//! the plateau at levels 2–4 (plate, Q1 rules: 8.6e-7 and 7.2e-7 at levels 2
//! and 3), so the extra point is the price of the rate.
//!
//! Voxel image leaves keep `q`: their ψ is trilinear per voxel, with no
//! branch point to resolve ([`super::saye`] leaves them out).
//!
//! Only the volume rule takes the extra points: the surface rule, the SPR
//! samples and everything built on them stay as they were (see
//! [`super::saye::box_rule`]).

use crate::geometry::scalar::{Dual, Interval};

/// The most points per segment a lower dimension gets.
pub const MAX_POINTS: usize = 16;

/// `E(t) = 1 + 2t + 2√(t + t²)`: the sum of the semi-axes of the Bernstein
/// ellipse of `[0, 1]` through a point `t` beyond an end (in segment lengths).
fn ellipse(t: f64) -> f64 {
    1.0 + 2.0 * t + 2.0 * (t + t * t).sqrt()
}

/// Points per segment for the lower dimensions of a volume sweep along `k`
/// over a box of size `s` (free axes `free`) in a cell of edge `cell`, with
/// base rule `q`, from the bounds of the kept leaves over the box.
pub(super) fn lower_points<'a>(
    bounds: impl Iterator<Item = &'a Dual<Interval>>,
    free: &[usize],
    k: usize,
    s: f64,
    cell: f64,
    q: usize,
) -> usize {
    let mut n = q as f64;
    for bd in bounds {
        let width = free
            .iter()
            .map(|&a| (bd.d[a].hi - bd.d[a].lo).powi(2))
            .sum::<f64>()
            .sqrt();
        let gmax = free
            .iter()
            .map(|&a| bd.d[a].lo.abs().max(bd.d[a].hi.abs()).powi(2))
            .sum::<f64>()
            .sqrt();
        // A plane (its height function is linear), or no height function
        // along k (a last-resort sweep): nothing to gain.
        let curved = width > 0.0 && width.is_finite() && gmax.is_finite();
        if !curved || !bd.d[k].strictly_signed() {
            continue;
        }
        let dk = bd.d[k].lo.abs().min(bd.d[k].hi.abs());
        let rho = gmax / width;
        let delta = dk * dk / (2.0 * gmax * width);
        let wanted = q as f64 * ellipse(rho * s / cell).ln() / ellipse(delta).ln();
        if wanted.is_finite() {
            n = n.max(wanted);
        }
    }
    (n.ceil() as usize).clamp(q, MAX_POINTS.max(q))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bounds(d: [(f64, f64); 3]) -> Dual<Interval> {
        Dual {
            v: Interval::new(-1.0, 1.0),
            d: d.map(|(lo, hi)| Interval::new(lo, hi)),
        }
    }

    #[test]
    fn ellipse_of_a_singularity_at_the_end_is_one() {
        assert_eq!(ellipse(0.0), 1.0);
        assert!((ellipse(1.0) - (3.0 + 2.0 * 2f64.sqrt())).abs() < 1e-15);
    }

    #[test]
    fn a_plane_keeps_the_base_rule() {
        let plane = bounds([(0.3, 0.3), (-0.8, -0.8), (0.5, 0.5)]);
        assert_eq!(
            lower_points([&plane].into_iter(), &[0, 1, 2], 1, 1.0, 1.0, 2),
            2
        );
    }

    #[test]
    fn a_near_branch_point_gets_more_points_and_more_as_the_cell_shrinks() {
        let free = [0, 1, 2];
        // Curved over the box (ρ ≈ 4 box lengths) and steep along k = 0
        // (quality 0.3): the branch point is about 0.1 box lengths away.
        let steep = bounds([(0.3, 0.5), (0.7, 0.9), (0.2, 0.4)]);
        let n_cell = lower_points([&steep].into_iter(), &free, 0, 1.0, 1.0, 2);
        assert!(n_cell > 2, "{n_cell}");
        // The same box as a quarter of a cell twice as large (a sub-box of a
        // coarse cell): the reference accuracy is that of the larger cell's
        // rule, which is lower, so fewer points.
        let n_sub = lower_points([&steep].into_iter(), &free, 0, 1.0, 4.0, 2);
        assert!(n_sub < n_cell, "{n_sub} vs {n_cell}");
        // A finer grid asks more of the same box shape.
        let n_fine = lower_points([&steep].into_iter(), &free, 0, 4.0, 1.0, 2);
        assert!(n_fine > n_cell && n_fine <= MAX_POINTS, "{n_fine}");
        // A box whose gradient is nearly along k (branch point far) needs
        // fewer than the steep one.
        let flat = bounds([(0.9, 1.0), (0.1, 0.3), (-0.1, 0.1)]);
        let n_flat = lower_points([&flat].into_iter(), &free, 0, 1.0, 1.0, 2);
        assert!(n_flat < n_cell, "{n_flat} vs {n_cell}");
    }
}
