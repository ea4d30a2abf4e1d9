//! `ptsa instrument new --class CLASS --output FILE`: a commented instrument file to start from,
//! one of the shipped ones (`--instrument NAME` takes the same names).

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::{Args, Subcommand};
use ptsa_host_sim::Instrument;
use ptsa_host_sim::model::instrument::{SHIPPED, shipped};
use ptsa_host_sim::output::write_atomic;

use crate::paths;

/// Arguments of `ptsa instrument`.
#[derive(Args, Debug, Clone)]
pub struct InstrumentArgs {
    /// What to do.
    #[command(subcommand)]
    pub action: InstrumentAction,
}

/// The `instrument` subcommands.
#[derive(Subcommand, Debug, Clone)]
pub enum InstrumentAction {
    /// Write a commented template instrument file of a class, to edit: kearfott-2401 (the
    /// PTSA loop of R-890, Table 2.1), navigation (a navigation-grade servo accelerometer,
    /// no PTSA loop: reading in mA) or mems (a consumer MEMS axis, no PTSA loop: reading in
    /// LSB). Each bound's source is in the file's comments; every key names its unit (cgs:
    /// cm/s², s²/cm, rad; the reading's nominal scale factor in reading units per g).
    New {
        /// The class: kearfott-2401, navigation or mems.
        #[arg(long, value_name = "CLASS",
              value_parser = clap::builder::PossibleValuesParser::new(["kearfott-2401", "navigation", "mems"]))]
        class: String,
        /// The file to write (not replaced without --force).
        #[arg(short = 'o', long = "output", alias = "out", value_name = "FILE")]
        out: PathBuf,
        /// Replace an existing file.
        #[arg(long)]
        force: bool,
        /// Hidden: the global `--instrument` names a file to read, which `new` never does
        /// (refused when given, and so not listed in its help).
        #[arg(long, hide = true, value_name = "FILE")]
        instrument: Option<PathBuf>,
    },
}

/// A template to write.
pub struct Request {
    class: String,
    out: PathBuf,
    /// What the file held, when `--force` replaces one.
    replaced: Option<String>,
}

impl InstrumentArgs {
    /// The request: the output file checked (an existing one only with `--force`).
    ///
    /// # Errors
    /// `--output` is refused.
    pub fn request(self) -> Result<Request> {
        let InstrumentAction::New {
            class,
            out,
            force,
            instrument,
        } = self.action;
        if let Some(f) = instrument {
            anyhow::bail!(
                "--instrument {}: `instrument new` reads no instrument file; expected --class CLASS --output FILE only",
                f.display()
            );
        }
        let replaced = paths::output_file("--output", &out, force)?.then(|| replaced_text(&out));
        Ok(Request {
            class,
            out,
            replaced,
        })
    }
}

/// What an existing file is, for the warning when `--force` replaces it.
fn replaced_text(p: &Path) -> String {
    match Instrument::load(p) {
        Ok(i) => format!(
            "an instrument file ({})",
            i.name.as_deref().unwrap_or("the PTSA loop")
        ),
        Err(_) => paths::what_is_replaced(p),
    }
}

/// Write the template; say what was written on stderr.
///
/// # Errors
/// An unknown class (clap refuses it first) or the write fails.
pub fn run(req: &Request, _out: &mut dyn Write) -> Result<()> {
    let (path, text) = shipped(&req.class).ok_or_else(|| {
        let names: Vec<&str> = SHIPPED.iter().map(|s| s.0).collect();
        anyhow::anyhow!(
            "--class {}: expected one of {}",
            req.class,
            names.join(", ")
        )
    })?;
    write_atomic(&req.out, text.as_bytes())?;
    if let Some(w) = &req.replaced {
        eprintln!(
            "warning: --output {}: replaced {w} (--force)",
            req.out.display()
        );
    }
    eprintln!(
        "wrote {}: the {} template ({path}); edit it, then use it with --instrument {}",
        req.out.display(),
        req.class,
        req.out.display()
    );
    Ok(())
}
