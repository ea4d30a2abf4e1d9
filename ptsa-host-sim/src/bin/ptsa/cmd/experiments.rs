//! The report programme's experiments, each on its own: `ptsa tumble`, `anisoinertia`,
//! `oa-coupling`, `vibropendulosity`, `anisoelasticity`, `sculling`, `waveform` and
//! `monte-carlo`. One file for all of them: each is a few checks, a work estimate and a
//! call of its `report::experiments` module, whose `Output` goes to stdout and `--out`.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;
use ptsa_host_sim::lab::fixtures::TwoAxisKind;
use ptsa_host_sim::model::effects::{CandidateId, Effects};
use ptsa_host_sim::report::experiments::appendix_a::{self, TwoAxisPlan};
use ptsa_host_sim::report::experiments::{
    anisoinertia, frequency_response, limit_cycle, monte_carlo, oa_coupling, tumble, waveform,
};
use ptsa_host_sim::simulation::sim::SimOptions;

use super::{Ctx, emit, gate_ticks};
use crate::flags::values::{
    amplitude_mrad, anisoinertia_g_cm2, count, cycles, finite, lever_cm, num, positive_hz,
    positive_s, radius_cm,
};
use crate::flags::{OutArgs, RunArgs, SettleArgs};
use crate::paths;
use crate::work::{self, Work};

/// Arguments of `ptsa tumble`.
#[derive(Args, Debug, Clone)]
pub struct TumbleArgs {
    /// Counting gate, s (at least one limit cycle, 0.001 s for the shipped file, and at
    /// most what the core's 32-bit counters hold, 67 108 s; rounded to whole limit cycles).
    #[arg(long, default_value_t = tumble::DEFAULT_GATE_S, value_name = "S",
          value_parser = positive_s)]
    pub gate_s: f64,
    #[command(flatten)]
    pub run: RunArgs,
    #[command(flatten)]
    pub out: OutArgs,
}

/// Arguments of `ptsa anisoinertia`.
#[derive(Args, Debug, Clone)]
pub struct AnisoinertiaArgs {
    /// Anisoinertia I_PA − I_IA of the simulated instrument, g·cm² (report: 3.4;
    /// |value| below 100, the instrument file's range).
    #[arg(long, default_value_t = 3.4, value_name = "G_CM2",
          value_parser = anisoinertia_g_cm2)]
    pub anisoinertia_g_cm2: f64,
    /// Offset of the proof mass from the table axis along PA, cm (0 in the report's
    /// revised set-up; |value| up to 100).
    #[arg(long, default_value_t = 0.0, value_name = "CM", value_parser = lever_cm)]
    pub lever_pa_cm: f64,
    #[command(flatten)]
    pub run: RunArgs,
    #[command(flatten)]
    pub out: OutArgs,
}

/// Arguments of `ptsa oa-coupling`.
#[derive(Args, Debug, Clone)]
pub struct OaCouplingArgs {
    /// Offset of the proof mass from the table axis along IA, PA, OA, cm (three values,
    /// each |value| up to 100).
    #[arg(long, num_args = 3, default_values_t = [0.0, 0.0, 0.0],
          value_names = ["IA_CM", "PA_CM", "OA_CM"], value_parser = lever_cm)]
    pub lever_cm: Vec<f64>,
    #[command(flatten)]
    pub run: RunArgs,
    #[command(flatten)]
    pub out: OutArgs,
}

/// Options of the Appendix A set-ups (`vibropendulosity`, `anisoelasticity`, `sculling`).
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

/// Arguments of `ptsa waveform`.
#[derive(Args, Debug, Clone)]
pub struct WaveformArgs {
    /// Constant acceleration along IA, cm/s² (beyond the loop's full scale the loop
    /// saturates; a warning says so).
    #[arg(long, default_value_t = waveform::DEFAULT_ACCEL_CM_S2, value_name = "CM_S2",
          value_parser = finite)]
    pub accel_cm_s2: f64,
    /// Limit cycles to trace (1 to 10 000; the CSV has one row per clock tick; more
    /// with --no-limit).
    #[arg(long, default_value_t = waveform::DEFAULT_CYCLES, value_name = "N",
          value_parser = cycles)]
    pub cycles: u64,
    #[command(flatten)]
    pub run: SettleArgs,
    #[command(flatten)]
    pub out: OutArgs,
}

