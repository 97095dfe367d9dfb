//! Exact cut-cell rules for solids bounded by triangle meshes ([`MeshSolid`]).
//!
//! On a box `B` (a cell, or a cell face for the consistency correction) the
//! part `P = B ∩ Ω` is a polyhedron (a polygon on a face), so its moments can
//! be had exactly from its boundary by the divergence theorem, with nothing
//! but Gauss rules on flat pieces.
//!
//! **The rule.** With `n = q + 1` Gauss points `t_i` (weights `ω_i`) per axis of
//! `B`, the volume rule is the tensor of those points with the weights
//! `W_q = ∫_P L_q`, `L_q = ℓ_i(x)ℓ_j(y)ℓ_k(z)` the Lagrange polynomials of the
//! points. It integrates every polynomial of `Q_q` (degree `≤ q` per axis)
//! exactly over `P`: `Q_2` for Q1 elements (`q = 2`), `Q_4` for Q2 (`q = 4`),
//! which are the spaces the moment-fitted element rules need
//! ([`crate::fem::moment_fit`]). The weights may be negative and the points
//! may lie outside `P`: the rule is an exact functional, not a sampling.
//!
//! **The moments, dimension by dimension.** Take the first free axis `a` and
//! `Λ_i(x_a) = ∫_{lo_a}^{x_a} ℓ_i`, so that `∂_a (Λ_i L_J) = ℓ_i L_J`. Then
//!
//! ```text
//! ∫_P ℓ_i L_J = ∫_{∂P} Λ_i L_J ν_a
//!             = Σ_{pieces of ∂Ω ∩ B} ∫ Λ_i L_J ν_a  +  h_a ω_i ∫_{P ∩ {x_a = hi_a}} L_J,
//! ```
//! since `ν_a = 0` on the faces of `B` normal to the other axes, `Λ_i = 0` on
//! the face `x_a = lo_a` and `Λ_i = h_a ω_i` on `x_a = hi_a`. In 3D the pieces
//! are the mesh triangles clipped to `B` (Sutherland–Hodgman against its six
//! planes) with their facet normals; the last term is the same problem one
//! dimension down on the face. In 2D the pieces are the segments where the
//! triangles cross the face's plane, clipped to the face, with the in-plane
//! normal (the facet normal without its component across the plane,
//! normalised); the last term is an edge of the face. In 1D the edge is split
//! at its crossings with the triangles and each piece is inside or not by the
//! winding number at its midpoint. Every integral is of a polynomial over a
//! flat piece: triangles by the collapsed (Duffy) Gauss rule, segments by
//! Gauss–Legendre, each exact for the degree at hand. The moments are thus
//! exact to round-off for a closed mesh, and so are the divergence theorem
//! between the volume, face and boundary rules and the patch test.
//!
//! **Samples.** The least-squares fits of the recovery need points of the
//! body, which the volume points need not be; the rule lists inside points of
//! a sub-lattice (and boundary points in a sliver) for them.
//!
//! **The boundary rule** is the clipped triangles' own: a collapsed Gauss rule
//! of `q × q` points on each fan triangle of each clipped polygon (exact for
//! total degree `2q − 2`: the Dirichlet penalty's `N_a N_b` on a facet for Q1,
//! and more for Q2), with the facet normal and the facet's tag. Its flux of
//! higher-degree polynomials need not be exact: the consistency correction
//! ([`crate::fem::flux_consistency`]) makes the boundary flux agree with the
//! exact volume and face rules, as it does for Saye's rules. (A rule exact for
//! `Q_q` would need `(3q/2 + 1)²` points per fan triangle, which on a level-6
//! plate gave 660 000 boundary points.)
//!
//! **Degenerate positions** (a facet in a grid plane, which every part whose
//! bounding box sets the grid has) are decided as if the mesh were moved by
//! an infinitesimal `+0⁺` along every axis (simulation of simplicity): a
//! vertex on a plane is above it, a box keeps the half-open `[lo, hi)` of each
//! axis, and a piece of edge lying in a facet is inside when the point just
//! below it (`−η` along every axis, `η = 10⁻⁹ h`) is. Every predicate follows
//! the same convention, so each facet in a grid plane belongs to exactly one
//! cell and the rules stay exact there (tested on boxes aligned with the
//! lattice).

