//! The bench table as text, and `bench.json`.
//!
//! Beside each rate the table shows
//! - `×ref`: the rate over the reference of its kind at the same level: faer's
//!   one-thread `cpu-csr` for `apply` and `*_iter`, `cpu-direct` (same
//!   threads) for `solve`;
//! - `×1t`: the rate over the same row at one thread;
//! - `its` (`solve` rows of the Krylov methods): iterations to the tolerance;
//! - `%bw` (applies): bytes moved per second over the triad's at the same
//!   thread count (CPU) or the copy kernel's (GPU, same precision): on the
//!   CPU `(bytes_per_dof + 16) · dofs_per_s`, operator data plus `x` and
//!   `y`; a GPU row's `bytes_per_dof` already counts `x` and `y`.

use std::fmt::Write;
use std::path::Path;

use super::Row;
use crate::error::{Error, Result};

/// The rate of the first row matching `pred`.
fn rate(rows: &[Row], pred: impl Fn(&Row) -> bool) -> Option<f64> {
    rows.iter().find(|r| pred(r)).map(|r| r.dofs_per_s)
}

/// `a / b` formatted, or `-` when there is no `b`.
fn ratio(a: f64, b: Option<f64>, unit: &str) -> String {
    b.map_or("-".into(), |b| format!("{:.2}{unit}", a / b))
}

/// The reference rate of `r` (see the module doc).
fn reference(rows: &[Row], r: &Row) -> Option<f64> {
    let (backend, threads) = if r.what == "solve" {
        ("cpu-direct", r.threads)
    } else {
        ("cpu-csr", 1)
    };
    rate(rows, |q| {
        q.what == r.what
            && q.element == r.element
            && q.level == r.level
            && q.backend == backend
            && q.threads == threads
    })
}

/// The bandwidth fraction of an apply row, in percent: against the triad at
/// the same thread count on the CPU, against the device copy kernel of the
/// same adapter and precision on a GPU.
fn bandwidth(rows: &[Row], r: &Row) -> String {
    let reference = if r.backend.starts_with("gpu:") {
        rows.iter()
            .find(|q| q.what == "bandwidth" && q.backend == r.backend && q.precision == r.precision)
    } else {
        rows.iter()
            .find(|q| q.what == "bandwidth" && q.backend == "cpu" && q.threads == r.threads)
    };
    match (r.what.as_str(), reference) {
        ("apply" | "apply_gather", Some(q)) => {
            let value_bytes = if r.precision == "f32" { 4.0 } else { 8.0 };
            let vectors = match r.backend.starts_with("gpu:") {
                true => 0.0,
                false => 2.0 * value_bytes,
            };
            let moved = (r.bytes_per_dof + vectors) * r.dofs_per_s;
            format!("{:.0}%", 100.0 * moved / (q.dofs_per_s * q.bytes_per_dof))
        }
        _ => "-".into(),
    }
}

/// The rows as an aligned text table.
pub fn format_table(rows: &[Row]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:<12} {:<14} {:<3} {:>3} {:>9} {:>3} {:>9} {:>7} {:>6} {:>5} {:>8} {:>10} {:>8} {:>5}",
        "what",
        "backend",
        "el",
        "lvl",
        "dofs",
        "thr",
        "Mdofs/s",
        "×ref",
        "×1t",
        "%bw",
        "B/dof",
        "seconds",
        "peak MB",
        "its"
    );
    for r in rows {
        let one = rate(rows, |q| {
            q.what == r.what
                && q.backend == r.backend
                && q.element == r.element
                && q.precision == r.precision
                && q.level == r.level
                && q.threads == 1
        });
        let _ = writeln!(
            s,
            "{:<12} {:<14} {:<3} {:>3} {:>9} {:>3} {:>9.2} {:>7} {:>6} {:>5} {:>8.1} {:>10.3e} {:>8.0} {:>5}",
            r.what,
            r.backend,
            r.element,
            r.level,
            r.dofs,
            r.threads,
            r.dofs_per_s / 1e6,
            ratio(r.dofs_per_s, reference(rows, r), "×"),
            ratio(r.dofs_per_s, one, "×"),
            bandwidth(rows, r),
            r.bytes_per_dof,
            r.seconds,
            r.peak_bytes as f64 / (1 << 20) as f64,
            r.iterations.map_or("-".into(), |i| i.to_string())
        );
    }
    s
}

/// Writes `dir/bench.json`: `{"rows": [...]}`.
pub fn write_json(rows: &[Row], dir: &Path) -> Result<()> {
    let io = |e: std::io::Error| Error::Io {
        path: dir.join("bench.json").display().to_string(),
        reason: e.to_string(),
    };
    std::fs::create_dir_all(dir).map_err(io)?;
    let json = serde_json::json!({ "rows": rows });
    let text = serde_json::to_vec_pretty(&json).map_err(|e| io(e.into()))?;
    crate::output::write_atomic(&dir.join("bench.json"), &text)
}
