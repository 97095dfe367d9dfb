//! A body's boundary as a triangle mesh on its Cartesian grid, in the
//! reference configuration, and its image in the current configuration.
//!
//! **Extraction, part by part.** The boundary parts are the CSG leaves,
//! each a smooth level set ψ with its tag, or a triangle mesh (an STL part)
//! with a tag per triangle. A mesh leaf's part is its own triangles, split
//! on the grid and clipped to the body ([`super::surface_mesh`]). For every
//! analytic leaf whose
//! tag is requested, the zero set of ψ is meshed by marching tetrahedra (see
//! the crate-private `marching` module): vertices lie on ψ = 0 to round-off, on
//! edges of the grid's Freudenthal tetrahedra, shared between neighbouring
//! triangles. A triangle is kept when its centroid, projected onto ψ = 0 by a
//! Newton step `p = c − ψ(c) ∇ψ/|∇ψ|²`, lies on the body's boundary as this
//! leaf: just off `p` along `∇ψ`, at `q = p + 10⁻⁶ h ∇ψ/|∇ψ|`, the leaf attains
//! φ, i.e. `φ(q) = ψ(q)` (an added leaf; the triangle keeps the orientation of
//! ∇ψ) or `φ(q) = −ψ(q)` (a subtracted leaf: the triangle is flipped), bit for
//! bit, since the geometry evaluates the same leaf function. So triangles are
//! oriented by the body's outward normal and carry their leaf's tag.
//!
//! Meshing each leaf rather than the combined φ = min/max(ψ…) matters where a
//! second part lies on grid nodes: a plane-strain slab one cell thick has its
//! caps on node planes, so φ ≥ 0 at every node and the zero set of φ has no
//! sign change to mesh, while the lateral leaf's zero set is found as usual.
//! The price: where two parts meet, whole triangles are kept or dropped, so a
//! part's rim is ragged by up to one triangle (O(h)) instead of chamfered.
//!
//! Away from the rims the geometric error is O(h²): chords of a surface of
//! curvature κ sag by at most `κ ℓ²/8` over an edge of length `ℓ ≤ √3 h`,
//! and the area converges at rate 2 (measured in `tests/suite/contact/search.rs`).
//!
//! The surface also indexes the triangles around each vertex, for the
//! area-weighted vertex normals of the curved master patches
//! ([`super::patch`]) and the search's candidates around a hit.
//!
//! Each triangle also carries the cell whose tetrahedron produced it. The
//! current configuration maps each reference vertex `X` to `x = X + u(X)`,
//! with `u` evaluated in the cell of a triangle using the vertex (the vertex
//! lies in that cell's closure) — by a closure, or from a nodal field with the
//! grid's numbering through the cell's shape functions
//! ([`crate::discrete::field::value_and_gradient`]). The displacement is continuous
//! across cells, so the choice of cell does not matter.

use rayon::prelude::*;

use crate::discrete::dofs::DofMap;
use crate::discrete::field::value_and_gradient;
use crate::discrete::marching;
use crate::element::ElementOrder;
use crate::geometry::polarity::{polarity_on_boundary, Polarity};
use crate::geometry::Geometry;
use crate::grid::Grid;
use crate::spatial::vec3::{add, norm, normalize, triangle_normal_scaled};

/// One triangle of a [`Surface`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceTriangle {
    /// Indices into [`Surface::vertices`], counter-clockwise seen from outside.
    pub vertices: [u32; 3],
    /// The grid cell the triangle lies in.
    pub cell: usize,
    /// The boundary tag (of the leaf whose zero set it meshes).
    pub tag: u16,
}

/// A triangulated boundary part in the reference configuration.
#[derive(Clone, Debug)]
pub struct Surface {
    /// Reference positions `X` of the vertices (all on φ = 0 up to the
    /// part's rim).
    pub vertices: Vec<[f64; 3]>,
    /// A grid cell whose closure contains each vertex, that of the first
    /// triangle using it (for evaluating `u`).
    pub vertex_cell: Vec<usize>,
    /// The reference vertex normals, [`Surface::vertex_normals`] at
    /// [`Surface::vertices`] (the corner normals of the reference patches,
    /// [`super::patch`]).
    pub normals: Vec<[f64; 3]>,
    pub triangles: Vec<SurfaceTriangle>,
    /// The triangles around each vertex: those of vertex `v` are
    /// `vertex_triangles[vertex_start[v]..vertex_start[v + 1]]`.
    pub vertex_start: Vec<usize>,
    pub vertex_triangles: Vec<u32>,
}

