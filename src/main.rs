//! The `cgfem-gpu` command line. Exit codes (DESIGN §8): 0 success, 2 bad
//! input (the message names the file, key and reason), 3 solver failure (the
//! report is still written, marked failed), 1 internal error, 130 interrupted
//! by Ctrl-C (the report is still written, marked interrupted).

mod cli_progress;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Instant;

use anyhow::Context;
use clap::{Parser, Subcommand};

use cgfem_gpu::case::Case;
use cgfem_gpu::condition::{condition_number, ConditionOptions};
use cgfem_gpu::fem::field::{error_norms, interpolate};
use cgfem_gpu::fem::fixed_point::FixedPointReport;
use cgfem_gpu::fem::linear::{CpuSolver, LinearSolver};
use cgfem_gpu::fem::output::write_solution;
use cgfem_gpu::fem::setup::Setup;
use cgfem_gpu::fem::solve::solve_with_progress;
use cgfem_gpu::gpu::linear::{GpuSolver, Scalars};
use cgfem_gpu::gpu::{list_adapters, BackendChoice, GpuContext, PrecisionChoice};
use cgfem_gpu::output::write_atomic;
use cgfem_gpu::report::{Condition, FixedPoint, Krylov, Report, Stabilisation};
use cgfem_gpu::reproduce::{self, CutSweepOptions};
use cli_progress::Terminal;

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

#[derive(Subcommand)]
enum Command {
    /// Solve a case; writes DIR/report.json and DIR/solution.vtu.
    Run {
        /// The case file (TOML).
        case: PathBuf,
        /// Grid level (overrides grid.level).
        #[arg(long)]
        level: Option<u32>,
        /// Override any case key: --set solver.method=cg (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Output folder (default: out/<case name>).
        #[arg(long)]
        out: Option<PathBuf>,
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
        /// Also write DIR/residuals.svg: ε per fixed-point iteration and the
        /// Krylov iterations per solve.
        #[arg(long)]
        plots: bool,
    },
    /// List the GPU adapters: backend, device type, driver, f64 and subgroup
    /// support, storage and dispatch limits.
    Info,
    /// Regenerate a result of the paper beside the paper's figures:
    /// DIR/<what>.json, .md and .svg.
    Reproduce {
        /// What to reproduce: table1, fig3, cut-sweep or all.
        what: String,
        /// Levels to run (default: table1 4 5; fig3 2 3 4 5; cut-sweep 4 5 6).
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
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn"));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
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
        Command::Run {
            case,
            level,
            set,
            out,
            condition,
            backend,
            adapter,
            precision,
            plots,
        } => {
            let device = Device {
                backend,
                adapter,
                precision,
            };
            let progress = Terminal::new(cli.quiet);
            progress.catch_ctrl_c()?;
            let outputs = Outputs { dir: out, plots };
            run_case(&case, level, &set, &outputs, condition, &device, &progress)
        }
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
            reproduce(&what, &levels, &sweep, out)
        }
        Command::Bench {
            levels,
            threads,
            solve_levels,
            no_solve,
            budget,
            backend,
            out,
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
            let gpu = backend != BackendChoice::Cpu;
            bench(levels, threads, solve_levels, budget, gpu, out)
        }
    }
}

