//! `ptsa correct` on a single-axis record, for the command line and the Python package: the
//! calibration read ([`read_calibration`]), every row of the case frame corrected with its
//! refusals by file and line, the warnings ([`correct_record`]), and the JSON
//! ([`CorrectedRecord::json`]).

use std::path::Path;

use anyhow::{Context as _, Result, bail};

use super::correct as lib;
use crate::Condition;
use crate::model::caseframe;
use crate::model::condition::{RowKind, with_history};
use crate::model::counts;
use crate::model::instrument::Instrument;
use crate::output::command_json::{CorrectJson, CorrectedRow};
use crate::output::count;

/// A single-axis record corrected: every row (with its line, and its correction when it has
/// a reading), the warnings, the local gravity used.
pub struct CorrectedRecord {
    /// Each row of the data, its line, and its correction (`None`: no reading).
    pub rows: Vec<(Condition, usize, Option<lib::Corrected>)>,
    /// What the run warns of.
    pub warnings: Vec<String>,
    /// The local gravity the calibration used, cm/s².
    pub g_cm_s2: f64,
}

/// A `ptsa discover --json` result file read as JSON (`predict --effects`, `correct
/// --calibration`); `what` prefixes the message when it cannot be read (e.g. the flag).
///
/// # Errors
/// The file cannot be read, or is not JSON (`file:line:column` and what was expected).
pub fn read_result_json(p: &Path, what: &str) -> Result<serde_json::Value> {
    let text = std::fs::read_to_string(p).with_context(|| format!("{what}: cannot read"))?;
    serde_json::from_str(&text).map_err(|e| {
        anyhow::anyhow!(
            "{}:{}:{}: not JSON: {e}; expected the output of `ptsa discover --json`",
            p.display(),
            e.line(),
            e.column()
        )
    })
}

/// The calibration at `p` (a single-axis `ptsa discover --json` result) for the record
/// `data`; refusals name it as `--calibration FILE`.
///
/// # Errors
/// It cannot be read; it is a triad's; `correct` cannot apply it.
pub fn read_calibration(p: &Path, data: &Path, instr: &Instrument) -> Result<lib::Calibration> {
    let triad_file = std::fs::read_to_string(p)
        .is_ok_and(|t| t.contains(crate::triad::apply::FORMAT) && !t.trim_start().starts_with('{'));
    let v = if triad_file {
        None
    } else {
        Some(read_result_json(
            p,
            &format!("--calibration {}", p.display()),
        )?)
    };
    let Some(v) = v.filter(|v| v.get("triad").is_none()) else {
        bail!(
            "--calibration {}: a triad's calibration, but {} is a single-axis record; expected a single-axis `ptsa discover --json` result, or a triad record (g_x, ..., measured_x_cm_s2, ... or each axis's counts)",
            p.display(),
            data.display()
        );
    };
    lib::Calibration::from_discover_json(&v, instr)
        .with_context(|| format!("--calibration {}", p.display()))
}

/// The calibration `correct` applies to the record `data`: the file `calibration` (a
/// `ptsa discover --json` result), or without one the instrument file `name` when it was
/// given (`instrument_given`) as the instrument's own calibrated model; with its name as
/// printed and the option that gave it.
///
/// # Errors
/// Neither; the calibration cannot be read or applied.
pub fn choose_calibration(
    calibration: Option<&Path>,
    data: &Path,
    instr: &Instrument,
    name: &str,
    instrument_given: bool,
) -> Result<(lib::Calibration, String, String)> {
    Ok(match calibration {
        Some(p) => (
            read_calibration(p, data, instr)?,
            p.display().to_string(),
            format!("--calibration {}", p.display()),
        ),
        None if instrument_given => (
            lib::Calibration::of_instrument(instr),
            format!("the instrument file {name}"),
            format!("--instrument {name}"),
        ),
        None => bail!(
            "no calibration to apply; expected --calibration FILE.json (the output of `ptsa discover --json`) or --instrument FILE (an instrument file of the instrument's calibrated values, e.g. written by `ptsa discover --write-instrument`)"
        ),
    })
}