use crate::mesh::MeshSolid;
use crate::spatial::intersect_line;
use crate::spatial::vec3::{cross, norm, sub};
use crate::spatial::Aabb;

use super::gauss::{gauss_jacobi_u_unit, gauss_legendre_unit};
use super::repaired;
use super::saye::{BoxRule, SurfacePoint, VolumePoint};

/// The Lagrange basis of the `n` Gauss points of `[0, 1]` in monomial form,
/// and the rules that integrate its products exactly on flat pieces.
struct Basis {
    n: usize,
    /// Gauss points and weights of `[0, 1]` (`n` of them): the rule's nodes.
    t: Vec<f64>,
    w: Vec<f64>,
    /// `ℓ_i(s) = Σ_k coef[i][k] s^k`.
    coef: Vec<Vec<f64>>,
    /// Collapsed rule for the moments (degree `3n − 2` on a triangle).
    moment_tri: Vec<([f64; 2], f64)>,
    /// Collapsed rule for the boundary points (degree `2q − 2`).
    surface_tri: Vec<([f64; 2], f64)>,
}

impl Basis {
    fn new(q: usize) -> Basis {
        let n = q + 1;
        let (t, w) = gauss_legendre_unit(n);
        // Multiply out Π_{j≠i} (s − t_j) / (t_i − t_j).
        let coef = (0..n)
            .map(|i| {
                let mut c = vec![1.0];
                for tj in t
                    .iter()
                    .enumerate()
                    .filter(|&(j, _)| j != i)
                    .map(|(_, tj)| tj)
                {
                    let d = t[i] - tj;
                    let mut next = vec![0.0; c.len() + 1];
                    for (k, ck) in c.iter().enumerate() {
                        next[k + 1] += ck / d;
                        next[k] -= ck * tj / d;
                    }
                    c = next;
                }
                c
            })
            .collect();
        Basis {
            n,
            t,
            w,
            coef,
            moment_tri: collapsed_jacobi_rule((3 * n - 1).div_ceil(2)),
            surface_tri: collapsed_rule(q),
        }
    }

    /// `ℓ_i(s)` for every `i` into `out`, `s` in unit coordinates.
    fn lagrange(&self, s: f64, out: &mut [f64]) {
        for (o, c) in out.iter_mut().zip(&self.coef) {
            *o = c.iter().rev().fold(0.0, |acc, ck| acc * s + ck);
        }
    }

    /// `∫_0^s ℓ_i` for every `i` into `out`.
    fn lagrange_integral(&self, s: f64, out: &mut [f64]) {
        for (o, c) in out.iter_mut().zip(&self.coef) {
            let p = c
                .iter()
                .enumerate()
                .rev()
                .fold(0.0, |acc, (k, ck)| acc * s + ck / (k + 1) as f64);
            *o = p * s;
        }
    }
}

/// The collapsed Gauss rule on the reference triangle `{u, v ≥ 0, u + v ≤ 1}`
/// with `m × m` points, exact for total degree `2m − 2`: barycentric-free
/// coordinates `(u, uv)` of the square's points, weights summing to ½.
fn collapsed_rule(m: usize) -> Vec<([f64; 2], f64)> {
    let (u, w) = gauss_legendre_unit(m);
    let with_jacobian: Vec<f64> = u.iter().zip(&w).map(|(u, w)| u * w).collect();
    collapsed(&u, &with_jacobian)
}

/// The collapsed rule with the Jacobian `u` in the weights of the collapsed
/// direction (Gauss–Jacobi there, Gauss–Legendre along `v`): `m × m` points,
/// exact for total degree `2m − 1`, one more than [`collapsed_rule`] with
/// as many points. The moments' integrands, of degree `3n − 2` (`∫ℓ_i` of
/// degree `n` times two `ℓ` of degree `n − 1`), take `m = ⌈(3n − 1)/2⌉`: 16
/// points per fan triangle for Q1 (25 with the Legendre rule), 49 for Q2 (64).
fn collapsed_jacobi_rule(m: usize) -> Vec<([f64; 2], f64)> {
    let (u, w) = gauss_jacobi_u_unit(m);
    collapsed(&u, &w)
}

