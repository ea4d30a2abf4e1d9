//! The case-frame CSV format (`docs/reference/case-frame-format.md`): reader and writer.
//!
//! One row is one test condition ([`Condition`]). The file has a header; any column may be
//! left out (a missing column means 0, or "not given" for `measured_cm_s2` and
//! `sigma_cm_s2`); an unknown or repeated column is an error; a bad value is an error that
//! names the file, the line, the column and what was expected. Lines whose first non-blank
//! character is `#` are comments (the shipped files cite their source there). An empty cell
//! means 0 in an input column, "not measured" in `measured_cm_s2` (the row is kept but not
//! fitted, as the resonance rows of Tables 6.2/6.3) and "use `--sigma`" in `sigma_cm_s2`.
//! The reader accepts a UTF-8 byte-order mark and CRLF line ends, and refuses text that is
//! not UTF-8 or is not comma-separated with an error that says so.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result, bail};

use crate::model::condition::{Approach, Condition, RowKind};
use crate::model::counts::MAX_COUNT;

/// A cell's value as read or written.
#[derive(Clone, Debug, PartialEq)]
enum Value {
    /// A text cell (empty = not given).
    Text(Option<String>),
    /// A number cell (empty = not given: 0 in an input column).
    Num(Option<f64>),
}

/// What a cell must hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Check {
    /// Free text.
    Text,
    /// One of these words (or empty: the first).
    OneOf(&'static [&'static str]),
    /// Any finite number.
    Finite,
    /// A finite number, 0 or more.
    NonNegative,
    /// A finite number greater than 0.
    Positive,
    /// A whole number from 0 to [`MAX_COUNT`] (a count of pulses or ticks).
    Count,
}

/// One column of the format: its name, what it holds and where it goes in a [`Condition`].
pub struct Column {
    /// Header name, units in the name.
    pub name: &'static str,
    /// What a cell must hold, for error messages.
    pub expected: &'static str,
    check: Check,
    get: fn(&Condition) -> Value,
    set: fn(&mut Condition, Value),
}

impl Column {
    /// Whether the cells are text (else numbers).
    #[must_use]
    pub fn is_text(&self) -> bool {
        matches!(self.check, Check::Text | Check::OneOf(_))
    }
}

// The setters hand every cell over by value.
#[allow(clippy::needless_pass_by_value)]
fn num_or_zero(v: Value) -> f64 {
    match v {
        Value::Num(x) => x.unwrap_or(0.0),
        Value::Text(_) => 0.0,
    }
}

// The setters hand every cell over by value.
#[allow(clippy::needless_pass_by_value)]
fn num(v: Value) -> Option<f64> {
    match v {
        Value::Num(x) => x,
        Value::Text(_) => None,
    }
}

fn text(v: Value) -> Option<String> {
    match v {
        Value::Text(t) => t,
        Value::Num(_) => None,
    }
}

/// A number column of an `[f64; 3]` field, one per axis.
macro_rules! axis_column {
    ($name:literal, $field:ident, $j:literal, $check:expr, $expected:expr) => {
        Column {
            name: $name,
            expected: $expected,
            check: $check,
            get: |c| Value::Num(Some(c.$field[$j])),
            set: |c, v| c.$field[$j] = num_or_zero(v),
        }
    };
}

const INPUT: &str = "a finite number (an empty cell means 0)";
const ANGLE: &str = "a finite angle amplitude in mrad (an empty cell means 0)";

/// Every column of the format, in the order the writer uses.
pub const COLUMNS: &[Column] = &[
    Column {
        name: "label",
        expected: "free text",
        check: Check::Text,
        get: |c| Value::Text(Some(c.label.clone())),
        set: |c, v| c.label = text(v).unwrap_or_default(),
    },
    Column {
        name: "kind",
        expected: "`difference` (condition minus its reference; also an empty cell), `absolute` (the indicated acceleration itself) or `response` (gain and phase at freq_hz)",
        check: Check::OneOf(&["difference", "absolute", "response"]),
        get: |c| Value::Text(Some(c.kind.name().to_string())),
        set: |c, v| c.kind = text(v).and_then(|t| RowKind::parse(&t)).unwrap_or_default(),
    },
    Column {
        name: "block",
        expected: "free text naming the rows that share a reference run (empty: the one block)",
        check: Check::Text,
        get: |c| Value::Text(c.block.clone()),
        set: |c, v| c.block = text(v),
    },
    Column {
        name: "time_s",
        expected: "a finite time in seconds, or an empty cell (row order)",
        check: Check::Finite,
        get: |c| Value::Num(c.time_s),
        set: |c, v| c.time_s = num(v),
    },
    axis_column!("g_ia", g, 0, Check::Finite, INPUT),
    axis_column!("g_pa", g, 1, Check::Finite, INPUT),
    axis_column!("g_oa", g, 2, Check::Finite, INPUT),
    axis_column!("w_ia_rad_s", w_rad_s, 0, Check::Finite, INPUT),
    axis_column!("w_pa_rad_s", w_rad_s, 1, Check::Finite, INPUT),
    axis_column!("w_oa_rad_s", w_rad_s, 2, Check::Finite, INPUT),
    Column {
        name: "freq_hz",
        expected: "a finite number of hertz, 0 or more",
        check: Check::NonNegative,
        get: |c| Value::Num(Some(c.freq_hz)),
        set: |c, v| c.freq_hz = num_or_zero(v),
    },
    axis_column!(
        "lin_ia_cm_s2",
        lin_cm_s2,
        0,
        Check::Finite,
        "a finite number (an empty cell means 0)"
    ),
    axis_column!(
        "lin_pa_cm_s2",
        lin_cm_s2,
        1,
        Check::Finite,
        "a finite number (an empty cell means 0)"
    ),
    axis_column!(
        "lin_oa_cm_s2",
        lin_cm_s2,
        2,
        Check::Finite,
        "a finite number (an empty cell means 0)"
    ),
    axis_column!("lin_ia_deg", lin_deg, 0, Check::Finite, INPUT),
    axis_column!("lin_pa_deg", lin_deg, 1, Check::Finite, INPUT),
    axis_column!("lin_oa_deg", lin_deg, 2, Check::Finite, INPUT),
    axis_column!("ang_ia_mrad", ang_mrad, 0, Check::Finite, ANGLE),
    axis_column!("ang_pa_mrad", ang_mrad, 1, Check::Finite, ANGLE),
    axis_column!("ang_oa_mrad", ang_mrad, 2, Check::Finite, ANGLE),
    axis_column!("ang_ia_deg", ang_deg, 0, Check::Finite, INPUT),
    axis_column!("ang_pa_deg", ang_deg, 1, Check::Finite, INPUT),
    axis_column!("ang_oa_deg", ang_deg, 2, Check::Finite, INPUT),
    axis_column!("ref_w_ia_rad_s", ref_w_rad_s, 0, Check::Finite, INPUT),
    axis_column!("ref_w_pa_rad_s", ref_w_rad_s, 1, Check::Finite, INPUT),
    axis_column!("ref_w_oa_rad_s", ref_w_rad_s, 2, Check::Finite, INPUT),
    Column {
        name: "radius_cm",
        expected: "a finite distance in cm from the spin axis of the row's rates to the proof mass (a centrifuge arm; an empty cell means 0)",
        check: Check::Finite,
        get: |c| Value::Num(Some(c.radius_cm)),
        set: |c, v| c.radius_cm = num_or_zero(v),
    },
    Column {
        name: "measured_cm_s2",
        expected: "a finite number of cm/s², or an empty cell (not measured)",
        check: Check::Finite,
        get: |c| Value::Num(c.measured_cm_s2),
        set: |c, v| c.measured_cm_s2 = num(v),
    },
    Column {
        name: "sigma_cm_s2",
        expected: "a finite number of cm/s² greater than 0, or an empty cell",
        check: Check::Positive,
        get: |c| Value::Num(c.sigma_cm_s2),
        set: |c, v| c.sigma_cm_s2 = num(v),
    },
    Column {
        name: "pulses",
        expected: "a whole number of pulses of positive torque counted over the row's gate (0 to `ticks`), or an empty cell (not counted)",
        check: Check::Count,
        get: |c| Value::Num(c.pulses),
        set: |c, v| c.pulses = num(v),
    },
    Column {
        name: "ticks",
        expected: "a whole number of clock ticks of the row's gate (greater than 0), or an empty cell (not counted)",
        check: Check::Count,
        get: |c| Value::Num(c.ticks),
        set: |c, v| c.ticks = num(v),
    },
    Column {
        name: "measured_gain",
        expected: "a response row's gain (output amplitude over input amplitude), greater than 0, or an empty cell",
        check: Check::Positive,
        get: |c| Value::Num(c.measured_gain),
        set: |c, v| c.measured_gain = num(v),
    },
    Column {
        name: "measured_phase_deg",
        expected: "a response row's phase (output minus input) in degrees, or an empty cell",
        check: Check::Finite,
        get: |c| Value::Num(c.measured_phase_deg),
        set: |c, v| c.measured_phase_deg = num(v),
    },
    Column {
        name: "sigma_gain",
        expected: "the gain's 1-sigma uncertainty, greater than 0, or an empty cell",
        check: Check::Positive,
        get: |c| Value::Num(c.sigma_gain),
        set: |c, v| c.sigma_gain = num(v),
    },
    Column {
        name: "sigma_phase_deg",
        expected: "the phase's 1-sigma uncertainty in degrees, greater than 0, or an empty cell",
        check: Check::Positive,
        get: |c| Value::Num(c.sigma_phase_deg),
        set: |c, v| c.sigma_phase_deg = num(v),
    },
    Column {
        name: "sigma_angle_urad",
        expected: "the 1-sigma error of the position's orientation in µrad about each axis across IA (how precisely the fixture sets it), greater than 0, or an empty cell (exact)",
        check: Check::Positive,
        get: |c| Value::Num(c.sigma_angle_urad),
        set: |c, v| c.sigma_angle_urad = num(v),
    },
    Column {
        name: "approach",
        expected: "`up` or `+` (the input along IA rose to this reading: approached from below), `down` or `-` (it fell: approached from above), or an empty cell (not recorded: the change of the input along IA since the previous row gives it)",
        check: Check::OneOf(Approach::WORDS),
        get: |c| Value::Text(c.approach.map(|a| a.name().to_string())),
        set: |c, v| c.approach = text(v).and_then(|t| Approach::parse(&t)),
    },
    Column {
        name: "power_on_s",
        expected: "a finite time in seconds on the `time_s` clock at which the instrument was last switched on, at or before the row's `time_s`, or an empty cell (an earlier row's, else the first row's time)",
        check: Check::Finite,
        get: |c| Value::Num(c.power_on_s),
        set: |c, v| c.power_on_s = num(v),
    },
    Column {
        name: "temp_c",
        expected: "a finite temperature of the instrument in °C, or an empty cell (not measured)",
        check: Check::Finite,
        get: |c| Value::Num(c.temp_c),
        set: |c, v| c.temp_c = num(v),
    },
];

