//! `ptsa`: the host simulator's command line. This file is the dispatcher: it loads and
//! checks the instrument file, turns the validated options of [`flags`] into the library's
//! requests, runs them and prints; the work itself lives in the `ptsa_host_sim` library.
//! A closed stdout (`ptsa | head -1`) is not an error: the output is dropped and the run
//! finishes (so a report folder is still written whole).

mod flags;
mod paths;
mod signals;
mod work;

use std::ffi::OsString;
use std::io::Write;
use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use clap::error::ErrorKind;
use clap::parser::ValueSource;
use clap::{CommandFactory as _, FromArgMatches as _};
use flags::{
    Cli, Cmd, DiscoverArgs, OutArgs, PlanArgs, PlanKind, PredictArgs, ReportArgs, ResponseArgs,
    RunArgs, TwoAxisArgs, num,
};
use ptsa_host_sim::bench::{BenchPlan, bench, bench_batch};
use ptsa_host_sim::discovery::{self, InstrumentOut, Options, Request, Simulator};
use ptsa_host_sim::lab::fixtures::TwoAxisKind;
use ptsa_host_sim::model::design::{Design, check_loop};
use ptsa_host_sim::model::effects::{CandidateId, Effects};
use ptsa_host_sim::output::Output;
use ptsa_host_sim::output::fs::{persist, temp_beside};
use ptsa_host_sim::report::experiments::{
    anisoinertia, appendix_a, design, frequency_response, limit_cycle, monte_carlo, oa_coupling,
    tumble, waveform,
};
use ptsa_host_sim::simulation::sim::{SimOptions, run_static_with};
use ptsa_host_sim::{Instrument, report};
use work::Work;

fn main() -> ExitCode {
    signals::clean_up_on_signals();
    let cli = parse_cli();
    let mut out = Stdout::default();
    let result = run(cli, &mut out);
    let _ = out.flush();
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!(
                "error: {}",
                paths::without_os_error_numbers(&format!("{e:#}"))
            );
            ExitCode::FAILURE
        }
    }
}

/// The command line, with two refusals clap cannot express: a report option before a
/// subcommand (`ptsa --window-s 5 tumble`, which would be ignored) and, made possible, a
/// negative number clap takes for short flags (`-1e-5`, `-.5`: see [`join_negative_numbers`]).
fn parse_cli() -> Cli {
    let mut cmd = Cli::command();
    let matches = cmd
        .try_get_matches_from_mut(join_negative_numbers(&Cli::command(), std::env::args_os()))
        .unwrap_or_else(|e| e.exit());
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.format(&mut cmd).exit());
    if let Some(sub) = matches.subcommand_name() {
        for (id, flag) in [
            ("seed", "--seed"),
            ("warmup_s", "--warmup-s"),
            ("window_s", "--window-s"),
            ("force", "--force"),
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

/// Standard output that turns a closed pipe into silence: once a write fails with
/// `BrokenPipe`, everything after it is dropped, and nothing is reported as an error.
#[derive(Default)]
struct Stdout {
    closed: bool,
}

impl Write for Stdout {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.closed {
            return Ok(buf.len());
        }
        match std::io::stdout().lock().write_all(buf) {
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
                self.closed = true;
                Ok(buf.len())
            }
            Err(e) => Err(e),
            Ok(()) => Ok(buf.len()),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        if self.closed {
            return Ok(());
        }
        match std::io::stdout().lock().flush() {
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
                self.closed = true;
                Ok(())
            }
            r => r,
        }
    }
}

/// The files the command line names as inputs, by their flags: no output may replace them.
fn inputs(cli: &Cli) -> Vec<(&'static str, Option<&Path>)> {
    let mut v = vec![("--instrument", cli.instrument.as_deref())];
    match &cli.cmd {
        Some(Cmd::Discover(a)) => v.push(("--data", a.data.as_deref())),
        Some(Cmd::Predict(a)) => {
            v.push(("--data", Some(&a.data)));
            v.push(("--effects", a.effects.as_deref()));
        }
        Some(Cmd::Response(a)) => v.push(("--counts", Some(&a.counts))),
        _ => {}
    }
    v
}

/// The instrument file (or the shipped one), its name for messages and its text.
fn load_instrument(path: Option<&Path>) -> Result<(Instrument, String, String)> {
    Ok(match path {
        Some(p) => {
            let i = Instrument::load(p)?;
            // Read again for `--write-instrument` (load has validated it as UTF-8).
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("{}: cannot read", p.display()))?;
            (i, p.display().to_string(), text)
        }
        None => (
            Instrument::kearfott_2401(),
            "data/kearfott-2401.toml (the shipped file, built in)".to_string(),
            ptsa_host_sim::model::instrument::KEARFOTT_2401_TOML.to_string(),
        ),
    })
}

