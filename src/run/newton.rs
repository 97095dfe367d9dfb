//! The Newton path of a run (hyperelastic bodies, several bodies, contact,
//! load steps): [`crate::bodies::run`] on the device asked for, and
//! DIR/report.json — written also when a step fails or the run is
//! interrupted, the last converged step's files kept.

use std::path::PathBuf;
use std::sync::Arc;

use super::{RunOptions, RunOutcome};
use crate::bodies::run::run_writing;
use crate::case::Case;
use crate::error::Result;
use crate::gpu::{BackendChoice, GpuContext, PrecisionChoice};
use crate::progress::Progress;
use crate::report::Report;

/// The device for the bodies' inside-cell tangents: only with `--backend gpu`
/// (`auto` keeps Newton runs on the CPU, where the Krylov iterations run
/// anyway), in f64. The preconditioner (Jacobi or the bodies' multigrid)
/// runs on the CPU beside it.
fn tangent_device(options: &RunOptions) -> Result<Option<Arc<GpuContext>>> {
    let d = &options.device;
    if BackendChoice::resolve(d.backend)? != BackendChoice::Gpu {
        return Ok(None);
    }
    if d.precision == PrecisionChoice::F32 {
        return Err(super::precision_refused("large-deformation runs need f64"));
    }
    let filter = crate::gpu::context::adapter_filter(d.adapter.as_deref());
    let ctx = GpuContext::new(filter.as_deref(), PrecisionChoice::F64)?;
    Ok(Some(Arc::new(ctx)))
}

/// Solves `case` over its load steps and writes its outputs into the
/// options' folder.
pub(super) fn run(
    case: &Case,
    options: &RunOptions,
    dir: PathBuf,
    progress: &dyn Progress,
) -> Result<RunOutcome> {
    if options.plots {
        progress.say("note: --plots draws the linear path's charts only".into());
    }
    let gpu = tangent_device(options)?;
    if let Some(ctx) = &gpu {
        progress.say(format!(
            "tangent of the inside cells on {}",
            ctx.adapter.name
        ));
    }
    let paraview = options.paraview;
    let (report, files, result) =
        match run_writing(case, options.level, Some(&dir), paraview, gpu, progress) {
            Ok(outcome) => (outcome.report, outcome.files, outcome.result),
            // A solver failure before the first step (the bodies' multigrid
            // set-up) still leaves a report.
            Err(e) if matches!(e.exit_code(), 3 | 130) => {
                let mut report = Report::new(case);
                report.fail(&e);
                (report, Vec::new(), Err(e))
            }
            Err(e) => return Err(e),
        };
    super::write_report(&dir, &report, &files)?;
    Ok(RunOutcome {
        dir,
        report,
        files,
        result,
    })
}
