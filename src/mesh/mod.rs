//! Solids bounded by triangle meshes (STL parts): the cleaned mesh, its
//! boundary tags, its load-time diagnostics, and the inside test by the
//! generalised winding number ([`winding`]).
//!
//! A mesh is taken as read (vertices welded where their coordinates are equal
//! bit for bit) and then cleaned: triangles with a repeated corner or no area
//! are dropped, and a mesh whose signed volume is negative (inverted normals)
//! is flipped. Edges used by one triangle only are *open*, edges used by more
//! than two *non-manifold*; both are counted and reported but not repaired:
//! the winding number degrades gracefully across them (a T-junction closes the
//! surface geometrically, so nothing is lost; a small hole blurs the inside
//! test only near the hole).
//!
//! The level set of a mesh solid is `φ = ½ − w` with `w` the generalised
//! winding number: `−½` inside and `+½` outside a closed mesh, exactly, and a
//! smooth blend across the gaps of an open one.

mod overlap;
pub mod stl;
mod winding;

use std::collections::HashMap;
use std::fmt;

use serde::Serialize;

use crate::spatial::vec3::{cross, dot, norm, sub};
use crate::spatial::Aabb;
use crate::spatial::Bvh;
use winding::FarField;

/// What loading and cleaning a mesh found, for `report.json` and stderr.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct MeshDiagnostics {
    /// Triangles in the file(s).
    pub triangles_read: usize,
    /// Triangles kept (read minus degenerate).
    pub triangles: usize,
    /// Triangles dropped for a repeated corner or a zero area.
    pub degenerate_dropped: usize,
    /// Welded vertices.
    pub vertices: usize,
    /// Edges used by one triangle only.
    pub open_edges: usize,
    /// Edges used by more than two triangles.
    pub non_manifold_edges: usize,
    /// Manifold edges that both of their triangles run the same way.
    pub misoriented_edges: usize,
    /// Edges that pass through the inside of a triangle they do not share a
    /// corner with: the surface intersects itself.
    pub self_intersections: usize,
    /// Connected pieces of the surface (triangles sharing a vertex): more
    /// than one where a part has a cavity, or shells lie inside each other.
    pub shells: usize,
    /// True when the mesh was inverted (negative volume) and has been flipped.
    pub flipped: bool,
    /// Enclosed volume `Σ v₀·(v₁×v₂)/6` after flipping.
    pub volume: f64,
    /// Surface area `Σ |(v₁−v₀)×(v₂−v₀)|/2`.
    pub area: f64,
}

impl MeshDiagnostics {
    /// One line for stderr.
    pub fn summary(&self) -> String {
        let mut s = format!(
            "{} triangles, {} vertices, volume {:.6e}, area {:.6e}, {} open and {} non-manifold edges",
            self.triangles, self.vertices, self.volume, self.area, self.open_edges, self.non_manifold_edges
        );
        if self.degenerate_dropped > 0 {
            s += &format!(", {} degenerate triangles dropped", self.degenerate_dropped);
        }
        if self.misoriented_edges > 0 {
            s += &format!(
                ", {} edges with inconsistent orientation",
                self.misoriented_edges
            );
        }
        if self.self_intersections > 0 {
            s += &format!(
                ", {} edges through other triangles",
                self.self_intersections
            );
        }
        if self.shells > 1 {
            s += &format!(", {} shells", self.shells);
        }
        if self.flipped {
            s += ", normals pointed inward: flipped";
        }
        s
    }
}

/// A solid bounded by a triangle mesh, with one boundary tag per triangle.
#[derive(Clone)]
pub struct MeshSolid {
    bvh: Bvh,
    /// Unit outward normal per triangle.
    normals: Vec<[f64; 3]>,
    /// Boundary tag per triangle (an index into the geometry's tag names).
    tags: Vec<u16>,
    far: Vec<FarField>,
    bbox: Aabb,
    diagnostics: MeshDiagnostics,
    /// Per triangle, whether the winding number on its two sides is not 1
    /// behind and 0 in front ([`MeshSolid::irregular`]); empty for a mesh
    /// without defects.
    irregular: Vec<bool>,
}

impl fmt::Debug for MeshSolid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "MeshSolid({})", self.diagnostics.summary())
    }
}

