//! `cgfem-gpu bench`: operator and solver throughput on the paper's
//! sphere (Q1, and Q2 when asked) for the CPU backends and the GPU, in one
//! process, as rows of `bench.json`.
//!
//! Per element order, level and thread count (each run inside its own rayon
//! pool):
//! - `apply`: `y = A x` by the matrix-free operator (`cpu-mf`), by faer's
//!   sparse × dense product of the assembled matrix (`cpu-csr`, one thread: faer
//!   does not split a single vector) and by a row-parallel CSR product
//!   (`cpu-csr-rayon`, [`csr`]);
//! - `cg_iter`, `cgs_iter`: one unpreconditioned iteration of each method per
//!   backend, `(t(K+2) − t(2)) / K` from solves capped at `K + 2` and `2`
//!   iterations, so the solve's start and end are not counted;
//! - `bandwidth`: the STREAM triad per thread count ([`measure`]), the
//!   reference for the bandwidth fraction
//!   `(bytes_per_dof + 16) · dofs_per_s / triad bytes/s` of an apply (operator
//!   data plus reading `x` and writing `y`, 8 bytes each per dof);
//! - `solve` at the solve levels: the first linear system of the fixed-point
//!   loop, `A u = F`, by the case's Krylov method and Jacobi on the
//!   matrix-free operator (`cpu-mf`), by CG and the multigrid V-cycle
//!   (`cpu-mg`, [`crate::multigrid`], the hierarchy's set-up included) and by
//!   assembly plus sparse Cholesky (`cpu-direct`, [`direct`],
//!   nested-dissection ordering [`ordering`]), each with its peak resident
//!   memory and the Krylov rows with their iterations.
//!
//! - `stl_load` and `classify` ([`stl`], with `--stl-level`): reading and
//!   cutting a 131 072-facet STL sphere against the analytic sphere.
//!
//! - on the preferred GPU adapter, when `gpu` is asked for and one is found:
//!   its copy-kernel bandwidth and the same apply and iteration rows
//!   ([`gpu`]), per precision.
//!
//! Rates are dofs per second (entries per second for the triad); `seconds` is
//! per call (per iteration for the `*_iter` rows); `peak_bytes` is the process's
//! peak resident memory since the level (or the solve) started.

mod csr;
mod direct;
mod gpu;
mod measure;
mod ordering;
mod stl;
mod table;

use rayon::ThreadPool;
use serde::{Deserialize, Serialize};

use crate::backend::{CpuBackend, LinearOperator};
use crate::case::Case;
use crate::driver::setup::Setup;
use crate::element::ElementOrder;
use crate::error::{Error, Result};
use crate::fem::operator::AssembledOperator;
use crate::solver::{solve, KrylovMethod, KrylovOptions, Preconditioner};

pub use csr::{csr_bytes, RayonCsr};
pub use measure::{peak_resident_bytes, reset_peak_resident, seconds_per_call, triad_seconds};
pub use measure::{TRIAD_BYTES_PER_ENTRY, TRIAD_LEN};
pub use table::{format_table, write_json};

/// One measurement, a row of `bench.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// `apply`, `cg_iter`, `cgs_iter`, `bandwidth` or `solve`.
    pub what: String,
    /// `cpu-mf`, `cpu-csr`, `cpu-csr-rayon`, `cpu-direct`, `cpu` (triad) or
    /// `gpu:<adapter>`.
    pub backend: String,
    pub element: String,
    pub precision: String,
    /// Grid level (0 for the triad).
    pub level: u32,
    /// Unknowns (array entries for the triad).
    pub dofs: usize,
    pub dofs_per_s: f64,
    /// Operator data per dof (the factor's for `cpu-direct`; bytes moved per
    /// entry for the triad).
    pub bytes_per_dof: f64,
    pub threads: usize,
    pub seconds: f64,
    pub peak_bytes: u64,
    /// `solve` rows of the Krylov methods: iterations to the tolerance.
    #[serde(default)]
    pub iterations: Option<usize>,
}

