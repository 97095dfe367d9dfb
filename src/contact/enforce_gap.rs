//! The normal gap of one slave point, its area ratio, current normal and
//! tangential slip as functions of 24 kinematic quantities, with exact
//! gradients and Hessians.
//!
//! **Variables** `y = [x1, F, p0, p1, p2, a]` (indices 0–2, 3–11 row-major
//! `F_ij` at `3 + 3i + j`, 12–14, 15–17, 18–20, 21–23): the current slave
//! point `x1 = X + u_s(X)`, the slave deformation gradient `F = I + ∇_X u_s`
//! there, the current corners `p_k = X_k + u_m(X_k)` of the master triangle
//! the ray hit, and the current position `a = Â + u_m(Â)` of the friction
//! anchor `Â` (the master point touched at the last converged step; unused
//! without friction). Every one of them is *linear* in the nodal
//! displacements, so the
//! chain rule to the dofs needs no second derivative of `y`:
//! `∇_u g = Aᵀ ∇_y g`, `∇²_u g = Aᵀ ∇²_y g A` with `A = ∂y/∂u` constant.
//!
//! **Gap.** The ray from `x1` along the current slave normal
//! `n1 = c/|c|`, `c = cof(F) N` (Nanson, for `det F > 0`), meets the plane
//! of the current master triangle, of normal `ν = (p1 − p0) × (p2 − p0)`, at
//! `x2 = x1 + g n1` with
//! `g_N = (p0 − x1)·ν / (n1·ν) = |c| (p0 − x1)·ν / (c·ν)`
//! — the search's `g_N = (x2 − x1)·n1` as a closed-form function of `y`
//! (the barycentric coordinates of `x2`, and their variation, are
//! eliminated by projecting on `ν`). The area ratio is
//! `J_s = da/dA = |c|`.
//!
//! **Slip.** The tangential relative displacement from the anchor,
//! `g_T = (I − n1 ⊗ n1)(x1 − a)`.

use super::enforce_dual::HyperDual;

/// Number of kinematic variables.
pub const NVAR: usize = 24;

/// Offset of `x1` in `y`.
pub const X1: usize = 0;
/// Offset of `F` (row-major) in `y`.
pub const F: usize = 3;
/// Offset of master corner `k` in `y` is `P + 3k`.
pub const P: usize = 12;
/// Offset of the anchor `a` in `y`.
pub const A: usize = 21;

/// A scalar with derivatives in `y`.
pub type D = HyperDual<NVAR>;
type V = [D; 3];

/// The point's kinematics, each with derivatives in `y`.
#[derive(Clone, Debug)]
pub struct LocalGap {
    /// `g_N`.
    pub gap: D,
    /// `J_s`.
    pub area_ratio: D,
    /// `n1`.
    pub normal: [D; 3],
    /// `g_T`.
    pub slip: [D; 3],
}

fn vector(y: &[f64; NVAR], at: usize) -> V {
    [0, 1, 2].map(|i| D::var(y[at + i], at + i))
}

fn sub(a: &V, b: &V) -> V {
    [0, 1, 2].map(|i| a[i] - b[i])
}

