//! `cgfem-gpu reproduce cut-sweep`: how robust the conditioning is to where
//! the grid cuts the body. The sphere (Problem 1) is run at each level under
//! `N` seeded random grid offsets (each component uniform in [0, 1) cells),
//! without and with the S-term; per level and stabilisation the largest and
//! median κ (plain and Jacobi-scaled) and Krylov iterations: of the first
//! solve `A U_0 = F` with the plain method (the paper's: what κ costs an
//! unpreconditioned solver; the whole fixed-point loop unpreconditioned is
//! too slow to sweep), of the first solve and the whole fixed-point
//! loop with Jacobi, and of the first solve with CG and the multigrid
//! V-cycle ([`crate::multigrid`]; CG whatever the sweep's method, since
//! the V-cycle is the SPD preconditioner CG needs).
//!
//! A Krylov solve that does not converge within the per-solve budget is a
//! measurement, not an error: it counts with the iterations it spent and in
//! `failures`; a level's worst case with failures is at least the budget.
//! Writes `cut-sweep.json` (`rows`: one per level, element and stabilisation;
//! `runs`: every offset), `cut-sweep.md` and `cut-sweep.svg`.

use std::path::Path;

use serde::Serialize;

use super::{median, run_sphere, write_outputs, RunConfig, Runs};
use crate::case::Case;
use crate::element::ElementOrder;
use crate::error::Result;
use crate::plot::{Chart, Series};
use crate::progress::Progress;
use crate::solver::{KrylovMethod, Preconditioner};

/// Settings of the sweep.
#[derive(Clone, Debug)]
pub struct CutSweepOptions {
    pub levels: Vec<u32>,
    /// Number of random offsets per level.
    pub offsets: usize,
    pub seed: u64,
    /// `(k2, A)` of the stabilised runs (the runs without use k2 = 0).
    pub k2: f64,
    pub a: f64,
    /// Krylov budget per solve.
    pub max_iterations: usize,
    /// Estimate κ (assembles and factorises: the dominant cost at level 6).
    pub condition: bool,
    /// The Krylov method (the paper's CGS by default).
    pub method: KrylovMethod,
}

impl CutSweepOptions {
    /// The Q2 sphere's own S-term (`case`'s k2 and Q2 threshold: the
    /// defaults, k2 = 0.01 and A = 20%) and CG (CGS diverges on Q2); for
    /// Q1 these options as they are (the paper's k2 = 0.01, A = 1% with
    /// CGS).
    pub fn with_case_stabilisation(self, case: &Case) -> Self {
        let st = &case.spec.stabilisation;
        match case.body().spec.element {
            ElementOrder::Q2 => CutSweepOptions {
                k2: st.k2,
                a: st.threshold(ElementOrder::Q2),
                method: KrylovMethod::Cg,
                ..self
            },
            ElementOrder::Q1 => self,
        }
    }
}

impl Default for CutSweepOptions {
    fn default() -> Self {
        CutSweepOptions {
            levels: vec![4, 5, 6],
            offsets: 50,
            seed: 2024,
            k2: 0.01,
            a: 0.01,
            max_iterations: 5000,
            condition: true,
            method: KrylovMethod::Cgs,
        }
    }
}

/// One run of the sweep (`runs` in the JSON).
#[derive(Clone, Debug, Serialize)]
pub struct SweepRun {
    pub level: u32,
    pub element: String,
    pub offset: [f64; 3],
    pub stabilised: bool,
    pub pathological: usize,
    pub kappa: Option<f64>,
    pub kappa_is_lower_bound: Option<bool>,
    pub kappa_jacobi: Option<f64>,
    pub first_solve_plain: usize,
    pub converged_plain: bool,
    pub iterations_jacobi: usize,
    pub first_solve_jacobi: usize,
    pub converged_jacobi: bool,
    pub first_solve_multigrid: usize,
    pub converged_multigrid: bool,
}

/// One row of `cut-sweep.json`: a level, element and stabilisation.
#[derive(Clone, Debug, Serialize)]
pub struct SweepRow {
    pub level: u32,
    pub element: String,
    pub stabilised: bool,
    pub k2: f64,
    #[serde(rename = "A")]
    pub a: f64,
    pub offsets: usize,
    pub kappa_max: Option<f64>,
    pub kappa_median: Option<f64>,
    /// Runs whose κ is only a lower bound (numerically singular matrix).
    pub kappa_lower_bounds: usize,
    pub kappa_jacobi_max: Option<f64>,
    pub kappa_jacobi_median: Option<f64>,
    pub first_solve_plain_max: usize,
    pub first_solve_plain_median: f64,
    pub failures_plain: usize,
    pub iterations_jacobi_max: usize,
    pub iterations_jacobi_median: f64,
    pub first_solve_jacobi_max: usize,
    pub first_solve_jacobi_median: f64,
    pub failures_jacobi: usize,
    pub first_solve_multigrid_max: usize,
    pub first_solve_multigrid_median: f64,
    pub failures_multigrid: usize,
}

