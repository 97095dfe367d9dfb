//! The line sweeps of Saye's algorithm: roots of the kept level sets along a
//! line in the height direction, Gauss rules on the segments between them, and
//! at the top level the volume points of the segments inside Ω and the boundary
//! points where the segment class changes (see [`super::saye`]).

use super::roots::roots_on_segment;
use super::saye::{BoxRule, Ctx, Restricted, SurfacePoint, VolumePoint};
use crate::spatial::Aabb;

/// A line of a sweep: direction `k` through `x`, carrying the weight `w`.
pub(super) struct Line {
    pub k: usize,
    pub x: [f64; 3],
    pub w: f64,
    pub monotone: bool,
}

/// Sorted roots of `fns` on the line through `x` along `k` within the box.
pub(super) fn line_roots(
    ctx: &Ctx,
    fns: &[Restricted],
    k: usize,
    b: &Aabb,
    x: [f64; 3],
    monotone: bool,
) -> Vec<(f64, usize)> {
    let mut roots: Vec<(f64, usize)> = Vec::new();
    let mut found = Vec::new();
    for (i, r) in fns.iter().enumerate() {
        let f = |t: f64| {
            let mut p = x;
            p[k] = t;
            let (v, d) = r.value_grad(ctx.g, p);
            (v, d[k])
        };
        found.clear();
        roots_on_segment(&f, b.lo[k], b.hi[k], monotone, &mut found);
        roots.extend(found.iter().map(|&t| (t, i)));
    }
    roots.sort_by(|a, b| a.0.total_cmp(&b.0));
    roots
}

/// Intermediate-level line: Gauss points on every segment between roots.
#[allow(clippy::too_many_arguments)]
pub(super) fn split_line(
    ctx: &Ctx,
    fns: &[Restricted],
    k: usize,
    b: &Aabb,
    x: [f64; 3],
    w: f64,
    monotone: bool,
    sink: &mut dyn FnMut([f64; 3], f64),
) {
    let roots = line_roots(ctx, fns, k, b, x, monotone);
    let mut a = b.lo[k];
    for t in roots.iter().map(|r| r.0).chain(std::iter::once(b.hi[k])) {
        if t > a {
            gauss_segment(ctx, x, k, a, t, w, sink);
            a = t;
        }
    }
}

/// Top-level line: volume points on the segments inside Ω and a surface point at
/// each root where the segment class changes.
pub(super) fn sweep_line(
    ctx: &Ctx,
    fns: &[Restricted],
    b: &Aabb,
    line: &Line,
    emit_volume: bool,
    emit_surface: &[bool],
    rule: &mut BoxRule,
) {
    let Line { k, x, w, monotone } = *line;
    let roots = line_roots(ctx, fns, k, b, x, monotone);
    let (lo, hi) = (b.lo[k], b.hi[k]);
    let at = |t: f64| {
        let mut p = x;
        p[k] = t;
        p
    };
    // Positions closer than `tol` are one. Relative to the box, but never
    // below a few ulps of the coordinate: far from the origin (x/h above
    // about 64) `t ± 1e-14 (hi − lo)` rounds back to `t`, the probes below
    // and above a root land in the same segment, and its surface point was
    // dropped (a quarter of the bracket's bolt holes at level 7).
    let tol = (1e-14 * (hi - lo)).max(4.0 * f64::EPSILON * lo.abs().max(hi.abs()));
    // Segment ends: distinct root positions strictly inside, plus the box ends.
    let mut ends = vec![lo];
    for &(t, _) in &roots {
        if t - ends[ends.len() - 1] > tol && hi - t > tol {
            ends.push(t);
        }
    }
    ends.push(hi);
    let inside: Vec<bool> = ends
        .windows(2)
        .map(|s| ctx.g.inside(at(0.5 * (s[0] + s[1]))))
        .collect();
    for (s, &ins) in ends.windows(2).zip(&inside) {
        if ins && emit_volume {
            gauss_segment(ctx, x, k, s[0], s[1], w, &mut |p, wp| {
                rule.volume.push(VolumePoint { x: p, w: wp })
            });
        }
    }
    let delta = 1e-9 * (hi - lo);
    let mut last_emitted = f64::NAN;
    for &(t, i) in roots.iter().filter(|r| emit_surface[r.1]) {
        // Classes just below and just above the root (outside the box: probe).
        let below = if t - lo <= tol {
            ctx.g.inside(at(lo - delta))
        } else {
            inside[segment_of(&ends, t - tol)]
        };
        let above = if hi - t <= tol {
            ctx.g.inside(at(hi + delta))
        } else {
            inside[segment_of(&ends, t + tol)]
        };
        let own_inside = if t - lo <= tol {
            above
        } else if hi - t <= tol {
            below
        } else {
            true
        };
        if below == above || !own_inside || (t - last_emitted).abs() <= tol {
            continue;
        }
        last_emitted = t;
        let p = at(t);
        let (_, grad) = fns[i].value_grad(ctx.g, p);
        let gnorm = (grad[0] * grad[0] + grad[1] * grad[1] + grad[2] * grad[2]).sqrt();
        if grad[k] == 0.0 || gnorm == 0.0 {
            continue;
        }
        // Outward: along +k when the inside lies below.
        let s = if below == (grad[k] > 0.0) { 1.0 } else { -1.0 };
        let n = grad.map(|c| s * c / gnorm);
        let tag = ctx.g.leaves()[fns[i].leaf].tag;
        rule.surface.push(SurfacePoint {
            x: p,
            w: w * gnorm / grad[k].abs(),
            n,
            tag,
        });
    }
}

fn segment_of(ends: &[f64], t: f64) -> usize {
    let n = ends.len() - 1;
    ends[1..n]
        .iter()
        .take_while(|&&e| e <= t)
        .count()
        .min(n - 1)
}

pub(super) fn gauss_segment(
    ctx: &Ctx,
    x: [f64; 3],
    k: usize,
    a: f64,
    c: f64,
    w: f64,
    sink: &mut dyn FnMut([f64; 3], f64),
) {
    let len = c - a;
    for (gx, gw) in ctx.gauss_x.iter().zip(&ctx.gauss_w) {
        let mut p = x;
        p[k] = a + gx * len;
        sink(p, w * gw * len);
    }
}
