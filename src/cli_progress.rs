//! The binary's side of the library's progress events: indicatif bars and
//! spinners when stderr is a terminal, one plain line per step when it is not,
//! nothing with `--quiet`; the log writer that prints `tracing` lines above
//! the bars (so neither garbles the other); and the Ctrl-C flag that stops a
//! run at the next fixed-point (or Newton) iteration boundary. A nonlinear
//! run shows a bar over its load steps and a spinner with the Newton
//! residual of the current step.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use cgfem_gpu::progress::{Event, Phase, Progress};
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};

/// How progress is shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    Quiet,
    Plain,
    Bars,
}

/// The bars on screen (or, in plain mode, when the current phase started).
#[derive(Default)]
struct State {
    phase: Option<(Phase, ProgressBar, Instant)>,
    fixed_point: Option<ProgressBar>,
    /// Load steps of a nonlinear run, and its Newton spinner.
    load_steps: Option<(ProgressBar, ProgressBar)>,
    /// The Newton spinner's text of the current iteration.
    newton: String,
    /// The true relative residual of the last Krylov solve.
    residual: f64,
}

/// The progress display and interrupt flag of one `run`.
pub struct Terminal {
    mode: Mode,
    multi: MultiProgress,
    state: Mutex<State>,
    interrupt: Arc<AtomicBool>,
}

impl Terminal {
    /// Bars when stderr is a terminal, plain lines otherwise; nothing if `quiet`.
    pub fn new(quiet: bool) -> Self {
        let mode = match (quiet, std::io::stderr().is_terminal()) {
            (true, _) => Mode::Quiet,
            (false, true) => Mode::Bars,
            (false, false) => Mode::Plain,
        };
        let target = if mode == Mode::Bars {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        };
        Terminal {
            mode,
            multi: MultiProgress::with_draw_target(target),
            state: Mutex::new(State::default()),
            interrupt: Arc::new(AtomicBool::new(false)),
        }
    }

    /// Installs the Ctrl-C handler: the first press asks the run to stop at
    /// the next fixed-point (or Newton) iteration boundary, a second one exits at once
    /// (code 130).
    pub fn catch_ctrl_c(&self) -> anyhow::Result<()> {
        let flag = self.interrupt.clone();
        let quiet = self.mode == Mode::Quiet;
        ctrlc::set_handler(move || {
            if flag.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
            if !quiet {
                eprintln!(
                    "interrupt: stopping at the next fixed-point or Newton iteration \
                     (Ctrl-C again to abort at once)"
                );
            }
        })?;
        Ok(())
    }

    /// The writer for `tracing`'s log lines: each line is printed with the
    /// bars suspended (cleared, then redrawn below it).
    pub fn log_writer(&self) -> LogWriter {
        LogWriter(self.multi.clone())
    }

    /// Clears the bars (before the summary is printed).
    pub fn finish(&self) {
        let mut s = self.state.lock().expect("progress state");
        if let Some((_, bar, _)) = s.phase.take() {
            bar.finish_and_clear();
        }
        if let Some(bar) = s.fixed_point.take() {
            bar.finish_and_clear();
        }
        if let Some((steps, newton)) = s.load_steps.take() {
            steps.finish_and_clear();
            newton.finish_and_clear();
        }
    }

    /// The load-step bar (`steps` long) and the Newton spinner below it.
    fn load_step_bars(&self, s: &mut State, steps: usize) -> (ProgressBar, ProgressBar) {
        s.load_steps
            .get_or_insert_with(|| {
                let bar = ProgressBar::new(steps as u64).with_style(
                    ProgressStyle::with_template(
                        "load steps [{bar:30}] {pos}/{len} {elapsed} {msg}",
                    )
                    .expect("template")
                    .progress_chars("=> "),
                );
                let spinner = ProgressBar::new_spinner().with_style(
                    ProgressStyle::with_template("{spinner} newton: {msg}").expect("template"),
                );
                spinner.enable_steady_tick(Duration::from_millis(120));
                (self.multi.add(bar), self.multi.add(spinner))
            })
            .clone()
    }

    fn newton_iteration(&self, s: &mut State, steps: usize, t: f64, iteration: usize, rel: f64) {
        let text = format!("t = {t:.4}, iteration {iteration}: ‖R‖/‖R0‖ = {rel:.2e}");
        match self.mode {
            Mode::Bars => {
                self.load_step_bars(s, steps).1.set_message(text.clone());
                s.newton = text;
            }
            _ => eprintln!("  newton {text}"),
        }
    }

    fn load_step(&self, s: &mut State, step: usize, steps: usize, t: f64, cuts: usize, ok: bool) {
        let (bar, _) = self.load_step_bars(s, steps);
        let text = match ok {
            true => format!("load step {step} converged at t = {t:.4} ({cuts} cuts)"),
            false => format!("load step {step} failed at t = {t:.4}; halving the increment"),
        };
        match self.mode {
            Mode::Bars => {
                if ok {
                    bar.set_position((t * steps as f64).floor() as u64);
                }
                bar.set_message(text);
            }
            _ => eprintln!("{text}"),
        }
    }

