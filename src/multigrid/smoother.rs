//! The smoother of every level but the coarsest: Chebyshev iteration over the
//! preconditioned operator `B⁻¹A`, `B` Jacobi inside the body and block
//! Jacobi on the cut band ([`super::blocks`]; `B = D = diag A`, floored as
//! the Jacobi preconditioner floors it, [`crate::solver::floor_diagonal`],
//! where there are no cut cells).
//!
//! # The polynomial
//! With the eigenvalues of `B⁻¹A` taken in `[a, b]`, `θ = (b + a)/2`,
//! `δ = (b − a)/2`, `σ = θ/δ`, one smoothing step of degree `k` from `x`
//! (Saad, *Iterative Methods*, Alg. 12.1 with the preconditioner `B⁻¹`) is
//!
//! ```text
//! r = b − A x;  d = B⁻¹ r / θ;  x = x + d;  ρ = 1/σ
//! repeat k − 1 times:
//!     r = r − A d;  ρ' = 1/(2σ − ρ)
//!     d = ρ'ρ d + (2ρ'/δ) B⁻¹ r;  x = x + d;  ρ = ρ'
//! ```
//! so that the error goes to `E e`, `E = T_k((θ − B⁻¹A)/δ) / T_k(σ)`: small
//! over `[a, b]` (the high frequencies the coarse grid cannot see), at most 1
//! over `(0, b]`. `E = I − N A` with `N = q(B⁻¹A) B⁻¹` symmetric (`B`
//! symmetric positive definite), so the step is self-adjoint in the energy
//! product and the same step before and after the coarse correction makes a
//! symmetric V-cycle.
//!
//! # The interval
//! `b = 1.2 λ̃` where `λ̃` is the largest Ritz value of [`LANCZOS_STEPS`]
//! Lanczos steps on `B⁻¹A` in the `B` inner product (a lower bound of
//! `λ_max`, the margin covers the gap), and `a = b / SMOOTHING_RANGE`, as
//! deal.II's `PreconditionChebyshev` (step-37) does. With `b ≥ λ_max`,
//! `|E| ≤ 1` on the whole spectrum: the smoother never amplifies an error
//! component.
//!
//! The vector kernels are explicit loops over fixed chunks, as the CPU
//! backend's are, so that WGSL kernels can mirror them.

use rayon::prelude::*;

use super::blocks::BlockJacobi;
use crate::backend::{CpuBackend, LinearOperator};
use crate::comm::{agree, Comm, Serial};
use crate::discrete::dofs::DofMap;
use crate::error::{Error, Result};
use crate::fem::operator::ElasticOperator;
use crate::solver::floor_diagonal_against;
use crate::solver::lanczos::{largest_eigenvalue, PreconditionedOperator};

/// Default degree `k` of the Chebyshev polynomial (applies of `A` per smoothing step,
/// counting the residual of a non-zero start).
pub const DEGREE: usize = 4;

/// `b / a`: the part of the spectrum of `B⁻¹A` the smoother damps.
pub const SMOOTHING_RANGE: f64 = 15.0;

/// Lanczos steps for the estimate of `λ_max(B⁻¹A)`.
pub const LANCZOS_STEPS: usize = 12;

/// Safety factor on the largest Ritz value.
const EIGENVALUE_MARGIN: f64 = 1.2;

/// Entries per parallel task of the vector kernels.
const CHUNK: usize = 8192;

/// The Chebyshev smoother of one level.
pub struct Chebyshev {
    pub(crate) pre: BlockJacobi,
    /// Degree `k` of the polynomial.
    pub(crate) degree: usize,
    /// The interval `[a, b]` of `B⁻¹A` it damps.
    pub lo: f64,
    pub hi: f64,
    /// Jacobi diagonal entries at round-off level that were floored.
    pub floored: usize,
}

/// A level as its smoother's set-up sees it: the whole operator on one
/// process ([`Whole`]), or one rank's share of it
/// (`crate::distributed::multigrid`), whose vectors keep their ghost
/// entries at zero and whose products are collective.
pub trait LevelShare {
    /// The ranks sharing the level.
    fn comm(&self) -> &dyn Comm;
    /// Whether local node `a` is this rank's own (its rows count).
    fn owns(&self, a: usize) -> bool;
    /// `y = A x`. Collective.
    fn apply(&self, x: &[f64], y: &mut [f64]);
    /// `z = B⁻¹ r` with `pre`. Collective.
    fn precondition(&self, pre: &BlockJacobi, r: &[f64], z: &mut [f64]);
}

/// A level operator on one process: every node its own.
pub struct Whole<'a>(pub &'a ElasticOperator);

impl LevelShare for Whole<'_> {
    fn comm(&self) -> &dyn Comm {
        &Serial
    }

    fn owns(&self, _a: usize) -> bool {
        true
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.0.apply(x, y);
    }

    fn precondition(&self, pre: &BlockJacobi, r: &[f64], z: &mut [f64]) {
        pre.apply(r, z);
    }
}

/// The start of the Lanczos estimate on a level with unknowns `dofs`: every
/// entry non-zero, with no grid-aligned pattern, a function of the lattice
/// node and component alone (so that every rank's share of a level starts
/// from the entries the whole level starts from).
pub fn lanczos_start(dofs: &DofMap) -> Vec<f64> {
    dofs.active_to_node
        .iter()
        .flat_map(|&node| {
            (0..3).map(move |c| {
                let i = 3 * node as usize + c;
                1.0 + 0.5 * ((i as f64 + 1.0) * 0.618_033_988_749_895).fract()
            })
        })
        .collect()
}

