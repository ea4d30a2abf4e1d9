//! A static record of readings (`ptsa noise --readings FILE`): one sample per row, CSV with
//! the columns `time_s` and `reading` (in any order, among others), evenly spaced in time.
//! Any instrument's record comes in this way: a MEMS part's samples, a DVM's readings of a
//! servo accelerometer's current, a PTSA loop's readings in cm/s².
//!
//! The reader is built for long records (10⁷ rows): the rows are parsed in parallel, in
//! blocks of whole lines, and every refusal names the file, the line and the column. The
//! record is refused, not repaired, when its samples are not evenly spaced: a duplicate or
//! out-of-order time, a gap, or a spacing beyond the tolerance of the record's own median
//! spacing. The reading's unit is the instrument file's (`instrument.reading_unit`), or
//! cm/s² for a file without one, unless the caller says otherwise; it becomes cm/s²
//! through the file ([`Instrument::reading_to_cm_s2`]).

use std::path::Path;

use anyhow::{Context as _, Result, bail};
use rayon::prelude::*;

use crate::model::instrument::{Instrument, ReadingUnit};

/// Fewest samples analysed: three octaves.
pub const MIN_SAMPLES: usize = super::MIN_GATES;

/// The default tolerance on each spacing, as a fraction of the record's median spacing.
pub const SPACING_TOL: f64 = super::SPACING_TOL;

/// A record of readings, checked and in cm/s².
#[derive(Clone, Debug)]
pub struct Readings {
    /// The readings, cm/s², in time order.
    pub y: Vec<f64>,
    /// The sample interval, s: the record's span over its samples less one.
    pub tau0_s: f64,
    /// The unit the readings were given in.
    pub unit: ReadingUnit,
    /// The first sample's time, s.
    pub t0_s: f64,
}

/// The rows' times and readings (in the file's unit), in order.
#[derive(Default)]
struct Columns {
    t: Vec<f64>,
    r: Vec<f64>,
}

/// Read the record at `path` ([`parse`]).
///
/// # Errors
/// The file cannot be read, or [`parse`] refuses it.
pub fn read(path: &Path, unit: ReadingUnit, instr: &Instrument, tol: f64) -> Result<Readings> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    parse(&path.display().to_string(), &text, unit, instr, tol)
}

/// The record `text` (`name` for messages): its header, every row's time and reading, the
/// spacing checked against `tol` of the median spacing, the readings in cm/s².
///
/// # Errors
/// No header with `time_s` and `reading`; a cell that is not a finite number (line and
/// column); fewer than [`MIN_SAMPLES`] rows; a time not after the one before; a spacing
/// beyond the tolerance (a gap: the samples missing); a unit the instrument file cannot
/// convert.
pub fn parse(
    name: &str,
    text: &str,
    unit: ReadingUnit,
    instr: &Instrument,
    tol: f64,
) -> Result<Readings> {
    let factor = instr
        .reading_to_cm_s2(1.0, unit)
        .map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let (header_line, columns, body, body_line) = header(name, text)?;
    let blocks = rows(name, body, body_line, columns)?;
    let n: usize = blocks.iter().map(|b| b.t.len()).sum();
    if n < MIN_SAMPLES {
        bail!(
            "{name}: {n} rows after the header (line {header_line}); expected at least {MIN_SAMPLES} samples (three octaves of averaging times)"
        );
    }
    // The readings in cm/s², each block's memory given back as it is read.
    let mut t = Vec::with_capacity(n);
    let mut y = Vec::with_capacity(n);
    for b in blocks {
        t.extend_from_slice(&b.t);
        y.extend(b.r.iter().map(|v| v * factor));
    }
    let tau0_s = check_spacing(&t, tol)
        .map_err(|e| e.message(name, &|k| line_of(body, body_line, k)))
        .map_err(anyhow::Error::msg)?;
    let t0_s = t[0];
    Ok(Readings {
        y,
        tau0_s,
        unit,
        t0_s,
    })
}

/// The header: its line, the indices of `time_s` and `reading`, the text after it and the
/// line the text starts on.
fn header<'a>(name: &str, text: &'a str) -> Result<(usize, (usize, usize), &'a str, usize)> {
    let mut rest = text;
    let mut line = 0;
    loop {
        line += 1;
        let (l, next) = rest.split_once('\n').unwrap_or((rest, ""));
        let t = l.trim();
        if t.is_empty() || t.starts_with('#') {
            if next.is_empty() {
                bail!(
                    "{name}: no header; expected a first line `time_s,reading` (one sample per row)"
                );
            }
            rest = next;
            continue;
        }
        let cells: Vec<&str> = t.split(',').map(str::trim).collect();
        let at = |c: &str| cells.iter().position(|x| *x == c);
        return match (at("time_s"), at("reading")) {
            (Some(i), Some(j)) => Ok((line, (i, j), next, line + 1)),
            (ti, _) => bail!(
                "{name}:{line}:1: the header `{t}` has no {}; expected the columns time_s (s) and reading (one sample per row; `ptsa noise --counts` reads a counter record `time_s,pulses,ticks`)",
                match (ti, at("reading")) {
                    (None, None) => "time_s and no reading",
                    (None, _) => "time_s",
                    _ => "reading",
                }
            ),
        };
    }
}

