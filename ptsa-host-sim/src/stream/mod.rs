//! Raw streams: an instrument's samples in time order, as a logger writes them, before
//! anyone has cut them into positions.
//!
//! * [`columns`]: a CSV of numeric columns read fast (parallel blocks of whole lines),
//!   every refusal with its file, line and column; `noise --readings` reads through it.
//! * [`segment`]: the static intervals of a stream (a moving-window variance against the
//!   record's starting rest, as `imu_tk` cuts a hand-turned record).
//! * this module: a stream read whole, its times checked.

pub mod axis;
pub mod columns;
pub mod segment;

use anyhow::{Result, bail};

/// A stream read: each sample's time and channels, in the file's order.
#[derive(Clone, Debug)]
pub struct Stream {
    /// The file's name, for messages.
    pub name: String,
    /// Each sample's time, s (increasing).
    pub t: Vec<f64>,
    /// The channels asked for, each as long as `t`, in the order asked.
    pub channels: Vec<Vec<f64>>,
    /// Each sample's 1-based line in the file.
    pub lines: Vec<usize>,
    /// Gaps: spacings beyond five times the median, as (sample after the gap, its length in
    /// s).
    pub gaps: Vec<(usize, f64)>,
}

impl Stream {
    /// Where the interval `iv` is: `12.5–15.02 s, lines 1252–1504`.
    #[must_use]
    pub fn place(&self, iv: &segment::Interval) -> String {
        use crate::output::significant as sig;
        format!(
            "{}–{} s, lines {}–{}",
            sig(iv.t0_s, 8),
            sig(iv.t1_s, 8),
            self.lines[iv.first],
            self.lines[iv.last]
        )
    }
}

/// Fewest samples a stream may have.
pub const MIN_SAMPLES: usize = 16;

/// Read the columns `time_s` and `names` (header names, in that order) of `text`; `what`
/// names each of `names` in errors ("the x axis's reading").
///
/// # Errors
/// No header; a column missing (`header_hint` says what the header should have); a cell
/// that is not a finite number (line and column); fewer than [`MIN_SAMPLES`] rows; a time
/// not after the one before (its line).
pub fn parse(
    name: &str,
    text: &str,
    names: &[&str],
    what: &[&str],
    header_hint: &str,
) -> Result<Stream> {
    let h = columns::header(name, text, header_hint)?;
    let mut at = Vec::with_capacity(names.len() + 1);
    for c in std::iter::once("time_s").chain(names.iter().copied()) {
        let Some(i) = h.find(c) else {
            bail!(
                "{name}:{}:1: the header `{}` has no `{c}`; expected {header_hint}",
                h.line,
                h.text()
            );
        };
        at.push(i);
    }
    let mut whats = vec!["the time_s, s"];
    whats.extend_from_slice(what);
    let mut cols = columns::columns(name, &h, &at, &whats)?;
    let n = cols[0].len();
    if n < MIN_SAMPLES {
        bail!(
            "{name}: {n} rows after the header (line {}); expected a stream of at least {MIN_SAMPLES} samples",
            h.line
        );
    }
    let t = cols.remove(0);
    let lines = row_lines(&h, n);
    if let Some(k) = (1..n).find(|&k| t[k] <= t[k - 1]) {
        bail!(
            "{name}:{}: time_s {} is not after line {}'s {}: a repeated or out-of-order sample; expected the samples in time order",
            lines[k],
            t[k],
            lines[k - 1],
            t[k - 1]
        );
    }
    let mut d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let mid = d.len() / 2;
    let median = *d.select_nth_unstable_by(mid, f64::total_cmp).1;
    let gaps = (1..n)
        .filter(|&k| t[k] - t[k - 1] > 5.0 * median)
        .map(|k| (k, t[k] - t[k - 1]))
        .collect();
    Ok(Stream {
        name: name.to_string(),
        t,
        channels: cols,
        lines,
        gaps,
    })
}

/// The 1-based line of each of the `n` data rows after the header `h`.
fn row_lines(h: &columns::Header<'_>, n: usize) -> Vec<usize> {
    let mut out = Vec::with_capacity(n);
    for (j, l) in h.body.lines().enumerate() {
        let t = l.trim_start();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        out.push(h.body_line + j);
    }
    out
}

#[cfg(test)]
mod tests {
    use std::fmt::Write as _;

    use super::*;

    fn text(rows: &[(f64, f64)]) -> String {
        let mut s = String::from("# logged\ntime_s,a\n");
        for (t, a) in rows {
            let _ = writeln!(s, "{t},{a}");
        }
        s
    }

    #[test]
    fn a_stream_is_read_with_its_lines_and_gaps() {
        let mut rows: Vec<(f64, f64)> = (0..20)
            .map(|k| (f64::from(k) * 0.1, f64::from(k)))
            .collect();
        rows[15].0 = 2.5;
        for r in &mut rows[16..] {
            r.0 += 1.0;
        }
        let s = parse("s.csv", &text(&rows), &["a"], &["the a"], "`time_s,a`").unwrap();
        assert_eq!(s.t.len(), 20);
        assert_eq!(s.lines[0], 3);
        assert_eq!(s.gaps.len(), 1);
        assert_eq!(s.gaps[0].0, 15);
        rows[10].0 = rows[9].0;
        let e = parse("s.csv", &text(&rows), &["a"], &["the a"], "`time_s,a`")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("s.csv:13: time_s 0.9 is not after line 12's 0.9"),
            "{e}"
        );
        let e = parse("s.csv", "time_s,b\n", &["a"], &["the a"], "`time_s,a`")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "s.csv:1:1: the header `time_s,b` has no `a`; expected `time_s,a`"
        );
    }
}
