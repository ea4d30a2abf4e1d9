//! `ptsa bench --batch N`: the batch engine against the single loop on one core, on N
//! static conditions, N oscillating ones (`--dynamic`), or one oscillating condition with N
//! instruments (`--dynamic --shared-condition`, parameter identification's shape). Both
//! passes run the same closed loops; every run checks that they give the same results bit
//! for bit before its times count.

use std::io::Write;
use std::time::Instant;

use anyhow::Result;
use ptsa_host_sim::lab::fixtures;
use ptsa_host_sim::model::instrument::Instrument;
use ptsa_host_sim::output::count;
use ptsa_host_sim::simulation::batch::{Engine, Job};
use ptsa_host_sim::simulation::sim::{
    self, SimOptions, SimResult, simulate_condition, window_ticks,
};
use ptsa_host_sim::simulation::simd::SimdLevel;

use super::{BenchPlan, median_min_max};

/// Which loops the batch runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Set {
    /// N static conditions along IA ([`fixtures::spread_accels`]): `sim::run_static`
    /// against `Engine::run_static`.
    Static,
    /// N different oscillating conditions ([`fixtures::oscillating_spread`]):
    /// `sim::simulate_condition` against `Engine::simulate_conditions`.
    Dynamic,
    /// One oscillating condition with N instruments
    /// ([`fixtures::shared_condition_spread`]): `sim::simulate_condition` against
    /// `Engine::simulate_jobs`.
    SharedCondition,
}

/// The single loop's and the batch engine's speed on the same loops, side by side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BatchRates {
    /// Every loop's ticks in one pass (settling included).
    pub ticks: u64,
    /// The single loop, one run after the other: median ticks per second.
    pub single_ticks_per_s: f64,
    /// The batch engine on one thread: median ticks per second (all lanes' ticks).
    pub batch_ticks_per_s_per_core: f64,
}

impl BatchRates {
    /// Batch over single.
    #[must_use]
    pub fn ratio(&self) -> f64 {
        self.batch_ticks_per_s_per_core / self.single_ticks_per_s
    }
}

/// `runs` times: `single()` then `batch()` on a one-thread pool, each timed, their results
/// compared by `same`; the median rates at `ticks` ticks per pass.
fn time_both<T>(
    ticks: u64,
    runs: usize,
    mut single: impl FnMut() -> T,
    mut batch: impl FnMut() -> T + Send,
    same: impl Fn(&T, &T) -> bool,
) -> Result<BatchRates>
where
    T: Send,
{
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    #[allow(clippy::cast_precision_loss)]
    let all = ticks as f64;
    let mut s = Vec::new();
    let mut b = Vec::new();
    for _ in 0..runs.max(1) {
        let t = Instant::now();
        let one = single();
        s.push(all / t.elapsed().as_secs_f64());
        let t = Instant::now();
        let many = pool.install(&mut batch);
        b.push(all / t.elapsed().as_secs_f64());
        anyhow::ensure!(
            same(&one, &many),
            "the batch engine disagrees with the single loop"
        );
    }
    Ok(BatchRates {
        ticks,
        single_ticks_per_s: median_min_max(&mut s).0,
        batch_ticks_per_s_per_core: median_min_max(&mut b).0,
    })
}

/// A result's every field as bits (NaN and −0 compared exactly); the destructuring names
/// every field, so one added to [`SimResult`] does not compile here until it is compared.
fn result_bits(r: &SimResult) -> [u64; 14] {
    let SimResult {
        indicated_cm_s2,
        count_cm_s2,
        ticks,
        pulses,
        window_s,
        theta_rms_rad,
        theta_max_rad,
        cycles,
        cycles_two_reversals,
        stop_ticks,
        harmonic_amp_cm_s2,
        harmonic_deg,
        harmonic_torque_amp_cm_s2,
        harmonic_torque_deg,
    } = *r;
    [
        indicated_cm_s2.to_bits(),
        count_cm_s2.to_bits(),
        ticks,
        pulses,
        window_s.to_bits(),
        theta_rms_rad.to_bits(),
        theta_max_rad.to_bits(),
        cycles,
        cycles_two_reversals,
        stop_ticks,
        harmonic_amp_cm_s2.to_bits(),
        harmonic_deg.to_bits(),
        harmonic_torque_amp_cm_s2.to_bits(),
        harmonic_torque_deg.to_bits(),
    ]
}

/// Two lists of results the same bit for bit.
fn same_bits(a: &[SimResult], b: &[SimResult]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| result_bits(x) == result_bits(y))
}

