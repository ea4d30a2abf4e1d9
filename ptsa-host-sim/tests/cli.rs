//! The `ptsa` binary's contract: every subcommand refuses nonsense with a clear message
//! (what was given, what was expected, with units) and a non-zero exit, writes nothing on
//! bad input, and long work is bounded; `static --json` prints exactly one object.
//!
//! Every run starts in a fresh temporary folder (its working directory, so that even a
//! default `--out out` lands there) and a refused run must leave that folder as it was.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The report's SF, cm/s².
const SF: f64 = 21121.1;

/// Options that keep the closed-loop subcommands fast.
const FAST: [&str; 4] = ["--window-s", "0.01", "--warmup-s", "0.01"];

mod common;
use common::{names, ptsa_in, stderr, stdout};

/// Beyond a panic and Rust's or the OS's internals, a refusal here never shows a closed
/// pipe or a `file:0:0` position.
const ALSO_FORBIDDEN: [&str; 2] = ["Broken pipe", ":0:0"];

/// Nothing a user should ever see in a refusal.
fn assert_clean(err: &str) {
    common::assert_clean_of(err, &ALSO_FORBIDDEN);
}

/// [`common::refused_in_folder`] with this file's forbidden words. Returns stderr.
fn refused_with(files: &[(&str, &[u8])], args: &[&str], code: i32, needles: &[&str]) -> String {
    common::refused_in_folder(files, args, code, needles, &ALSO_FORBIDDEN)
}

/// [`refused_with`] in an empty folder.
fn refused(args: &[&str], code: i32, needles: &[&str]) -> String {
    refused_with(&[], args, code, needles)
}

/// Run `args` in `dir`; it must succeed. Returns (stdout, stderr).
fn succeeds_in(dir: &Path, args: &[&str]) -> (String, String) {
    let o = ptsa_in(dir, args);
    let err = stderr(&o);
    assert!(o.status.success(), "ptsa {args:?}: {err}");
    assert_clean(&err);
    (stdout(&o), err)
}

fn static_json(args: &[&str]) -> (serde_json::Value, String) {
    let tmp = tempfile::tempdir().unwrap();
    let mut a = vec!["static", "--json"];
    a.extend_from_slice(args);
    let (out, err) = succeeds_in(tmp.path(), &a);
    assert_eq!(out.lines().count(), 1, "{out}");
    (serde_json::from_str(&out).unwrap(), err)
}

fn with(base: &[&str], more: &[&str]) -> Vec<String> {
    base.iter().chain(more).map(|s| (*s).to_string()).collect()
}

fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

/// The shipped instrument file with one line replaced.
fn instrument_with(line: &str, by: &str) -> String {
    let text = include_str!("../../data/kearfott-2401.toml");
    assert!(text.contains(line), "{line}");
    text.replace(line, by)
}

#[test]
fn static_json_is_one_object_with_eq_6_1() {
    let (v, _) = static_json(&["--accel-cm-s2", "-250.5", "--seconds", "0.5"]);
    let o = v.as_object().unwrap();
    let keys: Vec<&str> = o.keys().map(String::as_str).collect();
    assert_eq!(keys.len(), 4);
    for k in ["ticks", "pulses", "indicated_cm_s2", "saturated"] {
        assert!(o.contains_key(k), "{v}");
    }
    assert_eq!(o["saturated"], false);
    let t = o["ticks"].as_u64().unwrap();
    let p = o["pulses"].as_u64().unwrap();
    assert_eq!(t, 32_000);
    #[allow(clippy::cast_precision_loss)]
    let x = SF * (2.0 * p as f64 / t as f64 - 1.0);
    let got = o["indicated_cm_s2"].as_f64().unwrap();
    assert!((got - x).abs() < 1e-9, "{got} vs {x}");
    // Within one pulse over the gate of the input (the loop's own bias is 0 for the shipped
    // file; the measured A_b only with --with-bias).
    assert!((got - -250.5).abs() <= 2.0 * SF / 32_000.0, "{got}");
    let (v, _) = static_json(&["--accel-cm-s2", "-250.5", "--seconds", "0.5", "--with-bias"]);
    let got = v["indicated_cm_s2"].as_f64().unwrap();
    assert!(
        (got - (-250.5 + 18.7)).abs() <= 2.0 * SF / 32_000.0,
        "{got}"
    );
}

/// Case 1: `static`'s inputs.
#[test]
fn static_refuses_nonsense_and_flags_saturation() {
    refused(
        &["static", "--accel-cm-s2", "NaN"],
        2,
        &[
            "'--accel-cm-s2 <CM_S2>'",
            "expected a finite number, not NaN",
        ],
    );
    refused(
        &["static", "--accel-cm-s2", "abc"],
        2,
        &["`abc` is not a number"],
    );
    // Beyond full scale: it runs, and both the JSON and stderr say the loop saturated.
    let (v, err) = static_json(&["--accel-cm-s2", "1e6"]);
    assert_eq!(v["saturated"], true, "{v}");
    assert!(
        err.contains("warning: the loop saturated during the gate")
            && err.contains("full scale of ±21121.1 cm/s^2"),
        "{err}"
    );
    let (v, err) = static_json(&["--accel-cm-s2", "0", "--seconds", "0.5"]);
    assert_eq!(v["saturated"], false, "{v}");
    assert!(err.is_empty(), "{err}");
    refused(
        &["static", "--accel-cm-s2", "0", "--seconds", "1e-9"],
        1,
        &[
            "--seconds 1e-9: expected a gate of at least one limit cycle, 0.001 s (64 ticks at 64000 Hz)",
        ],
    );
    refused(
        &["static", "--accel-cm-s2", "0", "--seconds", "1e7"],
        1,
        &[
            "--seconds 1e7: expected a gate of at most 67108 s, the longest the core's 32-bit counters hold",
        ],
    );
    refused(
        &["static", "--accel-cm-s2", "0", "--warmup-s", "-1"],
        2,
        &[
            "'--warmup-s <S>'",
            "expected a time in seconds from 0 to 1e9, not -1",
        ],
    );
    refused(
        &["static", "--accel-cm-s2", "0", "--warmup-s", "nan"],
        2,
        &["'--warmup-s <S>'", "expected a finite number, not NaN"],
    );
    refused(
        &["static", "--accel-cm-s2", "0", "--seed", "-1"],
        2,
        &["expected a seed: a whole number from 0 to 18446744073709551615, not `-1`"],
    );
}

/// `static` with several accelerations: one batch, one JSON array of the usual objects,
/// each bit for bit the object of its own single run (the batch engine's guarantee, here
/// through the command line), with or without the bias and with another seed; one table
/// row per value in text.
#[test]
fn static_batch_is_the_single_runs_bit_for_bit() {
    for extra in [
        &[][..],
        &["--with-bias", "--seed", "3", "--warmup-s", "0.05"][..],
    ] {
        let accels = ["-1000", "0.25", "2500.5"];
        let mut a = vec!["--accel-cm-s2", "-1000,0.25,2500.5", "--seconds", "0.05"];
        a.extend_from_slice(extra);
        let (batch, err) = static_json(&a);
        assert!(err.is_empty(), "{err}");
        let batch = batch.as_array().expect("an array").clone();
        assert_eq!(batch.len(), 3);
        for (x, b) in accels.iter().zip(&batch) {
            let mut a = vec!["--accel-cm-s2", x, "--seconds", "0.05"];
            a.extend_from_slice(extra);
            let (single, _) = static_json(&a);
            assert!(single.is_object(), "{single}");
            // JSON numbers are written in their shortest round-trip form: equal values are
            // equal bits.
            assert_eq!(b, &single, "{x} cm/s^2 with {extra:?}");
        }
        // The inputs differ, so the results do (the test would not see lanes mixed up
        // otherwise).
        assert_ne!(batch[0], batch[1]);
    }
    // Duplicates are fine, negative first values can be typed, saturation is flagged.
    let (v, err) = static_json(&["--accel-cm-s2", "-2e3,-2e3,3e4", "--seconds", "0.05"]);
    let v = v.as_array().unwrap();
    assert_eq!(v[0], v[1]);
    assert_eq!(v[2]["saturated"], true);
    assert!(
        err.contains("warning: the loop saturated during the gate at 30000 cm/s^2")
            && err.contains("full scale of ±21121.1 cm/s^2"),
        "{err}"
    );
    // Text: a header line, a column header, one row per value.
    let tmp = tempfile::tempdir().unwrap();
    let (out, _) = succeeds_in(
        tmp.path(),
        &[
            "static",
            "--accel-cm-s2",
            "-1000,0,1000",
            "--seconds",
            "0.05",
        ],
    );
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 5, "{out}");
    assert!(
        lines[0].starts_with("static: 3 accelerations along IA in one batch"),
        "{out}"
    );
    for (l, x) in lines[2..].iter().zip(["-1000", "0", "1000"]) {
        let cells: Vec<&str> = l.split_whitespace().collect();
        assert_eq!(cells.len(), 4, "{l}");
        assert_eq!(cells[0], x, "{l}");
        assert_eq!(cells[1], "3200", "{l}");
    }
    // Refused: an empty item, NaN, and --trace with several values.
    for list in ["1,,2", "1,2,", ",1", "-1,,2"] {
        refused(
            &["static", "--accel-cm-s2", list],
            2,
            &[
                "'--accel-cm-s2 <CM_S2>'",
                "an empty value in the list (a stray comma?)",
            ],
        );
    }
    refused(
        &["static", "--accel-cm-s2", "1,NaN"],
        2,
        &[
            "'--accel-cm-s2 <CM_S2>'",
            "expected a finite number, not NaN",
        ],
    );
    refused(
        &["static", "--accel-cm-s2", "1,2", "--trace", "t.txt"],
        1,
        &[
            "--trace writes the ADC samples of one run; expected one --accel-cm-s2 value with it, not 2",
        ],
    );
    // The work estimate counts every gate (one of these alone is allowed; forty are
    // refused even on 4 cores).
    let forty = vec!["0"; 40].join(",");
    refused(
        &["static", "--accel-cm-s2", &forty, "--seconds", "67000"],
        1,
        &["this batch of 40 gates would run about 1.72e11 clock ticks"],
    );
}

