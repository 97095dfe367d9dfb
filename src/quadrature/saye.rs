//! Saye's high-order quadrature for implicitly defined domains in a box
//! (R. Saye, SIAM J. Sci. Comput. 37(2), A993–A1019, 2015), written for the CSG
//! trees of [`crate::geometry`].
//!
//! In a box `U` the leaves whose level set ψ can vanish are kept. A *height
//! direction* `k` is an axis along which every kept ψ is monotone on `U`
//! (`∂ψ/∂x_k` has one sign, checked with interval arithmetic). Then each line
//! parallel to `k` meets each ψ at most once, and
//!
//! ```text
//! ∫_{U∩Ω} f = ∫_{U'} F(x') dx',   F(x') = Σ_{segments s ⊂ Ω} ∫_s f(x', t) dt,
//! ```
//!
//! where the segments split the line at the roots of every ψ, and a segment is in
//! Ω when the CSG level set is negative at its midpoint. `F` is smooth on `U'`
//! away from the zero sets of the face restrictions `ψ(·, x_k = lo_k)` and
//! `ψ(·, x_k = hi_k)`, so `U'` is integrated by the same algorithm one dimension
//! down with those restrictions, ending in 1D with Gauss rules between roots.
//! The surface rule comes from the same sweep: a root where the segment class
//! changes is a boundary point `(x', t*)` of weight
//! `w' |∇ψ| / |∂ψ/∂x_k|` (the surface Jacobian) with the exact normal `±∇ψ/|∇ψ|`.
//! When no height direction exists the box is split in halves (up to a depth
//! limit, after which the best axis is used with a scanning root finder).
//!
//! A boundary point on the box's own face (boundaries aligned with the grid) is
//! claimed by the box whose side of the face is inside Ω, so a face shared by two
//! cells is counted once.

use std::cell::Cell;

use super::crossings::crossings;
use super::lines::{gauss_segment, split_line, sweep_line, Line};
pub(super) use super::restricted::Restricted;
use crate::geometry::scalar::{Dual, Interval};
use crate::geometry::surface::Shape;
use crate::geometry::Geometry;
use crate::spatial::Aabb;

/// A volume quadrature point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumePoint {
    pub x: [f64; 3],
    pub w: f64,
}

/// A boundary quadrature point: weight includes the surface Jacobian, `n` is the
/// exact outward unit normal, `tag` the boundary part.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    pub x: [f64; 3],
    pub w: f64,
    pub n: [f64; 3],
    pub tag: u16,
}

/// Volume and surface points of one box.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BoxRule {
    pub volume: Vec<VolumePoint>,
    pub surface: Vec<SurfacePoint>,
    /// Points of the body for least-squares fits (SPR samples) when the
    /// volume points are not all in it (the polyhedral rules); empty when
    /// they are (Saye's).
    pub samples: Vec<[f64; 3]>,
    /// Whether the rule is the first-order one of a cell where a mesh with
    /// defects does not bound a solid ([`super::repaired`]).
    pub repaired: bool,
}

const MAX_TOP_DEPTH: u32 = 3;
const MAX_LOWER_DEPTH: u32 = 4;
/// Smallest accepted [`quality`] before the depth limit (see [`height_axis`]).
const MIN_QUALITY: f64 = 0.4;

/// Shared state of one rule computation.
pub(super) struct Ctx<'a> {
    pub g: &'a Geometry,
    pub gauss_x: Vec<f64>,
    pub gauss_w: Vec<f64>,
    /// Points per segment of the base rule.
    q: usize,
    /// Edge length of the cell (the box [`box_rule`] was called with).
    cell: f64,
    /// Set when a volume sweep took more points than `q`
    /// ([`super::branch`]).
    refined: Cell<bool>,
}

