//! From a lab record to a frequency-response row (`ptsa response`): a counter record of
//! short gates under a sinusoidal input along IA, reduced by a least-squares sine fit to the
//! response's gain and phase with their uncertainties.
//!
//! The record is a CSV of `time_s,pulses,ticks`, one line per gate: the gate's start time
//! (s), the data pulses `P` counted in it and its clock ticks `T` (as the counter or the
//! firmware's gate reports give them). Each gate indicates `a_k = SF·(2P/T − 1)` (cm/s²),
//! the mean of the output over the gate `[t_k, t_k + T/f_clock]`. The mean of
//! `A·sin(ωt + φ)` over a gate of length `τ` is `A·sinc(ωτ/2)·sin(ω(t + τ/2) + φ)`, so the fit
//! is `a_k = c + s·sin(ω t_mid) + q·cos(ω t_mid)` at the gates' midpoints, and the amplitude is
//! divided by `sinc(ωτ/2)` (the gates must all have the same length). The output's amplitude
//! over the input's is the gain (dimensionless: cm/s² of indicated output per cm/s² of
//! input); its phase minus the input's is the phase, in degrees in (−180, 180], so an output
//! that lags the input has a negative phase (the sign of `arg H` of the loop's `L/(1 + L)`).
//! Their standard errors come from the fit's covariance with the residual scatter (the pulse
//! quantization and the noise).

use std::path::Path;

use anyhow::{Context, Result, bail};

use crate::condition::{Condition, RowKind};

/// One gate of the record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gate {
    /// Start of the gate, s.
    pub time_s: f64,
    /// Data pulses `P`.
    pub pulses: u64,
    /// Clock ticks `T`.
    pub ticks: u64,
}

/// Read a record (`time_s,pulses,ticks` with a header; `#` lines are comments).
///
/// # Errors
/// The file cannot be read, the header is not `time_s,pulses,ticks`, a line has a cell too
/// few or too many, a cell is not what its column expects, `pulses > ticks`, `ticks` is 0,
/// times do not increase, the gates differ in length, or there are fewer than
/// [`MIN_GATES`] gates: each error names the file and the line, and the column at fault
/// where there is one.
pub fn read(path: &Path) -> Result<Vec<Gate>> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).with_context(|| format!("{name}: cannot read"))?;
    match std::str::from_utf8(&bytes) {
        Ok(text) => parse(&name, text),
        Err(e) => {
            // One count per refused file; no bytecount dependency.
            #[allow(clippy::naive_bytecount)]
            let line = 1 + bytes[..e.valid_up_to()]
                .iter()
                .filter(|&&b| b == b'\n')
                .count();
            bail!(
                "{name}:{line}: not UTF-8 text (a bad byte at byte offset {}); expected a CSV of `time_s,pulses,ticks` in UTF-8 (ASCII digits)",
                e.valid_up_to()
            )
        }
    }
}

/// The record's columns, in order.
const COLUMNS: [&str; 3] = ["time_s", "pulses", "ticks"];

/// What is wrong with a header that is not `time_s,pulses,ticks`: the first column that
/// differs, is missing or is extra, by its 1-based number.
fn header_problem(cells: &[&str]) -> String {
    if cells.len() == 1 && (cells[0].contains(';') || cells[0].contains('\t')) {
        return "one column with `;` or tabs in it: this looks like a semicolon- or tab-separated file; the record separates cells with commas".into();
    }
    for (k, want) in COLUMNS.iter().enumerate() {
        match cells.get(k) {
            None => return format!("column {} (`{want}`) is missing", k + 1),
            Some(c) if c != want => {
                return format!("column {} is `{c}`, not `{want}`", k + 1);
            }
            Some(_) => {}
        }
    }
    format!(
        "column {} (`{}`) is one too many",
        COLUMNS.len() + 1,
        cells[COLUMNS.len()]
    )
}

