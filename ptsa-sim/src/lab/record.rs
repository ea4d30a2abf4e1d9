//! From the firmware's log to a counter record (`ptsa record`): the gate reports of the
//! production image (or of the triad image, one stream per axis) read out of a log, their
//! sequence checked for lost reports and merged gates, and the record `time_s,pulses,ticks`
//! that [`crate::lab::response`] reads.
//!
//! A gate report is one line holding, after whatever the log's transport puts before it
//! (probe-rs's timestamp and level, ANSI colours, nothing for QEMU's semihosting),
//!
//! `gate [axis=<k>] seq=<n> P=<pulses> T=<ticks> gates=<merged> tick=<ticks at its close> …`
//!
//! with more `key=value` fields after it (`stack=`, `t_ns=`), which are ignored, and
//! anything else after those (a location probe-rs may print on the same line). `seq` is the
//! number of the report's last gate since the loop started (from 1), `gates` how many gates
//! the firmware's queue merged into the report because its main loop fell behind (1
//! normally), `tick` the ticks from the loop's first tick to the close of the report's last
//! gate (a `u64` in the firmware, which never wraps). Every other line is not a report and
//! is skipped.
//!
//! The checks, per stream: consecutive reports `a`, `b` follow each other when
//! `seq_b − seq_a = gates_b` and then `tick_b − tick_a = T_b` must hold; a larger step in
//! `seq` is a gap (reports lost between the board and the file, e.g. RTT's buffer overrun),
//! whose ticks must fit in the step of `tick`; a step of 0 or less in `seq` or `tick` is a
//! restart (the board was reset, two logs were joined) and is refused. A report with
//! `gates > 1` is kept as one longer gate (its counts are exact: the queue sums, it never
//! drops) and counted as merged.
//!
//! A last line without a line end (a capture cut while the firmware was printing) is
//! dropped when it is a gate report, since its last number may be cut short; the result
//! says so.

use std::fmt::Write as _;

use anyhow::{Result, bail};

use crate::lab::response::Gate;

/// One gate report of the log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Report {
    /// Its line in the log, from 1.
    pub line: usize,
    /// The triad's axis (`axis=`), `None` in a single-axis log.
    pub axis: Option<u64>,
    /// Number of its last gate, from 1.
    pub seq: u64,
    /// Data pulses `P`.
    pub pulses: u64,
    /// Clock ticks `T`.
    pub ticks: u64,
    /// Gates merged into it (1 unless the firmware's queue was full).
    pub gates: u64,
    /// Ticks from the loop's first tick to the close of its last gate.
    pub tick: u64,
}

/// The gate reports of a log.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Log {
    /// The reports, in the log's order.
    pub reports: Vec<Report>,
    /// Lines read.
    pub lines: usize,
    /// Lines that are not gate reports (skipped).
    pub skipped: usize,
    /// The line of a gate report dropped because the log ends inside it (no line end).
    pub cut_last: Option<usize>,
}

/// The fields of a report, in the order the firmware prints them.
const KEYS: [&str; 6] = ["axis", "seq", "P", "T", "gates", "tick"];

/// What a report looks like, for messages.
pub const FORMAT: &str =
    "`gate [axis=K] seq=N P=N T=N gates=N tick=N` (the production image's gate report)";

/// Remove ANSI escape sequences (probe-rs colours its level names on a terminal).
fn strip_ansi(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let mut chars = s.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '\u{1b}' {
            if chars.peek() == Some(&'[') {
                chars.next();
                // Parameters and intermediates, then one final byte in '@'..='~'.
                for d in chars.by_ref() {
                    if ('@'..='~').contains(&d) {
                        break;
                    }
                }
            }
            continue;
        }
        out.push(c);
    }
    out
}