/// Case 1: `static --trace` writes one ADC code per tick, settling included.
#[test]
fn static_trace_has_one_sample_per_tick_settling_included() {
    let tmp = tempfile::tempdir().unwrap();
    let f = tmp.path().join("trace.txt");
    let (out, _) = succeeds_in(
        tmp.path(),
        &[
            "static",
            "--accel-cm-s2",
            "1000",
            "--seconds",
            "0.05",
            "--json",
            "--trace",
            f.to_str().unwrap(),
        ],
    );
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let gate = v["ticks"].as_u64().unwrap();
    assert_eq!(gate, 3200);
    let text = std::fs::read_to_string(&f).unwrap();
    let (comments, samples): (Vec<&str>, Vec<&str>) =
        text.lines().partition(|l| l.starts_with('#'));
    assert_eq!(comments.len(), 1, "{comments:?}");
    assert!(
        comments[0].contains("6400 settling ticks then a gate of 3200 ticks"),
        "{}",
        comments[0]
    );
    // The default settling time, 0.1 s = 6400 ticks, then the gate.
    assert_eq!(samples.len() as u64, 6400 + gate);
    assert!(samples.iter().all(|l| l.parse::<i16>().is_ok()));
    // Only the trace is left in the folder (no temporary file).
    assert_eq!(names(tmp.path()), ["trace.txt"]);
    // A trace path that is a folder, or below a file, is refused before the run.
    refused(
        &["static", "--accel-cm-s2", "0", "--trace", "{dir}"],
        1,
        &["--trace ", ": this is a folder; expected a file name"],
    );
    refused_with(
        &[("afile", b"x")],
        &["static", "--accel-cm-s2", "0", "--trace", "afile/t.txt"],
        1,
        &["--trace afile/t.txt: afile is a file; expected a folder there"],
    );
}

/// Case 2: `tumble --gate-s`.
#[test]
fn tumble_refuses_gates_it_cannot_count() {
    let out = ["--out", "{dir}/out"];
    for (gate, needle) in [
        ("0", "expected a time in seconds, more than 0, not 0"),
        (
            "-1",
            "expected a time in seconds, more than 0 and at most 1e9, not -1",
        ),
        ("nan", "expected a finite number, not NaN"),
        (
            "1e12",
            "expected a time in seconds, more than 0 and at most 1e9, not 1e12",
        ),
    ] {
        let a = with(&["tumble", "--gate-s", gate], &out);
        refused(&strs(&a), 2, &["'--gate-s <S>'", needle]);
    }
    let a = with(&["tumble", "--gate-s", "1e-9"], &out);
    refused(
        &strs(&a),
        1,
        &["--gate-s 1e-9: expected a gate of at least one limit cycle, 0.001 s"],
    );
}

/// Case 3: `bench`.
#[test]
fn bench_refuses_no_work() {
    refused(
        &["bench", "--ticks", "0"],
        2,
        &[
            "'--ticks <N>'",
            "expected ticks per run",
            "from 1 to 4294967295, not `0`",
        ],
    );
    refused(
        &["bench", "--runs", "0"],
        2,
        &[
            "'--runs <N>'",
            "expected a number of runs: a whole number from 1 to 1000, not `0`",
        ],
    );
    refused(&["bench", "--ticks", "1.5"], 2, &["not `1.5`"]);
    // No overflow of ticks × runs (it panicked): the estimate refuses it.
    refused(
        &[
            "bench",
            "--ticks",
            "4294967295",
            "--runs",
            "1000",
            "--compare-c",
        ],
        1,
        &[
            "the benchmark would run about 8.59e12 clock ticks",
            "pass --no-limit",
        ],
    );
    refused(
        &["bench", "--ticks", "18446744073709551615"],
        2,
        &["from 1 to 4294967295"],
    );
}

/// `PTSA_SIMD` chooses the batch engine's instructions: at every level this CPU has, eight
/// static and eight oscillating conditions give the single loop's pulses and results bit
/// for bit (the bench checks them before it prints a rate), and the bench says where the
/// core's tick was held; a value that is no level is warned about and ignored.
#[test]
fn every_simd_level_gives_the_single_loops_results() {
    let tmp = tempfile::tempdir().unwrap();
    let run = |level: &str, dynamic: bool| {
        let mut args = vec!["bench", "--batch", "8", "--ticks", "1000", "--runs", "1"];
        if dynamic {
            args.push("--dynamic");
        }
        let o = Command::new(env!("CARGO_BIN_EXE_ptsa"))
            .current_dir(tmp.path())
            .env("PTSA_SIMD", level)
            .args(&args)
            .output()
            .unwrap();
        assert!(o.status.success(), "PTSA_SIMD={level}: {}", stderr(&o));
        (stdout(&o), stderr(&o))
    };
    for (level, held) in [
        ("sse2", "arrays"),
        ("avx2", "AVX2 registers"),
        ("avx512", "AVX-512 registers"),
    ] {
        for dynamic in [false, true] {
            let (out, err) = run(level, dynamic);
            assert!(err.is_empty(), "{level}: {err}");
            let same = if dynamic {
                "(same results bit for bit in every run)"
            } else {
                "(same pulses in every run)"
            };
            assert!(out.contains(same), "{level}: {out}");
            let batch = out
                .lines()
                .find(|l| l.starts_with("bench: batch engine, 8 lanes per core"))
                .unwrap_or_else(|| panic!("{out}"));
            // Without AVX2, static lanes run one after the other (faster than on arrays).
            let how = if level == "sse2" && !dynamic {
                "the loops one after the other".to_string()
            } else {
                format!("the core's tick in {held}")
            };
            if batch.contains(&format!("(SIMD level {level})")) {
                assert!(batch.contains(&how), "{batch}");
            } else {
                // The CPU has less than was asked for: the kernels use what it has.
                eprintln!("this CPU has no {level}: {batch}");
            }
        }
    }
    let (out, err) = run("avx1024", false);
    assert!(
        err.starts_with("warning: PTSA_SIMD=avx1024: expected avx512, avx2 or sse2"),
        "{err}"
    );
    assert!(out.contains("(same pulses in every run)"), "{out}");
}

/// `bench --compare-c`: the plain C loop, built with the system's C compiler, gives the
/// same pulses and plant state as the Rust loop, bit for bit (a tiny run: the check
/// behind `cargo xtask figures bench-c`, not a timing).
#[test]
fn bench_compare_c_gives_the_same_pulses_bit_for_bit() {
    let tmp = tempfile::tempdir().unwrap();
    let (out, err) = succeeds_in(
        tmp.path(),
        &["bench", "--compare-c", "--ticks", "64000", "--runs", "1"],
    );
    assert!(err.is_empty(), "{err}");
    assert!(
        out.contains("same pulses and plant state bit for bit"),
        "{out}"
    );
    assert!(out.contains("bench: Rust / C = "), "{out}");
}

/// `bench --batch N`: both rates and their ratio, from a tiny run (a smoke test of the
/// command, not a timing); its options refused out of range.
#[test]
fn bench_batch_prints_both_rates() {
    let tmp = tempfile::tempdir().unwrap();
    let (out, err) = succeeds_in(
        tmp.path(),
        &["bench", "--batch", "3", "--ticks", "1000", "--runs", "3"],
    );
    assert!(err.is_empty(), "{err}");
    assert!(
        out.starts_with("bench --batch 3: 3 static conditions from -19009.0 to 19009.0 cm/s^2 (±0.9 of full scale)"),
        "{out}"
    );
    assert!(
        out.contains("1000 ticks each after 6400 settling ticks, 3 runs"),
        "{out}"
    );
    let rate = |what: &str| -> f64 {
        let l = out
            .lines()
            .find(|l| l.contains(what))
            .unwrap_or_else(|| panic!("no `{what}` in {out}"));
        let x = l
            .strip_suffix(" Mticks/s")
            .and_then(|l| l.rsplit(' ').next())
            .unwrap_or_else(|| panic!("{l}"));
        x.parse().unwrap()
    };
    let single = rate("single loop");
    let batch = rate("batch engine, 8 lanes per core");
    assert!(single > 0.0 && batch > 0.0, "{out}");
    let ratio: f64 = out
        .lines()
        .find_map(|l| l.strip_prefix("bench: batch / single = "))
        .and_then(|l| l.split(' ').next())
        .unwrap_or_else(|| panic!("{out}"))
        .parse()
        .unwrap();
    // The printed rates are rounded to 0.01 Mticks/s.
    assert!(
        (ratio - batch / single).abs() < 0.02 * ratio + 0.01 / single,
        "{ratio} vs {batch}/{single}"
    );
    let (out, _) = succeeds_in(
        tmp.path(),
        &[
            "bench",
            "--batch",
            "1",
            "--lanes",
            "4",
            "--ticks",
            "100",
            "--runs",
            "1",
            "--no-noise",
        ],
    );
    assert!(
        out.contains("1 static condition at 0 cm/s^2, without noise"),
        "{out}"
    );
    assert!(out.contains("batch engine, 4 lanes per core"), "{out}");
    for (n, needle) in [("0", "not `0`"), ("65", "not `65`"), ("2.5", "not `2.5`")] {
        refused(
            &["bench", "--batch", n],
            2,
            &[
                "'--batch <N>'",
                "expected a number of static conditions: a whole number from 1 to 64",
                needle,
            ],
        );
    }
    refused(
        &["bench", "--batch", "4", "--lanes", "3"],
        2,
        &[
            "expected lanes per core: a power of two from 1 to 16",
            "not `3`",
        ],
    );
    refused(&["bench", "--lanes", "2"], 2, &["--batch <N>"]);
    refused(
        &["bench", "--batch", "2", "--compare-c"],
        2,
        &["'--batch <N>' cannot be used with '--compare-c'"],
    );
    // The estimate counts both passes over every condition: 64 × 2 × 20 runs of 64e6 ticks
    // (beyond ten minutes at the estimate's rate even on 4 cores).
    refused(
        &[
            "bench", "--batch", "64", "--ticks", "64000000", "--runs", "20",
        ],
        1,
        &["the benchmark would run about 1.64e11 clock ticks"],
    );
    assert!(names(tmp.path()).is_empty());
}

