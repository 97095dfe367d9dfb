//! The body's boundary as a triangle mesh for output (`surface.vtp`): its
//! vertices on the boundary, one tag per triangle, and for each vertex the
//! active grid cell through whose shape functions fields are evaluated there.
//!
//! **Level sets.** Each CSG leaf ψ's zero set is meshed by the contact
//! surface's marching tetrahedra (`contact/marching.rs`): vertices on
//! ψ = 0 to round-off, the area converging like h². The leaf is the body's
//! boundary at `x` when it attains φ there, `φ(x) = ±ψ(x)` bit for bit (`+`
//! an added leaf, `−` a subtracted one): that is, where `x` lies inside (or on)
//! the other operands. Unlike the contact surface, which keeps or drops whole
//! triangles (a rim ragged by a triangle), each triangle is clipped to that
//! region: a vertex is kept where the leaf attains φ, and an edge from such a
//! vertex `a` to one `b` where it does not gets the rim point, found by
//! bisection on `t ∈ [0, 1]` of the predicate at `P(a + t (b − a))`, `P` the
//! projection onto ψ = 0 by Newton steps `x ← x − ψ ∇ψ / |∇ψ|²`; the rim
//! point is `P` at the last `t` where the leaf attains φ, so it lies on ψ = 0
//! and inside the other operands (on their boundary to the bisection's
//! accuracy). The clipped polygon is split into a fan, oriented outwards
//! (flipped for a subtracted leaf, as the contact surface's polarity test
//! decides), tagged by the leaf. A leaf with the same shape and placement
//! as an earlier one (coplanar faces of two cuboids in a union) is the same
//! function, so it attains φ exactly where the earlier one does: it is
//! meshed once, with the earlier leaf's tag. Rim points are shared by the two triangles
//! of their edge; the parts of different leaves are not stitched together.
//!
//! **Mesh solids.** A mesh solid's boundary is its own STL triangles,
//! each clipped to the grid's box `B` (Sutherland–Hodgman against the six
//! planes `x_a = lo_a`, `x_a = hi_a`: a vertex is kept when on the inner side,
//! and an edge crossing a plane adds the point `p + t (q − p)` with
//! `t = (c − p_a) / (q_a − p_a)`), the clipped polygon split into a fan.
//! Vertices are welded by exact equality of their coordinates. A mesh leaf
//! of a CSG tree keeps the parts of its clipped triangles that bound the
//! solid, each facing out: whole triangles away from the other surfaces,
//! split in four down to edges of `h/4` where they cross one (the rim is
//! ragged by that much, and the pieces are not welded); the analytic
//! leaves are meshed as above.
//!
//! **Host cells.** A boundary point `x` lies in the closure of one to eight
//! grid cells, of which those not outside carry the solution (all their nodes
//! are active) and agree on `u_h(x)` by continuity. The host is the cell
//! not outside nearest to `x` among the 27 around the cell of `x` (distance
//! from `x` to the cell's box, 0 for a cell containing it; ties to the lower
//! index). A cell is outside although `x` is on the boundary where it holds a
//! merged sliver (`crate::cells` merges cut cells of negligible volume into a
//! face neighbour, whose shape functions continue the solution there) or at a
//! ragged rim; the nearest active cell continues `u_h` polynomially. A
//! triangle with a vertex that has no active cell among the 27 is dropped.

use std::collections::HashMap;

use rayon::prelude::*;

use crate::cells::CellKind;
use crate::discrete::marching;
use crate::geometry::polarity::{polarity_on_boundary, Polarity};
use crate::geometry::scalar::Dual;
use crate::geometry::surface::Leaf;
use crate::geometry::{Geometry, LocalSolid};
use crate::grid::Grid;
use crate::mesh::MeshSolid;
use crate::quadrature::mixed::on_boundary;
use crate::quadrature::saye::SurfacePoint;
use crate::spatial::vec3::normalize;
use crate::spatial::vec3::{cross, sub};
use crate::spatial::Aabb;

