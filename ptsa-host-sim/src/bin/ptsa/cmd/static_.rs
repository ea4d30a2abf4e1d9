//! `ptsa static`: the plain closed loop under constant accelerations along IA, one gate
//! each after the settling; one acceleration on the single loop (its ADC trace on request),
//! several as one batch of the batch engine.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context as _, Result, bail};
use clap::Args;
use ptsa_host_sim::Instrument;
use ptsa_host_sim::output::fs::{persist, temp_beside};
use ptsa_host_sim::output::{Column, Table, count, num, text};
use ptsa_host_sim::simulation::pil::{PilInput, PilRun, pil_gates, pil_params};
use ptsa_host_sim::simulation::sim::{SimOptions, StaticRun, run_static_with};

use super::{Ctx, gate_ticks};
use crate::flags::values::{accel_item, finite, non_negative_s, positive_hz, positive_s, seed};
use crate::paths;
use crate::work::{self, Work};

/// Arguments of `ptsa static`.
#[derive(Args, Debug, Clone)]
pub struct StaticArgs {
    /// Acceleration along IA, cm/s² (beyond full scale the loop saturates: the output
    /// says so). Several, comma separated (`-1000,0,1000`), run as one batch, each with
    /// the same gate, settling and seed.
    #[arg(long, value_name = "CM_S2", value_delimiter = ',', required = true,
          value_parser = accel_item)]
    pub accel_cm_s2: Vec<f64>,
    /// Gate length, s (at least one limit cycle, 64 ticks = 0.001 s at 64 kHz, and at
    /// most what the core's 32-bit counters hold, 67 108 s at 64 kHz).
    #[arg(long, default_value_t = 1.0, value_name = "S", value_parser = positive_s)]
    pub seconds: f64,
    /// Settling time before the gate, s (0 or more).
    #[arg(long, default_value_t = SimOptions::default().warmup_s, value_name = "S",
          value_parser = non_negative_s)]
    pub warmup_s: f64,
    /// Seed of the pickoff noise (the instrument file's `noise_uv_rms`): a whole number
    /// from 0 to 2^64 − 1, no unit.
    #[arg(long, default_value_t = SimOptions::default().seed, value_name = "N",
          value_parser = seed)]
    pub seed: u64,
    /// Include the instrument file's bias A_b (18.7 cm/s² shipped) as a torque.
    #[arg(long)]
    pub with_bias: bool,
    /// Print exactly one JSON object (the gate's ticks and pulses, the indicated value in
    /// cm/s², whether the loop saturated); with several accelerations, one JSON array of
    /// such objects, in the order given. Every key: docs/reference/json.md.
    #[arg(long)]
    pub json: bool,
    /// Write the ADC samples of this very run, settling included (one i16 per line,
    /// golden-vector style) to FILE (one acceleration only).
    #[arg(long, value_name = "FILE")]
    pub trace: Option<PathBuf>,
    /// Write, instead of running, this run's discrete-time plant, ADC, noise, input and
    /// loop constants (settling, counted time and gate in ticks) to FILE for the firmware's
    /// processor-in-the-loop image (`cargo xtask pil`); one acceleration.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["trace", "json", "record"])]
    pub pil_params: Option<PathBuf>,
    /// Write, instead of one gate's result, the counter record (`time_s,pulses,ticks`, the
    /// CSV `ptsa response` reads) of the gates of --gate-s after the settling, time_s from
    /// the loop's reset: what the processor-in-the-loop image counts in the same run
    /// (`cargo xtask pil --compare`); one acceleration.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["trace", "json"])]
    pub record: Option<PathBuf>,
    /// The gate of --pil-params and --record, s (a whole number of ticks, at least one
    /// limit cycle, dividing --warmup-s and --seconds); default with a constant input: the
    /// greatest common divisor of the settling and the counted ticks. Required with --sine-hz
    /// or --step-cm-s2.
    #[arg(long, value_name = "S", value_parser = positive_s)]
    pub gate_s: Option<f64>,
    /// A sine along IA added to --accel-cm-s2, of this frequency, Hz, its phase 0 at the
    /// loop's reset (with --pil-params or --record only).
    #[arg(long, value_name = "HZ", value_parser = positive_hz, requires = "sine_cm_s2")]
    pub sine_hz: Option<f64>,
    /// The sine's amplitude along IA, cm/s².
    #[arg(long, value_name = "CM_S2", value_parser = finite, requires = "sine_hz")]
    pub sine_cm_s2: Option<f64>,
    /// A step: the acceleration along IA becomes this, cm/s², at --step-at-s (with
    /// --pil-params or --record only).
    #[arg(long, value_name = "CM_S2", value_parser = finite, requires = "step_at_s",
          conflicts_with = "sine_hz")]
    pub step_cm_s2: Option<f64>,
    /// When the step comes, s from the loop's reset (settling included), rounded to a tick.
    #[arg(long, value_name = "S", value_parser = non_negative_s, requires = "step_cm_s2")]
    pub step_at_s: Option<f64>,
    /// Replace an existing --record, --trace or --pil-params file (the work limit is
    /// --no-limit's).
    #[arg(long)]
    pub force: bool,
    #[command(flatten)]
    pub limit: crate::flags::LimitArg,
}

