//! The report's measurements, read from the transcriptions in `data/` (the only copy), and
//! their conversion into the case-frame format by the fixture geometry of [`crate::lab::fixtures`].
//!
//! * `data/r890-section-6.1.csv`: SF, `A_b`, local g and the test uncertainty ([`Section61`]);
//! * `data/r890-section-6.2.csv`: the anisoinertia measurement's rates and results
//!   ([`Section62`]);
//! * `data/r890-table-6.{1,2,3}.csv`: Tables 6.1–6.3 ([`table_6_1`], [`table_6_2`],
//!   [`table_6_3`]), and in the case frame ([`case_files`], `data/*.case.csv`).
//!
//! Geometry and signs (also in `data/README.md`):
//! * **Table 6.1** (dividing head on the rate table, Figs. 6.1–6.2,
//!   [`fixtures::rate_table`]): IA at φ above horizontal, `g_ia = sin φ`, `g_pa = cos φ`,
//!   table rate about the vertical; `measured_cm_s2` is eq. 6.5 as tabulated.
//! * **Tables 6.2/6.3** (single-axis oscillator, [`fixtures::angular_oscillator`]): OA up
//!   (6.2) or IA up (6.3), oscillation about OA. The tables give the "Static-Dynamic Output
//!   Difference"; the case frame's `measured_cm_s2` is condition − reference = dynamic −
//!   static, so the sign is flipped. Resonance rows keep their frequency and have no amplitude
//!   and no measurement.
//! * Every row carries `sigma_cm_s2` = the test uncertainty of section 6.1 (0.3 cm/s²).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

use crate::lab::fixtures;
use crate::model::caseframe::to_csv;
use crate::model::condition::Condition;
use crate::output::write_atomic;

/// Table 6.1 as transcribed (`data/r890-table-6.1.csv`).
pub const TABLE_6_1_CSV: &str = include_str!("../../../data/r890-table-6.1.csv");
/// Table 6.2 as transcribed.
pub const TABLE_6_2_CSV: &str = include_str!("../../../data/r890-table-6.2.csv");
/// Table 6.3 as transcribed.
pub const TABLE_6_3_CSV: &str = include_str!("../../../data/r890-table-6.3.csv");
/// Section 6.1's SF, bias, local g and test uncertainty.
pub const SECTION_6_1_CSV: &str = include_str!("../../../data/r890-section-6.1.csv");
/// Section 6.2's rates and results.
pub const SECTION_6_2_CSV: &str = include_str!("../../../data/r890-section-6.2.csv");

/// The data rows of a transcription: `(1-based line, cells)`, every cell trimmed; `#` lines
/// are comments, the first other line is the header, which must be `header`.
fn rows(text: &str, name: &str, header: &[&str]) -> Result<Vec<(u64, Vec<String>)>> {
    let mut r = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let h = r.headers().with_context(|| format!("{name}: header"))?;
    if h.iter().collect::<Vec<_>>() != header {
        bail!("{name}: header {h:?}; expected {}", header.join(","));
    }
    let mut out = Vec::new();
    for rec in r.records() {
        let rec = rec.with_context(|| format!("{name}: malformed line"))?;
        let line = rec.position().map_or(0, csv::Position::line);
        out.push((line, rec.iter().map(str::to_string).collect()));
    }
    Ok(out)
}

/// A cell as a number, or `None` if empty.
fn cell(name: &str, line: u64, col: &str, s: &str) -> Result<Option<f64>> {
    if s.is_empty() {
        return Ok(None);
    }
    s.parse::<f64>().map(Some).with_context(|| {
        format!("{name}:{line}: column `{col}` holds `{s}`; expected a number or an empty cell")
    })
}

/// A `quantity,value,unit` file as a lookup.
fn quantities(text: &str, name: &str) -> Result<Vec<(String, f64)>> {
    rows(text, name, &["quantity", "value", "unit"])?
        .into_iter()
        .map(|(line, c)| {
            let v = cell(name, line, "value", &c[1])?
                .with_context(|| format!("{name}:{line}: column `value` is empty"))?;
            Ok((c[0].clone(), v))
        })
        .collect()
}

