//! Frictionless contact enforcement (DESIGN §6, issue 8): the contact
//! residual and its exact tangent for one slave/master pair, by the
//! stabilised augmented Lagrangian.
//!
//! **Unknowns.** The two bodies' nodal displacements form one vector
//! `u = […, u_s, …, u_m, …]`: each body's [`DofMap`] layout
//! (`3 · active + component`) starting at its [`ContactBody::offset`].
//!
//! **Slave points** are the slave body's cut-cell boundary quadrature points
//! with the pair's slave tag ([`slave_points`]): reference position `X`,
//! reference unit outward normal `N`, weight `w = dΓ_0`.
//!
//! **Kinematics** (see [`super::enforce_gap`]). `x1 = X + u_s(X)`, current
//! normal `n1` by Nanson, area ratio `J_s = |cof(F) N|`; the ray search on
//! the current master surface (built from `u_m` at every call) gives the
//! master triangle, whose current corners `p_k = X_k + u_m(X_k)` are
//! evaluated with the shape functions of the triangle's master cell; then
//! `g_N = |c| (p0 − x1)·ν / (c·ν)`, exactly the search's `(x2 − x1)·n1`.
//! A hit whose master normal does not oppose `n1` (`n1·m ≥ 0`: the far side
//! of the master, or a point behind the slave's own front) is no contact.
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
//! dofs. **Tangent** (exact derivative of `R_c`, non-symmetric through
//! `J_s`), on active points (`T̂_N + κ g_N < 0`):
//! `K_c = Σ w [J_s κ ∇g ⊗ ∇g + J_s λ_N ∇²g + λ_N ∇g ⊗ ∇J_s]`
//! (row index first). Inactive points contribute nothing to either.

use faer::sparse::Triplet;
use rayon::prelude::*;

use super::enforce_gap::{local_gap, LocalGap, F, NVAR, P, X1};
use super::report::{ContactRow, SlaveSample};
use super::search::{current_normal, MasterSurface};
use super::surface::Surface;
use super::vec3::dot;
use crate::cells::Cells;
use crate::element::{shape_gradients, shape_values};
use crate::fem::dofs::DofMap;
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
}

impl ContactPairData<'_> {
    /// `κ = k E / h_slave`.
    pub fn stiffness(&self) -> f64 {
        self.penalty * self.young / self.slave.grid.h
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
    /// `−λ_N ≥ 0` (compression positive).
    pub pressure: f64,
}

/// The contact residual, optionally its tangent, and the points' states.
#[derive(Clone, Debug)]
pub struct Enforcement {
    /// `R_c`, as long as the global vector.
    pub residual: Vec<f64>,
    /// `K_c` as (row, column, value) triplets with repeats (to be summed);
    /// empty when only the residual was asked for.
    pub tangent: Vec<Triplet<usize, usize, f64>>,
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
                })
            })
            .collect();
        ContactRow::from_samples(pair, step, &samples)
    }
}

/// `R_c` at the global displacement `u` with recovered normal tractions
/// `traction` (one per slave point).
pub fn contact_residual(pair: &ContactPairData, u: &[f64], traction: &[f64]) -> Enforcement {
    enforce(pair, u, traction, false)
}

/// `R_c` and `K_c` at `u` (see [`contact_residual`]).
pub fn contact_residual_and_tangent(
    pair: &ContactPairData,
    u: &[f64],
    traction: &[f64],
) -> Enforcement {
    enforce(pair, u, traction, true)
}

/// Local contributions of one point: global dofs, `R` and row-major `K`.
struct Local {
    dofs: Vec<usize>,
    residual: Vec<f64>,
    tangent: Vec<f64>,
}

