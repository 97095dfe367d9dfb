//! A bounding-volume hierarchy over triangles, with nearest-hit line queries
//! (contact search), box queries and a node walk (the winding number of
//! [`crate::mesh`]).
//!
//! **Why a BVH rather than a uniform spatial hash.** The master surface is a
//! 2D set in 3D whose triangles range from cell-sized to slivers, and under
//! large deformation it stretches and folds far from the grid it was built
//! on; a hash needs a cell size tuned to the triangles and walks many empty
//! cells along an oblique line, while a BVH adapts to where the triangles are
//! and prunes a line query to O(log n) boxes. It is rebuilt from the current
//! corners whenever the configuration changes (median split along the
//! longest axis of the centroids' box, O(n log n), leaves of at most
//! [`LEAF_SIZE`] triangles): a rebuild keeps the tree tight under large
//! motions, where a refit would let boxes overlap more and more.
//!
//! **Line–triangle intersection (Möller–Trumbore).** For the line
//! `o + t d` and the triangle `p0, p1, p2` with `e1 = p1 − p0`,
//! `e2 = p2 − p0`, solve `o + t d = p0 + u e1 + v e2` by Cramer's rule with
//! scalar triple products: with `P = d × e2`, `det = e1·P`, `s = o − p0`,
//! `Q = s × e1`,
//! `u = s·P / det`, `v = d·Q / det`, `t = e2·Q / det`.
//! The line hits the triangle when `u ≥ 0`, `v ≥ 0`, `u + v ≤ 1` (accepted
//! with a tolerance of 1e-12 so that a line through a shared edge hits at
//! least one side); the barycentric coordinates of the hit are
//! `(1 − u − v, u, v)`. A line within 1e-14 radians of the triangle's plane
//! is taken as parallel (no hit). Queries search both directions along the
//! line and return the hit of smallest `|t|` within `|t| ≤ max_abs_t` (ties
//! to the lowest triangle index, so the result is the brute-force one).

use super::vec3::{cross, dot, norm, sub, triangle_normal_scaled};

/// Most triangles in a leaf.
pub const LEAF_SIZE: usize = 4;

/// Barycentric tolerance of the intersection test.
const EDGE_TOLERANCE: f64 = 1e-12;

/// A line–triangle intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Index of the triangle in the list the hierarchy was built from.
    pub triangle: usize,
    /// Signed line parameter: the hit is `o + t d`.
    pub t: f64,
    /// Barycentric coordinates of the hit in the triangle's corners.
    pub barycentric: [f64; 3],
}

/// The line `o + t d` against one triangle (Möller–Trumbore), both
/// directions: `(t, barycentric)` or `None`.
pub fn intersect_line(tri: &[[f64; 3]; 3], o: [f64; 3], d: [f64; 3]) -> Option<(f64, [f64; 3])> {
    let e1 = sub(tri[1], tri[0]);
    let e2 = sub(tri[2], tri[0]);
    let p = cross(d, e2);
    let det = dot(e1, p);
    if det.abs() <= 1e-14 * norm(d) * norm(triangle_normal_scaled(tri)) {
        return None;
    }
    let inv = 1.0 / det;
    let s = sub(o, tri[0]);
    let u = dot(s, p) * inv;
    if !(-EDGE_TOLERANCE..=1.0 + EDGE_TOLERANCE).contains(&u) {
        return None;
    }
    let q = cross(s, e1);
    let v = dot(d, q) * inv;
    if v < -EDGE_TOLERANCE || u + v > 1.0 + EDGE_TOLERANCE {
        return None;
    }
    let t = dot(e2, q) * inv;
    Some((t, [1.0 - u - v, u, v]))
}

#[derive(Clone, Copy, Debug)]
enum Children {
    /// Triangles `order[start..start + count]`.
    Leaf {
        start: usize,
        count: usize,
    },
    Inner {
        left: usize,
        right: usize,
    },
}

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: [f64; 3],
    hi: [f64; 3],
    /// The node's triangles are `order[start..start + count]`.
    start: usize,
    count: usize,
    children: Children,
}

/// A node as [`Bvh::visit`] shows it: its box (the triangles' padded boxes)
/// and its triangles.
pub struct NodeView<'a> {
    /// Index of the node, below [`Bvh::num_nodes`].
    pub id: usize,
    pub lo: [f64; 3],
    pub hi: [f64; 3],
    pub triangles: &'a [usize],
}

/// A bounding-volume hierarchy over a list of triangles (their corners).
#[derive(Clone, Debug)]
pub struct Bvh {
    triangles: Vec<[[f64; 3]; 3]>,
    order: Vec<usize>,
    nodes: Vec<Node>,
}