/// Where the report starts in `line`: the byte offset of a word `gate` followed by one
/// space and `seq=` or `axis=`.
fn report_start(line: &str) -> Option<usize> {
    let mut from = 0;
    while let Some(k) = line[from..].find("gate ") {
        let at = from + k;
        let before_ok = line[..at]
            .chars()
            .next_back()
            .is_none_or(|c| !c.is_alphanumeric() && c != '_');
        let rest = &line[at + 5..];
        if before_ok && (rest.starts_with("seq=") || rest.starts_with("axis=")) {
            return Some(at);
        }
        from = at + 5;
    }
    None
}

/// Whether `line` looks like a gate report of the firmware before reports were numbered
/// (`gate P=… T=…` over defmt, `gate <n>: P=…` over semihosting).
fn old_report(line: &str) -> bool {
    let mut from = 0;
    while let Some(k) = line[from..].find("gate ") {
        let rest = &line[from + k + 5..];
        let digits = rest.trim_start_matches(|c: char| c.is_ascii_digit());
        if rest.starts_with("P=") || (digits.len() < rest.len() && digits.starts_with(": P=")) {
            return true;
        }
        from += k + 5;
    }
    false
}

/// Parse one report from `line` (its `start` from [`report_start`]); `at` is
/// `name:line` for messages.
fn report(at: &str, number: usize, line: &str, start: usize) -> Result<Report> {
    let mut vals: [Option<u64>; 6] = [None; 6];
    // Byte offsets of the words after `gate`.
    let body = start + 4;
    let mut pos = body;
    for word in line[body..].split_whitespace() {
        let off = pos + line[pos..].find(word).unwrap_or(0);
        pos = off + word.len();
        let Some((key, value)) = word.split_once('=') else {
            break;
        };
        if key.is_empty() || !key.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            break;
        }
        let Some(k) = KEYS.iter().position(|x| *x == key) else {
            continue;
        };
        let col = line[..=(off + key.len())].chars().count() + 1;
        if vals[k].is_some() {
            bail!("{at}:{col}: gate report gives `{key}=` twice; expected {FORMAT}");
        }
        let v = (!value.is_empty() && value.bytes().all(|b| b.is_ascii_digit()))
            .then(|| value.parse::<u64>().ok())
            .flatten();
        let Some(v) = v else {
            bail!(
                "{at}:{col}: gate report's `{key}=` holds `{value}`; expected a whole number, 0 or more (a report is {FORMAT})"
            );
        };
        vals[k] = Some(v);
    }
    let col = line[..start].chars().count() + 1;
    let get = |k: usize| {
        vals[k].ok_or_else(|| {
            anyhow::anyhow!(
                "{at}:{col}: gate report without `{}=`; expected {FORMAT}",
                KEYS[k]
            )
        })
    };
    let r = Report {
        line: number,
        axis: vals[0],
        seq: get(1)?,
        pulses: get(2)?,
        ticks: get(3)?,
        gates: get(4)?,
        tick: get(5)?,
    };
    if r.ticks > 0 && r.tick < r.ticks {
        bail!(
            "{at}:{col}: gate report with tick={} below its T={}: no gate closes that early (a tick counter that wrapped, as a 32-bit one would, or a corrupt report); expected tick >= T, the firmware's tick never wraps",
            r.tick,
            r.ticks
        );
    }
    if r.ticks == 0 || r.pulses > r.ticks || r.gates == 0 || r.seq < r.gates {
        bail!(
            "{at}:{col}: gate report with seq={} P={} T={} gates={} tick={}; expected T >= 1, P <= T, gates >= 1, seq >= gates and tick >= T",
            r.seq,
            r.pulses,
            r.ticks,
            r.gates,
            r.tick
        );
    }
    Ok(r)
}

