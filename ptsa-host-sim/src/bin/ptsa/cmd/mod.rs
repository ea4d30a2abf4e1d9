//! The subcommands, one module each (the report programme's experiments run one by one
//! share [`experiments`]). Every module has the same three parts:
//!
//! * `…Args`: the clap arguments (its `--help`), each value range-checked by its parser in
//!   [`crate::flags::values`];
//! * `Request`, built by `…Args::request` before any work: the checks that need the
//!   instrument file (a gate against the limit cycle, a frequency against the loop's),
//!   the output paths checked ([`crate::paths`]), the inputs read, the options that
//!   exclude or imply each other resolved, a warning for a value that is taken but
//!   doubtful;
//! * `run(ctx, request, out)`: the work estimate ([`crate::work`]), the library's call,
//!   and the presentation (tables through [`ptsa_host_sim::output`]) on `out`, files in
//!   their folder, messages on stderr.
// The doc comments of the `…Args` are clap's `--help` text, printed as plain text:
// backticks around column names and symbols (time_s, A_b, θ_my) would show up verbatim.
#![allow(clippy::doc_markdown, reason = "clap help text, not rustdoc")]
#![allow(
    clippy::struct_excessive_bools,
    reason = "each bool of an `…Args` is a command-line switch of its own"
)]

pub mod bench;
pub mod correct;
pub mod design;
pub mod discover;
pub mod experiments;
pub mod instrument;
pub mod noise;
pub mod plan;
pub mod predict;
pub mod record;
pub mod report;
pub mod response;
pub mod static_;
pub mod triad;
pub mod yield_study;

use std::io::Write;
use std::path::Path;

use anyhow::Result;
use ptsa_host_sim::output::{Output, count};

use crate::paths;

/// What every subcommand runs against: the instrument file, loaded and its loop checked
/// once (the library's [`ptsa_host_sim::session::Session`], which the Python package uses
/// too).
pub use ptsa_host_sim::session::Session as Ctx;
pub use ptsa_host_sim::session::{gate_ticks, simulator};

/// Print an experiment's tables and notes, write its files into `dir`; `already` files
/// were written into the folder while the work ran (the waveform's trace).
///
/// # Errors
/// Writing stdout or a file fails.
pub fn emit(o: &Output, dir: &Path, already: usize, out: &mut dyn Write) -> Result<()> {
    o.print(out)?;
    let files = o.write_files(dir)?;
    eprintln!(
        "wrote {} into {}",
        count((files.len() + already) as u64, "file"),
        paths::shown(dir)
    );
    Ok(())
}
