//! The ray-tracing contact search (paper eq. 2) and the current
//! slave normal.
//!
//! **Search.** From a slave point `x1` in the current configuration, along its
//! current unit outward normal `n1`, the line `x1 + t n1` is intersected with
//! the current master surface (both directions, so a penetrated point finds
//! the surface behind it); `x2` is the hit of smallest `|t|` within the search
//! radius on the master surface (the marching-tetrahedra facets, or curved PN
//! patches on them, [`super::patch`]), and the normal gap is
//! `g_N = (x2 − x1)·n1`
//! (= t: positive when the master lies ahead of the slave's outward normal,
//! i.e. the bodies are apart; negative on penetration). With the hit come
//! what an augmented Lagrangian needs to linearise `g_N`: the master
//! triangle, its cell, the barycentric coordinates of `x2` in the current
//! triangle, the same point in the reference configuration
//! `X2 = Σ_i ξ_i X_i` (where the master's shape functions are evaluated) and
//! the master's current unit outward normal (of the flat triangle).
//!
//! **Nanson's formula.** An oriented area element `N dA` of the reference
//! configuration is mapped by the deformation gradient `F = I + ∇_X u` to
//! `n da = J F⁻ᵀ N dA = cof(F) N dA`, with `J = det F` and
//! `cof(F) = J F⁻ᵀ` the cofactor matrix (rows `F₂×F₃, F₃×F₁, F₁×F₂` for rows
//! `F₁, F₂, F₃` of F, so no inverse is formed). Hence the current unit normal
//! `n = F⁻ᵀN / |F⁻ᵀN| = sign(J) cof(F)N / |cof(F)N|` and the area ratio
//! `da/dA = |cof(F) N|` for a unit `N`.

use rayon::prelude::*;

use super::patch::{cofactor_times, Patch};
use super::surface::Surface;
use crate::discrete::dofs::DofMap;
use crate::discrete::field::value_and_gradient;
use crate::grid::Grid;
use crate::spatial::bvh::Bvh;
use crate::spatial::vec3::{cross, dot, norm, normalize, scale, sub, triangle_normal_scaled};

/// The master surface in its current configuration, ready for searches.
#[derive(Clone, Debug)]
pub struct MasterSurface<'a> {
    surface: &'a Surface,
    current: Vec<[f64; 3]>,
    /// The current vertex normals of curved patches (`None`: flat facets).
    normals: Option<Vec<[f64; 3]>>,
    bvh: Bvh,
}

/// The result of a successful search from one slave point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactPoint {
    /// Index of the master triangle (of its patch) in its [`Surface`].
    pub triangle: usize,
    /// The master cell the triangle lies in.
    pub cell: usize,
    /// Barycentric coordinates `(1 − s − t, s, t)` of `x2` in the patch.
    pub barycentric: [f64; 3],
    /// The hit in the current configuration.
    pub x2: [f64; 3],
    /// The same patch coordinates on the reference patch.
    pub reference_x2: [f64; 3],
    /// `g_N = (x2 − x1)·n1`; negative on penetration.
    pub gap: f64,
    /// Current unit outward normal of the master patch at `x2`.
    pub master_normal: [f64; 3],
}

/// Barycentric tolerance for a patch hit to count as inside its triangle.
const INSIDE: f64 = 1e-10;

/// How far outside its triangle (in barycentric coordinates) a hit may lie
/// and still keep to the preferred patch ([`MasterSurface::search_near`]).
const STICKY: f64 = 0.02;

