//! The command line: the top-level options, the list of subcommands (each subcommand's own
//! arguments live beside its code in `cmd/`), the option groups several of them share, the
//! value parsers ([`values`]) and the parse itself, with the two refusals clap cannot
//! express. Clap types never leave the binary: each subcommand turns its arguments into a
//! validated request before any work. Units are in every option's name and help.
// The doc comments here are clap's `--help` text, printed as plain text: backticks around
// column names and symbols (time_s, A_b, θ_my) would show up in the help verbatim.
#![allow(clippy::doc_markdown, reason = "clap help text, not rustdoc")]

#[cfg(test)]
mod reference;
pub mod values;

use std::ffi::OsString;
use std::path::{Path, PathBuf};

use clap::error::ErrorKind;
use clap::parser::ValueSource;
use clap::{Args, CommandFactory as _, FromArgMatches as _, Parser, Subcommand};
use ptsa_host_sim::simulation::sim::SimOptions;

use crate::cmd::{
    bench::BenchArgs, correct::CorrectArgs, design::DesignArgs, discover::DiscoverArgs,
    experiments, instrument::InstrumentArgs, noise::NoiseArgs, plan::PlanArgs,
    predict::PredictArgs, record::RecordArgs, report::ReportArgs, response::ResponseArgs,
    static_::StaticArgs,
};
use values::{non_negative_s, positive_s, seed};

/// Closed-loop simulator of the Kearfott 2401 accelerometer in the UAC PTSA forced-binary
/// loop (Draper report R-890), built on ptsa-core, the firmware's own loop code.
///
/// Without a subcommand, runs the report's whole test programme on the instrument file and
/// writes a report folder (tables as CSV, plots as PNG and SVG, summary.md), which appears
/// whole or not at all. Units: cm/s² for accelerations, rad/s for rates, mrad for
/// oscillation amplitudes, g·cm² for inertias, Hz, seconds.
#[derive(Parser, Debug)]
// The report's own options (`--out`, `--seed`, ...) before a subcommand would do nothing:
// [`parse`] refuses them there (clap's `args_conflicts_with_subcommands` would refuse the
// global `--instrument` as well).
#[command(
    name = "ptsa",
    version,
    about,
    long_about,
    allow_negative_numbers = true
)]
pub struct Cli {
    /// Instrument file (TOML: Table 2.1 with tolerances and the PTSA electronics, see
    /// data/kearfott-2401.toml; or an accelerometer without a PTSA loop, see
    /// docs/reference/instrument-files.md), or a shipped instrument by name: kearfott-2401 (the default),
    /// navigation, mems.
    // Listed after each subcommand's own options (a global option is otherwise sorted in
    // among them by name).
    #[arg(long, global = true, value_name = "FILE", display_order = 900)]
    pub instrument: Option<PathBuf>,
    /// Options of the report programme (no subcommand).
    #[command(flatten)]
    pub report: ReportArgs,
    /// What to run.
    #[command(subcommand)]
    pub cmd: Option<Cmd>,
}

impl Cli {
    /// The files the command line names as inputs, by their flags: no output may replace
    /// them.
    /// `--local-gravity` of the subcommands that take it (`discover`, `correct`), cm/s².
    pub fn local_gravity(&self) -> Option<f64> {
        match &self.cmd {
            Some(Cmd::Discover(a)) => a.local_gravity,
            Some(Cmd::Correct(a)) => a.local_gravity,
            _ => None,
        }
    }

    pub fn inputs(&self) -> Vec<(&'static str, Option<&Path>)> {
        let mut v = vec![("--instrument", self.instrument.as_deref())];
        match &self.cmd {
            Some(Cmd::Discover(a)) => v.extend(a.inputs()),
            Some(Cmd::Predict(a)) => v.extend(a.inputs()),
            Some(Cmd::Response(a)) => v.extend(a.inputs()),
            Some(Cmd::Record(a)) => v.extend(a.inputs()),
            Some(Cmd::Correct(a)) => v.extend(a.inputs()),
            Some(Cmd::Noise(a)) => v.extend(a.inputs()),
            _ => {}
        }
        v
    }
}

