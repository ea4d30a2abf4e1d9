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
