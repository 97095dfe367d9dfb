//! A run from a read case to its report: the one orchestration behind
//! `cgfem-gpu run`, which only parses its arguments and prints. The case
//! goes along its path ([`crate::case::SolutionPath`]): [`linear`] (the
//! fixed point on the recovered terms), [`newton`] (load steps, contact), or
//! on several ranks [`distributed`]. Each writes the one report schema
//! ([`Report`]) to DIR/report.json — also when the solve fails (status
//! "failed", exit code 3) or is interrupted (status "interrupted", exit
//! code 130), with the files written beside it under `outputs` — and the
//! ParaView files that [`RunOptions::paraview`] selects, each atomically.
//! What the run has to tell on the way (the body it set up, the backend it
//! took, what it found in the input) goes to the progress observer as
//! [`crate::progress::Event::Say`] and [`crate::progress::Event::Notice`].

mod distributed;
mod linear;
mod newton;
pub mod notes;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::Serialize;

use crate::case::{Case, SolutionPath};
use crate::comm::Comm;
use crate::driver::output::ParaView;
use crate::error::{Error, Result};
use crate::gpu::{BackendChoice, GpuContext, PrecisionChoice};
use crate::output::write_atomic;
use crate::progress::Progress;
use crate::report::Report;

/// What a run is asked besides its case.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Every body's grid level (default: the case's).
    pub level: Option<u32>,
    /// The output folder (created when the set-up succeeds); by default
    /// out/<case name>.
    pub out: Option<PathBuf>,
    /// Which ParaView files, in which encoding.
    pub paraview: ParaView,
    /// Also DIR/residuals.svg and DIR/deformed.svg (the linear path).
    pub plots: bool,
    /// The assembled operator's condition numbers in the report (the linear
    /// path on one rank).
    pub condition: bool,
    /// The device asked for.
    pub device: DeviceRequest,
}

/// The backend, adapter and precision a run is asked to solve on.
#[derive(Clone, Debug, Default)]
pub struct DeviceRequest {
    /// `None`: the default ([`BackendChoice::resolve`]).
    pub backend: Option<BackendChoice>,
    /// A substring of the adapter's name (or `CGFEM_ADAPTER`).
    pub adapter: Option<String>,
    pub precision: PrecisionChoice,
}

/// How a run ended: its report (as written to DIR/report.json on rank 0),
/// the files written beside it (names in the output folder, in order), and
/// whether it succeeded (the report then says why it did not).
pub struct RunOutcome {
    /// The output folder, DIR.
    pub dir: PathBuf,
    pub report: Report,
    pub files: Vec<String>,
    pub result: Result<()>,
}

/// Runs `case` with `options` on the ranks of `comm` (one rank: the case's
/// own path). An error before the run has a report (bad options, the
/// device, a set-up refusing the input) is returned as such; a failure or
/// interruption after it is in [`RunOutcome::result`], the report written.
pub fn run_case(
    case: Case,
    options: &RunOptions,
    comm: &dyn Comm,
    progress: &dyn Progress,
) -> Result<RunOutcome> {
    let name = case.spec.name.clone().unwrap_or_else(|| "case".into());
    let dir = match &options.out {
        Some(dir) => dir.clone(),
        None => PathBuf::from("out").join(&name),
    };
    if dir.exists() && !dir.is_dir() {
        return Err(Error::Io {
            path: dir.display().to_string(),
            reason: "--out names a file, not a folder".into(),
        });
    }
    if comm.size() > 1 {
        if options.condition && comm.rank() == 0 {
            progress
                .say("note: --condition needs the whole operator on one rank; not computed".into());
        }
        return distributed::run(&case, options, dir, comm, progress);
    }
    if let SolutionPath::Newton(why) = &case.path {
        progress.say(format!(
            "case {name} ({}): Newton over load steps ({why})",
            case.file
        ));
        if options.condition {
            progress.say("note: --condition applies to the linear path; not computed".into());
        }
        return newton::run(&case, options, dir, progress);
    }
    linear::run(case, options, dir, progress)
}

/// The GPU context to solve on, or `None` for the CPU; `auto` without an
/// adapter says so and takes the CPU.
fn open_device(d: &DeviceRequest, progress: &dyn Progress) -> Result<Option<Arc<GpuContext>>> {
    let filter = crate::gpu::context::adapter_filter(d.adapter.as_deref());
    match BackendChoice::resolve(d.backend)? {
        BackendChoice::Cpu => {
            if d.precision == PrecisionChoice::F32 {
                return Err(precision_refused("f32 needs the GPU backend"));
            }
            Ok(None)
        }
        BackendChoice::Gpu => Ok(Some(Arc::new(GpuContext::new(
            filter.as_deref(),
            d.precision,
        )?))),
        // An adapter named by `--adapter`/`CGFEM_ADAPTER` is taken even when it
        // is a software one; otherwise `auto` wants hardware.
        BackendChoice::Auto => match if filter.is_some() {
            GpuContext::new(filter.as_deref(), d.precision)
        } else {
            GpuContext::new_hardware(None, d.precision)
        } {
            Ok(ctx) => Ok(Some(Arc::new(ctx))),
            Err(e @ Error::NoAdapter { .. }) => {
                progress.say(format!("note: {e}; solving on the CPU"));
                Ok(None)
            }
            Err(e) => Err(e),
        },
    }
}

/// `--precision` refused for `reason` (exit code 2).
fn precision_refused(reason: &str) -> Error {
    Error::CaseFile {
        file: "(command line)".into(),
        key: "--precision".into(),
        reason: reason.into(),
    }
}

/// The report as written: its keys, then `outputs`.
#[derive(Serialize)]
struct ReportFile<'a> {
    #[serde(flatten)]
    report: &'a Report,
    /// The files written beside the report, by name, in order.
    outputs: &'a [String],
}

/// Writes DIR/report.json (creating DIR), listing `outputs`, the files
/// written beside it.
pub fn write_report(dir: &Path, report: &Report, outputs: &[String]) -> Result<()> {
    create_dir(dir)?;
    let json =
        serde_json::to_vec_pretty(&ReportFile { report, outputs }).map_err(|e| Error::Io {
            path: dir.join("report.json").display().to_string(),
            reason: format!("serialising the report: {e}"),
        })?;
    write_atomic(&dir.join("report.json"), &json)
}

/// Creates the output folder `dir` (and its parents).
fn create_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::Io {
        path: dir.display().to_string(),
        reason: format!("creating the output folder: {e}"),
    })
}

#[cfg(test)]
mod tests;