/// The subcommands; each variant's doc comment is its line in `--help`, its arguments are
/// in its module of `cmd/`.
#[derive(Subcommand, Debug)]
pub enum Cmd {
    /// Section 6.1: ±1 g counts P1, P2 over a gate T; SF and A_b by eqs. 6.3/6.4; and IA
    /// through 360°.
    #[command(allow_negative_numbers = true)]
    Tumble(experiments::TumbleArgs),
    /// Table 6.1: 8 IA positions on the rate table at 1.0 and 0.05 rad/s (eq. 6.5).
    #[command(allow_negative_numbers = true)]
    Anisoinertia(experiments::AnisoinertiaArgs),
    /// Tables 6.2/6.3: angular oscillation about OA, IA horizontal and vertical.
    #[command(allow_negative_numbers = true)]
    OaCoupling(experiments::OaCouplingArgs),
    /// Appendix A.1 (Fig. A.2): IA and PA vibration on the two-axis oscillator, phase sweep.
    #[command(allow_negative_numbers = true)]
    Vibropendulosity(experiments::TwoAxisArgs),
    /// Appendix A.2 (Fig. A.4): IA and OA vibration, phase sweep.
    #[command(allow_negative_numbers = true)]
    Anisoelasticity(experiments::TwoAxisArgs),
    /// Appendix A.3 (Fig. A.5): OA angular oscillation with PA vibration, phase sweep.
    #[command(allow_negative_numbers = true)]
    Sculling(experiments::TwoAxisArgs),
    /// Fig. 3.2's waveforms (torquer current, pulse train, pendulum angle) tick by tick,
    /// the closed loop's frequency response and the limit cycle across the range.
    #[command(allow_negative_numbers = true)]
    Waveform(experiments::WaveformArgs),
    /// The plain closed loop with a constant acceleration along IA (Table 2.1 instrument
    /// with its pickoff noise; the measured bias A_b only with --with-bias): after the
    /// settling time, one gate; prints P, T and SF·(2P/T − 1) with the configured SF.
    /// Several accelerations run as one batch (the batch engine: each result bit for bit
    /// that of its own run), one table row or JSON object each.
    #[command(allow_negative_numbers = true)]
    Static(StaticArgs),
    /// Print the compensator designed for the instrument file, the loop's margins, and the
    /// ptsa-core constants.
    Design(DesignArgs),
    /// Monte Carlo over the Table 2.1 tolerance box: stability margins at every corner and
    /// a closed-loop check of the worst ones.
    MonteCarlo(experiments::MonteCarloArgs),
    /// Speed of the closed loop: ticks per second of `static` on one core, median of runs.
    /// With --batch N: the single loop against the batch engine on N static conditions.
    Bench(BenchArgs),
    /// The whole report programme (the same as no subcommand).
    Report(ReportArgs),
    /// What the instrument should read in each row of a case-frame file, with the baseline
    /// model or with a discover result's effects put back into the closed loop.
    Predict(PredictArgs),
    /// Write a ready-to-run case-frame design: a tumble, a rate table, the shaker or a
    /// centrifuge (the measured column left empty for the lab).
    Plan(PlanArgs),
    /// Discovery: what the simulation gets wrong in measured data, the effect that explains
    /// it, and the gain of the extended model.
    Discover(DiscoverArgs),
    /// Reduce a counter record taken under a sine along IA to one case-frame response row:
    /// gain and phase with their 1-sigma uncertainties, by a least-squares sine fit.
    ///
    /// The record is a CSV `time_s,pulses,ticks`, one line per short gate (the gate's start
    /// in s, the data pulses P and the clock ticks T counted in it, as a counter or the
    /// firmware's gate reports give them). Each gate indicates SF·(2P/T − 1) cm/s² with the
    /// instrument file's SF; a sine at --sine-hz is fitted to these values (corrected for the
    /// averaging over each gate, whose length is T over the file's clock_hz).
    ///
    /// Gain: the output's amplitude over --sine-cm-s2, dimensionless (cm/s² indicated
    /// per cm/s² of input; 1 = the loop follows the input). Phase: the output's phase minus
    /// the input's, in degrees from −180 to 180; an output that lags the input has a
    /// negative phase. The input is taken as A·sin(2πF·t + --input-phase-deg) on the
    /// record's time_s.
    ///
    /// Prints the row as case-frame CSV with its header (docs/reference/case-frame-format.md: label, kind,
    /// freq_hz, lin_ia_cm_s2, measured_gain, measured_phase_deg, sigma_gain,
    /// sigma_phase_deg), ready to append to a data file for `ptsa discover`, or with --json
    /// one JSON object; the fit's summary goes to stderr. Writes a plot of the gates and the
    /// fitted sine, with the residuals below, into --out as STEM-response.png and .svg
    /// (STEM: the record's file name without its extension).
    #[command(allow_negative_numbers = true)]
    Response(ResponseArgs),
    /// Turn the firmware's log into a counter record for `ptsa response`: the gate reports
    /// of probe-rs run's defmt output, QEMU's semihosting lines or a saved copy.
    ///
    /// A report is a line holding `gate [axis=K] seq=N P=N T=N gates=N tick=N` (anything
    /// before it, such as probe-rs's timestamp and level, and fields after it are
    /// ignored; so are all other lines): seq the number of its last gate, P data pulses, T
    /// clock ticks, gates how many gates the firmware merged into it, tick the clock ticks
    /// from the loop's start to its close. The reports' numbers are checked: a gap (reports
    /// lost on the way) is refused unless --allow-gaps, a restart (board reset, logs
    /// joined) always; merged gates are written as one longer gate, with a warning. A last
    /// line cut short by the log's end is dropped, with a warning.
    ///
    /// Writes CSV `time_s,pulses,ticks` with a `#` comment naming the source: time_s the
    /// gate's start, (tick − T) over the instrument file's clock_hz, in s. To standard
    /// output, or to --out (written whole or not at all). A summary goes to stderr.
    Record(RecordArgs),
    /// Apply a calibration to a record of readings or counts: per row, the specific force
    /// along IA that gives the reading, with its 1-sigma uncertainty, cm/s².
    ///
    /// The calibration is a `ptsa discover --json` result (--calibration; made with the
    /// same --instrument file) or an instrument file of the instrument's calibrated values
    /// (--instrument alone). Each absolute, static row's reading (measured_cm_s2, or pulses
    /// and ticks read as SF·(2P/T − 1) cm/s² with the file's nominal SF) is inverted
    /// through the static model equation for a_IA with the row's cross-axis inputs
    /// (g_pa, g_oa, in g) held. The uncertainty is the reading's noise (sigma_cm_s2 or
    /// --sigma, the counting error of counts, the fixture's sigma_angle_urad) and the
    /// calibration's covariance (its terms' standard errors and correlation), each divided
    /// by the model's slope; terms the calibration did not select carry no uncertainty
    /// (docs/method/discovery.md, `ptsa correct`).
    ///
    /// Prints CSV (label, reading_cm_s2, sigma_reading_cm_s2, a_pa_cm_s2, a_oa_cm_s2,
    /// a_ia_cm_s2, a_ia_g, sigma_a_ia_cm_s2, sigma_noise_cm_s2, sigma_calibration_cm_s2:
    /// cm/s², a_ia_g in g), or one JSON object with --json.
    Correct(CorrectArgs),
    /// Noise of a static record, of any instrument or of the simulated loop at rest: the
    /// overlapping and modified Allan deviations and the overlapping Hadamard deviation
    /// (cm/s²) at the averaging times asked for, with intervals, and the noise terms read
    /// from their slopes.
    ///
    /// --readings FILE reads any instrument's record `time_s,reading` (one sample per row,
    /// evenly spaced; the reading in --unit). --counts FILE reads a PTSA counter record
    /// `time_s,pulses,ticks` (as for `ptsa response`) of gates back to back; each gate
    /// indicates SF·(2P/T − 1) cm/s² with the instrument file's nominal SF. --simulate
    /// --seconds N runs the instrument file's closed loop at rest (its bias and pickoff noise
    /// included) and analyses its record the same way (--output FILE keeps the record).
    ///
    /// The intervals are chi-squared intervals with Greenhall's equivalent degrees of
    /// freedom (as Stable32 and allantools compute them) for every deviation, at 95 % and at
    /// --confidence; the noise type at each tau is identified by the lag-1 autocorrelation
    /// (Riley and Greenhall). The terms (IEEE Std 952: quantization Q, slope −1; velocity
    /// random walk N, −1/2; bias instability B, 0; acceleration random walk K, +1/2; for
    /// readings also the rate ramp R, +1) come from a weighted fit of the variance curve, in
    /// cgs and in µg, µg/√Hz, (m/s)/√h, (m/s)/h^1.5, (m/s)/h², with 1-sigma uncertainties
    /// (docs/method/noise.md). Prints a table, or one JSON object with --json; --plot FILE writes the
    /// log–log plot as PNG and SVG.
    #[command(allow_negative_numbers = true)]
    Noise(NoiseArgs),
    /// Instrument files: `instrument new --class CLASS --output FILE` writes a commented
    /// template (kearfott-2401, navigation, mems).
    Instrument(InstrumentArgs),
}

