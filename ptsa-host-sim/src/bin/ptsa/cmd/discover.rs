//! `ptsa discover`: what measured data say the simulation gets wrong (the library's
//! `discovery`), on a case-frame file or, without `--data`, on the report's Tables 6.1–6.3;
//! or, with `--convert-report-data`, the report's case-frame files regenerated.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use anyhow::Result;
use clap::Args;
use ptsa_host_sim::discovery::cost::Cost;
use ptsa_host_sim::discovery::library::Term;
use ptsa_host_sim::discovery::{self, InstrumentOut, Options, Simulator};
use ptsa_host_sim::model::effects::CandidateId;
use ptsa_host_sim::report::r890;
use ptsa_host_sim::simulation::sim::SimOptions;
use ptsa_host_sim::simulation::work::{Estimate, Ticks, human};

use super::{Ctx, simulator};
use crate::flags::values::{
    candidate, candidates_help, local_gravity_cm_s2, non_negative_s, positive_cm_s2, positive_s,
    seed, term,
};
use crate::{paths, work};

/// Arguments of `ptsa discover`.
#[derive(Args, Debug, Clone)]
#[command(allow_negative_numbers = true)]
pub struct DiscoverArgs {
    /// Case-frame CSV file of measured conditions (docs/reference/case-frame-format.md). Without it, the
    /// report's Tables 6.1, 6.2 and 6.3 are analysed. A triad file (columns g_x, g_y, g_z,
    /// measured_x_cm_s2, measured_y_cm_s2, measured_z_cm_s2) is one calibration of three
    /// accelerometers on one block instead (docs/method/discovery.md, "A triad"); with time_s and
    /// no g_x, g_y, g_z it is a raw stream of samples, cut into positions and calibrated
    /// from gravity alone ("A raw stream").
    #[arg(long, value_name = "FILE")]
    pub data: Option<PathBuf>,
    /// 1-sigma uncertainty of the rows without `sigma_cm_s2`, cm/s² (more than 0). Without
    /// it, their noise is estimated: from replicated rows where there are some, else from
    /// the residuals, per block and kind of row.
    #[arg(long, value_name = "CM_S2", value_parser = positive_cm_s2)]
    pub sigma: Option<f64>,
    /// Candidate effects, comma separated: effect names (`lever_arm` = its three
    /// components) or candidate names (`lever_arm.r_pa_cm`); default all.
    #[arg(long, value_name = "LIST", value_delimiter = ',', value_parser = candidate,
          long_help = candidates_help())]
    pub candidates: Vec<Vec<CandidateId>>,
    /// A term of your own, tested after the selection like a selection step (repeatable;
    /// Bonferroni over the terms; the JSON's `unexplained.terms`): products, whole powers
    /// (^1 to ^6), sums of terms of one unit, numbers and parentheses over the case inputs
    /// a_ia, a_pa, a_oa (cm/s²), w_ia, w_pa, w_oa (rad/s), dw_ia, dw_pa, dw_oa (rad/s²),
    /// the previous row's prev_X, the change since it delta_X and sign_delta_a_ia (absolute
    /// rows), e.g. `a_pa^3` or `a_pa*w_oa`. The coefficient's unit is derived (s⁴/cm² for
    /// a_pa^3).
    #[arg(long = "term", value_name = "TEXT", value_parser = term)]
    pub terms: Vec<Term>,
    /// The local gravity at the test stand, cm/s² (970 to 990): replaces the instrument
    /// file's local_gravity_cm_s2 for this run (what g_ia = 1 means, and every value in
    /// g). The shipped mems and navigation classes give standard gravity, 980.665.
    #[arg(long, value_name = "CM_S2", value_parser = local_gravity_cm_s2)]
    pub local_gravity: Option<f64>,
    /// Print exactly one JSON object on stdout (the text report goes to stderr); every key,
    /// its type and meaning: docs/reference/json.md. Without --data, the object maps each
    /// report table's file name to its result.
    #[arg(long)]
    pub json: bool,
    /// Folder for the per-row table and plots, STEM-discover.csv, .png and .svg (STEM: the
    /// data file's name without .case.csv or .csv; with response rows also
    /// STEM-discover-bode.png and .svg); relative to the current folder.
    #[arg(long, value_name = "DIR", default_value = "out/discover")]
    pub out: PathBuf,
    /// Do not write the table and plots.
    #[arg(long)]
    pub no_plots: bool,
    /// Seed of the simulator's pickoff noise (closed loop; not used with --analytic): a
    /// whole number from 0 to 2^64 − 1, no unit.
    #[arg(long, default_value_t = SimOptions::default().seed, value_name = "N",
          value_parser = seed)]
    pub seed: u64,
    /// Use the quasi-static analytic model instead of the closed loop (fast, no loop
    /// dynamics).
    #[arg(long)]
    pub analytic: bool,
    /// Write the rows the advice proposes (to break each confounding, or to test what these
    /// data cannot) to FILE as a case-frame file, ready to measure.
    #[arg(long, value_name = "FILE", requires = "data")]
    pub advice_out: Option<PathBuf>,
    /// Write the instrument file (--instrument, or the shipped one) to FILE with the
    /// fitted values of the selected parameters (damping, spring, ...; each with a comment
    /// of its value ± 1 σ and where it came from), everything else as it was. Not written
    /// when no parameter is selected. With a triad file: the triad's calibration, one file
    /// for the three axes (biases in cm/s², scale-factor changes, misalignments in rad,
    /// K_2, their covariance), which `ptsa correct --calibration FILE` applies.
    #[arg(long, value_name = "FILE", requires = "data")]
    pub write_instrument: Option<PathBuf>,
    /// Write a calibration sheet into the folder DIR, which appears whole or not at all:
    /// DIR/NAME.md (the data and instrument files with their SHA-256, the date in UTC, or
    /// SOURCE_DATE_EPOCH's when set, the model equation with the instrument's values, the
    /// calibration table in IEEE Std 1293 units with 1 σ and k = 2, the correlation, the
    /// design, the residuals in cm/s²), DIR/NAME.csv (the calibration table) and
    /// DIR/NAME-residuals.png and .svg, NAME the folder's name. An existing DIR is replaced
    /// only with --force, and only when it is empty or an earlier sheet. With a triad file:
    /// the three axes' coefficients, the non-orthogonality, the correlation, the fit's χ²
    /// and |g| check, the per-position residuals and their plot.
    #[arg(long, value_name = "DIR", requires = "data")]
    pub sheet: Option<PathBuf>,
    /// Keep the rows the outlier test flags as suspected gross errors in the fit (they are
    /// still reported and warned about). Without it such a row (its value many sigma from
    /// what the model selected without it expects, familywise 1 %) is set aside.
    #[arg(long)]
    pub keep_outliers: bool,
    /// Analyse measured values that are a unit's multiple of the simulated ones (1/980.4:
    /// typed in g; 1/100: m/s²; 1020: µg; ...) or their negative as they are, with a
    /// warning. Without it such data are refused (exit 1) as a unit or sign slip.
    #[arg(long)]
    pub units_as_given: bool,
    /// Regenerate the report's case-frame files (`r890-table-6.*.case.csv`) into DIR and
    /// exit: a maintainer's task, `cargo xtask report-data`.
    #[arg(long, value_name = "DIR", hide = true)]
    pub convert_report_data: Option<PathBuf>,
    /// Replace an existing --advice-out or --write-instrument file (never an input of the
    /// run) or an earlier --sheet folder (the work limit is --no-limit's).
    #[arg(long)]
    pub force: bool,
    #[command(flatten)]
    pub limit: crate::flags::LimitArg,
    /// With a triad file: what its positions' nominal orientations are worth (default
    /// exact).
    #[arg(long, value_enum, value_name = "HOW", requires = "data")]
    pub orientation: Option<super::triad::OrientationArg>,
    /// With a raw stream (time_s and the three axes' samples, no g_x, g_y, g_z): how long
    /// the record starts at rest, s (default 10); the static limit is measured on it.
    #[arg(long, value_name = "S", value_parser = positive_s, requires = "data")]
    pub rest_s: Option<f64>,
    /// With a raw stream: the moving window whose variance says whether the instrument is
    /// still, s (default 1; at least 5 samples).
    #[arg(long, value_name = "S", value_parser = positive_s, requires = "data")]
    pub static_window_s: Option<f64>,
    /// With a raw stream: a window is still while its variance, summed over the axes, is at
    /// most FACTOR times the rest's median window variance; a factor, no unit, more than 1
    /// (default 4).
    #[arg(long, value_name = "FACTOR", value_parser = above_one, requires = "data")]
    pub static_threshold: Option<f64>,
    /// With a raw stream: the shortest still interval taken as a position, s (default 1).
    #[arg(long, value_name = "S", value_parser = positive_s, requires = "data")]
    pub static_min_s: Option<f64>,
    /// With a raw stream: what each still interval loses at each end before its mean is
    /// taken, s (0 or more; default 0, and 1 for a record of gates, whose summed counts
    /// see what the window does not): the gentle start and end of a turn.
    #[arg(long, value_name = "S", value_parser = non_negative_s, requires = "data")]
    pub static_trim_s: Option<f64>,
    /// With a raw stream: write the positions found to FILE as a triad file (each
    /// interval's time, lines and samples in its comments) for a person to inspect, edit
    /// and calibrate again with --orientation approximate; an existing file is replaced
    /// only with --force.
    #[arg(long, value_name = "FILE", requires = "data")]
    pub positions_out: Option<PathBuf>,
    /// With one axis's raw stream (time_s and measured_cm_s2, reading, or a gate's
    /// pulses,ticks; no g_ia): the plan of the positions held, in their order (a case-frame
    /// file such as `ptsa plan tumble` writes, its measured cells empty). The stream's
    /// still intervals fill its rows; the filled plan goes to --positions-out, or to
    /// STEM-positions.csv in --out, and is analysed.
    #[arg(long, value_name = "FILE", requires = "data")]
    pub plan: Option<PathBuf>,
}