/// Two mesh solids are equal when their triangles and tags are.
impl PartialEq for MeshSolid {
    fn eq(&self, o: &MeshSolid) -> bool {
        self.tags == o.tags && (0..self.num_triangles()).all(|t| self.triangle(t) == o.triangle(t))
    }
}

impl MeshSolid {
    /// The solid bounded by `triangles` (corners), with `tags` per triangle.
    /// Vertices are welded by exact equality; degenerate triangles are dropped
    /// and an inverted mesh is flipped. `None` when no triangle is left.
    pub fn new(triangles: &[[[f64; 3]; 3]], tags: &[u16]) -> Option<MeshSolid> {
        let mut index: HashMap<[u64; 3], u32> = HashMap::new();
        let mut vertices: Vec<[f64; 3]> = Vec::new();
        let mut weld = |p: [f64; 3]| -> u32 {
            *index.entry(p.map(f64::to_bits)).or_insert_with(|| {
                vertices.push(p);
                (vertices.len() - 1) as u32
            })
        };
        let extent = Aabb::around(triangles.iter().flatten());
        let diag2: f64 = (0..3).map(|i| (extent.hi[i] - extent.lo[i]).powi(2)).sum();
        let mut kept: Vec<[u32; 3]> = Vec::with_capacity(triangles.len());
        let mut kept_tags = Vec::with_capacity(triangles.len());
        for (t, &tag) in triangles.iter().zip(tags) {
            let ids = t.map(&mut weld);
            let twice_area = norm(cross(sub(t[1], t[0]), sub(t[2], t[0])));
            let repeated = ids[0] == ids[1] || ids[1] == ids[2] || ids[0] == ids[2];
            let degenerate =
                twice_area.partial_cmp(&(1e-14 * diag2)) != Some(std::cmp::Ordering::Greater);
            if repeated || degenerate {
                continue;
            }
            kept.push(ids);
            kept_tags.push(tag);
        }
        if kept.is_empty() {
            return None;
        }
        let mut diagnostics = MeshDiagnostics {
            triangles_read: triangles.len(),
            triangles: kept.len(),
            degenerate_dropped: triangles.len() - kept.len(),
            vertices: vertices.len(),
            ..MeshDiagnostics::default()
        };
        count_edges(&kept, &mut diagnostics);
        diagnostics.shells = count_shells(&kept, vertices.len());
        let corners = |t: &[u32; 3]| t.map(|v| vertices[v as usize]);
        let volume: f64 = kept
            .iter()
            .map(|t| {
                let p = corners(t);
                dot(p[0], cross(p[1], p[2])) / 6.0
            })
            .sum();
        if volume < 0.0 {
            kept.iter_mut().for_each(|t| t.swap(1, 2));
            diagnostics.flipped = true;
        }
        diagnostics.volume = volume.abs();
        let corner_list: Vec<[[f64; 3]; 3]> = kept.iter().map(corners).collect();
        let mut mesh = MeshSolid::from_corners(corner_list, kept_tags, diagnostics);
        let crossing = mesh.self_intersections(&kept);
        mesh.diagnostics.self_intersections = crossing.len();
        if mesh.is_dirty() {
            mesh.irregular = (0..mesh.num_triangles())
                .map(|t| mesh.sides_are_irregular(t))
                .collect();
            // A facet through another is irregular along the crossing,
            // wherever its centroid lies.
            for (t, o) in crossing {
                mesh.irregular[t] = true;
                mesh.irregular[o] = true;
            }
        }
        Some(mesh)
    }

    /// Edges crossing the inside of a triangle with no common vertex
    /// (`ids`: the welded vertex ids of each triangle), as (the edge's
    /// triangle, the crossed triangle), one per crossing.
    fn self_intersections(&self, ids: &[[u32; 3]]) -> Vec<(usize, usize)> {
        const INTERIOR: f64 = 1e-9;
        let mut crossing = Vec::new();
        for (t, tid) in ids.iter().enumerate() {
            let p = self.triangle(t);
            for k in 0..3 {
                let (a, b) = (p[k], p[(k + 1) % 3]);
                let lo = [0, 1, 2].map(|i| a[i].min(b[i]));
                let hi = [0, 1, 2].map(|i| a[i].max(b[i]));
                let d = sub(b, a);
                self.bvh.for_each_in_box(lo, hi, |o| {
                    if ids[o].iter().any(|v| tid.contains(v)) {
                        return;
                    }
                    if let Some((s, bary)) = crate::spatial::intersect_line(self.triangle(o), a, d)
                    {
                        let inside = bary.iter().all(|&w| w > INTERIOR);
                        if inside && s > INTERIOR && s < 1.0 - INTERIOR {
                            crossing.push((t, o));
                        }
                    }
                });
            }
        }
        crossing
    }

