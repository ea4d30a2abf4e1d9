//! `ptsa discover --data` on a triad file: the calibration printed and in `--json`'s
//! `"triad"`, `--orientation`, the per-position table, and every refusal with its exit
//! status and message.

use std::fmt::Write as _;
use std::path::Path;

use rand::SeedableRng as _;
use rand_distr::Distribution as _;

mod common;
use common::{json_in, numbers, ptsa_in, refused_in_folder, stderr, stdout};

/// The triad generator written from the equations (shared with the triad campaign and
/// the benchmark; it uses nothing of `ptsa_host_sim`).
#[path = "../../ptsa-campaigns/src/triad_gen.rs"]
mod triad_gen;
use triad_gen::{G, TriadTruth};

/// The 24 directions `(±1, ±2, ±3)/√14` under the cube's proper rotations.
fn design24() -> Vec<[f64; 3]> {
    triad_gen::cube_turns([1.0, 2.0, 3.0])
}

/// The triad of the files: bias, scale-factor change, Γ (rad).
const BIAS: [f64; 3] = [12.0, -8.0, 30.0];
const SF: [f64; 3] = [0.01, -0.005, 0.002];
const GAMMA: [[f64; 3]; 3] = [[0.0, 0.0, 0.0], [0.004, 0.0, 0.0], [-0.002, 0.003, 0.0]];
/// The same as the generator's truth (no `K_2`).
const TRUTH: TriadTruth = TriadTruth {
    b: BIAS,
    k: SF,
    gamma: GAMMA,
    q: [0.0; 3],
};

/// A triad file of the 24 positions, each turned by `tilt_rad` about a fixed axis
/// perpendicular to its gravity (0: a precision fixture), noise 0.1 cm/s² stated.
fn triad_csv(tilt_rad: f64, seed: u64) -> String {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let noise = rand_distr::Normal::new(0.0, 0.1).unwrap();
    let mut s = String::from(
        "# a triad\nlabel,g_x,g_y,g_z,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2,sigma_cm_s2\n",
    );
    for (i, n) in design24().iter().enumerate() {
        // Turn n toward a perpendicular direction by tilt (alternating in sign).
        let e = if n[0].abs() < 0.5 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let d = e[0] * n[0] + e[1] * n[1] + e[2] * n[2];
        let mut p = [0, 1, 2].map(|k| e[k] - d * n[k]);
        let pn = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        p = p.map(|x| x / pn);
        let t = if i % 2 == 0 { tilt_rad } else { -tilt_rad };
        let f = [0, 1, 2].map(|k| G * (n[k] * t.cos() + p[k] * t.sin()));
        let u: Vec<String> = TRUTH
            .readings(f)
            .iter()
            .map(|u| format!("{:.5}", u + noise.sample(&mut rng)))
            .collect();
        let _ = writeln!(
            s,
            "p{},{:.9},{:.9},{:.9},{},0.1",
            i + 1,
            n[0],
            n[1],
            n[2],
            u.join(",")
        );
    }
    s
}

#[test]
fn a_triad_file_is_calibrated_and_its_json_holds_the_truth() {
    let tmp = tempfile::tempdir().unwrap();
    let text = triad_csv(0.0, 1);
    std::fs::write(tmp.path().join("t.csv"), &text).unwrap();
    let j = json_in(tmp.path(), &["discover", "--data", "t.csv", "--json"]);
    // The input is untouched; the per-position table is written.
    assert_eq!(
        std::fs::read_to_string(tmp.path().join("t.csv")).unwrap(),
        text
    );
    let table = std::fs::read_to_string(tmp.path().join("out/discover/t-triad.csv")).unwrap();
    assert_eq!(table.lines().count(), 25);
    let t = &j["triad"];
    assert_eq!(t["orientation"], "exact");
    let (b, bs) = (numbers(&t["bias_cm_s2"]), numbers(&t["bias_sigma_cm_s2"]));
    let (k, ks) = (
        numbers(&t["scale_factor_ppm"]),
        numbers(&t["scale_factor_sigma_ppm"]),
    );
    for a in 0..3 {
        assert!((b[a] - BIAS[a]).abs() < 4.0 * bs[a], "bias {b:?} ± {bs:?}");
        assert!(
            (k[a] - SF[a] * 1e6).abs() < 4.0 * ks[a],
            "sf {k:?} ± {ks:?}"
        );
        for c in 0..3 {
            let m = t["misalignment_rad"][a][c].as_f64().unwrap();
            match t["misalignment_sigma_rad"][a][c].as_f64() {
                Some(s) => assert!((m - GAMMA[a][c]).abs() < 4.0 * s, "Γ{a}{c} {m} ± {s}"),
                None => assert_eq!(a, c),
            }
        }
    }
    assert_eq!(t["g_check"]["consistent"], true);
    assert_eq!(t["g_check"]["positions"], 24);
    assert!(t["p_value"].as_f64().unwrap() > 0.001);
    assert_eq!(t["correction_matrix"].as_array().unwrap().len(), 3);
    assert!(
        t["warnings"].as_array().unwrap().is_empty(),
        "{}",
        t["warnings"]
    );
}

