//! The triad file (`docs/reference/case-frame-format.md`, "A triad"): one calibration of three
//! accelerometers on one block, one row per position, read with the case-frame's CSV rules
//! and errors (`model::caseframe::records`).
//!
//! Columns: `g_x`, `g_y`, `g_z` (the block's nominal gravity in g, block frame: the input
//! the three axes feel, as `g_ia` is for a single axis), `measured_x_cm_s2`,
//! `measured_y_cm_s2`, `measured_z_cm_s2` (each axis's reading through its nominal scale
//! factor, cm/s²; an empty cell: that axis not measured in that position) or, per axis,
//! its counts over its gate, `pulses_x` with `ticks_x` (and `_y`, `_z`; read as
//! `SF·(2P/T − 1)` with the instrument file's nominal scale factor, [`with_counts`],
//! through `model::counts`, and checked as the case frame's `pulses` and `ticks` are), and
//! optional `label`, `time_s`, `sigma_cm_s2` (1 σ of each of the row's three readings) and
//! `sigma_angle_urad` (1 σ of the fixture's orientation about each axis, µrad). An axis of
//! a row gives its measured column or its counts, never both. A file that mixes these with
//! a single-axis case-frame column (`g_ia`, `measured_cm_s2`, …) is refused: it is one kind
//! of file or the other.

use std::path::Path;

use anyhow::{Context as _, Result, bail};

use crate::model::caseframe::{self, COLUMNS};

/// The columns that make a file a triad file (none of them is a case-frame column; the
/// triad's other columns, `label`, `time_s`, `sigma_cm_s2` and `sigma_angle_urad`, are
/// also the case-frame's).
pub const TRIAD_ONLY: &[&str] = &[
    "g_x",
    "g_y",
    "g_z",
    "measured_x_cm_s2",
    "measured_y_cm_s2",
    "measured_z_cm_s2",
    "pulses_x",
    "ticks_x",
    "pulses_y",
    "ticks_y",
    "pulses_z",
    "ticks_z",
];

/// Every column of a triad file, in the order the writer uses.
pub const TRIAD_COLUMNS: &[&str] = &[
    "label",
    "time_s",
    "g_x",
    "g_y",
    "g_z",
    "measured_x_cm_s2",
    "measured_y_cm_s2",
    "measured_z_cm_s2",
    "pulses_x",
    "ticks_x",
    "pulses_y",
    "ticks_y",
    "pulses_z",
    "ticks_z",
    "sigma_cm_s2",
    "sigma_angle_urad",
];

/// The columns every triad file has: the gravity, and per axis its measured column or its
/// counts ([`AXIS_COLUMNS`]).
const REQUIRED: &[&str] = &[
    "g_x",
    "g_y",
    "g_z",
    "measured_x_cm_s2",
    "measured_y_cm_s2",
    "measured_z_cm_s2",
];

/// Per axis (x, y, z): its measured column, then its counts' (`pulses_*`, `ticks_*`).
pub const AXIS_COLUMNS: [[&str; 3]; 3] = [
    ["measured_x_cm_s2", "pulses_x", "ticks_x"],
    ["measured_y_cm_s2", "pulses_y", "ticks_y"],
    ["measured_z_cm_s2", "pulses_z", "ticks_z"],
];

/// How far the nominal gravity's magnitude may be from 1 g (its direction is used).
pub const G_MAGNITUDE_TOLERANCE: f64 = 0.01;

/// One position of the block: one row of a triad file.
#[derive(Clone, Debug, PartialEq)]
pub struct Position {
    /// The row's label (`line N` when the file gives none).
    pub label: String,
    /// Its 1-based line in the file.
    pub line: usize,
    /// Its time, s, if given.
    pub time_s: Option<f64>,
    /// The nominal gravity as written, g, block frame.
    pub g_nominal: [f64; 3],
    /// Its direction (unit vector): what the fit uses, with the instrument file's local
    /// gravity as its magnitude.
    pub g_unit: [f64; 3],
    /// The three axes' readings, cm/s² (`None`: not measured; an axis given as counts
    /// has its reading once [`with_counts`] has converted them).
    pub measured: [Option<f64>; 3],
    /// Each axis's counts over its gate as read, `[pulses, ticks]` (`None`: not counted).
    pub counts: [Option<[f64; 2]>; 3],
    /// Each counted axis's counting error, cm/s² (1 σ, `model::counts`), once
    /// [`with_counts`] has converted its counts; it adds to the reading's stated sigma in
    /// quadrature.
    pub counting_sigma_cm_s2: [Option<f64>; 3],
    /// 1 σ of each reading of the row, cm/s², if given.
    pub sigma_cm_s2: Option<f64>,
    /// 1 σ of the fixture's orientation about each axis, rad, if given.
    pub sigma_angle_rad: Option<f64>,
}

