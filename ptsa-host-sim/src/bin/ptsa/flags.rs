//! The command line: clap types only (they never leave the binary), and the value parsers
//! that refuse nonsense before anything runs. Units are in every option's name and help.
// The doc comments here are clap's `--help` text, printed as plain text: backticks around
// column names and symbols (time_s, A_b, θ_my) would show up in the help verbatim.
#![allow(clippy::doc_markdown, reason = "clap help text, not rustdoc")]
#![allow(
    clippy::struct_excessive_bools,
    reason = "each bool is a command-line switch of its own"
)]

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};
use ptsa_host_sim::lab::plan::Axis;
use ptsa_host_sim::model::effects::{CandidateId, candidate_names, resolve_candidates};
use ptsa_host_sim::report::experiments::{appendix_a::TwoAxisPlan, tumble, waveform};
use ptsa_host_sim::simulation::sim::SimOptions;

/// Closed-loop simulator of the Kearfott 2401 accelerometer in the UAC PTSA forced-binary
/// loop (Draper report R-890), built on ptsa-core, the firmware's own loop code.
///
/// Without a subcommand, runs the report's whole test programme on the instrument file and
/// writes a report folder (tables as CSV, plots as PNG and SVG, summary.md), which appears
/// whole or not at all. Units: cm/s² for accelerations, rad/s for rates, mrad for
/// oscillation amplitudes, g·cm² for inertias, Hz, seconds.
#[derive(Parser, Debug)]
// The report's own options (`--out`, `--seed`, ...) before a subcommand would do nothing:
// `main` refuses them there (clap's `args_conflicts_with_subcommands` would refuse the
// global `--instrument` as well).
#[command(
    name = "ptsa",
    version,
    about,
    long_about,
    allow_negative_numbers = true
)]
pub struct Cli {
    /// Instrument file (TOML: Table 2.1 with tolerances and the PTSA electronics; see
    /// data/kearfott-2401.toml). Default: the shipped Kearfott 2401 file, compiled in.
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

/// Options of every simulated run.
#[derive(Args, Debug, Clone, Copy)]
pub struct RunArgs {
    /// Seed of the pickoff noise (the instrument file's `noise_uv_rms`).
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
    /// Run even when the work is estimated to take more than ten minutes.
    #[arg(long)]
    pub force: bool,
}

impl RunArgs {
    /// The run options.
    pub fn options(&self) -> SimOptions {
        SimOptions {
            seed: self.seed,
            warmup_s: self.warmup_s,
            min_window_s: self.window_s,
            ..SimOptions::default()
        }
    }
}

/// Options of a run without measurement windows of its own (`waveform`: its trace is a
/// number of limit cycles, its frequency response and limit-cycle sweep use 1 s windows).
#[derive(Args, Debug, Clone, Copy)]
pub struct SettleArgs {
    /// Seed of the pickoff noise (the instrument file's `noise_uv_rms`).
    #[arg(long, default_value_t = SimOptions::default().seed, value_name = "N",
          value_parser = seed)]
    pub seed: u64,
    /// Settling time before the trace and before each window, s (0 or more).
    #[arg(long, default_value_t = SimOptions::default().warmup_s, value_name = "S",
          value_parser = non_negative_s)]
    pub warmup_s: f64,
    /// Run even when the work is estimated to take more than ten minutes.
    #[arg(long)]
    pub force: bool,
}

impl SettleArgs {
    /// The run options.
    pub fn options(&self) -> SimOptions {
        SimOptions {
            seed: self.seed,
            warmup_s: self.warmup_s,
            ..SimOptions::default()
        }
    }
}

/// Where files go.
#[derive(Args, Debug, Clone)]
pub struct OutArgs {
    /// Folder for the tables (CSV) and plots (PNG, SVG); kept apart from the report
    /// programme's folder so that neither overwrites the other.
    #[arg(long, default_value = "out", value_name = "DIR")]
    pub out: PathBuf,
}

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

