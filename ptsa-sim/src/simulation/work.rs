//! Work counted before it runs and while it runs.
//!
//! * [`Ticks`]: closed-loop clock ticks by path, the static one (a constant input, the fast
//!   path of [`crate::simulation::sim::ClosedLoop`]) and the dynamic one (oscillating inputs, a harmonic
//!   measured), which runs several times slower per tick; [`Ticks::seconds`] turns them into
//!   an estimate of wall time with the measured rates [`STATIC_TICKS_PER_S`] and
//!   [`DYNAMIC_TICKS_PER_S`].
//! * The ticks run so far in this process ([`done`]): the closed loop and the batch engine
//!   count every run they finish, so that a command can show how far its estimated work has
//!   got.
//! * The stage a long computation is in ([`set_stage`], [`stage`]), for progress lines.
//! * A limit on a long computation whose length is only known part way (discover's search
//!   of the loop's parameters): [`set_limit`] by the command line, [`ahead`] by the
//!   computation before such a stage.
//! * Cancellation, for a host whose user pressed Ctrl-C while a call runs (Python's):
//!   [`cancel`], checked at every [`checkpoint`] (the end of each closed-loop run and of
//!   each step of the batch engine; the analysis adds its own: each row of the analytic
//!   model, each averaging time of an Allan analysis, each set of a campaign), and
//!   [`resume`].

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

use crate::model::condition::Condition;
use crate::model::instrument::Instrument;
use crate::simulation::sim::SimOptions;

/// Closed-loop ticks of the static path one core runs per second, counted on the slow side:
/// the batch engine's static lanes with their per-tick statistics (measured 0.9e8 to 1.3e8
/// per second per core on the development machine; `docs/method/host-sim.md`, "Work estimates").
pub const STATIC_TICKS_PER_S: f64 = 6e7;

/// Closed-loop ticks of the dynamic path (oscillating inputs or a harmonic measured) one
/// core runs per second, counted on the slow side (measured 2.5e7 to 3.5e7).
pub const DYNAMIC_TICKS_PER_S: f64 = 2e7;

/// Cores counted on: rayon's threads, at most four (beyond that the runs of one call are
/// too few to keep every core busy).
#[must_use]
pub fn cores() -> f64 {
    #[allow(clippy::cast_precision_loss)]
    let c = rayon::current_num_threads().clamp(1, 4) as f64;
    c
}

/// Closed-loop clock ticks, by path.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Ticks {
    /// Ticks of static runs (constant inputs, no harmonic).
    pub fixed: f64,
    /// Ticks of dynamic runs (oscillating inputs, or a harmonic measured).
    pub dynamic: f64,
}

impl Ticks {
    /// No work.
    pub const ZERO: Ticks = Ticks {
        fixed: 0.0,
        dynamic: 0.0,
    };

    /// `n` ticks of the static path (`dynamic` false) or of the dynamic one.
    #[must_use]
    pub fn of(n: f64, dynamic: bool) -> Self {
        if dynamic {
            Ticks {
                fixed: 0.0,
                dynamic: n,
            }
        } else {
            Ticks {
                fixed: n,
                dynamic: 0.0,
            }
        }
    }

    /// All ticks.
    #[must_use]
    pub fn total(&self) -> f64 {
        self.fixed + self.dynamic
    }

    /// Estimated wall time on [`cores`] cores, s (errs on the long side).
    #[must_use]
    pub fn seconds(&self) -> f64 {
        (self.fixed / STATIC_TICKS_PER_S + self.dynamic / DYNAMIC_TICKS_PER_S) / cores()
    }

    /// `self` `n` times over.
    #[must_use]
    pub fn times(self, n: f64) -> Self {
        Ticks {
            fixed: self.fixed * n,
            dynamic: self.dynamic * n,
        }
    }
}

impl std::ops::Add for Ticks {
    type Output = Ticks;
    fn add(self, o: Ticks) -> Ticks {
        Ticks {
            fixed: self.fixed + o.fixed,
            dynamic: self.dynamic + o.dynamic,
        }
    }
}

