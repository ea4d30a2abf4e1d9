//! Work that is estimated before it runs (and refused beyond a sane limit without
//! `--force`), and shown while it runs: progress bars and spinners on stderr when it is a
//! terminal, nothing otherwise.

use std::io::IsTerminal as _;
use std::time::Duration;

use anyhow::{Result, bail};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use ptsa_host_sim::Instrument;
use ptsa_host_sim::sim::SimOptions;

/// Simulated ticks per second this program can be counted on for, per core, in the slower
/// (dynamic, statistics-gathering) path; the estimate errs on the long side.
const TICKS_PER_S: f64 = 2e7;
/// Estimated seconds beyond which a run needs `--force`.
const LIMIT_S: f64 = 600.0;
/// Most limit cycles the waveform trace takes without `--force`.
pub const MAX_TRACE_CYCLES: u64 = 10_000;

/// An estimate of a command's closed-loop ticks.
pub struct Work<'a> {
    instr: &'a Instrument,
    opts: &'a SimOptions,
    ticks: f64,
}

impl<'a> Work<'a> {
    /// No work yet.
    pub fn new(instr: &'a Instrument, opts: &'a SimOptions) -> Self {
        Self {
            instr,
            opts,
            ticks: 0.0,
        }
    }

    /// One long gate of `ticks`, after a settling time.
    pub fn gate(mut self, ticks: u64) -> Self {
        #[allow(clippy::cast_precision_loss)]
        let t = ticks as f64;
        self.ticks += t + self.opts.warmup_s * self.instr.clock_hz;
        self
    }

    /// `n` static conditions: settling plus the shortest window each.
    pub fn conditions(mut self, n: u32) -> Self {
        self.ticks +=
            f64::from(n) * (self.opts.warmup_s + self.opts.min_window_s) * self.instr.clock_hz;
        self
    }

    /// `n` dynamic conditions (the window may be a little longer: whole periods).
    pub fn dynamic_conditions(mut self, n: u32) -> Self {
        self.ticks += f64::from(n)
            * (self.opts.warmup_s + self.opts.min_window_s + 0.05)
            * self.instr.clock_hz;
        self
    }

    /// `n` more windows of `s` seconds.
    pub fn window_s(mut self, s: f64, n: u32) -> Self {
        self.ticks += f64::from(n) * s * self.instr.clock_hz;
        self
    }

    /// The work so far, `n` times over (`n` runs of the same).
    pub fn times(mut self, n: f64) -> Self {
        self.ticks *= n;
        self
    }

    /// Refuse work estimated beyond ten minutes unless `force`.
    pub fn check(self, force: bool, what: &str) -> Result<()> {
        let cores = rayon::current_num_threads().max(1);
        #[allow(clippy::cast_precision_loss)]
        let s = self.ticks / TICKS_PER_S / cores.min(4) as f64;
        if s > LIMIT_S && !force {
            bail!(
                "{what} would run about {:.2e} clock ticks, roughly {} on this machine; expected at most about {} (shorten the times asked for, or pass --force to run it anyway)",
                self.ticks,
                human(s),
                human(LIMIT_S)
            );
        }
        Ok(())
    }
}

/// Seconds as a human duration.
fn human(s: f64) -> String {
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

fn draw_target() -> ProgressDrawTarget {
    if std::io::stderr().is_terminal() {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::hidden()
    }
}

/// A spinner with a message, ticking on its own, for work of unknown length.
pub fn spinner(msg: &str) -> ProgressBar {
    let pb = ProgressBar::with_draw_target(None, draw_target());
    pb.set_style(
        ProgressStyle::with_template("{spinner} {msg} {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    pb.set_message(msg.to_string());
    pb.enable_steady_tick(Duration::from_millis(120));
    pb
}

/// A bar over `n` named steps.
pub fn steps(n: usize) -> ProgressBar {
    let pb = ProgressBar::with_draw_target(Some(n as u64), draw_target());
    pb.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} {msg} {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    pb.enable_steady_tick(Duration::from_millis(200));
    pb
}

/// A bar over `n` clock ticks.
pub fn ticks_bar(n: u64) -> ProgressBar {
    let pb = ProgressBar::with_draw_target(Some(n), draw_target());
    pb.set_style(
        ProgressStyle::with_template("{bar:40} {percent}% of {len} ticks, {eta} left")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    pb
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