/// `bench --batch N --dynamic` (N oscillating conditions) and `--dynamic --shared-condition`
/// (one condition, N instruments): the header, both rates and their ratio from a tiny run
/// (a smoke test, not a timing), and the combinations that mean nothing refused.
#[test]
fn bench_batch_dynamic_prints_both_rates() {
    let tmp = tempfile::tempdir().unwrap();
    let rates = |out: &str, batch: &str| -> (f64, f64, f64) {
        let rate = |what: &str| -> f64 {
            let l = out
                .lines()
                .find(|l| l.contains(what))
                .unwrap_or_else(|| panic!("no `{what}` in {out}"));
            l.strip_suffix(" Mticks/s")
                .and_then(|l| l.rsplit(' ').next())
                .unwrap_or_else(|| panic!("{l}"))
                .parse()
                .unwrap()
        };
        let ratio: f64 = out
            .lines()
            .find_map(|l| l.strip_prefix("bench: batch / single = "))
            .and_then(|l| l.strip_suffix(" (same results bit for bit in every run)"))
            .unwrap_or_else(|| panic!("{out}"))
            .parse()
            .unwrap();
        (rate("bench: single loop"), rate(batch), ratio)
    };
    let (out, err) = succeeds_in(
        tmp.path(),
        &[
            "bench",
            "--batch",
            "3",
            "--dynamic",
            "--ticks",
            "1000",
            "--runs",
            "2",
        ],
    );
    assert!(err.is_empty(), "{err}");
    assert!(
        out.starts_with("bench --batch 3 --dynamic: 3 oscillating conditions from 10.0 to 36.7 Hz (angular oscillation about OA and IA+PA vibration in turn, with sculling and anisoinertia), windows of at least 1000 ticks in whole periods after 6400 settling ticks, "),
        "{out}"
    );
    // 10, 23.3 and 36.7 Hz: whole periods of at least 1000 ticks (6400, 2743 and 3491).
    assert!(
        out.contains(", 30088 ticks in all, 2 runs, medians"),
        "{out}"
    );
    assert!(
        out.contains("one condition after the other (sim::simulate_condition)"),
        "{out}"
    );
    let (single, batch, ratio) = rates(
        &out,
        "batch engine, 8 lanes per core, on one thread (Engine::simulate_conditions)",
    );
    assert!(single > 0.0 && batch > 0.0, "{out}");
    assert!(
        (ratio - batch / single).abs() < 0.02 * ratio + 0.01 / single,
        "{ratio} vs {batch}/{single}"
    );
    let (out, err) = succeeds_in(
        tmp.path(),
        &[
            "bench",
            "--batch",
            "3",
            "--dynamic",
            "--shared-condition",
            "--lanes",
            "2",
            "--ticks",
            "1000",
            "--runs",
            "1",
            "--no-noise",
        ],
    );
    assert!(err.is_empty(), "{err}");
    assert!(
        out.starts_with("bench --batch 3 --dynamic --shared-condition: one oscillating condition (20 Hz, 2 mrad about OA) with 3 instruments (spring 0 to 10.7 % stiffer), without noise, "),
        "{out}"
    );
    assert!(
        out.contains(", 28800 ticks in all, 1 run, medians"),
        "{out}"
    );
    let (single, batch, _) = rates(
        &out,
        "batch engine, 2 lanes per core, on one thread (Engine::simulate_jobs)",
    );
    assert!(single > 0.0 && batch > 0.0, "{out}");
    assert!(names(tmp.path()).is_empty());
}

/// `bench --dynamic` and `--shared-condition` refused where they mean nothing, and the
/// work estimate of `--dynamic` at the dynamic rate.
#[test]
fn bench_dynamic_refuses_meaningless_combinations() {
    // Without --batch (or --dynamic) the flags mean nothing: refused, naming what is missing.
    refused(
        &["bench", "--dynamic"],
        2,
        &[
            "the following required arguments were not provided",
            "--batch <N>",
        ],
    );
    refused(
        &["bench", "--batch", "2", "--shared-condition"],
        2,
        &[
            "the following required arguments were not provided",
            "--dynamic",
        ],
    );
    refused(
        &["bench", "--batch", "2", "--dynamic", "--compare-c"],
        2,
        &["'--batch <N>' cannot be used with '--compare-c'"],
    );
    // The estimate counts both passes at the dynamic rate: 64 × 2 × 10 runs of 5e7 ticks
    // (at the static rate it would pass on 2 cores).
    refused(
        &[
            "bench",
            "--batch",
            "64",
            "--dynamic",
            "--ticks",
            "50000000",
            "--runs",
            "10",
        ],
        1,
        &[
            "the benchmark would run about 6.40e10 clock ticks",
            "pass --no-limit",
        ],
    );
}

/// Case 4: the run options, on the report and on a subcommand.
#[test]
fn run_options_refuse_nan_everywhere() {
    for opt in ["--warmup-s", "--window-s"] {
        refused(
            &[opt, "nan", "--out", "{dir}/report"],
            2,
            &[&format!("'{opt} <S>'"), "expected a finite number, not NaN"],
        );
        refused(
            &["tumble", opt, "nan", "--out", "{dir}/out"],
            2,
            &[&format!("'{opt} <S>'"), "expected a finite number, not NaN"],
        );
        refused(
            &["report", opt, "nan", "--out", "{dir}/report"],
            2,
            &["expected a finite number, not NaN"],
        );
    }
    refused(
        &["--window-s", "0", "--out", "{dir}/report"],
        2,
        &["expected a time in seconds, more than 0, not 0"],
    );
}

/// The report's options before a subcommand would be ignored: refused, and the global
/// `--instrument` still goes anywhere.
#[test]
fn report_options_before_a_subcommand_are_refused() {
    refused(
        &["--window-s", "5", "tumble", "--out", "{dir}/out"],
        2,
        &[
            "--window-s before the subcommand `tumble` is an option of the report programme (no subcommand) and would be ignored",
        ],
    );
    refused(
        &["--out", "{dir}/x", "design"],
        2,
        &["--out before the subcommand `design`"],
    );
    refused(
        &["--force", "bench"],
        2,
        &["--force before the subcommand `bench`"],
    );
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(
        tmp.path().join("k.toml"),
        include_str!("../../data/kearfott-2401.toml"),
    )
    .unwrap();
    let a = succeeds_in(tmp.path(), &["--instrument", "k.toml", "design"]).0;
    let b = succeeds_in(tmp.path(), &["design", "--instrument", "k.toml"]).0;
    assert_eq!(a, b);
}

/// Case 5: the Appendix A and Table 6.1 set-ups.
#[test]
fn set_ups_refuse_out_of_range_values() {
    let out = ["--out", "{dir}/out"];
    for (f, code, needle) in [
        ("0", 2, "expected a frequency in Hz, more than 0, not 0"),
        ("nan", 2, "expected a finite number, not NaN"),
        (
            "1e6",
            1,
            "--freq-hz 1e6: expected at most half the limit-cycle frequency, 500 Hz",
        ),
    ] {
        let a = with(&["vibropendulosity", "--freq-hz", f], &out);
        refused(&strs(&a), code, &[needle]);
    }
    let a = with(&["anisoinertia", "--anisoinertia-g-cm2", "nan"], &out);
    refused(&strs(&a), 2, &["expected a finite number, not NaN"]);
    let a = with(&["anisoinertia", "--anisoinertia-g-cm2", "1e9"], &out);
    refused(
        &strs(&a),
        2,
        &["expected |I_PA − I_IA| below 100 g·cm²", "not 1e9"],
    );
    let a = with(&["sculling", "--theta-my-mrad", "1e6"], &out);
    refused(
        &strs(&a),
        2,
        &[
            "'--theta-my-mrad <MRAD>'",
            "expected an amplitude in mrad from 0 to 100",
            "not 1e6",
        ],
    );
    let a = with(&["oa-coupling", "--lever-cm", "1", "2"], &out);
    refused(
        &strs(&a),
        2,
        &["3 values required for '--lever-cm <IA_CM> <PA_CM> <OA_CM>' but 2 were provided"],
    );
}

/// Case 6: negative numbers can be typed, in every form `f64` reads.
#[test]
fn negative_numbers_can_be_typed() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let (out, _) = succeeds_in(
        d,
        &strs(&with(
            &["anisoinertia", "--anisoinertia-g-cm2", "-3.4", "--out", "a"],
            &FAST,
        )),
    );
    assert!(out.contains("configured -3.030"), "{out}");
    succeeds_in(
        d,
        &strs(&with(
            &["vibropendulosity", "--k-ip-s2-cm", "-1e-5", "--out", "v"],
            &FAST,
        )),
    );
    let (out, _) = succeeds_in(
        d,
        &[
            "waveform",
            "--accel-cm-s2",
            "-5000",
            "--warmup-s",
            "0.01",
            "--out",
            "w",
        ],
    );
    assert!(out.contains("at -5000 cm/s^2 along IA"), "{out}");
    succeeds_in(
        d,
        &strs(&with(
            &["oa-coupling", "--lever-cm", "1", "-2", "3", "--out", "o"],
            &FAST,
        )),
    );
    succeeds_in(
        d,
        &strs(&with(
            &[
                "oa-coupling",
                "--lever-cm",
                "-1e-3",
                "-.5",
                "-2E1",
                "--out",
                "o",
            ],
            &FAST,
        )),
    );
    let (v, _) = static_json(&["--accel-cm-s2", "-1e3", "--seconds", "0.5"]);
    assert!(
        (v["indicated_cm_s2"].as_f64().unwrap() + 1000.0).abs() < 2.0,
        "{v}"
    );
    let (v, _) = static_json(&["--accel-cm-s2", "-.5e3", "--seconds", "0.5"]);
    assert!(
        (v["indicated_cm_s2"].as_f64().unwrap() + 500.0).abs() < 2.0,
        "{v}"
    );
    // A negative number where no value is taken is still refused, in clap's words.
    refused(
        &["static", "--json", "-1e-5", "--accel-cm-s2", "0"],
        2,
        &["unexpected value '-1e-5' for '--json'"],
    );
    refused(
        &["static", "--accel-cm-s2", "-inf"],
        2,
        &["expected a finite number, not -inf"],
    );
    refused(
        &["--warmup-s", "-1e-3", "--out", "{dir}/r"],
        2,
        &["expected a time in seconds from 0 to 1e9, not -0.001"],
    );
}

