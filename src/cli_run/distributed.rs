//! `mpirun -n P cgfem-gpu run case.toml` (feature `mpi`, P > 1): the linear
//! path on P ranks ([`cgfem_gpu::distributed::run`]). Every rank reads the
//! case and solves its share; rank 0 prints and writes DIR/report.json (with
//! a row per rank), also when the run fails. On the CPU of each rank, with
//! the case's preconditioner (`auto`: the multigrid V-cycle, every level
//! shared out over the ranks); with `--backend gpu`, on each rank's GPU
//! with Jacobi. `--output volume` (or `all`): each
//! rank writes its piece `solution_<rank>.vtu` and rank 0 `solution.pvtu`
//! listing them; `--output surface` (or `all`): rank 0 writes
//! `surface.vtp`, gathered from every rank.

use std::path::Path;

use cgfem_gpu::case::Case;
use cgfem_gpu::comm::Comm;
use cgfem_gpu::distributed::run::{Pieces, RunOutcome};
use cgfem_gpu::gpu::BackendChoice;
use cgfem_gpu::progress::{Event, Progress};
use cgfem_gpu::solver::Preconditioner;

use super::{Device, Outputs};
use crate::cli_progress::Terminal;

/// Runs `case` on the ranks of `comm` and writes its report to `dir` from
/// rank 0.
pub fn run(
    case: &Case,
    level: Option<u32>,
    dir: &Path,
    outputs: &Outputs,
    device: &Device,
    comm: &dyn Comm,
    progress: &Terminal,
) -> anyhow::Result<()> {
    let ranks = comm.size();
    // `--backend gpu` puts each rank on its GPU (Jacobi); otherwise the
    // ranks solve on their CPUs, with the multigrid V-cycle.
    let gpu = match BackendChoice::resolve(device.backend)? {
        BackendChoice::Gpu => super::open_device(device)?,
        BackendChoice::Cpu | BackendChoice::Auto => None,
    };
    let lead = comm.rank() == 0;
    let name = case.spec.name.clone().unwrap_or_else(|| "case".into());
    let files = outputs.paraview.files;
    if lead {
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
        println!(
            "case {name} ({}): {ranks} ranks, {on} each, {pre}",
            case.file
        );
    }
    let pieces = (files.volume() || files.surface()).then_some(Pieces {
        dir,
        paraview: outputs.paraview,
    });
    let unshown = Unshown(progress);
    let quiet: &dyn Progress = match lead {
        true => progress,
        false => &unshown,
    };
    let RunOutcome {
        report,
        files,
        result,
    } = cgfem_gpu::distributed::run::run(case, level, comm, quiet, pieces, gpu);
    progress.finish();
    if lead {
        let b = &report.bodies.first();
        if let (Some(b), Some(fp), Some(k)) = (b, &report.fixed_point, &report.krylov) {
            println!(
                "  level {}, {} dofs; {} inside, {} cut cells",
                b.level, report.dofs, b.cells.inside, b.cells.cut
            );
            println!(
                "  {} {}: {} fixed-point iterations, Krylov iterations {:?} (total {})",
                k.method,
                k.preconditioner,
                fp.iterations,
                k.iterations_per_solve,
                k.total_iterations
            );
            if let Some(e) = &b.error {
                println!(
                    "  energy error {:.4e} (relative {:.4e}), L2 relative {:.4e}",
                    e.energy, e.energy_relative, e.l2_relative
                );
            }
        }
        for r in &report.reactions {
            let f = r.force;
            println!(
                "  reaction on '{}': [{:.6e}, {:.6e}, {:.6e}]",
                r.part, f[0], f[1], f[2]
            );
        }
        for r in &report.ranks {
            println!(
                "  rank {}: {} owned + {} ghost dofs, {} B per halo exchange, {:.2} s solve",
                r.rank, r.owned_dofs, r.ghost_dofs, r.halo_bytes_per_apply, r.solve_seconds
            );
        }
        super::write_report(dir, &report, &files)?;
        println!(
            "  wrote {}{}",
            dir.join("report.json").display(),
            files.iter().map(|f| format!(", {f}")).collect::<String>()
        );
    }
    Ok(result?)
}

/// The progress of a rank other than 0: it shows nothing, but its Ctrl-C
/// counts (the ranks stop together when any is interrupted).
struct Unshown<'a>(&'a Terminal);

impl Progress for Unshown<'_> {
    fn event(&self, _event: &Event) {}

    fn should_stop(&self) -> bool {
        self.0.should_stop()
    }
}
