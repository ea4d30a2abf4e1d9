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

use crate::model::condition::{Condition, RowKind};

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
    /// The fit as a case-frame row, `kind = response` (`docs/reference/case-frame-format.md`): the input
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

/// Response rows as case-frame CSV of the [`ROW_COLUMNS`] (the case frame's own writer,
/// [`crate::model::caseframe::to_csv_columns`]): the header, then one line per row,
/// numbers in Rust's shortest round-trip form (the case-frame reader gives them back bit for
/// bit), a label quoted when the reader would otherwise split, trim or skip it.
#[must_use]
pub fn rows_csv(rows: &[Condition]) -> String {
    crate::model::caseframe::to_csv_columns(rows, &[], &ROW_COLUMNS)
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
    let f = crate::stats::lsq(&y, &[&ones, &s, &c])
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

/// What a right sine fit leaves in the gates of a pulse-rebalance counter record: the
/// counting's own scatter.
///
/// A gate of `T` ticks counts whole pulses, each worth `2·SF/T` cm/s² of indication. What
/// the loop holds between pulses at a gate's boundary (the charge-balance carry: the
/// quantizer's sub-tick carry and what the pendulum, the torquer and the compensator hold)
/// is not lost but counted in the next gate, so a gate's count is off by the carry at its
/// end minus the carry at its start. The simulated loop's carry at a boundary spreads over
/// about ±1 pulse (a 1 s gate indicates the input within two pulses, `docs/method/host-sim.md`);
/// taken as uniform over that width, its variance is [`CARRY_VAR`] = 1/3 pulse², and the
/// two ends together give `2/3` pulse². On top of that, a gate that does not start at the
/// beginning of a limit cycle cuts a cycle: a cycle of `N` ticks with duty `d` (the
/// fraction of positive ticks, `(1 + a/SF)/2`) is positive for its first `d·N` ticks, so
/// the count after `j` of its ticks is ahead of the average by `w(j) = min(j, d·N) − d·j`
/// pulses (a triangle up to `N·d·(1 − d)`: 16 pulses at `N = 64`, `d = 1/2`). The gate is
/// off by `w` at its end minus `w` at its start; with the gates' phase in the cycle
/// unknown, this ripple's variance is the mean of that difference squared over the start
/// phase, the end `T mod N` ticks further on, each end's duty from the fitted output
/// there. The ripple is largest for gates of half-cycles (`T mod N = N/2`) and nil for
/// whole cycles at constant input; for a given phase it can be up to `√3` times its mean
/// over phases (a triangle's peak over its RMS), or near 0.
///
/// Checked against records counted from the simulated closed loop
/// (`tests/cli_response.rs`, `the_expected_scatter_is_that_of_the_simulated_loop`): the
/// residual RMS over this estimate lies between 0.05 and 1.72.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scatter {
    /// One pulse of a gate, `2·SF/T`, cm/s².
    pub pulse_cm_s2: f64,
    /// The limit-cycle ripple's RMS contribution to a gate, pulses.
    pub ripple_pulses: f64,
    /// The RMS a right fit leaves, `pulse·√(2·CARRY_VAR + ripple²)`, cm/s².
    pub rms_cm_s2: f64,
}

/// The variance of the charge the loop holds at a gate boundary, pulse² (uniform over
/// ±1 pulse: the most the simulated loop shows, with slow inputs; fast ones leave less,
/// down to a uniform spread over one pulse, 1/12).
pub const CARRY_VAR: f64 = 1.0 / 3.0;
/// The gates [`expected_scatter`] averages the ripple over, at most.
const SCATTER_GATES: usize = 2000;
/// The start phases in a cycle it averages over, at most.
const SCATTER_PHASES: u32 = 64;

