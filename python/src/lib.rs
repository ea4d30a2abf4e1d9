//! The native half of the Python package `ptsa`: each function here calls the
//! `ptsa-host-sim` library exactly as the `ptsa` command line does and hands back its
//! JSON text (the same serde types the command prints) or numpy arrays.
//!
//! The Python half (`python/ptsa/__init__.py`) turns the JSON into dicts and the inputs
//! (paths, pandas frames, dicts of arrays) into what these functions take. No algorithm
//! lives in either half: a result that differs from the command line's is a bug here.
#![allow(
    clippy::needless_pass_by_value,
    reason = "pyo3 hands each argument of a Python function over as an owned value"
)]

use std::path::PathBuf;

mod hidden;
mod interrupt;

use interrupt::interruptible;

use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::create_exception;
use pyo3::prelude::*;

use ptsa_host_sim::discovery::{self, Options};
use ptsa_host_sim::model::instrument::ReadingUnit;
use ptsa_host_sim::noise::allan::{Settings, Taus};
use ptsa_host_sim::noise::comparison::Comparison;
use ptsa_host_sim::noise::json::{IdentificationJson, NoiseJson, TermsIdentificationJson};
use ptsa_host_sim::noise::{self, Analysis, identify, readings};
use ptsa_host_sim::session::{Session, gate_ticks, simulator};
use ptsa_host_sim::simulation::sim::SimOptions;
use ptsa_host_sim::simulation::yield_study::{self, Plan, Spec};

// Named `ptsa.PtsaError` (the package re-exports it), so that it pickles: an error raised in
// another process or a Ray task is the same class.
create_exception!(
    ptsa,
    PtsaError,
    pyo3::exceptions::PyValueError,
    "A refusal of ptsa's library: the command line's error message (file, line, column and what was expected, where a file is at fault)."
);

/// An error of the library as the exception the command line's message would be.
fn refused(e: anyhow::Error) -> PyErr {
    PtsaError::new_err(format!("{e:#}"))
}

/// `instrument=` as Python gives it.
#[derive(FromPyObject)]
enum InstrumentIn {
    /// `(name, text)`: an instrument file's name in messages and its text, for a campaign's
    /// task on a machine that does not have the file.
    Text((String, String)),
    /// A file's path or a shipped name.
    Path(PathBuf),
}

/// The instrument file given (a shipped name, a file, or a file's name and text; `None`: the
/// Kearfott 2401).
fn session(instrument: Option<&InstrumentIn>) -> PyResult<Session> {
    match instrument {
        Some(InstrumentIn::Text((name, text))) => Session::of_text(name, text),
        Some(InstrumentIn::Path(p)) => Session::load(Some(p)),
        None => Session::load(None),
    }
    .map_err(refused)
}

/// `warmup_s` refused unless it is a settling of 0 s or more.
fn check_warmup(warmup_s: Option<f64>) -> PyResult<()> {
    match warmup_s {
        Some(w) if !(w >= 0.0 && w.is_finite()) => Err(PtsaError::new_err(format!(
            "warmup_s {w}: expected a settling of 0 s or more"
        ))),
        _ => Ok(()),
    }
}

/// The simulation options of `seed` and `warmup_s` (the command line's defaults where
/// `None`) for the checked loop of `s`.
fn sim_options(s: &Session, seed: Option<u64>, warmup_s: Option<f64>) -> PyResult<SimOptions> {
    let d = SimOptions::default();
    check_warmup(warmup_s)?;
    Ok(SimOptions {
        seed: seed.unwrap_or(d.seed),
        warmup_s: warmup_s.unwrap_or(d.warmup_s),
        config: s.config().map_err(refused)?,
        ..d
    })
}

/// The command line's defaults, by option name (so that the Python docstrings need not
/// copy them).
#[pyfunction]
fn defaults() -> (f64, u64, f64) {
    let d = SimOptions::default();
    (d.warmup_s, d.seed, readings::SPACING_TOL)
}

