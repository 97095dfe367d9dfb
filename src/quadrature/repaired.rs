//! Cut-cell rules where a mesh is not a clean closed surface.
//!
//! The polyhedral rule ([`super::polyhedral`]) gets the moments of `B ∩ Ω`
//! from the facets in the cell by the divergence theorem, which holds only
//! when they close the part up (with the cell's faces). Where a mesh has a
//! hole, a flipped or overlapping shell, or facets through each other, the
//! same formula gives a number that is no volume at all: weights of the
//! wrong size or sign, and a negative stiffness. So on a mesh with defects
//! ([`MeshSolid::is_dirty`]) every cell is checked ([`needs_repair`]): a
//! facet in it that does not separate `w = 1` from `w = 0`
//! ([`MeshSolid::irregular`]), a volume that differs when the divergence
//! theorem is taken along x, y or z (an open surface), or one outside
//! `[0, h³]`, and the cell takes
//! the repaired rule ([`repaired_rule`]) instead: the body is
//! `{w ≥ ½}`, `w` the generalised winding number, its volume integrated by
//! the midpoints of a sub-lattice (first order in the sub-cell size, every
//! weight positive) and its boundary by the facets' own points where `w`
//! crosses ½ through them. Clean cells of the same mesh, and every cell of a
//! clean mesh, keep the exact rule.

use super::saye::{BoxRule, SurfacePoint, VolumePoint};
use crate::mesh::MeshSolid;
use crate::spatial::Aabb;

/// Sub-cells per axis of a repaired cell's volume rule.
pub const SUBDIVISIONS: usize = 6;

/// Relative difference, in units of the cell's volume, between the volumes
/// along the axes above which the cell's facets do not close: round-off on
/// a closed surface (T-junctions included) is about `1e-15`.
const OPEN: f64 = 1e-9;

/// Whether the cell `b` needs the repaired rule: one of the facets `near` it
/// is irregular, its volumes by the divergence theorem along x, y and z
/// (`along`) differ (a facet normal to z adds nothing along x or y, so a
/// hole in it shows only along z), or the volume is not in `[0, |b|]`.
pub fn needs_repair(mesh: &MeshSolid, b: &Aabb, near: &[usize], along: [f64; 3]) -> bool {
    let volume: f64 = (0..3).map(|a| b.hi[a] - b.lo[a]).product();
    let (lo, hi) = along
        .iter()
        .fold((f64::MAX, f64::MIN), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    let impossible = lo < -OPEN * volume || hi > (1.0 + OPEN) * volume;
    near.iter().any(|&t| mesh.irregular(t)) || hi - lo > OPEN * volume || impossible
}

/// The repaired rule of the cell `b`: volume points at the centres of the
/// [`SUBDIVISIONS`]³ sub-cells where `w ≥ ½`; the boundary points `surface`
/// (the clipped facets' rule) kept where `w` is at least ½ just behind and
/// below ½ just in front; samples the inside points of a `k³` sub-lattice
/// (`k = q/2 + 2`), topped up with boundary points as the exact rule's are.
pub fn repaired_rule(mesh: &MeshSolid, b: &Aabb, q: usize, surface: Vec<SurfacePoint>) -> BoxRule {
    let size = [0, 1, 2].map(|a| b.hi[a] - b.lo[a]);
    let inside = |x: [f64; 3]| mesh.winding_number(x) >= 0.5;
    let lattice = |k: usize| {
        (0..k * k * k).map(move |idx| {
            let ijk = [idx % k, (idx / k) % k, idx / (k * k)];
            [0, 1, 2].map(|a| b.lo[a] + size[a] * (ijk[a] as f64 + 0.5) / k as f64)
        })
    };
    let m = SUBDIVISIONS;
    let w = size.iter().product::<f64>() / (m * m * m) as f64;
    let volume = lattice(m)
        .filter(|&x| inside(x))
        .map(|x| VolumePoint { x, w })
        .collect();
    let eps = 1e-6 * size.iter().cloned().fold(0.0, f64::max);
    let surface: Vec<SurfacePoint> = surface
        .into_iter()
        .filter(|p| {
            let at = |s: f64| [0, 1, 2].map(|a| p.x[a] + s * eps * p.n[a]);
            inside(at(-1.0)) && !inside(at(1.0))
        })
        .collect();
    let k = q / 2 + 2;
    let want = 2 * (q / 2 + 1).pow(3);
    let mut samples: Vec<[f64; 3]> = lattice(k).filter(|&x| inside(x)).collect();
    if samples.len() < want && !surface.is_empty() {
        let stride = surface.len().div_ceil(want - samples.len()).max(1);
        samples.extend(surface.iter().step_by(stride).map(|p| p.x));
    }
    BoxRule {
        volume,
        surface,
        samples,
        repaired: true,
    }
}