/// A triangulated boundary with host cells and tags.
#[derive(Clone, Debug, Default)]
pub struct BoundaryMesh {
    /// Reference positions of the vertices, on the boundary.
    pub points: Vec<[f64; 3]>,
    /// The active cell each point is evaluated in (see the module doc).
    pub host: Vec<usize>,
    /// Vertex indices, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    /// The boundary tag of each triangle (an index into the geometry's tag
    /// names).
    pub tags: Vec<u16>,
}

impl BoundaryMesh {
    /// The boundary of `geometry` on `grid`, with hosts among the cells of
    /// class `kinds` (see the module doc).
    pub fn new(grid: &Grid, kinds: &[CellKind], geometry: &Geometry) -> BoundaryMesh {
        let raw = RawSurface::new(grid, geometry);
        let hosts = raw.hosts(grid, kinds);
        raw.hosted(&hosts).0
    }
}

/// The boundary's triangles before any host is looked up: the same on
/// every rank of a distributed run, whatever cells it classified.
#[derive(Clone, Debug, Default)]
pub struct RawSurface {
    pub points: Vec<[f64; 3]>,
    pub triangles: Vec<[u32; 3]>,
    pub tags: Vec<u16>,
}

impl RawSurface {
    /// The boundary of `geometry` on `grid` (marching tetrahedra on each
    /// CSG leaf, or a mesh solid's triangles clipped to the grid).
    pub fn new(grid: &Grid, geometry: &Geometry) -> RawSurface {
        let (points, triangles, tags) = match geometry.mesh() {
            Some(mesh) => clipped_mesh(mesh, &grid.bounding_box()),
            None => {
                let mut out = (Vec::new(), Vec::new(), Vec::new());
                let leaves = geometry.leaves();
                for (i, leaf) in leaves.iter().enumerate() {
                    // A leaf equal to an earlier one (two cuboids on one
                    // plane) attains φ wherever the earlier one does.
                    let repeated = leaves[..i]
                        .iter()
                        .any(|l| l.shape == leaf.shape && l.frame == leaf.frame);
                    if !repeated {
                        add_leaf(grid, geometry, leaf, &mut out);
                    }
                }
                for mesh in geometry.meshes() {
                    add_mesh_leaf(grid, geometry, mesh, &mut out);
                }
                out
            }
        };
        RawSurface {
            points,
            triangles,
            tags,
        }
    }

    /// Each point's host among the cells of class `kinds`, if it has one.
    pub fn hosts(&self, grid: &Grid, kinds: &[CellKind]) -> Vec<Option<usize>> {
        self.points
            .par_iter()
            .map(|&x| host_cell(grid, kinds, x))
            .collect()
    }

    /// The triangles whose vertices all have a host in `hosts` (one per
    /// point), their vertices renumbered in order of first use; and the
    /// index in `self.points` of each vertex kept.
    pub fn hosted(&self, hosts: &[Option<usize>]) -> (BoundaryMesh, Vec<usize>) {
        let mut out = BoundaryMesh::default();
        let mut sources = Vec::new();
        let mut new_index = vec![u32::MAX; self.points.len()];
        for (t, &tag) in self.triangles.iter().zip(&self.tags) {
            if t.iter().any(|&v| hosts[v as usize].is_none()) {
                continue;
            }
            let mut tri = [0u32; 3];
            for (k, &v) in t.iter().enumerate() {
                let v = v as usize;
                if new_index[v] == u32::MAX {
                    new_index[v] = out.points.len() as u32;
                    out.points.push(self.points[v]);
                    out.host.push(hosts[v].expect("checked above"));
                    sources.push(v);
                }
                tri[k] = new_index[v];
            }
            out.triangles.push(tri);
            out.tags.push(tag);
        }
        (out, sources)
    }
}

/// The cell not outside nearest to `x` among the 27 around the cell of `x`
/// (see the module doc), or `None`.
fn host_cell(grid: &Grid, kinds: &[CellKind], x: [f64; 3]) -> Option<usize> {
    let centre = [0, 1, 2].map(|a| {
        let i = ((x[a] - grid.origin[a]) / grid.h).floor();
        i.clamp(0.0, (grid.n[a] - 1) as f64) as usize
    });
    let mut best: Option<(f64, usize)> = None;
    for dk in 0..3 {
        for dj in 0..3 {
            for di in 0..3 {
                let d = [di, dj, dk];
                // The neighbour's index along each axis, `None` off the grid.
                let along = |a: usize| (centre[a] + d[a]).checked_sub(1).filter(|&i| i < grid.n[a]);
                let (Some(i), Some(j), Some(k)) = (along(0), along(1), along(2)) else {
                    continue;
                };
                let c = grid.cell_index([i, j, k]);
                if kinds[c] == CellKind::Outside {
                    continue;
                }
                let dist = box_distance(&grid.cell_box(c), x);
                if best.is_none_or(|(bd, bc)| dist < bd || (dist == bd && c < bc)) {
                    best = Some((dist, c));
                }
            }
        }
    }
    best.map(|(_, c)| c)
}