/// One axis's stream cut into its positions: the filled plan's file, its text, the summary
/// of the cut, and what the file replaces.
pub struct Filled {
    path: PathBuf,
    text: String,
    summary: String,
    replaced: Option<String>,
}

/// `--static-threshold`: a factor more than 1.
fn above_one(s: &str) -> Result<f64, String> {
    let x = crate::flags::values::finite(s)?;
    if x > 1.0 {
        Ok(x)
    } else {
        Err(format!(
            "expected a factor more than 1 (times the rest's variance), not {s}"
        ))
    }
}

impl DiscoverArgs {
    /// The raw stream's detector as the flags set it, and whether any of its flags (or
    /// `--positions-out`) was given.
    pub fn detector(
        &self,
    ) -> (
        ptsa_host_sim::stream::segment::Detector,
        Option<&'static str>,
    ) {
        let d = ptsa_host_sim::stream::segment::Detector::default();
        let given = [
            ("--rest-s", self.rest_s.is_some()),
            ("--static-window-s", self.static_window_s.is_some()),
            ("--static-threshold", self.static_threshold.is_some()),
            ("--static-min-s", self.static_min_s.is_some()),
            ("--static-trim-s", self.static_trim_s.is_some()),
            ("--positions-out", self.positions_out.is_some()),
        ]
        .into_iter()
        .find(|(_, on)| *on)
        .map(|(f, _)| f);
        (
            ptsa_host_sim::stream::segment::Detector {
                rest_s: self.rest_s.unwrap_or(d.rest_s),
                window_s: self.static_window_s.unwrap_or(d.window_s),
                threshold: self.static_threshold.unwrap_or(d.threshold),
                min_static_s: self.static_min_s.unwrap_or(d.min_static_s),
                trim_s: self.static_trim_s.unwrap_or(d.trim_s),
            },
            given,
        )
    }
}