/// The scatter a right sine fit `fit` should leave in `gates` ([`Scatter`]): `sf_cm_s2`
/// the nominal SF, `ticks_per_cycle` the loop's `N`.
#[must_use]
pub fn expected_scatter(
    gates: &[Gate],
    fit: &ResponseFit,
    sf_cm_s2: f64,
    ticks_per_cycle: u32,
) -> Scatter {
    let ticks = gates.first().map_or(1, |g| g.ticks);
    #[allow(clippy::cast_precision_loss)]
    let pulse_cm_s2 = 2.0 * sf_cm_s2 / ticks as f64;
    let n_cyc = f64::from(ticks_per_cycle.max(1));
    #[allow(clippy::cast_precision_loss)]
    let delta = (ticks % u64::from(ticks_per_cycle.max(1))) as f64;
    let duty = |t: f64| (0.5 * (1.0 + fit.output_cm_s2(t) / sf_cm_s2)).clamp(0.0, 1.0);
    // Pulses ahead of the average after `j` ticks of a cycle of duty `d`.
    let w = |j: f64, d: f64| j.min(d * n_cyc) - d * j;
    let phases = ticks_per_cycle.clamp(1, SCATTER_PHASES);
    let stride = gates.len().div_ceil(SCATTER_GATES).max(1);
    let (mut sum, mut count) = (0.0, 0.0);
    for g in gates.iter().step_by(stride) {
        let (d0, d1) = (duty(g.time_s), duty(g.time_s + fit.gate_s));
        for m in 0..phases {
            let j0 = (f64::from(m) + 0.5) * n_cyc / f64::from(phases);
            let j1 = (j0 + delta) % n_cyc;
            sum += (w(j1, d1) - w(j0, d0)).powi(2);
            count += 1.0;
        }
    }
    let ripple2 = if count > 0.0 { sum / count } else { 0.0 };
    Scatter {
        pulse_cm_s2,
        ripple_pulses: ripple2.sqrt(),
        rms_cm_s2: pulse_cm_s2 * (2.0 * CARRY_VAR + ripple2).sqrt(),
    }
}

/// The loop's predicted response at a frequency, for the check of a fit: the instrument
/// file's linear loop model `L/(1 + L)` (`design::loop_gain`, the compensator designed for
/// the file) at its nominal parameters, and the range it spans over the corners of the
/// file's tolerance box (every corner up to 14 toleranced parameters, else 1024 seeded
/// random ones).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prediction {
    /// Nominal gain.
    pub gain: f64,
    /// Nominal phase, degrees.
    pub phase_deg: f64,
    /// Smallest and largest gain over the tolerance box.
    pub gain_range: [f64; 2],
    /// Smallest and largest phase over the tolerance box, degrees (about the nominal one).
    pub phase_range_deg: [f64; 2],
}

/// How far beyond the tolerance box's range a fit may lie before it is "far" from the
/// prediction: the linear model's own shortfall against the simulated loop (up to 2.5 dB
/// and 20° at 400 Hz, `docs/method/host-sim.md`), rounded up: a factor in gain, degrees in phase.
pub const MODEL_MARGIN: (f64, f64) = (1.413, 25.0);

/// The gain above which a fit is refused without `--force`: no loop the simulator accepts
/// (phase margin at least 30°, so `|H| ≤ 1/(2 sin 15°) = 1.93` at crossover) gets there.
pub const MAX_GAIN: f64 = 2.0;

/// `x` wrapped to (−180, 180], degrees.
fn wrap_deg(x: f64) -> f64 {
    let r = x.rem_euclid(360.0);
    if r > 180.0 { r - 360.0 } else { r }
}