impl Chebyshev {
    /// The smoother of `op`: its block Jacobi preconditioner over the
    /// floored diagonal and the interval from a Lanczos estimate (module
    /// doc). A diagonal entry that is not finite or is negative beyond the
    /// floor is a breakdown.
    pub fn new(op: &ElasticOperator, degree: usize) -> Result<Chebyshev> {
        Chebyshev::on(op, &Whole(op), degree)
    }

    /// The smoother of `op`, a level as `share` sees it: the floor and the
    /// interval are the whole level's; the blocks are `op`'s own.
    /// Collective where `share` is.
    pub fn on(op: &ElasticOperator, share: &dyn LevelShare, degree: usize) -> Result<Chebyshev> {
        assert!(degree >= 1, "Chebyshev smoother of degree 0");
        let mut d = op.diagonal();
        let (mut largest, mut owned) = (0.0_f64, 0);
        for (a, node) in d.chunks_exact_mut(3).enumerate() {
            match share.owns(a) {
                true => {
                    largest = node.iter().fold(largest, |m, v| m.max(v.abs()));
                    owned += 3;
                }
                false => node.fill(1.0),
            }
        }
        let comm = share.comm();
        let cpu = CpuBackend::new();
        let floored = floor_diagonal_against(&mut d, true, comm.max(largest)).map_err(|(i, v)| {
            Error::Breakdown {
                method: "multigrid".into(),
                iterations: 0,
                what: format!("smoother: diagonal entry {i} of a level operator is {v:e}"),
            }
        });
        let floored = agree(comm, floored)?;
        let inv_diag: Vec<f64> = d.iter().map(|v| 1.0 / v).collect();
        let pre = BlockJacobi::new(op, &inv_diag);
        let mut start = lanczos_start(&op.dofs);
        for (a, node) in start.chunks_exact_mut(3).enumerate() {
            if !share.owns(a) {
                node.fill(0.0);
            }
        }
        let ops = PreconditionedOperator {
            apply: &|x, y| share.apply(x, y),
            pre: &|r, z| share.precondition(&pre, r, z),
            dot: &|a, b| cpu.total_dot(comm, a, b),
        };
        let mut rows = [owned as f64];
        comm.sum(&mut rows);
        let steps = LANCZOS_STEPS.min(rows[0] as usize);
        let lambda = largest_eigenvalue(&ops, start, steps);
        if !(lambda.is_finite() && lambda > 0.0) {
            return Err(Error::Breakdown {
                method: "multigrid".into(),
                iterations: 0,
                what: format!("smoother: the Lanczos estimate of λ_max(B⁻¹A) is {lambda:e}"),
            });
        }
        let hi = EIGENVALUE_MARGIN * lambda;
        Ok(Chebyshev {
            pre,
            degree,
            lo: hi / SMOOTHING_RANGE,
            hi,
            floored,
        })
    }

    /// The cut-band blocks of its preconditioner and the unknowns they hold.
    pub fn block_sizes(&self) -> (usize, usize) {
        self.pre.block_sizes()
    }
}

/// The coefficients `(a, c)` of the `degree` updates `d = a d + c B⁻¹r`
/// of one smoothing step over the interval `[lo, hi]` (module doc): `(0,
/// 1/θ)` first, then `(ρ'ρ, 2ρ'/δ)` with `ρ' = 1/(2σ − ρ)`. Every backend's
/// step takes them from here ([`super::cycle`]; the device keeps them in a
/// buffer per level).
pub fn chebyshev_coefficients(lo: f64, hi: f64, degree: usize) -> Vec<(f64, f64)> {
    let theta = 0.5 * (hi + lo);
    let delta = 0.5 * (hi - lo);
    let sigma = theta / delta;
    let mut out = vec![(0.0, 1.0 / theta)];
    let mut rho = 1.0 / sigma;
    for _ in 1..degree {
        let rho_next = 1.0 / (2.0 * sigma - rho);
        out.push((rho_next * rho, 2.0 * rho_next / delta));
        rho = rho_next;
    }
    out
}

/// `d = a d + c z` (`z = B⁻¹ r`), then `x = x + d`, entry by entry.
pub(crate) fn chebyshev_update(a: f64, c: f64, z: &[f64], d: &mut [f64], x: &mut [f64]) {
    d.par_chunks_mut(CHUNK)
        .zip(x.par_chunks_mut(CHUNK))
        .enumerate()
        .for_each(|(t, (dc, xc))| {
            let base = t * CHUNK;
            for i in 0..dc.len() {
                let di = a * dc[i] + c * z[base + i];
                dc[i] = di;
                xc[i] += di;
            }
        });
}

/// `r = r − v`.
pub(crate) fn sub_assign(r: &mut [f64], v: &[f64]) {
    r.par_chunks_mut(CHUNK).enumerate().for_each(|(t, rc)| {
        let base = t * CHUNK;
        for i in 0..rc.len() {
            rc[i] -= v[base + i];
        }
    });
}

/// `r = b − r`.
pub(crate) fn rsub_assign(r: &mut [f64], b: &[f64]) {
    r.par_chunks_mut(CHUNK).enumerate().for_each(|(t, rc)| {
        let base = t * CHUNK;
        for i in 0..rc.len() {
            rc[i] = b[base + i] - rc[i];
        }
    });
}
