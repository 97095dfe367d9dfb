//! Cut rules for CSG trees with mesh leaves (an STL part minus a drilled
//! hole, a mesh intersected with a half-space, two STL parts in a union).
//!
//! Over a box the tree reduces to the surfaces that cross it
//! ([`Geometry::local`]):
//! - only one mesh crosses and the solid is its inside: the exact
//!   polyhedral rule ([`super::polyhedral`]); its outside (a cavity): the
//!   whole box's Gauss weights minus that rule's, exact too;
//! - no mesh crosses, or each crossing mesh is one flat face there (its
//!   triangles in the box coplanar, with one tag): Saye's rule of the reduced
//!   tree, with each such face a plane leaf ([`super::saye`]). That is the
//!   usual case where a drilled hole meets an STL face, and it is as accurate
//!   as on analytic parts;
//! - otherwise (another surface, or another mesh, meets a mesh's edge or
//!   corner) the box is halved along its free axes, down to
//!   [`MAX_DEPTH`] levels, and each half gets its own rule by the same
//!   choice. The boxes of size `h / 2^MAX_DEPTH` still left get a
//!   **first-order rule**: the tensor Gauss points of the box that lie in the
//!   solid (the point-membership rule), and on each crossing surface its own
//!   boundary points (clipped triangles, or Saye's points of the leaf alone)
//!   where they are on the solid's boundary, with the solid's outward normal
//!   (see [`on_boundary`]). Where another surface crosses a mesh edge these
//!   are a few boxes around each crossing point.
//!
//! **Accuracy.** Measured in `tests/suite/geometry/cut_volume.rs` and docs/stl.md. The
//! patch test stays exact whatever the rules' accuracy: the boundary flux of
//! every cut cell is derived from its volume rule
//! ([`crate::fem::flux_consistency`]).

use super::gauss::gauss_legendre_unit;
use super::polyhedral::mesh_box_rule;
use super::saye::{box_rule, halves, BoxRule, SurfacePoint, VolumePoint};
use crate::geometry::{Geometry, LocalSolid};
use crate::mesh::MeshSolid;
use crate::spatial::Aabb;

/// Halvings of a box where a mesh meets another surface: boxes of `h/8`.
pub const MAX_DEPTH: u32 = 3;

/// The rule of `b ∩ Ω` for a tree with mesh leaves (`free`, `q` as in
/// [`box_rule`]). A box that is split gets the fit samples of
/// [`lattice_samples`]; one that is not keeps its rule's own.
pub fn mixed_box_rule(g: &Geometry, b: &Aabb, free: &[usize], q: usize) -> BoxRule {
    let local = g.local(b);
    if let Some(rule) = whole_box_rule(g, &local, b, free, q) {
        return rule;
    }
    let mut parts = Vec::new();
    for child in halves(b, free) {
        collect(g, &child, free, q, 1, &mut parts);
    }
    let mut rule = BoxRule::default();
    for part in parts {
        rule.volume.extend(part.volume);
        rule.surface.extend(part.surface);
    }
    if free.len() == 3 {
        rule.samples = lattice_samples(g, b, q, &rule.surface);
    }
    rule
}

/// The rule of a box that needs no split: Saye's, the polyhedral one or its
/// complement; `None` for [`LocalSolid::Mixed`].
fn whole_box_rule(
    g: &Geometry,
    local: &LocalSolid,
    b: &Aabb,
    free: &[usize],
    q: usize,
) -> Option<BoxRule> {
    match local {
        LocalSolid::Analytic(reduced) => Some(box_rule(reduced, b, free, q)),
        LocalSolid::Mesh(mesh) => Some(mesh_box_rule(mesh, b, free, q)),
        LocalSolid::MeshOutside(mesh) => Some(outside_rule(g, mesh, b, free, q)),
        LocalSolid::Mixed { .. } => None,
    }
}

/// The exact rule of `b` outside a mesh solid (a cavity): on the polyhedral
/// rule's points (`q + 1` per free axis) the tensor Gauss weights of the
/// whole box minus the polyhedral weights, the mesh's boundary points facing
/// into it, and [`lattice_samples`].
fn outside_rule(g: &Geometry, mesh: &MeshSolid, b: &Aabb, free: &[usize], q: usize) -> BoxRule {
    let inner = mesh_box_rule(mesh, b, free, q);
    let n = q + 1;
    let mut rule = tensor_rule(b, free, n, |_| true);
    for (p, i) in rule.volume.iter_mut().zip(&inner.volume) {
        p.w -= i.w;
    }
    rule.surface = inner
        .surface
        .into_iter()
        .map(|p| SurfacePoint {
            n: p.n.map(|v| -v),
            ..p
        })
        .collect();
    if free.len() == 3 {
        rule.samples = lattice_samples(g, b, q, &rule.surface);
    }
    rule
}