#[test]
fn a_hand_placed_triad_is_flagged_exact_and_fits_approximate() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("h.csv"), triad_csv(0.012, 2)).unwrap();
    // Exact orientations assumed: the χ² and the |g| check flag it, with a warning.
    let o = ptsa_in(tmp.path(), &["discover", "--data", "h.csv", "--no-plots"]);
    assert_eq!(o.status.code(), Some(0));
    let err = stderr(&o);
    assert!(
        err.contains("warning: the fit's χ²") && err.contains("--orientation approximate"),
        "{err}"
    );
    assert!(err.contains("warning: the |g| check fails"), "{err}");
    assert!(stdout(&o).contains("NOT consistent"));
    // Approximate: the misalignments above the diagonal are the convention's zeros, the
    // rest recovered, the g check consistent, the tilts estimated.
    let j = json_in(
        tmp.path(),
        &[
            "discover",
            "--data",
            "h.csv",
            "--orientation",
            "approximate",
            "--json",
            "--no-plots",
        ],
    );
    let t = &j["triad"];
    assert_eq!(t["orientation"], "approximate");
    assert_eq!(t["g_check"]["consistent"], true);
    assert!(
        t["misalignment_sigma_rad"][0][1].is_null() && t["misalignment_sigma_rad"][1][2].is_null()
    );
    let m = t["misalignment_rad"][1][0].as_f64().unwrap();
    let s = t["misalignment_sigma_rad"][1][0].as_f64().unwrap();
    // The triad's frame here is the block's within 1e-5 rad (Γ_xy = Γ_xz = Γ_yz = 0).
    assert!((m - 0.004).abs() < 4.0 * s + 1e-5, "{m} ± {s}");
    let rot = t["rows"][0]["rotation_urad"].as_f64().unwrap();
    assert!((rot - 12_000.0).abs() < 500.0, "{rot}");
    // Turned 3° from nominal: beyond the small angles, warned.
    std::fs::write(tmp.path().join("w.csv"), triad_csv(0.052, 4)).unwrap();
    let o = ptsa_in(
        tmp.path(),
        &[
            "discover",
            "--data",
            "w.csv",
            "--orientation",
            "approximate",
            "--no-plots",
        ],
    );
    assert_eq!(o.status.code(), Some(0));
    assert!(
        stderr(&o).contains("from its nominal orientation, beyond the small angles"),
        "{}",
        stderr(&o)
    );
}

