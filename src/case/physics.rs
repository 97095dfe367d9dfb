//! The physics tables of a case file: exact field, body load, stabilisation
//! and solver settings, and the load steps and Newton settings of the Newton
//! path (the body's own tables are in [`super::body`], the boundary
//! conditions in [`super::boundary`]).
//!
//! ```toml
//! [material]             # super::body: model, E and ν
//! young = 1000.0
//! poisson = 0.3
//!
//! [exact]                 # optional: exact displacement, gives b, g and errors
//! displacement = ["x + x^2", "-y", "0"]
//!
//! [body_load]             # optional: default from the exact field, else zero
//! value = ["0", "0", "-9.81"]
//!
//! [dirichlet.surface]     # per boundary tag (see [`super::boundary`])
//! value = "exact"
//!
//! [neumann.top]
//! traction = ["0", "0", "-1"]
//!
//! [stabilisation]          # defaults: the paper's stabilised method
//! k1 = 30.0               # Dirichlet penalty β = k1 E
//! k2 = 0.01               # S-term weight (0: off, the paper's runs without it)
//! A = 0.05                # pathological volume fraction threshold (default 0.05 for Q1, 0.2 for Q2)
//! balanced = true         # S-term without net force or moment (false: the paper's F_S)
//!
//! [solver]
//! method = "cg"             # cg | cgs | bicgstab
//! preconditioner = "auto"   # auto (multigrid; jacobi on an f32-only GPU) | multigrid | jacobi | none
//! outer = "fgmres"          # fgmres | picard (the paper's fixed point)
//! inner_rel_tol = 1e-2      # fgmres: tolerance of each inner solve with A (default 1e-2
//!                           # with multigrid, 1e-3 with jacobi or none)
//! rel_tol = 1e-8            # picard: Krylov tolerance of the first solve (τ0)
//! min_rel_tol = 1e-12       # picard: floor of the adaptive Krylov tolerance (τ_min)
//! max_iterations = 20000    # per Krylov solve
//! fixed_point_tol = 1e-10   # fgmres: ‖F + R(U) − A U‖ ≤ this ‖F + R(0)‖ (default 1e-10);
//!                           # picard: ‖U_k+1 − U_k‖ < this ‖U_k+1‖ (default 1e-8)
//! max_fixed_point = 200     # outer iterations
//! ```
//! On the Newton path (`super::SolutionPath`) `[solver]` sets the Krylov
//! solves inside Newton: `method` (default `"bicgstab"`: the tangent with
//! contact is not symmetric), `preconditioner` (`auto` is multigrid),
//! `rel_tol` and `max_iterations`; the recovered terms' fixed point is set in
//! `[newton]`:
//!
//! ```toml
//! [load]
//! steps = 5                    # step k of N is load factor t = k/N; a prescribed value grows
//!                              # with t (linearly, or along its `ramp`: super::boundary)
//!
//! [newton]
//! max_iterations = 25          # per load step
//! rel_tol = 1e-8               # ‖R‖ / ‖R_0‖ of the step
//! energy_tol = 1e-16           # |Δu · R| / |Δu_0 · R_0| of the step
//! line_search = true           # backtracking on ‖R‖
//! max_cuts = 5                 # a failed step is halved at most this many times
//! fixed_point_tol = 1e-6       # recovered terms (T̂_N, S): ‖u_k − u_{k−1}‖/‖u_k‖ between passes
//! max_fixed_point = 30         # Newton passes per step with recovered terms
//! recovery = "passes"          # or "embedded" (after every Newton update), "step" (once per step)
//! forcing = "adaptive"         # Krylov tolerance ‖R_k‖/‖R_0‖ in [solver.rel_tol, 1e-4]; "fixed": solver.rel_tol
//! ```
//! Boundary parts named in neither table are traction free.

use std::fmt;

use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::Deserialize;

use crate::element::ElementOrder;
use crate::expr::VectorExpr;
use crate::solver::{KrylovMethod, Preconditioner};

/// `[exact]`: an exact displacement field.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ExactSpec {
    pub displacement: VectorExpr,
}

/// `[body_load]`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BodyLoadSpec {
    pub value: FieldValue,
}

/// A vector field given as three expressions, or `"exact"`: derived from the
/// exact displacement (its value, its traction σ(u)n or its body load −∇·σ).
#[derive(Clone, Debug, PartialEq)]
pub enum FieldValue {
    Exact,
    Given(VectorExpr),
}

impl<'de> Deserialize<'de> for FieldValue {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = FieldValue;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("\"exact\" or an array of three expressions")
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<FieldValue, E> {
                if s == "exact" {
                    Ok(FieldValue::Exact)
                } else {
                    Err(E::custom(format!(
                        "expected \"exact\" or an array of three expressions, got \"{s}\""
                    )))
                }
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<FieldValue, A::Error> {
                let v = VectorExpr::deserialize(de::value::SeqAccessDeserializer::new(seq))?;
                Ok(FieldValue::Given(v))
            }
        }
        d.deserialize_any(V)
    }
}