/// Options of every simulated run.
#[derive(Args, Debug, Clone, Copy)]
pub struct RunArgs {
    /// Seed of the pickoff noise (the instrument file's `noise_uv_rms`): a whole number
    /// from 0 to 2^64 − 1, no unit.
    #[arg(long, default_value_t = SimOptions::default().seed, value_name = "N",
          value_parser = seed)]
    pub seed: u64,
    /// Settling time before each measurement, s (0 or more).
    #[arg(long, default_value_t = SimOptions::default().warmup_s, value_name = "S",
          value_parser = non_negative_s)]
    pub warmup_s: f64,
    /// Shortest measurement window, s (more than 0; whole limit cycles, or whole periods of a
    /// condition's oscillation).
    #[arg(long, default_value_t = SimOptions::default().min_window_s, value_name = "S",
          value_parser = positive_s)]
    pub window_s: f64,
    /// The old spelling of --no-limit, accepted until the next release.
    #[arg(long, hide = true)]
    pub force: bool,
    #[command(flatten)]
    pub limit: LimitArg,
}

impl RunArgs {
    /// The run options, with the loop's compensator `config`.
    pub fn options(&self, config: ptsa_core::Config) -> SimOptions {
        SimOptions {
            seed: self.seed,
            warmup_s: self.warmup_s,
            min_window_s: self.window_s,
            config,
            ..SimOptions::default()
        }
    }
}