impl Position {
    /// Whether any axis is measured (its reading given, or its counts).
    #[must_use]
    pub fn is_measured(&self) -> bool {
        self.measured.iter().any(Option::is_some) || self.counts.iter().any(Option::is_some)
    }

    /// The first axis whose counts are not yet converted to its reading ([`with_counts`]).
    #[must_use]
    pub fn unconverted(&self) -> Option<usize> {
        (0..3).find(|&j| self.counts[j].is_some() && self.measured[j].is_none())
    }
}

/// The positions with every axis given as counts turned into its reading
/// `SF·(2P/T − 1)` and its counting error, with the instrument file's nominal scale
/// factor `sf_cm_s2` (cm/s²): the single-axis rows' conversion (`model::counts`). The
/// counts stay in the positions.
pub fn with_counts(positions: &mut [Position], sf_cm_s2: f64) {
    use crate::model::counts::{counting_sigma_cm_s2, indicated_cm_s2};
    for p in positions {
        for j in 0..3 {
            if let Some([pulses, ticks]) = p.counts[j] {
                p.measured[j] = Some(indicated_cm_s2(pulses, ticks, sf_cm_s2));
                p.counting_sigma_cm_s2[j] = Some(counting_sigma_cm_s2(ticks, sf_cm_s2));
            }
        }
    }
}

/// Whether `bytes` are a triad file: its header names one of [`TRIAD_ONLY`].
#[must_use]
pub fn is_triad(bytes: &[u8]) -> bool {
    caseframe::header_cells(bytes)
        .iter()
        .any(|c| TRIAD_ONLY.contains(&c.as_str()))
}

/// Whether the file at `path` is a triad file (false when it cannot be read: the reader
/// that follows says why).
#[must_use]
pub fn is_triad_file(path: &Path) -> bool {
    std::fs::read(path).is_ok_and(|b| is_triad(&b))
}

/// Read a triad file.
///
/// # Errors
/// The file cannot be read, or [`parse_bytes`] fails.
pub fn read(path: &Path) -> Result<Vec<Position>> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    parse_bytes(&path.display().to_string(), &bytes)
}

/// Parse the bytes of a triad file; `name` names it in the errors.
///
/// # Errors
/// The case-frame's CSV errors (encoding, malformed lines, cell counts); a header cell that
/// is not a triad column, a repeated one, a single-axis case-frame column beside the triad
/// ones, a missing required column; a cell that is not what its column expects; a nominal
/// gravity whose magnitude is not 1 g within 1 %; no measured row. Each error names `name`,
/// the line and, for a cell, the column.
pub fn parse_bytes(name: &str, bytes: &[u8]) -> Result<Vec<Position>> {
    parse(name, bytes, false)
}

/// Read a triad record to correct (`ptsa correct`): a triad file whose gravity columns
/// are not needed (the specific force is what the correction recovers; given, they are
/// read as numbers and not used).
///
/// # Errors
/// As [`parse_bytes`], less the gravity's columns and magnitude.
pub fn read_record(path: &Path) -> Result<Vec<Position>> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    parse(&path.display().to_string(), &bytes, true)
}