/// The points `(u(1 − v), uv)` of the collapsed square for the points `u`
/// (weights `wu`, the Jacobian `u` included) and as many Gauss–Legendre
/// points `v`.
fn collapsed(u: &[f64], wu: &[f64]) -> Vec<([f64; 2], f64)> {
    let (v, wv) = gauss_legendre_unit(u.len());
    let mut out = Vec::with_capacity(u.len() * v.len());
    for (u, wu) in u.iter().zip(wu) {
        for (v, wv) in v.iter().zip(&wv) {
            out.push(([u * (1.0 - v), u * v], wu * wv));
        }
    }
    out
}

/// The cut rule of `b ∩ Ω` (`free` lists the axes `b` spans: three for a
/// cell, two for a face), with `q + 1` points per axis.
pub fn mesh_box_rule(mesh: &MeshSolid, b: &Aabb, free: &[usize], q: usize) -> BoxRule {
    let basis = Basis::new(q);
    let mut rule = BoxRule::default();
    // A cell's facets are gathered and clipped once, for its moments, its
    // boundary points and its samples.
    let mut near = Vec::new();
    mesh.for_each_triangle_in(b, |t| near.push(t));
    let pieces: Vec<Piece> = if free.len() == 3 {
        near.iter()
            .map(|&t| Piece {
                t,
                poly: clip_triangle(mesh.triangle(t), b),
            })
            .collect()
    } else {
        Vec::new()
    };
    let weights = if !near.is_empty() {
        if free.len() == 3 {
            let weights = cell_moments(mesh, &basis, b, free, &pieces);
            if mesh.is_dirty() {
                // The volume by the divergence theorem along x, y and z.
                let along = [[0, 1, 2], [1, 2, 0], [2, 0, 1]].map(|order| match order[0] {
                    0 => weights.iter().sum::<f64>(),
                    _ => cell_moments(mesh, &basis, b, &order, &pieces).iter().sum(),
                });
                if repaired::needs_repair(mesh, b, &near, along) {
                    boundary_points(mesh, &basis, &pieces, &mut rule.surface);
                    return repaired::repaired_rule(mesh, b, q, rule.surface);
                }
            }
            weights
        } else {
            moments(mesh, &basis, b, free)
        }
    } else if mesh.phi(center(b)) < 0.0 {
        full_weights(&basis, b, free)
    } else {
        return rule;
    };
    let n = basis.n;
    for (idx, &w) in weights.iter().enumerate() {
        let mut x = b.lo;
        let mut rest = idx;
        for &a in free {
            x[a] = b.lo[a] + (b.hi[a] - b.lo[a]) * basis.t[rest % n];
            rest /= n;
        }
        rule.volume.push(VolumePoint { x, w });
    }
    if free.len() == 3 {
        boundary_points(mesh, &basis, &pieces, &mut rule.surface);
        rule.samples = sample_points(mesh, b, q, &near, &rule.surface);
    }
    rule
}

/// A facet near a cell and its part in the cell (empty when they only touch).
struct Piece {
    t: usize,
    poly: Vec<[f64; 3]>,
}

/// Points of `b ∩ Ω` for least-squares fits (the volume points above may
/// lie outside the body): the centres of a `k³` sub-lattice that are inside
/// (`k = q/2 + 2`, so at least twice the element's Gauss points when the cell
/// is full), topped up with boundary points when the cell holds fewer.
///
/// One winding number decides the cell's centre; a lattice point is inside
/// when the segment from the centre to it crosses the surface an even number
/// of times from an inside centre (odd from an outside one). A crossing
/// counted twice where the segment grazes a shared edge only misplaces a
/// sample, which costs the fit a little and never the rule's exactness.
fn sample_points(
    mesh: &MeshSolid,
    b: &Aabb,
    q: usize,
    near: &[usize],
    surface: &[SurfacePoint],
) -> Vec<[f64; 3]> {
    let k = q / 2 + 2;
    let want = 2 * (q / 2 + 1).pow(3);
    let c = center(b);
    let center_inside = mesh.phi(c) < 0.0;
    let mut out = Vec::with_capacity(k * k * k);
    for idx in 0..k * k * k {
        let ijk = [idx % k, (idx / k) % k, idx / (k * k)];
        let x = [0, 1, 2].map(|a| b.lo[a] + (b.hi[a] - b.lo[a]) * (ijk[a] as f64 + 0.5) / k as f64);
        let d = sub(x, c);
        let crossings = near
            .iter()
            .filter(|&&t| {
                intersect_line(mesh.triangle(t), c, d).is_some_and(|(s, _)| s > 0.0 && s < 1.0)
            })
            .count();
        if center_inside == (crossings % 2 == 0) {
            out.push(x);
        }
    }
    if out.len() < want && !surface.is_empty() {
        let stride = surface.len().div_ceil(want - out.len()).max(1);
        out.extend(surface.iter().step_by(stride).map(|p| p.x));
    }
    out
}