/// `ptsa static --json`: one gate at each acceleration along IA, as one batch of the batch
/// engine (its lanes bit for bit the single loop's), the GIL released while it runs.
#[pyfunction]
#[pyo3(signature = (accels_cm_s2, seconds, warmup_s, instrument, seed, with_bias))]
fn static_json(
    py: Python<'_>,
    accels_cm_s2: Vec<f64>,
    seconds: f64,
    warmup_s: Option<f64>,
    instrument: Option<InstrumentIn>,
    seed: Option<u64>,
    with_bias: bool,
) -> PyResult<String> {
    let s = session(instrument.as_ref())?;
    let opts = sim_options(&s, seed, warmup_s)?;
    let mut instr = s.instr.clone();
    if !with_bias {
        instr.bias_cm_s2 = 0.0;
    }
    let ticks = gate_ticks("seconds", seconds, &instr, &opts).map_err(refused)?;
    if let Some(a) = accels_cm_s2.iter().find(|a| !a.is_finite()) {
        return Err(PtsaError::new_err(format!(
            "accels_cm_s2: {a}; expected finite accelerations, cm/s²"
        )));
    }
    let runs = interruptible(py, "ptsa.static", || {
        ptsa_host_sim::simulation::batch::run_static(&instr, &accels_cm_s2, ticks, &opts)
    })?;
    serde_json::to_string(&runs).map_err(|e| refused(e.into()))
}

/// The three columns of a counter record, as numpy arrays.
type RecordArrays<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<u64>>,
    Bound<'py, PyArray1<u64>>,
);

/// `ptsa noise --simulate --output FILE`'s record: the loop at rest, gates of `gate_s`
/// back to back for `seconds` after the settling, as arrays `time_s, pulses, ticks`.
#[pyfunction]
#[pyo3(signature = (seconds, gate_s, warmup_s, instrument, seed))]
fn record(
    py: Python<'_>,
    seconds: f64,
    gate_s: Option<f64>,
    warmup_s: Option<f64>,
    instrument: Option<InstrumentIn>,
    seed: Option<u64>,
) -> PyResult<RecordArrays<'_>> {
    let s = session(instrument.as_ref())?;
    let opts = sim_options(&s, seed, warmup_s)?;
    let gate_s = gate_s.unwrap_or(noise::DEFAULT_GATE_S);
    let ticks = gate_ticks("gate_s", gate_s, &s.instr, &opts).map_err(refused)?;
    let gates = noise::simulated_gates(("seconds", "gate_s"), seconds, ticks, s.instr.clock_hz)
        .map_err(refused)?;
    let g = interruptible(py, "ptsa.record", || {
        noise::simulate_record(&s.instr, &opts, 0.0, ticks, gates)
    })?;
    Ok((
        PyArray1::from_iter(py, g.iter().map(|g| g.time_s)),
        PyArray1::from_iter(py, g.iter().map(|g| g.pulses)),
        PyArray1::from_iter(py, g.iter().map(|g| g.ticks)),
    ))
}

/// The columns as the CSV text the command line reads (Rust's shortest round-trip form of
/// each number, so that the file's reader and its checks see exactly these values; its
/// line numbers are the rows' plus one, the header being line 1).
#[pyfunction]
fn columns_csv(names: Vec<String>, columns: Vec<PyReadonlyArray1<'_, f64>>) -> PyResult<String> {
    use std::fmt::Write as _;
    let columns: Vec<Vec<f64>> = columns.iter().map(|c| c.as_array().to_vec()).collect();
    let n = columns.first().map_or(0, Vec::len);
    if let Some((k, c)) = columns.iter().enumerate().find(|(_, c)| c.len() != n) {
        return Err(PtsaError::new_err(format!(
            "{}: {} values, and {}: {n}; expected columns of equal length",
            names.get(k).map_or("?", String::as_str),
            c.len(),
            names.first().map_or("?", String::as_str)
        )));
    }
    let mut s = String::with_capacity(n * 24 * columns.len() + 32);
    s.push_str(&names.join(","));
    s.push('\n');
    for i in 0..n {
        for (k, c) in columns.iter().enumerate() {
            let sep = if k + 1 == columns.len() { '\n' } else { ',' };
            let _ = write!(s, "{}{sep}", c[i]);
        }
    }
    Ok(s)
}

