//! `cgfem-gpu reproduce fig3`: the paper's Figure 3, the energy-norm error of
//! the sphere (Problem 1) against the mesh size, with and without the S-term,
//! as `fig3.json` (rows), `fig3.md` and `fig3.svg` (log–log error against
//! dofs, with a reference slope of the optimal rate).
//!
//! The paper draws the curves without printing their values; it says every
//! case converges at the right rate for a linear discretisation (rate 1 in h,
//! −1/3 in dofs for Q1), which is what the table compares with.

use std::path::Path;

use serde::Serialize;

use super::table1::CONFIGS;
use super::{rate, run_sphere, write_outputs, RunConfig};
use crate::case::Case;
use crate::error::{Error, Result};
use crate::plot::{Chart, Series};

/// One row of `fig3.json`.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Fig3Row {
    pub level: u32,
    pub element: String,
    pub k2: f64,
    #[serde(rename = "A")]
    pub a: f64,
    pub h: f64,
    pub dofs: usize,
    pub energy_error: f64,
    /// Rate in h against the previous level of the same configuration
    /// (`null` on the coarsest).
    pub energy_rate: Option<f64>,
    pub krylov_iterations: usize,
}

/// Runs every configuration of Table 1 at `levels` and writes the files.
pub fn fig3(case: &Case, levels: &[u32], out: &Path) -> Result<Vec<Fig3Row>> {
    let element = format!("{:?}", case.spec.element).to_lowercase();
    let mut rows: Vec<Fig3Row> = Vec::new();
    for (k2, a) in CONFIGS {
        let mut previous: Option<(f64, f64)> = None;
        for &level in levels {
            let run = run_sphere(case, &RunConfig::new(level, k2, a))?;
            let energy_error = match (run.energy_error, &run.failure) {
                (Some(e), None) => e,
                (_, failure) => {
                    return Err(Error::Breakdown {
                        method: case.spec.solver.method.name().into(),
                        iterations: run.krylov_iterations,
                        what: format!(
                            "fig3 at level {level}, k2 = {k2}, A = {a}: {}",
                            failure
                                .as_deref()
                                .unwrap_or("no error norm (no exact field)")
                        ),
                    })
                }
            };
            let energy_rate = previous.map(|p| rate(p, (run.h, energy_error)));
            previous = Some((run.h, energy_error));
            eprintln!(
                "  level {level}, k2 = {k2}, A = {a}: {} dofs, energy error {energy_error:.4e}, rate {}",
                run.dofs,
                energy_rate.map_or("–".into(), |r| format!("{r:.3}"))
            );
            rows.push(Fig3Row {
                level,
                element: element.clone(),
                k2,
                a,
                h: run.h,
                dofs: run.dofs,
                energy_error,
                energy_rate,
                krylov_iterations: run.krylov_iterations,
            });
        }
    }
    let json = serde_json::json!({ "rows": rows });
    write_outputs(
        out,
        "fig3",
        &json,
        &markdown(&rows, case.spec.element.degree()),
        &chart(&rows, case.spec.element.degree()).to_svg()?,
    )?;
    Ok(rows)
}

fn config_label(k2: f64, a: f64) -> String {
    if k2 > 0.0 {
        format!("with S, k2 = {k2}, A = {a}")
    } else {
        "without S".into()
    }
}

fn markdown(rows: &[Fig3Row], degree: usize) -> String {
    let mut s = String::from(
        "# Figure 3: energy-norm convergence of the sphere (Problem 1)\n\n\
         ‖u − u_h‖_E against the level, with and without the S-term; the rate is\n\
         log(e_coarse/e_fine)/log(h_coarse/h_fine). The paper shows the curves\n\
         (no values) and reports the optimal rate for every case: p (1 for Q1).\n\n\
         | element | k2 | A | level | h | dofs | energy error | rate | paper rate |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        s += &format!(
            "| {} | {} | {} | {} | {:.4} | {} | {:.4e} | {} | {} |\n",
            r.element,
            r.k2,
            r.a,
            r.level,
            r.h,
            r.dofs,
            r.energy_error,
            r.energy_rate.map_or("–".into(), |v| format!("{v:.3}")),
            degree
        );
    }
    let finest = rows.iter().map(|r| r.level).max().unwrap_or(0);
    let base = rows
        .iter()
        .find(|r| r.k2 == 0.0 && r.level == finest)
        .map(|r| r.energy_error);
    if let Some(base) = base {
        s += &format!("\nAt level {finest}, error relative to the run without the S-term:\n\n");
        for r in rows.iter().filter(|r| r.level == finest && r.k2 > 0.0) {
            s += &format!(
                "- {}: {:+.3}%\n",
                config_label(r.k2, r.a),
                100.0 * (r.energy_error / base - 1.0)
            );
        }
    }
    s
}

/// Error against dofs, log–log, one series per configuration, and the
/// optimal slope (−p/3 in dofs) through the first point.
fn chart(rows: &[Fig3Row], degree: usize) -> Chart {
    let mut series: Vec<Series> = CONFIGS
        .iter()
        .map(|&(k2, a)| Series {
            label: config_label(k2, a),
            points: rows
                .iter()
                .filter(|r| r.k2 == k2 && r.a == a)
                .map(|r| (r.dofs as f64, r.energy_error))
                .collect(),
            reference: false,
        })
        .collect();
    if let (Some(first), Some(last)) = (rows.first(), rows.iter().max_by_key(|r| r.dofs)) {
        let p = degree as f64;
        let slope = |n: f64| first.energy_error * (n / first.dofs as f64).powf(-p / 3.0);
        series.push(Series {
            label: format!("rate {degree} in h (slope −{degree}/3 in dofs)"),
            points: vec![
                (first.dofs as f64, slope(first.dofs as f64)),
                (last.dofs as f64, slope(last.dofs as f64)),
            ],
            reference: true,
        });
    }
    Chart {
        title: "Figure 3: energy-norm error of the sphere".into(),
        x_label: "dofs".into(),
        y_label: "‖u − u_h‖_E".into(),
        x_log: true,
        series,
    }
}