#[allow(clippy::too_many_lines)] // one match arm per subcommand
fn run(cli: Cli, out: &mut dyn Write) -> Result<()> {
    paths::inputs(inputs(&cli));
    let (instr, name, instr_text) = load_instrument(cli.instrument.as_deref())?;
    let checked = check_loop(&instr);
    if let Some(Cmd::Design {
        print_core_constants,
    }) = &cli.cmd
    {
        return design_cmd(&instr, &name, *print_core_constants, checked.as_ref(), out);
    }
    // The reduction of a record simulates nothing: it needs the file's SF and clock only.
    if let Some(Cmd::Response(a)) = &cli.cmd {
        return response_cmd(&instr, a, out);
    }
    let config = checked.map_err(|e| anyhow::anyhow!("{name}: {e}"))?.config;
    let opts = |r: &RunArgs| SimOptions {
        config,
        ..r.options()
    };
    let Some(cmd) = cli.cmd else {
        return report_cmd(&instr, &name, &cli.report, config, out);
    };
    match cmd {
        Cmd::Report(a) => report_cmd(&instr, &name, &a, config, out),
        Cmd::Tumble {
            gate_s,
            run,
            out: o,
        } => {
            let opts = opts(&run);
            gate_fits("--gate-s", gate_s, &instr, &opts)?;
            paths::folder("--out", &o.out)?;
            let est = Work::new(&instr, &opts)
                .ticks(tumble::work(&instr, &opts, gate_s))
                .check(run.force, "the tumble")?;
            let p = work::Progress::start("tumble", &est);
            let r = tumble::run(&instr, &opts, gate_s)?;
            p.finish();
            emit(&r.output, &o, out)
        }
        Cmd::Anisoinertia {
            anisoinertia_g_cm2,
            lever_pa_cm,
            run,
            out: o,
        } => {
            let opts = opts(&run);
            paths::folder("--out", &o.out)?;
            let lever = [0.0, lever_pa_cm, 0.0];
            let est = Work::new(&instr, &opts)
                .ticks(anisoinertia::work(&instr, &opts, lever)?)
                .check(run.force, "Table 6.1")?;
            let p = work::Progress::start("Table 6.1", &est);
            let r = anisoinertia::run(&instr, &opts, anisoinertia_g_cm2, lever)?;
            p.finish();
            emit(&r.output, &o, out)
        }
        Cmd::OaCoupling {
            lever_cm,
            run,
            out: o,
        } => {
            let opts = opts(&run);
            paths::folder("--out", &o.out)?;
            let l = [lever_cm[0], lever_cm[1], lever_cm[2]];
            let est = Work::new(&instr, &opts)
                .ticks(oa_coupling::work(&instr, &opts, l)?)
                .check(run.force, "Tables 6.2 and 6.3")?;
            let p = work::Progress::start("Tables 6.2 and 6.3", &est);
            let r = oa_coupling::run(&instr, &opts, l)?;
            p.finish();
            emit(&r.output, &o, out)
        }
        Cmd::Vibropendulosity(a) => two_axis(&instr, config, TwoAxisKind::Vibropendulous, &a, out),
        Cmd::Anisoelasticity(a) => two_axis(&instr, config, TwoAxisKind::Anisoelastic, &a, out),
        Cmd::Sculling(a) => two_axis(&instr, config, TwoAxisKind::Sculling, &a, out),
        Cmd::Waveform {
            accel_cm_s2,
            cycles,
            run,
            out: o,
        } => {
            let opts = SimOptions {
                config,
                ..run.options()
            };
            let per_cycle = u64::from(opts.config.ticks_per_cycle);
            let Some(ticks) = cycles.checked_mul(per_cycle) else {
                bail!(
                    "--cycles {cycles}: expected at most {} limit cycles ({per_cycle} ticks each, counted in 64 bits)",
                    u64::MAX / per_cycle
                );
            };
            if cycles > work::MAX_TRACE_CYCLES && !run.force {
                bail!(
                    "--cycles {cycles}: the trace has one row per clock tick ({ticks} rows); expected at most {} cycles without --force",
                    work::MAX_TRACE_CYCLES
                );
            }
            paths::folder("--out", &o.out)?;
            work::warn_beyond_full_scale(&instr, accel_cm_s2, "--accel-cm-s2");
            // The trace after its settling, then the frequency response (11 frequencies)
            // and the limit-cycle sweep (11 inputs), each a settling and a 1 s window.
            #[allow(clippy::cast_precision_loss)]
            let est = Work::new(&instr, &opts)
                .ticks(
                    waveform::work(&instr, &opts, cycles)
                        + frequency_response::work(&instr, &opts)
                        + limit_cycle::work(&instr, &opts),
                )
                .seconds(waveform::TRACE_S_PER_TICK * ticks as f64)
                .check(run.force, "the waveform")?;
            let p = work::Progress::start("waveform, frequency response, limit cycle", &est);
            let mut all = waveform::run(&instr, &opts, accel_cm_s2, cycles, &o.out)?;
            all.extend(frequency_response::run(&instr, &opts)?.output);
            all.extend(limit_cycle::run(&instr, &opts)?.output);
            p.finish();
            // The trace's CSV was streamed into the folder by `waveform::run`.
            emit_counting(&all, &o, 1, out)
        }
        Cmd::Static {
            accel_cm_s2,
            seconds,
            json,
            trace,
            with_bias,
            force,
            seed,
            warmup_s,
        } => {
            let opts = SimOptions {
                seed,
                warmup_s,
                config,
                ..SimOptions::default()
            };
            if let [_, _, ..] = accel_cm_s2[..] {
                if trace.is_some() {
                    bail!(
                        "--trace writes the ADC samples of one run; expected one --accel-cm-s2 value with it, not {}",
                        accel_cm_s2.len()
                    );
                }
                return static_batch_cmd(
                    &instr,
                    &opts,
                    &accel_cm_s2,
                    seconds,
                    json,
                    with_bias,
                    force,
                    out,
                );
            }
            if let Some(t) = &trace {
                paths::output_file("--trace", t, force)?;
            }
            static_cmd(
                &instr,
                &opts,
                accel_cm_s2[0],
                seconds,
                json,
                trace.as_deref(),
                with_bias,
                force,
                out,
            )
        }
        Cmd::Design { .. } | Cmd::Response(_) => unreachable!("handled above"),
        Cmd::MonteCarlo {
            samples,
            run,
            out: o,
        } => {
            let opts = opts(&run);
            let n = instr.tolerances.len();
            if let Some(k) = samples
                && n <= monte_carlo::MAX_EXHAUSTIVE
            {
                eprintln!(
                    "warning: --samples {k} is not used: the tolerance box has {n} parameters, so all {} of its corners are checked (random corners only beyond {} parameters)",
                    1u64 << n,
                    monte_carlo::MAX_EXHAUSTIVE
                );
            }
            paths::folder("--out", &o.out)?;
            let samples = samples.unwrap_or(monte_carlo::DEFAULT_SAMPLES);
            #[allow(clippy::cast_precision_loss)]
            let est = Work::new(&instr, &opts)
                .ticks(monte_carlo::work(&instr, &opts, samples))
                .seconds(
                    work::MARGINS_S_PER_CORNER * monte_carlo::corners(&instr, samples) as f64
                        / ptsa_host_sim::simulation::work::cores(),
                )
                .check(run.force, "the Monte Carlo")?;
            let p = work::Progress::start("monte carlo", &est);
            let r = monte_carlo::run(&instr, &opts, samples)?;
            p.finish();
            emit(&r.output, &o, out)
        }
        Cmd::Bench {
            ticks,
            runs,
            no_noise,
            compare_c,
            batch,
            lanes,
            force,
            seed,
        } => {
            let opts = SimOptions {
                seed,
                config,
                ..SimOptions::default()
            };
            let default_ticks = BenchPlan::TICKS / batch.unwrap_or(1) as u64;
            let ticks = ticks.unwrap_or(default_ticks);
            // Each run settles and then runs its ticks, twice with the C loop, and with
            // --batch N twice (single and batch) for each of N conditions; counted in
            // floating point so that no product of the options can overflow.
            #[allow(clippy::cast_precision_loss)]
            let per = match batch {
                Some(n) => 2.0 * n as f64,
                None if compare_c => 2.0,
                None => 1.0,
            };
            #[allow(clippy::cast_precision_loss)]
            let run_s = (ticks as f64 / instr.clock_hz + opts.warmup_s) * per;
            #[allow(clippy::cast_precision_loss)]
            Work::new(&instr, &opts)
                .ticks(ptsa_host_sim::simulation::work::Ticks::of(
                    run_s * instr.clock_hz,
                    false,
                ))
                .times(runs as f64)
                .check(force, "the benchmark")?;
            let plan = BenchPlan {
                ticks,
                runs,
                no_noise,
                compare_c,
            };
            match batch {
                Some(n) => bench_batch(&instr, &opts, &plan, n, lanes, out),
                None => bench(&instr, &opts, &plan, out),
            }
        }
        Cmd::Discover(a) => discover_cmd(&instr, (&name, &instr_text), config, &a, out),
        Cmd::Predict(a) => predict_cmd(&instr, config, &a, out),
        Cmd::Plan(a) => plan_cmd(&instr, &a, out),
    }
}

