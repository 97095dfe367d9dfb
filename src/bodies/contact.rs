//! The case's contact pairs as the [`Coupling`] of the stacked problem, by the
//! enforcement of [`crate::contact::enforce`]: per pair its slave points (the
//! slave tag's boundary quadrature points), the master tag's surface, `k` and
//! `μ` of the pair, the slave's `E`, and the points' histories.
//!
//! **Recovered normal traction** (`recovered_traction = true`, the default;
//! `false` gives the pure penalty method `λ_N = min(0, κ g_N)`,
//! `κ = k E / h_slave`). [`Coupling::refresh_recovered`] (called by Newton at
//! the start of each step attempt and after each converged pass, see
//! [`crate::hyper::newton`], *Recovered terms*) recovers the slave body's
//! Cauchy stress `σ̂` by SPR ([`super::traction`]) on the patches of the
//! cells holding the **active** slave points (`λ_N < 0` at `u` with the
//! current `T̂_N`) and sets, per point,
//! ```text
//! T̂_N ← min(0, n1 · σ̂(X) n1)   active points
//! T̂_N ← 0                      the others
//! ```
//! with `n1` the point's current normal. This is an Uzawa-type update of the
//! augmented Lagrangian (`T̂_N` plays the multiplier, the stress the contact
//! put into the slave body): at its fixed point `λ_N = T̂_N + κ g_N` with
//! `T̂_N` the body's own normal stress, so `κ g_N → 0` as the FE stress meets
//! the contact traction, whatever `κ`; `κ` mostly sets how fast the passes
//! settle. Inactive points get no `T̂_N`, so a point stays out of contact
//! until its own gap closes (`κ g_N < 0`), as in the pure penalty method; the
//! clamp keeps a tensile recovered stress from ever pulling. `T̂_N` is held
//! fixed inside each Newton pass and kept in the points' histories across
//! steps. Histories (the friction anchors) advance at each converged load
//! step. The ray search
//! looks for master hits within half the smaller of the two bodies' bounding
//! box diagonals. Each report row carries the contact residual's resultants
//! on the slave and the master body (their force balance).

use std::sync::Mutex;

use super::problem::{Coupling, CouplingTangent};
use super::traction::{normal_traction, StressSampler};
use crate::case::{Case, MasterSurfaceKind};
use crate::cells::Cells;
use crate::contact::enforce::{
    contact_residual, contact_residual_and_tangent, slave_points, ContactBody, ContactPairData,
    PointHistory, SlaveQuadraturePoint,
};
use crate::contact::{ContactPoints, ContactRow, ContactTangent, Surface};
use crate::discrete::dofs::DofMap;
use crate::error::Result;
use crate::geometry::Geometry;
use crate::grid::Grid;
use crate::hyper::problem::HyperProblem;
use crate::recovery::Mirror;

/// One pair, ready to enforce.
struct Pair {
    name: String,
    slave: usize,
    master: usize,
    points: Vec<SlaveQuadraturePoint>,
    surface: Surface,
    penalty: f64,
    young: f64,
    friction: f64,
    curved: bool,
    search_radius: f64,
    /// The slave body's stress sampler when `T̂_N` is recovered.
    sampler: Option<StressSampler>,
    history: Mutex<Vec<PointHistory>>,
}

/// Every contact pair of a case on the stacked dofs.
pub struct ContactCoupling {
    grids: Vec<Grid>,
    dofs: Vec<DofMap>,
    offsets: Vec<usize>,
    pairs: Vec<Pair>,
}

/// A body as the contact set-up needs it.
pub struct ContactSide<'a> {
    pub grid: &'a Grid,
    pub dofs: &'a DofMap,
    pub solid: &'a Geometry,
    pub cells: &'a Cells,
    /// The body's symmetry planes (the recovered traction's patches
    /// continue across them).
    pub mirror: Mirror,
}

fn diagonal(g: &Geometry) -> f64 {
    let b = g.bounding_box();
    (0..3)
        .map(|a| (b.hi[a] - b.lo[a]).powi(2))
        .sum::<f64>()
        .sqrt()
}

