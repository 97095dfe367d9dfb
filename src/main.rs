//! The `cgfem-gpu` command line. Exit codes (DESIGN §8): 0 success, 2 bad
//! input (the message names the file, key and reason), 3 solver failure, 1
//! internal error.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use clap::{Parser, Subcommand};

use cgfem_gpu::case::Case;
use cgfem_gpu::grid::machine_memory_bytes;
use cgfem_gpu::output::write_atomic;
use cgfem_gpu::report::Report;

#[derive(Parser)]
#[command(
    name = "cgfem-gpu",
    version,
    about = "Cartesian grid FEM for 3D solid mechanics"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a case: classify the grid, build the cut-cell quadrature, write
    /// DIR/report.json.
    Run {
        /// The case file (TOML).
        case: PathBuf,
        /// Grid level (overrides grid.level).
        #[arg(long)]
        level: Option<u32>,
        /// Output folder (default: out/<case name>).
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            let code = e
                .chain()
                .find_map(|c| c.downcast_ref::<cgfem_gpu::Error>())
                .map(|e| e.exit_code())
                .unwrap_or(1);
            ExitCode::from(code as u8)
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Run { case, level, out } => run_case(case, level, out),
    }
}

fn run_case(path: PathBuf, level: Option<u32>, out: Option<PathBuf>) -> anyhow::Result<()> {
    let case = Case::from_file(&path)?;
    let order = case.spec.element;
    let grid = case.grid(level)?;
    case.check_memory(&grid, machine_memory_bytes())?;
    let name = case.spec.name.clone().unwrap_or_else(|| "case".into());
    let start = Instant::now();
    let cells = case.classify(&grid)?;
    let classify_s = start.elapsed().as_secs_f64();
    let mut report = Report::geometry(&name, &case.file, order, &case.geometry, &grid, &cells);
    report
        .timings
        .insert("classification_and_quadrature".into(), classify_s);

    println!(
        "case {name} ({}), level {}, element {order:?}",
        case.file, grid.level
    );
    println!(
        "  grid {}x{}x{} cells of h = {:.6}: {} inside, {} cut, {} outside; {} dofs",
        grid.n[0],
        grid.n[1],
        grid.n[2],
        grid.h,
        report.cells.inside,
        report.cells.cut,
        report.cells.outside,
        report.dofs
    );
    println!(
        "  domain volume {:.12}, boundary area {:.12} (cut-cell quadrature, {classify_s:.3} s)",
        report.domain.volume, report.domain.boundary_area
    );
    for (tag, area) in &report.domain.boundary_area_by_tag {
        println!("    boundary '{tag}': area {area:.12}");
    }

    let dir = out.unwrap_or_else(|| PathBuf::from("out").join(&name));
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let json = serde_json::to_vec_pretty(&report).context("serialising the report")?;
    write_atomic(&dir.join("report.json"), &json)?;
    println!("  wrote {}", dir.join("report.json").display());
    Ok(())
}
