//! Progress of the long phases of a run, reported to an observer so that the
//! library stays free of terminal code: the binary draws bars (or prints plain
//! lines, or nothing) from these events, and prints the lines a run says
//! ([`Event::Say`], [`Event::Notice`]). The observer is also asked, at each
//! fixed-point iteration boundary (and each Newton iteration of a nonlinear
//! run), whether the run should stop (Ctrl-C).

/// A phase of a run with a progress display.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// Classification of the cells and the cut-cell quadrature.
    Quadrature,
    /// The operator and the fixed right-hand side.
    Operator,
    /// Stress (and displacement) recovery.
    Recovery,
    /// The runs of a `reproduce` table or figure (one step per run).
    Runs,
}

impl Phase {
    /// Short name, as in the report's `timings`.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Quadrature => "quadrature",
            Phase::Operator => "operator",
            Phase::Recovery => "recovery",
            Phase::Runs => "runs",
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
    /// One run of a `reproduce` result ended; `summary` is a line for the user.
    RunDone { summary: String },
    /// A line of the run's account for the user: what it solves, on what,
    /// what it chose (the binary prints it on stdout, `--quiet` or not).
    Say { text: String },
    /// A finding about the input or the answer that the user must read (a
    /// repaired mesh, glued walls), with its `note:` or `warning:` prefix
    /// (the binary prints it on stderr, `--quiet` or not).
    Notice { text: String },
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
    /// A Newton iteration of a nonlinear run starts in load step `step` (of
    /// `steps` nominal ones) at load factor `load_factor`: `iteration` from 0,
    /// with `‖R‖ / ‖R_0‖` of the step.
    NewtonIteration {
        step: usize,
        steps: usize,
        load_factor: f64,
        iteration: usize,
        relative_residual: f64,
    },
    /// An attempt at load step `step` (from 1, of `steps` nominal ones) ended
    /// at load factor `load_factor` after `newton_iterations` updates; a
    /// failed attempt is retried with a halved increment.
    LoadStep {
        step: usize,
        steps: usize,
        load_factor: f64,
        cuts: usize,
        newton_iterations: usize,
        converged: bool,
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
    /// Says `text`: [`Event::Say`].
    fn say(&self, text: String) {
        self.event(&Event::Say { text });
    }
    /// Tells the finding `text`: [`Event::Notice`].
    fn notice(&self, text: String) {
        self.event(&Event::Notice { text });
    }
}

/// The observer that ignores everything and never stops a run.
#[derive(Clone, Copy, Debug, Default)]
pub struct Silent;

impl Progress for Silent {
    fn event(&self, _: &Event) {}
}