/// Correct every row of the single-axis case frame `data` with `cal` (`flag` names the
/// calibration in warnings; `sigma`, cm/s², the noise of a reading that states none).
///
/// # Errors
/// The file is refused; a row is not absolute and static, or no specific force gives its
/// reading (file and line); no row has a reading.
pub fn correct_record(
    data: &Path,
    instr: &Instrument,
    cal: &lib::Calibration,
    flag: &str,
    sigma: Option<f64>,
) -> Result<CorrectedRecord> {
    let name = data.display().to_string();
    let mut frame = caseframe::read_frame(data)?;
    // Raw readings (`reading`, `reading_unit`) in cm/s² through the instrument file.
    frame.convert_readings(&name, instr)?;
    let mut warnings: Vec<String> = cal.notes.iter().map(|n| format!("{flag}: {n}")).collect();
    let g = cal.g_cm_s2();
    let rows = with_history(&counts::with_counts(&frame.rows, instr.sf_cm_s2), g);
    let mut done = Vec::with_capacity(rows.len());
    for (k, r) in rows.iter().enumerate() {
        let line = frame.lines.get(k).copied().unwrap_or(0);
        let c = lib::correct_row(cal, r, sigma).map_err(|e| match e {
                lib::Refusal::Kind(kind) => anyhow::anyhow!(
                    "{name}:{line}: row `{}` is a {} row; expected absolute rows (one reading of the case at rest each: `kind` = absolute)",
                    r.label,
                    kind.name()
                ),
                lib::Refusal::NotStatic => anyhow::anyhow!(
                    "{name}:{line}: row `{}` has a rate, an oscillation or a centrifuge arm; expected static rows (the case at rest: `correct` recovers the specific force of gravity's kind only)",
                    r.label
                ),
                lib::Refusal::NoSolution => anyhow::anyhow!(
                    "{name}:{line}: row `{}`: no specific force along IA gives the reading {} cm/s² under the calibration; expected a reading within the instrument's range (a value in another unit?)",
                    r.label,
                    r.measured_cm_s2.unwrap_or(f64::NAN)
                ),
            })?;
        done.push((frame.rows[k].clone(), line, c));
    }
    warnings.extend(untested_warnings(flag, cal, &done, &rows));
    let with_reading = done.iter().filter(|d| d.2.is_some()).count();
    if with_reading == 0 {
        bail!(
            "{name}: no row has a reading; expected `measured_cm_s2` or `pulses` and `ticks` on the rows to correct"
        );
    }
    if with_reading < done.len() {
        warnings.push(format!(
                "{name}: {} without a reading (`measured_cm_s2` or counts empty): written without corrected values",
                count((done.len() - with_reading) as u64, "row")
            ));
    }
    let noiseless = rows
        .iter()
        .filter(|r| {
            r.measured_cm_s2.is_some()
                && r.sigma_cm_s2.is_none()
                && r.counting_sigma_cm_s2.is_none()
        })
        .count();
    if noiseless > 0 && sigma.is_none() {
        warnings.push(format!(
                "{name}: {} with a reading {} no noise (no `sigma_cm_s2`, no counts) and --sigma is not given: their sigmas hold the calibration's uncertainty only (give --sigma CM_S2, or sigma_cm_s2 on the rows)",
                count(noiseless as u64, "row"),
                if noiseless == 1 { "states" } else { "state" }
            ));
    }
    if rows
        .iter()
        .filter(|r| r.kind == RowKind::Absolute)
        .all(|r| r.g[1] == 0.0 && r.g[2] == 0.0)
    {
        warnings.push(format!(
                "{name}: no row gives a cross-axis input (`g_pa`, `g_oa` absent or 0): a_PA and a_OA are taken as 0, so the calibration's misalignment and cross-axis terms correct nothing; give them where the case is tilted"
            ));
    }
    Ok(CorrectedRecord {
        rows: done,
        warnings,
        g_cm_s2: g,
    })
}

/// A warning for each term the calibration could not test that acts on some corrected row.
fn untested_warnings(
    flag: &str,
    cal: &lib::Calibration,
    done: &[(Condition, usize, Option<lib::Corrected>)],
    rows: &[Condition],
) -> Vec<String> {
    let mut warnings = Vec::new();
    // The terms the calibration could not test, by the rows they act on.
    let mut untested: Vec<(&'static str, usize)> = Vec::new();
    for ((_, _, c), r) in done.iter().zip(rows) {
        for id in c.iter().flat_map(|c| lib::untested_terms(cal, r, c)) {
            let n = id.info().name;
            match untested.iter_mut().find(|u| u.0 == n) {
                Some(u) => u.1 += 1,
                None => untested.push((n, 1)),
            }
        }
    }
    // A warm-up acts through the time since power-on, which rows without `time_s` lack.
    if let Some((name, a, tau)) = cal.warm_up() {
        let untimed = done
            .iter()
            .zip(rows)
            .filter(|((_, _, c), r)| c.is_some() && r.history.t_on_span.is_none())
            .count();
        if untimed > 0 {
            warnings.push(format!(
                "{flag}: the calibration's warm-up (`{name}` = {} cm/s²{}) acts through the time since power-on, which {} without `time_s` lack: their readings are corrected as if the instrument had warmed up (give `time_s`, and `power_on_s` where it was switched on, to correct the transient)",
                crate::output::significant(a, 4),
                tau.map_or(String::new(), |t| format!(", τ = {} s", crate::output::significant(t, 4))),
                count(untimed as u64, "row")
            ));
        }
    }
    for (n, k) in untested {
        warnings.push(format!(
                "{flag}: `{n}` was not testable in the calibration's data, and it acts on {} here: {} (calibrate with positions that exercise it)",
                count(k as u64, "row"),
                if lib::at_its_bound(cal, n) {
                    "not corrected; its plausibility bound is in their sigmas, which it may dominate"
                } else {
                    "its error is in neither their corrected values nor their sigmas"
                }
            ));
    }
    warnings
}

impl CorrectedRecord {
    /// `ptsa correct --json`'s object for the record `data`, the calibration `calibration`
    /// and the instrument file `instrument` (their names as printed).
    ///
    /// # Panics
    /// Never: the object is plain data, which `serde_json` always turns into a value.
    #[must_use]
    pub fn json(&self, data: &str, calibration: &str, instrument: &str) -> serde_json::Value {
        let rows = self
            .rows
            .iter()
            .map(|(r, line, c)| CorrectedRow {
                label: r.label.clone(),
                line: *line,
                corrected: c.clone(),
            })
            .collect();
        let v = CorrectJson {
            data: data.to_string(),
            calibration: calibration.to_string(),
            instrument: instrument.to_string(),
            g_cm_s2: self.g_cm_s2,
            rows,
            warnings: self.warnings.clone(),
        };
        // Through a `Value`: its keys in the order of their names.
        serde_json::to_value(v).expect("plain data")
    }
}