/// [`parse_bytes`], or with `record` a record to correct.
fn parse(name: &str, bytes: &[u8], record: bool) -> Result<Vec<Position>> {
    let (header, at, records) = caseframe::records(
        name,
        bytes,
        "triad columns (g_x, g_y, g_z, measured_x_cm_s2, measured_y_cm_s2, measured_z_cm_s2 or pulses_x, ticks_x, ..., ...)",
    )?;
    let line = header.line;
    let mut cols: Vec<&'static str> = Vec::with_capacity(header.cells.len());
    for (i, cell) in header.cells.iter().enumerate() {
        let cell = cell.trim();
        let place = at
            .get(i)
            .copied()
            .flatten()
            .map_or(String::new(), |c| format!(":{c}"));
        let Some(&k) = TRIAD_COLUMNS.iter().find(|&&c| c == cell) else {
            if COLUMNS.iter().any(|c| c.name == cell) {
                bail!(
                    "{name}:{line}{place}: column {} of the header is `{cell}`, a single-axis \
                     case-frame column, in a triad file (its header has {}); expected one kind \
                     of file: a triad file of {} only, or a single-axis case-frame file \
                     (docs/reference/case-frame-format.md)",
                    i + 1,
                    header
                        .cells
                        .iter()
                        .map(|c| c.trim())
                        .filter(|c| TRIAD_ONLY.contains(c))
                        .map(|c| format!("`{c}`"))
                        .collect::<Vec<_>>()
                        .join(", "),
                    TRIAD_COLUMNS.join(", ")
                );
            }
            bail!(
                "{name}:{line}{place}: column {} of the header is `{cell}`, which is not a \
                 triad column; expected one of: {}",
                i + 1,
                TRIAD_COLUMNS.join(", ")
            );
        };
        if cols.contains(&k) {
            bail!("{name}:{line}{place}: column `{cell}` appears twice in the header");
        }
        cols.push(k);
    }
    // An axis is in the header by its measured column or by either of its counts' (a
    // count without its partner is refused row by row, as in the case frame).
    let missing: Vec<&str> = REQUIRED
        .iter()
        .copied()
        .filter(|c| !(record && c.starts_with("g_")))
        .filter(|c| {
            !cols.contains(c)
                && AXIS_COLUMNS
                    .iter()
                    .find(|a| a[0] == *c)
                    .is_none_or(|a| !cols.contains(&a[1]) && !cols.contains(&a[2]))
        })
        .collect();
    if !missing.is_empty() {
        bail!(
            "{name}:{line}: the triad header has no {}; expected all of {} (the block's \
             nominal gravity in g and the three axes' readings in cm/s²; an axis may give \
             its counts instead, pulses_x with ticks_x, ...)",
            missing
                .iter()
                .map(|c| format!("`{c}`"))
                .collect::<Vec<_>>()
                .join(", "),
            REQUIRED.join(", ")
        );
    }
    let mut rows = Vec::with_capacity(records.len());
    for r in &records {
        rows.push(parse_row(name, r.line, &r.cells, &cols, record)?);
    }
    if !rows.iter().any(Position::is_measured) {
        bail!(
            "{name}: no row has a measurement; expected `measured_x_cm_s2`, \
             `measured_y_cm_s2` or `measured_z_cm_s2` (or an axis's counts) filled in on at \
             least one row"
        );
    }
    Ok(rows)
}

/// What a cell of `col` must hold, for the errors.
fn expected(col: &str) -> &'static str {
    match col {
        "time_s" => "a finite time in seconds, or an empty cell",
        "g_x" | "g_y" | "g_z" => {
            "a finite number of g, the nominal gravity along the block's axis (an empty cell means 0)"
        }
        "sigma_cm_s2" => "a finite number of cm/s² greater than 0, or an empty cell",
        "sigma_angle_urad" => "a finite number of µrad greater than 0, or an empty cell",
        "pulses_x" | "pulses_y" | "pulses_z" => count_expected("pulses"),
        "ticks_x" | "ticks_y" | "ticks_z" => count_expected("ticks"),
        _ => "a finite number of cm/s², or an empty cell (not measured)",
    }
}

/// What a count cell must hold: the case frame's `pulses` or `ticks` column's words.
fn count_expected(col: &str) -> &'static str {
    COLUMNS
        .iter()
        .find(|c| c.name == col)
        .map_or("a whole number, or an empty cell", |c| c.expected)
}

/// One data row.
fn parse_row(
    name: &str,
    line: usize,
    cells: &[String],
    cols: &[&str],
    record: bool,
) -> Result<Position> {
    let (mut p, counts) = read_cells(name, line, cells, cols)?;
    take_counts(name, cols, counts, &mut p)?;
    gravity_direction(name, record, &mut p)?;
    if p.label.is_empty() {
        p.label = format!("line {line}");
    }
    Ok(p)
}

/// Each axis's counts as read: pulses, ticks.
type RawCounts = [[Option<f64>; 2]; 3];

