//! `ptsa discover`: given measured data, show what the simulation gets wrong, name the cause,
//! extend the model and measure the gain (method in `docs/discovery.md`, data format
//! in `docs/case-frame.md`).
//!
//! * [`caseframe`]: the case-frame CSV reader and writer.
//! * [`report_data`]: the report's Tables 6.1–6.3 and their conversion to the case frame.
//! * [`sim`]: the [`Simulator`] trait, the analytic model and the closed-loop adapter.
//! * [`method`]: baseline, selection with familywise error control, confounding, extension.
//! * [`hidden`]: the hidden-effect generator and campaign used by the tests.
//! * [`show`]: text table, plots and the report section.

use std::io::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};

pub mod caseframe;
pub mod hidden;
pub mod method;
pub mod report_data;
pub mod show;
pub mod sim;
pub mod stats;

pub use method::{CANDIDATES, Discovery, Options, TEST_STATEMENT, discover};
pub use sim::{AnalyticSimulator, Simulator};

/// Arguments of `ptsa discover`.
#[derive(clap::Args, Clone, Debug)]
pub struct DiscoverArgs {
    /// Case-frame CSV file of measured conditions (`docs/case-frame.md`). Without it, the
    /// report's Tables 6.1, 6.2 and 6.3 are analysed.
    #[arg(long, value_name = "FILE")]
    pub data: Option<PathBuf>,
    /// 1-sigma uncertainty for rows without `sigma_cm_s2`, cm/s².
    #[arg(long, default_value_t = 0.3, value_name = "CM_S2")]
    pub sigma: f64,
    /// Candidate effects, comma separated (effect names, or lever-arm components such as
    /// `lever_arm.r_pa_cm`); default all.
    #[arg(long, value_name = "LIST", default_value = "")]
    pub candidates: String,
    /// Print exactly one JSON object on stdout (logs go to stderr). Without `--data`, the
    /// object maps each report table's file name to its result.
    #[arg(long)]
    pub json: bool,
    /// Directory for the table (CSV) and plots (PNG, SVG).
    #[arg(long, value_name = "DIR", default_value = "report/discover")]
    pub out: PathBuf,
    /// Seed of the simulator's noise (closed loop).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Use the quasi-static analytic model instead of the closed loop (fast, no loop
    /// dynamics).
    #[arg(long)]
    pub analytic: bool,
    /// Do not write the table and plots.
    #[arg(long)]
    pub no_plots: bool,
    /// Regenerate the report's case-frame files (`*.case.csv`) into DIR and exit.
    #[arg(long, value_name = "DIR")]
    pub convert_report_data: Option<PathBuf>,
}

/// The simulator `ptsa discover` uses: the closed loop, or the analytic model on request.
#[must_use]
pub fn simulator(analytic: bool, seed: u64) -> Box<dyn Simulator> {
    if analytic {
        Box::new(AnalyticSimulator)
    } else {
        sim::closed_loop(seed)
    }
}

/// Run `ptsa discover` with the shipped instrument (closed loop, or the analytic model with
/// `--analytic`).
///
/// # Errors
/// Bad arguments, an unreadable or malformed data file, or an output that cannot be written.
pub fn run(args: &DiscoverArgs) -> Result<()> {
    run_with(args, &*simulator(args.analytic, args.seed))
}

