//! One hyperelastic body on its grid, set up once: the dofs, the quadrature
//! points of every non-outside cell with their shape gradients, the Dirichlet
//! penalty points with their per-component masks, and the external load
//! vector at load factor 1.
//!
//! The element is the dof map's ([`ElementOrder`]: Q1 or Q2); a cell's nodal
//! values are `nodes_per_cell` rows `[f64; 3]` in the element's lexicographic
//! node order, and everything per node (shape gradients of a point, shape
//! values of a penalty point, a cell's node indices) is stored flat with that
//! stride. Inside cells share one rule (the element's full Gauss rule,
//! weights `h³ w`); cut cells carry their own points from the cut-cell
//! quadrature of [`Cells`] (classified with the element's cut rules). The
//! S-term of the pathological cells ([`super::stabilisation`]) is optional
//! ([`HyperProblem::set_s_term`]).

use std::sync::Arc;

use rayon::prelude::*;

use crate::cells::{CellKind, Cells};
use crate::discrete::dofs::DofMap;
use crate::element::{shape_values, tensor_gauss_rule, ElementOrder};
use crate::error::{Error, Result};
use crate::fem::rhs::add_point_load;
use crate::geometry::Geometry;
use crate::grid::Grid;

use super::material::Material;
pub use super::points::{PointSet, QuadPoint};
use super::stabilisation::STerm;

/// The most nodes a cell has (Q2): the size of a cell's stack buffers.
pub const MAX_NODES: usize = 27;

/// A cell's nodal values on the stack, `[node][component]`; the first
/// `nodes_per_cell` rows are the cell's.
pub type CellBuffer = [[f64; 3]; MAX_NODES];

/// A vector field of the reference position.
pub type VectorField = Arc<dyn Fn([f64; 3]) -> [f64; 3] + Send + Sync>;
/// A point-wise predicate of the reference position: where a Dirichlet
/// condition applies (a box of the case file, say).
pub type Region = Arc<dyn Fn([f64; 3]) -> bool + Send + Sync>;
/// A traction of the reference position and outward normal.
pub type TractionField = Arc<dyn Fn([f64; 3], [f64; 3]) -> [f64; 3] + Send + Sync>;

/// The load path of a prescribed value: its factor at load factor `t` is
/// `r(t) = clamp((t − start)/(end − start), 0, 1)`, with `0 ≤ start < end ≤ 1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ramp {
    pub start: f64,
    pub end: f64,
}

impl Ramp {
    /// `r(t) = t`: the value grows with the load factor.
    pub const LINEAR: Ramp = Ramp {
        start: 0.0,
        end: 1.0,
    };

    /// `r(t)`; 0 at `t = 0` and 1 at `t = 1`.
    pub fn factor(&self, t: f64) -> f64 {
        ((t - self.start) / (self.end - self.start)).clamp(0.0, 1.0)
    }
}

/// A prescribed displacement on one boundary part, imposed by the penalty
/// `(β/h) ∫ N m_i (u_i − r_i(t) g_i)` on the components `i` with `m_i = 1`
/// (all three: a fixed part; one: a roller), `r_i` the component's [`Ramp`].
#[derive(Clone)]
pub struct DirichletCondition {
    pub tag: u16,
    pub components: [bool; 3],
    /// `g` at load factor 1.
    pub value: VectorField,
    /// Per component: how `g_i` grows with the load factor.
    pub ramps: [Ramp; 3],
}

/// Dead loads at load factor 1, on the reference configuration. The body
/// load grows with the load factor; each traction along its ramps.
#[derive(Clone, Default)]
pub struct Loads {
    pub body: Option<VectorField>,
    pub tractions: Vec<TractionLoad>,
}

/// A traction on the boundary part `tag`, its component `i` scaled by
/// `ramps[i]` at load factor `t`.
#[derive(Clone)]
pub struct TractionLoad {
    pub tag: u16,
    pub field: TractionField,
    pub ramps: [Ramp; 3],
}