/// The distance from `x` to the box `b` (0 inside or on it).
fn box_distance(b: &Aabb, x: [f64; 3]) -> f64 {
    let mut d2 = 0.0;
    for a in 0..3 {
        let e = (b.lo[a] - x[a]).max(x[a] - b.hi[a]).max(0.0);
        d2 += e * e;
    }
    d2.sqrt()
}

/// Points, triangles and a tag per triangle.
type Triangulation = (Vec<[f64; 3]>, Vec<[u32; 3]>, Vec<u16>);

/// Whether `leaf` attains the level set φ of `geometry` at `x` (is the
/// boundary there when `x` is on its zero set).
fn attains(geometry: &Geometry, leaf: &Leaf, x: [f64; 3]) -> bool {
    let (phi, psi) = (geometry.phi(x), leaf.eval(x));
    phi == psi || phi == -psi
}

/// `x` moved onto the leaf's zero set by Newton steps along ∇ψ.
fn project(leaf: &Leaf, mut x: [f64; 3]) -> [f64; 3] {
    for _ in 0..4 {
        let d = leaf.eval([Dual::var(x[0], 0), Dual::var(x[1], 1), Dual::var(x[2], 2)]);
        let g2 = d.d[0] * d.d[0] + d.d[1] * d.d[1] + d.d[2] * d.d[2];
        if d.v == 0.0 || g2 == 0.0 {
            break;
        }
        x = [0, 1, 2].map(|a| x[a] - d.v * d.d[a] / g2);
    }
    x
}

/// The rim point between `a` (the leaf attains φ) and `b` (it does not):
/// bisection of the projected edge (see the module doc).
fn rim_point(geometry: &Geometry, leaf: &Leaf, a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    let at = |t: f64| project(leaf, [0, 1, 2].map(|k| a[k] + t * (b[k] - a[k])));
    let (mut t_in, mut t_out) = (0.0f64, 1.0f64);
    let mut inside = a;
    for _ in 0..60 {
        let t = 0.5 * (t_in + t_out);
        let x = at(t);
        if attains(geometry, leaf, x) {
            (t_in, inside) = (t, x);
        } else {
            t_out = t;
        }
    }
    inside
}

/// Appends leaf `leaf`'s part of the boundary to `out` (see the module doc).
fn add_leaf(grid: &Grid, geometry: &Geometry, leaf: &Leaf, out: &mut Triangulation) {
    let raw = marching::extract(grid, &|x| leaf.eval(x));
    let on: Vec<bool> = raw
        .vertices
        .iter()
        .map(|&x| attains(geometry, leaf, x))
        .collect();
    let (points, triangles, tags) = out;
    let mut kept = vec![u32::MAX; raw.vertices.len()];
    let mut rim: HashMap<(u32, u32), u32> = HashMap::new();
    for (v, _) in &raw.triangles {
        let polarity = v
            .iter()
            .filter(|&&k| on[k as usize])
            .find_map(|&k| polarity_on_boundary(geometry, leaf, raw.vertices[k as usize], grid.h));
        let Some(polarity) = polarity else {
            continue;
        };
        let mut polygon: Vec<u32> = Vec::with_capacity(4);
        for e in 0..3 {
            let (a, b) = (v[e] as usize, v[(e + 1) % 3] as usize);
            if on[a] {
                if kept[a] == u32::MAX {
                    kept[a] = points.len() as u32;
                    points.push(raw.vertices[a]);
                }
                polygon.push(kept[a]);
            }
            if on[a] != on[b] {
                let (i, o) = if on[a] { (a, b) } else { (b, a) };
                let id = *rim.entry((i as u32, o as u32)).or_insert_with(|| {
                    let x = rim_point(geometry, leaf, raw.vertices[i], raw.vertices[o]);
                    points.push(x);
                    (points.len() - 1) as u32
                });
                polygon.push(id);
            }
        }
        for k in 1..polygon.len().saturating_sub(1) {
            let mut t = [polygon[0], polygon[k], polygon[k + 1]];
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                continue;
            }
            if let Polarity::Subtracted = polarity {
                t.swap(1, 2);
            }
            triangles.push(t);
            tags.push(leaf.tag);
        }
    }
}

