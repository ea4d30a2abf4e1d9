//! Noise (`ptsa noise`): the Allan deviation of a static counter record, the noise terms
//! read from it, and the same analysis of the simulated loop at rest.
//!
//! * [`allan`]: the overlapping and modified Allan deviations in `O(N)` per averaging time,
//!   the noise type by the lag-1 autocorrelation, the equivalent degrees of freedom and the
//!   95 % intervals;
//! * [`terms`]: IEEE Std 952's noise terms (quantization, velocity random walk, bias
//!   instability, acceleration random walk) fitted to the curve, in cgs and navigation
//!   units;
//! * [`identify_terms`]: which of those terms a record of readings holds, selected under
//!   Holm's step-down with intervals, the points' covariance drawn from records made of
//!   the terms ([`synth`]);
//! * here: the record checked for what the analysis needs (gates back to back, of equal
//!   length), the analysis of a record ([`Analysis`]: its JSON, its table, its plot), and a
//!   record of the simulated closed loop at rest ([`simulate_record`], on the batch engine),
//!   with acceleration noise at the plant's input when asked ([`InputNoise`]).
//!
//! The record is `ptsa response`'s (`time_s,pulses,ticks`, read by
//! [`crate::lab::response::read`]); each gate indicates `SF·(2P/T − 1)` cm/s² with the
//! instrument file's nominal SF.
#![allow(
    clippy::cast_precision_loss,
    reason = "gate counts and averaging factors, far below 2^52, as f64"
)]

pub mod allan;
pub mod comparison;
pub mod edf;
pub mod identify;
pub mod identify_terms;
pub mod json;
pub mod readings;
pub mod synth;
pub mod terms;

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context as _, Result, bail};
use plotters::prelude::*;

use crate::lab::response::{self, Gate};
use crate::model::effects::Effects;
use crate::model::instrument::Instrument;
use crate::output::plot::font_ready;
use crate::output::significant as sig;
use crate::simulation::batch::{Engine, RecordJob};
use crate::simulation::sim::{ClosedLoop, SimOptions};
use allan::Point;
use terms::{Fitted, Term};

/// Fewest gates `ptsa noise` analyses: three octaves (τ₀, 2τ₀, 4τ₀).
pub const MIN_GATES: usize = 8;

/// The largest departure of a gate's start from the previous start plus one gate that
/// counts as back to back, as a fraction of the gate (time stamps rounded by the counter).
pub const SPACING_TOL: f64 = 0.01;

/// The lines of a record's gates, in order: the rule of [`response::parse`] (a byte-order
/// mark dropped, blank and `#` lines skipped, the first other line the header).
fn gate_lines(text: &str) -> Vec<usize> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    text.lines()
        .enumerate()
        .filter(|(_, l)| {
            let t = l.trim();
            !t.is_empty() && !t.starts_with('#')
        })
        .skip(1)
        .map(|(i, _)| i + 1)
        .collect()
}

/// A static record, read and checked for the Allan analysis.
#[derive(Clone, Debug)]
pub struct Record {
    /// The gates.
    pub gates: Vec<Gate>,
    /// The gate `T/f_clock`, s.
    pub tau0_s: f64,
}

/// Read the counter record at `path` ([`response::read`]'s reader and its refusals) and
/// check it for the analysis: at least [`MIN_GATES`] gates, each starting one gate
/// (`T/clock_hz`) after the previous one, within [`SPACING_TOL`] of a gate.
///
/// # Errors
/// The reader's refusals; too few gates; a gap, an overlap or dead time between two gates,
/// or a counter clock other than `clock_hz` (the first gate pair already off): named by
/// `file:line`, with what was expected.
pub fn read_record(path: &Path, clock_hz: f64) -> Result<Record> {
    let gates = response::read(path)?;
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).with_context(|| format!("{name}: cannot read"))?;
    let lines = gate_lines(&text);
    check_record(&name, gates, &lines, clock_hz)
}

/// The counter record `text` (`name` in messages) read as [`read_record`] reads a file,
/// with the same refusals.
///
/// # Errors
/// As [`read_record`].
pub fn parse_record(name: &str, text: &str, clock_hz: f64) -> Result<Record> {
    let gates = response::parse(name, text)?;
    check_record(name, gates, &gate_lines(text), clock_hz)
}

/// The gate of a simulated record by default, s (`ptsa noise --simulate --gate-s`).
pub const DEFAULT_GATE_S: f64 = 0.01;

/// Most gates a simulated record holds (memory: a record of that many gates is about
/// 0.5 GB of gates and text).
pub const MAX_SIMULATED_GATES: f64 = 2e7;

/// The whole gates of `gate_ticks` ticks in `seconds` of a simulated record, from
/// [`MIN_GATES`] to [`MAX_SIMULATED_GATES`]; `flags` name the length and the gate in a
/// refusal.
///
/// # Errors
/// Fewer or more gates than that.
pub fn simulated_gates(
    flags: (&str, &str),
    seconds: f64,
    gate_ticks: u64,
    clock_hz: f64,
) -> Result<u64> {
    let (seconds_flag, gate_flag) = flags;
    #[allow(clippy::cast_precision_loss)]
    let gate = gate_ticks as f64 / clock_hz;
    let n = (seconds / gate).floor();
    #[allow(clippy::cast_precision_loss)]
    if n.is_nan() || n < MIN_GATES as f64 {
        bail!(
            "{seconds_flag} {}: {} gates of {} s; expected at least {} gates ({seconds_flag} at least {} s)",
            sig(seconds, 8),
            n,
            sig(gate, 8),
            MIN_GATES,
            sig(gate * MIN_GATES as f64, 8)
        );
    }
    if n > MAX_SIMULATED_GATES {
        bail!(
            "{seconds_flag} {}: {} gates of {} s; expected at most {} gates (a longer {gate_flag}, or fewer {seconds_flag})",
            sig(seconds, 8),
            sig(n, 6),
            sig(gate, 8),
            sig(MAX_SIMULATED_GATES, 3)
        );
    }
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    Ok(n as u64)
}

