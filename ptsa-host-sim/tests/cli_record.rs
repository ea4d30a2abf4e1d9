//! `ptsa record`: the firmware's gate reports (the QEMU image's own log, probe-rs-style
//! defmt logs, synthetic logs with gaps, merges, restarts, junk and cut lines) turned into
//! the counter record `ptsa response` reads; and the chain log → record → response giving
//! the simulated loop's frequency response.

mod common;

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;
use std::process::{Command, Stdio};

use common::{assert_clean_of, names, ptsa_in, refused_in_folder, stderr, stdout};

/// The production image's QEMU output, recorded by `cargo xtask firmware --overwrite-log`.
const QEMU_LOG: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../tests/golden/firmware-qemu.stdout"
);

/// The triad image's QEMU output, recorded the same way.
const TRIAD_LOG: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../tests/golden/triad-qemu.stdout"
);

/// The value of `key=` in a report line.
fn field(line: &str, key: &str) -> u64 {
    line.split_whitespace()
        .find_map(|w| w.strip_prefix(key)?.strip_prefix('=')?.parse().ok())
        .unwrap_or_else(|| panic!("no {key}= in `{line}`"))
}

/// The data rows of a record (its comment and header checked and left out).
fn rows(record: &str) -> Vec<(f64, u64, u64)> {
    let mut lines = record.lines();
    let comment = lines.next().unwrap();
    assert!(comment.starts_with("# ptsa record: "), "{record}");
    assert_eq!(lines.next(), Some("time_s,pulses,ticks"), "{record}");
    lines
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            assert_eq!(c.len(), 3, "{l}");
            (
                c[0].parse().unwrap(),
                c[1].parse().unwrap(),
                c[2].parse().unwrap(),
            )
        })
        .collect()
}

/// Run `ptsa args` in `dir` with `input` on standard input.
fn ptsa_stdin(dir: &Path, args: &[&str], input: &[u8]) -> std::process::Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_ptsa"))
        .current_dir(dir)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(input).unwrap();
    child.wait_with_output().unwrap()
}

/// A report line of the single-axis firmware, in QEMU's semihosting form.
fn report(seq: u64, p: u64, t: u64, gates: u64, tick: u64) -> String {
    format!("gate seq={seq} P={p} T={t} gates={gates} tick={tick} t_ns=0 stack=544\n")
}

/// The log the QEMU production image wrote goes through: one row per report, its start
/// `(tick − T)/64000` s, P and T as the image counted them (read here from the log's own
/// fields), the other lines skipped, the summary in --json.
#[test]
fn the_qemu_images_own_log_becomes_a_record() {
    let log = std::fs::read_to_string(QEMU_LOG).unwrap();
    let reports: Vec<&str> = log.lines().filter(|l| l.starts_with("gate ")).collect();
    assert!(reports.len() >= 3, "{log}");
    let tmp = tempfile::tempdir().unwrap();
    let o = ptsa_in(
        tmp.path(),
        &[
            "record", "--from", QEMU_LOG, "--output", "rec.csv", "--json",
        ],
    );
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("warning:"), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["reports"], reports.len());
    assert_eq!(v["gates"], reports.len());
    assert_eq!(v["first_seq"], 1);
    assert_eq!(v["gaps"], serde_json::json!([]));
    assert_eq!(v["merged_gates"], 0);
    assert_eq!(v["skipped_lines"], log.lines().count() - reports.len());
    assert_eq!(v["clock_hz"], 64_000.0);
    let rec = std::fs::read_to_string(tmp.path().join("rec.csv")).unwrap();
    let got = rows(&rec);
    assert_eq!(got.len(), reports.len());
    for (r, (t, p, n)) in reports.iter().zip(&got) {
        assert_eq!(*p, field(r, "P"));
        assert_eq!(*n, field(r, "T"));
        #[allow(clippy::cast_precision_loss)]
        let want = (field(r, "tick") - field(r, "T")) as f64 / 64_000.0;
        assert!((t - want).abs() < 1e-12, "{t} vs {want}");
    }
    assert!(rec.contains("firmware-qemu.stdout"), "{rec}");
}