/// `confidence` refused unless it is a level between 0 and 1.
fn check_confidence(confidence: f64) -> PyResult<()> {
    if confidence > 0.0 && confidence < 1.0 {
        Ok(())
    } else {
        Err(PtsaError::new_err(format!(
            "confidence {confidence}: expected a level more than 0 and less than 1 (0.95 for 95 %)"
        )))
    }
}

/// The analysis settings of `ptsa noise`: `taus` a name or times in s, the second
/// confidence level, the Hadamard deviation computed.
fn settings(taus: &TausIn, confidence: f64, tau0_s: f64, n: usize) -> PyResult<Settings> {
    check_confidence(confidence)?;
    let taus = match taus {
        TausIn::Named(name) => Taus::named(name).ok_or_else(|| {
            PtsaError::new_err(format!(
                "taus `{name}`: expected octave, decade, all, or averaging times in s"
            ))
        })?,
        TausIn::Seconds(ts) => Taus::of_seconds("taus", ts, tau0_s, n).map_err(refused)?,
    };
    Ok(Settings {
        taus,
        confidence,
        hadamard: true,
    })
}

/// `taus=` as Python gives it: a name or a sequence of times in s.
#[derive(FromPyObject)]
enum TausIn {
    /// `"octave"`, `"decade"` or `"all"`.
    Named(String),
    /// Averaging times, s.
    Seconds(Vec<f64>),
}

/// `ptsa noise --readings FILE --json` (or `--counts FILE` when `counts`; with `--compare`
/// and `--identify` when asked): the record's text `text` (`name` in messages) read by the
/// command line's reader and analysed as the command analyses it.
#[pyfunction]
#[pyo3(signature = (name, text, counts, unit, instrument, spacing_tol, taus, confidence, compare, identify, seed, warmup_s))]
#[allow(
    clippy::too_many_arguments,
    reason = "the Python function's keyword arguments"
)]
fn noise_json(
    py: Python<'_>,
    name: &str,
    text: &str,
    counts: bool,
    unit: Option<&str>,
    instrument: Option<InstrumentIn>,
    spacing_tol: Option<f64>,
    taus: TausIn,
    confidence: f64,
    compare: bool,
    identify: bool,
    seed: Option<u64>,
    warmup_s: Option<f64>,
) -> PyResult<String> {
    let against = Against {
        compare,
        identify,
        seed,
        warmup_s,
    };
    against.check(counts, &taus)?;
    if counts && unit.is_some() {
        return Err(PtsaError::new_err(
            "unit applies to a record of readings (time_s, reading) only; expected it with one, or not at all",
        ));
    }
    check_warmup(warmup_s)?;
    let s = session(instrument.as_ref())?;
    let v = if counts {
        counts_json(py, &s, name, text, &taus, confidence, &against)?
    } else {
        let r = readings_of(&s, name, text, unit, spacing_tol)?;
        let settings = settings(&taus, confidence, r.tau0_s, r.y.len())?;
        let a = interruptible(py, "ptsa.noise", || Analysis::of_readings(&r, &settings))?;
        let warnings = noise::analysis_warnings(name, &a);
        let id = if identify {
            // Only the seed: the replicas are drawn from the terms, not simulated.
            let seed = seed.unwrap_or(SimOptions::default().seed);
            Some(
                interruptible(py, "ptsa.noise", || {
                    noise::identify_readings(&r, &a, seed, &mut |_| {})
                })?
                .map_err(refused)?,
            )
        } else {
            None
        };
        let mut v = a.json(name, &warnings);
        v.terms_identification = id.as_ref().map(TermsIdentificationJson::new);
        v
    };
    serde_json::to_value(v)
        .map(|v| v.to_string())
        .map_err(|e| refused(e.into()))
}