/// The analysis's own warnings on the record `name`: too few averaging times for the
/// terms, a curve the terms do not describe.
#[must_use]
pub fn analysis_warnings(name: &str, a: &Analysis) -> Vec<String> {
    let mut warnings = Vec::new();
    let what = if a.pulse_cm_s.is_some() {
        "gates"
    } else {
        "samples"
    };
    if a.points.len() < 4 {
        warnings.push(format!(
            "{name}: {} {what} give {} averaging times: too few to read the noise terms from the slopes",
            a.gates,
            a.points.len()
        ));
    }
    #[allow(clippy::cast_precision_loss)]
    if a.fit_dof > 0 && crate::stats::chi2_sf(a.fit_chi2, a.fit_dof as f64) < 1e-3 {
        warnings.push(format!(
            "{name}: the Allan variance is not a sum of the {} power laws (the terms' fit has chi2 {} on {} dof): the terms are the fit's compromise, not readings{}",
            a.terms.len(),
            sig(a.fit_chi2, 4),
            a.fit_dof,
            if a.pulse_cm_s.is_some() {
                "; a loop's count pattern (its limit cycle's tones) gives stretches of slope -1/2 and sudden drops that no noise term makes (docs/method/noise.md)"
            } else {
                "; look at the plot for a step, a periodic disturbance or a drift that is not a ramp"
            }
        ));
    }
    warnings
}

/// The identification's warnings: what the record needs beyond the file's loop, and each
/// selected noise whose interval is open above.
#[must_use]
pub fn identification_warnings(name: &str, id: &identify::Identification) -> Vec<String> {
    let mut out = Vec::new();
    let chosen: Vec<&str> = id
        .candidates
        .iter()
        .filter(|c| c.selected)
        .map(|c| c.kind.key())
        .collect();
    if !chosen.is_empty() {
        out.push(format!(
            "{name}: beyond the instrument file's loop the record needs {} (Holm, 5 % familywise): the file's noise is not the instrument's",
            chosen.join(", ")
        ));
    }
    for c in id.candidates.iter().filter(|c| c.selected && c.open_above) {
        let top = match c.kind {
            identify::Kind::Pickoff => id.grid_uv.last(),
            identify::Kind::WhiteAcceleration => id.grid_white.last(),
            identify::Kind::RandomWalk => id.grid_walk.last(),
        };
        let unit = c.kind.units().first().map_or("", |u| u.0);
        out.push(format!(
            "{name}: the {}'s 95 % interval reaches the largest simulated value ({} {unit}): it is open above",
            c.kind.key().replace('_', " "),
            sig(top.copied().unwrap_or(0.0), 4)
        ));
    }
    out
}

/// `noise --readings FILE --identify`: which of IEEE Std 952's terms the readings hold,
/// the replicas seeded from the record and `seed`; `on_round` is told each round as it
/// starts (a progress line).
///
/// # Errors
/// The identification cannot be made (too few samples for its replicas).
pub fn identify_readings(
    r: &readings::Readings,
    a: &Analysis,
    seed: u64,
    on_round: &mut dyn FnMut(usize),
) -> Result<identify_terms::Identification> {
    let seed = identify_terms::record_seed(&r.y, seed);
    identify_terms::identify(&r.y, r.tau0_s, &a.terms, seed, on_round)
        .map_err(|e| anyhow::anyhow!("--identify: {} samples: {e}", r.y.len()))
}

/// [`read_record`]'s checks on gates already read; `lines[k]` is gate `k`'s line.
///
/// # Errors
/// As [`read_record`].
pub fn check_record(
    name: &str,
    gates: Vec<Gate>,
    lines: &[usize],
    clock_hz: f64,
) -> Result<Record> {
    let line = |k: usize| lines.get(k).copied().unwrap_or(0);
    if gates.len() < MIN_GATES {
        bail!(
            "{name}:{}: the record ends after {} gates; expected at least {MIN_GATES} (the Allan deviation at 3 octaves of the gate)",
            line(gates.len().saturating_sub(1)),
            gates.len()
        );
    }
    #[allow(clippy::cast_precision_loss)]
    let tau0_s = gates[0].ticks as f64 / clock_hz;
    for (k, w) in gates.windows(2).enumerate() {
        let step = w[1].time_s - w[0].time_s;
        if (step - tau0_s).abs() > SPACING_TOL * tau0_s {
            let what = if k == 0 {
                format!(
                    "every gate is {} s long ({} ticks at the instrument file's clock_hz {} Hz); if the counter's clock is another, give its instrument file",
                    sig(tau0_s, 8),
                    gates[0].ticks,
                    sig(clock_hz, 10)
                )
            } else if step > tau0_s {
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                let missing = ((step / tau0_s).round() as u64).saturating_sub(1);
                format!(
                    "a gap of {} s after the gate of line {} ({} missing, or dead time between gates)",
                    sig(step - tau0_s, 6),
                    line(k),
                    if missing == 0 {
                        "less than a gate".to_string()
                    } else {
                        crate::output::count(missing, "gate")
                    }
                )
            } else {
                format!(
                    "it overlaps the gate of line {} by {} s",
                    line(k),
                    sig(tau0_s - step, 6)
                )
            };
            bail!(
                "{name}:{}: column 1 (`time_s`) holds {}, {} s after the previous gate's start; expected back-to-back gates {} s apart (T/clock_hz): {what}; the Allan deviation needs contiguous gates",
                line(k + 1),
                w[1].time_s,
                sig(step, 8),
                sig(tau0_s, 8)
            );
        }
    }
    Ok(Record { gates, tau0_s })
}

