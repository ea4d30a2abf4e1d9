//! Work that is estimated before it runs (refused beyond a limit without `--no-limit`, and
//! announced when it is long), and shown while it runs: a progress bar on stderr when it is
//! a terminal; otherwise (a log, a pipe) a plain line every
//! [`PROGRESS_S`](ptsa_host_sim::simulation::work::PROGRESS_S) seconds (the
//! environment variable `PTSA_PROGRESS_S` sets another) once the
//! work has run that long, so that a short run stays quiet.
//!
//! The estimate and the progress count closed-loop ticks ([`ptsa_host_sim::simulation::work`]): the
//! ticks a command will run, by path, at the measured rates, and the ticks the closed loop
//! and the batch engine have run so far.

use std::io::IsTerminal as _;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{RecvTimeoutError, Sender, channel};
use std::sync::{Arc, Mutex, OnceLock};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use ptsa_host_sim::Instrument;
use ptsa_host_sim::simulation::sim::SimOptions;
use ptsa_host_sim::simulation::work::{
    Estimate, Lines, Ticks, human, line, progress_s, seconds_from_env,
};

/// Estimated seconds beyond which a run needs `--no-limit` (the environment variable
/// `PTSA_LIMIT_S` sets another).
pub const LIMIT_S: f64 = 600.0;
/// Estimated seconds beyond which the estimate is printed before the work starts.
pub const ANNOUNCE_S: f64 = 10.0;
/// Seconds of the linear margins of one corner of the tolerance box (`ptsa monte-carlo`),
/// on one core, on the slow side.
pub const MARGINS_S_PER_CORNER: f64 = 2e-4;
/// Most limit cycles the waveform trace takes without `--no-limit`.
pub const MAX_TRACE_CYCLES: u64 = 10_000;

/// `--no-limit` was given: run whatever the estimate.
static NO_LIMIT: AtomicBool = AtomicBool::new(false);

/// Set from the command line's `--no-limit`, once, before any work.
pub fn set_no_limit(on: bool) {
    NO_LIMIT.store(on, Ordering::Relaxed);
}

/// Whether a subcommand's `force` (its `--force`, which replaces files) or `--no-limit` lets
/// work beyond the limit run. `--force` lifted the limit before `--no-limit` existed and
/// still does for this release; [`check`] warns when it is what let the work run.
pub fn lifted(force: bool) -> bool {
    force || NO_LIMIT.load(Ordering::Relaxed)
}

/// The limit of the estimated work without `--no-limit`, s (read once).
pub fn limit_s() -> f64 {
    static LIMIT: OnceLock<f64> = OnceLock::new();
    *LIMIT.get_or_init(|| seconds_from_env("PTSA_LIMIT_S", LIMIT_S))
}

/// An estimate of a command's closed-loop ticks, built up by the shape of its runs.
pub struct Work<'a> {
    instr: &'a Instrument,
    opts: &'a SimOptions,
    est: Estimate,
}

impl<'a> Work<'a> {
    /// No work yet.
    pub fn new(instr: &'a Instrument, opts: &'a SimOptions) -> Self {
        Self {
            instr,
            opts,
            est: Estimate::default(),
        }
    }

    /// One gate of `ticks` on the static path, after a settling time.
    pub fn gate(mut self, ticks: u64) -> Self {
        #[allow(clippy::cast_precision_loss)]
        let t = ticks as f64 + self.opts.warmup_s * self.instr.clock_hz;
        self.est.ticks += Ticks::of(t, false);
        self
    }

    /// Work counted by the library ([`ptsa_host_sim::report::experiments`]' `work` functions).
    pub fn ticks(mut self, t: Ticks) -> Self {
        self.est.ticks += t;
        self
    }

    /// The work so far, `n` times over (`n` runs of the same).
    pub fn times(mut self, n: f64) -> Self {
        self.est.ticks = self.est.ticks.times(n);
        self.est.other_s *= n;
        self
    }

    /// Seconds of work that is not closed-loop ticks.
    pub fn seconds(mut self, s: f64) -> Self {
        self.est.other_s += s;
        self
    }

    /// Refuse the work beyond the limit unless lifted ([`lifted`]), announce it when long;
    /// the estimate.
    pub fn check(self, force: bool, what: &str) -> Result<Estimate> {
        check(self.est, force, what, None, "shorten the times asked for")
    }
}

/// Refuse `est` beyond the limit ([`limit_s`]) unless lifted ([`lifted`]), with a one-line reason
/// naming `what` and `remedy`; print it on stderr when it is beyond [`ANNOUNCE_S`] (with
/// `more`, a clause on work that may follow). Returns `est`.
pub fn check(
    est: Estimate,
    force: bool,
    what: &str,
    more: Option<&str>,
    remedy: &str,
) -> Result<Estimate> {
    let s = est.seconds();
    let limit = limit_s();
    let more = more.map(|m| format!(", {m}")).unwrap_or_default();
    let no_limit = NO_LIMIT.load(Ordering::Relaxed);
    if s > limit && !no_limit && !force {
        bail!(
            "{what} would run about {:.2e} clock ticks, roughly {} on this machine{more}; expected at most about {} ({remedy}, or pass --no-limit to run it anyway)",
            est.ticks.total(),
            human(s),
            human(limit)
        );
    }
    if s > limit && !no_limit {
        eprintln!(
            "warning: --force let work beyond the limit run; that is --no-limit's task now (--force only replaces files), and --force will stop lifting the limit in the next release"
        );
    }
    if s > ANNOUNCE_S {
        eprintln!(
            "{what}: about {} of work estimated ({:.2e} closed-loop ticks on {} cores){more}{}",
            human(s),
            est.ticks.total(),
            ptsa_host_sim::simulation::work::cores(),
            if s > limit {
                "; run because of --no-limit"
            } else {
                ""
            }
        );
    }
    Ok(est)
}