/// Arguments of `ptsa monte-carlo`.
#[derive(Args, Debug, Clone)]
pub struct MonteCarloArgs {
    /// Random corners when the box has more than 14 parameters (1 to 100 000; default
    /// 1024). With 14 or fewer (12 in the shipped file) every corner is checked and this
    /// option is not used.
    #[arg(long, value_name = "N", value_parser = count)]
    pub samples: Option<usize>,
    #[command(flatten)]
    pub yield_study: super::yield_study::YieldArgs,
    #[command(flatten)]
    pub run: RunArgs,
    #[command(flatten)]
    pub out: OutArgs,
}

/// One experiment to run, its options and the folder for its files (checked).
pub struct Request {
    opts: SimOptions,
    force: bool,
    /// The folder for the tables and plots.
    out: PathBuf,
    what: Experiment,
}

/// Which experiment, with its own values resolved.
enum Experiment {
    Tumble {
        gate_s: f64,
    },
    Anisoinertia {
        anisoinertia_g_cm2: f64,
        lever: [f64; 3],
    },
    OaCoupling {
        lever: [f64; 3],
    },
    TwoAxis(Box<TwoAxisPlan>),
    Waveform {
        accel_cm_s2: f64,
        cycles: u64,
        /// The trace's rows: `cycles` limit cycles of the loop's ticks.
        ticks: u64,
    },
    /// `samples` random corners, or every corner of a small box.
    MonteCarlo {
        samples: usize,
    },
    /// The yield study of `--yield N` (its own output: nothing written into the folder).
    Yield(Box<super::yield_study::Request>),
}

impl TumbleArgs {
    /// The request: the gate against the loop's limit cycle and counters, the folder.
    ///
    /// # Errors
    /// The loop cannot be simulated; the gate does not fit; `--out` is not a folder.
    pub fn request(self, ctx: &Ctx) -> Result<Request> {
        let opts = self.run.options(ctx.config()?);
        gate_ticks("--gate-s", self.gate_s, &ctx.instr, &opts)?;
        paths::folder("--out", &self.out.out)?;
        Ok(Request {
            opts,
            force: self.run.force,
            out: self.out.out,
            what: Experiment::Tumble {
                gate_s: self.gate_s,
            },
        })
    }
}

impl AnisoinertiaArgs {
    /// The request: the folder checked, the lever along PA.
    ///
    /// # Errors
    /// The loop cannot be simulated; `--out` is not a folder.
    pub fn request(self, ctx: &Ctx) -> Result<Request> {
        let opts = self.run.options(ctx.config()?);
        paths::folder("--out", &self.out.out)?;
        Ok(Request {
            opts,
            force: self.run.force,
            out: self.out.out,
            what: Experiment::Anisoinertia {
                anisoinertia_g_cm2: self.anisoinertia_g_cm2,
                lever: [0.0, self.lever_pa_cm, 0.0],
            },
        })
    }
}

impl OaCouplingArgs {
    /// The request: the folder checked, the lever's three components.
    ///
    /// # Errors
    /// The loop cannot be simulated; `--out` is not a folder.
    pub fn request(self, ctx: &Ctx) -> Result<Request> {
        let opts = self.run.options(ctx.config()?);
        paths::folder("--out", &self.out.out)?;
        let l = &self.lever_cm;
        let lever = [l[0], l[1], l[2]];
        Ok(Request {
            opts,
            force: self.run.force,
            out: self.out.out,
            what: Experiment::OaCoupling { lever },
        })
    }
}

