//! The calibration sheet (`ptsa discover --sheet DIR`): one folder, written whole or not at
//! all, that a lab can file in an instrument's logbook. For a folder `DIR` named `NAME` it
//! holds
//!
//! * `NAME.md`: the sheet (the data file's name and SHA-256, the date in UTC, the instrument
//!   file's name and SHA-256, the analysis, the model equation with its values and its sign
//!   convention, the calibration table, the correlation of the measured terms, the design,
//!   the residual table, the verdict and the warnings, and the residual plot);
//! * `NAME.csv`: the calibration table (every key of `calibration.terms`), after `#` lines
//!   with the data file, the instrument file, their hashes and the date;
//! * `NAME-residuals.png` and `.svg`: each row's residual against the instrument's model
//!   (measured − extended) with its 1 σ.
//!
//! The date is the time of the run, or `SOURCE_DATE_EPOCH` (whole seconds since
//! 1970-01-01 UTC) when the environment sets it, so that a sheet can be reproduced byte for
//! byte.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

use super::calibration;
use super::outcome::Discovery;
use super::report::{Calibration, RowResult};
use crate::model::condition::{Condition, RowKind};
use crate::output::{Figure, Plot, Series, StagedDir, XAxis, significant};

/// Where `--sheet` goes and what it records of the instrument file.
#[derive(Clone, Debug)]
pub struct SheetOut {
    /// The folder to write (its name is the stem of the files in it).
    pub dir: PathBuf,
    /// The instrument file's name, as the run names it.
    pub instrument_name: String,
    /// Its text (hashed on the sheet).
    pub instrument_text: String,
    /// Replace an existing folder (`--force`); without it an existing `dir` is refused.
    pub replace: bool,
}

/// The SHA-256 digest of `bytes` (FIPS 180-4, the `sha2` crate of `RustCrypto`).
#[must_use]
pub fn sha256(bytes: &[u8]) -> [u8; 32] {
    use sha2::Digest as _;
    sha2::Sha256::digest(bytes).into()
}

/// `bytes` in lower-case hexadecimal.
#[must_use]
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().fold(String::new(), |mut s, b| {
        let _ = write!(s, "{b:02x}");
        s
    })
}

/// `YYYY-MM-DD hh:mm:ss UTC` of `secs` seconds since 1970-01-01 00:00:00 UTC (the proleptic
/// Gregorian calendar; days to a date by the civil-from-days algorithm).
#[must_use]
pub fn utc(secs: i64) -> String {
    let days = secs.div_euclid(86_400);
    let rest = secs.rem_euclid(86_400);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02}:{:02} UTC",
        rest / 3600,
        rest % 3600 / 60,
        rest % 60
    )
}

/// The sheet's time: `SOURCE_DATE_EPOCH` when set (whole seconds since 1970-01-01 UTC),
/// else now; and whether it came from the environment.
///
/// # Errors
/// `SOURCE_DATE_EPOCH` is set but not a whole number of seconds.
pub fn sheet_time() -> Result<(i64, bool)> {
    if let Some(v) = std::env::var_os("SOURCE_DATE_EPOCH") {
        let v = v.to_string_lossy();
        let secs: i64 = v.trim().parse().map_err(|_| {
            anyhow::anyhow!(
                "SOURCE_DATE_EPOCH={v}: expected whole seconds since 1970-01-01 00:00:00 UTC (or leave it unset for the time of the run)"
            )
        })?;
        return Ok((secs, true));
    }
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_secs()).unwrap_or(i64::MAX));
    Ok((now, false))
}

/// What the sheet records of its inputs.
pub struct Provenance<'a> {
    /// The data file as given.
    pub data: &'a Path,
    /// Its bytes as read.
    pub data_bytes: &'a [u8],
    /// The rows read from it.
    pub rows: &'a [Condition],
    /// The sheet's time, seconds since 1970-01-01 UTC, and whether from `SOURCE_DATE_EPOCH`.
    pub time: (i64, bool),
}