/// A probe-rs-style defmt log on standard input: timestamps, levels, ANSI colours,
/// location lines, CRLF line ends, a line of bytes that are not UTF-8 and other junk; the
/// record is the same as from the bare reports.
#[test]
fn a_defmt_log_with_prefixes_and_junk_reads_on_stdin() {
    let mut log = Vec::new();
    log.extend_from_slice(b"      Erasing \xe2\x9c\x94 100% [####] 16.00 KiB\r\n");
    log.extend_from_slice(b"0.000000 INFO  PTSA loop running: 64000 Hz tick, gate 64000 ticks\r\n");
    log.extend_from_slice(b"\xff\xfe garbage from a reset \x00\r\n");
    let mut bare = String::new();
    for k in 1..=6u64 {
        let p = 31_990 + k;
        let line = format!(
            "gate seq={k} P={p} T=64000 gates=1 tick={} stack=568",
            k * 64_000
        );
        let _ = writeln!(bare, "{line}");
        let _ = write!(
            log,
            "{k}.000001 \u{1b}[32mINFO \u{1b}[0m {line}\r\n\u{2514}\u{2500} ptsa::__cortex_m_rt_main @ src/bin/ptsa.rs:83\r\n"
        );
    }
    let tmp = tempfile::tempdir().unwrap();
    let o = ptsa_stdin(tmp.path(), &["record", "--from", "-"], &log);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert_clean_of(&err, &["warning:"]);
    assert!(err.contains("stdin: 6 gate report(s)"), "{err}");
    let got = rows(&stdout(&o));
    let o2 = ptsa_stdin(tmp.path(), &["record", "--from", "-"], bare.as_bytes());
    assert_eq!(got, rows(&stdout(&o2)));
    assert_eq!(got.len(), 6);
    assert_eq!(got[0], (0.0, 31_991, 64_000));
    assert_eq!(got[5], (5.0, 31_996, 64_000));
    assert!(names(tmp.path()).is_empty());
}

/// A gap (reports lost on the way) is refused with the lines around it and nothing
/// written; --allow-gaps writes the gates around it at their true times, with a warning and
/// the gap in --json.
#[test]
fn a_gap_is_refused_unless_allowed() {
    let mut log = String::from("boot\n");
    for k in [1u64, 2, 5, 6] {
        log += &report(k, 100 + k, 1000, 1, 1000 * k);
    }
    let err = refused_in_folder(
        &[("run.log", log.as_bytes())],
        &["record", "--from", "run.log", "--output", "rec.csv"],
        1,
        &[
            "run.log: 1 gap(s) in the gate numbers, 2 gate(s) lost",
            "lines 3-4: gates 3..4 (2000 ticks)",
            "--allow-gaps",
        ],
        &[],
    );
    assert!(err.starts_with("error: "), "{err}");
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("run.log"), &log).unwrap();
    let o = ptsa_in(
        tmp.path(),
        &[
            "record",
            "--from",
            "run.log",
            "--output",
            "rec.csv",
            "--allow-gaps",
            "--json",
        ],
    );
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["lost_gates"], 2);
    assert_eq!(v["gaps"][0]["after_line"], 3);
    assert_eq!(v["gaps"][0]["before_line"], 4);
    assert_eq!(v["gaps"][0]["missing_ticks"], 2000);
    let w = v["warnings"][0].as_str().unwrap();
    assert!(w.contains("written with the gaps (--allow-gaps)"), "{w}");
    let got = rows(&std::fs::read_to_string(tmp.path().join("rec.csv")).unwrap());
    let times: Vec<f64> = got.iter().map(|r| r.0).collect();
    assert_eq!(
        times,
        [0.0, 1000.0 / 64_000.0, 4000.0 / 64_000.0, 5000.0 / 64_000.0]
    );
    // Without --json the warning is on stderr.
    let o = ptsa_in(tmp.path(), &["record", "--from", "run.log", "--allow-gaps"]);
    assert!(
        stderr(&o).contains("warning: run.log: 1 gap(s)"),
        "{}",
        stderr(&o)
    );
}

