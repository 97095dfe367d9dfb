//! The traction law of one slave point and its contribution to the residual
//! and tangent in the kinematic variables `y` of [`super::enforce_gap`].
//!
//! **Normal** (stabilised augmented Lagrangian):
//! `λ_N = min(0, T̂_N + κ g_N)`; the point is active when `λ_N < 0`.
//!
//! **Coulomb friction** (coefficient `μ`, only on active points with an
//! anchor): the trial tangential traction is the last converged one, turned
//! into the current tangent plane, plus the elastic increment,
//! `t_trial = (I − n1 ⊗ n1) t_old + κ g_T`. Stick when
//! `|t_trial| ≤ μ |λ_N|`: `t_T = t_trial`; slip otherwise (return map onto
//! the Coulomb cone): `t_T = μ |λ_N| t_trial / |t_trial|`. The tangential
//! penalty is the normal one, `κ = k E / h`.
//!
//! **Contribution.** With the work-conjugate pairs `(λ_N, g_N)` and
//! `(t_T,i, g_T,i)`, on the current surface:
//! `R_y = w J_s Σ_pairs t ∇g` and, differentiating every factor
//! (the branch of the return map is fixed, everything else varies),
//! `K_y = w Σ_pairs [t ∇g ⊗ ∇J_s + J_s ∇g ⊗ ∇t + J_s t ∇²g]`
//! (row index first). `∇t` comes from the forward-mode numbers: `t` is
//! computed from `g_N`, `n1` and `g_T` as a [`HyperDual`]
//! (`super::enforce_dual`). The residual needs gradients only: the law is
//! generic over the [`Order`] of its numbers.

use super::enforce_gap::{LocalGap, Order, Second, NVAR};
use super::patch::Real;

/// What the law needs besides the kinematics.
#[derive(Clone, Copy, Debug)]
pub struct LawInput {
    /// `T̂_N`.
    pub recovered: f64,
    /// `κ`.
    pub kappa: f64,
    /// `μ` (0: frictionless).
    pub friction: f64,
    /// `t_old` when the point has an anchor.
    pub previous_tangential: Option<[f64; 3]>,
}

/// The tractions of an active point.
#[derive(Clone, Debug)]
pub struct Tractions<O: Order> {
    /// `λ_N < 0`.
    pub normal: O::Y,
    /// `t_T` and whether it slips, when friction applies.
    pub tangential: Option<([O::Y; 3], bool)>,
}

/// The tractions at the kinematic state `lg`, or `None` when the point is
/// not active.
pub fn tractions<O: Order>(lg: &LocalGap<O>, input: &LawInput) -> Option<Tractions<O>> {
    let trial = lg.gap.scale(input.kappa) + O::Y::cst(input.recovered);
    if trial.value() >= 0.0 {
        return None;
    }
    let tangential = input
        .previous_tangential
        .filter(|_| input.friction > 0.0)
        .map(|old| friction_traction(lg, &trial, old, input));
    Some(Tractions {
        normal: trial,
        tangential,
    })
}

/// The return map of `t_trial` onto `|t_T| ≤ μ |λ_N|`.
fn friction_traction<O: Order>(
    lg: &LocalGap<O>,
    lambda: &O::Y,
    old: [f64; 3],
    input: &LawInput,
) -> ([O::Y; 3], bool) {
    let n1 = &lg.normal;
    let along = n1[0].scale(old[0]) + n1[1].scale(old[1]) + n1[2].scale(old[2]);
    let trial: [O::Y; 3] =
        [0, 1, 2].map(|i| O::Y::cst(old[i]) - n1[i] * along + lg.slip[i].scale(input.kappa));
    let size2 = trial[0] * trial[0] + trial[1] * trial[1] + trial[2] * trial[2];
    let bound = -input.friction * lambda.value();
    if size2.value().sqrt() <= bound {
        return (trial, false);
    }
    let factor = lambda.scale(-input.friction) * size2.sqrt().recip();
    (trial.map(|t| t * factor), true)
}

/// The conjugate pairs `(t, g)` of the tractions.
fn pairs<'a, O: Order>(lg: &'a LocalGap<O>, tr: &'a Tractions<O>) -> Vec<(&'a O::Y, &'a O::Y)> {
    let mut out = vec![(&tr.normal, &lg.gap)];
    if let Some((t, _)) = &tr.tangential {
        out.extend(t.iter().zip(&lg.slip));
    }
    out
}

/// `R_y = w J_s Σ t ∇g`.
pub fn residual_in_y<O: Order>(lg: &LocalGap<O>, tr: &Tractions<O>, w: f64) -> [f64; NVAR] {
    let mut r = [0.0; NVAR];
    for (t, g) in pairs(lg, tr) {
        let s = w * lg.area_ratio.value() * t.value();
        let g = O::gradient(g);
        (0..NVAR).for_each(|a| r[a] += s * g[a]);
    }
    r
}

/// `K_y = w Σ [t ∇g ⊗ ∇J_s + J_s ∇g ⊗ ∇t + J_s t ∇²g]`.
pub fn tangent_in_y(lg: &LocalGap<Second>, tr: &Tractions<Second>, w: f64) -> Vec<[f64; NVAR]> {
    let j = &lg.area_ratio;
    let mut k = vec![[0.0; NVAR]; NVAR];
    for (t, g) in pairs(lg, tr) {
        for (a, row) in k.iter_mut().enumerate() {
            for (b, kab) in row.iter_mut().enumerate() {
                *kab += w * (t.v * g.g[a] * j.g[b] + j.v * g.g[a] * t.g[b] + j.v * t.v * g.h[a][b]);
            }
        }
    }
    k
}
