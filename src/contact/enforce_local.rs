//! One slave point's contribution to the contact residual and tangent on its
//! local dofs: the chain from the kinematic variables `y` of
//! [`super::enforce_gap`] to the nodal displacements.
//!
//! `y` is linear in the local dofs, `y = y0 + A u_local`, with `A`'s columns
//! from the shape functions: the slave cell's `N_a(X)` and `∂N_a/∂X` for
//! `x1` and `F`, the hit triangle's master cell's `N_b(X_k)` for the corners
//! `p_k`, and the anchor cell's `N_b(Â)` for `a`. The corner normals `m_k`
//! are quadratic in the master's vertex positions (`enforce_normals`): their
//! columns are evaluated at the current state, and their second
//! derivatives add a term to the tangent. So `R_local = Aᵀ R_y` and
//! `K_local = Aᵀ K_y A + Σ_k R_y[m_k]·∇²m_k` exactly (kept factored, see
//! `enforce_tangent`).

use super::enforce::SlaveQuadraturePoint;
use super::enforce::{
    ContactBody, ContactPairData, FrictionState, MasterPoint, PointHistory, PointState,
};
use super::enforce_gap::{local_gap, First, LocalGap, Order, Second, A, F, M, NVAR, P, X1};
use super::enforce_law::{residual_in_y, tangent_in_y, tractions, LawInput, Tractions};
use super::enforce_normals::CornerNormals;
use super::enforce_tangent::PointTangent;
use super::patch::Real;
use super::search::{area_ratio, current_normal, MasterSurface};
use crate::element::{shape_gradients, shape_values};
use crate::spatial::vec3::dot;

/// Local contributions of one point: global dofs, `R` and, when asked
/// for, the factored tangent.
pub struct Local {
    pub dofs: Vec<usize>,
    pub residual: Vec<f64>,
    pub tangent: Option<PointTangent>,
}

/// `∂y/∂u` for one point: the global dofs and, per dof, its column of `A`.
pub(super) struct Jacobian {
    dofs: Vec<usize>,
    columns: Vec<[f64; NVAR]>,
}