impl Surface {
    /// The triangles of `geometry`'s boundary on `grid` whose tag is in `tags`.
    pub fn from_level_set(grid: &Grid, geometry: &Geometry, tags: &[u16]) -> Surface {
        Surface::for_element(grid, ElementOrder::Q1, geometry, tags)
    }

    /// The triangles of `geometry`'s boundary, whose tag is in `tags`, of a
    /// body with elements of `order` on `grid`: marching tetrahedra on the
    /// element's node lattice, each triangle and vertex in the cell of `grid`
    /// that holds it. For Q2 the lattice is the grid refined once, so that
    /// every Q2 node of a boundary face on a grid plane is a vertex: the
    /// contact forces on the master reach its mid-edge and mid-face nodes,
    /// and the master surface follows them. (On the Q1 lattice a Q2 master
    /// moves with its vertex nodes only and is loaded there only; the
    /// pressed blocks of `tests/suite/hyper/bodies/coupling.rs` then carried
    /// 40 where Q1 gives 68.)
    pub fn for_element(
        grid: &Grid,
        order: ElementOrder,
        geometry: &Geometry,
        tags: &[u16],
    ) -> Surface {
        let ratio = order.degree();
        let lattice = match order {
            ElementOrder::Q1 => grid.clone(),
            ElementOrder::Q2 => grid.refined(),
        };
        let cell_of = |c: usize| grid.cell_index(lattice.cell_ijk(c).map(|i| i / ratio));
        let mut surface = Surface {
            vertices: Vec::new(),
            vertex_cell: Vec::new(),
            normals: Vec::new(),
            triangles: Vec::new(),
            vertex_start: Vec::new(),
            vertex_triangles: Vec::new(),
        };
        for (i, leaf) in geometry.leaves().iter().enumerate() {
            if tags.contains(&leaf.tag) {
                surface.add_leaf(&lattice, &cell_of, geometry, i);
            }
        }
        for mesh in geometry.meshes() {
            surface.add_mesh(&lattice, &cell_of, geometry, mesh, tags);
        }
        surface.index_vertex_triangles();
        surface.normals = surface.vertex_normals(&surface.vertices);
        surface
    }

    /// Appends the triangles of leaf `i`'s zero set on `lattice` that lie on
    /// the boundary; `cell_of` maps a lattice cell to the body grid's.
    fn add_leaf(
        &mut self,
        lattice: &Grid,
        cell_of: &dyn Fn(usize) -> usize,
        geometry: &Geometry,
        i: usize,
    ) {
        let (grid, leaf) = (lattice, &geometry.leaves()[i]);
        let raw = marching::extract(grid, &|x| leaf.eval(x));
        let mut kept = vec![u32::MAX; raw.vertices.len()];
        for (mut v, cell) in raw.triangles {
            let cell = cell_of(cell);
            let p = v.map(|k| raw.vertices[k as usize]);
            let centroid = [0, 1, 2].map(|a| (p[0][a] + p[1][a] + p[2][a]) / 3.0);
            match polarity_on_boundary(geometry, leaf, centroid, grid.h) {
                None => continue,
                Some(Polarity::Subtracted) => v.swap(1, 2),
                Some(Polarity::Added) => {}
            }
            let vertices = v.map(|k| {
                let k = k as usize;
                if kept[k] == u32::MAX {
                    kept[k] = self.vertices.len() as u32;
                    self.vertices.push(raw.vertices[k]);
                    self.vertex_cell.push(cell);
                }
                kept[k]
            });
            let tag = leaf.tag;
            self.triangles.push(SurfaceTriangle {
                vertices,
                cell,
                tag,
            });
        }
    }