/// Static runs to make.
pub struct Request {
    /// The instrument, its bias A_b zeroed unless `--with-bias`.
    instr: Instrument,
    opts: SimOptions,
    /// The gate, clock ticks (one limit cycle to what the core's counters hold).
    ticks: u64,
    json: bool,
    force: bool,
    runs: Runs,
}

/// One acceleration (with its trace file, checked) or several in one batch, or the
/// parameters of one run for the processor-in-the-loop image.
enum Runs {
    Pil {
        run: PilRun,
        path: PathBuf,
    },
    Record {
        run: PilRun,
        path: PathBuf,
    },
    One {
        accel_cm_s2: f64,
        trace: Option<PathBuf>,
    },
    Batch(Vec<f64>),
}

impl StaticArgs {
    /// The request: `--trace` only with one acceleration (its file checked), the bias
    /// resolved, the gate against the loop's limit cycle and counters.
    ///
    /// # Errors
    /// The loop cannot be simulated; `--trace` with several accelerations or at a path
    /// that cannot be written or exists; the gate does not fit.
    pub fn request(self, ctx: &Ctx) -> Result<Request> {
        let opts = SimOptions {
            seed: self.seed,
            warmup_s: self.warmup_s,
            config: ctx.config()?,
            ..SimOptions::default()
        };
        let mut instr = ctx.instr.clone();
        if !self.with_bias {
            instr.bias_cm_s2 = 0.0;
        }
        let ticks = gate_ticks("--seconds", self.seconds, &instr, &opts)?;
        let moving = self.sine_hz.is_some() || self.step_cm_s2.is_some();
        let gates = self.pil_params.is_some() || self.record.is_some();
        if moving && !gates {
            bail!(
                "--sine-hz and --step-cm-s2 describe a run for --pil-params or --record; expected one of them"
            );
        }
        if self.gate_s.is_some() && !gates {
            bail!("--gate-s is the gate of --pil-params or --record; expected one of them");
        }
        let runs = match (
            &self.accel_cm_s2[..],
            self.trace.clone(),
            self.pil_params.clone(),
            self.record.clone(),
        ) {
            ([a], None, pil, record) if pil.is_some() || record.is_some() => {
                let run = self.pil_run(*a, &instr, &opts, ticks)?;
                match (pil, record) {
                    (Some(path), _) => {
                        paths::output_file("--pil-params", &path, self.force)?;
                        Runs::Pil { run, path }
                    }
                    (None, Some(path)) => {
                        paths::output_file("--record", &path, self.force)?;
                        Runs::Record { run, path }
                    }
                    (None, None) => unreachable!("one of them is given"),
                }
            }
            (several, None, Some(_), _) => bail!(
                "--pil-params writes the parameters of one run; expected one --accel-cm-s2 value with it, not {}",
                several.len()
            ),
            (several, None, None, Some(_)) => bail!(
                "--record writes the gates of one run; expected one --accel-cm-s2 value with it, not {}",
                several.len()
            ),
            ([a], trace, None, None) => {
                if let Some(t) = &trace {
                    paths::output_file("--trace", t, self.force)?;
                }
                Runs::One {
                    accel_cm_s2: *a,
                    trace,
                }
            }
            (several, Some(_), _, _) => bail!(
                "--trace writes the ADC samples of one run; expected one --accel-cm-s2 value with it, not {}",
                several.len()
            ),
            (several, None, None, None) => Runs::Batch(several.to_vec()),
        };
        Ok(Request {
            instr,
            opts,
            ticks,
            json: self.json,
            force: self.force,
            runs,
        })
    }
}

