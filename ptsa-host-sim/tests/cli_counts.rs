//! Counts in: a lab's pulses and ticks per position (`pulses`, `ticks`), from `ptsa plan
//! --counts` to `ptsa discover`, and every refusal of a count cell with its file, line and
//! column.
//!
//! The counts are made here from the IEEE 1293 model equation with known absolute
//! coefficients (not from the project's own model): P = round(T·(1 + a/SF)/2 + c₁ − c₀),
//! with the carries c₀, c₁ drawn uniform over one pulse (the rounding adds 1/12 pulse² to
//! the model's 1/6).

#![allow(
    clippy::float_cmp,
    reason = "the converted values are compared bit for bit"
)]

use std::path::Path;

use rand::SeedableRng as _;
use rand_distr::Distribution as _;

mod common;
use common::{ptsa_in, refused_in_folder, stderr, stdout};

/// The shipped instrument file's gravity and nominal scale factor, cm/s².
const G: f64 = 980.4;
const SF: f64 = 21_121.1;
/// A 60 s gate at 64 kHz, ticks.
const T: u64 = 3_840_000;

/// The true instrument: its absolute bias (cm/s²), scale-factor error (ppm) and the tilt
/// of IA toward PA (rad, the coefficient of `a_PA`).
const BIAS: f64 = 19.19;
const K1_PPM: f64 = -146.8;
const DELTA_P: f64 = -1.19e-4;

/// The reading the true instrument gives, cm/s².
fn reading(a_ia: f64, a_pa: f64) -> f64 {
    BIAS + (1.0 + K1_PPM * 1e-6) * a_ia + DELTA_P * a_pa
}

/// Run `ptsa args` in `dir`; it must succeed. Returns (stdout, stderr).
fn succeeds(dir: &Path, args: &[&str]) -> (String, String) {
    let o = ptsa_in(dir, args);
    let err = stderr(&o);
    assert!(o.status.success(), "ptsa {args:?}: {err}");
    common::assert_clean_of(&err, &[]);
    (stdout(&o), err)
}

/// The plan's lines with `pulses` and `ticks` filled in from [`reading`] (carries of seed
/// `seed`), and the pulses written.
fn fill(plan: &str, seed: u64) -> (String, Vec<u64>) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let carry = rand_distr::Uniform::new(-0.5, 0.5).unwrap();
    let mut header: Vec<String> = Vec::new();
    let mut out = String::new();
    let mut pulses = Vec::new();
    for line in plan.lines() {
        if line.starts_with('#') {
            out.push_str(line);
            out.push('\n');
            continue;
        }
        if header.is_empty() {
            header = line.split(',').map(str::to_string).collect();
            out.push_str(line);
            out.push('\n');
            continue;
        }
        // The label is quoted and holds a comma: split it off first.
        let (label, rest) = line.split_at(line[1..].find('"').unwrap() + 2);
        let mut cells: Vec<String> = std::iter::once(label.to_string())
            .chain(rest[1..].split(',').map(str::to_string))
            .collect();
        let at = |n: &str| header.iter().position(|h| h == n).unwrap();
        let num = |c: &str| {
            if c.is_empty() {
                0.0
            } else {
                c.parse::<f64>().unwrap()
            }
        };
        let y = reading(num(&cells[at("g_ia")]) * G, num(&cells[at("g_pa")]) * G);
        #[allow(clippy::cast_precision_loss)]
        let tf = T as f64;
        let p =
            (tf * (1.0 + y / SF) / 2.0 + carry.sample(&mut rng) - carry.sample(&mut rng)).round();
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        pulses.push(p as u64);
        cells[at("pulses")] = format!("{p}");
        cells[at("ticks")] = T.to_string();
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    (out, pulses)
}