/// Read the gate reports out of a log's bytes (`name` names it in messages). Lines end with
/// LF or CRLF; bytes that are not UTF-8 outside a report are skipped with their line.
///
/// # Errors
/// A line that is a gate report but malformed (a field missing, given twice or not a whole
/// number; `P > T`, `T = 0`), or a report of the firmware before numbered reports:
/// `name:line:column` and what was expected.
pub fn parse(name: &str, bytes: &[u8]) -> Result<Log> {
    let mut log = Log::default();
    let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    let ends_open = !bytes.is_empty() && !bytes.ends_with(b"\n");
    let mut lines: Vec<&[u8]> = bytes.split(|&b| b == b'\n').collect();
    if !ends_open {
        lines.pop();
    }
    log.lines = lines.len();
    for (i, raw) in lines.iter().enumerate() {
        let number = i + 1;
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        let text = strip_ansi(&String::from_utf8_lossy(raw));
        let Some(start) = report_start(&text) else {
            if old_report(&text) {
                bail!(
                    "{name}:{number}: a gate report without `seq=` and `tick=` (`{}`), from firmware older than the numbered reports; expected {FORMAT}: build and flash the current firmware",
                    text.trim()
                );
            }
            log.skipped += 1;
            continue;
        };
        if ends_open && number == lines.len() {
            log.cut_last = Some(number);
            continue;
        }
        log.reports
            .push(report(&format!("{name}:{number}"), number, &text, start)?);
    }
    Ok(log)
}

/// Reports lost between two that arrived.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Gap {
    /// Line of the report before the gap.
    pub after_line: usize,
    /// Line of the report after it.
    pub before_line: usize,
    /// First and last number of the gates missing.
    pub first_missing: u64,
    /// Last missing gate's number.
    pub last_missing: u64,
    /// Ticks of the missing gates (from the two reports' `tick`).
    pub missing_ticks: u64,
}

impl Gap {
    /// Gates missing.
    #[must_use]
    pub fn gates(&self) -> u64 {
        self.last_missing - self.first_missing + 1
    }
}

/// A report that holds more than one gate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Merge {
    /// Its line.
    pub line: usize,
    /// Gates summed in it.
    pub gates: u64,
}

/// One stream of reports, checked, and its counter record.
#[derive(Clone, Debug, PartialEq)]
pub struct Stream {
    /// The record's gates: start `(tick − T)/clock`, s; pulses; ticks.
    pub gates: Vec<Gate>,
    /// The reports' lines, first and last.
    pub lines: (usize, usize),
    /// The gate numbers the record covers, first and last.
    pub seq: (u64, u64),
    /// Lost reports.
    pub gaps: Vec<Gap>,
    /// Reports with merged gates.
    pub merges: Vec<Merge>,
}

impl Stream {
    /// Gates lost in the gaps.
    #[must_use]
    pub fn lost_gates(&self) -> u64 {
        self.gaps.iter().map(Gap::gates).sum()
    }

    /// Gates inside merged reports.
    #[must_use]
    pub fn merged_gates(&self) -> u64 {
        self.merges.iter().map(|m| m.gates).sum()
    }
}

/// The axes the log's reports name, sorted (empty for a single-axis log).
#[must_use]
pub fn axes(log: &Log) -> Vec<u64> {
    let mut v: Vec<u64> = log.reports.iter().filter_map(|r| r.axis).collect();
    v.sort_unstable();
    v.dedup();
    v
}