/// Gates the firmware's queue merged are kept, exactly, as one longer gate, and counted.
#[test]
fn merged_gates_are_counted_and_kept_whole() {
    let log = [
        report(1, 10, 1000, 1, 1000),
        report(4, 33, 3000, 3, 4000),
        report(5, 12, 1000, 1, 5000),
    ]
    .concat();
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("m.log"), &log).unwrap();
    let o = ptsa_in(tmp.path(), &["record", "--from", "m.log"]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("warning: m.log: 1 report(s) hold 3 merged gates (lines 2 (3 gates))"),
        "{err}"
    );
    assert!(err.contains("`ptsa response` refuses"), "{err}");
    assert_eq!(
        rows(&stdout(&o)),
        [
            (0.0, 10, 1000),
            (1000.0 / 64_000.0, 33, 3000),
            (4000.0 / 64_000.0, 12, 1000)
        ]
    );
    assert!(stdout(&o).contains("1 merged report(s) holding 3 gate(s)"));
}

/// A sequence that starts again (the board reset, two logs joined, or a counter that
/// wrapped) is refused even with --allow-gaps, naming both lines; so are reports whose
/// ticks do not add up.
#[test]
fn a_restart_or_a_wrapped_counter_is_refused() {
    let restart = [report(7, 1, 10, 1, 70), report(1, 1, 10, 1, 10)].concat();
    refused_in_folder(
        &[("r.log", restart.as_bytes())],
        &["record", "--from", "r.log", "--allow-gaps"],
        1,
        &[
            "r.log:2: gate report with seq=1 tick=10 after seq=7 tick=70 on line 1",
            "the sequence starts again",
        ],
        &[],
    );
    // A tick count that wrapped at 2^32 (as a 32-bit counter would): it lands below T.
    let wrapped = [
        report(671_088, 10, 6400, 1, 4_294_963_200),
        report(671_089, 10, 6400, 1, 4_294_969_600 - (1 << 32)),
    ]
    .concat();
    refused_in_folder(
        &[("w.log", wrapped.as_bytes())],
        &["record", "--from", "w.log", "--allow-gaps"],
        1,
        &[
            "w.log:2:1: gate report with tick=2304 below its T=6400",
            "a tick counter that wrapped",
        ],
        &[],
    );
    let bad = [report(1, 1, 10, 1, 10), report(2, 1, 10, 1, 25)].concat();
    refused_in_folder(
        &[("b.log", bad.as_bytes())],
        &["record", "--from", "b.log"],
        1,
        &["b.log:2: gate report's tick=25 is 15 ticks after line 1's tick=10, not its T=10"],
        &[],
    );
}

/// A log cut inside its last report (no line end) loses that report, with a warning; the
/// rest is written. A malformed report elsewhere is refused with its line and column.
#[test]
fn a_cut_last_line_is_dropped_and_a_bad_report_refused() {
    let mut log = [report(1, 1, 10, 1, 10), report(2, 2, 10, 1, 20)].concat();
    log += "gate seq=3 P=3 T=10 gates=1 tick=3";
    let tmp = tempfile::tempdir().unwrap();
    let o = ptsa_stdin(tmp.path(), &["record", "--from", "-"], log.as_bytes());
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains(
            "warning: stdin:3: the log ends inside this gate report (no line end); dropped"
        ),
        "{err}"
    );
    assert_eq!(rows(&stdout(&o)).len(), 2);
    let bad = [
        report(1, 1, 10, 1, 10),
        "gate seq=2 P=x T=10 gates=1 tick=20\n".into(),
    ]
    .concat();
    refused_in_folder(
        &[("bad.log", bad.as_bytes())],
        &["record", "--from", "bad.log"],
        1,
        &["bad.log:2:14: gate report's `P=` holds `x`; expected a whole number"],
        &[],
    );
    refused_in_folder(
        &[(
            "old.log",
            b"0 INFO gate P=3 T=64000 (1 gate(s)); stack high-water 544 B\n",
        )],
        &["record", "--from", "old.log"],
        1,
        &[
            "old.log:1: a gate report without `seq=` and `tick=`",
            "build and flash the current firmware",
        ],
        &[],
    );
    refused_in_folder(
        &[("none.log", b"PTSA loop running\nnothing else\n")],
        &["record", "--from", "none.log"],
        1,
        &["none.log: no gate reports in 2 lines"],
        &[],
    );
}