impl Bvh {
    /// The hierarchy over `triangles`; hits name indices into this list.
    pub fn new(triangles: Vec<[[f64; 3]; 3]>) -> Bvh {
        let boxes: Vec<([f64; 3], [f64; 3])> = triangles.iter().map(padded_box).collect();
        let centroids: Vec<[f64; 3]> = triangles
            .iter()
            .map(|t| [0, 1, 2].map(|i| (t[0][i] + t[1][i] + t[2][i]) / 3.0))
            .collect();
        let mut order: Vec<usize> = (0..triangles.len()).collect();
        let mut bvh = Bvh {
            triangles,
            order: Vec::new(),
            nodes: Vec::new(),
        };
        if !order.is_empty() {
            bvh.build(&mut order, 0, &boxes, &centroids);
        }
        bvh.order = order;
        bvh
    }

    pub fn num_triangles(&self) -> usize {
        self.triangles.len()
    }

    /// The corners of triangle `i`.
    pub fn triangle(&self, i: usize) -> &[[f64; 3]; 3] {
        &self.triangles[i]
    }

    /// The number of nodes (0 for no triangles).
    pub fn num_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// Node `id` as [`Bvh::visit`] shows it.
    pub fn node(&self, id: usize) -> NodeView<'_> {
        let n = &self.nodes[id];
        NodeView {
            id,
            lo: n.lo,
            hi: n.hi,
            triangles: &self.order[n.start..n.start + n.count],
        }
    }

    /// Depth-first walk from the root: `enter(node)` says whether to look
    /// inside a node; the triangles of an entered leaf go to `leaf`.
    pub fn visit(&self, mut enter: impl FnMut(&NodeView) -> bool, mut leaf: impl FnMut(usize)) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = vec![0usize];
        while let Some(id) = stack.pop() {
            if !enter(&self.node(id)) {
                continue;
            }
            match self.nodes[id].children {
                Children::Leaf { start, count } => {
                    self.order[start..start + count]
                        .iter()
                        .for_each(|&t| leaf(t));
                }
                Children::Inner { left, right } => {
                    stack.push(right);
                    stack.push(left);
                }
            }
        }
    }

    /// Calls `f` for every triangle whose padded box meets the box `lo..hi`.
    pub fn for_each_in_box(&self, lo: [f64; 3], hi: [f64; 3], mut f: impl FnMut(usize)) {
        let meets =
            |a_lo: &[f64; 3], a_hi: &[f64; 3]| (0..3).all(|i| a_lo[i] <= hi[i] && a_hi[i] >= lo[i]);
        let boxes = |t: usize| padded_box(&self.triangles[t]);
        self.visit(
            |n| meets(&n.lo, &n.hi),
            |t| {
                let (tlo, thi) = boxes(t);
                if meets(&tlo, &thi) {
                    f(t)
                }
            },
        );
    }

    /// Builds the subtree over `items` (which start at `start` in the final
    /// order); returns its node index.
    fn build(
        &mut self,
        items: &mut [usize],
        start: usize,
        boxes: &[([f64; 3], [f64; 3])],
        centroids: &[[f64; 3]],
    ) -> usize {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        let (mut clo, mut chi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for &i in items.iter() {
            for a in 0..3 {
                lo[a] = lo[a].min(boxes[i].0[a]);
                hi[a] = hi[a].max(boxes[i].1[a]);
                clo[a] = clo[a].min(centroids[i][a]);
                chi[a] = chi[a].max(centroids[i][a]);
            }
        }
        let id = self.nodes.len();
        let leaf = Children::Leaf {
            start,
            count: items.len(),
        };
        self.nodes.push(Node {
            lo,
            hi,
            start,
            count: items.len(),
            children: leaf,
        });
        if items.len() <= LEAF_SIZE {
            return id;
        }
        let axis = (0..3)
            .max_by(|&a, &b| (chi[a] - clo[a]).total_cmp(&(chi[b] - clo[b])))
            .unwrap_or(0);
        let mid = items.len() / 2;
        items.select_nth_unstable_by(mid, |&a, &b| {
            centroids[a][axis].total_cmp(&centroids[b][axis])
        });
        let (left_items, right_items) = items.split_at_mut(mid);
        let left = self.build(left_items, start, boxes, centroids);
        let right = self.build(right_items, start + mid, boxes, centroids);
        self.nodes[id].children = Children::Inner { left, right };
        id
    }

    /// The hit of smallest `|t|` (ties: lowest triangle index) of the line
    /// `o + t d` with `|t| ≤ max_abs_t`.
    pub fn nearest_hit(&self, o: [f64; 3], d: [f64; 3], max_abs_t: f64) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut bound = max_abs_t;
        let mut stack = Vec::with_capacity(64);
        if let Some(root) = self.nodes.first() {
            if let Some(lower) = line_box_distance(root, o, d, max_abs_t) {
                stack.push((0usize, lower));
            }
        }
        while let Some((id, lower)) = stack.pop() {
            if lower > bound {
                continue;
            }
            match self.nodes[id].children {
                Children::Leaf { start, count } => {
                    for &tri in &self.order[start..start + count] {
                        self.consider(tri, o, d, &mut best, &mut bound);
                    }
                }
                Children::Inner { left, right } => {
                    let l = line_box_distance(&self.nodes[left], o, d, bound);
                    let r = line_box_distance(&self.nodes[right], o, d, bound);
                    // Push the farther child first: the nearer is searched first.
                    let mut pair = [(left, l), (right, r)];
                    if l.unwrap_or(f64::INFINITY) < r.unwrap_or(f64::INFINITY) {
                        pair.swap(0, 1);
                    }
                    for (child, dist) in pair {
                        if let Some(dist) = dist {
                            stack.push((child, dist));
                        }
                    }
                }
            }
        }
        best
    }

    /// [`Bvh::nearest_hit`] by testing every triangle (the reference).
    pub fn nearest_hit_linear(&self, o: [f64; 3], d: [f64; 3], max_abs_t: f64) -> Option<Hit> {
        let mut best = None;
        let mut bound = max_abs_t;
        for tri in 0..self.triangles.len() {
            self.consider(tri, o, d, &mut best, &mut bound);
        }
        best
    }

    /// Replaces `best` by the hit on triangle `tri` when it is nearer.
    fn consider(
        &self,
        tri: usize,
        o: [f64; 3],
        d: [f64; 3],
        best: &mut Option<Hit>,
        bound: &mut f64,
    ) {
        let Some((t, barycentric)) = intersect_line(&self.triangles[tri], o, d) else {
            return;
        };
        let better = match best {
            None => t.abs() <= *bound,
            Some(b) => t.abs() < b.t.abs() || (t.abs() == b.t.abs() && tri < b.triangle),
        };
        if better {
            *best = Some(Hit {
                triangle: tri,
                t,
                barycentric,
            });
            *bound = t.abs();
        }
    }
}

