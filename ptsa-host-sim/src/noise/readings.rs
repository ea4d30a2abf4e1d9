//! A static record of readings (`ptsa noise --readings FILE`): one sample per row, CSV with
//! the columns `time_s` and `reading` (in any order, among others), evenly spaced in time.
//! Any instrument's record comes in this way: a MEMS part's samples, a DVM's readings of a
//! servo accelerometer's current, a PTSA loop's readings in cm/s².
//!
//! The reader is built for long records (10⁷ rows): the rows are parsed in parallel, in
//! blocks of whole lines (`stream::columns`), and every refusal names the file, the line
//! and the column. The
//! record is refused, not repaired, when its samples are not evenly spaced: a duplicate or
//! out-of-order time, a gap, or a spacing beyond the tolerance of the record's own median
//! spacing. The reading's unit is the instrument file's (`instrument.reading_unit`), or
//! cm/s² for a file without one, unless the caller says otherwise; it becomes cm/s²
//! through the file ([`Instrument::reading_to_cm_s2`]).

use std::path::Path;

use anyhow::{Context as _, Result, bail};

use crate::model::instrument::{Instrument, ReadingUnit};
use crate::stream::columns;

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
    let h = columns::header(name, text, "`time_s,reading` (one sample per row)")?;
    let (Some(ti), Some(ri)) = (h.find("time_s"), h.find("reading")) else {
        bail!(
            "{name}:{}:1: the header `{}` has no {}; expected the columns time_s (s) and reading (one sample per row; `ptsa noise --counts` reads a counter record `time_s,pulses,ticks`)",
            h.line,
            h.text(),
            match (h.find("time_s"), h.find("reading")) {
                (None, None) => "time_s and no reading",
                (None, _) => "time_s",
                _ => "reading",
            }
        );
    };
    let mut c = columns::columns(name, &h, &[ti, ri], &["the time_s, s", "the reading"])?;
    let n = c[0].len();
    if n < MIN_SAMPLES {
        bail!(
            "{name}: {n} rows after the header (line {}); expected at least {MIN_SAMPLES} samples (three octaves of averaging times)",
            h.line
        );
    }
    let mut y = c.pop().unwrap_or_default();
    let t = c.pop().unwrap_or_default();
    for v in &mut y {
        *v *= factor;
    }
    let tau0_s = check_spacing(&t, tol)
        .map_err(|e| e.message(name, &|k| h.line_of(k)))
        .map_err(anyhow::Error::msg)?;
    let t0_s = t[0];
    Ok(Readings {
        y,
        tau0_s,
        unit,
        t0_s,
    })
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
