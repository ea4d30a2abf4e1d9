//! The report's measurements (`data/r890-*.csv`, transcribed from R-890) and their
//! conversion into the case-frame format by the fixture geometry (`data/*.case.csv`).
//!
//! Geometry and signs (also in `data/README.md`):
//! * **Table 6.1** (dividing head on the rate table, Figs. 6.1–6.2): IA and PA turn in the
//!   vertical plane about OA (horizontal); IA at φ above horizontal, so the upward unit vector
//!   in case axes is `(sin φ, cos φ, 0)`. Gravity's specific force at rest points up:
//!   `g_ia = sin φ`, `g_pa = cos φ`. The table turns about the vertical at ω = 1.0 rad/s, so
//!   `w_ia = ω sin φ`, `w_pa = ω cos φ`; the reference is the 0.05 rad/s run about the same
//!   axis. `measured_cm_s2` is eq. 6.5 as tabulated (A_in at 1.0 − A_in at 0.05 rad/s).
//! * **Table 6.2** (single-axis oscillator, OA perpendicular to the table top, IA horizontal):
//!   OA is vertical and taken as pointing up, so `g_oa = 1`; the case oscillates about OA at
//!   the table's frequency with the table's amplitude (`ang_oa_mrad`, phase 0); the reference
//!   is the table at rest.
//! * **Table 6.3** (table top turned 90° about the tilt axis, IA up): `g_ia = 1`, OA
//!   horizontal, oscillation about OA as in 6.2.
//! * Tables 6.2/6.3 tabulate the "Static-Dynamic Output Difference"; the case frame's
//!   `measured_cm_s2` is condition (dynamic) minus reference (static), so the sign is flipped.
//!   Resonance rows keep their frequency and have no amplitude and no measurement.
//! * Every row carries `sigma_cm_s2` = 0.3, the test uncertainty of section 6.1.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

use super::caseframe::{to_csv, write_atomic};
use crate::condition::Condition;

/// Table 6.1 as transcribed (`data/r890-table-6.1.csv`).
pub const TABLE_6_1_CSV: &str = include_str!("../../../data/r890-table-6.1.csv");
/// Table 6.2 as transcribed.
pub const TABLE_6_2_CSV: &str = include_str!("../../../data/r890-table-6.2.csv");
/// Table 6.3 as transcribed.
pub const TABLE_6_3_CSV: &str = include_str!("../../../data/r890-table-6.3.csv");
/// Section 6.1's SF, bias, local g and test uncertainty.
pub const SECTION_6_1_CSV: &str = include_str!("../../../data/r890-section-6.1.csv");

/// Table rate of Table 6.1's measurement run, rad/s.
pub const TABLE_6_1_RATE_RAD_S: f64 = 1.0;
/// Table rate of Table 6.1's reference run, rad/s.
pub const TABLE_6_1_REF_RATE_RAD_S: f64 = 0.05;

/// The report's test uncertainty (section 6.1), cm/s².
#[must_use]
pub fn test_uncertainty_cm_s2() -> f64 {
    section_6_1()
        .ok()
        .and_then(|v| {
            v.into_iter()
                .find(|(k, _)| k == "test_uncertainty")
                .map(|(_, v)| v)
        })
        .unwrap_or(0.3)
}

/// Section 6.1's quantities as `(name, value in cm/s²)`.
///
/// # Errors
/// The shipped file is malformed.
pub fn section_6_1() -> Result<Vec<(String, f64)>> {
    parse_plain(SECTION_6_1_CSV, "r890-section-6.1.csv", 3)?
        .into_iter()
        .map(|(line, cells)| {
            let v = cells[1].parse::<f64>().with_context(|| {
                format!("r890-section-6.1.csv:{line}: column `value`: expected a number")
            })?;
            Ok((cells[0].clone(), v))
        })
        .collect()
}

/// Non-comment data lines after the header: `(line number, cells)`.
fn parse_plain(text: &str, name: &str, ncols: usize) -> Result<Vec<(usize, Vec<String>)>> {
    let mut out = Vec::new();
    let mut header = false;
    for (i, l) in text.lines().enumerate() {
        let t = l.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let cells: Vec<String> = t.split(',').map(|s| s.trim().to_string()).collect();
        if cells.len() != ncols {
            bail!("{name}:{}: {} cells, expected {ncols}", i + 1, cells.len());
        }
        if header {
            out.push((i + 1, cells));
        } else {
            header = true;
        }
    }
    Ok(out)
}

