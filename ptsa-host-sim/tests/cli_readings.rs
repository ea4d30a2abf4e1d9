//! `ptsa noise --readings`: any instrument's static record of readings (issue 44, item 1).
//! The deviations are checked against the published results of NIST's 1000-point test
//! record (NBS14, computed with Stable32; NIST SP 1065, 2008, p. 108; W. J. Riley, "Stable32
//! test suite"), generated here by its published generator; the options (`--taus`,
//! `--confidence`, `--unit`), the plot and every refusal with its line.

mod common;

use std::fmt::Write as _;

use common::{assert_clean_of, json_in, ptsa_in, stderr, stdout};

/// NIST's 1000-point test record: `n_{i+1} = 16807·n_i mod 2147483647` from 1234567890,
/// each divided by 2147483647 (frequency data, τ₀ = 1 s).
fn nbs14() -> Vec<f64> {
    let mut n = vec![1_234_567_890u64];
    for i in 0..999 {
        n.push(16_807 * n[i] % 2_147_483_647);
    }
    assert_eq!(&n[1..4], &[395_529_916, 1_209_410_747, 633_705_974]);
    #[allow(clippy::cast_precision_loss)]
    n.into_iter().map(|x| x as f64 / 2_147_483_647.0).collect()
}

/// A record `time_s,reading` of `y` every `dt` s, after a comment line.
fn record(y: &[f64], dt: f64) -> String {
    let mut s = String::from("# a static record\ntime_s,reading\n");
    for (k, v) in y.iter().enumerate() {
        #[allow(clippy::cast_precision_loss)]
        let t = k as f64 * dt;
        let _ = writeln!(s, "{t},{v}");
    }
    s
}

fn near(got: f64, want: f64, rel: f64) -> bool {
    (got / want - 1.0).abs() < rel
}

/// The published overlapping ADEV, MDEV and overlapping HDEV of the NBS14 record at τ = 1,
/// 10 and 100 s, to their 7 digits.
#[test]
fn the_nist_1000_point_record_gives_the_published_deviations() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("nbs14.csv"), record(&nbs14(), 1.0)).unwrap();
    let v = json_in(
        tmp.path(),
        &[
            "noise",
            "--readings",
            "nbs14.csv",
            "--unit",
            "cm/s2",
            "--taus",
            "1,10,100",
            "--json",
        ],
    );
    let points = v["points"].as_array().unwrap();
    let taus: Vec<f64> = points
        .iter()
        .map(|p| p["tau_s"].as_f64().unwrap())
        .collect();
    assert_eq!(taus, [1.0, 10.0, 100.0]);
    let published = [
        ("adev_cm_s2", [2.922_319e-1, 9.159_953e-2, 3.241_343e-2]),
        ("mdev_cm_s2", [2.922_319e-1, 6.172_376e-2, 2.170_921e-2]),
        ("hdev_cm_s2", [2.943_883e-1, 9.581_083e-2, 3.237_638e-2]),
    ];
    for (key, want) in published {
        for (p, w) in points.iter().zip(want) {
            let got = p[key].as_f64().unwrap();
            assert!(
                near(got, w, 2e-6),
                "{key} at {}: {got} against {w}",
                p["tau_s"]
            );
        }
    }
    assert_eq!(v["reading_unit"], "cm/s²");
    assert!(v["sf_cm_s2"].is_null() && v["pulse_cm_s"].is_null());
    assert_eq!(v["taus"], "listed");
    assert!(v["terms"]["rate_ramp"].is_object(), "{}", v["terms"]);
}