/// Part of `f_ext`: the loads that share one set of ramps, assembled at load
/// factor 1; component `i` of every node is scaled by `ramps[i]`.
#[derive(Clone, Debug, PartialEq)]
pub struct ExternalLoad {
    pub ramps: [Ramp; 3],
    pub f: Vec<f64>,
}

/// A Dirichlet penalty point: its boundary tag, `w β/h`, mask, `g` at load 1
/// and its ramps (its shape values are [`HyperProblem::penalty_points`]'s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PenaltyPoint {
    pub tag: u16,
    pub weight: f64,
    pub mask: [f64; 3],
    pub g: [f64; 3],
    pub ramps: [Ramp; 3],
}

impl PenaltyPoint {
    /// The prescribed value at load factor `t`: `r_i(t) g_i`.
    pub fn target(&self, t: f64) -> [f64; 3] {
        [0, 1, 2].map(|i| self.ramps[i].factor(t) * self.g[i])
    }
}

/// What is prescribed on a body: its Dirichlet conditions, the regions they
/// are restricted to (`regions[i]` for condition `i`; none past the end) and
/// its loads.
#[derive(Clone, Copy)]
pub struct Conditions<'a> {
    pub dirichlet: &'a [DirichletCondition],
    pub regions: &'a [Option<Region>],
    pub loads: &'a Loads,
}

/// The body, its grid and its boundary conditions.
pub struct HyperProblem {
    pub grid: Grid,
    pub dofs: DofMap,
    pub material: Material,
    /// Penalty `β` (the penalty term carries `β/h`).
    pub beta: f64,
    /// Non-outside cells, ascending.
    pub cells: Vec<usize>,
    /// Per entry of `cells`, its active node indices, `nodes_per_cell` each.
    cell_nodes: Vec<u32>,
    /// Per entry of `cells`: `None` for an inside cell, else its cut index.
    pub cut_index: Vec<Option<usize>>,
    /// The shared inside-cell rule.
    pub inside_rule: PointSet,
    cut_points: PointSet,
    cut_start: Vec<usize>,
    penalty: Vec<PenaltyPoint>,
    /// Shape values of the penalty points, `nodes_per_cell` each.
    penalty_n: Vec<f64>,
    penalty_start: Vec<usize>,
    /// `f_ext`, one part per set of ramps ([`HyperProblem::external_at`]).
    pub external: Vec<ExternalLoad>,
    /// The S-stabilisation of the pathological cells, if switched on.
    pub s_term: Option<STerm>,
}

impl HyperProblem {
    /// Sets up the body with elements of `order`: `cells` must be classified
    /// with that element's cut rules.
    pub fn new(
        grid: &Grid,
        cells: &Cells,
        order: ElementOrder,
        material: Material,
        beta: f64,
        dirichlet: &[DirichletCondition],
        loads: &Loads,
    ) -> Result<HyperProblem> {
        let conditions = Conditions {
            dirichlet,
            regions: &[],
            loads,
        };
        Self::new_restricted(grid, cells, order, material, beta, &conditions)
    }