/// The subcommands.
#[derive(Subcommand, Debug)]
pub enum Cmd {
    /// Section 6.1: ±1 g counts P1, P2 over a gate T; SF and A_b by eqs. 6.3/6.4; and IA
    /// through 360°.
    #[command(allow_negative_numbers = true)]
    Tumble {
        /// Counting gate, s (at least one limit cycle, 0.001 s for the shipped file, and at
        /// most what the core's 32-bit counters hold, 67 108 s; rounded to whole limit cycles).
        #[arg(long, default_value_t = tumble::DEFAULT_GATE_S, value_name = "S",
              value_parser = positive_s)]
        gate_s: f64,
        #[command(flatten)]
        run: RunArgs,
        #[command(flatten)]
        out: OutArgs,
    },
    /// Table 6.1: 8 IA positions on the rate table at 1.0 and 0.05 rad/s (eq. 6.5).
    #[command(allow_negative_numbers = true)]
    Anisoinertia {
        /// Anisoinertia I_PA − I_IA of the simulated instrument, g·cm² (report: 3.4;
        /// |value| below 100, the instrument file's range).
        #[arg(long, default_value_t = 3.4, value_name = "G_CM2",
              value_parser = anisoinertia_g_cm2)]
        anisoinertia_g_cm2: f64,
        /// Offset of the proof mass from the table axis along PA, cm (0 in the report's
        /// revised set-up; |value| up to 100).
        #[arg(long, default_value_t = 0.0, value_name = "CM", value_parser = lever_cm)]
        lever_pa_cm: f64,
        #[command(flatten)]
        run: RunArgs,
        #[command(flatten)]
        out: OutArgs,
    },
    /// Tables 6.2/6.3: angular oscillation about OA, IA horizontal and vertical.
    #[command(allow_negative_numbers = true)]
    OaCoupling {
        /// Offset of the proof mass from the table axis along IA, PA, OA, cm (three values,
        /// each |value| up to 100).
        #[arg(long, num_args = 3, default_values_t = [0.0, 0.0, 0.0],
              value_names = ["IA_CM", "PA_CM", "OA_CM"], value_parser = lever_cm)]
        lever_cm: Vec<f64>,
        #[command(flatten)]
        run: RunArgs,
        #[command(flatten)]
        out: OutArgs,
    },
    /// Appendix A.1 (Fig. A.2): IA and PA vibration on the two-axis oscillator, phase sweep.
    #[command(allow_negative_numbers = true)]
    Vibropendulosity(TwoAxisArgs),
    /// Appendix A.2 (Fig. A.4): IA and OA vibration, phase sweep.
    #[command(allow_negative_numbers = true)]
    Anisoelasticity(TwoAxisArgs),
    /// Appendix A.3 (Fig. A.5): OA angular oscillation with PA vibration, phase sweep.
    #[command(allow_negative_numbers = true)]
    Sculling(TwoAxisArgs),
    /// Fig. 3.2's waveforms (torquer current, pulse train, pendulum angle) tick by tick,
    /// the closed loop's frequency response and the limit cycle across the range.
    #[command(allow_negative_numbers = true)]
    Waveform {
        /// Constant acceleration along IA, cm/s² (beyond the loop's full scale the loop
        /// saturates; a warning says so).
        #[arg(long, default_value_t = waveform::DEFAULT_ACCEL_CM_S2, value_name = "CM_S2",
              value_parser = finite)]
        accel_cm_s2: f64,
        /// Limit cycles to trace (1 to 10 000; the CSV has one row per clock tick; more
        /// with --force).
        #[arg(long, default_value_t = waveform::DEFAULT_CYCLES, value_name = "N",
              value_parser = cycles)]
        cycles: u64,
        #[command(flatten)]
        run: SettleArgs,
        #[command(flatten)]
        out: OutArgs,
    },
    /// The plain closed loop with a constant acceleration along IA (Table 2.1 instrument
    /// with its pickoff noise; the measured bias A_b only with --with-bias): after the
    /// settling time, one gate; prints P, T and SF·(2P/T − 1) with the configured SF.
    /// Several accelerations run as one batch (the batch engine: each result bit for bit
    /// that of its own run), one table row or JSON object each.
    #[command(allow_negative_numbers = true)]
    Static {
        /// Acceleration along IA, cm/s² (beyond full scale the loop saturates: the output
        /// says so). Several, comma separated (`-1000,0,1000`), run as one batch, each with
        /// the same gate, settling and seed.
        #[arg(long, value_name = "CM_S2", value_delimiter = ',', required = true,
              value_parser = accel_item)]
        accel_cm_s2: Vec<f64>,
        /// Gate length, s (at least one limit cycle, 64 ticks = 0.001 s at 64 kHz, and at
        /// most what the core's 32-bit counters hold, 67 108 s at 64 kHz).
        #[arg(long, default_value_t = 1.0, value_name = "S", value_parser = positive_s)]
        seconds: f64,
        /// Settling time before the gate, s (0 or more).
        #[arg(long, default_value_t = SimOptions::default().warmup_s, value_name = "S",
              value_parser = non_negative_s)]
        warmup_s: f64,
        /// Seed of the pickoff noise (the instrument file's `noise_uv_rms`).
        #[arg(long, default_value_t = SimOptions::default().seed, value_name = "N",
              value_parser = seed)]
        seed: u64,
        /// Include the instrument file's bias A_b (18.7 cm/s² shipped) as a torque.
        #[arg(long)]
        with_bias: bool,
        /// Print exactly one JSON object {"ticks", "pulses", "indicated_cm_s2",
        /// "saturated"}; with several accelerations, one JSON array of such objects, in the
        /// order given.
        #[arg(long)]
        json: bool,
        /// Write the ADC samples of this very run, settling included (one i16 per line,
        /// golden-vector style) to FILE (one acceleration only).
        #[arg(long, value_name = "FILE")]
        trace: Option<PathBuf>,
        /// Run even when the work is estimated to take more than ten minutes.
        #[arg(long)]
        force: bool,
    },
    /// Print the compensator designed for the instrument file, the loop's margins, and the
    /// ptsa-core constants.
    Design {
        /// Print only the four DEFAULT_*_BITS constants of ptsa-core/src/config.rs.
        #[arg(long)]
        print_core_constants: bool,
    },
    /// Monte Carlo over the Table 2.1 tolerance box: stability margins at every corner and
    /// a closed-loop check of the worst ones.
    MonteCarlo {
        /// Random corners when the box has more than 14 parameters (1 to 100 000; default
        /// 1024). With 14 or fewer (12 in the shipped file) every corner is checked and this
        /// option is not used.
        #[arg(long, value_name = "N", value_parser = count)]
        samples: Option<usize>,
        #[command(flatten)]
        run: RunArgs,
        #[command(flatten)]
        out: OutArgs,
    },
    /// Speed of the closed loop: ticks per second of `static` on one core, median of runs.
    /// With --batch N: the single loop against the batch engine on N static conditions.
    Bench {
        /// Ticks per run (1 to 4 294 967 295, what the core's 32-bit counters hold; default
        /// 64 000 000). With --batch N: ticks per condition (default 64 000 000 / N, a run
        /// as long as without --batch).
        #[arg(long, value_name = "N", value_parser = ticks)]
        ticks: Option<u64>,
        /// Runs (1 to 1000).
        #[arg(long, default_value_t = ptsa_host_sim::bench::BenchPlan::RUNS, value_name = "N",
              value_parser = runs)]
        runs: usize,
        /// Without pickoff noise.
        #[arg(long)]
        no_noise: bool,
        /// Also build the plain C loop (ptsa-host-sim/benches/c_static/static_loop.c) with
        /// the system C compiler (`$CC`, default `cc`, `-std=c11 -O2`), check that it gives
        /// the same pulses and plant state bit for bit, and time it in alternation.
        #[arg(long)]
        compare_c: bool,
        /// Instead: N static conditions (1 to 64, spread over ±0.9 of full scale) run one
        /// after the other with the single loop and as one batch of the batch engine on one
        /// thread; prints both rates in Mticks/s (all conditions' ticks, settling included,
        /// per second of one core) and their ratio, medians of --runs, after checking that
        /// both give the same pulses.
        #[arg(long, value_name = "N", value_parser = batch_conditions,
              conflicts_with = "compare_c")]
        batch: Option<usize>,
        /// With --batch: loops interleaved tick by tick per core in the batch (1, 2, 4, 8 or
        /// 16; 1, the engine's default, runs them one after the other, block by block).
        #[arg(long, default_value_t = ptsa_host_sim::simulation::batch::LANES, value_name = "K",
              value_parser = lanes, requires = "batch")]
        lanes: usize,
        /// Seed of the pickoff noise (the instrument file's `noise_uv_rms`).
        #[arg(long, default_value_t = SimOptions::default().seed, value_name = "N",
              value_parser = seed)]
        seed: u64,
        /// Run even when the work is estimated to take more than ten minutes.
        #[arg(long)]
        force: bool,
    },
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
    /// instrument file's SF; a sine at --freq-hz is fitted to these values (corrected for the
    /// averaging over each gate, whose length is T over the file's clock_hz).
    ///
    /// Gain: the output's amplitude over --amplitude-cm-s2, dimensionless (cm/s² indicated
    /// per cm/s² of input; 1 = the loop follows the input). Phase: the output's phase minus
    /// the input's, in degrees from −180 to 180; an output that lags the input has a
    /// negative phase. The input is taken as A·sin(2πF·t + --input-phase-deg) on the
    /// record's time_s.
    ///
    /// Prints the row as case-frame CSV with its header (docs/case-frame.md: label, kind,
    /// freq_hz, lin_ia_cm_s2, measured_gain, measured_phase_deg, sigma_gain,
    /// sigma_phase_deg), ready to append to a data file for `ptsa discover`, or with --json
    /// one JSON object; the fit's summary goes to stderr. Writes a plot of the gates and the
    /// fitted sine, with the residuals below, into --out as STEM-response.png and .svg
    /// (STEM: the record's file name without its extension).
    #[command(allow_negative_numbers = true)]
    Response(ResponseArgs),
}

