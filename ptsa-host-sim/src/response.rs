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
//! over the input's is the gain; its phase minus the input's is the phase. Their standard
//! errors come from the fit's covariance with the residual scatter (the pulse quantization
//! and the noise).

use std::path::Path;

use anyhow::{Context, Result, bail};

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
/// The file cannot be read, the header is not `time_s,pulses,ticks`, a cell is not what its
/// column expects, `pulses > ticks`, `ticks` is 0, times do not increase, or fewer than four
/// gates: each error names the file, the line and the column.
pub fn read(path: &Path) -> Result<Vec<Gate>> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).with_context(|| format!("{name}: cannot read"))?;
    parse(&name, &text)
}

/// Parse a record's text; `name` names it in errors.
///
/// # Errors
/// As [`read`].
pub fn parse(name: &str, text: &str) -> Result<Vec<Gate>> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut gates: Vec<Gate> = Vec::new();
    let mut header = false;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let t = raw.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let cells: Vec<&str> = t.split(',').map(str::trim).collect();
        if !header {
            if cells != ["time_s", "pulses", "ticks"] {
                bail!(
                    "{name}:{line}: header `{t}`; expected `time_s,pulses,ticks` (gate start in s, data pulses, clock ticks)"
                );
            }
            header = true;
            continue;
        }
        if cells.len() != 3 {
            bail!(
                "{name}:{line}: {} cells, expected 3 (time_s,pulses,ticks)",
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
            cells[k].parse::<u64>().with_context(|| {
                format!(
                    "{name}:{line}: column {} (`{col}`) holds `{}`; expected a whole number, 0 or more",
                    k + 1,
                    cells[k]
                )
            })
        };
        let pulses = whole(1, "pulses")?;
        let ticks = whole(2, "ticks")?;
        if ticks == 0 || pulses > ticks {
            bail!(
                "{name}:{line}: pulses {pulses}, ticks {ticks}; expected 0 <= pulses <= ticks and ticks > 0"
            );
        }
        if let Some(prev) = gates.last()
            && time_s <= prev.time_s
        {
            bail!(
                "{name}:{line}: column 1 (`time_s`) holds {time_s}, not after the previous gate's {}; expected increasing times",
                prev.time_s
            );
        }
        gates.push(Gate {
            time_s,
            pulses,
            ticks,
        });
    }
    if !header {
        bail!("{name}: no header line; expected `time_s,pulses,ticks`");
    }
    if gates.len() < 4 {
        bail!(
            "{name}: {} gate(s); expected at least 4 to fit a sine and its uncertainty",
            gates.len()
        );
    }
    if gates.iter().any(|g| g.ticks != gates[0].ticks) {
        bail!("{name}: the gates have different lengths; expected equal gates (ticks)");
    }
    Ok(gates)
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
    #[allow(clippy::cast_precision_loss)]
    let y: Vec<f64> = gates
        .iter()
        .map(|g| sf_cm_s2 * (2.0 * g.pulses as f64 / g.ticks as f64 - 1.0))
        .collect();
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
                total += (mean / sf + 1.0) / 2.0 * 320.0;
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
    }
}
