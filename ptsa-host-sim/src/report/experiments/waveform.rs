//! Fig. 3.2: the torquer current, the pulse train and the pendulum angle over a few limit
//! cycles with a constant input along IA. The tick-by-tick trace is streamed to its CSV file
//! as the loop runs (any length, constant memory); the figure shows the first
//! [`PLOTTED_CYCLES`] cycles.

use std::path::Path;

use anyhow::{Context, Result};

use crate::lab::fixtures;
use crate::model::effects::Effects;
use crate::model::instrument::Instrument;
use crate::output::fs::{persist, temp_beside};
use crate::output::{Figure, Output, Plot, Series};
use crate::report::{Experiment, Finding, Setup, Sink, ticks_only};
use crate::simulation::sim::{ClosedLoop, SimOptions};
use crate::simulation::work::Estimate;

/// Default constant acceleration along IA, cm/s².
pub const DEFAULT_ACCEL_CM_S2: f64 = 5000.0;
/// Default number of limit cycles traced.
pub const DEFAULT_CYCLES: u64 = 4;
/// Limit cycles drawn in the figure (the CSV holds all of them).
pub const PLOTTED_CYCLES: u64 = 8;
/// File stem of the trace and its figure.
pub const STEM: &str = "waveform-limit-cycle";

/// The closed-loop ticks [`run`] runs: the settling and the trace (each traced tick is
/// also written out, which takes far longer than the tick: [`TRACE_S_PER_TICK`]).
#[must_use]
pub fn work(instr: &Instrument, opts: &SimOptions, cycles: u64) -> crate::simulation::work::Ticks {
    #[allow(clippy::cast_precision_loss)]
    let n = (opts.warmup_ticks(instr.clock_hz)
        + cycles.saturating_mul(u64::from(opts.config.ticks_per_cycle))) as f64;
    crate::simulation::work::Ticks::of(n, false)
}

/// Seconds to write one traced tick's row (`docs/method/host-sim.md`, "Work estimates"), on the
/// slow side.
pub const TRACE_S_PER_TICK: f64 = 2e-6;

/// Trace `cycles` limit cycles at `accel_cm_s2` along IA after the run's settling time;
/// writes `<dir>/waveform-limit-cycle.csv` (one row per tick) as it runs.
///
/// # Errors
/// The trace cannot be written.
pub fn run(
    instr: &Instrument,
    opts: &SimOptions,
    accel_cm_s2: f64,
    cycles: u64,
    dir: &Path,
) -> Result<Output> {
    let cond = fixtures::along_ia(accel_cm_s2, instr.g_cm_s2);
    let mut l = ClosedLoop::new(instr, &cond, &Effects::NONE, opts);
    l.run(opts.warmup_ticks(instr.clock_hz));
    let per_cycle = u64::from(opts.config.ticks_per_cycle);
    let t_us = 1e6 / instr.clock_hz;
    let i_fs = instr.full_current_ma;
    let csv_path = dir.join(format!("{STEM}.csv"));
    let tmp = temp_beside(&csv_path)?;
    let mut w = csv::Writer::from_writer(std::io::BufWriter::new(tmp.as_file()));
    w.write_record([
        "t us",
        "command",
        "current mA",
        "pulse",
        "theta urad",
        "ADC code",
    ])?;
    let plotted = cycles.min(PLOTTED_CYCLES) * per_cycle;
    let (mut cur, mut cmd, mut th) = (Vec::new(), Vec::new(), Vec::new());
    let k0 = l.ticks();
    // Sub-sample the current inside each tick for the figure (exact first-order rise).
    let a = (-1.0 / (instr.clock_hz * instr.torquer_tau_s)).exp();
    let mut prev_i = l.state()[2];
    let mut failed: Option<csv::Error> = None;
    let ticks = cycles.checked_mul(per_cycle).ok_or_else(|| {
        anyhow::anyhow!("{cycles} limit cycles of {per_cycle} ticks: too many ticks to count")
    })?;
    l.run_observed(ticks, |v| {
        #[allow(clippy::cast_precision_loss)]
        let t = (v.k - k0) as f64 * t_us;
        if v.k - k0 < plotted {
            for s in 0..8 {
                let frac = f64::from(s) / 8.0;
                let i = v.u + (prev_i - v.u) * a.powf(frac);
                cur.push((t + frac * t_us, i * i_fs));
            }
            cmd.push((t, v.u * i_fs));
            cmd.push((t + t_us, v.u * i_fs));
            th.push((t + t_us, v.x[0] * 1e6));
        }
        prev_i = v.x[2];
        if failed.is_none()
            && let Err(e) = w.write_record(&[
                format!("{t:.3}"),
                format!("{}", v.u),
                format!("{}", v.x[2] * i_fs),
                if v.u > 0.0 { "1" } else { "0" }.to_string(),
                format!("{}", v.x[0] * 1e6),
                format!("{}", v.code),
            ])
        {
            failed = Some(e);
        }
    });
    if let Some(e) = failed {
        return Err(e).with_context(|| format!("writing {}", csv_path.display()));
    }
    w.flush()
        .with_context(|| format!("writing {}", csv_path.display()))?;
    drop(w);
    persist(tmp, &csv_path)?;
    let plot = Plot {
        title: format!(
            "Fig. 3.2: torquer current and pulse train, {accel_cm_s2} cm/s^2 ({} of {cycles} cycles)",
            cycles.min(PLOTTED_CYCLES)
        ),
        x_label: "time, us".into(),
        y_label: "current, mA / pendulum angle, urad".into(),
        series: vec![
            Series::line("torquer current, mA", cur),
            Series::line("command (pulse train), mA", cmd),
            Series::line("theta, urad", th),
        ],
        ..Plot::default()
    };
    Ok(Output {
        tables: Vec::new(),
        plots: vec![Figure::single(STEM, plot)],
        notes: vec![format!(
            "waveform: {} ({}) at {accel_cm_s2} cm/s^2 along IA, tick by tick in {STEM}.csv",
            crate::output::count(cycles, "limit cycle"),
            crate::output::count(cycles.saturating_mul(per_cycle), "tick")
        )],
    })
}

/// The step of the report programme (see [`crate::report::Experiment`]).
#[derive(Clone, Copy, Debug)]
pub struct Step;

impl Experiment for Step {
    fn name(&self) -> &'static str {
        "waveform"
    }

    fn work(&self, s: Setup<'_>) -> Result<Estimate> {
        Ok(ticks_only(work(s.instr, s.opts, DEFAULT_CYCLES)))
    }

    fn run(&self, s: Setup<'_>, to: &mut Sink<'_>) -> Result<Finding> {
        let o = run(s.instr, s.opts, DEFAULT_ACCEL_CM_S2, DEFAULT_CYCLES, to.dir)?;
        to.emit(&o)?;
        Ok(Finding::Waveform(o))
    }
}
