//! `ptsa bench`: the speed of the static closed loop on one core, and the comparison with
//! a plain C loop of the same model (`benches/c_static/static_loop.c`), checked bit for bit
//! against the Rust loop before it is timed.

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};

use crate::model::effects::Effects;
use crate::model::instrument::Instrument;
use crate::simulation::sim::{ClosedLoop, SimOptions, run_static};

/// The plain C loop of `bench --compare-c`.
const C_STATIC_LOOP: &str = include_str!("../benches/c_static/static_loop.c");

/// What `ptsa bench` measures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BenchPlan {
    /// Ticks per timed run (after the settling of `opts.warmup_s`).
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

/// `ptsa bench`: `run_static` timed `plan.runs` times at 1 g along IA (and, with
/// `compare_c`, the C loop after each Rust run); prints the medians and, for C, the ratio,
/// to `out`.
///
/// # Errors
/// The C compiler or the C loop fails, the C loop disagrees with the Rust loop, or `out`
/// fails.
pub fn bench(
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
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        (v[v.len() / 2], v[0], v[v.len() - 1])
    };
    let (med, lo, hi) = median(&mut rates);
    writeln!(
        out,
        "bench: static closed loop{}, {ticks} ticks x {}: median {med:.4e} ticks/s ({:.0}x real time at {} Hz), min {lo:.4e}, max {hi:.4e}",
        if opts.noise { "" } else { " without noise" },
        crate::output::count(rates.len() as u64, "run"),
        med / instr.clock_hz,
        instr.clock_hz,
    )?;
    if c_loop.is_some() {
        let (c_med, c_lo, c_hi) = median(&mut c_rates);
        writeln!(
            out,
            "bench: plain C loop (cc -std=c11 -O2), same ticks, alternating: median {c_med:.4e} ticks/s, min {c_lo:.4e}, max {c_hi:.4e}; same pulses and plant state bit for bit"
        )?;
        writeln!(out, "bench: Rust / C = {:.3}", med / c_med)?;
    }
    Ok(())
}

/// `ptsa bench --batch N`: [`batch_rates`](crate::simulation::batch::batch_rates) on `conditions`
/// static conditions ([`spread_accels`](crate::simulation::batch::spread_accels)) of `plan.ticks` gate
/// ticks each after the settling, `plan.runs` times, with `lanes` lanes per core; prints the
/// single loop's and the batch engine's median rates in Mticks/s and their ratio to `out`.
/// `plan.compare_c` is not used.
///
/// # Errors
/// The one-thread pool cannot be built, the batch disagrees with the single loops (never,
/// the engine's guarantee, checked every run), or `out` fails.
///
/// # Panics
/// If `lanes` is not a power of two from 1 to [`MAX_LANES`](crate::simulation::batch::MAX_LANES).
pub fn bench_batch(
    instr: &Instrument,
    opts: &SimOptions,
    plan: &BenchPlan,
    conditions: usize,
    lanes: usize,
    out: &mut dyn Write,
) -> Result<()> {
    let opts = SimOptions {
        noise: opts.noise && !plan.no_noise,
        ..*opts
    };
    let r = crate::simulation::batch::batch_rates(
        instr, &opts, conditions, lanes, plan.ticks, plan.runs,
    )?;
    let settle = opts.warmup_ticks(instr.clock_hz);
    let accels = crate::simulation::batch::spread_accels(instr, conditions);
    let spread = match (accels.first(), accels.last()) {
        (Some(lo), Some(hi)) if conditions > 1 => {
            format!("from {lo:.1} to {hi:.1} cm/s^2 (±0.9 of full scale)")
        }
        _ => "at 0 cm/s^2".to_string(),
    };
    writeln!(
        out,
        "bench --batch {conditions}: {} {spread}{}, {} ticks each after {settle} settling ticks, {}, medians (all conditions' ticks per second of one core):",
        crate::output::count(conditions as u64, "static condition"),
        if opts.noise { "" } else { ", without noise" },
        plan.ticks,
        crate::output::count(plan.runs.max(1) as u64, "run"),
    )?;
    writeln!(
        out,
        "bench: single loop, one condition after the other (sim::run_static): {:.2} Mticks/s",
        r.single_ticks_per_s / 1e6
    )?;
    writeln!(
        out,
        "bench: batch engine, {} per core, on one thread (Engine::run_static): {:.2} Mticks/s",
        crate::output::count(lanes as u64, "lane"),
        r.batch_ticks_per_s_per_core / 1e6
    )?;
    writeln!(
        out,
        "bench: batch / single = {:.3} (same pulses in every run)",
        r.ratio()
    )?;
    Ok(())
}

