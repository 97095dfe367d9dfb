//! The `cgfem-gpu` command line. Exit codes: 0 success, 2 bad
//! input (the message names the file, key and reason), 3 solver failure (the
//! report is still written, marked failed), 1 internal error, 130 interrupted
//! by Ctrl-C (the report is still written, marked interrupted).

mod cli_progress;
mod cli_run;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use cgfem_gpu::case::Case;
use cgfem_gpu::driver::output::{OutputFiles, ParaView};
use cgfem_gpu::element::ElementOrder;
use cgfem_gpu::gpu::{list_adapters, BackendChoice, PrecisionChoice};
use cgfem_gpu::reproduce::{self, CutSweepOptions};
use cgfem_gpu::run::{notes, DeviceRequest, RunOptions};
use cgfem_gpu::solver::{KrylovMethod, Preconditioner};
use cgfem_gpu::vtu::VtuEncoding;
use cli_progress::Terminal;
use cli_run::run_case;

#[derive(Parser)]
#[command(
    name = "cgfem-gpu",
    version,
    about = "Cartesian grid FEM for 3D solid mechanics"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// No progress bars or progress lines on stderr (errors still show).
    #[arg(long, short, global = true)]
    quiet: bool,
}

/// The case and where its results go, as `run` and `geometry` take them.
#[derive(clap::Args)]
struct CaseArgs {
    /// The case file (TOML).
    case: PathBuf,
    /// Grid level (overrides grid.level).
    #[arg(long)]
    level: Option<u32>,
    /// Override any case key: --set solver.method=cg (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Output folder (default: out/<case name> for run, out/<case name>/geometry
    /// for geometry).
    #[arg(long)]
    out: Option<PathBuf>,
}

