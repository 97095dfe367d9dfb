//! The stacked problem of several bodies: the unknowns `[u_1; u_2; …]` (body
//! `b`'s dofs at `offsets[b]..offsets[b+1]`), the residual and tangent of
//! each body on its slice, an optional [`Coupling`] between them (contact),
//! and dofs held at zero (the `u_z` of plane-strain slabs):
//! ```text
//! R(u, t) = [R_1(u_1, t); …; R_n(u_n, t)] + R_c(u, t)
//! K(u, t) = blockdiag(K_1(u_1), …, K_n(u_n)) + K_c(u, t)
//! ```
//! A held dof `d` has `R_d = 0` and the row and column of the identity in
//! `K`, so every Newton correction leaves it at its start value 0.

use std::borrow::Cow;
use std::sync::Arc;

use crate::backend::LinearOperator;
use crate::contact::{ContactPoints, ContactRow, ContactTangent};
use crate::error::Result;
use crate::gpu::GpuContext;
use crate::hyper::gpu::GpuHyperBody;
use crate::hyper::newton::NonlinearProblem;
use crate::hyper::problem::HyperProblem;
use crate::hyper::tangent::TangentOperator;

/// The tangent of a [`Coupling`] on the stacked vector.
pub trait CouplingTangent {
    /// `out += K_c v`.
    fn apply_add(&self, v: &[f64], out: &mut [f64]);
    /// `out += diag(K_c)`.
    fn add_diagonal(&self, out: &mut [f64]);
}

/// The factored contact tangent of [`crate::contact::enforce`].
impl CouplingTangent for ContactTangent {
    fn apply_add(&self, v: &[f64], out: &mut [f64]) {
        ContactTangent::apply_add(self, v, out)
    }

    fn add_diagonal(&self, out: &mut [f64]) {
        ContactTangent::add_diagonal(self, out)
    }
}

/// A coupling tangent given by its entries `(row, column, value)`
/// (duplicates summed).
pub struct Triplets(pub Vec<(usize, usize, f64)>);

impl CouplingTangent for Triplets {
    fn apply_add(&self, v: &[f64], out: &mut [f64]) {
        for &(i, j, a) in &self.0 {
            out[i] += a * v[j];
        }
    }

    fn add_diagonal(&self, out: &mut [f64]) {
        for &(i, j, a) in &self.0 {
            if i == j {
                out[i] += a;
            }
        }
    }
}

/// A term that couples the bodies (the contact enforcement), on the stacked
/// dof vector of a [`BodiesProblem`] (body `b`'s dofs from `offsets[b]`, as
/// [`crate::contact::enforce::ContactBody::offset`] expects).
pub trait Coupling: Sync {
    /// `r += R_c(u, t)`; `None` where `u` is inadmissible for the coupling.
    fn residual_add(&self, u: &[f64], t: f64, r: &mut [f64]) -> Option<()>;
    /// `K_c = ∂R_c/∂u` at `u`.
    fn tangent<'a>(&'a self, u: &[f64], t: f64) -> Option<Box<dyn CouplingTangent + 'a>>;
    /// Load step `step` (from 1) converged at `u`: update what the coupling
    /// carries between steps (friction anchors, say; hence `&self` with
    /// interior mutability) and return the report's rows for the step.
    fn step_converged(&self, _u: &[f64], _step: usize) -> Vec<ContactRow> {
        Vec::new()
    }
    /// The contact points at a converged `u`, per pair, for the ParaView
    /// output (call before [`Coupling::step_converged`] advances the
    /// histories).
    fn contact_points(&self, _u: &[f64]) -> Vec<ContactPoints> {
        Vec::new()
    }
    /// Re-evaluates at `u` the terms the coupling recovers from the solution
    /// and holds fixed in `R_c` and `K_c` (the recovered normal traction);
    /// `false` when it has none (see [`NonlinearProblem::refresh_recovered`]).
    fn refresh_recovered(&self, _bodies: &[HyperProblem], _u: &[f64], _t: f64) -> Result<bool> {
        Ok(false)
    }
}

/// The bodies, stacked.
pub struct BodiesProblem {
    pub bodies: Vec<HyperProblem>,
    /// `offsets[b]` is body `b`'s first dof; the last entry is the total.
    pub offsets: Vec<usize>,
    /// Per dof: held at zero.
    held: Vec<bool>,
    coupling: Option<Box<dyn Coupling>>,
    /// Per body its device side of the tangent (empty: the CPU tangent).
    devices: Vec<GpuHyperBody>,
}

impl BodiesProblem {
    /// The bodies without coupling and with no held dofs.
    pub fn new(bodies: Vec<HyperProblem>) -> BodiesProblem {
        let mut offsets = vec![0];
        for b in &bodies {
            offsets.push(offsets.last().copied().unwrap_or(0) + b.ndofs());
        }
        let n = offsets.last().copied().unwrap_or(0);
        BodiesProblem {
            bodies,
            offsets,
            held: vec![false; n],
            coupling: None,
            devices: Vec::new(),
        }
    }

    /// Holds dof `d` of body `b` at zero.
    pub fn hold(&mut self, b: usize, d: usize) {
        self.held[self.offsets[b] + d] = true;
    }

    /// Per dof: held at zero.
    pub fn held(&self) -> &[bool] {
        &self.held
    }

