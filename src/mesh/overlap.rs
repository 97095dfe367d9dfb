//! Whether a triangle meets an axis-aligned box: the separating-axis test of
//! Akenine-Möller (2001). The triangle and the box are disjoint exactly when
//! their projections onto one of 13 axes are: the box's three axes, the
//! triangle's normal, and the nine cross products of a box axis with a
//! triangle edge.
//!
//! The test is conservative: projections that touch within `10⁻¹²` of the
//! box's size count as overlapping, so a facet in a box's face plane meets
//! that box (the cut rules decide its side by their own conventions).

use crate::spatial::vec3::{cross, dot, sub};
use crate::spatial::Aabb;

/// True when the triangle `t` meets the closed box `b` (within the slack of
/// the module doc).
pub fn triangle_meets_box(t: &[[f64; 3]; 3], b: &Aabb) -> bool {
    let c = [0, 1, 2].map(|i| 0.5 * (b.lo[i] + b.hi[i]));
    let e = [0, 1, 2].map(|i| 0.5 * (b.hi[i] - b.lo[i]));
    let slack = 1e-12 * e.iter().fold(0.0, |m: f64, v| m.max(*v));
    let v = t.map(|p| sub(p, c));
    let separated = |axis: [f64; 3]| {
        let p = v.map(|x| dot(x, axis));
        let r: f64 = (0..3).map(|i| e[i] * axis[i].abs()).sum();
        let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
        lo > r + slack || hi < -r - slack
    };
    let unit = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    if unit.iter().any(|&a| separated(a)) {
        return false;
    }
    let edges = [sub(v[1], v[0]), sub(v[2], v[1]), sub(v[0], v[2])];
    if separated(cross(edges[0], edges[1])) {
        return false;
    }
    !edges
        .iter()
        .any(|&f| unit.iter().any(|&a| separated(cross(a, f))))
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRI: [[f64; 3]; 3] = [[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 4.0, 0.0]];

    fn unit_box_at(lo: [f64; 3]) -> Aabb {
        Aabb::new(lo, lo.map(|v| v + 1.0))
    }

    #[test]
    fn a_box_beside_the_hypotenuse_is_missed_though_the_boxes_overlap() {
        // Inside the triangle's bounding box, beyond x + y = 4.
        assert!(!triangle_meets_box(&TRI, &unit_box_at([2.6, 2.6, -0.5])));
        assert!(triangle_meets_box(&TRI, &unit_box_at([1.4, 1.4, -0.5])));
    }

    #[test]
    fn a_box_above_or_below_the_plane_is_missed_and_one_touching_it_is_met() {
        assert!(!triangle_meets_box(&TRI, &unit_box_at([0.5, 0.5, 0.1])));
        assert!(!triangle_meets_box(&TRI, &unit_box_at([0.5, 0.5, -1.1])));
        assert!(triangle_meets_box(&TRI, &unit_box_at([0.5, 0.5, 0.0])));
        assert!(triangle_meets_box(&TRI, &unit_box_at([0.5, 0.5, -1.0])));
    }

    #[test]
    fn a_tilted_triangle_through_a_box_corner_region_is_decided_by_an_edge_axis() {
        // The plane x + y + z = 2.9 passes the unit box's corner (1, 1, 1)
        // (sum 3) but this thin triangle in it stays away from the box.
        let t = [[2.9, 0.0, 0.0], [0.0, 2.9, 0.0], [2.9, -1.0, 1.0]];
        assert!(!triangle_meets_box(&t, &unit_box_at([0.0, 0.0, 0.0])));
        let big = [[2.9, 0.0, 0.0], [0.0, 2.9, 0.0], [0.0, 0.0, 2.9]];
        assert!(triangle_meets_box(&big, &unit_box_at([0.0, 0.0, 0.0])));
    }
}
