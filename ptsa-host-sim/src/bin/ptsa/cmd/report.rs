//! `ptsa report` (and `ptsa` without a subcommand): the report's whole test programme into
//! a report folder that appears whole or not at all.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use ptsa_host_sim::report;
use ptsa_host_sim::simulation::sim::SimOptions;

use super::Ctx;
use crate::flags::RunArgs;
use crate::{paths, work};

/// The report programme's options.
#[derive(Args, Debug, Clone)]
pub struct ReportArgs {
    /// Run options.
    #[command(flatten)]
    pub run: RunArgs,
    /// Report folder, replaced as a whole when the run succeeds (so an existing folder must
    /// be empty or an earlier report).
    #[arg(long, default_value = "report", value_name = "DIR")]
    pub out: PathBuf,
}

/// A report programme to run.
pub struct Request {
    opts: SimOptions,
    force: bool,
    /// The report folder: new, empty or an earlier report.
    out: PathBuf,
}

impl ReportArgs {
    /// The request: the loop's compensator, the report folder checked.
    ///
    /// # Errors
    /// The loop cannot be simulated; the folder is not one the report may replace.
    pub fn request(self, ctx: &Ctx) -> Result<Request> {
        let opts = self.run.options(ctx.config()?);
        paths::report_folder("--out", &self.out)?;
        Ok(Request {
            opts,
            force: self.run.force,
            out: self.out,
        })
    }
}

/// Run the programme (refused beyond the work limit without `--no-limit`), the steps shown
/// as it goes; the report's summary on `out`.
///
/// # Errors
/// Refused work; an experiment or a write fails.
pub fn run(ctx: &Ctx, req: &Request, out: &mut dyn Write) -> Result<()> {
    let instr = &ctx.instr;
    let est = work::check(
        report::work(instr, &req.opts)?,
        req.force,
        "the report programme",
        None,
        "shorten the times asked for",
    )?;
    // Its discovery section holds its search of the loop's parameters to the limit.
    ptsa_host_sim::simulation::work::set_limit((!work::lifted(req.force)).then(work::limit_s));
    let bar = work::Progress::start("the report programme", &est);
    let info = report::RunInfo {
        instrument: ctx.name.clone(),
        options: req.opts,
        threads: rayon::current_num_threads(),
    };
    let steps = report::steps().len();
    let (p, dir) = report::run(
        instr,
        &req.opts,
        info,
        &req.out,
        &mut |k, step| {
            bar.set_step(&format!("step {} of {steps}, {step}", k + 1));
        },
        out,
    )?;
    bar.finish();
    eprintln!(
        "report written to {} in {:.2} s",
        paths::shown(&dir),
        p.wall_s
    );
    Ok(())
}
