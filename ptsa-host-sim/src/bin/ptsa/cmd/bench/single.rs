//! `ptsa bench` without `--batch`: the static closed loop's speed on one core, and with
//! `--compare-c` the plain C loop's ([`super::c_loop`]) timed after each Rust run.

use std::io::Write;
use std::time::Instant;

use anyhow::Result;
use ptsa_host_sim::model::instrument::Instrument;
use ptsa_host_sim::output::count;
use ptsa_host_sim::simulation::sim::{SimOptions, run_static};

use super::c_loop::CStaticLoop;
use super::{BenchPlan, median_min_max};

/// `run_static` timed `plan.runs` times at 1 g along IA (and, with `compare_c`, the C loop
/// after each Rust run); prints the medians and, for C, the ratio, to `out`.
///
/// # Errors
/// The C compiler or the C loop fails, the C loop disagrees with the Rust loop, or `out`
/// fails.
pub(super) fn bench(
    instr: &Instrument,
    opts: &SimOptions,
    plan: &BenchPlan,
    out: &mut dyn Write,
) -> Result<()> {
    let accel = instr.g_cm_s2;
    let BenchPlan {
        ticks,
        runs,
        no_noise,
        compare_c,
    } = *plan;
    let settle = opts.warmup_ticks(instr.clock_hz);
    let opts = SimOptions {
        noise: opts.noise && !no_noise,
        ..*opts
    };
    let c_loop = if compare_c {
        Some(CStaticLoop::build(instr, &opts, accel, ticks)?)
    } else {
        None
    };
    let mut rates = Vec::new();
    let mut c_rates = Vec::new();
    for _ in 0..runs.max(1) {
        let t = Instant::now();
        let r = run_static(instr, accel, ticks, &opts);
        let e = t.elapsed().as_secs_f64();
        #[allow(clippy::cast_precision_loss)]
        let rate = (ticks + settle) as f64 / e;
        rates.push(rate);
        std::hint::black_box(r);
        if let Some(c) = &c_loop {
            c_rates.push(c.run()?);
        }
    }
    let (med, lo, hi) = median_min_max(&mut rates);
    writeln!(
        out,
        "bench: static closed loop{}, {ticks} ticks x {}: median {med:.4e} ticks/s ({:.0}x real time at {} Hz), min {lo:.4e}, max {hi:.4e}",
        if opts.noise { "" } else { " without noise" },
        count(rates.len() as u64, "run"),
        med / instr.clock_hz,
        instr.clock_hz,
    )?;
    if c_loop.is_some() {
        let (c_med, c_lo, c_hi) = median_min_max(&mut c_rates);
        writeln!(
            out,
            "bench: plain C loop (cc -std=c11 -O2), same ticks, alternating: median {c_med:.4e} ticks/s, min {c_lo:.4e}, max {c_hi:.4e}; same pulses and plant state bit for bit"
        )?;
        writeln!(out, "bench: Rust / C = {:.3}", med / c_med)?;
    }
    Ok(())
}
