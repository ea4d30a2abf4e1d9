//! `ptsa response`: a counter record taken under a sine along IA reduced to one case-frame
//! response row by a least-squares sine fit (`lab::response`), with its checks, its plot
//! and the row (CSV or JSON). Simulates nothing: it needs the instrument file's SF and
//! clock only, and runs for a loop the simulator refuses too.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result, bail};
use clap::Args;
use ptsa_host_sim::lab::response::{self, FitCheck, Gate, ResponseFit};
use ptsa_host_sim::model::condition::Condition;
use ptsa_host_sim::model::design::Design;
use ptsa_host_sim::output::command_json::ResponseJson;
use ptsa_host_sim::output::{Figure, Plot, Series, count, significant as sig, write_figure};

use super::Ctx;
use crate::flags::OutArgs;
use crate::flags::values::{finite, input_amplitude_cm_s2, label, num, positive_hz};
use crate::paths;

/// Arguments of `ptsa response`.
#[derive(Args, Debug, Clone)]
pub struct ResponseArgs {
    /// Counter record: CSV `time_s,pulses,ticks` with that header, one line per gate (start
    /// in s, data pulses, clock ticks); gates of equal length, times increasing, at least 4
    /// gates; `#` lines are comments.
    #[arg(long, value_name = "FILE")]
    pub counts: PathBuf,
    /// Frequency of the input sine, Hz (more than 0, below the Nyquist frequency of the
    /// record: half its gate rate).
    #[arg(long = "sine-hz", alias = "freq-hz", value_name = "HZ", value_parser = positive_hz)]
    pub freq_hz: f64,
    /// Amplitude of the input sine along IA, cm/s² (more than 0).
    #[arg(long = "sine-cm-s2", alias = "amplitude-cm-s2", value_name = "CM_S2",
          value_parser = input_amplitude_cm_s2)]
    pub amplitude_cm_s2: f64,
    /// Phase of the input sine at time_s = 0, degrees: the input is
    /// A·sin(2πF·time_s + phase).
    #[arg(long, default_value_t = 0.0, value_name = "DEG", value_parser = finite)]
    pub input_phase_deg: f64,
    /// The row's label (default: the frequency and the record's file name).
    #[arg(long, value_name = "TEXT", value_parser = label)]
    pub label: Option<String>,
    /// Print exactly one JSON object: the row's columns, the fit (its gates and residual
    /// RMS, cm/s²), the loop's predicted gain and phase, the warnings. Every key:
    /// docs/reference/json.md.
    #[arg(long)]
    pub json: bool,
    /// Write the row even when the fit makes no physical sense: a gain above 2 (no loop the
    /// simulator accepts gets there) or an uncertainty larger than the gain (no sine at
    /// --sine-hz); refused without it, naming the likely slip (an amplitude in g, another
    /// frequency).
    #[arg(long)]
    pub force: bool,
    #[command(flatten)]
    pub out: OutArgs,
}

/// A record to reduce: read, its sampling checked against the frequency, the plot's folder
/// checked.
pub struct Request {
    /// The record's name for messages (the path given).
    name: String,
    gates: Vec<Gate>,
    /// Gates per second.
    rate_hz: f64,
    /// From the first gate's start to the last's, s.
    span_s: f64,
    freq_hz: f64,
    amplitude_cm_s2: f64,
    input_phase_deg: f64,
    /// The row's label (`--label`, or the frequency and the record's file name).
    label: String,
    /// The plot's file stem, `STEM-response`.
    stem: String,
    json: bool,
    force: bool,
    /// The plot's folder.
    out: PathBuf,
}