/// Print an experiment's tables and notes, write its files into `--out`.
fn emit(o: &Output, dir: &OutArgs, out: &mut dyn Write) -> Result<()> {
    emit_counting(o, dir, 0, out)
}

/// [`emit`], when `already` files were written into the folder while the work ran.
fn emit_counting(o: &Output, dir: &OutArgs, already: usize, out: &mut dyn Write) -> Result<()> {
    o.print(out)?;
    let files = o.write_files(&dir.out)?;
    eprintln!(
        "wrote {} into {}",
        plural((files.len() + already) as u64, "file"),
        paths::shown(&dir.out)
    );
    Ok(())
}

/// `1 file`, `2 files`.
fn plural(n: u64, word: &str) -> String {
    if n == 1 {
        format!("1 {word}")
    } else {
        format!("{n} {word}s")
    }
}

/// A counting gate of `gate_s` seconds: at least one limit cycle, at most what the core's
/// 32-bit counters hold.
fn gate_fits(flag: &str, gate_s: f64, instr: &Instrument, opts: &SimOptions) -> Result<()> {
    let per_cycle = f64::from(opts.config.ticks_per_cycle);
    let ticks = (gate_s * instr.clock_hz).round();
    if ticks < per_cycle {
        bail!(
            "{flag} {}: expected a gate of at least one limit cycle, {} s ({per_cycle} ticks at {} Hz); {} s is {} ticks",
            num(gate_s),
            num(per_cycle / instr.clock_hz),
            num(instr.clock_hz),
            num(gate_s),
            num(ticks)
        );
    }
    let max = f64::from(u32::MAX);
    if ticks > max {
        bail!(
            "{flag} {}: expected a gate of at most {} s, the longest the core's 32-bit counters hold ({} ticks at {} Hz); {} s is {} ticks",
            num(gate_s),
            (max / instr.clock_hz).floor(),
            u32::MAX,
            num(instr.clock_hz),
            num(gate_s),
            num(ticks)
        );
    }
    Ok(())
}

/// The ADC must see the pendulum's swing in a limit cycle: beyond its full scale it clips,
/// and the loop is then not the linear one whose margins `check_loop` computed (an
/// `amplifier_gain` of 100 000 instead of 100 passes `check_loop` with the same margins,
/// but the simulated loop's response is off by tens of dB). The swing is that of the
/// pendulum, damping-dominated with the lag `I/C`, driven by full torque for half a limit
/// cycle (102 µrad peak to peak for the shipped file, against an ADC full scale of
/// ±2.5 mrad).
fn report_cmd(
    instr: &Instrument,
    name: &str,
    a: &ReportArgs,
    config: ptsa_core::Config,
    out: &mut dyn Write,
) -> Result<()> {
    let opts = SimOptions {
        config,
        ..a.run.options()
    };
    paths::report_folder("--out", &a.out)?;
    let est = work::check(
        report::work(instr, &opts)?,
        a.run.force,
        "the report programme",
        None,
        "shorten the times asked for",
    )?;
    // Its discovery section holds its search of the loop's parameters to the limit.
    ptsa_host_sim::simulation::work::set_limit((!a.run.force).then(work::limit_s));
    let bar = work::Progress::start("the report programme", &est);
    let info = report::RunInfo {
        instrument: name.to_string(),
        options: opts,
        threads: rayon::current_num_threads(),
    };
    let (p, dir) = report::run(
        instr,
        &opts,
        info,
        &a.out,
        &mut |k, step| {
            bar.set_step(&format!(
                "step {} of {}, {step}",
                k + 1,
                report::STEPS.len()
            ));
        },
        out,
    )?;
    bar.finish();
    eprintln!(
        "report written to {} in {:.2} s",
        paths::shown(&dir),
        p.wall_s
    );
    Ok(())
}

fn two_axis(
    instr: &Instrument,
    config: ptsa_core::Config,
    kind: TwoAxisKind,
    a: &TwoAxisArgs,
    out: &mut dyn Write,
) -> Result<()> {
    let opts = SimOptions {
        config,
        ..a.run.options()
    };
    let lc = instr.clock_hz / f64::from(config.ticks_per_cycle);
    if a.freq_hz > lc / 2.0 {
        bail!(
            "--freq-hz {}: expected at most half the limit-cycle frequency, {} Hz (clock_hz / {} ticks / 2)",
            num(a.freq_hz),
            num(lc / 2.0),
            config.ticks_per_cycle
        );
    }
    paths::folder("--out", &a.out.out)?;
    let plan = appendix_a::TwoAxisPlan {
        kind,
        freq_hz: a.freq_hz,
        theta_my_mrad: a.theta_my_mrad,
        theta_mz_mrad: a.theta_mz_mrad,
        r_cm: a.r_cm,
        effects: Effects::NONE
            .with(CandidateId::Anisoelasticity, a.k_io_s2_cm)
            .with(CandidateId::Vibropendulosity, a.k_ip_s2_cm)
            .with(CandidateId::Sculling, a.k_sc_s2),
    };
    let c = ptsa_host_sim::lab::fixtures::two_axis(
        kind,
        a.freq_hz,
        a.theta_my_mrad,
        a.theta_mz_mrad,
        90.0,
        a.r_cm,
    );
    let peak = c.lin_cm_s2.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    work::warn_beyond_full_scale(instr, peak, "the vibration (r·θ·ω²)");
    let est = Work::new(instr, &opts)
        .ticks(appendix_a::work(instr, &opts, &plan))
        .check(a.run.force, appendix_a::name(kind))?;
    let p = work::Progress::start(appendix_a::name(kind), &est);
    let r = appendix_a::run(instr, &opts, &plan)?;
    p.finish();
    emit(&r.output, &a.out, out)
}