fn center(b: &Aabb) -> [f64; 3] {
    [0, 1, 2].map(|i| 0.5 * (b.lo[i] + b.hi[i]))
}

/// The tensor Gauss weights of the whole box (index `Σ i_m n^m`).
fn full_weights(basis: &Basis, b: &Aabb, free: &[usize]) -> Vec<f64> {
    let n = basis.n;
    (0..n.pow(free.len() as u32))
        .map(|idx| {
            let mut rest = idx;
            let mut w = 1.0;
            for &a in free {
                w *= (b.hi[a] - b.lo[a]) * basis.w[rest % n];
                rest /= n;
            }
            w
        })
        .collect()
}

/// `W_J = ∫_{b∩Ω} L_J` over the three axes of the cell `b` (index
/// `Σ i_m n^m`): the flux through the clipped facets `pieces` plus the face
/// `x_a = hi_a` one dimension down.
fn cell_moments(
    mesh: &MeshSolid,
    basis: &Basis,
    b: &Aabb,
    free: &[usize],
    pieces: &[Piece],
) -> Vec<f64> {
    let mut w = triangle_flux(mesh, basis, b, free, pieces);
    add_upper_face(mesh, basis, b, free, &mut w);
    w
}

/// [`cell_moments`] on a face (two free axes) or an edge (one).
fn moments(mesh: &MeshSolid, basis: &Basis, b: &Aabb, free: &[usize]) -> Vec<f64> {
    if free.len() == 1 {
        return edge_moments(mesh, basis, b, free[0]);
    }
    let mut w = segment_flux(mesh, basis, b, free);
    add_upper_face(mesh, basis, b, free, &mut w);
    w
}

/// Adds `h_a ω_i ∫_{P ∩ {x_a = hi_a}} L_J` (the moments of the face one
/// dimension down, `a = free[0]`) to `w`.
fn add_upper_face(mesh: &MeshSolid, basis: &Basis, b: &Aabb, free: &[usize], w: &mut [f64]) {
    let (n, a) = (basis.n, free[0]);
    let h = b.hi[a] - b.lo[a];
    let mut face = *b;
    face.lo[a] = b.hi[a];
    for (k, low) in moments(mesh, basis, &face, &free[1..]).iter().enumerate() {
        for i in 0..n {
            w[i + n * k] += h * basis.w[i] * low;
        }
    }
}

/// The moments of the inside part of an edge along `a`.
fn edge_moments(mesh: &MeshSolid, basis: &Basis, b: &Aabb, a: usize) -> Vec<f64> {
    let h = b.hi[a] - b.lo[a];
    let mut dir = [0.0; 3];
    dir[a] = 1.0;
    let mut cuts = vec![0.0, h];
    mesh.for_each_triangle_in(b, |t| {
        if let Some((s, _)) = intersect_line(mesh.triangle(t), b.lo, dir) {
            if s > 0.0 && s < h {
                cuts.push(s);
            }
        }
    });
    cuts.sort_by(f64::total_cmp);
    let mut w = vec![0.0; basis.n];
    let mut l = vec![0.0; basis.n];
    for pair in cuts.windows(2) {
        let (s0, s1) = (pair[0], pair[1]);
        if s1 <= s0 {
            continue;
        }
        // Just below the edge (the mesh moved by +0⁺): see the module doc.
        let mut mid = b.lo.map(|v| v - 1e-9 * h);
        mid[a] = b.lo[a] + 0.5 * (s0 + s1);
        if mesh.phi(mid) >= 0.0 {
            continue;
        }
        for (tg, wg) in basis.t.iter().zip(&basis.w) {
            basis.lagrange((s0 + (s1 - s0) * tg) / h, &mut l);
            for (wi, li) in w.iter_mut().zip(&l) {
                *wi += (s1 - s0) * wg * li;
            }
        }
    }
    w
}