fn quantity(q: &[(String, f64)], name: &str, key: &str) -> Result<f64> {
    q.iter()
        .find(|(k, _)| k == key)
        .map(|&(_, v)| v)
        .with_context(|| format!("{name}: no quantity `{key}`"))
}

/// Section 6.1 (`data/r890-section-6.1.csv`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Section61 {
    /// SF by eq. 6.3, cm/s².
    pub sf_cm_s2: f64,
    /// `A_b` by eq. 6.4, cm/s².
    pub bias_cm_s2: f64,
    /// Local gravity used there, cm/s².
    pub g_cm_s2: f64,
    /// The test uncertainty observed, cm/s².
    pub test_uncertainty_cm_s2: f64,
}

/// Section 6.1's figures.
///
/// # Errors
/// The shipped transcription is malformed (a unit test parses it).
pub fn section_6_1() -> Result<Section61> {
    let name = "r890-section-6.1.csv";
    let q = quantities(SECTION_6_1_CSV, name)?;
    Ok(Section61 {
        sf_cm_s2: quantity(&q, name, "scale_factor")?,
        bias_cm_s2: quantity(&q, name, "bias")?,
        g_cm_s2: quantity(&q, name, "local_gravity")?,
        test_uncertainty_cm_s2: quantity(&q, name, "test_uncertainty")?,
    })
}

/// Section 6.2 (`data/r890-section-6.2.csv`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Section62 {
    /// Table rate of the measurement run, rad/s.
    pub rate_rad_s: f64,
    /// Table rate of the reference run, rad/s.
    pub reference_rate_rad_s: f64,
    /// Mean `|A_in|` at the 45° positions, cm/s².
    pub mean_error_45_cm_s2: f64,
    /// Anisoinertia error coefficient `(I_PA − I_IA)/(m·l)`, cm.
    pub coefficient_cm: f64,
    /// Anisoinertia `I_PA − I_IA`, g·cm².
    pub anisoinertia_g_cm2: f64,
}

/// Section 6.2's figures.
///
/// # Errors
/// The shipped transcription is malformed (a unit test parses it).
pub fn section_6_2() -> Result<Section62> {
    let name = "r890-section-6.2.csv";
    let q = quantities(SECTION_6_2_CSV, name)?;
    Ok(Section62 {
        rate_rad_s: quantity(&q, name, "rate")?,
        reference_rate_rad_s: quantity(&q, name, "reference_rate")?,
        mean_error_45_cm_s2: quantity(&q, name, "mean_error_at_45_deg")?,
        coefficient_cm: quantity(&q, name, "coefficient")?,
        anisoinertia_g_cm2: quantity(&q, name, "anisoinertia")?,
    })
}

/// One row of Table 6.1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Table61Row {
    /// IA position above horizontal, deg.
    pub ia_deg: f64,
    /// Eq. 6.5 as tabulated (`A_in` at 1.0 − at 0.05 rad/s), cm/s².
    pub a_in_cm_s2: Option<f64>,
}

/// Table 6.1 as transcribed.
///
/// # Errors
/// The shipped transcription is malformed.
pub fn table_6_1() -> Result<Vec<Table61Row>> {
    let name = "r890-table-6.1.csv";
    rows(TABLE_6_1_CSV, name, &["ia_deg", "a_in_cm_s2"])?
        .into_iter()
        .map(|(line, c)| {
            Ok(Table61Row {
                ia_deg: cell(name, line, "ia_deg", &c[0])?
                    .with_context(|| format!("{name}:{line}: `ia_deg` is empty"))?,
                a_in_cm_s2: cell(name, line, "a_in_cm_s2", &c[1])?,
            })
        })
        .collect()
}

/// One row of Table 6.2 or 6.3.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OaRow {
    /// Oscillation frequency, Hz.
    pub freq_hz: f64,
    /// Amplitude about OA, mrad (`None`: system resonance, not measured).
    pub amp_mrad: Option<f64>,
    /// The table's "Static-Dynamic Output Difference", cm/s² (`None`: not measured).
    pub static_minus_dynamic_cm_s2: Option<f64>,
}

