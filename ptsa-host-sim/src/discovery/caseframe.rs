//! The case-frame CSV format (`docs/case-frame.md`): reader and writer.
//!
//! One row is one test condition ([`Condition`]). The file has a header; any column may be
//! left out (a missing column means 0, or "not given" for `measured_cm_s2` and
//! `sigma_cm_s2`); an unknown or repeated column is an error; a bad value is an error that
//! names the file, the line, the column and what was expected. Lines whose first character
//! is `#` are comments (the shipped files cite their source there). An empty cell means 0 in
//! an input column, "not measured" in `measured_cm_s2` (the row is kept but not fitted, as
//! the resonance rows of Tables 6.2/6.3) and "use `--sigma`" in `sigma_cm_s2`.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result, bail};

use crate::condition::Condition;

/// Every column of the format, in the order the writer uses.
pub const COLUMNS: [&str; 25] = [
    "label",
    "g_ia",
    "g_pa",
    "g_oa",
    "w_ia_rad_s",
    "w_pa_rad_s",
    "w_oa_rad_s",
    "freq_hz",
    "lin_ia_cm_s2",
    "lin_pa_cm_s2",
    "lin_oa_cm_s2",
    "lin_ia_deg",
    "lin_pa_deg",
    "lin_oa_deg",
    "ang_ia_mrad",
    "ang_pa_mrad",
    "ang_oa_mrad",
    "ang_ia_deg",
    "ang_pa_deg",
    "ang_oa_deg",
    "ref_w_ia_rad_s",
    "ref_w_pa_rad_s",
    "ref_w_oa_rad_s",
    "measured_cm_s2",
    "sigma_cm_s2",
];

/// What each numeric column must hold (used in error messages).
fn expectation(col: usize) -> &'static str {
    match COLUMNS[col] {
        "freq_hz" => "a finite number of hertz, 0 or more",
        "sigma_cm_s2" => "a finite number of cm/s² greater than 0, or an empty cell",
        "measured_cm_s2" => "a finite number of cm/s², or an empty cell (not measured)",
        "ang_ia_mrad" | "ang_pa_mrad" | "ang_oa_mrad" => {
            "a finite angle amplitude in mrad (an empty cell means 0)"
        }
        _ => "a finite number (an empty cell means 0)",
    }
}

fn set_value(c: &mut Condition, col: usize, v: f64) {
    match col {
        1..=3 => c.g[col - 1] = v,
        4..=6 => c.w_rad_s[col - 4] = v,
        7 => c.freq_hz = v,
        8..=10 => c.lin_cm_s2[col - 8] = v,
        11..=13 => c.lin_deg[col - 11] = v,
        14..=16 => c.ang_mrad[col - 14] = v,
        17..=19 => c.ang_deg[col - 17] = v,
        20..=22 => c.ref_w_rad_s[col - 20] = v,
        23 => c.measured_cm_s2 = Some(v),
        24 => c.sigma_cm_s2 = Some(v),
        _ => {}
    }
}

fn get_value(c: &Condition, col: usize) -> Option<f64> {
    Some(match col {
        1..=3 => c.g[col - 1],
        4..=6 => c.w_rad_s[col - 4],
        7 => c.freq_hz,
        8..=10 => c.lin_cm_s2[col - 8],
        11..=13 => c.lin_deg[col - 11],
        14..=16 => c.ang_mrad[col - 14],
        17..=19 => c.ang_deg[col - 17],
        20..=22 => c.ref_w_rad_s[col - 20],
        23 => return c.measured_cm_s2,
        24 => return c.sigma_cm_s2,
        _ => return None,
    })
}