/// `n` static conditions ([`fixtures::spread_accels`]) of `ticks` gate ticks each (plus
/// `opts.warmup_s` of settling): [`sim::run_static`] one after the other against one
/// `Engine::run_static` with `lanes` lanes per core on one thread, `runs` times.
///
/// # Errors
/// The one-thread pool cannot be built, or the batch disagrees with the single loops.
pub fn static_rates(
    instr: &Instrument,
    opts: &SimOptions,
    n: usize,
    lanes: usize,
    ticks: u64,
    runs: usize,
) -> Result<BatchRates> {
    let engine = Engine::new(lanes);
    let accels = fixtures::spread_accels(instr, n);
    let all = n as u64 * (ticks + opts.warmup_ticks(instr.clock_hz));
    // `StaticRun` holds integers, a flag and a value computed from them: `==` is exact.
    time_both(
        all,
        runs,
        || {
            accels
                .iter()
                .map(|&a| sim::run_static(instr, a, ticks, opts))
                .collect::<Vec<_>>()
        },
        || engine.run_static(instr, &accels, ticks, opts),
        |a, b| a == b,
    )
}

/// `n` oscillating conditions ([`fixtures::oscillating_spread`]) or, with `shared`, one
/// with `n` instruments ([`fixtures::shared_condition_spread`]), each settled for
/// `opts.warmup_s` and measured over a window of at least `opts.min_window_s` in whole
/// periods: [`simulate_condition`] one after the other against one
/// `Engine::simulate_conditions` (`Engine::simulate_jobs` with `shared`) with `lanes` lanes
/// per core on one thread, `runs` times; the results compared bit for bit.
///
/// # Errors
/// The one-thread pool cannot be built, or the batch disagrees with the single loops.
pub fn dynamic_rates(
    instr: &Instrument,
    opts: &SimOptions,
    n: usize,
    lanes: usize,
    shared: bool,
    runs: usize,
) -> Result<BatchRates> {
    let engine = Engine::new(lanes);
    let settle = opts.warmup_ticks(instr.clock_hz);
    if shared {
        let (cond, instrs) = fixtures::shared_condition_spread(instr, n);
        let all = instrs
            .iter()
            .map(|i| settle + window_ticks(i, &cond, opts))
            .sum();
        let jobs: Vec<Job<'_>> = instrs
            .iter()
            .map(|i| Job {
                instr: i,
                cond: &cond,
                effects: ptsa_host_sim::Effects::NONE,
                seed: opts.seed,
            })
            .collect();
        time_both(
            all,
            runs,
            || {
                jobs.iter()
                    .map(|j| simulate_condition(j.instr, j.cond, &j.effects, opts))
                    .collect()
            },
            || engine.simulate_jobs(&jobs, opts),
            |a, b| same_bits(a, b),
        )
    } else {
        let conds = fixtures::oscillating_spread(n);
        let all = conds
            .iter()
            .map(|(c, _)| settle + window_ticks(instr, c, opts))
            .sum();
        time_both(
            all,
            runs,
            || {
                conds
                    .iter()
                    .map(|(c, e)| simulate_condition(instr, c, e, opts))
                    .collect()
            },
            || engine.simulate_conditions(instr, &conds, opts),
            |a, b| same_bits(a, b),
        )
    }
}

/// The loops of `set` with `n` lanes, in words, for the header.
fn describe(instr: &Instrument, set: Set, n: usize) -> String {
    match set {
        Set::Static => {
            let accels = fixtures::spread_accels(instr, n);
            let spread = match (accels.first(), accels.last()) {
                (Some(lo), Some(hi)) if n > 1 => {
                    format!("from {lo:.1} to {hi:.1} cm/s^2 (±0.9 of full scale)")
                }
                _ => "at 0 cm/s^2".to_string(),
            };
            format!("{} {spread}", count(n as u64, "static condition"))
        }
        Set::Dynamic => {
            let conds = fixtures::oscillating_spread(n);
            let freqs = match (conds.first(), conds.last()) {
                (Some(lo), Some(hi)) if n > 1 => {
                    format!("from {:.1} to {:.1} Hz", lo.0.freq_hz, hi.0.freq_hz)
                }
                (Some(c), _) => format!("at {:.1} Hz", c.0.freq_hz),
                _ => String::new(),
            };
            let kinds = if n > 1 {
                "angular oscillation about OA and IA+PA vibration in turn"
            } else {
                "angular oscillation about OA"
            };
            format!(
                "{} {freqs} ({kinds}, with sculling and anisoinertia)",
                count(n as u64, "oscillating condition")
            )
        }
        Set::SharedCondition => {
            let (cond, instrs) = fixtures::shared_condition_spread(instr, n);
            let stiffer = instrs.last().map_or(0.0, |i| {
                100.0 * (i.spring_dyn_cm_rad / instr.spring_dyn_cm_rad - 1.0)
            });
            format!(
                "one oscillating condition ({}) with {} (spring 0 to {stiffer:.1} % stiffer)",
                cond.label,
                count(n as u64, "instrument")
            )
        }
    }
}

