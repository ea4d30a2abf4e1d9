//! Result tables: aligned text for the terminal, Markdown for the report, CSV for files.

use std::fmt::Write as _;

use anyhow::Result;

/// A cell: a number (with its display precision) or text; `Missing` is a missing value.
#[derive(Clone, Debug, PartialEq)]
pub enum Cell {
    /// Number and decimals shown.
    Num(f64, usize),
    /// Text.
    Text(String),
    /// Missing (shown as `—`, empty in CSV).
    Missing,
}

impl Cell {
    /// As shown in text and Markdown (no `-0.000`).
    #[must_use]
    pub fn show(&self) -> String {
        match self {
            Cell::Num(x, d) => {
                let t = format!("{x:.d$}", d = *d);
                if t.starts_with('-') && t[1..].chars().all(|c| c == '0' || c == '.') {
                    t[1..].to_string()
                } else {
                    t
                }
            }
            Cell::Text(s) => s.clone(),
            Cell::Missing => "—".into(),
        }
    }

    /// As written in CSV (full precision, shortest round-trip form).
    #[must_use]
    pub fn csv(&self) -> String {
        match self {
            Cell::Num(x, _) => format!("{x}"),
            Cell::Text(s) => s.clone(),
            Cell::Missing => String::new(),
        }
    }
}

/// `Cell::Num` shorthand.
#[must_use]
pub fn num(x: f64, decimals: usize) -> Cell {
    Cell::Num(x, decimals)
}

/// `x` with `digits` significant digits for a reader, trailing zeros dropped: plain from
/// 1e-3 up to 1e6 (`0.02991`, `1960.8`; the integer part is never cut: `21121` to 4
/// digits), in exponent form beyond
/// (`2.991e-8`, `1.5e6`); `0` for zero, Rust's `NaN` and `inf` as they are.
#[must_use]
pub fn significant(x: f64, digits: usize) -> String {
    if !x.is_finite() {
        return format!("{x}");
    }
    if x == 0.0 {
        return "0".into();
    }
    let digits = digits.clamp(1, 17);
    let trim = |t: &str| -> String {
        if t.contains('.') {
            t.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            t.to_string()
        }
    };
    // Rounded to `digits` first, so that 999_999.7 goes to exponent form as 1e6.
    let e = format!("{x:.p$e}", p = digits - 1);
    let (mantissa, exp) = e.split_once('e').unwrap_or((&e, "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    if (-3..6).contains(&exp) {
        // `digits` ≤ 17 and `exp` in −3..6: no truncation, no sign lost after `max(0)`.
        #[allow(
            clippy::cast_possible_truncation,
            clippy::cast_possible_wrap,
            clippy::cast_sign_loss
        )]
        let decimals = (digits as i32 - 1 - exp).max(0) as usize;
        trim(&format!("{x:.decimals$}"))
    } else {
        format!("{}e{exp}", trim(mantissa))
    }
}

/// `Cell::Text` shorthand.
#[must_use]
pub fn text(s: impl Into<String>) -> Cell {
    Cell::Text(s.into())
}

/// `Cell::Num`, or `Cell::Missing` for `None`.
#[must_use]
pub fn opt(x: Option<f64>, decimals: usize) -> Cell {
    x.map_or(Cell::Missing, |x| num(x, decimals))
}

/// A result table, written to `<stem>.csv`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Table {
    /// File stem: the table is written to `<stem>.csv`; named after what it holds.
    pub stem: String,
    /// Title.
    pub title: String,
    /// Column names (with units).
    pub header: Vec<String>,
    /// Rows.
    pub rows: Vec<Vec<Cell>>,
}

impl Table {
    /// An empty table.
    #[must_use]
    pub fn new(stem: &str, title: &str, header: &[&str]) -> Self {
        Self {
            stem: stem.into(),
            title: title.into(),
            header: header.iter().map(|s| (*s).to_string()).collect(),
            rows: Vec::new(),
        }
    }