/// `[stabilisation]`. By default the paper's stabilised method: the S-term
/// on with [`DEFAULT_K2`] (the paper's 0.01) and the pathological threshold
/// `A` of the element order, [`default_threshold`]. `k2 = 0` switches the
/// S-term off (the paper's runs without it).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct StabilisationSpec {
    /// Dirichlet penalty factor: β = k1 E (dimensionless).
    pub k1: f64,
    /// Weight of the S-term, `k2 E / h²` (0 switches it off).
    pub k2: f64,
    /// Volume fraction under which a cut cell is pathological; `None`: the
    /// element order's [`default_threshold`] ([`StabilisationSpec::threshold`]).
    #[serde(rename = "A")]
    pub a: Option<f64>,
    /// Whether the S-term's right-hand side drops the rigid-body part of
    /// `u_h − S` on Ω*, so that it puts no net force or moment on the body
    /// (`crate::fem::rigid_resultant`). `false`: the paper's `F_S`; `None`:
    /// `true` ([`StabilisationSpec::balanced`]). Linear path only.
    pub balanced: Option<bool>,
}

/// The default S-term weight `k2`: the paper's 0.01.
pub const DEFAULT_K2: f64 = 0.01;

/// The default pathological threshold `A` of an element order, chosen by
/// measurement on the paper's sphere (`cases/sphere.toml`,
/// `cases/sphere_q2.toml` with `k2 = 0.01`; relative energy error, Krylov
/// iterations accumulated over the fixed point):
///
/// - Q1: 5% (the paper's larger value). At level 4, plain CGS (the default
///   solver) needs 11 812 iterations with A = 1%, 4 272 with 5% and 4 774
///   with 20%; CGS with Jacobi 159, 183, 180; the energy error is 7.158e-2
///   for all three (to 1e-4 relative). At level 3 no cell is below 1%.
/// - Q2: 20%. Q2 cut cells are ill-conditioned up to much larger fractions:
///   at level 3 CG with Jacobi needs 11 273 iterations with A = 1%, 4 692
///   with 5% and 2 135 with 20% (κ 9.8e11, 1.5e8, 6.2e5), for energy errors
///   7.736e-3, 7.736e-3, 7.742e-3; at level 4, 8 261 with 5% and 2 699 with
///   20%, energy errors 1.9941e-3 and 1.9931e-3.
pub fn default_threshold(order: ElementOrder) -> f64 {
    match order {
        ElementOrder::Q1 => 0.05,
        ElementOrder::Q2 => 0.2,
    }
}

impl StabilisationSpec {
    /// Whether the S-term is balanced (default `true`).
    pub fn balanced(&self) -> bool {
        self.balanced.unwrap_or(true)
    }

    /// `A` as given, else the default of the element `order`.
    pub fn threshold(&self, order: ElementOrder) -> f64 {
        self.a.unwrap_or_else(|| default_threshold(order))
    }
}

impl Default for StabilisationSpec {
    fn default() -> Self {
        StabilisationSpec {
            k1: 30.0,
            k2: DEFAULT_K2,
            a: None,
            balanced: None,
        }
    }
}

/// The outer iteration on the recovered terms `R(U)` of `A U = F + R(U)`.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum OuterMethod {
    /// Flexible GMRES on `(A − R) U = F`, preconditioned by inner solves
    /// with `A` ([`crate::driver::outer_krylov`]).
    #[default]
    Fgmres,
    /// The paper's fixed point: `A U_{k+1} = F + R(U_k)` ([`crate::driver::fixed_point`]).
    Picard,
}

impl OuterMethod {
    /// The name used in case files and reports.
    pub fn name(self) -> &'static str {
        match self {
            OuterMethod::Fgmres => "fgmres",
            OuterMethod::Picard => "picard",
        }
    }
}

/// `[solver]`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct SolverSpec {
    pub method: KrylovMethod,
    pub preconditioner: Preconditioner,
    /// How the recovered terms are solved for.
    pub outer: OuterMethod,
    /// `fgmres`: relative tolerance of each inner solve with `A`; `None`:
    /// [`SolverSpec::inner_rel_tol`]'s default for the preconditioner.
    pub inner_rel_tol: Option<f64>,
    pub rel_tol: f64,
    pub min_rel_tol: f64,
    pub max_iterations: usize,
    /// When the outer iteration stops; `None`: [`SolverSpec::fixed_point_tol`]'s
    /// default for the method.
    pub fixed_point_tol: Option<f64>,
    /// Outer iterations at most (default 200: a rotated level-6 bracket at
    /// half scale needs 95, `crate::fem::rigid_resultant`).
    pub max_fixed_point: usize,
}

