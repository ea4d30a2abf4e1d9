//! `ptsa bench`: the speed of the closed loop (against the plain C loop with
//! `--compare-c`), or with `--batch N` of the batch engine against the single loop, on
//! static conditions, oscillating ones (`--dynamic`) or one oscillating condition with many
//! instruments (`--dynamic --shared-condition`). The measurements live here, in the binary,
//! not in the library: [`single`] (the single loop), [`c_loop`] (the plain C loop),
//! [`batch`] (the batch engine); the library only lends its fixtures
//! (`lab::fixtures::spread_accels`, `oscillating_spread`, `shared_condition_spread`) and
//! `ClosedLoop::c_static_params`.

mod batch;
mod c_loop;
mod single;

use std::io::Write;

use anyhow::Result;
use clap::Args;
use ptsa_host_sim::simulation::sim::SimOptions;

use batch::Set;

use super::Ctx;
use crate::flags::values::{batch_conditions, lanes, runs, seed, ticks};
use crate::work::Work;

/// Arguments of `ptsa bench`.
#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    /// Clock ticks per run (of the instrument file's clock_hz, 64 kHz shipped; 1 to
    /// 4 294 967 295, what the core's 32-bit counters hold; default 64 000 000). With
    /// --batch N: ticks per condition (default 64 000 000 / N, a run as long as without
    /// --batch); with --dynamic, each condition's shortest measurement window, in whole
    /// oscillation periods.
    #[arg(long, value_name = "N", value_parser = ticks)]
    pub ticks: Option<u64>,
    /// Runs (1 to 1000).
    #[arg(long, default_value_t = BenchPlan::RUNS, value_name = "N", value_parser = runs)]
    pub runs: usize,
    /// Without pickoff noise.
    #[arg(long)]
    pub no_noise: bool,
    /// Also build the plain C loop (ptsa-host-sim/benches/c_static/static_loop.c) with
    /// the system C compiler (`$CC`, default `cc`, `-std=c11 -O2`), check that it gives
    /// the same pulses and plant state bit for bit, and time it in alternation.
    #[arg(long)]
    pub compare_c: bool,
    /// Instead: N static conditions (1 to 64, spread over ±0.9 of full scale; oscillating
    /// ones with --dynamic) run one after the other with the single loop and as one batch of the batch engine on one
    /// thread; prints both rates in Mticks/s (all conditions' ticks, settling included,
    /// per second of one core) and their ratio, medians of --runs, after checking that
    /// both give the same pulses.
    #[arg(long, value_name = "N", value_parser = batch_conditions,
          conflicts_with = "compare_c")]
    pub batch: Option<usize>,
    /// With --batch: N different oscillating conditions instead of static ones (from 10 Hz
    /// up to 47.5 Hz for 16: angular oscillation about OA and IA+PA vibration in turn, with
    /// sculling and anisoinertia), each settled for 0.1 s and measured over a window of at
    /// least --ticks ticks in whole periods; the single loop (sim::simulate_condition) one
    /// after the other against one Engine::simulate_conditions call on one thread, their
    /// results compared bit for bit; rates in Mticks/s as above.
    #[arg(long, requires = "batch")]
    pub dynamic: bool,
    /// With --dynamic: one oscillating condition (2 mrad about OA at 20 Hz) with N
    /// instruments, the spring up to 16 % stiffer (0 to 15 % for 16) (parameter identification, as discover's
    /// parameter sides: lanes that share their inputs); sim::simulate_condition for each
    /// against one Engine::simulate_jobs call.
    #[arg(long, requires = "dynamic")]
    pub shared_condition: bool,
    /// With --batch: loops side by side per core in the batch, on SIMD lanes where the CPU
    /// has them (1, 2, 4, 8 or 16; 1 runs them one after the other, block by block; static
    /// loops run in kernels of at most 8 lanes; a kernel of 8 holds the core's tick in
    /// AVX-512 or AVX2 registers; the environment variable PTSA_SIMD=avx512, avx2 or sse2
    /// lets the kernels use at most those instructions, to compare the paths).
    #[arg(long, default_value_t = ptsa_host_sim::simulation::batch::LANES, value_name = "K",
          value_parser = lanes, requires = "batch")]
    pub lanes: usize,
    /// Seed of the pickoff noise (the instrument file's `noise_uv_rms`): a whole number
    /// from 0 to 2^64 − 1, no unit.
    #[arg(long, default_value_t = SimOptions::default().seed, value_name = "N",
          value_parser = seed)]
    pub seed: u64,
    /// The old spelling of --no-limit, accepted until the next release.
    #[arg(long, hide = true)]
    pub force: bool,
    #[command(flatten)]
    pub limit: crate::flags::LimitArg,
}