/// The loop's predicted response at `f_hz` for `instr` ([`Prediction`]); `None` if the
/// simulator refuses the file's loop (`design::check_loop`).
#[must_use]
pub fn predict(instr: &crate::Instrument, f_hz: f64) -> Option<Prediction> {
    use rand::{Rng as _, SeedableRng as _};
    let config = crate::model::design::check_loop(instr).ok()?.config;
    let h = |i: &crate::Instrument| {
        let l = crate::model::design::loop_gain(i, &config, f_hz);
        l / (1.0 + l)
    };
    let h0 = h(instr);
    let (gain, phase_deg) = (h0.norm(), h0.arg().to_degrees());
    let tol = &instr.tolerances;
    let corners: Vec<u64> = if tol.len() <= 14 {
        (0..1u64 << tol.len()).collect()
    } else {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        (0..1024).map(|_| rng.random::<u64>()).collect()
    };
    let mut p = Prediction {
        gain,
        phase_deg,
        gain_range: [gain, gain],
        phase_range_deg: [phase_deg, phase_deg],
    };
    for bits in corners {
        let mut c = instr.clone();
        for (k, t) in tol.iter().enumerate() {
            // Every key is the file's own, so `set` knows it.
            let _ = c.set(t.key, if bits >> k & 1 == 1 { t.hi } else { t.lo });
        }
        let hc = h(&c);
        let dp = wrap_deg(hc.arg().to_degrees() - phase_deg);
        p.gain_range = [
            p.gain_range[0].min(hc.norm()),
            p.gain_range[1].max(hc.norm()),
        ];
        p.phase_range_deg = [
            p.phase_range_deg[0].min(phase_deg + dp),
            p.phase_range_deg[1].max(phase_deg + dp),
        ];
    }
    Some(p)
}

/// The residual sum of squares of `y` (cm/s²) about the best `c + s·sin ωt + q·cos ωt` at
/// the times `t`, and whether the fit is determined.
fn rss_at(t: &[f64], y: &[f64], f_hz: f64) -> Option<f64> {
    let w = std::f64::consts::TAU * f_hz;
    let mut sums = SineSums::default();
    for (&tk, &yk) in t.iter().zip(y) {
        let (s, c) = (w * tk).sin_cos();
        sums.add(yk, s, c);
    }
    sums.rss()
}

/// The sums of a sine fit at one frequency, `y` already centred.
#[derive(Clone, Copy, Debug, Default)]
struct SineSums {
    n: f64,
    yy: f64,
    s: f64,
    c: f64,
    ss: f64,
    cc: f64,
    sc: f64,
    ys: f64,
    yc: f64,
}

impl SineSums {
    fn add(&mut self, y: f64, s: f64, c: f64) {
        self.n += 1.0;
        self.yy += y * y;
        self.s += s;
        self.c += c;
        self.ss += s * s;
        self.cc += c * c;
        self.sc += s * c;
        self.ys += y * s;
        self.yc += y * c;
    }

    /// What the sine leaves of `Σ y²` (the mean is already out), if it is determined.
    fn rss(&self) -> Option<f64> {
        let n = self.n.max(1.0);
        let mss = self.ss - self.s * self.s / n;
        let mcc = self.cc - self.c * self.c / n;
        let msc = self.sc - self.s * self.c / n;
        let det = mss * mcc - msc * msc;
        if !(det > 1e-9 * mss * mcc && det > 0.0) {
            return None;
        }
        let bs = (mcc * self.ys - msc * self.yc) / det;
        let bc = (mss * self.yc - msc * self.ys) / det;
        Some((self.yy - bs * self.ys - bc * self.yc).max(0.0))
    }
}

/// The frequency whose sine fits the record best, and its residual RMS (as
/// [`ResponseFit::rms_cm_s2`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BestFrequency {
    /// The frequency, Hz.
    pub freq_hz: f64,
    /// The residual RMS of a sine fitted there, cm/s².
    pub rms_cm_s2: f64,
    /// The resolution the record gives it, Hz: a tenth of one over the record's span.
    pub resolution_hz: f64,
}

/// Most `gates × frequencies` [`best_frequency`] evaluates on its grid (the whole band for
/// records up to about 5 000 gates).
const SCAN_BUDGET: f64 = 5e7;

