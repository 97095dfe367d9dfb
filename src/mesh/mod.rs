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

pub mod stl;
mod winding;

use std::collections::HashMap;
use std::fmt;

use serde::Serialize;

use crate::contact::vec3::{cross, dot, norm, sub};
use crate::contact::Bvh;
use crate::geometry::Aabb;
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
        let extent = bounding_box(triangles.iter().flatten());
        let diag2: f64 = (0..3).map(|i| (extent.hi[i] - extent.lo[i]).powi(2)).sum();
        let mut kept: Vec<[u32; 3]> = Vec::with_capacity(triangles.len());
        let mut kept_tags = Vec::with_capacity(triangles.len());
        for (t, &tag) in triangles.iter().zip(tags) {
            let ids = t.map(&mut weld);
            let twice_area = norm(cross(sub(t[1], t[0]), sub(t[2], t[0])));
            let repeated = ids[0] == ids[1] || ids[1] == ids[2] || ids[0] == ids[2];
            if repeated || !(twice_area > 1e-14 * diag2) {
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
        Some(MeshSolid::from_corners(corner_list, kept_tags, diagnostics))
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
        let bbox = bounding_box(corners.iter().flatten());
        let bvh = Bvh::new(corners);
        let far = winding::far_fields(&bvh);
        MeshSolid {
            bvh,
            normals,
            tags,
            far,
            bbox,
            diagnostics,
        }
    }

    /// The mesh after the motion `x ↦ R x + s` (R by columns, orthogonal).
    pub fn moved(&self, r: &[[f64; 3]; 3], s: [f64; 3]) -> MeshSolid {
        let apply =
            |v: [f64; 3]| [0, 1, 2].map(|i| (0..3).map(|c| r[c][i] * v[c]).sum::<f64>() + s[i]);
        let corners = (0..self.num_triangles())
            .map(|t| self.triangle(t).map(apply))
            .collect();
        MeshSolid::from_corners(corners, self.tags.clone(), self.diagnostics.clone())
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

    /// True when some triangle's box meets `b`.
    pub fn may_cross(&self, b: &Aabb) -> bool {
        let mut any = false;
        self.bvh.for_each_in_box(b.lo, b.hi, |_| any = true);
        any
    }

    /// The generalised winding number at `x`: 1 inside and 0 outside a closed
    /// mesh (see [`winding`]).
    pub fn winding_number(&self, x: [f64; 3]) -> f64 {
        winding::winding_number(self, x)
    }

    /// The level set `½ − w(x)`, negative inside.
    pub fn phi(&self, x: [f64; 3]) -> f64 {
        0.5 - self.winding_number(x)
    }
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

fn bounding_box<'a>(points: impl Iterator<Item = &'a [f64; 3]>) -> Aabb {
    let mut b = Aabb::new([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in points {
        for i in 0..3 {
            b.lo[i] = b.lo[i].min(p[i]);
            b.hi[i] = b.hi[i].max(p[i]);
        }
    }
    b
}

#[cfg(test)]
pub(crate) mod tests;