impl SolverSpec {
    /// The outer tolerance: as given, else 1e-10 on the residual (fgmres) or
    /// 1e-8 on the change of `U` (picard, the paper's). The residual needs the
    /// tighter value for the same answer: at 1e-8 the Q2 sphere's energy error
    /// differed from the paper loop's by 3e-8 relative, at 1e-10 by 2e-10.
    pub fn fixed_point_tol(&self) -> f64 {
        self.fixed_point_tol.unwrap_or(match self.outer {
            OuterMethod::Fgmres => 1e-10,
            OuterMethod::Picard => 1e-8,
        })
    }

    /// The inner solves' tolerance: as given, else 1e-2 with the multigrid
    /// preconditioner (`auto` included) and 1e-3 with Jacobi or none. An
    /// outer iteration costs a recovery, an inner iteration a V-cycle or a
    /// Jacobi-CG step: with multigrid, 1e-2 gave every case the same outer
    /// iterations as 1e-3 (the Q2 sphere at level 5 one more) with a fifth to
    /// a half fewer V-cycles; with Jacobi, 1e-3 the fewest recoveries
    /// (docs/outer-iteration.md, *The inner tolerance*).
    pub fn inner_rel_tol(&self) -> f64 {
        self.inner_rel_tol.unwrap_or(match self.preconditioner {
            Preconditioner::Multigrid | Preconditioner::Auto => 1e-2,
            Preconditioner::Jacobi | Preconditioner::None => 1e-3,
        })
    }
}

impl Default for SolverSpec {
    fn default() -> Self {
        SolverSpec {
            method: KrylovMethod::Cg,
            preconditioner: Preconditioner::Auto,
            outer: OuterMethod::Fgmres,
            inner_rel_tol: None,
            rel_tol: 1e-8,
            min_rel_tol: 1e-12,
            max_iterations: 20_000,
            fixed_point_tol: None,
            max_fixed_point: 200,
        }
    }
}

/// `[load]`: load stepping.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct LoadSpec {
    /// Load steps; step k of N is load factor `k/N`, where every prescribed
    /// value is at its ramp's factor (`t` itself by default).
    pub steps: usize,
}

impl Default for LoadSpec {
    fn default() -> Self {
        LoadSpec { steps: 1 }
    }
}

/// `[newton]`: the Newton–Raphson iterations of each load step.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct NewtonSpec {
    pub max_iterations: usize,
    /// Converged when ‖R‖ ≤ rel_tol ‖R_0‖ ...
    pub rel_tol: f64,
    /// ... and |Δu·R| ≤ energy_tol |Δu_0·R_0| (the energy norm of the increment).
    pub energy_tol: f64,
    pub line_search: bool,
    /// Halvings of a failed step before the run stops (exit code 3).
    pub max_cuts: usize,
    /// With recovered terms: passes end when ‖u_k − u_{k−1}‖ ≤ fixed_point_tol ‖u_k‖.
    pub fixed_point_tol: f64,
    /// With recovered terms: Newton passes allowed per step.
    pub max_fixed_point: usize,
    /// With recovered terms: `"passes"` (between Newton solves),
    /// `"embedded"` (after every Newton update) or `"step"` (once per step).
    pub recovery: RecoveryMode,
    /// How tightly each Newton iteration's linear solve is converged.
    pub forcing: Forcing,
}

impl Default for NewtonSpec {
    fn default() -> Self {
        NewtonSpec {
            max_iterations: 25,
            rel_tol: 1e-8,
            energy_tol: 1e-16,
            line_search: true,
            max_cuts: 5,
            fixed_point_tol: 1e-6,
            max_fixed_point: 30,
            recovery: RecoveryMode::Passes,
            forcing: Forcing::Adaptive,
        }
    }
}

/// How tightly the linear solve of a Newton iteration is converged
/// (`crate::hyper::newton`'s module doc, *Inexact solves*).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Forcing {
    /// The Krylov tolerance follows the residual, `η_k = ‖R_k‖/‖R_0‖`
    /// between `solver.rel_tol` and 1e-4 (1e-2 first where the residual
    /// already passes `newton.rel_tol` and the solve may only check the
    /// energy). Newton stays quadratic; the first iterations of a step cost
    /// fewer Krylov iterations than a full solve.
    #[default]
    Adaptive,
    /// Every linear solve to `solver.rel_tol`.
    Fixed,
}

/// When the recovered terms are re-evaluated (`crate::hyper::newton`'s module doc, *Recovered terms*).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RecoveryMode {
    /// Between whole Newton solves (passes): each pass converges
    /// quadratically; the passes repeat until `u` settles.
    #[default]
    Passes,
    /// After every Newton update, inside one Newton loop (the paper's fixed
    /// point embedded in the solver): fewer linear solves, but the lagged
    /// terms make the last iterations linear.
    Embedded,
    /// Once per step attempt, at the last converged `u`, and held for the
    /// whole step (the terms lag one load step; no extra Newton work).
    Step,
}