/// The frequency whose sine fits `gates` best ([`BestFrequency`]): a grid of a quarter of
/// one over the record's span from one period in the record to 0.98 of its Nyquist
/// frequency (for long records, where that grid would pass `SCAN_BUDGET`, the part of it
/// centred on `around_hz` that fits the budget), then a golden-section refinement about the
/// best grid point. `sf_cm_s2` turns counts into accelerations, `gate_s` is the gates'
/// length. `None` for a record too short to scan.
#[must_use]
pub fn best_frequency(
    gates: &[Gate],
    sf_cm_s2: f64,
    gate_s: f64,
    around_hz: f64,
) -> Option<BestFrequency> {
    let n = gates.len();
    if n < MIN_GATES {
        return None;
    }
    let t: Vec<f64> = gates.iter().map(|g| g.time_s + gate_s / 2.0).collect();
    let y0: Vec<f64> = gates.iter().map(|g| g.indicated_cm_s2(sf_cm_s2)).collect();
    #[allow(clippy::cast_precision_loss)]
    let mean = y0.iter().sum::<f64>() / n as f64;
    let y: Vec<f64> = y0.iter().map(|v| v - mean).collect();
    let span = t[n - 1] - t[0] + gate_s;
    let step = 0.25 / span;
    let (mut lo, mut hi) = (1.0 / span, 0.98 * gate_rate_hz(gates) / 2.0);
    #[allow(clippy::cast_precision_loss)]
    let most = (SCAN_BUDGET / n as f64).max(64.0);
    if (hi - lo) / step > most {
        let half = most * step / 2.0;
        let centre = around_hz.clamp(lo + half, (hi - half).max(lo + half));
        (lo, hi) = (centre - half, centre + half);
    }
    if hi <= lo {
        return None;
    }
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let points = ((hi - lo) / step).ceil() as usize + 1;
    // sin and cos of ω t_k for every gate, advanced by a rotation of Δω t_k per grid step
    // and recomputed exactly every 256 steps.
    let (mut s, mut c): (Vec<f64>, Vec<f64>) = (vec![0.0; n], vec![0.0; n]);
    let (rs, rc): (Vec<f64>, Vec<f64>) = t
        .iter()
        .map(|&tk| (std::f64::consts::TAU * step * tk).sin_cos())
        .unzip();
    let mut best: Option<(f64, f64)> = None;
    for g in 0..points {
        #[allow(clippy::cast_precision_loss)]
        let f = lo + step * g as f64;
        if g % 256 == 0 {
            let w = std::f64::consts::TAU * f;
            for k in 0..n {
                (s[k], c[k]) = (w * t[k]).sin_cos();
            }
        }
        let mut sums = SineSums::default();
        for k in 0..n {
            sums.add(y[k], s[k], c[k]);
            let (sk, ck) = (s[k], c[k]);
            s[k] = sk * rc[k] + ck * rs[k];
            c[k] = ck * rc[k] - sk * rs[k];
        }
        if let Some(r) = sums.rss()
            && best.is_none_or(|(_, b)| r < b)
        {
            best = Some((f, r));
        }
    }
    let (f0, _) = best?;
    // Golden section on [f0 − step, f0 + step].
    let rss = |f: f64| rss_at(&t, &y, f).unwrap_or(f64::INFINITY);
    let phi = 0.5 * (5f64.sqrt() - 1.0);
    let (mut a, mut b) = ((f0 - step).max(lo * 0.5), f0 + step);
    let (mut x1, mut x2) = (b - phi * (b - a), a + phi * (b - a));
    let (mut r1, mut r2) = (rss(x1), rss(x2));
    for _ in 0..40 {
        if r1 < r2 {
            (b, x2, r2) = (x2, x1, r1);
            x1 = b - phi * (b - a);
            r1 = rss(x1);
        } else {
            (a, x1, r1) = (x1, x2, r2);
            x2 = a + phi * (b - a);
            r2 = rss(x2);
        }
    }
    let (freq_hz, r) = if r1 < r2 { (x1, r1) } else { (x2, r2) };
    #[allow(clippy::cast_precision_loss)]
    Some(BestFrequency {
        freq_hz,
        rms_cm_s2: (r / n as f64).sqrt(),
        resolution_hz: 0.1 / span,
    })
}