/// `Σ ∫ Λ_i(x_a) ℓ_j(x_r) ν_a ds` over the segments where the triangles cross
/// the plane of the face `b` (spanning `free = [a, r]`).
fn segment_flux(mesh: &MeshSolid, basis: &Basis, b: &Aabb, free: &[usize]) -> Vec<f64> {
    let (a, r) = (free[0], free[1]);
    let p = 3 - a - r;
    let c = b.lo[p];
    let (ha, hr) = (b.hi[a] - b.lo[a], b.hi[r] - b.lo[r]);
    let n = basis.n;
    let mut w = vec![0.0; n * n];
    let (mut big, mut small) = (vec![0.0; n], vec![0.0; n]);
    mesh.for_each_triangle_in(b, |t| {
        let Some((p0, p1)) = plane_crossing(mesh.triangle(t), p, c) else {
            return;
        };
        let normal = mesh.normal(t);
        let inplane = (normal[a] * normal[a] + normal[r] * normal[r]).sqrt();
        if inplane == 0.0 {
            return;
        }
        let Some((l0, l1)) = clip_segment(p0, p1, b, &[a, r]) else {
            return;
        };
        let len =
            (((p1[a] - p0[a]) * (l1 - l0)).powi(2) + ((p1[r] - p0[r]) * (l1 - l0)).powi(2)).sqrt();
        let nu_a = normal[a] / inplane;
        for (tg, wg) in basis.t.iter().zip(&basis.w) {
            let lam = l0 + (l1 - l0) * tg;
            let x = [0, 1, 2].map(|k| p0[k] + lam * (p1[k] - p0[k]));
            basis.lagrange_integral((x[a] - b.lo[a]) / ha, &mut big);
            basis.lagrange((x[r] - b.lo[r]) / hr, &mut small);
            let f = wg * len * nu_a * ha;
            for (j, lj) in small.iter().enumerate() {
                for (i, li) in big.iter().enumerate() {
                    w[i + n * j] += f * li * lj;
                }
            }
        }
    });
    w
}

/// The segment where the triangle `v` crosses the plane `x_p = c`, endpoints
/// computed from the edges' lower ends (so that neighbours agree bit for bit).
fn plane_crossing(v: &[[f64; 3]; 3], p: usize, c: f64) -> Option<([f64; 3], [f64; 3])> {
    let above = v.map(|x| x[p] >= c);
    if above.iter().all(|&u| u) || above.iter().all(|&u| !u) {
        return None;
    }
    let mut ends = Vec::with_capacity(2);
    for k in 0..3 {
        let (mut lo, mut hi) = (v[k], v[(k + 1) % 3]);
        if above[k] == above[(k + 1) % 3] {
            continue;
        }
        if lo[p] >= c {
            std::mem::swap(&mut lo, &mut hi);
        }
        let s = (c - lo[p]) / (hi[p] - lo[p]);
        let mut x = [0, 1, 2].map(|i| lo[i] + s * (hi[i] - lo[i]));
        x[p] = c;
        ends.push(x);
    }
    Some((ends[0], ends[1]))
}

/// The parameter range `[λ0, λ1] ⊂ [0, 1]` of `p0 + λ (p1 − p0)` inside the box
/// along `axes` (Liang–Barsky), if not empty; a segment on the box's upper
/// side is outside (half-open box).
fn clip_segment(p0: [f64; 3], p1: [f64; 3], b: &Aabb, axes: &[usize]) -> Option<(f64, f64)> {
    let (mut l0, mut l1) = (0.0f64, 1.0f64);
    for &k in axes {
        let d = p1[k] - p0[k];
        if d == 0.0 {
            if p0[k] < b.lo[k] || p0[k] >= b.hi[k] {
                return None;
            }
            continue;
        }
        let (mut ta, mut tb) = ((b.lo[k] - p0[k]) / d, (b.hi[k] - p0[k]) / d);
        if ta > tb {
            std::mem::swap(&mut ta, &mut tb);
        }
        l0 = l0.max(ta);
        l1 = l1.min(tb);
    }
    (l1 > l0).then_some((l0, l1))
}