fn num(name: &str, line: usize, col: &str, s: &str) -> Result<Option<f64>> {
    if s.is_empty() {
        return Ok(None);
    }
    s.parse::<f64>().map(Some).with_context(|| {
        format!("{name}:{line}: column `{col}` holds `{s}`; expected a number or an empty cell")
    })
}

/// Table 6.1 in the case frame.
///
/// # Errors
/// The transcription is malformed.
pub fn table_6_1() -> Result<Vec<Condition>> {
    let sigma = test_uncertainty_cm_s2();
    let name = "r890-table-6.1.csv";
    parse_plain(TABLE_6_1_CSV, name, 2)?
        .into_iter()
        .map(|(line, c)| {
            let phi_deg = num(name, line, "ia_deg", &c[0])?.context("ia_deg missing")?;
            let a = num(name, line, "a_in_cm_s2", &c[1])?;
            let (s, co) = phi_deg.to_radians().sin_cos();
            let (s, co) = (clean(s), clean(co));
            Ok(Condition {
                label: format!("IA {phi_deg} deg"),
                g: [s, co, 0.0],
                w_rad_s: [TABLE_6_1_RATE_RAD_S * s, TABLE_6_1_RATE_RAD_S * co, 0.0],
                ref_w_rad_s: [
                    TABLE_6_1_REF_RATE_RAD_S * s,
                    TABLE_6_1_REF_RATE_RAD_S * co,
                    0.0,
                ],
                measured_cm_s2: a,
                sigma_cm_s2: Some(sigma),
                ..Condition::default()
            })
        })
        .collect()
}

/// Round a unit-circle value to 0 / ±1 when it is within rounding of them (so 180° gives
/// `g_ia = 0`, not 1.2e-16).
fn clean(x: f64) -> f64 {
    if x.abs() < 1e-12 {
        0.0
    } else if (x.abs() - 1.0).abs() < 1e-12 {
        x.signum()
    } else {
        x
    }
}

fn oa_coupling(text: &str, name: &str, g: [f64; 3], what: &str) -> Result<Vec<Condition>> {
    let sigma = test_uncertainty_cm_s2();
    parse_plain(text, name, 3)?
        .into_iter()
        .map(|(line, c)| {
            let f = num(name, line, "freq_hz", &c[0])?.context("freq_hz missing")?;
            let amp = num(name, line, "amplitude_mrad", &c[1])?;
            let diff = num(name, line, "output_difference_cm_s2", &c[2])?;
            let label = match amp {
                Some(a) => format!("{what} {f} Hz {a} mrad"),
                None => format!("{what} {f} Hz (system resonance, not measured)"),
            };
            Ok(Condition {
                label,
                g,
                freq_hz: f,
                ang_mrad: [0.0, 0.0, amp.unwrap_or(0.0)],
                measured_cm_s2: diff.map(|d| if d == 0.0 { 0.0 } else { -d }),
                sigma_cm_s2: Some(sigma),
                ..Condition::default()
            })
        })
        .collect()
}

/// Table 6.2 in the case frame.
///
/// # Errors
/// The transcription is malformed.
pub fn table_6_2() -> Result<Vec<Condition>> {
    oa_coupling(
        TABLE_6_2_CSV,
        "r890-table-6.2.csv",
        [0.0, 0.0, 1.0],
        "IA horizontal, OA up,",
    )
}

/// Table 6.3 in the case frame.
///
/// # Errors
/// The transcription is malformed.
pub fn table_6_3() -> Result<Vec<Condition>> {
    oa_coupling(
        TABLE_6_3_CSV,
        "r890-table-6.3.csv",
        [1.0, 0.0, 0.0],
        "IA up,",
    )
}

/// One shipped case-frame file: `(file name, comment lines, rows)`.
pub type CaseFile = (&'static str, Vec<&'static str>, Vec<Condition>);

