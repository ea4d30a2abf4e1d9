//! `ptsa correct` of a triad record: the triad's calibration read (its calibration file or
//! its `discover --json`), and every row with its three readings turned into the specific
//! force in the calibration's frame, with its covariance. The command line and the Python
//! package both call it.

use std::path::Path;

use anyhow::{Context as _, Result, bail};

use super::apply::{Corrected, TriadCalibration};
use super::frame::{self, Position};
use crate::output::command_json::{TriadCorrectJson, TriadCorrected, TriadCorrectedRow};

/// A triad's calibration for the record `data` from the file `calibration` (`flag` names
/// it in messages): a triad calibration file, or a triad's `ptsa discover --json`.
///
/// # Errors
/// The file cannot be read; it is a single-axis calibration; it is neither a calibration
/// file nor a triad's JSON.
pub fn read_calibration(calibration: &Path, flag: &str, data: &Path) -> Result<TriadCalibration> {
    let text =
        std::fs::read_to_string(calibration).with_context(|| format!("{flag}: cannot read"))?;
    match serde_json::from_str::<serde_json::Value>(&text) {
        Ok(v) if v.get("triad").is_some() => TriadCalibration::from_json(flag, &v),
        Ok(_) => bail!(
            "{flag}: a single-axis calibration, but {} is a triad record (three axes' readings per row); expected a triad's calibration (`ptsa discover --data TRIAD.csv --json` or its --write-instrument file)",
            data.display()
        ),
        Err(_) => TriadCalibration::parse(&calibration.display().to_string(), &text),
    }
}

/// One row of a triad record: the position as read and, with three readings, their 1 σ
/// (cm/s²) and the corrected force.
#[derive(Clone, Debug)]
pub struct TriadRow {
    /// The row as read.
    pub p: Position,
    /// The readings' 1 σ and the correction, when the row has all three readings.
    pub c: Option<([f64; 3], Corrected)>,
}

/// A triad record corrected: the calibration, every row, the warnings.
#[derive(Clone, Debug)]
pub struct CorrectedTriad {
    /// The calibration applied.
    pub cal: TriadCalibration,
    /// The rows, in the record's order.
    pub rows: Vec<TriadRow>,
    /// Rows left without a correction, readings without a stated noise.
    pub warnings: Vec<String>,
}

/// The triad record `data` corrected with `cal`: its counts read with the scale factor
/// `sf_cm_s2` (cm/s² per unit of the count rate), each row's noise its `sigma_cm_s2`, else
/// `sigma` (cm/s², 1 σ), combined with its counting noise.
///
/// # Errors
/// The record cannot be read; no row has all three readings.
pub fn correct_triad(
    data: &Path,
    cal: TriadCalibration,
    sf_cm_s2: f64,
    sigma: Option<f64>,
) -> Result<CorrectedTriad> {
    let name = data.display().to_string();
    let mut positions = frame::read_record(data)?;
    frame::with_counts(&mut positions, sf_cm_s2);
    let mut noiseless = 0usize;
    let rows: Vec<TriadRow> = positions
        .into_iter()
        .map(|p| {
            let c = if let [Some(x), Some(y), Some(z)] = p.measured {
                let stated = p.sigma_cm_s2.or(sigma);
                if stated.is_none() && p.counting_sigma_cm_s2.iter().all(Option::is_none) {
                    noiseless += 1;
                }
                let var = [0, 1, 2].map(|j| {
                    stated
                        .unwrap_or(0.0)
                        .hypot(p.counting_sigma_cm_s2[j].unwrap_or(0.0))
                        .powi(2)
                });
                Some((var.map(f64::sqrt), cal.correct([x, y, z], var)))
            } else {
                None
            };
            TriadRow { p, c }
        })
        .collect();
    let warnings = warnings(&name, &rows, noiseless, sigma.is_some())?;
    Ok(CorrectedTriad {
        cal,
        rows,
        warnings,
    })
}

/// The correction's warnings; no row corrected is an error.
fn warnings(
    name: &str,
    rows: &[TriadRow],
    noiseless: usize,
    sigma_given: bool,
) -> Result<Vec<String>> {
    let mut warnings = Vec::new();
    let with = rows.iter().filter(|r| r.c.is_some()).count();
    if with == 0 {
        bail!(
            "{name}: no row has all three axes' readings; expected `measured_x_cm_s2`, `measured_y_cm_s2` and `measured_z_cm_s2` (or each axis's counts) on the rows to correct"
        );
    }
    if with < rows.len() {
        warnings.push(format!(
            "{name}: {} without all three axes' readings: written without corrected values (the triad's correction needs the three at once)",
            crate::output::count((rows.len() - with) as u64, "row")
        ));
    }
    if noiseless > 0 && !sigma_given {
        warnings.push(format!(
            "{name}: {} with readings {} no noise (no `sigma_cm_s2`, no counts) and --sigma is not given: their covariance holds the calibration's uncertainty only (give --sigma CM_S2, or sigma_cm_s2 on the rows)",
            crate::output::count(noiseless as u64, "row"),
            if noiseless == 1 { "states" } else { "state" }
        ));
    }
    Ok(warnings)
}

impl CorrectedTriad {
    /// The JSON object `ptsa correct --json` prints for a triad record: `data` the record,
    /// `calibration` the calibration file, `instrument` the instrument file, as named.
    ///
    /// # Panics
    /// Never: the object is plain data (numbers, strings, lists), which always serialises.
    #[must_use]
    pub fn json(&self, data: &str, calibration: &str, instrument: &str) -> serde_json::Value {
        let g = self.cal.g_cm_s2;
        let rows = self
            .rows
            .iter()
            .map(|r| TriadCorrectedRow {
                label: r.p.label.clone(),
                line: r.p.line,
                corrected: r.c.as_ref().map(|(sig, c)| {
                    let (mag, smag) = c.magnitude();
                    TriadCorrected {
                        reading_cm_s2: r.p.measured,
                        sigma_reading_cm_s2: *sig,
                        f_cm_s2: c.f,
                        f_g: c.f.map(|x| x / g),
                        f_magnitude_cm_s2: mag,
                        sigma_f_magnitude_cm_s2: smag,
                        covariance_cm2_s4: c.covariance(),
                        covariance_noise_cm2_s4: c.noise,
                        covariance_calibration_cm2_s4: c.calibration,
                    }
                }),
            })
            .collect();
        let v = TriadCorrectJson {
            data: data.to_string(),
            calibration: calibration.to_string(),
            instrument: instrument.to_string(),
            g_cm_s2: g,
            frame: self.cal.orientation.name().to_string(),
            rows,
            warnings: self.warnings.clone(),
        };
        // Through a `Value`: its keys in the order of their names.
        serde_json::to_value(v).expect("plain data")
    }
}