/// `ptsa static`'s instrument (its bias left out unless `with_bias`) and its gate in clock
/// ticks, `--seconds` checked against the clock.
fn static_gate(
    instr: &Instrument,
    opts: &SimOptions,
    seconds: f64,
    with_bias: bool,
) -> Result<(Instrument, u64)> {
    let mut instr = instr.clone();
    if !with_bias {
        instr.bias_cm_s2 = 0.0;
    }
    gate_fits("--seconds", seconds, &instr, opts)?;
    let ticks_f = (seconds * instr.clock_hz).round();
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let ticks = ticks_f as u64;
    Ok((instr, ticks))
}

#[allow(clippy::too_many_arguments)]
fn static_cmd(
    instr: &Instrument,
    opts: &SimOptions,
    accel_cm_s2: f64,
    seconds: f64,
    json: bool,
    trace: Option<&Path>,
    with_bias: bool,
    force: bool,
    out: &mut dyn Write,
) -> Result<()> {
    let (instr, ticks) = static_gate(instr, opts, seconds, with_bias)?;
    let est = Work::new(&instr, opts)
        .gate(ticks)
        .check(force, "this gate")?;
    let bar = work::Progress::start("static", &est);
    let mut progress = |_: u64, _: u64| {};
    let r = if let Some(path) = trace {
        let tmp = temp_beside(path)?;
        let mut w = std::io::BufWriter::new(tmp.as_file());
        writeln!(
            w,
            "# closed-loop ADC codes of `ptsa static`: {accel_cm_s2} cm/s^2 along IA, seed {}, {} settling ticks then a gate of {ticks} ticks",
            opts.seed,
            opts.warmup_ticks(instr.clock_hz)
        )?;
        let mut failed = None;
        let r = run_static_with(
            &instr,
            accel_cm_s2,
            ticks,
            opts,
            Some(&mut |v| {
                if failed.is_none()
                    && let Err(e) = writeln!(w, "{}", v.code)
                {
                    failed = Some(e);
                }
            }),
            &mut progress,
        );
        if let Some(e) = failed {
            return Err(e).with_context(|| format!("writing {}", path.display()));
        }
        w.flush()?;
        drop(w);
        persist(tmp, path)?;
        r
    } else {
        run_static_with(&instr, accel_cm_s2, ticks, opts, None, &mut progress)
    };
    bar.finish();
    if r.saturated {
        eprintln!(
            "warning: the loop saturated during the gate ({accel_cm_s2} cm/s^2 + bias {} cm/s^2 against a full scale of ±{} cm/s^2): the indicated value is not the input",
            instr.bias_cm_s2, instr.sf_cm_s2
        );
    }
    if json {
        writeln!(out, "{}", serde_json::to_string(&r)?)?;
    } else {
        writeln!(
            out,
            "static: {accel_cm_s2} cm/s^2 along IA (bias {} cm/s^2, loop's own {:.5}): T = {}, P = {}, indicated SF(2P/T - 1) = {:.4} cm/s^2{}",
            instr.bias_cm_s2,
            instr.loop_bias_cm_s2(0.0),
            plural(r.ticks, "tick"),
            plural(r.pulses, "pulse"),
            r.indicated_cm_s2,
            if r.saturated { " (SATURATED)" } else { "" }
        )?;
    }
    Ok(())
}

