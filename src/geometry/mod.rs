//! Implicit geometry: a CSG tree of smooth leaf level sets with boundary tags.
//!
//! The level set φ is negative inside. Leaves are combined by union (min),
//! intersection (max) and difference (`max(a, −b)`), so the sign of φ is exactly
//! the boolean combination and its zero set is the boundary. The gradient of φ
//! is that of the leaf that attains it; the exact outward normal at a boundary
//! point is that gradient normalised. Every leaf carries a tag naming its part of
//! the boundary (`outer`, `inner`, `xmin`, …) so that a case can load the parts
//! differently.
//!
//! A leaf may also be a solid bounded by a triangle mesh (an `stl` node,
//! [`MeshSolid`]), whose level set is `½ − w` with `w` the generalised winding
//! number. Over one box the tree reduces to what crosses it ([`local`]): that
//! decides which cut rule a cell gets. A leaf may be a voxel image
//! ([`voxels`], read by [`nrrd`]): its level set is the trilinear
//! interpolant of the image, and the analytic leaves' cut rules apply to it.

mod csg;
mod local;
mod mesh_solid;
pub mod nrrd;
pub mod polarity;
mod primitives;
pub mod scalar;
pub mod surface;
pub mod voxels;

pub use local::LocalSolid;

use std::sync::Arc;

use crate::mesh::MeshSolid;
use crate::spatial::Aabb;
use scalar::{box_intervals, Dual, Interval, Lattice, Scalar};
use surface::Leaf;

/// A node of the CSG tree; leaves index [`Geometry::leaves`].
#[derive(Clone, Debug, PartialEq)]
enum Node {
    Leaf(usize),
    /// A solid bounded by a triangle mesh ([`Geometry::from_mesh`]).
    Mesh(Arc<MeshSolid>),
    /// Everything (`true`, φ = −∞) or nothing (`false`, φ = +∞): what a
    /// leaf that keeps one sign over a box is there ([`local`]). After
    /// [`local`]'s simplification one remains only as the whole tree or as
    /// the first operand of a difference (the complement of the second).
    Const(bool),
    Union(Box<Node>, Box<Node>),
    Intersection(Box<Node>, Box<Node>),
    Difference(Box<Node>, Box<Node>),
}

/// An implicitly defined solid.
#[derive(Clone, Debug, PartialEq)]
pub struct Geometry {
    leaves: Vec<Leaf>,
    tags: Vec<String>,
    root: Node,
    bbox: Aabb,
}

impl Geometry {
    /// φ at `x` in any lattice scalar (f64, interval bounds over a box, duals).
    pub fn eval<T: Lattice>(&self, x: [T; 3]) -> T {
        self.eval_node(&self.root, x)
    }

    fn eval_node<T: Lattice>(&self, node: &Node, x: [T; 3]) -> T {
        match node {
            Node::Leaf(i) => self.leaves[*i].eval(x),
            Node::Mesh(m) => T::mesh_level_set(m, x),
            Node::Const(inside) => T::cst(const_level_set(*inside)),
            Node::Union(a, b) => self.eval_node(a, x).min(self.eval_node(b, x)),
            Node::Intersection(a, b) => self.eval_node(a, x).max(self.eval_node(b, x)),
            Node::Difference(a, b) => self.eval_node(a, x).max(-self.eval_node(b, x)),
        }
    }

    /// The level set φ(x), negative inside.
    pub fn phi(&self, x: [f64; 3]) -> f64 {
        self.eval(x)
    }

    /// True when `x` lies in the open solid (φ < 0).
    pub fn inside(&self, x: [f64; 3]) -> bool {
        self.phi(x) < 0.0
    }

    /// ∇φ(x) (of the leaf attaining φ).
    pub fn gradient(&self, x: [f64; 3]) -> [f64; 3] {
        self.eval([Dual::var(x[0], 0), Dual::var(x[1], 1), Dual::var(x[2], 2)])
            .d
    }

    /// Unit outward normal at (or near) a boundary point.
    pub fn normal(&self, x: [f64; 3]) -> [f64; 3] {
        crate::spatial::vec3::normalize(self.gradient(x))
    }

    /// Bounds of φ over a box: each leaf's tight enclosure ([`Leaf::bounds`])
    /// combined through the tree.
    pub fn bounds(&self, b: &Aabb) -> Interval {
        // The natural extension is cheap and often decisive already.
        let natural: Interval = self.eval(box_intervals(b));
        if natural.strictly_signed() {
            return natural;
        }
        let leaf_bounds: Vec<Interval> = self.leaves.iter().map(|l| l.bounds(b).v).collect();
        self.combine(&self.root, &leaf_bounds, b)
    }

    fn combine(&self, node: &Node, leaf_values: &[Interval], bx: &Aabb) -> Interval {
        match node {
            Node::Leaf(i) => leaf_values[*i],
            Node::Mesh(m) => Interval::mesh_level_set(m, box_intervals(bx)),
            Node::Const(inside) => Interval::cst(const_level_set(*inside)),
            Node::Union(a, b) => {
                self.combine(a, leaf_values, bx)
                    .min(self.combine(b, leaf_values, bx))
            }
            Node::Intersection(a, b) => {
                self.combine(a, leaf_values, bx)
                    .max(self.combine(b, leaf_values, bx))
            }
            Node::Difference(a, b) => {
                self.combine(a, leaf_values, bx)
                    .max(-self.combine(b, leaf_values, bx))
            }
        }
    }

    /// A box containing the solid (infinite along unbounded directions).
    pub fn bounding_box(&self) -> Aabb {
        self.bbox
    }

    /// The leaf level sets.
    pub fn leaves(&self) -> &[Leaf] {
        &self.leaves
    }

    /// Name of a boundary tag.
    pub fn tag_name(&self, tag: u16) -> &str {
        &self.tags[tag as usize]
    }

    /// All boundary tag names, indexed by tag id.
    pub fn tag_names(&self) -> &[String] {
        &self.tags
    }

    /// The id of a tag name, if some leaf carries it.
    pub fn tag_id(&self, name: &str) -> Option<u16> {
        self.tags.iter().position(|t| t == name).map(|i| i as u16)
    }
}

/// The level set of [`Node::Const`]: `∓∞`, which `min` and `max` pass
/// through exactly (`max(−∞, −ψ) = −ψ`, the complement of ψ).
fn const_level_set(inside: bool) -> f64 {
    if inside {
        f64::NEG_INFINITY
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
mod tests;
