//! `ptsa noise`: the overlapping and modified Allan deviations and the overlapping Hadamard
//! deviation of a static counter record (`--counts`), of a record of any instrument's
//! readings (`--readings`) or of the simulated loop at rest (`--simulate`), with their
//! intervals, the noise terms read from them, a table or JSON, and a log–log plot
//! (`ptsa_host_sim::noise`).
#![allow(
    clippy::cast_precision_loss,
    reason = "gate counts, far below 2^52, as f64"
)]

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result, bail};
use clap::Args;
use ptsa_host_sim::model::instrument::ReadingUnit;
use ptsa_host_sim::noise::allan::{Settings, Taus};
use ptsa_host_sim::noise::comparison::Comparison;
use ptsa_host_sim::noise::identify::{self as ident, Identification, Kind};
use ptsa_host_sim::noise::identify_terms as ident_terms;
use ptsa_host_sim::noise::json::{IdentificationJson, TermsIdentificationJson};
use ptsa_host_sim::noise::readings::{self, Readings};
use ptsa_host_sim::noise::{self, Analysis, Record};
use ptsa_host_sim::output::significant as sig;
use ptsa_host_sim::output::write_atomic;
use ptsa_host_sim::simulation::sim::SimOptions;
use ptsa_host_sim::simulation::work::Estimate;

use super::{Ctx, gate_ticks};
use crate::flags::values::{non_negative_s, positive_s, seed};
use crate::paths;
use crate::work::{self, Work};

