//! GPU rows of `cgfem-gpu bench`: on the first adapter found (the preferred
//! one, as `run --backend gpu` picks it), per precision it offers (f64 where
//! it has `SHADER_F64`, and f32):
//! - `bandwidth`: the device copy kernel over one storage binding's worth of
//!   entries (at most 2^24), `bytes_per_dof` = bytes read + written per entry;
//! - `apply`: the device-resident operator as runs pick it (the Q1 plan,
//!   [`crate::gpu::q1_operator`], where it applies), `y = A x`, waited for;
//!   `bytes_per_dof` is the traffic model's bytes moved per dof
//!   ([`crate::gpu::q1_operator::Q1Device::modelled_traffic`]);
//! - `q1_cells`, `q1_nodes`: the Q1 plan's two kernels timed apart;
//! - `apply_gather`: the node-centred gather of `apply.wgsl` on the same
//!   operator, `bytes_per_dof` its data plus `x` and `y` (what it would move
//!   if every cached re-read were free);
//! - `cg_iter`, `cgs_iter`: `(t(K+2) − t(2)) / K` of device-scalar iterations
//!   ([`crate::gpu::device_krylov::run_iterations`]), residual read back at the
//!   end of each run; the dispatches per iteration go to stderr;
//! - `vcycle` (f64): one multigrid V-cycle on the device
//!   ([`crate::gpu::multigrid`]) over the hierarchy a run would build, its
//!   levels and dispatches to stderr.
//!
//! No adapter is not an error here: the bench says so and has no GPU rows.

use std::sync::Arc;

use super::{peak_resident_bytes, seconds_per_call, BenchOptions, Row};
use crate::backend::Backend;
use crate::case::Case;
use crate::driver::setup::Setup;
use crate::error::{Error, Result};
use crate::fem::operator::ElasticOperator;
use crate::gpu::device_krylov::run_iterations;
use crate::gpu::multigrid::DeviceMultigrid;
use crate::gpu::q1_operator::Q1Kernel;
use crate::gpu::{GpuBackend, GpuContext, GpuOperator, GpuVector, Precision, PrecisionChoice};
use crate::multigrid::{Hierarchy, MultigridOptions};
use crate::solver::{ApplyInverse, KrylovMethod};

/// Iterations timed per method (beyond the 2 subtracted).
const ITERATIONS: usize = 10;

/// The precisions to bench on the preferred adapter, each with its backend;
/// empty (with a notice) when there is no adapter.
pub fn backends() -> Vec<GpuBackend> {
    let mut out = Vec::new();
    for choice in [PrecisionChoice::Auto, PrecisionChoice::F32] {
        match GpuContext::new(None, choice) {
            Ok(ctx) => {
                let dup = out
                    .iter()
                    .any(|b: &GpuBackend| b.precision() == ctx.precision);
                if !dup {
                    out.push(GpuBackend::new(Arc::new(ctx)));
                }
            }
            Err(Error::NoAdapter { .. }) => {
                eprintln!("bench: no GPU adapter; GPU rows skipped");
                break;
            }
            Err(e) => eprintln!("bench: GPU at {choice:?} precision skipped: {e}"),
        }
    }
    out
}

fn name(be: &GpuBackend) -> String {
    format!("gpu:{}", be.context().adapter.name)
}

fn precision(be: &GpuBackend) -> &'static str {
    match be.precision() {
        Precision::F64 => "f64",
        Precision::F32 => "f32",
    }
}

fn row(be: &GpuBackend, what: &str, level: u32, dofs: usize, seconds: f64) -> Row {
    Row {
        what: what.into(),
        backend: name(be),
        element: "q1".into(),
        precision: precision(be).into(),
        level,
        dofs,
        dofs_per_s: dofs as f64 / seconds,
        bytes_per_dof: 0.0,
        threads: 1,
        seconds,
        peak_bytes: peak_resident_bytes(),
        iterations: None,
    }
}

/// The copy-kernel bandwidth row of `be`.
pub fn bandwidth(be: &GpuBackend, budget: f64) -> Row {
    let n = be.context().max_binding_entries().min(1 << 24) as usize;
    let src = be.upload(&vec![1.0; n]);
    let mut dst = be.zeros(n);
    let seconds = seconds_per_call(budget, || {
        be.copy(&src, &mut dst);
        be.finish();
    });
    Row {
        element: "-".into(),
        bytes_per_dof: 2.0 * be.precision().bytes() as f64,
        ..row(be, "bandwidth", 0, n, seconds)
    }
}

