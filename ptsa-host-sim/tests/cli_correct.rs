//! `ptsa correct`: a calibration applied to a record of readings or counts.
//!
//! The round trip: counts made from the IEEE 1293 model equation with known absolute
//! coefficients (not from the project's model; carries uniform over one pulse at each end of
//! a gate, then rounded to a whole count), a calibration from `ptsa discover --analytic --json` on a tumble of them, and
//! `correct` on other positions: each recovers the true specific force along IA within its
//! stated uncertainty. Then every refusal and warning.

#![allow(
    clippy::float_cmp,
    reason = "the CSV and the JSON give the same numbers bit for bit"
)]

use std::fmt::Write as _;
use std::path::Path;

use rand::SeedableRng as _;
use rand_distr::Distribution as _;

mod common;
use common::{ptsa_in, refused_in_folder, stderr, stdout};

/// The shipped instrument file's gravity and nominal scale factor, cm/s².
const G: f64 = 980.4;
const SF: f64 = 21_121.1;
/// A 60 s gate at 64 kHz, ticks.
const T: f64 = 3_840_000.0;

/// The true reading at specific force `a_ia`, `a_pa` (cm/s²): an absolute bias, a
/// scale-factor error, IA tilted toward PA and a second-order term.
fn reading(a_ia: f64, a_pa: f64) -> f64 {
    19.19 + (1.0 - 146.8e-6) * a_ia - 1.19e-4 * a_pa + 1.5e-7 * a_ia * a_ia
}

/// Counts of the true reading at IA `deg` above horizontal in the IA–PA plane.
fn counts(deg: f64, rng: &mut rand_chacha::ChaCha8Rng) -> (f64, f64, f64) {
    let carry = rand_distr::Uniform::new(-0.5, 0.5).unwrap();
    let (s, c) = deg.to_radians().sin_cos();
    let y = reading(s * G, c * G);
    let p = (T * (1.0 + y / SF) / 2.0 + carry.sample(rng) - carry.sample(rng)).round();
    (s, c, p)
}

/// Run `ptsa args` in `dir`; it must succeed. Returns (stdout, stderr).
fn succeeds(dir: &Path, args: &[&str]) -> (String, String) {
    let o = ptsa_in(dir, args);
    let err = stderr(&o);
    assert!(o.status.success(), "ptsa {args:?}: {err}");
    common::assert_clean_of(&err, &[]);
    (stdout(&o), err)
}

/// A folder with `tumble.csv` (24 positions, counts), `cal.json` (its calibration) and
/// `record.csv` (12 other positions, counts, `g_ia` left out, the rounding's noise in
/// `sigma_cm_s2`), and the true `a_IA` of each record row, cm/s².
fn calibrated() -> (tempfile::TempDir, Vec<f64>) {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(22);
    let mut tumble = String::from("label,kind,g_ia,g_pa,pulses,ticks\n");
    for k in 0..24 {
        let deg = 15.0 * f64::from(k);
        let (s, c, p) = counts(deg, &mut rng);
        let _ = writeln!(tumble, "t{deg},absolute,{s},{c},{p},{T}");
    }
    std::fs::write(d.join("tumble.csv"), &tumble).unwrap();
    let (json, _) = succeeds(
        d,
        &["discover", "--data", "tumble.csv", "--analytic", "--json"],
    );
    std::fs::write(d.join("cal.json"), &json).unwrap();
    // The rounding to whole pulses is noise beyond the counting model's: stated.
    let rounding = 2.0 * SF / T * (1.0f64 / 12.0).sqrt();
    let mut record = String::from("label,kind,g_pa,pulses,ticks,sigma_cm_s2\n");
    let mut truth = Vec::new();
    for k in 0..12 {
        let deg = 7.5 + 30.0 * f64::from(k);
        let (s, c, p) = counts(deg, &mut rng);
        let _ = writeln!(record, "r{deg},absolute,{c},{p},{T},{rounding}");
        truth.push(s * G);
    }
    std::fs::write(d.join("record.csv"), &record).unwrap();
    (tmp, truth)
}