/// Options of a run without measurement windows of its own (`waveform`: its trace is a
/// number of limit cycles, its frequency response and limit-cycle sweep use 1 s windows).
#[derive(Args, Debug, Clone, Copy)]
pub struct SettleArgs {
    /// Seed of the pickoff noise (the instrument file's `noise_uv_rms`): a whole number
    /// from 0 to 2^64 − 1, no unit.
    #[arg(long, default_value_t = SimOptions::default().seed, value_name = "N",
          value_parser = seed)]
    pub seed: u64,
    /// Settling time before the trace and before each window, s (0 or more).
    #[arg(long, default_value_t = SimOptions::default().warmup_s, value_name = "S",
          value_parser = non_negative_s)]
    pub warmup_s: f64,
    /// The old spelling of --no-limit, accepted until the next release.
    #[arg(long, hide = true)]
    pub force: bool,
    #[command(flatten)]
    pub limit: LimitArg,
}

impl SettleArgs {
    /// The run options, with the loop's compensator `config`.
    pub fn options(&self, config: ptsa_core::Config) -> SimOptions {
        SimOptions {
            seed: self.seed,
            warmup_s: self.warmup_s,
            config,
            ..SimOptions::default()
        }
    }
}

/// Work beyond the limit, for a command that estimates its work before it runs. Read in
/// [`parse`], which hands it to `work::set_no_limit`.
#[derive(Args, Debug, Clone, Copy)]
pub struct LimitArg {
    /// Run work estimated beyond about ten minutes on this machine (the environment
    /// variable PTSA_LIMIT_S, in s, sets another limit); without it such work is refused
    /// before it starts, with its estimate.
    #[arg(long)]
    #[allow(dead_code, reason = "read from the matches in `parse`")]
    pub no_limit: bool,
}

/// Where files go.
#[derive(Args, Debug, Clone)]
pub struct OutArgs {
    /// Folder for the tables (CSV) and plots (PNG, SVG); kept apart from the report
    /// programme's folder so that neither overwrites the other.
    #[arg(long, default_value = "out", value_name = "DIR")]
    pub out: PathBuf,
}