/// `plan tumble --counts` writes `pulses` and `ticks` to fill in, not `measured_cm_s2`;
/// filled from the equations, `discover --analytic` reads each row as SF·(2P/T − 1) with the
/// file's nominal SF (the JSON's table shows that value), weighs it with at least its
/// counting error, and recovers the true bias, scale factor and misalignment within 3 σ.
#[test]
fn a_counted_tumble_is_calibrated() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    succeeds(
        d,
        &[
            "plan",
            "tumble",
            "--positions",
            "24",
            "--count-columns",
            "--output",
            "plan.csv",
        ],
    );
    let plan = std::fs::read_to_string(d.join("plan.csv")).unwrap();
    let header = plan.lines().find(|l| !l.starts_with('#')).unwrap();
    assert_eq!(header, "label,kind,g_ia,g_pa,pulses,ticks,approach,temp_c");
    assert!(plan.contains("# Fill in pulses and ticks"), "{plan}");
    let (filled, pulses) = fill(&plan, 7);
    std::fs::write(d.join("counts.csv"), &filled).unwrap();
    let (out, _) = succeeds(
        d,
        &["discover", "--data", "counts.csv", "--analytic", "--json"],
    );
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    #[allow(clippy::cast_precision_loss)]
    let (p0, tf) = (pulses[0] as f64, T as f64);
    let first = &v["table"][0];
    assert_eq!(
        first["measured_cm_s2"].as_f64().unwrap(),
        SF * (2.0 * p0 / tf - 1.0),
        "{first}"
    );
    let counting = 2.0 * SF / tf * (1.0f64 / 6.0).sqrt();
    for row in v["table"].as_array().unwrap() {
        assert!(
            row["sigma_cm_s2"].as_f64().unwrap() >= counting * 0.999,
            "{row}"
        );
    }
    let coef = |effect: &str, key: &str| {
        let e = v["effects"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["name"] == effect)
            .unwrap_or_else(|| panic!("{effect} not selected: {}", v["effects"]));
        (
            e["coefficients"][key].as_f64().unwrap(),
            e["stderr"][key].as_f64().unwrap(),
        )
    };
    // The shipped file's bias is 18.7 cm/s² and its scale factor nominal: the changes.
    for ((c, s), truth) in [
        (coef("bias", "k0_cm_s2"), BIAS - 18.7),
        (coef("scale_factor", "k1_ppm"), K1_PPM),
        (coef("misalignment", "delta_p_rad"), DELTA_P),
    ] {
        assert!(
            (c - truth).abs() < 3.0 * s && s < 0.1 * truth.abs(),
            "{c} ± {s} against {truth}"
        );
    }
    // The text reports show the converted value too (to the digits they give a measured
    // value): discover's table and predict's.
    let shown = format!("{:.3}", SF * (2.0 * p0 / tf - 1.0));
    for cmd in ["discover", "predict"] {
        let (text, _) = succeeds(d, &[cmd, "--data", "counts.csv", "--analytic"]);
        let line = text
            .lines()
            .find(|l| l.starts_with("tumble 0 deg"))
            .unwrap();
        assert!(
            line.contains(&format!(" {shown} ")),
            "{cmd}: {shown} not in:\n{text}"
        );
    }
}

/// `plan centrifuge --counts` writes the count columns; a design of difference rows has no
/// `--counts` (clap refuses it, status 2).
#[test]
fn plans_with_count_columns() {
    let tmp = tempfile::tempdir().unwrap();
    let (out, _) = succeeds(
        tmp.path(),
        &[
            "plan",
            "centrifuge",
            "--radius-cm",
            "50",
            "--g-levels",
            "2",
            "--count-columns",
        ],
    );
    let header = out.lines().find(|l| !l.starts_with('#')).unwrap();
    assert_eq!(
        header,
        "label,kind,g_oa,w_oa_rad_s,radius_cm,pulses,ticks,approach,temp_c"
    );
    for kind in ["rate-table", "shaker"] {
        refused_in_folder(
            &[],
            &["plan", kind, "--count-columns"],
            2,
            &["unexpected argument '--count-columns'"],
            &[],
        );
    }
}

/// An existing file is not replaced by a plan with counts without --force: its bytes are
/// unchanged.
#[test]
fn a_counts_plan_never_replaces_a_file_without_force() {
    let data = b"label,kind,g_ia,pulses,ticks\nup,absolute,1,2009123,3840000\n";
    let m = refused_in_folder(
        &[("day.csv", data)],
        &[
            "plan",
            "tumble",
            "--count-columns",
            "--output",
            "{dir}/day.csv",
        ],
        1,
        &["day.csv: the file exists and is not replaced without --force"],
        &[],
    );
    assert!(m.starts_with("error: --out"), "{m}");
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("day.csv"), data).unwrap();
    let o = ptsa_in(
        tmp.path(),
        &[
            "plan",
            "tumble",
            "--count-columns",
            "--output",
            "day.csv",
            "--force",
        ],
    );
    assert!(o.status.success());
    assert!(
        stderr(&o).contains("warning: --output day.csv: replaced a case-frame file of 1 row, 1 of them measured (--force)"),
        "{}",
        stderr(&o)
    );
}

