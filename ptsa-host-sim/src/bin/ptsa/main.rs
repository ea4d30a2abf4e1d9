//! `ptsa`: the host simulator's command line. This file is the dispatcher: it parses the
//! command line ([`flags`]), sets up the signal handler and standard output, loads the
//! instrument file ([`cmd::Ctx`]), hands the subcommand to its module of [`cmd`] (which
//! turns its arguments into a validated request, then runs it) and maps the outcome to the
//! exit status: 0, 1 for an error (one line on stderr), 2 for a command line clap refuses,
//! 128 + N when signal N interrupts the run ([`signals`]). The work itself lives in the
//! `ptsa_host_sim` library.

mod cmd;
mod flags;
mod paths;
mod signals;
mod stdout;
mod work;

use std::io::Write;

use ptsa_host_sim::simulation::simd::SimdLevel;
use std::process::ExitCode;

use anyhow::Result;
use cmd::{
    Ctx, bench, correct, design, discover, experiments, instrument, noise, plan, predict, record,
    report, response, static_,
};
use flags::{Cli, Cmd};
use ptsa_host_sim::lab::fixtures::TwoAxisKind;

fn main() -> ExitCode {
    signals::clean_up_on_signals();
    let cli = flags::parse();
    if let Err(w) = SimdLevel::from_env() {
        eprintln!("warning: {w}");
    }
    let mut out = stdout::Stdout::default();
    let result = run(cli, &mut out);
    let _ = out.flush();
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!(
                "error: {}",
                paths::without_os_error_numbers(&format!("{e:#}"))
            );
            ExitCode::FAILURE
        }
    }
}

/// Protect the inputs, load the instrument file, run the subcommand (the report programme
/// without one): its request first (every check before any work), then the work.
fn run(cli: Cli, out: &mut dyn Write) -> Result<()> {
    paths::inputs(cli.inputs());
    let mut ctx = Ctx::load(cli.instrument.as_deref())?;
    if let Some(g) = cli.local_gravity() {
        ctx.set_local_gravity(g)?;
    }
    let instrument_given = cli.instrument.is_some();
    match cli.cmd.unwrap_or(Cmd::Report(cli.report)) {
        Cmd::Report(a) => report::run(&ctx, &a.request(&ctx)?, out),
        Cmd::Tumble(a) => experiments::run(&ctx, &a.request(&ctx)?, out),
        Cmd::Anisoinertia(a) => experiments::run(&ctx, &a.request(&ctx)?, out),
        Cmd::OaCoupling(a) => experiments::run(&ctx, &a.request(&ctx)?, out),
        Cmd::Vibropendulosity(a) => {
            experiments::run(&ctx, &a.request(&ctx, TwoAxisKind::Vibropendulous)?, out)
        }
        Cmd::Anisoelasticity(a) => {
            experiments::run(&ctx, &a.request(&ctx, TwoAxisKind::Anisoelastic)?, out)
        }
        Cmd::Sculling(a) => experiments::run(&ctx, &a.request(&ctx, TwoAxisKind::Sculling)?, out),
        Cmd::Waveform(a) => experiments::run(&ctx, &a.request(&ctx)?, out),
        Cmd::MonteCarlo(a) => experiments::run(&ctx, &a.request(&ctx)?, out),
        Cmd::Static(a) => static_::run(&a.request(&ctx)?, out),
        Cmd::Design(a) => {
            ctx.require_loop()?;
            design::run(&ctx, &a.request(), out)
        }
        Cmd::Bench(a) => bench::run(&ctx, &a.request(&ctx)?, out),
        Cmd::Predict(a) => predict::run(&a.request(&ctx)?, out),
        Cmd::Plan(a) => plan::run(&a.request(&ctx)?, out),
        Cmd::Discover(a) => discover::run(&ctx, &a.request(&ctx)?, out),
        Cmd::Response(a) => {
            ctx.require_loop()?;
            response::run(&ctx, &a.request()?, out)
        }
        Cmd::Record(a) => record::run(&ctx, &a.request()?, out),
        Cmd::Correct(a) => correct::run(&a.request(&ctx, instrument_given)?, out),
        Cmd::Instrument(a) => instrument::run(&a.request()?, out),
        Cmd::Noise(a) => noise::run(&ctx, &a.request(&ctx)?, out),
    }
}