/// What `noise` sets a record against: the simulated loop (`--compare`), the candidates
/// beyond it (`--identify`), and the simulations' seed and settling.
struct Against {
    compare: bool,
    identify: bool,
    seed: Option<u64>,
    warmup_s: Option<f64>,
}

impl Against {
    /// The refusals of the command line's `check_flags`, in the Python names.
    fn check(&self, counts: bool, taus: &TausIn) -> PyResult<()> {
        if self.compare && !counts {
            return Err(PtsaError::new_err(
                "compare applies to a counter record (time_s, pulses, ticks) only; expected it with one, or not at all",
            ));
        }
        if (self.compare || self.identify) && !matches!(taus, TausIn::Named(t) if t == "octave") {
            return Err(PtsaError::new_err(format!(
                "taus: {} compares the record with simulated ones at octave averaging times; expected taus=\"octave\" (the default) with it",
                if self.identify { "identify" } else { "compare" }
            )));
        }
        Ok(())
    }
}

/// `noise --counts FILE [--compare] [--identify] --json`'s object, the warnings in the
/// command's order.
fn counts_json(
    py: Python<'_>,
    s: &Session,
    name: &str,
    text: &str,
    taus: &TausIn,
    confidence: f64,
    against: &Against,
) -> PyResult<NoiseJson> {
    s.require_loop().map_err(refused)?;
    // The simulations' options before the record (the command checks --identify's so).
    let opts = if against.compare || against.identify {
        sim_options(s, against.seed, against.warmup_s)?
    } else {
        SimOptions::default()
    };
    let rec = noise::parse_record(name, text, s.instr.clock_hz).map_err(refused)?;
    let settings = settings(taus, confidence, rec.tau0_s, rec.gates.len())?;
    let (sf, clock) = (s.instr.sf_cm_s2, s.instr.clock_hz);
    let a = interruptible(py, "ptsa.noise", || {
        Analysis::of_with(&rec, sf, clock, &settings)
    })?;
    let mut warnings = noise::analysis_warnings(name, &a);
    let comparison = if against.compare {
        let c = interruptible(py, "ptsa.noise", || {
            Comparison::simulate(&s.instr, &opts, &rec, &a)
        })?
        .map_err(refused)?;
        warnings.extend(c.warning(name));
        Some(c)
    } else {
        None
    };
    let id = if against.identify {
        let id = interruptible(py, "ptsa.noise", || {
            identify::identify(&s.instr, &opts, &rec, &a, &mut |_, _| {})
        })?;
        warnings.extend(noise::identification_warnings(name, &id));
        Some(id)
    } else {
        None
    };
    let mut v = a.json(name, &warnings);
    v.comparison = comparison.as_ref().map(Comparison::json);
    v.identification = id.as_ref().map(IdentificationJson::new);
    Ok(v)
}

/// The options of `noise_json` checked without a record, as a campaign does once before
/// its tasks: the instrument file read, the unit and the taus named, the confidence, the
/// settling, and with `compare` a loop to simulate (`identify` needs one for a counter
/// record only). A record's own refusals (its kind, its rows, taus it is too short for) are
/// its task's.
#[pyfunction]
#[pyo3(signature = (instrument, unit, taus, confidence, compare, identify, warmup_s))]
fn noise_check(
    instrument: Option<InstrumentIn>,
    unit: Option<&str>,
    taus: TausIn,
    confidence: f64,
    compare: bool,
    identify: bool,
    warmup_s: Option<f64>,
) -> PyResult<()> {
    let against = Against {
        compare,
        identify,
        seed: None,
        warmup_s,
    };
    against.check(true, &taus)?;
    check_warmup(warmup_s)?;
    check_confidence(confidence)?;
    if matches!(taus, TausIn::Named(_)) {
        // A name checked as the analysis checks it; the record's length does not matter.
        settings(&taus, confidence, 1.0, 1 << 20)?;
    }
    let s = session(instrument.as_ref())?;
    if unit.is_some() {
        reading_unit(&s, unit)?;
    }
    if compare {
        s.require_loop().map_err(refused)?;
        sim_options(&s, None, warmup_s)?;
    }
    Ok(())
}