    fn start(&self, s: &mut State, phase: Phase, total: Option<u64>) {
        let bar = match total {
            Some(n) => ProgressBar::new(n).with_style(
                ProgressStyle::with_template("{msg:>10} [{bar:30}] {pos}/{len} {rate} ETA {eta}")
                    .expect("template")
                    .with_key("rate", rate)
                    .progress_chars("=> "),
            ),
            None => {
                let bar = ProgressBar::new_spinner().with_style(
                    ProgressStyle::with_template("{spinner} {msg:>10} {elapsed}")
                        .expect("template"),
                );
                bar.enable_steady_tick(Duration::from_millis(120));
                bar
            }
        };
        let bar = self.multi.add(bar.with_message(phase.name()));
        if let Some((_, old, _)) = s.phase.replace((phase, bar, Instant::now())) {
            old.finish_and_clear();
        }
        if self.mode == Mode::Plain && phase != Phase::Recovery {
            match total {
                Some(n) => eprintln!("{}: {n} steps", phase.name()),
                None => eprintln!("{}", phase.name()),
            }
        }
    }

    fn fixed_point_bar(&self, s: &mut State) -> ProgressBar {
        s.fixed_point
            .get_or_insert_with(|| {
                let bar = ProgressBar::new_spinner().with_style(
                    ProgressStyle::with_template(
                        "{spinner} fixed point: {pos} iterations ({rate}) {elapsed} {msg}",
                    )
                    .expect("template")
                    .with_key("rate", rate),
                );
                bar.enable_steady_tick(Duration::from_millis(120));
                self.multi.insert(0, bar)
            })
            .clone()
    }
}

/// `tracing`'s writer through the bars (see [`Terminal::log_writer`]).
#[derive(Clone)]
pub struct LogWriter(MultiProgress);

impl std::io::Write for LogWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.suspend(|| std::io::stderr().write_all(buf))?;
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        std::io::stderr().flush()
    }
}

impl<'a> tracing_subscriber::fmt::MakeWriter<'a> for LogWriter {
    type Writer = LogWriter;

    fn make_writer(&'a self) -> LogWriter {
        self.clone()
    }
}

/// Steps per second with three significant digits (indicatif's `per_sec`
/// prints all of them).
fn rate(state: &ProgressState, w: &mut dyn std::fmt::Write) {
    let r = state.per_sec();
    let _ = match r {
        r if r >= 100.0 => write!(w, "{r:.0}/s"),
        r if r >= 10.0 => write!(w, "{r:.1}/s"),
        r => write!(w, "{r:.2}/s"),
    };
}

impl Progress for Terminal {
    fn event(&self, event: &Event) {
        match event {
            Event::Say { text } => return self.multi.suspend(|| println!("{text}")),
            Event::Notice { text } => return self.multi.suspend(|| eprintln!("{text}")),
            _ => {}
        }
        if self.mode == Mode::Quiet {
            return;
        }
        let mut s = self.state.lock().expect("progress state");
        match event {
            Event::RunDone { summary } => match self.mode {
                Mode::Bars => self.multi.suspend(|| eprintln!("{summary}")),
                _ => eprintln!("{summary}"),
            },
            _ => self.show(&mut s, event.clone()),
        }
    }

    fn should_stop(&self) -> bool {
        self.interrupt.load(Ordering::SeqCst)
    }
}

impl Terminal {
    /// Draws (or prints) a phase, Krylov or fixed-point event.
    fn show(&self, s: &mut State, event: Event) {
        match event {
            Event::RunDone { .. } | Event::Say { .. } | Event::Notice { .. } => {}
            Event::Start { phase, total } => self.start(s, phase, total),
            Event::Advance { steps, .. } => {
                if let Some((_, bar, _)) = &s.phase {
                    bar.inc(steps);
                }
            }
            Event::Finish { phase } => {
                if let Some((p, bar, t)) = s.phase.take() {
                    bar.finish_and_clear();
                    if self.mode == Mode::Plain && p == phase && p != Phase::Recovery {
                        eprintln!("{}: done in {:.2} s", p.name(), t.elapsed().as_secs_f64());
                    }
                }
            }
            Event::KrylovSolve {
                index,
                iterations,
                relative_residual,
            } => {
                s.residual = relative_residual;
                let text = format!(
                    "solve {index}: {iterations} Krylov iterations, residual {relative_residual:.2e}"
                );
                match self.mode {
                    Mode::Bars => match &s.load_steps {
                        // A nonlinear run: the solve joins the Newton line.
                        Some((_, spinner)) => spinner
                            .set_message(format!("{}; {iterations} Krylov iterations", s.newton)),
                        None => self.fixed_point_bar(s).set_message(text),
                    },
                    // The later solves are told with their iteration.
                    _ if index == 0 => eprintln!("{text}"),
                    _ => {}
                }
            }
            Event::FixedPoint {
                iteration,
                eps,
                krylov_iterations,
            } => match self.mode {
                Mode::Bars => {
                    let bar = self.fixed_point_bar(s);
                    bar.set_position(iteration as u64);
                    bar.set_message(format!(
                        "ε = {eps:.2e}, {krylov_iterations} Krylov iterations, residual {:.2e}",
                        s.residual
                    ));
                }
                _ => eprintln!(
                    "fixed-point iteration {iteration}: ε = {eps:.3e} \
                     ({krylov_iterations} Krylov iterations, residual {:.2e})",
                    s.residual
                ),
            },
            Event::NewtonIteration {
                steps,
                load_factor,
                iteration,
                relative_residual,
                ..
            } => self.newton_iteration(s, steps, load_factor, iteration, relative_residual),
            Event::LoadStep {
                step,
                steps,
                load_factor,
                cuts,
                converged,
                ..
            } => self.load_step(s, step, steps, load_factor, cuts, converged),
        }
    }
}