/// The record is never written over a file without --force, never over the log itself,
/// and --json needs --out; the files' bytes are unchanged by a refusal.
#[test]
fn existing_files_and_the_log_are_safe() {
    let log = [report(1, 1, 10, 1, 10), report(2, 2, 10, 1, 20)].concat();
    let old = b"time_s,pulses,ticks\n0,5,10\n";
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("a.log"), &log).unwrap();
    std::fs::write(tmp.path().join("day.csv"), old).unwrap();
    let o = ptsa_in(
        tmp.path(),
        &["record", "--from", "a.log", "--output", "day.csv"],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o)
            .contains("--output day.csv: the file exists and is not replaced without --force"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(tmp.path().join("day.csv")).unwrap(), old);
    let o = ptsa_in(
        tmp.path(),
        &["record", "--from", "a.log", "--output", "a.log", "--force"],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("an output never replaces an input"),
        "{}",
        stderr(&o)
    );
    assert_eq!(
        std::fs::read(tmp.path().join("a.log")).unwrap(),
        log.as_bytes()
    );
    let o = ptsa_in(
        tmp.path(),
        &[
            "record", "--from", "a.log", "--output", "day.csv", "--force",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("warning: --output day.csv: replaced"),
        "{}",
        stderr(&o)
    );
    assert_eq!(
        rows(&std::fs::read_to_string(tmp.path().join("day.csv")).unwrap()).len(),
        2
    );
    assert_eq!(names(tmp.path()), ["a.log", "day.csv"]);
    refused_in_folder(
        &[("a.log", log.as_bytes())],
        &["record", "--from", "a.log", "--json"],
        1,
        &[
            "--json: the record and the JSON would both go to standard output; expected --output FILE",
        ],
        &[],
    );
    refused_in_folder(
        &[("a.log", log.as_bytes())],
        &["record", "--from", "missing.log"],
        1,
        &["--from missing.log: cannot read"],
        &[],
    );
}

/// A triad's log (reports with axis=) is split by --axis; it is refused without one, and
/// --axis is refused on a single-axis log or for an axis the log does not hold.
#[test]
fn a_triad_log_is_split_by_axis() {
    let mut log = String::new();
    for k in 1..=4u64 {
        for a in 0..3u64 {
            let _ = writeln!(
                log,
                "gate axis={a} seq={k} P={} T=100 gates=1 tick={} stack=900",
                10 * a + k,
                100 * k
            );
        }
    }
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("t.log"), &log).unwrap();
    for a in 0..3u64 {
        let o = ptsa_in(
            tmp.path(),
            &["record", "--from", "t.log", "--axis", &a.to_string()],
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let got = rows(&stdout(&o));
        let p: Vec<u64> = got.iter().map(|r| r.1).collect();
        assert_eq!(p, (1..=4).map(|k| 10 * a + k).collect::<Vec<_>>());
        assert!(stdout(&o).contains(&format!("axis {a}")));
    }
    refused_in_folder(
        &[("t.log", log.as_bytes())],
        &["record", "--from", "t.log"],
        1,
        &["t.log: reports of axes 0, 1, 2 (a triad's log); expected --axis N"],
        &[],
    );
    refused_in_folder(
        &[("t.log", log.as_bytes())],
        &["record", "--from", "t.log", "--axis", "3"],
        1,
        &["--axis 3: t.log has no reports of axis 3; expected one of 0, 1, 2"],
        &[],
    );
    let single = report(1, 1, 10, 1, 10);
    refused_in_folder(
        &[("s.log", single.as_bytes())],
        &["record", "--from", "s.log", "--axis", "0"],
        1,
        &["--axis 0: s.log is a single-axis log"],
        &[],
    );
}