/// Arguments of `ptsa noise`.
#[derive(Args, Debug, Clone)]
pub struct NoiseArgs {
    /// Static counter record: CSV `time_s,pulses,ticks` with that header (as `ptsa
    /// response` reads), gates back to back (each starting one gate, T/clock_hz s, after
    /// the previous, within 1 %), of equal length, at least 8.
    #[arg(
        long,
        value_name = "FILE",
        conflicts_with_all = ["simulate", "readings"],
        required_unless_present_any = ["simulate", "readings"]
    )]
    pub counts: Option<PathBuf>,
    /// Static record of any instrument's readings: CSV with the columns time_s (s) and
    /// reading (others ignored), one sample per row, evenly spaced (each spacing within
    /// --spacing-tol of the median; a gap or a duplicate time is refused with its line), at
    /// least 8 rows. The reading in --unit. Analysed as a counter record is, with the
    /// Hadamard deviation and the rate ramp besides.
    #[arg(long, value_name = "FILE", conflicts_with = "simulate")]
    pub readings: Option<PathBuf>,
    /// With --readings: the readings' unit, one of V, mA, LSB, g, m/s2, cm/s2 (V, mA and LSB
    /// through the instrument file's instrument.scale_factor_per_g; g of its local
    /// gravity). Default: the file's instrument.reading_unit, cm/s² without one.
    #[arg(long, value_name = "UNIT", value_parser = reading_unit, requires = "readings")]
    pub unit: Option<ReadingUnit>,
    /// With --readings: the largest departure of a spacing from the record's median
    /// spacing, as a fraction of it (0 to 0.5; default 0.01).
    #[arg(long, value_name = "FRACTION", value_parser = spacing_tol, requires = "readings",
          default_value_t = readings::SPACING_TOL)]
    pub spacing_tol: f64,
    /// The averaging times: octave (1, 2, 4, 8, ... times the gate or sample interval, the
    /// default), decade (1, 2, 4, 10, 20, 40, 100, ...), all (every whole multiple; O(N²),
    /// refused beyond the work limit without --no-limit), or a list of times in s (T1,T2,...),
    /// each a whole number of gates or samples. --compare and --identify take octave.
    #[arg(long, value_name = "SPEC", value_parser = taus_arg, default_value = "octave")]
    pub taus: TausArg,
    /// The confidence level of the intervals given beside the 95 % ones (JSON ci_lo, ci_hi,
    /// mdev_ci_lo, mdev_ci_hi, hdev_ci_lo, hdev_ci_hi), more than 0 and less than 1; e.g.
    /// 0.683 for Stable32's 1-sigma bounds. Default 0.95.
    #[arg(long, value_name = "P", value_parser = confidence, default_value_t = 0.95)]
    pub confidence: f64,
    /// Simulate the instrument file's closed loop at rest (no acceleration along IA; its
    /// bias and pickoff noise noise_uv_rms included) for --seconds, and analyse that record.
    #[arg(long, requires = "seconds")]
    pub simulate: bool,
    /// With --counts: simulate the instrument file's loop for as long as the record, with its
    /// gate and with the acceleration along IA that gives the record's mean (less the file's
    /// bias), and compare the two Allan deviations tau by tau: z of the log ratio from both
    /// EDFs, Holm's step-down over the taus at 5 % familywise.
    #[arg(long, requires = "counts")]
    pub compare: bool,
    /// With --counts: identify what the instrument file's loop lacks: the record's Allan
    /// variance modelled as the simulated loop's (as --compare) with a pickoff noise
    /// (noise_uv_rms, 0 to 8 uV rms), a white acceleration noise N (alone AVAR = N^2/tau;
    /// cm/s^2/rtHz, ug/rtHz) and a bias random walk K (alone AVAR = K^2 tau/3; cm/s^2.5,
    /// ug/rts) inside the loop (N and K entering the plant's input), on a grid interpolated
    /// in noise power, averaged over 2 seeds; selected forward with Holm's thresholds at
    /// 5 % familywise; the selected ones with their 95 % intervals (docs/method/noise.md). A
    /// record longer than 8192 gates has the loop simulated for its first 8192 and the
    /// added noises for its whole length (a 12-hour record of 10 ms gates in about a
    /// minute; docs/method/noise.md, "Long records").
    /// With --readings: which of IEEE Std 952's terms the record holds (Q cm/s, N
    /// cm/s^2/rtHz, B cm/s^2, K cm/s^2.5, R cm/s^3, each also in ug and navigation units),
    /// the best single term first, then forward with Holm's thresholds at 5 % familywise,
    /// the points' covariance from 200 records drawn at the fitted terms; each selected
    /// one with its 95 % interval (docs/method/noise.md, "Which terms a record holds").
    #[arg(long)]
    pub identify: bool,
    /// With --identify: write the instrument file with the identified pickoff noise
    /// (noise_uv_rms, uV rms) to FILE, only when the pickoff noise was identified; an
    /// existing file is replaced only with --force.
    #[arg(long, value_name = "FILE", requires = "identify")]
    pub write_instrument: Option<PathBuf>,
    /// With --simulate: the simulated record's length after the settling, s (more than 0).
    #[arg(long, value_name = "S", value_parser = positive_s, requires = "simulate")]
    pub seconds: Option<f64>,
    /// With --simulate: the gate, s (at least one limit cycle, 0.001 s at 64 kHz).
    #[arg(long, default_value_t = noise::DEFAULT_GATE_S, value_name = "S",
          value_parser = positive_s)]
    pub gate_s: f64,
    /// With --simulate, --compare or --identify: seed of the simulated loop's pickoff
    /// noise, a whole number from 0 to 2^64 − 1, no unit (with --identify mixed with the
    /// record's own counts: two records never share their simulated records).
    #[arg(long, default_value_t = SimOptions::default().seed, value_name = "N",
          value_parser = seed)]
    pub seed: u64,
    /// With --simulate or --compare: settling time from reset before the first gate, s (0 or
    /// more).
    #[arg(long, default_value_t = SimOptions::default().warmup_s, value_name = "S",
          value_parser = non_negative_s)]
    pub warmup_s: f64,
    /// With --simulate: write the simulated counter record (time_s,pulses,ticks) to FILE;
    /// an existing file is replaced only with --force.
    #[arg(
        short = 'o',
        long = "output",
        alias = "out",
        value_name = "FILE",
        requires = "simulate"
    )]
    pub out: Option<PathBuf>,
    /// Write the log–log plot (ADEV with its 95 % bars, MDEV, HDEV where computed, the
    /// fitted terms) as STEM.png and STEM.svg, STEM the file given without its .png or .svg;
    /// an existing file is replaced only with --force.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
    /// Print exactly one JSON object: the record's figures, one point per tau (the
    /// deviations and their intervals, cm/s²) and the noise terms; with --compare also
    /// "comparison", with --identify "identification" (counts) or "terms_identification"
    /// (readings). Every key, with its unit and meaning: docs/reference/json.md.
    #[arg(long)]
    pub json: bool,
    /// Replace an existing --output, --plot or --write-instrument file (the work limit is
    /// --no-limit's).
    #[arg(long)]
    pub force: bool,
    #[command(flatten)]
    pub limit: crate::flags::LimitArg,
}

