//! The closed loop's small-signal frequency response: a sine along IA, the component of the
//! pulse output at its frequency, against the linear model `L/(1 + L)` of the same loop.

use anyhow::Result;
use rayon::prelude::*;

use crate::model::condition::{Condition, IA};
use crate::model::design::loop_gain;
use crate::model::effects::Effects;
use crate::model::instrument::Instrument;
use crate::output::{Figure, Output, Plot, Series, Table, XAxis, num};
use crate::report::{Experiment, Finding, Setup, Sink, ticks_only};
use crate::simulation::sim::{SimOptions, simulate_condition};
use crate::simulation::work::Estimate;

/// Input amplitude, cm/s² (large enough that the 1-count dead band does not matter).
pub const AMPLITUDE_CM_S2: f64 = 2000.0;
/// Frequencies, Hz.
pub const FREQS_HZ: [f64; 11] = [
    1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 150.0, 200.0, 300.0, 400.0,
];

/// One frequency.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ResponseRow {
    /// Frequency, Hz.
    pub freq_hz: f64,
    /// Simulated gain, dB.
    pub sim_db: f64,
    /// Simulated phase, deg.
    pub sim_deg: f64,
    /// Linear model's gain, dB.
    pub model_db: f64,
    /// Linear model's phase, deg.
    pub model_deg: f64,
}

/// What [`run`] returns.
#[derive(Clone, Debug, PartialEq)]
pub struct ResponseRun {
    /// One row per frequency of [`FREQS_HZ`].
    pub rows: Vec<ResponseRow>,
    /// Table, figure, notes.
    pub output: Output,
}

/// The options of the runs: the first harmonic, windows of at least 1 s.
fn options(opts: &SimOptions) -> SimOptions {
    SimOptions {
        harmonic: 1,
        min_window_s: 1.0,
        ..*opts
    }
}

/// The sine along IA at `f` Hz.
fn sine(f: f64) -> Condition {
    let mut c = Condition {
        label: format!("{f} Hz sine along IA"),
        freq_hz: f,
        ..Condition::default()
    };
    c.lin_cm_s2[IA] = AMPLITUDE_CM_S2;
    c
}

/// The closed-loop ticks [`run`] runs.
#[must_use]
pub fn work(instr: &Instrument, opts: &SimOptions) -> crate::simulation::work::Ticks {
    let o = options(opts);
    FREQS_HZ
        .iter()
        .map(|&f| crate::simulation::work::condition(instr, &sine(f), &o))
        .sum()
}

/// The response at [`FREQS_HZ`] with 1 s windows.
///
/// # Errors
/// None today (kept for symmetry with the other experiments).
pub fn run(instr: &Instrument, opts: &SimOptions) -> Result<ResponseRun> {
    let o = options(opts);
    let rows: Vec<ResponseRow> = FREQS_HZ
        .par_iter()
        .map(|&f| {
            let c = sine(f);
            let r = simulate_condition(instr, &c, &Effects::NONE, &o);
            let l = loop_gain(instr, &opts.config, f);
            let h = l / (1.0 + l);
            ResponseRow {
                freq_hz: f,
                sim_db: 20.0 * (r.harmonic_amp_cm_s2 / AMPLITUDE_CM_S2).log10(),
                sim_deg: r.harmonic_deg,
                model_db: 20.0 * h.norm().log10(),
                model_deg: h.arg().to_degrees(),
            }
        })
        .collect();
    let t = table(&rows);
    // The model on a dense log grid from the first to the last frequency.
    let (f0, f1) = (FREQS_HZ[0], FREQS_HZ[FREQS_HZ.len() - 1]);
    let model: Vec<(f64, f64, f64)> = (0..=200)
        .map(|k| {
            let f = f0 * (f1 / f0).powf(f64::from(k) / 200.0);
            let l = loop_gain(instr, &opts.config, f);
            let h = l / (1.0 + l);
            (f, 20.0 * h.norm().log10(), h.arg().to_degrees())
        })
        .collect();
    let gain = Plot {
        title: "Closed-loop frequency response (indicated / input): gain".into(),
        x_label: "frequency, Hz".into(),
        y_label: "gain, dB".into(),
        series: vec![
            Series::line("model L/(1+L)", model.iter().map(|m| (m.0, m.1)).collect()),
            Series::markers(
                "simulated",
                rows.iter().map(|r| (r.freq_hz, r.sim_db)).collect(),
            ),
        ],
        x_axis: XAxis::Log,
        zero_line: true,
    };
    let phase = Plot {
        title: "Closed-loop frequency response (indicated / input): phase".into(),
        x_label: "frequency, Hz".into(),
        y_label: "phase, deg".into(),
        series: vec![
            Series::line("model L/(1+L)", model.iter().map(|m| (m.0, m.2)).collect()),
            Series::markers(
                "simulated",
                rows.iter().map(|r| (r.freq_hz, r.sim_deg)).collect(),
            ),
        ],
        x_axis: XAxis::Log,
        zero_line: true,
    };
    let worst_db = rows
        .iter()
        .map(|r| (r.sim_db - r.model_db).abs())
        .fold(0.0, f64::max);
    Ok(ResponseRun {
        output: Output {
            tables: vec![t],
            plots: vec![Figure {
                stem: "frequency-response".into(),
                panels: vec![gain, phase],
            }],
            notes: vec![format!(
                "frequency response: simulated and linear-model gain agree within {worst_db:.2} dB from {} to {} Hz",
                FREQS_HZ[0],
                FREQS_HZ[FREQS_HZ.len() - 1]
            )],
        },
        rows,
    })
}

/// The table of `rows`.
fn table(rows: &[ResponseRow]) -> Table {
    let mut t = Table::new(
        "frequency-response",
        &format!(
            "Small-signal frequency response of the pulse output, indicated / input ({AMPLITUDE_CM_S2} cm/s^2 sine along IA, 1 s windows)"
        ),
        &[
            "freq Hz",
            "simulated dB",
            "simulated deg",
            "model dB",
            "model deg",
        ],
    );
    for r in rows {
        t.rows.push(vec![
            num(r.freq_hz, 0),
            num(r.sim_db, 2),
            num(r.sim_deg, 1),
            num(r.model_db, 2),
            num(r.model_deg, 1),
        ]);
    }
    t
}

/// The step of the report programme (see [`crate::report::Experiment`]).
#[derive(Clone, Copy, Debug)]
pub struct Step;

impl Experiment for Step {
    fn name(&self) -> &'static str {
        "frequency response"
    }

    fn work(&self, s: Setup<'_>) -> Result<Estimate> {
        Ok(ticks_only(work(s.instr, s.opts)))
    }

    fn run(&self, s: Setup<'_>, to: &mut Sink<'_>) -> Result<Finding> {
        let r = run(s.instr, s.opts)?;
        to.emit(&r.output)?;
        Ok(Finding::Response(r))
    }
}