/// The line of the `k`-th data row of `body` (starting on line `first_line`; blank and `#`
/// lines are not rows): the slow path, for a message.
fn line_of(body: &str, first_line: usize, k: usize) -> usize {
    let mut seen = 0;
    for (j, l) in body.lines().enumerate() {
        let t = l.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        if seen == k {
            return first_line + j;
        }
        seen += 1;
    }
    first_line
}

/// Every row of `body` (starting on line `first_line`), parsed in parallel in blocks of
/// whole lines, block by block; blank and `#` lines skipped.
fn rows(
    name: &str,
    body: &str,
    first_line: usize,
    (ti, ri): (usize, usize),
) -> Result<Vec<Columns>> {
    let blocks = blocks(body, 1 << 20);
    // Each block's first line number: the newlines before it.
    let mut starts = Vec::with_capacity(blocks.len());
    let mut line = first_line;
    for b in &blocks {
        starts.push(line);
        line += memchr::memchr_iter(b'\n', b.as_bytes()).count();
    }
    blocks
        .par_iter()
        .zip(starts.par_iter())
        .map(|(b, &start)| parse_block(name, b, start, ti, ri))
        .collect()
}

/// `text` cut into blocks of about `size` bytes, each ending at a line's end.
fn blocks(text: &str, size: usize) -> Vec<&str> {
    let mut out = Vec::new();
    let mut rest = text;
    while !rest.is_empty() {
        if rest.len() <= size {
            out.push(rest);
            break;
        }
        let cut =
            memchr::memchr(b'\n', &rest.as_bytes()[size..]).map_or(rest.len(), |k| size + k + 1);
        out.push(&rest[..cut]);
        rest = &rest[cut..];
    }
    out
}