/// The file name of `p` (the whole path when it has none).
fn file_name(p: &Path) -> String {
    p.file_name().map_or_else(
        || p.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// A number for the sheet's tables: six significant digits, `—` for `None`.
fn cell(x: Option<f64>) -> String {
    x.map_or_else(|| "—".to_string(), |x| significant(x, 6))
}

/// The provenance every sheet carries, `(what, value)`: the data file (`data_what`: its
/// name and size in words) and its SHA-256, the instrument file's name and SHA-256, the
/// date (`time`: seconds since 1970-01-01 UTC, and whether from `SOURCE_DATE_EPOCH`); the
/// triad's sheet and calibration file too.
#[must_use]
pub fn provenance(
    data_what: String,
    data_bytes: &[u8],
    instrument: (&str, &str),
    time: (i64, bool),
) -> Vec<(&'static str, String)> {
    vec![
        ("data file", data_what),
        ("data SHA-256", hex(&sha256(data_bytes))),
        ("instrument file", instrument.0.to_string()),
        ("instrument SHA-256", hex(&sha256(instrument.1.as_bytes()))),
        (
            "date",
            format!(
                "{}{}",
                utc(time.0),
                if time.1 { " (SOURCE_DATE_EPOCH)" } else { "" }
            ),
        ),
    ]
}

/// The header lines both files carry: `(what, value)`.
fn header(out: &SheetOut, p: &Provenance<'_>, d: &Discovery) -> Vec<(&'static str, String)> {
    let mut v = provenance(
        format!("{} ({} rows)", file_name(p.data), p.rows.len()),
        p.data_bytes,
        (&out.instrument_name, &out.instrument_text),
        p.time,
    );
    v.push((
        "analysis",
        format!(
            "ptsa discover {} ({} simulator; {} fitted observations)",
            env!("CARGO_PKG_VERSION"),
            d.simulator,
            d.json.rows
        ),
    ));
    v
}

/// The sheet in Markdown (`NAME.md`), with the residual plot `plot` (a file name beside it).
#[must_use]
pub fn markdown(
    out: &SheetOut,
    p: &Provenance<'_>,
    d: &Discovery,
    c: &Calibration,
    plot: &str,
) -> String {
    let mut s = String::from("# Calibration sheet\n\n| | |\n|---|---|\n");
    for (k, v) in header(out, p, d) {
        let _ = writeln!(s, "| {k} | `{v}` |");
    }
    let _ = write!(
        s,
        "\n## Model equation (IEEE Std 1293, pendulous accelerometer)\n\n    {}\n\nWith this instrument's values (the terms not written are nominal 0):\n\n    {}\n\n",
        c.equation,
        calibration::equation_with_values(c)
    );
    let _ = writeln!(
        s,
        "Signs: δ_o is the tilt of IA toward PA (a rotation about OA) and enters as + δ_o·a_p; δ_p is the tilt of IA toward OA (about PA) and enters as − δ_p·a_o; each is given as itself. {}.\n",
        c.scale_factor
    );
    let _ = writeln!(
        s,
        "## Calibration\n\nAbsolute values (the instrument file's nominal value plus the change these data measure), 1 σ and the expanded uncertainty with k = 2; noise {}, {} residual degrees of freedom. A term marked nominal is not measured by these data.\n",
        c.noise, c.dof
    );
    if let Some(m) = super::verdict::misfit_sentence(&d.json.fit_check, d.json.unexplained.detected)
    {
        let _ = writeln!(s, "**{m}**\n");
    }
    s.push_str(&calibration::table("calibration", c).to_markdown());
    for n in calibration::show::statements(c) {
        let _ = writeln!(s, "\nNote: {n}");
    }
    correlation_table(&mut s, c);
    s.push_str(
        "\n## Design\n\nEach row's kind and gravity's specific force along IA, PA, OA with the case at rest (g).\n\n| row | kind | g_IA | g_PA | g_OA |\n|---|---|---|---|---|\n",
    );
    table_rows(&mut s, p.rows.iter().map(design_row));
    s.push_str(
        "\n## Residuals\n\nMeasured against the instrument's model (baseline, nuisance terms and the selected terms), cm/s² (a response row's gain and phase in their own units).\n\n| row | measured | 1 σ | model | residual | residual/σ | set aside |\n|---|---|---|---|---|---|---|\n",
    );
    table_rows(&mut s, d.table.iter().map(residual_row));
    let _ = writeln!(
        s,
        "\n![residuals]({plot})\n\n## Verdict\n\n{}",
        d.json.verdict
    );
    if !d.json.warnings.is_empty() {
        s.push_str("\n## Warnings\n\n");
        for w in &d.json.warnings {
            let _ = writeln!(s, "* {w}");
        }
    }
    s
}

/// `rows` as the body of a Markdown table, one line `| a | b | … |` each.
fn table_rows(s: &mut String, rows: impl Iterator<Item = Vec<String>>) {
    for row in rows {
        s.push('|');
        for c in row {
            let _ = write!(s, " {c} |");
        }
        s.push('\n');
    }
}

/// The design table's row of `r`: its label, its kind and gravity's specific force along
/// IA, PA, OA (g).
fn design_row(r: &Condition) -> Vec<String> {
    let kind = match r.kind {
        RowKind::Absolute => "absolute",
        RowKind::Difference => "difference",
        RowKind::Response => "response",
    };
    let mut row = vec![r.label.clone(), kind.to_string()];
    row.extend(r.g.iter().map(|&g| significant(g, 6)));
    row
}

/// The residual table's row of `r`: measured, 1 σ, the model's value, the residual, the
/// residual over σ, and whether it was set aside.
fn residual_row(r: &RowResult) -> Vec<String> {
    let res = r.residual_extended_cm_s2;
    vec![
        r.label.clone(),
        cell(r.measured_cm_s2),
        cell(Some(r.sigma_cm_s2)),
        cell(Some(r.extended_cm_s2)),
        cell(res),
        res.map_or_else(|| "—".into(), |x| format!("{:+.2}", x / r.sigma_cm_s2)),
        if r.outlier { "yes" } else { "" }.to_string(),
    ]
}

/// The correlation of the measured terms, when more than one is measured: a table with a
/// row and a column per term.
fn correlation_table(s: &mut String, c: &Calibration) {
    let measured: Vec<usize> = (0..c.terms.len())
        .filter(|&i| c.terms[i].measured)
        .collect();
    if measured.len() <= 1 {
        return;
    }
    s.push_str("\n## Correlation of the measured terms\n\n| |");
    for &i in &measured {
        let _ = write!(s, " {} |", c.terms[i].symbol);
    }
    s.push_str("\n|---|");
    s.push_str(&"---|".repeat(measured.len()));
    s.push('\n');
    table_rows(
        s,
        measured.iter().map(|&i| {
            let mut row = vec![c.terms[i].symbol.clone()];
            row.extend(
                measured.iter().map(|&j| {
                    c.correlation[i][j].map_or_else(|| "—".into(), |r| format!("{r:+.3}"))
                }),
            );
            row
        }),
    );
}

/// The calibration table as CSV (`NAME.csv`): `#` lines with the provenance, then one row
/// per term with every key of `calibration.terms`.
///
/// # Errors
/// Never in practice (in-memory writer).
pub fn csv(out: &SheetOut, p: &Provenance<'_>, d: &Discovery, c: &Calibration) -> Result<String> {
    let mut s = String::new();
    for (k, v) in header(out, p, d) {
        let _ = writeln!(s, "# {k}: {v}");
    }
    let _ = writeln!(s, "# model equation: {}", c.equation);
    for n in calibration::show::statements(c) {
        let _ = writeln!(s, "# note: {n}");
    }
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "symbol",
        "candidate",
        "value",
        "sigma",
        "expanded_k2",
        "unit",
        "nominal",
        "change",
        "change_sigma",
        "change_unit",
        "value_cgs",
        "sigma_cgs",
        "unit_cgs",
        "measured",
        "status",
        "marks",
    ])?;
    let o = |x: Option<f64>| x.map_or_else(String::new, |x| format!("{x}"));
    for t in &c.terms {
        w.write_record([
            t.symbol.clone(),
            t.candidate.clone(),
            format!("{}", t.value),
            o(t.sigma),
            o(t.expanded_k2),
            t.unit.clone(),
            format!("{}", t.nominal),
            format!("{}", t.change),
            o(t.change_sigma),
            t.change_unit.clone(),
            format!("{}", t.value_cgs),
            o(t.sigma_cgs),
            t.unit_cgs.clone(),
            t.measured.to_string(),
            t.status.to_string(),
            t.marks.join(";"),
        ])?;
    }
    s.push_str(&String::from_utf8(w.into_inner()?)?);
    Ok(s)
}

