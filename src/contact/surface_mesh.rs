//! The part of a contact [`Surface`] on a mesh (STL) leaf: the mesh's own
//! triangles, split so that each piece lies in one cell's closure, cut
//! along the analytic leaves, and kept where they bound the body.
//!
//! **Pieces.** A triangle whose tag is requested is split, as a convex
//! polygon, by the element lattice's planes `x_a = o_a + k h` that cross it
//! (axis by axis, planes in increasing order), and clipped to the lattice's
//! box: every piece lies in the closure of one lattice cell. The pieces are
//! split further by the planes `X_p − X_q = m` (lattice coordinates
//! `X = (x − o)/h`, integer `m`) that cut each cell into the Freudenthal
//! tetrahedra of the marching-tetrahedra surfaces, so that a face on a grid
//! plane is triangulated as an analytic face there: along the same
//! diagonal of each cell. (The current surface interpolates `u` linearly
//! between the vertices; with the diagonals left to the fans of the pieces,
//! the Hertz case's recovered peak at level 4 was 2% to 10% above the
//! analytic block's, depending on the diagonal of the STL's top face.) A piece is then
//! split along the zero set of each analytic leaf ψ of the CSG tree whose
//! sign changes strictly across its corners, the cut on an edge from `p` to
//! `q` at `p + ψ(p)/(ψ(p) − ψ(q)) (q − p)`: exact on planes (an STL part
//! intersected with a half-space keeps its trimmed area to round-off), a
//! chord of the rim, `O(h²)` off it, on curved leaves. A second mesh leaf
//! does not cut: where it trims the part, whole pieces are kept or dropped
//! (a rim ragged by up to one cell, as the analytic leaves' rims are).
//!
//! A corner within `10⁻¹²` (of `h`, or of a lattice unit) of a cutting
//! plane or zero set lies on it: no cut falls next to it. A cut point is
//! computed from its edge alone, whatever the polygon
//! (endpoints in a fixed order: by the split axis, or lexicographically), so
//! the two pieces on either side of an edge cut it at the same point bit for
//! bit; vertices are welded by exact equality, and a closed mesh gives a
//! closed surface with no T-junctions.
//!
//! **Kept pieces.** A piece bounds the body when the body is on one side of
//! its centroid and not on the other
//! ([`crate::quadrature::mixed::on_boundary`], the test of the STL cut
//! rules): inside behind the mesh's outward normal, the piece keeps the
//! mesh's orientation; inside in front (a subtracted mesh), it is turned
//! over. It is split into a fan of triangles from its lowest corner
//! (lexicographically), carrying the mesh triangle's tag (one of collinear
//! corners is dropped). The pieces are ordered by cell and
//! centroid, so that the surface does not depend on the order of the
//! mesh's facets or of their corners (the search breaks ties by triangle
//! index).
//!
//! **Host cells.** Each piece's cell is the lattice cell whose closure holds
//! it (the slab of the midpoint of its extent along each axis; a piece lying
//! in a lattice plane takes the cell behind it, on the body's side),
//! mapped to the body grid's cell; its vertices are evaluated there, like
//! the marching-tetrahedra triangles' (see [`super::surface`]).

use std::collections::HashMap;

use super::surface::{Surface, SurfaceTriangle};
use crate::geometry::Geometry;
use crate::grid::Grid;
use crate::mesh::MeshSolid;
use crate::quadrature::mixed::on_boundary;
use crate::quadrature::saye::SurfacePoint;
use crate::spatial::vec3::{norm, triangle_normal_scaled};

type Polygon = Vec<[f64; 3]>;