/// `ptsa response`: read and check the record, fit, check the fit, write the plot, print
/// the row.
#[allow(clippy::too_many_lines)] // the record's checks, the fit's, then the output
fn response_cmd(instr: &Instrument, a: &ResponseArgs, out: &mut dyn Write) -> Result<()> {
    use ptsa_host_sim::lab::response;
    use ptsa_host_sim::output::significant as sig;
    let stem = format!(
        "{}-response",
        a.counts
            .file_stem()
            .map_or_else(|| "record".into(), |s| s.to_string_lossy())
    );
    paths::folder_with(
        "--out",
        &a.out.out,
        &[format!("{stem}.png"), format!("{stem}.svg")],
    )?;
    let name = a.counts.display().to_string();
    let gates = response::read(&a.counts)?;
    let n = gates.len();
    let rate = response::gate_rate_hz(&gates);
    let span_s = gates[n - 1].time_s - gates[0].time_s;
    if a.freq_hz >= rate / 2.0 {
        bail!(
            "--freq-hz {}: expected a frequency below {} Hz, the Nyquist frequency of {name} ({n} gates in {} s, {} gates/s): gates that far apart cannot show a sine of {} Hz",
            num(a.freq_hz),
            sig(rate / 2.0, 8),
            sig(span_s, 8),
            sig(rate, 8),
            num(a.freq_hz)
        );
    }
    // Every warning, for stderr and for the JSON's "warnings".
    let mut warnings: Vec<String> = Vec::new();
    #[allow(clippy::cast_precision_loss)]
    let gate_s = gates[0].ticks as f64 / instr.clock_hz;
    let spacing = gates
        .windows(2)
        .map(|w| w[1].time_s - w[0].time_s)
        .fold(f64::INFINITY, f64::min);
    if spacing < gate_s * (1.0 - 1e-6) {
        warnings.push(format!(
            "{name}: gates start {} s apart but each is {} s long ({} ticks at the instrument file's clock_hz {} Hz): they overlap; if the counter's clock is not {} Hz, the gain's correction for the gate averaging is wrong",
            sig(spacing, 8),
            sig(gate_s, 8),
            gates[0].ticks,
            num(instr.clock_hz),
            num(instr.clock_hz)
        ));
    }
    if span_s * a.freq_hz < 1.0 {
        warnings.push(format!(
            "{name} spans {} s, less than one period of {} Hz: the fit extrapolates the sine and its uncertainties are large",
            sig(span_s, 8),
            num(a.freq_hz)
        ));
    }
    if a.amplitude_cm_s2.abs() > instr.sf_cm_s2 {
        warnings.push(format!(
            "--amplitude-cm-s2 = {} cm/s^2 is beyond the loop's full scale of ±{} cm/s^2: the loop saturates and the results are not measurements of the input",
            num(a.amplitude_cm_s2),
            num(instr.sf_cm_s2)
        ));
    }
    let fit = response::fit(
        &gates,
        a.freq_hz,
        a.amplitude_cm_s2,
        a.input_phase_deg,
        instr.sf_cm_s2,
        instr.clock_hz,
    )
    .with_context(|| format!("{name} at --freq-hz {}", num(a.freq_hz)))?;
    if !(fit.gain > 0.0 && fit.gain.is_finite()) {
        bail!(
            "{name}: no component at --freq-hz {} in the record (gain {}); expected the response to a sine at that frequency",
            num(a.freq_hz),
            sig(fit.gain, 4)
        );
    }
    let checked = response::check(
        &response::CheckContext {
            name: &name,
            gates: &gates,
            instrument: instr,
            ticks_per_cycle: u32::from(Design::for_instrument(instr).config().ticks_per_cycle),
        },
        &fit,
    );
    if let Some(r) = &checked.refusal {
        if !a.force {
            for w in &warnings {
                eprintln!("warning: {w}");
            }
            bail!("{r}; --force writes the row anyway");
        }
        warnings.push(format!("{r} (written because of --force)"));
    }
    warnings.extend(checked.warnings.iter().cloned());
    let file = a
        .counts
        .file_name()
        .map_or_else(|| name.clone(), |f| f.to_string_lossy().into_owned());
    let label = a
        .label
        .clone()
        .unwrap_or_else(|| format!("{} Hz ({file})", a.freq_hz));
    let fig = response_figure(
        &stem,
        &label,
        &gates,
        &fit,
        instr.sf_cm_s2,
        checked.expected.rms_cm_s2,
    );
    let files = ptsa_host_sim::output::write_figure(&a.out.out, &fig)?;
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    eprintln!(
        "response: {name}: {n} gates of {} s ({} gates/s), {} Hz at {} cm/s^2: gain {:.5} ± {:.5}, phase {:.3} ± {:.3} deg (output lagging: negative), mean {:.3} cm/s^2, residual RMS {:.3} cm/s^2 (counting leaves {:.3}){}",
        sig(gate_s, 8),
        sig(rate, 8),
        num(a.freq_hz),
        num(a.amplitude_cm_s2),
        fit.gain,
        fit.sigma_gain,
        fit.phase_deg,
        fit.sigma_phase_deg,
        fit.mean_cm_s2,
        fit.rms_cm_s2,
        checked.expected.rms_cm_s2,
        checked.prediction.map_or(String::new(), |p| format!(
            "; the instrument file's loop predicts gain {:.5}, phase {:.3} deg",
            p.gain, p.phase_deg
        ))
    );
    eprintln!(
        "wrote {} into {}",
        plural(files.len() as u64, "file"),
        paths::shown(&a.out.out)
    );
    print_response_row(out, fit.row(&label), &fit, &checked, &warnings, a.json)
}

/// Print `ptsa response`'s `row` as case-frame CSV with its header, or with `json` as one
/// JSON object with `fit`'s summary, the check's figures and the `warnings`.
fn print_response_row(
    out: &mut dyn Write,
    row: ptsa_host_sim::model::condition::Condition,
    fit: &ptsa_host_sim::lab::response::ResponseFit,
    checked: &ptsa_host_sim::lab::response::FitCheck,
    warnings: &[String],
    json: bool,
) -> Result<()> {
    if json {
        let v = serde_json::json!({
            "label": row.label,
            "kind": row.kind.name(),
            "freq_hz": row.freq_hz,
            "lin_ia_cm_s2": row.lin_cm_s2[0],
            "measured_gain": row.measured_gain,
            "measured_phase_deg": row.measured_phase_deg,
            "sigma_gain": row.sigma_gain,
            "sigma_phase_deg": row.sigma_phase_deg,
            "gates": fit.gates,
            "gate_s": fit.gate_s,
            "mean_cm_s2": fit.mean_cm_s2,
            "rms_cm_s2": fit.rms_cm_s2,
            "expected_rms_cm_s2": checked.expected.rms_cm_s2,
            "predicted_gain": checked.prediction.map(|p| p.gain),
            "predicted_phase_deg": checked.prediction.map(|p| p.phase_deg),
            "warnings": warnings,
        });
        writeln!(out, "{v}")?;
    } else {
        write!(out, "{}", ptsa_host_sim::lab::response::rows_csv(&[row]))?;
    }
    Ok(())
}

/// The plot of `ptsa response`: the gates' indicated accelerations with the fitted sine
/// (its gate means) over them, and the residuals below, their RMS against the
/// `expected_rms` counting leaves (cm/s²).
fn response_figure(
    stem: &str,
    label: &str,
    gates: &[ptsa_host_sim::lab::response::Gate],
    fit: &ptsa_host_sim::lab::response::ResponseFit,
    sf_cm_s2: f64,
    expected_rms: f64,
) -> ptsa_host_sim::output::Figure {
    use ptsa_host_sim::output::{Figure, Plot, Series};
    let half = fit.gate_s / 2.0;
    let mids: Vec<(f64, f64)> = gates
        .iter()
        .map(|g| (g.time_s + half, g.indicated_cm_s2(sf_cm_s2)))
        .collect();
    let resid: Vec<(f64, f64)> = gates
        .iter()
        .zip(&mids)
        .map(|(g, &(t, y))| (t, y - fit.gate_mean_cm_s2(g.time_s)))
        .collect();
    // The fitted gate mean as a curve: 48 points a period, at most 100 000 in all (the
    // plot thins a long line to its envelope).
    let (t0, t1) = (mids[0].0, mids[mids.len() - 1].0);
    let per_period = 48.0 * fit.freq_hz * (t1 - t0);
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let k = per_period.clamp(200.0, 100_000.0) as usize;
    #[allow(clippy::cast_precision_loss)]
    let curve: Vec<(f64, f64)> = (0..=k)
        .map(|i| {
            let t = t0 + (t1 - t0) * i as f64 / k as f64;
            (t, fit.gate_mean_cm_s2(t - half))
        })
        .collect();
    Figure {
        stem: stem.to_string(),
        panels: vec![
            Plot {
                title: format!(
                    "{label}: gain {:.4} ± {:.4}, phase {:.2} ± {:.2}°",
                    fit.gain, fit.sigma_gain, fit.phase_deg, fit.sigma_phase_deg
                ),
                x_label: "time (gate midpoint), s".into(),
                y_label: "indicated acceleration, cm/s²".into(),
                series: vec![
                    Series::crosses("gates: SF·(2P/T − 1)", mids),
                    Series::line("fitted sine, averaged over each gate", curve),
                ],
                ..Plot::default()
            },
            Plot {
                title: format!(
                    "residuals: gate minus fitted gate mean, RMS {:.3} cm/s² (counting leaves {:.3})",
                    fit.rms_cm_s2, expected_rms
                ),
                x_label: "time (gate midpoint), s".into(),
                y_label: "residual, cm/s²".into(),
                series: vec![Series::crosses("residual", resid)],
                zero_line: true,
                ..Plot::default()
            },
        ],
    }
}