/// Parse a record's text; `name` names it in errors.
///
/// # Errors
/// As [`read`].
pub fn parse(name: &str, text: &str) -> Result<Vec<Gate>> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut gates: Vec<Gate> = Vec::new();
    // The line of the first gate (for the equal-length check) and of the last one.
    let (mut first_line, mut last_line) = (0, 0);
    let mut header = false;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let t = raw.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let cells: Vec<&str> = t.split(',').map(str::trim).collect();
        if !header {
            if cells != COLUMNS {
                bail!(
                    "{name}:{line}: header `{t}`: {}; expected `time_s,pulses,ticks` (gate start in s, data pulses, clock ticks)",
                    header_problem(&cells)
                );
            }
            header = true;
            continue;
        }
        let Gate {
            time_s,
            pulses,
            ticks,
        } = gate(name, line, &cells)?;
        if let Some(prev) = gates.last()
            && time_s <= prev.time_s
        {
            bail!(
                "{name}:{line}: column 1 (`time_s`) holds {time_s}, not after the previous gate's {}; expected increasing times",
                prev.time_s
            );
        }
        if let Some(g0) = gates.first()
            && ticks != g0.ticks
        {
            bail!(
                "{name}:{line}: column 3 (`ticks`) holds {ticks}, not the first gate's {} (line {first_line}); expected gates of equal length",
                g0.ticks
            );
        }
        if gates.is_empty() {
            first_line = line;
        }
        last_line = line;
        gates.push(Gate {
            time_s,
            pulses,
            ticks,
        });
    }
    if !header {
        bail!("{name}: no header line; expected `time_s,pulses,ticks`");
    }
    if gates.len() < MIN_GATES {
        let at = if gates.is_empty() {
            String::new()
        } else {
            format!(":{last_line}")
        };
        bail!(
            "{name}{at}: the record ends after {}; expected at least {MIN_GATES} gates to fit a sine (3 parameters) and its uncertainty",
            if gates.len() == 1 {
                "1 gate".to_string()
            } else {
                format!("{} gates", gates.len())
            }
        );
    }
    Ok(gates)
}

/// One gate from the `cells` of data line `line` of record `name`, checked on its own.
fn gate(name: &str, line: usize, cells: &[&str]) -> Result<Gate> {
    if cells.len() < 3 {
        bail!(
            "{name}:{line}: column {} (`{}`) is missing ({} cells); expected 3 cells, time_s,pulses,ticks",
            cells.len() + 1,
            COLUMNS[cells.len()],
            cells.len()
        );
    }
    if cells.len() > 3 {
        bail!(
            "{name}:{line}: column 4 holds `{}`, one cell too many ({} cells); expected 3 cells, time_s,pulses,ticks",
            cells[3],
            cells.len()
        );
    }
    let time_s = cells[0]
        .parse::<f64>()
        .ok()
        .filter(|x| x.is_finite())
        .with_context(|| {
            format!(
                "{name}:{line}: column 1 (`time_s`) holds `{}`; expected a finite time in s",
                cells[0]
            )
        })?;
    let whole = |k: usize, col: &str| {
        // Without the parser's own words ("invalid digit found in string").
        cells[k].parse::<u64>().ok().with_context(|| {
            format!(
                "{name}:{line}: column {} (`{col}`) holds `{}`; expected a whole number, 0 or more",
                k + 1,
                cells[k]
            )
        })
    };
    let pulses = whole(1, "pulses")?;
    let ticks = whole(2, "ticks")?;
    if ticks == 0 {
        bail!(
            "{name}:{line}: column 3 (`ticks`) holds 0; expected a gate of at least one clock tick"
        );
    }
    if pulses > ticks {
        bail!(
            "{name}:{line}: column 2 (`pulses`) holds {pulses}, more than the gate's {ticks} ticks; expected 0 <= pulses <= ticks (one pulse decision per tick)"
        );
    }
    Ok(Gate {
        time_s,
        pulses,
        ticks,
    })
}

/// The fewest gates [`fit`] takes: three parameters and one degree of freedom for the
/// scatter.
pub const MIN_GATES: usize = 4;

