//! Geometry utilities at the bottom of the layers: 3-vectors, axis-aligned
//! boxes, and a bounding-volume hierarchy over triangles with its
//! line–triangle intersection. Nothing here knows the grid, the elements or
//! the mechanics; the STL meshes, the implicit geometry, the quadrature and
//! the contact search all build on it.

pub mod aabb;
pub mod bvh;
pub mod vec3;

pub use aabb::Aabb;
pub use bvh::{intersect_line, Bvh, Hit, NodeView};