/// The reports of one stream: all of a single-axis log (`axis` `None`), or those of `axis`
/// in a triad log.
///
/// # Errors
/// No report at all; a log that mixes reports with and without `axis=`; a triad log without
/// `axis`; `axis` given for a single-axis log or naming an axis the log does not hold.
pub fn select(name: &str, log: &Log, axis: Option<u64>) -> Result<Vec<Report>> {
    if log.reports.is_empty() {
        let cut = log.cut_last.map_or(String::new(), |l| {
            format!(" (the one on line {l} is cut short by the log's end)")
        });
        bail!(
            "{name}: no gate reports in {} lines{cut}; expected lines holding {FORMAT}: probe-rs run's output, QEMU's semihosting output or a saved copy",
            log.lines
        );
    }
    let have = axes(log);
    if !have.is_empty()
        && let Some(r) = log.reports.iter().find(|r| r.axis.is_none())
    {
        bail!(
            "{name}:{}: a report without `axis=` in a log whose other reports name axes; expected one firmware's log",
            r.line
        );
    }
    let list = |v: &[u64]| v.iter().map(u64::to_string).collect::<Vec<_>>().join(", ");
    match (axis, have.is_empty()) {
        (None, true) => Ok(log.reports.clone()),
        (None, false) => bail!(
            "{name}: reports of axes {} (a triad's log); expected --axis N to choose one",
            list(&have)
        ),
        (Some(a), true) => bail!(
            "--axis {a}: {name} is a single-axis log (its reports have no `axis=`); expected no --axis"
        ),
        (Some(a), false) => {
            if !have.contains(&a) {
                bail!(
                    "--axis {a}: {name} has no reports of axis {a}; expected one of {}",
                    list(&have)
                );
            }
            Ok(log
                .reports
                .iter()
                .filter(|r| r.axis == Some(a))
                .copied()
                .collect())
        }
    }
}

/// Check one stream's sequence and turn it into gates, `time_s` from the tick counts and
/// the clock `clock_hz` (Hz). Gaps and merges are returned, not refused (the caller decides).
///
/// # Errors
/// The sequence runs backwards or stands still (a restart: the board reset, logs joined),
/// or the tick counts disagree with the gates' ticks (a corrupt report): both lines named.
pub fn check(name: &str, reports: &[Report], clock_hz: f64) -> Result<Stream> {
    let Some(first) = reports.first() else {
        bail!("{name}: no gate reports");
    };
    let mut s = Stream {
        gates: Vec::with_capacity(reports.len()),
        lines: (first.line, first.line),
        seq: (first.seq - first.gates + 1, first.seq),
        gaps: Vec::new(),
        merges: Vec::new(),
    };
    let mut prev: Option<&Report> = None;
    for r in reports {
        if let Some(p) = prev {
            if r.seq <= p.seq || r.tick <= p.tick {
                bail!(
                    "{name}:{}: gate report with seq={} tick={} after seq={} tick={} on line {}: the sequence starts again (the board was reset, or two logs are joined); expected increasing numbers, one run per record",
                    r.line,
                    r.seq,
                    r.tick,
                    p.seq,
                    p.tick,
                    p.line
                );
            }
            let step = r.seq - p.seq;
            let span = r.tick - p.tick;
            if step == r.gates {
                if span != r.ticks {
                    bail!(
                        "{name}:{}: gate report's tick={} is {span} ticks after line {}'s tick={}, not its T={}; expected consecutive gates to add up (a corrupt report)",
                        r.line,
                        r.tick,
                        p.line,
                        p.tick,
                        r.ticks
                    );
                }
            } else if step < r.gates || span <= r.ticks {
                bail!(
                    "{name}:{}: gate report seq={} gates={} tick={} T={} does not follow line {}'s seq={} tick={}: expected seq to grow by gates and tick by T (a corrupt report)",
                    r.line,
                    r.seq,
                    r.gates,
                    r.tick,
                    r.ticks,
                    p.line,
                    p.seq,
                    p.tick
                );
            } else {
                s.gaps.push(Gap {
                    after_line: p.line,
                    before_line: r.line,
                    first_missing: p.seq + 1,
                    last_missing: r.seq - r.gates,
                    missing_ticks: span - r.ticks,
                });
            }
        }
        if r.gates > 1 {
            s.merges.push(Merge {
                line: r.line,
                gates: r.gates,
            });
        }
        #[allow(clippy::cast_precision_loss)]
        let time_s = (r.tick - r.ticks) as f64 / clock_hz;
        s.gates.push(Gate {
            time_s,
            pulses: r.pulses,
            ticks: r.ticks,
        });
        s.lines.1 = r.line;
        s.seq.1 = r.seq;
        prev = Some(r);
    }
    Ok(s)
}