    /// Aligned text: the title, then the header and the rows.
    #[must_use]
    pub fn to_text(&self) -> String {
        let cells: Vec<Vec<String>> = self
            .rows
            .iter()
            .map(|r| r.iter().map(Cell::show).collect())
            .collect();
        let mut w: Vec<usize> = self.header.iter().map(|h| h.chars().count()).collect();
        for r in &cells {
            for (i, c) in r.iter().enumerate() {
                if i < w.len() {
                    w[i] = w[i].max(c.chars().count());
                }
            }
        }
        let mut s = format!("{}\n", self.title);
        let line = |s: &mut String, items: &[String]| {
            for (i, c) in items.iter().enumerate() {
                let pad = w
                    .get(i)
                    .copied()
                    .unwrap_or(0)
                    .saturating_sub(c.chars().count());
                let _ = write!(s, "{}{}  ", " ".repeat(pad), c);
            }
            s.truncate(s.trim_end().len());
            s.push('\n');
        };
        line(&mut s, &self.header);
        for r in &cells {
            line(&mut s, r);
        }
        s
    }

    /// Markdown (header and rows; the title is the caller's).
    #[must_use]
    pub fn to_markdown(&self) -> String {
        let mut s = format!(
            "| {} |\n|{}\n",
            self.header.join(" | "),
            "---|".repeat(self.header.len())
        );
        for r in &self.rows {
            let cells: Vec<String> = r.iter().map(Cell::show).collect();
            let _ = writeln!(s, "| {} |", cells.join(" | "));
        }
        s
    }

    /// CSV (header with units; missing values empty).
    ///
    /// # Errors
    /// Never in practice (in-memory writer).
    pub fn to_csv(&self) -> Result<String> {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(&self.header)?;
        for r in &self.rows {
            w.write_record(r.iter().map(Cell::csv))?;
        }
        Ok(String::from_utf8(w.into_inner()?)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn significant_digits() {
        for (x, d, want) in [
            (2.990_511_374_147_487e-8, 4, "2.991e-8"),
            (0.1 + 0.2, 6, "0.3"),
            (1960.8, 6, "1960.8"),
            (21_121.1, 4, "21121"),
            (21_121.1, 6, "21121.1"),
            (-0.000_123_456, 3, "-1.23e-4"),
            (0.001_234_56, 3, "0.00123"),
            (999_999.7, 6, "1e6"),
            (999.96, 4, "1000"),
            (200.000_000_000_000_03, 6, "200"),
            (-0.0, 3, "0"),
            (3.0e-8, 4, "3e-8"),
            (0.001_019_99, 5, "0.00102"),
            (0.001_020_37, 5, "0.0010204"),
            (94_878.2, 3, "94878"),
            (2.8e-5, 2, "2.8e-5"),
            (1e6, 5, "1e6"),
        ] {
            assert_eq!(significant(x, d), want, "{x} to {d} digits");
        }
        assert_eq!(significant(f64::NAN, 3), "NaN");
    }

    #[test]
    fn cells_show_without_negative_zero_and_csv_keeps_precision() {
        assert_eq!(num(-0.0004, 3).show(), "0.000");
        assert_eq!(num(-0.0006, 3).show(), "-0.001");
        assert_eq!(num(0.1 + 0.2, 1).csv(), "0.30000000000000004");
        assert_eq!(Cell::Missing.csv(), "");
        let mut t = Table::new("t", "T", &["a", "b, with comma"]);
        t.rows.push(vec![text("x,y"), num(1.5, 1)]);
        assert_eq!(t.to_csv().unwrap(), "a,\"b, with comma\"\n\"x,y\",1.5\n");
        let text = t.to_text();
        assert!(
            text.lines()
                .nth(2)
                .is_some_and(|l| l.starts_with("x,y") && l.ends_with("1.5")),
            "{text}"
        );
    }
}