impl Surface {
    /// Appends the pieces of `mesh`'s triangles tagged in `tags` that bound
    /// `geometry` (see the module doc); `cell_of` maps a lattice cell to the
    /// body grid's.
    pub(super) fn add_mesh(
        &mut self,
        lattice: &Grid,
        cell_of: &dyn Fn(usize) -> usize,
        geometry: &Geometry,
        mesh: &MeshSolid,
        tags: &[u16],
    ) {
        let mut kept = Vec::new();
        for t in 0..mesh.num_triangles() {
            let tag = mesh.tag(t);
            if !tags.contains(&tag) {
                continue;
            }
            let n = mesh.normal(t);
            for mut piece in pieces(lattice, geometry, mesh.triangle(t)) {
                let x = centroid(&piece);
                let point = SurfacePoint { x, w: 0.0, n, tag };
                let Some(on) = on_boundary(geometry, point, lattice.h) else {
                    continue;
                };
                if on.n != n {
                    piece.reverse();
                }
                // The fan from the lowest corner.
                let first = (0..piece.len())
                    .min_by(|&i, &j| piece[i].partial_cmp(&piece[j]).expect("finite corners"))
                    .expect("a piece has corners");
                piece.rotate_left(first);
                kept.push((cell_of(host(lattice, &piece, on.n)), x, tag, piece));
            }
        }
        // In the order of the cells, then of the centroids: the surface does
        // not depend on the order of the mesh's facets or of their corners.
        kept.sort_by(|a, b| {
            (a.0, a.1)
                .partial_cmp(&(b.0, b.1))
                .expect("finite centroids")
        });
        let mut weld: HashMap<[u64; 3], u32> = HashMap::new();
        for (cell, _, tag, piece) in kept {
            let ids: Vec<u32> = piece
                .iter()
                .map(|&x| {
                    *weld.entry(x.map(f64::to_bits)).or_insert_with(|| {
                        self.vertices.push(x);
                        self.vertex_cell.push(cell);
                        (self.vertices.len() - 1) as u32
                    })
                })
                .collect();
            for k in 1..ids.len() - 1 {
                let vertices = [ids[0], ids[k], ids[k + 1]];
                let corners = vertices.map(|v| self.vertices[v as usize]);
                // Collinear corners have no normal.
                if norm(triangle_normal_scaled(&corners)) > 0.0 {
                    self.triangles.push(SurfaceTriangle {
                        vertices,
                        cell,
                        tag,
                    });
                }
            }
        }
    }
}

/// The pieces of `triangle` in the lattice's box, one lattice cell's
/// closure each, cut along the analytic leaves of `geometry`.
fn pieces(lattice: &Grid, geometry: &Geometry, triangle: &[[f64; 3]; 3]) -> Vec<Polygon> {
    let mut pieces = vec![triangle.to_vec()];
    for a in 0..3 {
        let (lo, hi) = extent(triangle, a);
        let index = |x: f64| ((x - lattice.origin[a]) / lattice.h).clamp(0.0, lattice.n[a] as f64);
        let (first, last) = (index(lo).floor() as usize, index(hi).ceil() as usize);
        for k in first..=last {
            let c = lattice.origin[a] + k as f64 * lattice.h;
            let (bottom, top) = (k == 0, k == lattice.n[a]);
            let mut next = Vec::with_capacity(pieces.len() + 1);
            for p in pieces {
                let (lo, hi) = extent(&p, a);
                if (bottom && hi < c) || (top && lo > c) {
                    continue;
                }
                if !(lo < c && c < hi) {
                    next.push(p);
                    continue;
                }
                let values: Vec<f64> = p.iter().map(|x| x[a] - c).collect();
                let [below, above] = split(&p, &values, |p, q, _, _| {
                    let (l, h) = if p[a] < q[a] { (p, q) } else { (q, p) };
                    let s = (c - l[a]) / (h[a] - l[a]);
                    let mut x = [0, 1, 2].map(|i| l[i] + s * (h[i] - l[i]));
                    x[a] = c;
                    x
                });
                if !bottom {
                    next.push(below);
                }
                if !top {
                    next.push(above);
                }
            }
            pieces = next;
        }
    }
    // The planes `X_p − X_q = m` (lattice coordinates `X = (x − o)/h`,
    // integer `m`) that split the cells into Freudenthal tetrahedra.
    for (p, q) in [(0, 1), (1, 2), (0, 2)] {
        let at = |x: [f64; 3]| {
            (x[p] - lattice.origin[p]) / lattice.h - (x[q] - lattice.origin[q]) / lattice.h
        };
        let values = triangle.map(at);
        let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        for m in lo.floor() as i64..=hi.ceil() as i64 {
            pieces = cut_along(pieces, 1.0, |x| at(x) - m as f64);
        }
    }
    for leaf in geometry.leaves() {
        pieces = cut_along(pieces, lattice.h, |x| leaf.eval(x));
    }
    pieces
}

