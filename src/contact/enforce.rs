//! Contact enforcement: the contact residual and its
//! exact tangent for one slave/master pair, by the stabilised augmented
//! Lagrangian, frictionless or with Coulomb friction.
//!
//! **Unknowns.** The two bodies' nodal displacements form one vector
//! `u = […, u_s, …, u_m, …]`: each body's [`DofMap`] layout
//! (`3 · active + component`) starting at its [`ContactBody::offset`].
//!
//! **Slave points** are the slave body's cut-cell boundary quadrature points
//! with the pair's slave tag ([`slave_points`]): reference position `X`,
//! reference unit outward normal `N`, weight `w = dΓ_0`.
//!
//! **Kinematics** (module `enforce_gap`). `x1 = X + u_s(X)`, current
//! normal `n1` by Nanson, area ratio `J_s = |cof(F) N|`; the ray search on
//! the current master surface (built from `u_m` at every call) gives the
//! master patch (a flat facet or, with [`ContactPairData::curved`], a PN
//! triangle on the current vertex normals, see `patch`), whose current
//! corners `p_k = X_k + u_m(X_k)` are evaluated with the shape functions of
//! the triangle's master cell; then `g_N` is the ray parameter of the hit on
//! the patch, exactly the search's `(x2 − x1)·n1` (in closed form on a
//! facet, through the ray–patch equations on a curved patch). Each point
//! keeps to the patch of its [`PointHistory::patch`] while the ray stays
//! near it.
//! A hit whose master normal `m` does not oppose `n1` (`n1·m ≥ 0`, e.g. a
//! backward ray from a slave point beside the contact zone reaching the
//! master's surface under it, or the master's far side) is no contact.
//!
//! **Multiplier.** `λ_N = min(0, T̂_N + κ g_N)` with `T̂_N` the given
//! recovered normal traction of the point (held fixed in the linearisation;
//! `T̂_N = 0` is the pure penalty method) and `κ = k E / h`: the penalty
//! factor `k` (dimensionless, as the Nitsche `k1`) times the slave's Young's
//! modulus over the slave grid's cell size. The scaling makes `κ g_N` a
//! stress of order `E (g_N/h)`, so the same `k` serves every material and
//! level, and the penetration at a given pressure `p` is `p h /(k E)`,
//! shrinking with `h`.
//!
//! **Residual** (virtual work on the current surface, `da = J_s dA`):
//! `R_c = Σ_points w J_s λ_N ∇_u g_N`, `λ_N` being the Cauchy normal
//! traction (negative in compression); `−R_c` is the contact force on the
//! dofs, so `R_c` (and `K_c`) add to the bodies' `R = f_int − f_ext`. **Tangent** (exact derivative of `R_c`, non-symmetric through
//! `J_s`), on active points (`T̂_N + κ g_N < 0`):
//! `K_c = Σ w [J_s κ ∇g ⊗ ∇g + J_s λ_N ∇²g + λ_N ∇g ⊗ ∇J_s]`
//! (row index first). Inactive points contribute nothing to either.
//!
//! **Friction** (μ > 0, module `enforce_law`): a point active at the
//! last converged step carries a [`PointHistory`]: the master point it
//! touched (the anchor) and its tangential traction then. The trial
//! traction `(I − n1⊗n1) t_old + κ g_T`, with the slip
//! `g_T = (I − n1⊗n1)(x1 − a)` from the anchor's current position `a`, is
//! returned onto the Coulomb cone `|t_T| ≤ μ |λ_N|`; the conjugate
//! `w J_s t_T · ∇g_T` joins the residual and its exact derivative the
//! tangent (non-symmetric in slip). A point without an anchor (first touch in
//! this step) is frictionless until the step converges.
//! [`Enforcement::converged_history`] gives the next step's histories.

use rayon::prelude::*;

use super::enforce_local::{point_contact, Local};
use super::enforce_tangent::ContactTangent;
use super::report::{ContactPoints, ContactRow, SlaveSample};
use super::search::MasterSurface;
use super::surface::Surface;
use crate::cells::Cells;
use crate::discrete::dofs::DofMap;
use crate::grid::Grid;

/// One body's discretisation and where its dofs start in the global vector.
#[derive(Clone, Copy, Debug)]
pub struct ContactBody<'a> {
    pub grid: &'a Grid,
    pub dofs: &'a DofMap,
    pub offset: usize,
}

