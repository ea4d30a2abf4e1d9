//! `ptsa`: the host simulator's command line. Units: accelerations in cm/s², rates in
//! rad/s, angles in mrad or degrees as named, times in seconds.

use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use ptsa_host_sim::experiments::{self, report};
use ptsa_host_sim::fixtures::TwoAxisKind;
use ptsa_host_sim::output::{Output, write_atomic};
use ptsa_host_sim::sim::run_static;
use ptsa_host_sim::{Effects, Instrument, SimOptions, design::Design};

/// Closed-loop simulator of the Kearfott 2401 accelerometer in the UAC PTSA forced-binary
/// loop (Draper report R-890), built on ptsa-core, the firmware's own loop code.
///
/// Without a subcommand, runs the report's whole test programme on the instrument file and
/// writes a report folder (tables, CSV, PNG and SVG plots, summary.md). Units: cm/s² for
/// accelerations, rad/s for rates, mrad for oscillation amplitudes, Hz, seconds.
#[derive(Parser, Debug)]
#[command(name = "ptsa", version, about)]
struct Cli {
    /// Instrument file (TOML, Table 2.1 with tolerances); default: the shipped
    /// data/kearfott-2401.toml (compiled in).
    #[arg(long, global = true, value_name = "FILE")]
    instrument: Option<PathBuf>,
    /// Seed of the pickoff noise.
    #[arg(long, global = true, default_value_t = 1)]
    seed: u64,
    /// Output folder for CSV and plots.
    #[arg(long, global = true, default_value = "report", value_name = "DIR")]
    out: PathBuf,
    /// Settling time before each measurement window, s.
    #[arg(long, global = true, default_value_t = 0.1, value_name = "S")]
    warmup_s: f64,
    /// Shortest measurement window, s (dynamic conditions: whole periods).
    #[arg(long, global = true, default_value_t = 0.1, value_name = "S")]
    window_s: f64,
    #[command(subcommand)]
    cmd: Option<Cmd>,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Section 6.1: ±1 g counts P1, P2 over a gate T; SF and A_b by eqs. 6.3/6.4.
    Tumble {
        /// Counting gate, s.
        #[arg(long, default_value_t = 1.0, value_name = "S")]
        gate_s: f64,
    },
    /// Table 6.1: 8 IA positions on the rate table at 1.0 and 0.05 rad/s (eq. 6.5).
    Anisoinertia {
        /// Anisoinertia I_PA − I_IA of the simulated instrument, g·cm² (report: 3.4).
        #[arg(long, default_value_t = report::ANISOINERTIA_G_CM2, value_name = "G_CM2")]
        anisoinertia_g_cm2: f64,
        /// CG offset from the table axis along PA, cm (0 in the report's revised set-up).
        #[arg(long, default_value_t = 0.0, value_name = "CM")]
        lever_pa_cm: f64,
    },
    /// Tables 6.2/6.3: angular oscillation about OA, IA horizontal and vertical.
    OaCoupling {
        /// Proof-mass offset from the table axis along IA, PA, OA, cm.
        #[arg(long, num_args = 3, default_values_t = [0.0, 0.0, 0.0], value_name = "CM")]
        lever_cm: Vec<f64>,
    },
    /// Appendix A.1 (Fig. A.2): IA and PA vibration on the two-axis oscillator, phase sweep.
    Vibropendulosity(TwoAxisArgs),
    /// Appendix A.2 (Fig. A.4): IA and OA vibration, phase sweep.
    Anisoelasticity(TwoAxisArgs),
    /// Appendix A.3 (Fig. A.5): OA angular oscillation with PA vibration, phase sweep.
    Sculling(TwoAxisArgs),
    /// Fig. 3.2 waveforms (torquer current, pulse train) and the small-signal frequency
    /// response measured by simulation.
    Waveform {
        /// Constant acceleration along IA, cm/s².
        #[arg(long, default_value_t = 5000.0, value_name = "CM_S2")]
        accel_cm_s2: f64,
        /// Limit cycles to trace.
        #[arg(long, default_value_t = 4)]
        cycles: u64,
    },
    /// The plain closed loop with a constant acceleration along IA (Table 2.1 instrument
    /// with its pickoff noise; the measured bias A_b only with --with-bias): after 0.1 s of
    /// settling, one gate of S seconds; prints P, T and SF·(2P/T − 1) with the configured SF.
    Static {
        /// Acceleration along IA, cm/s².
        #[arg(long, allow_hyphen_values = true, value_name = "CM_S2")]
        accel_cm_s2: f64,
        /// Gate length, s.
        #[arg(long, default_value_t = 1.0, value_name = "S")]
        seconds: f64,
        /// Print exactly one JSON object {"ticks": T, "pulses": P, "indicated_cm_s2": x}.
        #[arg(long)]
        json: bool,
        /// Write the ADC samples of the run (one i16 per line, golden-vector style) here.
        #[arg(long, value_name = "FILE")]
        trace: Option<PathBuf>,
        /// Include the instrument file's bias A_b (18.7 cm/s² shipped) as a torque.
        #[arg(long)]
        with_bias: bool,
    },
    /// Print the compensator design (and the ptsa-core constants).
    Design {
        /// Print the four DEFAULT_*_BITS constants of ptsa-core/src/config.rs.
        #[arg(long)]
        print_core_constants: bool,
    },
    /// Monte Carlo over the Table 2.1 tolerance box: stability margins at every corner.
    MonteCarlo {
        /// Random corners when the box has more than 14 parameters.
        #[arg(long, default_value_t = 1024)]
        samples: usize,
    },
    /// Speed of the closed loop: ticks per second of `static` on one core, median of runs.
    Bench {
        /// Ticks per run.
        #[arg(long, default_value_t = 64_000_000)]
        ticks: u64,
        /// Runs.
        #[arg(long, default_value_t = 5)]
        runs: usize,
        /// Without pickoff noise.
        #[arg(long)]
        no_noise: bool,
        /// Also build the plain C loop (ptsa-host-sim/benches/c_static/static_loop.c) with
        /// the system C compiler (`$CC`, default `cc`, `-std=c11 -O2`), check that it gives
        /// the same pulses and plant state bit for bit, and time it in alternation.
        #[arg(long)]
        compare_c: bool,
    },
    /// The whole report programme (same as no subcommand).
    Report,
    /// Discovery: what the simulation gets wrong in measured data, the effect that explains it, and the gain of the extended model.
    Discover(ptsa_host_sim::discovery::DiscoverArgs),
}

