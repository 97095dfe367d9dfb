//! Progress of the long phases of a run, reported to an observer so that the
//! library stays free of terminal code: the binary draws bars (or prints plain
//! lines, or nothing) from these events. The observer is also asked, at each
//! fixed-point iteration boundary, whether the run should stop (Ctrl-C).

/// A phase of a run with a progress display.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// Classification of the cells and the cut-cell quadrature.
    Quadrature,
    /// The operator and the fixed right-hand side.
    Operator,
    /// Stress (and displacement) recovery.
    Recovery,
}

impl Phase {
    /// Short name, as in the report's `timings`.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Quadrature => "quadrature",
            Phase::Operator => "operator",
            Phase::Recovery => "recovery",
        }
    }
}

/// What a run reports as it goes.
#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    /// A phase starts; `total` is its number of steps when known (the
    /// candidate cells of the cut-cell quadrature), else `None`.
    Start { phase: Phase, total: Option<u64> },
    /// `steps` more steps of the current phase are done (may come from any thread).
    Advance { phase: Phase, steps: u64 },
    /// A phase ends.
    Finish { phase: Phase },
    /// A Krylov solve ended: `index` 0 is the initial solve.
    KrylovSolve {
        index: usize,
        iterations: usize,
        relative_residual: f64,
    },
    /// Fixed-point iteration `iteration` (from 1) ended with change `eps`.
    FixedPoint {
        iteration: usize,
        eps: f64,
        krylov_iterations: usize,
    },
}

/// An observer of a run: receives [`Event`]s and says whether to stop.
pub trait Progress: Sync {
    /// Called for each event.
    fn event(&self, event: &Event);
    /// Polled at each fixed-point iteration boundary: `true` stops the run
    /// with [`crate::Error::Interrupted`].
    fn should_stop(&self) -> bool {
        false
    }
}

/// The observer that ignores everything and never stops a run.
#[derive(Clone, Copy, Debug, Default)]
pub struct Silent;

impl Progress for Silent {
    fn event(&self, _: &Event) {}
}