/// The readings' unit by name (None: the instrument file's, else cm/s²).
fn reading_unit(s: &Session, unit: Option<&str>) -> PyResult<ReadingUnit> {
    match unit {
        Some(u) => ReadingUnit::parse(u).ok_or_else(|| {
            PtsaError::new_err(format!(
                "unit `{u}`: expected one of {}",
                ReadingUnit::names()
            ))
        }),
        None => Ok(s
            .instr
            .reading_scale
            .as_ref()
            .map_or(ReadingUnit::CmPerS2, |r| r.unit)),
    }
}

/// A record of readings as `noise --readings` reads it: the unit by name (None: the
/// instrument file's, else cm/s²), the spacing's tolerance a fraction (None: the default).
fn readings_of(
    s: &Session,
    name: &str,
    text: &str,
    unit: Option<&str>,
    spacing_tol: Option<f64>,
) -> PyResult<readings::Readings> {
    let unit = reading_unit(s, unit)?;
    let tol = spacing_tol.unwrap_or(readings::SPACING_TOL);
    if !(0.0..=0.5).contains(&tol) {
        return Err(PtsaError::new_err(format!(
            "spacing_tol {tol}: expected a fraction of the spacing from 0 to 0.5 (0.01 for 1 %)"
        )));
    }
    readings::parse(name, text, unit, &s.instr, tol).map_err(refused)
}

/// `ptsa discover --data FILE --json --no-plots`: the case frame at `path` analysed, the
/// JSON object the command prints.
#[pyfunction]
#[pyo3(signature = (path, instrument, analytic, seed, sigma_cm_s2, keep_outliers))]
fn discover_json(
    py: Python<'_>,
    path: PathBuf,
    instrument: Option<InstrumentIn>,
    analytic: bool,
    seed: Option<u64>,
    sigma_cm_s2: Option<f64>,
    keep_outliers: bool,
) -> PyResult<String> {
    let s = session(instrument.as_ref())?;
    let seed = seed.unwrap_or(SimOptions::default().seed);
    let config = s.model_config(seed).map_err(refused)?;
    let sim = simulator(&s.instr, config, analytic, seed);
    let options = Options {
        default_sigma_cm_s2: sigma_cm_s2,
        seed,
        keep_outliers,
        ..Options::for_instrument(&s.instr)
    };
    let (_, d) = interruptible(py, "ptsa.discover", || {
        discovery::analyse(&path, &*sim, &options)
    })?
    .map_err(refused)?;
    serde_json::to_string(&d.json).map_err(|e| refused(e.into()))
}

/// A specification's limits as Python passes them: |SF error| ppm, |bias| cm/s²,
/// linearity ppm of full scale, noise cm/s², phase margin degrees, gain margin dB.
type SpecLimits = (
    Option<f64>,
    Option<f64>,
    Option<f64>,
    Option<f64>,
    Option<f64>,
    Option<f64>,
);