/// `ptsa bench --batch N`: the rates of `set` with `n` lanes, `lanes` per core, `plan.ticks`
/// ticks per condition (with a dynamic set, the shortest window, whole periods), `plan.runs`
/// times; prints the header, the single loop's and the batch engine's median rates in
/// Mticks/s and their ratio to `out`. `plan.compare_c` is not used.
///
/// # Errors
/// The one-thread pool cannot be built, the batch disagrees with the single loops (never,
/// the engine's guarantee, checked every run), or `out` fails.
///
/// # Panics
/// If `lanes` is not a power of two from 1 to `batch::MAX_LANES` (the flag's parser
/// refuses them).
pub fn bench_batch(
    instr: &Instrument,
    opts: &SimOptions,
    plan: &BenchPlan,
    set: Set,
    n: usize,
    lanes: usize,
    out: &mut dyn Write,
) -> Result<()> {
    // A dynamic set's `--ticks` is its shortest window (`run_static` has no window).
    #[allow(clippy::cast_precision_loss)]
    let opts = SimOptions {
        noise: opts.noise && !plan.no_noise,
        min_window_s: if set == Set::Static {
            opts.min_window_s
        } else {
            plan.ticks as f64 / instr.clock_hz
        },
        ..*opts
    };
    let settle = opts.warmup_ticks(instr.clock_hz);
    let noise = if opts.noise { "" } else { ", without noise" };
    let runs = count(plan.runs.max(1) as u64, "run");
    let medians = |what| format!("medians (all {what}' ticks per second of one core):");
    let what = describe(instr, set, n);
    let (r, single, batch) = if set == Set::Static {
        let r = static_rates(instr, &opts, n, lanes, plan.ticks, plan.runs)?;
        writeln!(
            out,
            "bench --batch {n}: {what}{noise}, {} ticks each after {settle} settling ticks, {runs}, {}",
            plan.ticks,
            medians("conditions"),
        )?;
        (r, "one condition", "Engine::run_static")
    } else {
        let shared = set == Set::SharedCondition;
        let r = dynamic_rates(instr, &opts, n, lanes, shared, plan.runs)?;
        writeln!(
            out,
            "bench --batch {n} --dynamic{}: {what}{noise}, windows of at least {} ticks in whole periods after {settle} settling ticks, {} ticks in all, {runs}, {}",
            if shared { " --shared-condition" } else { "" },
            plan.ticks,
            r.ticks,
            medians("loops"),
        )?;
        if shared {
            (r, "one instrument", "Engine::simulate_jobs")
        } else {
            (r, "one condition", "Engine::simulate_conditions")
        }
    };
    let call = if set == Set::Static {
        "sim::run_static"
    } else {
        "sim::simulate_condition"
    };
    writeln!(
        out,
        "bench: single loop, {single} after the other ({call}): {:.2} Mticks/s",
        r.single_ticks_per_s / 1e6
    )?;
    // Where the kernels hold the core's tick: registers for kernels of eight, if the CPU
    // (or `PTSA_SIMD`) allows; arrays otherwise.
    let level = SimdLevel::current();
    let how = if set == Set::Static && (lanes == 1 || !level.static_kernels()) {
        "the loops one after the other".to_string()
    } else if lanes >= 8 {
        format!("the core's tick in {}", level.lanes_of_eight())
    } else {
        "the core's tick in arrays".to_string()
    };
    writeln!(
        out,
        "bench: batch engine, {} per core, on one thread ({batch}), {how} (SIMD level {}): {:.2} Mticks/s",
        count(lanes as u64, "lane"),
        level.name(),
        r.batch_ticks_per_s_per_core / 1e6
    )?;
    let same = if set == Set::Static {
        "same pulses in every run"
    } else {
        "same results bit for bit in every run"
    };
    writeln!(out, "bench: batch / single = {:.3} ({same})", r.ratio())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn short(noise: bool) -> SimOptions {
        SimOptions {
            warmup_s: 0.002,
            min_window_s: 0.005,
            noise,
            ..SimOptions::default()
        }
    }

    #[test]
    fn static_rates_run_both_and_agree() {
        // Only that it runs and that the batch agrees (no timing is asserted).
        let i = Instrument::kearfott_2401();
        let o = short(true);
        let r = static_rates(&i, &o, 5, 1, 640, 1).expect("rates");
        assert_eq!(r.ticks, 5 * (640 + o.warmup_ticks(i.clock_hz)));
        assert!(r.single_ticks_per_s > 0.0 && r.batch_ticks_per_s_per_core > 0.0);
        assert!(r.ratio() > 0.0);
    }

    #[test]
    fn dynamic_rates_run_both_and_agree() {
        let i = Instrument::kearfott_2401();
        let o = short(true);
        let settle = o.warmup_ticks(i.clock_hz);
        for (shared, lanes) in [(false, 4), (true, 2)] {
            let r = dynamic_rates(&i, &o, 3, lanes, shared, 1).expect("rates");
            // Three windows of whole periods (10 to 50 Hz), each at least 0.005 s.
            assert!(r.ticks >= 3 * (settle + 320), "{r:?}");
            assert!(r.single_ticks_per_s > 0.0 && r.batch_ticks_per_s_per_core > 0.0);
        }
    }

    #[test]
    fn results_differ_in_any_bit() {
        let a = SimResult {
            pulses: 3,
            ..SimResult::default()
        };
        let b = SimResult {
            harmonic_torque_deg: -0.0,
            ..a
        };
        assert!(same_bits(&[a], &[a]));
        assert!(!same_bits(&[a], &[b]));
        assert!(!same_bits(&[a], &[a, a]));
    }
}