impl StaticArgs {
    /// The run of --pil-params or --record at `accel_cm_s2`: the input, the settling and
    /// the counted ticks, the gate (--gate-s, or for a constant input the greatest common
    /// divisor of the two), checked.
    fn pil_run(
        &self,
        accel_cm_s2: f64,
        instr: &Instrument,
        opts: &SimOptions,
        ticks: u64,
    ) -> Result<PilRun> {
        let warmup = opts.warmup_ticks(instr.clock_hz);
        let input = match (
            self.sine_hz,
            self.sine_cm_s2,
            self.step_cm_s2,
            self.step_at_s,
        ) {
            (Some(freq_hz), Some(amp_cm_s2), None, None) => PilInput::Sine {
                accel_cm_s2,
                freq_hz,
                amp_cm_s2,
            },
            (None, None, Some(to_cm_s2), Some(at_s)) => {
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                let at_tick = (at_s * instr.clock_hz).round() as u64;
                PilInput::Step {
                    accel_cm_s2,
                    to_cm_s2,
                    at_tick,
                }
            }
            _ => PilInput::Static { accel_cm_s2 },
        };
        let gate = match (self.gate_s, input) {
            (Some(g), _) => gate_ticks("--gate-s", g, instr, opts)?,
            (None, PilInput::Static { .. }) => gcd(warmup, ticks),
            (None, _) => {
                bail!("--sine-hz and --step-cm-s2 need --gate-s, the gate of the reported counts")
            }
        };
        let run = PilRun {
            input,
            warmup,
            ticks,
            gate,
        };
        run.check().map_err(|e| {
            anyhow::anyhow!(
                "--warmup-s {}, --seconds {}: {e}",
                self.warmup_s,
                self.seconds
            )
        })?;
        Ok(run)
    }
}

/// The greatest common divisor (`gcd(0, b) = b`).
fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// Run the gate(s) (refused beyond the work limit without `--no-limit`); a warning for each
/// saturated one; the result as a line or a table, or JSON.
///
/// # Errors
/// Refused work; the trace or stdout cannot be written.
pub fn run(req: &Request, out: &mut dyn Write) -> Result<()> {
    match &req.runs {
        Runs::Pil { run, path } => {
            let text = pil_params(&req.instr, run, &req.opts)
                .map_err(|e| anyhow::anyhow!("--pil-params: {e}"))?;
            write_atomic(path, &text)
        }
        Runs::Record { run, path } => {
            let est = Work::new(&req.instr, &req.opts)
                .gate(run.ticks)
                .check(req.force, "this record")?;
            let bar = work::Progress::start("static --record", &est);
            let gates = pil_gates(&req.instr, run, &req.opts)
                .map_err(|e| anyhow::anyhow!("--record: {e}"))?;
            bar.finish();
            let text = ptsa_host_sim::noise::record_csv(
                &gates,
                &[format!(
                    "ptsa static --record: {:?} along IA, bias {} cm/s^2, seed {}, {} settling ticks, gates of {} ticks",
                    run.input, req.instr.bias_cm_s2, req.opts.seed, run.warmup, run.gate
                )],
            );
            write_atomic(path, &text)
        }
        Runs::One { accel_cm_s2, trace } => one(req, *accel_cm_s2, trace.as_ref(), out),
        Runs::Batch(accels) => batch(req, accels, out),
    }
}

/// Write `text` to `path`, which appears whole.
fn write_atomic(path: &std::path::Path, text: &str) -> Result<()> {
    ptsa_host_sim::output::fs::write_atomic(path, text.as_bytes())
}