/// Everything `ptsa noise` reports about a record.
#[derive(Clone, Debug)]
pub struct Analysis {
    /// Gates (a counter record) or samples (a record of readings) analysed.
    pub gates: usize,
    /// The gate, or the sample interval, s.
    pub tau0_s: f64,
    /// Mean indicated acceleration, cm/s².
    pub mean_cm_s2: f64,
    /// For a counter record: the nominal SF the counts were read with, cm/s².
    pub sf_cm_s2: Option<f64>,
    /// For a counter record: one data pulse as a velocity step, `2·SF/f_clock`, cm/s.
    pub pulse_cm_s: Option<f64>,
    /// For a record of readings: the unit they were given in (`LSB`, `mA`, `cm/s²`, …).
    pub reading_unit: Option<&'static str>,
    /// The averaging times, the second confidence level and the Hadamard deviation asked for.
    pub settings: allan::Settings,
    /// Lag-1 autocorrelation of the gates' indicated accelerations (−0.5 for pure count
    /// quantization: adjacent gates share the charge stored at their common boundary).
    pub lag1: f64,
    /// The octave points.
    pub points: Vec<Point>,
    /// The fitted noise terms.
    pub terms: Vec<Fitted>,
    /// The terms' fit: `χ²` and degrees of freedom.
    pub fit_chi2: f64,
    /// Degrees of freedom of the fit.
    pub fit_dof: usize,
}

/// The statement of the confidence intervals, for the JSON and the docs.
pub const EDF_METHOD: &str = "chi-squared intervals with Greenhall's EDF algorithm (Greenhall & Riley 2003, as Stable32 and allantools compute it) for the overlapping and the modified ADEV and the overlapping HDEV, the noise type at each tau by the lag-1 autocorrelation (Riley & Greenhall 2004)";

/// How the noise type at each τ is identified, for the JSON and the text.
pub const NOISE_ID_METHOD: &str = "the lag-1 autocorrelation of the m-averaged series, differenced until delta < 0.25 (Riley & Greenhall 2004, Stable32's method with 30 or more averages); with fewer, the type of the longest shorter tau";

impl Analysis {
    /// Analyse `record` with the nominal SF `sf_cm_s2` and clock `clock_hz`.
    #[must_use]
    pub fn of(record: &Record, sf_cm_s2: f64, clock_hz: f64) -> Self {
        Self::of_with(record, sf_cm_s2, clock_hz, &allan::Settings::default())
    }

    /// [`Analysis::of`] at the averaging times and second confidence of `settings`.
    #[must_use]
    pub fn of_with(
        record: &Record,
        sf_cm_s2: f64,
        clock_hz: f64,
        settings: &allan::Settings,
    ) -> Self {
        let y: Vec<f64> = record
            .gates
            .iter()
            .map(|g| g.indicated_cm_s2(sf_cm_s2))
            .collect();
        let mut a = Self::series(&y, record.tau0_s, settings, &terms::TERMS);
        a.sf_cm_s2 = Some(sf_cm_s2);
        a.pulse_cm_s = Some(2.0 * sf_cm_s2 / clock_hz);
        a
    }

    /// Analyse the gates' indicated accelerations `y` (cm/s²), gates of `tau0_s`.
    #[must_use]
    pub fn of_series(y: &[f64], tau0_s: f64, sf_cm_s2: f64, clock_hz: f64) -> Self {
        let mut a = Self::series(y, tau0_s, &allan::Settings::default(), &terms::TERMS);
        a.sf_cm_s2 = Some(sf_cm_s2);
        a.pulse_cm_s = Some(2.0 * sf_cm_s2 / clock_hz);
        a
    }

    /// Analyse a record of readings at the averaging times of `settings`, with the
    /// Hadamard deviation, and IEEE Std 952's terms with the rate ramp among them.
    #[must_use]
    pub fn of_readings(r: &readings::Readings, settings: &allan::Settings) -> Self {
        let settings = allan::Settings {
            hadamard: true,
            ..settings.clone()
        };
        let mut a = Self::series(&r.y, r.tau0_s, &settings, &terms::WITH_RATE_RAMP);
        a.reading_unit = Some(r.unit.name());
        a
    }

    /// The analysis of the series `y` (cm/s²) of interval `tau0_s`: the points of
    /// `settings`, the `terms` fitted to them.
    fn series(y: &[f64], tau0_s: f64, settings: &allan::Settings, terms: &[Term]) -> Self {
        let points = allan::analyse_with(y, tau0_s, settings);
        let (terms, fit_chi2, fit_dof) = terms::fit_terms(
            &points
                .iter()
                .map(|p| (p.tau_s, p.adev * p.adev, p.edf))
                .collect::<Vec<_>>(),
            terms,
        );
        #[allow(clippy::cast_precision_loss)]
        let mean_cm_s2 = y.iter().sum::<f64>() / y.len().max(1) as f64;
        let den: f64 = y.iter().map(|v| (v - mean_cm_s2).powi(2)).sum();
        let num: f64 = y
            .windows(2)
            .map(|w| (w[0] - mean_cm_s2) * (w[1] - mean_cm_s2))
            .sum();
        Self {
            gates: y.len(),
            tau0_s,
            mean_cm_s2,
            sf_cm_s2: None,
            pulse_cm_s: None,
            reading_unit: None,
            settings: settings.clone(),
            lag1: if den > 0.0 { num / den } else { 0.0 },
            points,
            terms,
            fit_chi2,
            fit_dof,
        }
    }

    /// The local slope of `log ADEV` against `log τ` from point `k` to the next.
    #[must_use]
    pub fn slope(&self, k: usize) -> Option<f64> {
        let (a, b) = (self.points.get(k)?, self.points.get(k + 1)?);
        if a.adev > 0.0 && b.adev > 0.0 {
            Some((b.adev / a.adev).ln() / (b.tau_s / a.tau_s).ln())
        } else {
            None
        }
    }