/// Case 7: instrument files the loop cannot work with.
#[test]
fn unusable_instrument_files_are_refused_naming_the_file() {
    let slow = instrument_with("clock_hz = 64000.0", "clock_hz = 1000");
    let why = "slow.toml: the loop's crossover (105.4 Hz) is not well below its limit cycle (15.6 Hz = clock_hz / 64 ticks): expected a crossover below 3.9 Hz (raise electronics.clock_hz)";
    let files: &[(&str, &[u8])] = &[("slow.toml", slow.as_bytes())];
    refused_with(
        files,
        &["--instrument", "slow.toml", "static", "--accel-cm-s2", "0"],
        1,
        &[why],
    );
    refused_with(
        files,
        &["--instrument", "slow.toml", "waveform", "--out", "out"],
        1,
        &[why],
    );
    // `design` prints the design, then refuses it with the same reason.
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("slow.toml"), &slow).unwrap();
    let o = ptsa_in(tmp.path(), &["--instrument", "slow.toml", "design"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains(why), "{}", stderr(&o));
    assert!(stdout(&o).contains("margins"), "{}", stdout(&o));
    assert!(!stdout(&o).contains("accepted"), "{}", stdout(&o));

    // An amplifier gain of 100 000: the linear design is the same (its margins do not
    // depend on the gain) but the ADC clips inside the limit cycle. Both refuse.
    let loud = instrument_with("amplifier_gain = 100.0", "amplifier_gain = 100000");
    let why = "loud.toml: the ADC's full scale is ±2.500 µrad of pendulum angle";
    let files: &[(&str, &[u8])] = &[("loud.toml", loud.as_bytes())];
    let expected = "expected electronics.amplifier_gain at most 2451 (it is 100000)";
    let wave = refused_with(
        files,
        &["--instrument", "loud.toml", "waveform", "--out", "out"],
        1,
        &[why, expected],
    );
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("loud.toml"), &loud).unwrap();
    let o = ptsa_in(tmp.path(), &["--instrument", "loud.toml", "design"]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(stderr(&o), wave);
    assert!(
        stdout(&o).contains("crossover 98.1 Hz, phase margin 112.4 deg, gain margin 26.3 dB"),
        "{}",
        stdout(&o)
    );
    assert!(!stdout(&o).contains("accepted"), "{}", stdout(&o));

    // Gain 1000 keeps the limit cycle inside the ADC's range: design and waveform agree.
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    std::fs::write(
        d.join("g1000.toml"),
        instrument_with("amplifier_gain = 100.0", "amplifier_gain = 1000"),
    )
    .unwrap();
    let margins = |out: &str| {
        out.lines()
            .find(|l| l.contains("margins (linearised loop"))
            .unwrap()
            .to_string()
    };
    let shipped = margins(&succeeds_in(d, &["design"]).0);
    let design = succeeds_in(d, &["--instrument", "g1000.toml", "design"]).0;
    assert_eq!(margins(&design), shipped);
    assert!(design.contains("verdict: the loop is accepted"), "{design}");
    let (wave, _) = succeeds_in(
        d,
        &[
            "--instrument",
            "g1000.toml",
            "waveform",
            "--warmup-s",
            "0.01",
            "--out",
            "w",
        ],
    );
    let agree: f64 = wave
        .split("linear-model gain agree within ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .unwrap();
    assert!(agree < 3.0, "{wave}");

    refused(
        &[
            "--instrument",
            "nonexist.toml",
            "static",
            "--accel-cm-s2",
            "0",
        ],
        1,
        &["error: nonexist.toml: cannot read: No such file or directory"],
    );
    refused(
        &["--instrument", "nonexist.toml", "design"],
        1,
        &["error: nonexist.toml: cannot read"],
    );
}

#[test]
fn bad_instrument_file_is_refused_with_position() {
    let text = instrument_with(
        "damping_dyn_cm_s = { value = 76400.0",
        "damping_dyn_cm_s = { value = \"fast\"",
    );
    refused_with(
        &[("bad.toml", text.as_bytes())],
        &[
            "--instrument",
            "bad.toml",
            "static",
            "--accel-cm-s2",
            "0",
            "--seconds",
            "0.01",
        ],
        1,
        &["bad.toml:", "expected a number, found the string \"fast\""],
    );
}

/// Case 8: a trace too long to be meant is refused at once (before any allocation or run).
#[test]
fn waveform_refuses_huge_traces_fast() {
    let t = Instant::now();
    refused(
        &["waveform", "--cycles", "100000000", "--out", "{dir}/out"],
        1,
        &[
            "--cycles 100000000: the trace has one row per clock tick (6400000000 rows); expected at most 10000 cycles without --no-limit",
        ],
    );
    // With --no-limit, a count whose ticks overflow 64 bits (it panicked).
    refused(
        &[
            "waveform",
            "--cycles",
            "18446744073709551615",
            "--no-limit",
            "--out",
            "{dir}/out",
        ],
        1,
        &["expected at most 288230376151711743 limit cycles"],
    );
    refused(
        &["waveform", "--cycles", "0", "--out", "{dir}/out"],
        2,
        &["expected a number of limit cycles: a whole number from 1"],
    );
    // `waveform` has no measurement windows of its own: no --window-s that does nothing.
    refused(
        &["waveform", "--window-s", "0.01"],
        2,
        &["unexpected argument '--window-s'"],
    );
    assert!(t.elapsed() < Duration::from_secs(3), "{:?}", t.elapsed());
}

/// Case 9: long work is refused quickly.
#[test]
fn long_work_is_refused_quickly() {
    let t = Instant::now();
    refused(
        &["static", "--accel-cm-s2", "0", "--seconds", "1e9"],
        1,
        &["--seconds 1e9: expected a gate of at most 67108 s"],
    );
    refused(
        &["static", "--accel-cm-s2", "0", "--warmup-s", "1e9"],
        1,
        &[
            "this gate would run about 6.40e13 clock ticks",
            "pass --no-limit",
        ],
    );
    refused(
        &["tumble", "--gate-s", "1e5", "--out", "{dir}/out"],
        1,
        &[
            "--gate-s 100000: expected a gate of at most 67108 s, the longest the core's 32-bit counters hold (4294967295 ticks at 64000 Hz)",
        ],
    );
    refused(
        &["--window-s", "1e6", "--out", "{dir}/report"],
        1,
        &["the report programme would run about"],
    );
    assert!(t.elapsed() < Duration::from_secs(3), "{:?}", t.elapsed());
}

/// Run `args` with stdout a pipe closed after reading `lines` lines; returns stderr.
fn closed_stdout(dir: &Path, args: &[&str], lines: usize) -> String {
    use std::io::BufRead as _;
    let mut c = Command::new(env!("CARGO_BIN_EXE_ptsa"))
        .current_dir(dir)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let out = c.stdout.take().unwrap();
    if lines > 0 {
        let mut r = std::io::BufReader::new(out);
        for _ in 0..lines {
            let mut l = String::new();
            r.read_line(&mut l).unwrap();
        }
    }
    let o = c.wait_with_output().unwrap();
    let err = stderr(&o);
    assert!(o.status.success(), "ptsa {args:?}: {:?} {err}", o.status);
    assert_clean(&err);
    err
}

/// Case 10: a closed stdout is not an error, and the files are still written whole.
#[test]
fn closed_stdout_is_not_an_error() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let err = closed_stdout(d, &strs(&with(&["tumble", "--out", "t"], &FAST)), 0);
    assert!(err.contains("wrote 6 files into t"), "{err}");
    assert_eq!(names(&d.join("t")).len(), 6);
    let err = closed_stdout(d, &strs(&with(&["--out", "report"], &FAST)), 1);
    assert!(err.contains("report written to report"), "{err}");
    assert!(d.join("report/summary.md").is_file());
    let summary = std::fs::read_to_string(d.join("report/summary.md")).unwrap();
    assert!(summary.contains("Noise seed 1"), "{summary}");
    assert_eq!(names(d), ["report", "t"]);
}

/// Case 11: the report folder appears whole or not at all, and replaces only an earlier
/// report: refused at once where it cannot be written or would replace something else.
#[test]
fn report_refuses_folders_it_must_not_replace() {
    // Its parent is a file: refused at once, nothing created.
    let a = with(&["--out", "afile/report"], &FAST);
    refused_with(
        &[("afile", b"not a folder")],
        &strs(&a),
        1,
        &["--out afile/report: afile is a file; expected a folder there"],
    );
    // It is a file: refused, the file kept (the report used to replace it).
    let a = with(&["--out", "afile"], &FAST);
    refused_with(
        &[("afile", b"not a folder")],
        &strs(&a),
        1,
        &["--out afile: this is a file; expected a folder"],
    );
    // A folder of other things (`--out .`): refused, nothing deleted.
    let a = with(&["--out", "."], &FAST);
    refused_with(
        &[("notes.txt", b"mine")],
        &strs(&a),
        1,
        &[
            "--out .: an existing folder that is not an earlier report",
            "would delete what is in it",
        ],
    );
}

/// Case 11: running the report twice into the same folder leaves exactly the second run's
/// files, and no temporaries beside it.
#[test]
fn report_twice_leaves_the_second_run() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let run = |seed: &str| {
        let a = with(&["--out", "report", "--seed", seed], &FAST);
        succeeds_in(d, &strs(&a));
    };
    run("1");
    let first = names(&d.join("report"));
    assert!(first.contains(&"summary.md".to_string()), "{first:?}");
    std::fs::write(d.join("report/stale.csv"), "from before").unwrap();
    run("2");
    assert_eq!(names(&d.join("report")), first);
    assert_eq!(names(d), ["report"]);
    let summary = std::fs::read_to_string(d.join("report/summary.md")).unwrap();
    assert!(summary.contains("Noise seed 2"), "{summary}");
}

/// Case 12: `discover`'s inputs.
#[test]
fn discover_reads_case_frames_and_refuses_bad_ones() {
    let table = include_str!("../../data/r890-table-6.1.case.csv");
    let body: String = table
        .lines()
        .filter(|l| !l.starts_with('#'))
        .flat_map(|l| [l, "\n"])
        .collect();
    // A UTF-8 byte-order mark is accepted.
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let mut bom = b"\xEF\xBB\xBF".to_vec();
    bom.extend_from_slice(body.as_bytes());
    std::fs::write(d.join("bom.csv"), &bom).unwrap();
    let (out, err) = succeeds_in(
        d,
        &[
            "discover",
            "--data",
            "bom.csv",
            "--analytic",
            "--out",
            "out",
        ],
    );
    assert!(out.contains("selected: anisoinertia"), "{out}");
    assert!(err.contains("8 rows"), "{err}");
    assert_eq!(
        names(&d.join("out")),
        ["bom-discover.csv", "bom-discover.png", "bom-discover.svg"]
    );

    let semi = body.replace(',', ";");
    refused_with(
        &[("semi.csv", semi.as_bytes())],
        &["discover", "--data", "semi.csv", "--out", "out"],
        1,
        &[
            "semi.csv:1:",
            "this looks like a semicolon-separated file: the case-frame format separates cells with commas",
        ],
    );
    let bad = body.replacen(",1.54,", ",abc,", 1);
    refused_with(
        &[("bad.csv", bad.as_bytes())],
        &["discover", "--data", "bad.csv", "--out", "out"],
        1,
        &[
            "bad.csv:2: column 8 (`measured_cm_s2`) holds `abc`; expected a finite number of cm/s², or an empty cell (not measured)",
        ],
    );
    refused(
        &["discover", "--data", "nonexist.csv", "--out", "out"],
        1,
        &["cannot read nonexist.csv: No such file or directory"],
    );
    refused(
        &["discover", "--candidates", "foo", "--out", "out"],
        2,
        &[
            "unknown candidate `foo`; expected one of: adc_offset, amplifier_gain, anisoelasticity, anisoinertia, bias,",
        ],
    );
    refused(
        &["discover", "--candidates", "anisoinertia,", "--out", "out"],
        2,
        &["an empty name in the list (a stray comma?); expected names separated by commas"],
    );
    refused(
        &["discover", "--sigma", "0", "--out", "out"],
        2,
        &[
            "'--sigma <CM_S2>'",
            "expected an uncertainty in cm/s², more than 0, not 0",
        ],
    );
    refused_with(
        &[("afile", b"x")],
        &["discover", "--out", "afile"],
        1,
        &["--out afile: this is a file; expected a folder"],
    );
    // Advice needs a data file to advise on.
    refused(
        &["discover", "--advice-out", "rows.csv"],
        2,
        &["--advice-out <FILE>", "--data <FILE>"],
    );
}