/// `--confidence` adds intervals at its level beside the 95 % ones (narrower at 68.3 %);
/// `--taus decade` is 1, 2, 4, 10, 20, 40, … τ₀; the plot is written as PNG and SVG.
#[test]
fn confidence_decade_taus_and_the_plot() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("r.csv"), record(&nbs14(), 0.5)).unwrap();
    let v = json_in(
        tmp.path(),
        &[
            "noise",
            "--readings",
            "r.csv",
            "--unit",
            "g",
            "--taus",
            "decade",
            "--confidence",
            "0.683",
            "--plot",
            "adev.svg",
            "--json",
        ],
    );
    let ms: Vec<u64> = v["points"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["m"].as_u64().unwrap())
        .collect();
    assert_eq!(ms, [1, 2, 4, 10, 20, 40, 100, 200, 400]);
    assert!((v["confidence"].as_f64().unwrap() - 0.683).abs() < 1e-12);
    for p in v["points"].as_array().unwrap() {
        let f = |k: &str| p[k].as_f64().unwrap();
        assert!(
            f("ci95_lo") < f("ci_lo") && f("ci_lo") < f("adev_cm_s2"),
            "{p}"
        );
        assert!(
            f("adev_cm_s2") < f("ci_hi") && f("ci_hi") < f("ci95_hi"),
            "{p}"
        );
    }
    // In g of the instrument file's gravity (the shipped Kearfott file's 980.4 cm/s²).
    let mean = v["mean_cm_s2"].as_f64().unwrap();
    let raw = nbs14().iter().sum::<f64>() / 1000.0;
    assert!(near(mean, raw * 980.4, 1e-12), "{mean}");
    for f in ["adev.png", "adev.svg"] {
        assert!(tmp.path().join(f).metadata().unwrap().len() > 1000, "{f}");
    }
}

/// A MEMS part's record in LSB through its class file; its text report names the unit.
#[test]
fn a_mems_record_in_lsb_through_its_instrument_file() {
    let tmp = tempfile::tempdir().unwrap();
    let lsb: Vec<f64> = nbs14().iter().map(|v| (v * 100.0).round()).collect();
    std::fs::write(tmp.path().join("m.csv"), record(&lsb, 0.01)).unwrap();
    let o = ptsa_in(
        tmp.path(),
        &["--instrument", "mems", "noise", "--readings", "m.csv"],
    );
    let out = stdout(&o);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        out.contains("1000 samples every 0.01 s (10 s), read in LSB"),
        "{out}"
    );
    assert!(out.contains("hdev cm/s^2"), "{out}");
    let mean: f64 = lsb.iter().sum::<f64>() / 1000.0 / 16384.0 * 980.665;
    let v = json_in(
        tmp.path(),
        &[
            "--instrument",
            "mems",
            "noise",
            "--readings",
            "m.csv",
            "--json",
        ],
    );
    assert!(near(v["mean_cm_s2"].as_f64().unwrap(), mean, 1e-12));
    assert_eq!(v["reading_unit"], "LSB");
}