    fn from_corners(
        corners: Vec<[[f64; 3]; 3]>,
        tags: Vec<u16>,
        mut diagnostics: MeshDiagnostics,
    ) -> MeshSolid {
        let scaled: Vec<[f64; 3]> = corners
            .iter()
            .map(|p| cross(sub(p[1], p[0]), sub(p[2], p[0])))
            .collect();
        diagnostics.area = scaled.iter().map(|n| 0.5 * norm(*n)).sum();
        let normals = scaled.iter().map(|&n| n.map(|v| v / norm(n))).collect();
        let bbox = Aabb::around(corners.iter().flatten());
        let bvh = Bvh::new(corners);
        let far = winding::far_fields(&bvh);
        MeshSolid {
            bvh,
            normals,
            tags,
            far,
            bbox,
            diagnostics,
            irregular: Vec::new(),
        }
    }

    /// Whether the load found a defect, or something that may hide one:
    /// open, non-manifold or misoriented edges, edges through other
    /// triangles, or several shells (one may lie inside another with the
    /// same orientation). The cut rules of a dirty mesh are checked cell by
    /// cell ([`crate::quadrature::repaired`]).
    pub fn is_dirty(&self) -> bool {
        let d = &self.diagnostics;
        d.open_edges + d.non_manifold_edges + d.misoriented_edges + d.self_intersections > 0
            || d.shells > 1
    }

    /// Whether triangle `t` does not separate the inside (`w = 1` behind it)
    /// from the outside (`w = 0` in front), within 0.25 (a closed mesh's
    /// far field is within a few hundredths; a duplicate facet puts 1.5 and
    /// 0.5 there): a
    /// facet of an overlapping or inverted shell, or one inside or outside
    /// another part of the surface. Always false on a mesh that is not
    /// [`MeshSolid::is_dirty`].
    pub fn irregular(&self, t: usize) -> bool {
        self.irregular.get(t).copied().unwrap_or(false)
    }

    /// The winding numbers just behind and in front of `t`'s centroid
    /// (`10⁻⁶` of its size away) are not within 0.25 of 1 and 0.
    fn sides_are_irregular(&self, t: usize) -> bool {
        let v = self.triangle(t);
        let c = [0, 1, 2].map(|i| (v[0][i] + v[1][i] + v[2][i]) / 3.0);
        let size = norm(sub(v[1], v[0])).max(norm(sub(v[2], v[0])));
        let n = self.normal(t);
        let at = |s: f64| self.winding_number([0, 1, 2].map(|i| c[i] + s * 1e-6 * size * n[i]));
        (at(-1.0) - 1.0).abs() > 0.25 || at(1.0).abs() > 0.25
    }

    /// The mesh after the motion `x ↦ R x + s` (R by columns, orthogonal).
    pub fn moved(&self, r: &[[f64; 3]; 3], s: [f64; 3]) -> MeshSolid {
        let apply =
            |v: [f64; 3]| [0, 1, 2].map(|i| (0..3).map(|c| r[c][i] * v[c]).sum::<f64>() + s[i]);
        let corners = (0..self.num_triangles())
            .map(|t| self.triangle(t).map(apply))
            .collect();
        let mut mesh =
            MeshSolid::from_corners(corners, self.tags.clone(), self.diagnostics.clone());
        mesh.irregular = self.irregular.clone();
        mesh
    }

    /// The same mesh with every tag passed through `f`.
    pub fn retagged(&self, f: impl Fn(u16) -> u16) -> MeshSolid {
        self.clone()
            .with_tags(self.tags.iter().map(|&t| f(t)).collect())
    }