/// The names of [`COLUMNS`], in order.
#[must_use]
pub fn column_names() -> Vec<&'static str> {
    COLUMNS.iter().map(|c| c.name).collect()
}

/// The index in [`COLUMNS`] of a header cell.
fn column_index(name: &str) -> Option<usize> {
    COLUMNS.iter().position(|c| c.name == name)
}

/// The columns of a raw reading, read beside [`COLUMNS`] but not into a [`Condition`]:
/// `reading` (a number in the row's `reading_unit`) and `reading_unit` (V, mA, LSB, g,
/// m/s², cm/s²). [`Frame::convert_readings`] turns them into `measured_cm_s2` through the
/// instrument file. In a parsed header they are `COLUMNS.len() + i`.
pub const READING_COLUMNS: &[&str] = &["reading", "reading_unit"];

/// The ways a row gives its measurement along IA (the one definition of the rule "one per
/// row, never two": a further source is one more entry): the columns whose filled cell
/// gives it, and how messages name it.
pub const MEASUREMENT_SOURCES: &[(&[&str], &str)] = &[
    (&["measured_cm_s2"], "`measured_cm_s2`"),
    (&["pulses", "ticks"], "`pulses` with `ticks`"),
    (&["reading"], "`reading` with `reading_unit`"),
];

/// The index in [`MEASUREMENT_SOURCES`] of the source a column belongs to.
fn measurement_source(column: &str) -> Option<usize> {
    MEASUREMENT_SOURCES
        .iter()
        .position(|(cols, _)| cols.contains(&column))
}

/// The header index of a header cell: [`COLUMNS`]' index, or beyond it a
/// [`READING_COLUMNS`] entry.
fn header_index(name: &str) -> Option<usize> {
    column_index(name).or_else(|| {
        READING_COLUMNS
            .iter()
            .position(|c| *c == name)
            .map(|i| COLUMNS.len() + i)
    })
}

/// The name of header index `k` ([`header_index`]).
fn header_name(k: usize) -> &'static str {
    COLUMNS
        .get(k)
        .map_or_else(|| READING_COLUMNS[k - COLUMNS.len()], |c| c.name)
}

/// A row's raw reading as read, before [`Frame::convert_readings`] makes it the row's
/// `measured_cm_s2`.
#[derive(Clone, Debug, PartialEq)]
pub struct RawReading {
    /// Index of the row in the rows read.
    pub row: usize,
    /// The row's 1-based line in the file.
    pub line: usize,
    /// The 1-based column of `reading_unit` in the header.
    pub unit_column: usize,
    /// The reading, in `unit`.
    pub value: f64,
    /// Its unit.
    pub unit: crate::model::instrument::ReadingUnit,
}

/// How to get UTF-8 out of a spreadsheet (used in encoding errors).
const SAVE_AS_UTF8: &str = "in a spreadsheet, save the file as \"CSV UTF-8\"";

/// The cells of one row that were left empty in a column where an empty cell means 0 (an
/// input column such as `g_ia`, `w_pa_rad_s`, `freq_hz` or `radius_cm`; not `time_s`,
/// `measured_cm_s2` or a sigma, where an empty cell means "not given"). A side record of
/// the reader, kept out of [`Condition`] (the physics): `ptsa discover` names such a cell
/// as the likely cause of a row that fits nothing.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct EmptyCells {
    /// Index of the row in the rows read.
    pub row: usize,
    /// The row's 1-based line in the file.
    pub line: usize,
    /// The columns whose cell was empty and read as 0, in header order.
    pub columns: Vec<&'static str>,
}

/// A case-frame file as read: its rows, and which of their input cells were empty and read
/// as 0 (one entry per row that has any).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Frame {
    /// The rows.
    pub rows: Vec<Condition>,
    /// The empty input cells read as 0, by row.
    pub empty: Vec<EmptyCells>,
    /// Each row's 1-based line in the file (for messages about a row).
    pub lines: Vec<usize>,
    /// The rows' raw readings (`reading`, `reading_unit`), not yet converted: their rows'
    /// `measured_cm_s2` is empty until [`Frame::convert_readings`].
    pub readings: Vec<RawReading>,
}

impl Frame {
    /// Each raw reading converted to cm/s² through `instr`
    /// ([`crate::model::instrument::Instrument::reading_to_cm_s2`]) into its row's
    /// `measured_cm_s2`; `name` is the data file, for errors.
    ///
    /// # Errors
    /// A reading in V, mA or LSB when the instrument file gives no nominal scale in that
    /// unit (the message names the data file, the line and column, and the keys to add).
    pub fn convert_readings(
        &mut self,
        name: &str,
        instr: &crate::model::instrument::Instrument,
    ) -> Result<()> {
        for r in &self.readings {
            let v = instr.reading_to_cm_s2(r.value, r.unit).map_err(|m| {
                anyhow::anyhow!(
                    "{name}:{}: column {} (`reading_unit`) is `{}`: {m}",
                    r.line,
                    r.unit_column,
                    r.unit.name()
                )
            })?;
            self.rows[r.row].measured_cm_s2 = Some(v);
        }
        Ok(())
    }
}

/// Whether an empty cell of `col` reads as the number 0 (an input column), rather than as
/// "not given".
fn empty_reads_as_zero(col: &Column) -> bool {
    if col.is_text() {
        return false;
    }
    let mut c = Condition::default();
    (col.set)(&mut c, Value::Num(None));
    matches!((col.get)(&c), Value::Num(Some(x)) if x == 0.0)
}

/// Parse case-frame CSV text. `name` is the file name used in error messages.
///
/// A leading UTF-8 byte-order mark is ignored; lines may end in LF or CRLF.
///
/// # Errors
/// A missing or bad header (with a hint when the file looks semicolon- or tab-separated),
/// an unknown or repeated column, a row with the wrong number of cells, an unterminated
/// quoted cell, a NUL character, a value that is not what the column expects, or an
/// oscillation amplitude in a row whose `freq_hz` is 0: each error names `name`, the
/// 1-based line and, for a cell, the column.
pub fn parse(name: &str, text: &str) -> Result<Vec<Condition>> {
    parse_frame(name, text).map(|f| f.rows)
}

/// [`parse`], with the record of the empty input cells read as 0.
///
/// # Errors
/// As [`parse`].
pub fn parse_frame(name: &str, text: &str) -> Result<Frame> {
    let (cols, records) = records_with(name, text.as_bytes(), "case-frame columns", |h, at| {
        parse_header(name, h.line, at, &h.cells)
    })?;
    let mut rows = Vec::with_capacity(records.len());
    let mut lines = Vec::with_capacity(records.len());
    let mut empty = Vec::new();
    let mut readings = Vec::new();
    for r in &records {
        let line = r.line;
        let (row, columns, reading) = parse_row(name, line, &r.cells, &cols)?;
        if let Some((value, unit, unit_column)) = reading {
            readings.push(RawReading {
                row: rows.len(),
                line,
                unit_column,
                value,
                unit,
            });
        }
        if !columns.is_empty() {
            empty.push(EmptyCells {
                row: rows.len(),
                line,
                columns,
            });
        }
        rows.push(row);
        lines.push(line);
    }
    check_temperatures(name, &rows, &lines, &cols)?;
    Ok(Frame {
        rows,
        empty,
        lines,
        readings,
    })
}