    /// The text report: the table of points, then the terms.
    #[must_use]
    pub fn text(&self, record: &str) -> String {
        let mut s = String::new();
        let span = sig(self.tau0_s * self.gates as f64, 8);
        if let Some(pulse) = self.pulse_cm_s {
            let _ = writeln!(
                s,
                "noise: {record}: {} gates of {} s ({span} s), mean {} cm/s^2; one pulse = {} cm/s; lag-1 autocorrelation of the gates {:.3}",
                self.gates,
                sig(self.tau0_s, 8),
                sig(self.mean_cm_s2, 8),
                sig(pulse, 4),
                self.lag1
            );
        } else {
            let _ = writeln!(
                s,
                "noise: {record}: {} samples every {} s ({span} s), read in {}, mean {} cm/s^2; lag-1 autocorrelation of the samples {:.3}",
                self.gates,
                sig(self.tau0_s, 8),
                self.reading_unit.unwrap_or("cm/s²"),
                sig(self.mean_cm_s2, 8),
                self.lag1
            );
        }
        s.push_str(&self.table_text());
        let level = sig(self.settings.confidence * 100.0, 4);
        let _ = writeln!(
            s,
            "alpha: the noise type (2 white velocity/quantization, 0 white acceleration, -1 flicker, -2 random walk; to -4 for the Hadamard deviation's EDF) by {NOISE_ID_METHOD}; * inherited from a shorter tau, ? assumed. Intervals at 95 %{}: {EDF_METHOD}.",
            if (self.settings.confidence - 0.95).abs() < 1e-12 {
                String::new()
            } else {
                format!(" and {level} % (lo and hi, and the mdev and hdev intervals, at {level} %)")
            }
        );
        self.terms_text(&mut s);
        s
    }

    /// The table of points: τ, m, ADEV with its intervals, EDF, α, MDEV with its interval,
    /// HDEV with its interval where computed, the slope to the next τ.
    fn table_text(&self) -> String {
        let other = (self.settings.confidence - 0.95).abs() >= 1e-12;
        let hadamard = self.points.iter().any(|p| p.hdev.is_some());
        let e = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |v| format!("{v:.5e}"));
        let mut head = vec!["tau_s", "m", "adev cm/s^2", "ci95_lo", "ci95_hi"];
        if other {
            head.extend(["lo", "hi"]);
        }
        head.extend(["edf", "alpha", "mdev cm/s^2", "mdev lo", "mdev hi"]);
        if hadamard {
            head.extend(["hdev cm/s^2", "hdev lo", "hdev hi"]);
        }
        head.push("slope");
        let mut rows = vec![head.iter().map(|h| (*h).to_string()).collect::<Vec<_>>()];
        for (k, p) in self.points.iter().enumerate() {
            let mut r = vec![
                sig(p.tau_s, 6),
                p.m.to_string(),
                e(Some(p.adev)),
                e(Some(p.ci95_lo)),
                e(Some(p.ci95_hi)),
            ];
            let (lo, hi) = if other {
                p.mdev_ci.unzip()
            } else {
                p.mdev_ci95.unzip()
            };
            if other {
                r.extend([e(Some(p.ci.0)), e(Some(p.ci.1))]);
            }
            r.push(format!("{:.1}", p.edf));
            r.push(format!(
                "{}{}",
                p.alpha,
                match p.alpha_source {
                    allan::NoiseIdSource::Acf => " ",
                    allan::NoiseIdSource::Inherited => "*",
                    allan::NoiseIdSource::Assumed => "?",
                }
            ));
            r.extend([e(p.mdev), e(lo), e(hi)]);
            if hadamard {
                let (lo, hi) = p.hdev_ci.unzip();
                r.extend([e(p.hdev), e(lo), e(hi)]);
            }
            r.push(
                self.slope(k)
                    .map_or_else(|| "-".into(), |v| format!("{v:.2}")),
            );
            rows.push(r);
        }
        let widths: Vec<usize> = (0..rows[0].len())
            .map(|c| rows.iter().map(|r| r[c].chars().count()).max().unwrap_or(0))
            .collect();
        let mut s = String::new();
        for r in rows {
            let cells: Vec<String> = r
                .iter()
                .zip(&widths)
                .map(|(c, w)| format!("{c:>w$}"))
                .collect();
            let _ = writeln!(s, "{}", cells.join(" "));
        }
        s
    }

    /// The fitted terms, one line each.
    fn terms_text(&self, s: &mut String) {
        let formula = if self.terms.iter().any(|f| f.term == Term::RateRamp) {
            "AVAR = 3Q^2/tau^2 + N^2/tau + 0.4413 B^2 + K^2 tau/3 + R^2 tau^2/2"
        } else {
            "AVAR = 3Q^2/tau^2 + N^2/tau + 0.4413 B^2 + K^2 tau/3"
        };
        let _ = writeln!(
            s,
            "terms ({formula}, weighted fit; chi2 {:.1} on {} dof; 1-sigma):",
            self.fit_chi2, self.fit_dof
        );
        for f in &self.terms {
            let name = f.term.key().replace('_', " ");
            match f.value {
                None => {
                    let _ = writeln!(
                        s,
                        "  {} {name} (slope {}): not resolved",
                        f.term.symbol(),
                        f.term.slope()
                    );
                }
                Some((v, e)) => {
                    let parts: Vec<String> = f
                        .term
                        .units()
                        .into_iter()
                        .map(|(u, k)| format!("{:.4} ± {:.4} {u}", v * k, e * k))
                        .collect();
                    let _ = writeln!(
                        s,
                        "  {} {name} (slope {}): {}",
                        f.term.symbol(),
                        f.term.slope(),
                        parts.join(" = ")
                    );
                }
            }
        }
    }

    /// The log–log plot as SVG text: ADEV with its 95 % bars, MDEV, each fitted term's line
    /// and their sum. Without a font the plot is drawn without text.
    ///
    /// # Errors
    /// Drawing fails.
    pub fn svg(&self, title: &str) -> Result<String> {
        let mut s = String::new();
        draw(
            &SVGBackend::with_string(&mut s, (960, 640)).into_drawing_area(),
            self,
            title,
        )?;
        Ok(s)
    }

    /// The same plot as a PNG file at `path` (960 × 640), written whole or not at all.
    ///
    /// # Errors
    /// Drawing or writing fails.
    pub fn write_png(&self, path: &Path, title: &str) -> Result<()> {
        crate::output::plot::write_png(path, (960, 640), |area| draw(&area, self, title))
    }
}