#[derive(Subcommand)]
enum Command {
    /// Solve a case; writes DIR/report.json, DIR/solution.vtu, DIR/surface.vtp
    /// and DIR/solution.pvd listing the two (see --output).
    Run {
        #[command(flatten)]
        case: CaseArgs,
        /// Also estimate the condition numbers of the operator (plain and
        /// Jacobi-scaled; assembles the matrix and factorises it).
        #[arg(long)]
        condition: bool,
        /// Where the linear solves run: auto (the GPU when an adapter is
        /// found, else the CPU), cpu or gpu (default: $CGFEM_BACKEND, else auto).
        #[arg(long)]
        backend: Option<BackendChoice>,
        /// Use the first GPU adapter whose name contains this (default:
        /// $CGFEM_ADAPTER).
        #[arg(long)]
        adapter: Option<String>,
        /// GPU precision: auto (f64 where the adapter has it), f32 (inner solves
        /// in f64 defect correction) or f64.
        #[arg(long, default_value = "auto")]
        precision: PrecisionChoice,
        /// Also write DIR/residuals.svg (ε per fixed-point iteration and the
        /// Krylov iterations per solve) and DIR/deformed.svg (the deformed
        /// boundary surface coloured by von Mises).
        #[arg(long)]
        plots: bool,
        /// Which ParaView files to write: volume (solution.vtu; Newton path:
        /// the bodies' .vtu), surface (surface.vtp; Newton path: the bodies'
        /// surfaces and the contact points), all, or none (report.json only).
        #[arg(long, default_value = "all")]
        output: OutputFiles,
        /// Compress the ParaView files' data with zlib (smaller, slower to
        /// write; default: appended raw binary).
        #[arg(long)]
        compress: bool,
    },
    /// Classify a case's grid against its solid without solving: writes
    /// DIR/cells.vtu, DIR/boundary.vtp (the boundary points with their tags)
    /// and DIR/report.json (with the STL diagnostics), to check a part and
    /// its boundary parts in ParaView.
    Geometry {
        #[command(flatten)]
        case: CaseArgs,
    },
    /// List the GPU adapters: backend, device type, driver, f64 and subgroup
    /// support, storage and dispatch limits.
    Info,
    /// Regenerate a result of the paper beside the paper's figures:
    /// DIR/<what>.json, .md and .svg.
    Reproduce {
        /// What to reproduce: table1, fig3, cut-sweep, table2 or all.
        what: String,
        /// Levels to run (default: table1 4 5; fig3 2 3 4 5; cut-sweep 4 5 6;
        /// table2 3 4 5).
        #[arg(long = "level")]
        levels: Vec<u32>,
        /// Output folder (default: out/reproduce).
        #[arg(long)]
        out: Option<PathBuf>,
        /// cut-sweep: random grid offsets per level.
        #[arg(long, default_value_t = 50)]
        offsets: usize,
        /// cut-sweep: seed of the offsets.
        #[arg(long, default_value_t = 2024)]
        seed: u64,
        /// cut-sweep: Krylov budget per solve.
        #[arg(long, default_value_t = 5000)]
        max_iterations: usize,
        /// cut-sweep: skip the condition numbers (iterations only).
        #[arg(long)]
        no_condition: bool,
        /// Element order: q1, q2 or all (default: fig3 all, the others q1;
        /// table1 and cut-sweep run the first element of all).
        /// Q2 runs cases/sphere_q2.toml (its own S-term and CG).
        #[arg(long)]
        element: Option<String>,
        /// table2: the preconditioner, multigrid (the default of `[[body]]`
        /// cases), jacobi, or all (both, each with CGS and BiCGStab).
        #[arg(long, default_value = "multigrid")]
        preconditioner: String,
    },
    /// Measure operator and solver throughput on the paper's sphere (Q1, f64):
    /// prints a table and writes DIR/bench.json.
    Bench {
        /// Levels to run (default 5 and 6; 7 needs about 10 GB for the CSR).
        #[arg(long = "level")]
        levels: Vec<u32>,
        /// Rayon thread counts to run each measurement with (default 1 and 2).
        #[arg(long = "threads", value_delimiter = ',')]
        threads: Vec<usize>,
        /// Levels of the end-to-end solves, matrix-free against sparse
        /// Cholesky (default 5 and 6; Cholesky is skipped where its factor
        /// would not fit in half the available memory).
        #[arg(long = "solve-level")]
        solve_levels: Vec<u32>,
        /// Skip the end-to-end solves.
        #[arg(long)]
        no_solve: bool,
        /// Skip the assembled-matrix rows (cpu-csr, cpu-csr-rayon): their
        /// assembly needs about 10 GB at level 7 and 80 GB at level 8.
        #[arg(long)]
        no_csr: bool,
        /// Levels at which to cut a 131 072-facet STL sphere against the
        /// analytic one (load, classification and rules; none by default).
        #[arg(long = "stl-level")]
        stl_levels: Vec<u32>,
        /// Seconds spent on each timed measurement.
        #[arg(long, default_value_t = 1.0)]
        budget: f64,
        /// cpu: the CPU backends only; auto (default): also the preferred GPU
        /// adapter when one is found; gpu: as auto, but no adapter is an error.
        #[arg(long)]
        backend: Option<BackendChoice>,
        /// Output folder (default: out/bench).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Element orders to run, e.g. q1,q2 (default q1): q1 runs cases/sphere.toml, q2 cases/sphere_q2.toml.
        #[arg(long = "element", value_delimiter = ',', value_parser = parse_element)]
        elements: Vec<ElementOrder>,
    },
}

/// Turns off Mesa's Vulkan device-select layer, which only orders adapters
/// for a desktop compositor (we pick the adapter ourselves) and, on a machine
/// with no desktop session, prints `error: XDG_RUNTIME_DIR is invalid or not
/// set` once per instance before a run that succeeds. Set before any thread
/// starts; a value the user set is kept.
fn quiet_vulkan_layers() {
    if std::env::var_os("NODEVICE_SELECT").is_none() {
        std::env::set_var("NODEVICE_SELECT", "1");
    }
}