impl ResponseArgs {
    /// The files the command reads, by their flags: no output may replace them.
    pub fn inputs(&self) -> [(&'static str, Option<&Path>); 1] {
        [("--counts", Some(&self.counts))]
    }

    /// The request: the plot's folder checked (its files never an input), the record read
    /// and checked, `--sine-hz` below the record's Nyquist frequency, the label resolved.
    ///
    /// # Errors
    /// `--out` is refused; the record cannot be read or is not a counter record; the
    /// gates are too far apart for the frequency.
    pub fn request(self) -> Result<Request> {
        let stem = format!(
            "{}-response",
            self.counts
                .file_stem()
                .map_or_else(|| "record".into(), |s| s.to_string_lossy())
        );
        paths::folder_with(
            "--out",
            &self.out.out,
            &[format!("{stem}.png"), format!("{stem}.svg")],
        )?;
        let name = self.counts.display().to_string();
        let gates = response::read(&self.counts)?;
        let n = gates.len();
        let rate_hz = response::gate_rate_hz(&gates);
        let span_s = gates[n - 1].time_s - gates[0].time_s;
        if self.freq_hz >= rate_hz / 2.0 {
            bail!(
                "--sine-hz {}: expected a frequency below {} Hz, the Nyquist frequency of {name} ({n} gates in {} s, {} gates/s): gates that far apart cannot show a sine of {} Hz",
                num(self.freq_hz),
                sig(rate_hz / 2.0, 8),
                sig(span_s, 8),
                sig(rate_hz, 8),
                num(self.freq_hz)
            );
        }
        let file = self
            .counts
            .file_name()
            .map_or_else(|| name.clone(), |f| f.to_string_lossy().into_owned());
        let label = self
            .label
            .unwrap_or_else(|| format!("{} Hz ({file})", self.freq_hz));
        Ok(Request {
            name,
            gates,
            rate_hz,
            span_s,
            freq_hz: self.freq_hz,
            amplitude_cm_s2: self.amplitude_cm_s2,
            input_phase_deg: self.input_phase_deg,
            label,
            stem,
            json: self.json,
            force: self.force,
            out: self.out.out,
        })
    }
}

/// Fit, check the fit (a fit that makes no physical sense refused without `--force`),
/// write the plot, print the fit's summary on stderr and the row on `out`.
///
/// # Errors
/// The fit fails or finds no component at the frequency; the check refuses it; a write
/// fails.
pub fn run(ctx: &Ctx, req: &Request, out: &mut dyn Write) -> Result<()> {
    let instr = &ctx.instr;
    let (name, gates, n) = (&req.name, &req.gates, req.gates.len());
    #[allow(clippy::cast_precision_loss)]
    let gate_s = gates[0].ticks as f64 / instr.clock_hz;
    // Every warning, for stderr and for the JSON's "warnings".
    let mut warnings = record_warnings(ctx, req, gate_s);
    let fit = response::fit(
        gates,
        req.freq_hz,
        req.amplitude_cm_s2,
        req.input_phase_deg,
        instr.sf_cm_s2,
        instr.clock_hz,
    )
    .with_context(|| format!("{name} at --sine-hz {}", num(req.freq_hz)))?;
    if !(fit.gain > 0.0 && fit.gain.is_finite()) {
        bail!(
            "{name}: no component at --sine-hz {} in the record (gain {}); expected the response to a sine at that frequency",
            num(req.freq_hz),
            sig(fit.gain, 4)
        );
    }
    let checked = response::check(
        &response::CheckContext {
            name,
            gates,
            instrument: instr,
            ticks_per_cycle: u32::from(Design::for_instrument(instr).config().ticks_per_cycle),
        },
        &fit,
    );
    if let Some(r) = &checked.refusal {
        if !req.force {
            for w in &warnings {
                eprintln!("warning: {w}");
            }
            bail!("{r}; --force writes the row anyway");
        }
        warnings.push(format!("{r} (written because of --force)"));
    }
    warnings.extend(checked.warnings.iter().cloned());
    let fig = figure(
        &req.stem,
        &req.label,
        gates,
        &fit,
        instr.sf_cm_s2,
        checked.expected.rms_cm_s2,
    );
    let files = write_figure(&req.out, &fig)?;
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    eprintln!(
        "response: {name}: {n} gates of {} s ({} gates/s), {} Hz at {} cm/s^2: gain {:.5} ± {:.5}, phase {:.3} ± {:.3} deg (output lagging: negative), mean {:.3} cm/s^2, residual RMS {:.3} cm/s^2 (counting leaves {:.3}){}",
        sig(gate_s, 8),
        sig(req.rate_hz, 8),
        num(req.freq_hz),
        num(req.amplitude_cm_s2),
        fit.gain,
        fit.sigma_gain,
        fit.phase_deg,
        fit.sigma_phase_deg,
        fit.mean_cm_s2,
        fit.rms_cm_s2,
        checked.expected.rms_cm_s2,
        checked.prediction.map_or(String::new(), |p| format!(
            "; the instrument file's loop predicts gain {:.5}, phase {:.3} deg",
            p.gain, p.phase_deg
        ))
    );
    eprintln!(
        "wrote {} into {}",
        count(files.len() as u64, "file"),
        paths::shown(&req.out)
    );
    print_row(
        out,
        fit.row(&req.label),
        &fit,
        &checked,
        &warnings,
        req.json,
    )
}

/// The warnings about the record and the input before the fit: overlapping gates (a
/// counter clock other than the file's), a record shorter than a period, an input beyond
/// the loop's full scale.
fn record_warnings(ctx: &Ctx, req: &Request, gate_s: f64) -> Vec<String> {
    let (instr, name, gates) = (&ctx.instr, &req.name, &req.gates);
    let mut warnings = Vec::new();
    let spacing = gates
        .windows(2)
        .map(|w| w[1].time_s - w[0].time_s)
        .fold(f64::INFINITY, f64::min);
    if spacing < gate_s * (1.0 - 1e-6) {
        warnings.push(format!(
            "{name}: gates start {} s apart but each is {} s long ({} ticks at the instrument file's clock_hz {} Hz): they overlap; if the counter's clock is not {} Hz, the gain's correction for the gate averaging is wrong",
            sig(spacing, 8),
            sig(gate_s, 8),
            gates[0].ticks,
            num(instr.clock_hz),
            num(instr.clock_hz)
        ));
    }
    if req.span_s * req.freq_hz < 1.0 {
        warnings.push(format!(
            "{name} spans {} s, less than one period of {} Hz: the fit extrapolates the sine and its uncertainties are large",
            sig(req.span_s, 8),
            num(req.freq_hz)
        ));
    }
    if req.amplitude_cm_s2.abs() > instr.sf_cm_s2 {
        warnings.push(format!(
            "--sine-cm-s2 = {} cm/s^2 is beyond the loop's full scale of ±{} cm/s^2: the loop saturates and the results are not measurements of the input",
            num(req.amplitude_cm_s2),
            num(instr.sf_cm_s2)
        ));
    }
    warnings
}

/// Print `row` as case-frame CSV with its header, or with `json` as one JSON object with
/// `fit`'s summary, the check's figures and the `warnings`.
fn print_row(
    out: &mut dyn Write,
    row: Condition,
    fit: &ResponseFit,
    checked: &FitCheck,
    warnings: &[String],
    json: bool,
) -> Result<()> {
    if json {
        let v = ResponseJson {
            label: row.label.clone(),
            kind: row.kind.name().to_string(),
            freq_hz: row.freq_hz,
            lin_ia_cm_s2: row.lin_cm_s2[0],
            measured_gain: row.measured_gain,
            measured_phase_deg: row.measured_phase_deg,
            sigma_gain: row.sigma_gain,
            sigma_phase_deg: row.sigma_phase_deg,
            gates: fit.gates,
            gate_s: fit.gate_s,
            mean_cm_s2: fit.mean_cm_s2,
            rms_cm_s2: fit.rms_cm_s2,
            expected_rms_cm_s2: checked.expected.rms_cm_s2,
            predicted_gain: checked.prediction.map(|p| p.gain),
            predicted_phase_deg: checked.prediction.map(|p| p.phase_deg),
            warnings: warnings.to_vec(),
        };
        // Through a `Value`: its keys in the order of their names.
        let v = serde_json::to_value(v)?;
        writeln!(out, "{v}")?;
    } else {
        write!(out, "{}", response::rows_csv(&[row]))?;
    }
    Ok(())
}

/// The plot of `ptsa response`: the gates' indicated accelerations with the fitted sine
/// (its gate means) over them, and the residuals below, their RMS against the
/// `expected_rms` counting leaves (cm/s²).
fn figure(
    stem: &str,
    label: &str,
    gates: &[Gate],
    fit: &ResponseFit,
    sf_cm_s2: f64,
    expected_rms: f64,
) -> Figure {
    let half = fit.gate_s / 2.0;
    let mids: Vec<(f64, f64)> = gates
        .iter()
        .map(|g| (g.time_s + half, g.indicated_cm_s2(sf_cm_s2)))
        .collect();
    let resid: Vec<(f64, f64)> = gates
        .iter()
        .zip(&mids)
        .map(|(g, &(t, y))| (t, y - fit.gate_mean_cm_s2(g.time_s)))
        .collect();
    // The fitted gate mean as a curve: 48 points a period, at most 100 000 in all (the
    // plot thins a long line to its envelope).
    let (t0, t1) = (mids[0].0, mids[mids.len() - 1].0);
    let per_period = 48.0 * fit.freq_hz * (t1 - t0);
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let k = per_period.clamp(200.0, 100_000.0) as usize;
    #[allow(clippy::cast_precision_loss)]
    let curve: Vec<(f64, f64)> = (0..=k)
        .map(|i| {
            let t = t0 + (t1 - t0) * i as f64 / k as f64;
            (t, fit.gate_mean_cm_s2(t - half))
        })
        .collect();
    Figure {
        stem: stem.to_string(),
        panels: vec![
            Plot {
                title: format!(
                    "{label}: gain {:.4} ± {:.4}, phase {:.2} ± {:.2}°",
                    fit.gain, fit.sigma_gain, fit.phase_deg, fit.sigma_phase_deg
                ),
                x_label: "time (gate midpoint), s".into(),
                y_label: "indicated acceleration, cm/s²".into(),
                series: vec![
                    Series::crosses("gates: SF·(2P/T − 1)", mids),
                    Series::line("fitted sine, averaged over each gate", curve),
                ],
                ..Plot::default()
            },
            Plot {
                title: format!(
                    "residuals: gate minus fitted gate mean, RMS {:.3} cm/s² (counting leaves {:.3})",
                    fit.rms_cm_s2, expected_rms
                ),
                x_label: "time (gate midpoint), s".into(),
                y_label: "residual, cm/s²".into(),
                series: vec![Series::crosses("residual", resid)],
                zero_line: true,
                ..Plot::default()
            },
        ],
    }
}