/// The shipped case-frame files.
///
/// # Errors
/// A transcription is malformed.
pub fn case_files() -> Result<Vec<CaseFile>> {
    let note = "Generated from the transcription by ptsa-host-sim::discovery::report_data \
                (regenerate: `ptsa discover --convert-report-data data`); do not edit.";
    Ok(vec![
        (
            "r890-table-6.1.case.csv",
            vec![
                "Draper R-890 Table 6.1 (anisoinertia) in the case frame: IA at phi above horizontal,",
                "g_ia = sin phi, g_pa = cos phi, table rate 1.0 rad/s about the vertical, reference 0.05 rad/s.",
                note,
            ],
            table_6_1()?,
        ),
        (
            "r890-table-6.2.case.csv",
            vec![
                "Draper R-890 Table 6.2 (OA coupling, IA horizontal) in the case frame: OA up (g_oa = 1),",
                "oscillation about OA; measured = dynamic - static (the table's static - dynamic, negated).",
                note,
            ],
            table_6_2()?,
        ),
        (
            "r890-table-6.3.case.csv",
            vec![
                "Draper R-890 Table 6.3 (OA coupling, IA vertical) in the case frame: IA up (g_ia = 1),",
                "oscillation about OA (horizontal); measured = dynamic - static (the table's value negated).",
                note,
            ],
            table_6_3()?,
        ),
    ])
}

/// A synthetic 48-row example (`data/synthetic-48.case.csv`): [`super::hidden::design_48`]
/// with anisoinertia 3.0 cm hidden, noise 0.2 cm/s² (seed 5), computed by the analytic model
/// so that it is exactly reproducible. For trying the command and timing it.
#[must_use]
pub fn synthetic_48() -> CaseFile {
    let truth = crate::condition::Effects {
        k_ai_cm: 3.0,
        ..crate::condition::Effects::default()
    };
    (
        "synthetic-48.case.csv",
        vec![
            "Synthetic example, not measured: 16 rate-table rows and 32 two-axis-oscillator rows",
            "(discovery::hidden::design_48) with anisoinertia k_ai_cm = 3.0 hidden and noise 0.2 cm/s^2, seed 5.",
            "Generated by ptsa-host-sim::discovery::report_data::synthetic_48; do not edit.",
        ],
        super::hidden::design_48(&super::sim::AnalyticSimulator, &truth, 0.2, 5),
    )
}

/// Write the case-frame files (the three tables and the synthetic example) into `dir`;
/// returns the paths written.
///
/// # Errors
/// A transcription is malformed or a file cannot be written.
pub fn write_case_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    let mut files = case_files()?;
    files.push(synthetic_48());
    for (name, comments, rows) in files {
        let p = dir.join(name);
        write_atomic(&p, &to_csv(&rows, &comments))?;
        out.push(p);
    }
    Ok(out)
}

#[cfg(test)]
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;
    use crate::discovery::caseframe;

    /// The shipped `data/*.case.csv` equal the code's conversion. With
    /// `PTSA_WRITE_REPORT_DATA=1` the test rewrites them instead.
    #[test]
    fn shipped_case_files_match_the_conversion() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data");
        if std::env::var_os("PTSA_WRITE_REPORT_DATA").is_some() {
            write_case_files(&dir).unwrap();
        }
        let mut files = case_files().unwrap();
        files.push(synthetic_48());
        for (name, comments, rows) in files {
            let shipped = std::fs::read_to_string(dir.join(name)).unwrap_or_else(|e| {
                panic!(
                    "data/{name}: {e}; regenerate with `ptsa discover --convert-report-data data`"
                )
            });
            assert_eq!(
                shipped,
                to_csv(&rows, &comments),
                "data/{name} differs from the conversion"
            );
            assert_eq!(caseframe::parse(name, &shipped).unwrap(), rows);
        }
    }

    #[test]
    fn geometry_of_table_6_1() {
        let t = table_6_1().unwrap();
        assert_eq!(t.len(), 8);
        let r45 = &t[0];
        assert!(
            (r45.g[0] - 0.5f64.sqrt()).abs() < 1e-15
                && (r45.w_rad_s[1] - 0.5f64.sqrt()).abs() < 1e-15
        );
        assert_eq!(t[3].g, [0.0, -1.0, 0.0]); // 180°: IA horizontal, PA down
        assert_eq!(t[1].g, [1.0, 0.0, 0.0]); // 90°: IA up
        let t2 = table_6_2().unwrap();
        assert_eq!(t2.len(), 12);
        assert_eq!(t2.iter().filter(|r| r.measured_cm_s2.is_none()).count(), 3);
        assert_eq!(t2[0].measured_cm_s2, Some(0.03));
        assert_eq!(
            table_6_3()
                .unwrap()
                .iter()
                .filter(|r| r.measured_cm_s2.is_none())
                .count(),
            2
        );
    }
}