/// `ptsa static` with several accelerations: one batch through the batch engine, whose
/// lanes are bit for bit the single loop's runs (`batch::run_static`).
#[allow(clippy::too_many_arguments)]
fn static_batch_cmd(
    instr: &Instrument,
    opts: &SimOptions,
    accels_cm_s2: &[f64],
    seconds: f64,
    json: bool,
    with_bias: bool,
    force: bool,
    out: &mut dyn Write,
) -> Result<()> {
    let (instr, ticks) = static_gate(instr, opts, seconds, with_bias)?;
    let n = accels_cm_s2.len();
    #[allow(clippy::cast_precision_loss)]
    let est = Work::new(&instr, opts)
        .gate(ticks)
        .times(n as f64)
        .check(force, &format!("this batch of {n} gates"))?;
    let p = work::Progress::start(&format!("static, {n} accelerations in one batch"), &est);
    let runs = ptsa_host_sim::simulation::batch::run_static(&instr, accels_cm_s2, ticks, opts);
    p.finish();
    for (a, r) in accels_cm_s2.iter().zip(&runs) {
        if r.saturated {
            eprintln!(
                "warning: the loop saturated during the gate at {a} cm/s^2 (+ bias {} cm/s^2, against a full scale of ±{} cm/s^2): its indicated value is not the input",
                instr.bias_cm_s2, instr.sf_cm_s2
            );
        }
    }
    if json {
        writeln!(out, "{}", serde_json::to_string(&runs)?)?;
        return Ok(());
    }
    writeln!(
        out,
        "static: {n} accelerations along IA in one batch (bias {} cm/s^2, loop's own {:.5}), each a gate of T = {} after {} s of settling; indicated SF(2P/T - 1):",
        instr.bias_cm_s2,
        instr.loop_bias_cm_s2(0.0),
        plural(ticks, "tick"),
        opts.warmup_s
    )?;
    writeln!(
        out,
        "{:>16} {:>12} {:>12} {:>18}",
        "input cm/s^2", "T", "P", "indicated cm/s^2"
    )?;
    for (a, r) in accels_cm_s2.iter().zip(&runs) {
        writeln!(
            out,
            "{:>16} {:>12} {:>12} {:>18.4}{}",
            a,
            r.ticks,
            r.pulses,
            r.indicated_cm_s2,
            if r.saturated { " (SATURATED)" } else { "" }
        )?;
    }
    Ok(())
}

fn design_cmd(
    instr: &Instrument,
    name: &str,
    print_core_constants: bool,
    checked: std::result::Result<&ptsa_host_sim::model::design::LoopCheck, &String>,
    out: &mut dyn Write,
) -> Result<()> {
    let d = Design::for_instrument(instr);
    if print_core_constants {
        write!(out, "{}", d.core_constants())?;
    } else {
        write!(out, "{}", design::text(instr))?;
        writeln!(out, "\n// ptsa-core/src/config.rs\n{}", d.core_constants())?;
    }
    match checked {
        Ok(c) => {
            if !print_core_constants {
                writeln!(
                    out,
                    "verdict: the loop is accepted (limit cycle {:.1} Hz)",
                    c.limit_cycle_hz
                )?;
            }
            Ok(())
        }
        Err(e) => bail!("{name}: {e}"),
    }
}

/// The simulator of `discover` and `predict`: the closed loop of the instrument file, or
/// the analytic model.
fn simulator(
    instr: &Instrument,
    config: ptsa_core::Config,
    analytic: bool,
    seed: u64,
) -> Box<dyn Simulator> {
    if analytic {
        Box::new(discovery::AnalyticSimulator::for_instrument(instr))
    } else {
        Box::new(discovery::sim::ClosedLoopSimulator {
            instrument: instr.clone(),
            options: SimOptions {
                seed,
                config,
                ..SimOptions::default()
            },
        })
    }
}

/// The effects of a `ptsa discover --json` result file (`predict --effects`), and the
/// standard error of each coefficient the file gives one for (its `"stderr"`).
fn load_effects(p: &Path) -> Result<(Effects, Vec<(CandidateId, f64)>)> {
    let text =
        std::fs::read_to_string(p).with_context(|| format!("{}: cannot read", p.display()))?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| {
        anyhow::anyhow!(
            "{}:{}:{}: not JSON: {e}; expected the output of `ptsa discover --json`",
            p.display(),
            e.line(),
            e.column()
        )
    })?;
    let effects = discovery::effects_from_json(&v).with_context(|| p.display().to_string())?;
    let list = v.get("effects").unwrap_or(&v);
    let mut sigmas = Vec::new();
    for item in list.as_array().into_iter().flatten() {
        let name = item.get("name").and_then(serde_json::Value::as_str);
        let errs = item.get("stderr").and_then(serde_json::Value::as_object);
        for (key, se) in errs.into_iter().flatten() {
            let id = ptsa_host_sim::model::effects::REGISTRY
                .iter()
                .find(|c| Some(c.effect) == name && c.key == key);
            if let (Some(c), Some(se)) = (id, se.as_f64().filter(|x| x.is_finite() && *x > 0.0)) {
                sigmas.push((c.id, se));
            }
        }
    }
    Ok((effects, sigmas))
}