/// The triad image's own QEMU log splits into its three axes: each axis's record holds
/// that axis's reports (read here from the log's own fields), in order.
#[test]
fn the_triad_images_own_log_splits_by_axis() {
    let log = std::fs::read_to_string(TRIAD_LOG).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    for a in 0..3u64 {
        let reports: Vec<&str> = log
            .lines()
            .filter(|l| l.starts_with(&format!("gate axis={a} ")))
            .collect();
        assert!(reports.len() >= 3, "{log}");
        let o = ptsa_in(
            tmp.path(),
            &["record", "--from", TRIAD_LOG, "--axis", &a.to_string()],
        );
        let err = stderr(&o);
        assert!(o.status.success(), "{err}");
        assert!(!err.contains("warning:"), "{err}");
        let got = rows(&stdout(&o));
        assert_eq!(got.len(), reports.len());
        for (r, (t, p, n)) in reports.iter().zip(&got) {
            assert_eq!((*p, *n), (field(r, "P"), field(r, "T")));
            #[allow(clippy::cast_precision_loss)]
            let want = (field(r, "tick") - field(r, "T")) as f64 / 64_000.0;
            assert!((t - want).abs() < 1e-12, "{t} vs {want}");
        }
    }
    refused_in_folder(
        &[],
        &["record", "--from", TRIAD_LOG],
        1,
        &["reports of axes 0, 1, 2 (a triad's log); expected --axis N"],
        &[],
    );
}

/// The other refusals, each with its one-line message and nothing written: a field given
/// twice, a report whose numbers cannot be (seq below gates), a report that does not follow
/// its predecessor, a log mixing reports with and without axis=, --force without --out,
/// --from a folder, a log whose only report is cut short.
#[test]
fn the_other_refusals_name_what_was_expected() {
    let twice = "gate seq=1 P=1 T=10 gates=1 tick=10 P=2\n";
    refused_in_folder(
        &[("a.log", twice.as_bytes())],
        &["record", "--from", "a.log"],
        1,
        &["a.log:1:39: gate report gives `P=` twice"],
        &[],
    );
    let low = "gate seq=1 P=1 T=10 gates=2 tick=10\n";
    refused_in_folder(
        &[("a.log", low.as_bytes())],
        &["record", "--from", "a.log"],
        1,
        &[
            "a.log:1:1: gate report with seq=1 P=1 T=10 gates=2 tick=10; expected T >= 1, P <= T, gates >= 1, seq >= gates",
        ],
        &[],
    );
    let skew = [report(1, 1, 10, 1, 10), report(3, 1, 10, 3, 40)].concat();
    refused_in_folder(
        &[("a.log", skew.as_bytes())],
        &["record", "--from", "a.log", "--allow-gaps"],
        1,
        &["a.log:2: gate report seq=3 gates=3 tick=40 T=10 does not follow line 1's seq=1 tick=10"],
        &[],
    );
    let mixed = [
        "gate axis=0 seq=1 P=1 T=10 gates=1 tick=10\n".to_string(),
        report(1, 1, 10, 1, 10),
    ]
    .concat();
    refused_in_folder(
        &[("a.log", mixed.as_bytes())],
        &["record", "--from", "a.log", "--axis", "0"],
        1,
        &["a.log:2: a report without `axis=` in a log whose other reports name axes"],
        &[],
    );
    let one = report(1, 1, 10, 1, 10);
    refused_in_folder(
        &[("a.log", one.as_bytes())],
        &["record", "--from", "a.log", "--force"],
        1,
        &["--force: nothing to replace without --output; expected --output FILE"],
        &[],
    );
    refused_in_folder(
        &[("a.log", one.as_bytes())],
        &["record", "--from", "{dir}"],
        1,
        &["this is a folder; expected a log file or - for standard input"],
        &[],
    );
    refused_in_folder(
        &[("a.log", b"boot\ngate seq=1 P=1 T=10 gat")],
        &["record", "--from", "a.log"],
        1,
        &["a.log: no gate reports in 2 lines (the one on line 2 is cut short by the log's end)"],
        &[],
    );
}

/// `--help` names the units and the format.
#[test]
fn record_help_names_the_format_and_units() {
    let tmp = tempfile::tempdir().unwrap();
    let o = ptsa_in(tmp.path(), &["record", "--help"]);
    let h = stdout(&o);
    for needle in [
        "gate [axis=K] seq=N P=N T=N gates=N tick=N",
        "time_s,pulses,ticks",
        "clock_hz, in s",
        "--allow-gaps",
        "--axis",
        "standard input",
    ] {
        assert!(h.contains(needle), "`{needle}` not in:\n{h}");
    }
}

