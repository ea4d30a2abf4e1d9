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