/// The command line, with two refusals clap cannot express: a report option before a
/// subcommand (`ptsa --window-s 5 tumble`, which would be ignored) and, made possible, a
/// negative number clap takes for short flags (`-1e-5`, `-.5`: see [`join_negative_numbers`]).
/// A refusal exits here, with clap's usage and status 2.
pub fn parse() -> Cli {
    let mut cmd = Cli::command();
    let matches = cmd
        .try_get_matches_from_mut(join_negative_numbers(&Cli::command(), std::env::args_os()))
        .unwrap_or_else(|e| e.exit());
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.format(&mut cmd).exit());
    for w in old_spellings(&cmd, &matches, &std::env::args_os().collect::<Vec<_>>()) {
        eprintln!("warning: {w}");
    }
    crate::work::set_no_limit(flag_of_subcommand(&matches, "no_limit"));
    if let Some(sub) = matches.subcommand_name() {
        for (id, flag) in [
            ("seed", "--seed"),
            ("warmup_s", "--warmup-s"),
            ("window_s", "--window-s"),
            ("force", "--force"),
            ("no_limit", "--no-limit"),
            ("out", "--out"),
        ] {
            if matches.value_source(id) == Some(ValueSource::CommandLine) {
                cmd.error(
                    ErrorKind::ArgumentConflict,
                    format!(
                        "{flag} before the subcommand `{sub}` is an option of the report programme (no subcommand) and would be ignored; expected it after the subcommand, if `{sub}` has it (`ptsa {sub} --help`)"
                    ),
                )
                .exit();
            }
        }
    }
    cli
}

/// The on/off flag `id` of the subcommand that runs (the deepest one matched; the report
/// programme's own without one); off when that command has no such flag.
fn flag_of_subcommand(matches: &clap::ArgMatches, id: &str) -> bool {
    let mut m = matches;
    while let Some((_, sub)) = m.subcommand() {
        m = sub;
    }
    m.try_get_one::<bool>(id)
        .ok()
        .flatten()
        .copied()
        .unwrap_or(false)
}

/// One line for each old spelling of an option (a hidden alias, kept for one release) that
/// `args` use in the subcommand `matches` ran, naming the spelling that replaces it.
fn old_spellings(
    cmd: &clap::Command,
    matches: &clap::ArgMatches,
    args: &[OsString],
) -> Vec<String> {
    let (mut c, mut m) = (cmd, matches);
    while let Some((name, sub)) = m.subcommand() {
        match c.find_subcommand(name) {
            Some(next) => (c, m) = (next, sub),
            None => break,
        }
    }
    let mut out = Vec::new();
    for a in c.get_arguments() {
        let (Some(long), Some(all)) = (a.get_long(), a.get_all_aliases()) else {
            continue;
        };
        let visible = a.get_visible_aliases().unwrap_or_default();
        for old in all.into_iter().filter(|x| !visible.contains(x)) {
            let flag = format!("--{old}");
            let used = args
                .iter()
                .filter_map(|x| x.to_str())
                .any(|x| x == flag || x.strip_prefix(&flag).is_some_and(|r| r.starts_with('=')));
            if used {
                let why = if old == "out" {
                    " (--out names a folder in every command)"
                } else {
                    ""
                };
                out.push(format!(
                    "{flag} is spelled --{long} now{why}; the old spelling is accepted until the next release"
                ));
            }
        }
    }
    out
}

