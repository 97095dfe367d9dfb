//! CG's iteration in four dispatches on the device ([`FusedCg`]), their
//! bind groups made once per solve:
//! `q1_cells`; `q1_nodes`' dot variant, which also sums `p · Ap` per
//! workgroup; `cg_update`, whose every workgroup reduces those sums itself to
//! take α (no scalar kernel between), steps `x`, `r`, `z` and sums
//! `(r · r, r · z)` per workgroup; `cg_direction`, whose every workgroup
//! reduces those to take β and set `p`, and whose first does the check. The
//! iteration's scalars live in the slots of a [`CgSlots`]; ρ alternates
//! between two so that no workgroup reads a slot another writes. Used by
//! [`super::device_krylov`] where the operator runs on the Q1 plan and the
//! vectors fit one binding.

use super::backend::GpuBackend;
use super::kernels::{reduction_groups, DirectionParams, UpdateParams};
use super::q1_operator::Q1Device;
use super::record::Prepared;

/// The device scalars of the fused CG iteration: ρ alternates between
/// `rho[0]` (read at even iterations) and `rho[1]`; α and −α at `alpha`,
/// `alpha + 1`.
#[derive(Clone, Copy, Debug)]
pub(super) struct CgSlots {
    pub tol2: u32,
    pub done: u32,
    pub iters: u32,
    pub rho: [u32; 2],
    pub alpha: u32,
    pub beta: u32,
    pub rr: u32,
    pub bad: u32,
    pub broke: u32,
}

/// The params of iteration `k`'s `cg_update` and `cg_direction` over `n`
/// entries with `terms` partials of `p · Ap` at the start of the partials
/// and `cg_update`'s pairs after them.
pub(super) fn fused_params(
    s: &CgSlots,
    k: usize,
    n: usize,
    terms: u32,
    precond: bool,
) -> (UpdateParams, DirectionParams) {
    let (rho_old, rho_new) = (s.rho[k % 2], s.rho[(k + 1) % 2]);
    let groups = reduction_groups(n as u32);
    let step = UpdateParams {
        n: n as u32,
        groups,
        ia: s.alpha,
        ib: s.alpha + 1,
        precond: u32::from(precond),
        terms,
        rho: rho_old,
        done: s.done,
        bad: s.bad,
        broke: s.broke,
        base: terms,
        ..Default::default()
    };
    let direction = DirectionParams {
        n: n as u32,
        groups,
        terms: groups,
        base: terms,
        rr: s.rr,
        rho_old,
        rho_new,
        beta: s.beta,
        done: s.done,
        iters: s.iters,
        tol2: s.tol2,
        bad: s.bad,
        broke: s.broke,
        ..Default::default()
    };
    (step, direction)
}

/// CG's iteration in four dispatches, prepared once for a solve's vectors
/// and recorded any number of times: `q1_cells`, `q1_nodes` with `p · Ap`'s
/// partials, `cg_update` (α from them), `cg_direction` (`p = z + β p` and
/// the check), for each parity of ρ's slots.
pub(super) struct FusedCg {
    iterations: [[Prepared; 4]; 2],
}

impl FusedCg {
    /// The iteration over the `n` entries of the vectors `[p, q, x, r, z]`;
    /// `z` is `d ∘ r` where `d` is given, else `r` stands in for it.
    /// `partials` holds `q1.node_groups()` and then twice
    /// `reduction_groups(n)` entries.
    pub(super) fn new(
        be: &GpuBackend,
        q1: &Q1Device,
        partials: &wgpu::Buffer,
        slots: &CgSlots,
        n: usize,
        [p, q, x, r, z]: [&wgpu::Buffer; 5],
        d: Option<&wgpu::Buffer>,
    ) -> FusedCg {
        let zr = if d.is_some() { z } else { r };
        let parity = |k: usize| {
            let (step, direction) = fused_params(slots, k, n, q1.node_groups(), d.is_some());
            let [cells, nodes] = q1.prepare_dot(be, p, q, partials);
            [
                cells,
                nodes,
                be.prepare_cg_step(n, [p, q, x, r, z], d, step, partials),
                be.prepare_cg_direction(n, direction, partials, [zr, p]),
            ]
        };
        FusedCg {
            iterations: [parity(0), parity(1)],
        }
    }

    /// Records iteration `k`.
    pub(super) fn record(&self, be: &GpuBackend, enc: &mut wgpu::CommandEncoder, k: usize) {
        for prepared in &self.iterations[k % 2] {
            be.record_prepared(enc, prepared);
        }
    }
}