impl<'a> MasterSurface<'a> {
    /// The master `surface` with current vertex positions `current` (one
    /// per surface vertex, e.g. from [`Surface::deformed`]), made of curved
    /// patches on the current vertex normals (`curved`) or of the flat
    /// facets; builds the BVH over the flat facets.
    pub fn new(surface: &'a Surface, current: Vec<[f64; 3]>, curved: bool) -> MasterSurface<'a> {
        assert_eq!(
            current.len(),
            surface.vertices.len(),
            "one position per vertex"
        );
        let corners = (0..surface.num_triangles())
            .map(|t| surface.corners(&current, t))
            .collect();
        let normals = curved.then(|| surface.vertex_normals(&current));
        MasterSurface {
            surface,
            current,
            normals,
            bvh: Bvh::new(corners),
        }
    }

    /// The current vertex positions.
    pub fn current(&self) -> &[[f64; 3]] {
        &self.current
    }

    /// The current vertex normals ([`Surface::vertex_normals`]) of curved
    /// patches.
    pub fn normals(&self) -> Option<&[[f64; 3]]> {
        self.normals.as_deref()
    }

    /// The current patch of triangle `t`: with the current vertex normals
    /// at its corners, or the flat facet (every corner normal the facet's).
    pub fn patch(&self, t: usize) -> Patch<f64> {
        let s = self.surface;
        let p = s.corners(&self.current, t);
        let n = match &self.normals {
            Some(normals) => s.corners(normals, t),
            None => [triangle_normal_scaled(&p); 3],
        };
        Patch::new(&p, &n)
    }

    /// The ray search from `x1` along `n1` (normalised here) for hits with
    /// `|t| ≤ radius`: the flat facets' nearest hit (the BVH), which is the
    /// answer on flat facets; on curved patches the ray is then intersected
    /// (Newton's method) with the patches of the triangles sharing a corner
    /// with that facet,
    /// and the hit inside its triangle (barycentric coordinates ≥ −10⁻¹⁰)
    /// of smallest `|t|` is taken (ties: the lowest triangle index).
    /// Neighbouring patches share their edge curve (it depends on the edge's
    /// two corners and normals only), so a ray through an edge hits both.
    pub fn search(&self, x1: [f64; 3], n1: [f64; 3], radius: f64) -> Option<ContactPoint> {
        let n1 = normalize(n1);
        let hit = self.bvh.nearest_hit(x1, n1, radius)?;
        let start = [hit.barycentric[1], hit.barycentric[2], hit.t];
        if self.normals.is_none() {
            let t = hit.triangle;
            return Some(self.contact_point(&self.patch(t), t, x1, n1, start));
        }
        let mut inside: Option<(f64, usize, [f64; 3])> = None;
        for t in self.surface.triangles_around(hit.triangle) {
            let Some(z) = self.patch(t).intersect(x1, n1, start) else {
                continue;
            };
            if z[2].abs() > radius {
                continue;
            }
            let l = (1.0 - z[0] - z[1]).min(z[0]).min(z[1]);
            if l >= -INSIDE && inside.is_none_or(|(tau, _, _)| z[2].abs() < tau) {
                inside = Some((z[2].abs(), t, z));
            }
        }
        let (_, t, z) = inside?;
        Some(self.contact_point(&self.patch(t), t, x1, n1, z))
    }

    /// [`MasterSurface::search`], keeping to the patch `preferred` (the one
    /// hit at the last Newton iterate) while the hit on its surface lies
    /// within [`STICKY`] of its triangle in barycentric coordinates.
    ///
    /// Why: neighbouring patches meet along their edges with a kink in the
    /// normal (flat facets, and PN triangles too, less so), and the contact
    /// solution tends to settle slave points exactly on such an edge; a
    /// point that switched patch at every Newton iteration would see a gap
    /// whose gradient jumps there, and Newton oscillated across the kink
    /// (docs/verification.md, "The aligned-grid stall"). Kept on one patch
    /// (extended a little beyond its triangle, where it deviates from the
    /// neighbour by the kink times that distance) the gap is smooth in the
    /// displacement within a Newton iteration; the caller moves the
    /// preference to the patch hit at each new iterate.
    pub fn search_near(
        &self,
        x1: [f64; 3],
        n1: [f64; 3],
        radius: f64,
        preferred: Option<usize>,
    ) -> Option<ContactPoint> {
        let n1 = normalize(n1);
        if let Some(t) = preferred {
            let patch = self.patch(t);
            let start = [1.0 / 3.0, 1.0 / 3.0, 0.0];
            if let Some(z) = patch.intersect(x1, n1, start) {
                let l = (1.0 - z[0] - z[1]).min(z[0]).min(z[1]);
                if l >= -STICKY && z[2].abs() <= radius {
                    return Some(self.contact_point(&patch, t, x1, n1, z));
                }
            }
        }
        self.search(x1, n1, radius)
    }

    fn contact_point(
        &self,
        patch: &Patch<f64>,
        t: usize,
        x1: [f64; 3],
        n1: [f64; 3],
        z: [f64; 3],
    ) -> ContactPoint {
        let s = self.surface;
        let x = s.reference_corners(t);
        let n = match self.normals {
            Some(_) => s.corners(&s.normals, t),
            None => [triangle_normal_scaled(&x); 3],
        };
        let reference = Patch::new(&x, &n);
        let x2 = patch.eval(z[0], z[1]).0;
        ContactPoint {
            triangle: t,
            cell: s.triangles[t].cell,
            barycentric: [1.0 - z[0] - z[1], z[0], z[1]],
            x2,
            reference_x2: reference.eval(z[0], z[1]).0,
            gap: dot(sub(x2, x1), n1),
            master_normal: patch.normal(z[0], z[1]),
        }
    }

    /// [`MasterSurface::search`] for many slave points `(x1, n1)`, in parallel.
    pub fn search_all(
        &self,
        points: &[([f64; 3], [f64; 3])],
        radius: f64,
    ) -> Vec<Option<ContactPoint>> {
        points
            .par_iter()
            .map(|&(x, n)| self.search(x, n, radius))
            .collect()
    }
}

/// `F = I + ∇u` from the displacement gradient `g[i][j] = ∂u_i/∂X_j`.
pub fn deformation_gradient(g: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut f = *g;
    (0..3).for_each(|i| f[i][i] += 1.0);
    f
}

/// The current unit normal `F⁻ᵀN / |F⁻ᵀN|` (Nanson) of the reference normal
/// `n_ref` under the deformation gradient `f` (`f[i][j] = ∂x_i/∂X_j`).
pub fn current_normal(f: &[[f64; 3]; 3], n_ref: [f64; 3]) -> [f64; 3] {
    let j = dot(f[0], cross(f[1], f[2]));
    scale(normalize(cofactor_times(f, n_ref)), j.signum())
}

/// The area ratio `da/dA = |J F⁻ᵀ N|` for a unit reference normal `n_ref`.
pub fn area_ratio(f: &[[f64; 3]; 3], n_ref: [f64; 3]) -> f64 {
    norm(cofactor_times(f, n_ref))
}

/// A slave boundary point in the current configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlavePoint {
    /// `x1 = X + u(X)`.
    pub x: [f64; 3],
    /// The current unit outward normal (Nanson).
    pub normal: [f64; 3],
    /// `da/dA`, which turns a reference surface weight into a current one.
    pub area_ratio: f64,
}