/// A file that gives `temp_c` gives it on every measured row: a measured row without it
/// would be analysed at the reference temperature (ΔT = 0, `condition::with_history`),
/// which the lab did not measure. Rows without a measurement may leave it empty (they are
/// predicted at the reference temperature).
fn check_temperatures(
    name: &str,
    rows: &[Condition],
    lines: &[usize],
    cols: &[usize],
) -> Result<()> {
    let Some(j) = cols.iter().position(|&k| header_name(k) == "temp_c") else {
        return Ok(());
    };
    let given = rows.iter().filter(|r| r.temp_c.is_some()).count();
    if given == 0 {
        return Ok(());
    }
    if let Some((r, line)) = rows
        .iter()
        .zip(lines)
        .find(|(r, _)| r.temp_c.is_none() && r.is_measured())
    {
        bail!(
            "{name}:{line}: column {} (`temp_c`) is empty in a measured row (`{}`), but {given} other rows give a temperature; expected the instrument's temperature in °C on every measured row or on none (ΔT is taken from the mean of the rows' `temp_c`; a row without it would be analysed at that mean)",
            j + 1,
            r.label
        );
    }
    Ok(())
}

/// Parse the bytes of a case-frame file: [`parse`] after checking that they are UTF-8.
///
/// # Errors
/// Bytes that are not UTF-8 (the error names `name`, the 1-based line and the byte offset of
/// the first bad byte; a UTF-16 byte-order mark is named as such), or any error of
/// [`parse`].
pub fn parse_bytes(name: &str, bytes: &[u8]) -> Result<Vec<Condition>> {
    parse_bytes_frame(name, bytes).map(|f| f.rows)
}

/// [`parse_bytes`], with the record of the empty input cells read as 0.
///
/// # Errors
/// As [`parse_bytes`].
pub fn parse_bytes_frame(name: &str, bytes: &[u8]) -> Result<Frame> {
    if bytes.starts_with(&[0xFF, 0xFE]) || bytes.starts_with(&[0xFE, 0xFF]) {
        bail!(
            "{name}:1: the file is UTF-16 text (it starts with a UTF-16 byte-order mark); \
             expected UTF-8 text ({SAVE_AS_UTF8})"
        );
    }
    match std::str::from_utf8(bytes) {
        Ok(text) => parse_frame(name, text),
        Err(e) => {
            let off = e.valid_up_to();
            let byte = bytes.get(off).copied().unwrap_or_default();
            bail!(
                "{name}:{}: the file is not UTF-8 text: byte 0x{byte:02X} at byte offset {off} \
                 is not valid UTF-8; expected UTF-8 text ({SAVE_AS_UTF8})",
                line_of(bytes, off)
            );
        }
    }
}

/// The 1-based line of byte offset `off`.
// Error messages only; no bytecount dependency.
#[allow(clippy::naive_bytecount)]
fn line_of(bytes: &[u8], off: usize) -> usize {
    bytes[..off.min(bytes.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// The lines of a file that hold CSV records, without the comment lines (first non-blank
/// character `#`) and the blank lines, and where each came from. The csv crate recognises a
/// comment only at the very start of a line, and it gives a record that follows blank
/// lines the position of the first blank line, so both are removed before it sees the
/// text and its line numbers are mapped back.
struct DataLines {
    /// The kept lines, each ending in `\n` (a CRLF line end becomes `\n`).
    text: String,
    /// `file_lines[i]`: the file's 1-based line number of kept line `i + 1`.
    file_lines: Vec<usize>,
}

impl DataLines {
    fn new(text: &str) -> Self {
        let mut kept = String::with_capacity(text.len() + 1);
        let mut file_lines = Vec::new();
        for (idx, raw) in text.split_inclusive('\n').enumerate() {
            let trimmed = raw.trim();
            if trimmed.is_empty() || trimmed.starts_with('#') {
                continue;
            }
            // Every kept line ends in a bare `\n`: after a CRLF the csv crate would give the
            // next record the line of the `\r`. The csv crate reads an unterminated quote at
            // the end of its input as closed; the final `\n` turns that into a cell holding
            // a line break, which `parse` refuses like any other multi-line cell.
            let content = raw.strip_suffix('\n').unwrap_or(raw);
            kept.push_str(content.strip_suffix('\r').unwrap_or(content));
            kept.push('\n');
            file_lines.push(idx + 1);
        }
        Self {
            text: kept,
            file_lines,
        }
    }

    /// The file's line number of the csv reader's 1-based line `csv_line`.
    fn file_line(&self, csv_line: u64) -> usize {
        let i = usize::try_from(csv_line.saturating_sub(1)).unwrap_or(usize::MAX);
        self.file_lines
            .get(i)
            .or(self.file_lines.last())
            .copied()
            .unwrap_or(0)
    }
}

/// The header: the column index (into [`COLUMNS`]) of every cell. `at` is the 1-based
/// character column of each cell in the header's line (for the column of a bad cell).
fn parse_header(
    name: &str,
    line: usize,
    at: &[Option<usize>],
    cells: &[String],
) -> Result<Vec<usize>> {
    if let [cell] = cells {
        let cell = cell.trim();
        if let Some(kind) = separator_hint(cell) {
            bail!(
                "{name}:{line}: the header has one column `{cell}`, which is not a case-frame \
                 column; this looks like a {kind}-separated file: the case-frame format \
                 separates cells with commas (and writes decimals with a point); expected a \
                 comma-separated header such as `label,g_ia,measured_cm_s2`"
            );
        }
    }
    let mut cols = Vec::with_capacity(cells.len());
    for (i, cell) in cells.iter().enumerate() {
        let cell = cell.trim();
        let place = at
            .get(i)
            .copied()
            .flatten()
            .map_or(String::new(), |c| format!(":{c}"));
        let Some(k) = header_index(cell) else {
            let hint = near_column(cell).map_or(String::new(), |near| {
                if near.eq_ignore_ascii_case(cell) {
                    format!(" (did you mean `{near}`? column names are lower case)")
                } else {
                    format!(" (did you mean `{near}`?)")
                }
            });
            bail!(
                "{name}:{line}{place}: column {} of the header is `{cell}`, which is not a \
                 case-frame column{hint}; expected one of: {}",
                i + 1,
                [column_names(), READING_COLUMNS.to_vec()]
                    .concat()
                    .join(", ")
            );
        };
        if cols.contains(&k) {
            bail!("{name}:{line}{place}: column `{cell}` appears twice in the header");
        }
        cols.push(k);
    }
    Ok(cols)
}

/// The 1-based character column at which each header cell's name starts in `raw`, the
/// header's line as written (`None` where it cannot be found, e.g. a quoted cell with
/// doubled quotes).
fn header_columns(raw: &str, record: &csv::StringRecord) -> Vec<Option<usize>> {
    let mut from = 0;
    record
        .iter()
        .map(|cell| {
            let cell = cell.trim();
            let at = raw.get(from..)?.find(cell)? + from;
            from = at + cell.len();
            Some(raw[..at].chars().count() + 1)
        })
        .collect()
}

/// The case-frame column a header cell that is none was probably meant to be: the same name
/// in another case or with `-`, `.` or blanks for `_`, or the one column within a small
/// edit distance (a letter wrong, missing, extra or two swapped: at most 1 for names up to
/// 5 characters, 2 beyond), when no other column is as near.
fn near_column(cell: &str) -> Option<&'static str> {
    let norm: String = cell
        .trim()
        .chars()
        .map(|c| match c {
            '-' | '.' | ' ' => '_',
            c => c.to_ascii_lowercase(),
        })
        .collect();
    if let Some(k) = column_index(&norm) {
        return Some(COLUMNS[k].name);
    }
    let limit = if norm.chars().count() <= 5 { 1 } else { 2 };
    let mut best: Option<(usize, &'static str)> = None;
    let mut tied = false;
    for c in COLUMNS {
        let d = edit_distance(&norm, c.name);
        match best {
            Some((b, _)) if d > b => {}
            Some((b, _)) if d == b => tied = true,
            _ => {
                best = Some((d, c.name));
                tied = false;
            }
        }
    }
    best.filter(|&(d, _)| d <= limit && !tied).map(|(_, n)| n)
}

/// Edit distance between `a` and `b` counting a substitution, an insertion, a deletion or a
/// swap of two neighbouring characters as one edit (optimal string alignment).
fn edit_distance(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    let w = b.len() + 1;
    let mut d = vec![0usize; (a.len() + 1) * w];
    for i in 0..=a.len() {
        for j in 0..=b.len() {
            d[i * w + j] = if i == 0 || j == 0 {
                i + j
            } else {
                let cost = usize::from(a[i - 1] != b[j - 1]);
                let mut v = (d[(i - 1) * w + j] + 1)
                    .min(d[i * w + j - 1] + 1)
                    .min(d[(i - 1) * w + j - 1] + cost);
                if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                    v = v.min(d[(i - 2) * w + j - 2] + 1);
                }
                v
            };
        }
    }
    d[a.len() * w + b.len()]
}

/// `Some("semicolon")` or `Some("tab")` when a header cell is several case-frame column
/// names joined by that separator.
fn separator_hint(cell: &str) -> Option<&'static str> {
    [(';', "semicolon"), ('\t', "tab")]
        .into_iter()
        .find(|&(sep, _)| {
            cell.contains(sep)
                && cell
                    .split(sep)
                    .any(|piece| column_index(piece.trim().trim_matches('"').trim()).is_some())
        })
        .map(|(_, kind)| kind)
}

/// A cell that starts with blanks and then `"`: not quoted (a quote opens a quoted cell only
/// as its first character), the likely cause of a wrong cell count.
fn blank_before_quote(cell: &str) -> bool {
    cell.starts_with(char::is_whitespace) && cell.trim_start().starts_with('"')
}

/// One cell of a [`READING_COLUMNS`] column (`column`, at `(file, line, 1-based column)`):
/// the reading's number or its unit, checked.
fn reading_cell(
    (name, line, j): (&str, usize, usize),
    column: &str,
    cell: &str,
    reading: &mut Option<f64>,
    unit: &mut Option<(crate::model::instrument::ReadingUnit, usize)>,
) -> Result<()> {
    let t = cell.trim();
    if t.is_empty() {
        return Ok(());
    }
    if column == "reading" {
        *reading = Some(t.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| {
            anyhow::anyhow!(
                "{name}:{line}: column {j} (`reading`) holds `{t}`; expected a finite number, the instrument's raw reading in the row's `reading_unit`"
            )
        })?);
    } else {
        let u = crate::model::instrument::ReadingUnit::parse(t).ok_or_else(|| {
            anyhow::anyhow!(
                "{name}:{line}: column {j} (`reading_unit`) holds `{t}`; expected one of {}",
                crate::model::instrument::ReadingUnit::names()
            )
        })?;
        *unit = Some((u, j));
    }
    Ok(())
}