/// Parse case-frame CSV text. `name` is the file name used in error messages.
///
/// # Errors
/// A missing or bad header, an unknown or repeated column, a row with the wrong number of
/// cells, a value that is not what the column expects, or an oscillation amplitude in a row
/// whose `freq_hz` is 0: each error names `name`, the 1-based line and the column.
pub fn parse(name: &str, text: &str) -> Result<Vec<Condition>> {
    let mut header: Option<Vec<usize>> = None;
    let mut rows = Vec::new();
    for (idx, raw) in text.lines().enumerate() {
        let line = idx + 1;
        let trimmed = raw.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        let cells =
            split_csv_line(raw).with_context(|| format!("{name}:{line}: malformed CSV line"))?;
        let Some(cols) = &header else {
            let mut cols = Vec::with_capacity(cells.len());
            for (i, cell) in cells.iter().enumerate() {
                let cell = cell.trim();
                let Some(k) = COLUMNS.iter().position(|c| *c == cell) else {
                    bail!(
                        "{name}:{line}: column {} of the header is `{cell}`, which is not a \
                         case-frame column; expected one of: {}",
                        i + 1,
                        COLUMNS.join(", ")
                    );
                };
                if cols.contains(&k) {
                    bail!("{name}:{line}: column `{cell}` appears twice in the header");
                }
                cols.push(k);
            }
            header = Some(cols);
            continue;
        };
        if cells.len() != cols.len() {
            bail!(
                "{name}:{line}: {} cells, expected {} (one per header column)",
                cells.len(),
                cols.len()
            );
        }
        let mut c = Condition::default();
        for (j, (cell, &k)) in cells.iter().zip(cols).enumerate() {
            if k == 0 {
                c.label = cell.clone();
                continue;
            }
            let s = cell.trim();
            if s.is_empty() {
                continue;
            }
            let v: f64 = match s.parse() {
                Ok(v) if f64::is_finite(v) => v,
                _ => bail!(
                    "{name}:{line}: column {} (`{}`) holds `{s}`; expected {}",
                    j + 1,
                    COLUMNS[k],
                    expectation(k)
                ),
            };
            if (k == 7 && v < 0.0) || (k == 24 && v <= 0.0) {
                bail!(
                    "{name}:{line}: column {} (`{}`) holds `{s}`; expected {}",
                    j + 1,
                    COLUMNS[k],
                    expectation(k)
                );
            }
            set_value(&mut c, k, v);
        }
        if c.freq_hz == 0.0 {
            for (j, axis) in ["ia", "pa", "oa"].iter().enumerate() {
                if c.lin_cm_s2[j] != 0.0 {
                    bail!(
                        "{name}:{line}: column `lin_{axis}_cm_s2` is {} but `freq_hz` is 0; \
                         expected a frequency greater than 0 for an oscillation",
                        c.lin_cm_s2[j]
                    );
                }
                if c.ang_mrad[j] != 0.0 {
                    bail!(
                        "{name}:{line}: column `ang_{axis}_mrad` is {} but `freq_hz` is 0; \
                         expected a frequency greater than 0 for an oscillation",
                        c.ang_mrad[j]
                    );
                }
            }
        }
        if c.label.is_empty() {
            c.label = format!("line {line}");
        }
        rows.push(c);
    }
    if header.is_none() {
        bail!("{name}: no header line; expected a CSV header of case-frame columns");
    }
    Ok(rows)
}

/// Split one CSV line into cells (RFC 4180 quoting: `"a,b"` and `""` inside quotes).
fn split_csv_line(line: &str) -> Result<Vec<String>> {
    let mut cells = Vec::new();
    let mut cur = String::new();
    let mut chars = line.chars().peekable();
    let mut quoted = false;
    let mut at_start = true;
    while let Some(ch) = chars.next() {
        if quoted {
            if ch == '"' {
                if chars.peek() == Some(&'"') {
                    chars.next();
                    cur.push('"');
                } else {
                    quoted = false;
                }
            } else {
                cur.push(ch);
            }
        } else if ch == '"' && at_start {
            quoted = true;
            at_start = false;
        } else if ch == ',' {
            cells.push(std::mem::take(&mut cur));
            at_start = true;
        } else if ch != '\r' {
            cur.push(ch);
            if !ch.is_whitespace() {
                at_start = false;
            }
        }
    }
    if quoted {
        bail!("unterminated quoted cell");
    }
    cells.push(cur);
    Ok(cells)
}

/// Read a case-frame file.
///
/// # Errors
/// The file cannot be read, or [`parse`] fails (the message names the file).
pub fn read(path: &Path) -> Result<Vec<Condition>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    parse(&path.display().to_string(), &text)
}

fn fmt_num(v: f64) -> String {
    if v == 0.0 {
        "0".to_string()
    } else {
        format!("{v}")
    }
}

