//! The end-to-end solve rows: the first linear system of the fixed-point loop,
//! `A u = F` (`F` the fixed right-hand side), by the case's Krylov method on the
//! matrix-free operator against assembly plus sparse Cholesky (faer's
//! supernodal factor, geometric nested-dissection ordering, [`super::ordering`]),
//! each timed from scratch with its own peak resident memory. The direct
//! solve is skipped, with the reason printed, when its factor would take more
//! than half the available memory.

use std::time::Instant;

use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::SymmetricOrdering;
use faer::Par;
use rayon::ThreadPool;

use super::measure::reset_peak_resident;
use super::ordering::nested_dissection;
use super::{row, Row};
use crate::backend::{CpuBackend, LinearOperator};
use crate::condition::sparse::Cholesky;
use crate::error::{Error, Result};
use crate::fem::setup::Setup;
use crate::grid::machine_memory_bytes;
use crate::solver::{solve, KrylovOptions};

/// The `solve` rows of `cpu-mf` and `cpu-direct`, run in `pool`. Prints the
/// phases and how far the two solutions differ.
pub(super) fn solves(setup: &Setup, krylov: &KrylovOptions, pool: &ThreadPool) -> Result<Vec<Row>> {
    let (level, n, f) = (setup.grid.level, setup.op.nrows(), &setup.fixed_rhs);
    let threads = pool.current_num_threads();
    let op = &setup.op;

    reset_peak_resident();
    let t = Instant::now();
    let mut u_mf = vec![0.0; n];
    let stats = pool.install(|| {
        let diag = op.diagonal();
        solve(&CpuBackend::new(), op, Some(&diag), f, &mut u_mf, krylov)
    })?;
    let mf = Row {
        bytes_per_dof: op.bytes() as f64 / n as f64,
        ..row(
            "solve",
            "cpu-mf",
            level,
            n,
            threads,
            t.elapsed().as_secs_f64(),
        )
    };
    println!(
        "solve level {level}: cpu-mf {} {} iterations, {:.2} s",
        krylov.method, stats.iterations, mf.seconds
    );

    reset_peak_resident();
    let t = Instant::now();
    let (u_direct, factor_len) = match pool.install(|| cholesky_solve(setup, threads)) {
        Ok(r) => r,
        Err(e) => {
            println!("solve level {level}: cpu-direct skipped: {e}");
            return Ok(vec![mf]);
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
    let diff = u_mf
        .iter()
        .zip(&u_direct)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    let scale = u_direct.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    println!(
        "solve level {level}: cpu-direct {:.2} s, factor {:.1} M entries; \
         max |u_mf − u_direct| / max |u_direct| = {:.1e}",
        direct.seconds,
        factor_len as f64 / 1e6,
        diff / scale
    );
    Ok(vec![mf, direct])
}

/// Assembles `A`, factors it and solves `A u = F`; returns `u` and the
/// number of entries of the factor.
fn cholesky_solve(setup: &Setup, threads: usize) -> Result<(Vec<f64>, usize)> {
    let t = Instant::now();
    let a = setup.op.assemble();
    let assembled = t.elapsed().as_secs_f64();
    let max_bytes = (available_memory_bytes() / 2) as usize;
    let failed = |reason: String| Error::Bench {
        what: "sparse Cholesky of the assembled operator".into(),
        reason,
    };
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

/// `MemAvailable` of `/proc/meminfo` (the machine's memory where unknown).
fn available_memory_bytes() -> u64 {
    let text = std::fs::read_to_string("/proc/meminfo").unwrap_or_default();
    text.lines()
        .find_map(|l| l.strip_prefix("MemAvailable:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        .map_or_else(machine_memory_bytes, |kb| kb * 1024)
}