/// What `predict` runs with: `baseline model`, or `with NAME = VALUE UNIT, ...`, each
/// coefficient with the digits its standard error in `sigmas` warrants, else four.
fn effects_text(effects: &Effects, sigmas: &[(CandidateId, f64)]) -> String {
    if effects.is_zero() {
        return "baseline model".to_string();
    }
    let list: Vec<String> = effects
        .nonzero()
        .map(|(id, c)| {
            let value = sigmas.iter().find(|s| s.0 == id).map_or_else(
                || ptsa_host_sim::output::significant(c, 4),
                |s| discovery::show::estimate(c, s.1),
            );
            format!("{} = {value} {}", id.info().name, id.info().unit)
        })
        .collect();
    format!("with {}", list.join(", "))
}

/// The work of `ptsa predict`: one observation of every row, refused beyond the limit
/// without `--force`.
fn predict_estimate(
    rows: &[ptsa_host_sim::Condition],
    sim: &dyn Simulator,
    force: bool,
) -> Result<ptsa_host_sim::simulation::work::Estimate> {
    let ticks = sim.pass_cost(&rows.iter().collect::<Vec<_>>());
    work::check(
        ptsa_host_sim::simulation::work::Estimate {
            ticks,
            other_s: 0.0,
        },
        force,
        "predict",
        None,
        "fewer rows, or rows of shorter periods",
    )
}

fn predict_cmd(
    instr: &Instrument,
    config: ptsa_core::Config,
    a: &PredictArgs,
    out: &mut dyn Write,
) -> Result<()> {
    let rows = ptsa_host_sim::model::caseframe::read(&a.data)?;
    let (effects, sigmas) = match &a.effects {
        Some(p) => load_effects(p)?,
        None => (Effects::NONE, Vec::new()),
    };
    let sim = simulator(instr, config, a.analytic, a.seed);
    let est = predict_estimate(&rows, &*sim, a.force)?;
    let p = work::Progress::start("predict", &est);
    let pred = discovery::predict(&rows, &*sim, &effects);
    p.finish();
    let response =
        |r: &ptsa_host_sim::Condition| r.kind == ptsa_host_sim::model::condition::RowKind::Response;
    if a.json {
        // A response row has no acceleration to predict: `predicted_cm_s2` is null and its
        // gain and phase come as `predicted_gain`, `predicted_phase_deg`.
        let rows: Vec<serde_json::Value> = rows
            .iter()
            .zip(&pred)
            .map(|(r, p)| {
                if response(r) {
                    serde_json::json!({
                        "label": r.label,
                        "predicted_cm_s2": null,
                        "predicted_gain": p.first(),
                        "predicted_phase_deg": p.get(1),
                    })
                } else {
                    serde_json::json!({"label": r.label, "predicted_cm_s2": p.first()})
                }
            })
            .collect();
        writeln!(out, "{}", serde_json::json!({ "rows": rows }))?;
        return Ok(());
    }
    writeln!(
        out,
        "predict: {} ({} simulator, {})",
        a.data.display(),
        sim.name(),
        effects_text(&effects, &sigmas)
    )?;
    writeln!(
        out,
        "{:<48} {:>10} {:>14} {:>12} {:>10}",
        "row", "kind", "predicted", "measured", "residual"
    )?;
    let line = |out: &mut dyn Write, label: &str, kind: &str, p: f64, m: Option<f64>, d: usize| {
        let (ms, res) = m.map_or(("-".to_string(), "-".to_string()), |m| {
            (format!("{m:.d$}"), format!("{:.d$}", m - p))
        });
        writeln!(
            out,
            "{:<48} {:>10} {:>14.4} {:>12} {:>10}",
            label.chars().take(48).collect::<String>(),
            kind,
            p,
            ms,
            res
        )
    };
    for (r, p) in rows.iter().zip(&pred) {
        let v = |k: usize| p.get(k).copied().unwrap_or(f64::NAN);
        if response(r) {
            line(
                out,
                &format!("{} (gain)", r.label),
                "response",
                v(0),
                r.measured_gain,
                4,
            )?;
            line(
                out,
                &format!("{} (phase, deg)", r.label),
                "response",
                v(1),
                r.measured_phase_deg,
                3,
            )?;
        } else {
            line(out, &r.label, r.kind.name(), v(0), r.measured_cm_s2, 3)?;
        }
    }
    writeln!(
        out,
        "(cm/s²; a difference row is condition − reference, an absolute row the indicated acceleration; a response row's gain is output over input amplitude, its phase output minus input in degrees)"
    )?;
    Ok(())
}