/// A slave boundary quadrature point in the reference configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlaveQuadraturePoint {
    pub cell: usize,
    /// `X`.
    pub x: [f64; 3],
    /// Reference unit outward normal `N`.
    pub normal: [f64; 3],
    /// `dΓ_0`.
    pub weight: f64,
}

/// The cut-cell boundary points of `cells` whose tag is `tag`.
pub fn slave_points(cells: &Cells, tag: u16) -> Vec<SlaveQuadraturePoint> {
    (0..cells.cut.len())
        .flat_map(|i| {
            cells
                .surface_points(i)
                .iter()
                .filter(move |p| p.tag == tag)
                .map(move |p| SlaveQuadraturePoint {
                    cell: cells.cut[i],
                    x: p.x,
                    normal: p.n,
                    weight: p.w,
                })
        })
        .collect()
}

/// A contact pair ready for enforcement.
#[derive(Clone, Copy, Debug)]
pub struct ContactPairData<'a> {
    pub slave: ContactBody<'a>,
    pub master: ContactBody<'a>,
    pub slave_points: &'a [SlaveQuadraturePoint],
    /// The master boundary part (reference configuration, on the master grid).
    pub master_surface: &'a Surface,
    /// `k` of `κ = k E / h`.
    pub penalty: f64,
    /// The slave's Young's modulus `E`.
    pub young: f64,
    /// Largest `|g_N|` searched for, in length units.
    pub search_radius: f64,
    /// Coulomb coefficient `μ` (0: frictionless).
    pub friction: f64,
    /// Curved master patches (`true`) or flat facets.
    pub curved: bool,
}

impl ContactPairData<'_> {
    /// `κ = k E / h_slave`.
    pub fn stiffness(&self) -> f64 {
        self.penalty * self.young / self.slave.grid.h
    }
}

/// A point of the master body's reference configuration and its cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MasterPoint {
    pub cell: usize,
    pub x: [f64; 3],
}

/// What a slave point carries between evaluations.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PointHistory {
    /// The recovered normal traction `T̂_N` (0: pure penalty).
    pub recovered: f64,
    /// The master point touched at the last converged step (friction only).
    pub anchor: Option<MasterPoint>,
    /// The tangential traction `t_T` at the last converged step.
    pub tangential: [f64; 3],
    /// The master patch hit at the last Newton iterate (or converged step),
    /// preferred by the search while the ray stays near it
    /// ([`MasterSurface::search_near`]; updated by the caller with each
    /// tangent, [`Enforcement::points`]' hits).
    pub patch: Option<usize>,
}

impl PointHistory {
    /// No anchor, no tangential traction, `T̂_N = recovered`.
    pub fn fresh(recovered: f64) -> PointHistory {
        PointHistory {
            recovered,
            ..PointHistory::default()
        }
    }
}

/// The state of one slave point after enforcement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointState {
    /// Current position `x1`.
    pub x: [f64; 3],
    /// Current unit normal `n1`.
    pub normal: [f64; 3],
    /// Current weight `w J_s`.
    pub weight: f64,
    /// The master triangle hit and `g_N`, when the search found a contact.
    pub hit: Option<(usize, f64)>,
    /// The master point hit (the next anchor), when there is a hit.
    pub master_point: Option<MasterPoint>,
    /// `−λ_N ≥ 0` (compression positive).
    pub pressure: f64,
    /// `t_T` (zero without friction).
    pub tangential: [f64; 3],
    /// Whether friction applies, and if so whether `t_T` lies inside the
    /// Coulomb cone (stick) or on it (slip).
    pub friction: FrictionState,
}

/// The Coulomb state of a slave point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrictionState {
    /// No tangential traction: inactive, frictionless, or touching for the
    /// first time (no anchor yet).
    Off,
    /// `|t_trial| ≤ μ |λ_N|`.
    Stick,
    /// On the cone.
    Slip,
}

impl FrictionState {
    /// The ParaView code: 0 off, 1 stick, 2 slip.
    pub fn code(self) -> f64 {
        match self {
            FrictionState::Off => 0.0,
            FrictionState::Stick => 1.0,
            FrictionState::Slip => 2.0,
        }
    }
}