/// Every piece across which `value` changes sign strictly split along its
/// zero set (a value within `10⁻¹² scale` of zero taken as zero), the cut on an edge interpolated linearly from the edge's ends
/// taken in lexicographic order (see the module doc).
fn cut_along(pieces: Vec<Polygon>, scale: f64, value: impl Fn([f64; 3]) -> f64) -> Vec<Polygon> {
    let mut next = Vec::with_capacity(pieces.len());
    for p in pieces {
        // A corner within round-off of the zero set lies on it.
        let snap = |v: f64| if v.abs() <= 1e-12 * scale { 0.0 } else { v };
        let values: Vec<f64> = p.iter().map(|&x| snap(value(x))).collect();
        let signs = (
            values.iter().any(|&v| v < 0.0),
            values.iter().any(|&v| v > 0.0),
        );
        if signs != (true, true) {
            next.push(p);
            continue;
        }
        next.extend(split(&p, &values, |p, q, vp, vq| {
            let ((l, vl), (h, vh)) = if p < q {
                ((p, vp), (q, vq))
            } else {
                ((q, vq), (p, vp))
            };
            let s = vl / (vl - vh);
            [0, 1, 2].map(|i| l[i] + s * (h[i] - l[i]))
        }));
    }
    next
}

/// The convex polygon `p` split where `values` (one per corner) changes
/// sign: the corners with `v ≤ 0` and those with `v ≥ 0`, each with the
/// points `cut(a, b, v_a, v_b)` on the edges whose ends have opposite signs,
/// in the polygon's order.
fn split(
    p: &[[f64; 3]],
    values: &[f64],
    cut: impl Fn([f64; 3], [f64; 3], f64, f64) -> [f64; 3],
) -> [Polygon; 2] {
    let mut sides = [Vec::new(), Vec::new()];
    for i in 0..p.len() {
        let j = (i + 1) % p.len();
        let (vi, vj) = (values[i], values[j]);
        if vi <= 0.0 {
            sides[0].push(p[i]);
        }
        if vi >= 0.0 {
            sides[1].push(p[i]);
        }
        if (vi < 0.0 && vj > 0.0) || (vi > 0.0 && vj < 0.0) {
            let x = cut(p[i], p[j], vi, vj);
            sides[0].push(x);
            sides[1].push(x);
        }
    }
    sides
}

/// The smallest and largest coordinate `a` of the corners.
fn extent(p: &[[f64; 3]], a: usize) -> (f64, f64) {
    p.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
            (lo.min(x[a]), hi.max(x[a]))
        })
}

fn centroid(p: &[[f64; 3]]) -> [f64; 3] {
    [0, 1, 2].map(|a| p.iter().map(|x| x[a]).sum::<f64>() / p.len() as f64)
}