/// A cell as a finite number: trimmed only when it needs it.
fn number(cell: &str) -> Option<f64> {
    let b = cell.as_bytes();
    let cell = if b.first().is_some_and(u8::is_ascii_whitespace)
        || b.last().is_some_and(u8::is_ascii_whitespace)
    {
        cell.trim()
    } else {
        cell
    };
    cell.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// The rows of one block starting on line `start`.
fn parse_block(name: &str, block: &str, start: usize, ti: usize, ri: usize) -> Result<Columns> {
    let want = ti.max(ri) + 1;
    let mut out = Columns {
        t: Vec::with_capacity(block.len() / 16),
        r: Vec::with_capacity(block.len() / 16),
    };
    let bytes = block.as_bytes();
    let mut pos = 0;
    let mut line = start;
    while pos < bytes.len() {
        let end = memchr::memchr(b'\n', &bytes[pos..]).map_or(bytes.len(), |k| pos + k);
        let l = block[pos..end]
            .strip_suffix('\r')
            .unwrap_or(&block[pos..end]);
        pos = end + 1;
        let here = line;
        line += 1;
        let first = l.as_bytes().iter().position(|b| !b.is_ascii_whitespace());
        if first.is_none_or(|k| l.as_bytes()[k] == b'#') {
            continue;
        }
        let (mut time, mut reading) = (None, None);
        let (mut j, mut from) = (0, 0);
        loop {
            let to = memchr::memchr(b',', &l.as_bytes()[from..]).map_or(l.len(), |k| from + k);
            if j == ti || j == ri {
                let cell = &l[from..to];
                let Some(v) = number(cell) else {
                    let what = if j == ti { "time_s, s" } else { "reading" };
                    let col = l[..from].chars().count() + 1;
                    bail!(
                        "{name}:{here}:{col}: `{}` is not a finite number; expected the {what}",
                        cell.trim()
                    );
                };
                if j == ti {
                    time = Some(v);
                } else {
                    reading = Some(v);
                }
            }
            j += 1;
            if to >= l.len() || j >= want {
                break;
            }
            from = to + 1;
        }
        match (time, reading) {
            (Some(a), Some(b)) => {
                out.t.push(a);
                out.r.push(b);
            }
            _ => bail!(
                "{name}:{here}: {j} cells; expected at least {want} (the header's time_s and reading)"
            ),
        }
    }
    Ok(out)
}

/// Why the samples are not evenly spaced, at data row `k` (its line found for the message
/// only when there is one).
enum Spacing {
    /// Row `k`'s time is not after row `k − 1`'s.
    NotAfter { k: usize, t: f64, before: f64 },
    /// A gap of `dt` before row `k`, about `missing` samples at the median spacing.
    Gap {
        k: usize,
        dt: f64,
        median: f64,
        missing: u64,
    },
    /// A spacing `dt` before row `k` beyond the tolerance `tol` of the median.
    Off {
        k: usize,
        dt: f64,
        median: f64,
        tol: f64,
    },
}

impl Spacing {
    /// The message, `line(k)` the line of data row `k`.
    fn message(&self, name: &str, line: &dyn Fn(usize) -> usize) -> String {
        use crate::output::significant as sig;
        match *self {
            Spacing::NotAfter { k, t, before } => format!(
                "{name}:{}: time_s {t} is not after line {}'s {before}: a duplicate or out-of-order sample; expected one sample per row, in time order",
                line(k),
                line(k - 1)
            ),
            Spacing::Gap {
                k,
                dt,
                median,
                missing,
            } => format!(
                "{name}:{}: a gap of {} s after line {} ({} missing at the record's {} s); expected samples evenly spaced: split the record at the gap",
                line(k),
                sig(dt, 6),
                line(k - 1),
                crate::output::count(missing, "sample"),
                sig(median, 6)
            ),
            Spacing::Off { k, dt, median, tol } => format!(
                "{name}:{}: a spacing of {} s after line {}, {:.1} % off the record's {} s; expected samples evenly spaced within {} % (--spacing-tol)",
                line(k),
                sig(dt, 6),
                line(k - 1),
                (dt / median - 1.0) * 100.0,
                sig(median, 6),
                tol * 100.0
            ),
        }
    }
}

/// The record's sample interval, the span over the samples less one, when every spacing of
/// the times `t` lies within `tol` of it; else the first spacing that does not, judged
/// against the median spacing (a gap named as such).
fn check_spacing(t: &[f64], tol: f64) -> Result<f64, Spacing> {
    #[allow(clippy::cast_precision_loss)]
    let mean = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    let fits = |step: f64| (step - mean).abs() <= tol * mean;
    if mean > 0.0 && t.windows(2).all(|w| fits(w[1] - w[0])) {
        return Ok(mean);
    }
    // The slow path: the first offending row against the median spacing.
    for (k, w) in t.windows(2).enumerate() {
        if w[1] <= w[0] {
            return Err(Spacing::NotAfter {
                k: k + 1,
                t: w[1],
                before: w[0],
            });
        }
    }
    let mut d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let mid = d.len() / 2;
    let median = *d.select_nth_unstable_by(mid, f64::total_cmp).1;
    for (k, w) in t.windows(2).enumerate() {
        let dt = w[1] - w[0];
        if (dt - median).abs() <= tol * median {
            continue;
        }
        let ratio = dt / median;
        if ratio >= 1.5 {
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let missing = (ratio.round() as u64).saturating_sub(1);
            return Err(Spacing::Gap {
                k: k + 1,
                dt,
                median,
                missing,
            });
        }
        return Err(Spacing::Off {
            k: k + 1,
            dt,
            median,
            tol,
        });
    }
    // Every spacing within the tolerance of the median, but not of the mean (a spread of
    // spacings near the tolerance): the median's interval.
    Ok(median)
}

#[cfg(test)]
mod tests {
    use std::fmt::Write as _;

    use super::*;

    fn instr() -> Instrument {
        Instrument::shipped("mems").unwrap()
    }

    fn record(n: usize, dt: f64) -> String {
        let mut s = String::from("# a record\ntime_s,reading\n");
        for k in 0..n {
            #[allow(clippy::cast_precision_loss)]
            let t = k as f64 * dt;
            let _ = writeln!(s, "{t},{}", k % 7);
        }
        s
    }

    #[test]
    fn a_record_is_read_whole_across_blocks() {
        // More than one block of 1 MiB: the rows and their lines survive the cut.
        let text = record(150_000, 0.01);
        let r = parse("r.csv", &text, ReadingUnit::Lsb, &instr(), SPACING_TOL).unwrap();
        assert_eq!(r.y.len(), 150_000);
        assert!((r.tau0_s - 0.01).abs() < 1e-12);
        let per_lsb = 980.665 / 16384.0;
        assert!((r.y[3] - 3.0 * per_lsb).abs() < 1e-12);
        // Line 100 004 (the 100 002nd sample): its reading made unreadable.
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        let (t, _) = lines[100_003].split_once(',').unwrap();
        let col = t.chars().count() + 2;
        lines[100_003] = format!("{t},x");
        let bad = lines.join("\n");
        let e = parse("r.csv", &bad, ReadingUnit::Lsb, &instr(), SPACING_TOL)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with(&format!("r.csv:100004:{col}: `x` is not a finite number")),
            "{e}"
        );
    }

    #[test]
    fn gaps_duplicates_and_headers_are_refused_with_their_line() {
        let i = instr();
        let p = |t: &str| {
            parse("r.csv", t, ReadingUnit::G, &i, SPACING_TOL)
                .unwrap_err()
                .to_string()
        };
        let mut gap = record(20, 0.1);
        gap = gap.replace("1.2000000000000002,5\n", "");
        let e = p(&gap);
        assert!(
            e.contains("a gap of 0.2 s after line") && e.contains("1 sample missing"),
            "{e}"
        );
        let dup = record(20, 0.1).replace("0.30000000000000004,3", "0.2,3");
        assert!(p(&dup).contains("is not after line"), "{}", p(&dup));
        let e = p("time_s,value\n0,1\n");
        assert!(
            e.starts_with("r.csv:1:1: the header `time_s,value` has no reading"),
            "{e}"
        );
        assert!(p(&record(5, 0.1)).contains("expected at least 8 samples"));
    }
}