/// The residual plot: each measured row's `measured − extended` with its 1 σ.
#[must_use]
pub fn residual_figure(stem: &str, d: &Discovery) -> Figure {
    let rows: Vec<_> = d
        .table
        .iter()
        .filter(|r| r.residual_extended_cm_s2.is_some())
        .collect();
    #[allow(clippy::cast_precision_loss)]
    let pts: Vec<(f64, f64)> = rows
        .iter()
        .enumerate()
        .filter_map(|(i, r)| Some((i as f64, r.residual_extended_cm_s2?)))
        .collect();
    Figure::single(
        stem,
        Plot {
            title: format!("{stem}: residual against the instrument's model, ± 1 σ"),
            x_label: "row".into(),
            y_label: "measured − model, cm/s²".into(),
            series: vec![
                Series::crosses("residual ± 1 σ", pts)
                    .with_error_bars(rows.iter().map(|r| r.sigma_cm_s2).collect()),
            ],
            x_axis: XAxis::Rows(rows.iter().map(|r| r.label.clone()).collect()),
            zero_line: true,
        },
    )
}

/// Whether the sheet may be written at `dir` (checked before the analysis and again before
/// the write): a new folder; an existing one only with `replace` (`--force`), and only when
/// it is empty or an earlier sheet (it holds `NAME.md` and `NAME.csv`, `NAME` its name), so
/// that no folder of other files is ever replaced. Returns whether one will be replaced.
///
/// # Errors
/// `dir` is a file, or an existing folder without `replace`, or one that is not an earlier
/// sheet.
pub fn check_target(dir: &Path, replace: bool) -> Result<bool> {
    let Ok(meta) = std::fs::symlink_metadata(dir) else {
        return Ok(false);
    };
    if !meta.is_dir() {
        bail!(
            "--sheet {}: this is a file; expected a folder for the sheet (or a name for a new one)",
            dir.display()
        );
    }
    if !replace {
        bail!(
            "--sheet {}: the folder exists and is not replaced without --force (expected a new folder name, or --force to replace an earlier sheet)",
            dir.display()
        );
    }
    let name = file_name(dir);
    let empty = std::fs::read_dir(dir).map_or(true, |mut d| d.next().is_none());
    let earlier =
        dir.join(format!("{name}.md")).is_file() && dir.join(format!("{name}.csv")).is_file();
    if !empty && !earlier {
        bail!(
            "--sheet {}: an existing folder that is not an earlier sheet (it has no {name}.md and {name}.csv); the sheet replaces its folder as a whole and would delete what is in it: expected a new folder, an empty one or an earlier sheet",
            dir.display()
        );
    }
    Ok(true)
}

