//! `ptsa discover --data STREAM` on a triad's raw stream (issue 44, item 2): the stream cut
//! into its positions, the positions written for a person (`--positions-out`) and
//! calibrated from gravity alone, the same calibration again from the written positions,
//! the readings in the instrument's unit, and every refusal with its message.

use std::fmt::Write as _;

use rand::SeedableRng as _;

mod common;
use common::{assert_clean_of, json_in, numbers, ptsa_in, stderr, stdout};

/// The triad generator written from the equations (shared with the triad campaign and
/// the benchmark; it uses nothing of `ptsa_host_sim`).
#[path = "../../ptsa-campaigns/src/triad_gen.rs"]
mod triad_gen;
use triad_gen::{StreamSpec, TriadTruth, design37, hand_placed, in_triad_frame, stream_csv};

/// The triad of the streams: bias, scale-factor change, Γ (rad), `K_2`.
fn truth() -> TriadTruth {
    TriadTruth {
        b: [12.0, -8.0, 30.0],
        k: [0.01, -0.005, 0.002],
        gamma: [
            [0.0, 0.002, -0.003],
            [0.004, 0.0, 0.001],
            [-0.002, 0.003, 0.0],
        ],
        q: [2e-7, -1e-7, 3e-7],
    }
}

/// A stream through the 37 directions (each placed by hand), seed `seed`: its text and
/// each hold's span.
fn stream(seed: u64, spec: &StreamSpec) -> (String, Vec<(f64, f64)>) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let dirs: Vec<[f64; 3]> = design37()
        .into_iter()
        .map(|n| hand_placed(n, &mut rng))
        .collect();
    stream_csv(&truth(), &dirs, spec, &mut rng)
}

/// Every coefficient within 4 σ of the truth in the triad's frame.
fn holds_the_truth(t: &serde_json::Value) {
    let want = in_triad_frame(&truth());
    let (b, bs) = (numbers(&t["bias_cm_s2"]), numbers(&t["bias_sigma_cm_s2"]));
    let (k, ks) = (
        numbers(&t["scale_factor_ppm"]),
        numbers(&t["scale_factor_sigma_ppm"]),
    );
    for a in 0..3 {
        assert!(
            (b[a] - want.b[a]).abs() < 4.0 * bs[a],
            "bias {b:?} ± {bs:?}"
        );
        assert!(
            (k[a] - want.k[a] * 1e6).abs() < 4.0 * ks[a],
            "sf {k:?} ± {ks:?} against {:?}",
            want.k
        );
        for c in 0..3 {
            let m = t["misalignment_rad"][a][c].as_f64().unwrap();
            if let Some(s) = t["misalignment_sigma_rad"][a][c].as_f64() {
                assert!(
                    (m - want.gamma[a][c]).abs() < 4.0 * s,
                    "Γ{a}{c} {m} ± {s} against {}",
                    want.gamma[a][c]
                );
            }
        }
    }
}