/// Output folders are checked before the work: a subcommand whose `--out` is a file, or
/// below one, is refused at once.
#[test]
fn subcommand_output_folders_are_checked_first() {
    for sub in [
        "tumble",
        "anisoinertia",
        "oa-coupling",
        "vibropendulosity",
        "waveform",
        "monte-carlo",
    ] {
        refused_with(
            &[("afile", b"x")],
            &[sub, "--out", "afile/x"],
            1,
            &["--out afile/x: afile is a file; expected a folder there"],
        );
    }
}

/// Every file a subcommand writes is counted, and an option that does nothing says so.
#[test]
fn subcommands_report_what_they_did() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let (_, err) = succeeds_in(d, &["waveform", "--warmup-s", "0.01", "--out", "w"]);
    assert!(err.contains("wrote 9 files into w"), "{err}");
    assert_eq!(names(&d.join("w")).len(), 9);
    // The warning comes before the work (here refused as too long, to keep this fast).
    refused(
        &[
            "monte-carlo",
            "--samples",
            "5",
            "--window-s",
            "1e6",
            "--out",
            "{dir}/m",
        ],
        1,
        &[
            "warning: --samples 5 is not used: the tolerance box has 12 parameters, so all 4096 of its corners are checked",
            "the Monte Carlo would run about",
        ],
    );
}

/// Case 13: help.
#[test]
fn help_exits_0_and_names_units() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let help = |args: &[&str]| {
        let (out, err) = succeeds_in(d, args);
        assert!(err.is_empty(), "{err}");
        out
    };
    let top = help(&["--help"]);
    assert!(top.contains("cm/s²") && top.contains("mrad"), "{top}");
    let units = [
        ("tumble", "s ("),
        ("anisoinertia", "g·cm²"),
        ("oa-coupling", "cm ("),
        ("vibropendulosity", "Hz"),
        ("anisoelasticity", "s²/cm"),
        ("sculling", "mrad"),
        ("waveform", "cm/s²"),
        ("static", "cm/s²"),
        ("design", "DEFAULT_*_BITS"),
        ("monte-carlo", "s ("),
        ("bench", "ticks"),
        ("report", "s ("),
        ("discover", "cm/s²"),
        ("response", "dimensionless"),
        ("record", "clock_hz, in s"),
        ("predict", "_cm_s2"),
        ("correct", "cm/s²"),
        ("noise", "cm/s²"),
        ("plan tumble", "s ("),
        ("plan rate-table", "rad/s"),
        ("plan shaker", "Hz"),
        ("plan centrifuge", "cm ("),
        ("instrument new", "cm/s²"),
        ("plan triad", "cm/s²"),
    ];
    // Every subcommand the help lists (a group's: each of its own) has its unit above.
    let listed = |text: &str| -> Vec<String> {
        text.lines()
            .skip_while(|l| !l.starts_with("Commands:"))
            .skip(1)
            .take_while(|l| l.starts_with("  "))
            .filter_map(|l| l.split_whitespace().next().map(str::to_string))
            .filter(|c| c != "help")
            .collect()
    };
    let mut commands = Vec::new();
    for c in listed(&top) {
        let inner = listed(&help(&[c.as_str(), "--help"]));
        if inner.is_empty() {
            commands.push(c);
        } else {
            commands.extend(inner.iter().map(|i| format!("{c} {i}")));
        }
    }
    for c in &commands {
        assert!(
            units.iter().any(|(u, _)| u == c),
            "ptsa {c}: a subcommand without a unit checked in its --help (add it to `units`)"
        );
    }
    for (sub, unit) in units {
        let args: Vec<&str> = sub.split(' ').collect();
        let h = help(&[args.as_slice(), &["--help"]].concat());
        assert!(h.contains(unit), "ptsa {sub} --help lacks `{unit}`:\n{h}");
        assert_eq!(help(&[&["help"], args.as_slice()].concat()), h);
        // The global --instrument comes after the subcommand's own options; `instrument
        // new`, which reads no instrument file, does not list it.
        let opts: Vec<&str> = h
            .lines()
            .filter_map(|l| l.trim_start().strip_prefix("--"))
            .collect();
        let last = opts.iter().rposition(|l| l.starts_with("instrument"));
        if sub == "instrument new" {
            assert!(last.is_none(), "{sub}: {opts:?}");
        } else {
            assert!(last.is_some_and(|i| i + 1 == opts.len()), "{sub}: {opts:?}");
        }
    }
    let design = help(&["design", "--help"]);
    for absent in ["--seed", "--out", "--warmup-s", "--window-s", "--force"] {
        assert!(
            !design.contains(absent),
            "design offers {absent}:\n{design}"
        );
    }
    let waveform = help(&["waveform", "--help"]);
    assert!(!waveform.contains("--window-s"), "{waveform}");
    assert!(names(d).is_empty());
}

/// `ptsa plan` writes designs the reader takes back; `ptsa predict` predicts them, with and
/// without a discover result's effects, and refuses an effects file that names no candidate.
#[test]
fn plan_and_predict() {
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("t.csv");
    let out = Command::new(env!("CARGO_BIN_EXE_ptsa"))
        .args([
            "plan",
            "tumble",
            "--positions",
            "12",
            "--axis",
            "pa",
            "--output",
        ])
        .arg(&plan)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows = ptsa_host_sim::model::caseframe::read(&plan).unwrap();
    assert_eq!(rows.len(), 12);
    let predict = |extra: &[&str]| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_ptsa"));
        c.args(["predict", "--analytic", "--json", "--data"])
            .arg(&plan)
            .args(extra);
        c.output().unwrap()
    };
    let base = predict(&[]);
    assert!(
        base.status.success(),
        "{}",
        String::from_utf8_lossy(&base.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&base.stdout).unwrap();
    let p: Vec<f64> = v["rows"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["predicted_cm_s2"].as_f64().unwrap())
        .collect();
    // 90°: IA up, g + A_b.
    assert!((p[3] - (980.4 + 18.7)).abs() < 1e-9, "{p:?}");
    let fx = dir.path().join("fx.json");
    std::fs::write(
        &fx,
        r#"{"effects": [{"name": "bias", "coefficients": {"k0_cm_s2": 2.5}}]}"#,
    )
    .unwrap();
    let with = predict(&["--effects", fx.to_str().unwrap()]);
    let w: serde_json::Value = serde_json::from_slice(&with.stdout).unwrap();
    let q = w["rows"][3]["predicted_cm_s2"].as_f64().unwrap();
    assert!((q - p[3] - 2.5).abs() < 1e-9, "{q}");
    std::fs::write(
        &fx,
        r#"{"effects": [{"name": "bias", "coefficients": {"k9": 1}}]}"#,
    )
    .unwrap();
    let bad = predict(&["--effects", fx.to_str().unwrap()]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("`bias.k9` is not a candidate"));
    let bad = Command::new(env!("CARGO_BIN_EXE_ptsa"))
        .args(["plan", "centrifuge", "--radius-cm", "0", "--g-levels", "2"])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    // A response row predicts a gain and a phase, not an acceleration.
    let resp = dir.path().join("resp.csv");
    std::fs::write(
        &resp,
        "label,kind,freq_hz,lin_ia_cm_s2\nlow,response,2,2000\n",
    )
    .unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_ptsa"))
        .args(["predict", "--analytic", "--json", "--data"])
        .arg(&resp)
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let r = &v["rows"][0];
    assert!(r["predicted_cm_s2"].is_null(), "{r}");
    let g = r["predicted_gain"].as_f64().unwrap();
    let ph = r["predicted_phase_deg"].as_f64().unwrap();
    // Well inside the loop's bandwidth: gain near 1, a small lag.
    assert!((g - 1.0).abs() < 0.05 && ph < 0.0 && ph > -5.0, "{r}");
}