impl Gate {
    /// The gate's indicated acceleration `SF·(2P/T − 1)`, cm/s², with the nominal SF
    /// `sf_cm_s2`.
    #[must_use]
    pub fn indicated_cm_s2(&self, sf_cm_s2: f64) -> f64 {
        #[allow(clippy::cast_precision_loss)]
        let x = sf_cm_s2 * (2.0 * self.pulses as f64 / self.ticks as f64 - 1.0);
        x
    }
}

/// The record's gate rate, Hz: gates per second over the record, `(n − 1)/(t_last −
/// t_first)` (for a record of at least two gates; half of it is the highest frequency the
/// record can show, its Nyquist frequency).
#[must_use]
pub fn gate_rate_hz(gates: &[Gate]) -> f64 {
    match (gates.first(), gates.last()) {
        (Some(a), Some(b)) if gates.len() >= 2 => {
            #[allow(clippy::cast_precision_loss)]
            let n = (gates.len() - 1) as f64;
            n / (b.time_s - a.time_s)
        }
        _ => 0.0,
    }
}

/// The fitted response.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ResponseFit {
    /// Output amplitude over input amplitude.
    pub gain: f64,
    /// Its standard error.
    pub sigma_gain: f64,
    /// Output phase minus input phase, degrees (in (−180, 180]).
    pub phase_deg: f64,
    /// Its standard error, degrees.
    pub sigma_phase_deg: f64,
    /// Mean output over the record, cm/s².
    pub mean_cm_s2: f64,
    /// RMS of the fit's residuals, cm/s².
    pub rms_cm_s2: f64,
    /// Gates fitted.
    pub gates: usize,
    /// The input's frequency, Hz.
    pub freq_hz: f64,
    /// The input's amplitude, cm/s².
    pub amplitude_cm_s2: f64,
    /// The input's phase at `t = 0`, degrees.
    pub input_phase_deg: f64,
    /// The gates' length `T/f_clock`, s.
    pub gate_s: f64,
}

impl ResponseFit {
    /// The fitted output at time `t_s`, cm/s²: `mean + gain·|A|·sin(2πf·t + input phase +
    /// phase)`.
    #[must_use]
    pub fn output_cm_s2(&self, t_s: f64) -> f64 {
        self.mean_cm_s2 + self.amplitude() * self.sine(t_s)
    }

    /// The fitted output's mean over the gate starting at `start_s` (what a gate of the
    /// record should indicate), cm/s².
    #[must_use]
    pub fn gate_mean_cm_s2(&self, start_s: f64) -> f64 {
        let x = std::f64::consts::TAU * self.freq_hz * self.gate_s / 2.0;
        let sinc = if x.abs() < 1e-12 { 1.0 } else { x.sin() / x };
        self.mean_cm_s2 + sinc * self.amplitude() * self.sine(start_s + self.gate_s / 2.0)
    }

    /// The output's amplitude, cm/s².
    fn amplitude(&self) -> f64 {
        self.gain * self.amplitude_cm_s2.abs()
    }

    /// `sin(2πf·t + input phase + phase)`.
    fn sine(&self, t_s: f64) -> f64 {
        (std::f64::consts::TAU * self.freq_hz * t_s
            + (self.input_phase_deg + self.phase_deg).to_radians())
        .sin()
    }
}

/// The case-frame columns of a response row, in the order [`rows_csv`] writes them.
pub const ROW_COLUMNS: [&str; 8] = [
    "label",
    "kind",
    "freq_hz",
    "lin_ia_cm_s2",
    "measured_gain",
    "measured_phase_deg",
    "sigma_gain",
    "sigma_phase_deg",
];

impl ResponseFit {
    /// The fit as a case-frame row, `kind = response` (`docs/case-frame.md`): the input
    /// (`freq_hz`, `lin_ia_cm_s2`), the gain and phase and their uncertainties. An
    /// uncertainty that is not greater than 0 (a record the sine fits exactly) is left out:
    /// the case frame takes only positive ones.
    #[must_use]
    pub fn row(&self, label: &str) -> Condition {
        let positive = |x: f64| (x > 0.0 && x.is_finite()).then_some(x);
        Condition {
            label: label.to_string(),
            kind: RowKind::Response,
            freq_hz: self.freq_hz,
            lin_cm_s2: [self.amplitude_cm_s2, 0.0, 0.0],
            measured_gain: Some(self.gain),
            measured_phase_deg: Some(self.phase_deg),
            sigma_gain: positive(self.sigma_gain),
            sigma_phase_deg: positive(self.sigma_phase_deg),
            ..Condition::default()
        }
    }
}