/// Options of the Appendix A set-ups.
#[derive(clap::Args, Debug, Clone)]
struct TwoAxisArgs {
    /// Oscillation frequency, Hz.
    #[arg(long, default_value_t = 100.0, value_name = "HZ")]
    freq_hz: f64,
    /// Y-axis amplitude θ_my, mrad.
    #[arg(long, default_value_t = 1.0, value_name = "MRAD")]
    theta_my_mrad: f64,
    /// Z-axis amplitude θ_mz, mrad.
    #[arg(long, default_value_t = 1.0, value_name = "MRAD")]
    theta_mz_mrad: f64,
    /// Radius of the proof mass from the oscillator axes, cm.
    #[arg(long, default_value_t = 10.0, value_name = "CM")]
    r_cm: f64,
    /// Injected anisoelastic coefficient k_io, s²/cm (the model has none by itself).
    #[arg(long, default_value_t = 0.0, value_name = "S2_CM")]
    k_io_s2_cm: f64,
    /// Injected vibropendulous coefficient k_ip, s²/cm.
    #[arg(long, default_value_t = 0.0, value_name = "S2_CM")]
    k_ip_s2_cm: f64,
    /// Injected sculling coefficient k_sc, s².
    #[arg(long, default_value_t = 0.0, value_name = "S2")]
    k_sc_s2: f64,
}

impl TwoAxisArgs {
    fn effects(&self) -> Effects {
        Effects {
            k_io_s2_cm: self.k_io_s2_cm,
            k_ip_s2_cm: self.k_ip_s2_cm,
            k_sc_s2: self.k_sc_s2,
            ..Effects::default()
        }
    }
}