/// `ptsa predict` names a discover result's coefficients with the digits their standard
/// errors warrant (four significant digits where the file gives none), with their units,
/// never as a raw `0.00000002990511374147487`.
#[test]
fn predict_prints_coefficients_with_their_significant_digits() {
    let data = b"label,g_ia\nup,1\n".as_slice();
    for (effects, want, not) in [
        (
            r#"{"effects": [{"name": "anisoinertia", "coefficients": {"k_ai_cm": 2.990511374147487e-8}}]}"#,
            "with anisoinertia = 2.991e-8 cm)",
            "0.0000000299",
        ),
        (
            r#"{"effects": [{"name": "anisoinertia", "coefficients": {"k_ai_cm": 3.00312345}, "stderr": {"k_ai_cm": 0.3234}}, {"name": "bias", "coefficients": {"k0_cm_s2": 0.1234567}}]}"#,
            "with anisoinertia = 3.00 ± 0.32 cm, bias = 0.1235 cm/s²)",
            "3.00312345",
        ),
    ] {
        let tmp = tempfile::tempdir().unwrap();
        std::fs::write(tmp.path().join("d.csv"), data).unwrap();
        std::fs::write(tmp.path().join("fx.json"), effects).unwrap();
        let o = ptsa_in(
            tmp.path(),
            &[
                "predict",
                "--analytic",
                "--data",
                "d.csv",
                "--effects",
                "fx.json",
            ],
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let first = stdout(&o).lines().next().unwrap_or_default().to_string();
        assert!(
            first.contains(want) && !first.contains(not),
            "`{want}` not in: {first}"
        );
    }
}

/// A case-frame header cell in the wrong case or a near miss of a column is refused by
/// every command that reads one, with its `file:line:column` and the column it was meant to
/// be; nothing written.
#[test]
fn a_near_miss_header_gets_a_did_you_mean() {
    let data = b"# my tumble\nLabel,G_IA,measured_cm_s2\nup,1,999.1\n".as_slice();
    for cmd in [
        &["predict", "--analytic", "--data", "t.csv"][..],
        &["discover", "--analytic", "--data", "t.csv"][..],
    ] {
        refused_with(
            &[("t.csv", data)],
            cmd,
            1,
            &[
                "t.csv:2:1: column 1 of the header is `Label`, which is not a case-frame column (did you mean `label`? column names are lower case); expected one of: label, kind,",
            ],
        );
    }
    let data = b"label,g-ia,mesured_cm_s2\nup,1,999.1\n".as_slice();
    refused_with(
        &[("t.csv", data)],
        &["predict", "--analytic", "--data", "t.csv"],
        1,
        &[
            "t.csv:1:7: column 2 of the header is `g-ia`, which is not a case-frame column (did you mean `g_ia`?)",
        ],
    );
    let data = b"label,g_ia,mesured_cm_s2\nup,1,999.1\n".as_slice();
    refused_with(
        &[("t.csv", data)],
        &["predict", "--analytic", "--data", "t.csv"],
        1,
        &[
            "t.csv:1:12: column 3 of the header is `mesured_cm_s2`, which is not a case-frame column (did you mean `measured_cm_s2`?)",
        ],
    );
}

/// `plan rate-table --help` lists the axes the rate table takes (oa, pa); `--axis ia`, which
/// `plan tumble` takes, is refused with the reason (exit 2, nothing written); `--axis pa`
/// writes the IA–OA plane.
#[test]
fn rate_table_axes_are_the_ones_its_help_lists() {
    let tmp = tempfile::tempdir().unwrap();
    let o = ptsa_in(tmp.path(), &["plan", "rate-table", "--help"]);
    assert!(o.status.success());
    let h = stdout(&o);
    let axis: String = h
        .lines()
        .skip_while(|l| !l.contains("--axis"))
        .take_while(|l| !l.trim_start().starts_with("--rate-rad-s"))
        .collect::<Vec<_>>()
        .join(" ");
    assert!(
        axis.contains("--axis <oa|pa>")
            && axis.contains("oa (IA in the IA–PA plane")
            && axis.contains("pa (IA in the IA–OA plane)")
            && axis.contains("Not ia")
            && axis.contains("[default: oa]"),
        "{axis}"
    );
    refused(
        &["plan", "rate-table", "--axis", "ia", "--output", "p.csv"],
        2,
        &[
            "'--axis <oa|pa>'",
            "ia is not a rate-table set-up: with IA along the dividing head's axis the table's rate never reaches IA",
            "expected oa (IA in the IA–PA plane) or pa (IA in the IA–OA plane)",
        ],
    );
    refused(
        &["plan", "rate-table", "--axis", "xa"],
        2,
        &["expected oa (IA in the IA–PA plane) or pa (IA in the IA–OA plane), not `xa`"],
    );
    let o = ptsa_in(tmp.path(), &["plan", "rate-table", "--axis", "pa"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("(IA-OA plane, about PA)"),
        "{}",
        stdout(&o)
    );
    // The tumble takes all three.
    let o = ptsa_in(
        tmp.path(),
        &["plan", "tumble", "--axis", "ia", "--positions", "4"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
}

/// The cells of a plan's line: its quoted label (kept quoted) and the cells after it.
fn plan_cells(line: &str) -> Vec<String> {
    let end = if line.starts_with('"') {
        line.find("\",").map_or(0, |i| i + 1)
    } else {
        line.find(',').unwrap_or(line.len())
    };
    std::iter::once(line[..end].to_string())
        .chain(line[end..].split(',').skip(1).map(str::to_string))
        .collect()
}

/// A 24-point tumble plan with its readings: what the analytic simulator predicts with
/// `effects` (a `--json` effects list), plus a fixed pattern of ±0.01 cm/s² noise, and
/// `sigma_cm_s2` 0.01; each row's line with `edit(row index, cells)` applied to its cells
/// (`label,kind,g_ia,g_pa,measured_cm_s2,approach,temp_c,sigma_cm_s2`).
fn lab_tumble(d: &Path, effects: &str, edit: impl Fn(usize, &mut Vec<String>)) -> String {
    let (_, err) = succeeds_in(
        d,
        &[
            "plan",
            "tumble",
            "--positions",
            "24",
            "--output",
            "plan.csv",
            "--force",
        ],
    );
    assert!(err.contains("wrote plan.csv (24 rows)"), "{err}");
    let plan = std::fs::read_to_string(d.join("plan.csv")).unwrap();
    let header = plan.lines().find(|l| !l.starts_with('#')).unwrap();
    assert_eq!(
        header,
        "label,kind,g_ia,g_pa,measured_cm_s2,approach,temp_c"
    );
    std::fs::write(d.join("truth.json"), effects).unwrap();
    let (out, _) = succeeds_in(
        d,
        &[
            "predict",
            "--data",
            "plan.csv",
            "--effects",
            "truth.json",
            "--json",
            "--analytic",
        ],
    );
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let pred = v["rows"].as_array().unwrap();
    let mut text = format!("{header},sigma_cm_s2\n");
    for (k, line) in plan
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .enumerate()
    {
        let mut cells = plan_cells(line);
        // Seven sevenths of a turn over 24 rows: a noise of no shape the vocabulary has.
        #[allow(clippy::cast_precision_loss)]
        let noise = 0.01 * (2.399 * k as f64).sin();
        let y = pred[k]["predicted_cm_s2"].as_f64().unwrap() + noise;
        cells[4] = format!("{y}");
        cells.push("0.01".into());
        edit(k, &mut cells);
        text.push_str(&cells.join(","));
        text.push('\n');
    }
    text
}

/// The lab's columns (`docs/reference/case-frame-format.md`): a tumble plan writes `approach` and `temp_c`
/// empty; a hysteresis hidden in a 24-point tumble taken in angle order is named from the
/// row order alone, and a recorded approach overrides it (every row `down`: the hysteresis
/// is the bias, and the output says they cannot be told apart).
#[test]
fn discover_names_a_hysteresis_from_the_row_order() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let discover = |name: &str, text: &str| -> serde_json::Value {
        std::fs::write(d.join(name), text).unwrap();
        discover_json(d, name)
    };
    let coef = |v: &serde_json::Value, name: &str, key: &str| -> Option<(f64, f64)> {
        v["effects"].as_array().unwrap().iter().find_map(|e| {
            let c = e["coefficients"][key].as_f64()?;
            (e["name"] == name).then(|| (c, e["stderr"][key].as_f64().unwrap()))
        })
    };
    let hyst = r#"{"effects":[{"name":"hysteresis","coefficients":{"h_cm_s2":0.05}}]}"#;
    let text = lab_tumble(d, hyst, |_, _| {});
    let v = discover("hyst.csv", &text);
    let (h, se) = coef(&v, "hysteresis", "h_cm_s2").unwrap_or_else(|| panic!("{v}"));
    assert!((h - 0.05).abs() < 4.0 * se, "h = {h} ± {se}");
    let terms = v["model_equation"]["terms"].as_array().unwrap();
    assert!(
        terms
            .iter()
            .any(|t| t["symbol"] == "h" && t["unit"] == "µg"),
        "{terms:?}"
    );
    // Every row recorded `down`: one constant, the bias's.
    let down = lab_tumble(d, hyst, |_, c| c[5] = "down".into());
    let v = discover("down.csv", &down);
    let groups = v["indistinguishable"].as_array().unwrap();
    assert!(
        groups.iter().any(|g| {
            let g = g.to_string();
            g.contains("\"bias\"") && g.contains("\"hysteresis\"")
        }),
        "{groups:?}"
    );
}

/// A warm-up `0.5·e^(−t/288 s)` less its mean over the run (the run's mean level is the
/// nominal one) written into a 24-point tumble with `time_s` (a row a minute): `discover
/// --json` names `warm_up.a_cm_s2` with its `time_constant` (the truth inside the
/// interval), the bias it settles to (−0.5 times the mean) marked `companion_of`, and
/// `predict --effects` on that result puts the transient back at that τ, row for row.
#[test]
fn discover_estimates_a_warm_up_s_time_constant_and_predict_reads_it() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let transient = |k: usize| 0.5 * (-60.0 * f64::from(u8::try_from(k).unwrap()) / 288.0).exp();
    let mean = (0..24).map(transient).sum::<f64>() / 24.0;
    let warm = |k: usize| {
        #[allow(clippy::cast_precision_loss)]
        let t = 60.0 * k as f64;
        (t, transient(k) - mean)
    };
    let text = lab_tumble(d, r#"{"effects":[]}"#, |k, c| {
        let (t, w) = warm(k);
        c[4] = format!("{}", c[4].parse::<f64>().unwrap() + w);
        c.push(format!("{t}"));
    })
    .replacen(",sigma_cm_s2\n", ",sigma_cm_s2,time_s\n", 1);
    std::fs::write(d.join("warm.csv"), &text).unwrap();
    let v = discover_json(d, "warm.csv");
    let w = effect_named(&v, "warm_up");
    let a = w["coefficients"]["a_cm_s2"]
        .as_f64()
        .unwrap_or_else(|| panic!("{w}"));
    let tc = &w["time_constant"];
    let tau = tc["tau_s"].as_f64().unwrap();
    let (lo, hi) = (
        tc["interval_95_s"][0].as_f64().unwrap(),
        tc["interval_95_s"][1].as_f64().unwrap(),
    );
    assert!(lo < 288.0 && 288.0 < hi, "{tc}");
    assert_eq!(tc["amplitude_cm_s2"].as_f64(), Some(a));
    let bias = effect_named(&v, "bias");
    assert_eq!(bias["companion_of"], "warm_up", "{bias}");
    let b = bias["coefficients"]["k0_cm_s2"].as_f64().unwrap();
    std::fs::write(d.join("found.json"), v.to_string()).unwrap();
    let predict = |effects: &str| -> Vec<f64> {
        let (out, _) = succeeds_in(
            d,
            &[
                "predict",
                "--data",
                "warm.csv",
                "--effects",
                effects,
                "--json",
                "--analytic",
            ],
        );
        let p: serde_json::Value = serde_json::from_str(&out).unwrap();
        p["rows"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["predicted_cm_s2"].as_f64().unwrap())
            .collect()
    };
    std::fs::write(d.join("none.json"), r#"{"effects":[]}"#).unwrap();
    let (with, without) = (predict("found.json"), predict("none.json"));
    for (k, (p, q)) in with.iter().zip(&without).enumerate() {
        let (t, _) = warm(k);
        let expected = b + a * (-t / tau).exp();
        assert!(
            (p - q - expected).abs() < 1e-9,
            "row {k}: {} against {expected}",
            p - q
        );
    }
    // `correct` with that calibration: rows without `time_s` are warned of (the transient
    // cannot be corrected there), rows with it are not.
    let untimed: String = text
        .lines()
        .map(|l| l.rsplit_once(',').map_or(l, |(a, _)| a))
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(d.join("untimed.csv"), untimed + "\n").unwrap();
    let correct = |data: &str| -> String {
        let o = ptsa_in(
            d,
            &[
                "correct",
                "--data",
                data,
                "--calibration",
                "found.json",
                "--output",
                "c.csv",
                "--force",
            ],
        );
        assert!(o.status.success(), "{}", stderr(&o));
        stderr(&o)
    };
    let warned = "the calibration's warm-up (`warm_up.a_cm_s2`";
    let e = correct("untimed.csv");
    assert!(
        e.contains(warned) && e.contains("24 rows without `time_s`"),
        "{e}"
    );
    assert!(!correct("warm.csv").contains(warned));
}

/// A named term whose value changes halfway through the run (a misalignment toward PA of
/// 3e-4 rad on the first 12 positions of a 24-point tumble, none on the rest) is reported
/// `"stable": false` with the parts' values, the text marks it and says why, and the
/// verdict does not give it as the cause; the same misalignment on every row is
/// `"stable": true`.
#[test]
fn discover_says_when_a_named_term_is_not_stable() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let tilt = r#"{"effects":[{"name":"misalignment","coefficients":{"delta_p_rad":3e-4}}]}"#;
    let tilted = lab_tumble(d, tilt, |_, _| {});
    let level = lab_tumble(d, r#"{"effects":[]}"#, |_, _| {});
    let header = tilted.lines().next().unwrap();
    let mut halfway = format!("{header}\n");
    for (k, (a, b)) in tilted.lines().zip(level.lines()).skip(1).enumerate() {
        halfway.push_str(if k < 12 { a } else { b });
        halfway.push('\n');
    }
    let run = |name: &str, text: &str, json: bool| -> String {
        std::fs::write(d.join(name), text).unwrap();
        let mut args = vec!["discover", "--data", name, "--analytic", "--no-plots"];
        if json {
            args.push("--json");
        }
        succeeds_in(d, &args).0
    };
    let effect = |v: &serde_json::Value| -> serde_json::Value {
        v["effects"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["name"] == "misalignment")
            .unwrap_or_else(|| panic!("{v}"))
            .clone()
    };
    let v: serde_json::Value = serde_json::from_str(&run("halfway.csv", &halfway, true)).unwrap();
    let e = effect(&v);
    assert_eq!(e["stable"], false, "{e}");
    let time = e["stability"]["tests"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["split"] == "time")
        .unwrap_or_else(|| panic!("{e}"))
        .clone();
    assert_eq!(time["agrees"], false, "{time}");
    let parts = time["parts"].as_array().unwrap();
    let first = parts[0]["coefficient"].as_f64().unwrap();
    let second = parts[1]["coefficient"].as_f64().unwrap();
    assert!(
        parts[0]["part"] == "first half in time"
            && (first - 3e-4).abs() < 2e-5
            && second.abs() < 2e-5,
        "{time}"
    );
    // The parts' difference with its standard error from their whole covariance: its
    // square over its variance is the test's chi2 (stated sigmas).
    let [diff, se] = [0, 1].map(|k| time["difference"][k].as_f64().unwrap());
    assert!((diff - (second - first)).abs() < 1e-12, "{time}");
    let chi2 = time["chi2"].as_f64().unwrap();
    assert!(
        ((diff / se).powi(2) - chi2).abs() < 1e-6 * chi2 && time["statistic"] == time["chi2"],
        "{time}"
    );
    let verdict = v["verdict"].as_str().unwrap();
    assert!(verdict.contains("Not given as a cause"), "{verdict}");
    assert!(!verdict.contains("Selected: misalignment"), "{verdict}");
    let text = run("halfway.csv", &halfway, false);
    assert!(
        text.contains("warning: misalignment.delta_p_rad = ")
            && text.contains("is not stable: first half in time ")
            && text.contains(" rad, difference -")
            && text.contains("its value depends on when or how it was measured"),
        "{text}"
    );
    assert!(
        text.lines().any(
            |l| l.starts_with("selected: misalignment delta_p_rad") && l.contains("NOT STABLE")
        ),
        "{text}"
    );
    let v: serde_json::Value = serde_json::from_str(&run("tilted.csv", &tilted, true)).unwrap();
    let e = effect(&v);
    assert_eq!(e["stable"], true, "{e}");
    assert!(
        !e["stability"]["tests"].as_array().unwrap().is_empty(),
        "{e}"
    );
}

/// A fixture that places each position of a 24-point tumble about OA with an error of
/// 1 mrad about OA (the reading moves by `−δ_OA·a_PA`, written here from the rotation of
/// gravity, not from discovery's code; 0.98 cm/s² rms against a stated noise of 0.01): told
/// nothing, discovery warns (the stated sigma is far below the scatter), names something or
/// sees structure; told the fixture's 1 mrad in `sigma_angle_urad`, it names nothing, sees
/// no structure and has nothing to warn of.
#[test]
fn a_declared_fixture_error_is_noise_not_an_effect() {
    use rand::SeedableRng as _;
    use rand_distr::Distribution as _;
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let g = 980.665;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
    let normal = rand_distr::Normal::new(0.0, 1e-3).unwrap();
    let deltas: Vec<f64> = (0..24).map(|_| normal.sample(&mut rng)).collect();
    let text = lab_tumble(d, r#"{"effects":[]}"#, |k, c| {
        let g_pa: f64 = c[3].parse().unwrap();
        let y: f64 = c[4].parse().unwrap();
        c[4] = format!("{}", y - deltas[k] * g_pa * g);
    });
    let mut declared = String::new();
    for (k, l) in text.lines().enumerate() {
        declared.push_str(l);
        declared.push_str(if k == 0 {
            ",sigma_angle_urad\n"
        } else {
            ",1000\n"
        });
    }
    let discover = |name: &str, text: &str| -> serde_json::Value {
        std::fs::write(d.join(name), text).unwrap();
        discover_json(d, name)
    };
    let named = |v: &serde_json::Value| {
        v["effects"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| e["name"].as_str().unwrap().to_string())
            .collect::<Vec<_>>()
    };
    let blind = discover("blind.csv", &text);
    let warned = |v: &serde_json::Value| !v["warnings"].as_array().unwrap().is_empty();
    assert!(
        !named(&blind).is_empty() || blind["unexplained"]["detected"] == true || warned(&blind),
        "{blind}"
    );
    let told = discover("told.csv", &declared);
    assert!(named(&told).is_empty(), "{:?}", named(&told));
    assert_eq!(told["unexplained"]["detected"], false, "{told}");
    assert!(!warned(&told), "{}", told["warnings"]);
    // No sigma stated: the noise is estimated beside the fixture's known variance.
    let mut estimated = String::new();
    for l in declared.lines() {
        let mut c: Vec<&str> = l.split(',').collect();
        c.remove(c.len() - 2);
        estimated.push_str(&c.join(","));
        estimated.push('\n');
    }
    assert!(
        estimated
            .starts_with("label,kind,g_ia,g_pa,measured_cm_s2,approach,temp_c,sigma_angle_urad\n")
    );
    let est = discover("estimated.csv", &estimated);
    assert!(named(&est).is_empty(), "{:?}", named(&est));
    assert_eq!(est["unexplained"]["detected"], false, "{est}");
}

/// The readings of a 24-point tumble over a warming ramp of `temp_c` (24 to 28 °C), with a
/// scale factor of 40 ppm per °C: the case-frame text.
fn warm_tumble(d: &Path) -> String {
    let temp = r#"{"effects":[{"name":"temperature","coefficients":{"k1_t_ppm_per_c":40.0}}]}"#;
    let ramp = |k: usize, c: &mut Vec<String>| {
        #[allow(clippy::cast_precision_loss)]
        let t = 24.0 + 4.0 * (1.0 - (-(k as f64) / 6.0).exp());
        c[6] = format!("{t}");
    };
    // The readings with their temperatures, then what the instrument reads with the
    // scale factor per °C (`predict` takes the temperatures from the file).
    let base = lab_tumble(d, r#"{"effects":[]}"#, ramp);
    std::fs::write(d.join("warm.csv"), &base).unwrap();
    std::fs::write(d.join("temp.json"), temp).unwrap();
    let (out, _) = succeeds_in(
        d,
        &[
            "predict",
            "--data",
            "warm.csv",
            "--effects",
            "temp.json",
            "--json",
            "--analytic",
        ],
    );
    let pred: serde_json::Value = serde_json::from_str(&out).unwrap();
    let mut measured = String::new();
    for (k, line) in base.lines().enumerate() {
        if k == 0 {
            measured.push_str(line);
        } else {
            let mut c = plan_cells(line);
            #[allow(clippy::cast_precision_loss)]
            let noise = 0.01 * (2.399 * (k - 1) as f64).sin();
            let y = pred["rows"][k - 1]["predicted_cm_s2"].as_f64().unwrap() + noise;
            c[4] = format!("{y}");
            measured.push_str(&c.join(","));
        }
        measured.push('\n');
    }
    measured
}

/// A scale factor that follows the temperature is named as such (`temp_c` ramp).
#[test]
fn discover_names_a_scale_factor_per_degree() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let measured = warm_tumble(d);
    std::fs::write(d.join("temp.csv"), &measured).unwrap();
    let v = discover_json(d, "temp.csv");
    let e = effect_named(&v, "temperature");
    let (k1, se) = (
        e["coefficients"]["k1_t_ppm_per_c"].as_f64().unwrap(),
        e["stderr"]["k1_t_ppm_per_c"].as_f64().unwrap(),
    );
    assert!((k1 - 40.0).abs() < 4.0 * se, "K_1,T = {k1} ± {se}");
}

/// A bad `approach` word and a measured row without a temperature in a file that gives
/// them are refused with the line and column, nothing written.
#[test]
fn bad_lab_columns_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let text = lab_tumble(d, r#"{"effects":[]}"#, |_, _| {});
    let measured = warm_tumble(d);
    // Refused: a word `approach` does not take; a measured row without a temperature.
    let bad = text.replacen(",,,0.01\n", ",rising,,0.01\n", 1);
    refused_with(
        &[("bad.csv", bad.as_bytes())],
        &["discover", "--data", "bad.csv", "--out", "out"],
        1,
        &["bad.csv:2: column 6 (`approach`) holds `rising`; expected `up` or `+`"],
    );
    // A power-on time without the row's time, or after it.
    refused_with(
        &[(
            "on.csv",
            b"label,kind,g_ia,power_on_s,measured_cm_s2\na,absolute,1,0,981\n",
        )],
        &["discover", "--data", "on.csv", "--out", "out"],
        1,
        &[
            "on.csv:2: column 4 (`power_on_s`) is 0 but the row has no `time_s`; expected `time_s` on the row",
        ],
    );
    refused_with(
        &[(
            "late.csv",
            b"label,kind,g_ia,time_s,power_on_s,measured_cm_s2\na,absolute,1,10,0,981\nb,absolute,0,20,30,19\n",
        )],
        &["discover", "--data", "late.csv", "--out", "out"],
        1,
        &["late.csv:3: column 5 (`power_on_s`) is 30 s, after the row's `time_s` 20 s; expected the time the instrument was switched on before this row"],
    );
    let gap: String = measured
        .lines()
        .enumerate()
        .map(|(k, l)| {
            if k == 5 {
                let mut c = plan_cells(l);
                c[6] = String::new();
                c.join(",") + "\n"
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    refused_with(
        &[("gap.csv", gap.as_bytes())],
        &["discover", "--data", "gap.csv", "--out", "out"],
        1,
        &[
            "gap.csv:6: column 7 (`temp_c`) is empty in a measured row (`tumble 60 deg",
            "but 23 other rows give a temperature; expected the instrument's temperature in °C on every measured row or on none",
        ],
    );
}

/// `approach` recorded on difference rows (Table 6.1's rate-table rows) is not used, and
/// the output says so: a `warning:` line naming the rows, in the text and in the JSON's
/// `warnings`; the analysis is the same as without the column.
#[test]
fn approach_on_difference_rows_is_warned_unused() {
    let table = include_str!("../../data/r890-table-6.1.case.csv");
    let mut text = String::new();
    for (k, l) in table.lines().filter(|l| !l.starts_with('#')).enumerate() {
        text.push_str(l);
        text.push_str(if k == 0 { ",approach\n" } else { ",up\n" });
    }
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    std::fs::write(d.join("t61.csv"), &text).unwrap();
    let (out, _) = succeeds_in(
        d,
        &["discover", "--data", "t61.csv", "--analytic", "--no-plots"],
    );
    // The line after the report's title.
    let first = out.lines().nth(1).unwrap_or_default();
    assert!(
        first.starts_with(
            "warning: 8 difference or response rows record `approach` but they are not absolute (`IA 45 deg`, `IA 90 deg`, `IA 135 deg`, …): the column is not used there"
        ),
        "{out}"
    );
    assert!(out.contains("selected: anisoinertia"), "{out}");
    let (json, _) = succeeds_in(
        d,
        &[
            "discover",
            "--data",
            "t61.csv",
            "--analytic",
            "--no-plots",
            "--json",
        ],
    );
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert!(
        v["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|w| w.as_str().unwrap().contains("record `approach`")),
        "{v}"
    );
}

/// `--term`: a user's term is tested after the selection and reported with its key, unit,
/// coefficient and p-value; a term with no column here is not testable; the library's
/// proposals name a planted cubic in `a_PA`; a malformed term is refused before any work,
/// naming the column of the bad token and what was expected.
#[test]
fn discover_tests_a_users_term_and_refuses_a_malformed_one() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    // k·a_PA³ with k = −2e-10 s⁴/cm² (a_PA from g_pa and 980.4 cm/s²).
    let k = -2e-10;
    let text = lab_tumble(d, r#"{"effects":[]}"#, |_, c| {
        let a_pa = c[3].parse::<f64>().unwrap() * 980.4;
        let y = c[4].parse::<f64>().unwrap() + k * a_pa.powi(3);
        c[4] = format!("{y}");
    });
    std::fs::write(d.join("cubic.csv"), &text).unwrap();
    let (out, err) = succeeds_in(
        d,
        &[
            "discover",
            "--data",
            "cubic.csv",
            "--analytic",
            "--json",
            "--no-plots",
            "--term",
            "a_pa^3",
            "--term",
            "a_pa*w_oa",
        ],
    );
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let u = &v["unexplained"];
    let t = &u["terms"];
    assert_eq!(t[0]["key"], "term:a_pa^3", "{u}");
    assert_eq!(t[0]["unit"], "s⁴/cm²");
    assert_eq!(t[0]["significant"], true, "{u}");
    let (c, se) = (
        t[0]["coefficient"].as_f64().unwrap(),
        t[0]["se"].as_f64().unwrap(),
    );
    assert!(
        (c - k).abs() < 0.2 * k.abs() && se < 0.1 * k.abs(),
        "{c} ± {se}"
    );
    assert_eq!(t[1]["key"], "term:a_pa*w_oa");
    assert_eq!(t[1]["unit"], "s/rad");
    assert_eq!(t[1]["testable"], false);
    assert!(t[1]["coefficient"].is_null() && t[1]["p_value"].is_null());
    assert_eq!(u["detected"], true, "{u}");
    assert_eq!(u["proposals"][0]["form"], "a_PA^3", "{u}");
    assert_eq!(u["proposals"][0]["unit"], "s⁴/cm²");
    assert!(
        err.contains("term:a_pa^3: ") && err.contains("(p = "),
        "{err}"
    );
    assert!(err.contains("term:a_pa*w_oa: not testable here"), "{err}");
    assert!(
        err.contains("proposal (a form the residual follows, not a cause): a_PA^3 × "),
        "{err}"
    );
    // Refusals: exit 2 before any work, the flag, the column and what was expected.
    for (term, needle) in [
        (
            "a_pa^x",
            "`a_pa^x`: column 6: expected a whole power from 1 to 6 after `^`, found `x`",
        ),
        (
            "a_pa*b_xx",
            "`a_pa*b_xx`: column 6: expected a case input (a_ia, a_pa, a_oa",
        ),
        (
            "a_pa + w_oa",
            "`a_pa + w_oa`: column 6: the terms of a sum must share a unit; expected a term in cm/s² like the one before, found one in rad/s",
        ),
        (
            "(a_ia",
            "`(a_ia`: column 6: expected `)`, found the end of the term",
        ),
        (
            "2*3",
            "`2*3`: no variable: expected a product of case inputs",
        ),
    ] {
        let err = refused(
            &[
                "discover",
                "--data",
                "cubic.csv",
                "--term",
                term,
                "--out",
                "out",
            ],
            2,
            &["--term <TEXT>", needle],
        );
        assert!(!err.contains("wrote"), "{err}");
    }
}

/// A cubic in `a_PA` (`k·a_PA³`, written here from the row's gravity along PA) in a
/// 24-point tumble about OA is taken for the misalignment toward PA; the result names the
/// misalignment with `a_PA^3` as its rival outside the vocabulary, in the JSON, the
/// selected line, a warning and the verdict.
#[test]
fn a_cubic_taken_for_a_misalignment_is_named_with_its_rival() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let g = 980.665_f64;
    let text = lab_tumble(d, r#"{"effects":[]}"#, |_, c| {
        let g_pa: f64 = c[3].parse().unwrap();
        let y: f64 = c[4].parse().unwrap();
        c[4] = format!("{}", y + 1e-10 * (g_pa * g).powi(3));
    });
    std::fs::write(d.join("cubic.csv"), &text).unwrap();
    let v = discover_json(d, "cubic.csv");
    let e = effect_named(&v, "misalignment");
    let rivals = e["rivals"].as_array().unwrap();
    assert!(rivals.iter().any(|r| r["form"] == "a_PA^3"), "{e}");
    assert!(
        v["verdict"]
            .as_str()
            .unwrap()
            .contains("or a form outside the vocabulary these data cannot tell from it"),
        "{}",
        v["verdict"]
    );
    let (out, _) = succeeds_in(
        d,
        &[
            "discover",
            "--data",
            "cubic.csv",
            "--analytic",
            "--no-plots",
        ],
    );
    assert!(
        out.lines()
            .any(|l| l.starts_with("selected: misalignment delta_p_rad")
                && l.contains("outside the vocabulary")
                && l.contains("a_PA^3")),
        "{out}"
    );
    assert!(out.contains("cannot be told here from a_PA^3"), "{out}");
}

/// `ptsa discover --data FILE --analytic --json --no-plots` in `d`: the JSON.
fn discover_json(d: &Path, file: &str) -> serde_json::Value {
    let (out, _) = succeeds_in(
        d,
        &[
            "discover",
            "--data",
            file,
            "--analytic",
            "--json",
            "--no-plots",
        ],
    );
    serde_json::from_str(&out).unwrap()
}

/// The effect `name` of a discovery's JSON (panics, with the JSON, when it is not there).
fn effect_named(v: &serde_json::Value, name: &str) -> serde_json::Value {
    v["effects"]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e["name"] == name)
        .unwrap_or_else(|| panic!("{v}"))
        .clone()
}