/// Appends the triangles of a mesh leaf of a CSG tree that bound the solid,
/// turned to face out of it: each clipped triangle whole where no other
/// surface reaches its box ([`Geometry::local`]) or where its corners
/// (nudged to its centroid) and centroid all bound it the same way
/// ([`crate::quadrature::mixed::on_boundary`]), else split in four at its
/// edges' midpoints down to edges of `h/4`, the smallest pieces kept by
/// their centroid.
fn add_mesh_leaf(grid: &Grid, geometry: &Geometry, mesh: &MeshSolid, out: &mut Triangulation) {
    let (points, triangles, tags) = clipped_mesh(mesh, &grid.bounding_box());
    for (t, tag) in triangles.into_iter().zip(tags) {
        let corners = t.map(|v| points[v as usize]);
        let n = normalize(cross(
            sub(corners[1], corners[0]),
            sub(corners[2], corners[0]),
        ));
        add_mesh_piece(geometry, corners, n, tag, grid.h, out);
    }
}

fn add_mesh_piece(
    geometry: &Geometry,
    c: [[f64; 3]; 3],
    n: [f64; 3],
    tag: u16,
    h: f64,
    out: &mut Triangulation,
) {
    // Where no other surface reaches the piece's box, the solid there is the
    // mesh's inside or outside as a whole: no winding numbers needed.
    match geometry.local(&Aabb::around(&c)) {
        LocalSolid::Mesh(_) => return push_piece(c, true, tag, out),
        LocalSolid::MeshOutside(_) => return push_piece(c, false, tag, out),
        _ => {}
    }
    let centroid = [0, 1, 2].map(|i| (c[0][i] + c[1][i] + c[2][i]) / 3.0);
    let side = |x: [f64; 3]| {
        let p = SurfacePoint { x, w: 0.0, n, tag };
        on_boundary(geometry, p, h).map(|kept| kept.n == n)
    };
    let at_centroid = side(centroid);
    let nudged = c.map(|v| [0, 1, 2].map(|i| 0.9 * v[i] + 0.1 * centroid[i]));
    let longest = (0..3)
        .map(|k| crate::spatial::vec3::norm(sub(c[(k + 1) % 3], c[k])))
        .fold(0.0, f64::max);
    if longest > 0.25 * h && nudged.iter().any(|&x| side(x) != at_centroid) {
        let m = [0, 1, 2].map(|k| [0, 1, 2].map(|i| 0.5 * (c[k][i] + c[(k + 1) % 3][i])));
        for piece in [
            [c[0], m[0], m[2]],
            [m[0], c[1], m[1]],
            [m[2], m[1], c[2]],
            m,
        ] {
            add_mesh_piece(geometry, piece, n, tag, h, out);
        }
        return;
    }
    if let Some(facing_n) = at_centroid {
        push_piece(c, facing_n, tag, out);
    }
}

/// Appends the triangle `c` (turned over unless `facing_n`) with its tag.
fn push_piece(c: [[f64; 3]; 3], facing_n: bool, tag: u16, out: &mut Triangulation) {
    let base = out.0.len() as u32;
    out.0.extend(c);
    out.1.push(if facing_n {
        [base, base + 1, base + 2]
    } else {
        [base, base + 2, base + 1]
    });
    out.2.push(tag);
}