/// `ptsa correct --data FILE --json` on a single-axis record: the calibration (a `discover
/// --json` file, or the instrument file's own model when only `instrument` is given)
/// applied to every row.
#[pyfunction]
#[pyo3(signature = (data, calibration, instrument, sigma, local_gravity_cm_s2))]
fn correct_json(
    data: PathBuf,
    calibration: Option<PathBuf>,
    instrument: Option<InstrumentIn>,
    sigma: Option<f64>,
    local_gravity_cm_s2: Option<f64>,
) -> PyResult<String> {
    use ptsa_host_sim::discovery::correct_record::{choose_calibration, correct_record};
    if let Some(v) = sigma
        && !(v > 0.0 && v.is_finite())
    {
        return Err(PtsaError::new_err(format!(
            "sigma {v}: expected a noise in cm/s², more than 0"
        )));
    }
    let mut s = session(instrument.as_ref())?;
    if let Some(g) = local_gravity_cm_s2 {
        if !(970.0..=990.0).contains(&g) {
            return Err(PtsaError::new_err(format!(
                "local_gravity_cm_s2 {g}: expected a local gravity from 970 to 990 cm/s²"
            )));
        }
        s.set_local_gravity(g).map_err(refused)?;
    }
    if ptsa_host_sim::triad::frame::is_triad_file(&data) {
        return correct_triad_json(&s, &data, calibration.as_deref(), sigma);
    }
    let (cal, name, flag) = choose_calibration(
        calibration.as_deref(),
        &data,
        &s.instr,
        &s.name,
        instrument.is_some(),
    )
    .map_err(refused)?;
    let rec = correct_record(&data, &s.instr, &cal, &flag, sigma).map_err(refused)?;
    Ok(rec
        .json(&data.display().to_string(), &name, &s.name)
        .to_string())
}

/// `ptsa correct --data TRIAD --calibration FILE --json`: the triad record `data` corrected
/// with the triad's calibration in the file `calibration`.
fn correct_triad_json(
    s: &Session,
    data: &std::path::Path,
    calibration: Option<&std::path::Path>,
    sigma: Option<f64>,
) -> PyResult<String> {
    use ptsa_host_sim::triad::correct_record::{correct_triad, read_calibration};
    let Some(p) = calibration else {
        return Err(PtsaError::new_err(format!(
            "{} is a triad record (three axes' readings per row); expected calibration: a triad's calibration file (`ptsa discover --data TRIAD.csv --write-instrument FILE`) or what ptsa.discover returned for the triad",
            data.display()
        )));
    };
    let cal =
        read_calibration(p, &format!("--calibration {}", p.display()), data).map_err(refused)?;
    let t = correct_triad(data, cal, s.instr.sf_cm_s2, sigma).map_err(refused)?;
    Ok(t.json(
        &data.display().to_string(),
        &p.display().to_string(),
        &s.name,
    )
    .to_string())
}

/// The plan of `ptsa monte-carlo --yield N` from its options (the command line's default
/// where `None`), checked as the command checks it; as JSON.
#[pyfunction]
#[pyo3(signature = (instruments, instrument, seed, warmup_s, fractions, gate_s, gates, spec))]
#[allow(
    clippy::too_many_arguments,
    reason = "the Python function's keyword arguments"
)]
fn yield_plan_json(
    instruments: u64,
    instrument: Option<InstrumentIn>,
    seed: Option<u64>,
    warmup_s: Option<f64>,
    fractions: Option<Vec<f64>>,
    gate_s: Option<f64>,
    gates: Option<u64>,
    spec: SpecLimits,
) -> PyResult<String> {
    let s = session(instrument.as_ref())?;
    let opts = sim_options(&s, seed, warmup_s)?;
    yield_study::check_box(&s.instr, &s.name).map_err(PtsaError::new_err)?;
    let gate_s = gate_s.unwrap_or(yield_study::DEFAULT_GATE_S);
    let ticks = gate_ticks("gate_s", gate_s, &s.instr, &opts).map_err(refused)?;
    let d = Spec::default();
    #[allow(clippy::cast_precision_loss)]
    let plan = Plan {
        instruments,
        seed: opts.seed,
        fractions_of_full_scale: fractions
            .unwrap_or_else(|| yield_study::DEFAULT_FRACTIONS.to_vec()),
        gate_s: ticks as f64 / s.instr.clock_hz,
        gates: gates.unwrap_or(yield_study::DEFAULT_GATES),
        warmup_s: opts.warmup_s,
        spec: Spec {
            sf_error_ppm: spec.0,
            bias_cm_s2: spec.1,
            linearity_ppm_fs: spec.2,
            noise_cm_s2: spec.3,
            phase_margin_deg: spec.4.or(d.phase_margin_deg),
            gain_margin_db: spec.5.or(d.gain_margin_db),
        },
    };
    plan.check().map_err(PtsaError::new_err)?;
    serde_json::to_string(&plan).map_err(|e| refused(e.into()))
}