/// Write the sheet folder whole (a staged folder renamed into place): refused when the folder
/// exists and `out.replace` is off, or when the discovery has no calibration.
///
/// # Errors
/// As above; a file cannot be written (nothing appears then).
pub fn write(out: &SheetOut, p: &Provenance<'_>, d: &Discovery) -> Result<Vec<PathBuf>> {
    let Some(c) = d.json.calibration.as_ref() else {
        bail!(
            "--sheet {}: the simulator has no instrument file, so there is no calibration to write",
            out.dir.display()
        );
    };
    check_target(&out.dir, out.replace)?;
    let name = file_name(&out.dir);
    let staged = StagedDir::new(&out.dir)?;
    let plot_stem = format!("{name}-residuals");
    let mut files = crate::output::write_figure(staged.path(), &residual_figure(&plot_stem, d))?;
    let md = staged.path().join(format!("{name}.md"));
    crate::output::write_atomic(
        &md,
        markdown(out, p, d, c, &format!("{plot_stem}.svg")).as_bytes(),
    )?;
    let csv_path = staged.path().join(format!("{name}.csv"));
    crate::output::write_atomic(&csv_path, csv(out, p, d, c)?.as_bytes())?;
    files.extend([md, csv_path]);
    let dir = staged
        .commit()
        .with_context(|| format!("--sheet {}", out.dir.display()))?;
    Ok(files
        .iter()
        .filter_map(|f| f.file_name().map(|n| dir.join(n)))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The published test vectors of FIPS 180-2 (Appendix B) and the empty message.
    #[test]
    fn sha256_gives_the_published_digests() {
        assert_eq!(
            hex(&sha256(b"abc")),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        assert_eq!(
            hex(&sha256(b"")),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"
        );
        assert_eq!(
            hex(&sha256(
                b"abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"
            )),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1"
        );
        // A million `a`s: many blocks.
        assert_eq!(
            hex(&sha256(&vec![b'a'; 1_000_000])),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0"
        );
    }

    #[test]
    fn utc_dates_of_known_instants() {
        assert_eq!(utc(0), "1970-01-01 00:00:00 UTC");
        assert_eq!(utc(951_782_400), "2000-02-29 00:00:00 UTC");
        assert_eq!(utc(1_700_000_000), "2023-11-14 22:13:20 UTC");
        assert_eq!(utc(-1), "1969-12-31 23:59:59 UTC");
    }
}
