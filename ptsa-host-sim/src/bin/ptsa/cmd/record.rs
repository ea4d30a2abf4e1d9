//! `ptsa record`: the firmware's log (probe-rs's defmt output, QEMU's semihosting lines or
//! a saved copy) turned into the counter record `time_s,pulses,ticks` that `ptsa response`
//! reads (`lab::record`): the gate reports found, their sequence checked for lost reports
//! and merged gates, the record written atomically (never over a file without `--force`).
//! Simulates nothing: it needs only the instrument file's clock.

use std::io::{Read as _, Write};
use std::path::{Path, PathBuf};

use ptsa_host_sim::output::command_json::{GapJson, RecordJson};

use anyhow::{Context as _, Result, bail};
use clap::Args;
use ptsa_host_sim::lab::record::{self, Stream};
use ptsa_host_sim::output::{significant as sig, write_atomic};

use super::Ctx;
use crate::paths;

/// Arguments of `ptsa record`.
#[derive(Args, Debug, Clone)]
pub struct RecordArgs {
    /// The log to read: a file, or - for standard input (e.g. `probe-rs run … | ptsa record
    /// --from -`). Lines that are not gate reports are skipped.
    #[arg(long, value_name = "FILE|-")]
    pub from: PathBuf,
    /// Write the record to this file (not replaced without --force); without it the record
    /// goes to standard output.
    #[arg(short = 'o', long = "output", alias = "out", value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Replace an existing --output file.
    #[arg(long)]
    pub force: bool,
    /// Write the record even when reports are missing from the log (gaps in the gates'
    /// numbers): the gates around a gap are kept with their true start times, the lost ones
    /// are absent. Without it such a log is refused, naming the lines around each gap.
    #[arg(long)]
    pub allow_gaps: bool,
    /// The axis to take from a triad's log (its reports carry axis=N: 0, 1 or 2; a number,
    /// no unit); refused for a single-axis log.
    #[arg(long, value_name = "N")]
    pub axis: Option<u64>,
    /// Print one JSON object on standard output instead of the summary on stderr (needs
    /// --output): the log's lines and reports, its gaps and merged gates, the record's
    /// span in s, the warnings. Every key: docs/reference/json.md.
    #[arg(long)]
    pub json: bool,
}

/// A log to turn into a record: read, its output path checked.
pub struct Request {
    /// The log's name for messages (`stdin` for -).
    name: String,
    bytes: Vec<u8>,
    out: Option<PathBuf>,
    /// What the file held, when `--force` replaces one.
    replaced: Option<String>,
    allow_gaps: bool,
    axis: Option<u64>,
    json: bool,
}