    /// Fills [`Surface::vertex_start`] and [`Surface::vertex_triangles`].
    fn index_vertex_triangles(&mut self) {
        let mut start = vec![0usize; self.vertices.len() + 1];
        for t in &self.triangles {
            t.vertices.iter().for_each(|&v| start[v as usize + 1] += 1);
        }
        for v in 0..self.vertices.len() {
            start[v + 1] += start[v];
        }
        let mut next = start.clone();
        let mut list = vec![0u32; start[self.vertices.len()]];
        for (i, t) in self.triangles.iter().enumerate() {
            for &v in &t.vertices {
                list[next[v as usize]] = i as u32;
                next[v as usize] += 1;
            }
        }
        self.vertex_start = start;
        self.vertex_triangles = list;
    }

    /// The vertex normals at `positions`: the sum over the triangles around
    /// each vertex of `(p1 − p0) × (p2 − p0)` (twice the area times the unit
    /// normal, so a sliver weighs nothing), not normalised.
    pub fn vertex_normals(&self, positions: &[[f64; 3]]) -> Vec<[f64; 3]> {
        (0..self.vertices.len())
            .map(|v| {
                self.triangles_at_vertex(v).fold([0.0; 3], |acc, t| {
                    add(
                        acc,
                        triangle_normal_scaled(&self.corners(positions, t as usize)),
                    )
                })
            })
            .collect()
    }

