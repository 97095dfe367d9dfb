//! Triangle-mesh solids ([`MeshSolid`]) in the CSG tree: construction,
//! access, and the motions and tag edits that reach every mesh leaf.
//!
//! A geometry that is one mesh solid gets the exact polyhedral cut rules of
//! [`crate::quadrature::polyhedral`] everywhere. A mesh combined with other
//! solids gets them (or their complement, for a cavity) in the cells only its
//! surface crosses, Saye's where analytic surfaces cross it or flat faces of
//! it, and a first-order rule in the small boxes where another surface
//! crosses one of its edges ([`crate::quadrature::mixed`]).

use std::sync::Arc;

use super::{Geometry, Node};
use crate::mesh::MeshSolid;
use crate::spatial::Aabb;

impl Geometry {
    /// The solid bounded by `mesh`, whose triangle tags index `tags`.
    pub fn from_mesh(mesh: MeshSolid, tags: Vec<String>) -> Geometry {
        Geometry {
            leaves: Vec::new(),
            tags,
            bbox: grid_box(&mesh),
            root: Node::Mesh(Arc::new(mesh)),
        }
    }

    /// The mesh, when the whole solid is one.
    pub fn mesh(&self) -> Option<&MeshSolid> {
        match &self.root {
            Node::Mesh(m) => Some(m),
            _ => None,
        }
    }

    /// Every mesh leaf of the tree, in the order of the case file.
    pub fn meshes(&self) -> Vec<&MeshSolid> {
        fn walk<'a>(n: &'a Node, out: &mut Vec<&'a MeshSolid>) {
            match n {
                Node::Mesh(m) => out.push(m),
                Node::Union(a, b) | Node::Intersection(a, b) | Node::Difference(a, b) => {
                    walk(a, out);
                    walk(b, out);
                }
                Node::Leaf(_) | Node::Const(_) => {}
            }
        }
        let mut out = Vec::new();
        walk(&self.root, &mut out);
        out
    }

    /// True when some leaf of the tree is a mesh.
    pub fn has_mesh(&self) -> bool {
        super::local::has_mesh(&self.root)
    }

    /// Every mesh leaf moved by `x ↦ R x + s`; the box of a solid that is
    /// one mesh follows it (the caller moves the box of any other).
    pub(super) fn move_meshes(&mut self, r: &[[f64; 3]; 3], s: [f64; 3]) {
        self.root =
            std::mem::replace(&mut self.root, Node::Const(false)).map_meshes(&|m| m.moved(r, s));
        if let Some(m) = self.mesh() {
            self.bbox = grid_box(m);
        }
    }

    /// Every mesh leaf's tags passed through `f`.
    pub(super) fn retag_meshes(&mut self, f: impl Fn(u16) -> u16) {
        self.root =
            std::mem::replace(&mut self.root, Node::Const(false)).map_meshes(&|m| m.retagged(&f));
    }
}

impl Node {
    /// The tree with every mesh leaf replaced by `f` of it.
    pub(super) fn map_meshes(self, f: &dyn Fn(&MeshSolid) -> MeshSolid) -> Node {
        let map2 =
            |a: Box<Node>, b: Box<Node>| (Box::new(a.map_meshes(f)), Box::new(b.map_meshes(f)));
        match self {
            Node::Mesh(m) => Node::Mesh(Arc::new(f(&m))),
            Node::Union(a, b) => {
                let (a, b) = map2(a, b);
                Node::Union(a, b)
            }
            Node::Intersection(a, b) => {
                let (a, b) = map2(a, b);
                Node::Intersection(a, b)
            }
            Node::Difference(a, b) => {
                let (a, b) = map2(a, b);
                Node::Difference(a, b)
            }
            leaf @ (Node::Leaf(_) | Node::Const(_)) => leaf,
        }
    }
}

/// The mesh's box grown by `10⁻⁹` of its diagonal on its upper sides: the
/// polyhedral rules give each cell the half-open `[lo, hi)`, so a facet on
/// the upper face of a grid fitted to the exact box would belong to no cell.
fn grid_box(mesh: &MeshSolid) -> Aabb {
    let mut b = mesh.bounding_box();
    let diag = (0..3)
        .map(|i| (b.hi[i] - b.lo[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    b.hi = b.hi.map(|v| v + 1e-9 * diag);
    b
}