fn progress(n: u64) -> ProgressBar {
    let pb = ProgressBar::new(n);
    if std::io::stderr().is_terminal() {
        pb.set_style(
            ProgressStyle::with_template("{bar:40} {pos}/{len} {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
    } else {
        pb.set_draw_target(ProgressDrawTarget::hidden());
    }
    pb
}

fn emit(out: &Output, dir: &Path) -> Result<()> {
    out.emit(dir, true)?;
    Ok(())
}

fn main() -> std::process::ExitCode {
    match run(Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

#[allow(clippy::too_many_lines)]
fn run(cli: Cli) -> Result<()> {
    let instr = match &cli.instrument {
        Some(p) => Instrument::load(p)?,
        None => Instrument::kearfott_2401(),
    };
    let opts = SimOptions {
        seed: cli.seed,
        warmup_s: cli.warmup_s,
        min_window_s: cli.window_s,
        ..SimOptions::default()
    };
    let dir = cli.out.clone();
    match cli.cmd {
        None | Some(Cmd::Report) => {
            report_programme(&instr, &opts, &dir, cli.instrument.as_deref())?
        }
        Some(Cmd::Tumble { gate_s }) => emit(&experiments::tumble(&instr, &opts, gate_s).1, &dir)?,
        Some(Cmd::Anisoinertia {
            anisoinertia_g_cm2,
            lever_pa_cm,
        }) => {
            emit(
                &experiments::anisoinertia(
                    &instr,
                    &opts,
                    anisoinertia_g_cm2,
                    [0.0, lever_pa_cm, 0.0],
                )
                .2,
                &dir,
            )?;
        }
        Some(Cmd::OaCoupling { lever_cm }) => {
            let l = [lever_cm[0], lever_cm[1], lever_cm[2]];
            emit(&experiments::oa_coupling(&instr, &opts, l).1, &dir)?;
        }
        Some(Cmd::Vibropendulosity(a)) => emit(
            &two_axis(&instr, &opts, TwoAxisKind::Vibropendulous, &a),
            &dir,
        )?,
        Some(Cmd::Anisoelasticity(a)) => emit(
            &two_axis(&instr, &opts, TwoAxisKind::Anisoelastic, &a),
            &dir,
        )?,
        Some(Cmd::Sculling(a)) => emit(&two_axis(&instr, &opts, TwoAxisKind::Sculling, &a), &dir)?,
        Some(Cmd::Waveform {
            accel_cm_s2,
            cycles,
        }) => emit(
            &experiments::waveform(&instr, &opts, accel_cm_s2, cycles),
            &dir,
        )?,
        Some(Cmd::Static {
            accel_cm_s2,
            seconds,
            json,
            trace,
            with_bias,
        }) => {
            anyhow::ensure!(
                seconds > 0.0 && seconds.is_finite(),
                "--seconds must be > 0"
            );
            let mut instr = instr.clone();
            if !with_bias {
                instr.bias_cm_s2 = 0.0;
            }
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let ticks = (seconds * instr.clock_hz).round().max(1.0) as u64;
            if let Some(path) = trace {
                write_trace(&instr, &opts, accel_cm_s2, ticks, &path)?;
            }
            let r = run_static(&instr, accel_cm_s2, ticks, &opts);
            if json {
                println!("{}", serde_json::to_string(&r)?);
            } else {
                println!(
                    "static: {accel_cm_s2} cm/s^2 along IA (bias {} cm/s^2, loop's own {:.5}): T = {} ticks, P = {} pulses, indicated SF(2P/T - 1) = {:.4} cm/s^2",
                    instr.bias_cm_s2,
                    instr.loop_bias_cm_s2(0.0),
                    r.ticks,
                    r.pulses,
                    r.indicated_cm_s2
                );
            }
        }
        Some(Cmd::Design {
            print_core_constants,
        }) => {
            let d = Design::for_instrument(&instr);
            if print_core_constants {
                print!("{}", d.core_constants());
            } else {
                print!("{}", experiments::design_text(&instr));
                println!("\n// ptsa-core/src/config.rs\n{}", d.core_constants());
            }
        }
        Some(Cmd::MonteCarlo { samples }) => {
            emit(&experiments::monte_carlo(&instr, &opts, samples).2, &dir)?
        }
        Some(Cmd::Bench {
            ticks,
            runs,
            no_noise,
            compare_c,
        }) => bench(&instr, &opts, ticks, runs, no_noise, compare_c)?,
        Some(Cmd::Discover(args)) => {
            if args.analytic {
                ptsa_host_sim::discovery::run(&args)?;
            } else {
                // The closed loop of the instrument file and run options given to `ptsa`.
                let sim = ptsa_host_sim::discovery::sim::ClosedLoopSimulator {
                    instrument: instr.clone(),
                    options: SimOptions {
                        seed: args.seed,
                        ..opts
                    },
                };
                ptsa_host_sim::discovery::run_with(&args, &sim)?;
            }
        }
    }
    Ok(())
}

fn two_axis(instr: &Instrument, opts: &SimOptions, kind: TwoAxisKind, a: &TwoAxisArgs) -> Output {
    experiments::appendix_a(
        instr,
        opts,
        kind,
        a.freq_hz,
        a.theta_my_mrad,
        a.theta_mz_mrad,
        a.r_cm,
        &a.effects(),
    )
}

fn write_trace(
    instr: &Instrument,
    opts: &SimOptions,
    accel: f64,
    ticks: u64,
    path: &Path,
) -> Result<()> {
    use std::fmt::Write as _;
    let cond = ptsa_host_sim::Condition {
        g: [accel / instr.g_cm_s2, 0.0, 0.0],
        ..Default::default()
    };
    let mut l = ptsa_host_sim::sim::ClosedLoop::new(instr, &cond, &Effects::default(), opts);
    let mut s = format!(
        "# closed-loop pickoff samples: {accel} cm/s^2 along IA, seed {}, from reset\n",
        opts.seed
    );
    l.run_observed(ticks, |v| {
        let _ = writeln!(s, "{}", v.code);
    });
    write_atomic(path, s.as_bytes()).with_context(|| format!("writing {}", path.display()))
}

/// The plain C loop of `bench --compare-c`.
const C_STATIC_LOOP: &str = include_str!("../benches/c_static/static_loop.c");

/// `ptsa bench`: `run_static` timed `runs` times (and, with `compare_c`, the C loop after
/// each Rust run); prints the medians and, for C, the ratio.
fn bench(
    instr: &Instrument,
    opts: &SimOptions,
    ticks: u64,
    runs: usize,
    no_noise: bool,
    compare_c: bool,
) -> Result<()> {
    const ACCEL: f64 = 980.4;
    let settle = ptsa_host_sim::sim::STATIC_SETTLE_TICKS;
    let opts = SimOptions {
        noise: opts.noise && !no_noise,
        ..*opts
    };
    let c_loop = if compare_c {
        Some(CStaticLoop::build(instr, &opts, ACCEL, ticks)?)
    } else {
        None
    };
    let mut rates = Vec::new();
    let mut c_rates = Vec::new();
    for _ in 0..runs.max(1) {
        let t = Instant::now();
        let r = run_static(instr, ACCEL, ticks, &opts);
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
    println!(
        "bench: static closed loop{}, {ticks} ticks x {} runs: median {med:.4e} ticks/s ({:.0}x real time at {} Hz), min {lo:.4e}, max {hi:.4e}",
        if opts.noise { "" } else { " without noise" },
        rates.len(),
        med / instr.clock_hz,
        instr.clock_hz,
    );
    if c_loop.is_some() {
        let (c_med, c_lo, c_hi) = median(&mut c_rates);
        println!(
            "bench: plain C loop (cc -std=c11 -O2), same ticks, alternating: median {c_med:.4e} ticks/s, min {c_lo:.4e}, max {c_hi:.4e}; same pulses and plant state bit for bit"
        );
        println!("bench: Rust / C = {:.3}", med / c_med);
    }
    Ok(())
}

/// The plain C loop, compiled into a temporary folder, with its parameters.
struct CStaticLoop {
    dir: PathBuf,
    exe: PathBuf,
    params: String,
    ticks: u64,
}

impl CStaticLoop {
    /// Compile the C loop and check it once against the Rust loop (pulses and plant state).
    fn build(instr: &Instrument, opts: &SimOptions, accel: f64, ticks: u64) -> Result<Self> {
        use ptsa_host_sim::sim::{ClosedLoop, STATIC_SETTLE_TICKS};
        let dir = std::env::temp_dir().join(format!("ptsa-c-static-{}", std::process::id()));
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        let src = dir.join("static_loop.c");
        let exe = dir.join("static_loop");
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
        let cond = ptsa_host_sim::Condition {
            label: "static".into(),
            g: [accel / ptsa_host_sim::condition::G_CM_S2, 0.0, 0.0],
            ..Default::default()
        };
        let mut l = ClosedLoop::new(instr, &cond, &Effects::default(), opts);
        let params = l
            .c_static_params()
            .context("no C parameters for this loop")?;
        let c = Self {
            dir,
            exe,
            params,
            ticks,
        };
        // The check: the same pulses over the gate and the same final plant state.
        let (_, pulses, x) = c.run_once()?;
        l.run_fast(STATIC_SETTLE_TICKS);
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
            .args([
                ptsa_host_sim::sim::STATIC_SETTLE_TICKS.to_string(),
                self.ticks.to_string(),
                "1".into(),
            ])
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

impl Drop for CStaticLoop {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The whole programme: every experiment, into `dir`, and `summary.md`.
#[allow(clippy::too_many_lines)]
fn report_programme(
    instr: &Instrument,
    opts: &SimOptions,
    dir: &Path,
    file: Option<&Path>,
) -> Result<()> {
    let t0 = Instant::now();
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let pb = progress(10);
    let mut timings: Vec<(String, f64)> = Vec::new();
    let mut last = Instant::now();
    let mut step = |pb: &ProgressBar, m: &str| {
        let now = Instant::now();
        if let Some(msg) = Some(pb.message()).filter(|s| !s.is_empty()) {
            timings.push((msg, (now - last).as_secs_f64()));
        }
        last = now;
        pb.set_message(m.to_string());
    };
    step(&pb, "tumble");
    let (tumble, o_t) = experiments::tumble(instr, opts, 1.0);
    o_t.emit(dir, true)?;
    pb.inc(1);
    step(&pb, "anisoinertia");
    let (aniso, k_sim, o_a) =
        experiments::anisoinertia(instr, opts, report::ANISOINERTIA_G_CM2, [0.0; 3]);
    o_a.emit(dir, true)?;
    pb.inc(1);
    step(&pb, "oa-coupling");
    let (oa, o_o) = experiments::oa_coupling(instr, opts, [0.0; 3]);
    o_o.emit(dir, true)?;
    pb.inc(1);
    let ta = TwoAxisArgs {
        freq_hz: 100.0,
        theta_my_mrad: 1.0,
        theta_mz_mrad: 1.0,
        r_cm: 10.0,
        k_io_s2_cm: 0.0,
        k_ip_s2_cm: 0.0,
        k_sc_s2: 0.0,
    };
    let mut appendix = Vec::new();
    for kind in [
        TwoAxisKind::Vibropendulous,
        TwoAxisKind::Anisoelastic,
        TwoAxisKind::Sculling,
    ] {
        step(&pb, &format!("{kind:?}"));
        let o = two_axis(instr, opts, kind, &ta);
        o.emit(dir, true)?;
        appendix.extend(o.notes.clone());
        pb.inc(1);
    }
    step(&pb, "waveform");
    let o_w = experiments::waveform(instr, opts, 5000.0, 4);
    o_w.emit(dir, true)?;
    pb.inc(1);
    step(&pb, "monte carlo");
    let (pm, gm, o_m) = experiments::monte_carlo(instr, opts, 1024);
    o_m.emit(dir, true)?;
    pb.inc(1);
    step(&pb, "discovery");
    let discovery = {
        let sim = ptsa_host_sim::discovery::sim::ClosedLoopSimulator {
            instrument: instr.clone(),
            options: *opts,
        };
        ptsa_host_sim::discovery::show::report_section(
            &sim,
            &ptsa_host_sim::discovery::Options::default(),
            Some(&dir.join("discover")),
        )
    };
    pb.inc(1);
    step(&pb, "design");
    let design = experiments::design_text(instr);
    write_atomic(&dir.join("design.txt"), design.as_bytes())?;
    pb.inc(1);
    step(&pb, "");
    pb.finish_and_clear();
    let wall = t0.elapsed().as_secs_f64();

    // Summary.
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# PTSA / Kearfott 2401 host simulation: the R-890 test programme\n"
    );
    let _ = writeln!(
        s,
        "Instrument file: `{}`; seed {}; {} threads; wall time {wall:.2} s. Every figure is reproduced by `ptsa` (this report) or the subcommand named. Details: `docs/host-sim.md`.\n",
        file.map_or_else(
            || "data/kearfott-2401.toml (built in)".to_string(),
            |p| p.display().to_string()
        ),
        opts.seed,
        rayon::current_num_threads()
    );
    let _ = writeln!(s, "## Scale factor and bias (section 6.1, `ptsa tumble`)\n");
    let _ = writeln!(
        s,
        "| quantity | simulated (charge balance) | simulated (1 s counts) | configured | report |\n|---|---|---|---|---|"
    );
    let _ = writeln!(
        s,
        "| SF, cm/s² | {:.4} | {:.2} | {:.4} | {} |",
        tumble.sf,
        tumble.sf_count,
        tumble.sf_configured,
        report::SF_CM_S2
    );
    let _ = writeln!(
        s,
        "| A_b, cm/s² | {:.4} | {:.3} | {:.4} | {} |\n",
        tumble.bias,
        tumble.bias_count,
        tumble.bias_configured,
        report::BIAS_CM_S2
    );
    let _ = writeln!(
        s,
        "The instrument file sets the full scale to the report's SF (torquer current {:.4} mA) and the bias to the report's A_b, so the tumble checks that the loop and eqs. 6.3/6.4 give back what was configured: SF error {:.3} ppm, bias error {:.5} cm/s². Note: eq. 6.2 as printed has a sign typo; with IA down the count gives SF(2P2/T − 1) = −g + A_b, i.e. SF(1 − 2P2/T) = g − A_b; eqs. 6.3 and 6.4 are right as printed.\n",
        instr.full_current_ma,
        (tumble.sf / tumble.sf_configured - 1.0) * 1e6,
        tumble.bias - tumble.bias_configured
    );
    let _ = writeln!(s, "## Anisoinertia (Table 6.1, `ptsa anisoinertia`)\n");
    let _ = writeln!(
        s,
        "Simulated with I_PA − I_IA = {} g·cm² (the report's result) and with the baseline (0).\n",
        report::ANISOINERTIA_G_CM2
    );
    let _ = writeln!(
        s,
        "| IA deg | report cm/s² | simulated cm/s² | baseline cm/s² |\n|---|---|---|---|"
    );
    for r in &aniso {
        let _ = writeln!(
            s,
            "| {:.0} | {:.2} | {:.3} | {:.3} |",
            r.ia_deg, r.report, r.simulated, r.baseline
        );
    }
    let _ = writeln!(
        s,
        "\nCoefficient from the simulated table as the report derives it: {k_sim:.3} cm (report: {} cm).\n",
        report::K_AI_CM
    );
    let _ = writeln!(
        s,
        "## OA coupling (Tables 6.2 and 6.3, `ptsa oa-coupling`)\n"
    );
    let _ = writeln!(
        s,
        "| IA | Hz | mrad | report static−dynamic cm/s² | simulated static−dynamic cm/s² |\n|---|---|---|---|---|"
    );
    for r in &oa {
        let f =
            |x: Option<f64>, d: usize| x.map_or_else(|| "—".to_string(), |x| format!("{x:.d$}"));
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} |",
            if r.ia_vertical {
                "vertical"
            } else {
                "horizontal"
            },
            r.freq_hz,
            f(r.amp_mrad, 1),
            f(r.report, 2),
            f(r.simulated, 4)
        );
    }
    let _ = writeln!(
        s,
        "\nThe simulated loop shows no rectified OA coupling (eq. 4.6 averages to zero), as the report concluded; the report's scatter is its 0.3 cm/s² test uncertainty.\n"
    );
    let _ = writeln!(
        s,
        "## Appendix A (`ptsa vibropendulosity`, `anisoelasticity`, `sculling`)\n"
    );
    for n in &appendix {
        let _ = writeln!(s, "* {n}");
    }
    let _ = writeln!(
        s,
        "\n## Loop (`ptsa waveform`, `ptsa monte-carlo`, `ptsa design`)\n"
    );
    for n in o_w.notes.iter().chain(&o_m.notes) {
        let _ = writeln!(s, "* {n}");
    }
    let _ = writeln!(
        s,
        "* Monte Carlo worst case: phase margin {pm:.2} deg, gain margin {gm:.2} dB.\n"
    );
    match discovery {
        Ok(text) => {
            let _ = writeln!(s, "{text}");
        }
        Err(e) => {
            let _ = writeln!(s, "## Discovery\n\nNot available: {e:#}\n");
        }
    }
    let _ = writeln!(
        s,
        "## Timing\n\n{}\n",
        timings
            .iter()
            .map(|(n, t)| format!("{n} {t:.2} s"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let _ = writeln!(
        s,
        "## Files\n\nCSV tables and PNG/SVG plots beside this file: tumble, anisoinertia, oa-coupling (-2), vibropendulosity, anisoelasticity, sculling, waveform (-2), monte-carlo (-2), design.txt, discover/."
    );
    write_atomic(&dir.join("summary.md"), s.as_bytes())?;
    println!("report written to {} in {wall:.2} s", dir.display());
    Ok(())
}