/// The triangle's box, padded by a little more than the intersection test's
/// edge tolerance.
fn padded_box(t: &[[f64; 3]; 3]) -> ([f64; 3], [f64; 3]) {
    let lo = [0, 1, 2].map(|i| t[0][i].min(t[1][i]).min(t[2][i]));
    let hi = [0, 1, 2].map(|i| t[0][i].max(t[1][i]).max(t[2][i]));
    let size = (0..3).map(|i| hi[i] - lo[i]).fold(0.0, f64::max);
    let pad = 1e-10 * size + 1e-300;
    (lo.map(|v| v - pad), hi.map(|v| v + pad))
}

/// The smallest `|t|` of the points of the line `o + t d` inside the node's
/// box with `|t| ≤ max_abs_t`, or `None` when there is none (slab test).
fn line_box_distance(node: &Node, o: [f64; 3], d: [f64; 3], max_abs_t: f64) -> Option<f64> {
    let (mut t0, mut t1) = (-max_abs_t, max_abs_t);
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] < node.lo[a] || o[a] > node.hi[a] {
                return None;
            }
            continue;
        }
        let (mut ta, mut tb) = ((node.lo[a] - o[a]) / d[a], (node.hi[a] - o[a]) / d[a]);
        if ta > tb {
            std::mem::swap(&mut ta, &mut tb);
        }
        t0 = t0.max(ta);
        t1 = t1.min(tb);
        if t0 > t1 {
            return None;
        }
    }
    Some(if t0 <= 0.0 && t1 >= 0.0 {
        0.0
    } else {
        t0.abs().min(t1.abs())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRI: [[f64; 3]; 3] = [[0.0, 0.0, 1.0], [2.0, 0.0, 1.0], [0.0, 2.0, 1.0]];

    #[test]
    fn moller_trumbore_gives_t_and_barycentrics() {
        let (t, b) = intersect_line(&TRI, [0.5, 0.25, 3.0], [0.0, 0.0, -2.0]).unwrap();
        assert!((t - 1.0).abs() < 1e-15);
        let expected = [0.625, 0.25, 0.125];
        assert!((0..3).all(|i| (b[i] - expected[i]).abs() < 1e-15), "{b:?}");
        // Behind the origin: negative t.
        let (t, _) = intersect_line(&TRI, [0.5, 0.25, -1.0], [0.0, 0.0, -1.0]).unwrap();
        assert!((t + 2.0).abs() < 1e-15);
        // Outside the triangle and parallel to it: no hit.
        assert!(intersect_line(&TRI, [1.5, 1.5, 0.0], [0.0, 0.0, 1.0]).is_none());
        assert!(intersect_line(&TRI, [0.5, 0.5, 0.0], [1.0, 0.0, 0.0]).is_none());
    }

    #[test]
    fn nearest_hit_picks_the_smallest_abs_t_in_both_directions() {
        let shifted = |z: f64| TRI.map(|p| [p[0], p[1], z]);
        let bvh = Bvh::new(vec![
            shifted(5.0),
            shifted(-0.5),
            shifted(0.75),
            shifted(-3.0),
        ]);
        let o = [0.3, 0.3, 0.0];
        let d = [0.0, 0.0, 1.0];
        let hit = bvh.nearest_hit(o, d, 10.0).unwrap();
        assert_eq!(hit.triangle, 1);
        assert_eq!(hit.t, -0.5);
        assert!(bvh.nearest_hit(o, d, 0.4).is_none());
        assert_eq!(
            bvh.nearest_hit(o, d, 10.0),
            bvh.nearest_hit_linear(o, d, 10.0)
        );
    }
}
