//! The Newton path of `cgfem-gpu run` (hyperelastic bodies, several bodies,
//! contact, load steps): set-up, the load steps with progress and Ctrl-C,
//! the ParaView series (the files `--output` selects) written as steps
//! converge, and DIR/report.json — written also when a step fails or the
//! run is interrupted.

use std::path::Path;
use std::sync::Arc;

use cgfem_gpu::bodies::run::run_writing;
use cgfem_gpu::case::Case;
use cgfem_gpu::gpu::{BackendChoice, GpuContext, PrecisionChoice};
use cgfem_gpu::report::Report;

use super::{Device, Outputs};
use crate::cli_progress::Terminal;

/// The device for the bodies' inside-cell tangents: only with `--backend gpu`
/// (`auto` keeps Newton runs on the CPU, where the Krylov iterations run
/// anyway), in f64. The preconditioner (Jacobi or the bodies' multigrid)
/// runs on the CPU beside it.
fn tangent_device(d: &Device) -> anyhow::Result<Option<Arc<GpuContext>>> {
    if BackendChoice::resolve(d.backend)? != BackendChoice::Gpu {
        return Ok(None);
    }
    if d.precision == PrecisionChoice::F32 {
        return Err(super::precision_refused("large-deformation runs need f64"));
    }
    let filter = cgfem_gpu::gpu::context::adapter_filter(d.adapter.as_deref());
    let ctx = GpuContext::new(filter.as_deref(), PrecisionChoice::F64)?;
    Ok(Some(Arc::new(ctx)))
}

/// Solves `case` over its load steps and writes its outputs into `dir`.
pub fn run(
    case: &Case,
    level: Option<u32>,
    dir: &Path,
    outputs: &Outputs,
    device: &Device,
    progress: &Terminal,
) -> anyhow::Result<()> {
    if outputs.plots {
        println!("note: --plots draws the linear path's charts only");
    }
    let gpu = tangent_device(device)?;
    if let Some(ctx) = &gpu {
        println!("tangent of the inside cells on {}", ctx.adapter.name);
    }
    let outcome = run_writing(case, level, Some(dir), outputs.paraview, gpu, progress);
    progress.finish();
    let outcome = match outcome {
        Ok(outcome) => outcome,
        // A solver failure before the first step (the bodies' multigrid set-up)
        // still leaves a report.
        Err(e) if matches!(e.exit_code(), 3 | 130) => {
            let mut report = Report::new(case);
            report.fail(&e);
            super::write_report(dir, &report, &[])?;
            eprintln!(
                "report (marked {}): {}",
                report.status,
                dir.join("report.json").display()
            );
            return Err(e.into());
        }
        Err(e) => return Err(e.into()),
    };
    let report = &outcome.report;
    for b in &report.bodies {
        super::repaired_note(b);
        super::glued_note(b);
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
    super::write_report(dir, report, &outcome.files)?;
    let load = report
        .load
        .as_ref()
        .expect("a Newton run reports its load steps");
    println!(
        "  {} of {} load steps converged (load factor {:.4}), {} Newton iterations, {} Krylov iterations",
        load.converged_steps,
        load.steps,
        load.load_factor,
        outcome.solution.newton_iterations(),
        outcome.solution.krylov_iterations()
    );
    match outcome.result {
        Ok(()) => {
            let count = |is: &dyn Fn(&str) -> bool| outcome.files.iter().filter(|f| is(f)).count();
            println!(
                "  wrote {}{}, {} body files, {} surface files and {} contact point files",
                dir.join("report.json").display(),
                match count(&|f| f == "solution.pvd") {
                    0 => "",
                    _ => ", solution.pvd",
                },
                count(&|f| f.ends_with(".vtu")),
                count(&|f| f.ends_with(".vtp") && f.contains("_surface_")),
                count(&|f| f.ends_with(".vtp") && !f.contains("_surface_"))
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
