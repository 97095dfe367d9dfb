//! The loop's progress events, its stop at an iteration boundary and its chart,
//! on a diagonal system solved exactly (`u = rhs / d`) with the contraction
//! `F_rec(U) = U / 2`: `U* = F / (d − 1/2)`, reached geometrically.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use super::*;

/// Solves `diag(d) u = rhs` exactly, reporting `k + 1` iterations for solve `k`.
struct Diagonal {
    d: Vec<f64>,
    solves: usize,
}

impl LinearSolver for Diagonal {
    fn solve(&mut self, rhs: &[f64], u: &mut Vec<f64>, _: &KrylovOptions) -> Result<KrylovStats> {
        for ((u, r), d) in u.iter_mut().zip(rhs).zip(&self.d) {
            *u = r / d;
        }
        self.solves += 1;
        Ok(KrylovStats {
            iterations: self.solves,
            ..KrylovStats::default()
        })
    }
}

/// Records the events; asks to stop once `stop_after` fixed-point iterations
/// have ended.
struct Recorder {
    events: Mutex<Vec<Event>>,
    iterations: AtomicUsize,
    stop_after: usize,
}

impl Recorder {
    fn new(stop_after: usize) -> Self {
        Recorder {
            events: Mutex::new(Vec::new()),
            iterations: AtomicUsize::new(0),
            stop_after,
        }
    }
}

impl Progress for Recorder {
    fn event(&self, event: &Event) {
        if matches!(event, Event::FixedPoint { .. }) {
            self.iterations.fetch_add(1, Ordering::SeqCst);
        }
        self.events.lock().unwrap().push(event.clone());
    }
    fn should_stop(&self) -> bool {
        self.iterations.load(Ordering::SeqCst) >= self.stop_after
    }
}

fn options(max_iterations: usize) -> FixedPointOptions {
    FixedPointOptions {
        krylov: KrylovOptions::default(),
        min_rel_tol: 1e-12,
        tol: 1e-6,
        max_iterations,
        inner_rel_tol: 1e-2,
    }
}

fn run(progress: &dyn Progress, report: &mut FixedPointReport) -> Result<Vec<f64>> {
    let mut solver = Diagonal {
        d: vec![1.0, 2.0, 4.0],
        solves: 0,
    };
    let mut half = |u: &[f64]| -> Result<Vec<f64>> { Ok(u.iter().map(|x| x / 2.0).collect()) };
    let fixed = [1.0, 1.0, 1.0];
    fixed_point_with_progress(
        &mut solver,
        &fixed,
        &mut half,
        &options(50),
        report,
        progress,
    )
}

#[test]
fn converges_and_reports_each_solve_and_iteration() {
    let rec = Recorder::new(usize::MAX);
    let mut report = FixedPointReport::default();
    let u = run(&rec, &mut report).unwrap();
    assert!(report.converged);
    for (got, want) in u.iter().zip([2.0, 2.0 / 3.0, 2.0 / 7.0]) {
        assert!((got - want).abs() < 1e-5, "{got} vs {want}");
    }
    let events = rec.events.lock().unwrap();
    let eps: Vec<f64> = events
        .iter()
        .filter_map(|e| match e {
            Event::FixedPoint { eps, .. } => Some(*eps),
            _ => None,
        })
        .collect();
    assert_eq!(eps, report.eps_history);
    let solves = events
        .iter()
        .filter(|e| matches!(e, Event::KrylovSolve { .. }))
        .count();
    assert_eq!(solves, report.iterations + 1);
    // Each iteration's event carries the Krylov iterations of its solve.
    let last = events
        .iter()
        .rev()
        .find(|e| matches!(e, Event::FixedPoint { .. }))
        .unwrap();
    assert_eq!(
        *last,
        Event::FixedPoint {
            iteration: report.iterations,
            eps: *report.eps_history.last().unwrap(),
            krylov_iterations: report.iterations + 1,
        }
    );
    let recoveries = events
        .iter()
        .filter(|e| {
            **e == Event::Start {
                phase: Phase::Recovery,
                total: None,
            }
        })
        .count();
    assert_eq!(recoveries, report.iterations);
}

#[test]
fn stops_at_the_next_iteration_boundary_with_a_typed_error() {
    let rec = Recorder::new(3);
    let mut report = FixedPointReport::default();
    let err = run(&rec, &mut report).unwrap_err();
    assert_eq!(err, Error::Interrupted { iterations: 3 });
    assert_eq!(err.exit_code(), 130);
    assert_eq!(report.iterations, 3);
    assert_eq!(report.eps_history.len(), 3);
    assert_eq!(report.iterations_per_solve, vec![1, 2, 3, 4]);
    assert!(!report.converged);
}

#[test]
fn a_stop_asked_before_the_start_solves_nothing() {
    let rec = Recorder::new(0);
    let mut report = FixedPointReport::default();
    let err = run(&rec, &mut report).unwrap_err();
    assert_eq!(err, Error::Interrupted { iterations: 0 });
    assert!(report.iterations_per_solve.is_empty());
    assert!(rec.events.lock().unwrap().is_empty());
}

#[test]
fn the_residual_chart_has_both_series_on_a_log_axis() {
    let report = FixedPointReport {
        iterations: 2,
        eps_history: vec![1e-2, 1e-5],
        iterations_per_solve: vec![40, 0, 12],
        ..FixedPointReport::default()
    };
    let chart = report.residual_chart("sphere");
    assert_eq!(chart.series.len(), 2);
    assert_eq!(chart.series[0].points, vec![(1.0, 1e-2), (2.0, 1e-5)]);
    // The zero-iteration solve cannot go on a log axis.
    assert_eq!(chart.series[1].points, vec![(0.0, 40.0), (2.0, 12.0)]);
    let svg = chart.to_svg().unwrap();
    for text in ["sphere", "ε = ‖ΔU‖/‖U‖", "Krylov iterations per solve"] {
        assert!(svg.contains(text), "{text} missing");
    }
}
