//! Result tables: aligned text for the terminal, Markdown for the report, CSV for files.

use std::fmt::Write as _;

use anyhow::Result;

// Its old path: `output::table::significant`.
pub use ptsa_sim::text::significant;

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

/// Where a cell sits in its [`Column`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Align {
    /// Text first, padding after.
    Left,
    /// Padding first (numbers).
    Right,
}

/// A column of [`Table::to_fixed_text`]: its width in characters, its alignment, the spaces
/// before it, whether a longer cell is cut to the width, and what a missing cell shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Column {
    /// Width, characters (a cell is padded to it).
    pub width: usize,
    /// Alignment in the width.
    pub align: Align,
    /// Spaces before the column.
    pub gap: usize,
    /// Cut a longer cell to the width (a label), instead of letting it overflow.
    pub clip: bool,
    /// What a [`Cell::Missing`] shows.
    pub missing: &'static str,
    /// Show a negative number that rounds to zero with its sign (`-0.0000`, as `format!`
    /// does), instead of [`Cell::show`]'s `0.0000`: for a table whose text has always kept
    /// it.
    pub signed_zero: bool,
}

impl Column {
    /// A left-aligned column of `width` characters, one space after the previous one.
    #[must_use]
    pub const fn left(width: usize) -> Self {
        Self {
            width,
            align: Align::Left,
            gap: 1,
            clip: false,
            missing: "—",
            signed_zero: false,
        }
    }

    /// A right-aligned column of `width` characters, one space after the previous one.
    #[must_use]
    pub const fn right(width: usize) -> Self {
        Self {
            align: Align::Right,
            ..Self::left(width)
        }
    }

    /// The same with `gap` spaces before it (0 for the first column, or for a suffix).
    #[must_use]
    pub const fn gap(self, gap: usize) -> Self {
        Self { gap, ..self }
    }

    /// The same, a longer cell cut to the width.
    #[must_use]
    pub const fn clipped(self) -> Self {
        Self { clip: true, ..self }
    }

    /// The same, a negative number that rounds to zero shown with its sign.
    #[must_use]
    pub const fn signed_zero(self) -> Self {
        Self {
            signed_zero: true,
            ..self
        }
    }

    /// The same, a missing cell shown as `text`.
    #[must_use]
    pub const fn missing(self, text: &'static str) -> Self {
        Self {
            missing: text,
            ..self
        }
    }
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

    /// Text in columns of fixed widths set by the caller (one [`Column`] per header entry),
    /// for a table whose layout is part of a command's interface (`ptsa predict`, `ptsa
    /// static`): the title, then the header and the rows. A cell shows as [`Cell::show`]
    /// (a missing one as its column's [`Column::missing`], a number in a
    /// [`Column::signed_zero`] column with the sign of a negative zero), padded to its column's width (a
    /// longer one overflows it, or is cut to it when the column clips); trailing spaces are
    /// dropped.
    #[must_use]
    pub fn to_fixed_text(&self, columns: &[Column]) -> String {
        let mut s = format!("{}\n", self.title);
        let line = |s: &mut String, items: &mut dyn Iterator<Item = (String, &Column)>| {
            let start = s.len();
            for (text, c) in items {
                s.push_str(&" ".repeat(c.gap));
                let text: String = if c.clip {
                    text.chars().take(c.width).collect()
                } else {
                    text
                };
                let pad = " ".repeat(c.width.saturating_sub(text.chars().count()));
                match c.align {
                    Align::Left => {
                        s.push_str(&text);
                        s.push_str(&pad);
                    }
                    Align::Right => {
                        s.push_str(&pad);
                        s.push_str(&text);
                    }
                }
            }
            let end = start + s[start..].trim_end_matches(' ').len();
            s.truncate(end);
            s.push('\n');
        };
        line(&mut s, &mut self.header.iter().cloned().zip(columns.iter()));
        for r in &self.rows {
            line(
                &mut s,
                &mut r.iter().zip(columns).map(|(cell, c)| match cell {
                    Cell::Missing => (c.missing.to_string(), c),
                    Cell::Num(x, d) if c.signed_zero => (format!("{x:.d$}", d = *d), c),
                    cell => (cell.show(), c),
                }),
            );
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

    /// Fixed columns: padded to their widths and aligned, a clipped one cut, a missing cell
    /// shown as its column says, a longer cell overflowing, a negative zero signed only
    /// where its column says so, no trailing spaces; a row with fewer cells than columns
    /// ends early.
    #[test]
    fn fixed_columns_pad_align_clip_and_show_missing() {
        let mut t = Table::new("", "title line", &["name", "x", "y", ""]);
        t.rows.push(vec![
            text("a long label"),
            num(-0.00004, 4),
            opt(None, 2),
            text(""),
        ]);
        t.rows.push(vec![
            text("b"),
            num(12_345.678, 1),
            num(2.5, 2),
            text(" (!)"),
        ]);
        t.rows
            .push(vec![text("z"), num(-0.00004, 1), num(-0.004, 2)]);
        t.rows.push(vec![text("c")]);
        let cols = [
            Column::left(6).gap(0).clipped(),
            Column::right(7),
            Column::right(5).missing("-").signed_zero(),
            Column::left(0).gap(0),
        ];
        assert_eq!(
            t.to_fixed_text(&cols),
            "title line\nname         x     y\na long  0.0000     -\nb      12345.7  2.50 (!)\nz          0.0 -0.00\nc\n"
        );
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