impl std::ops::AddAssign for Ticks {
    fn add_assign(&mut self, o: Ticks) {
        *self = *self + o;
    }
}

impl std::iter::Sum for Ticks {
    fn sum<I: Iterator<Item = Ticks>>(iter: I) -> Ticks {
        iter.fold(Ticks::ZERO, |a, b| a + b)
    }
}

/// An estimate of a command's work: closed-loop ticks and the seconds of what is not
/// ticks (least squares, figures, the linear margins).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate {
    /// Closed-loop ticks.
    pub ticks: Ticks,
    /// Seconds of the rest.
    pub other_s: f64,
}

impl Estimate {
    /// Estimated wall time, s.
    #[must_use]
    pub fn seconds(&self) -> f64 {
        self.ticks.seconds() + self.other_s
    }
}

/// The ticks of [`crate::simulation::sim::simulate_condition`]`(instr, cond, _, opts)`: the settling and
/// the window, on the path the loop takes.
#[must_use]
pub fn condition(instr: &Instrument, cond: &Condition, opts: &SimOptions) -> Ticks {
    let dynamic = cond.prepare(instr.g_cm_s2).is_dynamic() || opts.harmonic != 0;
    #[allow(clippy::cast_precision_loss)]
    let n = (opts.warmup_ticks(instr.clock_hz)
        + crate::simulation::sim::window_ticks(instr, cond, opts)) as f64;
    Ticks::of(n, dynamic)
}

/// The ticks of [`crate::simulation::sim::simulate_difference`]: the condition and its reference.
#[must_use]
pub fn difference(instr: &Instrument, cond: &Condition, opts: &SimOptions) -> Ticks {
    condition(instr, cond, opts) + condition(instr, &cond.reference(), opts)
}

static DONE_FIXED: AtomicU64 = AtomicU64::new(0);
static DONE_DYNAMIC: AtomicU64 = AtomicU64::new(0);

/// Count `n` ticks run (by the closed loop or the batch engine), then [`checkpoint`].
pub(crate) fn count(n: u64, dynamic: bool) {
    if dynamic {
        DONE_DYNAMIC.fetch_add(n, Ordering::Relaxed);
    } else {
        DONE_FIXED.fetch_add(n, Ordering::Relaxed);
    }
    checkpoint();
}

static CANCEL: AtomicBool = AtomicBool::new(false);

/// The payload a cancelled computation unwinds with ([`cancel`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cancelled;

/// Ask every computation of this process to stop at its next [`checkpoint`], where it
/// unwinds with the payload [`Cancelled`] (`std::panic::resume_unwind`: no panic message,
/// and rayon carries it to the caller of a parallel loop). The caller catches it with
/// `std::panic::catch_unwind`, then calls [`resume`]. No lock is held at a checkpoint, so
/// nothing is left poisoned; the result of the cancelled call is simply not made.
pub fn cancel() {
    CANCEL.store(true, Ordering::Relaxed);
}

/// Let computations run again after [`cancel`].
pub fn resume() {
    CANCEL.store(false, Ordering::Relaxed);
}

/// Unwind with [`Cancelled`] if [`cancel`] was asked (and not [`resume`]d).
pub fn checkpoint() {
    if CANCEL.load(Ordering::Relaxed) {
        std::panic::resume_unwind(Box::new(Cancelled));
    }
}

/// The ticks every closed loop of this process has run so far (all threads; a run is
/// counted when it ends, or a batch's lanes when they reach the end of a step).
#[must_use]
pub fn done() -> Ticks {
    #[allow(clippy::cast_precision_loss)]
    Ticks {
        fixed: DONE_FIXED.load(Ordering::Relaxed) as f64,
        dynamic: DONE_DYNAMIC.load(Ordering::Relaxed) as f64,
    }
}

static STAGE: Mutex<String> = Mutex::new(String::new());