    /// Number of held dofs.
    pub fn num_held(&self) -> usize {
        self.held.iter().filter(|&&h| h).count()
    }

    /// Adds the coupling term.
    pub fn set_coupling(&mut self, coupling: Box<dyn Coupling>) {
        self.coupling = Some(coupling);
    }

    /// Puts the bodies' inside-cell tangents on the device of `ctx`
    /// ([`GpuHyperBody`]); the cut cells and the coupling stay on the CPU.
    pub fn use_device(&mut self, ctx: Arc<GpuContext>) -> Result<()> {
        self.devices = self
            .bodies
            .iter()
            .map(|b| GpuHyperBody::new(ctx.clone(), b))
            .collect::<Result<_>>()?;
        Ok(())
    }

    /// The adapter the tangents run on, if any.
    pub fn device_name(&self) -> Option<&str> {
        self.devices.first().map(GpuHyperBody::adapter)
    }

    /// The coupling's contact points at `u` (none without a coupling).
    pub fn contact_points(&self, u: &[f64]) -> Vec<ContactPoints> {
        self.coupling
            .as_ref()
            .map_or_else(Vec::new, |c| c.contact_points(u))
    }

    /// Tells the coupling that load step `step` converged at `u`; its rows.
    pub fn step_converged(&self, u: &[f64], step: usize) -> Vec<ContactRow> {
        self.coupling
            .as_ref()
            .map_or_else(Vec::new, |c| c.step_converged(u, step))
    }

    /// Body `b`'s part of a stacked vector.
    pub fn part<'v>(&self, b: usize, u: &'v [f64]) -> &'v [f64] {
        &u[self.offsets[b]..self.offsets[b + 1]]
    }

    fn zero_held(&self, v: &mut [f64]) {
        for (x, &h) in v.iter_mut().zip(&self.held) {
            if h {
                *x = 0.0;
            }
        }
    }
}

impl NonlinearProblem for BodiesProblem {
    fn ndofs(&self) -> usize {
        self.held.len()
    }

    fn residual(&self, u: &[f64], t: f64) -> Option<Vec<f64>> {
        let mut r = Vec::with_capacity(u.len());
        for (b, body) in self.bodies.iter().enumerate() {
            r.extend(crate::hyper::residual::residual(body, self.part(b, u), t)?);
        }
        if let Some(c) = &self.coupling {
            c.residual_add(u, t, &mut r)?;
        }
        self.zero_held(&mut r);
        Some(r)
    }

    /// Every body's S-term and the coupling's recovered terms, all of them
    /// (no short cut): `true` when any has some.
    fn refresh_recovered(&self, u: &[f64], t: f64) -> Result<bool> {
        let mut any = false;
        for (b, body) in self.bodies.iter().enumerate() {
            any |= body.refresh_s_term(self.part(b, u))?;
        }
        let coupling = match &self.coupling {
            Some(c) => c.refresh_recovered(&self.bodies, u, t)?,
            None => false,
        };
        Ok(any || coupling)
    }

    fn tangent<'a>(&'a self, u: &[f64], t: f64) -> Option<Box<dyn LinearOperator + 'a>> {
        let mut blocks: Vec<Box<dyn LinearOperator + 'a>> = Vec::new();
        for (b, body) in self.bodies.iter().enumerate() {
            let k = TangentOperator::new(body, self.part(b, u))?;
            blocks.push(match self.devices.get(b) {
                Some(d) => Box::new(d.bind(k)),
                None => Box::new(k),
            });
        }
        let coupling = match &self.coupling {
            Some(c) => Some(c.tangent(u, t)?),
            None => None,
        };
        Some(Box::new(BodiesTangent {
            problem: self,
            blocks,
            coupling,
        }))
    }
}

/// `K(u, t)` of a [`BodiesProblem`]: the bodies' matrix-free tangents on the
/// diagonal blocks, the coupling's tangent, identity rows and columns on held
/// dofs (the coupling sees held entries of `v` as zero, and its rows there
/// are replaced).
pub struct BodiesTangent<'p> {
    problem: &'p BodiesProblem,
    blocks: Vec<Box<dyn LinearOperator + 'p>>,
    coupling: Option<Box<dyn CouplingTangent + 'p>>,
}

impl LinearOperator for BodiesTangent<'_> {
    fn nrows(&self) -> usize {
        self.problem.ndofs()
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let p = self.problem;
        let free: Cow<[f64]> = match p.held.iter().any(|&h| h) {
            true => {
                let mut v = x.to_vec();
                p.zero_held(&mut v);
                Cow::Owned(v)
            }
            false => Cow::Borrowed(x),
        };
        for (b, k) in self.blocks.iter().enumerate() {
            let range = p.offsets[b]..p.offsets[b + 1];
            k.apply(&free[range.clone()], &mut y[range]);
        }
        if let Some(c) = &self.coupling {
            c.apply_add(&free, y);
        }
        for (d, &h) in p.held.iter().enumerate() {
            if h {
                y[d] = x[d];
            }
        }
    }

    fn diagonal(&self) -> Vec<f64> {
        let mut d: Vec<f64> = self.blocks.iter().flat_map(|k| k.diagonal()).collect();
        if let Some(c) = &self.coupling {
            c.add_diagonal(&mut d);
        }
        for (x, &h) in d.iter_mut().zip(&self.problem.held) {
            if h {
                *x = 1.0;
            }
        }
        d
    }
}