/// SplitMix64: a documented, seedable generator for the offsets, so that a
/// sweep is reproducible from its seed alone.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The `n` offsets of a sweep: the same for every level and stabilisation.
pub fn offsets(n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut g = SplitMix64(seed);
    (0..n)
        .map(|_| [g.next_unit(), g.next_unit(), g.next_unit()])
        .collect()
}

/// Runs the sweep and writes the files; returns the summary rows.
/// Each run is reported to `progress` ([`crate::progress::Phase::Runs`]).
pub fn cut_sweep(
    case: &Case,
    opts: &CutSweepOptions,
    out: &Path,
    progress: &dyn Progress,
) -> Result<Vec<SweepRow>> {
    let element = format!("{:?}", case.body().spec.element).to_lowercase();
    let offsets = offsets(opts.offsets, opts.seed);
    let progress = Runs::start(progress, opts.levels.len() * 2 * offsets.len());
    let mut runs = Vec::new();
    let mut rows = Vec::new();
    for &level in &opts.levels {
        for stabilised in [false, true] {
            let k2 = if stabilised { opts.k2 } else { 0.0 };
            let mut these = Vec::new();
            for (i, &offset) in offsets.iter().enumerate() {
                let run = sweep_run(case, opts, level, k2, offset)?;
                progress.done(format!(
                    "cut-sweep {element} level {level}, {} S, offset {i} {:?}: κ = {}, first solve {} (plain{}), {} (Jacobi{}), {} (CG + multigrid{})",
                    if stabilised { "with" } else { "without" },
                    offset.map(|v| (v * 1000.0).round() / 1000.0),
                    run.kappa.map_or("–".into(), |k| format!("{k:.3e}")),
                    run.first_solve_plain,
                    if run.converged_plain { "" } else { ", not converged" },
                    run.iterations_jacobi,
                    if run.converged_jacobi { " accumulated" } else { ", not converged" },
                    run.first_solve_multigrid,
                    if run.converged_multigrid { "" } else { ", not converged" },
                ));
                these.push(run);
            }
            rows.push(summarise(&these, level, &element, stabilised, k2, opts.a));
            runs.extend(these);
        }
    }
    progress.finish();
    let json = serde_json::json!({ "rows": rows, "runs": runs });
    write_outputs(
        out,
        "cut-sweep",
        &json,
        &markdown(&rows, opts),
        &chart(&runs).to_svg()?,
    )?;
    Ok(rows)
}

fn sweep_run(
    case: &Case,
    opts: &CutSweepOptions,
    level: u32,
    k2: f64,
    offset: [f64; 3],
) -> Result<SweepRun> {
    let base = RunConfig {
        offset,
        method: Some(opts.method),
        max_iterations: Some(opts.max_iterations),
        ..RunConfig::new(level, k2, opts.a)
    };
    let plain = run_sphere(
        case,
        &RunConfig {
            preconditioner: Some(Preconditioner::None),
            condition: opts.condition,
            first_solve_only: true,
            ..base.clone()
        },
    )?;
    let jacobi = run_sphere(
        case,
        &RunConfig {
            preconditioner: Some(Preconditioner::Jacobi),
            ..base.clone()
        },
    )?;
    let multigrid = run_sphere(
        case,
        &RunConfig {
            method: Some(KrylovMethod::Cg),
            preconditioner: Some(Preconditioner::Multigrid),
            first_solve_only: true,
            ..base
        },
    )?;
    Ok(SweepRun {
        level,
        element: format!("{:?}", case.body().spec.element).to_lowercase(),
        offset,
        stabilised: k2 > 0.0,
        pathological: plain.pathological,
        kappa: plain.kappa.as_ref().map(|k| k.kappa),
        kappa_is_lower_bound: plain.kappa.as_ref().map(|k| k.kappa_is_lower_bound),
        kappa_jacobi: plain.kappa_jacobi.as_ref().map(|k| k.kappa),
        first_solve_plain: plain.first_solve_iterations,
        converged_plain: plain.failure.is_none(),
        iterations_jacobi: jacobi.krylov_iterations,
        first_solve_jacobi: jacobi.first_solve_iterations,
        converged_jacobi: jacobi.failure.is_none(),
        first_solve_multigrid: multigrid.first_solve_iterations,
        converged_multigrid: multigrid.failure.is_none(),
    })
}