/// A discovery to run, or the report's files to regenerate.
pub enum Request {
    /// `--convert-report-data DIR`: the folder checked.
    Convert(PathBuf),
    /// An analysis.
    Analyse(Box<Analysis>),
    /// A triad file's calibration (`cmd::triad`).
    Triad(Box<super::triad::Request>),
}

/// An analysis of `data` (or of the report's tables), its output files checked.
pub struct Analysis {
    data: Option<PathBuf>,
    /// One axis's stream cut into its plan's positions: written before the analysis,
    /// which reads it as `data`.
    filled: Option<Filled>,
    options: Options,
    sim: Box<dyn Simulator>,
    json: bool,
    /// The folder for the table and plots, or `None` (`--no-plots`).
    plots: Option<PathBuf>,
    advice_out: Option<PathBuf>,
    write_instrument: Option<PathBuf>,
    /// The calibration sheet's folder (`--sheet`).
    sheet: Option<PathBuf>,
    /// The single files `--force` will replace: the flag, the file, its time of change
    /// (to see whether the run wrote it) and what it holds.
    replaced: Vec<Replaced>,
    force: bool,
}

/// A file `--force` will replace: the flag, the file, its time of change (to see whether
/// the run wrote it) and what it holds.
type Replaced = (&'static str, PathBuf, Option<SystemTime>, String);

impl DiscoverArgs {
    /// The files the command reads, by their flags: no output may replace them.
    pub fn inputs(&self) -> [(&'static str, Option<&Path>); 2] {
        [
            ("--data", self.data.as_deref()),
            ("--plan", self.plan.as_deref()),
        ]
    }

    /// One axis's stream (`--data` with `--plan`): read, cut, its plan filled, the file it
    /// goes to checked (`--positions-out`, else STEM-positions.csv in `--out`).
    ///
    /// # Errors
    /// No `--plan`; the stream, the plan or the output refused; the intervals do not fill
    /// the plan.
    fn axis_stream(&self, data: &Path, ctx: &Ctx) -> Result<Filled> {
        use ptsa_host_sim::stream::axis;
        let Some(plan) = &self.plan else {
            anyhow::bail!(
                "{}: one axis's raw stream (time_s and its readings, no g_ia); expected --plan FILE, the plan of the positions held in their order (`ptsa plan tumble`), whose rows the stream's still intervals fill",
                data.display()
            );
        };
        if self.orientation.is_some() {
            anyhow::bail!(
                "--orientation applies to a triad file; {} is one axis's stream",
                data.display()
            );
        }
        let name = data.display().to_string();
        let text = std::fs::read_to_string(data)
            .map_err(|e| anyhow::anyhow!("cannot read {name}: {e}"))?;
        let s = axis::parse(&name, &text, &ctx.instr)?;
        let mut detector = self.detector().0;
        if s.source == axis::Source::Counts && self.static_trim_s.is_none() {
            detector.trim_s = axis::COUNTS_TRIM_S;
        }
        let seg = axis::cut(&s, &detector)?;
        let plan_rows = ptsa_host_sim::model::caseframe::read(plan)?;
        let plan_name = plan.display().to_string();
        let (rows, open) = axis::fill(&s, &seg, &plan_rows, &plan_name, ctx.instr.g_cm_s2)?;
        let path = self.positions_out.clone().unwrap_or_else(|| {
            let stem = data
                .file_stem()
                .map_or_else(|| "stream".into(), |s| s.to_string_lossy().into_owned());
            self.out.join(format!("{stem}-positions.csv"))
        });
        let replaced = if self.positions_out.is_some() {
            paths::output_file("--positions-out", &path, self.force)?
                .then(|| paths::what_is_replaced(&path))
        } else {
            paths::folder_with(
                "--out",
                &self.out,
                &[path
                    .file_name()
                    .map_or_else(String::new, |f| f.to_string_lossy().into_owned())],
            )?;
            None
        };
        Ok(Filled {
            text: axis::filled_csv(&s, &seg, (&rows, &open), &plan_name),
            summary: axis::text(&s, &seg),
            path,
            replaced,
        })
    }

    /// The request: the candidates resolved (each once, in the registry's order), the
    /// folder and files it writes checked (never an input; an existing single file only
    /// with `--force`, and what it holds noted), the method's options, the simulator.
    ///
    /// # Errors
    /// The loop cannot be simulated; an output path is refused.
    pub fn request(self, ctx: &Ctx) -> Result<Request> {
        // A triad file needs no loop: dispatched before the loop's check.
        if let Some(d) = &self.data
            && (ptsa_host_sim::triad::frame::is_triad_file(d)
                || ptsa_host_sim::triad::stream::is_stream_file(d))
        {
            return Ok(Request::Triad(Box::new(super::triad::request(
                &self, d, ctx,
            )?)));
        }
        let filled = match &self.data {
            Some(d) if ptsa_host_sim::stream::axis::is_stream_file(d) => {
                Some(self.axis_stream(d, ctx)?)
            }
            _ => None,
        };
        if filled.is_none()
            && let Some(p) = &self.plan
        {
            anyhow::bail!(
                "--plan {} applies to one axis's raw stream (time_s and its readings, no g_ia); expected --data STREAM with it",
                p.display()
            );
        }
        let data = filled
            .as_ref()
            .map(|f| f.path.clone())
            .or(self.data.clone());
        if self.data.is_none() && self.convert_report_data.is_none() && !ctx.instr.has_loop {
            anyhow::bail!(
                "discover without --data analyses R-890's Tables 6.1–6.3, measured on the Kearfott 2401 in its PTSA loop, and {} describes another instrument without a loop; expected --data FILE with this instrument's measurements",
                ctx.name
            );
        }
        let config = ctx.model_config(self.seed)?;
        if let Some(dir) = self.convert_report_data {
            let names: Vec<String> = r890::case_files()?
                .iter()
                .map(|f| f.name.to_string())
                .collect();
            paths::folder_with("--convert-report-data", &dir, &names)?;
            return Ok(Request::Convert(dir));
        }
        self.single_axis_flags(filled.is_some())?;
        let candidates = self.candidates(ctx)?;
        let replaced = self.outputs(data.as_deref())?;
        let options = Options {
            default_sigma_cm_s2: self.sigma,
            candidates,
            seed: self.seed,
            keep_outliers: self.keep_outliers,
            units_as_given: self.units_as_given,
            terms: self.terms,
            ..Options::for_instrument(&ctx.instr)
        };
        Ok(Request::Analyse(Box::new(Analysis {
            sim: simulator(&ctx.instr, config, self.analytic, self.seed),
            plots: (!self.no_plots).then_some(self.out),
            data,
            filled,
            options,
            json: self.json,
            advice_out: self.advice_out,
            write_instrument: self.write_instrument,
            sheet: self.sheet,
            replaced,
            force: self.force,
        })))
    }

    /// The flags a single-axis case-frame file refuses: the stream's (unless it is one
    /// axis's stream) and `--orientation`.
    fn single_axis_flags(&self, stream: bool) -> Result<()> {
        let data = self
            .data
            .as_deref()
            .map_or(String::new(), |d| d.display().to_string());
        if let (_, Some(flag)) = self.detector()
            && !stream
        {
            anyhow::bail!(
                "{flag} applies to a raw stream (time_s and the three axes' samples: measured_x_cm_s2, measured_y_cm_s2, measured_z_cm_s2 or reading_x, reading_y, reading_z), but {data} is a single-axis case-frame file; expected {flag} only with a stream"
            );
        }
        if self.orientation.is_some() {
            anyhow::bail!(
                "--orientation applies to a triad file (g_x, g_y, g_z, measured_x_cm_s2, ...), but {data} is a single-axis case-frame file; expected --orientation only with a triad file"
            );
        }
        Ok(())
    }

    /// The outputs checked: the table and plots' folder for `data`'s stem (or the report's
    /// tables'), `--advice-out`, `--write-instrument`, `--sheet`; the files `--force` will
    /// replace.
    fn outputs(&self, data: Option<&Path>) -> Result<Vec<Replaced>> {
        if !self.no_plots {
            // The files written: `<stem>-discover.*` of the data file, or, without one,
            // those of each of the report's tables (`report::discovery`).
            let stems = match data {
                Some(p) => vec![discovery::output_stem(Some(p))],
                None => r890::case_files()?
                    .iter()
                    .map(|f| f.name.trim_end_matches(".case.csv").to_string())
                    .collect(),
            };
            let names: Vec<String> = stems
                .iter()
                .flat_map(|stem| {
                    [".csv", ".png", ".svg", "-bode.png", "-bode.svg"].map(|e| format!("{stem}{e}"))
                })
                .collect();
            paths::folder_with("--out", &self.out, &names)?;
        }
        let mut replaced = Vec::new();
        for (flag, p) in [
            ("--advice-out", &self.advice_out),
            ("--write-instrument", &self.write_instrument),
        ] {
            if let Some(p) = p
                && paths::output_file(flag, p, self.force)?
            {
                let before = std::fs::metadata(p).and_then(|m| m.modified()).ok();
                replaced.push((flag, p.clone(), before, paths::what_is_replaced(p)));
            }
        }
        if let Some(dir) = &self.sheet {
            paths::folder("--sheet", dir)?;
            if discovery::sheet::check_target(dir, self.force)? {
                let before = std::fs::metadata(dir).and_then(|m| m.modified()).ok();
                replaced.push(("--sheet", dir.clone(), before, "an earlier sheet".into()));
            }
        }
        Ok(replaced)
    }

    /// The candidates: `--candidates` (each once, in the registry's order), else the
    /// instrument's defaults; a loop parameter is refused for a file without a loop.
    fn candidates(&self, ctx: &Ctx) -> Result<Vec<CandidateId>> {
        let candidates: Vec<CandidateId> = if self.candidates.is_empty() {
            Options::for_instrument(&ctx.instr).candidates
        } else {
            let mut v: Vec<CandidateId> = self.candidates.iter().flatten().copied().collect();
            v.sort_unstable();
            v.dedup();
            v
        };
        if let Some(p) = candidates.iter().find(|id| id.parameter().is_some())
            && !ctx.instr.has_loop
        {
            anyhow::bail!(
                "--candidates {p}: a parameter of the PTSA loop, and {} describes an instrument without one; expected terms of the model equation or other additive effects",
                ctx.name
            );
        }
        Ok(candidates)
    }
}

/// Run the request: the analysis (refused beyond the work limit without `--no-limit`), its
/// report on `out` and its files; a warning for each file `--force` replaced.
///
/// # Errors
/// Refused work; the data cannot be read or analysed; a write fails.
pub fn run(ctx: &Ctx, req: &Request, out: &mut dyn Write) -> Result<()> {
    let a = match req {
        Request::Convert(dir) => {
            for p in r890::write_case_files(dir)? {
                eprintln!("wrote {}", p.display());
            }
            return Ok(());
        }
        Request::Analyse(a) => a,
        Request::Triad(t) => return super::triad::run(ctx, t, out),
    };
    if let Some(f) = &a.filled {
        ptsa_host_sim::output::fs::write_atomic(&f.path, f.text.as_bytes())?;
        if a.json {
            eprint!("{}", f.summary);
        } else {
            write!(out, "{}", f.summary)?;
        }
        if let Some(w) = &f.replaced {
            eprintln!(
                "warning: --positions-out {}: replaced {w} (--force)",
                f.path.display()
            );
        }
        eprintln!(
            "wrote {} (the plan filled from the stream; analysed below)",
            f.path.display()
        );
    }
    let est = estimate(a)?;
    // The search of the loop's parameters, whose length is known only once they are
    // selected, is held to the limit too.
    ptsa_host_sim::simulation::work::set_limit((!work::lifted(a.force)).then(work::limit_s));
    let p = work::Progress::start("discover", &est);
    let r = match &a.data {
        Some(data) => {
            let req = discovery::Request {
                data: data.clone(),
                options: a.options.clone(),
                json: a.json,
                out: a.plots.clone(),
                advice_out: a.advice_out.clone(),
                write_instrument: a.write_instrument.as_ref().map(|p| InstrumentOut {
                    path: p.clone(),
                    source: ctx.text.clone(),
                    source_name: ctx.name.clone(),
                }),
                sheet: a.sheet.as_ref().map(|dir| discovery::sheet::SheetOut {
                    dir: dir.clone(),
                    instrument_name: ctx.name.clone(),
                    instrument_text: ctx.text.clone(),
                    replace: a.force,
                }),
            };
            discovery::run(&req, &*a.sim, out)
        }
        None => report_tables(a, out),
    };
    p.finish();
    if r.is_ok() {
        for (flag, p, before, w) in &a.replaced {
            if std::fs::metadata(p).and_then(|m| m.modified()).ok() != *before {
                eprintln!("warning: {flag} {}: replaced {w} (--force)", p.display());
            }
        }
    }
    r
}

/// `ptsa discover` without `--data`: the report's Tables 6.1, 6.2 and 6.3, each analysed on
/// its own, as the report programme's Markdown section on stdout (with `--json`, the
/// section on stderr and one JSON object by file name on stdout); tables and plots into
/// the plots folder.
fn report_tables(a: &Analysis, out: &mut dyn Write) -> Result<()> {
    let (text, all) =
        ptsa_host_sim::report::discovery::section_json(&*a.sim, &a.options, a.plots.as_deref())?;
    if a.json {
        eprint!("{text}");
        writeln!(out, "{}", serde_json::Value::Object(all))?;
    } else {
        write!(out, "{text}")?;
    }
    Ok(())
}

/// The work of `ptsa discover` before it runs (`discovery::cost`), refused beyond the limit
/// without `--no-limit` and announced when long, with what the search of the loop's
/// parameters may add when one is selected.
fn estimate(a: &Analysis) -> Result<Estimate> {
    let (sim, candidates) = (&*a.sim, &a.options.candidates);
    let costs: Vec<Cost> = match &a.data {
        Some(p) => vec![Cost::of(
            &ptsa_host_sim::model::caseframe::read(p)?,
            sim,
            candidates,
        )],
        None => r890::case_files()?
            .iter()
            .map(|f| Cost::of(&f.rows, sim, candidates))
            .collect(),
    };
    let ticks = costs.iter().map(|c| c.ticks).sum();
    let seconds: f64 = costs.iter().map(Cost::seconds).sum();
    let est = Estimate {
        ticks,
        other_s: seconds - ticks.seconds(),
    };
    let search: Ticks = costs.iter().map(|c| c.search(1)).sum();
    let more = (search.seconds() > 1.0).then(|| {
        format!(
            "and up to {} more if a parameter of the loop is selected (the closed-loop search of the others, held to the same limit)",
            human(search.seconds())
        )
    });
    work::check(
        est,
        a.force,
        "discover",
        more.as_deref(),
        "fewer rows, or rows of shorter periods",
    )
}