/// The plan's JSON read back.
fn plan_of(plan_json: &str) -> PyResult<Plan> {
    let plan: Plan =
        serde_json::from_str(plan_json).map_err(|e| PtsaError::new_err(format!("plan: {e}")))?;
    plan.check().map_err(PtsaError::new_err)?;
    Ok(plan)
}

/// Instruments `start .. start + count` of the yield study `plan_json`, as a JSON list:
/// each depends on the plan's seed and its index only, so pieces run anywhere join into
/// the study.
#[pyfunction]
#[pyo3(signature = (plan_json, instrument, start, count))]
fn yield_units_json(
    py: Python<'_>,
    plan_json: &str,
    instrument: Option<InstrumentIn>,
    start: u64,
    count: u64,
) -> PyResult<String> {
    let s = session(instrument.as_ref())?;
    let plan = plan_of(plan_json)?;
    let opts = sim_options(&s, Some(plan.seed), Some(plan.warmup_s))?;
    let end = start
        .checked_add(count)
        .filter(|&e| e <= plan.instruments)
        .ok_or_else(|| {
            PtsaError::new_err(format!(
                "start {start}, count {count}: expected instruments inside the plan's {}",
                plan.instruments
            ))
        })?;
    let units = interruptible(py, "ptsa.yield_units", || {
        yield_study::units(&s.instr, &opts, &plan, start..end)
    })?;
    serde_json::to_string(&units).map_err(|e| refused(e.into()))
}

/// `ptsa monte-carlo --yield N --json` from the study's instruments (the pieces joined, in
/// any order).
#[pyfunction]
#[pyo3(signature = (plan_json, instrument, units_json))]
fn yield_summary_json(
    plan_json: &str,
    instrument: Option<InstrumentIn>,
    units_json: &str,
) -> PyResult<String> {
    let s = session(instrument.as_ref())?;
    let plan = plan_of(plan_json)?;
    let units: Vec<yield_study::Unit> =
        serde_json::from_str(units_json).map_err(|e| PtsaError::new_err(format!("units: {e}")))?;
    yield_study::check_units(&plan, &units).map_err(PtsaError::new_err)?;
    serde_json::to_string(&yield_study::summary(&s.instr, &plan, units))
        .map_err(|e| refused(e.into()))
}

/// The module `ptsa._ptsa`.
#[pymodule]
fn _ptsa(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("PtsaError", m.py().get_type::<PtsaError>())?;
    m.add_function(wrap_pyfunction!(defaults, m)?)?;
    m.add_function(wrap_pyfunction!(static_json, m)?)?;
    m.add_function(wrap_pyfunction!(record, m)?)?;
    m.add_function(wrap_pyfunction!(columns_csv, m)?)?;
    m.add_function(wrap_pyfunction!(noise_json, m)?)?;
    m.add_function(wrap_pyfunction!(noise_check, m)?)?;
    m.add_function(wrap_pyfunction!(discover_json, m)?)?;
    m.add_function(wrap_pyfunction!(correct_json, m)?)?;
    m.add_function(wrap_pyfunction!(yield_plan_json, m)?)?;
    m.add_function(wrap_pyfunction!(yield_units_json, m)?)?;
    m.add_function(wrap_pyfunction!(yield_summary_json, m)?)?;
    m.add_function(wrap_pyfunction!(hidden::hidden_names, m)?)?;
    m.add_function(wrap_pyfunction!(hidden::hidden_check, m)?)?;
    m.add_function(wrap_pyfunction!(hidden::hidden_part, m)?)?;
    m.add_function(wrap_pyfunction!(hidden::hidden_gather, m)?)?;
    m.add_function(wrap_pyfunction!(hidden::hidden_whole, m)?)?;
    Ok(())
}