/// The eight corners alone (every `a_j² = g²/3`): `K_2` cannot be told from the bias; it
/// is left out, with a warning and the JSON's note, and the rest is fitted.
#[test]
fn eight_corners_leave_k2_out_with_a_warning() {
    let tmp = tempfile::tempdir().unwrap();
    let mut s = String::from("g_x,g_y,g_z,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2\n");
    let c = 1.0 / 3f64.sqrt();
    for i in 0..8u8 {
        let n = [0, 1, 2].map(|b| if i >> b & 1 == 1 { -c } else { c });
        let u: Vec<String> = (0..3)
            .map(|j| {
                format!(
                    "{}",
                    BIAS[j] + (1.0 + SF[j]) * G * n[j] + 0.01 * f64::from(i % 3)
                )
            })
            .collect();
        let _ = writeln!(s, "{},{},{},{}", n[0], n[1], n[2], u.join(","));
    }
    std::fs::write(tmp.path().join("c.csv"), s).unwrap();
    let o = ptsa_in(
        tmp.path(),
        &["discover", "--data", "c.csv", "--json", "--no-plots"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("warning: K_2 not fitted"),
        "{}",
        stderr(&o)
    );
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert!(j["triad"]["k2_ug_per_g2"].is_null());
    assert!(j["triad"]["k2_note"].as_str().unwrap().contains("bias"));
}

/// The triad's refusals of flags: each names the flag and what was expected.
#[test]
fn triad_flag_refusals() {
    let good = triad_csv(0.0, 3);
    let t: &[(&str, &[u8])] = &[("t.csv", good.as_bytes())];
    refused_in_folder(
        t,
        &[
            "discover",
            "--data",
            "t.csv",
            "--candidates",
            "bias",
            "--no-plots",
        ],
        1,
        &[
            "--candidates applies to a single-axis",
            "t.csv is a triad file",
        ],
        &[],
    );
    refused_in_folder(
        t,
        &[
            "discover",
            "--data",
            "t.csv",
            "--advice-out",
            "a.csv",
            "--no-plots",
        ],
        1,
        &["--advice-out applies to a single-axis"],
        &[],
    );
    refused_in_folder(
        t,
        &["discover", "--data", "t.csv", "--orientation", "sideways"],
        2,
        &["sideways", "exact", "approximate"],
        &[],
    );
    refused_in_folder(
        &[],
        &["plan", "triad", "--positions", "7"],
        2,
        &[
            "'7'",
            "expected one of the triad designs' position counts: 6, 8, 12, 24, 37",
        ],
        &[],
    );
    let single = "label,g_ia,measured_cm_s2\na,1,980\nb,-1,-980\n";
    refused_in_folder(
        &[("s.csv", single.as_bytes())],
        &[
            "discover",
            "--data",
            "s.csv",
            "--orientation",
            "exact",
            "--no-plots",
        ],
        1,
        &[
            "--orientation applies to a triad file",
            "s.csv is a single-axis",
        ],
        &[],
    );
}

/// The triad file's refusals: each names the file's place and what was expected.
#[test]
fn triad_file_refusals() {
    let good = triad_csv(0.0, 3);
    let mixed = good.replacen("sigma_cm_s2", "measured_cm_s2", 1);
    refused_in_folder(
        &[("m.csv", mixed.as_bytes())],
        &["discover", "--data", "m.csv", "--no-plots"],
        1,
        &[
            "m.csv:2:",
            "single-axis case-frame column",
            "`g_x`",
            "one kind of file",
        ],
        &[],
    );
    let bad = good.replacen(",0.1\n", ",-0.1\n", 1);
    refused_in_folder(
        &[("b.csv", bad.as_bytes())],
        &["discover", "--data", "b.csv", "--no-plots"],
        1,
        &[
            "b.csv:3: column 8 (`sigma_cm_s2`) holds `-0.1`",
            "greater than 0",
        ],
        &[],
    );
    let planar = "g_x,g_y,g_z,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2\n\
                  1,0,0,980,0,0\n-1,0,0,-980,0,0\n0,1,0,0,980,0\n0,-1,0,0,-980,0\n\
                  0.7071068,0.7071068,0,693,693,0\n-0.7071068,0.7071068,0,-693,693,0\n\
                  0.7071068,-0.7071068,0,693,-693,0\n-0.7071068,-0.7071068,0,-693,-693,0\n";
    refused_in_folder(
        &[("p.csv", planar.as_bytes())],
        &["discover", "--data", "p.csv", "--no-plots"],
        1,
        &["p.csv: the 8 positions do not determine", "one plane"],
        &[],
    );
    let few = good.lines().take(8).collect::<Vec<_>>().join("\n") + "\n";
    refused_in_folder(
        &[("f.csv", few.as_bytes())],
        &[
            "discover",
            "--data",
            "f.csv",
            "--orientation",
            "approximate",
            "--no-plots",
        ],
        1,
        &[
            "f.csv: 6 positions give 18 readings for 21 unknowns",
            "more positions",
        ],
        &[],
    );
}

/// `ptsa plan triad` → the lab fills the readings in → `discover` calibrates: the truth
/// comes back within 4 σ; the plan as written (nothing measured) is refused.
#[test]
fn plan_filled_in_and_calibrated() {
    let tmp = tempfile::tempdir().unwrap();
    let o = ptsa_in(
        tmp.path(),
        &["plan", "triad", "--positions", "24", "--output", "p.csv"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("wrote p.csv (24 rows)"),
        "{}",
        stderr(&o)
    );
    let plan = std::fs::read_to_string(tmp.path().join("p.csv")).unwrap();
    let o = ptsa_in(tmp.path(), &["discover", "--data", "p.csv", "--no-plots"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("p.csv: no row has a measurement"),
        "{}",
        stderr(&o)
    );
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let noise = rand_distr::Normal::new(0.0, 0.05).unwrap();
    let mut filled = String::new();
    for line in plan.lines() {
        let cells: Vec<&str> = line.split(',').collect();
        let Ok(n) = cells
            .get(1..4)
            .unwrap_or_default()
            .iter()
            .map(|c| c.parse::<f64>())
            .collect::<Result<Vec<f64>, _>>()
        else {
            let _ = writeln!(filled, "{line}");
            continue;
        };
        if n.len() != 3 {
            let _ = writeln!(filled, "{line}");
            continue;
        }
        let u: Vec<String> = TRUTH
            .readings([n[0] * G, n[1] * G, n[2] * G])
            .iter()
            .map(|u| format!("{}", u + noise.sample(&mut rng)))
            .collect();
        let _ = writeln!(
            filled,
            "{},{},{},{},{},0.05",
            cells[0],
            cells[1],
            cells[2],
            cells[3],
            u.join(",")
        );
    }
    std::fs::write(tmp.path().join("p.csv"), filled).unwrap();
    let j = json_in(
        tmp.path(),
        &["discover", "--data", "p.csv", "--json", "--no-plots"],
    );
    let t = &j["triad"];
    let (b, bs) = (numbers(&t["bias_cm_s2"]), numbers(&t["bias_sigma_cm_s2"]));
    let (k, ks) = (
        numbers(&t["scale_factor_ppm"]),
        numbers(&t["scale_factor_sigma_ppm"]),
    );
    for a in 0..3 {
        assert!((b[a] - BIAS[a]).abs() < 4.0 * bs[a], "bias {b:?} ± {bs:?}");
        assert!(
            (k[a] - SF[a] * 1e6).abs() < 4.0 * ks[a],
            "sf {k:?} ± {ks:?}"
        );
    }
    assert_eq!(t["positions"], 24);
    assert_eq!(t["g_check"]["consistent"], true);
}

/// The shipped instrument file's nominal scale factor, cm/s² (what counts are read through).
fn nominal_sf() -> f64 {
    ptsa_host_sim::Instrument::kearfott_2401().sf_cm_s2
}

/// The pulses a gate of `ticks` counts at an indicated acceleration `a` (cm/s²), written
/// from the equations, not the project's conversion: the loop's mean duty `d` of positive
/// pulses is `(1 + a/SF)/2`, and with the charge it holds at the gate's start uniform over
/// one pulse (`c₀`) it counts `P = ⌊T·d + c₀⌋` = `T·d + c₀ − c₁`, `c₁` what it holds at
/// the end: whole, unbiased, and scattered by `√(1/6)` pulse on average over `T·d`.
fn counted(a: f64, ticks: f64, rng: &mut rand_chacha::ChaCha8Rng) -> f64 {
    let c0: f64 = rand_distr::Uniform::new(0.0, 1.0).unwrap().sample(rng);
    (ticks * (1.0 + a / nominal_sf()) / 2.0 + c0).floor()
}

/// `ptsa plan triad --counts` → the lab counts every axis over 10 s gates → `discover`
/// calibrates: the truth within 4 σ, and the χ² against the stated sigma (0.02 cm/s²)
/// consistent only because each reading's counting error (0.027 cm/s² on a 10 s gate at
/// 64 kHz) is added to it in quadrature; the plan as written is refused, the file is
/// untouched.
#[test]
fn a_counted_triad_is_calibrated_within_its_intervals() {
    let tmp = tempfile::tempdir().unwrap();
    let o = ptsa_in(
        tmp.path(),
        &[
            "plan",
            "triad",
            "--positions",
            "24",
            "--count-columns",
            "--output",
            "p.csv",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let plan = std::fs::read_to_string(tmp.path().join("p.csv")).unwrap();
    let header = plan.lines().find(|l| !l.starts_with('#')).unwrap();
    assert_eq!(
        header,
        "label,g_x,g_y,g_z,pulses_x,ticks_x,pulses_y,ticks_y,pulses_z,ticks_z,sigma_cm_s2"
    );
    assert!(plan.contains("pulses_x, ticks_x"), "{plan}");
    let o = ptsa_in(tmp.path(), &["discover", "--data", "p.csv", "--no-plots"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("p.csv: no row has a measurement"),
        "{}",
        stderr(&o)
    );
    let ticks = 640_000.0;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let noise = rand_distr::Normal::new(0.0, 0.02).unwrap();
    let mut filled = String::new();
    for line in plan.lines() {
        let cells: Vec<&str> = line.split(',').collect();
        let n: Vec<f64> = cells
            .get(1..4)
            .unwrap_or_default()
            .iter()
            .filter_map(|c| c.parse::<f64>().ok())
            .collect();
        if line.starts_with('#') || n.len() != 3 {
            let _ = writeln!(filled, "{line}");
            continue;
        }
        let counts: Vec<String> = TRUTH
            .readings([n[0] * G, n[1] * G, n[2] * G])
            .iter()
            .map(|u| {
                let u = u + noise.sample(&mut rng);
                format!("{},{ticks}", counted(u, ticks, &mut rng))
            })
            .collect();
        let _ = writeln!(
            filled,
            "{},{},{},{},{},0.02",
            cells[0],
            cells[1],
            cells[2],
            cells[3],
            counts.join(",")
        );
    }
    std::fs::write(tmp.path().join("p.csv"), &filled).unwrap();
    let j = json_in(
        tmp.path(),
        &["discover", "--data", "p.csv", "--json", "--no-plots"],
    );
    assert_eq!(
        std::fs::read_to_string(tmp.path().join("p.csv")).unwrap(),
        filled
    );
    let t = &j["triad"];
    let (b, bs) = (numbers(&t["bias_cm_s2"]), numbers(&t["bias_sigma_cm_s2"]));
    let (k, ks) = (
        numbers(&t["scale_factor_ppm"]),
        numbers(&t["scale_factor_sigma_ppm"]),
    );
    for a in 0..3 {
        assert!((b[a] - BIAS[a]).abs() < 4.0 * bs[a], "bias {b:?} ± {bs:?}");
        assert!(
            (k[a] - SF[a] * 1e6).abs() < 4.0 * ks[a],
            "sf {k:?} ± {ks:?}"
        );
        for c in 0..3 {
            let m = t["misalignment_rad"][a][c].as_f64().unwrap();
            if let Some(s) = t["misalignment_sigma_rad"][a][c].as_f64() {
                assert!((m - GAMMA[a][c]).abs() < 4.0 * s, "Γ{a}{c} {m} ± {s}");
            }
        }
    }
    assert_eq!(t["readings"], 72);
    // The stated 0.02 alone would give χ²/dof ≈ 2.8 (p ≈ 1e-11): the counting error is in.
    let p = t["p_value"].as_f64().unwrap();
    assert!(p > 0.001, "p {p}, χ² {}", t["chi2"]);
    assert_eq!(t["g_check"]["consistent"], true);
}

/// Every refusal of a triad's counts, with the single-axis rules' words: an axis given as
/// its reading and its counts, one count without the other, a gate of 0 ticks, more pulses
/// than ticks, a count that is not whole, a header without an axis.
#[test]
fn triad_count_refusals() {
    let head =
        "label,g_x,g_y,g_z,measured_x_cm_s2,pulses_x,ticks_x,pulses_y,ticks_y,pulses_z,ticks_z\n";
    let ok = "a,1,0,0,,1000,2000,500,1000,10,20\n";
    let run = |name: &str, row: &str, needles: &[&str]| {
        let text = format!("{head}{ok}{row}");
        refused_in_folder(
            &[(name, text.as_bytes())],
            &["discover", "--data", name, "--no-plots"],
            1,
            needles,
            &[],
        );
    };
    run(
        "both.csv",
        "b,-1,0,0,-980,500,1000,500,1000,10,20\n",
        &[
            "both.csv:3: column 5 (`measured_x_cm_s2`) and column 6 (`pulses_x`) both give the x axis's measurement; expected one of `measured_x_cm_s2`, `pulses_x` with `ticks_x` in a row, the others empty",
        ],
    );
    run(
        "half.csv",
        "b,-1,0,0,,500,1000,500,,10,20\n",
        &[
            "half.csv:3: column 8 (`pulses_y`) is given but `ticks_y` is empty; expected both counts of the gate: the pulses P and the clock ticks T",
        ],
    );
    run(
        "zero.csv",
        "b,-1,0,0,,500,1000,500,1000,0,0\n",
        &[
            "zero.csv:3: column 11 (`ticks_z`) is 0 (with 0 pulses); expected a gate of at least one clock tick",
        ],
    );
    run(
        "more.csv",
        "b,-1,0,0,,1001,1000,500,1000,10,20\n",
        &[
            "more.csv:3: column 6 (`pulses_x`) is 1001, more than the gate's 1000 ticks (column 7); expected 0 ≤ pulses ≤ ticks",
        ],
    );
    run(
        "whole.csv",
        "b,-1,0,0,,500.5,1000,500,1000,10,20\n",
        &[
            "whole.csv:3: column 6 (`pulses_x`) holds `500.5`; expected a whole number of pulses of positive torque counted over the row's gate (0 to `ticks`)",
        ],
    );
    let no_ticks = "g_x,g_y,g_z,pulses_x,measured_y_cm_s2,measured_z_cm_s2\n1,0,0,1000,0,0\n";
    refused_in_folder(
        &[("nt.csv", no_ticks.as_bytes())],
        &["discover", "--data", "nt.csv", "--no-plots"],
        1,
        &["nt.csv:2: column 4 (`pulses_x`) is given but `ticks_x` is not a column"],
        &[],
    );
    let no_axis = "g_x,g_y,g_z,pulses_x,ticks_x,measured_y_cm_s2\n1,0,0,1000,2000,0\n";
    refused_in_folder(
        &[("na.csv", no_axis.as_bytes())],
        &["discover", "--data", "na.csv", "--no-plots"],
        1,
        &[
            "na.csv:1: the triad header has no `measured_z_cm_s2`",
            "pulses_x with ticks_x",
        ],
        &[],
    );
}

/// `plan triad --help` gives `--count-columns` with its units.
#[test]
fn plan_triad_counts_help_gives_units() {
    let tmp = tempfile::tempdir().unwrap();
    let o = ptsa_in(tmp.path(), &["plan", "triad", "--help"]);
    assert_eq!(o.status.code(), Some(0));
    let h = stdout(&o);
    for w in [
        "--count-columns",
        "pulses_x",
        "clock ticks",
        "cm/s²",
        "nominal SF",
    ] {
        assert!(h.contains(w), "`{w}` not in: {h}");
    }
}

/// `ptsa args` in `dir` with `SOURCE_DATE_EPOCH` set.
fn ptsa_dated(dir: &Path, args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_ptsa"))
        .current_dir(dir)
        .args(args)
        .env("SOURCE_DATE_EPOCH", "1790000000")
        .output()
        .unwrap()
}

/// A record to correct: the 12 edge directions, readings of the triad of the files
/// written from the equations with 0.1 cm/s² of noise stated (no gravity columns: the force
/// is what is recovered), and the true forces.
fn record(seed: u64) -> (String, Vec<[f64; 3]>) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let forces: Vec<[f64; 3]> = triad_gen::edges()
        .iter()
        .map(|n| n.map(|x| x * G))
        .collect();
    let mut s =
        String::from("label,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2,sigma_cm_s2\n");
    for (i, f) in forces.iter().enumerate() {
        let u = TRUTH
            .readings(*f)
            .map(|u| u + 0.1 * triad_gen::normal(&mut rng));
        let _ = writeln!(s, "r{},{},{},{},0.1", i + 1, u[0], u[1], u[2]);
    }
    (s, forces)
}

/// `--sheet` and `--write-instrument` on a triad file: the sheet folder (Markdown with the
/// data file's SHA-256, the coefficients, the non-orthogonality, the correlation, the
/// residual table; CSV; the plot), the same bytes again with `SOURCE_DATE_EPOCH`; the
/// calibration file, one for the three axes, which `correct` applies as it applies the
/// `--json` result: every corrected force of a record within its covariance of the truth
/// (Mahalanobis χ² with 3 dof below 16.3, p = 0.001), the same from both.
#[test]
fn a_triad_sheet_and_calibration_file_are_written_and_applied() {
    let tmp = tempfile::tempdir().unwrap();
    let text = triad_csv(0.0, 5);
    std::fs::write(tmp.path().join("t.csv"), &text).unwrap();
    let args = [
        "discover",
        "--data",
        "t.csv",
        "--no-plots",
        "--sheet",
        "sh",
        "--write-instrument",
        "cal.toml",
        "--json",
    ];
    let o = ptsa_dated(tmp.path(), &args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    std::fs::write(tmp.path().join("cal.json"), &o.stdout).unwrap();
    let dir = tmp.path().join("sh");
    assert_eq!(
        common::names(&dir),
        ["sh-residuals.png", "sh-residuals.svg", "sh.csv", "sh.md"]
    );
    let md = std::fs::read_to_string(dir.join("sh.md")).unwrap();
    let hash = ptsa_host_sim::discovery::sheet::hex(&ptsa_host_sim::discovery::sheet::sha256(
        text.as_bytes(),
    ));
    for needle in [
        "# Calibration sheet: accelerometer triad",
        "t.csv (24 positions)",
        hash.as_str(),
        "2026-09-21 14:13:20 UTC (SOURCE_DATE_EPOCH)",
        "| Γ_yx |",
        "| k_z |",
        "## Correlation of the parameters",
        "## Design and residuals",
        "| p24 |",
        "|g| check (24 positions)",
        "M = (diag(1 + k)·(I + Γ))⁻¹",
        "![residuals](sh-residuals.svg)",
    ] {
        assert!(md.contains(needle), "`{needle}` not in the sheet:\n{md}");
    }
    let csv = std::fs::read_to_string(dir.join("sh.csv")).unwrap();
    assert!(csv.contains(&format!("# data SHA-256: {hash}")), "{csv}");
    assert!(csv.lines().any(|l| l.starts_with("Γ_zy,")), "{csv}");
    let first = std::fs::read(dir.join("sh.md")).unwrap();
    // Again over the earlier sheet (--force): the same bytes, and the replacement warned.
    let mut again = args.to_vec();
    again.push("--force");
    let o = ptsa_dated(tmp.path(), &again);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("warning: --sheet sh: replaced an earlier sheet (--force)"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(dir.join("sh.md")).unwrap(), first);
    let cal = std::fs::read_to_string(tmp.path().join("cal.toml")).unwrap();
    assert!(
        cal.contains("format = \"ptsa triad calibration 1\""),
        "{cal}"
    );
    assert!(cal.contains(&hash), "{cal}");
    applied_to_a_record(tmp.path());
}

/// `correct` with the calibration file `cal.toml` and the `--json` result `cal.json` in
/// `dir` on a record of other directions: every force within its covariance of the truth,
/// the same from both, and the CSV's columns.
fn applied_to_a_record(dir: &Path) {
    // Applied to a record of other directions, from the file and from the JSON.
    let (rec, forces) = record(9);
    std::fs::write(dir.join("rec.csv"), &rec).unwrap();
    let mut results = Vec::new();
    for c in ["cal.toml", "cal.json"] {
        let j = json_in(
            dir,
            &["correct", "--data", "rec.csv", "--calibration", c, "--json"],
        );
        assert_eq!(j["frame"], "exact");
        let rows = j["rows"].as_array().unwrap();
        assert_eq!(rows.len(), 12);
        for (r, f) in rows.iter().zip(&forces) {
            let got = numbers(&r["f_cm_s2"]);
            let cov =
                nalgebra::Matrix3::from_fn(|a, b| r["covariance_cm2_s4"][a][b].as_f64().unwrap());
            let d = nalgebra::Vector3::new(got[0] - f[0], got[1] - f[1], got[2] - f[2]);
            let chi2 = (d.transpose() * cov.try_inverse().unwrap() * d)[(0, 0)];
            assert!(chi2 < 16.3, "{c}: {got:?} against {f:?}: χ² {chi2}");
            // The noise's part is about the readings' 0.1 per axis.
            let noise = r["covariance_noise_cm2_s4"][0][0].as_f64().unwrap().sqrt();
            assert!((noise - 0.1).abs() < 0.02, "{noise}");
        }
        results.push(j["rows"].clone());
    }
    for (a, b) in results[0]
        .as_array()
        .unwrap()
        .iter()
        .zip(results[1].as_array().unwrap())
    {
        let (fa, fb) = (numbers(&a["f_cm_s2"]), numbers(&b["f_cm_s2"]));
        for k in 0..3 {
            assert!((fa[k] - fb[k]).abs() < 1e-9, "{fa:?} {fb:?}");
        }
        let (sa, sb) = (
            a["sigma_f_magnitude_cm_s2"].as_f64().unwrap(),
            b["sigma_f_magnitude_cm_s2"].as_f64().unwrap(),
        );
        assert!((sa / sb - 1.0).abs() < 1e-9, "{sa} {sb}");
    }
    // The CSV: a row per record row, the force and its covariance.
    let o = ptsa_in(
        dir,
        &["correct", "--data", "rec.csv", "--calibration", "cal.toml"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(
        out.lines()
            .nth(1)
            .unwrap()
            .starts_with("label,reading_x_cm_s2,reading_y_cm_s2,reading_z_cm_s2,"),
        "{out}"
    );
    assert!(out.contains("cov_xy_cm2_s4"), "{out}");
    assert_eq!(out.lines().count(), 14);
}

/// `discover --data t.csv --write-instrument cal.toml` in `dir`; it must succeed.
fn calibrate_to_file(dir: &Path) {
    let o = ptsa_in(
        dir,
        &[
            "discover",
            "--data",
            "t.csv",
            "--no-plots",
            "--write-instrument",
            "cal.toml",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// The triad's calibration and correction refusals: each names its file or flag and what
/// was expected, and writes nothing.
#[test]
fn triad_calibration_refusals() {
    let tmp = tempfile::tempdir().unwrap();
    let text = triad_csv(0.0, 6);
    std::fs::write(tmp.path().join("t.csv"), &text).unwrap();
    calibrate_to_file(tmp.path());
    let cal = std::fs::read(tmp.path().join("cal.toml")).unwrap();
    let (rec, _) = record(3);
    let single = "label,g_pa,measured_cm_s2\na,0,980\n";
    let single_cal = r#"{"effects": [{"name": "bias", "coefficients": {"k0_cm_s2": 0.4}, "stderr": {"k0_cm_s2": 0.01}}]}"#;
    let files: &[(&str, &[u8])] = &[
        ("t.csv", text.as_bytes()),
        ("cal.toml", &cal),
        ("rec.csv", rec.as_bytes()),
        ("s.csv", single.as_bytes()),
        ("s.json", single_cal.as_bytes()),
    ];
    // The calibration file exists: not replaced without --force.
    refused_in_folder(
        files,
        &[
            "discover",
            "--data",
            "t.csv",
            "--no-plots",
            "--write-instrument",
            "cal.toml",
        ],
        1,
        &["--write-instrument", "cal.toml", "--force"],
        &[],
    );
    refused_in_folder(
        files,
        &["correct", "--data", "rec.csv"],
        1,
        &["rec.csv is a triad record", "expected --calibration FILE"],
        &[],
    );
    refused_in_folder(
        files,
        &["correct", "--data", "rec.csv", "--calibration", "s.json"],
        1,
        &[
            "--calibration s.json: a single-axis calibration",
            "rec.csv is a triad record",
        ],
        &[],
    );
    refused_in_folder(
        files,
        &["correct", "--data", "s.csv", "--calibration", "cal.toml"],
        1,
        &[
            "--calibration cal.toml: a triad's calibration",
            "s.csv is a single-axis record",
        ],
        &[],
    );
    let broken = String::from_utf8(cal.clone())
        .unwrap()
        .replace("values = [", "values = [x");
    let line = broken
        .lines()
        .position(|l| l.starts_with("values = [x"))
        .unwrap()
        + 1;
    refused_in_folder(
        &[("rec.csv", rec.as_bytes()), ("b.toml", broken.as_bytes())],
        &["correct", "--data", "rec.csv", "--calibration", "b.toml"],
        1,
        &[
            &format!("b.toml:{line}:"),
            "expected a triad calibration file",
        ],
        &[],
    );
}

/// A row of a triad record without its three readings is written with empty cells, with a
/// warning.
#[test]
fn a_triad_row_without_three_readings_is_written_empty() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("t.csv"), triad_csv(0.0, 6)).unwrap();
    calibrate_to_file(tmp.path());
    let (rec, _) = record(3);
    let mut lines: Vec<String> = rec.lines().map(String::from).collect();
    let cells: Vec<String> = lines[1].split(',').map(String::from).collect();
    lines[1] = format!("r1x,{},,{},0.1", cells[1], cells[3]);
    let partial = lines.join("\n") + "\n";
    std::fs::write(tmp.path().join("p.csv"), &partial).unwrap();
    let o = ptsa_in(
        tmp.path(),
        &["correct", "--data", "p.csv", "--calibration", "cal.toml"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("warning: p.csv: 1 row without all three axes' readings"),
        "{}",
        stderr(&o)
    );
    assert!(stdout(&o).contains("\nr1x,,,,"), "{}", stdout(&o));
}

/// A triad measured at 980.4 cm/s² and calibrated with `--local-gravity 979.4`: its three
/// scale factors take up one change of +1021 ppm alike, which the |g| check cannot see;
/// a warning names the gravity that explains it. With the right gravity, no warning.
#[test]
fn a_gravity_the_data_disagree_with_is_named() {
    let tmp = tempfile::tempdir().unwrap();
    let truth = TriadTruth {
        b: BIAS,
        gamma: GAMMA,
        ..TriadTruth::default()
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
    let noise = rand_distr::Normal::new(0.0, 0.02).unwrap();
    let rows: Vec<([f64; 3], [f64; 3])> = design24()
        .into_iter()
        .map(|n| {
            let u = truth.readings(n.map(|x| x * G));
            (n, u.map(|x| x + noise.sample(&mut rng)))
        })
        .collect();
    std::fs::write(
        tmp.path().join("t.csv"),
        triad_gen::triad_csv(&rows, Some(0.02), "a triad read at 980.4 cm/s²"),
    )
    .unwrap();
    let warned = |args: &[&str]| -> Vec<String> {
        let v = json_in(tmp.path(), args);
        v["triad"]["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|w| w.as_str().unwrap().to_string())
            .filter(|w| w.contains("share one change"))
            .collect()
    };
    let base = ["discover", "--data", "t.csv", "--json"];
    assert!(warned(&base).is_empty());
    let w = warned(&[&base[..], &["--local-gravity", "979.4"]].concat());
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].contains("the local gravity is 980.4"), "{}", w[0]);
    assert!(w[0].contains("not the 979.4 cm/s² used"), "{}", w[0]);
}
