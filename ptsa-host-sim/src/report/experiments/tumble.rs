//! Section 6.1: the ±1 g tumble (eqs. 6.1–6.4) and a sweep of IA through 360°.
//!
//! Eq. 6.2 as printed has a sign typo: with IA down the count gives
//! `SF·(2P₂/T − 1) = −g + A_b`, i.e. `SF·(1 − 2P₂/T) = g − A_b`; eqs. 6.3 and 6.4 are right
//! as printed and are what [`sf_and_bias`] computes.

use anyhow::Result;
use rayon::prelude::*;

use crate::lab::fixtures;
use crate::model::effects::Effects;
use crate::model::instrument::Instrument;
use crate::output::{Cell, Figure, Output, Plot, Series, Table, num, text};
use crate::report::r890;
use crate::report::{Experiment, Finding, Setup, Sink, ticks_only};
use crate::simulation::sim::{ClosedLoop, SimOptions, simulate_condition};
use crate::simulation::work::Estimate;

/// Default counting gate, s (the report's count period is not given; 1 s).
pub const DEFAULT_GATE_S: f64 = 1.0;

/// Tumble result: counts and eqs. 6.3/6.4.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tumble {
    /// Gate, ticks (`T`), whole limit cycles.
    pub ticks: u64,
    /// Pulses with IA up (`P1`).
    pub p1: u64,
    /// Pulses with IA down (`P2`).
    pub p2: u64,
    /// SF from the plain counts, eq. 6.3, cm/s².
    pub sf_count: f64,
    /// Bias from the plain counts, eq. 6.4, cm/s².
    pub bias_count: f64,
    /// `P1/T` from the charge-balance estimator (the count's limit), fraction.
    pub p1_frac: f64,
    /// `P2/T` likewise.
    pub p2_frac: f64,
    /// SF by eq. 6.3 from the estimator, cm/s².
    pub sf: f64,
    /// Bias by eq. 6.4 from the estimator, cm/s².
    pub bias: f64,
    /// The SF the simulation was configured with, cm/s².
    pub sf_configured: f64,
    /// The bias it was configured with (instrument `A_b` plus the loop's own), cm/s².
    pub bias_configured: f64,
}

/// What [`run`] returns.
#[derive(Clone, Debug, PartialEq)]
pub struct TumbleRun {
    /// The ±1 g result.
    pub tumble: Tumble,
    /// The 360° sweep: IA angle above horizontal (deg), indicated (cm/s²).
    pub sweep: Vec<(f64, f64)>,
    /// Tables, figures, notes.
    pub output: Output,
}

/// Eqs. 6.3 and 6.4: `SF = g / (P1/T − P2/T)`, `A_b = SF·(P1/T + P2/T − 1)`.
#[must_use]
pub fn sf_and_bias(g: f64, p1_frac: f64, p2_frac: f64) -> (f64, f64) {
    let sf = g / (p1_frac - p2_frac);
    (sf, sf * (p1_frac + p2_frac - 1.0))
}

/// The gate actually counted, s (the asked one rounded to whole limit cycles).
fn gate_used_s(instr: &Instrument, ticks: u64) -> f64 {
    #[allow(clippy::cast_precision_loss)]
    let s = ticks as f64 / instr.clock_hz;
    s
}

/// Ticks of a gate of `gate_s` seconds, rounded to whole limit cycles (at least one).
#[must_use]
pub fn gate_ticks(instr: &Instrument, opts: &SimOptions, gate_s: f64) -> u64 {
    let n = f64::from(opts.config.ticks_per_cycle);
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let t = ((gate_s * instr.clock_hz / n).round().max(1.0) * n) as u64;
    t
}

/// The closed-loop ticks [`run`] runs: the two gates after their settling, and the
/// sweep's conditions.
#[must_use]
pub fn work(instr: &Instrument, opts: &SimOptions, gate_s: f64) -> crate::simulation::work::Ticks {
    #[allow(clippy::cast_precision_loss)]
    let gates = 2.0 * (opts.warmup_ticks(instr.clock_hz) + gate_ticks(instr, opts, gate_s)) as f64;
    crate::simulation::work::Ticks::of(gates, false)
        + sweep_deg()
            .into_iter()
            .map(|a| crate::simulation::work::condition(instr, &fixtures::dividing_head(a), opts))
            .sum()
}