/// Arguments of `ptsa response`.
#[derive(Args, Debug, Clone)]
pub struct ResponseArgs {
    /// Counter record: CSV `time_s,pulses,ticks` with that header, one line per gate (start
    /// in s, data pulses, clock ticks); gates of equal length, times increasing, at least 4
    /// gates; `#` lines are comments.
    #[arg(long, value_name = "FILE")]
    pub counts: PathBuf,
    /// Frequency of the input sine, Hz (more than 0, below the Nyquist frequency of the
    /// record: half its gate rate).
    #[arg(long, value_name = "HZ", value_parser = positive_hz)]
    pub freq_hz: f64,
    /// Amplitude of the input sine along IA, cm/s² (more than 0).
    #[arg(long, value_name = "CM_S2", value_parser = input_amplitude_cm_s2)]
    pub amplitude_cm_s2: f64,
    /// Phase of the input sine at time_s = 0, degrees: the input is
    /// A·sin(2πF·time_s + phase).
    #[arg(long, default_value_t = 0.0, value_name = "DEG", value_parser = finite)]
    pub input_phase_deg: f64,
    /// The row's label (default: the frequency and the record's file name).
    #[arg(long, value_name = "TEXT", value_parser = label)]
    pub label: Option<String>,
    /// Print exactly one JSON object: the row's columns {"label", "kind", "freq_hz",
    /// "lin_ia_cm_s2", "measured_gain", "measured_phase_deg", "sigma_gain",
    /// "sigma_phase_deg"}, the fit's "gates", "gate_s", "mean_cm_s2" and "rms_cm_s2", the
    /// check's "expected_rms_cm_s2" (what counting leaves, cm/s²), "predicted_gain" and
    /// "predicted_phase_deg" (the instrument file's loop; null if it has none) and
    /// "warnings" (a list of the warnings' texts, empty if none).
    #[arg(long)]
    pub json: bool,
    /// Write the row even when the fit makes no physical sense: a gain above 2 (no loop the
    /// simulator accepts gets there) or an uncertainty larger than the gain (no sine at
    /// --freq-hz); refused without it, naming the likely slip (an amplitude in g, another
    /// frequency).
    #[arg(long)]
    pub force: bool,
    #[command(flatten)]
    pub out: OutArgs,
}