/// Every refusal of a count cell names the file, the line, the column and what was
/// expected, and nothing is written; `predict` refuses the same file the same way.
#[test]
fn bad_count_cells_are_refused_with_file_line_and_column() {
    for (text, needle) in [
        (
            "label,kind,g_ia,measured_cm_s2,pulses,ticks\nup,absolute,1,980,2009123,3840000\n",
            "data.csv:2: column 4 (`measured_cm_s2`) and column 5 (`pulses`) both give the row's measurement; expected one of `measured_cm_s2`, `pulses` with `ticks`, `reading` with `reading_unit` in a row",
        ),
        (
            "label,kind,g_ia,pulses,ticks\nup,absolute,1,2009123,\n",
            "data.csv:2: column 4 (`pulses`) is given but `ticks` is empty; expected both counts of the gate",
        ),
        (
            "label,kind,g_ia,pulses,ticks\nup,absolute,1,3840001,3840000\n",
            "data.csv:2: column 4 (`pulses`) is 3840001, more than the gate's 3840000 ticks (column 5); expected 0 ≤ pulses ≤ ticks",
        ),
        (
            "label,kind,g_ia,pulses,ticks\nup,absolute,1,0,0\n",
            "data.csv:2: column 5 (`ticks`) is 0 (with 0 pulses); expected a gate of at least one clock tick",
        ),
        (
            "label,kind,g_ia,pulses,ticks\n# c\nup,absolute,1,2009123.5,3840000\n",
            "data.csv:3: column 4 (`pulses`) holds `2009123.5`; expected a whole number of pulses of positive torque",
        ),
        (
            "label,g_ia,pulses,ticks\nup,1,2009123,3840000\n",
            "data.csv:2: column 3 (`pulses`) in a difference row; expected counts only in an absolute row",
        ),
    ] {
        for cmd in ["discover", "predict"] {
            let m = refused_in_folder(
                &[("data.csv", text.as_bytes())],
                &[cmd, "--data", "data.csv", "--analytic"],
                1,
                &[needle],
                &[],
            );
            assert!(m.starts_with("error: data.csv:"), "{m}");
        }
    }
}

/// What `stdout` holds is not used by a refusal; a counts file whose rows hold no counts
/// yet (the plan as written) is not measured: discover says so.
#[test]
fn an_unfilled_counts_plan_has_nothing_to_fit() {
    let tmp = tempfile::tempdir().unwrap();
    let (plan, _) = succeeds(
        tmp.path(),
        &["plan", "tumble", "--positions", "4", "--count-columns"],
    );
    refused_in_folder(
        &[("plan.csv", plan.as_bytes())],
        &["discover", "--data", "plan.csv", "--analytic"],
        1,
        &["no row has a measurement"],
        &[],
    );
    let o = ptsa_in(tmp.path(), &["plan", "tumble", "--positions", "4"]);
    assert!(!stdout(&o).contains("pulses"));
}

/// The counting error the case frame adds to a counted row (`model::counts`) is the
/// simulated loop's: static gates of 6400 ticks (100 limit cycles) at 48 inputs and
/// settling times scatter about the input by `(2·SF/T)·√(1/6)` (each end of a gate off by
/// a carry uniform over one pulse), to within a quarter.
#[test]
fn the_counting_error_is_the_simulated_loops() {
    use ptsa_host_sim::model::counts::counting_sigma_cm_s2;
    use ptsa_host_sim::simulation::sim::SimOptions;
    let instr = ptsa_host_sim::Instrument::kearfott_2401();
    let ticks = 6400;
    let accels: Vec<f64> = (0..8).map(|k| -900.0 + 251.3 * f64::from(k)).collect();
    let mut errs = Vec::new();
    for k in 0..6 {
        let opts = SimOptions {
            warmup_s: 0.1 + 0.000_731 * f64::from(k),
            ..SimOptions::default()
        };
        let runs = ptsa_host_sim::simulation::batch::run_static(&instr, &accels, ticks, &opts);
        errs.extend(runs.iter().zip(&accels).map(|(r, a)| r.indicated_cm_s2 - a));
    }
    #[allow(clippy::cast_precision_loss)]
    let n = errs.len() as f64;
    let mean = errs.iter().sum::<f64>() / n;
    let sd = (errs.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    #[allow(clippy::cast_precision_loss)]
    let model = counting_sigma_cm_s2(ticks as f64, instr.sf_cm_s2);
    assert!(
        (sd / model - 1.0).abs() < 0.25,
        "{sd} against {model} ({n} gates)"
    );
}

/// A stated sigma is the reading's other noise: the counting error is added to it in
/// quadrature (discover's table gives each row the sum).
#[test]
fn the_counting_error_adds_to_a_stated_sigma() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let (plan, _) = succeeds(
        d,
        &["plan", "tumble", "--positions", "8", "--count-columns"],
    );
    let (filled, _) = fill(&plan, 3);
    // Every row states 0.01 cm/s², in a column added at the end.
    let text: String = filled
        .lines()
        .map(|l| {
            if l.starts_with('#') {
                format!("{l}\n")
            } else if l.starts_with("label") {
                format!("{l},sigma_cm_s2\n")
            } else {
                format!("{l},0.01\n")
            }
        })
        .collect();
    std::fs::write(d.join("counts.csv"), text).unwrap();
    let (out, _) = succeeds(
        d,
        &["discover", "--data", "counts.csv", "--analytic", "--json"],
    );
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    #[allow(clippy::cast_precision_loss)]
    let want = 0.01f64.hypot(2.0 * SF / T as f64 * (1.0f64 / 6.0).sqrt());
    for row in v["table"].as_array().unwrap() {
        let s = row["sigma_cm_s2"].as_f64().unwrap();
        assert!((s - want).abs() < 1e-12, "{row}: {s} against {want}");
    }
}