/// The refusal of a row whose measurement `what` (e.g. "the row's measurement") two
/// sources give, each a 1-based column and its name; `all` the sources a row may give it
/// in (the case frame's [`MEASUREMENT_SOURCES`], a triad file's per axis): one wording for
/// every file that takes more than one source.
#[must_use]
pub fn two_sources(
    name: &str,
    line: usize,
    (j1, first): (usize, &str),
    (j2, second): (usize, &str),
    what: &str,
    all: &[&str],
) -> String {
    format!(
        "{name}:{line}: column {j1} (`{first}`) and column {j2} (`{second}`) both give {what}; expected one of {} in a row, the others empty",
        all.join(", ")
    )
}

/// A row's measurement: at most one of [`MEASUREMENT_SOURCES`] (`sources`: the given ones,
/// by 1-based column), and its raw reading with its unit (none in a response row).
fn one_source(
    name: &str,
    line: usize,
    cols: &[usize],
    sources: &[(usize, &str, usize)],
    reading: Option<f64>,
    unit: Option<(crate::model::instrument::ReadingUnit, usize)>,
    kind: RowKind,
) -> Result<Option<Reading>> {
    if let [(j1, first, _), (j2, second, _), ..] = sources[..] {
        let all: Vec<&str> = MEASUREMENT_SOURCES.iter().map(|&(_, n)| n).collect();
        bail!(two_sources(
            name,
            line,
            (j1, first),
            (j2, second),
            "the row's measurement",
            &all
        ));
    }
    let reading = match (reading, unit) {
        (Some(v), Some((u, j))) => Some((v, u, j)),
        (Some(_), None) => {
            let j = cols
                .iter()
                .position(|&k| header_name(k) == "reading")
                .map_or(0, |j| j + 1);
            bail!(
                "{name}:{line}: column {j} (`reading`) is given without its unit; expected a `reading_unit` column and cell on the row ({})",
                crate::model::instrument::ReadingUnit::names()
            );
        }
        (None, _) => None,
    };
    if reading.is_some() && kind == RowKind::Response {
        bail!(
            "{name}:{line}: a response row holds `reading`; expected its measurement in `measured_gain` and `measured_phase_deg`"
        );
    }
    Ok(reading)
}

/// A row's raw reading as read: value, unit, and the 1-based header column of its unit.
type Reading = (f64, crate::model::instrument::ReadingUnit, usize);

/// One data row, the columns whose cell was empty and read as 0, and its raw reading.
fn parse_row(
    name: &str,
    line: usize,
    cells: &[String],
    cols: &[usize],
) -> Result<(Condition, Vec<&'static str>, Option<Reading>)> {
    let mut cells = read_cells(name, line, cells, cols)?;
    let c = &mut cells.row;
    check_oscillation(name, line, c)?;
    check_response(name, line, c)?;
    check_centrifuge(name, line, c)?;
    check_power_on(name, line, c, cols)?;
    let reading = one_source(
        name,
        line,
        cols,
        &cells.sources,
        cells.reading,
        cells.unit,
        c.kind,
    )?;
    check_counts(name, line, c, cols)?;
    if c.label.is_empty() {
        c.label = format!("line {line}");
    }
    Ok((cells.row, cells.empty, reading))
}

/// A row's cells as read, before the checks across its columns.
struct Cells {
    row: Condition,
    /// The columns whose cell was empty and read as 0.
    empty: Vec<&'static str>,
    /// The measurement sources the row gives, by header column (one at most): the 1-based
    /// column, its name and its source.
    sources: Vec<(usize, &'static str, usize)>,
    /// The raw reading and its unit with the unit's column.
    reading: Option<f64>,
    unit: Option<(crate::model::instrument::ReadingUnit, usize)>,
}

/// Every cell of a data row read into its column (as many cells as the header: `records`
/// checked it); a cell that is not what its column expects refused with its column.
fn read_cells(name: &str, line: usize, cells: &[String], cols: &[usize]) -> Result<Cells> {
    let mut r = Cells {
        row: Condition::default(),
        empty: Vec::new(),
        sources: Vec::new(),
        reading: None,
        unit: None,
    };
    for (j, (cell, &k)) in cells.iter().map(String::as_str).zip(cols).enumerate() {
        if let Some(g) = measurement_source(header_name(k))
            && !cell.trim().is_empty()
            && !r.sources.iter().any(|&(_, _, h)| h == g)
        {
            r.sources.push((j + 1, header_name(k), g));
        }
        if k >= COLUMNS.len() {
            reading_cell(
                (name, line, j + 1),
                header_name(k),
                cell,
                &mut r.reading,
                &mut r.unit,
            )?;
            continue;
        }
        let col = &COLUMNS[k];
        let check = match col.check {
            Check::Text => {
                let t = if col.name == "label" {
                    cell
                } else {
                    cell.trim()
                };
                (col.set)(
                    &mut r.row,
                    Value::Text((!t.is_empty()).then(|| t.to_string())),
                );
                continue;
            }
            Check::OneOf(words) => {
                let t = cell.trim();
                if !t.is_empty() && !words.contains(&t) {
                    bail!(
                        "{name}:{line}: column {} (`{}`) holds `{t}`; expected {}",
                        j + 1,
                        col.name,
                        col.expected
                    );
                }
                (col.set)(
                    &mut r.row,
                    Value::Text((!t.is_empty()).then(|| t.to_string())),
                );
                continue;
            }
            check => check,
        };
        let s = cell.trim();
        if s.is_empty() {
            if empty_reads_as_zero(col) {
                r.empty.push(col.name);
            }
            continue;
        }
        let v = s.parse::<f64>().ok().filter(|v| {
            v.is_finite()
                && match check {
                    Check::NonNegative => *v >= 0.0,
                    Check::Positive => *v > 0.0,
                    Check::Count => is_count(*v),
                    Check::Finite | Check::Text | Check::OneOf(_) => true,
                }
        });
        let Some(v) = v else {
            bail!(
                "{name}:{line}: column {} (`{}`) holds `{s}`; expected {}",
                j + 1,
                col.name,
                col.expected
            );
        };
        (col.set)(&mut r.row, Value::Num(Some(v)));
    }
    Ok(r)
}

/// A static row (`freq_hz` 0) holds no oscillation.
fn check_oscillation(name: &str, line: usize, c: &Condition) -> Result<()> {
    if c.freq_hz != 0.0 {
        return Ok(());
    }
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
    Ok(())
}

/// A response row has a frequency, an input along IA and a gain and phase, not a value;
/// no other row has a gain or phase.
fn check_response(name: &str, line: usize, c: &Condition) -> Result<()> {
    if c.kind == RowKind::Response {
        if c.freq_hz <= 0.0 {
            bail!(
                "{name}:{line}: a response row without a frequency; expected `freq_hz` greater than 0 (the sine's frequency)"
            );
        }
        if c.lin_cm_s2[0] == 0.0 {
            bail!(
                "{name}:{line}: a response row without an input; expected `lin_ia_cm_s2`, the sine's amplitude along IA"
            );
        }
        if c.measured_cm_s2.is_some() {
            bail!(
                "{name}:{line}: a response row holds `measured_cm_s2`; expected its measurement in `measured_gain` and `measured_phase_deg`"
            );
        }
    } else if c.measured_gain.is_some() || c.measured_phase_deg.is_some() {
        bail!(
            "{name}:{line}: `measured_gain`/`measured_phase_deg` in a {} row; expected them only with kind = response",
            c.kind.name()
        );
    }
    Ok(())
}

/// A centrifuge row (`radius_cm` not 0) has a rate, and an arm whose direction is defined.
fn check_centrifuge(name: &str, line: usize, c: &Condition) -> Result<()> {
    if c.radius_cm == 0.0 {
        return Ok(());
    }
    if c.w_rad_s.iter().all(|&w| w == 0.0) {
        bail!(
            "{name}:{line}: column `radius_cm` is {} but the row has no rate (`w_ia_rad_s`, `w_pa_rad_s`, `w_oa_rad_s` all 0); expected the centrifuge's rate for a centrifuge row",
            c.radius_cm
        );
    }
    if c.centripetal_cm_s2(c.w_rad_s).is_none() || c.centripetal_cm_s2(c.ref_w_rad_s).is_none() {
        bail!(
            "{name}:{line}: column `radius_cm` is {} but IA lies along the spin axis (the rates point along IA), so the arm's direction is undefined; expected IA in or tilted out of the turntable plane (docs/reference/case-frame-format.md, centrifuge rows)",
            c.radius_cm
        );
    }
    Ok(())
}

/// `power_on_s` is read on the row's `time_s` clock, at or before it.
fn check_power_on(name: &str, line: usize, c: &Condition, cols: &[usize]) -> Result<()> {
    let Some(p) = c.power_on_s else {
        return Ok(());
    };
    let j = column_at(cols, "power_on_s");
    match c.time_s {
        None => bail!(
            "{name}:{line}: column {j} (`power_on_s`) is {p} but the row has no `time_s`; expected `time_s` on the row, on the clock `power_on_s` is read on"
        ),
        Some(t) if p > t => bail!(
            "{name}:{line}: column {j} (`power_on_s`) is {p} s, after the row's `time_s` {t} s; expected the time the instrument was switched on before this row, at or before its `time_s`"
        ),
        Some(_) => Ok(()),
    }
}

/// The 1-based column of `name` in the header `cols` (0 when it is not there).
fn column_at(cols: &[usize], name: &str) -> usize {
    cols.iter()
        .position(|&k| header_name(k) == name)
        .map_or(0, |j| j + 1)
}

/// A row's counts, if it gives them, whole and in an absolute row: both `pulses` and
/// `ticks`, `ticks` > 0 and `pulses` ≤ `ticks` (that no other source gives the row's
/// measurement beside them is checked with [`MEASUREMENT_SOURCES`]).
fn check_counts(name: &str, line: usize, c: &Condition, cols: &[usize]) -> Result<()> {
    let (p, t) = (c.pulses, c.ticks);
    if p.is_none() && t.is_none() {
        return Ok(());
    }
    let (jp, jt) = (column_at(cols, "pulses"), column_at(cols, "ticks"));
    if c.kind != RowKind::Absolute {
        let (j, n) = if p.is_some() {
            (jp, "pulses")
        } else {
            (jt, "ticks")
        };
        bail!(
            "{name}:{line}: column {j} (`{n}`) in a {} row; expected counts only in an absolute row (one gate's reading: a tumble or centrifuge position; a difference row gives the difference of two readings in `measured_cm_s2`, a response row comes from a counter record through `ptsa response`)",
            c.kind.name()
        );
    }
    check_gate(name, line, (p, jp, "pulses"), (t, jt, "ticks"))
}

/// The checks of one gate's counts, whole numbers already (the cells' [`Column::expected`]
/// of `pulses` and `ticks`): both or neither, `ticks` > 0, `pulses` ≤ `ticks`. Each count
/// comes with its 1-based column (0: not a column of the file) and its column's name
/// (`pulses`, `ticks`; a triad file's `pulses_x`, `ticks_x`, …).
///
/// # Errors
/// One count without the other; a gate of 0 ticks; more pulses than ticks. The message
/// names `name`, the line and the column.
pub fn check_gate(
    name: &str,
    line: usize,
    (p, jp, pn): (Option<f64>, usize, &str),
    (t, jt, tn): (Option<f64>, usize, &str),
) -> Result<()> {
    match (p, t) {
        (Some(_), None) => bail!(
            "{name}:{line}: column {jp} (`{pn}`) is given but `{tn}` is {}; expected both counts of the gate: the pulses P and the clock ticks T",
            if jt == 0 { "not a column" } else { "empty" }
        ),
        (None, Some(_)) => bail!(
            "{name}:{line}: column {jt} (`{tn}`) is given but `{pn}` is {}; expected both counts of the gate: the pulses P and the clock ticks T",
            if jp == 0 { "not a column" } else { "empty" }
        ),
        (Some(p), Some(0.0)) => bail!(
            "{name}:{line}: column {jt} (`{tn}`) is 0 (with {p} pulses); expected a gate of at least one clock tick"
        ),
        (Some(p), Some(t)) if p > t => bail!(
            "{name}:{line}: column {jp} (`{pn}`) is {p}, more than the gate's {t} ticks (column {jt}); expected 0 ≤ pulses ≤ ticks (one pulse per tick at most)"
        ),
        _ => Ok(()),
    }
}

/// Whether a cell's number `v` is a count: a whole number from 0 to [`MAX_COUNT`] (the
/// check of the `pulses` and `ticks` columns, and of a triad file's counts).
#[must_use]
pub fn is_count(v: f64) -> bool {
    v.is_finite() && v >= 0.0 && v.fract() == 0.0 && v <= MAX_COUNT
}

/// Read a case-frame file.
///
/// # Errors
/// The file cannot be read, or [`parse_bytes`] fails (the message names the file).
pub fn read(path: &Path) -> Result<Vec<Condition>> {
    read_frame(path).map(|f| f.rows)
}

/// [`read`], with the record of the empty input cells read as 0.
///
/// # Errors
/// As [`read`].
pub fn read_frame(path: &Path) -> Result<Frame> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    parse_bytes_frame(&path.display().to_string(), &bytes)
}

