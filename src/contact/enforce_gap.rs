//! The normal gap of one slave point, its area ratio, current normal and
//! tangential slip as functions of 33 kinematic quantities, with exact
//! gradients and Hessians.
//!
//! **Variables** `y = [x1, F, p0, p1, p2, a, m0, m1, m2]` (indices 0–2,
//! 3–11 row-major `F_ij` at `3 + 3i + j`, 12–14, 15–17, 18–20, 21–23,
//! 24–26, 27–29, 30–32): the current slave point `x1 = X + u_s(X)`, the
//! slave deformation gradient `F = I + ∇_X u_s` there, the current corners
//! `p_k = X_k + u_m(X_k)` of the master patch the ray hit, the current
//! position `a = Â + u_m(Â)` of the friction anchor `Â` (the master point
//! touched at the last converged step; unused without friction), and the
//! patch's corner normals `m_k` (the current vertex normals,
//! [`super::surface::Surface::vertex_normals`]). All but the `m_k` are
//! linear in the nodal displacements; each `m_k` is quadratic in the
//! current positions of the vertices around corner `k`, and the chain rule
//! to the dofs adds their second derivatives (`enforce_local`).
//!
//! **Gap.** The ray from `x1` along the current slave normal
//! `n1 = c/|c|`, `c = cof(F) N` (Nanson, for `det F > 0`), meets the
//! master's curved patch ([`super::patch`], from `p_k` and `m_k`) at
//! `x2 = x(s, t) = x1 + g_N n1`: `g_N` is the search's `(x2 − x1)·n1`, an
//! implicit function of 24 inner quantities `z = [x1, c, p_k, m_k]`. Two
//! Newton steps of the ray–patch equations in forward-mode numbers in `z`,
//! from the converged `(s, t, g_N)`, give its exact gradient and Hessian in
//! `z`; the chain rule to `y` ([`HyperDual::compose`]) adds the second
//! derivatives of `c`, quadratic in `F`. On a flat facet (the default
//! master surface) the same gap has a closed form in `y`,
//! `g_N = |c| (p0 − x1)·ν / (c·ν)` with `ν = (p1 − p0) × (p2 − p0)`, and
//! the `m_k` are not used. The area ratio is `J_s = da/dA = |c|`.
//!
//! **Slip.** The tangential relative displacement from the anchor,
//! `g_T = (I − n1 ⊗ n1)(x1 − a)`.

use super::enforce_dual::HyperDual;
use super::patch::{cofactor_times, cross, dot, sub, Patch, Real};

/// Number of kinematic variables.
pub const NVAR: usize = 33;

/// Offset of `x1` in `y`.
pub const X1: usize = 0;
/// Offset of `F` (row-major) in `y`.
pub const F: usize = 3;
/// Offset of master corner `k` in `y` is `P + 3k`.
pub const P: usize = 12;
/// Offset of the anchor `a` in `y`.
pub const A: usize = 21;
/// Offset of the normal at master corner `k` in `y` is `M + 3k`.
pub const M: usize = 24;

/// Number of inner variables of the gap, `z = [x1, c, p0, p1, p2, m0, m1, m2]`.
const NZ: usize = 24;

/// The numbers a point's kinematics are computed in: with their Hessians
/// ([`Second`], for the tangent) or gradients only ([`First`], for the
/// residual: the same values and gradients, a hundredth of the work).
pub trait Order: Clone + std::fmt::Debug {
    /// A scalar with derivatives in `y`.
    type Y: Real;
    /// A scalar with derivatives in `z`.
    type Z: Real;
    /// A scalar with derivatives in a block of 9 consecutive entries of `y`.
    type Block: Real;
    fn var_y(v: f64, i: usize) -> Self::Y;
    fn var_z(v: f64, i: usize) -> Self::Z;
    fn var_block(v: f64, i: usize) -> Self::Block;
    /// A block's number among the `y` ([`HyperDual::embed`]).
    fn embed(offset: usize, x: &Self::Block) -> Self::Y;
    /// `q(z(y))` ([`HyperDual::compose`]).
    fn compose(q: &Self::Z, z: &[(usize, Self::Block); NZ]) -> Self::Y;
    /// `∇_y` of a number.
    fn gradient(x: &Self::Y) -> &[f64; NVAR];
}

/// The [`Order`] whose numbers have the Hessian extents `HY`, `HZ`, `HB`
/// (each its type's variable count, or 0).
#[derive(Clone, Debug)]
pub struct Extents<const HY: usize, const HZ: usize, const HB: usize>;

/// Values, gradients and Hessians.
pub type Second = Extents<NVAR, NZ, 9>;

/// Values and gradients.
pub type First = Extents<0, 0, 0>;

