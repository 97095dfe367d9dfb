//! The total Lagrangian residual of one body at load factor `t`:
//! ```text
//! R(u) = Σ_cells Σ_q w_q Bᵀ P(F_q)  +  Σ_p w_p (β/h) Nᵀ M (N u − g(t))  −  f_ext(t)
//! F_q  = I + Σ_a u_a ⊗ ∇_X N_a(X_q)        (Bᵀ P)_{a i} = P_iJ ∂N_a/∂X_J
//! ```
//! with `M = diag(m)` the component mask of the Dirichlet part, `g(t)` and
//! `f_ext(t)` the prescribed values and loads along their ramps (`t g` and
//! `t f_ext` by default; [`super::problem::Ramp`]), plus the
//! S-term `R_S` of [`super::stabilisation`] when the problem has one, and the
//! total potential energy whose gradient it is:
//! ```text
//! Π(u) = Σ_q w_q W(F_q) + Σ_p w_p (β/h)/2 |M (N u − g(t))|² − f_ext(t) · u  (+ Π_S).
//! ```
//! Each cell's vector is computed in parallel, then scattered. A point with
//! `det F ≤ 0` has no energy: the residual is then `None` (the Newton line
//! search backs off from such a state).

use nalgebra::Matrix3;
use rayon::prelude::*;

use super::material::PointState;
use super::problem::{CellBuffer, HyperProblem, PenaltyPoint, QuadPoint, MAX_NODES};

/// `Σ_a v_a ⊗ ∇N_a`, the gradient of the cell's field `v` (one row per
/// node) at a point.
#[inline(always)]
pub fn field_gradient(ve: &[[f64; 3]], q: &QuadPoint) -> Matrix3<f64> {
    let mut g = Matrix3::zeros();
    for (v, grad) in ve.iter().zip(q.grads) {
        for i in 0..3 {
            for j in 0..3 {
                g[(i, j)] += v[i] * grad[j];
            }
        }
    }
    g
}

/// `F = I + ∇u` at a point.
pub fn deformation_gradient(ue: &[[f64; 3]], q: &QuadPoint) -> Matrix3<f64> {
    Matrix3::identity() + field_gradient(ue, q)
}

/// `out_a += w P ∇N_a` (the point's `w Bᵀ P`).
#[inline(always)]
pub fn add_bt_stress(p: &Matrix3<f64>, q: &QuadPoint, out: &mut [[f64; 3]]) {
    for (o, grad) in out.iter_mut().zip(q.grads) {
        for i in 0..3 {
            let mut s = 0.0;
            for j in 0..3 {
                s += p[(i, j)] * grad[j];
            }
            o[i] += q.w * s;
        }
    }
}

/// `out_a += w N_a M (Σ_b N_b v_b − shift)` for each penalty point (with its
/// shape values); `shift` is the prescribed value at load factor `t` for the
/// residual and 0 (at `t = 0`) for the tangent.
pub fn add_penalty<'a>(
    points: impl Iterator<Item = (&'a PenaltyPoint, &'a [f64])>,
    ve: &[[f64; 3]],
    t: f64,
    out: &mut [[f64; 3]],
) {
    for (pp, n) in points {
        let target = pp.target(t);
        let mut jump = [0.0; 3];
        for i in 0..3 {
            let s: f64 = n.iter().zip(ve).map(|(n, v)| n * v[i]).sum();
            jump[i] = pp.mask[i] * (s - target[i]);
        }
        for (o, n) in out.iter_mut().zip(n) {
            for i in 0..3 {
                o[i] += pp.weight * n * jump[i];
            }
        }
    }
}

/// The `k`-th cell's internal force plus penalty force (plus its S-term
/// force, with the S-term's current `targets`) into `out` (zeroed), `None`
/// if some `det F ≤ 0`.
fn cell_residual(
    p: &HyperProblem,
    k: usize,
    u: &[f64],
    t: f64,
    targets: Option<&[[f64; 3]]>,
    out: &mut [[f64; 3]],
) -> Option<()> {
    let mut buffer: CellBuffer = [[0.0; 3]; MAX_NODES];
    let ue = p.gather(k, u, &mut buffer);
    for q in p.points(k) {
        let s = PointState::new(deformation_gradient(ue, &q))?;
        add_bt_stress(&p.material.stress(&s), &q, out);
    }
    add_penalty(p.penalty_points(k), ue, t, out);
    if let (Some(s), Some(targets)) = (&p.s_term, targets) {
        s.add_cell_residual(k, ue, targets, out);
    }
    Some(())
}

/// `R(u)` at load factor `t`, or `None` where some point has `det F ≤ 0`.
pub fn residual(p: &HyperProblem, u: &[f64], t: f64) -> Option<Vec<f64>> {
    let targets = p.s_term.as_ref().map(|s| s.targets());
    let targets = targets.as_deref().map(Vec::as_slice);
    let cell_vectors = p.try_cell_vectors(|k, out| cell_residual(p, k, u, t, targets, out))?;
    let mut r = p.external_at(t);
    r.iter_mut().for_each(|f| *f = -*f);
    p.scatter(&cell_vectors, &mut r);
    Some(r)
}

/// `Π(u)` at load factor `t`, or `None` where some point has `det F ≤ 0`.
pub fn energy(p: &HyperProblem, u: &[f64], t: f64) -> Option<f64> {
    let targets = p.s_term.as_ref().map(|s| s.targets());
    let cells: Option<Vec<f64>> = (0..p.cells.len())
        .into_par_iter()
        .map(|k| {
            let mut buffer: CellBuffer = [[0.0; 3]; MAX_NODES];
            let ue = p.gather(k, u, &mut buffer);
            let mut e = 0.0;
            for q in p.points(k) {
                let s = PointState::new(deformation_gradient(ue, &q))?;
                e += q.w * p.material.energy(&s);
            }
            for (pp, n) in p.penalty_points(k) {
                let target = pp.target(t);
                for i in 0..3 {
                    let s: f64 = n.iter().zip(ue).map(|(n, v)| n * v[i]).sum();
                    let jump = pp.mask[i] * (s - target[i]);
                    e += 0.5 * pp.weight * jump * jump;
                }
            }
            if let (Some(s), Some(targets)) = (&p.s_term, &targets) {
                e += s.cell_energy(k, ue, targets);
            }
            Some(e)
        })
        .collect();
    let load: f64 = p.external_at(t).iter().zip(u).map(|(f, x)| f * x).sum();
    Some(cells?.iter().sum::<f64>() - load)
}

/// `(F, P)` at a volume point.
pub type PointFields = (Matrix3<f64>, Matrix3<f64>);

/// The deformation gradient and first Piola–Kirchhoff stress at every volume
/// point, per entry of [`HyperProblem::cells`] (for checks and output), or
/// `None` if some `det F ≤ 0`.
pub fn point_fields(p: &HyperProblem, u: &[f64]) -> Option<Vec<Vec<PointFields>>> {
    (0..p.cells.len())
        .into_par_iter()
        .map(|k| {
            let mut buffer: CellBuffer = [[0.0; 3]; MAX_NODES];
            let ue = p.gather(k, u, &mut buffer);
            p.points(k)
                .map(|q| {
                    let s = PointState::new(deformation_gradient(ue, &q))?;
                    Some((s.f, p.material.stress(&s)))
                })
                .collect()
        })
        .collect()
}
