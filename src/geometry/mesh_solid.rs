//! Geometries made of one triangle-mesh solid ([`MeshSolid`]): construction
//! and access. The cut-cell rules of such a geometry are the exact polyhedral
//! ones of [`crate::quadrature::polyhedral`].
//!
//! A mesh solid is not yet combined with other solids by union, intersection
//! or difference: a cell where a mesh facet meets an analytic surface would
//! need a rule for both at once, which neither Saye's algorithm (smooth level
//! sets) nor the polyhedral rules (flat pieces) give. The CSG operations
//! refuse it with a clear error; motions and tag edits work.

use std::sync::Arc;

use super::{Geometry, Node};
use crate::error::{Error, Result};
use crate::mesh::MeshSolid;

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

    /// The mesh, when the solid is one.
    pub fn mesh(&self) -> Option<&MeshSolid> {
        match &self.root {
            Node::Mesh(m) => Some(m),
            _ => None,
        }
    }

    /// An error when `self` or `other` is a mesh solid (see the module doc).
    pub(super) fn refuse_mesh_operand(&self, other: &Geometry, op: &str) -> Result<()> {
        if self.mesh().is_some() || other.mesh().is_some() {
            return Err(Error::InvalidGeometry {
                what: op.into(),
                reason: "an stl solid cannot be combined with other solids yet (a cell where a facet meets an analytic surface has no exact rule); mesh the combined part as one STL".into(),
            });
        }
        Ok(())
    }

    /// The mesh moved by `x ↦ R x + s`, if the solid is one.
    pub(super) fn move_mesh(&mut self, r: &[[f64; 3]; 3], s: [f64; 3]) {
        if let Node::Mesh(m) = &self.root {
            let moved = m.moved(r, s);
            self.bbox = grid_box(&moved);
            self.root = Node::Mesh(Arc::new(moved));
        }
    }

    /// The mesh's tags passed through `f`, if the solid is one.
    pub(super) fn retag_mesh(&mut self, f: impl Fn(u16) -> u16) {
        if let Node::Mesh(m) = &self.root {
            self.root = Node::Mesh(Arc::new(m.retagged(f)));
        }
    }
}

/// The mesh's box grown by `10⁻⁹` of its diagonal on its upper sides: the
/// polyhedral rules give each cell the half-open `[lo, hi)`, so a facet on
/// the upper face of a grid fitted to the exact box would belong to no cell.
fn grid_box(mesh: &MeshSolid) -> crate::geometry::Aabb {
    let mut b = mesh.bounding_box();
    let diag = (0..3)
        .map(|i| (b.hi[i] - b.lo[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    b.hi = b.hi.map(|v| v + 1e-9 * diag);
    b
}