/// A record's residual RMS more than this many times the [`Scatter`] a right fit leaves is
/// "far" from it (the simulated loop's right records stay below `√3`, the ripple's largest
/// at the worst start phase).
pub const SCATTER_LIMIT: f64 = 3.0;

/// What the check of a fit found (`ptsa response`).
#[derive(Clone, Debug, PartialEq)]
pub struct FitCheck {
    /// The scatter a right fit leaves.
    pub expected: Scatter,
    /// The loop's prediction at the frequency, if the simulator accepts the file's loop.
    pub prediction: Option<Prediction>,
    /// The frequency that fits the record best, if the record could be scanned.
    pub best: Option<BestFrequency>,
    /// Warnings, one line each, without the `warning: ` prefix.
    pub warnings: Vec<String>,
    /// Why the row makes no physical sense (refused without `--force`), one line.
    pub refusal: Option<String>,
}

/// What [`check`] needs besides the fit.
#[derive(Clone, Copy, Debug)]
pub struct CheckContext<'a> {
    /// The record's name for messages.
    pub name: &'a str,
    /// The record.
    pub gates: &'a [Gate],
    /// The instrument file (SF, local gravity, the loop).
    pub instrument: &'a crate::Instrument,
    /// Ticks per limit cycle of the file's loop.
    pub ticks_per_cycle: u32,
}

/// The hint for a gain `ratio` times the one expected (`band`: the expected range): the
/// unit `--sine-cm-s2` was probably typed in, as `if A was in UNIT, --sine-cm-s2
/// X`, when reading it so puts the gain inside `band` (the nearest to `nominal` if several
/// do).
fn unit_hint(amp: f64, gain: f64, nominal: f64, band: [f64; 2], g_cm_s2: f64) -> Option<String> {
    use crate::text::significant;
    [
        ("g", g_cm_s2),
        ("ft/s²", 30.48),
        ("m/s²", 100.0),
        ("mm/s²", 0.1),
    ]
    .into_iter()
    .filter(|&(_, f)| (band[0]..=band[1]).contains(&(gain / f)))
    .min_by(|a, b| {
        let d = |f: f64| (gain / f / nominal).ln().abs();
        d(a.1).total_cmp(&d(b.1))
    })
    .map(|(unit, f)| {
        format!(
            "if {} was in {unit}, --sine-cm-s2 {}",
            significant(amp, 12),
            significant(amp * f, 8)
        )
    })
}

/// Check `fit` of the record in `cx`: its residual scatter against the [`Scatter`] a right
/// fit leaves (and, when it is far above, the frequency that fits best), its gain and phase
/// against the loop's [`Prediction`] (far: outside the tolerance box's range by more than
/// [`MODEL_MARGIN`] and four standard errors), and refused ([`FitCheck::refusal`]) a gain
/// above [`MAX_GAIN`] (or 1.41 times the box's largest gain, where that is more) or with
/// an uncertainty larger than itself. Each message names the likely slip: a frequency that
/// fits far better, an amplitude in another unit, the input's phase.
#[must_use]
pub fn check(cx: &CheckContext<'_>, fit: &ResponseFit) -> FitCheck {
    let f = fit.freq_hz;
    let instr = cx.instrument;
    let expected = expected_scatter(cx.gates, fit, instr.sf_cm_s2, cx.ticks_per_cycle);
    let prediction = predict(instr, f);
    let best = best_frequency(cx.gates, instr.sf_cm_s2, fit.gate_s, f);
    let w = Words::new(cx, fit, prediction, best);
    let refusal = w.refusal();
    let mut warnings = Vec::new();
    let ratio = fit.rms_cm_s2 / expected.rms_cm_s2;
    // (A refusal that already names the frequency that fits says it all.)
    if ratio > SCATTER_LIMIT && !(refusal.is_some() && w.better.is_some()) {
        warnings.push(w.scattered(&expected, ratio));
    }
    // Against the loop only when the fit is the record's sine (not refused, and no other
    // frequency fits far better).
    if let Some(p) = prediction
        && refusal.is_none()
        && w.better.is_none()
    {
        warnings.extend(w.far_from_the_loop(&p));
    }
    FitCheck {
        expected,
        prediction,
        best,
        warnings,
        refusal,
    }
}

