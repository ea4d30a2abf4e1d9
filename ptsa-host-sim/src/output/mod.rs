//! The output stack of the host simulator, used by the experiments and discovery alike:
//! result tables ([`Table`]: text, Markdown, CSV), plots ([`Plot`]: PNG and SVG, one font
//! lookup) and files that appear whole or not at all ([`write_atomic`], [`StagedDir`]).
//! An experiment returns an [`Output`]: its tables, plots and summary lines, each file named
//! after what it holds.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Result;

pub mod command_json;
pub mod fs;
pub mod json_reference;
pub mod plot;
pub mod table;

pub use fs::{StagedDir, write_atomic};
pub use plot::{Figure, Plot, Series, Style, XAxis, write_figure};
pub use ptsa_sim::text::{reference_page_is_current, significant};
pub use table::{Align, Cell, Column, Table, num, opt, text};

/// A number as the messages show it: plain from 0.001 to 10⁶, in exponent form beyond.
#[must_use]
pub fn shown_number(x: f64) -> String {
    let a = x.abs();
    if a != 0.0 && a.is_finite() && !(1e-3..1e6).contains(&a) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// `n thing` or `n things`.
#[must_use]
pub fn count(n: u64, thing: &str) -> String {
    if n == 1 {
        format!("1 {thing}")
    } else {
        format!("{n} {thing}s")
    }
}

/// Tables longer than this are not printed on the terminal, only written (and named).
pub const MAX_PRINTED_ROWS: usize = 40;

/// What an experiment produced: tables (`<stem>.csv`), plots (`<stem>.png`, `.svg`) and
/// one-line notes for the terminal and the report's summary.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Output {
    /// Tables.
    pub tables: Vec<Table>,
    /// Figures (one PNG/SVG pair each).
    pub plots: Vec<Figure>,
    /// Summary lines.
    pub notes: Vec<String>,
}

impl Output {
    /// Print the tables (those of at most [`MAX_PRINTED_ROWS`] rows in full, longer ones as
    /// one line naming their file) and the notes.
    ///
    /// # Errors
    /// The writer fails (e.g. a closed pipe).
    pub fn print(&self, out: &mut dyn Write) -> std::io::Result<()> {
        for t in &self.tables {
            if t.rows.len() <= MAX_PRINTED_ROWS {
                writeln!(out, "{}", t.to_text())?;
            } else {
                writeln!(
                    out,
                    "{}: {}, in {}.csv
",
                    t.title,
                    count(t.rows.len() as u64, "row"),
                    t.stem
                )?;
            }
        }
        for n in &self.notes {
            writeln!(out, "{n}")?;
        }
        Ok(())
    }

    /// Write every table as CSV and every plot as PNG and SVG into `dir`; returns the files.
    /// A plot that cannot be drawn is a warning on stderr, not an error.
    ///
    /// # Errors
    /// A table cannot be written.
    pub fn write_files(&self, dir: &Path) -> Result<Vec<PathBuf>> {
        let mut files = Vec::new();
        for t in &self.tables {
            let f = dir.join(format!("{}.csv", t.stem));
            write_atomic(&f, t.to_csv()?.as_bytes())?;
            files.push(f);
        }
        for p in &self.plots {
            match write_figure(dir, p) {
                Ok(mut f) => files.append(&mut f),
                Err(e) => eprintln!("warning: plot {} not written: {e:#}", p.stem),
            }
        }
        Ok(files)
    }

    /// Append `other`'s tables, plots and notes.
    pub fn extend(&mut self, other: Output) {
        self.tables.extend(other.tables);
        self.plots.extend(other.plots);
        self.notes.extend(other.notes);
    }
}