/// The cells of the row at `line` read into a position, each checked against what its
/// column expects; the counts as read are returned beside it, not yet checked.
fn read_cells(
    name: &str,
    line: usize,
    cells: &[String],
    cols: &[&str],
) -> Result<(Position, RawCounts)> {
    let mut p = Position {
        label: String::new(),
        line,
        time_s: None,
        g_nominal: [0.0; 3],
        g_unit: [0.0; 3],
        measured: [None; 3],
        counts: [None; 3],
        counting_sigma_cm_s2: [None; 3],
        sigma_cm_s2: None,
        sigma_angle_rad: None,
    };
    let mut counts: RawCounts = [[None; 2]; 3];
    for (j, (cell, &col)) in cells.iter().zip(cols).enumerate() {
        if col == "label" {
            p.label.clone_from(cell);
            continue;
        }
        let s = cell.trim();
        if s.is_empty() {
            continue;
        }
        let positive = matches!(col, "sigma_cm_s2" | "sigma_angle_urad");
        let count = col.starts_with("pulses_") || col.starts_with("ticks_");
        let Some(v) = s.parse::<f64>().ok().filter(|v| {
            v.is_finite() && (!positive || *v > 0.0) && (!count || caseframe::is_count(*v))
        }) else {
            bail!(
                "{name}:{line}: column {} (`{col}`) holds `{s}`; expected {}",
                j + 1,
                expected(col)
            );
        };
        match col {
            "time_s" => p.time_s = Some(v),
            "g_x" => p.g_nominal[0] = v,
            "g_y" => p.g_nominal[1] = v,
            "g_z" => p.g_nominal[2] = v,
            "measured_x_cm_s2" => p.measured[0] = Some(v),
            "measured_y_cm_s2" => p.measured[1] = Some(v),
            "measured_z_cm_s2" => p.measured[2] = Some(v),
            "sigma_cm_s2" => p.sigma_cm_s2 = Some(v),
            "sigma_angle_urad" => p.sigma_angle_rad = Some(v * 1e-6),
            c => {
                let axis = AXIS_COLUMNS
                    .iter()
                    .position(|a| a.contains(&c))
                    .unwrap_or(0);
                counts[axis][usize::from(c.starts_with("ticks_"))] = Some(v);
            }
        }
    }
    Ok((p, counts))
}

/// Each axis's counts as read into `p`, checked as the case frame checks them: never beside
/// the axis's measured column, and both of the gate (pulses and ticks) or neither.
fn take_counts(name: &str, cols: &[&str], counts: RawCounts, p: &mut Position) -> Result<()> {
    let line = p.line;
    let at = |c: &str| cols.iter().position(|k| *k == c).map_or(0, |j| j + 1);
    for (axis, names) in AXIS_COLUMNS.iter().enumerate() {
        let [pulses, ticks] = counts[axis];
        if p.measured[axis].is_some() && (pulses.is_some() || ticks.is_some()) {
            let second = if pulses.is_some() { names[1] } else { names[2] };
            let one = format!("`{}`", names[0]);
            let both = format!("`{}` with `{}`", names[1], names[2]);
            bail!(caseframe::two_sources(
                name,
                line,
                (at(names[0]), names[0]),
                (at(second), second),
                &format!("the {} axis's measurement", super::fit::AXES[axis]),
                &[one.as_str(), both.as_str()]
            ));
        }
        caseframe::check_gate(
            name,
            line,
            (pulses, at(names[1]), names[1]),
            (ticks, at(names[2]), names[2]),
        )?;
        if let (Some(pv), Some(tv)) = (pulses, ticks) {
            p.counts[axis] = Some([pv, tv]);
        }
    }
    Ok(())
}

/// The direction of `p`'s nominal gravity (zero when it has none), its magnitude checked to
/// be 1 g within [`G_MAGNITUDE_TOLERANCE`] unless the row is of a `record` to correct.
fn gravity_direction(name: &str, record: bool, p: &mut Position) -> Result<()> {
    let line = p.line;
    let mag = p.g_nominal.iter().map(|x| x * x).sum::<f64>().sqrt();
    if !record && (mag - 1.0).abs() > G_MAGNITUDE_TOLERANCE {
        bail!(
            "{name}:{line}: the nominal gravity (g_x, g_y, g_z) = ({}, {}, {}) has a magnitude \
             of {mag:.4} g; expected 1 g within {:.0} % (a static position: its direction is \
             used, the local gravity comes from the instrument file)",
            p.g_nominal[0],
            p.g_nominal[1],
            p.g_nominal[2],
            G_MAGNITUDE_TOLERANCE * 100.0
        );
    }
    p.g_unit = if mag > 0.0 {
        p.g_nominal.map(|x| x / mag)
    } else {
        [0.0; 3]
    };
    Ok(())
}