fn oa_table(text: &str, name: &str) -> Result<Vec<OaRow>> {
    rows(
        text,
        name,
        &["freq_hz", "amplitude_mrad", "output_difference_cm_s2"],
    )?
    .into_iter()
    .map(|(line, c)| {
        Ok(OaRow {
            freq_hz: cell(name, line, "freq_hz", &c[0])?
                .with_context(|| format!("{name}:{line}: `freq_hz` is empty"))?,
            amp_mrad: cell(name, line, "amplitude_mrad", &c[1])?,
            static_minus_dynamic_cm_s2: cell(name, line, "output_difference_cm_s2", &c[2])?,
        })
    })
    .collect()
}

/// Table 6.2 (IA horizontal) as transcribed.
///
/// # Errors
/// The shipped transcription is malformed.
pub fn table_6_2() -> Result<Vec<OaRow>> {
    oa_table(TABLE_6_2_CSV, "r890-table-6.2.csv")
}

/// Table 6.3 (IA vertical) as transcribed.
///
/// # Errors
/// The shipped transcription is malformed.
pub fn table_6_3() -> Result<Vec<OaRow>> {
    oa_table(TABLE_6_3_CSV, "r890-table-6.3.csv")
}

/// Table 6.1 in the case frame.
///
/// # Errors
/// A transcription is malformed.
pub fn table_6_1_case() -> Result<Vec<Condition>> {
    let sigma = section_6_1()?.test_uncertainty_cm_s2;
    let s62 = section_6_2()?;
    Ok(table_6_1()?
        .into_iter()
        .map(|r| {
            let mut c =
                fixtures::rate_table(r.ia_deg, s62.rate_rad_s, s62.reference_rate_rad_s, [0.0; 3])
                    .cond;
            c.label = format!("IA {} deg", r.ia_deg);
            c.measured_cm_s2 = r.a_in_cm_s2;
            c.sigma_cm_s2 = Some(sigma);
            c
        })
        .collect())
}

fn oa_case(rows: Vec<OaRow>, ia_vertical: bool, what: &str) -> Result<Vec<Condition>> {
    let sigma = section_6_1()?.test_uncertainty_cm_s2;
    Ok(rows
        .into_iter()
        .map(|r| {
            let f = r.freq_hz;
            let mut c =
                fixtures::angular_oscillator(f, r.amp_mrad.unwrap_or(0.0), ia_vertical, [0.0; 3])
                    .cond;
            c.label = match r.amp_mrad {
                Some(a) => format!("{what} {f} Hz {a} mrad"),
                None => format!("{what} {f} Hz (system resonance, not measured)"),
            };
            // Condition minus reference = dynamic − static: the table's value negated.
            c.measured_cm_s2 = r
                .static_minus_dynamic_cm_s2
                .map(|d| if d == 0.0 { 0.0 } else { -d });
            c.sigma_cm_s2 = Some(sigma);
            c
        })
        .collect())
}

/// Table 6.2 in the case frame.
///
/// # Errors
/// A transcription is malformed.
pub fn table_6_2_case() -> Result<Vec<Condition>> {
    oa_case(table_6_2()?, false, "IA horizontal, OA up,")
}

/// Table 6.3 in the case frame.
///
/// # Errors
/// A transcription is malformed.
pub fn table_6_3_case() -> Result<Vec<Condition>> {
    oa_case(table_6_3()?, true, "IA up,")
}

/// One shipped case-frame file.
#[derive(Clone, Debug, PartialEq)]
pub struct CaseFile {
    /// File name in `data/`.
    pub name: &'static str,
    /// Its `#` comment lines.
    pub comments: Vec<&'static str>,
    /// Its rows.
    pub rows: Vec<Condition>,
}

