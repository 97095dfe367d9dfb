//! `cgfem-gpu run` on a multi-body case (`[[body]]`, large deformation):
//! set-up, the load steps with progress and Ctrl-C, the ParaView series
//! written as steps converge, and DIR/report.json — written also when a step
//! fails (status "failed", exit code 3) or the run is interrupted (status
//! "interrupted", exit code 130).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::Context;

use cgfem_gpu::bodies::run::run_on;
use cgfem_gpu::case::bodies::BodiesCase;
use cgfem_gpu::gpu::{BackendChoice, GpuContext, PrecisionChoice};
use cgfem_gpu::output::write_atomic;
use cgfem_gpu::report::BodiesReport;

use crate::cli_progress::Terminal;
use crate::cli_run::{Device, Outputs};

fn write_report(dir: &Path, report: &BodiesReport) -> anyhow::Result<()> {
    let json = serde_json::to_vec_pretty(report).context("serialising the report")?;
    write_atomic(&dir.join("report.json"), &json)?;
    Ok(())
}

/// The device for the bodies' inside-cell tangents: only with `--backend gpu`
/// (`auto` keeps multi-body runs on the CPU, where the Krylov iterations run
/// anyway), in f64. The preconditioner (Jacobi or the bodies' multigrid)
/// runs on the CPU beside it.
fn tangent_device(d: &Device) -> anyhow::Result<Option<Arc<GpuContext>>> {
    if BackendChoice::resolve(d.backend)? != BackendChoice::Gpu {
        return Ok(None);
    }
    if d.precision == PrecisionChoice::F32 {
        return Err(cgfem_gpu::Error::CaseFile {
            file: "(command line)".into(),
            key: "--precision".into(),
            reason: "large-deformation runs need f64".into(),
        }
        .into());
    }
    let filter = cgfem_gpu::gpu::context::adapter_filter(d.adapter.as_deref());
    let ctx = GpuContext::new(filter.as_deref(), PrecisionChoice::F64)?;
    Ok(Some(Arc::new(ctx)))
}

/// Runs the multi-body case at `path`.
pub fn run_bodies_case(
    path: &Path,
    level: Option<u32>,
    set: &[String],
    outputs: &Outputs,
    device: &Device,
    progress: &Terminal,
) -> anyhow::Result<()> {
    let case = BodiesCase::from_file_with(path, set)?;
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
    if outputs.plots {
        println!("note: --plots has no chart for multi-body cases yet");
    }
    let gpu = tangent_device(device)?;
    if let Some(ctx) = &gpu {
        println!("tangent of the inside cells on {}", ctx.adapter.name);
    }
    let outcome = run_on(&case, level, Some(&dir), gpu, progress);
    progress.finish();
    let outcome = outcome?;
    let report = &outcome.report;
    for b in &report.bodies {
        println!(
            "body {}: level {}, {} dofs; {} inside, {} cut cells{}",
            b.name,
            b.level,
            b.dofs,
            b.cells.inside,
            b.cells.cut,
            if b.plane_strain {
                " (plane strain)"
            } else {
                ""
            }
        );
    }
    write_report(&dir, report)?;
    println!(
        "  {} of {} load steps converged (load factor {:.4}), {} Newton iterations, {} Krylov iterations",
        report.converged_steps,
        report.steps,
        report.load_factor,
        outcome.solution.newton_iterations(),
        outcome.solution.krylov_iterations()
    );
    match outcome.result {
        Ok(()) => {
            println!(
                "  wrote {}, solution.pvd, {} body files, {} surface files and {} contact point files",
                dir.join("report.json").display(),
                report.bodies.len() * report.converged_steps,
                report.bodies.len() * report.converged_steps,
                report.contact.len()
            );
            Ok(())
        }
        Err(e) => {
            eprintln!(
                "report (marked {}): {}; the last converged step's files are kept",
                report.status,
                dir.join("report.json").display()
            );
            Err(e.into())
        }
    }
}