/// `positions` as a triad file (the columns of [`TRIAD_COLUMNS`] that any row gives, and
/// always `label`, the gravity and the three measured columns; an axis given as counts
/// keeps its counts and leaves its measured cell empty), after `comments` (each a `# `
/// line): the writer of the tests.
#[must_use]
pub fn to_csv(positions: &[Position], comments: &[&str]) -> String {
    use std::fmt::Write as _;
    let num = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v}"));
    let time = positions.iter().any(|p| p.time_s.is_some());
    let sigma = positions.iter().any(|p| p.sigma_cm_s2.is_some());
    let angle = positions.iter().any(|p| p.sigma_angle_rad.is_some());
    let counted = positions
        .iter()
        .any(|p| p.counts.iter().any(Option::is_some));
    let mut out = String::new();
    for c in comments {
        let _ = writeln!(out, "# {c}");
    }
    let mut head = vec!["label"];
    if time {
        head.push("time_s");
    }
    head.extend(REQUIRED);
    if counted {
        head.extend(AXIS_COLUMNS.iter().flat_map(|a| [a[1], a[2]]));
    }
    if sigma {
        head.push("sigma_cm_s2");
    }
    if angle {
        head.push("sigma_angle_urad");
    }
    let _ = writeln!(out, "{}", head.join(","));
    for p in positions {
        let label = if p.label.contains([',', '"']) || p.label.starts_with('#') {
            format!("\"{}\"", p.label.replace('"', "\"\""))
        } else {
            p.label.clone()
        };
        let mut cells = vec![label];
        if time {
            cells.push(num(p.time_s));
        }
        cells.extend(p.g_nominal.iter().map(|v| format!("{v}")));
        cells.extend((0..3).map(|j| num(p.measured[j].filter(|_| p.counts[j].is_none()))));
        if counted {
            for c in p.counts {
                cells.push(num(c.map(|c| c[0])));
                cells.push(num(c.map(|c| c[1])));
            }
        }
        if sigma {
            cells.push(num(p.sigma_cm_s2));
        }
        if angle {
            cells.push(num(p.sigma_angle_rad.map(|a| a * 1e6)));
        }
        let _ = writeln!(out, "{}", cells.join(","));
    }
    out
}