    /// The mesh with the tags `tags`, one per triangle.
    pub fn with_tags(mut self, tags: Vec<u16>) -> MeshSolid {
        assert_eq!(tags.len(), self.tags.len(), "one tag per triangle");
        self.tags = tags;
        self
    }

    pub fn num_triangles(&self) -> usize {
        self.bvh.num_triangles()
    }

    /// The corners of triangle `t` (counter-clockwise seen from outside).
    pub fn triangle(&self, t: usize) -> &[[f64; 3]; 3] {
        self.bvh.triangle(t)
    }

    /// The unit outward normal of triangle `t`.
    pub fn normal(&self, t: usize) -> [f64; 3] {
        self.normals[t]
    }

    /// The boundary tag of triangle `t`.
    pub fn tag(&self, t: usize) -> u16 {
        self.tags[t]
    }

    /// The box of the mesh.
    pub fn bounding_box(&self) -> Aabb {
        self.bbox
    }

    pub fn diagnostics(&self) -> &MeshDiagnostics {
        &self.diagnostics
    }

    /// Calls `f` for every triangle whose box meets `b`.
    pub fn for_each_triangle_in(&self, b: &Aabb, f: impl FnMut(usize)) {
        self.bvh.for_each_in_box(b.lo, b.hi, f)
    }

    /// True when some triangle meets `b` ([`overlap::triangle_meets_box`]):
    /// the boxes of a few large facets of a rotated part cover much of its
    /// inside, where they are not.
    pub fn crosses(&self, b: &Aabb) -> bool {
        let mut any = false;
        self.bvh.for_each_in_box(b.lo, b.hi, |t| {
            any = any || overlap::triangle_meets_box(self.triangle(t), b)
        });
        any
    }

    /// The plane `(n, d)` (`n·x = d`, `n` the outward normal) and the tag
    /// of the triangles that meet `b`, when there are some and they lie in
    /// one plane with one tag: normals within `10⁻⁶` and corners within
    /// `10⁻⁶` of `b`'s size of the first one's (an STL's float corners put
    /// the two triangles of a flat face that far apart). Inside `b` the
    /// solid is then that half-space, up to that tolerance.
    pub fn plane_in(&self, b: &Aabb) -> Option<([f64; 3], f64, u16)> {
        let size = (0..3).map(|i| b.hi[i] - b.lo[i]).fold(0.0, f64::max);
        let mut plane: Option<([f64; 3], f64, u16)> = None;
        let mut planar = true;
        self.bvh.for_each_in_box(b.lo, b.hi, |t| {
            if !planar || !overlap::triangle_meets_box(self.triangle(t), b) {
                return;
            }
            let (n, tag) = (self.normals[t], self.tags[t]);
            match plane {
                None => plane = Some((n, dot(n, self.triangle(t)[0]), tag)),
                Some((n0, d0, tag0)) => {
                    let close = norm(sub(n, n0)) <= 1e-6
                        && tag == tag0
                        && self
                            .triangle(t)
                            .iter()
                            .all(|&v| (dot(n0, v) - d0).abs() <= 1e-6 * size);
                    planar = close;
                }
            }
        });
        plane.filter(|_| planar)
    }

    /// The generalised winding number at `x`: 1 inside and 0 outside a closed
    /// mesh (see [`winding`]).
    pub fn winding_number(&self, x: [f64; 3]) -> f64 {
        winding::winding_number(self, x)
    }

    /// The share of the points of a `16³` lattice in the mesh's box where the
    /// winding number is not within 0.2 of 0 or 1: about zero for a closed
    /// surface (T-junctions included), small for a mesh with a small hole,
    /// large for a triangle soup or overlapping shells (where `w` reaches 2).
    pub fn ambiguity(&self) -> f64 {
        let k = 16;
        let b = self.bbox;
        let mut ambiguous = 0;
        for idx in 0..k * k * k {
            let ijk = [idx % k, (idx / k) % k, idx / (k * k)];
            let x =
                [0, 1, 2].map(|a| b.lo[a] + (b.hi[a] - b.lo[a]) * (ijk[a] as f64 + 0.5) / k as f64);
            let w = self.winding_number(x);
            if w.min((w - 1.0).abs()).abs() > 0.2 {
                ambiguous += 1;
            }
        }
        f64::from(ambiguous) / (k * k * k) as f64
    }