/// The stream is cut into the 37 holds, calibrated within its intervals; the written
/// positions give the same calibration again with --orientation approximate; the input
/// is untouched.
#[test]
fn a_stream_is_cut_calibrated_and_its_positions_written() {
    let tmp = tempfile::tempdir().unwrap();
    let (text, spans) = stream(5, &StreamSpec::default());
    std::fs::write(tmp.path().join("s.csv"), &text).unwrap();
    let j = json_in(
        tmp.path(),
        &[
            "discover",
            "--data",
            "s.csv",
            "--positions-out",
            "pos.csv",
            "--json",
        ],
    );
    assert_eq!(
        std::fs::read_to_string(tmp.path().join("s.csv")).unwrap(),
        text
    );
    let s = &j["stream"];
    let found = s["positions"].as_array().unwrap();
    assert_eq!(found.len(), 37, "{s}");
    for (p, sp) in found.iter().zip(&spans) {
        let (a, b) = (p["start_s"].as_f64().unwrap(), p["end_s"].as_f64().unwrap());
        assert!(a >= sp.0 - 0.005 && b <= sp.1 + 0.005, "{p} in {sp:?}");
        assert!(b - a > 0.5 * (sp.1 - sp.0), "{p} of {sp:?}");
    }
    assert_eq!(s["window_samples"], 100);
    assert_eq!(j["triad"]["orientation"], "approximate");
    holds_the_truth(&j["triad"]);
    assert!(
        j["triad"]["warnings"].as_array().unwrap().is_empty(),
        "{}",
        j["triad"]["warnings"]
    );
    let pos = std::fs::read_to_string(tmp.path().join("pos.csv")).unwrap();
    assert!(
        pos.contains("\n# s1: 0–14.") && pos.contains("\n# s37: "),
        "{pos}"
    );
    let again = json_in(
        tmp.path(),
        &[
            "discover",
            "--data",
            "pos.csv",
            "--orientation",
            "approximate",
            "--json",
        ],
    );
    for key in ["bias_cm_s2", "scale_factor_ppm"] {
        let (a, b) = (numbers(&j["triad"][key]), numbers(&again["triad"][key]));
        for (x, y) in a.iter().zip(&b) {
            assert!(
                (x - y).abs() <= 1e-9 * x.abs().max(1.0),
                "{key}: {a:?} {b:?}"
            );
        }
    }
    // The text report says what was found.
    let o = ptsa_in(tmp.path(), &["discover", "--data", "s.csv", "--no-plots"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains("37 positions held"), "{out}");
    assert!(
        out.contains("--static-threshold 4 times the first --rest-s 10 s"),
        "{out}"
    );
}

/// Readings in the instrument's unit: LSB through the mems file's 16384 LSB per g.
#[test]
fn a_stream_in_lsb_is_read_through_the_instrument_file() {
    let tmp = tempfile::tempdir().unwrap();
    let (text, _) = stream(6, &StreamSpec::default());
    let per_lsb = 980.665 / 16384.0;
    let mut lsb = String::new();
    for l in text.lines() {
        if l.starts_with('#') {
            continue;
        }
        if l.starts_with("time_s") {
            lsb.push_str("time_s,reading_x,reading_y,reading_z\n");
            continue;
        }
        let c: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
        let _ = writeln!(
            lsb,
            "{},{},{},{}",
            c[0],
            c[1] / per_lsb,
            c[2] / per_lsb,
            c[3] / per_lsb
        );
    }
    std::fs::write(tmp.path().join("lsb.csv"), &lsb).unwrap();
    let j = json_in(
        tmp.path(),
        &[
            "--instrument",
            "mems",
            "discover",
            "--data",
            "lsb.csv",
            "--json",
            "--no-plots",
        ],
    );
    assert_eq!(j["stream"]["reading_unit"], "LSB");
    assert_eq!(j["stream"]["positions"].as_array().unwrap().len(), 37);
}

/// Refused, each with what was expected; nothing on stdout.
#[test]
fn stream_refusals() {
    let tmp = tempfile::tempdir().unwrap();
    let (text, _) = stream(7, &StreamSpec::default());
    std::fs::write(tmp.path().join("s.csv"), &text).unwrap();
    // The rest moves: a knock at 4 s.
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let (t, rest) = lines[402].split_once(',').unwrap();
    let x: f64 = rest.split(',').next().unwrap().parse().unwrap();
    let tail: Vec<&str> = rest.split(',').skip(1).collect();
    lines[402] = format!("{t},{},{}", x + 200.0, tail.join(","));
    std::fs::write(tmp.path().join("knock.csv"), lines.join("\n")).unwrap();
    // Too few positions: the first 45 s only.
    let mut short = text.lines().take(4500).collect::<Vec<_>>().join("\n");
    short.push('\n');
    std::fs::write(tmp.path().join("short.csv"), short).unwrap();
    // A repeated time.
    let dup = text.replacen("\n0.02,", "\n0.01,", 1);
    std::fs::write(tmp.path().join("dup.csv"), dup).unwrap();
    std::fs::write(
        tmp.path().join("pos.csv"),
        "label,g_x,g_y,g_z,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2\np1,0,0,1,1,2,980\n",
    )
    .unwrap();
    std::fs::write(tmp.path().join("taken.csv"), "mine\n").unwrap();
    let cases: [(&[&str], &str); 7] = [
        (
            &["--data", "knock.csv"],
            "knock.csv: --rest-s 10: the readings move at 3.",
        ),
        (&["--data", "short.csv"], "positions found ("),
        (
            &["--data", "dup.csv"],
            "dup.csv:5: time_s 0.01 is not after line 4's 0.01",
        ),
        (
            &["--data", "s.csv", "--orientation", "exact"],
            "--orientation exact: s.csv is a raw stream",
        ),
        (
            &["--data", "pos.csv", "--static-threshold", "3"],
            "--static-threshold applies to a raw stream",
        ),
        (
            &["--data", "s.csv", "--positions-out", "taken.csv"],
            "taken.csv",
        ),
        (
            &["--data", "s.csv", "--static-window-s", "0.03"],
            "--static-window-s 0.03: 3 samples",
        ),
    ];
    for (args, needle) in cases {
        let mut a = vec!["discover", "--no-plots"];
        a.extend_from_slice(args);
        let o = ptsa_in(tmp.path(), &a);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: `{needle}` not in {err}");
        assert!(o.stdout.is_empty(), "{args:?}");
        assert_clean_of(&err, &[]);
    }
    assert_eq!(
        std::fs::read_to_string(tmp.path().join("taken.csv")).unwrap(),
        "mine\n"
    );
    let o = ptsa_in(tmp.path(), &["discover", "--static-min-s", "2"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}