fn summarise(
    runs: &[SweepRun],
    level: u32,
    element: &str,
    stabilised: bool,
    k2: f64,
    a: f64,
) -> SweepRow {
    let stat = |v: Vec<f64>| -> (Option<f64>, Option<f64>) {
        if v.is_empty() {
            (None, None)
        } else {
            (
                Some(v.iter().cloned().fold(f64::MIN, f64::max)),
                Some(median(&v)),
            )
        }
    };
    let (kappa_max, kappa_median) = stat(runs.iter().filter_map(|r| r.kappa).collect());
    let (kappa_jacobi_max, kappa_jacobi_median) =
        stat(runs.iter().filter_map(|r| r.kappa_jacobi).collect());
    let its = |f: fn(&SweepRun) -> usize| -> (usize, f64) {
        let v: Vec<f64> = runs.iter().map(|r| f(r) as f64).collect();
        (runs.iter().map(f).max().unwrap_or(0), median(&v))
    };
    let (iterations_jacobi_max, iterations_jacobi_median) = its(|r| r.iterations_jacobi);
    let (first_solve_plain_max, first_solve_plain_median) = its(|r| r.first_solve_plain);
    let (first_solve_jacobi_max, first_solve_jacobi_median) = its(|r| r.first_solve_jacobi);
    let (first_solve_multigrid_max, first_solve_multigrid_median) =
        its(|r| r.first_solve_multigrid);
    SweepRow {
        level,
        element: element.into(),
        stabilised,
        k2,
        a,
        offsets: runs.len(),
        kappa_max,
        kappa_median,
        kappa_lower_bounds: runs
            .iter()
            .filter(|r| r.kappa_is_lower_bound == Some(true))
            .count(),
        kappa_jacobi_max,
        kappa_jacobi_median,
        first_solve_plain_max,
        first_solve_plain_median,
        failures_plain: runs.iter().filter(|r| !r.converged_plain).count(),
        iterations_jacobi_max,
        iterations_jacobi_median,
        first_solve_jacobi_max,
        first_solve_jacobi_median,
        failures_jacobi: runs.iter().filter(|r| !r.converged_jacobi).count(),
        first_solve_multigrid_max,
        first_solve_multigrid_median,
        failures_multigrid: runs.iter().filter(|r| !r.converged_multigrid).count(),
    }
}

fn markdown(rows: &[SweepRow], opts: &CutSweepOptions) -> String {
    let e = |v: Option<f64>| v.map_or("–".into(), |v| format!("{v:.3e}"));
    let mut s = format!(
        "# Cut sweep: the sphere under {} random grid offsets (seed {})\n\n\
         κ of the operator (Lanczos / shift-invert Lanczos; `≥` where some matrix\n\
         was numerically singular and κ is a lower bound), the Jacobi-scaled κ, and\n\
         the Krylov iterations ({}) of the first solve (`A U_0 = F`), plain, and of\n\
         the first solve and accumulated over the fixed-point loop with Jacobi,\n\
         and of the first solve with CG + multigrid (max / median over the\n\
         offsets). Budget {} iterations per solve; a run\n\
         over budget counts in `failed` with the iterations it spent. S-term:\n\
         k2 = {}, A = {}.\n\n\
         | level | element | S-term | κ max | κ median | κ_J max | κ_J median | plain: first solve | plain failed | Jacobi: first solve | Jacobi: accumulated | Jacobi failed | CG + multigrid: first solve | multigrid failed |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        opts.offsets, opts.seed, opts.method, opts.max_iterations, opts.k2, opts.a
    );
    for r in rows {
        let bound = if r.kappa_lower_bounds > 0 { "≥ " } else { "" };
        s += &format!(
            "| {} | {} | {} | {bound}{} | {} | {} | {} | {} / {} | {} | {} / {} | {} / {} | {} | {} / {} | {} |\n",
            r.level,
            r.element,
            if r.stabilised { "with" } else { "without" },
            e(r.kappa_max),
            e(r.kappa_median),
            e(r.kappa_jacobi_max),
            e(r.kappa_jacobi_median),
            r.first_solve_plain_max,
            r.first_solve_plain_median,
            r.failures_plain,
            r.first_solve_jacobi_max,
            r.first_solve_jacobi_median,
            r.iterations_jacobi_max,
            r.iterations_jacobi_median,
            r.failures_jacobi,
            r.first_solve_multigrid_max,
            r.first_solve_multigrid_median,
            r.failures_multigrid,
        );
    }
    s
}

/// κ of every run against its offset index, per level and stabilisation.
fn chart(runs: &[SweepRun]) -> Chart {
    let mut keys: Vec<(u32, bool)> = runs.iter().map(|r| (r.level, r.stabilised)).collect();
    keys.dedup();
    let element = runs.first().map_or(String::new(), |r| r.element.clone());
    let series = keys
        .into_iter()
        .map(|(level, stabilised)| Series {
            label: format!(
                "{element} level {level}, {} S",
                if stabilised { "with" } else { "without" }
            ),
            points: runs
                .iter()
                .filter(|r| r.level == level && r.stabilised == stabilised)
                .enumerate()
                .filter_map(|(i, r)| r.kappa.map(|k| (i as f64, k)))
                .collect(),
            reference: false,
        })
        .collect();
    Chart {
        title: "Cut sweep: κ of the sphere per grid offset".into(),
        x_label: "offset index".into(),
        y_label: "κ".into(),
        x_log: false,
        series,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_are_reproducible_and_in_the_unit_cube() {
        let a = offsets(50, 7);
        assert_eq!(a, offsets(50, 7));
        assert_ne!(a, offsets(50, 8));
        assert!(a.iter().flatten().all(|v| (0.0..1.0).contains(v)));
        let mean: f64 = a.iter().flatten().sum::<f64>() / 150.0;
        assert!((mean - 0.5).abs() < 0.1, "{mean}");
    }
}