/// What [`check`]'s messages are made of: the fit, the frequency that fits far better
/// (if any) and its hint, the loop's prediction with its band, and the phrases the
/// messages share.
struct Words<'a> {
    cx: &'a CheckContext<'a>,
    fit: &'a ResponseFit,
    prediction: Option<Prediction>,
    /// A clearly different frequency that fits far better: half the residual RMS or less.
    better: Option<BestFrequency>,
    freq_hint: Option<String>,
    nominal: f64,
    band: [f64; 2],
    predicted_text: String,
    gain_pm: String,
}

impl<'a> Words<'a> {
    fn new(
        cx: &'a CheckContext<'a>,
        fit: &'a ResponseFit,
        prediction: Option<Prediction>,
        best: Option<BestFrequency>,
    ) -> Self {
        use crate::text::significant as sig;
        let f = fit.freq_hz;
        let better = best.filter(|b| {
            2.0 * b.rms_cm_s2 < fit.rms_cm_s2 && (b.freq_hz - f).abs() > b.resolution_hz
        });
        let freq_hint = better.map(|b| {
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let d = (-b.resolution_hz.log10().floor()).clamp(0.0, 9.0) as usize;
            format!(
                "the record's sine is near {:.d$} Hz (residual RMS {} cm/s² there against {} at {} Hz): --sine-hz {:.d$}",
                b.freq_hz,
                sig(b.rms_cm_s2, 3),
                sig(fit.rms_cm_s2, 3),
                sig(f, 8),
                b.freq_hz
            )
        });
        let (nominal, band) = prediction.map_or((1.0, [0.5, 2.0]), |p| {
            (
                p.gain,
                [
                    p.gain_range[0] / MODEL_MARGIN.0,
                    p.gain_range[1] * MODEL_MARGIN.0,
                ],
            )
        });
        let predicted_text = prediction.map_or_else(
            || "the instrument file's loop is refused by the simulator, so there is no prediction".to_string(),
            |p| {
                format!(
                    "the instrument file's loop predicts {}, {} to {} over its tolerance box, its linear model good to a factor {}",
                    sig(p.gain, 4),
                    sig(p.gain_range[0], 4),
                    sig(p.gain_range[1], 4),
                    sig(MODEL_MARGIN.0, 3)
                )
            },
        );
        Self {
            cx,
            fit,
            prediction,
            better,
            freq_hint,
            nominal,
            band,
            predicted_text,
            gain_pm: format!("gain {} ± {}", sig(fit.gain, 4), sig(fit.sigma_gain, 2)),
        }
    }

    /// The likely slip of a gain far from the loop's: an amplitude in another unit, or
    /// the amplitude that would give the loop's gain.
    fn amp_hint(&self) -> String {
        use crate::text::significant as sig;
        let fit = self.fit;
        unit_hint(
            fit.amplitude_cm_s2,
            fit.gain,
            self.nominal,
            self.band,
            self.cx.instrument.g_cm_s2,
        )
        .unwrap_or_else(|| {
            format!(
                "--sine-cm-s2 {} would give the loop's gain {}; check --sine-cm-s2 (cm/s²) and the instrument file's sf_cm_s2",
                sig(fit.amplitude_cm_s2 * fit.gain / self.nominal, 4),
                sig(self.nominal, 4)
            )
        })
    }