/// The shipped case-frame files of the report's tables.
///
/// # Errors
/// A transcription is malformed.
pub fn case_files() -> Result<Vec<CaseFile>> {
    let note = "Generated from the transcription by ptsa-host-sim::r890 \
                (regenerate: `cargo xtask report-data`); do not edit.";
    Ok(vec![
        CaseFile {
            name: "r890-table-6.1.case.csv",
            comments: vec![
                "Draper R-890 Table 6.1 (anisoinertia) in the case frame: IA at phi above horizontal,",
                "g_ia = sin phi, g_pa = cos phi, table rate 1.0 rad/s about the vertical, reference 0.05 rad/s.",
                note,
            ],
            rows: table_6_1_case()?,
        },
        CaseFile {
            name: "r890-table-6.2.case.csv",
            comments: vec![
                "Draper R-890 Table 6.2 (OA coupling, IA horizontal) in the case frame: OA up (g_oa = 1),",
                "oscillation about OA; measured = dynamic - static (the table's static - dynamic, negated).",
                note,
            ],
            rows: table_6_2_case()?,
        },
        CaseFile {
            name: "r890-table-6.3.case.csv",
            comments: vec![
                "Draper R-890 Table 6.3 (OA coupling, IA vertical) in the case frame: IA up (g_ia = 1),",
                "oscillation about OA (horizontal); measured = dynamic - static (the table's value negated).",
                note,
            ],
            rows: table_6_3_case()?,
        },
    ])
}

/// Write the case-frame files of the three tables into `dir`; returns the paths written.
///
/// # Errors
/// A transcription is malformed or a file cannot be written.
pub fn write_case_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for f in case_files()? {
        let p = dir.join(f.name);
        write_atomic(&p, to_csv(&f.rows, &f.comments).as_bytes())?;
        out.push(p);
    }
    Ok(out)
}

#[cfg(test)]
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;
    use crate::model::caseframe;

    /// The shipped `data/*.case.csv` equal the code's conversion. With
    /// `PTSA_WRITE_REPORT_DATA=1` the test rewrites them instead.
    #[test]
    fn shipped_case_files_match_the_conversion() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data");
        if std::env::var_os("PTSA_WRITE_REPORT_DATA").is_some() {
            write_case_files(&dir).unwrap();
        }
        for f in case_files().unwrap() {
            let shipped = std::fs::read_to_string(dir.join(f.name)).unwrap_or_else(|e| {
                panic!(
                    "data/{}: {e}; regenerate with `cargo xtask report-data`",
                    f.name
                )
            });
            assert_eq!(
                shipped,
                to_csv(&f.rows, &f.comments),
                "data/{} differs from the conversion",
                f.name
            );
            assert_eq!(caseframe::parse(f.name, &shipped).unwrap(), f.rows);
        }
    }

    #[test]
    fn the_transcriptions_hold_the_report_figures() {
        let s = section_6_1().unwrap();
        assert_eq!(
            (
                s.sf_cm_s2,
                s.bias_cm_s2,
                s.g_cm_s2,
                s.test_uncertainty_cm_s2
            ),
            (21121.1, 18.7, 980.4, 0.3)
        );
        let a = section_6_2().unwrap();
        assert_eq!((a.coefficient_cm, a.anisoinertia_g_cm2), (3.0, 3.4));
        assert_eq!((a.rate_rad_s, a.reference_rate_rad_s), (1.0, 0.05));
        let t = table_6_1().unwrap();
        assert_eq!(t.len(), 8);
        assert_eq!(
            t[2],
            Table61Row {
                ia_deg: 135.0,
                a_in_cm_s2: Some(-1.5)
            }
        );
        assert_eq!(table_6_2().unwrap().len(), 12);
        assert_eq!(table_6_3().unwrap().len(), 10);
    }

    #[test]
    fn geometry_of_the_tables() {
        let t = table_6_1_case().unwrap();
        assert_eq!(t.len(), 8);
        let r45 = &t[0];
        assert!(
            (r45.g[0] - 0.5f64.sqrt()).abs() < 1e-15
                && (r45.w_rad_s[1] - 0.5f64.sqrt()).abs() < 1e-15
        );
        assert_eq!(t[3].g, [0.0, -1.0, 0.0]); // 180°: IA horizontal, PA down
        assert_eq!(t[1].g, [1.0, 0.0, 0.0]); // 90°: IA up
        let t2 = table_6_2_case().unwrap();
        assert_eq!(t2.len(), 12);
        assert_eq!(t2.iter().filter(|r| r.measured_cm_s2.is_none()).count(), 3);
        assert_eq!(t2[0].measured_cm_s2, Some(0.03));
        assert_eq!(
            table_6_3_case()
                .unwrap()
                .iter()
                .filter(|r| r.measured_cm_s2.is_none())
                .count(),
            2
        );
    }
}