/// The averaging times' name in the JSON: `octave`, `decade`, `all` or `listed`.
fn taus_name(t: &allan::Taus) -> &'static str {
    match t {
        allan::Taus::Octave => "octave",
        allan::Taus::Decade => "decade",
        allan::Taus::All => "all",
        allan::Taus::Factors(_) => "listed",
    }
}

fn err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow::anyhow!("{e:?}")
}

/// Colours of the terms' lines, in [`terms::TERMS`]' order.
const TERM_COLORS: [RGBColor; 5] = [
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

#[allow(
    clippy::too_many_lines,
    reason = "one plot: axes, bars, points, lines, legend in drawing order"
)]
fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    a: &Analysis,
    title: &str,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let fonts = font_ready();
    root.fill(&WHITE).map_err(err)?;
    let pos = |v: f64| v > 0.0 && v.is_finite();
    let ((t0, t1), (y0, y1)) = plot_ranges(a);
    let xr = (t0 / 1.5)..(t1 * 1.5);
    let mut b = ChartBuilder::on(root);
    b.margin(14).margin_right(30);
    if fonts {
        b.caption(title, ("sans-serif", 18))
            .x_label_area_size(44)
            .y_label_area_size(90);
    }
    let mut chart = b
        .build_cartesian_2d(xr.log_scale(), (y0..y1).log_scale())
        .map_err(err)?;
    {
        let mut m = chart.configure_mesh();
        if fonts {
            let f = |v: &f64| sig(*v, 3);
            m.x_desc("averaging time tau, s")
                .y_desc("Allan deviation, cm/s²")
                .x_label_formatter(&f)
                .y_label_formatter(&f)
                .label_style(("sans-serif", 13));
            m.draw().map_err(err)?;
        } else {
            m.x_labels(0).y_labels(0).draw().map_err(err)?;
        }
    }
    let blue = RGBColor(31, 119, 180);
    chart
        .draw_series(
            a.points
                .iter()
                .filter(|p| pos(p.ci95_lo) && pos(p.ci95_hi))
                .map(|p| PathElement::new(vec![(p.tau_s, p.ci95_lo), (p.tau_s, p.ci95_hi)], blue)),
        )
        .map_err(err)?;
    let ann = chart
        .draw_series(
            a.points
                .iter()
                .filter(|p| pos(p.adev))
                .map(|p| Circle::new((p.tau_s, p.adev), 4, blue.filled())),
        )
        .map_err(err)?;
    if fonts {
        ann.label("overlapping ADEV, 95 % interval")
            .legend(move |(x, y)| Circle::new((x + 9, y), 4, blue.filled()));
    }
    // The modified deviation's interval a little to the right of its τ, apart from the
    // overlapping one's.
    chart
        .draw_series(
            a.points
                .iter()
                .filter_map(|p| p.mdev_ci95.map(|c| (p.tau_s * 1.06, c)))
                .filter(|(_, c)| pos(c.0) && pos(c.1))
                .map(|(t, c)| PathElement::new(vec![(t, c.0), (t, c.1)], BLACK)),
        )
        .map_err(err)?;
    let ann = chart
        .draw_series(
            a.points
                .iter()
                .filter_map(|p| p.mdev.filter(|v| pos(*v)).map(|v| (p.tau_s * 1.06, v)))
                .map(|p| TriangleMarker::new(p, 5, BLACK.filled())),
        )
        .map_err(err)?;
    if fonts {
        ann.label("modified ADEV, 95 % interval")
            .legend(|(x, y)| TriangleMarker::new((x + 9, y), 5, BLACK.filled()));
    }
    term_lines(&mut chart, a, fonts, (t0, t1), (y0, y1))?;
    if fonts {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 13))
            .draw()
            .map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}

/// The plot's τ range (the first and last τ) and its deviation range (every positive
/// deviation and interval end, with room above and below).
fn plot_ranges(a: &Analysis) -> ((f64, f64), (f64, f64)) {
    let pos = |v: f64| v > 0.0 && v.is_finite();
    let taus: Vec<f64> = a.points.iter().map(|p| p.tau_s).collect();
    let t = (
        taus.first().copied().unwrap_or(1.0),
        taus.last().copied().unwrap_or(1.0),
    );
    let mut ys: Vec<f64> = a
        .points
        .iter()
        .flat_map(|p| {
            let (lo, hi) = p.mdev_ci95.unwrap_or((p.adev, p.adev));
            [
                p.ci95_lo,
                p.ci95_hi,
                p.adev,
                p.mdev.unwrap_or(p.adev),
                lo,
                hi,
            ]
        })
        .filter(|v| pos(*v))
        .collect();
    ys.sort_by(f64::total_cmp);
    let y = match (ys.first(), ys.last()) {
        (Some(&lo), Some(&hi)) => (lo / 2.0, hi * 3.0),
        _ => (1e-6, 1.0),
    };
    (t, y)
}

/// The fitted noise terms' lines and their sum, each with its legend entry when the fonts
/// are there.
fn term_lines<DB: DrawingBackend>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<LogCoord<f64>, LogCoord<f64>>>,
    a: &Analysis,
    fonts: bool,
    (t0, t1): (f64, f64),
    (y0, y1): (f64, f64),
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    // 60 points a line across the τ range.
    let grid: Vec<f64> = (0..=60)
        .map(|i| t0 / 1.5 * ((t1 * 2.25 / t0).powf(f64::from(i) / 60.0)))
        .collect();
    for (f, c) in a.terms.iter().zip(TERM_COLORS) {
        let Some((v, _)) = f.value else { continue };
        let pts: Vec<(f64, f64)> = grid
            .iter()
            .map(|&t| (t, (v * v * f.term.shape(t)).sqrt()))
            .filter(|p| p.1 >= y0 && p.1 <= y1)
            .collect();
        let ann = chart
            .draw_series(LineSeries::new(pts, c.stroke_width(2)))
            .map_err(err)?;
        if fonts {
            let label = format!(
                "{} (slope {}): {} {}",
                f.term.symbol(),
                f.term.slope(),
                sig(v, 3),
                f.term.units()[0].0
            );
            ann.label(label).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2))
            });
        }
    }
    if a.terms.iter().any(|f| f.value.is_some()) {
        let pts: Vec<(f64, f64)> = grid
            .iter()
            .map(|&t| (t, terms::model_avar(&a.terms, t).sqrt()))
            .filter(|p| p.1 >= y0 && p.1 <= y1)
            .collect();
        let ann = chart
            .draw_series(LineSeries::new(pts, BLACK.stroke_width(1)))
            .map_err(err)?;
        if fonts {
            ann.label("sum of the fitted terms")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK));
        }
    }
    Ok(())
}