impl Jacobian {
    /// The column of global dof `dof` (a new zero column when it has none).
    pub(super) fn column(&mut self, dof: usize) -> &mut [f64; NVAR] {
        let c = match self.dofs.iter().position(|&d| d == dof) {
            Some(c) => c,
            None => {
                self.dofs.push(dof);
                self.columns.push([0.0; NVAR]);
                self.dofs.len() - 1
            }
        };
        &mut self.columns[c]
    }

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
pub(super) fn cell_shape(
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

/// The slave cell's dofs with the shape values and physical gradients at
/// a slave point.
type SlaveShape = (Vec<usize>, Vec<f64>, Vec<[f64; 3]>);

/// Columns of `A` for the slave dofs: `x1_i` and `F_ij` depend on `u_{a,i}`
/// through `N_a(X)` and `∂N_a/∂X_j`.
fn slave_jacobian((dofs, n, dn): SlaveShape) -> Jacobian {
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

/// `y0 + A u_local` over the slave columns alone (`x1` and `F`; the
/// other variables at their reference values), without forming them: the
/// same sums in the same order as [`Jacobian::state`], whose other terms
/// are zeros.
fn slave_state((dofs, n, dn): &SlaveShape, y0: [f64; NVAR], u: &[f64]) -> [f64; NVAR] {
    let mut y = y0;
    for (d, &dof) in dofs.iter().enumerate() {
        let (a, i) = (d / 3, d % 3);
        y[X1 + i] += n[a] * u[dof];
        (0..3).for_each(|j| y[F + 3 * i + j] += dn[a][j] * u[dof]);
    }
    y
}

/// Adds the columns of the master `cell`'s dofs for the master points
/// `(offset in y, reference position)` that lie in it: component `i` of the
/// point at `offset` depends on `u_{b,i}` through `N_b(X)`.
fn add_master_columns(
    jac: &mut Jacobian,
    body: &ContactBody,
    cell: usize,
    at: &[(usize, [f64; 3])],
) {
    let shapes: Vec<(Vec<usize>, Vec<f64>)> = at
        .iter()
        .map(|&(_, x)| {
            let (dofs, n, _) = cell_shape(body, cell, x);
            (dofs, n)
        })
        .collect();
    for (d, &dof) in shapes[0].0.iter().enumerate() {
        let (b, i) = (d / 3, d % 3);
        let mut col = [0.0; NVAR];
        for (&(offset, _), (_, n)) in at.iter().zip(&shapes) {
            col[offset + i] = n[b];
        }
        jac.dofs.push(dof);
        jac.columns.push(col);
    }
}

/// `y0`: the kinematic state at `u = 0`.
fn reference_state(x: [f64; 3], corners: &[[f64; 3]; 3], anchor: [f64; 3]) -> [f64; NVAR] {
    let mut y = [0.0; NVAR];
    y[X1..X1 + 3].copy_from_slice(&x);
    (0..3).for_each(|i| y[F + 4 * i] = 1.0);
    (0..3).for_each(|k| y[P + 3 * k..P + 3 * k + 3].copy_from_slice(&corners[k]));
    y[A..A + 3].copy_from_slice(&anchor);
    y
}

/// The state of slave point `p` and, when active, its local contributions.
pub fn point_contact(
    pair: &ContactPairData,
    surface: &MasterSurface,
    u: &[f64],
    p: &SlaveQuadraturePoint,
    history: &PointHistory,
    tangent: bool,
) -> (PointState, Option<Local>) {
    // Most points are clearly apart: their state needs no columns.
    let shape = cell_shape(&pair.slave, p.cell, p.x);
    let y_slave = slave_state(&shape, reference_state(p.x, &[[0.0; 3]; 3], [0.0; 3]), u);
    let f = [0, 1, 2].map(|i| [0, 1, 2].map(|j| y_slave[F + 3 * i + j]));
    let normal = current_normal(&f, p.normal);
    let mut state = PointState {
        x: [y_slave[0], y_slave[1], y_slave[2]],
        normal,
        weight: p.weight * area_ratio(&f, p.normal),
        hit: None,
        master_point: None,
        pressure: 0.0,
        tangential: [0.0; 3],
        friction: FrictionState::Off,
    };
    let hit = surface
        .search_near(state.x, normal, pair.search_radius, history.patch)
        .filter(|h| dot(h.master_normal, normal) < 0.0);
    let Some(hit) = hit else {
        return (state, None);
    };
    state.master_point = Some(MasterPoint {
        cell: hit.cell,
        x: hit.reference_x2,
    });
    state.hit = Some((hit.triangle, hit.gap));
    // Clearly inactive points skip the derivatives (the search's gap equals
    // the closed form to round-off; the law decides on the latter).
    if history.recovered + pair.stiffness() * hit.gap > 0.0 {
        return (state, None);
    }
    let mut jac = slave_jacobian(shape);
    let corners = pair.master_surface.reference_corners(hit.triangle);
    let anchor = history.anchor.filter(|_| pair.friction > 0.0);
    let mut in_hit_cell: Vec<(usize, [f64; 3])> = (0..3).map(|k| (P + 3 * k, corners[k])).collect();
    match anchor {
        Some(a) if a.cell == hit.cell => in_hit_cell.push((A, a.x)),
        Some(a) => add_master_columns(&mut jac, &pair.master, a.cell, &[(A, a.x)]),
        None => {}
    }
    add_master_columns(&mut jac, &pair.master, hit.cell, &in_hit_cell);
    let anchor_x = anchor.map_or([0.0; 3], |a| a.x);
    let mut y = jac.state(reference_state(p.x, &corners, anchor_x), u);
    // The corner normals of a curved patch: their values, then their
    // (state-dependent) columns.
    let master = pair.master_surface;
    let normals = surface.normals().map(|current_normals| {
        let vertices = master.triangles[hit.triangle].vertices.map(|v| v as usize);
        for (k, &v) in vertices.iter().enumerate() {
            y[M + 3 * k..M + 3 * k + 3].copy_from_slice(&current_normals[v]);
        }
        CornerNormals::add_columns(&mut jac, &pair.master, master, surface.current(), vertices)
    });
    let start = [hit.barycentric[1], hit.barycentric[2], hit.gap];
    let input = LawInput {
        recovered: history.recovered,
        kappa: pair.stiffness(),
        friction: pair.friction,
        previous_tangential: anchor.map(|_| history.tangential),
    };
    let curved = normals.is_some();
    // The residual needs gradients only; the tangent the Hessians too.
    let (r_y, k_y) = if tangent {
        let Some((lg, tr)) = law::<Second>(&y, p, start, curved, &input, &mut state) else {
            return (state, None);
        };
        let r_y = residual_in_y(&lg, &tr, p.weight);
        (r_y, Some(tangent_in_y(&lg, &tr, p.weight)))
    } else {
        let Some((lg, tr)) = law::<First>(&y, p, start, curved, &input, &mut state) else {
            return (state, None);
        };
        (residual_in_y(&lg, &tr, p.weight), None)
    };
    let residual = jac.columns.iter().map(|c| dot_n(c, &r_y)).collect();
    let tangent = k_y.map(|k_y| {
        let normals = normals.map_or_else(Default::default, |n| n.second_derivatives(master, &r_y));
        PointTangent::new(jac.dofs.clone(), &jac.columns, k_y, normals)
    });
    let local = Local {
        dofs: jac.dofs,
        residual,
        tangent,
    };
    (state, Some(local))
}

/// The point's kinematics and tractions to the order `O` at the state `y`,
/// recorded in `state`; `None` when the point is not active.
fn law<O: Order>(
    y: &[f64; NVAR],
    p: &SlaveQuadraturePoint,
    start: [f64; 3],
    curved: bool,
    input: &LawInput,
    state: &mut PointState,
) -> Option<(LocalGap<O>, Tractions<O>)> {
    let lg = local_gap::<O>(y, p.normal, start, curved);
    state.hit = state.hit.map(|(triangle, _)| (triangle, lg.gap.value()));
    let tr = tractions(&lg, input)?;
    state.pressure = -tr.normal.value();
    if let Some((t, slipping)) = &tr.tangential {
        state.tangential = t.map(|ti| ti.value());
        state.friction = match slipping {
            true => FrictionState::Slip,
            false => FrictionState::Stick,
        };
    }
    Some((lg, tr))
}

fn dot_n(a: &[f64; NVAR], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