/// What to run.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    pub levels: Vec<u32>,
    pub threads: Vec<usize>,
    /// Levels of the end-to-end solves.
    pub solve_levels: Vec<u32>,
    /// Seconds spent on each timed measurement.
    pub budget: f64,
    /// Also bench the assembled matrix (`cpu-csr`, `cpu-csr-rayon`).
    pub csr: bool,
    /// Also bench the preferred GPU adapter (f64 where it can, and f32).
    pub gpu: bool,
    /// Element orders, each run at every level.
    pub elements: Vec<ElementOrder>,
    /// Levels of the STL rows ([`stl`]); none when empty.
    pub stl_levels: Vec<u32>,
}

/// Iterations timed per Krylov method (beyond the 2 subtracted).
const ITERATIONS: usize = 10;

/// Runs the benchmarks on `case_of(element)` for each element order of
/// `opts` (the paper's sphere: `cases/sphere.toml` for Q1,
/// `cases/sphere_q2.toml` for Q2, whose CG and S-term threshold Q2 needs),
/// calling `progress` with each row.
pub fn run(
    case_of: impl Fn(ElementOrder) -> Result<Case>,
    opts: &BenchOptions,
    mut progress: impl FnMut(&Row),
) -> Result<Vec<Row>> {
    let mut rows = Vec::new();
    let mut emit = |row: Row| {
        progress(&row);
        rows.push(row);
    };
    for &t in &opts.threads {
        let seconds = pool(t)?.install(|| triad_seconds(opts.budget));
        let dofs = TRIAD_LEN;
        emit(Row {
            element: "-".into(),
            bytes_per_dof: TRIAD_BYTES_PER_ENTRY,
            ..row("bandwidth", "cpu", 0, dofs, t, seconds)
        });
    }
    if !opts.stl_levels.is_empty() {
        let threads = opts.threads.iter().copied().max().unwrap_or(1);
        for r in pool(threads)?.install(|| stl::rows(&opts.stl_levels, threads))? {
            emit(r);
        }
    }
    let gpus = if opts.gpu {
        gpu::backends()
    } else {
        Vec::new()
    };
    for be in &gpus {
        emit(gpu::bandwidth(be, opts.budget));
    }
    let mut levels = opts.levels.clone();
    levels.extend(&opts.solve_levels);
    levels.sort_unstable();
    levels.dedup();
    for &element in &opts.elements {
        let case = case_of(element)?;
        let mut emit = |mut row: Row| {
            row.element = element_name(element).into();
            emit(row);
        };
        for &level in &levels {
            reset_peak_resident();
            let setup = Setup::new(&case, Some(level))?;
            if opts.solve_levels.contains(&level) {
                let threads = opts.threads.iter().copied().max().unwrap_or(1);
                let krylov = krylov_options(&case);
                for r in direct::solves(&case, &setup, &krylov, &pool(threads)?)? {
                    emit(r);
                }
            }
            if opts.levels.contains(&level) {
                for r in throughput(&setup, opts)? {
                    emit(r);
                }
                for be in &gpus {
                    for r in gpu::throughput(be, &case, &setup, opts)? {
                        emit(r);
                    }
                }
            }
        }
    }
    Ok(rows)
}

/// `q1` or `q2`, as in case files and rows.
pub fn element_name(order: ElementOrder) -> &'static str {
    match order {
        ElementOrder::Q1 => "q1",
        ElementOrder::Q2 => "q2",
    }
}

/// The Krylov settings of the case's `[solver]` table.
fn krylov_options(case: &Case) -> KrylovOptions {
    let s = &case.spec.solver;
    KrylovOptions {
        method: s.method,
        preconditioner: s.preconditioner,
        rel_tol: s.rel_tol,
        max_iterations: s.max_iterations,
    }
}

/// A rayon pool of `threads` threads.
fn pool(threads: usize) -> Result<ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::Bench {
            what: format!("a pool of {threads} threads"),
            reason: e.to_string(),
        })
}