/// Work shown while it runs (see the module docs); stop it with [`Progress::finish`] (or
/// by dropping it).
pub struct Progress {
    what: String,
    est: Estimate,
    start: Instant,
    start_ticks: Ticks,
    start_ahead: Ticks,
    every_s: f64,
    bar: Option<ProgressBar>,
    step: Arc<Mutex<String>>,
    stop: Option<(Sender<()>, JoinHandle<()>)>,
}

impl Progress {
    /// Show `what` while `est`'s work runs.
    pub fn start(what: &str, est: &Estimate) -> Self {
        ptsa_host_sim::simulation::work::set_stage("");
        let terminal = std::io::stderr().is_terminal();
        let bar = terminal.then(|| {
            let pb = ProgressBar::with_draw_target(Some(1000), ProgressDrawTarget::stderr());
            pb.set_style(
                ProgressStyle::with_template("{bar:40} {percent}% {msg} {elapsed}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            pb.set_message(what.to_string());
            pb
        });
        let step = Arc::new(Mutex::new(String::new()));
        let (tx, rx) = channel::<()>();
        let every = progress_s();
        let poll = Duration::from_secs_f64((every / 4.0).clamp(0.01, 0.2));
        let start_ticks = ptsa_host_sim::simulation::work::done();
        let start_ahead = ptsa_host_sim::simulation::work::announced();
        let (what2, ticks) = (what.to_string(), est.ticks.seconds());
        let (bar2, step2) = (bar.clone(), Arc::clone(&step));
        let handle = std::thread::spawn(move || {
            let start = Instant::now();
            let mut lines = Lines::new(every);
            loop {
                match rx.recv_timeout(poll) {
                    Err(RecvTimeoutError::Timeout) => {}
                    _ => return,
                }
                let done = ptsa_host_sim::simulation::work::done();
                let run = Ticks {
                    fixed: done.fixed - start_ticks.fixed,
                    dynamic: done.dynamic - start_ticks.dynamic,
                };
                // The estimate, and what the work found to lie ahead since it started.
                let ahead = ptsa_host_sim::simulation::work::announced();
                let more = Ticks {
                    fixed: ahead.fixed - start_ahead.fixed,
                    dynamic: ahead.dynamic - start_ahead.dynamic,
                };
                let all = ticks + more.seconds();
                let fraction = (all > 0.0).then(|| run.seconds() / all);
                let stage = {
                    let outer = step2.lock().map(|s| s.clone()).unwrap_or_default();
                    let inner = ptsa_host_sim::simulation::work::stage();
                    match (outer.is_empty(), inner.is_empty()) {
                        (false, false) => format!("{outer}: {inner}"),
                        (false, true) => outer,
                        _ => inner,
                    }
                };
                if let Some(pb) = &bar2 {
                    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                    pb.set_position((1000.0 * fraction.unwrap_or(0.0).clamp(0.0, 0.99)) as u64);
                    pb.set_message(if stage.is_empty() {
                        what2.clone()
                    } else {
                        format!("{what2}: {stage}")
                    });
                } else if lines.due(start.elapsed().as_secs_f64()) {
                    eprintln!(
                        "{}",
                        line(&what2, &stage, fraction, start.elapsed().as_secs_f64())
                    );
                }
            }
        });
        Self {
            what: what.to_string(),
            est: *est,
            start: Instant::now(),
            start_ticks,
            start_ahead,
            every_s: every,
            bar,
            step,
            stop: Some((tx, handle)),
        }
    }

    /// Name the step the command is in (the report programme's experiment).
    pub fn set_step(&self, step: &str) {
        if let Ok(mut s) = self.step.lock() {
            step.clone_into(&mut s);
        }
        ptsa_host_sim::simulation::work::set_stage("");
    }

    /// Stop showing the work.
    pub fn finish(mut self) {
        self.stop_now();
    }

    /// Stop the display; after a run long enough to have shown progress lines, say how
    /// long it took and how much it ran against the estimate.
    fn stop_now(&mut self) {
        let Some((tx, handle)) = self.stop.take() else {
            return;
        };
        let _ = tx.send(());
        let _ = handle.join();
        if let Some(pb) = &self.bar {
            pb.finish_and_clear();
        }
        let elapsed = self.start.elapsed().as_secs_f64();
        if elapsed >= self.every_s.min(ANNOUNCE_S) {
            let done = ptsa_host_sim::simulation::work::done().total() - self.start_ticks.total();
            let ahead = ptsa_host_sim::simulation::work::announced();
            let more = Ticks {
                fixed: ahead.fixed - self.start_ahead.fixed,
                dynamic: ahead.dynamic - self.start_ahead.dynamic,
            };
            let found = if more.total() > 0.0 {
                format!(
                    ", and at most {:.1} s ({:.3e} ticks) found ahead on the way",
                    more.seconds(),
                    more.total()
                )
            } else {
                String::new()
            };
            eprintln!(
                "{}: {elapsed:.1} s, {done:.3e} closed-loop ticks (estimated {:.1} s, {:.3e} ticks{found})",
                self.what,
                self.est.seconds(),
                self.est.ticks.total(),
            );
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.stop_now();
    }
}

/// Warn when an input's size is beyond the loop's full scale.
pub fn warn_beyond_full_scale(instr: &Instrument, a_cm_s2: f64, what: &str) {
    if a_cm_s2.abs() > instr.sf_cm_s2 {
        eprintln!(
            "warning: {what} = {a_cm_s2} cm/s^2 is beyond the loop's full scale of ±{} cm/s^2: the loop saturates and the results are not measurements of the input",
            instr.sf_cm_s2
        );
    }
}