/// A file and what it replaces when `--force` replaces it.
type Checked = Option<(PathBuf, Option<String>)>;

/// `--plot FILE`'s two files, PNG then SVG: FILE as given and its sibling of the other
/// format, each checked by `checked` (the given one first).
///
/// # Errors
/// FILE does not end in .png or .svg (or has no extension); a file refused by `checked`.
fn plot_files(
    p: &Path,
    checked: &dyn Fn(&str, Option<PathBuf>) -> Result<Checked>,
) -> Result<(Checked, Checked)> {
    let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("");
    if !matches!(ext, "" | "png" | "svg") {
        bail!(
            "--plot {}: expected a file name ending in .png or .svg (the plot is written in both formats), or a stem without an extension",
            p.display()
        );
    }
    let stem = p.with_extension("");
    let (png, svg) = (stem.with_extension("png"), stem.with_extension("svg"));
    Ok(if ext == "svg" {
        let s = checked("--plot", Some(svg))?;
        (checked("--plot", Some(png))?, s)
    } else {
        let g = checked("--plot", Some(png))?;
        (g, checked("--plot", Some(svg))?)
    })
}

/// `--taus` as given: a name, or times in s (made factors once the interval is known).
#[derive(Clone, Debug, PartialEq)]
pub enum TausArg {
    /// `octave`, `decade` or `all`.
    Named(Taus),
    /// Times in s.
    Seconds(Vec<f64>),
}

/// `--taus`: `octave`, `decade`, `all` or a list of times in s, each more than 0.
fn taus_arg(s: &str) -> Result<TausArg, String> {
    if let Some(t) = Taus::named(s) {
        return Ok(TausArg::Named(t));
    }
    s.trim()
        .split(',')
        .map(|t| {
            t.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v > 0.0)
                .ok_or_else(|| format!("`{}`: expected octave, decade, all, or averaging times in s (more than 0), comma separated", t.trim()))
        })
        .collect::<Result<Vec<f64>, String>>()
        .map(TausArg::Seconds)
}

/// `--confidence`: a level strictly between 0 and 1.
fn confidence(s: &str) -> Result<f64, String> {
    let x = crate::flags::values::finite(s)?;
    if x > 0.0 && x < 1.0 {
        Ok(x)
    } else {
        Err(format!(
            "expected a confidence level more than 0 and less than 1 (0.95 for 95 %), not {s}"
        ))
    }
}

/// `--spacing-tol`: a fraction from 0 to 0.5.
fn spacing_tol(s: &str) -> Result<f64, String> {
    let x = crate::flags::values::finite(s)?;
    if (0.0..=0.5).contains(&x) {
        Ok(x)
    } else {
        Err(format!(
            "expected a fraction of the spacing from 0 to 0.5 (0.01 for 1 %), not {s}"
        ))
    }
}

/// `--unit`: a reading unit.
fn reading_unit(s: &str) -> Result<ReadingUnit, String> {
    ReadingUnit::parse(s).ok_or_else(|| format!("expected one of {}", ReadingUnit::names()))
}

impl TausArg {
    /// The factors for a record of interval `tau0_s` and `n` gates or samples.
    ///
    /// # Errors
    /// A time that is not a whole number of intervals, or beyond half the record.
    fn taus(&self, tau0_s: f64, n: usize) -> Result<Taus> {
        match self {
            TausArg::Named(t) => Ok(t.clone()),
            TausArg::Seconds(ts) => Taus::of_seconds("--taus", ts, tau0_s, n),
        }
    }
}

/// Nanoseconds of the all-tau analysis per sample and averaging time (the deviations and
/// the noise type, each a pass over the record; measured on the development machine,
/// rounded up).
const ALL_TAU_NS: f64 = 12.0;