impl<const HY: usize, const HZ: usize, const HB: usize> Order for Extents<HY, HZ, HB> {
    type Y = HyperDual<NVAR, HY>;
    type Z = HyperDual<NZ, HZ>;
    type Block = HyperDual<9, HB>;
    fn var_y(v: f64, i: usize) -> Self::Y {
        HyperDual::var(v, i)
    }
    fn var_z(v: f64, i: usize) -> Self::Z {
        HyperDual::var(v, i)
    }
    fn var_block(v: f64, i: usize) -> Self::Block {
        HyperDual::var(v, i)
    }
    fn embed(offset: usize, x: &Self::Block) -> Self::Y {
        HyperDual::embed(offset, x)
    }
    fn compose(q: &Self::Z, z: &[(usize, Self::Block); NZ]) -> Self::Y {
        HyperDual::compose(q, z)
    }
    fn gradient(x: &Self::Y) -> &[f64; NVAR] {
        &x.g
    }
}

/// The point's kinematics, each with derivatives in `y`.
#[derive(Clone, Debug)]
pub struct LocalGap<O: Order> {
    /// `g_N`.
    pub gap: O::Y,
    /// `J_s`.
    pub area_ratio: O::Y,
    /// `n1`.
    pub normal: [O::Y; 3],
    /// `g_T`.
    pub slip: [O::Y; 3],
}

fn vector<O: Order>(y: &[f64; NVAR], at: usize) -> [O::Y; 3] {
    [0, 1, 2].map(|i| O::var_y(y[at + i], at + i))
}

/// The entries `y[at..at + 3]` as variables of their block.
fn block_vector<O: Order>(y: &[f64; NVAR], at: usize) -> [(usize, O::Block); 3] {
    [0, 1, 2].map(|i| (at, O::var_block(y[at + i], i)))
}

/// `cof(M) N` for the row-major 3 × 3 matrix `M = y[at..at + 9]`, in its
/// block.
fn cofactor_block<O: Order>(y: &[f64; NVAR], at: usize, n: [f64; 3]) -> [(usize, O::Block); 3] {
    let rows = [0, 1, 2].map(|i| [0, 1, 2].map(|j| O::var_block(y[at + 3 * i + j], 3 * i + j)));
    cofactor_times(&rows, n).map(|c| (at, c))
}

/// `g_N` in the inner variables `z` (values `zv`), from `start`, the
/// search's `(s, t, g_N)`: the ray–patch solve refined in `f64`, then two
/// Newton steps in forward-mode numbers.
fn gap_in_z<O: Order>(zv: &[f64; NZ], start: [f64; 3]) -> O::Z {
    let var = |r: usize| O::var_z(zv[r], r);
    let x1 = [0, 1, 2].map(var);
    let c = [3, 4, 5].map(var);
    let p = [0, 1, 2].map(|k| [0, 1, 2].map(|i| var(6 + 3 * k + i)));
    let m = [0, 1, 2].map(|k| [0, 1, 2].map(|i| var(15 + 3 * k + i)));
    let value = |x: &[O::Z; 3]| x.map(|c| c.value());
    let plain = Patch::new(&p.each_ref().map(value), &m.each_ref().map(value));
    let d = super::patch::unit(&value(&c));
    let z = plain.intersect(value(&x1), d, start).unwrap_or(start);
    let patch = Patch::new(&p, &m);
    let d = super::patch::unit(&c);
    let mut z = z.map(O::Z::cst);
    for _ in 0..2 {
        z = patch.newton_step(&x1, &d, z);
    }
    z[2]
}

/// `g_N` on the plane of a flat facet, in closed form: the ray meets the
/// plane of normal `ν = (p1 − p0) × (p2 − p0)` at
/// `g_N = |c| (p0 − x1)·ν / (c·ν)`.
fn flat_gap<O: Order>(y: &[f64; NVAR], c: &[O::Y; 3]) -> O::Y {
    let x1 = vector::<O>(y, X1);
    let p = [0, 1, 2].map(|k| vector::<O>(y, P + 3 * k));
    let nu = cross(&sub(&p[1], &p[0]), &sub(&p[2], &p[0]));
    dot(c, c).sqrt() * dot(&sub(&p[0], &x1), &nu) * dot(c, &nu).recip()
}