impl RecordArgs {
    /// The files the command reads, by their flags: no output may replace them.
    pub fn inputs(&self) -> [(&'static str, Option<&Path>); 1] {
        let from = (self.from.as_os_str() != "-").then_some(self.from.as_path());
        [("--from", from)]
    }

    /// The request: `--output` checked (an existing file only with `--force`; never the log),
    /// `--json` only with `--output`, the log read.
    ///
    /// # Errors
    /// `--json` without `--output`; `--output` is refused; the log cannot be read.
    pub fn request(self) -> Result<Request> {
        if self.json && self.out.is_none() {
            bail!(
                "--json: the record and the JSON would both go to standard output; expected --output FILE for the record"
            );
        }
        if self.force && self.out.is_none() {
            bail!("--force: nothing to replace without --output; expected --output FILE");
        }
        let replaced = match &self.out {
            Some(p) => {
                paths::output_file("--output", p, self.force)?.then(|| paths::what_is_replaced(p))
            }
            None => None,
        };
        let (name, bytes) = if self.from.as_os_str() == "-" {
            let mut b = Vec::new();
            std::io::stdin()
                .read_to_end(&mut b)
                .context("--from -: cannot read standard input")?;
            ("stdin".to_string(), b)
        } else {
            let name = self.from.display().to_string();
            if self.from.is_dir() {
                bail!(
                    "--from {name}: this is a folder; expected a log file or - for standard input"
                );
            }
            let b =
                std::fs::read(&self.from).with_context(|| format!("--from {name}: cannot read"))?;
            (name, b)
        };
        Ok(Request {
            name,
            bytes,
            out: self.out,
            replaced,
            allow_gaps: self.allow_gaps,
            axis: self.axis,
            json: self.json,
        })
    }
}

/// Parse, check, write the record; the summary on stderr (or the JSON on `out`).
///
/// # Errors
/// The log holds no usable reports, a report is malformed, the sequence restarts or does
/// not add up, a gap without `--allow-gaps`, or the write fails.
pub fn run(ctx: &Ctx, req: &Request, out: &mut dyn Write) -> Result<()> {
    let name = &req.name;
    let clock_hz = ctx.instr.clock_hz;
    let log = record::parse(name, &req.bytes)?;
    let reports = record::select(name, &log, req.axis)?;
    let stream = record::check(name, &reports, clock_hz)?;
    let mut warnings = Vec::new();
    if !stream.gaps.is_empty() {
        let what = format!(
            "{name}: {} gap(s) in the gate numbers, {} gate(s) lost between the board and the log ({})",
            stream.gaps.len(),
            stream.lost_gates(),
            record::gaps_text(&stream.gaps)
        );
        if !req.allow_gaps {
            bail!(
                "{what}; a record with gaps is refused without --allow-gaps (which writes the gates around them at their true times)"
            );
        }
        warnings.push(format!("{what}; written with the gaps (--allow-gaps)"));
    }
    if !stream.merges.is_empty() {
        let lines: Vec<String> = stream
            .merges
            .iter()
            .take(5)
            .map(|m| format!("{} ({} gates)", m.line, m.gates))
            .collect();
        warnings.push(format!(
            "{name}: {} report(s) hold {} merged gates (lines {}{}): the firmware's main loop fell behind and its queue summed them, exactly; each is written as one longer gate, which `ptsa response` refuses (it needs gates of equal length)",
            stream.merges.len(),
            stream.merged_gates(),
            lines.join(", "),
            if stream.merges.len() > 5 { ", …" } else { "" }
        ));
    }
    if let Some(l) = log.cut_last {
        warnings.push(format!(
            "{name}:{l}: the log ends inside this gate report (no line end); dropped, since its last number may be cut short"
        ));
    }
    let text = record::record_csv(name, req.axis, &stream, clock_hz);
    match &req.out {
        Some(p) => write_atomic(p, text.as_bytes())?,
        None => out.write_all(text.as_bytes())?,
    }
    if let (Some(p), Some(w)) = (&req.out, &req.replaced) {
        warnings.push(format!("--output {}: replaced {w} (--force)", p.display()));
    }
    let span_s = span_s(&stream, clock_hz);
    if req.json {
        let v = json(req, &log, &stream, clock_hz, span_s, &warnings);
        writeln!(out, "{v}")?;
    } else {
        for w in &warnings {
            eprintln!("warning: {w}");
        }
        eprintln!("{}", summary(req, &log, &stream, span_s));
    }
    Ok(())
}

/// From the first gate's start to the last one's end, s.
fn span_s(s: &Stream, clock_hz: f64) -> f64 {
    match (s.gates.first(), s.gates.last()) {
        #[allow(clippy::cast_precision_loss)]
        (Some(a), Some(b)) => b.time_s + b.ticks as f64 / clock_hz - a.time_s,
        _ => 0.0,
    }
}

/// One line for stderr: what was read and written.
fn summary(req: &Request, log: &record::Log, s: &Stream, span_s: f64) -> String {
    let axis = req.axis.map_or(String::new(), |a| format!(" of axis {a}"));
    let to = req
        .out
        .as_ref()
        .map_or("standard output".to_string(), |p| p.display().to_string());
    format!(
        "{}: {} gate report(s){axis} on lines {}..{} ({} of {} lines skipped as not reports), gates {}..{} over {} s; {} gap(s) ({} gate(s) lost), {} merged report(s) ({} gates); record written to {to}",
        req.name,
        s.gates.len(),
        s.lines.0,
        s.lines.1,
        log.skipped,
        log.lines,
        s.seq.0,
        s.seq.1,
        sig(span_s, 9),
        s.gaps.len(),
        s.lost_gates(),
        s.merges.len(),
        s.merged_gates(),
    )
}

/// The `--json` object.
fn json(
    req: &Request,
    log: &record::Log,
    s: &Stream,
    clock_hz: f64,
    span_s: f64,
    warnings: &[String],
) -> serde_json::Value {
    let gaps = s
        .gaps
        .iter()
        .map(|g| GapJson {
            after_line: g.after_line,
            before_line: g.before_line,
            first_missing: g.first_missing,
            last_missing: g.last_missing,
            missing_gates: g.gates(),
            missing_ticks: g.missing_ticks,
        })
        .collect();
    let v = RecordJson {
        from: req.name.clone(),
        out: req.out.as_ref().map(|p| p.display().to_string()),
        axis: req.axis,
        lines: log.lines,
        skipped_lines: log.skipped,
        reports: s.gates.len(),
        gates: s.gates.len() - s.merges.len()
            + usize::try_from(s.merged_gates()).unwrap_or(usize::MAX),
        first_seq: s.seq.0,
        last_seq: s.seq.1,
        gaps,
        lost_gates: s.lost_gates(),
        merged_reports: s.merges.len(),
        merged_gates: s.merged_gates(),
        cut_last_line: log.cut_last,
        clock_hz,
        span_s,
        warnings: warnings.to_vec(),
    };
    // Through a `Value`: its keys in the order of their names.
    serde_json::to_value(v).expect("plain data")
}