/// One averaging time of a measured record against the simulated one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Compared {
    /// The measured record's point.
    pub measured: Point,
    /// The simulated record's point at the same τ.
    pub simulated: Point,
    /// `ln(σ_measured/σ_simulated)` over its standard error `√(1/(2ν_m) + 1/(2ν_s))` (the
    /// log of a deviation with ν degrees of freedom has a variance of about `1/(2ν)`).
    pub z: f64,
    /// Two-sided p-value of `z` (normal).
    pub p: f64,
    /// The two differ at this τ, Holm's step-down over all the τ at the familywise level.
    pub differs: bool,
}

/// Familywise level of [`compare`]'s Holm step-down over the τ.
pub const COMPARE_ALPHA: f64 = 0.05;

/// `--compare`'s test, in words (its JSON's `test`).
pub const COMPARE_TEST: &str = "z = ln(adev_measured/adev_simulated)/sqrt(1/(2 edf_measured) + 1/(2 edf_simulated)), two-sided normal p, Holm step-down over the taus";

/// The measured and simulated Allan deviations τ by τ (the τ both have), each difference's
/// `z` on the log scale and whether it is significant under Holm's step-down at
/// [`COMPARE_ALPHA`] over all those τ.
#[must_use]
pub fn compare(measured: &[Point], simulated: &[Point]) -> Vec<Compared> {
    let mut out: Vec<Compared> = measured
        .iter()
        .filter_map(|m| {
            let s = simulated
                .iter()
                .find(|s| (s.tau_s - m.tau_s).abs() <= 1e-9 * m.tau_s)?;
            let z = (m.adev / s.adev).ln() / (0.5 / m.edf + 0.5 / s.edf).sqrt();
            let p = if z.is_finite() {
                use statrs::distribution::{ContinuousCDF as _, Normal};
                Normal::standard().sf(z.abs()) * 2.0
            } else {
                0.0
            };
            Some(Compared {
                measured: *m,
                simulated: *s,
                z,
                p,
                differs: false,
            })
        })
        .collect();
    let mut order: Vec<usize> = (0..out.len()).collect();
    order.sort_by(|&a, &b| out[a].p.total_cmp(&out[b].p));
    let k = order.len();
    for (rank, &i) in order.iter().enumerate() {
        if out[i].p <= COMPARE_ALPHA / (k - rank) as f64 {
            out[i].differs = true;
        } else {
            break;
        }
    }
    out
}

/// Acceleration noise entering the plant's input along IA, beyond the pickoff noise: the
/// candidates `ptsa noise --identify` simulates inside the loop.
///
/// Each gate of `τ₀` holds the acceleration `a_k = w_k + n/√τ₀·ξ_k` (cm/s²), with `w_{k+1}
/// = w_k + k·√τ₀·ζ_k`, `ξ, ζ` independent standard normal draws from the seed: a white
/// acceleration noise of two-sided density `n` (cm/s²/√Hz; Allan variance `n²/τ`) and a
/// bias random walk of `k` (cm/s²·√Hz, i.e. cm/s^2.5; Allan variance `k²τ/3` for τ ≫ τ₀).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct InputNoise {
    /// White acceleration noise `N`, cm/s²/√Hz.
    pub white_cm_s2_rthz: f64,
    /// Bias random walk `K`, cm/s²·√Hz.
    pub walk_cm_s2_rthz: f64,
}

impl InputNoise {
    /// No noise at the input.
    pub const NONE: Self = Self {
        white_cm_s2_rthz: 0.0,
        walk_cm_s2_rthz: 0.0,
    };

    /// The acceleration along IA of each of `gates` gates of `tau0_s`: `base_cm_s2` plus
    /// this noise, drawn from `seed` (`ChaCha8`); empty when there is no noise (the
    /// condition is then never changed).
    #[must_use]
    pub fn gate_accels(self, base_cm_s2: f64, tau0_s: f64, gates: u64, seed: u64) -> Vec<f64> {
        use rand::SeedableRng as _;
        use rand_distr::Distribution as _;
        if self == Self::NONE {
            return Vec::new();
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let (sw, sk) = (
            self.white_cm_s2_rthz / tau0_s.sqrt(),
            self.walk_cm_s2_rthz * tau0_s.sqrt(),
        );
        let mut walk = 0.0;
        (0..gates)
            .map(|_| {
                let xi: f64 = rand_distr::StandardNormal.sample(&mut rng);
                let zeta: f64 = rand_distr::StandardNormal.sample(&mut rng);
                let a = base_cm_s2 + walk + sw * xi;
                walk += sk * zeta;
                a
            })
            .collect()
    }
}

impl InputNoise {
    /// The expected Allan variance of the accelerations [`InputNoise::gate_accels`] draws,
    /// averaged over `m` gates of `tau0_s`, (cm/s²)²: the white part held per gate, `N²/τ`
    /// (τ = m·τ₀), and the walk stepped per gate with variance `q = K²τ₀`,
    /// `q·(2m² + 1)/(6m)` (the discrete random walk's, `K²τ/3` for large m).
    #[must_use]
    pub fn expected_avar(self, tau0_s: f64, m: usize) -> f64 {
        let m = m as f64;
        let tau = m * tau0_s;
        let q = self.walk_cm_s2_rthz * self.walk_cm_s2_rthz * tau0_s;
        self.white_cm_s2_rthz * self.white_cm_s2_rthz / tau + q * (2.0 * m * m + 1.0) / (6.0 * m)
    }