fn bench(
    levels: Vec<u32>,
    threads: Vec<usize>,
    solve_levels: Vec<u32>,
    budget: f64,
    gpu: bool,
    out: Option<PathBuf>,
) -> anyhow::Result<()> {
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
        gpu,
    };
    let dir = out.unwrap_or_else(|| PathBuf::from("out").join("bench"));
    let case = Case::from_str("cases/sphere.toml", SPHERE_CASE)?;
    let rows = cgfem_gpu::bench::run(&case, &opts, |r| {
        println!(
            "  {} {} level {} threads {}: {:.2} Mdofs/s",
            r.what,
            r.backend,
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

/// Where `run` writes and what besides the report and the solution.
struct Outputs {
    /// `--out` (default: out/<case name>).
    dir: Option<PathBuf>,
    /// `--plots`: also DIR/residuals.svg.
    plots: bool,
}

/// Writes DIR/report.json and, with `plots`, DIR/residuals.svg from the loop's
/// history.
fn write_report(
    dir: &Path,
    report: &Report,
    fp: &FixedPointReport,
    plots: bool,
) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let json = serde_json::to_vec_pretty(report).context("serialising the report")?;
    write_atomic(&dir.join("report.json"), &json)?;
    if plots {
        let title = format!("{}: fixed-point convergence", report.case);
        let svg = fp.residual_chart(&title).to_svg()?;
        write_atomic(&dir.join("residuals.svg"), svg.as_bytes())?;
    }
    Ok(())
}

/// The paper's Problem 1 as shipped in `cases/sphere.toml`.
const SPHERE_CASE: &str = include_str!("../cases/sphere.toml");

fn reproduce(
    what: &str,
    levels: &[u32],
    sweep: &CutSweepOptions,
    out: Option<PathBuf>,
) -> anyhow::Result<()> {
    let dir = out.unwrap_or_else(|| PathBuf::from("out").join("reproduce"));
    let case = Case::from_str("cases/sphere.toml", SPHERE_CASE)?;
    let or = |default: &[u32]| {
        if levels.is_empty() {
            default.to_vec()
        } else {
            levels.to_vec()
        }
    };
    let known = ["table1", "fig3", "cut-sweep", "all"];
    if !known.contains(&what) {
        return Err(cgfem_gpu::Error::CaseFile {
            file: "(command line)".into(),
            key: "reproduce".into(),
            reason: format!("unknown result '{what}'; available: {}", known.join(", ")),
        }
        .into());
    }
    if what == "table1" || what == "all" {
        let rows = reproduce::table1(&case, &or(&[4, 5]), &dir)?;
        println!(
            "table1: {} rows; wrote {}/table1.{{json,md,svg}}",
            rows.len(),
            dir.display()
        );
    }
    if what == "fig3" || what == "all" {
        let rows = reproduce::fig3(&case, &or(&[2, 3, 4, 5]), &dir)?;
        println!(
            "fig3: {} rows; wrote {}/fig3.{{json,md,svg}}",
            rows.len(),
            dir.display()
        );
    }
    if what == "cut-sweep" || what == "all" {
        let rows = reproduce::cut_sweep(&case, sweep, &dir)?;
        println!(
            "cut-sweep: {} rows; wrote {}/cut-sweep.{{json,md,svg}}",
            rows.len(),
            dir.display()
        );
    }
    Ok(())
}

/// κ and Jacobi-scaled κ of the assembled operator.
fn condition_numbers(setup: &Setup) -> anyhow::Result<Condition> {
    let a = setup.op.assemble();
    let opts = ConditionOptions::default();
    let plain = condition_number(&a, false, &opts)?;
    let scaled = condition_number(&a, true, &opts)?;
    Ok(Condition {
        kappa: plain.kappa,
        kappa_jacobi: scaled.kappa,
        kappa_is_lower_bound: plain.kappa_is_lower_bound,
        kappa_jacobi_is_lower_bound: scaled.kappa_is_lower_bound,
        method: format!("plain: {}; jacobi: {}", plain.method, scaled.method),
    })
}

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

/// What `run` asked of the device.
struct Device {
    backend: Option<BackendChoice>,
    adapter: Option<String>,
    precision: PrecisionChoice,
}

/// The GPU context to solve on, or `None` for the CPU.
fn open_device(d: &Device) -> anyhow::Result<Option<Arc<GpuContext>>> {
    let filter = cgfem_gpu::gpu::context::adapter_filter(d.adapter.as_deref());
    match BackendChoice::resolve(d.backend)? {
        BackendChoice::Cpu => {
            if d.precision == PrecisionChoice::F32 {
                return Err(cgfem_gpu::Error::CaseFile {
                    file: "(command line)".into(),
                    key: "--precision".into(),
                    reason: "f32 needs the GPU backend".into(),
                }
                .into());
            }
            Ok(None)
        }
        BackendChoice::Gpu => Ok(Some(Arc::new(GpuContext::new(
            filter.as_deref(),
            d.precision,
        )?))),
        BackendChoice::Auto => match GpuContext::new(filter.as_deref(), d.precision) {
            Ok(ctx) => Ok(Some(Arc::new(ctx))),
            Err(e @ cgfem_gpu::Error::NoAdapter { .. }) => {
                println!("note: {e}; solving on the CPU");
                Ok(None)
            }
            Err(e) => Err(e.into()),
        },
    }
}

fn run_case(
    path: &Path,
    level: Option<u32>,
    set: &[String],
    outputs: &Outputs,
    condition: bool,
    device: &Device,
    progress: &Terminal,
) -> anyhow::Result<()> {
    let case = Case::from_file_with(path, set)?;
    let gpu = open_device(device)?;
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
    let setup = Setup::new_with_progress(&case, level, progress);
    progress.finish();
    let setup = setup?;
    let order = case.spec.element;
    let mut report = Report::geometry(
        &name,
        &case.file,
        order,
        &case.geometry,
        &setup.grid,
        &setup.cells,
    );
    report.timings.extend(setup.timings.iter().cloned());
    report.cells.pathological = Some(setup.omega_star.len());
    let st = &case.spec.stabilisation;
    report.stabilisation = Some(Stabilisation {
        k1: st.k1,
        k2: st.k2,
        a: st.a,
    });
    println!(
        "case {name} ({}): level {}, {order:?}, {} dofs; {} inside, {} cut cells",
        case.file, setup.grid.level, report.dofs, report.cells.inside, report.cells.cut
    );

    if condition {
        let t = Instant::now();
        report.condition = Some(condition_numbers(&setup)?);
        report
            .timings
            .insert("condition".into(), t.elapsed().as_secs_f64());
        if let Some(c) = &report.condition {
            let bound = |b: bool| if b { "≥ " } else { "" };
            println!(
                "  κ = {}{:.3e}, Jacobi-scaled κ = {}{:.3e}",
                bound(c.kappa_is_lower_bound),
                c.kappa,
                bound(c.kappa_jacobi_is_lower_bound),
                c.kappa_jacobi
            );
        }
    }

    let t = Instant::now();
    let (mut cpu_solver, mut gpu_solver);
    let gpu = match gpu {
        Some(ctx) => match ctx.check_vector_len(setup.op.dofs.ndofs()) {
            Ok(()) => Some(ctx),
            Err(e) if BackendChoice::resolve(device.backend)? == BackendChoice::Auto => {
                println!("note: {e}; solving on the CPU");
                None
            }
            Err(e) => return Err(e.into()),
        },
        None => None,
    };
    let solver: &mut dyn LinearSolver = match &gpu {
        Some(ctx) => {
            gpu_solver = GpuSolver::new(ctx.clone(), &setup.op, Scalars::Device);
            report.backend = "gpu".into();
            report.adapter = Some(ctx.adapter.name.clone());
            report.precision = ctx.precision.name().into();
            &mut gpu_solver
        }
        None => {
            cpu_solver = CpuSolver::new(&setup.op);
            &mut cpu_solver
        }
    };
    report
        .timings
        .insert("upload".into(), t.elapsed().as_secs_f64());
    println!(
        "  backend {}{} ({})",
        report.backend,
        report
            .adapter
            .as_ref()
            .map_or(String::new(), |a| format!(": {a}")),
        report.precision
    );
    let t = Instant::now();
    let mut fp = FixedPointReport::default();
    let result = solve_with_progress(&setup, &case.spec.solver, solver, &mut fp, progress);
    progress.finish();
    report
        .timings
        .insert("solve".into(), t.elapsed().as_secs_f64());
    report.timings.insert("krylov".into(), fp.krylov_seconds);
    report
        .timings
        .insert("recovery".into(), fp.recovery_seconds);
    let so = &case.spec.solver;
    report.krylov = Some(Krylov {
        method: so.method.name().into(),
        preconditioner: format!("{:?}", so.preconditioner).to_lowercase(),
        iterations_per_solve: fp.iterations_per_solve.clone(),
        total_iterations: fp.total_iterations,
        final_relative_residual: fp.final_relative_residual,
    });
    report.fixed_point = Some(FixedPoint {
        iterations: fp.iterations,
        eps_history: fp.eps_history.clone(),
        converged: fp.converged,
    });
    let solution = match result {
        Ok(s) => s,
        Err(e) => {
            report.status = match e {
                cgfem_gpu::Error::Interrupted { .. } => "interrupted",
                _ => "failed",
            }
            .into();
            report.failure = Some(e.to_string());
            write_report(&dir, &report, &fp, outputs.plots)?;
            eprintln!(
                "report (marked {}): {}",
                report.status,
                dir.join("report.json").display()
            );
            return Err(e.into());
        }
    };
    if let Some(exact) = &setup.problem.exact {
        let (l, m) = (setup.problem.lambda, setup.problem.mu);
        let dofs = &setup.op.dofs;
        report.error = Some(error_norms(
            &setup.grid,
            &setup.cells,
            dofs,
            &solution.u,
            exact,
            l,
            m,
        ));
        let ui = interpolate(&setup.grid, dofs, exact);
        report.interpolant_error = Some(error_norms(
            &setup.grid,
            &setup.cells,
            dofs,
            &ui,
            exact,
            l,
            m,
        ));
    }
    let mut reactions: BTreeMap<String, [f64; 3]> = BTreeMap::new();
    for (p, r) in setup.dirichlet.iter().zip(&solution.reactions) {
        let e = reactions
            .entry(case.geometry.tag_name(p.tag).to_string())
            .or_default();
        for i in 0..3 {
            e[i] += p.w * r[i];
        }
    }
    report.reactions = reactions;

    let t = Instant::now();
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    write_solution(&setup, &solution.u, &dir.join("solution.vtu"))?;
    report
        .timings
        .insert("output".into(), t.elapsed().as_secs_f64());
    write_report(&dir, &report, &fp, outputs.plots)?;

    println!(
        "  {} {}: {} fixed-point iterations, Krylov iterations {:?} (total {}), final residual {:.2e}",
        so.method.name(),
        format!("{:?}", so.preconditioner).to_lowercase(),
        fp.iterations,
        fp.iterations_per_solve,
        fp.total_iterations,
        fp.final_relative_residual
    );
    if let (Some(e), Some(ei)) = (&report.error, &report.interpolant_error) {
        println!(
            "  energy error {:.4e} (relative {:.4e}; interpolant {:.4e}), L2 relative {:.4e}",
            e.energy, e.energy_relative, ei.energy_relative, e.l2_relative
        );
    }
    for (tag, r) in &report.reactions {
        println!(
            "  reaction on '{tag}': [{:.6e}, {:.6e}, {:.6e}]",
            r[0], r[1], r[2]
        );
    }
    println!(
        "  wrote {} and solution.vtu{}",
        dir.join("report.json").display(),
        if outputs.plots { ", residuals.svg" } else { "" }
    );
    Ok(())
}