/// One run on the single loop, its ADC codes streamed into `trace` (a file that appears
/// whole).
fn one(req: &Request, a: f64, trace: Option<&PathBuf>, out: &mut dyn Write) -> Result<()> {
    let (instr, opts, ticks) = (&req.instr, &req.opts, req.ticks);
    let est = Work::new(instr, opts)
        .gate(ticks)
        .check(req.force, "this gate")?;
    let bar = work::Progress::start("static", &est);
    let mut progress = |_: u64, _: u64| {};
    let r = if let Some(path) = trace {
        let tmp = temp_beside(path)?;
        let mut w = std::io::BufWriter::new(tmp.as_file());
        writeln!(
            w,
            "# closed-loop ADC codes of `ptsa static`: {a} cm/s^2 along IA, seed {}, {} settling ticks then a gate of {ticks} ticks",
            opts.seed,
            opts.warmup_ticks(instr.clock_hz)
        )?;
        let mut failed = None;
        let r = run_static_with(
            instr,
            a,
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
        run_static_with(instr, a, ticks, opts, None, &mut progress)
    };
    bar.finish();
    if r.saturated {
        eprintln!(
            "warning: the loop saturated during the gate ({a} cm/s^2 + bias {} cm/s^2 against a full scale of ±{} cm/s^2): the indicated value is not the input",
            instr.bias_cm_s2, instr.sf_cm_s2
        );
    }
    if req.json {
        writeln!(out, "{}", serde_json::to_string(&r)?)?;
    } else {
        writeln!(
            out,
            "static: {a} cm/s^2 along IA (bias {} cm/s^2, loop's own {:.5}): T = {}, P = {}, indicated SF(2P/T - 1) = {:.4} cm/s^2{}",
            instr.bias_cm_s2,
            instr.loop_bias_cm_s2(0.0),
            count(r.ticks, "tick"),
            count(r.pulses, "pulse"),
            r.indicated_cm_s2,
            saturated(r.saturated)
        )?;
    }
    Ok(())
}

/// Several accelerations as one batch of the batch engine, whose lanes are bit for bit the
/// single loop's runs (`batch::run_static`).
fn batch(req: &Request, accels: &[f64], out: &mut dyn Write) -> Result<()> {
    let (instr, opts, ticks) = (&req.instr, &req.opts, req.ticks);
    let n = accels.len();
    #[allow(clippy::cast_precision_loss)]
    let est = Work::new(instr, opts)
        .gate(ticks)
        .times(n as f64)
        .check(req.force, &format!("this batch of {n} gates"))?;
    let p = work::Progress::start(&format!("static, {n} accelerations in one batch"), &est);
    let runs = ptsa_host_sim::simulation::batch::run_static(instr, accels, ticks, opts);
    p.finish();
    for (a, r) in accels.iter().zip(&runs) {
        if r.saturated {
            eprintln!(
                "warning: the loop saturated during the gate at {a} cm/s^2 (+ bias {} cm/s^2, against a full scale of ±{} cm/s^2): its indicated value is not the input",
                instr.bias_cm_s2, instr.sf_cm_s2
            );
        }
    }
    if req.json {
        writeln!(out, "{}", serde_json::to_string(&runs)?)?;
        return Ok(());
    }
    write!(out, "{}", batch_table(req, accels, &runs))?;
    Ok(())
}

/// The batch's table: a title line, then one row per acceleration (input as given, T, P,
/// the indicated value, and a mark when it saturated).
fn batch_table(req: &Request, accels: &[f64], runs: &[StaticRun]) -> String {
    let mut t = Table::new(
        "static",
        &format!(
            "static: {} accelerations along IA in one batch (bias {} cm/s^2, loop's own {:.5}), each a gate of T = {} after {} s of settling; indicated SF(2P/T - 1):",
            accels.len(),
            req.instr.bias_cm_s2,
            req.instr.loop_bias_cm_s2(0.0),
            count(req.ticks, "tick"),
            req.opts.warmup_s
        ),
        &["input cm/s^2", "T", "P", "indicated cm/s^2", ""],
    );
    for (a, r) in accels.iter().zip(runs) {
        t.rows.push(vec![
            text(a.to_string()),
            text(r.ticks.to_string()),
            text(r.pulses.to_string()),
            num(r.indicated_cm_s2, 4),
            text(saturated(r.saturated)),
        ]);
    }
    // The indicated value keeps the sign of one that rounds to zero, as this table always
    // has; the mark follows the last column without a gap.
    t.to_fixed_text(&[
        Column::right(16).gap(0),
        Column::right(12),
        Column::right(12),
        Column::right(18).signed_zero(),
        Column::left(0).gap(0),
    ])
}

/// The mark of a saturated run.
fn saturated(yes: bool) -> &'static str {
    if yes { " (SATURATED)" } else { "" }
}