impl ContactCoupling {
    /// The pairs of `case` on the bodies `sides` with dofs from `offsets`.
    pub fn new(case: &Case, sides: &[ContactSide], offsets: &[usize]) -> ContactCoupling {
        let pairs = case
            .pairs
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let (s, m) = (&sides[p.slave.body], &sides[p.master.body]);
                let points = slave_points(s.cells, p.slave.tag);
                let spec = &case.spec.contact[i];
                Pair {
                    name: format!("{}→{}", spec.slave, spec.master),
                    slave: p.slave.body,
                    master: p.master.body,
                    history: Mutex::new(vec![PointHistory::fresh(0.0); points.len()]),
                    points,
                    surface: Surface::for_element(m.grid, m.dofs.order, m.solid, &[p.master.tag]),
                    penalty: p.penalty,
                    young: case.bodies[p.slave.body].spec.material.young,
                    friction: p.friction,
                    curved: spec.master_surface == MasterSurfaceKind::Curved,
                    search_radius: 0.5 * diagonal(s.solid).min(diagonal(m.solid)),
                    sampler: spec
                        .recovered_traction
                        .then(|| StressSampler::new(s.grid, s.cells, s.dofs.order, s.mirror)),
                }
            })
            .collect();
        ContactCoupling {
            grids: sides.iter().map(|s| s.grid.clone()).collect(),
            dofs: sides.iter().map(|s| s.dofs.clone()).collect(),
            offsets: offsets.to_vec(),
            pairs,
        }
    }

    fn body(&self, b: usize) -> ContactBody<'_> {
        ContactBody {
            grid: &self.grids[b],
            dofs: &self.dofs[b],
            offset: self.offsets[b],
        }
    }

    /// `Σ r` over body `b`'s dofs, per component.
    fn resultant(&self, b: usize, r: &[f64]) -> [f64; 3] {
        let body = &r[self.offsets[b]..self.offsets[b] + self.dofs[b].ndofs()];
        let mut sum = [0.0; 3];
        for node in body.chunks_exact(3) {
            (0..3).for_each(|c| sum[c] += node[c]);
        }
        sum
    }

    fn data<'a>(&'a self, p: &'a Pair) -> ContactPairData<'a> {
        ContactPairData {
            slave: self.body(p.slave),
            master: self.body(p.master),
            slave_points: &p.points,
            master_surface: &p.surface,
            penalty: p.penalty,
            young: p.young,
            search_radius: p.search_radius,
            friction: p.friction,
            curved: p.curved,
        }
    }

    /// Sets the pair's `T̂_N` from the slave body's recovered stress at `u`
    /// (module doc).
    fn refresh_pair(
        &self,
        p: &Pair,
        sampler: &StressSampler,
        body: &HyperProblem,
        u: &[f64],
    ) -> Result<()> {
        let mut h = p.history.lock().expect("contact history");
        let e = contact_residual(&self.data(p), u, &h);
        let active: Vec<usize> = (0..p.points.len())
            .filter(|&i| e.points[i].pressure > 0.0)
            .collect();
        let mut cells: Vec<usize> = active.iter().map(|&i| p.points[i].cell).collect();
        cells.sort_unstable();
        cells.dedup();
        let slave = &u[self.offsets[p.slave]..self.offsets[p.slave] + self.dofs[p.slave].ndofs()];
        let sigma = sampler.recover(body, slave, &cells)?;
        h.iter_mut().for_each(|x| x.recovered = 0.0);
        for i in active {
            let (x, n1) = (p.points[i].x, e.points[i].normal);
            let s = sigma.eval(p.points[i].cell, x)?;
            h[i].recovered = normal_traction(&s, n1).min(0.0);
        }
        Ok(())
    }
}

fn history(p: &Pair) -> Vec<PointHistory> {
    p.history.lock().expect("contact history").clone()
}

/// The pairs' tangents, summed.
struct Tangents(Vec<ContactTangent>);

impl CouplingTangent for Tangents {
    fn apply_add(&self, v: &[f64], out: &mut [f64]) {
        self.0.iter().for_each(|k| k.apply_add(v, out));
    }

    fn add_diagonal(&self, out: &mut [f64]) {
        self.0.iter().for_each(|k| k.add_diagonal(out));
    }
}

impl Coupling for ContactCoupling {
    fn residual_add(&self, u: &[f64], _t: f64, r: &mut [f64]) -> Option<()> {
        for p in &self.pairs {
            let e = contact_residual(&self.data(p), u, &history(p));
            r.iter_mut().zip(&e.residual).for_each(|(a, b)| *a += b);
        }
        Some(())
    }

    fn tangent<'a>(&'a self, u: &[f64], _t: f64) -> Option<Box<dyn CouplingTangent + 'a>> {
        let tangents = self
            .pairs
            .iter()
            .map(|p| {
                let e = contact_residual_and_tangent(&self.data(p), u, &history(p));
                // The patch each point hit at this iterate is the one it keeps
                // to until the next tangent (`MasterSurface::search_near`):
                // the residual at `u` is unchanged, and within a Newton
                // iteration every point stays on one smooth patch.
                let mut h = p.history.lock().expect("contact history");
                for (x, point) in h.iter_mut().zip(&e.points) {
                    x.patch = point.hit.map(|(t, _)| t);
                }
                e.tangent
            })
            .collect();
        Some(Box::new(Tangents(tangents)))
    }

    fn step_converged(&self, u: &[f64], step: usize) -> Vec<ContactRow> {
        self.pairs
            .iter()
            .map(|p| {
                let mut h = p.history.lock().expect("contact history");
                let e = contact_residual(&self.data(p), u, &h);
                let recovered: Vec<f64> = h.iter().map(|x| x.recovered).collect();
                *h = e.converged_history(&recovered);
                let force = |b: usize| self.resultant(b, &e.residual);
                let peak = recovered.iter().map(|t| -t).fold(0.0, f64::max);
                // Per point `J_s = w J_s / w`: the current weight over dΓ_0.
                let (mut area, mut nominal) = (0.0, 0.0f64);
                for ((q, s), t) in p.points.iter().zip(&e.points).zip(&recovered) {
                    let ratio = s.weight / q.weight;
                    if s.hit.is_some() && s.pressure > 0.0 {
                        area += q.weight;
                    }
                    nominal = nominal.max(-t * ratio);
                }
                e.contact_row(&p.name, step)
                    .with_forces(force(p.slave), force(p.master))
                    .with_recovered_peak(peak)
                    .with_reference_measures(area, nominal)
            })
            .collect()
    }

    fn contact_points(&self, u: &[f64]) -> Vec<ContactPoints> {
        self.pairs
            .iter()
            .map(|p| {
                let h = history(p);
                contact_residual(&self.data(p), u, &h).contact_points(&p.name, &h)
            })
            .collect()
    }

    fn refresh_recovered(&self, bodies: &[HyperProblem], u: &[f64], _t: f64) -> Result<bool> {
        let mut any = false;
        for p in &self.pairs {
            if let Some(sampler) = &p.sampler {
                self.refresh_pair(p, sampler, &bodies[p.slave], u)?;
                any = true;
            }
        }
        Ok(any)
    }
}