    /// The triangles around vertex `v`.
    pub fn triangles_at_vertex(&self, v: usize) -> impl Iterator<Item = u32> + '_ {
        self.vertex_triangles[self.vertex_start[v]..self.vertex_start[v + 1]]
            .iter()
            .copied()
    }

    /// The triangles sharing a corner with triangle `t` (`t` included, in
    /// increasing order, each once).
    pub fn triangles_around(&self, t: usize) -> Vec<usize> {
        let mut out: Vec<usize> = self.triangles[t]
            .vertices
            .iter()
            .flat_map(|&v| self.triangles_at_vertex(v as usize).map(|o| o as usize))
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Every boundary part of `geometry` on `grid`.
    pub fn whole_boundary(grid: &Grid, geometry: &Geometry) -> Surface {
        let tags: Vec<u16> = (0..geometry.tag_names().len() as u16).collect();
        Surface::from_level_set(grid, geometry, &tags)
    }

    pub fn num_triangles(&self) -> usize {
        self.triangles.len()
    }

    /// The corners of triangle `t` taken from `positions` (reference or
    /// current vertex positions).
    pub fn corners(&self, positions: &[[f64; 3]], t: usize) -> [[f64; 3]; 3] {
        self.triangles[t].vertices.map(|v| positions[v as usize])
    }

    /// The reference corners `X` of triangle `t`.
    pub fn reference_corners(&self, t: usize) -> [[f64; 3]; 3] {
        self.corners(&self.vertices, t)
    }

    /// The unit outward normal of triangle `t` at `positions`.
    pub fn normal(&self, positions: &[[f64; 3]], t: usize) -> [f64; 3] {
        normalize(triangle_normal_scaled(&self.corners(positions, t)))
    }

    /// The total area at `positions`.
    pub fn area(&self, positions: &[[f64; 3]]) -> f64 {
        (0..self.triangles.len())
            .map(|t| 0.5 * norm(triangle_normal_scaled(&self.corners(positions, t))))
            .sum()
    }

    /// Current vertex positions `x = X + u(X)`, with `displacement_at(cell, X)`
    /// the displacement at the reference point `X` of `cell`.
    pub fn deformed(
        &self,
        displacement_at: impl Fn(usize, [f64; 3]) -> [f64; 3] + Sync,
    ) -> Vec<[f64; 3]> {
        self.vertices
            .par_iter()
            .zip(&self.vertex_cell)
            .map(|(&x, &cell)| add(x, displacement_at(cell, x)))
            .collect()
    }

    /// Current vertex positions for a nodal displacement field `u`
    /// (`u[3 · active + component]`, the layout of [`DofMap`]).
    pub fn deformed_by_field(&self, grid: &Grid, dofs: &DofMap, u: &[f64]) -> Vec<[f64; 3]> {
        self.deformed(|cell, x| value_and_gradient(grid, dofs, u, cell, x).0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spatial::vec3::dot;
    use crate::spatial::Aabb;

    #[test]
    fn a_plane_is_meshed_exactly_with_its_normal() {
        // Linear level set: marching tetrahedra is exact.
        let n = normalize([0.3, -0.5, 0.8]);
        let g = Geometry::half_space([0.1, 0.05, -0.02], n).unwrap();
        let grid = Grid::new(&Aabb::new([-1.0; 3], [1.0; 3]), 3, [0.37, 0.11, 0.73]).unwrap();
        let s = Surface::whole_boundary(&grid, &g);
        assert!(s.num_triangles() > 50);
        for t in 0..s.num_triangles() {
            let nt = s.normal(&s.vertices, t);
            assert!((0..3).all(|i| (nt[i] - n[i]).abs() < 1e-12), "{nt:?}");
        }
        for x in &s.vertices {
            assert!(g.phi(*x).abs() < 1e-15);
        }
    }

    #[test]
    fn a_shell_splits_into_its_tagged_parts_oriented_outwards() {
        let g = Geometry::shell([0.0; 3], 0.5, 1.0).unwrap();
        let grid = Grid::new(&g.bounding_box(), 4, [0.2, 0.4, 0.1]).unwrap();
        for (tag, r, outward) in [("inner", 0.5, -1.0), ("outer", 1.0, 1.0)] {
            let s = Surface::from_level_set(&grid, &g, &[g.tag_id(tag).unwrap()]);
            assert!(s.num_triangles() > 100);
            for x in &s.vertices {
                assert!((norm(*x) - r).abs() < 1e-12, "{tag}");
            }
            for t in 0..s.num_triangles() {
                let c = s.reference_corners(t);
                assert!(outward * dot(s.normal(&s.vertices, t), c[0]) > 0.0, "{tag}");
            }
            // Area within the O(h²) chord error of 4πr².
            let exact = 4.0 * std::f64::consts::PI * r * r;
            assert!((s.area(&s.vertices) / exact - 1.0).abs() < 0.5 * grid.h * grid.h / (r * r));
        }
        assert_eq!(Surface::from_level_set(&grid, &g, &[]).num_triangles(), 0);
    }

    /// A Q2 body's face on a grid plane: every Q2 node of the face is a
    /// vertex (the Q1 surface has the vertex nodes only), each vertex lies in
    /// its cell of the body's grid, and the area is the face's.
    #[test]
    fn a_q2_surface_has_every_q2_node_of_a_face_as_a_vertex() {
        let g = Geometry::cuboid([0.0; 3], [1.0, 1.0, 0.5]).unwrap();
        let grid = Grid::new(&g.bounding_box(), 2, [0.0; 3]).unwrap();
        let top = [g.tag_id("zmax").unwrap()];
        let (q1, q2) = (
            Surface::for_element(&grid, ElementOrder::Q1, &g, &top),
            Surface::for_element(&grid, ElementOrder::Q2, &g, &top),
        );
        // 4 × 4 cells on the face: 5² vertex nodes, 9² Q2 nodes.
        assert_eq!((q1.vertices.len(), q2.vertices.len()), (25, 81));
        for s in [&q1, &q2] {
            assert!((s.area(&s.vertices) - 1.0).abs() < 1e-14);
            for (x, &c) in s.vertices.iter().zip(&s.vertex_cell) {
                let b = grid.cell_box(c);
                assert!((0..3).all(|a| b.lo[a] - 1e-14 <= x[a] && x[a] <= b.hi[a] + 1e-14));
            }
        }
        let mut lattice: Vec<[i64; 2]> = q2
            .vertices
            .iter()
            .map(|x| [0, 1].map(|a| (x[a] / (0.5 * grid.h)).round() as i64))
            .collect();
        lattice.sort_unstable();
        lattice.dedup();
        assert_eq!(lattice.len(), 81);
    }
}