/// The gaps as text for a message, the first few in full: `lines 4-5: gates 3..4 (2 gates,
/// 12800 ticks)`.
#[must_use]
pub fn gaps_text(gaps: &[Gap]) -> String {
    const SHOWN: usize = 5;
    let mut t = gaps
        .iter()
        .take(SHOWN)
        .map(|g| {
            format!(
                "lines {}-{}: gate{} {} ({} ticks)",
                g.after_line,
                g.before_line,
                if g.gates() == 1 { "" } else { "s" },
                if g.gates() == 1 {
                    g.first_missing.to_string()
                } else {
                    format!("{}..{}", g.first_missing, g.last_missing)
                },
                g.missing_ticks
            )
        })
        .collect::<Vec<_>>()
        .join("; ");
    if gaps.len() > SHOWN {
        let _ = write!(t, "; and {} more", gaps.len() - SHOWN);
    }
    t
}

/// The counter record's text: a comment naming the source and the counts, the header
/// `time_s,pulses,ticks`, one line per gate (times in Rust's shortest round-trip form).
#[must_use]
pub fn record_csv(source: &str, axis: Option<u64>, s: &Stream, clock_hz: f64) -> String {
    let axis = axis.map_or(String::new(), |a| format!(", axis {a}"));
    let mut t = format!(
        "# ptsa record: {n} gate reports from {source}{axis} (lines {}..{}), gates {}..{}; {} gap(s), {} gate(s) lost; {} merged report(s) holding {} gate(s); time_s = (tick - T) / {clock_hz} Hz\ntime_s,pulses,ticks\n",
        s.lines.0,
        s.lines.1,
        s.seq.0,
        s.seq.1,
        s.gaps.len(),
        s.lost_gates(),
        s.merges.len(),
        s.merged_gates(),
        n = s.gates.len(),
    );
    for g in &s.gates {
        let _ = writeln!(t, "{},{},{}", g.time_s, g.pulses, g.ticks);
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    fn log(text: &str) -> Log {
        parse("log", text.as_bytes()).unwrap()
    }

    #[test]
    fn reports_are_found_behind_any_prefix() {
        let l = log(concat!(
            "tim2 psc=0 arr=15624 ug_ns=130983\n",
            "gate seq=1 P=3 T=10 gates=1 tick=10 t_ns=5 stack=544\n",
            "0.000001 INFO  gate seq=2 P=4 T=10 gates=1 tick=20 stack=544\n",
            "└─ ptsa::__cortex_m_rt_main @ src/bin/ptsa.rs:80\n",
            "[INFO ] \u{1b}[32mgate seq=3 P=5 T=10 gates=1 tick=30 stack=544\u{1b}[0m (ptsa src/bin/ptsa.rs:80)\r\n",
            "PTSA loop running: 64000 Hz tick, gate 64000 ticks\n",
            "gate axis=2 seq=1 P=1 T=2 gates=1 tick=2\n",
        ));
        assert_eq!(l.lines, 6 + 1);
        assert_eq!(l.skipped, 3);
        let seqs: Vec<u64> = l.reports.iter().map(|r| r.seq).collect();
        assert_eq!(seqs, [1, 2, 3, 1]);
        assert_eq!(l.reports[2].pulses, 5);
        assert_eq!(l.reports[2].line, 5);
        assert_eq!(l.reports[3].axis, Some(2));
    }

    #[test]
    fn malformed_reports_name_line_and_column() {
        let e = parse("x.log", b"junk\ngate seq=1 P=3 T=1O gates=1 tick=10\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("x.log:2:18: gate report's `T=` holds `1O`"),
            "{e}"
        );
        let e = parse("x.log", b"gate seq=1 P=3 T=10 tick=10\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("x.log:1:1: gate report without `gates=`"), "{e}");
        let e = parse("x.log", b"gate seq=1 P=30 T=10 gates=1 tick=10\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("expected T >= 1, P <= T"), "{e}");
        let e = parse(
            "x.log",
            b"0 INFO gate P=3 T=10 (1 gate(s)); stack high-water 5 B\n",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("older than the numbered reports"), "{e}");
        let e = parse("x.log", b"gate 1: P=0 T=6400 gates=1 t_ns=1 stack=2\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("x.log:1: a gate report without `seq=`"), "{e}");
    }

    #[test]
    fn a_cut_last_line_is_dropped() {
        let l = log("gate seq=1 P=3 T=10 gates=1 tick=10\ngate seq=2 P=3 T=10 gates=1 ti");
        assert_eq!(l.reports.len(), 1);
        assert_eq!(l.cut_last, Some(2));
        // Even when what is there parses: its last number may be cut short.
        let l = log("gate seq=1 P=3 T=10 gates=1 tick=10\ngate seq=2 P=3 T=10 gates=1 tick=2");
        assert_eq!((l.reports.len(), l.cut_last), (1, Some(2)));
        // An unterminated line that is no report is just skipped.
        let l = log("gate seq=1 P=3 T=10 gates=1 tick=10\nPTSA");
        assert_eq!((l.reports.len(), l.cut_last, l.skipped), (1, None, 1));
    }

    #[test]
    fn gaps_merges_and_restarts() {
        let l = log(concat!(
            "gate seq=1 P=3 T=10 gates=1 tick=10\n",
            "gate seq=3 P=9 T=20 gates=2 tick=30\n",
            "gate seq=6 P=4 T=10 gates=1 tick=60\n",
        ));
        let s = check("log", &l.reports, 10.0).unwrap();
        assert_eq!(s.merges, [Merge { line: 2, gates: 2 }]);
        assert_eq!(
            s.gaps,
            [Gap {
                after_line: 2,
                before_line: 3,
                first_missing: 4,
                last_missing: 5,
                missing_ticks: 20
            }]
        );
        assert_eq!(s.lost_gates(), 2);
        let times: Vec<f64> = s.gates.iter().map(|g| g.time_s).collect();
        assert_eq!(times, [0.0, 1.0, 5.0]);
        assert_eq!(gaps_text(&s.gaps), "lines 2-3: gates 4..5 (20 ticks)");
        // A restart is refused whatever the flags.
        let l = log("gate seq=7 P=3 T=10 gates=1 tick=70\ngate seq=1 P=3 T=10 gates=1 tick=10\n");
        let e = check("log", &l.reports, 10.0).unwrap_err().to_string();
        assert!(e.contains("log:2: gate report with seq=1 tick=10 after seq=7 tick=70 on line 1: the sequence starts again"), "{e}");
        // Ticks that do not add up.
        let l = log("gate seq=1 P=3 T=10 gates=1 tick=10\ngate seq=2 P=3 T=10 gates=1 tick=25\n");
        let e = check("log", &l.reports, 10.0).unwrap_err().to_string();
        assert!(
            e.contains("log:2: gate report's tick=25 is 15 ticks after line 1's"),
            "{e}"
        );
    }

    #[test]
    fn axes_are_selected() {
        let l = log(
            "gate axis=0 seq=1 P=1 T=2 gates=1 tick=2\ngate axis=1 seq=1 P=2 T=2 gates=1 tick=2\n",
        );
        assert_eq!(axes(&l), [0, 1]);
        assert_eq!(select("l", &l, Some(1)).unwrap()[0].pulses, 2);
        assert!(
            select("l", &l, None)
                .unwrap_err()
                .to_string()
                .contains("axes 0, 1")
        );
        assert!(
            select("l", &l, Some(5))
                .unwrap_err()
                .to_string()
                .contains("one of 0, 1")
        );
        let single = log("gate seq=1 P=1 T=2 gates=1 tick=2\n");
        assert!(
            select("l", &single, Some(0))
                .unwrap_err()
                .to_string()
                .contains("single-axis")
        );
    }
}