fn enforce(pair: &ContactPairData, u: &[f64], traction: &[f64], tangent: bool) -> Enforcement {
    assert_eq!(traction.len(), pair.slave_points.len(), "one T̂_N per point");
    let (master, m) = (pair.master, pair.master_surface);
    let um = &u[master.offset..master.offset + master.dofs.ndofs()];
    let surface = MasterSurface::new(m, m.deformed_by_field(master.grid, master.dofs, um));
    let results: Vec<(PointState, Option<Local>)> = pair
        .slave_points
        .par_iter()
        .zip(traction)
        .map(|(p, &t)| point_contact(pair, &surface, u, p, t, tangent))
        .collect();
    let mut residual = vec![0.0; u.len()];
    let mut triplets = Vec::new();
    let mut points = Vec::with_capacity(results.len());
    for (state, local) in results {
        points.push(state);
        let Some(local) = local else { continue };
        let n = local.dofs.len();
        for (a, &da) in local.dofs.iter().enumerate() {
            residual[da] += local.residual[a];
            if tangent {
                for (b, &db) in local.dofs.iter().enumerate() {
                    triplets.push(Triplet::new(da, db, local.tangent[a * n + b]));
                }
            }
        }
    }
    Enforcement {
        residual,
        tangent: triplets,
        points,
    }
}

/// `∂y/∂u` for one point: the global dofs and, per dof, its column of `A`.
struct Jacobian {
    dofs: Vec<usize>,
    columns: Vec<[f64; NVAR]>,
}

impl Jacobian {
    /// `y = y0 + A u_local`.
    fn state(&self, y0: [f64; NVAR], u: &[f64]) -> [f64; NVAR] {
        let mut y = y0;
        for (col, &d) in self.columns.iter().zip(&self.dofs) {
            (0..NVAR).for_each(|r| y[r] += col[r] * u[d]);
        }
        y
    }
}

/// The active global dofs of `cell` (node-major, three components each) and
/// the shape values and physical gradients at the reference point `x`.
fn cell_shape(
    body: &ContactBody,
    cell: usize,
    x: [f64; 3],
) -> (Vec<usize>, Vec<f64>, Vec<[f64; 3]>) {
    let npc = body.dofs.order.nodes_per_cell();
    let mut nodes = vec![0usize; npc];
    body.grid.cell_nodes(body.dofs.order, cell, &mut nodes);
    let active = nodes.iter().map(|&n| {
        let a = body.dofs.node_to_active[n];
        assert!(
            a != u32::MAX,
            "contact point in cell {cell} with an inactive node"
        );
        a as usize
    });
    let dofs = active
        .flat_map(|a| (0..3).map(move |i| body.offset + 3 * a + i))
        .collect();
    let lo = body.grid.cell_box(cell).lo;
    let xi = [0, 1, 2].map(|k| (x[k] - lo[k]) / body.grid.h);
    let mut n = vec![0.0; npc];
    let mut dn = vec![[0.0; 3]; npc];
    shape_values(body.dofs.order, xi, &mut n);
    shape_gradients(body.dofs.order, xi, &mut dn);
    dn.iter_mut().flatten().for_each(|d| *d /= body.grid.h);
    (dofs, n, dn)
}

/// Columns of `A` for the slave dofs: `x1_i` and `F_ij` depend on `u_{a,i}`
/// through `N_a(X)` and `∂N_a/∂X_j`.
fn slave_jacobian(body: &ContactBody, p: &SlaveQuadraturePoint) -> Jacobian {
    let (dofs, n, dn) = cell_shape(body, p.cell, p.x);
    let columns = (0..dofs.len())
        .map(|d| {
            let (a, i) = (d / 3, d % 3);
            let mut col = [0.0; NVAR];
            col[X1 + i] = n[a];
            (0..3).for_each(|j| col[F + 3 * i + j] = dn[a][j]);
            col
        })
        .collect();
    Jacobian { dofs, columns }
}

/// Adds the master dofs of triangle `t`'s cell: corner `k`'s component `i`
/// depends on `u_{b,i}` through `N_b(X_k)`.
fn add_master_jacobian(jac: &mut Jacobian, body: &ContactBody, surface: &Surface, t: usize) {
    let cell = surface.triangles[t].cell;
    let corners = surface.reference_corners(t);
    let shapes: Vec<(Vec<usize>, Vec<f64>)> = corners
        .iter()
        .map(|&x| {
            let (dofs, n, _) = cell_shape(body, cell, x);
            (dofs, n)
        })
        .collect();
    for (d, &dof) in shapes[0].0.iter().enumerate() {
        let (b, i) = (d / 3, d % 3);
        let mut col = [0.0; NVAR];
        (0..3).for_each(|k| col[P + 3 * k + i] = shapes[k].1[b]);
        jac.dofs.push(dof);
        jac.columns.push(col);
    }
}