/// Options of the Appendix A set-ups.
#[derive(Args, Debug, Clone)]
pub struct TwoAxisArgs {
    /// Oscillation frequency, Hz (more than 0, at most half the limit-cycle frequency: 500 Hz
    /// for the shipped file).
    #[arg(long, default_value_t = TwoAxisPlan::FREQ_HZ, value_name = "HZ",
          value_parser = positive_hz)]
    pub freq_hz: f64,
    /// Y-axis amplitude θ_my, mrad (0 to 100: the model is small-angle).
    #[arg(long, default_value_t = TwoAxisPlan::THETA_MRAD, value_name = "MRAD",
          value_parser = amplitude_mrad)]
    pub theta_my_mrad: f64,
    /// Z-axis amplitude θ_mz, mrad (0 to 100).
    #[arg(long, default_value_t = TwoAxisPlan::THETA_MRAD, value_name = "MRAD",
          value_parser = amplitude_mrad)]
    pub theta_mz_mrad: f64,
    /// Radius of the proof mass from the oscillator axes, cm (0 to 100).
    #[arg(long, default_value_t = TwoAxisPlan::R_CM, value_name = "CM", value_parser = radius_cm)]
    pub r_cm: f64,
    /// Injected anisoelastic coefficient k_io, s²/cm (the model has none by itself).
    #[arg(long, default_value_t = 0.0, value_name = "S2_CM", value_parser = finite)]
    pub k_io_s2_cm: f64,
    /// Injected vibropendulous coefficient k_ip, s²/cm.
    #[arg(long, default_value_t = 0.0, value_name = "S2_CM", value_parser = finite)]
    pub k_ip_s2_cm: f64,
    /// Injected sculling coefficient k_sc, s².
    #[arg(long, default_value_t = 0.0, value_name = "S2", value_parser = finite)]
    pub k_sc_s2: f64,
    #[command(flatten)]
    pub run: RunArgs,
    #[command(flatten)]
    pub out: OutArgs,
}