/// `g_N`, `J_s`, `n1` and `g_T` at the kinematic state `y` for the slave
/// point's reference unit normal `n_ref`, the search's patch coordinates and
/// gap `start = (s, t, g_N)` (where the Newton iteration starts), on the
/// curved patch (`curved`, corner normals `m_k` from `y`) or the flat facet
/// (the `m_k` of `y` are not used), to the order `O`.
pub fn local_gap<O: Order>(
    y: &[f64; NVAR],
    n_ref: [f64; 3],
    start: [f64; 3],
    curved: bool,
) -> LocalGap<O> {
    let c = cofactor_block::<O>(y, F, n_ref);
    let mut z: Vec<(usize, O::Block)> = block_vector::<O>(y, X1).to_vec();
    z.extend(c);
    (0..3).for_each(|k| z.extend(block_vector::<O>(y, P + 3 * k)));
    (0..3).for_each(|k| z.extend(block_vector::<O>(y, M + 3 * k)));
    let z: [(usize, O::Block); NZ] = z.try_into().expect("24 inner variables");
    let c_y = c.map(|(at, b)| O::embed(at, &b));
    let gap = if curved {
        let zv = z.each_ref().map(|(_, b)| b.value());
        O::compose(&gap_in_z::<O>(&zv, start), &z)
    } else {
        flat_gap::<O>(y, &c_y)
    };

    let c = c_y;
    let area_ratio = dot(&c, &c).sqrt();
    let inverse_norm = area_ratio.recip();
    let n1 = c.map(|ci| ci * inverse_norm);
    let x1 = vector::<O>(y, X1);
    let anchor = vector::<O>(y, A);
    let d: [O::Y; 3] = [0, 1, 2].map(|i| x1[i] - anchor[i]);
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

    /// A state: a sheared slave point over a tilted, curved master patch.
    fn state() -> [f64; NVAR] {
        let mut y = [0.0; NVAR];
        y[..3].copy_from_slice(&[0.1, -0.05, 0.02]);
        let f = [[1.1, 0.05, -0.02], [0.03, 0.95, 0.04], [0.01, -0.06, 1.02]];
        for i in 0..3 {
            y[F + 3 * i..F + 3 * i + 3].copy_from_slice(&f[i]);
        }
        let p = [[-0.5, -0.4, -0.1], [0.6, -0.3, -0.05], [0.0, 0.7, -0.2]];
        let m = [[0.2, -0.1, 1.0], [-0.25, 0.05, 1.1], [0.0, 0.3, 0.9]];
        for k in 0..3 {
            y[P + 3 * k..P + 3 * k + 3].copy_from_slice(&p[k]);
            y[M + 3 * k..M + 3 * k + 3].copy_from_slice(&m[k]);
        }
        y[A..A + 3].copy_from_slice(&[0.13, -0.01, -0.04]);
        y
    }

    #[test]
    fn first_order_gives_the_second_orders_values_and_gradients_to_the_bit() {
        let y = state();
        let start = [1.0 / 3.0, 1.0 / 3.0, 0.0];
        for curved in [false, true] {
            let full = local_gap::<Second>(&y, [0.0, 0.0, -1.0], start, curved);
            let first = local_gap::<First>(&y, [0.0, 0.0, -1.0], start, curved);
            let pairs = [
                (&full.gap, &first.gap),
                (&full.area_ratio, &first.area_ratio),
            ]
            .into_iter()
            .chain(full.normal.iter().zip(&first.normal))
            .chain(full.slip.iter().zip(&first.slip));
            for (a, b) in pairs {
                assert_eq!((a.v, a.g), (b.v, b.g), "curved {curved}");
                assert!(a.h.iter().flatten().any(|&h| h != 0.0), "curved {curved}");
            }
        }
    }

    #[test]
    fn the_gap_is_the_ray_distance_to_the_patch_and_its_hessian_matches_differences() {
        let n_ref = [0.0, 0.0, -1.0];
        let y = state();
        let start = [1.0 / 3.0, 1.0 / 3.0, 0.0];
        let lg = local_gap::<Second>(&y, n_ref, start, true);
        // Independent value: x1 + g n1 lies on the current patch.
        let fm = [0, 1, 2].map(|i| [0, 1, 2].map(|j| y[F + 3 * i + j]));
        let n1 = crate::contact::current_normal(&fm, n_ref);
        let p = [0, 1, 2].map(|k| [0, 1, 2].map(|i| y[P + 3 * k + i]));
        let m = [0, 1, 2].map(|k| [0, 1, 2].map(|i| y[M + 3 * k + i]));
        let patch = Patch::new(&p, &m);
        let x1 = [y[0], y[1], y[2]];
        let z = patch.intersect(x1, n1, start).unwrap();
        assert!((z[2] - lg.gap.v).abs() < 1e-14, "{} vs {}", z[2], lg.gap.v);
        assert!((0.0..1.0).contains(&z[0]) && (0.0..1.0 - z[0]).contains(&z[1]));
        assert!((lg.area_ratio.v - crate::contact::area_ratio(&fm, n_ref)).abs() < 1e-14);
        // The slip is tangential.
        let along: f64 = (0..3).map(|i| lg.slip[i].v * n1[i]).sum();
        assert!(along.abs() < 1e-15, "{along}");
        // The corner normals matter: the patch is curved.
        assert!((M..NVAR).any(|a| lg.gap.g[a].abs() > 1e-3));
        // Gradient and Hessian columns against central differences.
        let eps = 1e-6;
        for b in 0..NVAR {
            let (mut yp, mut ym) = (y, y);
            yp[b] += eps;
            ym[b] -= eps;
            let (gp, gm) = (
                local_gap::<Second>(&yp, n_ref, start, true).gap,
                local_gap::<Second>(&ym, n_ref, start, true).gap,
            );
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
            let (sp, sm) = (
                local_gap::<Second>(&yp, n_ref, start, true).slip,
                local_gap::<Second>(&ym, n_ref, start, true).slip,
            );
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