/// Response rows as case-frame CSV of the [`ROW_COLUMNS`]: the header, then one line per
/// row, numbers in Rust's shortest round-trip form (the case-frame reader gives them back
/// bit for bit), a label quoted when the reader would otherwise split, trim or skip it.
#[must_use]
pub fn rows_csv(rows: &[Condition]) -> String {
    let mut out = ROW_COLUMNS.join(",");
    out.push('\n');
    let num = |x: Option<f64>| match x {
        Some(0.0) => "0".to_string(),
        Some(v) => format!("{v}"),
        None => String::new(),
    };
    for c in rows {
        let label = &c.label;
        let label = if label.contains([',', '"', '\n', '\r'])
            || label.starts_with('#')
            || label.trim() != label
        {
            format!("\"{}\"", label.replace('"', "\"\""))
        } else {
            label.clone()
        };
        let cells = [
            label,
            c.kind.name().to_string(),
            num(Some(c.freq_hz)),
            num(Some(c.lin_cm_s2[0])),
            num(c.measured_gain),
            num(c.measured_phase_deg),
            num(c.sigma_gain),
            num(c.sigma_phase_deg),
        ];
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    out
}

/// Fit the record: input `amp_cm_s2·sin(2π·freq_hz·t + input_phase_deg)` along IA; the
/// instrument's nominal SF (cm/s²) and clock (Hz) turn counts into accelerations and ticks
/// into seconds.
///
/// # Errors
/// A singular fit (the gates do not sample the period), or a gate as long as a period.
pub fn fit(
    gates: &[Gate],
    freq_hz: f64,
    amp_cm_s2: f64,
    input_phase_deg: f64,
    sf_cm_s2: f64,
    clock_hz: f64,
) -> Result<ResponseFit> {
    let w = std::f64::consts::TAU * freq_hz;
    #[allow(clippy::cast_precision_loss)]
    let tau = gates[0].ticks as f64 / clock_hz;
    let x = w * tau / 2.0;
    let sinc = if x.abs() < 1e-12 { 1.0 } else { x.sin() / x };
    if sinc.abs() < 0.05 {
        bail!(
            "gates of {tau} s average out a {freq_hz} Hz response (sinc = {sinc:.3}); expected gates much shorter than the period ({} s)",
            1.0 / freq_hz
        );
    }
    let n = gates.len();
    let y: Vec<f64> = gates.iter().map(|g| g.indicated_cm_s2(sf_cm_s2)).collect();
    let (s, c): (Vec<f64>, Vec<f64>) = gates
        .iter()
        .map(|g| (w * (g.time_s + tau / 2.0)).sin_cos())
        .unzip();
    let ones = vec![1.0; n];
    let f = crate::discovery::stats::lsq(&y, &[&ones, &s, &c])
        .context("the gates do not sample the period well enough to fit a sine")?;
    #[allow(clippy::cast_precision_loss)]
    let s2 = f.chi2 / (n - 3).max(1) as f64;
    let (bs, bc) = (f.beta[1] / sinc, f.beta[2] / sinc);
    let (vss, vcc, vsc) = (
        f.cov[(1, 1)] * s2 / (sinc * sinc),
        f.cov[(2, 2)] * s2 / (sinc * sinc),
        f.cov[(1, 2)] * s2 / (sinc * sinc),
    );
    let amp = bs.hypot(bc);
    // amp·sin(ωt + ψ) = amp·cos ψ·sin ωt + amp·sin ψ·cos ωt.
    let psi = bc.atan2(bs);
    let (cs, sn) = (bs / amp, bc / amp);
    let var_amp = cs * cs * vss + sn * sn * vcc + 2.0 * cs * sn * vsc;
    let var_psi = (sn * sn * vss + cs * cs * vcc - 2.0 * cs * sn * vsc) / (amp * amp);
    let mut phase = (psi.to_degrees() - input_phase_deg) % 360.0;
    if phase > 180.0 {
        phase -= 360.0;
    } else if phase <= -180.0 {
        phase += 360.0;
    }
    #[allow(clippy::cast_precision_loss)]
    Ok(ResponseFit {
        gain: amp / amp_cm_s2.abs(),
        sigma_gain: var_amp.max(0.0).sqrt() / amp_cm_s2.abs(),
        phase_deg: phase,
        sigma_phase_deg: var_psi.max(0.0).sqrt().to_degrees(),
        mean_cm_s2: f.beta[0],
        rms_cm_s2: (f.chi2 / n as f64).sqrt(),
        gates: n,
        freq_hz,
        amplitude_cm_s2: amp_cm_s2,
        input_phase_deg,
        gate_s: tau,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A record made from a known sine, counted as a charge-balancing loop does (the pulses
    /// are the running total's whole part, so what one gate leaves over goes into the next):
    /// the fit gives back the gain and phase within their uncertainties.
    #[test]
    fn a_known_sine_comes_back() {
        let (sf, clock, f, amp) = (21121.1, 64000.0, 20.0, 2000.0);
        let (g_true, ph_true) = (0.8, -30.0_f64);
        let ticks = 320u64; // 5 ms gates
        let tau = 320.0 / clock;
        let w = std::f64::consts::TAU * f;
        let mut total = 0.0f64;
        let mut counted = 0.0f64;
        let gates: Vec<Gate> = (0..400)
            .map(|k| {
                let t0 = f64::from(k) * tau;
                // Mean of the output over the gate; pulses carry the charge over.
                let x = w * tau / 2.0;
                let mean = g_true
                    * amp
                    * (x.sin() / x)
                    * (w * (t0 + tau / 2.0) + ph_true.to_radians()).sin();
                total += f64::midpoint(mean / sf, 1.0) * 320.0;
                let p = total.floor() - counted;
                counted += p;
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                Gate {
                    time_s: t0,
                    pulses: p as u64,
                    ticks,
                }
            })
            .collect();
        let r = fit(&gates, f, amp, 0.0, sf, clock).unwrap();
        assert!((r.gain - g_true).abs() < 4.0 * r.sigma_gain + 1e-9, "{r:?}");
        assert!(
            (r.phase_deg - ph_true).abs() < 4.0 * r.sigma_phase_deg + 1e-9,
            "{r:?}"
        );
        assert!(r.sigma_gain > 0.0 && r.sigma_gain < 0.05, "{r:?}");
        // The fitted gate means leave the fit's residuals.
        let ss: f64 = gates
            .iter()
            .map(|g| (g.indicated_cm_s2(sf) - r.gate_mean_cm_s2(g.time_s)).powi(2))
            .sum();
        #[allow(clippy::cast_precision_loss)]
        let rms = (ss / gates.len() as f64).sqrt();
        assert!(
            (rms - r.rms_cm_s2).abs() < 1e-6 * r.rms_cm_s2,
            "{rms} {r:?}"
        );
        // The output itself has the fitted amplitude and lags by 30 degrees: it crosses zero
        // upwards 30/360 of a period after the input does.
        let lag_s = 30.0 / 360.0 / f;
        assert!(
            (r.output_cm_s2(lag_s) - r.mean_cm_s2).abs() < 0.05 * amp,
            "{r:?}"
        );
        let fitted_lag_s = -r.phase_deg / 360.0 / f;
        let peak = r.output_cm_s2(fitted_lag_s + 0.25 / f) - r.mean_cm_s2;
        assert!((peak - r.gain * amp).abs() < 1e-9 * amp, "{peak} {r:?}");
        assert!((gate_rate_hz(&gates) - 200.0).abs() < 1e-9);
    }

    /// The row's CSV is a case-frame file the reader takes back bit for bit, awkward labels
    /// included, and an uncertainty of 0 is left empty.
    #[test]
    fn rows_read_back_as_case_frame() {
        let fit = ResponseFit {
            gain: 0.1 + 0.2,
            sigma_gain: 1e-3 / 3.0,
            phase_deg: 0.0,
            sigma_phase_deg: 0.0,
            mean_cm_s2: 0.5,
            rms_cm_s2: 1.0,
            gates: 10,
            freq_hz: 20.0 / 3.0,
            amplitude_cm_s2: 2000.0,
            input_phase_deg: 0.0,
            gate_s: 0.005,
        };
        let rows: Vec<Condition> = ["plain", "a, \"b\"", "# not a comment", " padded "]
            .iter()
            .map(|l| fit.row(l))
            .collect();
        let text = rows_csv(&rows);
        assert!(
            text.starts_with(
                "label,kind,freq_hz,lin_ia_cm_s2,measured_gain,measured_phase_deg,sigma_gain,sigma_phase_deg\nplain,response,6.666666666666667,2000,0.30000000000000004,0,0.0003333333333333333,\n"
            ),
            "{text}"
        );
        let back = crate::discovery::caseframe::parse("r.csv", &text).unwrap();
        assert_eq!(back, rows);
        assert_eq!(back[0].sigma_phase_deg, None);
    }

    #[test]
    fn bad_records_name_line_and_column() {
        let e = parse(
            "r.csv",
            "time_s,pulses,ticks\n0,1,10\n0.1,2,10\n0.05,3,10\n1,1,10\n",
        )
        .unwrap_err();
        assert!(format!("{e:#}").contains("r.csv:4: column 1"), "{e:#}");
        let e = parse("r.csv", "time_s,pulses,ticks\n0,x,10\n").unwrap_err();
        assert!(
            format!("{e:#}").contains("r.csv:2: column 2 (`pulses`)"),
            "{e:#}"
        );
        let e = parse("r.csv", "time_s,pulses,ticks\n0,11,10\n").unwrap_err();
        assert!(format!("{e:#}").contains("0 <= pulses <= ticks"), "{e:#}");
        assert!(parse("r.csv", "t,p,q\n").is_err());
        for (text, needle) in [
            (
                "time_s,pulses\n",
                "r.csv:1: header `time_s,pulses`: column 3 (`ticks`) is missing",
            ),
            (
                "time_s,ticks,pulses\n",
                "r.csv:1: header `time_s,ticks,pulses`: column 2 is `ticks`, not `pulses`",
            ),
            ("time_s;pulses;ticks\n", "semicolon- or tab-separated"),
            (
                "# c\ntime_s,pulses,ticks\n0,1\n",
                "r.csv:3: column 3 (`ticks`) is missing (2 cells)",
            ),
            (
                "time_s,pulses,ticks\n0,1,10,4\n",
                "r.csv:2: column 4 holds `4`, one cell too many",
            ),
            (
                "time_s,pulses,ticks\n0,0,0\n",
                "r.csv:2: column 3 (`ticks`) holds 0",
            ),
            (
                "time_s,pulses,ticks\n0,1,10\n1,1,10\n2,1,11\n",
                "r.csv:4: column 3 (`ticks`) holds 11, not the first gate's 10 (line 2)",
            ),
            (
                "time_s,pulses,ticks\n0,1,10\n\n1,1,10\n",
                "r.csv:4: the record ends after 2 gates; expected at least 4",
            ),
            (
                "time_s,pulses,ticks\n",
                "r.csv: the record ends after 0 gates",
            ),
            (
                "time_s,pulses,ticks\n0,,10\n",
                "column 2 (`pulses`) holds ``",
            ),
            (
                "time_s,pulses,ticks\ninf,1,10\n",
                "column 1 (`time_s`) holds `inf`",
            ),
            ("", "r.csv: no header line"),
        ] {
            let e = format!("{:#}", parse("r.csv", text).unwrap_err());
            assert!(e.contains(needle), "{text:?}: {e}");
        }
    }
}
