//! The linear path on several ranks ([`crate::distributed::run`]): every
//! rank reads the case and solves its share; rank 0 tells what the run does
//! and writes DIR/report.json (with a row per rank), also when the run
//! fails. On the CPU of each rank, with the case's preconditioner (`auto`:
//! the multigrid V-cycle, every level shared out over the ranks); with
//! `--backend gpu`, on each rank's GPU with Jacobi. Volume output: each rank
//! writes its piece `solution_<rank>.vtu` and rank 0 `solution.pvtu` listing
//! them; surface output: rank 0 writes `surface.vtp`, gathered from every
//! rank.

use std::path::PathBuf;

use super::{RunOptions, RunOutcome};
use crate::case::Case;
use crate::comm::Comm;
use crate::distributed::run::Pieces;
use crate::error::Result;
use crate::gpu::BackendChoice;
use crate::progress::{Event, Progress};
use crate::solver::Preconditioner;

/// Runs `case` on the ranks of `comm`; rank 0 writes the report.
pub(super) fn run(
    case: &Case,
    options: &RunOptions,
    dir: PathBuf,
    comm: &dyn Comm,
    progress: &dyn Progress,
) -> Result<RunOutcome> {
    let lead = comm.rank() == 0;
    let unshown = Unshown(progress);
    let progress: &dyn Progress = match lead {
        true => progress,
        false => &unshown,
    };
    // `--backend gpu` puts each rank on its GPU (Jacobi); otherwise the
    // ranks solve on their CPUs, with the multigrid V-cycle.
    let gpu = match BackendChoice::resolve(options.device.backend)? {
        BackendChoice::Gpu => super::open_device(&options.device, progress)?,
        BackendChoice::Cpu | BackendChoice::Auto => None,
    };
    let name = case.spec.name.clone().unwrap_or_else(|| "case".into());
    let pre = match case.spec.solver.preconditioner {
        Preconditioner::Auto if gpu.is_some() => "Jacobi",
        Preconditioner::Auto | Preconditioner::Multigrid => "multigrid",
        Preconditioner::Jacobi => "Jacobi",
        Preconditioner::None => "no preconditioner",
    };
    let on = match &gpu {
        Some(ctx) => format!("GPU {}", ctx.adapter.name),
        None => "CPU".to_string(),
    };
    progress.say(format!(
        "case {name} ({}): {} ranks, {on} each, {pre}",
        case.file,
        comm.size()
    ));
    let files = options.paraview.files;
    let pieces = (files.volume() || files.surface()).then_some(Pieces {
        dir: &dir,
        paraview: options.paraview,
    });
    let ran = crate::distributed::run::run(case, options.level, comm, progress, pieces, gpu);
    if lead {
        super::write_report(&dir, &ran.report, &ran.files)?;
    }
    let (report, files, result) = (ran.report, ran.files, ran.result);
    Ok(RunOutcome {
        dir,
        report,
        files,
        result,
    })
}

/// The progress of a rank other than 0: it shows and says nothing, but its
/// Ctrl-C counts (the ranks stop together when any is interrupted).
struct Unshown<'a>(&'a dyn Progress);

impl Progress for Unshown<'_> {
    fn event(&self, _event: &Event) {}

    fn should_stop(&self) -> bool {
        self.0.should_stop()
    }
}