/// The slave point with reference position `x_ref` in `cell` and reference
/// unit normal `n_ref`, under the nodal displacement field `u` (layout of
/// [`DofMap`]).
pub fn slave_point(
    grid: &Grid,
    dofs: &DofMap,
    u: &[f64],
    cell: usize,
    x_ref: [f64; 3],
    n_ref: [f64; 3],
) -> SlavePoint {
    let (value, grad) = value_and_gradient(grid, dofs, u, cell, x_ref);
    let f = deformation_gradient(&grad);
    SlavePoint {
        x: [0, 1, 2].map(|i| x_ref[i] + value[i]),
        normal: current_normal(&f, n_ref),
        area_ratio: area_ratio(&f, n_ref),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nanson_for_a_stretch_and_shear() {
        // x = (2X + Y, Y, Z/2): J = 1, F⁻¹ = [[1/2, −1/2, 0], [0, 1, 0], [0, 0, 2]];
        // F⁻ᵀN is the row of F⁻¹ picked by N.
        let f = [[2.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.5]];
        let n = current_normal(&f, [1.0, 0.0, 0.0]);
        let expected = normalize([0.5, -0.5, 0.0]);
        assert!((0..3).all(|i| (n[i] - expected[i]).abs() < 1e-15), "{n:?}");
        assert!((area_ratio(&f, [1.0, 0.0, 0.0]) - 0.5f64.sqrt()).abs() < 1e-15);
        // Planes Y = const stay planes y = const, with unchanged area.
        assert_eq!(current_normal(&f, [0.0, 1.0, 0.0]), [0.0, 1.0, 0.0]);
        assert!((area_ratio(&f, [0.0, 1.0, 0.0]) - 1.0).abs() < 1e-15);
        // e_z: F⁻ᵀ e_z = (0, 0, 2); the area ratio J·2 = 2.
        assert_eq!(current_normal(&f, [0.0, 0.0, 1.0]), [0.0, 0.0, 1.0]);
        assert!((area_ratio(&f, [0.0, 0.0, 1.0]) - 2.0).abs() < 1e-15);
    }
}