fn fmt_num(v: f64) -> String {
    if v == 0.0 {
        "0".to_string()
    } else {
        format!("{v}")
    }
}

/// Whether a value is worth a column (not empty, not 0).
fn given(v: &Value) -> bool {
    match v {
        Value::Text(t) => t
            .as_ref()
            .is_some_and(|t| !t.is_empty() && t != RowKind::Difference.name()),
        Value::Num(x) => x.is_some_and(|x| x != 0.0),
    }
}

/// A row as an object of its case-frame columns (those that are not empty or zero, and the
/// label), numbers as numbers.
#[must_use]
pub fn to_object(c: &Condition) -> serde_json::Map<String, serde_json::Value> {
    let mut m = serde_json::Map::new();
    for col in COLUMNS {
        let v = (col.get)(c);
        if col.name == "label" || given(&v) {
            m.insert(
                col.name.to_string(),
                match v {
                    Value::Text(t) => t.unwrap_or_default().into(),
                    Value::Num(x) => x.map_or(serde_json::Value::Null, Into::into),
                },
            );
        }
    }
    m
}

/// Render rows as case-frame CSV: `comments` (each line prefixed with `# `), the header
/// (columns that are empty or zero in every row are left out, except `label` and
/// `measured_cm_s2`; a column whose empty cell means "not given", such as `sigma_cm_s2`,
/// `time_s` or `temp_c`, whenever a row gives it, 0 included), then one line per row.
#[must_use]
pub fn to_csv(rows: &[Condition], comments: &[&str]) -> String {
    to_csv_with(rows, comments, &[])
}

/// [`to_csv`], with the columns named in `also` written even where every cell is empty
/// (a plan's columns for the lab to fill in, such as `temp_c`).
#[must_use]
pub fn to_csv_with(rows: &[Condition], comments: &[&str], also: &[&str]) -> String {
    write(rows, comments, &used_columns(rows, also, "measured_cm_s2"))
}

/// [`to_csv_with`] for a design whose readings are to be counted: `pulses` and `ticks`,
/// written even where every cell is empty, in place of `measured_cm_s2` (which is written
/// only where a row gives it).
#[must_use]
pub fn to_csv_counts(rows: &[Condition], comments: &[&str], also: &[&str]) -> String {
    let mut also = also.to_vec();
    also.extend(["pulses", "ticks"]);
    write(rows, comments, &used_columns(rows, &also, "pulses"))
}

/// The columns [`to_csv_with`] writes: `label`, `always`, the columns in `also`, and
/// those some row gives.
fn used_columns(rows: &[Condition], also: &[&str], always: &str) -> Vec<usize> {
    (0..COLUMNS.len())
        .filter(|&k| {
            let col = &COLUMNS[k];
            // A number where an empty cell means "not given" (`time_s`, `temp_c`, a
            // measurement or a sigma) is given even when it is 0 (0 °C, a phase of 0°).
            let optional = !col.is_text() && !empty_reads_as_zero(col);
            col.name == "label"
                || col.name == always
                || also.contains(&col.name)
                || rows.iter().any(|c| {
                    let v = (col.get)(c);
                    given(&v) || (optional && matches!(v, Value::Num(Some(_))))
                })
        })
        .collect()
}

/// `rows` as case-frame CSV of exactly `columns` (case-frame column names), in that order,
/// after `comments` (each a `# ` line): the writer of [`to_csv`], for a caller that owns its
/// column set (`ptsa response`'s rows).
///
/// # Panics
/// If a name is not a case-frame column (a programming error: the names are constants).
#[must_use]
pub fn to_csv_columns(rows: &[Condition], comments: &[&str], columns: &[&str]) -> String {
    let used: Vec<usize> = columns
        .iter()
        .map(|&name| {
            column_index(name).unwrap_or_else(|| panic!("`{name}` is not a case-frame column"))
        })
        .collect();
    write(rows, comments, &used)
}

/// The one writer: `comments`, the header of the columns `used` (indices into
/// [`COLUMNS`]), one line per row.
fn write(rows: &[Condition], comments: &[&str], used: &[usize]) -> String {
    let mut out = String::new();
    for c in comments {
        let _ = writeln!(out, "# {c}");
    }
    let names: Vec<&str> = used.iter().map(|&k| COLUMNS[k].name).collect();
    let _ = writeln!(out, "{}", names.join(","));
    for c in rows {
        let cells: Vec<String> = used
            .iter()
            .map(|&k| match (COLUMNS[k].get)(c) {
                Value::Text(t) => t.as_deref().map(quote).unwrap_or_default(),
                Value::Num(x) => x.map(fmt_num).unwrap_or_default(),
            })
            .collect();
        let _ = writeln!(out, "{}", cells.join(","));
    }
    out
}