impl<'a> Ctx<'a> {
    fn new(g: &'a Geometry, q: usize, cell: f64) -> Ctx<'a> {
        let (gauss_x, gauss_w) = super::gauss::gauss_legendre_unit(q);
        Ctx {
            g,
            gauss_x,
            gauss_w,
            q,
            cell,
            refined: Cell::new(false),
        }
    }
}

/// Volume rule on `b ∩ Ω` and, when all three axes are free, surface rule on
/// `b ∩ ∂Ω`, with `q` Gauss points per segment and dimension. `free` lists the
/// axes the box spans (three for a cell, two for a cell face; the others are
/// degenerate in `b`).
///
/// A mesh solid gets the exact polyhedral rule instead
/// ([`super::polyhedral::mesh_box_rule`], `q + 1` points per axis), a tree
/// with mesh leaves the rules of [`super::mixed`].
pub fn box_rule(g: &Geometry, b: &Aabb, free: &[usize], q: usize) -> BoxRule {
    if let Some(mesh) = g.mesh() {
        return super::polyhedral::mesh_box_rule(mesh, b, free, q);
    }
    if g.has_mesh() {
        return super::mixed::mixed_box_rule(g, b, free, q);
    }
    let cell = free.iter().map(|&a| b.hi[a] - b.lo[a]).fold(0.0, f64::max);
    let ctx = Ctx::new(g, q, cell);
    let mut rule = BoxRule::default();
    top(&ctx, b, free, 0, &mut rule);
    rule
}

/// Emits the volume points of `b` by `ctx`'s tensor rule.
fn whole_box(ctx: &Ctx, b: &Aabb, free: &[usize], rule: &mut BoxRule) {
    let start = rule.volume.len();
    tensor(ctx, b, free, 1.0, &mut |x, w| {
        rule.volume.push(VolumePoint { x, w })
    });
    extend_samples(ctx, rule, start);
}

fn top(ctx: &Ctx, b: &Aabb, free: &[usize], depth: u32, rule: &mut BoxRule) {
    let phi = ctx.g.bounds(b);
    if phi.hi < 0.0 {
        whole_box(ctx, b, free, rule);
        return;
    }
    if phi.lo > 0.0 {
        return;
    }
    let pins = pins_of(b, free);
    let fns: Vec<(Restricted, Dual<Interval>)> = (0..ctx.g.leaves().len())
        .map(|leaf| Restricted {
            leaf,
            pinned: pins,
            on_plane: None,
        })
        .filter_map(|r| r.bounds_if_active(ctx.g, b, true).map(|bd| (r, bd)))
        .collect();
    if fns.is_empty() {
        if ctx.g.inside(center(b)) {
            whole_box(ctx, b, free, rule);
        }
        return;
    }
    let want_surface = free.len() == 3;
    let min_quality = if depth < MAX_TOP_DEPTH {
        MIN_QUALITY
    } else {
        0.0
    };
    let Some(plan) = sweep_plan(&fns, free, want_surface, min_quality) else {
        if depth < MAX_TOP_DEPTH {
            for child in halves(b, free) {
                top(ctx, &child, free, depth + 1, rule);
            }
        } else {
            // Last resort: one sweep along the best axis with scanning roots.
            let k = best_axis(&fns, free);
            let emit = vec![want_surface; fns.len()];
            let start = rule.volume.len();
            sweep_box(ctx, ctx, &fns, b, free, k, false, true, &emit, rule);
            extend_samples(ctx, rule, start);
        }
        return;
    };
    for (sweep, (k, emit, monotone)) in plan.into_iter().enumerate() {
        let size = free.iter().map(|&a| b.hi[a] - b.lo[a]).fold(0.0, f64::max);
        let n = if sweep == 0 && want_surface {
            // An image's ψ is trilinear per voxel, not smooth: more points
            // per segment gain nothing there.
            let smooth = fns
                .iter()
                .filter(|f| !matches!(ctx.g.leaves()[f.0.leaf].shape, Shape::Image(_)))
                .map(|f| &f.1);
            super::branch::lower_points(smooth, free, k, size, ctx.cell, ctx.q)
        } else {
            ctx.q
        };
        if n > ctx.q {
            // The volume from the refined lower dimensions; the surface
            // points and the samples from the base rule's sweep. The cell's
            // volume points so far are the base rule's: they start the samples.
            if !ctx.refined.replace(true) {
                rule.samples = rule.volume.iter().map(|p| p.x).collect();
            }
            let fine = Ctx::new(ctx.g, n, ctx.cell);
            let none = vec![false; fns.len()];
            sweep_box(ctx, &fine, &fns, b, free, k, true, true, &none, rule);
            let mut base = BoxRule::default();
            sweep_box(ctx, ctx, &fns, b, free, k, true, true, &emit, &mut base);
            rule.surface.extend(base.surface);
            rule.samples.extend(base.volume.iter().map(|p| p.x));
        } else {
            let start = rule.volume.len();
            sweep_box(
                ctx,
                ctx,
                &fns,
                b,
                free,
                k,
                monotone,
                sweep == 0,
                &emit,
                rule,
            );
            extend_samples(ctx, rule, start);
        }
    }
}

/// Records the base rule's volume points from `start` on as samples, once the
/// cell has a refined box (until then the volume points are the samples).
fn extend_samples(ctx: &Ctx, rule: &mut BoxRule, start: usize) {
    if ctx.refined.get() {
        for i in start..rule.volume.len() {
            let x = rule.volume[i].x;
            rule.samples.push(x);
        }
    }
}

/// The sweeps that cover a box: the first gives the volume rule and the surface
/// points of the leaves with a nonzero derivative along its axis; further
/// sweeps along other axes give the surface points of the remaining leaves
/// (a boundary parallel to a sweep direction has no points on its lines).
/// Each sweep is `(axis, leaves whose surface it emits, monotone)`: a leaf
/// that is a plane on a face of the box (a CSG cut on a grid plane) may be
/// swept along its normal although other leaves are not monotone along it,
/// with the scanning root finder ([`on_face_plane`]). `None` when some leaf
/// has no usable axis.
fn sweep_plan(
    fns: &[(Restricted, Dual<Interval>)],
    free: &[usize],
    want_surface: bool,
    min_quality: f64,
) -> Option<Vec<(usize, Vec<bool>, bool)>> {
    let k = height_axis(fns, free, min_quality)?;
    let strict = |k: usize, i: usize| fns[i].1.d[k].strictly_signed();
    let mut plan = vec![(
        k,
        (0..fns.len())
            .map(|i| want_surface && strict(k, i))
            .collect::<Vec<_>>(),
        true,
    )];
    if !want_surface {
        return Some(plan);
    }
    let mut done: Vec<bool> = plan[0].1.clone();
    while let Some(i) = done.iter().position(|d| !d) {
        let monotone = |k: usize| {
            fns.iter()
                .all(|(_, bd)| monotone_or_constant(bd, k) && quality(bd, k, free) >= min_quality)
        };
        let (k, monotone) = match free.iter().copied().find(|&k| strict(k, i) && monotone(k)) {
            Some(k) => (k, true),
            None => {
                let k = free
                    .iter()
                    .copied()
                    .find(|&k| on_face_plane(&fns[i].1, k, free))?;
                (k, false)
            }
        };
        let emit: Vec<bool> = (0..fns.len())
            .map(|j| !done[j] && strict(k, j) && (monotone || on_face_plane(&fns[j].1, k, free)))
            .collect();
        for (d, e) in done.iter_mut().zip(&emit) {
            *d |= e;
        }
        plan.push((k, emit, monotone));
    }
    Some(plan)
}

/// ψ is linear with its gradient along `k` and only touches zero on the box:
/// its zero set there is a face of the box normal to `k`. Its boundary
/// points lie at the lines' ends, so a sweep along `k` emits them whatever
/// the other leaves do along `k`, given roots found by scanning.
fn on_face_plane(bd: &Dual<Interval>, k: usize, free: &[usize]) -> bool {
    let linear = free.iter().all(|&a| bd.d[a].lo == bd.d[a].hi);
    let along_k = free.iter().all(|&a| a == k || bd.d[a].lo == 0.0);
    linear && along_k && bd.d[k].strictly_signed() && !bd.v.straddles_zero()
}

/// One height-direction sweep of the box along `k`: the lines' Gauss rules
/// from `ctx`, the lower dimensions' from `lower_ctx`.
#[allow(clippy::too_many_arguments)]
fn sweep_box(
    ctx: &Ctx,
    lower_ctx: &Ctx,
    fns: &[(Restricted, Dual<Interval>)],
    b: &Aabb,
    free: &[usize],
    k: usize,
    monotone: bool,
    emit_volume: bool,
    emit_surface: &[bool],
    rule: &mut BoxRule,
) {
    let lower_free: Vec<usize> = free.iter().copied().filter(|&a| a != k).collect();
    let mut faces = face_restrictions(fns, k, b);
    faces.extend(edge_functions(ctx.g, fns, k));
    let line_fns: Vec<Restricted> = fns.iter().map(|(r, _)| *r).collect();
    let mut sink = |x: [f64; 3], w: f64| {
        let line = Line { k, x, w, monotone };
        sweep_line(ctx, &line_fns, b, &line, emit_volume, emit_surface, rule);
    };
    lower(lower_ctx, &faces, b, &lower_free, 0, false, &mut sink);
}

/// Integrates over the free axes of `b` a function that is smooth away from the
/// zero sets of `fns`, emitting points to `sink`.
fn lower(
    ctx: &Ctx,
    fns: &[Restricted],
    b: &Aabb,
    free: &[usize],
    depth: u32,
    crossings_split: bool,
    sink: &mut dyn FnMut([f64; 3], f64),
) {
    let active: Vec<(Restricted, Dual<Interval>)> = fns
        .iter()
        .filter_map(|r| r.bounds_if_active(ctx.g, b, false).map(|bd| (*r, bd)))
        .collect();
    if active.is_empty() {
        tensor(ctx, b, free, 1.0, sink);
        return;
    }
    if free.len() == 1 {
        let k = free[0];
        let line: Vec<Restricted> = active.iter().map(|(r, _)| *r).collect();
        let monotone = active.iter().all(|(_, bd)| monotone_or_constant(bd, k));
        split_line(ctx, &line, k, b, b.lo, 1.0, monotone, sink);
        return;
    }
    let min_quality = if depth < MAX_LOWER_DEPTH {
        MIN_QUALITY
    } else {
        0.0
    };
    let (k, monotone) = match height_axis(&active, free, min_quality) {
        Some(k) => (k, true),
        None if depth < MAX_LOWER_DEPTH => {
            for child in halves(b, free) {
                lower(ctx, fns, &child, free, depth + 1, crossings_split, sink);
            }
            return;
        }
        None => (best_axis(&active, free), false),
    };
    let lower_free: Vec<usize> = free.iter().copied().filter(|&a| a != k).collect();
    if let ([m], false) = (&lower_free[..], crossings_split) {
        let m = *m;
        // The outer integrand has a kink where two curves cross: split there
        // (once: the children start past the crossing depth).
        let cuts = crossings(ctx.g, &active, b, k, m);
        if !cuts.is_empty() {
            let ends: Vec<f64> = std::iter::once(b.lo[m])
                .chain(cuts)
                .chain(std::iter::once(b.hi[m]))
                .collect();
            for s in ends.windows(2) {
                let mut child = *b;
                child.lo[m] = s[0];
                child.hi[m] = s[1];
                lower(ctx, fns, &child, free, depth, true, sink);
            }
            return;
        }
    }
    let faces = face_restrictions(&active, k, b);
    let line: Vec<Restricted> = active.iter().map(|(r, _)| *r).collect();
    let mut inner = |x: [f64; 3], w: f64| split_line(ctx, &line, k, b, x, w, monotone, sink);
    lower(ctx, &faces, b, &lower_free, depth, false, &mut inner);
}

/// Tensor Gauss rule over the free axes of `b`.
fn tensor(ctx: &Ctx, b: &Aabb, free: &[usize], w: f64, sink: &mut dyn FnMut([f64; 3], f64)) {
    match free.split_first() {
        None => sink(b.lo, w),
        Some((&k, rest)) => {
            let mut inner = |x: [f64; 3], wx: f64| {
                gauss_segment(ctx, x, k, b.lo[k], b.hi[k], wx, sink);
            };
            tensor(ctx, b, rest, w, &mut inner);
        }
    }
}

/// An axis along which every function is strictly monotone on the box (or
/// independent of it), the one with the largest normalised gradient component
/// first. With `min_quality > 0` the axis must also keep [`quality`] at least
/// `min_quality` for every function: a steep height function on a curved
/// boundary (lines near tangency, curvature on the scale of the box) converges
/// slowly, and splitting the box is then the better deal.
fn height_axis(
    fns: &[(Restricted, Dual<Interval>)],
    free: &[usize],
    min_quality: f64,
) -> Option<usize> {
    let mut axes: Vec<usize> = free.to_vec();
    let score = |k: usize| -> f64 { fns.iter().map(|(_, bd)| bd.d[k].mid().abs()).sum() };
    axes.sort_by(|&a, &c| score(c).total_cmp(&score(a)));
    axes.into_iter().find(|&k| {
        fns.iter()
            .all(|(_, bd)| monotone_or_constant(bd, k) && quality(bd, k, free) >= min_quality)
    })
}

/// `min |∂ψ/∂x_k| / max |∇ψ|` over the box: how steep the height function may
/// get. Steepness amplifies curvature, so a linear ψ (constant gradient: its
/// height function is linear whatever the slope) scores 1, as does a function
/// independent of `x_k`.
fn quality(bd: &Dual<Interval>, k: usize, free: &[usize]) -> f64 {
    let d = bd.d[k];
    let linear = free.iter().all(|&a| bd.d[a].lo == bd.d[a].hi);
    if linear || (d.lo == 0.0 && d.hi == 0.0) {
        return 1.0;
    }
    if !d.strictly_signed() {
        return 0.0;
    }
    let mag2: f64 = free
        .iter()
        .map(|&a| bd.d[a].lo.abs().max(bd.d[a].hi.abs()).powi(2))
        .sum();
    d.lo.abs().min(d.hi.abs()) / mag2.sqrt()
}

/// ψ is strictly monotone along `k` on the box, or does not depend on `x_k`.
fn monotone_or_constant(bd: &Dual<Interval>, k: usize) -> bool {
    bd.d[k].strictly_signed() || (bd.d[k].lo == 0.0 && bd.d[k].hi == 0.0)
}

fn best_axis(fns: &[(Restricted, Dual<Interval>)], free: &[usize]) -> usize {
    let score = |k: usize| -> f64 { fns.iter().map(|(_, bd)| bd.d[k].mid().abs()).sum() };
    *free
        .iter()
        .max_by(|&&a, &&c| score(a).total_cmp(&score(c)))
        .expect("at least one free axis")
}

fn face_restrictions(fns: &[(Restricted, Dual<Interval>)], k: usize, b: &Aabb) -> Vec<Restricted> {
    let mut out = Vec::with_capacity(2 * fns.len());
    for (r, bd) in fns {
        out.push(r.pinned_at(k, b.lo[k]));
        // A function independent of x_k has the same restriction on both faces.
        if !(bd.d[k].lo == 0.0 && bd.d[k].hi == 0.0) {
            out.push(r.pinned_at(k, b.hi[k]));
        }
    }
    out
}

/// The edge functions of the kept leaves along `k`: for every plane leaf that
/// is strictly monotone along `k` and every other kept leaf, the other leaf on
/// the plane. The integrand of the lower dimension has a kink where the
/// projected edge runs (the segment structure of the lines changes there);
/// splitting at it keeps Saye's high order on cells where a plane meets
/// another surface (Saye 2022 splits at the resultant's zero set; for a plane
/// the resultant is this composition). Two planes give one function.
fn edge_functions(g: &Geometry, fns: &[(Restricted, Dual<Interval>)], k: usize) -> Vec<Restricted> {
    let is_plane = |r: &Restricted| matches!(g.leaves()[r.leaf].shape, Shape::Plane { .. });
    let mut out = Vec::new();
    for (i, (p, pbd)) in fns.iter().enumerate() {
        if !is_plane(p) {
            continue;
        }
        for (j, (other, _)) in fns.iter().enumerate() {
            if j == i || (is_plane(other) && j < i) || other.leaf == p.leaf {
                continue;
            }
            out.extend(other.on_plane(p.leaf, pbd, k));
        }
    }
    out
}

fn pins_of(b: &Aabb, free: &[usize]) -> [Option<f64>; 3] {
    [0, 1, 2].map(|i| {
        if free.contains(&i) {
            None
        } else {
            Some(b.lo[i])
        }
    })
}

fn center(b: &Aabb) -> [f64; 3] {
    [0, 1, 2].map(|i| 0.5 * (b.lo[i] + b.hi[i]))
}

/// The 2^d boxes halving `b` along its free axes.
pub(super) fn halves(b: &Aabb, free: &[usize]) -> Vec<Aabb> {
    let c = center(b);
    let mut out = vec![*b];
    for &a in free {
        out = out
            .into_iter()
            .flat_map(|bx| {
                let mut l = bx;
                let mut r = bx;
                l.hi[a] = c[a];
                r.lo[a] = c[a];
                [l, r]
            })
            .collect();
    }
    out
}
