//! The generalised winding number of a triangle mesh (Jacobson, Kavan and
//! Sorkine-Hornung, SIGGRAPH 2013) with the hierarchical far-field
//! approximation of Barill et al. (SIGGRAPH 2018).
//!
//! `w(p) = (1/4π) Σ_t Ω_t(p)`, with `Ω_t` the signed solid angle of triangle
//! `t` seen from `p` (van Oosterom and Strackee):
//!
//! ```text
//! tan(Ω/2) = a·(b×c) / (|a||b||c| + (a·b)|c| + (a·c)|b| + (b·c)|a|),
//! a, b, c = v₀ − p, v₁ − p, v₂ − p.
//! ```
//! For a closed, outward-oriented mesh `w` is 1 inside and 0 outside exactly;
//! across a hole or a flipped patch it blends smoothly, which is what makes the
//! inside test robust to imperfect meshes.
//!
//! **Far field.** A node of the triangle hierarchy whose triangles lie within
//! radius `r` of their area-weighted centroid `c` is replaced, for `|p − c| >
//! β r`, by its dipole term `(Σ_t A_t n_t)·(c − p) / (4π |c − p|³)` (the first
//! term of the expansion; the error of a node is `O((r/|p−c|)²)` of its solid
//! angle). With `β = 3` a closed mesh's `w` stays within a few hundredths of
//! 0 or 1, far from the threshold ½; near the surface every triangle is exact.

use super::MeshSolid;
use crate::spatial::vec3::{cross, dot, norm, scale, sub};
use crate::spatial::Bvh;

/// Far-field radius factor `β`.
const BETA: f64 = 3.0;

/// The dipole of one hierarchy node.
#[derive(Clone, Copy, Debug)]
pub(super) struct FarField {
    /// `Σ_t A_t n_t`.
    area_vector: [f64; 3],
    /// Area-weighted centroid.
    center: [f64; 3],
    /// Largest distance from `center` to a corner.
    radius: f64,
}

/// The far field of every node of `bvh`, by node index.
pub(super) fn far_fields(bvh: &Bvh) -> Vec<FarField> {
    (0..bvh.num_nodes())
        .map(|id| {
            let node = bvh.node(id);
            let (mut av, mut moment, mut area) = ([0.0; 3], [0.0; 3], 0.0);
            for &t in node.triangles {
                let p = bvh.triangle(t);
                let n2 = cross(sub(p[1], p[0]), sub(p[2], p[0]));
                let a = 0.5 * norm(n2);
                for i in 0..3 {
                    av[i] += 0.5 * n2[i];
                    moment[i] += a * (p[0][i] + p[1][i] + p[2][i]) / 3.0;
                }
                area += a;
            }
            let center = if area > 0.0 {
                scale(moment, 1.0 / area)
            } else {
                bvh.triangle(node.triangles[0])[0]
            };
            let radius = node
                .triangles
                .iter()
                .flat_map(|&t| bvh.triangle(t).iter())
                .map(|&v| norm(sub(v, center)))
                .fold(0.0, f64::max);
            FarField {
                area_vector: av,
                center,
                radius,
            }
        })
        .collect()
}

/// The signed solid angle of the triangle `v` seen from `p`.
fn solid_angle(v: &[[f64; 3]; 3], p: [f64; 3]) -> f64 {
    let (a, b, c) = (sub(v[0], p), sub(v[1], p), sub(v[2], p));
    let (la, lb, lc) = (norm(a), norm(b), norm(c));
    let det = dot(a, cross(b, c));
    let den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
    2.0 * det.atan2(den)
}

/// `w(p)` with the far-field approximation.
pub(super) fn winding_number(mesh: &MeshSolid, p: [f64; 3]) -> f64 {
    let (mut far, mut near) = (0.0, 0.0);
    mesh.bvh.visit(
        |node| {
            let f = &mesh.far[node.id];
            let d = sub(f.center, p);
            let dist = norm(d);
            if node.triangles.len() > 1 && dist > BETA * f.radius {
                far += dot(f.area_vector, d) / (dist * dist * dist);
                return false;
            }
            true
        },
        |t| near += solid_angle(mesh.bvh.triangle(t), p),
    );
    (far + near) / (4.0 * std::f64::consts::PI)
}

/// `w(p)` summed over every triangle exactly (the reference).
#[cfg(test)]
pub(super) fn winding_number_exact(mesh: &MeshSolid, p: [f64; 3]) -> f64 {
    (0..mesh.num_triangles())
        .map(|t| solid_angle(mesh.triangle(t), p))
        .sum::<f64>()
        / (4.0 * std::f64::consts::PI)
}
