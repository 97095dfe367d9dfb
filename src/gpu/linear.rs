//! [`GpuSolver`]: the [`LinearSolver`] of the fixed-point loop on the GPU. The
//! operator and its diagonal are uploaded once; each solve writes the
//! right-hand side and the warm start into device vectors kept between
//! solves and reads the solution back (through the backend's staging
//! buffers, [`super::staging`]).
//!
//! - f64 device: CG, CGS and BiCGStab with device scalars
//!   ([`super::device_krylov`]) by default, or the generic
//!   [`crate::solver::solve`] with host scalars ([`Scalars::Host`]);
//! - f32 device: f32 inner solves in f64 defect correction ([`super::defect`]);
//! - with a multigrid hierarchy (f64 device, `preconditioner = "multigrid"`
//!   or `"auto"`): the generic solver preconditioned by the V-cycle on the
//!   device ([`super::multigrid`]).

use std::sync::Arc;

use crate::backend::Backend;
use crate::driver::linear::LinearSolver;
use crate::driver::setup::Setup;
use crate::error::{Error, Result};
use crate::fem::operator::ElasticOperator;
use crate::solver::Preconditioner;
use crate::solver::{solve, solve_preconditioned, KrylovOptions, KrylovStats};

use super::backend::{GpuBackend, GpuVector};
use super::context::{GpuContext, Precision};
use super::defect::solve_defect_correction;
use super::device_krylov::{solve_device, DeviceOptions};
use super::multigrid::DeviceMultigrid;
use super::operator::GpuOperator;

/// Where the Krylov scalars of an f64 solve live.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Scalars {
    /// α, β, … on the host: one read-back per dot product.
    Host,
    /// On the device, the residual read back every few iterations (CG, CGS).
    #[default]
    Device,
}

/// The GPU linear solver of a run.
pub struct GpuSolver<'o> {
    be: GpuBackend,
    op: GpuOperator<'o>,
    diag: GpuVector,
    scalars: Scalars,
    multigrid: Option<DeviceMultigrid<'o>>,
    /// The right-hand side and solution on the device, kept between solves.
    b: GpuVector,
    x: GpuVector,
}

impl<'o> GpuSolver<'o> {
    /// Uploads `op` and its diagonal to the device of `ctx`
    /// ([`crate::error::Error::DeviceTooSmall`] when it does not fit).
    pub fn new(ctx: Arc<GpuContext>, op: &'o ElasticOperator, scalars: Scalars) -> Result<Self> {
        let be = GpuBackend::new(ctx);
        let dop = GpuOperator::new(&be, op)?;
        Ok(Self::with_operator(be, dop, scalars))
    }

    /// The solver of a set-up's operator on `be`, with its multigrid
    /// hierarchy on the device when the set-up built one and the device
    /// computes in f64. A hierarchy the device cannot hold is
    /// [`crate::error::Error::DeviceTooSmall`], unless `jacobi_instead`
    /// (the case said `"auto"`): then the solver has no hierarchy and the
    /// error comes back beside it, for a note (solve with Jacobi).
    pub fn for_setup(
        be: GpuBackend,
        setup: &'o Setup,
        scalars: Scalars,
        jacobi_instead: bool,
    ) -> Result<(Self, Option<Error>)> {
        let op = GpuOperator::new(&be, &setup.op)?;
        let mut solver = Self::with_operator(be, op, scalars);
        let Some(h) = setup.multigrid.as_ref() else {
            return Ok((solver, None));
        };
        if solver.be.precision() == Precision::F64 {
            match DeviceMultigrid::new(&solver.be, &setup.op, h) {
                Ok(mg) => solver.multigrid = Some(mg),
                Err(e @ Error::DeviceTooSmall { .. }) if jacobi_instead => {
                    return Ok((solver, Some(e)))
                }
                Err(e) => return Err(e),
            }
        }
        Ok((solver, None))
    }

    /// The solver over an operator already uploaded to `be` (tests give
    /// both with a lowered binding size).
    pub fn with_operator(be: GpuBackend, op: GpuOperator<'o>, scalars: Scalars) -> Self {
        let diag = be.diagonal(&op);
        let n = op.nrows();
        let (b, x) = (be.zeros(n), be.zeros(n));
        GpuSolver {
            b,
            x,
            be,
            op,
            diag,
            scalars,
            multigrid: None,
        }
    }

    /// The backend (its name and precision go into the report).
    pub fn backend(&self) -> &GpuBackend {
        &self.be
    }
}

impl LinearSolver for GpuSolver<'_> {
    fn solve(
        &mut self,
        rhs: &[f64],
        u: &mut Vec<f64>,
        opts: &KrylovOptions,
    ) -> Result<KrylovStats> {
        let (be, op, diag) = (&self.be, &self.op, Some(&self.diag));
        if be.precision() == Precision::F32 {
            return solve_defect_correction(be, op, diag, op.host(), rhs, u, opts);
        }
        let (b, x) = (&mut self.b, &mut self.x);
        // The phases' seconds, waited for, only when they are logged.
        let timed = tracing::enabled!(tracing::Level::DEBUG);
        let t = std::time::Instant::now();
        be.write_vector(rhs, b);
        match u.iter().all(|&v| v == 0.0) {
            true => be.clear_vector(x),
            false => be.write_vector(u, x),
        }
        let with_multigrid = matches!(
            opts.preconditioner,
            Preconditioner::Multigrid | Preconditioner::Auto
        );
        if timed {
            be.finish();
        }
        let written = t.elapsed().as_secs_f64();
        let device = self.scalars == Scalars::Device;
        let result = match &self.multigrid {
            Some(mg) if with_multigrid => {
                solve_preconditioned(be, op, &mg.cycle(be, op), b, x, opts)
            }
            _ if device => solve_device(be, op, diag, b, x, opts, &DeviceOptions::default()),
            _ => solve(be, op, diag, b, x, opts),
        };
        if timed {
            be.finish();
        }
        let solved = t.elapsed().as_secs_f64();
        be.read_vector(x, u);
        tracing::debug!(
            written,
            solved = solved - written,
            read = t.elapsed().as_secs_f64() - solved,
            "gpu solve: seconds to write b and x, solve, read x"
        );
        result
    }
}