fn quote(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) || s.starts_with('#') || s.trim() != s {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// One CSV record of a case-frame-like file: its 1-based line in the file and its cells.
#[derive(Clone, Debug)]
pub struct Record {
    /// The record's line in the file.
    pub line: usize,
    /// Its cells, as written (not trimmed).
    pub cells: Vec<String>,
}

/// The records of a case-frame-like file under the case-frame's CSV rules and with its
/// errors (for another reader of the same kind of file, such as the triad's): UTF-8 (a
/// UTF-16 file, bytes that are not UTF-8 or a NUL refused), a byte-order mark and CRLF
/// line ends accepted, comment and blank lines skipped, no cell spanning lines, every data
/// row as many cells as the header. Returns the header, the 1-based character column of
/// each of its cells (`None` where it cannot be found) and the data records. `header_of`
/// names what the header should hold, for the error of a file without one.
///
/// # Errors
/// As [`parse_bytes`] for the encoding and the CSV itself; no header line.
pub fn records(
    name: &str,
    bytes: &[u8],
    header_of: &str,
) -> Result<(Record, Vec<Option<usize>>, Vec<Record>)> {
    let ((h, at), rows) =
        records_with(name, bytes, header_of, |h, at| Ok((h.clone(), at.to_vec())))?;
    Ok((h, at, rows))
}

/// [`records`], with the header read by `on_header` (given the header and the column of
/// each of its cells) as soon as it is met, before any data row is checked: a header's
/// error is the file's first.
///
/// # Errors
/// As [`records`], and `on_header`'s.
pub fn records_with<H>(
    name: &str,
    bytes: &[u8],
    header_of: &str,
    on_header: impl FnOnce(&Record, &[Option<usize>]) -> Result<H>,
) -> Result<(H, Vec<Record>)> {
    let mut on_header = Some(on_header);
    let mut read: Option<H> = None;
    if bytes.starts_with(&[0xFF, 0xFE]) || bytes.starts_with(&[0xFE, 0xFF]) {
        bail!(
            "{name}:1: the file is UTF-16 text (it starts with a UTF-16 byte-order mark); \
             expected UTF-8 text ({SAVE_AS_UTF8})"
        );
    }
    let text = match std::str::from_utf8(bytes) {
        Ok(t) => t,
        Err(e) => {
            let off = e.valid_up_to();
            let byte = bytes.get(off).copied().unwrap_or_default();
            bail!(
                "{name}:{}: the file is not UTF-8 text: byte 0x{byte:02X} at byte offset {off} \
                 is not valid UTF-8; expected UTF-8 text ({SAVE_AS_UTF8})",
                line_of(bytes, off)
            );
        }
    };
    if let Some(off) = text.find('\0') {
        bail!(
            "{name}:{}: the file holds a NUL character (byte offset {off}); expected UTF-8 \
             text, not UTF-16 or a binary file ({SAVE_AS_UTF8})",
            line_of(text.as_bytes(), off)
        );
    }
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let data = DataLines::new(text);
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(data.text.as_bytes());
    let mut header: Option<(Record, Vec<Option<usize>>)> = None;
    let mut rows = Vec::new();
    for record in reader.records() {
        let record = match record {
            Ok(r) => r,
            Err(e) => {
                let line = e.position().map_or(0, |p| data.file_line(p.line()));
                bail!("{name}:{line}: malformed CSV line: {e}");
            }
        };
        let line = record.position().map_or(0, |p| data.file_line(p.line()));
        if record.iter().any(|cell| cell.contains('\n')) {
            bail!(
                "{name}:{line}: malformed CSV line: unterminated quoted cell; expected a \
                 closing `\"` on the same line (a cell cannot span lines)"
            );
        }
        let cells: Vec<String> = record.iter().map(str::to_string).collect();
        match &header {
            None => {
                let raw = text.lines().nth(line.saturating_sub(1)).unwrap_or_default();
                let h = Record { line, cells };
                let at = header_columns(raw, &record);
                if let Some(f) = on_header.take() {
                    read = Some(f(&h, &at)?);
                }
                header = Some((h, at));
            }
            Some((h, _)) => {
                if cells.len() != h.cells.len() {
                    let hint = match record.iter().position(blank_before_quote) {
                        Some(j) => format!(
                            "; column {} starts with a blank before `\"`, so it is not a quoted \
                             cell: put the quote right after the comma",
                            j + 1
                        ),
                        None => String::new(),
                    };
                    bail!(
                        "{name}:{line}: {} cells, expected {} (one per header column){hint}",
                        cells.len(),
                        h.cells.len()
                    );
                }
                rows.push(Record { line, cells });
            }
        }
    }
    let (Some(_), Some(h)) = (header, read) else {
        bail!(
            "{name}: no header line (the file is empty or holds only comments and blank \
             lines); expected a CSV header of {header_of}"
        );
    };
    Ok((h, rows))
}

/// The first header cell (trimmed, in order) of a case-frame-like text, without reading
/// further: what a caller looks at to tell one kind of file from another. Empty when the
/// bytes are not UTF-8 or hold no header (the reader then says why).
#[must_use]
pub fn header_cells(bytes: &[u8]) -> Vec<String> {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return Vec::new();
    };
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let data = DataLines::new(text);
    csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(data.text.as_bytes())
        .records()
        .next()
        .and_then(Result::ok)
        .map(|r| r.iter().map(|c| c.trim().to_string()).collect())
        .unwrap_or_default()
}