/// Arguments of `ptsa discover`.
#[derive(Args, Debug, Clone)]
#[command(allow_negative_numbers = true)]
pub struct DiscoverArgs {
    /// Case-frame CSV file of measured conditions (docs/case-frame.md). Without it, the
    /// report's Tables 6.1, 6.2 and 6.3 are analysed.
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
    /// Print exactly one JSON object on stdout (the text report goes to stderr). Without
    /// --data, the object maps each report table's file name to its result.
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
    /// Seed of the simulator's pickoff noise (closed loop; not used with --analytic).
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
    /// when no parameter is selected.
    #[arg(long, value_name = "FILE", requires = "data")]
    pub write_instrument: Option<PathBuf>,
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
    /// Regenerate the report's case-frame files (`r890-table-6.*.case.csv`) into DIR and exit.
    #[arg(long, value_name = "DIR")]
    pub convert_report_data: Option<PathBuf>,
    /// Replace an existing --advice-out or --write-instrument file (never an input of the
    /// run), and run even when the work is estimated to take more than ten minutes (before
    /// it starts, or, when a parameter of the loop is selected, before the closed-loop
    /// search of the other parameters).
    #[arg(long)]
    pub force: bool,
}

/// Arguments of `ptsa predict`.
#[derive(Args, Debug, Clone)]
pub struct PredictArgs {
    /// Case-frame CSV file (docs/case-frame.md): the conditions to predict (a
    /// `measured_cm_s2` column, if any, is shown beside the prediction).
    #[arg(long, value_name = "FILE")]
    pub data: PathBuf,
    /// The effects to put into the plant: the JSON of `ptsa discover --json` (or its
    /// `effects` array). Without it, the baseline model.
    #[arg(long, value_name = "FILE.json")]
    pub effects: Option<PathBuf>,
    /// Print exactly one JSON object {"rows": [{"label", "predicted_cm_s2"}]} (a response
    /// row: `predicted_cm_s2` null, and `predicted_gain`, `predicted_phase_deg`).
    #[arg(long)]
    pub json: bool,
    /// Seed of the simulator's pickoff noise (closed loop).
    #[arg(long, default_value_t = SimOptions::default().seed, value_name = "N",
          value_parser = seed)]
    pub seed: u64,
    /// Use the quasi-static analytic model instead of the closed loop.
    #[arg(long)]
    pub analytic: bool,
    /// Run even when the work is estimated to take more than ten minutes.
    #[arg(long)]
    pub force: bool,
}