/// Render rows as case-frame CSV: `comments` (each line prefixed with `# `), the header
/// (columns that are zero in every row are left out, except `label` and
/// `measured_cm_s2`), then one line per row.
#[must_use]
pub fn to_csv(rows: &[Condition], comments: &[&str]) -> String {
    let used: Vec<usize> = (0..COLUMNS.len())
        .filter(|&k| {
            k == 0
                || k == 23
                || rows.iter().any(|c| {
                    get_value(c, k).is_some_and(|v| v != 0.0)
                        || (k == 24 && c.sigma_cm_s2.is_some())
                })
        })
        .collect();
    let mut out = String::new();
    for c in comments {
        let _ = writeln!(out, "# {c}");
    }
    let names: Vec<&str> = used.iter().map(|&k| COLUMNS[k]).collect();
    let _ = writeln!(out, "{}", names.join(","));
    for c in rows {
        let cells: Vec<String> = used
            .iter()
            .map(|&k| {
                if k == 0 {
                    quote(&c.label)
                } else {
                    get_value(c, k).map(fmt_num).unwrap_or_default()
                }
            })
            .collect();
        let _ = writeln!(out, "{}", cells.join(","));
    }
    out
}

fn quote(s: &str) -> String {
    if s.contains([',', '"', '\n']) || s.starts_with('#') || s.trim() != s {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Write text to `path` atomically (a temporary file renamed into place), so a failure
/// leaves nothing half-written.
///
/// # Errors
/// The directory cannot be created or the file cannot be written.
pub fn write_atomic(path: &Path, text: &str) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let tmp = path.with_extension("tmp-write");
    std::fs::write(&tmp, text).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}

#[cfg(test)]
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_every_field() {
        let c = Condition {
            label: "a, \"quoted\" row".into(),
            g: [0.5, -0.25, 0.0],
            w_rad_s: [0.1, 0.2, 0.3],
            freq_hz: 10.0,
            lin_cm_s2: [100.0, 0.0, 50.0],
            lin_deg: [0.0, 0.0, 90.0],
            ang_mrad: [0.0, 0.0, 2.0],
            ang_deg: [0.0, 0.0, 45.0],
            ref_w_rad_s: [0.0, 0.05, 0.0],
            measured_cm_s2: Some(1.25),
            sigma_cm_s2: Some(0.2),
        };
        let text = to_csv(std::slice::from_ref(&c), &["test"]);
        let back = parse("t.csv", &text).unwrap();
        assert_eq!(back, vec![c]);
    }

    #[test]
    fn missing_columns_are_zero_and_missing_measurement_is_none() {
        let rows = parse("t.csv", "label,g_ia,measured_cm_s2\nx,1,\n").unwrap();
        assert_eq!(rows[0].g, [1.0, 0.0, 0.0]);
        assert_eq!(rows[0].measured_cm_s2, None);
        assert_eq!(rows[0].sigma_cm_s2, None);
    }

    #[test]
    fn errors_name_file_line_column_and_expectation() {
        let e = parse("bad.csv", "# c\ng_ia,measured_cm_s2\n1,0.5\n1,abc\n").unwrap_err();
        let m = format!("{e:#}");
        assert!(
            m.contains("bad.csv:4: column 2 (`measured_cm_s2`)") && m.contains("expected"),
            "{m}"
        );
        let e = parse("bad.csv", "g_ia,bogus\n1,2\n").unwrap_err();
        assert!(format!("{e:#}").contains("bogus"));
        let e = parse("bad.csv", "g_ia,sigma_cm_s2\n1,0\n").unwrap_err();
        assert!(format!("{e:#}").contains("greater than 0"));
        let e = parse("bad.csv", "g_ia,lin_ia_cm_s2\n1,3\n").unwrap_err();
        assert!(format!("{e:#}").contains("freq_hz"));
        let e = parse("bad.csv", "g_ia,g_ia\n1,3\n").unwrap_err();
        assert!(format!("{e:#}").contains("twice"));
        let e = parse("bad.csv", "g_ia,g_pa\n1\n").unwrap_err();
        assert!(format!("{e:#}").contains("bad.csv:2"));
    }
}