/// The arguments with the negative numbers clap would take for short flags made readable
/// to it. Clap reads a value starting with `-` as a value only when it looks like an integer
/// or a plain decimal (`-5`, `-0.5`), and takes `-1e-5`, `-.5` or `-inf` for a cluster of
/// short flags ("unexpected argument '-1'"). Such a number right after a long option that
/// takes one value is joined to it (`--k-ip-s2-cm=-1e-5`); elsewhere (the second value of
/// `--lever-cm`) a finite one is written as the plain decimal of the same number. The
/// command has no positional arguments, so every number is an option's value; a long
/// option that takes no value then says so. A comma-separated list of numbers starting with a
/// negative one is joined to its option in the same way.
fn join_negative_numbers(
    cmd: &clap::Command,
    args: impl Iterator<Item = OsString>,
) -> Vec<OsString> {
    let mut multi = Vec::new();
    for c in std::iter::once(cmd).chain(cmd.get_subcommands()) {
        for a in c.get_arguments() {
            if a.get_num_args().is_some_and(|r| r.max_values() > 1)
                && let Some(l) = a.get_long()
            {
                multi.push(format!("--{l}"));
            }
        }
    }
    let mut out: Vec<OsString> = Vec::new();
    for a in args {
        let Some(s) = a.to_str() else {
            out.push(a);
            continue;
        };
        // A list of numbers, the first negative (`--accel-cm-s2 -1e3,0,1e3`; an empty item is
        // kept for the option's own refusal): joined to its option like one number.
        let list = s.starts_with('-')
            && s.contains(',')
            && s.split(',')
                .all(|p| p.trim().is_empty() || p.trim().parse::<f64>().is_ok());
        let plain = s.len() > 1
            && s.starts_with('-')
            && s[1..].bytes().all(|b| b.is_ascii_digit() || b == b'.')
            && s.as_bytes()[1] != b'.';
        let x = match s.parse::<f64>() {
            Ok(x) if s.starts_with('-') && !plain => x,
            _ if list => f64::NAN,
            _ => {
                out.push(a);
                continue;
            }
        };
        if let Some(prev) = out.last_mut()
            && let Some(p) = prev.to_str()
            && p.starts_with("--")
            && p.len() > 2
            && !p.contains('=')
            && !multi.iter().any(|m| m == p)
        {
            let joined = format!("{p}={s}");
            *prev = joined.into();
        } else if x.is_finite() && !list {
            out.push(format!("{x}").into());
        } else {
            out.push(a);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unit a numeric option's help must name, by its value name; `None` for a value
    /// that is not a number (a path, a list of names, a text).
    fn unit_of(value_name: &str) -> Option<&'static [&'static str]> {
        Some(match value_name {
            "FILE" | "FILE.json" | "FILE|-" | "DIR" | "LIST" | "TEXT" | "oa|pa" | "UNIT" => {
                return None;
            }
            "SPEC" => &["in s"],
            "FRACTION" => &["fraction"],
            "FACTOR" => &["a factor, no unit"],
            "P" => &["confidence level"],
            "S" => &[", s"],
            "HZ" => &["Hz"],
            "CM_S2" => &["cm/s²"],
            "MRAD" => &["mrad"],
            "G_CM2" => &["g·cm²"],
            "CM" | "IA_CM" => &[", cm"],
            "RAD_S" => &["rad/s"],
            "S2_CM" => &["s²/cm"],
            "S2" => &[", s²"],
            "DEG" => &["degrees"],
            "PPM" => &["ppm"],
            "DB" => &["dB"],
            "G" => &["in g"],
            // A count: of what, or that it has none (a seed).
            "N" | "K" => &[
                "no unit",
                "ticks",
                "Runs",
                "conditions",
                "loops",
                "corners",
                "ositions",
                "Phases",
                "cycles",
            ],
            other => panic!("value name {other}: add it and its unit to `unit_of`"),
        })
    }

    /// Every option of every subcommand that takes a number says its unit in `--help` (a
    /// count says what it counts, a seed that it has no unit); an option with a new value
    /// name fails until its unit is added here.
    #[test]
    fn every_numeric_option_names_its_unit() {
        fn walk(cmd: &clap::Command, path: &str, checked: &mut usize) {
            for a in cmd.get_arguments() {
                if !a.get_action().takes_values() || !a.get_possible_values().is_empty() {
                    continue;
                }
                let name = a.get_value_names().and_then(|v| v.first()).map_or_else(
                    || a.get_id().to_string().to_uppercase(),
                    ToString::to_string,
                );
                let Some(units) = unit_of(&name) else {
                    continue;
                };
                let help = a
                    .get_long_help()
                    .or_else(|| a.get_help())
                    .map(ToString::to_string)
                    .unwrap_or_default();
                assert!(
                    units.iter().any(|u| help.contains(u)),
                    "ptsa {path} --{}: its help names none of {units:?}: {help}",
                    a.get_id()
                );
                *checked += 1;
            }
            for s in cmd.get_subcommands() {
                walk(s, &format!("{path} {}", s.get_name()), checked);
            }
        }
        let mut checked = 0;
        walk(&Cli::command(), "", &mut checked);
        assert!(checked > 50, "{checked} numeric options checked");
    }
}
