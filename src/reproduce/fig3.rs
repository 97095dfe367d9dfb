//! `cgfem-gpu reproduce fig3`: the paper's Figure 3, the energy-norm error of
//! the sphere (Problem 1) against the mesh size, with and without the S-term,
//! for each element order asked for (Q1 and Q2 by default), as `fig3.json`
//! (rows), `fig3.md` and `fig3.svg` (log–log error against dofs, with a
//! reference slope of the optimal rate per element).
//!
//! The paper draws the curves without printing their values; it says every
//! case converges at the right rate: `p` in h (−p/3 in dofs), 1 for Q1 and 2
//! for Q2, which is what the table compares with.

use std::path::Path;

use serde::Serialize;

use super::table1::CONFIGS;
use super::{rate, run_sphere, write_outputs, RunConfig, Runs};
use crate::case::Case;
use crate::element::ElementOrder;
use crate::error::{Error, Result};
use crate::plot::{Chart, Series};
use crate::progress::Progress;

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
    /// Rate in h against the previous level of the same element and
    /// configuration (`null` on the coarsest).
    pub energy_rate: Option<f64>,
    pub krylov_iterations: usize,
}

/// The curves of one element order: its sphere case (which sets the
/// element, the solver and its own stabilisation), the levels and the
/// `(k2, A)` configurations (k2 = 0: without the S-term).
#[derive(Clone, Debug)]
pub struct Fig3Curves<'a> {
    pub case: &'a Case,
    pub levels: Vec<u32>,
    pub configs: Vec<(f64, f64)>,
}

impl<'a> Fig3Curves<'a> {
    /// The configurations of Table 1 for Q1 (without S and the paper's four);
    /// for Q2 only the case's own `(k2, A)`: without the S-term (or with
    /// the Q1 thresholds of 1% and 5%) the Q2 solves do not converge from
    /// level 4 on, and each Q2 curve to level 5 costs minutes.
    pub fn for_case(case: &'a Case, levels: &[u32]) -> Self {
        let st = &case.spec.stabilisation;
        let configs = match case.body().spec.element {
            ElementOrder::Q1 => CONFIGS.to_vec(),
            ElementOrder::Q2 => vec![(st.k2, st.threshold(ElementOrder::Q2))],
        };
        Fig3Curves {
            case,
            levels: levels.to_vec(),
            configs,
        }
    }
}

fn element_name(e: ElementOrder) -> String {
    format!("{e:?}").to_lowercase()
}

/// Runs every curve and writes the files.
/// Each run is reported to `progress` ([`crate::progress::Phase::Runs`]).
pub fn fig3(
    curves: &[Fig3Curves<'_>],
    out: &Path,
    progress: &dyn Progress,
) -> Result<Vec<Fig3Row>> {
    let mut rows: Vec<Fig3Row> = Vec::new();
    let total = curves
        .iter()
        .map(|c| c.configs.len() * c.levels.len())
        .sum();
    let runs = Runs::start(progress, total);
    for c in curves {
        for &(k2, a) in &c.configs {
            rows.extend(curve(c.case, &c.levels, k2, a, &runs)?);
        }
    }
    runs.finish();
    let json = serde_json::json!({ "rows": rows });
    write_outputs(
        out,
        "fig3",
        &json,
        &markdown(&rows),
        &chart(&rows).to_svg()?,
    )?;
    Ok(rows)
}

/// One configuration of one element over the levels.
fn curve(case: &Case, levels: &[u32], k2: f64, a: f64, runs: &Runs) -> Result<Vec<Fig3Row>> {
    let element = element_name(case.body().spec.element);
    let mut rows = Vec::new();
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
                        "fig3 {element} at level {level}, k2 = {k2}, A = {a}: {}",
                        failure
                            .as_deref()
                            .unwrap_or("no error norm (no exact field)")
                    ),
                })
            }
        };
        let energy_rate = previous.map(|p| rate(p, (run.h, energy_error)));
        previous = Some((run.h, energy_error));
        runs.done(format!(
            "fig3 {element} level {level}, k2 = {k2}, A = {a}: {} dofs, energy error {energy_error:.4e}, rate {}",
            run.dofs,
            energy_rate.map_or("–".into(), |r| format!("{r:.3}"))
        ));
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
    Ok(rows)
}

fn config_label(element: &str, k2: f64, a: f64) -> String {
    if k2 > 0.0 {
        format!("{element}, with S, k2 = {k2}, A = {a}")
    } else {
        format!("{element}, without S")
    }
}

/// The optimal rate in h of an element named in a row.
fn degree_of(element: &str) -> usize {
    if element == "q2" {
        2
    } else {
        1
    }
}

fn markdown(rows: &[Fig3Row]) -> String {
    let mut s = String::from(
        "# Figure 3: energy-norm convergence of the sphere (Problem 1)\n\n\
         ‖u − u_h‖_E against the level, with and without the S-term; the rate is\n\
         log(e_coarse/e_fine)/log(h_coarse/h_fine). The paper shows the curves\n\
         (no values) and reports the optimal rate for every case: p (1 for Q1, 2\n\
         for Q2).\n\n\
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
            degree_of(&r.element)
        );
    }
    let finest = rows.iter().map(|r| r.level).max().unwrap_or(0);
    for element in elements(rows) {
        let at_finest = |r: &&Fig3Row| r.element == element && r.level == finest;
        let Some(base) = rows.iter().filter(at_finest).find(|r| r.k2 == 0.0) else {
            continue;
        };
        s += &format!(
            "\n{element} at level {finest}, error relative to the run without the S-term:\n\n"
        );
        for r in rows.iter().filter(at_finest).filter(|r| r.k2 > 0.0) {
            s += &format!(
                "- {}: {:+.3}%\n",
                config_label(&element, r.k2, r.a),
                100.0 * (r.energy_error / base.energy_error - 1.0)
            );
        }
    }
    s
}

/// The element names of the rows, in order of appearance.
fn elements(rows: &[Fig3Row]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for r in rows {
        if !names.contains(&r.element) {
            names.push(r.element.clone());
        }
    }
    names
}

/// Error against dofs, log–log, one series per element and configuration,
/// and per element the optimal slope (−p/3 in dofs) through its first point.
fn chart(rows: &[Fig3Row]) -> Chart {
    let mut keys: Vec<(String, f64, f64)> = Vec::new();
    for r in rows {
        let key = (r.element.clone(), r.k2, r.a);
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    let mut series: Vec<Series> = keys
        .iter()
        .map(|(element, k2, a)| Series {
            label: config_label(element, *k2, *a),
            points: rows
                .iter()
                .filter(|r| &r.element == element && r.k2 == *k2 && r.a == *a)
                .map(|r| (r.dofs as f64, r.energy_error))
                .collect(),
            reference: false,
        })
        .collect();
    for element in elements(rows) {
        let mine: Vec<&Fig3Row> = rows.iter().filter(|r| r.element == element).collect();
        let (Some(first), Some(last)) = (mine.first(), mine.iter().max_by_key(|r| r.dofs)) else {
            continue;
        };
        let degree = degree_of(&element);
        let p = degree as f64;
        let slope = |n: f64| first.energy_error * (n / first.dofs as f64).powf(-p / 3.0);
        series.push(Series {
            label: format!("{element}: rate {degree} in h (slope −{degree}/3 in dofs)"),
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