    /// [`Self::new`] with Dirichlet conditions restricted to regions:
    /// `regions[i]` (when given) keeps condition `i` at the surface quadrature
    /// points where it holds; conditions past the end of `regions` apply on
    /// their whole part.
    pub fn new_restricted(
        grid: &Grid,
        cells: &Cells,
        order: ElementOrder,
        material: Material,
        beta: f64,
        conditions: &Conditions<'_>,
    ) -> Result<HyperProblem> {
        check_parameters(&material, beta)?;
        let Conditions {
            dirichlet,
            regions,
            loads,
        } = *conditions;
        let applies = |i: usize, x: [f64; 3]| match regions.get(i) {
            Some(Some(region)) => region(x),
            _ => true,
        };
        let dofs = DofMap::new(grid, cells, order);
        let npc = order.nodes_per_cell();
        let inv_h = 1.0 / grid.h;
        let vol = grid.h.powi(3);
        let mut inside_rule = PointSet::new(npc);
        for (xi, w) in tensor_gauss_rule(order.gauss_points_per_axis()) {
            inside_rule.push(order, xi, w * vol, inv_h);
        }
        let mut p = HyperProblem {
            grid: grid.clone(),
            dofs,
            material,
            beta,
            cells: Vec::new(),
            cell_nodes: Vec::new(),
            cut_index: Vec::new(),
            inside_rule,
            cut_points: PointSet::new(npc),
            cut_start: vec![0],
            penalty: Vec::new(),
            penalty_n: Vec::new(),
            penalty_start: vec![0],
            external: Vec::new(),
            s_term: None,
        };
        let mut nodes = [0usize; MAX_NODES];
        for (c, kind) in cells.kinds.iter().enumerate() {
            let cut = match kind {
                CellKind::Outside => continue,
                CellKind::Inside => None,
                CellKind::Cut => cells.cut_position(c),
            };
            p.dofs.cell_active_nodes(grid, c, &mut nodes[..npc]);
            p.cells.push(c);
            p.cell_nodes.extend(nodes[..npc].iter().map(|&n| n as u32));
            p.cut_index.push(cut);
        }
        for (i, &c) in cells.cut.iter().enumerate() {
            let x0 = grid.cell_box(c).lo;
            let xi = |x: [f64; 3]| [0, 1, 2].map(|a| (x[a] - x0[a]) * inv_h);
            for q in cells.volume_points(i) {
                p.cut_points.push(order, xi(q.x), q.w, inv_h);
            }
            p.cut_start.push(p.cut_points.len());
            for q in cells.surface_points(i) {
                let here =
                    |(i, d): &(usize, &DirichletCondition)| d.tag == q.tag && applies(*i, q.x);
                for (_, d) in dirichlet.iter().enumerate().filter(here) {
                    let start = p.penalty_n.len();
                    p.penalty_n.resize(start + npc, 0.0);
                    shape_values(order, xi(q.x), &mut p.penalty_n[start..]);
                    p.penalty.push(PenaltyPoint {
                        tag: d.tag,
                        weight: q.w * beta * inv_h,
                        mask: d.components.map(|m| if m { 1.0 } else { 0.0 }),
                        g: (d.value)(q.x),
                        ramps: d.ramps,
                    });
                }
            }
            p.penalty_start.push(p.penalty.len());
        }
        p.external = external_loads(grid, cells, &p.dofs, loads);
        Ok(p)
    }

    /// `f_ext(t) = Σ_parts Σ_i r_i(t) f_i`, `f_i` a part's load on the
    /// component-`i` dofs.
    pub fn external_at(&self, t: f64) -> Vec<f64> {
        let mut f = vec![0.0; self.ndofs()];
        for part in &self.external {
            let factors = part.ramps.map(|r| r.factor(t));
            for (k, (out, v)) in f.iter_mut().zip(&part.f).enumerate() {
                *out += factors[k % 3] * v;
            }
        }
        f
    }

    /// The reaction of each Dirichlet part at `u` and load factor `t`, by
    /// tag (ascending): the force the condition exerts on the body,
    /// `−Σ_q w_q β/h M (u_h(x_q) − r(t) g)`.
    pub fn dirichlet_reactions(&self, u: &[f64], t: f64) -> Vec<(u16, [f64; 3])> {
        let mut sums = std::collections::BTreeMap::<u16, [f64; 3]>::new();
        for k in 0..self.cells.len() {
            let mut ue = [[0.0; 3]; MAX_NODES];
            let ue = self.gather(k, u, &mut ue);
            for (pp, n) in self.penalty_points(k) {
                let target = pp.target(t);
                let sum = sums.entry(pp.tag).or_default();
                for i in 0..3 {
                    let uh: f64 = n.iter().zip(ue.iter()).map(|(n, u)| n * u[i]).sum();
                    sum[i] -= pp.weight * pp.mask[i] * (uh - target[i]);
                }
            }
        }
        sums.into_iter().collect()
    }

    /// Switches the S-term on (`k2 > 0`) with weight `k2 E` and threshold
    /// `a`, on the `cells` of `solid` the problem was set up on; `k2 = 0`
    /// switches it off.
    pub fn set_s_term(&mut self, cells: &Cells, solid: &Geometry, k2: f64, young: f64, a: f64) {
        self.s_term = (k2 > 0.0).then(|| STerm::new(self, cells, solid, k2 * young, a));
    }