/// What `ptsa plan` writes.
#[derive(Subcommand, Debug, Clone)]
pub enum PlanKind {
    /// A multipoint tumble on a dividing head (IEEE Std 1293: 4, 8, 12 or 24 positions, or
    /// any number): absolute rows, IA at equally spaced angles in the plane of --axis.
    Tumble {
        /// Positions (2 to 360).
        #[arg(long, default_value_t = 24, value_name = "N", value_parser = positions)]
        positions: usize,
        /// The horizontal axis the dividing head turns about: oa (IA in the IA–PA plane), pa
        /// (IA in the IA–OA plane) or ia (IA horizontal, PA and OA turning).
        #[arg(long, value_enum, default_value = "oa")]
        axis: Axis,
        #[command(flatten)]
        out: PlanOut,
    },
    /// The dividing head on a rate table (Table 6.1's procedure): difference rows against a
    /// slow reference run.
    RateTable {
        /// IA positions (2 to 360).
        #[arg(long, default_value_t = 8, value_name = "N", value_parser = positions)]
        positions: usize,
        /// The dividing head's horizontal axis: oa (IA in the IA–PA plane, Table 6.1) or pa
        /// (IA in the IA–OA plane). Not ia: with IA along the head's axis the table's rate
        /// never reaches IA.
        #[arg(long, default_value = "oa", value_name = "oa|pa", value_parser = rate_table_axis)]
        axis: Axis,
        /// Table rate, rad/s.
        #[arg(long, default_value_t = 1.0, value_name = "RAD_S", value_parser = rate_rad_s)]
        rate_rad_s: f64,
        /// Rate of the reference run, rad/s.
        #[arg(long, default_value_t = 0.05, value_name = "RAD_S", value_parser = rate_rad_s)]
        ref_rate_rad_s: f64,
        /// Distance of the proof mass from the table axis, cm (0: centred).
        #[arg(long, default_value_t = 0.0, value_name = "CM", value_parser = lever_cm)]
        radius_cm: f64,
        #[command(flatten)]
        out: PlanOut,
    },
    /// The two-axis oscillator of Appendix A, IA up: blocks of phases of IA+PA and IA+OA
    /// vibration, OA rocking with PA vibration, and IA+OA rocking; difference rows.
    Shaker {
        /// Frequency, Hz (more than 0, at most 500).
        #[arg(long, default_value_t = 10.0, value_name = "HZ", value_parser = positive_hz)]
        freq_hz: f64,
        /// Vibration amplitude, cm/s².
        #[arg(long, default_value_t = 300.0, value_name = "CM_S2", value_parser = amplitude_cm_s2)]
        amplitude_cm_s2: f64,
        /// Rocking amplitude, mrad (0 to 100).
        #[arg(long, default_value_t = 1.0, value_name = "MRAD", value_parser = amplitude_mrad)]
        rock_mrad: f64,
        /// Phases per block (2 to 360).
        #[arg(long, default_value_t = 8, value_name = "N", value_parser = positions)]
        phases: usize,
        #[command(flatten)]
        out: PlanOut,
    },
    /// A centrifuge (IEEE Std 836): the proof mass at --radius-cm from the vertical spin
    /// axis, IA along the arm pointing at the axis and away from it, at each g level;
    /// absolute rows.
    Centrifuge {
        /// Arm length to the proof mass, cm (more than 0).
        #[arg(long, value_name = "CM", value_parser = arm_cm)]
        radius_cm: f64,
        /// The arm's push, in g (ω²R/g), comma separated, e.g. 2,5,10.
        #[arg(long, value_name = "G", value_delimiter = ',', required = true,
              value_parser = g_level)]
        g_levels: Vec<f64>,
        #[command(flatten)]
        out: PlanOut,
    },
}

/// Arguments of `ptsa plan`.
#[derive(Args, Debug, Clone)]
pub struct PlanArgs {
    /// The design.
    #[command(subcommand)]
    pub kind: PlanKind,
}

/// Where `ptsa plan` writes.
#[derive(Args, Debug, Clone)]
pub struct PlanOut {
    /// Write the case-frame file here (default: standard output). An existing file is not
    /// replaced without --force: it may hold the lab's measurements.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Replace an existing --out file (a warning says how many measured rows it held).
    #[arg(long, requires = "out")]
    pub force: bool,
}