/// The sweep's IA angles, deg: 0° to 345° in 15° steps.
fn sweep_deg() -> Vec<f64> {
    (0..24).map(|k| f64::from(k) * 15.0).collect()
}

/// The ±1 g tumble of section 6.1 over a gate of `gate_s` seconds, and a sweep of IA
/// through 360° in the vertical plane.
///
/// # Errors
/// The report's transcription (section 6.1) is malformed.
pub fn run(instr: &Instrument, opts: &SimOptions, gate_s: f64) -> Result<TumbleRun> {
    let report = r890::section_6_1()?;
    let t = tumble(instr, opts, gate_ticks(instr, opts, gate_s));
    let tab = sf_bias_table(instr, &t, &report);
    let sweep = sweep(instr, opts);
    let expected = |a: f64| instr.g_cm_s2 * a.to_radians().sin() + t.bias_configured;
    let tab2 = sweep_table(&sweep, &expected);
    let [plot, residual] = sweep_plots(&sweep, &expected);
    let notes = vec![format!(
        "tumble: SF {:.4} cm/s^2 (configured {:.4}, error {:.3} ppm), A_b {:.5} cm/s^2 (configured {:.5}); plain {} s counts give SF {:.2}, A_b {:.3}",
        t.sf,
        t.sf_configured,
        (t.sf / t.sf_configured - 1.0) * 1e6,
        t.bias,
        t.bias_configured,
        gate_used_s(instr, t.ticks),
        t.sf_count,
        t.bias_count
    )];
    Ok(TumbleRun {
        tumble: t,
        sweep,
        output: Output {
            tables: vec![tab, tab2],
            plots: vec![
                Figure::single("tumble-sweep", plot),
                Figure::single("tumble-sweep-error", residual),
            ],
            notes,
        },
    })
}

/// The ±1 g tumble over a gate of `ticks`: IA up and IA down counted after their settling,
/// and SF and bias by eqs. 6.3 and 6.4 from the plain counts and from the estimator.
fn tumble(instr: &Instrument, opts: &SimOptions, ticks: u64) -> Tumble {
    let count = |up: bool| {
        let c = fixtures::dividing_head(if up { 90.0 } else { 270.0 });
        let mut l = ClosedLoop::new(instr, &c, &Effects::NONE, opts);
        l.run(opts.warmup_ticks(instr.clock_hz));
        l.measure(ticks)
    };
    let (up, down) = rayon::join(|| count(true), || count(false));
    let g = instr.g_cm_s2;
    #[allow(clippy::cast_precision_loss)]
    let (c1, c2) = (
        up.pulses as f64 / ticks as f64,
        down.pulses as f64 / ticks as f64,
    );
    let (sf_count, bias_count) = sf_and_bias(g, c1, c2);
    let sfc = instr.sf_cm_s2;
    let f1 = 0.5 * (1.0 + up.indicated_cm_s2 / sfc);
    let f2 = 0.5 * (1.0 + down.indicated_cm_s2 / sfc);
    let (sf, bias) = sf_and_bias(g, f1, f2);
    Tumble {
        ticks,
        p1: up.pulses,
        p2: down.pulses,
        sf_count,
        bias_count,
        p1_frac: f1,
        p2_frac: f2,
        sf,
        bias,
        sf_configured: instr.actual_sf_cm_s2(),
        bias_configured: instr.bias_cm_s2 + instr.loop_bias_cm_s2(0.0),
    }
}

/// The sweep's table: at each IA angle the indicated acceleration against the `expected`
/// `g sin(phi) + A_b`, and their difference.
fn sweep_table(sweep: &[(f64, f64)], expected: &dyn Fn(f64) -> f64) -> Table {
    let mut tab = Table::new(
        "tumble-sweep",
        "Tumble sweep: IA angle above horizontal",
        &[
            "IA deg",
            "indicated cm/s^2",
            "g sin(phi) + A_b cm/s^2",
            "difference cm/s^2",
        ],
    );
    for &(a, x) in sweep {
        let e = expected(a);
        tab.rows
            .push(vec![num(a, 0), num(x, 4), num(e, 4), num(x - e, 5)]);
    }
    tab
}