/// A mesh solid's triangles clipped to `bx`, welded, with their tags.
fn clipped_mesh(mesh: &MeshSolid, bx: &Aabb) -> Triangulation {
    let mut index: HashMap<[u64; 3], u32> = HashMap::new();
    let mut points = Vec::new();
    let (mut triangles, mut tags) = (Vec::new(), Vec::new());
    for t in 0..mesh.num_triangles() {
        let polygon = clip_to_box(mesh.triangle(t).to_vec(), bx);
        if polygon.len() < 3 {
            continue;
        }
        let ids: Vec<u32> = polygon
            .iter()
            .map(|p| {
                *index.entry(p.map(f64::to_bits)).or_insert_with(|| {
                    points.push(*p);
                    (points.len() - 1) as u32
                })
            })
            .collect();
        for k in 1..ids.len() - 1 {
            let tri = [ids[0], ids[k], ids[k + 1]];
            if tri[0] != tri[1] && tri[1] != tri[2] && tri[0] != tri[2] {
                triangles.push(tri);
                tags.push(mesh.tag(t));
            }
        }
    }
    (points, triangles, tags)
}

/// The convex polygon `polygon` clipped to the box `bx` (Sutherland–Hodgman,
/// see the module doc); the polygon itself when it lies in the box.
fn clip_to_box(mut polygon: Vec<[f64; 3]>, bx: &Aabb) -> Vec<[f64; 3]> {
    for a in 0..3 {
        for (c, sign) in [(bx.lo[a], -1.0), (bx.hi[a], 1.0)] {
            // Inside the half-space `sign (x_a − c) ≤ 0`.
            let inside = |p: &[f64; 3]| sign * (p[a] - c) <= 0.0;
            if polygon.iter().all(inside) {
                continue;
            }
            let mut out = Vec::with_capacity(polygon.len() + 1);
            for i in 0..polygon.len() {
                let (p, q) = (polygon[i], polygon[(i + 1) % polygon.len()]);
                if inside(&p) {
                    out.push(p);
                }
                if inside(&p) != inside(&q) {
                    let t = (c - p[a]) / (q[a] - p[a]);
                    let mut x = [0, 1, 2].map(|k| p[k] + t * (q[k] - p[k]));
                    x[a] = c;
                    out.push(x);
                }
            }
            polygon = out;
        }
    }
    polygon
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_triangle_across_a_box_face_is_cut_on_the_face() {
        let bx = Aabb::new([0.0; 3], [1.0; 3]);
        let inside = vec![[0.1, 0.1, 0.5], [0.9, 0.1, 0.5], [0.1, 0.9, 0.5]];
        assert_eq!(clip_to_box(inside.clone(), &bx), inside);
        // Half of this triangle lies at x > 1: a quadrilateral remains.
        let across = vec![[0.5, 0.2, 0.5], [1.5, 0.2, 0.5], [0.5, 0.8, 0.5]];
        let clipped = clip_to_box(across, &bx);
        assert_eq!(clipped.len(), 4);
        assert!(clipped.iter().all(|p| p[0] <= 1.0));
        assert_eq!(clipped.iter().filter(|p| p[0] == 1.0).count(), 2);
        let outside = vec![[2.0, 0.2, 0.5], [3.0, 0.2, 0.5], [2.0, 0.8, 0.5]];
        assert!(clip_to_box(outside, &bx).is_empty());
    }

    #[test]
    fn hosts_are_active_cells_at_or_next_to_the_point() {
        let grid = Grid::new(&Aabb::new([0.0; 3], [1.0; 3]), 2, [0.0; 3]).unwrap();
        let mut kinds = vec![CellKind::Outside; grid.num_cells()];
        let active = grid.cell_index([1, 1, 1]);
        kinds[active] = CellKind::Cut;
        // On the shared corner of eight cells, one of them active.
        assert_eq!(host_cell(&grid, &kinds, [0.5, 0.5, 0.5]), Some(active));
        assert_eq!(host_cell(&grid, &kinds, [0.3, 0.4, 0.4]), Some(active));
        // In outside neighbours: the nearest active cell continues u_h.
        assert_eq!(host_cell(&grid, &kinds, [0.55, 0.4, 0.4]), Some(active));
        assert_eq!(host_cell(&grid, &kinds, [0.05, 0.05, 0.05]), Some(active));
        // Two cells away: none.
        assert_eq!(host_cell(&grid, &kinds, [0.9, 0.9, 0.9]), None);
    }
}
