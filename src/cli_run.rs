//! `cgfem-gpu run`: reads the case, hands it to the library's one
//! orchestration ([`cgfem_gpu::run::run_case`]; with the `mpi` feature under
//! `mpirun`, on every rank) and prints what it did: the lines the run says as
//! it goes (through [`Terminal`]), then a summary from its report. The run
//! writes DIR/report.json, also when it fails (exit code 3) or is
//! interrupted (130), and the ParaView files that `--output` selects.

use std::path::Path;

use cgfem_gpu::case::{Case, SolutionPath};
use cgfem_gpu::comm::Comm;
use cgfem_gpu::report::Report;
use cgfem_gpu::run::{notes, RunOptions, RunOutcome};

use crate::cli_progress::Terminal;

/// Runs the case at `path` (`set` overriding its keys) with `options`.
pub fn run_case(
    path: &Path,
    set: &[String],
    options: &RunOptions,
    progress: &Terminal,
) -> anyhow::Result<()> {
    let case = Case::from_file_with(path, set)?;
    let comm = world();
    // Every rank reads the case; rank 0 tells what it found.
    if comm.rank() == 0 {
        mesh_notes(&case);
    }
    let newton = matches!(case.path, SolutionPath::Newton(_));
    let outcome = cgfem_gpu::run::run_case(case, options, comm.as_ref(), progress);
    progress.finish();
    let outcome = outcome?;
    if comm.rank() == 0 {
        let dir = &outcome.dir;
        match (comm.size() > 1, newton) {
            (true, _) => print_ranks(&outcome, dir),
            (false, true) => print_newton(&outcome, dir),
            (false, false) => print_linear(&outcome, dir),
        }
    }
    Ok(outcome.result?)
}

/// The ranks of this run: MPI's world when started by `mpirun` (feature
/// `mpi`), else one.
fn world() -> Box<dyn Comm> {
    #[cfg(feature = "mpi")]
    if let Some(comm) = cgfem_gpu::comm::mpi::Mpi::init() {
        return Box::new(comm);
    }
    Box::new(cgfem_gpu::comm::Serial)
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

/// Where a failed or interrupted run left its report, on stderr.
fn failed(report: &Report, dir: &Path, kept: &str) {
    eprintln!(
        "report (marked {}): {}{kept}",
        report.status,
        dir.join("report.json").display()
    );
}

/// The report's path and the files beside it.
fn wrote(dir: &Path, files: &[String]) -> String {
    let beside: String = files.iter().map(|f| format!(", {f}")).collect();
    format!("  wrote {}{beside}", dir.join("report.json").display())
}

/// The reactions of the report, a line per part.
fn print_reactions(report: &Report) {
    for r in &report.reactions {
        let f = r.force;
        println!(
            "  reaction on '{}': [{:.6e}, {:.6e}, {:.6e}]",
            r.part, f[0], f[1], f[2]
        );
    }
}

/// The summary of a linear run on one rank.
fn print_linear(outcome: &RunOutcome, dir: &Path) {
    let report = &outcome.report;
    let (Ok(()), Some(k), Some(fp)) = (&outcome.result, &report.krylov, &report.fixed_point) else {
        return failed(report, dir, "");
    };
    println!(
        "  {} {}: {} fixed-point iterations, Krylov iterations {:?} (total {}), final residual {:.2e}",
        k.method,
        k.preconditioner,
        fp.iterations,
        k.iterations_per_solve,
        k.total_iterations,
        k.final_relative_residual
    );
    if k.floored_diagonal_entries > 0 {
        println!(
            "  note: Jacobi floored {} diagonal entries at round-off level (cut artefacts)",
            k.floored_diagonal_entries
        );
    }
    let row = &report.bodies[0];
    if let Some(e) = &row.error {
        let interpolant = match &row.interpolant_error {
            Some(Some(ei)) => format!("; interpolant {:.4e}", ei.energy_relative),
            _ => String::new(),
        };
        println!(
            "  energy error {:.4e} (relative {:.4e}{interpolant}), L2 relative {:.4e}",
            e.energy, e.energy_relative, e.l2_relative
        );
        if let Some(why) = &row.interpolant_error_note {
            println!("  interpolant error not reported: {why}");
        }
    }
    print_reactions(report);
    println!("{}", wrote(dir, &outcome.files));
}

/// The summary of a Newton run: its bodies and load steps.
fn print_newton(outcome: &RunOutcome, dir: &Path) {
    let report = &outcome.report;
    let Some(load) = &report.load else {
        // It failed before the first step.
        return failed(report, dir, "");
    };
    for b in &report.bodies {
        for notice in [notes::repaired(b), notes::glued(b)].into_iter().flatten() {
            eprintln!("{notice}");
        }
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
    let rows = &load.load_steps;
    let newton: usize = rows
        .iter()
        .filter(|r| r.converged)
        .map(|r| r.newton.iterations)
        .sum();
    let krylov: usize = rows.iter().flat_map(|r| &r.krylov_iterations).sum();
    println!(
        "  {} of {} load steps converged (load factor {:.4}), {newton} Newton iterations, {krylov} Krylov iterations",
        load.converged_steps, load.steps, load.load_factor,
    );
    if outcome.result.is_err() {
        return failed(report, dir, "; the last converged step's files are kept");
    }
    let files = &outcome.files;
    let count = |is: &dyn Fn(&str) -> bool| files.iter().filter(|f| is(f)).count();
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
}

/// The summary of a run on several ranks (rank 0), with a row per rank.
fn print_ranks(outcome: &RunOutcome, dir: &Path) {
    let report = &outcome.report;
    let b = &report.bodies.first();
    if let (Some(b), Some(fp), Some(k)) = (b, &report.fixed_point, &report.krylov) {
        println!(
            "  level {}, {} dofs; {} inside, {} cut cells",
            b.level, report.dofs, b.cells.inside, b.cells.cut
        );
        println!(
            "  {} {}: {} fixed-point iterations, Krylov iterations {:?} (total {})",
            k.method, k.preconditioner, fp.iterations, k.iterations_per_solve, k.total_iterations
        );
        if let Some(e) = &b.error {
            println!(
                "  energy error {:.4e} (relative {:.4e}), L2 relative {:.4e}",
                e.energy, e.energy_relative, e.l2_relative
            );
        }
    }
    print_reactions(report);
    for r in &report.ranks {
        println!(
            "  rank {}: {} owned + {} ghost dofs, {} B per halo exchange, {:.2} s solve",
            r.rank, r.owned_dofs, r.ghost_dofs, r.halo_bytes_per_apply, r.solve_seconds
        );
    }
    println!("{}", wrote(dir, &outcome.files));
}