/// A triad plan: `design`'s positions (`p1`, `p2`, …) with the measured columns (with
/// `counts`, each axis's `pulses_*` and `ticks_*` in their place) and `sigma_cm_s2` empty
/// for the lab to fill in, after `comments` (each a `# ` line).
#[must_use]
pub fn plan_csv(design: &[[f64; 3]], comments: &[&str], counts: bool) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    for c in comments {
        let _ = writeln!(out, "# {c}");
    }
    let measured: Vec<&str> = if counts {
        AXIS_COLUMNS.iter().flat_map(|a| [a[1], a[2]]).collect()
    } else {
        AXIS_COLUMNS.iter().map(|a| a[0]).collect()
    };
    let _ = writeln!(out, "label,g_x,g_y,g_z,{},sigma_cm_s2", measured.join(","));
    let empty = ",".repeat(measured.len() + 1);
    for (i, n) in design.iter().enumerate() {
        let _ = writeln!(out, "p{},{},{},{}{empty}", i + 1, n[0], n[1], n[2]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const OK: &str = "# a triad\nlabel,g_x,g_y,g_z,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2,sigma_cm_s2\n\
                      +x,1,0,0,981.2,0.3,-0.1,0.05\n-y,0,-1,0,0.1,-980.1,,\n";

    #[test]
    fn reads_a_triad_and_names_its_columns() {
        assert!(is_triad(OK.as_bytes()));
        assert!(!is_triad(b"label,g_ia,measured_cm_s2\nx,1,980\n"));
        assert!(!is_triad(
            b"label,g_ia,measured_cm_s2,sigma_angle_urad,sigma_cm_s2,time_s\nx,1,980,5,0.1,0\n"
        ));
        for c in TRIAD_ONLY {
            assert!(COLUMNS.iter().all(|k| k.name != *c), "{c}");
        }
        let p = parse_bytes("t.csv", OK.as_bytes()).unwrap();
        assert_eq!(p.len(), 2);
        assert_eq!(p[0].measured, [Some(981.2), Some(0.3), Some(-0.1)]);
        assert_eq!(p[1].measured[2], None);
        assert_eq!(p[1].sigma_cm_s2, None);
        assert_eq!(p[0].line, 3);
        let back = parse_bytes("t.csv", to_csv(&p, &["again"]).as_bytes()).unwrap();
        assert_eq!(
            back.iter().map(|q| q.measured).collect::<Vec<_>>(),
            [p[0].measured, p[1].measured]
        );
    }

    /// An axis given as counts: kept as read, converted by [`with_counts`] through the
    /// single-axis conversion, written back as counts.
    #[test]
    fn counts_per_axis_are_read_converted_and_written_back() {
        use crate::model::counts::{counting_sigma_cm_s2, indicated_cm_s2};
        let text = "label,g_x,g_y,g_z,pulses_x,ticks_x,measured_y_cm_s2,pulses_z,ticks_z\n\
                    +x,1,0,0,2009123,3840000,0.3,,\n-y,0,-1,0,,,-980.1,32000,64000\n";
        let mut p = parse_bytes("t.csv", text.as_bytes()).unwrap();
        assert_eq!(p[0].counts, [Some([2_009_123.0, 3_840_000.0]), None, None]);
        assert_eq!(p[0].measured, [None, Some(0.3), None]);
        assert!(p[0].is_measured());
        assert_eq!(p[0].unconverted(), Some(0));
        assert_eq!(p[1].unconverted(), Some(2));
        let sf = 21_121.1;
        with_counts(&mut p, sf);
        assert_eq!(p[0].unconverted(), None);
        assert_eq!(
            p[0].measured[0],
            Some(indicated_cm_s2(2_009_123.0, 3_840_000.0, sf))
        );
        assert_eq!(
            p[0].counting_sigma_cm_s2,
            [Some(counting_sigma_cm_s2(3_840_000.0, sf)), None, None]
        );
        assert_eq!(p[1].measured[2], Some(0.0));
        let back = parse_bytes("t.csv", to_csv(&p, &[]).as_bytes()).unwrap();
        assert_eq!(back[0].counts, p[0].counts);
        assert_eq!(back[1].counts, p[1].counts);
        assert_eq!(back[0].measured, [None, Some(0.3), None]);
        let plan = plan_csv(&[[1.0, 0.0, 0.0]], &[], true);
        assert!(
            plan.starts_with(
                "label,g_x,g_y,g_z,pulses_x,ticks_x,pulses_y,ticks_y,pulses_z,ticks_z,sigma_cm_s2\np1,1,0,0,,,,,,,\n"
            ),
            "{plan}"
        );
    }

    #[test]
    fn refusals_name_the_place_and_what_was_expected() {
        let err = |t: &str| format!("{:#}", parse_bytes("t.csv", t.as_bytes()).unwrap_err());
        let e = err(
            "label,g_x,g_y,g_z,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2,measured_cm_s2\n",
        );
        assert!(
            e.starts_with("t.csv:1:") && e.contains("single-axis") && e.contains("`g_x`"),
            "{e}"
        );
        let e = err("g_x,g_y,g_z,measured_x_cm_s2,measured_y_cm_s2\n");
        assert!(e.contains("no `measured_z_cm_s2`"), "{e}");
        let e =
            err("g_x,g_y,g_z,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2\n1,0,0,abc,0,0\n");
        assert!(
            e.contains("t.csv:2: column 4 (`measured_x_cm_s2`) holds `abc`"),
            "{e}"
        );
        let e = err(
            "g_x,g_y,g_z,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2\n1,1,0,980,980,0\n",
        );
        assert!(
            e.contains("t.csv:2:") && e.contains("magnitude of 1.4142 g"),
            "{e}"
        );
        let e = err("g_x,g_y,g_z,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2\n1,0,0,,,\n");
        assert!(e.contains("no row has a measurement"), "{e}");
        let e = err(
            "g_x,g_y,g_z,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2,sigma_cm_s2\n1,0,0,1,1,1,0\n",
        );
        assert!(e.contains("greater than 0"), "{e}");
        let e = err("g_x,g_y,g_z,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2\n1,0,0,1,1\n");
        assert!(e.contains("t.csv:2: 5 cells, expected 6"), "{e}");
    }
}
