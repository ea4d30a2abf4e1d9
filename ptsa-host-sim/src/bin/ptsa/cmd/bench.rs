//! `ptsa bench`: the speed of the closed loop (against the plain C loop with
//! `--compare-c`), or with `--batch N` of the batch engine against the single loop. The
//! measurements are the library's (`ptsa_host_sim::bench`); this module only resolves the
//! options and holds the run to the work limit.

use std::io::Write;

use anyhow::Result;
use clap::Args;
use ptsa_host_sim::bench::{BenchPlan, bench, bench_batch};
use ptsa_host_sim::simulation::sim::SimOptions;

use super::Ctx;
use crate::flags::values::{batch_conditions, lanes, runs, seed, ticks};
use crate::work::Work;

/// Arguments of `ptsa bench`.
#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    /// Clock ticks per run (of the instrument file's clock_hz, 64 kHz shipped; 1 to
    /// 4 294 967 295, what the core's 32-bit counters hold; default 64 000 000). With
    /// --batch N: ticks per condition (default 64 000 000 / N, a run as long as without
    /// --batch).
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
    /// Instead: N static conditions (1 to 64, spread over ±0.9 of full scale) run one
    /// after the other with the single loop and as one batch of the batch engine on one
    /// thread; prints both rates in Mticks/s (all conditions' ticks, settling included,
    /// per second of one core) and their ratio, medians of --runs, after checking that
    /// both give the same pulses.
    #[arg(long, value_name = "N", value_parser = batch_conditions,
          conflicts_with = "compare_c")]
    pub batch: Option<usize>,
    /// With --batch: static loops side by side per core in the batch, on SIMD lanes where
    /// the CPU has them (1, 2, 4, 8 or 16; 1 runs them one after the other, block by block).
    #[arg(long, default_value_t = ptsa_host_sim::simulation::batch::LANES, value_name = "K",
          value_parser = lanes, requires = "batch")]
    pub lanes: usize,
    /// Seed of the pickoff noise (the instrument file's `noise_uv_rms`): a whole number
    /// from 0 to 2^64 − 1, no unit.
    #[arg(long, default_value_t = SimOptions::default().seed, value_name = "N",
          value_parser = seed)]
    pub seed: u64,
    /// Run even when the work is estimated to take more than ten minutes.
    #[arg(long)]
    pub force: bool,
}

/// A benchmark to run.
pub struct Request {
    opts: SimOptions,
    /// Ticks per run (the default resolved), runs, noise, the C loop.
    plan: BenchPlan,
    /// `--batch N` with its lanes, or the single loop.
    batch: Option<(usize, usize)>,
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
            batch: self.batch.map(|n| (n, self.lanes)),
            force: self.force,
        })
    }
}

/// Run the benchmark (refused beyond the work limit without `--force`); its table on
/// `out`.
///
/// # Errors
/// Refused work; the C loop cannot be built or disagrees; stdout cannot be written.
pub fn run(ctx: &Ctx, req: &Request, out: &mut dyn Write) -> Result<()> {
    let (instr, opts, plan) = (&ctx.instr, &req.opts, &req.plan);
    // Each run settles and then runs its ticks, twice with the C loop, and with
    // --batch N twice (single and batch) for each of N conditions; counted in
    // floating point so that no product of the options can overflow.
    #[allow(clippy::cast_precision_loss)]
    let per = match req.batch {
        Some((n, _)) => 2.0 * n as f64,
        None if plan.compare_c => 2.0,
        None => 1.0,
    };
    #[allow(clippy::cast_precision_loss)]
    let run_s = (plan.ticks as f64 / instr.clock_hz + opts.warmup_s) * per;
    #[allow(clippy::cast_precision_loss)]
    Work::new(instr, opts)
        .ticks(ptsa_host_sim::simulation::work::Ticks::of(
            run_s * instr.clock_hz,
            false,
        ))
        .times(plan.runs as f64)
        .check(req.force, "the benchmark")?;
    match req.batch {
        Some((n, lanes)) => bench_batch(instr, opts, plan, n, lanes, out),
        None => bench(instr, opts, plan, out),
    }
}