/// Refuse the all-tau analysis of `n` samples beyond the work limit unless lifted
/// ([`work::lifted`]); announce it when long.
///
/// # Errors
/// Beyond the limit without `--no-limit`.
fn all_taus_check(n: usize, force: bool) -> Result<()> {
    #[allow(clippy::cast_precision_loss)]
    let s = ALL_TAU_NS * 1e-9 * n as f64 * n as f64 / 2.0;
    let limit = work::limit_s();
    if s > limit && !work::lifted(force) {
        bail!(
            "--taus all: {} averaging times over {n} samples would take roughly {} on this machine; expected at most about {} (--taus octave or decade, or --no-limit to run it anyway)",
            n / 2,
            ptsa_host_sim::simulation::work::human(s),
            ptsa_host_sim::simulation::work::human(limit)
        );
    }
    if s > work::ANNOUNCE_S {
        eprintln!(
            "--taus all: about {} of work estimated",
            ptsa_host_sim::simulation::work::human(s)
        );
    }
    Ok(())
}

/// What to analyse.
enum Source {
    /// A record read and checked, by its name; with the options of the comparison's
    /// simulation (`--compare`).
    Counts(String, Record, Option<SimOptions>),
    /// A record of readings read and checked, by its name.
    Readings(String, Readings),
    /// The loop to simulate: options, gate ticks, gates.
    Simulate {
        opts: SimOptions,
        ticks: u64,
        gates: u64,
    },
}

/// A noise analysis to run.
pub struct Request {
    source: Source,
    /// The averaging times (resolved) and the second confidence level.
    settings: Settings,
    out: Checked,
    /// The plot's PNG and SVG files, each with what it replaces.
    plot: Option<(Checked, Checked)>,
    json: bool,
    force: bool,
    /// `--identify`: the simulations' options.
    identify: Option<SimOptions>,
    /// `--write-instrument`: the file, and what it replaces.
    write_instrument: Checked,
}

/// The outputs checked: `--output`, `--plot`'s two files, `--write-instrument`.
struct Outputs {
    out: Checked,
    plot: Option<(Checked, Checked)>,
    write_instrument: Checked,
}