    /// The level set `½ − w(x)`, negative inside.
    pub fn phi(&self, x: [f64; 3]) -> f64 {
        0.5 - self.winding_number(x)
    }
}

/// The 12 triangles of the box `lo..hi`, outward (for tests of STL parts).
pub fn box_triangles(lo: [f64; 3], hi: [f64; 3]) -> Vec<[[f64; 3]; 3]> {
    let c = |k: usize| [0, 1, 2].map(|i| if k >> i & 1 == 1 { hi[i] } else { lo[i] });
    // Faces as corner-index quads, counter-clockwise seen from outside.
    let quads = [
        [0, 4, 6, 2],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 2, 3, 1],
        [4, 5, 7, 6],
    ];
    quads
        .iter()
        .flat_map(|q| [[c(q[0]), c(q[1]), c(q[2])], [c(q[0]), c(q[2]), c(q[3])]])
        .collect()
}

/// A sphere of radius `r` about `center` tessellated from an octahedron by
/// `k` midpoint subdivisions pushed to the sphere: `8 · 4^k` triangles,
/// outward (for tests and benchmarks of STL parts).
pub fn tessellated_sphere(center: [f64; 3], r: f64, k: u32) -> Vec<[[f64; 3]; 3]> {
    let mut tris: Vec<[[f64; 3]; 3]> = Vec::new();
    for s in 0..8u32 {
        let sg = |b: u32| if s >> b & 1 == 1 { -1.0 } else { 1.0 };
        let (x, y, z) = ([sg(0), 0.0, 0.0], [0.0, sg(1), 0.0], [0.0, 0.0, sg(2)]);
        // A reflection in an odd number of planes reverses the orientation.
        tris.push(if s.count_ones() % 2 == 1 {
            [x, z, y]
        } else {
            [x, y, z]
        });
    }
    let unit = |a: [f64; 3], b: [f64; 3]| {
        let m = [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
        let l = norm(m);
        m.map(|v| v / l)
    };
    for _ in 0..k {
        tris = tris
            .iter()
            .flat_map(|t| {
                let (a, b, c) = (unit(t[0], t[1]), unit(t[1], t[2]), unit(t[2], t[0]));
                [[t[0], a, c], [a, t[1], b], [c, b, t[2]], [a, b, c]]
            })
            .collect();
    }
    tris.iter()
        .map(|t| t.map(|p| [0, 1, 2].map(|i| center[i] + r * p[i])))
        .collect()
}

/// Connected pieces of `triangles` (welded vertex ids, `vertices` of
/// them), triangles sharing a vertex being connected.
fn count_shells(triangles: &[[u32; 3]], vertices: usize) -> usize {
    let mut parent: Vec<u32> = (0..vertices as u32).collect();
    fn root(parent: &mut [u32], mut v: u32) -> u32 {
        while parent[v as usize] != v {
            parent[v as usize] = parent[parent[v as usize] as usize];
            v = parent[v as usize];
        }
        v
    }
    for t in triangles {
        for k in 1..3 {
            let (a, b) = (root(&mut parent, t[0]), root(&mut parent, t[k]));
            parent[a.max(b) as usize] = a.min(b);
        }
    }
    let mut used = vec![false; vertices];
    for &v in triangles.iter().flatten() {
        used[v as usize] = true;
    }
    (0..vertices as u32)
        .filter(|&v| used[v as usize] && root(&mut parent, v) == v)
        .count()
}

/// Counts open, non-manifold and misoriented edges.
fn count_edges(triangles: &[[u32; 3]], d: &mut MeshDiagnostics) {
    // Per undirected edge: (uses, uses running from the lower to the higher id).
    let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let e = edges.entry((a.min(b), a.max(b))).or_default();
            e.0 += 1;
            e.1 += u32::from(a < b);
        }
    }
    for (uses, forward) in edges.values() {
        match uses {
            1 => d.open_edges += 1,
            2 if *forward != 1 => d.misoriented_edges += 1,
            2 => {}
            _ => d.non_manifold_edges += 1,
        }
    }
}

#[cfg(test)]
pub(crate) mod tests;