/// The contact residual, optionally its tangent, and the points' states.
#[derive(Clone, Debug)]
pub struct Enforcement {
    /// `R_c`, as long as the global vector.
    pub residual: Vec<f64>,
    /// `K_c`, factored per point (apply it, take its diagonal or assemble
    /// it); empty when only the residual was asked for.
    pub tangent: ContactTangent,
    /// One per slave point, in the order of [`ContactPairData::slave_points`].
    pub points: Vec<PointState>,
}

impl Enforcement {
    /// The report row of pair `pair` at load step `step`: samples are the
    /// points with a hit (current weight `w J_s`, gap, pressure).
    pub fn contact_row(&self, pair: &str, step: usize) -> ContactRow {
        let samples: Vec<SlaveSample> = self
            .points
            .iter()
            .filter_map(|p| {
                p.hit.map(|(_, gap)| SlaveSample {
                    weight: p.weight,
                    gap,
                    pressure: p.pressure,
                    sticking: p.friction == FrictionState::Stick,
                })
            })
            .collect();
        ContactRow::from_samples(pair, step, &samples)
    }

    /// The points of pair `pair` for the ParaView output, with the
    /// recovered `T̂_N` of each point in `history`.
    pub fn contact_points(&self, pair: &str, history: &[PointHistory]) -> ContactPoints {
        ContactPoints {
            pair: pair.to_string(),
            x: self.points.iter().map(|p| p.x).collect(),
            normal: self.points.iter().map(|p| p.normal).collect(),
            gap: self
                .points
                .iter()
                .map(|p| p.hit.map_or(f64::NAN, |(_, g)| g))
                .collect(),
            pressure: self.points.iter().map(|p| p.pressure).collect(),
            recovered_pressure: history.iter().map(|h| -h.recovered).collect(),
            friction: self.points.iter().map(|p| p.friction.code()).collect(),
        }
    }

    /// The histories for the next step once this state has converged:
    /// active points are anchored at their master point with their
    /// tangential traction, every point with a hit keeps its patch;
    /// `recovered` gives the next `T̂_N` per point.
    pub fn converged_history(&self, recovered: &[f64]) -> Vec<PointHistory> {
        assert_eq!(recovered.len(), self.points.len(), "one T̂_N per point");
        self.points
            .iter()
            .zip(recovered)
            .map(|(p, &r)| {
                let patch = p.hit.map(|(t, _)| t);
                match p.master_point.filter(|_| p.pressure > 0.0) {
                    Some(anchor) => PointHistory {
                        recovered: r,
                        anchor: Some(anchor),
                        tangential: p.tangential,
                        patch,
                    },
                    None => PointHistory {
                        patch,
                        ..PointHistory::fresh(r)
                    },
                }
            })
            .collect()
    }
}

/// `R_c` at the global displacement `u` with the points' histories (one
/// per slave point).
pub fn contact_residual(
    pair: &ContactPairData,
    u: &[f64],
    history: &[PointHistory],
) -> Enforcement {
    enforce(pair, u, history, false)
}

/// `R_c` and `K_c` at `u` (see [`contact_residual`]).
pub fn contact_residual_and_tangent(
    pair: &ContactPairData,
    u: &[f64],
    history: &[PointHistory],
) -> Enforcement {
    enforce(pair, u, history, true)
}

fn enforce(
    pair: &ContactPairData,
    u: &[f64],
    history: &[PointHistory],
    tangent: bool,
) -> Enforcement {
    assert_eq!(
        history.len(),
        pair.slave_points.len(),
        "one history per point"
    );
    let (master, m) = (pair.master, pair.master_surface);
    let um = &u[master.offset..master.offset + master.dofs.ndofs()];
    let current = m.deformed_by_field(master.grid, master.dofs, um);
    let surface = MasterSurface::new(m, current, pair.curved);
    let results: Vec<(PointState, Option<Local>)> = pair
        .slave_points
        .par_iter()
        .zip(history)
        .map(|(p, h)| point_contact(pair, &surface, u, p, h, tangent))
        .collect();
    let mut residual = vec![0.0; u.len()];
    let mut factors = ContactTangent::default();
    let mut points = Vec::with_capacity(results.len());
    for (state, local) in results {
        points.push(state);
        let Some(local) = local else { continue };
        for (&d, r) in local.dofs.iter().zip(&local.residual) {
            residual[d] += r;
        }
        factors.points.extend(local.tangent);
    }
    Enforcement {
        residual,
        tangent: factors,
        points,
    }
}