impl NoiseArgs {
    /// The files the command reads, by their flags: no output may replace them.
    pub fn inputs(&self) -> [(&'static str, Option<&Path>); 2] {
        [
            ("--counts", self.counts.as_deref()),
            ("--readings", self.readings.as_deref()),
        ]
    }

    /// The request: the outputs checked (never an input, an existing file only with
    /// `--force`), the record read and checked, or the simulation's gate and length.
    ///
    /// # Errors
    /// An output refused; the record cannot be read, is not a counter record or its gates
    /// are not back to back; the gate does not fit the loop; too many gates.
    pub fn request(self, ctx: &Ctx) -> Result<Request> {
        self.check_flags()?;
        let outputs = self.outputs()?;
        let identify = if self.identify && self.readings.is_some() {
            // Only the seed: the replicas are drawn from the terms, not simulated.
            Some(SimOptions {
                seed: self.seed,
                ..SimOptions::default()
            })
        } else if self.identify {
            Some(self.sim_options(ctx)?)
        } else {
            None
        };
        let source = self.source(ctx)?;
        let (tau0_s, n) = match &source {
            Source::Counts(_, r, _) => (r.tau0_s, r.gates.len()),
            Source::Readings(_, r) => (r.tau0_s, r.y.len()),
            #[allow(clippy::cast_precision_loss, clippy::cast_possible_truncation)]
            Source::Simulate { ticks, gates, .. } => {
                (*ticks as f64 / ctx.instr.clock_hz, *gates as usize)
            }
        };
        let settings = Settings {
            taus: self.taus.taus(tau0_s, n)?,
            confidence: self.confidence,
            hadamard: true,
        };
        if settings.taus == Taus::All {
            all_taus_check(n, self.force)?;
        }
        Ok(Request {
            source,
            settings,
            out: outputs.out,
            plot: outputs.plot,
            json: self.json,
            force: self.force,
            identify,
            write_instrument: outputs.write_instrument,
        })
    }

    /// The flags that need a source clap cannot check (it drops an option's `requires`
    /// when the option it requires conflicts with one given, --counts with --simulate),
    /// and `--taus` with `--compare` or `--identify`.
    fn check_flags(&self) -> Result<()> {
        for (given, flag, needs, present) in [
            (
                self.unit.is_some(),
                "--unit",
                "--readings",
                self.readings.is_some(),
            ),
            (self.compare, "--compare", "--counts", self.counts.is_some()),
            (
                self.identify,
                "--identify",
                "--counts or --readings",
                self.counts.is_some() || self.readings.is_some(),
            ),
            (
                self.write_instrument.is_some(),
                "--write-instrument",
                "--counts",
                self.counts.is_some(),
            ),
        ] {
            if given && !present {
                bail!(
                    "{flag} applies to {needs} FILE only; expected it with {needs}, or not at all"
                );
            }
        }
        if (self.compare || self.identify) && self.taus != TausArg::Named(Taus::Octave) {
            bail!(
                "--taus: {} compares the record with simulated ones at octave averaging times; expected --taus octave (the default) with it",
                if self.identify {
                    "--identify"
                } else {
                    "--compare"
                }
            );
        }
        Ok(())
    }

    /// The outputs, each checked (never an input, an existing file only with `--force`)
    /// and none the same file as another.
    fn outputs(&self) -> Result<Outputs> {
        let checked = |flag: &str, p: Option<PathBuf>| -> Result<_> {
            Ok(match p {
                Some(p) => {
                    let replaced = paths::output_file(flag, &p, self.force)?
                        .then(|| paths::what_is_replaced(&p));
                    Some((p, replaced))
                }
                None => None,
            })
        };
        let out = checked("--output", self.out.clone())?;
        // The plot as STEM.png and STEM.svg, the file as given checked first.
        let plot = match self.plot.clone() {
            Some(p) => Some(plot_files(&p, &checked)?),
            None => None,
        };
        let write_instrument = checked("--write-instrument", self.write_instrument.clone())?;
        let plots: Vec<&(PathBuf, Option<String>)> = plot
            .iter()
            .flat_map(|(a, b)| [a.as_ref(), b.as_ref()])
            .flatten()
            .collect();
        for p in plots.iter().map(|p| &p.0).chain(out.iter().map(|o| &o.0)) {
            if write_instrument.as_ref().is_some_and(|w| w.0 == *p) {
                bail!(
                    "--write-instrument {}: the same file as another output; expected its own file",
                    p.display()
                );
            }
        }
        if let Some((o, _)) = &out
            && plots.iter().any(|p| p.0 == *o)
        {
            bail!(
                "--plot {}: the same file as --output; expected two files (the record and its plot)",
                o.display()
            );
        }
        Ok(Outputs {
            out,
            plot,
            write_instrument,
        })
    }

    /// The simulations' options: seed, settling, the loop's configuration.
    fn sim_options(&self, ctx: &Ctx) -> Result<SimOptions> {
        Ok(SimOptions {
            seed: self.seed,
            warmup_s: self.warmup_s,
            config: ctx.config()?,
            ..SimOptions::default()
        })
    }

    /// What to analyse: the readings or the counter record read and checked, or the
    /// simulation's gate and length.
    fn source(&self, ctx: &Ctx) -> Result<Source> {
        if let Some(path) = &self.readings {
            let unit = self.unit.unwrap_or_else(|| {
                ctx.instr
                    .reading_scale
                    .as_ref()
                    .map_or(ReadingUnit::CmPerS2, |r| r.unit)
            });
            let r = readings::read(path, unit, &ctx.instr, self.spacing_tol)?;
            return Ok(Source::Readings(path.display().to_string(), r));
        }
        if let Some(path) = &self.counts {
            ctx.require_loop()?;
            let rec = noise::read_record(path, ctx.instr.clock_hz)?;
            let compare = if self.compare {
                Some(self.sim_options(ctx)?)
            } else {
                None
            };
            return Ok(Source::Counts(path.display().to_string(), rec, compare));
        }
        let opts = self.sim_options(ctx)?;
        let ticks = gate_ticks("--gate-s", self.gate_s, &ctx.instr, &opts)?;
        let gates = noise::simulated_gates(
            ("--seconds", "--gate-s"),
            self.seconds.unwrap_or(0.0),
            ticks,
            ctx.instr.clock_hz,
        )?;
        Ok(Source::Simulate { opts, ticks, gates })
    }
}

/// Simulate (refused beyond the work limit without `--no-limit`) or take the record; analyse
/// it; write the record and the plot; print the table or the JSON.
///
/// # Errors
/// Refused work; a write fails.
pub fn run(ctx: &Ctx, req: &Request, out: &mut dyn Write) -> Result<()> {
    let instr = &ctx.instr;
    let mut warnings: Vec<String> = Vec::new();
    let mut compare_opts = None;
    let (name, record) = match &req.source {
        Source::Counts(name, rec, opts) => {
            compare_opts = *opts;
            (name.clone(), Some(rec.clone()))
        }
        Source::Readings(name, _) => (name.clone(), None),
        Source::Simulate { opts, ticks, gates } => {
            let (n, r) = simulated(ctx, req, opts, *ticks, *gates)?;
            (n, Some(r))
        }
    };
    let a = match (&req.source, &record) {
        (Source::Readings(_, r), _) => Analysis::of_readings(r, &req.settings),
        (_, Some(rec)) => Analysis::of_with(rec, instr.sf_cm_s2, instr.clock_hz, &req.settings),
        (_, None) => unreachable!("a counter record or a simulated one"),
    };
    warnings.extend(noise::analysis_warnings(&name, &a));
    let comparison = match (&compare_opts, &record) {
        (Some(opts), Some(record)) => Some(simulate_and_compare(ctx, req, opts, record, &a)?),
        _ => None,
    };
    if let Some(w) = comparison.as_ref().and_then(|c| c.warning(&name)) {
        warnings.push(w);
    }
    let identification = match (&req.identify, &record) {
        (Some(opts), Some(record)) => Some(identify(ctx, req, opts, record, &a)?),
        _ => None,
    };
    if let Some(id) = &identification {
        warnings.extend(noise::identification_warnings(&name, id));
    }
    let terms_identification = match (&req.source, &req.identify) {
        (Source::Readings(_, r), Some(opts)) => Some(identify_terms(r, &a, opts.seed)?),
        _ => None,
    };
    if let (Some((path, replaced)), Some(id)) = (&req.write_instrument, &identification) {
        write_identified(ctx, path, replaced.as_deref(), &name, id)?;
    }
    if let Some((Some((png, png_was)), Some((svg, svg_was)))) = &req.plot {
        let title = format!("Allan deviation: {name}");
        a.write_png(png, &title)?;
        write_atomic(svg, a.svg(&title)?.as_bytes())?;
        for (p, w) in [(png, png_was), (svg, svg_was)] {
            if let Some(w) = w {
                eprintln!("warning: --plot {}: replaced {w} (--force)", p.display());
            }
        }
        eprintln!("wrote the plot {} and {}", png.display(), svg.display());
    }
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    if req.json {
        let mut v = a.json(&name, &warnings);
        v.comparison = comparison.as_ref().map(Comparison::json);
        v.identification = identification.as_ref().map(IdentificationJson::new);
        v.terms_identification = terms_identification
            .as_ref()
            .map(TermsIdentificationJson::new);
        // Through a `Value`: its keys are printed in the order of their names, as ever.
        writeln!(out, "{}", serde_json::to_value(&v)?)?;
    } else {
        write!(out, "{}", a.text(&name))?;
        if let Some(c) = &comparison {
            write!(out, "{}", c.text())?;
        }
        if let Some(id) = &identification {
            write!(out, "{}", identification_text(id))?;
        }
        if let Some(id) = &terms_identification {
            write!(out, "{}", id.text())?;
        }
    }
    Ok(())
}

/// Which of IEEE Std 952's terms the readings hold (`--readings FILE --identify`), with a
/// progress line on a long record.
fn identify_terms(r: &Readings, a: &Analysis, seed: u64) -> Result<ident_terms::Identification> {
    let est = Estimate {
        other_s: ident_terms::work_seconds(r.y.len()),
        ..Estimate::default()
    };
    let bar = work::Progress::start("noise --identify", &est);
    let id = noise::identify_readings(r, a, seed, &mut |round| {
        bar.set_step(&format!("round {}", round + 1));
    });
    bar.finish();
    id
}

/// Simulate the loop at rest (refused beyond the work limit without `--no-limit`), write its
/// record to `--output` if given; the record's name and the record.
fn simulated(
    ctx: &Ctx,
    req: &Request,
    opts: &SimOptions,
    ticks: u64,
    gates: u64,
) -> Result<(String, Record)> {
    let instr = &ctx.instr;
    let est = Work::new(instr, opts)
        .gate(ticks * gates)
        .check(req.force, "this simulated record")?;
    let bar = work::Progress::start("noise --simulate", &est);
    let g = noise::simulate_record(instr, opts, 0.0, ticks, gates);
    bar.finish();
    #[allow(clippy::cast_precision_loss)]
    let gate = ticks as f64 / instr.clock_hz;
    let comments = [
        format!(
            "the simulated closed loop at rest (`ptsa noise --simulate`): {}, pickoff noise noise_uv_rms = {} uV, bias {} cm/s^2, seed {}",
            ctx.name,
            instr.noise_v_rms * 1e6,
            instr.bias_cm_s2,
            opts.seed
        ),
        format!(
            "{gates} gates of {ticks} ticks ({} s) back to back after {} s of settling from reset; time_s from the end of the settling",
            sig(gate, 8),
            opts.warmup_s
        ),
    ];
    if let Some((path, replaced)) = &req.out {
        write_atomic(path, noise::record_csv(&g, &comments).as_bytes())?;
        if let Some(w) = replaced {
            eprintln!(
                "warning: --output {}: replaced {w} (--force)",
                path.display()
            );
        }
        eprintln!("wrote the record {}", path.display());
    }
    let name = req.out.as_ref().map_or_else(
        || format!("simulated ({}, seed {})", ctx.name, opts.seed),
        |(p, _)| p.display().to_string(),
    );
    // The lines the gates have in the written record: the comments, the header.
    let lines: Vec<usize> = (0..g.len()).map(|k| k + comments.len() + 2).collect();
    let record = noise::check_record(&name, g, &lines, instr.clock_hz)?;
    Ok((name, record))
}

/// Simulate the loop as long as `record`, with its gate, at the acceleration along IA that
/// gives its mean, and compare the deviations (refused beyond the work limit without
/// `--no-limit`).
fn simulate_and_compare(
    ctx: &Ctx,
    req: &Request,
    opts: &SimOptions,
    record: &Record,
    measured: &Analysis,
) -> Result<Comparison> {
    let ticks = record.gates[0].ticks;
    let gates = record.gates.len() as u64;
    let est = Work::new(&ctx.instr, opts)
        .gate(ticks * gates)
        .check(req.force, "the comparison's simulated record")?;
    let bar = work::Progress::start("noise --compare", &est);
    let c = Comparison::simulate(&ctx.instr, opts, record, measured);
    bar.finish();
    c
}

/// Identify the candidates beyond the file's loop (`--identify`): the simulations refused
/// beyond the work limit without `--no-limit`.
fn identify(
    ctx: &Ctx,
    req: &Request,
    opts: &SimOptions,
    record: &Record,
    measured: &Analysis,
) -> Result<Identification> {
    let instr = &ctx.instr;
    let ticks = record.gates[0].ticks;
    // At most every node of the grid; a record with nothing beyond the file's loop needs
    // about a tenth of it. A record longer than LOOP_GATES runs the loop for that many.
    let sims = ident::MAX_RECORDS;
    let looped = (record.gates.len() as u64).min(ident::LOOP_GATES);
    let est = Work::new(instr, opts)
        .gate(ticks * looped * sims)
        .check(req.force, "the identification's simulated records")?;
    let bar = work::Progress::start("noise --identify", &est);
    let id = ident::identify(instr, opts, record, measured, &mut |_, _| {});
    bar.finish();
    Ok(id)
}

/// `--write-instrument`: the instrument file with the identified pickoff noise, written
/// only when it was identified (otherwise a line saying so).
fn write_identified(
    ctx: &Ctx,
    path: &Path,
    replaced: Option<&str>,
    record: &str,
    id: &Identification,
) -> Result<()> {
    let Some((u, lo, hi)) = id
        .get(Kind::Pickoff)
        .filter(|c| c.selected)
        .and_then(|c| c.value)
    else {
        eprintln!(
            "the pickoff noise was not identified: --write-instrument {} not written",
            path.display()
        );
        return Ok(());
    };
    let value: f64 = format!("{u:.3}").parse().unwrap_or(u);
    let note = format!(
        "ptsa noise --counts {record} --identify: noise_uv_rms {} uV rms, 95 % interval [{}, {}], was {}",
        sig(value, 4),
        sig(lo, 4),
        sig(hi, 4),
        sig(id.file_uv, 4)
    );
    let text = ptsa_host_sim::Instrument::rewrite(
        &ctx.text,
        &ctx.name,
        &[("pickoff.noise_uv_rms", value, note)],
    )
    .with_context(|| format!("--write-instrument {}", path.display()))?;
    write_atomic(path, text.as_bytes())?;
    if let Some(w) = replaced {
        eprintln!(
            "warning: --write-instrument {}: replaced {w} (--force)",
            path.display()
        );
    }
    eprintln!(
        "wrote {} ({} with the identified noise_uv_rms)",
        path.display(),
        ctx.name
    );
    Ok(())
}

fn identification_text(id: &Identification) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "identification beyond the file's loop ({} cm/s^2 along IA, its pickoff noise {} uV rms; the loop simulated with the noises inside at {} uV, N {} cm/s^2/rtHz, K {} cm/s^2.5, {} records; chi2 of the file's loop alone {:.1} on {} taus); Holm at 5 % familywise:",
        sig(id.input_cm_s2, 8),
        sig(id.file_uv, 4),
        id.grid_uv
            .iter()
            .map(|u| sig(*u, 3))
            .collect::<Vec<_>>()
            .join(", "),
        id.grid_white
            .iter()
            .map(|u| sig(*u, 3))
            .collect::<Vec<_>>()
            .join(", "),
        id.grid_walk
            .iter()
            .map(|u| sig(*u, 3))
            .collect::<Vec<_>>()
            .join(", "),
        id.simulated_records,
        id.chi2_file,
        id.taus.len()
    );
    for c in &id.candidates {
        let name = match c.kind {
            Kind::WhiteAcceleration => "white acceleration noise N",
            Kind::RandomWalk => "bias random walk K",
            Kind::Pickoff => "pickoff noise noise_uv_rms",
        };
        let stat = if c.kind == Kind::Pickoff {
            format!("delta-chi2 {:.2}", c.statistic)
        } else {
            format!("z {:.2}", c.statistic)
        };
        match c.value.filter(|_| c.selected) {
            Some((v, lo, hi)) => {
                let parts: Vec<String> = c
                    .kind
                    .units()
                    .into_iter()
                    .map(|(u, k)| {
                        format!(
                            "{} [{}, {}]{} {u}",
                            sig(v * k, 4),
                            sig(lo * k, 4),
                            sig(hi * k, 4),
                            if c.open_above { "+" } else { "" }
                        )
                    })
                    .collect();
                let _ = writeln!(
                    s,
                    "  {name}: identified ({stat}, p {:.2e}): {} (95 %; the profile's threshold x{:.2}, interval_scale)",
                    c.p,
                    parts.join(" = "),
                    c.interval_scale
                );
            }
            None => {
                let _ = writeln!(s, "  {name}: not identified ({stat}, p {:.3})", c.p);
            }
        }
    }
    if id.candidates.iter().all(|c| !c.selected) {
        let _ = writeln!(
            s,
            "  nothing identified: the record's Allan deviation is the instrument file's loop's within its intervals"
        );
    }
    if let Some(t) = id.loop_split_tau_s {
        let _ = writeln!(
            s,
            "  a long record: each simulated record ran the loop for its first {} gates; the loop's part is simulated up to tau {} s and carried as 1/tau^2 beyond, the added noises drawn for the whole length (docs/method/noise.md, \"Long records\")",
            id.simulated_gates,
            sig(t, 4)
        );
    }
    s
}
