//! CSG operations, rigid motions and boundary-tag editing on [`Geometry`].

use super::surface::Frame;
use super::{Geometry, Node};
use crate::error::{Error, Result};
use crate::spatial::vec3::norm;
use crate::spatial::Aabb;

impl Node {
    fn shifted(self, by: usize) -> Node {
        match self {
            Node::Leaf(i) => Node::Leaf(i + by),
            leaf @ (Node::Mesh(_) | Node::Const(_)) => leaf,
            Node::Union(a, b) => Node::Union(Box::new(a.shifted(by)), Box::new(b.shifted(by))),
            Node::Intersection(a, b) => {
                Node::Intersection(Box::new(a.shifted(by)), Box::new(b.shifted(by)))
            }
            Node::Difference(a, b) => {
                Node::Difference(Box::new(a.shifted(by)), Box::new(b.shifted(by)))
            }
        }
    }
}

impl Geometry {
    /// Appends `other`'s leaves (tags merged by name, in its analytic leaves
    /// and its meshes' triangles); returns both roots.
    fn merge(mut self, mut other: Geometry) -> (Geometry, Node, Node) {
        let by = self.leaves.len();
        let ids: Vec<u16> = other
            .tags
            .iter()
            .map(|name| match self.tag_id(name) {
                Some(id) => id,
                None => {
                    self.tags.push(name.clone());
                    (self.tags.len() - 1) as u16
                }
            })
            .collect();
        other.retag_meshes(|t| ids[t as usize]);
        for mut leaf in other.leaves {
            leaf.tag = ids[leaf.tag as usize];
            self.leaves.push(leaf);
        }
        let a = std::mem::replace(&mut self.root, Node::Leaf(0));
        (self, a, other.root.shifted(by))
    }

    /// `self ∪ other`.
    pub fn union(self, other: Geometry) -> Result<Geometry> {
        let bbox = self.bbox.union(&other.bbox);
        let (mut g, a, b) = self.merge(other);
        g.root = Node::Union(Box::new(a), Box::new(b));
        g.bbox = bbox;
        Ok(g)
    }

    /// `self ∩ other`; an error when the bounding boxes are disjoint.
    pub fn intersection(self, other: Geometry) -> Result<Geometry> {
        let bbox = self.bbox.intersection(&other.bbox);
        if bbox.is_empty() {
            return Err(Error::EmptyGeometry {
                what: "intersection of two solids whose bounding boxes are disjoint".into(),
            });
        }
        let (mut g, a, b) = self.merge(other);
        g.root = Node::Intersection(Box::new(a), Box::new(b));
        g.bbox = bbox;
        Ok(g)
    }

    /// `self \ other`; an error when `other`'s box covers `self`'s and `other`
    /// contains every corner and the centre of `self`'s box (a cheap emptiness
    /// test; the grid reports an empty result it finds later).
    pub fn difference(self, other: Geometry) -> Result<Geometry> {
        let bbox = self.bbox;
        if bbox.is_finite() && bbox.intersection(&other.bbox) == bbox {
            let c = [0, 1, 2].map(|i| 0.5 * (bbox.lo[i] + bbox.hi[i]));
            let corners_inside = (0..8).all(|k| {
                let p = [0, 1, 2].map(|i| {
                    if k >> i & 1 == 1 {
                        bbox.hi[i]
                    } else {
                        bbox.lo[i]
                    }
                });
                other.phi(p) < 0.0
            });
            if corners_inside && other.phi(c) < 0.0 && other.is_convex() {
                return Err(Error::EmptyGeometry {
                    what: "difference whose subtracted convex solid covers the whole body".into(),
                });
            }
        }
        let (mut g, a, b) = self.merge(other);
        g.root = Node::Difference(Box::new(a), Box::new(b));
        g.bbox = bbox;
        Ok(g)
    }