    /// Re-evaluates the S-term's recovered displacement at `u`; `false` when
    /// there is nothing to recover (no S-term, or Ω* empty).
    pub fn refresh_s_term(&self, u: &[f64]) -> Result<bool> {
        match &self.s_term {
            Some(s) if !s.omega_star.is_empty() => s.refresh(self, u).map(|()| true),
            _ => Ok(false),
        }
    }

    /// Number of unknowns.
    pub fn ndofs(&self) -> usize {
        self.dofs.ndofs()
    }

    /// Nodes per cell of the element.
    pub fn nodes_per_cell(&self) -> usize {
        self.dofs.order.nodes_per_cell()
    }

    /// The element.
    pub fn order(&self) -> ElementOrder {
        self.dofs.order
    }

    /// The active node indices of the `k`-th entry of [`Self::cells`].
    pub fn cell_nodes(&self, k: usize) -> &[u32] {
        let npc = self.nodes_per_cell();
        &self.cell_nodes[k * npc..(k + 1) * npc]
    }

    /// The volume points of the `k`-th entry of [`Self::cells`].
    pub fn points(&self, k: usize) -> impl ExactSizeIterator<Item = QuadPoint<'_>> + Clone {
        match self.cut_index[k] {
            None => self.inside_rule.range(0..self.inside_rule.len()),
            Some(i) => self
                .cut_points
                .range(self.cut_start[i]..self.cut_start[i + 1]),
        }
    }

    /// The penalty points of the `k`-th entry of [`Self::cells`], each with
    /// its shape values.
    pub fn penalty_points(&self, k: usize) -> impl Iterator<Item = (&PenaltyPoint, &[f64])> {
        let range = match self.cut_index[k] {
            None => 0..0,
            Some(i) => self.penalty_start[i]..self.penalty_start[i + 1],
        };
        let npc = self.nodes_per_cell();
        range.map(move |p| (&self.penalty[p], &self.penalty_n[p * npc..(p + 1) * npc]))
    }

    /// The cell's nodal values of a global vector, `[node][component]`, in
    /// the first `nodes_per_cell` rows of `buffer`.
    pub fn gather<'b>(&self, k: usize, x: &[f64], buffer: &'b mut CellBuffer) -> &'b [[f64; 3]] {
        let nodes = self.cell_nodes(k);
        for (v, &a) in buffer.iter_mut().zip(nodes) {
            let a = 3 * a as usize;
            *v = [x[a], x[a + 1], x[a + 2]];
        }
        &buffer[..nodes.len()]
    }

    /// Adds cell vectors (`nodes_per_cell` rows per entry of
    /// [`Self::cells`], back to back) into a global vector.
    pub fn scatter(&self, cell_vectors: &[[f64; 3]], y: &mut [f64]) {
        let npc = self.nodes_per_cell();
        for (k, v) in cell_vectors.chunks_exact(npc).enumerate() {
            self.scatter_cell(k, v, y);
        }
    }

    /// Adds the cell vector of the `k`-th entry into a global vector.
    pub fn scatter_cell(&self, k: usize, v: &[[f64; 3]], y: &mut [f64]) {
        for (&node, v) in self.cell_nodes(k).iter().zip(v) {
            for i in 0..3 {
                y[3 * node as usize + i] += v[i];
            }
        }
    }

    /// One cell vector per entry of [`Self::cells`], computed in parallel
    /// (`cell(k, out)` adds into the `nodes_per_cell` zeroed rows of `out`),
    /// back to back.
    pub fn cell_vectors<F>(&self, cell: F) -> Vec<[f64; 3]>
    where
        F: Fn(usize, &mut [[f64; 3]]) + Sync,
    {
        let npc = self.nodes_per_cell();
        let mut out = vec![[0.0; 3]; npc * self.cells.len()];
        out.par_chunks_mut(npc)
            .enumerate()
            .for_each(|(k, v)| cell(k, v));
        out
    }

    /// [`Self::cell_vectors`] of a cell function that may fail: `None` if it
    /// does on some cell.
    pub fn try_cell_vectors<F>(&self, cell: F) -> Option<Vec<[f64; 3]>>
    where
        F: Fn(usize, &mut [[f64; 3]]) -> Option<()> + Sync,
    {
        let npc = self.nodes_per_cell();
        let mut out = vec![[0.0; 3]; npc * self.cells.len()];
        let ok = out
            .par_chunks_mut(npc)
            .enumerate()
            .all(|(k, v)| cell(k, v).is_some());
        ok.then_some(out)
    }
}

