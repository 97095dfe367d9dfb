//! The end-to-end solve rows: the first linear system of the fixed-point loop,
//! `A u = F` (`F` the fixed right-hand side), by the case's Krylov method with
//! Jacobi and by CG with the multigrid V-cycle on the matrix-free operator,
//! against assembly plus sparse Cholesky (faer's
//! supernodal factor, geometric nested-dissection ordering, [`super::ordering`]),
//! each timed from scratch with its own peak resident memory. The direct
//! solve is skipped, with the reason printed, when its assembly or its factor
//! would take more than half the available memory.

use std::time::Instant;

use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::SymmetricOrdering;
use faer::Par;
use rayon::ThreadPool;

use super::measure::reset_peak_resident;
use super::ordering::nested_dissection;
use super::{row, Row};
use crate::backend::{CpuBackend, LinearOperator};
use crate::case::Case;
use crate::condition::sparse::Cholesky;
use crate::driver::setup::Setup;
use crate::error::{Error, Result};
use crate::grid::machine_memory_bytes;
use crate::multigrid::{Hierarchy, Multigrid, MultigridOptions};
use crate::solver::{solve, solve_preconditioned, KrylovMethod, KrylovOptions, Preconditioner};

/// The `solve` rows of `cpu-mf` (the case's method, Jacobi), `cpu-mg` (CG,
/// multigrid) and `cpu-direct`, run in `pool`. Prints the phases and how far
/// the solutions differ.
pub(super) fn solves(
    case: &Case,
    setup: &Setup,
    krylov: &KrylovOptions,
    pool: &ThreadPool,
) -> Result<Vec<Row>> {
    let level = setup.grid.level;
    let jacobi = KrylovOptions {
        preconditioner: Preconditioner::Jacobi,
        ..krylov.clone()
    };
    let multigrid = KrylovOptions {
        method: KrylovMethod::Cg,
        preconditioner: Preconditioner::Multigrid,
        ..krylov.clone()
    };
    let (mf, u_mf) = krylov_row(case, setup, &jacobi, pool)?;
    let (mg, u_mg) = krylov_row(case, setup, &multigrid, pool)?;
    let mut rows = vec![mf, mg];
    let threads = pool.current_num_threads();
    let n = setup.op.nrows();
    reset_peak_resident();
    let t = Instant::now();
    let (u_direct, factor_len) = match pool.install(|| cholesky_solve(setup, threads)) {
        Ok(r) => r,
        Err(e) => {
            println!("solve level {level}: cpu-direct skipped: {e}");
            return Ok(rows);
        }
    };
    let direct = Row {
        bytes_per_dof: 8.0 * factor_len as f64 / n as f64,
        ..row(
            "solve",
            "cpu-direct",
            level,
            n,
            threads,
            t.elapsed().as_secs_f64(),
        )
    };
    println!(
        "solve level {level}: cpu-direct {:.2} s, factor {:.1} M entries; \
         max |u − u_direct| / max |u_direct|: cpu-mf {:.1e}, cpu-mg {:.1e}",
        direct.seconds,
        factor_len as f64 / 1e6,
        relative_difference(&u_mf, &u_direct),
        relative_difference(&u_mg, &u_direct)
    );
    rows.push(direct);
    Ok(rows)
}