/// A Q1 f64 row with the rate from `seconds` and the current peak memory
/// (the caller sets the element of a Q2 row).
fn row(what: &str, backend: &str, level: u32, dofs: usize, threads: usize, seconds: f64) -> Row {
    Row {
        what: what.into(),
        backend: backend.into(),
        element: "q1".into(),
        precision: "f64".into(),
        level,
        dofs,
        dofs_per_s: dofs as f64 / seconds,
        bytes_per_dof: 0.0,
        threads,
        seconds,
        peak_bytes: peak_resident_bytes(),
        iterations: None,
    }
}

/// Apply and Krylov-iteration rows of every backend and thread count.
fn throughput(setup: &Setup, opts: &BenchOptions) -> Result<Vec<Row>> {
    let level = setup.grid.level;
    let n = setup.op.nrows();
    let per_dof = |bytes: usize| bytes as f64 / n as f64;
    let csc = opts.csr.then(|| AssembledOperator(setup.op.assemble()));
    let rayon_csr = csc.as_ref().map(RayonCsr);
    let mut backends: Vec<(&str, &(dyn LinearOperator + Sync), f64)> =
        vec![("cpu-mf", &setup.op, per_dof(setup.op.bytes()))];
    if let (Some(csc), Some(rayon_csr)) = (&csc, &rayon_csr) {
        backends.push(("cpu-csr", csc, per_dof(csr_bytes(csc))));
        backends.push(("cpu-csr-rayon", rayon_csr, per_dof(csr_bytes(csc))));
    }
    let x: Vec<f64> = (0..n)
        .map(|i| ((i * 7919) % 1000) as f64 / 500.0 - 1.0)
        .collect();
    let mut b = vec![0.0; n];
    setup.op.apply(&x, &mut b);
    let mut rows = Vec::new();
    for &t in &opts.threads {
        let pool = pool(t)?;
        for &(name, op, bytes_per_dof) in &backends {
            // faer's product is sequential: one row, at one thread.
            if name == "cpu-csr" && t != 1 {
                continue;
            }
            let mut y = vec![0.0; n];
            let apply = pool.install(|| seconds_per_call(opts.budget, || op.apply(&x, &mut y)));
            rows.push(Row {
                bytes_per_dof,
                ..row("apply", name, level, n, t, apply)
            });
            for (what, method) in [
                ("cg_iter", KrylovMethod::Cg),
                ("cgs_iter", KrylovMethod::Cgs),
            ] {
                let seconds =
                    pool.install(|| seconds_per_iteration(op, method, &b, opts.budget))?;
                rows.push(Row {
                    bytes_per_dof,
                    ..row(what, name, level, n, t, seconds)
                });
            }
        }
    }
    Ok(rows)
}

/// Seconds per unpreconditioned iteration of `method` on `A x = b`.
fn seconds_per_iteration(
    op: &dyn LinearOperator,
    method: KrylovMethod,
    b: &Vec<f64>,
    budget: f64,
) -> Result<f64> {
    let be = CpuBackend::new();
    let mut failure = None;
    let mut timed = |iterations: usize| {
        let opts = KrylovOptions {
            method,
            preconditioner: Preconditioner::None,
            rel_tol: f64::MIN_POSITIVE,
            max_iterations: iterations,
        };
        let mut x = vec![0.0; b.len()];
        seconds_per_call(budget / 2.0, || {
            match solve(&be, op, None, b, &mut x, &opts) {
                Err(Error::MaxIterations { .. }) => {}
                Err(e) => failure = Some(e),
                Ok(_) => {
                    failure = Some(Error::Bench {
                        what: format!("timing {method}"),
                        reason: "converged to the smallest tolerance".into(),
                    })
                }
            }
        })
    };
    let short = timed(2);
    let long = timed(2 + ITERATIONS);
    match failure {
        Some(e) => Err(e),
        None => Ok(((long - short) / ITERATIONS as f64).max(f64::MIN_POSITIVE)),
    }
}