/// The tensor Gauss rule of `n` points per free axis of `b`, the points
/// `keep` accepts (in the polyhedral rules' order: first free axis fastest).
fn tensor_rule(b: &Aabb, free: &[usize], n: usize, keep: impl Fn([f64; 3]) -> bool) -> BoxRule {
    let (t, w) = gauss_legendre_unit(n);
    let mut rule = BoxRule::default();
    for idx in 0..n.pow(free.len() as u32) {
        let mut x = b.lo;
        let mut weight = 1.0;
        let mut rest = idx;
        for &a in free {
            let len = b.hi[a] - b.lo[a];
            x[a] = b.lo[a] + len * t[rest % n];
            weight *= len * w[rest % n];
            rest /= n;
        }
        if keep(x) {
            rule.volume.push(VolumePoint { x, w: weight });
        }
    }
    rule
}

/// Points of `b ∩ Ω` for the recovery's fits ([`BoxRule::samples`]): the
/// centres of a `k³` lattice (`k = q/2 + 2`) in the solid, topped up with
/// boundary points when fewer than `2 (q/2 + 1)³`, as the polyhedral rules
/// choose theirs. Not the pieces' own points: their number and density
/// follow the halvings, and with them (all the pieces' points, strided to
/// [`crate::cells::MAX_FIT_POINTS`]) the Q2 fixed point of the patch test on
/// a drilled STL cube stalled at a residual of 3e-5; with the lattice it
/// converges in 40 iterations (34 on the same part made of cuboids).
fn lattice_samples(g: &Geometry, b: &Aabb, q: usize, surface: &[SurfacePoint]) -> Vec<[f64; 3]> {
    let k = q / 2 + 2;
    let want = 2 * (q / 2 + 1).pow(3);
    let mut out: Vec<[f64; 3]> = (0..k * k * k)
        .map(|idx| {
            let ijk = [idx % k, (idx / k) % k, idx / (k * k)];
            [0, 1, 2].map(|a| b.lo[a] + (b.hi[a] - b.lo[a]) * (ijk[a] as f64 + 0.5) / k as f64)
        })
        .filter(|&x| g.inside(x))
        .collect();
    if out.len() < want && !surface.is_empty() {
        let stride = surface.len().div_ceil(want - out.len()).max(1);
        out.extend(surface.iter().step_by(stride).map(|p| p.x));
    }
    out
}

fn collect(g: &Geometry, b: &Aabb, free: &[usize], q: usize, depth: u32, out: &mut Vec<BoxRule>) {
    let local = g.local(b);
    if let Some(rule) = whole_box_rule(g, &local, b, free, q) {
        out.push(rule);
    } else if depth < MAX_DEPTH {
        for child in halves(b, free) {
            collect(g, &child, free, q, depth + 1, out);
        }
    } else if let LocalSolid::Mixed { meshes, leaves } = local {
        out.push(membership_rule(g, b, free, q, &meshes, &leaves));
    }
}

/// The first-order rule of a box where a mesh meets another surface: the
/// tensor Gauss points (`q` per free axis) inside the solid, and the
/// crossing surfaces' own boundary points where they bound the solid.
fn membership_rule(
    g: &Geometry,
    b: &Aabb,
    free: &[usize],
    q: usize,
    meshes: &[std::sync::Arc<MeshSolid>],
    leaves: &[usize],
) -> BoxRule {
    let mut rule = tensor_rule(b, free, q, |x| g.inside(x));
    if free.len() < 3 {
        return rule;
    }
    let size = free.iter().map(|&a| b.hi[a] - b.lo[a]).fold(0.0, f64::max);
    let mut candidates: Vec<SurfacePoint> = Vec::new();
    for mesh in meshes {
        candidates.extend(mesh_box_rule(mesh, b, free, q).surface);
    }
    for &leaf in leaves {
        candidates.extend(box_rule(&g.leaf_solid(leaf), b, free, q).surface);
    }
    rule.surface = candidates
        .into_iter()
        .filter_map(|p| on_boundary(g, p, size))
        .collect();
    rule
}

/// A surface's boundary point `p` as a point of the solid's boundary, or
/// `None` when the solid is on both sides of it or on neither (the surface
/// is inside or outside the other operands there): the solid is tested just
/// inside and just outside, `x ∓ ε n` with `ε = 10⁻⁸` of the box size, and
/// the normal is `n` or `−n` so that it points out of the solid (a
/// subtracted solid's surface faces into it).
pub fn on_boundary(g: &Geometry, p: SurfacePoint, size: f64) -> Option<SurfacePoint> {
    let eps = 1e-8 * size;
    let at = |s: f64| [0, 1, 2].map(|i| p.x[i] + s * eps * p.n[i]);
    match (g.inside(at(-1.0)), g.inside(at(1.0))) {
        (true, false) => Some(p),
        (false, true) => Some(SurfacePoint {
            n: p.n.map(|v| -v),
            ..p
        }),
        _ => None,
    }
}