/// `max |u − v| / max |v|`.
fn relative_difference(u: &[f64], v: &[f64]) -> f64 {
    let diff = u
        .iter()
        .zip(v)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    diff / v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// The matrix-free solve of `A u = F` from zero with `krylov`, from scratch
/// (for multigrid, the hierarchy's set-up included): its row (`cpu-mf` for
/// Jacobi, `cpu-mg` for multigrid) and `u`.
fn krylov_row(
    case: &Case,
    setup: &Setup,
    krylov: &KrylovOptions,
    pool: &ThreadPool,
) -> Result<(Row, Vec<f64>)> {
    let (level, n, f) = (setup.grid.level, setup.op.nrows(), &setup.fixed_rhs);
    let op = &setup.op;
    let multigrid = krylov.preconditioner == Preconditioner::Multigrid;
    reset_peak_resident();
    let t = Instant::now();
    let mut u = vec![0.0; n];
    let stats = pool.install(|| {
        let be = CpuBackend::new();
        if multigrid {
            let h = Hierarchy::new(
                case,
                &setup.problem,
                &setup.cells,
                op,
                &MultigridOptions::default(),
            )?;
            let mg = Multigrid::new(op, &h);
            solve_preconditioned(&be, op, &mg, f, &mut u, krylov)
        } else {
            let diag = op.diagonal();
            solve(&be, op, Some(&diag), f, &mut u, krylov)
        }
    })?;
    let backend = if multigrid { "cpu-mg" } else { "cpu-mf" };
    let threads = pool.current_num_threads();
    let r = Row {
        bytes_per_dof: op.bytes() as f64 / n as f64,
        iterations: Some(stats.iterations),
        ..row(
            "solve",
            backend,
            level,
            n,
            threads,
            t.elapsed().as_secs_f64(),
        )
    };
    println!(
        "solve level {level}: {backend} {} + {} {} iterations, {:.2} s",
        krylov.method,
        krylov.preconditioner.name(),
        stats.iterations,
        r.seconds
    );
    Ok((r, u))
}

/// Assembles `A`, factors it and solves `A u = F`; returns `u` and the
/// number of entries of the factor.
fn cholesky_solve(setup: &Setup, threads: usize) -> Result<(Vec<f64>, usize)> {
    let max_bytes = (available_memory_bytes() / 2) as usize;
    let failed = |reason: String| Error::Bench {
        what: "sparse Cholesky of the assembled operator".into(),
        reason,
    };
    // Checked before assembling: the assembly alone can exceed the memory
    // (level 8 of the sphere: 27 M rows, up to 70 GB).
    let csr = assembly_bytes(setup);
    if csr > max_bytes {
        return Err(failed(format!(
            "assembling the matrix needs up to {:.1} GB, over the limit of {:.1} GB",
            csr as f64 / 1e9,
            max_bytes as f64 / 1e9
        )));
    }
    let t = Instant::now();
    let a = setup.op.assemble();
    let assembled = t.elapsed().as_secs_f64();
    let (forward, inverse) = nested_dissection(&setup.op);
    let ordering = SymmetricOrdering::Custom(PermRef::new_checked(&forward, &inverse, a.nrows()));
    let factor =
        Cholesky::with_ordering(&a, ordering, Par::rayon(threads), max_bytes).map_err(failed)?;
    let factored = t.elapsed().as_secs_f64();
    let mut u = setup.fixed_rhs.clone();
    factor.solve_in_place(&mut u);
    println!(
        "  direct: assembly {assembled:.2} s, factorisation {:.2} s, solve {:.2} s",
        factored - assembled,
        t.elapsed().as_secs_f64() - factored
    );
    Ok((u, factor.len()))
}

/// An upper bound of the bytes held while assembling the operator: each of
/// its rows has at most `3 (2p + 1)³` entries (the nodes of the cells around
/// a node), each 16 bytes (value and row index), held twice (the per-node
/// rows and the column-major matrix built from them).
fn assembly_bytes(setup: &Setup) -> usize {
    let span = 2 * setup.op.dofs.order.degree() + 1;
    2 * 16 * 3 * span.pow(3) * setup.op.nrows()
}

/// `MemAvailable` of `/proc/meminfo` (the machine's memory where unknown).
fn available_memory_bytes() -> u64 {
    let text = std::fs::read_to_string("/proc/meminfo").unwrap_or_default();
    text.lines()
        .find_map(|l| l.strip_prefix("MemAvailable:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        .map_or_else(machine_memory_bytes, |kb| kb * 1024)
}