/// The lattice cell whose closure holds `piece`, `outward` its outward
/// normal (see the module doc).
fn host(lattice: &Grid, piece: &[[f64; 3]], outward: [f64; 3]) -> usize {
    let ijk = [0, 1, 2].map(|a| {
        let (lo, hi) = extent(piece, a);
        let s = (0.5 * (lo + hi) - lattice.origin[a]) / lattice.h;
        let plane = s.round();
        let i = if lo == hi && (s - plane).abs() < 1e-9 {
            // In a lattice plane: the cell on the body's side.
            if outward[a] > 0.0 {
                plane - 1.0
            } else {
                plane
            }
        } else {
            s.floor()
        };
        i.clamp(0.0, (lattice.n[a] - 1) as f64) as usize
    });
    lattice.cell_index(ijk)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::box_triangles;

    /// The tags of a box's faces by outward normal: `xmin, xmax, …, zmax`.
    fn tagged_box(lo: [f64; 3], hi: [f64; 3]) -> Geometry {
        let triangles = box_triangles(lo, hi);
        let tags: Vec<u16> = triangles
            .iter()
            .map(|t| {
                let n = crate::spatial::vec3::triangle_normal_scaled(t);
                let a = (0..3).find(|&a| n[a] != 0.0).unwrap();
                (2 * a + usize::from(n[a] > 0.0)) as u16
            })
            .collect();
        let names = ["xmin", "xmax", "ymin", "ymax", "zmin", "zmax"];
        let mesh = MeshSolid::new(&triangles, &tags).unwrap();
        Geometry::from_mesh(mesh, names.iter().map(|s| s.to_string()).collect())
    }

    /// Every edge of the surface is shared by exactly two triangles running
    /// it in opposite directions.
    fn assert_closed(s: &Surface) {
        let mut edges: HashMap<(u32, u32), i32> = HashMap::new();
        for t in &s.triangles {
            for k in 0..3 {
                let (a, b) = (t.vertices[k], t.vertices[(k + 1) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_default() += if a < b { 1 } else { -1 };
            }
        }
        let mut uses: HashMap<(u32, u32), usize> = HashMap::new();
        for t in &s.triangles {
            for k in 0..3 {
                let (a, b) = (t.vertices[k], t.vertices[(k + 1) % 3]);
                *uses.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        assert!(uses.values().all(|&u| u == 2), "open or non-manifold edges");
        assert!(edges.values().all(|&d| d == 0), "misoriented edges");
    }

    #[test]
    fn a_box_part_is_its_faces_in_cells_with_outward_normals() {
        let (lo, hi) = ([0.1, -0.2, 0.0], [1.3, 0.7, 0.55]);
        let g = tagged_box(lo, hi);
        let grid = Grid::new(&g.bounding_box(), 3, [0.3, 0.6, 0.0]).unwrap();
        let whole = Surface::whole_boundary(&grid, &g);
        assert_closed(&whole);
        let area = 2.0 * (1.2 * 0.9 + 1.2 * 0.55 + 0.9 * 0.55);
        assert!((whole.area(&whole.vertices) / area - 1.0).abs() < 1e-14);
        for (t, tri) in whole.triangles.iter().enumerate() {
            let b = grid.cell_box(tri.cell);
            let c = whole.reference_corners(t);
            for x in c {
                assert!((0..3).all(|a| b.lo[a] - 1e-12 <= x[a] && x[a] <= b.hi[a] + 1e-12));
            }
            // The cell holds the body just behind the triangle.
            let n = whole.normal(&whole.vertices, t);
            let behind = [0, 1, 2].map(|a| (c[0][a] + c[1][a] + c[2][a]) / 3.0 - 1e-13 * n[a]);
            assert!(
                (0..3).all(|a| b.lo[a] <= behind[a] && behind[a] <= b.hi[a]),
                "{t} {c:?} {n:?} {b:?} {}",
                tri.cell
            );
        }
        let top = Surface::from_level_set(&grid, &g, &[g.tag_id("zmax").unwrap()]);
        assert!((top.area(&top.vertices) - 1.2 * 0.9).abs() < 1e-14);
        assert!(top.num_triangles() > 2 * 4 * 4);
        for t in 0..top.num_triangles() {
            assert_eq!(top.normal(&top.vertices, t), [0.0, 0.0, 1.0]);
        }
    }

    #[test]
    fn a_trimmed_box_part_is_cut_exactly_along_the_plane() {
        let g = tagged_box([0.0; 3], [1.0, 1.0, 0.5]);
        // Trimmed by the oblique plane x + y ≤ 1.4 (a new face 'cut').
        let n = crate::spatial::vec3::normalize([1.0, 1.0, 0.0]);
        let plane = Geometry::half_space([0.7, 0.7, 0.0], n)
            .unwrap()
            .with_tag("cut");
        let g = g.intersection(plane).unwrap();
        let grid = Grid::new(&g.bounding_box(), 3, [0.25, 0.5, 0.0]).unwrap();
        let top = Surface::from_level_set(&grid, &g, &[g.tag_id("zmax").unwrap()]);
        // The unit square less the corner triangle of legs 0.6.
        let exact = 1.0 - 0.5 * 0.6 * 0.6;
        assert!(
            (top.area(&top.vertices) - exact).abs() < 1e-14,
            "{}",
            top.area(&top.vertices)
        );
        for x in &top.vertices {
            assert!(x[0] + x[1] <= 1.4 + 1e-14);
        }
        // The side x = 1 keeps 0.5 × 0.4 below the plane.
        let side = Surface::from_level_set(&grid, &g, &[g.tag_id("xmax").unwrap()]);
        assert!((side.area(&side.vertices) - 0.5 * 0.4).abs() < 1e-14);
        // A box subtracted from a larger one: its faces turn inwards.
        let outer = Geometry::cuboid([-1.0; 3], [2.0, 2.0, 1.5]).unwrap();
        let hole = tagged_box([0.0; 3], [1.0, 1.0, 0.5]).with_tag("cavity");
        let cavity = outer.difference(hole).unwrap();
        let grid = Grid::new(&cavity.bounding_box(), 3, [0.0; 3]).unwrap();
        let s = Surface::from_level_set(&grid, &cavity, &[cavity.tag_id("cavity").unwrap()]);
        assert_closed(&s);
        assert!((s.area(&s.vertices) - 4.0).abs() < 1e-14);
        for t in 0..s.num_triangles() {
            let c = s.reference_corners(t)[0];
            let to_centre = crate::spatial::vec3::sub([0.5, 0.5, 0.25], c);
            assert!(crate::spatial::vec3::dot(s.normal(&s.vertices, t), to_centre) > 0.0);
        }
    }
}