/// The triangle `v` clipped to the half-open box `[lo, hi)` of `b`
/// (Sutherland–Hodgman): a convex polygon, empty when they do not meet.
fn clip_triangle(v: &[[f64; 3]; 3], b: &Aabb) -> Vec<[f64; 3]> {
    let mut poly: Vec<[f64; 3]> = v.to_vec();
    for k in 0..3 {
        for (bound, keep_above) in [(b.lo[k], true), (b.hi[k], false)] {
            if poly.is_empty() {
                return poly;
            }
            let inside = |x: &[f64; 3]| (x[k] >= bound) == keep_above;
            let mut out = Vec::with_capacity(poly.len() + 1);
            for i in 0..poly.len() {
                let (cur, next) = (poly[i], poly[(i + 1) % poly.len()]);
                let (ci, ni) = (inside(&cur), inside(&next));
                if ci {
                    out.push(cur);
                }
                if ci != ni {
                    let (lo, hi) = if cur[k] < next[k] {
                        (cur, next)
                    } else {
                        (next, cur)
                    };
                    let s = (bound - lo[k]) / (hi[k] - lo[k]);
                    let mut x = [0, 1, 2].map(|i| lo[i] + s * (hi[i] - lo[i]));
                    x[k] = bound;
                    out.push(x);
                }
            }
            poly = out;
        }
    }
    if poly.len() < 3 {
        poly.clear();
    }
    poly
}

/// Calls `f(x, w)` for the collapsed rule `tri` on every fan triangle of the
/// convex polygon `poly`.
fn for_each_polygon_point(
    poly: &[[f64; 3]],
    tri: &[([f64; 2], f64)],
    mut f: impl FnMut([f64; 3], f64),
) {
    for k in 1..poly.len().saturating_sub(1) {
        let (o, e1, e2) = (poly[0], sub(poly[k], poly[0]), sub(poly[k + 1], poly[0]));
        let twice_area = norm(cross(e1, e2));
        if twice_area == 0.0 {
            continue;
        }
        for ([u, v], w) in tri {
            f(
                [0, 1, 2].map(|i| o[i] + u * e1[i] + v * e2[i]),
                w * twice_area,
            );
        }
    }
}

/// `Σ ∫ Λ_i(x_a) ℓ_j(x_r) ℓ_k(x_s) n_a dS` over the triangles clipped to the
/// cell `b` (`free = [a, r, s]`).
fn triangle_flux(
    mesh: &MeshSolid,
    basis: &Basis,
    b: &Aabb,
    free: &[usize],
    pieces: &[Piece],
) -> Vec<f64> {
    let (a, r, s) = (free[0], free[1], free[2]);
    let h = [0, 1, 2].map(|k| b.hi[k] - b.lo[k]);
    let n = basis.n;
    let mut w = vec![0.0; n * n * n];
    let (mut la, mut lr, mut ls) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for Piece { t, poly } in pieces {
        let na = mesh.normal(*t)[a];
        if na == 0.0 {
            continue;
        }
        for_each_polygon_point(poly, &basis.moment_tri, |x, wq| {
            basis.lagrange_integral((x[a] - b.lo[a]) / h[a], &mut la);
            basis.lagrange((x[r] - b.lo[r]) / h[r], &mut lr);
            basis.lagrange((x[s] - b.lo[s]) / h[s], &mut ls);
            let f = wq * na * h[a];
            for (k, lk) in ls.iter().enumerate() {
                for (j, lj) in lr.iter().enumerate() {
                    let fjk = f * lj * lk;
                    for (i, li) in la.iter().enumerate() {
                        w[i + n * (j + n * k)] += fjk * li;
                    }
                }
            }
        });
    }
    w
}

/// The boundary points of a cell: the rules of its clipped facets.
fn boundary_points(mesh: &MeshSolid, basis: &Basis, pieces: &[Piece], out: &mut Vec<SurfacePoint>) {
    for Piece { t, poly } in pieces {
        let (n, tag) = (mesh.normal(*t), mesh.tag(*t));
        for_each_polygon_point(poly, &basis.surface_tri, |x, w| {
            out.push(SurfacePoint { x, w, n, tag })
        });
    }
}

#[cfg(test)]
mod tests;
