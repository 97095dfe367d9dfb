//! What a CSG tree with mesh leaves is over one box: the tree with every
//! surface that does not cross the box replaced by the side the box is on,
//! simplified. It decides a cell's cut rule ([`crate::quadrature::mixed`]).
//!
//! A leaf is replaced when its enclosure over the box has one strict sign
//! (the natural interval extension, then [`super::surface::Leaf::bounds`]),
//! a mesh when no triangle meets the box ([`MeshSolid::crosses`]),
//! by its side at the box's centre (one winding number). The constants then
//! fold through the operations (`A ∪ all = all`, `A ∩ all = A`,
//! `A \ all = none`, …); what is left holds only surfaces that may cross.
//! A mesh left beside other surfaces whose triangles in the box lie in one
//! plane ([`MeshSolid::plane_in`]) is that half-space there: a plane leaf.

use std::sync::Arc;

use super::scalar::box_intervals;
use super::surface::{Frame, Leaf, Shape};
use super::{Geometry, Node};
use crate::mesh::MeshSolid;
use crate::spatial::Aabb;

/// A solid over one box.
pub enum LocalSolid {
    /// No mesh crosses the box, or each is one plane there: the tree with
    /// the meshes replaced by their sides or their planes (added leaves),
    /// for Saye's rules.
    Analytic(Geometry),
    /// Only this mesh crosses the box, and the solid there is its inside.
    Mesh(Arc<MeshSolid>),
    /// Only this mesh crosses the box, and the solid there is its outside
    /// (a cavity).
    MeshOutside(Arc<MeshSolid>),
    /// Anything else: a mesh's edge or corner beside another surface.
    Mixed {
        /// The meshes that may cross the box.
        meshes: Vec<Arc<MeshSolid>>,
        /// The analytic leaves (indices into [`Geometry::leaves`]) that may.
        leaves: Vec<usize>,
    },
}

impl Geometry {
    /// The solid over the box `b` (see the module doc).
    pub fn local(&self, b: &Aabb) -> LocalSolid {
        let root = self.reduce(&self.root, b);
        if let Some(m) = cavity(&root) {
            return LocalSolid::MeshOutside(m);
        }
        match root {
            Node::Mesh(m) => LocalSolid::Mesh(m),
            root if !has_mesh(&root) => LocalSolid::Analytic(Geometry {
                leaves: self.leaves.clone(),
                tags: self.tags.clone(),
                root,
                bbox: self.bbox,
            }),
            root => {
                let mut planes = Vec::new();
                if let Some(planar) = planarise(&root, b, self.leaves.len(), &mut planes) {
                    let mut leaves = self.leaves.clone();
                    leaves.extend(planes);
                    return LocalSolid::Analytic(Geometry {
                        leaves,
                        tags: self.tags.clone(),
                        root: planar,
                        bbox: self.bbox,
                    });
                }
                let (mut meshes, mut leaves) = (Vec::new(), Vec::new());
                surfaces(&root, &mut meshes, &mut leaves);
                LocalSolid::Mixed { meshes, leaves }
            }
        }
    }

    /// The solid bounded by leaf `i` alone (its tag, among the same names).
    pub fn leaf_solid(&self, i: usize) -> Geometry {
        Geometry {
            leaves: vec![self.leaves[i].clone()],
            tags: self.tags.clone(),
            root: Node::Leaf(0),
            bbox: Aabb::EVERYTHING,
        }
    }