fn check_parameters(material: &Material, beta: f64) -> Result<()> {
    let bad = |what: &str, reason: String| {
        Err(Error::InvalidSolverOptions {
            what: what.into(),
            reason,
        })
    };
    if !(material.mu.is_finite() && material.mu > 0.0 && material.lambda.is_finite()) {
        return bad(
            "material",
            format!(
                "needs μ > 0 and finite λ, got μ = {}, λ = {}",
                material.mu, material.lambda
            ),
        );
    }
    if !(beta.is_finite() && beta >= 0.0) {
        return bad("penalty", format!("β must be finite and ≥ 0, got {beta}"));
    }
    Ok(())
}

/// `f_ext = ∫ Nᵀ b dV + ∫_ΓN Nᵀ t dA` on the reference configuration, with the
/// same rules as the linear right-hand side (one Gauss order more inside),
/// one part per distinct set of ramps (the body load's is linear).
fn external_loads(grid: &Grid, cells: &Cells, dofs: &DofMap, loads: &Loads) -> Vec<ExternalLoad> {
    let mut parts: Vec<ExternalLoad> = Vec::new();
    let mut part = |ramps: [Ramp; 3]| -> usize {
        match parts.iter().position(|p| p.ramps == ramps) {
            Some(i) => i,
            None => {
                let f = vec![0.0; dofs.ndofs()];
                parts.push(ExternalLoad { ramps, f });
                parts.len() - 1
            }
        }
    };
    let indices: Vec<usize> = loads.tractions.iter().map(|t| part(t.ramps)).collect();
    let body_index = loads.body.as_ref().map(|_| part([Ramp::LINEAR; 3]));
    if let (Some(body), Some(i)) = (&loads.body, body_index) {
        let f = &mut parts[i].f;
        let rule = tensor_gauss_rule(dofs.order.gauss_points_per_axis() + 1);
        let vol = grid.h.powi(3);
        for (c, kind) in cells.kinds.iter().enumerate() {
            if *kind == CellKind::Inside {
                let lo = grid.cell_box(c).lo;
                for (xi, w) in &rule {
                    let x = [0, 1, 2].map(|a| lo[a] + grid.h * xi[a]);
                    add_point_load(grid, dofs, c, x, body(x).map(|v| v * w * vol), f);
                }
            }
        }
        for (i, &c) in cells.cut.iter().enumerate() {
            for q in cells.volume_points(i) {
                add_point_load(grid, dofs, c, q.x, body(q.x).map(|v| v * q.w), f);
            }
        }
    }
    for (i, &c) in cells.cut.iter().enumerate() {
        for q in cells.surface_points(i) {
            for (t, &k) in loads.tractions.iter().zip(&indices) {
                if t.tag == q.tag {
                    let load = (t.field)(q.x, q.n).map(|v| v * q.w);
                    add_point_load(grid, dofs, c, q.x, load, &mut parts[k].f);
                }
            }
        }
    }
    parts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ramp_holds_zero_then_grows_then_holds_one() {
        let r = Ramp {
            start: 0.25,
            end: 0.75,
        };
        let factors = [0.0, 0.25, 0.5, 0.625, 0.75, 1.0].map(|t| r.factor(t));
        assert_eq!(factors, [0.0, 0.0, 0.5, 0.75, 1.0, 1.0]);
        assert_eq!(
            [0.0, 0.3, 1.0].map(|t| Ramp::LINEAR.factor(t)),
            [0.0, 0.3, 1.0]
        );
    }
}
