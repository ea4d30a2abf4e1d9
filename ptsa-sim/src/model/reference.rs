//! `docs/reference/instrument.md` and `docs/reference/case-frame.md`, written from the
//! tables the readers themselves go through: the instrument file's numeric entries
//! ([`PARAMETERS`]: key, unit, form, valid range, meaning) and the case-frame's columns
//! ([`COLUMNS`]: name and what a cell must hold). The tests check both pages are current;
//! `PTSA_WRITE_REFERENCE=1 cargo test -p ptsa-sim --lib reference` writes them again.

use std::fmt::Write as _;

use super::caseframe::COLUMNS;
use super::instrument::{Form, PARAMETERS};

/// A table cell: one line, `|` escaped.
fn cell(text: &str) -> String {
    text.split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .replace('|', "\\|")
}

/// How an entry is written, in words.
fn form(f: Form) -> &'static str {
    match f {
        Form::Toleranced => "`{ value, tol_pct }`, `tol_abs` or `min` and `max`; required",
        Form::NumberOrToleranced => "a number (exact) or `{ value, tol_… }`",
        Form::OptionalToleranced => "`{ value, tol_… }`, optional (0, exact, when left out)",
        Form::Number => "a number (exact, never fitted)",
    }
}

/// The instrument file's page.
#[must_use]
pub fn instrument_page() -> String {
    let mut out = String::from(
        "# Reference: the instrument file's loop entries\n\n\
         Every numeric entry of the `[pendulum]`, `[pickoff]`, `[torquer]`, `[electronics]` \
         and `[stops]` tables, generated from the table the reader, `--write-instrument` \
         and `ptsa discover` go through (`PARAMETERS`, `model/instrument/schema.rs`) by the test \
         `model::reference::tests::the_pages_are_current`. A toleranced entry can be fitted \
         by `ptsa discover` and rewritten by `--write-instrument`. The other sections \
         (`[instrument]`, `[board]`, `[model_equation]`, `[plausibility]`) and the classes \
         without a loop are in [instrument-files.md](instrument-files.md).\n\n\
         | key | unit | written as | valid | meaning |\n|---|---|---|---|---|\n",
    );
    for p in PARAMETERS {
        let _ = writeln!(
            out,
            "| `{}` | {} | {} | {} | {} |",
            p.key,
            cell(p.unit),
            form(p.form),
            cell(p.expected()),
            cell(p.description)
        );
    }
    out
}

/// The case-frame's page.
#[must_use]
pub fn case_frame_page() -> String {
    let mut out = String::from(
        "# Reference: the case-frame's columns\n\n\
         Every column of a single-axis case-frame file, in the order the writer uses, with \
         what a cell must hold (the reader's own words when it refuses one). Generated from \
         `COLUMNS` (`model/caseframe.rs`) by the test \
         `model::reference::tests::the_pages_are_current`. Units are in the names. What \
         the rows mean, blocks, counts, response rows and the triad file are in \
         [case-frame-format.md](case-frame-format.md).\n\n\
         | column | a cell holds |\n|---|---|\n",
    );
    for c in COLUMNS {
        let _ = writeln!(out, "| `{}` | {} |", c.name, cell(c.expected));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pages_are_current() {
        for (file, want) in [
            ("instrument.md", instrument_page()),
            ("case-frame.md", case_frame_page()),
        ] {
            assert!(
                crate::text::reference_page_is_current(file, &want),
                "docs/reference/{file} is not what the code defines: \
                 PTSA_WRITE_REFERENCE=1 cargo test -p ptsa-sim --lib reference"
            );
        }
    }
}