/// Refused, each naming the file and line (or the option) and what was expected; nothing
/// on stdout.
#[test]
fn bad_records_and_options_are_refused_with_their_line() {
    let tmp = tempfile::tempdir().unwrap();
    let y = nbs14();
    let good = record(&y[..50], 0.1);
    let lines: Vec<&str> = good.lines().collect();
    // A gap: line 20 (the 18th sample) left out.
    let mut gap = String::new();
    for (_, l) in lines.iter().enumerate().filter(|(k, _)| *k != 19) {
        gap.push_str(l);
        gap.push('\n');
    }
    let dup = good.replacen("0.30000000000000004,", "0.2,", 1);
    let cases: [(&str, String, &[&str], &str); 6] = [
        (
            "gap.csv",
            gap,
            &[],
            "gap.csv:20: a gap of 0.2 s after line 19 (1 sample missing",
        ),
        (
            "dup.csv",
            dup,
            &[],
            "dup.csv:6: time_s 0.2 is not after line 5's 0.2",
        ),
        (
            "head.csv",
            "time_s,pulses,ticks\n0,1,2\n".into(),
            &[],
            "head.csv:1:1: the header `time_s,pulses,ticks` has no reading",
        ),
        (
            "cell.csv",
            good.replacen(",0.57", ",0.5x7", 1),
            &[],
            "is not a finite number; expected the reading",
        ),
        (
            "lsb.csv",
            good.clone(),
            &["--unit", "LSB"],
            "a reading in LSB needs the instrument file's nominal scale factor",
        ),
        (
            "tau.csv",
            good.clone(),
            &["--taus", "0.15"],
            "--taus 0.15: not a whole number of the record's 0.1 s intervals",
        ),
    ];
    for (name, text, extra, needle) in cases {
        std::fs::write(tmp.path().join(name), &text).unwrap();
        let mut args = vec!["noise", "--readings", name];
        args.extend(extra);
        let o = ptsa_in(tmp.path(), &args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{name}: {err}");
        assert!(err.contains(needle), "{name}: `{needle}` not in {err}");
        assert!(o.stdout.is_empty(), "{name}");
        assert_clean_of(&err, &[]);
    }
    // A confidence of 95 (clap, exit 2); --unit without --readings (exit 1: clap drops the
    // requirement when --simulate conflicts with --readings).
    for (args, code, needle) in [
        (
            &["noise", "--readings", "tau.csv", "--confidence", "95"][..],
            2,
            "less than 1",
        ),
        (
            &["noise", "--simulate", "--seconds", "1", "--unit", "g"][..],
            1,
            "--unit applies to --readings FILE only",
        ),
        (
            &["noise", "--simulate", "--seconds", "1", "--compare"][..],
            1,
            "--compare applies to --counts FILE only",
        ),
    ] {
        let o = ptsa_in(tmp.path(), args);
        assert_eq!(o.status.code(), Some(code), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
    }
}

/// A white noise N and a random walk K (cm/s²/√Hz, cm/s^2.5) at `dt`, `n` samples, from
/// Marsaglia's xorshift64 and Box–Muller (no code shared with the identification's
/// replicas).
fn white_and_walk(n: usize, dt: f64, white: f64, walk: f64) -> Vec<f64> {
    let mut state = 0x9E37_79B9_7F4A_7C15_u64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        #[allow(clippy::cast_precision_loss)]
        let u = ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
        u
    };
    let mut normal = move || {
        let (u, v) = (uniform(), uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    };
    let mut w = 0.0;
    (0..n)
        .map(|_| {
            let y = white / dt.sqrt() * normal() + w;
            w += walk * dt.sqrt() * normal();
            y
        })
        .collect()
}

/// `--readings --identify`: a white noise and a walk are the terms selected (Holm at 5 %
/// familywise), the white noise's 95 % interval holds the value the record was made with,
/// the JSON keys and the text say so; refusals of what does not apply.
#[test]
fn the_terms_a_record_holds_are_identified() {
    let tmp = tempfile::tempdir().unwrap();
    let (white, walk) = (0.05, 0.01);
    std::fs::write(
        tmp.path().join("nk.csv"),
        record(&white_and_walk(20_000, 0.01, white, walk), 0.01),
    )
    .unwrap();
    let v = json_in(
        tmp.path(),
        &["noise", "--readings", "nk.csv", "--identify", "--json"],
    );
    let id = &v["terms_identification"];
    assert_eq!(
        id["selected"],
        serde_json::json!(["velocity_random_walk", "acceleration_random_walk"]),
        "{id}"
    );
    let n = &id["candidates"][1];
    assert_eq!(n["term"], "velocity_random_walk");
    let ci = n["values"][0]["ci95"].as_array().unwrap();
    let (lo, hi) = (ci[0].as_f64().unwrap(), ci[1].as_f64().unwrap());
    assert!(lo < white && white < hi, "{n}");
    assert_eq!(n["values"][0]["unit"], "cm/s^2/rtHz");
    for key in [
        "taus_s",
        "chi2",
        "dof",
        "replicas",
        "rounds",
        "familywise_alpha",
        "test",
    ] {
        assert!(!id[key].is_null(), "{key} in {id}");
    }
    assert_eq!(id["candidates"][2]["selected"], false);
    let o = ptsa_in(tmp.path(), &["noise", "--readings", "nk.csv", "--identify"]);
    let text = stdout(&o);
    assert!(text.contains("identified terms (IEEE Std 952;"), "{text}");
    assert!(
        text.contains("K acceleration random walk: selected (z "),
        "{text}"
    );
    assert!(text.contains("B bias instability: not selected"), "{text}");
    for (args, needle) in [
        (
            &[
                "noise",
                "--readings",
                "nk.csv",
                "--identify",
                "--write-instrument",
                "x.toml",
            ][..],
            "--write-instrument applies to --counts FILE only",
        ),
        (
            &[
                "noise",
                "--readings",
                "nk.csv",
                "--identify",
                "--taus",
                "decade",
            ][..],
            "expected --taus octave",
        ),
        (
            &["noise", "--simulate", "--seconds", "1", "--identify"][..],
            "--identify applies to --counts or --readings FILE only",
        ),
    ] {
        let o = ptsa_in(tmp.path(), args);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
    }
    assert!(!tmp.path().join("x.toml").exists());
}