    /// The standard error, cm/s², that this noise gives the mean of a record of `span_s`
    /// seconds: `√(N²/T + K²T/3)` (the white part's mean; the walk's mean over the record).
    #[must_use]
    pub fn mean_sd(self, span_s: f64) -> f64 {
        let (n, k) = (self.white_cm_s2_rthz, self.walk_cm_s2_rthz);
        (n * n / span_s + k * k * span_s / 3.0).sqrt()
    }
}

/// The gates of a record from the pulses counted in each (`gate_ticks` ticks of
/// `clock_hz`), `time_s` from 0.
#[must_use]
pub fn record_gates(counts: &[u32], gate_ticks: u64, clock_hz: f64) -> Vec<Gate> {
    let tau0 = gate_ticks as f64 / clock_hz;
    counts
        .iter()
        .enumerate()
        .map(|(k, &p)| Gate {
            time_s: k as f64 * tau0,
            pulses: u64::from(p),
            ticks: gate_ticks,
        })
        .collect()
}

/// A counter record of the closed loop at rest: the instrument file's loop (its bias and
/// pickoff noise `noise_uv_rms` included) with `accel_cm_s2` along IA (0 at rest on a
/// level bench; a tilt's share of gravity otherwise), settled for `opts.warmup_s` from
/// reset, then `gates` gates of `gate_ticks` ticks back to back, `time_s` counted from the
/// end of the settling. Run by the batch engine ([`Engine::simulate_records`], one lane):
/// bit for bit [`single_loop_record`].
#[must_use]
pub fn simulate_record(
    instr: &Instrument,
    opts: &SimOptions,
    accel_cm_s2: f64,
    gate_ticks: u64,
    gates: u64,
) -> Vec<Gate> {
    let job = RecordJob {
        instr,
        seed: opts.seed,
        accel_cm_s2,
        gate_accels_cm_s2: &[],
    };
    let counts = Engine::default().simulate_records(&[job], opts, gate_ticks, gates);
    record_gates(&counts[0], gate_ticks, instr.clock_hz)
}

/// The single loop's record, the reference the batch engine's records are checked against:
/// [`ClosedLoop::new`] in `along_ia(accel_cm_s2)`, `run_fast` for the settling, then per
/// gate the acceleration `gate_accels_cm_s2[k]` set (when given) and `run_fast(gate_ticks)`.
///
/// # Panics
/// If `gate_accels_cm_s2` is neither empty nor one per gate.
#[must_use]
pub fn single_loop_record(
    instr: &Instrument,
    opts: &SimOptions,
    accel_cm_s2: f64,
    gate_accels_cm_s2: &[f64],
    gate_ticks: u64,
    gates: u64,
) -> Vec<Gate> {
    assert!(gate_accels_cm_s2.is_empty() || gate_accels_cm_s2.len() as u64 == gates);
    let cond = crate::lab::fixtures::along_ia(accel_cm_s2, instr.g_cm_s2);
    let mut l = ClosedLoop::new(instr, &cond, &Effects::NONE, opts);
    l.run_fast(opts.warmup_ticks(instr.clock_hz));
    let mut counts = Vec::with_capacity(usize::try_from(gates).unwrap_or(0));
    let mut p0 = l.core().total_pulses();
    for k in 0..usize::try_from(gates).unwrap_or(usize::MAX) {
        if let Some(&a) = gate_accels_cm_s2.get(k) {
            l.set_condition(
                &crate::lab::fixtures::along_ia(a, instr.g_cm_s2),
                &Effects::NONE,
            );
        }
        l.run_fast(gate_ticks);
        let p1 = l.core().total_pulses();
        counts.push((p1 - p0).0);
        p0 = p1;
    }
    record_gates(&counts, gate_ticks, instr.clock_hz)
}

/// A record as the CSV `ptsa response` and `ptsa noise --counts` read: `# ` comment lines
/// (`comments`, one per entry), the header, one line per gate (times in Rust's shortest
/// round-trip form).
#[must_use]
pub fn record_csv(gates: &[Gate], comments: &[String]) -> String {
    let mut s = String::with_capacity(gates.len() * 24 + 200);
    for c in comments {
        let _ = writeln!(s, "# {c}");
    }
    s.push_str("time_s,pulses,ticks\n");
    for g in gates {
        let _ = writeln!(s, "{},{},{}", g.time_s, g.pulses, g.ticks);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gates(times: &[f64]) -> Vec<Gate> {
        times
            .iter()
            .map(|&t| Gate {
                time_s: t,
                pulses: 320,
                ticks: 640,
            })
            .collect()
    }

    /// Back-to-back gates pass; a missing gate, dead time, and another clock are refused at
    /// the right line.
    #[test]
    fn contiguity_is_checked_at_its_line() {
        let ok: Vec<f64> = (0..10).map(|k| f64::from(k) * 0.01).collect();
        let lines: Vec<usize> = (3..13).collect();
        assert!(check_record("r.csv", gates(&ok), &lines, 64_000.0).is_ok());
        let mut gap = ok.clone();
        for t in &mut gap[5..] {
            *t += 0.01;
        }
        let e = check_record("r.csv", gates(&gap), &lines, 64_000.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("r.csv:8:") && e.contains("1 gate missing"),
            "{e}"
        );
        let e = check_record("r.csv", gates(&ok), &lines, 32_000.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("r.csv:4:") && e.contains("clock_hz 32000"),
            "{e}"
        );
        let e = check_record("r.csv", gates(&ok[..7]), &lines, 64_000.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("at least 8"), "{e}");
    }

    /// The comparison: the same curve differs nowhere (z = 0); a curve twice as high at one
    /// τ with many degrees of freedom differs there only; Holm's threshold for the smallest
    /// p of k is 0.05/k (a p of 0.02 among 4 is not significant).
    #[test]
    fn compare_is_holm_over_the_taus() {
        let y: Vec<f64> = (0..64).map(|k| f64::from(k % 5)).collect();
        let pts = allan::analyse(&y, 0.01);
        let same = compare(&pts, &pts);
        assert!(same.iter().all(|c| !c.differs && c.z == 0.0), "{same:?}");
        let mut other = pts.clone();
        other[1].adev *= 2.0;
        for p in &mut other {
            p.edf = 1000.0;
        }
        let mut meas = pts.clone();
        for p in &mut meas {
            p.edf = 1000.0;
        }
        let c = compare(&meas, &other);
        assert!(
            c[1].differs && c.iter().filter(|c| c.differs).count() == 1,
            "{c:?}"
        );
        // z for a p of 0.02: 2.326; among 4 taus Holm asks p <= 0.0125 first.
        let mut four: Vec<Point> = pts[..4].to_vec();
        for p in &mut four {
            p.edf = 1000.0;
        }
        let mut shifted = four.clone();
        let z = 2.326_348;
        shifted[0].adev = four[0].adev / (z * (1.0 / 1000.0f64).sqrt()).exp();
        let c = compare(&four, &shifted);
        assert!((c[0].p - 0.02).abs() < 1e-4, "{}", c[0].p);
        assert!(c.iter().all(|c| !c.differs), "{c:?}");
    }

    /// The batch engine's records are the single loop's bit for bit: one lane at rest,
    /// and lanes of different seeds, pickoff noises and accelerations per gate together.
    #[test]
    fn engine_records_are_the_single_loops() {
        let instr = Instrument::kearfott_2401();
        let opts = SimOptions::default();
        let (ticks, gates) = (640, 150);
        assert_eq!(
            simulate_record(&instr, &opts, 0.0, ticks, gates),
            single_loop_record(&instr, &opts, 0.0, &[], ticks, gates)
        );
        let mut noisy = instr.clone();
        noisy.noise_v_rms = 3e-6;
        let inputs: Vec<Vec<f64>> = (0..6u64)
            .map(|s| {
                let n = InputNoise {
                    white_cm_s2_rthz: 0.05 * s as f64,
                    walk_cm_s2_rthz: if s % 2 == 0 { 0.01 } else { 0.0 },
                };
                n.gate_accels(2.0, 0.01, gates, s)
            })
            .collect();
        let jobs: Vec<RecordJob<'_>> = inputs
            .iter()
            .enumerate()
            .map(|(s, a)| RecordJob {
                instr: if s % 3 == 0 { &noisy } else { &instr },
                seed: 7 + s as u64 / 2,
                accel_cm_s2: 2.0,
                gate_accels_cm_s2: a,
            })
            .collect();
        for lanes in [1, 4] {
            let got = Engine::new(lanes).simulate_records(&jobs, &opts, ticks, gates);
            for (j, c) in jobs.iter().zip(&got) {
                let o = SimOptions {
                    seed: j.seed,
                    ..opts
                };
                let want = single_loop_record(j.instr, &o, 2.0, j.gate_accels_cm_s2, ticks, gates);
                assert_eq!(
                    record_gates(c, ticks, instr.clock_hz),
                    want,
                    "lanes {lanes}"
                );
            }
        }
    }

    /// The input noise: none gives no accelerations; white noise of N has a per-gate
    /// standard deviation N/√τ₀, a random walk of K steps of K·√τ₀ (sample figures of
    /// 20 000 draws within 3 %).
    #[test]
    fn input_noise_has_its_units() {
        assert!(InputNoise::NONE.gate_accels(1.0, 0.01, 10, 1).is_empty());
        let n = 20_000;
        let a = InputNoise {
            white_cm_s2_rthz: 0.1,
            walk_cm_s2_rthz: 0.0,
        }
        .gate_accels(5.0, 0.01, n, 3);
        let mean = a.iter().sum::<f64>() / n as f64;
        let sd = (a.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64).sqrt();
        assert!(
            (mean - 5.0).abs() < 0.05 && (sd / 1.0 - 1.0).abs() < 0.03,
            "{mean} {sd}"
        );
        let w = InputNoise {
            white_cm_s2_rthz: 0.0,
            walk_cm_s2_rthz: 0.2,
        }
        .gate_accels(0.0, 0.01, n, 4);
        let steps: Vec<f64> = w.windows(2).map(|p| p[1] - p[0]).collect();
        let sd = (steps.iter().map(|x| x * x).sum::<f64>() / steps.len() as f64).sqrt();
        assert!((sd / 0.02 - 1.0).abs() < 0.03, "{sd}");
    }

    #[test]
    fn gate_lines_follow_the_readers_rule() {
        let t = "\u{feff}# c\n\ntime_s,pulses,ticks\n0,1,2\n# x\n0.1,1,2\n";
        assert_eq!(gate_lines(t), [4, 6]);
    }

    /// The simulated record: contiguous, the CSV read back by the record reader bit for
    /// bit, the mean indicating the loop's bias.
    #[test]
    fn a_simulated_record_reads_back() {
        let instr = Instrument::kearfott_2401();
        let opts = SimOptions::default();
        let g = simulate_record(&instr, &opts, 0.0, 640, 200);
        let csv = record_csv(&g, &["test".into()]);
        let back = response::parse("sim", &csv).unwrap();
        assert_eq!(back, g);
        let lines = gate_lines(&csv);
        let r = check_record("sim", back, &lines, instr.clock_hz).unwrap();
        let a = Analysis::of(&r, instr.sf_cm_s2, instr.clock_hz);
        assert!(
            (a.mean_cm_s2 - instr.bias_cm_s2).abs() < 1.0,
            "{} {}",
            a.mean_cm_s2,
            instr.bias_cm_s2
        );
        assert!(a.points[0].adev > 0.0);
    }
}
