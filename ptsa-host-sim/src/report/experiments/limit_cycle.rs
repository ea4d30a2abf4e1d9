//! The limit cycle across and beyond the range: cycles with two current reversals, the
//! pendulum's excursion, the plain 1 s count and the charge-balance estimate, from 0 to
//! 1.3 × full scale (no bias, so the input is the whole torque).

use anyhow::Result;
use rayon::prelude::*;

use crate::lab::fixtures;
use crate::model::effects::Effects;
use crate::model::instrument::Instrument;
use crate::output::{Figure, Output, Plot, Series, Table, num};
use crate::report::{Experiment, Finding, Setup, Sink, ticks_only};
use crate::simulation::sim::{SimOptions, SimResult, simulate_condition};
use crate::simulation::work::Estimate;

/// Inputs as fractions of full scale.
pub const FRACTIONS: [f64; 11] = [
    0.0, 0.5, 0.9, 0.95, 0.96875, 0.975, 0.985, 0.994, 1.0, 1.05, 1.3,
];

/// What [`run`] returns.
#[derive(Clone, Debug, PartialEq)]
pub struct LimitCycleRun {
    /// `(input cm/s², result)` per fraction of [`FRACTIONS`].
    pub rows: Vec<(f64, SimResult)>,
    /// Table, figure, notes.
    pub output: Output,
}

/// The instrument without its bias and the options of the runs (1 s windows).
fn setup(instr: &Instrument, opts: &SimOptions) -> (Instrument, SimOptions) {
    let mut nb = instr.clone();
    nb.bias_cm_s2 = 0.0;
    (
        nb,
        SimOptions {
            min_window_s: 1.0,
            ..*opts
        },
    )
}

/// The closed-loop ticks [`run`] runs.
#[must_use]
pub fn work(instr: &Instrument, opts: &SimOptions) -> crate::simulation::work::Ticks {
    let (nb, o) = setup(instr, opts);
    FRACTIONS
        .iter()
        .map(|&fr| {
            crate::simulation::work::condition(
                &nb,
                &fixtures::along_ia(fr * nb.sf_cm_s2, nb.g_cm_s2),
                &o,
            )
        })
        .sum()
}

/// The sweep with 1 s windows.
///
/// # Errors
/// None today (kept for symmetry with the other experiments).
pub fn run(instr: &Instrument, opts: &SimOptions) -> Result<LimitCycleRun> {
    let (nb, o) = setup(instr, opts);
    let rows: Vec<(f64, SimResult)> = FRACTIONS
        .par_iter()
        .map(|&fr| {
            let a = fr * nb.sf_cm_s2;
            let c = fixtures::along_ia(a, nb.g_cm_s2);
            (a, simulate_condition(&nb, &c, &Effects::NONE, &o))
        })
        .collect();
    let mut t = Table::new(
        "limit-cycle-range",
        "Limit cycle across the range (no bias, 1 s windows): cycles with two reversals, pendulum excursion, plain count and estimate",
        &[
            "input cm/s^2",
            "fraction of SF",
            "cycles",
            "2 reversals",
            "max |theta| urad",
            "stop ticks",
            "1 s count cm/s^2",
            "estimate cm/s^2",
        ],
    );
    for (a, r) in &rows {
        #[allow(clippy::cast_precision_loss)]
        t.rows.push(vec![
            num(*a, 1),
            num(a / nb.sf_cm_s2, 5),
            num(r.cycles as f64, 0),
            num(r.cycles_two_reversals as f64, 0),
            num(r.theta_max_rad * 1e6, 1),
            num(r.stop_ticks as f64, 0),
            num(r.count_cm_s2, 3),
            num(r.indicated_cm_s2, 4),
        ]);
    }
    let fs = nb.sf_cm_s2;
    let last_two = rows
        .iter()
        .filter(|(_, r)| r.cycles > 0 && r.cycles == r.cycles_two_reversals)
        .map(|(a, _)| a / fs)
        .fold(0.0, f64::max);
    let worst_in_range = rows
        .iter()
        .filter(|(a, _)| *a <= fs)
        .map(|(a, r)| (r.indicated_cm_s2 - a).abs())
        .fold(0.0, f64::max);
    let first_stop = rows
        .iter()
        .find(|(_, r)| r.stop_ticks > 0)
        .map(|(a, _)| a / fs);
    let fig = figure(&rows, nb.sf_cm_s2);
    Ok(LimitCycleRun {
        rows,
        output: Output {
            tables: vec![t],
            plots: vec![fig],
            notes: vec![format!(
                "limit cycle: two reversals in every cycle up to {last_two:.5} of full scale; closer to full scale cycles lose a reversal but the charge-balance estimate stays within {worst_in_range:.3} cm/s^2 of the input up to full scale; {}",
                first_stop.map_or_else(
                    || "the pendulum never reached a stop".to_string(),
                    |f| format!("from {f:.3} of full scale the pendulum sits on its stop and the output clips at the full scale")
                )
            )],
        },
    })
}

/// The figure of the sweep `rows` (input cm/s², result) for a full scale of `sf_cm_s2`.
/// Two panels: the errors within the range, where the plain count and the estimate differ
/// by a few cm/s² at most, on their own axis; and beyond it, where the pendulum sits on its
/// stop and the output clips at full scale (errors of thousands of cm/s², which would
/// squash the first panel to a line).
fn figure(rows: &[(f64, SimResult)], sf_cm_s2: f64) -> Figure {
    let saturated = |a: f64, r: &SimResult| r.stop_ticks > 0 || a > sf_cm_s2;
    let panel = |title: &str, beyond: bool| Plot {
        title: title.into(),
        x_label: "input, fraction of full scale".into(),
        y_label: "indicated − input, cm/s^2".into(),
        series: vec![
            Series::markers(
                "1 s plain count",
                rows.iter()
                    .filter(|(a, r)| saturated(*a, r) == beyond)
                    .map(|(a, r)| (a / sf_cm_s2, r.count_cm_s2 - a))
                    .collect(),
            ),
            Series::triangles(
                "charge-balance estimate",
                rows.iter()
                    .filter(|(a, r)| saturated(*a, r) == beyond)
                    .map(|(a, r)| (a / sf_cm_s2, r.indicated_cm_s2 - a))
                    .collect(),
            ),
        ],
        zero_line: true,
        ..Plot::default()
    };
    let within = panel("Within the range: indicated − input", false);
    let beyond = panel(
        "Beyond full scale (pendulum on its stop, output clipped): indicated − input",
        true,
    );
    Figure {
        stem: "limit-cycle-range".into(),
        panels: if beyond.series.iter().all(|s| s.points.is_empty()) {
            vec![within]
        } else {
            vec![within, beyond]
        },
    }
}

/// The step of the report programme (see [`crate::report::Experiment`]).
#[derive(Clone, Copy, Debug)]
pub struct Step;

impl Experiment for Step {
    fn name(&self) -> &'static str {
        "limit cycle"
    }

    fn work(&self, s: Setup<'_>) -> Result<Estimate> {
        Ok(ticks_only(work(s.instr, s.opts)))
    }

    fn run(&self, s: Setup<'_>, to: &mut Sink<'_>) -> Result<Finding> {
        let r = run(s.instr, s.opts)?;
        to.emit(&r.output)?;
        Ok(Finding::LimitCycle(r))
    }
}