#[cfg(test)]
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;

    /// Every column the reader accepts is written by the writer and read back: each
    /// column, given in a row of 20 Hz (a response row for the response columns), comes out
    /// of [`to_csv`] under its name and [`parse`] gives the same row back.
    #[test]
    fn every_column_the_reader_accepts_the_writer_writes() {
        for col in COLUMNS.iter().filter(|c| c.name != "label") {
            // A sine's frequency, for the oscillation and response columns.
            let mut c = Condition {
                label: "r".into(),
                freq_hz: 20.0,
                ..Condition::default()
            };
            if col.name.contains("gain") || col.name.contains("phase") {
                c.kind = RowKind::Response;
                c.lin_cm_s2 = [2000.0, 0.0, 0.0];
            }
            if col.name == "radius_cm" {
                // A centrifuge arm turns at a rate.
                c.w_rad_s = [0.0, 0.0, 3.0];
            }
            if col.name == "power_on_s" {
                // A power-on time is on the clock of the row's time.
                c.time_s = Some(1.0);
            }
            if col.check == Check::Count {
                // Counts come in pairs, in an absolute row.
                c.kind = RowKind::Absolute;
                (c.pulses, c.ticks) = (Some(3.0), Some(7.0));
            }
            let v = match col.check {
                Check::Text => Value::Text(Some("t 1".into())),
                // A word other than the empty cell's (the first).
                Check::OneOf(words) => Value::Text(words.get(1).map(|w| (*w).to_string())),
                Check::Finite | Check::NonNegative | Check::Positive => Value::Num(Some(0.75)),
                Check::Count => Value::Num(Some(5.0)),
            };
            (col.set)(&mut c, v.clone());
            assert_eq!((col.get)(&c), v, "{}: set, get", col.name);
            let text = to_csv(std::slice::from_ref(&c), &[]);
            let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
            assert!(
                header.contains(&col.name),
                "{}: not written:\n{text}",
                col.name
            );
            let back = parse("t.csv", &text).unwrap_or_else(|e| panic!("{}: {e:#}", col.name));
            assert_eq!(back, vec![c], "{}", col.name);
        }
    }

    #[test]
    fn round_trip_keeps_every_field() {
        let c = Condition {
            label: "a, \"quoted\" row".into(),
            kind: RowKind::Absolute,
            radius_cm: 12.5,
            block: Some("run 2, morning".into()),
            time_s: Some(3600.5),
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
            ..Condition::default()
        };
        let text = to_csv(std::slice::from_ref(&c), &["test"]);
        let back = parse("t.csv", &text).unwrap();
        assert_eq!(back, vec![c]);
        // A response row.
        let c = Condition {
            label: "20 Hz".into(),
            kind: RowKind::Response,
            freq_hz: 20.0,
            lin_cm_s2: [2000.0, 0.0, 0.0],
            measured_gain: Some(0.83),
            measured_phase_deg: Some(-31.5),
            sigma_gain: Some(0.004),
            sigma_phase_deg: Some(0.3),
            ..Condition::default()
        };
        let text = to_csv(std::slice::from_ref(&c), &["test"]);
        let back = parse("t.csv", &text).unwrap();
        assert_eq!(back, vec![c]);
    }

    #[test]
    fn empty_input_cells_read_as_zero_are_recorded_beside_the_rows() {
        let text = "# c\nlabel,time_s,g_ia,g_pa,freq_hz,measured_cm_s2,sigma_cm_s2\n\
                    a,1,0.5,0.5,,1.0,\n\
                    b,,, 0.7,0,2.0,0.1\n\
                    c,3,1,0,0,,0.1\n";
        let f = parse_frame("t.csv", text).unwrap();
        assert_eq!(f.rows, parse("t.csv", text).unwrap());
        assert_eq!(f.rows[1].g, [0.0, 0.7, 0.0]);
        // Empty `time_s`, `measured_cm_s2` and `sigma_cm_s2` mean "not given", not 0; a
        // column left out of the header is no empty cell.
        assert_eq!(
            f.empty,
            vec![
                EmptyCells {
                    row: 0,
                    line: 3,
                    columns: vec!["freq_hz"],
                },
                EmptyCells {
                    row: 1,
                    line: 4,
                    columns: vec!["g_ia"],
                },
            ]
        );
        assert_eq!(parse_bytes_frame("t.csv", text.as_bytes()).unwrap(), f);
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

    fn err(text: &str) -> String {
        format!("{:#}", parse("t.csv", text).unwrap_err())
    }

    /// `approach` takes `up`, `down`, `+`, `-` or an empty cell and nothing else;
    /// `temp_c` is a number, given on every measured row or on none.
    #[test]
    fn approach_and_temperature_cells() {
        use Approach::{Down, Up};
        let rows = parse(
            "t.csv",
            "label,kind,g_ia,approach,temp_c,measured_cm_s2\n\
             a,absolute,1,up,21.5,1\nb,absolute,0,-,22,1\nc,absolute,-1,,22.5,1\n\
             d,absolute,0, down ,23,1\ne,absolute,1,+,,\n",
        )
        .unwrap();
        let a: Vec<Option<Approach>> = rows.iter().map(|r| r.approach).collect();
        assert_eq!(a, [Some(Up), Some(Down), None, Some(Down), Some(Up)]);
        let t: Vec<Option<f64>> = rows.iter().map(|r| r.temp_c).collect();
        assert_eq!(t, [Some(21.5), Some(22.0), Some(22.5), Some(23.0), None]);
        let m = err("label,approach\nx,rising\n");
        assert!(
            m.starts_with("t.csv:2: column 2 (`approach`) holds `rising`; expected `up` or `+`"),
            "{m}"
        );
        let m = err("g_ia,temp_c\n1,warm\n");
        assert!(
            m.starts_with(
                "t.csv:2: column 2 (`temp_c`) holds `warm`; expected a finite temperature"
            ),
            "{m}"
        );
        // A measured row without a temperature in a file that gives them.
        let m = err("label,temp_c,measured_cm_s2\na,21,1\nb,,2\nc,22,3\n");
        assert!(
            m.starts_with("t.csv:3: column 2 (`temp_c`) is empty in a measured row (`b`), but 2 other rows give a temperature"),
            "{m}"
        );
        // 0 °C is a temperature (and a time of 0 a time): written, read back.
        let cold = Condition {
            label: "c".into(),
            temp_c: Some(0.0),
            time_s: Some(0.0),
            ..Condition::default()
        };
        let text = to_csv(std::slice::from_ref(&cold), &[]);
        assert!(
            text.starts_with("label,time_s,measured_cm_s2,temp_c\n"),
            "{text}"
        );
        assert_eq!(parse("t.csv", &text).unwrap(), vec![cold]);
        // No temperature anywhere, or only unmeasured rows without one: accepted.
        assert!(parse("t.csv", "label,temp_c,measured_cm_s2\na,,1\nb,,2\n").is_ok());
        assert!(parse("t.csv", "label,temp_c,measured_cm_s2\na,21,1\nb,,\n").is_ok());
    }

    /// `pulses` and `ticks`: whole numbers, both or neither, `ticks` > 0, `pulses` ≤
    /// `ticks`, in absolute rows, never beside `measured_cm_s2`; each refusal names the
    /// file, the line, the column and what was expected.
    #[test]
    fn count_cells() {
        let rows = parse(
            "t.csv",
            "label,kind,g_ia,pulses,ticks,measured_cm_s2\n\
             a,absolute,1,2009123,3840000,\n\
             b,absolute,-1,,,\n\
             c,absolute,0,,,0.5\n\
             d,absolute,0,0,1,\n",
        )
        .unwrap();
        assert_eq!(
            (rows[0].pulses, rows[0].ticks),
            (Some(2_009_123.0), Some(3_840_000.0))
        );
        assert_eq!(rows[0].measured_cm_s2, None);
        assert!(rows[0].is_measured() && !rows[1].is_measured() && rows[2].is_measured());
        assert_eq!((rows[3].pulses, rows[3].ticks), (Some(0.0), Some(1.0)));
        for (text, want) in [
            (
                "kind,pulses,ticks\nabsolute,1.5,10\n",
                "t.csv:2: column 2 (`pulses`) holds `1.5`; expected a whole number of pulses",
            ),
            (
                "kind,pulses,ticks\nabsolute,-1,10\n",
                "t.csv:2: column 2 (`pulses`) holds `-1`; expected a whole number",
            ),
            (
                "kind,pulses,ticks\nabsolute,1,1e300\n",
                "t.csv:2: column 3 (`ticks`) holds `1e300`; expected a whole number of clock ticks",
            ),
            (
                "kind,pulses,ticks\nabsolute,11,10\n",
                "t.csv:2: column 2 (`pulses`) is 11, more than the gate's 10 ticks (column 3); expected 0 ≤ pulses ≤ ticks",
            ),
            (
                "kind,pulses,ticks\nabsolute,0,0\n",
                "t.csv:2: column 3 (`ticks`) is 0 (with 0 pulses); expected a gate of at least one clock tick",
            ),
            (
                "kind,pulses,ticks\nabsolute,5,\n",
                "t.csv:2: column 2 (`pulses`) is given but `ticks` is empty; expected both counts",
            ),
            (
                "kind,ticks\nabsolute,5\n",
                "t.csv:2: column 2 (`ticks`) is given but `pulses` is not a column; expected both counts",
            ),
            (
                "label,pulses,ticks\nx,5,10\n",
                "t.csv:2: column 2 (`pulses`) in a difference row; expected counts only in an absolute row",
            ),
            (
                "label,kind,freq_hz,lin_ia_cm_s2,ticks\nx,response,10,100,10\n",
                "t.csv:2: column 5 (`ticks`) in a response row; expected counts only in an absolute row",
            ),
            (
                "kind,measured_cm_s2,ticks,pulses\nabsolute,1.0,10,5\n",
                "t.csv:2: column 2 (`measured_cm_s2`) and column 3 (`ticks`) both give the row's measurement; expected one of `measured_cm_s2`, `pulses` with `ticks`, `reading` with `reading_unit` in a row",
            ),
            (
                "kind,measured_cm_s2,ticks\nabsolute,1.0,10\n",
                "t.csv:2: column 2 (`measured_cm_s2`) and column 3 (`ticks`) both give",
            ),
        ] {
            let m = err(text);
            assert!(m.starts_with(want), "{text:?}: {m}");
        }
        // A design to count: `pulses` and `ticks` in place of `measured_cm_s2`.
        let plan = vec![Condition {
            label: "up".into(),
            kind: RowKind::Absolute,
            g: [1.0, 0.0, 0.0],
            ..Condition::default()
        }];
        let text = to_csv_counts(&plan, &["c"], &["temp_c"]);
        assert_eq!(
            text,
            "# c\nlabel,kind,g_ia,pulses,ticks,temp_c\nup,absolute,1,,,\n"
        );
        assert_eq!(parse("t.csv", &text).unwrap(), plan);
    }

    fn err_bytes(bytes: &[u8]) -> String {
        format!("{:#}", parse_bytes("t.csv", bytes).unwrap_err())
    }

    #[test]
    fn byte_order_mark_crlf_and_indented_comments_are_accepted() {
        let text =
            "\u{feff}# source\r\nlabel,g_ia\r\nx,1\r\n\r\n  # indented comment\r\n \t\r\ny,2\r\n";
        for rows in [
            parse("t.csv", text).unwrap(),
            parse_bytes("t.csv", text.as_bytes()).unwrap(),
        ] {
            assert_eq!(rows.len(), 2);
            assert_eq!((rows[0].label.as_str(), rows[0].g[0]), ("x", 1.0));
            assert_eq!((rows[1].label.as_str(), rows[1].g[0]), ("y", 2.0));
        }
        // Line numbers count the BOM line, CRLF lines, comments and blank lines.
        let m = err("\u{feff}label,g_ia\r\n\r\n# c\r\n   # c\r\nx,abc\r\n");
        assert!(
            m.starts_with("t.csv:5: column 2 (`g_ia`) holds `abc`"),
            "{m}"
        );
        // An unlabelled row is named after its file line.
        let rows = parse("t.csv", "# c\r\n\r\ng_ia\r\n\r\n1\r\n").unwrap();
        assert_eq!(rows[0].label, "line 5");
    }

    #[test]
    fn semicolon_and_tab_separated_files_get_a_hint() {
        let m = err("# c\nlabel;g_ia;measured_cm_s2\nx;0,5;1,25\n");
        assert!(
            m.starts_with(
                "t.csv:2: the header has one column `label;g_ia;measured_cm_s2`, which is not \
                 a case-frame column; this looks like a semicolon-separated file: the \
                 case-frame format separates cells with commas"
            ),
            "{m}"
        );
        let m = err("\"label\";\"g_ia\"\n\"x\";1\n");
        assert!(m.contains("semicolon-separated"), "{m}");
        let m = err("label\tg_ia\tmeasured_cm_s2\nx\t0.5\t1.25\n");
        assert!(
            m.starts_with("t.csv:1: the header has one column `label\tg_ia\tmeasured_cm_s2`")
                && m.contains("this looks like a tab-separated file"),
            "{m}"
        );
        // A single unknown column without those separators gets the ordinary message.
        let m = err("bogus\n1\n");
        assert!(m.contains("column 1 of the header is `bogus`") && !m.contains("looks like"));
    }

    /// A header cell in the wrong case or a near miss of a column's name is refused with
    /// its `file:line:column` and the column it was probably meant to be; a name near none, or
    /// as near two columns, gets no guess.
    #[test]
    fn near_miss_header_cells_get_a_did_you_mean() {
        for (text, want) in [
            (
                "# c\nLabel,g_ia\nx,1\n",
                "t.csv:2:1: column 1 of the header is `Label`, which is not a case-frame column (did you mean `label`? column names are lower case); expected one of: label, kind,",
            ),
            (
                "label,G_IA\nx,1\n",
                "t.csv:1:7: column 2 of the header is `G_IA`, which is not a case-frame column (did you mean `g_ia`? column names are lower case)",
            ),
            (
                "label, g-ia ,measured_cm_s2\nx,1,2\n",
                "t.csv:1:8: column 2 of the header is `g-ia`, which is not a case-frame column (did you mean `g_ia`?)",
            ),
            (
                "lable,g_ia\nx,1\n",
                "t.csv:1:1: column 1 of the header is `lable`, which is not a case-frame column (did you mean `label`?)",
            ),
            (
                "label,g_ia,measured_cm_s\nx,1,2\n",
                "t.csv:1:12: column 3 of the header is `measured_cm_s`, which is not a case-frame column (did you mean `measured_cm_s2`?)",
            ),
            (
                "\u{feff}\"label\",\"µ\",\"Sigma_cm_s2\"\nx,1,2\n",
                "t.csv:1:10: column 2 of the header is `µ`, which is not a case-frame column; expected one of:",
            ),
            (
                "label,g_ia,g_ia\nx,1,2\n",
                "t.csv:1:12: column `g_ia` appears twice in the header",
            ),
        ] {
            let m = err(text);
            assert!(m.starts_with(want), "{text:?}: {m}");
        }
        // Equally near two columns (g_ia, g_pa, g_oa): no guess.
        let m = err("label,g_xa\nx,1\n");
        assert!(
            m.contains("`g_xa`, which is not a case-frame column; expected"),
            "{m}"
        );
        assert_eq!(near_column("Sigma_CM_S2"), Some("sigma_cm_s2"));
        assert_eq!(near_column("bogus"), None);
        assert_eq!(edit_distance("lable", "label"), 1);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
    }

    #[test]
    fn text_that_is_not_utf8_is_refused_with_its_line_and_offset() {
        let m = err_bytes(b"label,g_ia\nx,1\n\xB5 rad,2\n");
        assert!(
            m.starts_with(
                "t.csv:3: the file is not UTF-8 text: byte 0xB5 at byte offset 15 is not valid UTF-8"
            ),
            "{m}"
        );
        let m = err_bytes(b"\xFF\xFEl\0a\0b\0e\0l\0\n\0");
        assert!(m.starts_with("t.csv:1: the file is UTF-16 text"), "{m}");
        let m = err_bytes(b"l\0a\0b\0e\0l\0\n\0");
        assert!(m.starts_with("t.csv:1: the file holds a NUL character (byte offset 1)"));
        let m = err_bytes(b"\xEF\xBB\xBFg_ia\n\n1\0\n");
        assert!(
            m.starts_with("t.csv:3: the file holds a NUL character (byte offset 10)"),
            "{m}"
        );
        let m = err_bytes(b"label\nx\n\xE2\x82");
        assert!(m.starts_with("t.csv:3: the file is not UTF-8 text"), "{m}");
    }

    #[test]
    fn quoted_cells_hold_commas_and_doubled_quotes() {
        let rows = parse(
            "t.csv",
            "label,g_ia\n\"a, \"\"b\"\", c\",\" 1.5 \"\n\"\",2\n",
        )
        .unwrap();
        assert_eq!(rows[0].label, "a, \"b\", c");
        assert_eq!(rows[0].g[0], 1.5);
        assert_eq!(rows[1].label, "line 3");
        // A label keeps its blanks; a number may have blanks around it.
        let rows = parse("t.csv", "label , g_ia\n x ,  2 \n").unwrap();
        assert_eq!((rows[0].label.as_str(), rows[0].g[0]), (" x ", 2.0));
    }

    #[test]
    fn unterminated_quotes_are_refused_on_their_line() {
        for text in [
            "label,g_ia\n\"x,1\n",
            "label,g_ia\n\"x,1",
            "label,g_ia\n\"x,1\ny,2\n",
            "label,g_ia\n\"x\n# c\ny\",2\n",
            "label,g_ia\nx,\"",
        ] {
            let m = err(text);
            assert!(
                m.starts_with("t.csv:2: malformed CSV line: unterminated quoted cell"),
                "{text:?}: {m}"
            );
        }
    }

    #[test]
    fn rows_with_too_few_or_too_many_cells_are_refused() {
        assert!(err("label,g_ia\nx,1\nx\n").starts_with("t.csv:3: 1 cells, expected 2"));
        assert!(err("label,g_ia\nx,1,2\n").starts_with("t.csv:2: 3 cells, expected 2"));
        let m = err("g_ia,label\n1, \"a, b\"\n");
        assert!(
            m.starts_with("t.csv:2: 3 cells, expected 2")
                && m.contains("column 2 starts with a blank before `\"`"),
            "{m}"
        );
    }

    #[test]
    fn files_without_a_header_are_refused() {
        for text in ["", "\u{feff}", "\n\n", "# only\n  # comments\r\n\n"] {
            let m = err(text);
            assert!(m.starts_with("t.csv: no header line"), "{text:?}: {m}");
        }
        assert_eq!(parse("t.csv", "label,g_ia\n# no rows\n").unwrap(), vec![]);
    }

    #[test]
    fn labels_that_need_quotes_round_trip() {
        let rows: Vec<Condition> = ["#x", " pad ", "cr\rlf", "semi;colon", "q\"", "tab\there"]
            .iter()
            .map(|l| Condition {
                label: (*l).into(),
                ..Condition::default()
            })
            .collect();
        assert_eq!(parse("t.csv", &to_csv(&rows, &[])).unwrap(), rows);
    }

    /// `reading` and `reading_unit`: read beside the row, converted through the instrument
    /// file into `measured_cm_s2`; a row gives one measurement source, never two; a reading
    /// needs its unit, and a unit must be one of the six.
    #[test]
    #[allow(clippy::float_cmp, reason = "exact conversions of exact numbers")]
    fn readings_are_converted_through_the_instrument_file() {
        use crate::model::instrument::{Instrument, ReadingUnit};
        let text = "label,g_ia,reading,reading_unit,sigma_cm_s2\n\
                    a,1,16384,LSB,0.5\n\
                    b,0,-0.25,g,\n\
                    c,0,,LSB,\n\
                    d,1,,,\n";
        let mut f = parse_frame("r.csv", text).unwrap();
        assert_eq!(f.readings.len(), 2);
        assert_eq!(f.readings[0].unit, ReadingUnit::Lsb);
        assert_eq!((f.readings[1].row, f.readings[1].line), (1, 3));
        assert!(f.rows.iter().all(|r| r.measured_cm_s2.is_none()));
        let mems = Instrument::shipped("mems").unwrap();
        f.convert_readings("r.csv", &mems).unwrap();
        let m: Vec<Option<f64>> = f.rows.iter().map(|r| r.measured_cm_s2).collect();
        assert_eq!(m, [Some(980.665), Some(-0.25 * 980.665), None, None]);
        assert_eq!(f.rows[0].sigma_cm_s2, Some(0.5));
        // The Kearfott file gives no scale in LSB: refused, naming the keys to add.
        let mut f = parse_frame("r.csv", text).unwrap();
        let e = f
            .convert_readings("r.csv", &Instrument::kearfott_2401())
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("r.csv:2: column 4 (`reading_unit`) is `LSB`: a reading in LSB needs the instrument file's nominal scale factor: expected instrument.reading_unit = \"LSB\" and instrument.scale_factor_per_g"),
            "{e}"
        );
        for (text, message) in [
            (
                "label,g_ia,measured_cm_s2,reading,reading_unit\na,1,980,1,g\n",
                "t.csv:2: column 3 (`measured_cm_s2`) and column 4 (`reading`) both give the row's measurement; expected one of `measured_cm_s2`, `pulses` with `ticks`, `reading` with `reading_unit` in a row",
            ),
            (
                "label,g_ia,reading\na,1,1\n",
                "t.csv:2: column 3 (`reading`) is given without its unit",
            ),
            (
                "label,g_ia,reading,reading_unit\na,1,1,counts\n",
                "t.csv:2: column 4 (`reading_unit`) holds `counts`; expected one of V, mA, LSB, g, m/s², cm/s²",
            ),
            (
                "label,g_ia,reading,reading_unit\na,1,x,g\n",
                "t.csv:2: column 3 (`reading`) holds `x`; expected a finite number",
            ),
            ("label,reading,reading_unit\nlabel,1,g\n", ""),
            (
                "label,kind,freq_hz,lin_ia_cm_s2,reading,reading_unit\nr,response,10,100,1,g\n",
                "t.csv:2: a response row holds `reading`",
            ),
        ] {
            match parse_frame("t.csv", text) {
                Ok(_) => assert!(message.is_empty(), "{text}"),
                Err(e) => assert!(
                    e.to_string().starts_with(message) && !message.is_empty(),
                    "{e}"
                ),
            }
        }
        // The header names them among the columns it expects.
        let e = err("label,readings\nx,1\n");
        assert!(
            e.contains("(did you mean") || e.contains("reading, reading_unit"),
            "{e}"
        );
    }
}