fn dot(a: &V, b: &V) -> D {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: &V, b: &V) -> V {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `c = cof(F) N`: rows of `cof(F)` are `F₂×F₃, F₃×F₁, F₁×F₂` (rows `Fᵢ`).
fn cofactor_times(rows: &[V; 3], n_ref: [f64; 3]) -> V {
    let cof = [
        cross(&rows[1], &rows[2]),
        cross(&rows[2], &rows[0]),
        cross(&rows[0], &rows[1]),
    ];
    cof.map(|r| r[0].scale(n_ref[0]) + r[1].scale(n_ref[1]) + r[2].scale(n_ref[2]))
}

/// `g_N` and `J_s` at the kinematic state `y` for the reference unit normal
/// `n_ref` of the slave point.
pub fn local_gap(y: &[f64; NVAR], n_ref: [f64; 3]) -> LocalGap {
    let x1 = vector(y, X1);
    let rows = [0, 1, 2].map(|i| vector(y, F + 3 * i));
    let p = [0, 1, 2].map(|k| vector(y, P + 3 * k));
    let c = cofactor_times(&rows, n_ref);
    let nu = cross(&sub(&p[1], &p[0]), &sub(&p[2], &p[0]));
    let area_ratio = dot(&c, &c).sqrt();
    let gap = area_ratio * dot(&sub(&p[0], &x1), &nu) * dot(&c, &nu).recip();
    let inverse_norm = area_ratio.recip();
    let n1 = c.map(|ci| ci * inverse_norm);
    let d = sub(&x1, &vector(y, A));
    let normal_part = dot(&n1, &d);
    let slip = [0, 1, 2].map(|i| d[i] - n1[i] * normal_part);
    LocalGap {
        gap,
        area_ratio,
        normal: n1,
        slip,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A state: a sheared slave point over a tilted master triangle.
    fn state() -> [f64; NVAR] {
        let mut y = [0.0; NVAR];
        y[..3].copy_from_slice(&[0.1, -0.05, 0.02]);
        let f = [[1.1, 0.05, -0.02], [0.03, 0.95, 0.04], [0.01, -0.06, 1.02]];
        for i in 0..3 {
            y[F + 3 * i..F + 3 * i + 3].copy_from_slice(&f[i]);
        }
        let p = [[-0.5, -0.4, -0.1], [0.6, -0.3, -0.05], [0.0, 0.7, -0.2]];
        for k in 0..3 {
            y[P + 3 * k..P + 3 * k + 3].copy_from_slice(&p[k]);
        }
        y[A..A + 3].copy_from_slice(&[0.13, -0.01, -0.04]);
        y
    }

    #[test]
    fn the_gap_is_the_ray_distance_and_its_hessian_matches_differences() {
        let n_ref = [0.0, 0.0, -1.0];
        let y = state();
        let lg = local_gap(&y, n_ref);
        // Independent value: x1 + g n1 lies in the master plane.
        let fm = [0, 1, 2].map(|i| [0, 1, 2].map(|j| y[F + 3 * i + j]));
        let n1 = crate::contact::current_normal(&fm, n_ref);
        let x2 = [0, 1, 2].map(|i| y[i] + lg.gap.v * n1[i]);
        let p = [0, 1, 2].map(|k| [0, 1, 2].map(|i| y[P + 3 * k + i]));
        let e1 = [0, 1, 2].map(|i| p[1][i] - p[0][i]);
        let e2 = [0, 1, 2].map(|i| p[2][i] - p[0][i]);
        let nu = crate::geometry::surface::cross(e1, e2);
        let off: f64 = (0..3).map(|i| (x2[i] - p[0][i]) * nu[i]).sum();
        assert!(off.abs() < 1e-14, "{off}");
        assert!((lg.area_ratio.v - crate::contact::area_ratio(&fm, n_ref)).abs() < 1e-14);
        // The slip is tangential.
        let along: f64 = (0..3).map(|i| lg.slip[i].v * n1[i]).sum();
        assert!(along.abs() < 1e-15, "{along}");
        // Hessian columns against central differences of the gradient.
        let eps = 1e-6;
        for b in 0..NVAR {
            let (mut yp, mut ym) = (y, y);
            yp[b] += eps;
            ym[b] -= eps;
            let (gp, gm) = (local_gap(&yp, n_ref).gap, local_gap(&ym, n_ref).gap);
            for a in 0..NVAR {
                let fd = (gp.g[a] - gm.g[a]) / (2.0 * eps);
                assert!(
                    (fd - lg.gap.h[a][b]).abs() < 1e-7,
                    "({a}, {b}): {fd} vs {}",
                    lg.gap.h[a][b]
                );
            }
            let fd = (gp.v - gm.v) / (2.0 * eps);
            assert!((fd - lg.gap.g[b]).abs() < 1e-8, "{b}");
            let (sp, sm) = (local_gap(&yp, n_ref).slip, local_gap(&ym, n_ref).slip);
            for i in 0..3 {
                for a in 0..NVAR {
                    let fd = (sp[i].g[a] - sm[i].g[a]) / (2.0 * eps);
                    assert!(
                        (fd - lg.slip[i].h[a][b]).abs() < 1e-7,
                        "slip {i} ({a}, {b})"
                    );
                }
            }
        }
    }
}