/// Apply and iteration rows of `be` on the set-up sphere (`case`), and in
/// f64 the row of one multigrid V-cycle on the device.
pub fn throughput(
    be: &GpuBackend,
    case: &Case,
    setup: &Setup,
    opts: &BenchOptions,
) -> Result<Vec<Row>> {
    let level = setup.grid.level;
    let op = GpuOperator::new(be, &setup.op)?;
    let n = be.nrows(&op);
    let host: Vec<f64> = (0..n)
        .map(|i| ((i * 7919) % 1000) as f64 / 500.0 - 1.0)
        .collect();
    let x = be.upload(&host);
    let mut y = be.zeros(n);
    let vb = be.precision().bytes();
    let gather_bytes = (device_operator_bytes(be, &setup.op) + 2 * vb as usize * n) as f64;
    let bytes_per_dof = match op.q1() {
        Some(q1) => q1.modelled_traffic(vb) as f64 / n as f64,
        None => gather_bytes / n as f64,
    };
    let apply = seconds_per_call(opts.budget, || {
        be.apply(&op, &x, &mut y);
        be.finish();
    });
    let mut rows = vec![Row {
        bytes_per_dof,
        ..row(be, "apply", level, n, apply)
    }];
    if let Some(q1) = op.q1() {
        for (what, kernel) in [("q1_cells", Q1Kernel::Cells), ("q1_nodes", Q1Kernel::Nodes)] {
            let seconds = seconds_per_call(opts.budget / 2.0, || {
                be.apply_q1_kernel(q1, kernel, &x, &y);
                be.finish();
            });
            rows.push(row(be, what, level, n, seconds));
        }
        let p = q1.params();
        eprintln!(
            "bench: level {level}: {} interior segments, {} boundary nodes, {} cut and {} rim cells",
            p.n_segments,
            p.n_boundary,
            p.n_cut,
            p.n_cells - p.n_cut
        );
        let gather = GpuOperator::new_gather(be, &setup.op)?;
        let seconds = seconds_per_call(opts.budget, || {
            be.apply(&gather, &x, &mut y);
            be.finish();
        });
        rows.push(Row {
            bytes_per_dof: gather_bytes / n as f64,
            ..row(be, "apply_gather", level, n, seconds)
        });
    }
    let mut b = be.zeros(n);
    be.apply(&op, &x, &mut b);
    for (what, method) in [
        ("cg_iter", KrylovMethod::Cg),
        ("cgs_iter", KrylovMethod::Cgs),
    ] {
        let timed = |iterations: usize| {
            let mut u = be.zeros(n);
            seconds_per_call(opts.budget / 2.0, || {
                be.scale(0.0, &mut u);
                run_iterations(be, &op, method, &b, &mut u, iterations);
            })
        };
        let short = timed(2);
        let long = timed(2 + ITERATIONS);
        let seconds = ((long - short) / ITERATIONS as f64).max(f64::MIN_POSITIVE);
        let counted = |iterations: usize| {
            let mut u = be.zeros(n);
            let before = be.dispatches();
            run_iterations(be, &op, method, &b, &mut u, iterations);
            be.dispatches() - before
        };
        let per_iteration = (counted(2 + ITERATIONS) - counted(2)) as f64 / ITERATIONS as f64;
        eprintln!(
            "bench: {} {} level {level}: {per_iteration} dispatches per {what}",
            name(be),
            precision(be),
        );
        rows.push(Row {
            bytes_per_dof,
            ..row(be, what, level, n, seconds)
        });
    }
    if be.precision() == Precision::F64 {
        rows.push(vcycle(be, case, setup, &op, &x, opts)?);
    }
    Ok(rows)
}

/// One V-cycle of the set-up's hierarchy on the device (built here with the
/// default options, as a run builds it), timed from the same `x`.
fn vcycle(
    be: &GpuBackend,
    case: &Case,
    setup: &Setup,
    op: &GpuOperator<'_>,
    x: &GpuVector,
    opts: &BenchOptions,
) -> Result<Row> {
    let (problem, cells) = (&setup.problem, &setup.cells);
    let h = Hierarchy::new(
        case,
        problem,
        cells,
        &setup.op,
        &MultigridOptions::default(),
    )?;
    let mg = DeviceMultigrid::new(be, &setup.op, &h)?;
    let cycle = mg.cycle(be, op);
    let n = be.nrows(op);
    let mut z = be.zeros(n);
    let before = be.dispatches();
    cycle.apply_inverse(x, &mut z);
    eprintln!(
        "bench: {} {} level {}: {} levels, {} dispatches per vcycle",
        name(be),
        precision(be),
        setup.grid.level,
        h.num_levels(),
        be.dispatches() - before
    );
    let seconds = seconds_per_call(opts.budget, || {
        cycle.apply_inverse(x, &mut z);
        be.finish();
    });
    Ok(row(be, "vcycle", setup.grid.level, n, seconds))
}

/// Bytes of operator data on the device: the host operator's, with the cut
/// cells' forms or weights replaced by the dense matrices uploaded in the device's
/// precision.
fn device_operator_bytes(be: &GpuBackend, op: &ElasticOperator) -> usize {
    let ne = op.dofs_per_cell();
    let dense = op.own_cells().len() * ne * ne * be.precision().bytes() as usize;
    op.bytes() - op.cut_bytes() + dense
}