impl TwoAxisArgs {
    /// The request for the set-up `kind`: the frequency against the loop's limit cycle, the
    /// folder, the plan with its injected coefficients; a warning when the vibration is
    /// beyond the loop's full scale.
    ///
    /// # Errors
    /// The loop cannot be simulated; the frequency is above half the limit cycle's; `--out`
    /// is not a folder.
    pub fn request(self, ctx: &Ctx, kind: TwoAxisKind) -> Result<Request> {
        let config = ctx.config()?;
        let opts = self.run.options(config);
        let lc = ctx.instr.clock_hz / f64::from(config.ticks_per_cycle);
        if self.freq_hz > lc / 2.0 {
            bail!(
                "--freq-hz {}: expected at most half the limit-cycle frequency, {} Hz (clock_hz / {} ticks / 2)",
                num(self.freq_hz),
                num(lc / 2.0),
                config.ticks_per_cycle
            );
        }
        paths::folder("--out", &self.out.out)?;
        let plan = TwoAxisPlan {
            kind,
            freq_hz: self.freq_hz,
            theta_my_mrad: self.theta_my_mrad,
            theta_mz_mrad: self.theta_mz_mrad,
            r_cm: self.r_cm,
            effects: Effects::NONE
                .with(CandidateId::Anisoelasticity, self.k_io_s2_cm)
                .with(CandidateId::Vibropendulosity, self.k_ip_s2_cm)
                .with(CandidateId::Sculling, self.k_sc_s2),
        };
        let c = ptsa_host_sim::lab::fixtures::two_axis(
            kind,
            self.freq_hz,
            self.theta_my_mrad,
            self.theta_mz_mrad,
            90.0,
            self.r_cm,
        );
        let peak = c.lin_cm_s2.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        work::warn_beyond_full_scale(&ctx.instr, peak, "the vibration (r·θ·ω²)");
        Ok(Request {
            opts,
            force: self.run.force,
            out: self.out.out,
            what: Experiment::TwoAxis(Box::new(plan)),
        })
    }
}

impl WaveformArgs {
    /// The request: the trace's length (refused beyond what 64 bits count, and beyond
    /// [`work::MAX_TRACE_CYCLES`] without `--no-limit`), the folder; a warning when the
    /// acceleration is beyond the loop's full scale.
    ///
    /// # Errors
    /// The loop cannot be simulated; the trace is too long; `--out` is not a folder.
    pub fn request(self, ctx: &Ctx) -> Result<Request> {
        let opts = self.run.options(ctx.config()?);
        let cycles = self.cycles;
        let per_cycle = u64::from(opts.config.ticks_per_cycle);
        let Some(ticks) = cycles.checked_mul(per_cycle) else {
            bail!(
                "--cycles {cycles}: expected at most {} limit cycles ({per_cycle} ticks each, counted in 64 bits)",
                u64::MAX / per_cycle
            );
        };
        if cycles > work::MAX_TRACE_CYCLES && !work::lifted(self.run.force) {
            bail!(
                "--cycles {cycles}: the trace has one row per clock tick ({ticks} rows); expected at most {} cycles without --no-limit",
                work::MAX_TRACE_CYCLES
            );
        }
        paths::folder("--out", &self.out.out)?;
        work::warn_beyond_full_scale(&ctx.instr, self.accel_cm_s2, "--accel-cm-s2");
        Ok(Request {
            opts,
            force: self.run.force,
            out: self.out.out,
            what: Experiment::Waveform {
                accel_cm_s2: self.accel_cm_s2,
                cycles,
                ticks,
            },
        })
    }
}

impl MonteCarloArgs {
    /// The request: the folder, the number of random corners (a warning when `--samples`
    /// is given for a box small enough to check every corner).
    ///
    /// # Errors
    /// The loop cannot be simulated; `--out` is not a folder.
    pub fn request(self, ctx: &Ctx) -> Result<Request> {
        let opts = self.run.options(ctx.config()?);
        if let Some(y) = self.yield_study.request(ctx, opts, self.run.force)? {
            return Ok(Request {
                opts,
                force: self.run.force,
                out: self.out.out,
                what: Experiment::Yield(Box::new(y)),
            });
        }
        let n = ctx.instr.tolerances.len();
        if let Some(k) = self.samples
            && n <= monte_carlo::MAX_EXHAUSTIVE
        {
            eprintln!(
                "warning: --samples {k} is not used: the tolerance box has {n} parameters, so all {} of its corners are checked (random corners only beyond {} parameters)",
                1u64 << n,
                monte_carlo::MAX_EXHAUSTIVE
            );
        }
        paths::folder("--out", &self.out.out)?;
        Ok(Request {
            opts,
            force: self.run.force,
            out: self.out.out,
            what: Experiment::MonteCarlo {
                samples: self.samples.unwrap_or(monte_carlo::DEFAULT_SAMPLES),
            },
        })
    }
}