/// The chain log → `ptsa record` → `ptsa response`: gates counted by the simulated closed
/// loop of the shipped file under a 20 Hz, 2000 cm/s² sine along IA (5 ms gates over 1 s
/// after the settling), written as the firmware's defmt reports (probe-rs's prefixes, the
/// tick count from the loop's first tick), give the frequency response the simulator
/// measures on the same second (the component at 20 Hz of its pulse train), within the
/// fit's uncertainty.
#[test]
fn a_simulated_gate_stream_goes_through_record_and_response() {
    use ptsa_host_sim::model::condition::{Condition, IA};
    use ptsa_host_sim::simulation::sim::{ClosedLoop, SimOptions};
    use ptsa_host_sim::{Effects, Instrument};
    let (f, amp, gate, n) = (20.0, 2000.0, 320u64, 200u64);
    let instr = Instrument::kearfott_2401();
    let mut c = Condition {
        freq_hz: f,
        ..Condition::default()
    };
    c.lin_cm_s2[IA] = amp;
    let opts = SimOptions {
        harmonic: 1,
        ..SimOptions::default()
    };
    let mut l = ClosedLoop::new(&instr, &c, &Effects::NONE, &opts);
    // The firmware numbers every gate from the loop's first tick: the settling is gates too.
    let warm = opts.warmup_ticks(instr.clock_hz).div_ceil(gate) * gate;
    let mut log = String::from("0.000000 INFO  PTSA loop running: 64000 Hz tick, gate 320 ticks\n");
    let mut seq = 0;
    let mut first_time = None;
    while l.ticks() < warm + n * gate {
        let p0 = l.core().total_pulses();
        l.run(gate);
        seq += 1;
        if l.ticks() <= warm {
            continue;
        }
        #[allow(clippy::cast_precision_loss)]
        let start_s = (l.ticks() - gate) as f64 / instr.clock_hz;
        first_time.get_or_insert(start_s);
        let _ = writeln!(
            log,
            "{seq}.0 INFO  gate seq={seq} P={} T={gate} gates=1 tick={} stack=568\n\u{2514}\u{2500} ptsa::__cortex_m_rt_main @ src/bin/ptsa.rs:83",
            (l.core().total_pulses() - p0).0,
            l.ticks()
        );
    }
    // The simulator's own measure of the same second.
    let mut l2 = ClosedLoop::new(&instr, &c, &Effects::NONE, &opts);
    l2.run(warm);
    let r = l2.measure(n * gate);
    let (sim_gain, sim_deg) = (r.harmonic_amp_cm_s2 / amp, r.harmonic_deg);

    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("board.log"), &log).unwrap();
    let o = ptsa_in(
        tmp.path(),
        &["record", "--from", "board.log", "--output", "rec.csv"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("warning:"), "{}", stderr(&o));
    let rec = std::fs::read_to_string(tmp.path().join("rec.csv")).unwrap();
    assert_eq!(rows(&rec).len(), usize::try_from(n).unwrap());
    assert!((rows(&rec)[0].0 - first_time.unwrap()).abs() < 1e-12);
    let o = ptsa_in(
        tmp.path(),
        &[
            "response",
            "--counts",
            "rec.csv",
            "--sine-hz",
            "20",
            "--sine-cm-s2",
            "2000",
            "--json",
        ],
    );
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["warnings"], serde_json::json!([]), "{v}");
    let g = v["measured_gain"].as_f64().unwrap();
    let sg = v["sigma_gain"].as_f64().unwrap();
    let p = v["measured_phase_deg"].as_f64().unwrap();
    let sp = v["sigma_phase_deg"].as_f64().unwrap();
    eprintln!(
        "log -> record -> response: gain {g:.5} ± {sg:.5}, phase {p:.3} ± {sp:.3} deg; simulator: gain {sim_gain:.5}, phase {sim_deg:.3} deg"
    );
    assert!((g - sim_gain).abs() < 4.0 * sg, "{g} ± {sg} vs {sim_gain}");
    assert!((p - sim_deg).abs() < 4.0 * sp, "{p} ± {sp} vs {sim_deg}");
    assert!(g > 1.1 && p < -5.0, "{g} {p}");
}