fn positions(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(n @ 2..=360) => Ok(n),
        _ => Err(format!("expected a whole number from 2 to 360, not `{s}`")),
    }
}

/// The dividing head's axis on the rate table: `oa` or `pa`. `ia` is refused: IA would
/// lie along the head's horizontal axis, so the table's rate (about the vertical) has no
/// component along IA at any position, and the rows' differences carry no anisoinertia
/// (`w_IA·w_PA`), which is what the rate table measures.
fn rate_table_axis(s: &str) -> Result<Axis, String> {
    match s.trim() {
        "oa" => Ok(Axis::Oa),
        "pa" => Ok(Axis::Pa),
        "ia" => Err(
            "ia is not a rate-table set-up: with IA along the dividing head's axis the table's rate never reaches IA (w_IA = 0 at every position), so the rows would measure no anisoinertia (w_IA·w_PA); expected oa (IA in the IA–PA plane) or pa (IA in the IA–OA plane)"
                .into(),
        ),
        other => Err(format!(
            "expected oa (IA in the IA–PA plane) or pa (IA in the IA–OA plane), not `{other}`"
        )),
    }
}

fn rate_rad_s(s: &str) -> Result<f64, String> {
    within(s, 0.0, 100.0, "a rate in rad/s from 0 to 100")
}

fn amplitude_cm_s2(s: &str) -> Result<f64, String> {
    within(s, 0.0, 1e5, "an amplitude in cm/s² from 0 to 1e5")
}

/// One acceleration of a comma-separated list, cm/s².
fn accel_item(s: &str) -> Result<f64, String> {
    if s.trim().is_empty() {
        return Err(
            "an empty value in the list (a stray comma?); expected accelerations in cm/s² separated by commas, such as `-1000,0,1000`"
                .into(),
        );
    }
    finite(s)
}

fn input_amplitude_cm_s2(s: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if x > 0.0 {
        Ok(x)
    } else {
        Err(format!(
            "expected an amplitude in cm/s², more than 0, not {}",
            num(x)
        ))
    }
}

fn label(s: &str) -> Result<String, String> {
    if s.chars().any(char::is_control) {
        Err(format!(
            "expected a label on one line, without control characters (a case-frame cell cannot hold them), not {s:?}"
        ))
    } else {
        Ok(s.to_string())
    }
}

fn arm_cm(s: &str) -> Result<f64, String> {
    let x = within(
        s,
        0.0,
        1e4,
        "an arm length in cm, more than 0 and at most 1e4",
    )?;
    if x > 0.0 {
        Ok(x)
    } else {
        Err("expected an arm length in cm, more than 0".into())
    }
}

fn g_level(s: &str) -> Result<f64, String> {
    let x = within(s, 0.0, 1000.0, "a g level from 0 to 1000 (ω²R/g)")?;
    if x > 0.0 {
        Ok(x)
    } else {
        Err("expected a g level more than 0".into())
    }
}

fn candidates_help() -> String {
    format!(
        "Candidate effects, comma separated: effect names (`lever_arm` = its three components) or candidate names (`lever_arm.r_pa_cm`); default all. Known: {}",
        candidate_names().join(", ")
    )
}

fn candidate(s: &str) -> Result<Vec<CandidateId>, String> {
    if s.trim().is_empty() {
        return Err(format!(
            "an empty name in the list (a stray comma?); expected names separated by commas, such as `anisoinertia,lever_arm`; known: {}",
            candidate_names().join(", ")
        ));
    }
    resolve_candidates(s.trim())
}

fn number(s: &str) -> Result<f64, String> {
    s.trim()
        .parse::<f64>()
        .map_err(|_| format!("`{s}` is not a number"))
}