/// The sweep's plots: the indicated acceleration against the `expected` curve over IA's
/// angle, and the difference of the two.
fn sweep_plots(sweep: &[(f64, f64)], expected: &dyn Fn(f64) -> f64) -> [Plot; 2] {
    let plot = Plot {
        title: "Tumble: indicated acceleration vs IA angle".into(),
        x_label: "IA angle above horizontal, deg".into(),
        y_label: "indicated, cm/s^2".into(),
        series: vec![
            Series::line(
                "g sin(phi) + A_b",
                (0..=360)
                    .map(|a| (f64::from(a), expected(f64::from(a))))
                    .collect(),
            ),
            Series::markers("simulated", sweep.to_vec()),
        ],
        ..Plot::default()
    };
    // What the first plot cannot show at its 2000 cm/s^2 scale: the loop's error.
    let residual = Plot {
        title: "Tumble: indicated − (g sin(phi) + A_b) vs IA angle".into(),
        x_label: "IA angle above horizontal, deg".into(),
        y_label: "indicated − expected, cm/s^2".into(),
        series: vec![Series::markers(
            "simulated − expected",
            sweep.iter().map(|&(a, x)| (a, x - expected(a))).collect(),
        )],
        zero_line: true,
        ..Plot::default()
    };
    [plot, residual]
}

/// The tumble's SF and bias table: `t` against the configured values and the `report`'s.
fn sf_bias_table(instr: &Instrument, t: &Tumble, report: &r890::Section61) -> Table {
    let mut tab = Table::new(
        "tumble-sf-bias",
        &format!(
            "Tumble (section 6.1), gate T = {} ticks ({} s)",
            t.ticks,
            gate_used_s(instr, t.ticks)
        ),
        &[
            "quantity",
            "plain count",
            "charge balance",
            "configured",
            "report",
        ],
    );
    #[allow(clippy::cast_precision_loss)]
    let rows = vec![
        vec![
            text("P1 (IA up), pulses"),
            num(t.p1 as f64, 0),
            num(t.p1_frac * t.ticks as f64, 3),
            Cell::Missing,
            Cell::Missing,
        ],
        vec![
            text("P2 (IA down), pulses"),
            num(t.p2 as f64, 0),
            num(t.p2_frac * t.ticks as f64, 3),
            Cell::Missing,
            Cell::Missing,
        ],
        vec![
            text("SF, cm/s^2 (eq. 6.3)"),
            num(t.sf_count, 2),
            num(t.sf, 4),
            num(t.sf_configured, 4),
            num(report.sf_cm_s2, 1),
        ],
        vec![
            text("A_b, cm/s^2 (eq. 6.4)"),
            num(t.bias_count, 3),
            num(t.bias, 4),
            num(t.bias_configured, 4),
            num(report.bias_cm_s2, 1),
        ],
    ];
    tab.rows = rows;
    tab
}

/// IA through 360° in 15° steps: the indicated acceleration at each angle.
fn sweep(instr: &Instrument, opts: &SimOptions) -> Vec<(f64, f64)> {
    sweep_deg()
        .par_iter()
        .map(|&a| {
            let c = fixtures::dividing_head(a);
            (
                a,
                simulate_condition(instr, &c, &Effects::NONE, opts).indicated_cm_s2,
            )
        })
        .collect()
}

/// The step of the report programme (see [`crate::report::Experiment`]).
#[derive(Clone, Copy, Debug)]
pub struct Step;

impl Experiment for Step {
    fn name(&self) -> &'static str {
        "tumble"
    }

    fn work(&self, s: Setup<'_>) -> Result<Estimate> {
        Ok(ticks_only(work(s.instr, s.opts, DEFAULT_GATE_S)))
    }

    fn run(&self, s: Setup<'_>, to: &mut Sink<'_>) -> Result<Finding> {
        let r = run(s.instr, s.opts, DEFAULT_GATE_S)?;
        to.emit(&r.output)?;
        Ok(Finding::Tumble(r))
    }
}