    /// True for an intersection of convex leaves (spheres, planes, cylinders).
    fn is_convex(&self) -> bool {
        fn convex(g: &Geometry, n: &Node) -> bool {
            match n {
                Node::Leaf(i) => !matches!(
                    g.leaves[*i].shape,
                    super::surface::Shape::Torus { .. } | super::surface::Shape::Image(_)
                ),
                Node::Intersection(a, b) => convex(g, a) && convex(g, b),
                _ => false,
            }
        }
        convex(self, &self.root)
    }

    /// The solid moved by `x ↦ x + v`.
    pub fn translate(self, v: [f64; 3]) -> Result<Geometry> {
        if !v.iter().all(|c| c.is_finite()) {
            return Err(Error::InvalidGeometry {
                what: "translate".into(),
                reason: format!("offset must be finite, got {v:?}"),
            });
        }
        Ok(self.moved(&Frame::IDENTITY.q, v))
    }

    /// The solid rotated by `angle` radians about `axis` through the origin
    /// (right-hand rule).
    pub fn rotate(self, axis: [f64; 3], angle: f64) -> Result<Geometry> {
        let n = norm(axis);
        if !(n.is_finite() && n > 0.0 && angle.is_finite()) {
            return Err(Error::InvalidGeometry {
                what: "rotate".into(),
                reason: format!("axis must be non-zero and angle finite, got {axis:?}, {angle}"),
            });
        }
        let k = axis.map(|a| a / n);
        let (s, c) = angle.sin_cos();
        // Rodrigues: R e_j = c e_j + s (k × e_j) + (1 − c) k_j k, stored by columns.
        let mut r = [[0.0; 3]; 3];
        for (j, col) in r.iter_mut().enumerate() {
            let mut e = [0.0; 3];
            e[j] = 1.0;
            let kxe = crate::spatial::vec3::cross(k, e);
            for i in 0..3 {
                col[i] = c * e[i] + s * kxe[i] + (1.0 - c) * k[j] * k[i];
            }
        }
        Ok(self.moved(&r, [0.0; 3]))
    }

    fn moved(mut self, r: &[[f64; 3]; 3], s: [f64; 3]) -> Geometry {
        for leaf in &mut self.leaves {
            leaf.frame = leaf.frame.moved(r, s);
        }
        let b = self.bbox;
        self.bbox = if !b.is_finite() {
            Aabb::EVERYTHING
        } else {
            let corners: Vec<[f64; 3]> = (0..8)
                .map(|k| {
                    let p = [0, 1, 2].map(|i| if k >> i & 1 == 1 { b.hi[i] } else { b.lo[i] });
                    [0, 1, 2].map(|i| r[0][i] * p[0] + r[1][i] * p[1] + r[2][i] * p[2] + s[i])
                })
                .collect();
            Aabb::around(&corners)
        };
        // A solid that is one mesh takes its moved mesh's own box instead.
        self.move_meshes(r, s);
        self
    }

    /// Every boundary part renamed to `tag`.
    pub fn with_tag(mut self, tag: &str) -> Geometry {
        self.tags = vec![tag.to_string()];
        for leaf in &mut self.leaves {
            leaf.tag = 0;
        }
        self.retag_meshes(|_| 0);
        self
    }

    /// The boundary part `from` renamed to `to` (merged with `to` if it exists).
    pub fn retag(mut self, from: &str, to: &str) -> Result<Geometry> {
        let Some(old) = self.tag_id(from) else {
            return Err(Error::UnknownTag {
                tag: from.into(),
                known: self.tags.join(", "),
            });
        };
        if let Some(new) = self.tag_id(to) {
            self.tags.remove(old as usize);
            let new = if new > old { new - 1 } else { new };
            let renumber = |t: u16| match t.cmp(&old) {
                std::cmp::Ordering::Equal => new,
                std::cmp::Ordering::Greater => t - 1,
                std::cmp::Ordering::Less => t,
            };
            for leaf in &mut self.leaves {
                leaf.tag = renumber(leaf.tag);
            }
            self.retag_meshes(renumber);
        } else {
            self.tags[old as usize] = to.into();
        }
        Ok(self)
    }
}