fn plan_cmd(instr: &Instrument, a: &PlanArgs, out: &mut dyn Write) -> Result<()> {
    use ptsa_host_sim::lab::plan;
    let (rows, what, dest) = match &a.kind {
        PlanKind::Tumble {
            positions,
            axis,
            out,
        } => (
            plan::tumble(*positions, *axis),
            format!("{positions}-point tumble about {axis:?}").to_lowercase(),
            out,
        ),
        PlanKind::RateTable {
            positions,
            axis,
            rate_rad_s,
            ref_rate_rad_s,
            radius_cm,
            out,
        } => (
            plan::rate_table(*positions, *axis, *rate_rad_s, *ref_rate_rad_s, *radius_cm),
            format!(
                "rate table, {positions} positions about {axis:?}, {rate_rad_s} rad/s against {ref_rate_rad_s} rad/s, arm {radius_cm} cm"
            ),
            out,
        ),
        PlanKind::Shaker {
            freq_hz,
            amplitude_cm_s2,
            rock_mrad,
            phases,
            out,
        } => (
            plan::shaker(*freq_hz, *amplitude_cm_s2, *rock_mrad, *phases),
            format!(
                "two-axis oscillator at {freq_hz} Hz, {amplitude_cm_s2} cm/s^2, rocking {rock_mrad} mrad, {phases} phases per block"
            ),
            out,
        ),
        PlanKind::Centrifuge {
            radius_cm,
            g_levels,
            out,
        } => (
            plan::centrifuge(*radius_cm, g_levels, instr.g_cm_s2),
            format!(
                "centrifuge, arm {radius_cm} cm, at {} g, IA in and out",
                g_levels
                    .iter()
                    .map(|g| format!("{g}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            out,
        ),
    };
    let comments = [
        format!("Test plan written by `ptsa plan`: {what}."),
        "Fill in measured_cm_s2 (and sigma_cm_s2) from the lab, then `cargo ptsa discover --data FILE`."
            .to_string(),
    ];
    let refs: Vec<&str> = comments.iter().map(String::as_str).collect();
    let text = ptsa_host_sim::model::caseframe::to_csv(&rows, &refs);
    match &dest.out {
        Some(p) => {
            let replaced =
                paths::output_file("--out", p, dest.force)?.then(|| paths::what_is_replaced(p));
            ptsa_host_sim::output::write_atomic(p, text.as_bytes())?;
            eprintln!(
                "wrote {} ({})",
                p.display(),
                ptsa_host_sim::output::count(rows.len() as u64, "row")
            );
            if let Some(w) = replaced {
                eprintln!("warning: --out {}: replaced {w} (--force)", p.display());
            }
        }
        None => write!(out, "{text}")?,
    }
    Ok(())
}

fn discover_cmd(
    instr: &Instrument,
    (instr_name, instr_text): (&str, &str),
    config: ptsa_core::Config,
    a: &DiscoverArgs,
    out: &mut dyn Write,
) -> Result<()> {
    if let Some(dir) = &a.convert_report_data {
        let names: Vec<String> = ptsa_host_sim::report::r890::case_files()?
            .iter()
            .map(|f| f.name.to_string())
            .collect();
        paths::folder_with("--convert-report-data", dir, &names)?;
        for p in ptsa_host_sim::report::r890::write_case_files(dir)? {
            eprintln!("wrote {}", p.display());
        }
        return Ok(());
    }
    let candidates: Vec<CandidateId> = if a.candidates.is_empty() {
        CandidateId::ALL.to_vec()
    } else {
        let mut v: Vec<CandidateId> = a.candidates.iter().flatten().copied().collect();
        v.sort_unstable();
        v.dedup();
        v
    };
    if !a.no_plots {
        // The files written: `<stem>-discover.*` of the data file, or, without one, those of
        // each of the report's tables (`report::discovery`).
        let stems = match &a.data {
            Some(p) => vec![discovery::output_stem(Some(p))],
            None => ptsa_host_sim::report::r890::case_files()?
                .iter()
                .map(|f| f.name.trim_end_matches(".case.csv").to_string())
                .collect(),
        };
        let names: Vec<String> = stems
            .iter()
            .flat_map(|stem| {
                [".csv", ".png", ".svg", "-bode.png", "-bode.svg"].map(|e| format!("{stem}{e}"))
            })
            .collect();
        paths::folder_with("--out", &a.out, &names)?;
    }
    let mut replaced = Vec::new();
    for (flag, p) in [
        ("--advice-out", &a.advice_out),
        ("--write-instrument", &a.write_instrument),
    ] {
        if let Some(p) = p
            && paths::output_file(flag, p, a.force)?
        {
            let before = std::fs::metadata(p).and_then(|m| m.modified()).ok();
            replaced.push((flag, p, before, paths::what_is_replaced(p)));
        }
    }
    let options = Options {
        default_sigma_cm_s2: a.sigma,
        candidates,
        seed: a.seed,
        keep_outliers: a.keep_outliers,
        units_as_given: a.units_as_given,
        ..Options::for_instrument(instr)
    };
    let plots = (!a.no_plots).then(|| a.out.clone());
    let sim = simulator(instr, config, a.analytic, a.seed);
    let est = discover_estimate(a, &options.candidates, &*sim)?;
    // The search of the loop's parameters, whose length is known only once they are
    // selected, is held to the limit too.
    ptsa_host_sim::simulation::work::set_limit((!a.force).then(work::limit_s));
    let p = work::Progress::start("discover", &est);
    let r = match &a.data {
        Some(data) => {
            let req = Request {
                data: data.clone(),
                options,
                json: a.json,
                out: plots,
                advice_out: a.advice_out.clone(),
                write_instrument: a.write_instrument.as_ref().map(|p| InstrumentOut {
                    path: p.clone(),
                    source: instr_text.to_string(),
                    source_name: instr_name.to_string(),
                }),
            };
            discovery::run(&req, &*sim, out)
        }
        None => report_tables(&*sim, &options, plots.as_deref(), a.json, out),
    };
    p.finish();
    if r.is_ok() {
        for (flag, p, before, w) in replaced {
            if std::fs::metadata(p).and_then(|m| m.modified()).ok() != before {
                eprintln!("warning: {flag} {}: replaced {w} (--force)", p.display());
            }
        }
    }
    r
}

/// `ptsa discover` without `--data`: the report's Tables 6.1, 6.2 and 6.3, each analysed on
/// its own, as the report programme's Markdown section on stdout (with `json`, the section
/// on stderr and one JSON object by file name on stdout); tables and plots into `plots`.
fn report_tables(
    sim: &dyn Simulator,
    options: &Options,
    plots: Option<&Path>,
    json: bool,
    out: &mut dyn Write,
) -> Result<()> {
    let (text, all) = ptsa_host_sim::report::discovery::section_json(sim, options, plots)?;
    if json {
        eprint!("{text}");
        writeln!(out, "{}", serde_json::Value::Object(all))?;
    } else {
        write!(out, "{text}")?;
    }
    Ok(())
}

/// The work of `ptsa discover` before it runs (`discovery::cost`), refused beyond the limit
/// without `--force` and announced when long, with what the search of the loop's
/// parameters may add when one is selected.
fn discover_estimate(
    a: &DiscoverArgs,
    candidates: &[CandidateId],
    sim: &dyn Simulator,
) -> Result<ptsa_host_sim::simulation::work::Estimate> {
    use discovery::cost::Cost;
    let costs: Vec<Cost> = match &a.data {
        Some(p) => vec![Cost::of(
            &ptsa_host_sim::model::caseframe::read(p)?,
            sim,
            candidates,
        )],
        None => ptsa_host_sim::report::r890::case_files()?
            .iter()
            .map(|f| Cost::of(&f.rows, sim, candidates))
            .collect(),
    };
    let ticks = costs.iter().map(|c| c.ticks).sum();
    let seconds: f64 = costs.iter().map(Cost::seconds).sum();
    let est = ptsa_host_sim::simulation::work::Estimate {
        ticks,
        other_s: seconds - ticks.seconds(),
    };
    let search: ptsa_host_sim::simulation::work::Ticks = costs.iter().map(|c| c.search(1)).sum();
    let more = (search.seconds() > 1.0).then(|| {
        format!(
            "and up to {} more if a parameter of the loop is selected (the closed-loop search of the others, held to the same limit)",
            ptsa_host_sim::simulation::work::human(search.seconds())
        )
    });
    work::check(
        est,
        a.force,
        "discover",
        more.as_deref(),
        "fewer rows, or rows of shorter periods",
    )
}