/// Run `ptsa discover` with a given simulator, e.g. a [`sim::ClosedLoopSimulator`] built
/// from another instrument file or other run options.
///
/// # Errors
/// As [`run`].
pub fn run_with(args: &DiscoverArgs, sim: &dyn Simulator) -> Result<()> {
    if let Some(dir) = &args.convert_report_data {
        for p in report_data::write_case_files(dir)? {
            eprintln!("wrote {}", p.display());
        }
        return Ok(());
    }
    if !(args.sigma.is_finite() && args.sigma > 0.0) {
        anyhow::bail!(
            "--sigma {}: expected a finite number of cm/s² greater than 0",
            args.sigma
        );
    }
    let opts = Options {
        default_sigma_cm_s2: args.sigma,
        candidates: method::parse_candidates(&args.candidates)?,
        ..Options::default()
    };
    let Some(path) = &args.data else {
        let text =
            show::report_section(sim, &opts, (!args.no_plots).then_some(args.out.as_path()))?;
        if args.json {
            let mut all = serde_json::Map::new();
            for (name, _, rows) in report_data::case_files()? {
                let d = discover(&rows, sim, &opts)?;
                all.insert(name.to_string(), serde_json::to_value(&d.json)?);
            }
            eprint!("{text}");
            println!("{}", serde_json::Value::Object(all));
        } else {
            print!("{text}");
        }
        return Ok(());
    };
    let rows = caseframe::read(path)?;
    let t0 = Instant::now();
    let d = discover(&rows, sim, &opts)?;
    let elapsed = t0.elapsed();
    let text = show::text_report(&path.display().to_string(), &d);
    if !args.no_plots {
        let stem = path.file_stem().map_or_else(
            || "discover".to_string(),
            |s| s.to_string_lossy().into_owned(),
        );
        let stem = stem.trim_end_matches(".case").to_string();
        show::write_outputs(&args.out, &stem, &d)
            .with_context(|| format!("writing {}", args.out.display()))?;
        eprintln!("wrote {}/{stem}.{{csv,png,svg}}", args.out.display());
    }
    eprintln!(
        "discover: {} rows in {:.3} s ({} simulator)",
        rows.len(),
        elapsed.as_secs_f64(),
        d.simulator
    );
    if args.json {
        let s = serde_json::to_string(&d.json)?;
        let mut out = std::io::stdout().lock();
        writeln!(out, "{s}")?;
    } else {
        print!("{text}");
    }
    Ok(())
}

pub use show::report_section;

/// The discovery section of the no-argument report, with the closed-loop simulator and the
/// default options: the analysis of Tables 6.1, 6.2 and 6.3 as Markdown. Tables and plots
/// go into `out` (e.g. `report/discover`) when given.
///
/// # Errors
/// The shipped transcriptions are malformed or an output cannot be written.
pub fn report_markdown(out: Option<&std::path::Path>) -> Result<String> {
    report_section(&*sim::closed_loop(1), &Options::default(), out)
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;

    fn args(data: Option<PathBuf>, out: PathBuf) -> DiscoverArgs {
        DiscoverArgs {
            data,
            sigma: 0.3,
            candidates: String::new(),
            json: true,
            out,
            seed: 1,
            analytic: true,
            no_plots: false,
            convert_report_data: None,
        }
    }

    #[test]
    fn run_writes_table_and_plots_and_a_bad_file_writes_nothing() {
        let base = std::env::temp_dir().join(format!("ptsa-discover-run-{}", std::process::id()));
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/r890-table-6.1.case.csv");
        let out = base.join("ok");
        run(&args(Some(data), out.clone())).unwrap();
        for ext in ["csv", "png", "svg"] {
            assert!(out.join(format!("r890-table-6.1.{ext}")).exists(), "{ext}");
        }
        let bad = base.join("bad.case.csv");
        std::fs::write(&bad, "label,g_ia,measured_cm_s2\nx,1,0.5\ny,1,zz\n").unwrap();
        let out_bad = base.join("bad-out");
        let e = run(&args(Some(bad), out_bad.clone())).unwrap_err();
        let msg = format!("{e:#}");
        assert!(
            msg.contains("bad.case.csv:3") && msg.contains("measured_cm_s2"),
            "{msg}"
        );
        assert!(!out_bad.exists());
        let mut a = args(None, base.join("x"));
        a.sigma = -1.0;
        assert!(run(&a).is_err());
        let _ = std::fs::remove_dir_all(&base);
    }
}