/// One meaning per option: `--out` is a folder, `-o/--output` a file, `--no-limit` lifts
/// the work limit and `--force` replaces files. The old spellings still run for one
/// release, each with a warning naming the new one.
#[test]
fn old_spellings_run_and_name_the_new_ones() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let o = ptsa_in(
        d,
        &[
            "plan",
            "tumble",
            "--positions",
            "8",
            "--counts",
            "--out",
            "a.csv",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    for w in [
        "warning: --counts is spelled --count-columns now",
        "warning: --out is spelled --output now (--out names a folder in every command)",
    ] {
        assert!(err.contains(w), "{w}: {err}");
    }
    let old = std::fs::read_to_string(d.join("a.csv")).unwrap();
    let o = ptsa_in(
        d,
        &[
            "plan",
            "tumble",
            "--positions",
            "8",
            "--count-columns",
            "-o",
            "b.csv",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(d.join("b.csv")).unwrap(), old);

    // --force beyond the limit still runs, and says that it is --no-limit's task now.
    let run = |extra: &str| {
        Command::new(env!("CARGO_BIN_EXE_ptsa"))
            .current_dir(d)
            .env("PTSA_LIMIT_S", "0.001")
            .args(["noise", "--simulate", "--seconds", "2", extra])
            .output()
            .unwrap()
    };
    let forced = run("--force");
    assert!(forced.status.success(), "{}", stderr(&forced));
    assert!(stderr(&forced).contains("that is --no-limit's task now"));
    let lifted = run("--no-limit");
    assert!(lifted.status.success(), "{}", stderr(&lifted));
    assert!(!stderr(&lifted).contains("--force"), "{}", stderr(&lifted));

    // --no-limit only where work is estimated.
    for sub in [
        &["design"][..],
        &["instrument", "new"],
        &["plan", "tumble"],
        &["correct"],
    ] {
        let mut a = sub.to_vec();
        a.push("--help");
        let o = ptsa_in(d, &a);
        assert!(
            !stdout(&o).contains("--no-limit"),
            "{sub:?} offers --no-limit"
        );
    }
}