/// The round trip: every row within 3.5 σ of the truth, the z-scores' mean square near 1
/// (the σ neither far too small nor far too large), σ itself near the counting error.
#[test]
fn correct_recovers_the_true_specific_force_within_its_uncertainty() {
    let (tmp, truth) = calibrated();
    let d = tmp.path();
    let (out, err) = succeeds(
        d,
        &[
            "correct",
            "--data",
            "record.csv",
            "--calibration",
            "cal.json",
            "--json",
        ],
    );
    // g_oa is not given: the rows are in the IA–PA plane, where the calibration tested
    // everything that acts on them.
    assert!(!err.contains("was not testable"), "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), truth.len());
    let counting = 2.0 * SF / T * (1.0f64 / 6.0).sqrt();
    let mut z2 = 0.0;
    for (r, t) in rows.iter().zip(&truth) {
        let a = r["a_ia_cm_s2"].as_f64().unwrap();
        let s = r["sigma_a_ia_cm_s2"].as_f64().unwrap();
        let z = (a - t) / s;
        assert!(z.abs() < 3.5, "{r}: truth {t}, z = {z}");
        assert!(s > counting && s < 3.0 * counting, "{r}");
        assert!(r["sigma_calibration_cm_s2"].as_f64().unwrap() > 0.0, "{r}");
        z2 += z * z;
    }
    let cal: Vec<f64> = rows
        .iter()
        .map(|r| r["sigma_calibration_cm_s2"].as_f64().unwrap())
        .collect();
    // The figures docs/method/discovery.md quotes (`-- --nocapture`).
    eprintln!(
        "IA-PA rows: sigma_calibration_cm_s2 from {} to {}",
        cal.iter().copied().fold(f64::INFINITY, f64::min),
        cal.iter().copied().fold(0.0, f64::max)
    );
    #[allow(clippy::cast_precision_loss)]
    let msz = z2 / truth.len() as f64;
    assert!((0.2..3.0).contains(&msz), "mean square z = {msz}");
    // The CSV holds the same numbers.
    let (csv, _) = succeeds(
        d,
        &[
            "correct",
            "--data",
            "record.csv",
            "--calibration",
            "cal.json",
        ],
    );
    let mut lines = csv.lines().filter(|l| !l.starts_with('#'));
    assert_eq!(
        lines.next().unwrap(),
        "label,reading_cm_s2,sigma_reading_cm_s2,a_pa_cm_s2,a_oa_cm_s2,a_ia_cm_s2,a_ia_g,sigma_a_ia_cm_s2,sigma_noise_cm_s2,sigma_calibration_cm_s2"
    );
    let first: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(first[0], "r7.5");
    assert_eq!(
        first[5].parse::<f64>().unwrap(),
        rows[0]["a_ia_cm_s2"].as_f64().unwrap()
    );
}

/// The round trip on rows where a term the calibration never measured acts: the tumble
/// about OA never tilts toward OA, so `δ_p` (here −80 µrad, `+80e-6·a_o` in the reading) is
/// `not_measured`; rows in the IA–OA plane carry up to 0.078 cm/s² of it, over ten times
/// their counting error. `correct` does not correct it (it cannot know it) but enters it
/// at its plausibility bound over √3, times `a_o`: every row then within 3.5 σ of its
/// truth (without that part of the sigma, z reaches 11), and the rows in the calibration's
/// plane keep their small sigmas (the first test).
#[test]
fn a_term_the_calibration_did_not_measure_is_in_the_sigmas() {
    let (tmp, _) = calibrated();
    let d = tmp.path();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(23);
    let carry = rand_distr::Uniform::new(-0.5, 0.5).unwrap();
    let rounding = 2.0 * SF / T * (1.0f64 / 12.0).sqrt();
    let mut record = String::from("label,kind,g_oa,pulses,ticks,sigma_cm_s2\n");
    let mut truth = Vec::new();
    for k in 0..18 {
        let deg = 10.0 + 20.0 * f64::from(k);
        let (s, c) = f64::to_radians(deg).sin_cos();
        let y = reading(s * G, 0.0) + 80e-6 * c * G;
        let p =
            (T * (1.0 + y / SF) / 2.0 + carry.sample(&mut rng) - carry.sample(&mut rng)).round();
        let _ = writeln!(record, "o{deg},absolute,{c},{p},{T},{rounding}");
        truth.push((s * G, c));
    }
    std::fs::write(d.join("oa.csv"), &record).unwrap();
    let (out, err) = succeeds(
        d,
        &[
            "correct",
            "--data",
            "oa.csv",
            "--calibration",
            "cal.json",
            "--json",
        ],
    );
    // 16 of the 18 rows: at 90° and 270° a_o is cos 90° ≈ 6e-17 g, where δ_p at its bound
    // moves the reading by far less than a tenth of the noise.
    assert!(
        err.contains("`misalignment.delta_o_rad` was not testable in the calibration's data, and it acts on 16 rows here: not corrected; its plausibility bound is in their sigmas"),
        "{err}"
    );
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let bound = ptsa_host_sim::Instrument::kearfott_2401()
        .plausibility
        .misalignment_rad;
    // The figures docs/method/discovery.md quotes (`-- --nocapture`).
    let range = |v: &serde_json::Value, k: &str| {
        let x: Vec<f64> = v["rows"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r[k].as_f64().unwrap())
            .collect();
        (
            x.iter().copied().fold(f64::INFINITY, f64::min),
            x.iter().copied().fold(0.0, f64::max),
        )
    };
    eprintln!(
        "IA-OA rows, shipped bounds: sigma_calibration_cm_s2 {:?}",
        range(&v, "sigma_calibration_cm_s2")
    );
    for (r, (t, c)) in v["rows"].as_array().unwrap().iter().zip(&truth) {
        assert_within(r, *t);
        // The calibration's part holds δ_p at its bound over √3, times a_o.
        let want = bound / 3f64.sqrt() * c.abs() * G;
        let cal = r["sigma_calibration_cm_s2"].as_f64().unwrap();
        assert!(cal >= 0.99 * want, "{r}: {cal} against {want}");
    }
    // The shipped file's bounds are wide (10 mrad, 1e-4 s²/cm: two orders beyond catalogue
    // values), so those sigmas are large; with an instrument file of a class's tighter
    // bounds (200 µrad, 1e-8 s²/cm) the same rows are covered by sigmas of a tenth of a
    // cm/s² at most.
    let tight = ptsa_host_sim::model::instrument::KEARFOTT_2401_TOML
        .replace("second_order_s2_cm = 1e-4", "second_order_s2_cm = 1e-8")
        .replace("misalignment_rad = 0.01", "misalignment_rad = 2e-4");
    std::fs::write(d.join("tight.toml"), tight).unwrap();
    let (out, _) = succeeds(
        d,
        &[
            "correct",
            "--data",
            "oa.csv",
            "--calibration",
            "cal.json",
            "--instrument",
            "tight.toml",
            "--json",
        ],
    );
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    eprintln!(
        "IA-OA rows, tight bounds: sigma_calibration_cm_s2 {:?}",
        range(&v, "sigma_calibration_cm_s2")
    );
    for (r, (t, _)) in v["rows"].as_array().unwrap().iter().zip(&truth) {
        assert_within(r, *t);
        assert!(r["sigma_a_ia_cm_s2"].as_f64().unwrap() < 0.15, "{r}");
    }
}

/// A corrected row's `a_ia_cm_s2` within 3.5 of its `sigma_a_ia_cm_s2` of the truth `t`.
fn assert_within(r: &serde_json::Value, t: f64) {
    let a = r["a_ia_cm_s2"].as_f64().unwrap();
    let s = r["sigma_a_ia_cm_s2"].as_f64().unwrap();
    assert!(((a - t) / s).abs() < 3.5, "{r}: truth {t}");
}

/// `--out` writes the file whole; an existing one is replaced only with --force (its bytes
/// unchanged without), and never the data file.
#[test]
fn out_files_are_written_whole_and_never_replace_without_force() {
    let (tmp, _) = calibrated();
    let d = tmp.path();
    let (out, err) = succeeds(
        d,
        &[
            "correct",
            "--data",
            "record.csv",
            "--calibration",
            "cal.json",
            "--output",
            "c.csv",
        ],
    );
    assert!(
        out.is_empty() && err.contains("wrote c.csv (12 rows corrected)"),
        "{err}"
    );
    let before = std::fs::read(d.join("c.csv")).unwrap();
    let o = ptsa_in(
        d,
        &[
            "correct",
            "--data",
            "record.csv",
            "--calibration",
            "cal.json",
            "--output",
            "c.csv",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("--output c.csv: the file exists and is not replaced without --force"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(d.join("c.csv")).unwrap(), before);
    let data = std::fs::read(d.join("record.csv")).unwrap();
    for args in [
        &[
            "correct",
            "--data",
            "record.csv",
            "--calibration",
            "cal.json",
            "--output",
            "record.csv",
            "--force",
        ][..],
        &[
            "correct",
            "--data",
            "record.csv",
            "--calibration",
            "cal.json",
            "--output",
            "cal.json",
            "--force",
        ][..],
    ] {
        let o = ptsa_in(d, args);
        assert_eq!(o.status.code(), Some(1), "{args:?}");
        assert!(
            stderr(&o).contains("an output never replaces an input"),
            "{}",
            stderr(&o)
        );
    }
    assert_eq!(std::fs::read(d.join("record.csv")).unwrap(), data);
    let (_, err) = succeeds(
        d,
        &[
            "correct",
            "--data",
            "record.csv",
            "--calibration",
            "cal.json",
            "--output",
            "c.csv",
            "--force",
        ],
    );
    assert!(err.contains("warning: --output c.csv: replaced"), "{err}");
}

/// The warnings: a row without a reading (written with empty cells), rows without any
/// noise, no cross-axis input, a term the calibration could not test acting on a row, an
/// instrument file with no uncertainty.
#[test]
fn warnings_name_what_the_values_do_not_hold() {
    let (tmp, _) = calibrated();
    let d = tmp.path();
    std::fs::write(
        d.join("plain.csv"),
        "label,kind,measured_cm_s2\na,absolute,500\nb,absolute,\n",
    )
    .unwrap();
    let (out, err) = succeeds(
        d,
        &[
            "correct",
            "--data",
            "plain.csv",
            "--calibration",
            "cal.json",
        ],
    );
    for w in [
        "warning: plain.csv: 1 row without a reading (`measured_cm_s2` or counts empty): written without corrected values",
        "warning: plain.csv: 1 row with a reading states no noise (no `sigma_cm_s2`, no counts) and --sigma is not given",
        "warning: plain.csv: no row gives a cross-axis input (`g_pa`, `g_oa` absent or 0)",
    ] {
        assert!(err.contains(w), "`{w}` not in:\n{err}");
    }
    assert!(out.contains("\nb,,,,,,,,,\n"), "{out}");
    // --sigma gives the noise: that warning goes.
    let (_, err) = succeeds(
        d,
        &[
            "correct",
            "--data",
            "plain.csv",
            "--calibration",
            "cal.json",
            "--sigma",
            "0.01",
        ],
    );
    assert!(!err.contains("state no noise"), "{err}");
    // Tilted toward OA, which the tumble about OA never exercised.
    std::fs::write(
        d.join("oa.csv"),
        "label,kind,g_oa,measured_cm_s2,sigma_cm_s2\na,absolute,0.5,500,0.01\n",
    )
    .unwrap();
    let (_, err) = succeeds(
        d,
        &["correct", "--data", "oa.csv", "--calibration", "cal.json"],
    );
    assert!(
        err.contains("warning: --calibration cal.json: `misalignment.delta_o_rad` was not testable in the calibration's data, and it acts on 1 row here"),
        "{err}"
    );
    // The instrument file alone: its values, no uncertainty of their own.
    std::fs::write(
        d.join("i.toml"),
        ptsa_host_sim::model::instrument::KEARFOTT_2401_TOML,
    )
    .unwrap();
    let (out, err) = succeeds(
        d,
        &[
            "correct",
            "--data",
            "oa.csv",
            "--instrument",
            "i.toml",
            "--json",
        ],
    );
    assert!(
        err.contains(
            "warning: --instrument i.toml: the instrument file carries no uncertainty of its values"
        ),
        "{err}"
    );
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let r = &v["rows"][0];
    // The shipped file: bias 18.7 cm/s², nothing else on a static row at rest along PA 0.
    assert!(
        (r["a_ia_cm_s2"].as_f64().unwrap() - (500.0 - 18.7)).abs() < 0.05,
        "{r}"
    );
    assert_eq!(r["sigma_calibration_cm_s2"].as_f64().unwrap(), 0.0);
    assert_eq!(v["warnings"].as_array().unwrap().len(), 1, "{v}");
}

/// Every refusal: exit 1, one line naming the file (and line) and what was expected,
/// nothing on stdout, nothing written.
#[test]
fn refusals_name_the_file_and_what_was_expected() {
    let cal = br#"{"effects": [{"name": "bias", "coefficients": {"k0_cm_s2": 0.5}, "stderr": {"k0_cm_s2": 0.01}}]}"#;
    let ok = b"label,kind,g_pa,measured_cm_s2\na,absolute,0,500\n";
    for (files, args, needle) in [
        (
            vec![("d.csv", &ok[..])],
            vec!["correct", "--data", "d.csv"],
            "no calibration to apply; expected --calibration FILE.json",
        ),
        (
            vec![("d.csv", &ok[..]), ("c.json", b"{\"effects\": [")],
            vec!["correct", "--data", "d.csv", "--calibration", "c.json"],
            "c.json:1:13: not JSON",
        ),
        (
            vec![("d.csv", &ok[..])],
            vec!["correct", "--data", "d.csv", "--calibration", "missing.json"],
            "--calibration missing.json: cannot read",
        ),
        (
            vec![
                ("d.csv", &ok[..]),
                (
                    "c.json",
                    br#"{"effects": [{"name": "torquer_sf", "coefficients": {"current_scale_factor_ma_per_g": 0.01}}]}"#,
                ),
            ],
            vec!["correct", "--data", "d.csv", "--calibration", "c.json"],
            "--calibration c.json: the calibration changes the loop parameter(s) `torquer_sf`, which `correct` cannot apply",
        ),
        (
            vec![
                ("d.csv", &ok[..]),
                (
                    "c.json",
                    br#"{"effects": [{"name": "bias", "coefficients": {"k0_cm_s2": 0.5}, "stderr": {"k0_cm_s2": -1}}]}"#,
                ),
            ],
            vec!["correct", "--data", "d.csv", "--calibration", "c.json"],
            "the standard error of `bias.k0_cm_s2` is -1; expected a finite number of cm/s² of 0 or more",
        ),
        (
            vec![
                ("d.csv", &b"label,measured_cm_s2\n# c\na,1.0\n"[..]),
                ("c.json", &cal[..]),
            ],
            vec!["correct", "--data", "d.csv", "--calibration", "c.json"],
            "d.csv:3: row `a` is a difference row; expected absolute rows",
        ),
        (
            vec![
                ("d.csv", &b"label,kind,w_oa_rad_s,measured_cm_s2\na,absolute,1,1.0\n"[..]),
                ("c.json", &cal[..]),
            ],
            vec!["correct", "--data", "d.csv", "--calibration", "c.json"],
            "d.csv:2: row `a` has a rate, an oscillation or a centrifuge arm; expected static rows",
        ),
        (
            vec![
                ("d.csv", &b"label,kind,measured_cm_s2\na,absolute,\n"[..]),
                ("c.json", &cal[..]),
            ],
            vec!["correct", "--data", "d.csv", "--calibration", "c.json"],
            "d.csv: no row has a reading; expected `measured_cm_s2` or `pulses` and `ticks`",
        ),
        (
            vec![
                ("d.csv", &b"label,kind,measured_cm_s2\na,absolute,-100000\n"[..]),
                (
                    "c.json",
                    br#"{"effects": [{"name": "nonlinearity", "coefficients": {"k2_s2_cm": 1e-4}, "stderr": {"k2_s2_cm": 1e-6}}]}"#,
                ),
            ],
            vec!["correct", "--data", "d.csv", "--calibration", "c.json"],
            "d.csv:2: row `a`: no specific force along IA gives the reading -100000 cm/s² under the calibration",
        ),
        (
            vec![
                ("d.csv", &b"label,kind,pulses,ticks\na,absolute,11,10\n"[..]),
                ("c.json", &cal[..]),
            ],
            vec!["correct", "--data", "d.csv", "--calibration", "c.json"],
            "d.csv:2: column 3 (`pulses`) is 11, more than the gate's 10 ticks",
        ),
    ] {
        refused_in_folder(&files, &args, 1, &[needle], &[]);
    }
    // clap's own: --force without --out, a sigma of 0.
    refused_in_folder(
        &[("d.csv", ok)],
        &["correct", "--data", "d.csv", "--force"],
        2,
        &["--output"],
        &[],
    );
    refused_in_folder(
        &[("d.csv", ok)],
        &["correct", "--data", "d.csv", "--sigma", "0"],
        2,
        &["expected an uncertainty in cm/s², more than 0"],
        &[],
    );
}

/// `--help` gives the units.
#[test]
fn help_gives_units() {
    let o = ptsa_in(Path::new("."), &["correct", "--help"]);
    let h = stdout(&o);
    for u in ["cm/s²", "in g", "SF·(2P/T − 1)", "1-sigma"] {
        assert!(h.contains(u), "`{u}` not in:\n{h}");
    }
}

/// Labels are quoted as the case-frame writer quotes them: a comma, a quote or a leading `#`
/// (which a reader would take for a comment).
#[test]
fn labels_are_quoted_in_the_csv() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    std::fs::write(
        d.join("d.csv"),
        "label,kind,g_pa,measured_cm_s2,sigma_cm_s2\n\"#1, \"\"up\"\"\",absolute,0.5,500,0.01\n",
    )
    .unwrap();
    std::fs::write(
        d.join("i.toml"),
        ptsa_host_sim::model::instrument::KEARFOTT_2401_TOML,
    )
    .unwrap();
    let (out, _) = succeeds(d, &["correct", "--data", "d.csv", "--instrument", "i.toml"]);
    assert!(out.contains("\n\"#1, \"\"up\"\"\",500,0.01,"), "{out}");
}