/// Name the stage the work is in now (`"baseline"`, `"the parameters' central
/// differences"`), for progress lines.
pub fn set_stage(name: &str) {
    if let Ok(mut s) = STAGE.lock() {
        name.clone_into(&mut s);
    }
}

/// The stage named last (empty if none).
#[must_use]
pub fn stage() -> String {
    STAGE.lock().map(|s| s.clone()).unwrap_or_default()
}

/// The limit [`ahead`] holds a stage to: seconds in all from `start`.
#[derive(Clone, Copy, Debug)]
struct Limit {
    start: Instant,
    seconds: f64,
}

static LIMIT: Mutex<Option<Limit>> = Mutex::new(None);

/// Hold the work that follows to `seconds` of wall time from now in all (`None`: no limit,
/// the default). A computation calls [`ahead`] before a stage whose length it only then
/// knows.
pub fn set_limit(seconds: Option<f64>) {
    if let Ok(mut l) = LIMIT.lock() {
        *l = seconds.map(|seconds| Limit {
            start: Instant::now(),
            seconds,
        });
    }
}

static AHEAD_FIXED: AtomicU64 = AtomicU64::new(0);
static AHEAD_DYNAMIC: AtomicU64 = AtomicU64::new(0);

/// The ticks announced by [`ahead`] so far in this process (work found to lie ahead once a
/// computation knew it), for a progress display to add to its estimate.
#[must_use]
pub fn announced() -> Ticks {
    #[allow(clippy::cast_precision_loss)]
    Ticks {
        fixed: AHEAD_FIXED.load(Ordering::Relaxed) as f64,
        dynamic: AHEAD_DYNAMIC.load(Ordering::Relaxed) as f64,
    }
}

/// Before a stage of `more` ticks (an estimate from above): `Err` with a one-line reason
/// when the time spent since [`set_limit`] plus the stage's estimate is beyond the limit
/// (never without a limit); else the stage is added to the work [`announced`].
///
/// # Errors
/// The limit would be exceeded; the message names `what`, the estimate and the limit.
pub fn ahead(what: &str, more: Ticks) -> anyhow::Result<()> {
    let limit = LIMIT.lock().ok().and_then(|l| *l);
    if let Some(limit) = limit {
        let spent = limit.start.elapsed().as_secs_f64();
        let need = more.seconds();
        if spent + need > limit.seconds {
            anyhow::bail!(
                "{what} would run about {} more ({:.2e} clock ticks) after {} so far; expected at most about {} in all (pass --no-limit to run it anyway)",
                human(need),
                more.total(),
                human(spent),
                human(limit.seconds)
            );
        }
    }
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    {
        AHEAD_FIXED.fetch_add(more.fixed as u64, Ordering::Relaxed);
        AHEAD_DYNAMIC.fetch_add(more.dynamic as u64, Ordering::Relaxed);
    }
    Ok(())
}

/// Seconds between two progress lines of a log (not a terminal's bar), and before the
/// first, so that a short run stays quiet.
pub const PROGRESS_S: f64 = 10.0;

/// A positive number of seconds from the environment variable `var`, else `default` (with
/// a warning when it is set but not such a number).
#[must_use]
pub fn seconds_from_env(var: &str, default: f64) -> f64 {
    match std::env::var(var) {
        Err(_) => default,
        Ok(v) => match v.trim().parse::<f64>() {
            Ok(s) if s > 0.0 && s.is_finite() => s,
            _ => {
                eprintln!(
                    "warning: {var}={v}: expected a positive number of seconds; using {default}"
                );
                default
            }
        },
    }
}

/// Seconds between progress lines: `PTSA_PROGRESS_S` when set (read once), else
/// [`PROGRESS_S`].
#[must_use]
pub fn progress_s() -> f64 {
    static EVERY: std::sync::OnceLock<f64> = std::sync::OnceLock::new();
    *EVERY.get_or_init(|| seconds_from_env("PTSA_PROGRESS_S", PROGRESS_S))
}