/// Keeps freed memory in the process for the next allocation instead of
/// giving it back to the system (glibc's allocator). Every array above
/// 32 MiB is otherwise a fresh mapping whose pages the kernel zeroes on
/// first touch, and a run allocates and frees arrays of the grid's size in
/// every phase (recoveries, output fields): at level 7 that zeroing was 5 %
/// of the run's CPU time and a third of the output phase
/// (docs/performance.md, "Freed memory kept for reuse").
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn keep_freed_memory() {
    // SAFETY: `mallopt` only sets the allocator's parameters; it is called
    // before any other thread exists.
    unsafe {
        libc::mallopt(libc::M_MMAP_MAX, 0);
        libc::mallopt(libc::M_TRIM_THRESHOLD, i32::MAX);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn keep_freed_memory() {}

fn main() -> ExitCode {
    keep_freed_memory();
    quiet_vulkan_layers();
    let cli = Cli::parse();
    let terminal = Terminal::new(cli.quiet);
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn"));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(terminal.log_writer())
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    match run(cli, &terminal) {
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

/// The `geometry` command: classify and write, no solve.
fn geometry(args: &CaseArgs, progress: &Terminal) -> anyhow::Result<()> {
    let (level, out) = (args.level, args.out.clone());
    let case = cgfem_gpu::case::Case::from_file_with(&args.case, &args.set)?;
    cli_run::mesh_notes(&case);
    let name = case.spec.name.clone().unwrap_or_else(|| "case".into());
    let dir = out.unwrap_or_else(|| PathBuf::from("out").join(&name).join("geometry"));
    let written = cgfem_gpu::inspect::write_geometry(&case, level, &dir, progress);
    progress.finish();
    let written = written?;
    for r in &written.report.bodies {
        println!(
            "case {name} ({}), body '{}': level {}, h = {:.4e}, {} inside, {} cut cells ({} merged)",
            case.file, r.name, r.level, r.h, r.cells.inside, r.cells.cut, r.cells.merged
        );
        println!(
            "  volume {:.10e}, boundary area {:.10e}",
            r.domain.volume, r.domain.boundary_area
        );
        for (tag, area) in &r.domain.boundary_area_by_tag {
            println!("  boundary part '{tag}': area {area:.6e}");
        }
        for notice in [notes::repaired(r), notes::glued_geometry(r)]
            .into_iter()
            .flatten()
        {
            eprintln!("{notice}");
        }
    }
    let files = match case.bodies.len() {
        1 => "cells.vtu, boundary.vtp".to_string(),
        _ => "<body>.cells.vtu, <body>.boundary.vtp".to_string(),
    };
    println!("  wrote {}/{files} and report.json", dir.display());
    Ok(())
}

fn run(cli: Cli, progress: &Terminal) -> anyhow::Result<()> {
    match cli.command {
        Command::Run {
            case:
                CaseArgs {
                    case,
                    level,
                    set,
                    out,
                },
            condition,
            backend,
            adapter,
            precision,
            plots,
            output,
            compress,
        } => {
            let options = RunOptions {
                level,
                out,
                paraview: ParaView {
                    files: output,
                    encoding: match compress {
                        true => VtuEncoding::AppendedZlib,
                        false => VtuEncoding::Appended,
                    },
                },
                plots,
                condition,
                device: DeviceRequest {
                    backend,
                    adapter,
                    precision,
                },
            };
            progress.catch_ctrl_c()?;
            run_case(&case, &set, &options, progress)
        }
        Command::Geometry { case } => geometry(&case, progress),
        Command::Info => {
            info();
            Ok(())
        }
        Command::Reproduce {
            what,
            levels,
            out,
            offsets,
            seed,
            max_iterations,
            no_condition,
            element,
            preconditioner,
        } => {
            let sweep = CutSweepOptions {
                levels: if levels.is_empty() {
                    vec![4, 5, 6]
                } else {
                    levels.clone()
                },
                offsets,
                seed,
                max_iterations,
                condition: !no_condition,
                ..CutSweepOptions::default()
            };
            let table2 = table2_preconditioners(&preconditioner)?;
            reproduce(
                &what,
                &levels,
                &sweep,
                element.as_deref(),
                &table2,
                out,
                progress,
            )
        }
        Command::Bench {
            levels,
            threads,
            solve_levels,
            no_solve,
            no_csr,
            stl_levels,
            budget,
            backend,
            out,
            elements,
        } => {
            let solve_levels = match (no_solve, solve_levels.is_empty()) {
                (true, _) => Vec::new(),
                (false, true) => vec![5, 6],
                (false, false) => solve_levels,
            };
            let backend = BackendChoice::resolve(backend)?;
            if backend == BackendChoice::Gpu {
                // Refuse early, with the adapters found, rather than bench the CPU only.
                cgfem_gpu::gpu::GpuContext::new(None, Default::default())?;
            }
            let opts = cgfem_gpu::bench::BenchOptions {
                levels: if levels.is_empty() {
                    vec![5, 6]
                } else {
                    levels
                },
                threads: if threads.is_empty() {
                    vec![1, 2]
                } else {
                    threads
                },
                solve_levels,
                budget,
                csr: !no_csr,
                gpu: backend != BackendChoice::Cpu,
                elements: if elements.is_empty() {
                    vec![ElementOrder::Q1]
                } else {
                    elements
                },
                stl_levels,
            };
            bench(opts, out)
        }
    }
}

fn bench(opts: cgfem_gpu::bench::BenchOptions, out: Option<PathBuf>) -> anyhow::Result<()> {
    let dir = out.unwrap_or_else(|| PathBuf::from("out").join("bench"));
    let case_of = |element| match element {
        ElementOrder::Q1 => Case::from_str("cases/sphere.toml", SPHERE_CASE),
        ElementOrder::Q2 => Case::from_str("cases/sphere_q2.toml", SPHERE_Q2_CASE),
    };
    let rows = cgfem_gpu::bench::run(case_of, &opts, |r| {
        println!(
            "  {} {} {} level {} threads {}: {:.2} Mdofs/s",
            r.what,
            r.backend,
            r.element,
            r.level,
            r.threads,
            r.dofs_per_s / 1e6
        )
    })?;
    print!("{}", cgfem_gpu::bench::format_table(&rows));
    cgfem_gpu::bench::write_json(&rows, &dir)?;
    println!("wrote {}", dir.join("bench.json").display());
    Ok(())
}

/// The paper's Problem 1 as shipped in `cases/sphere.toml`.
const SPHERE_CASE: &str = include_str!("../cases/sphere.toml");
/// The same with Q2 elements, `cases/sphere_q2.toml`.
const SPHERE_Q2_CASE: &str = include_str!("../cases/sphere_q2.toml");

/// The sphere cases of `--element` (q1, q2 or all; `default` when absent).
fn sphere_cases(element: Option<&str>, default: &str) -> anyhow::Result<Vec<Case>> {
    let q1 = || Case::from_str("cases/sphere.toml", SPHERE_CASE);
    let q2 = || Case::from_str("cases/sphere_q2.toml", SPHERE_Q2_CASE);
    Ok(match element.unwrap_or(default) {
        "q1" => vec![q1()?],
        "q2" => vec![q2()?],
        "all" => vec![q1()?, q2()?],
        other => {
            return Err(cgfem_gpu::Error::CaseFile {
                file: "(command line)".into(),
                key: "element".into(),
                reason: format!("unknown element '{other}'; available: q1, q2, all"),
            }
            .into())
        }
    })
}

/// The preconditioners `--preconditioner` names for `reproduce table2`.
fn table2_preconditioners(name: &str) -> anyhow::Result<Vec<Preconditioner>> {
    Ok(match name {
        "multigrid" => vec![Preconditioner::Multigrid],
        "jacobi" => vec![Preconditioner::Jacobi],
        "all" => vec![Preconditioner::Jacobi, Preconditioner::Multigrid],
        other => {
            return Err(cgfem_gpu::Error::CaseFile {
                file: "(command line)".into(),
                key: "--preconditioner".into(),
                reason: format!(
                    "unknown preconditioner '{other}'; available: multigrid, jacobi, all"
                ),
            }
            .into())
        }
    })
}

fn reproduce(
    what: &str,
    levels: &[u32],
    sweep: &CutSweepOptions,
    element: Option<&str>,
    table2: &[Preconditioner],
    out: Option<PathBuf>,
    progress: &Terminal,
) -> anyhow::Result<()> {
    let dir = out.unwrap_or_else(|| PathBuf::from("out").join("reproduce"));
    let or = |default: &[u32]| {
        if levels.is_empty() {
            default.to_vec()
        } else {
            levels.to_vec()
        }
    };
    let known = ["table1", "fig3", "cut-sweep", "table2", "all"];
    if !known.contains(&what) {
        return Err(cgfem_gpu::Error::CaseFile {
            file: "(command line)".into(),
            key: "reproduce".into(),
            reason: format!("unknown result '{what}'; available: {}", known.join(", ")),
        }
        .into());
    }
    if what == "table1" || what == "all" {
        let case = &sphere_cases(element, "q1")?[0];
        let rows = reproduce::table1(case, &or(&[4, 5]), &dir, progress)?;
        println!(
            "table1: {} rows; wrote {}/table1.{{json,md,svg}}",
            rows.len(),
            dir.display()
        );
    }
    if what == "fig3" || what == "all" {
        let cases = sphere_cases(element, "all")?;
        let levels = or(&[2, 3, 4, 5]);
        let curves: Vec<_> = cases
            .iter()
            .map(|c| reproduce::Fig3Curves::for_case(c, &levels))
            .collect();
        let rows = reproduce::fig3(&curves, &dir, progress)?;
        println!(
            "fig3: {} rows; wrote {}/fig3.{{json,md,svg}}",
            rows.len(),
            dir.display()
        );
    }
    if what == "cut-sweep" || what == "all" {
        let case = &sphere_cases(element, "q1")?[0];
        let sweep = sweep.clone().with_case_stabilisation(case);
        let rows = reproduce::cut_sweep(case, &sweep, &dir, progress)?;
        println!(
            "cut-sweep: {} rows; wrote {}/cut-sweep.{{json,md,svg}}",
            rows.len(),
            dir.display()
        );
    }
    if what == "table2" || what == "all" {
        let case = Case::from_str_with("cases/annuli_contact.toml", ANNULI_CASE, &[])?;
        let solvers: Vec<_> = table2
            .iter()
            .flat_map(|p| [KrylovMethod::Cgs, KrylovMethod::BiCgStab].map(|m| (m, *p)))
            .collect();
        let rows = reproduce::table2(&case, &or(&[3, 4, 5]), &solvers, &dir, progress)?;
        println!(
            "table2: {} rows; wrote {}/table2.{{json,md,svg}}",
            rows.len(),
            dir.display()
        );
    }
    Ok(())
}

/// The contact problem of Table 2, built in.
const ANNULI_CASE: &str = include_str!("../cases/annuli_contact.toml");

/// `cgfem-gpu info`.
fn info() {
    let adapters = list_adapters();
    if adapters.is_empty() {
        println!("no GPU adapter found (Vulkan); runs use the CPU backend");
    }
    for (i, a) in adapters.iter().enumerate() {
        println!("[{i}] {a}");
    }
}

/// `q1` or `q2` (the `--element` values of `bench`).
fn parse_element(s: &str) -> Result<ElementOrder, String> {
    match s {
        "q1" => Ok(ElementOrder::Q1),
        "q2" => Ok(ElementOrder::Q2),
        _ => Err(format!("unknown element {s:?} (q1 or q2)")),
    }
}
