//! A body's boundary as a triangle mesh on its Cartesian grid, in the
//! reference configuration, and its image in the current configuration.
//!
//! The mesh is the zero set of the level set by marching tetrahedra (see the
//! private `marching` module): vertices lie on φ = 0 to round-off, on edges of
//! the grid's Freudenthal tetrahedra, shared between neighbouring triangles,
//! and triangles are oriented by the outward normal. Its geometric error is
//! O(h²): the chords of a surface of curvature κ sag by at most `κ ℓ²/8` over
//! an edge of length `ℓ ≤ √3 h`, so the area converges at rate 2 (measured in
//! `tests/contact_search.rs`).
//!
//! Each triangle carries the cell whose tetrahedron produced it and the
//! boundary tag at its centroid: the tag of the CSG leaf that attains φ there
//! (the leaf whose ψ equals φ, or −φ under a difference, bit for bit: the
//! geometry evaluates the same leaf functions), as [`Geometry::gradient`]
//! chooses its leaf. Only the triangles of the requested tags are kept (a
//! contact pair's master part).
//!
//! The current configuration maps each reference vertex `X` to
//! `x = X + u(X)`, with `u` evaluated in a cell containing `X` — by a closure,
//! or from a nodal field with the grid's numbering through the cell's shape
//! functions ([`crate::fem::field::value_and_gradient`]). The displacement is
//! continuous across cells, so the choice of cell does not matter.

use rayon::prelude::*;

use super::marching;
use super::vec3::{add, norm, normalize, triangle_normal_scaled};
use crate::fem::dofs::DofMap;
use crate::fem::field::value_and_gradient;
use crate::geometry::Geometry;
use crate::grid::Grid;

/// One triangle of a [`Surface`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceTriangle {
    /// Indices into [`Surface::vertices`], counter-clockwise seen from outside.
    pub vertices: [u32; 3],
    /// The grid cell the triangle lies in.
    pub cell: usize,
    /// The boundary tag at the centroid.
    pub tag: u16,
}

/// A triangulated boundary part in the reference configuration.
#[derive(Clone, Debug)]
pub struct Surface {
    /// Reference positions `X` of the vertices (all on φ = 0).
    pub vertices: Vec<[f64; 3]>,
    /// A grid cell containing each vertex (for evaluating `u`).
    pub vertex_cell: Vec<usize>,
    pub triangles: Vec<SurfaceTriangle>,
}

impl Surface {
    /// The triangles of `geometry`'s boundary on `grid` whose tag is in `tags`.
    pub fn from_level_set(grid: &Grid, geometry: &Geometry, tags: &[u16]) -> Surface {
        let raw = marching::extract(grid, geometry);
        let mut keep_vertex = vec![u32::MAX; raw.vertices.len()];
        let mut surface = Surface {
            vertices: Vec::new(),
            vertex_cell: Vec::new(),
            triangles: Vec::new(),
        };
        for (v, cell) in raw.triangles {
            let p = v.map(|i| raw.vertices[i as usize]);
            let centroid = [0, 1, 2].map(|i| (p[0][i] + p[1][i] + p[2][i]) / 3.0);
            let tag = tag_at(geometry, centroid);
            if !tags.contains(&tag) {
                continue;
            }
            let vertices = v.map(|i| {
                let i = i as usize;
                if keep_vertex[i] == u32::MAX {
                    keep_vertex[i] = surface.vertices.len() as u32;
                    surface.vertices.push(raw.vertices[i]);
                    surface.vertex_cell.push(raw.vertex_cell[i]);
                }
                keep_vertex[i]
            });
            surface.triangles.push(SurfaceTriangle {
                vertices,
                cell,
                tag,
            });
        }
        surface
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

/// The tag of the CSG leaf attaining φ at `x`: the first leaf with `ψ = φ`
/// exactly, else with `ψ = −φ` (a subtracted leaf), else (not reached with a
/// consistent tree) the leaf with the smallest `|ψ|`.
pub fn tag_at(geometry: &Geometry, x: [f64; 3]) -> u16 {
    let phi = geometry.phi(x);
    let leaves = geometry.leaves();
    let values: Vec<f64> = leaves.iter().map(|l| l.eval(x)).collect();
    let pick = values
        .iter()
        .position(|&v| v == phi)
        .or_else(|| values.iter().position(|&v| v == -phi))
        .unwrap_or_else(|| {
            (0..values.len())
                .min_by(|&a, &b| values[a].abs().total_cmp(&values[b].abs()))
                .unwrap_or(0)
        });
    leaves[pick].tag
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Aabb;

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
    fn tags_follow_the_leaf_attaining_phi() {
        let g = Geometry::shell([0.0; 3], 0.5, 1.0).unwrap();
        let inner = g.tag_id("inner").unwrap();
        let outer = g.tag_id("outer").unwrap();
        assert_eq!(tag_at(&g, [0.5, 0.0, 0.0]), inner);
        assert_eq!(tag_at(&g, [0.0, 1.0, 0.0]), outer);
        let grid = Grid::new(&g.bounding_box(), 4, [0.2, 0.4, 0.1]).unwrap();
        let s = Surface::from_level_set(&grid, &g, &[inner]);
        assert!(s.num_triangles() > 0);
        for x in &s.vertices {
            assert!((norm(*x) - 0.5).abs() < 1e-12);
        }
        // The inner boundary's outward normal points to the centre.
        let t = 0;
        let c = s.reference_corners(t);
        assert!(super::super::vec3::dot(s.normal(&s.vertices, t), c[0]) < 0.0);
    }
}