/// `y0`: the kinematic state at `u = 0`.
fn reference_state(x: [f64; 3], corners: &[[f64; 3]; 3]) -> [f64; NVAR] {
    let mut y = [0.0; NVAR];
    y[X1..X1 + 3].copy_from_slice(&x);
    (0..3).for_each(|i| y[F + 4 * i] = 1.0);
    (0..3).for_each(|k| y[P + 3 * k..P + 3 * k + 3].copy_from_slice(&corners[k]));
    y
}

fn point_contact(
    pair: &ContactPairData,
    surface: &MasterSurface,
    u: &[f64],
    p: &SlaveQuadraturePoint,
    traction: f64,
    tangent: bool,
) -> (PointState, Option<Local>) {
    let mut jac = slave_jacobian(&pair.slave, p);
    let y_slave = jac.state(reference_state(p.x, &[[0.0; 3]; 3]), u);
    let f = [0, 1, 2].map(|i| [0, 1, 2].map(|j| y_slave[F + 3 * i + j]));
    let normal = current_normal(&f, p.normal);
    let mut state = PointState {
        x: [y_slave[0], y_slave[1], y_slave[2]],
        normal,
        weight: p.weight * super::search::area_ratio(&f, p.normal),
        hit: None,
        pressure: 0.0,
    };
    let hit = surface
        .search(state.x, normal, pair.search_radius)
        .filter(|h| dot(h.master_normal, normal) < 0.0);
    let Some(hit) = hit else {
        return (state, None);
    };
    add_master_jacobian(&mut jac, &pair.master, pair.master_surface, hit.triangle);
    let corners = pair.master_surface.reference_corners(hit.triangle);
    let y = jac.state(reference_state(p.x, &corners), u);
    let lg = local_gap(&y, p.normal);
    let kappa = pair.stiffness();
    let lambda = (traction + kappa * lg.gap.v).min(0.0);
    state.hit = Some((hit.triangle, lg.gap.v));
    state.pressure = -lambda;
    if lambda == 0.0 {
        return (state, None);
    }
    let (w, j) = (p.weight, lg.area_ratio.v);
    let r_y: Vec<f64> = lg.gap.g.iter().map(|g| w * j * lambda * g).collect();
    let residual = jac.columns.iter().map(|c| dot_n(c, &r_y)).collect();
    let tangent = if tangent {
        local_tangent(&jac.columns, &tangent_in_y(&lg, w, kappa, lambda))
    } else {
        Vec::new()
    };
    let local = Local {
        dofs: jac.dofs,
        residual,
        tangent,
    };
    (state, Some(local))
}

/// `∂(w J_s λ_N ∇_y g)/∂y = w [J_s κ ∇g ⊗ ∇g + J_s λ_N ∇²g + λ_N ∇g ⊗ ∇J_s]`
/// on an active point.
fn tangent_in_y(lg: &LocalGap, w: f64, kappa: f64, lambda: f64) -> Vec<[f64; NVAR]> {
    let (g, dj, j) = (&lg.gap.g, &lg.area_ratio.g, lg.area_ratio.v);
    (0..NVAR)
        .map(|a| {
            let mut row = [0.0; NVAR];
            for (b, r) in row.iter_mut().enumerate() {
                *r = w
                    * (j * kappa * g[a] * g[b]
                        + j * lambda * lg.gap.h[a][b]
                        + lambda * g[a] * dj[b]);
            }
            row
        })
        .collect()
}

fn dot_n(a: &[f64; NVAR], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `Aᵀ K_y A`, row-major over the local dofs.
fn local_tangent(columns: &[[f64; NVAR]], k_y: &[[f64; NVAR]]) -> Vec<f64> {
    // (K_y A)_{r, d} for every local dof d.
    let ka: Vec<[f64; NVAR]> = columns
        .iter()
        .map(|c| {
            let mut out = [0.0; NVAR];
            (0..NVAR).for_each(|r| out[r] = dot_n(&k_y[r], c));
            out
        })
        .collect();
    let n = columns.len();
    let mut k = vec![0.0; n * n];
    for (a, ca) in columns.iter().enumerate() {
        for (b, kb) in ka.iter().enumerate() {
            k[a * n + b] = dot_n(ca, kb);
        }
    }
    k
}