/// The plain C loop, compiled into a temporary folder, with its parameters.
struct CStaticLoop {
    /// The folder of the source and the executable, removed when the loop is dropped.
    _dir: tempfile::TempDir,
    exe: PathBuf,
    params: String,
    settle: u64,
    ticks: u64,
}

impl CStaticLoop {
    /// Compile the C loop and check it once against the Rust loop (pulses and plant state).
    fn build(instr: &Instrument, opts: &SimOptions, accel: f64, ticks: u64) -> Result<Self> {
        let dir = tempfile::Builder::new()
            .prefix("ptsa-c-static-")
            .tempdir()
            .context("creating a temporary folder for the C loop")?;
        let src = dir.path().join("static_loop.c");
        let exe = dir.path().join("static_loop");
        std::fs::write(&src, C_STATIC_LOOP)
            .with_context(|| format!("writing {}", src.display()))?;
        let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
        let out = std::process::Command::new(&cc)
            .args(["-std=c11", "-O2", "-o"])
            .arg(&exe)
            .arg(&src)
            .output()
            .with_context(|| format!("running the C compiler `{cc}`"))?;
        anyhow::ensure!(
            out.status.success(),
            "`{cc} -std=c11 -O2` failed:\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let cond = crate::lab::fixtures::along_ia(accel, instr.g_cm_s2);
        let mut l = ClosedLoop::new(instr, &cond, &Effects::NONE, opts);
        let params = l
            .c_static_params()
            .context("no C parameters for this loop")?;
        let settle = opts.warmup_ticks(instr.clock_hz);
        let c = Self {
            _dir: dir,
            exe,
            params,
            settle,
            ticks,
        };
        // The check: the same pulses over the gate and the same final plant state.
        let (_, pulses, x) = c.run_once()?;
        l.run_fast(settle);
        let p0 = l.core().total_pulses();
        l.run_fast(ticks);
        let want_pulses = u64::from((l.core().total_pulses() - p0).0);
        let want_x: Vec<String> = l
            .state()
            .iter()
            .map(|v| format!("{:016x}", v.to_bits()))
            .collect();
        anyhow::ensure!(
            pulses == want_pulses && x == want_x.join(","),
            "the C loop disagrees with the Rust loop: pulses {pulses} vs {want_pulses}, state {x} vs {}",
            want_x.join(",")
        );
        Ok(c)
    }

    /// One timed run of the C loop: ticks/s.
    fn run(&self) -> Result<f64> {
        Ok(self.run_once()?.0)
    }

    /// One run: ticks/s, pulses over the gate, the final plant state's bits.
    fn run_once(&self) -> Result<(f64, u64, String)> {
        use std::io::Write as _;
        let mut child = std::process::Command::new(&self.exe)
            .args([self.settle.to_string(), self.ticks.to_string(), "1".into()])
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .spawn()
            .context("running the C loop")?;
        child
            .stdin
            .take()
            .context("C loop stdin")?
            .write_all(self.params.as_bytes())?;
        let out = child.wait_with_output()?;
        anyhow::ensure!(out.status.success(), "the C loop failed");
        let text = String::from_utf8_lossy(&out.stdout);
        let field = |name: &str| {
            text.split_whitespace()
                .find_map(|w| w.strip_prefix(name))
                .map(str::to_owned)
                .with_context(|| format!("C loop output without {name}: {text}"))
        };
        let rate: f64 = field("rate=")?.parse()?;
        let pulses: u64 = field("pulses=")?.parse()?;
        Ok((rate, pulses, field("x=")?))
    }
}