/// A benchmark to run.
pub struct Request {
    opts: SimOptions,
    /// Ticks per run (the default resolved), runs, noise, the C loop.
    plan: BenchPlan,
    /// `--batch N` with its lanes and set, or the single loop.
    batch: Option<(usize, usize, Set)>,
    force: bool,
}

impl BenchArgs {
    /// The request: the ticks per run (by default those of a 64 000 000-tick run, split
    /// over the conditions of `--batch`).
    ///
    /// # Errors
    /// The loop cannot be simulated.
    pub fn request(self, ctx: &Ctx) -> Result<Request> {
        let opts = SimOptions {
            seed: self.seed,
            config: ctx.config()?,
            ..SimOptions::default()
        };
        let default_ticks = BenchPlan::TICKS / self.batch.unwrap_or(1) as u64;
        Ok(Request {
            opts,
            plan: BenchPlan {
                ticks: self.ticks.unwrap_or(default_ticks),
                runs: self.runs,
                no_noise: self.no_noise,
                compare_c: self.compare_c,
            },
            batch: self.batch.map(|n| {
                let set = match (self.dynamic, self.shared_condition) {
                    (false, _) => Set::Static,
                    (true, false) => Set::Dynamic,
                    (true, true) => Set::SharedCondition,
                };
                (n, self.lanes, set)
            }),
            force: self.force,
        })
    }
}

/// Run the benchmark (refused beyond the work limit without `--no-limit`); its table on
/// `out`.
///
/// # Errors
/// Refused work; the C loop cannot be built or disagrees; stdout cannot be written.
pub fn run(ctx: &Ctx, req: &Request, out: &mut dyn Write) -> Result<()> {
    let (instr, opts, plan) = (&ctx.instr, &req.opts, &req.plan);
    // Each run settles and then runs its ticks, twice with the C loop, and with
    // --batch N twice (single and batch) for each of N conditions; counted in
    // floating point so that no product of the options can overflow.
    // (A dynamic window is rounded up to whole periods: at most one period, 0.1 s, more.)
    #[allow(clippy::cast_precision_loss)]
    let per = match req.batch {
        Some((n, _, _)) => 2.0 * n as f64,
        None if plan.compare_c => 2.0,
        None => 1.0,
    };
    let dynamic = matches!(req.batch, Some((_, _, s)) if s != Set::Static);
    #[allow(clippy::cast_precision_loss)]
    let run_s = (plan.ticks as f64 / instr.clock_hz + opts.warmup_s) * per;
    #[allow(clippy::cast_precision_loss)]
    Work::new(instr, opts)
        .ticks(ptsa_host_sim::simulation::work::Ticks::of(
            run_s * instr.clock_hz,
            dynamic,
        ))
        .times(plan.runs as f64)
        .check(req.force, "the benchmark")?;
    match req.batch {
        Some((n, lanes, set)) => batch::bench_batch(instr, opts, plan, set, n, lanes, out),
        None => single::bench(instr, opts, plan, out),
    }
}

/// What `ptsa bench` measures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BenchPlan {
    /// Ticks per timed run (after the settling of `opts.warmup_s`); per condition with
    /// `--batch`, the shortest window of a dynamic set.
    pub ticks: u64,
    /// Timed runs (the median is reported).
    pub runs: usize,
    /// Without pickoff noise.
    pub no_noise: bool,
    /// Also build, check and time the plain C loop.
    pub compare_c: bool,
}

impl BenchPlan {
    /// Default ticks per run (1000 s of simulated time).
    pub const TICKS: u64 = 64_000_000;
    /// Default runs.
    pub const RUNS: usize = 5;
}

/// The median, the least and the greatest of `v` (sorted in place; `v` not empty).
fn median_min_max(v: &mut [f64]) -> (f64, f64, f64) {
    v.sort_by(f64::total_cmp);
    (v[v.len() / 2], v[0], v[v.len() - 1])
}