/// When the progress lines of a log are due: the first after `every_s` seconds of work,
/// then one every `every_s` seconds (a line missed while the machine was busy is not made
/// up for).
#[derive(Clone, Copy, Debug)]
pub struct Lines {
    every_s: f64,
    next_s: f64,
}

impl Lines {
    /// Lines every `every_s` seconds, the first after `every_s`.
    #[must_use]
    pub fn new(every_s: f64) -> Self {
        Self {
            every_s,
            next_s: every_s,
        }
    }

    /// Whether a line is due `elapsed_s` seconds after the start (and if so, the next one
    /// is due a period later).
    pub fn due(&mut self, elapsed_s: f64) -> bool {
        if elapsed_s < self.next_s {
            return false;
        }
        while self.next_s <= elapsed_s {
            self.next_s += self.every_s;
        }
        true
    }
}

/// A progress line: `what`, the fraction of the estimated work done (capped at 99 %
/// while the work runs, `None` when it is not known) and the stage, the elapsed time.
#[must_use]
pub fn line(what: &str, stage: &str, fraction: Option<f64>, elapsed_s: f64) -> String {
    let stage = if stage.is_empty() {
        String::new()
    } else {
        format!(" ({stage})")
    };
    match fraction {
        Some(f) => format!(
            "progress: {what}: {:.0} % of the estimated work done{stage}, {elapsed_s:.0} s elapsed",
            100.0 * f.clamp(0.0, 0.99)
        ),
        None => format!("progress: {what}: running{stage}, {elapsed_s:.0} s elapsed"),
    }
}

/// Seconds as a human duration (`42 s`, `14 min`, `3 h`, `2 days`, `5 years`).
#[must_use]
pub fn human(s: f64) -> String {
    if s < 120.0 {
        format!("{s:.0} s")
    } else if s < 7200.0 {
        format!("{:.0} min", s / 60.0)
    } else if s < 2.0 * 86400.0 {
        format!("{:.0} h", s / 3600.0)
    } else if s < 2.0 * 365.25 * 86400.0 {
        format!("{:.0} days", s / 86400.0)
    } else {
        format!("{:.0} years", s / (365.25 * 86400.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lines every 10 s: none in the first 10 s (a short run stays quiet), then one per
    /// period, whatever the polling; a period the machine slept through is not made up.
    #[test]
    fn progress_lines_start_after_a_period_and_come_once_a_period() {
        let mut l = Lines::new(10.0);
        let polled: Vec<f64> = (0..=130).map(|k| f64::from(k) * 0.2).collect();
        let due: Vec<f64> = polled.into_iter().filter(|&t| l.due(t)).collect();
        assert_eq!(due.len(), 2, "{due:?}");
        assert!(
            (due[0] - 10.0).abs() < 1e-9 && (due[1] - 20.0).abs() < 1e-9,
            "{due:?}"
        );
        assert!(!l.due(29.9));
        assert!(l.due(55.0));
        assert!(!l.due(59.9));
        assert!(l.due(60.0));
    }

    #[test]
    fn a_progress_line_says_what_how_far_and_how_long() {
        assert_eq!(
            line("discover", "baseline", Some(0.421), 65.2),
            "progress: discover: 42 % of the estimated work done (baseline), 65 s elapsed"
        );
        assert_eq!(
            line("discover", "", Some(1.7), 700.0),
            "progress: discover: 99 % of the estimated work done, 700 s elapsed"
        );
        assert_eq!(
            line("predict", "", None, 12.0),
            "progress: predict: running, 12 s elapsed"
        );
    }

    #[test]
    fn ticks_add_and_convert_by_path() {
        let t = Ticks::of(STATIC_TICKS_PER_S, false) + Ticks::of(DYNAMIC_TICKS_PER_S, true);
        assert!((t.seconds() * cores() - 2.0).abs() < 1e-12);
        assert!((t.times(3.0).total() - 3.0 * t.total()).abs() < 1e-3);
        assert_eq!(human(42.0), "42 s");
        assert_eq!(human(840.0), "14 min");
    }
}
