//! `cgfem-gpu run`: one case from file to report. The case is read once
//! ([`cgfem_gpu::case::Case`]), its output folder checked, and it is solved
//! along its path ([`cgfem_gpu::case::SolutionPath`]): [`linear`] (the
//! fixed point on the recovered terms) or [`newton`] (load steps, contact).
//! Both write the one report schema ([`cgfem_gpu::report::Report`]) to
//! DIR/report.json — also when the solve fails (status "failed", exit code
//! 3) or is interrupted (status "interrupted", exit code 130), with the
//! files written beside it under `outputs` — and the ParaView files that
//! `--output` selects, each atomically.

#[cfg(feature = "mpi")]
mod distributed;
mod linear;
mod newton;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::Context;
use serde::Serialize;

use cgfem_gpu::case::{Case, SolutionPath};
use cgfem_gpu::driver::output::{OutputFiles, ParaView};
use cgfem_gpu::gpu::{BackendChoice, GpuContext, PrecisionChoice};
use cgfem_gpu::output::write_atomic;
use cgfem_gpu::report::Report;
use cgfem_gpu::vtu::VtuEncoding;

use crate::cli_progress::Terminal;

/// Where `run` writes and what besides the report and the solution.
pub struct Outputs {
    /// `--out` (default: out/<case name>).
    pub dir: Option<PathBuf>,
    /// `--plots`: also DIR/residuals.svg and DIR/deformed.svg.
    pub plots: bool,
    /// `--output` and `--compress`: which ParaView files, in which encoding.
    pub paraview: ParaView,
}

impl Outputs {
    /// The outputs of `--out`, `--plots`, `--output` and `--compress`: the
    /// ParaView files appended raw, or zlib-compressed with `compress`.
    pub fn new(dir: Option<PathBuf>, plots: bool, files: OutputFiles, compress: bool) -> Outputs {
        let encoding = match compress {
            true => VtuEncoding::AppendedZlib,
            false => VtuEncoding::Appended,
        };
        Outputs {
            dir,
            plots,
            paraview: ParaView { files, encoding },
        }
    }
}

/// What `run` asked of the device.
pub struct Device {
    pub backend: Option<BackendChoice>,
    pub adapter: Option<String>,
    pub precision: PrecisionChoice,
}

/// The GPU context to solve on, or `None` for the CPU.
pub(super) fn open_device(d: &Device) -> anyhow::Result<Option<Arc<GpuContext>>> {
    let filter = cgfem_gpu::gpu::context::adapter_filter(d.adapter.as_deref());
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
            Err(e @ cgfem_gpu::Error::NoAdapter { .. }) => {
                println!("note: {e}; solving on the CPU");
                Ok(None)
            }
            Err(e) => Err(e.into()),
        },
    }
}

/// Runs the case at `path`: `level` overrides every body's, `set` the keys.
pub fn run_case(
    path: &Path,
    level: Option<u32>,
    set: &[String],
    outputs: &Outputs,
    condition: bool,
    device: &Device,
    progress: &Terminal,
) -> anyhow::Result<()> {
    let case = Case::from_file_with(path, set)?;
    mesh_notes(&case);
    let name = case.spec.name.clone().unwrap_or_else(|| "case".into());
    let dir = outputs
        .dir
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&name));
    if dir.exists() && !dir.is_dir() {
        return Err(cgfem_gpu::Error::Io {
            path: dir.display().to_string(),
            reason: "--out names a file, not a folder".into(),
        }
        .into());
    }
    #[cfg(feature = "mpi")]
    {
        use cgfem_gpu::comm::Comm;
        // Started by mpirun on several ranks (one rank: the run below).
        if let Some(comm) = cgfem_gpu::comm::mpi::Mpi::init().filter(|c| c.size() > 1) {
            if condition && comm.rank() == 0 {
                println!("note: --condition needs the whole operator on one rank; not computed");
            }
            return distributed::run(&case, level, &dir, outputs, device, &comm, progress);
        }
    }
    match &case.path {
        SolutionPath::Linear => {
            linear::run(case, level, &dir, outputs, condition, device, progress)
        }
        SolutionPath::Newton(why) => {
            println!(
                "case {name} ({}): Newton over load steps ({why})",
                case.file
            );
            if condition {
                println!("note: --condition applies to the linear path; not computed");
            }
            newton::run(&case, level, &dir, outputs, device, progress)
        }
    }
}