/// Run the experiment (refused beyond the work limit without `--no-limit`), its tables and
/// notes on `out`, its files into its folder.
///
/// # Errors
/// Refused work; the experiment or a write fails.
pub fn run(ctx: &Ctx, req: &Request, out: &mut dyn Write) -> Result<()> {
    let (instr, opts, force) = (&ctx.instr, &req.opts, req.force);
    let base = Work::new(instr, opts);
    match &req.what {
        Experiment::Tumble { gate_s } => {
            let est = base
                .ticks(tumble::work(instr, opts, *gate_s))
                .check(force, "the tumble")?;
            let p = work::Progress::start("tumble", &est);
            let r = tumble::run(instr, opts, *gate_s)?;
            p.finish();
            emit(&r.output, &req.out, 0, out)
        }
        Experiment::Anisoinertia {
            anisoinertia_g_cm2,
            lever,
        } => {
            let est = base
                .ticks(anisoinertia::work(instr, opts, *lever)?)
                .check(force, "Table 6.1")?;
            let p = work::Progress::start("Table 6.1", &est);
            let r = anisoinertia::run(instr, opts, *anisoinertia_g_cm2, *lever)?;
            p.finish();
            emit(&r.output, &req.out, 0, out)
        }
        Experiment::OaCoupling { lever } => {
            let est = base
                .ticks(oa_coupling::work(instr, opts, *lever)?)
                .check(force, "Tables 6.2 and 6.3")?;
            let p = work::Progress::start("Tables 6.2 and 6.3", &est);
            let r = oa_coupling::run(instr, opts, *lever)?;
            p.finish();
            emit(&r.output, &req.out, 0, out)
        }
        Experiment::TwoAxis(plan) => {
            let name = appendix_a::name(plan.kind);
            let est = base
                .ticks(appendix_a::work(instr, opts, plan))
                .check(force, name)?;
            let p = work::Progress::start(name, &est);
            let r = appendix_a::run(instr, opts, plan)?;
            p.finish();
            emit(&r.output, &req.out, 0, out)
        }
        Experiment::Waveform {
            accel_cm_s2,
            cycles,
            ticks,
        } => {
            // The trace after its settling, then the frequency response (11 frequencies)
            // and the limit-cycle sweep (11 inputs), each a settling and a 1 s window.
            #[allow(clippy::cast_precision_loss)]
            let est = base
                .ticks(
                    waveform::work(instr, opts, *cycles)
                        + frequency_response::work(instr, opts)
                        + limit_cycle::work(instr, opts),
                )
                .seconds(waveform::TRACE_S_PER_TICK * *ticks as f64)
                .check(force, "the waveform")?;
            let p = work::Progress::start("waveform, frequency response, limit cycle", &est);
            let mut all = waveform::run(instr, opts, *accel_cm_s2, *cycles, &req.out)?;
            all.extend(frequency_response::run(instr, opts)?.output);
            all.extend(limit_cycle::run(instr, opts)?.output);
            p.finish();
            // The trace's CSV was streamed into the folder by `waveform::run`.
            emit(&all, &req.out, 1, out)
        }
        Experiment::MonteCarlo { samples } => {
            #[allow(clippy::cast_precision_loss)]
            let est = base
                .ticks(monte_carlo::work(instr, opts, *samples))
                .seconds(
                    work::MARGINS_S_PER_CORNER * monte_carlo::corners(instr, *samples) as f64
                        / ptsa_host_sim::simulation::work::cores(),
                )
                .check(force, "the Monte Carlo")?;
            let p = work::Progress::start("monte carlo", &est);
            let r = monte_carlo::run(instr, opts, *samples)?;
            p.finish();
            emit(&r.output, &req.out, 0, out)
        }
        Experiment::Yield(y) => super::yield_study::run(ctx, y, out),
    }
}