    /// Refused: a gain above what a loop the simulator accepts can give, or with an
    /// uncertainty larger than itself.
    fn refusal(&self) -> Option<String> {
        use crate::text::significant as sig;
        let (name, fit, f) = (self.cx.name, self.fit, self.fit.freq_hz);
        let gain_pm = &self.gain_pm;
        let limit = self
            .prediction
            .map_or(MAX_GAIN, |p| MAX_GAIN.max(p.gain_range[1] * MODEL_MARGIN.0));
        if fit.gain > limit {
            Some(format!(
                "{name}: {gain_pm} at --sine-hz {} is above {}, more than a loop the simulator accepts can give ({}); {}",
                sig(f, 8),
                sig(limit, 4),
                self.predicted_text,
                self.freq_hint.clone().unwrap_or_else(|| self.amp_hint())
            ))
        } else if fit.sigma_gain > fit.gain {
            Some(format!(
                "{name}: {gain_pm} at --sine-hz {}: the uncertainty is larger than the gain, so the record shows no sine at {} Hz; {}",
                sig(f, 8),
                sig(f, 8),
                self.freq_hint.clone().unwrap_or_else(|| {
                    "check --sine-hz and that the input reached the instrument (no other frequency fits better)".to_string()
                })
            ))
        } else {
            None
        }
    }

    /// The gates scatter about the sine `ratio` times what counting leaves.
    fn scattered(&self, expected: &Scatter, ratio: f64) -> String {
        use crate::text::significant as sig;
        let fit = self.fit;
        format!(
            "{}: the gates scatter about the fitted sine with RMS {} cm/s², {} times the {} cm/s² that counting leaves (pulses of {} cm/s² in gates of {} ticks, the charge carried between gates and the limit-cycle ripple): the record is not a clean sine at {} Hz; {}",
            self.cx.name,
            sig(fit.rms_cm_s2, 3),
            sig(ratio, 2),
            sig(expected.rms_cm_s2, 3),
            sig(expected.pulse_cm_s2, 4),
            self.cx.gates.first().map_or(0, |g| g.ticks),
            sig(fit.freq_hz, 8),
            self.freq_hint.clone().unwrap_or_else(|| {
                "no other frequency fits far better: a noisy or distorted input, or gates not counted on the instrument's clock".to_string()
            })
        )
    }