/// `--precision` refused for `reason` (exit code 2).
pub(super) fn precision_refused(reason: &str) -> anyhow::Error {
    cgfem_gpu::Error::CaseFile {
        file: "(command line)".into(),
        key: "--precision".into(),
        reason: reason.into(),
    }
    .into()
}

/// What loading each STL body found, on stderr.
pub fn mesh_notes(case: &Case) {
    for b in &case.bodies {
        for mesh in b.geometry.meshes() {
            eprintln!(
                "note: {}: body '{}': mesh: {}",
                case.file,
                b.spec.name,
                mesh.diagnostics().summary()
            );
        }
    }
}

/// A position as the notes print it.
fn point(v: [f64; 3]) -> String {
    format!("({:.4}, {:.4}, {:.4})", v[0], v[1], v[2])
}

/// How many cut cells of body `b` took the repaired rule, and where, on
/// stderr.
pub(crate) fn repaired_note(b: &cgfem_gpu::report::BodyReport) {
    if let Some([lo, hi]) = b.cells.repaired_box {
        eprintln!(
            "note: body '{}': {} cut cells in {}..{} took the first-order repaired rule: the \
             mesh does not bound a solid there (open, overlapping or crossing facets)",
            b.name,
            b.cells.repaired,
            point(lo),
            point(hi)
        );
    }
}

/// Warns where a run glued walls: vertices whose cells hold parts of the
/// body that do not meet, sharing one unknown.
pub(crate) fn glued_note(b: &cgfem_gpu::report::BodyReport) {
    glued(
        b,
        "one unknown moves both walls, so the part is stiffer there than it is; a finer level \
         resolves it",
    );
}

/// Says where the geometry has walls that a run may glue.
pub(crate) fn glued_geometry_note(b: &cgfem_gpu::report::BodyReport) {
    glued(
        b,
        "a linear Q1 run on the CPU gives them one set of unknowns per part (where no Dirichlet \
         boundary crosses their cells); other runs glue them, so the part is stiffer there than it is",
    );
}

/// The glued vertices of `b`, where there are some, and what they do.
fn glued(b: &cgfem_gpu::report::BodyReport, consequence: &str) {
    if let Some([lo, hi]) = b.cells.glued_box {
        eprintln!(
            "warning: body '{}': {} grid vertices in {}..{} join parts of the body that do not \
             meet inside their cells (a slot, gap or hole narrower than about two cells, h = {:.4}): \
             {consequence}",
            b.name,
            b.cells.glued_nodes,
            point(lo),
            point(hi),
            b.h
        );
    }
}

/// Says where the walls of a body were taken apart (one set of unknowns per
/// part of the body at the vertices between them).
pub(crate) fn split_note(b: &cgfem_gpu::report::BodyReport) {
    if let Some([lo, hi]) = b.cells.split_box {
        println!(
            "  note: body '{}': {} grid vertices in {}..{} get one set of unknowns per part of the \
             body around them (walls of a slot or gap thinner than a cell, h = {:.4})",
            b.name,
            b.cells.split_nodes,
            point(lo),
            point(hi),
            b.h
        );
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
fn write_report(dir: &Path, report: &Report, outputs: &[String]) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let json = serde_json::to_vec_pretty(&ReportFile { report, outputs })
        .context("serialising the report")?;
    write_atomic(&dir.join("report.json"), &json)?;
    Ok(())
}