    fn reduce(&self, node: &Node, b: &Aabb) -> Node {
        match node {
            Node::Leaf(i) => {
                let leaf = &self.leaves[*i];
                let natural = leaf.eval(box_intervals(b));
                let v = if natural.strictly_signed() {
                    natural
                } else {
                    leaf.bounds(b).v
                };
                if v.strictly_signed() {
                    Node::Const(v.hi < 0.0)
                } else {
                    Node::Leaf(*i)
                }
            }
            Node::Mesh(m) => {
                if m.crosses(b) {
                    Node::Mesh(m.clone())
                } else {
                    let c = [0, 1, 2].map(|i| 0.5 * (b.lo[i] + b.hi[i]));
                    Node::Const(m.phi(c) < 0.0)
                }
            }
            Node::Const(c) => Node::Const(*c),
            Node::Union(a, c) => match (self.reduce(a, b), self.reduce(c, b)) {
                (Node::Const(true), _) | (_, Node::Const(true)) => Node::Const(true),
                (Node::Const(false), x) | (x, Node::Const(false)) => x,
                (x, y) => Node::Union(Box::new(x), Box::new(y)),
            },
            Node::Intersection(a, c) => match (self.reduce(a, b), self.reduce(c, b)) {
                (Node::Const(false), _) | (_, Node::Const(false)) => Node::Const(false),
                (Node::Const(true), x) | (x, Node::Const(true)) => x,
                (x, y) => Node::Intersection(Box::new(x), Box::new(y)),
            },
            Node::Difference(a, c) => match (self.reduce(a, b), self.reduce(c, b)) {
                (Node::Const(false), _) | (_, Node::Const(true)) => Node::Const(false),
                (x, Node::Const(false)) => x,
                (x, y) => Node::Difference(Box::new(x), Box::new(y)),
            },
        }
    }
}

/// The mesh of a tree that is everything minus that mesh.
fn cavity(n: &Node) -> Option<Arc<MeshSolid>> {
    match n {
        Node::Difference(all, m) => match (&**all, &**m) {
            (Node::Const(true), Node::Mesh(m)) => Some(m.clone()),
            _ => None,
        },
        _ => None,
    }
}

/// True when the tree `n` has a mesh leaf.
pub(super) fn has_mesh(n: &Node) -> bool {
    match n {
        Node::Mesh(_) => true,
        Node::Union(a, b) | Node::Intersection(a, b) | Node::Difference(a, b) => {
            has_mesh(a) || has_mesh(b)
        }
        Node::Leaf(_) | Node::Const(_) => false,
    }
}

/// The tree `n` with each mesh replaced by the half-space of its facets in
/// `b` ([`MeshSolid::plane_in`]), appended to `planes` as leaves numbered
/// from `first`; `None` when some mesh is not one plane there.
fn planarise(n: &Node, b: &Aabb, first: usize, planes: &mut Vec<Leaf>) -> Option<Node> {
    let mut two = |x: &Node, y: &Node| -> Option<(Box<Node>, Box<Node>)> {
        let x = planarise(x, b, first, planes)?;
        let y = planarise(y, b, first, planes)?;
        Some((Box::new(x), Box::new(y)))
    };
    Some(match n {
        Node::Mesh(m) => {
            let (normal, offset, tag) = m.plane_in(b)?;
            planes.push(Leaf {
                shape: Shape::Plane { normal, offset },
                frame: Frame::IDENTITY,
                tag,
            });
            Node::Leaf(first + planes.len() - 1)
        }
        Node::Union(x, y) => {
            let (x, y) = two(x, y)?;
            Node::Union(x, y)
        }
        Node::Intersection(x, y) => {
            let (x, y) = two(x, y)?;
            Node::Intersection(x, y)
        }
        Node::Difference(x, y) => {
            let (x, y) = two(x, y)?;
            Node::Difference(x, y)
        }
        Node::Leaf(i) => Node::Leaf(*i),
        Node::Const(c) => Node::Const(*c),
    })
}

/// The meshes and the analytic leaves of the tree `n`, each once.
fn surfaces(n: &Node, meshes: &mut Vec<Arc<MeshSolid>>, leaves: &mut Vec<usize>) {
    match n {
        Node::Mesh(m) => {
            if !meshes.iter().any(|k| Arc::ptr_eq(k, m)) {
                meshes.push(m.clone());
            }
        }
        Node::Leaf(i) => {
            if !leaves.contains(i) {
                leaves.push(*i);
            }
        }
        Node::Union(a, b) | Node::Intersection(a, b) | Node::Difference(a, b) => {
            surfaces(a, meshes, leaves);
            surfaces(b, meshes, leaves);
        }
        Node::Const(_) => {}
    }
}