/// A number for a message: plain when it reads well, in exponent form when it is very large
/// or very small (`1e12`, `1e-9`, not twelve zeros).
pub fn num(x: f64) -> String {
    let a = x.abs();
    if a != 0.0 && a.is_finite() && !(1e-3..1e6).contains(&a) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// A finite number.
pub fn finite(s: &str) -> Result<f64, String> {
    let x = number(s)?;
    if x.is_finite() {
        Ok(x)
    } else {
        Err(format!("expected a finite number, not {x}"))
    }
}

/// A finite number within `[lo, hi]`.
fn within(s: &str, lo: f64, hi: f64, what: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if (lo..=hi).contains(&x) {
        Ok(x)
    } else {
        Err(format!("expected {what}, not {}", num(x)))
    }
}

fn non_negative_s(s: &str) -> Result<f64, String> {
    within(s, 0.0, 1e9, "a time in seconds from 0 to 1e9")
}

fn positive_s(s: &str) -> Result<f64, String> {
    let x = within(
        s,
        0.0,
        1e9,
        "a time in seconds, more than 0 and at most 1e9",
    )?;
    if x > 0.0 {
        Ok(x)
    } else {
        Err(format!(
            "expected a time in seconds, more than 0, not {}",
            num(x)
        ))
    }
}

/// More than 0; the upper limit, half the limit-cycle frequency, depends on the instrument
/// file and is checked with it.
fn positive_hz(s: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if x > 0.0 {
        Ok(x)
    } else {
        Err(format!(
            "expected a frequency in Hz, more than 0, not {}",
            num(x)
        ))
    }
}

fn positive_cm_s2(s: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if x > 0.0 {
        Ok(x)
    } else {
        Err(format!(
            "expected an uncertainty in cm/s², more than 0, not {}",
            num(x)
        ))
    }
}

fn anisoinertia_g_cm2(s: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if x.abs() < 100.0 {
        Ok(x)
    } else {
        Err(format!(
            "expected |I_PA − I_IA| below 100 g·cm² (the instrument file's range; the float's I_OA is 14 g·cm²), not {}",
            num(x)
        ))
    }
}

fn lever_cm(s: &str) -> Result<f64, String> {
    within(
        s,
        -100.0,
        100.0,
        "an offset in cm between −100 and 100 (the fixtures are table-top sized)",
    )
}

fn radius_cm(s: &str) -> Result<f64, String> {
    within(s, 0.0, 100.0, "a radius in cm from 0 to 100")
}

fn amplitude_mrad(s: &str) -> Result<f64, String> {
    within(
        s,
        0.0,
        100.0,
        "an amplitude in mrad from 0 to 100 (the oscillator model is small-angle)",
    )
}

/// A whole number in `lo..=hi`; `what` names it ("a seed", "ticks per run").
fn whole_in(s: &str, lo: u64, hi: u64, what: &str) -> Result<u64, String> {
    match s.trim().parse::<u64>() {
        Ok(n) if (lo..=hi).contains(&n) => Ok(n),
        _ => Err(format!(
            "expected {what}: a whole number from {lo} to {hi}, not `{s}`"
        )),
    }
}

fn seed(s: &str) -> Result<u64, String> {
    whole_in(s, 0, u64::MAX, "a seed")
}

fn ticks(s: &str) -> Result<u64, String> {
    whole_in(
        s,
        1,
        u64::from(u32::MAX),
        "ticks per run (the core's counters are 32-bit)",
    )
}

fn cycles(s: &str) -> Result<u64, String> {
    whole_in(s, 1, u64::MAX, "a number of limit cycles")
}

fn count(s: &str) -> Result<usize, String> {
    let n = whole_in(s, 1, 100_000, "a number of corners")?;
    usize::try_from(n).map_err(|e| e.to_string())
}

fn batch_conditions(s: &str) -> Result<usize, String> {
    let n = whole_in(s, 1, 64, "a number of static conditions")?;
    usize::try_from(n).map_err(|e| e.to_string())
}

fn lanes(s: &str) -> Result<usize, String> {
    let max = ptsa_host_sim::simulation::batch::MAX_LANES;
    match s.trim().parse::<usize>() {
        Ok(k) if k.is_power_of_two() && k <= max => Ok(k),
        _ => Err(format!(
            "expected lanes per core: a power of two from 1 to {max} (1, 2, 4, 8, 16), not `{s}`"
        )),
    }
}

fn runs(s: &str) -> Result<usize, String> {
    let n = whole_in(s, 1, 1000, "a number of runs")?;
    usize::try_from(n).map_err(|e| e.to_string())
}