    /// The gain and the phase against the loop's prediction `p`: a warning for each far
    /// from it.
    fn far_from_the_loop(&self, p: &Prediction) -> Vec<String> {
        use crate::text::significant as sig;
        let (name, fit, f) = (self.cx.name, self.fit, self.fit.freq_hz);
        let mut warnings = Vec::new();
        let s4 = 4.0 * fit.sigma_gain;
        if fit.gain < self.band[0] - s4 || fit.gain > self.band[1] + s4 {
            warnings.push(format!(
                "{name}: {} at {} Hz is far from the loop: {}; {}",
                self.gain_pm,
                sig(f, 8),
                self.predicted_text,
                self.amp_hint()
            ));
        }
        let dp = wrap_deg(fit.phase_deg - p.phase_deg);
        let lo = p.phase_range_deg[0] - p.phase_deg - MODEL_MARGIN.1 - 4.0 * fit.sigma_phase_deg;
        let hi = p.phase_range_deg[1] - p.phase_deg + MODEL_MARGIN.1 + 4.0 * fit.sigma_phase_deg;
        if fit.sigma_phase_deg < 30.0 && !(lo..=hi).contains(&dp) {
            warnings.push(format!(
                "{name}: phase {} ± {} deg at {} Hz is far from the loop's {} deg ({} to {} over the instrument file's tolerance box, its linear model good to {} deg): check --input-phase-deg (the input's phase at time_s = 0, now {}) and that time_s is on the input's time base",
                sig(fit.phase_deg, 4),
                sig(fit.sigma_phase_deg, 2),
                sig(f, 8),
                sig(p.phase_deg, 3),
                sig(p.phase_range_deg[0], 3),
                sig(p.phase_range_deg[1], 3),
                MODEL_MARGIN.1,
                sig(fit.input_phase_deg, 8)
            ));
        }
        warnings
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` gates of 320 ticks (5 ms at 64 kHz) counted as a charge-balancing loop counts
    /// (the pulses are the running total's whole part, so what one gate leaves over goes
    /// into the next) from the mean output `mean(t0)`, cm/s², of the gate starting at `t0`.
    fn counted(n: u32, sf: f64, mean: impl Fn(f64) -> f64) -> Vec<Gate> {
        let tau = 320.0 / 64000.0;
        let (mut total, mut counted) = (0.0f64, 0.0f64);
        (0..n)
            .map(|k| {
                let t0 = f64::from(k) * tau;
                total += f64::midpoint(mean(t0) / sf, 1.0) * 320.0;
                let p = total.floor() - counted;
                counted += p;
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                Gate {
                    time_s: t0,
                    pulses: p as u64,
                    ticks: 320,
                }
            })
            .collect()
    }

    /// A record made from a known sine, counted as a charge-balancing loop does (the pulses
    /// are the running total's whole part, so what one gate leaves over goes into the next):
    /// the fit gives back the gain and phase within their uncertainties.
    #[test]
    fn a_known_sine_comes_back() {
        let (sf, clock, f, amp) = (21121.1, 64000.0, 20.0, 2000.0);
        let (g_true, ph_true) = (0.8, -30.0_f64);
        let tau = 320.0 / clock; // 5 ms gates
        let w = std::f64::consts::TAU * f;
        // Mean of the output over the gate.
        let x = w * tau / 2.0;
        let gates = counted(400, sf, |t0| {
            g_true * amp * (x.sin() / x) * (w * (t0 + tau / 2.0) + ph_true.to_radians()).sin()
        });
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
        let back = crate::model::caseframe::parse("r.csv", &text).unwrap();
        assert_eq!(back, rows);
        assert_eq!(back[0].sigma_phase_deg, None);
    }

    /// The scan finds the record's frequency to within its resolution; the prediction is
    /// the linear loop's, inside its tolerance-box range; the unit hint reads a gain 980 or
    /// 0.1 times too large as an amplitude in g or mm/s², and nothing else.
    #[test]
    fn scan_prediction_and_unit_hints() {
        let (sf, clock) = (21121.1, 64000.0);
        let (f, tau) = (20.0, 0.005);
        let w = std::f64::consts::TAU * f;
        let gates = counted(300, sf, |t0| 1500.0 * (w * (t0 + tau / 2.0)).sin());
        let b = best_frequency(&gates, sf, tau, 23.0).unwrap();
        assert!((b.freq_hz - f).abs() < b.resolution_hz, "{b:?}");
        let at_f = fit(&gates, f, 1500.0, 0.0, sf, clock).unwrap();
        assert!(
            (b.rms_cm_s2 - at_f.rms_cm_s2).abs() < 0.01 * at_f.rms_cm_s2,
            "{b:?} {at_f:?}"
        );
        let instr = crate::Instrument::kearfott_2401();
        let p = predict(&instr, 20.0).unwrap();
        assert!(
            (p.gain - 1.1957).abs() < 1e-3 && (p.phase_deg + 13.10).abs() < 0.01,
            "{p:?}"
        );
        assert!(
            p.gain_range[0] < p.gain && p.gain < p.gain_range[1],
            "{p:?}"
        );
        assert!(
            p.phase_range_deg[0] < p.phase_deg && p.phase_deg < p.phase_range_deg[1],
            "{p:?}"
        );
        let band = [0.8, 1.9];
        assert_eq!(
            unit_hint(2.0, 1.2 * 980.4, 1.2, band, 980.4).as_deref(),
            Some("if 2 was in g, --sine-cm-s2 1960.8")
        );
        assert_eq!(
            unit_hint(20_000.0, 0.12, 1.2, band, 980.4).as_deref(),
            Some("if 20000 was in mm/s², --sine-cm-s2 2000")
        );
        assert_eq!(unit_hint(2000.0, 5.0, 1.2, band, 980.4), None);
        assert!(
            (wrap_deg(190.0) + 170.0).abs() < 1e-12 && (wrap_deg(-180.0) - 180.0).abs() < 1e-12
        );
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
