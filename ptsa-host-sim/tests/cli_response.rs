//! `ptsa response`: a counter record reduced to one case-frame response row. A record made
//! here from a known sine with noise (seeded) comes back within its uncertainties; every
//! bad record and option is refused naming what was wrong, with nothing written and nothing
//! on stdout.

use std::fmt::Write as _;

use rand::{Rng as _, SeedableRng as _};
use rand_chacha::ChaCha8Rng;

/// The shipped file's SF, cm/s², and clock, Hz.
const SF: f64 = 21121.1;
const CLOCK_HZ: f64 = 64000.0;

mod common;
use common::{assert_clean_of, names, ptsa_in};

/// Nothing a user should see in a message.
fn assert_clean(err: &str) {
    assert_clean_of(err, &[]);
}

/// Run `args` in a fresh folder holding `files`; it must exit with `code`, say every one of
/// `needles` on stderr, print nothing on stdout and leave the folder as it was. Returns
/// stderr.
fn refused_with(files: &[(&str, &str)], args: &[&str], code: i32, needles: &[&str]) -> String {
    let files: Vec<(&str, &[u8])> = files.iter().map(|(n, b)| (*n, b.as_bytes())).collect();
    common::refused_in_folder(&files, args, code, needles, &[])
}

/// A record of `n` contiguous gates of `ticks` clock ticks under the input
/// `amp·sin(2πf·t + input_deg)`, to which the instrument responds with `gain` and
/// `phase_deg` and a `mean` offset, each gate's mean output with white noise of
/// `noise_cm_s2` (rms), counted as a charge-balancing loop counts (what one gate leaves
/// over goes into the next).
#[allow(clippy::too_many_arguments)]
fn record(
    seed: u64,
    n: u32,
    ticks: u32,
    f: f64,
    amp: f64,
    input_deg: f64,
    gain: f64,
    phase_deg: f64,
    mean: f64,
    noise_cm_s2: f64,
) -> String {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let normal = rand_distr::Normal::new(0.0, noise_cm_s2).unwrap();
    let tau = f64::from(ticks) / CLOCK_HZ;
    let w = std::f64::consts::TAU * f;
    let x = w * tau / 2.0;
    let (mut total, mut counted) = (0.0f64, 0.0f64);
    let mut s = String::from("# made by cli_response.rs\ntime_s,pulses,ticks\n");
    for k in 0..n {
        let t0 = f64::from(k) * tau;
        let out = mean
            + gain
                * amp
                * (x.sin() / x)
                * (w * (t0 + tau / 2.0) + (input_deg + phase_deg).to_radians()).sin()
            + rng.sample(normal);
        total += f64::midpoint(out / SF, 1.0) * f64::from(ticks);
        let p = total.floor() - counted;
        counted += p;
        let _ = writeln!(s, "{t0},{p},{ticks}");
    }
    s
}

/// A known response comes back: gain and phase within four of their sigmas, the sigmas of
/// the size the scatter implies, the input's phase taken off; the CSV row is a case-frame
/// row with the same numbers; the plot is written.
#[test]
fn a_known_response_comes_back_within_its_uncertainty() {
    let (f, amp, gain, phase) = (20.0, 2000.0, 0.8, -30.0);
    // 400 gates of 5 ms (2 s, 40 periods), 20 cm/s² of noise per gate on top of the
    // counting's quantization (132 cm/s² per pulse in a 320-tick gate).
    let text = record(7, 400, 320, f, amp, 40.0, gain, phase, 5.0, 20.0);
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    std::fs::write(d.join("shaker.csv"), &text).unwrap();
    let args = [
        "response",
        "--counts",
        "shaker.csv",
        "--sine-hz",
        "20",
        "--sine-cm-s2",
        "2000",
        "--input-phase-deg",
        "40",
        "--label",
        "shaker 20 Hz, run \"1\"",
    ];
    let mut json_args = args.to_vec();
    json_args.push("--json");
    let o = ptsa_in(d, &json_args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert_clean(&err);
    assert!(
        err.contains("400 gates of 0.005 s (200 gates/s)")
            && err.contains("wrote 2 files into out"),
        "{err}"
    );
    let out = String::from_utf8(o.stdout).unwrap();
    assert_eq!(out.lines().count(), 1, "{out}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
    assert_eq!(
        keys.len(),
        16,
        "{keys:?}: the row's 8 columns; gates, gate_s, mean_cm_s2, rms_cm_s2; expected_rms_cm_s2, predicted_gain, predicted_phase_deg, warnings"
    );
    // A response within the loop's reach and a sine at the stated frequency: no warning.
    assert_eq!(v["warnings"], serde_json::json!([]), "{v}");
    assert!(!err.contains("warning:"), "{err}");
    assert_eq!(v["kind"], "response");
    assert_eq!(v["label"], "shaker 20 Hz, run \"1\"");
    assert_eq!(v["freq_hz"], 20.0);
    assert_eq!(v["lin_ia_cm_s2"], 2000.0);
    assert_eq!(v["gates"], 400);
    assert_eq!(v["gate_s"], 0.005);
    let g = v["measured_gain"].as_f64().unwrap();
    let sg = v["sigma_gain"].as_f64().unwrap();
    let p = v["measured_phase_deg"].as_f64().unwrap();
    let sp = v["sigma_phase_deg"].as_f64().unwrap();
    assert!((g - gain).abs() < 4.0 * sg, "gain {g} ± {sg}");
    assert!((p - phase).abs() < 4.0 * sp, "phase {p} ± {sp}");
    // The output lags: the phase is negative (not 360° − 30°, nor +30°).
    assert!(p < 0.0, "{p}");
    // The sigmas are those of the scatter: a residual rms r over n gates gives
    // σ_gain ≈ r·√(2/n)/(A·sinc) and σ_phase ≈ σ_gain/gain rad.
    let rms = v["rms_cm_s2"].as_f64().unwrap();
    let x = std::f64::consts::PI * f * 0.005;
    let expect = rms * (2.0f64 / 400.0).sqrt() / (amp * x.sin() / x);
    assert!(
        (0.8..1.25).contains(&(sg / expect)),
        "σ_gain {sg} vs {expect}"
    );
    let expect_deg = (sg / g).to_degrees();
    assert!(
        (0.8..1.25).contains(&(sp / expect_deg)),
        "σ_phase {sp} vs {expect_deg}"
    );
    assert!((v["mean_cm_s2"].as_f64().unwrap() - 5.0).abs() < 4.0 * rms / 20.0);
    assert_eq!(
        names(&d.join("out")),
        ["shaker-response.png", "shaker-response.svg"]
    );

    // Without --json: the row as case-frame CSV with its header, the same numbers.
    let o = ptsa_in(d, &args);
    assert!(o.status.success());
    let csv = String::from_utf8(o.stdout).unwrap();
    assert!(
        csv.starts_with(
            "label,kind,freq_hz,lin_ia_cm_s2,measured_gain,measured_phase_deg,sigma_gain,sigma_phase_deg\n\"shaker 20 Hz, run \"\"1\"\"\",response,20,2000,"
        ),
        "{csv}"
    );
    let rows = ptsa_host_sim::model::caseframe::parse("stdout", &csv).unwrap();
    assert_eq!(rows.len(), 1);
    let r = &rows[0];
    assert_eq!(r.kind, ptsa_host_sim::model::condition::RowKind::Response);
    assert_eq!(r.label, "shaker 20 Hz, run \"1\"");
    assert_eq!(r.measured_gain, Some(g));
    assert_eq!(r.measured_phase_deg, Some(p));
    assert_eq!(r.sigma_gain, Some(sg));
    assert_eq!(r.sigma_phase_deg, Some(sp));
}

/// A gain well away from 1 and a leading phase come back as well (the fit is not biased
/// toward the loop's own response), with a negative input phase; the default label names
/// the frequency and the file.
#[test]
fn a_leading_response_has_a_positive_phase() {
    let text = record(11, 300, 640, 5.0, 1500.0, -10.0, 1.3, 60.0, 0.0, 10.0);
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    std::fs::write(d.join("lead.csv"), &text).unwrap();
    let o = ptsa_in(
        d,
        &[
            "response",
            "--counts",
            "lead.csv",
            "--sine-hz",
            "5",
            "--sine-cm-s2",
            "1500",
            // Typed as a negative number in exponent form (see `ptsa`'s main.rs).
            "--input-phase-deg",
            "-1e1",
            "--json",
            "--out",
            "plots",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let g = v["measured_gain"].as_f64().unwrap();
    let p = v["measured_phase_deg"].as_f64().unwrap();
    assert!(
        (g - 1.3).abs() < 4.0 * v["sigma_gain"].as_f64().unwrap(),
        "{v}"
    );
    assert!(
        (p - 60.0).abs() < 4.0 * v["sigma_phase_deg"].as_f64().unwrap(),
        "{v}"
    );
    assert_eq!(v["label"], "5 Hz (lead.csv)");
    assert_eq!(
        names(&d.join("plots")),
        ["lead-response.png", "lead-response.svg"]
    );
}

/// Bad records, named by file, line and column, and bad options; nothing written.
#[test]
#[allow(clippy::too_many_lines)] // one refused case after another
fn response_refuses_bad_records_and_options() {
    fn run(file: &str) -> Vec<&str> {
        vec![
            "response",
            "--counts",
            file,
            "--sine-hz",
            "20",
            "--sine-cm-s2",
            "2000",
        ]
    }
    let good = record(3, 40, 320, 20.0, 2000.0, 0.0, 0.8, -30.0, 0.0, 20.0);
    let lines: Vec<&str> = good.lines().collect();
    // Line 5 (the fourth gate) earlier than line 4.
    let mut v = lines.clone();
    v.swap(3, 4);
    refused_with(
        &[("bad.csv", &v.join("\n"))],
        &run("bad.csv"),
        1,
        &[
            "bad.csv:5: column 1 (`time_s`) holds 0.005, not after the previous gate's 0.01; expected increasing times",
        ],
    );
    // A missing column, in the header and on a line.
    let no_ticks = good.replace("time_s,pulses,ticks", "time_s,pulses");
    refused_with(
        &[("bad.csv", &no_ticks)],
        &run("bad.csv"),
        1,
        &[
            "bad.csv:2: header `time_s,pulses`: column 3 (`ticks`) is missing; expected `time_s,pulses,ticks`",
        ],
    );
    let mut v = lines.clone();
    v[6] = "0.025,70";
    refused_with(
        &[("bad.csv", &v.join("\n"))],
        &run("bad.csv"),
        1,
        &["bad.csv:7: column 3 (`ticks`) is missing (2 cells); expected 3 cells"],
    );
    // A cell that is not a number.
    let mut v = lines.clone();
    v[2] = "0,abc,320";
    refused_with(
        &[("bad.csv", &v.join("\n"))],
        &run("bad.csv"),
        1,
        &["bad.csv:3: column 2 (`pulses`) holds `abc`; expected a whole number, 0 or more"],
    );
    let mut v = lines.clone();
    v[3] = "x,150,320";
    refused_with(
        &[("bad.csv", &v.join("\n"))],
        &run("bad.csv"),
        1,
        &["bad.csv:4: column 1 (`time_s`) holds `x`; expected a finite time in s"],
    );
    // More pulses than ticks, gates of different lengths.
    let mut v = lines.clone();
    v[3] = "0.005,400,320";
    refused_with(
        &[("bad.csv", &v.join("\n"))],
        &run("bad.csv"),
        1,
        &["bad.csv:4: column 2 (`pulses`) holds 400, more than the gate's 320 ticks"],
    );
    let mut v = lines.clone();
    v[3] = "0.005,150,321";
    refused_with(
        &[("bad.csv", &v.join("\n"))],
        &run("bad.csv"),
        1,
        &[
            "bad.csv:4: column 3 (`ticks`) holds 321, not the first gate's 320 (line 3); expected gates of equal length",
        ],
    );
    // Too few gates.
    refused_with(
        &[("few.csv", &lines[..5].join("\n"))],
        &run("few.csv"),
        1,
        &["few.csv:5: the record ends after 3 gates; expected at least 4 gates"],
    );
    refused_with(&[], &run("nope.csv"), 1, &["nope.csv: cannot read"]);
    let latin1 = format!("{}\n0.2,\u{b5},320\n", lines.join("\n"));
    let tmp = tempfile::tempdir().unwrap();
    let mut bytes = latin1.into_bytes();
    // µ in Latin-1: one byte, 0xB5, not UTF-8.
    let at = bytes.iter().position(|&b| b == 0xC2).unwrap();
    bytes.remove(at);
    std::fs::write(tmp.path().join("latin1.csv"), &bytes).unwrap();
    let o = ptsa_in(tmp.path(), &run("latin1.csv"));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("latin1.csv:43: not UTF-8 text (a bad byte at byte offset")
            && err.contains("expected a CSV of `time_s,pulses,ticks` in UTF-8"),
        "{err}"
    );
    assert!(o.stdout.is_empty());
    assert_eq!(names(tmp.path()), ["latin1.csv"]);
    // The frequency: more than 0 (an option: exit 2), below the record's Nyquist frequency
    // (200 gates/s: 100 Hz; exactly 100 Hz cannot be fitted either).
    for (f, needle) in [
        ("0", "expected a frequency in Hz, more than 0, not 0"),
        ("-5", "expected a frequency in Hz, more than 0, not -5"),
        ("nan", "expected a finite number, not NaN"),
    ] {
        let mut a = run("good.csv");
        a[4] = f;
        refused_with(&[("good.csv", &good)], &a, 2, &["'--sine-hz <HZ>'", needle]);
    }
    for f in ["100", "150"] {
        let mut a = run("good.csv");
        a[4] = f;
        refused_with(
            &[("good.csv", &good)],
            &a,
            1,
            &[&format!(
                "--sine-hz {f}: expected a frequency below 100 Hz, the Nyquist frequency of good.csv (40 gates in 0.195 s, 200 gates/s)"
            )],
        );
    }
    // The amplitude: more than 0.
    for (amp, needle) in [
        ("0", "expected an amplitude in cm/s², more than 0, not 0"),
        (
            "-2000",
            "expected an amplitude in cm/s², more than 0, not -2000",
        ),
        ("inf", "expected a finite number, not inf"),
    ] {
        let mut a = run("good.csv");
        a[6] = amp;
        refused_with(
            &[("good.csv", &good)],
            &a,
            2,
            &["'--sine-cm-s2 <CM_S2>'", needle],
        );
    }
    // A label that cannot be one case-frame cell; an --out that is a file.
    let mut a = run("good.csv");
    a.extend(["--label", "two\nlines"]);
    refused_with(
        &[("good.csv", &good)],
        &a,
        2,
        &["'--label <TEXT>'", "expected a label on one line"],
    );
    let mut a = run("good.csv");
    a.extend(["--out", "good.csv"]);
    refused_with(
        &[("good.csv", &good)],
        &a,
        1,
        &["--out good.csv: this is a file; expected a folder"],
    );
    refused_with(
        &[],
        &["response", "--sine-hz", "20", "--sine-cm-s2", "1"],
        2,
        &["--counts <FILE>"],
    );
}

/// The help states the units and the phase's sign.
#[test]
fn response_help_explains_gain_and_phase() {
    let tmp = tempfile::tempdir().unwrap();
    let o = ptsa_in(tmp.path(), &["response", "--help"]);
    assert!(o.status.success());
    let h = String::from_utf8(o.stdout).unwrap();
    for needle in [
        "dimensionless",
        "lags the input has a negative phase",
        "degrees",
        "cm/s²",
        "Hz",
        "time_s,pulses,ticks",
        "Nyquist",
        "--force",
        "docs/reference/json.md",
    ] {
        assert!(h.contains(needle), "`{needle}` not in:\n{h}");
    }
    assert!(names(tmp.path()).is_empty());
}

/// A record of `n` gates of `gate` ticks counted from the simulated closed loop of the
/// shipped file under `amp·sin(2πf·t)` along IA (the input's phase 0 at tick 0), after the
/// settling and `offset` more ticks (so that the gates start `offset` ticks into a limit
/// cycle). Returns the record's gates and the loop after them.
fn sim_gates(
    f: f64,
    amp: f64,
    gate: u64,
    n: usize,
    offset: u64,
) -> (
    Vec<ptsa_host_sim::lab::response::Gate>,
    ptsa_host_sim::simulation::sim::ClosedLoop,
) {
    use ptsa_host_sim::model::condition::{Condition, IA};
    use ptsa_host_sim::simulation::sim::{ClosedLoop, SimOptions};
    use ptsa_host_sim::{Effects, Instrument};
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
    l.run(opts.warmup_ticks(instr.clock_hz) + offset);
    let gates = (0..n)
        .map(|_| {
            #[allow(clippy::cast_precision_loss)]
            let time_s = l.ticks() as f64 / instr.clock_hz;
            let p0 = l.core().total_pulses();
            l.run(gate);
            ptsa_host_sim::lab::response::Gate {
                time_s,
                pulses: u64::from((l.core().total_pulses() - p0).0),
                ticks: gate,
            }
        })
        .collect();
    (gates, l)
}

/// [`sim_gates`] as the text of a record.
fn sim_record(f: f64, amp: f64, gate: u64, n: usize) -> String {
    let mut text = String::from("time_s,pulses,ticks\n");
    for g in sim_gates(f, amp, gate, n, 0).0 {
        let _ = writeln!(text, "{},{},{}", g.time_s, g.pulses, g.ticks);
    }
    text
}

/// A record counted from the simulated closed loop (gates of 5 ms over 1 s under a 20 Hz,
/// 2000 cm/s² sine along IA, after the settling) reduces to the loop's own frequency
/// response: the component at 20 Hz of the same second's pulse train
/// (`SimResult::harmonic_amp_cm_s2`, `harmonic_deg`, as `ptsa waveform`'s table measures
/// it), within the fit's uncertainty; and the check finds nothing to warn of: its scatter
/// is what counting leaves and its gain and phase are the loop's. Run with `--nocapture`
/// for the figures.
#[test]
fn a_record_of_the_simulated_loop_gives_its_frequency_response() {
    let (amp, gate) = (2000.0, 320u64);
    let (gates, _) = sim_gates(20.0, amp, gate, 200, 0);
    let mut text = String::from("time_s,pulses,ticks\n");
    for g in &gates {
        let _ = writeln!(text, "{},{},{}", g.time_s, g.pulses, g.ticks);
    }
    // The same second (the same loop, the same noise) measured by the simulator.
    let (_, mut l) = sim_gates(20.0, amp, gate, 0, 0);
    let r = l.measure(200 * gate);
    let (sim_gain, sim_deg) = (r.harmonic_amp_cm_s2 / amp, r.harmonic_deg);
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("sim.csv"), &text).unwrap();
    let o = ptsa_in(
        tmp.path(),
        &[
            "response",
            "--counts",
            "sim.csv",
            "--sine-hz",
            "20",
            "--sine-cm-s2",
            "2000",
            "--json",
        ],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("warning:"), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["warnings"], serde_json::json!([]), "{v}");
    let g = v["measured_gain"].as_f64().unwrap();
    let sg = v["sigma_gain"].as_f64().unwrap();
    let p = v["measured_phase_deg"].as_f64().unwrap();
    let sp = v["sigma_phase_deg"].as_f64().unwrap();
    eprintln!(
        "record: gain {g:.5} ± {sg:.5} ({:.3} dB), phase {p:.3} ± {sp:.3} deg; simulator: gain {sim_gain:.5} ({:.3} dB), phase {sim_deg:.3} deg; residual RMS {:.2} cm/s², counting leaves {:.2}; the linear loop: gain {:.5}, phase {:.3} deg",
        20.0 * g.log10(),
        20.0 * sim_gain.log10(),
        v["rms_cm_s2"].as_f64().unwrap(),
        v["expected_rms_cm_s2"].as_f64().unwrap(),
        v["predicted_gain"].as_f64().unwrap(),
        v["predicted_phase_deg"].as_f64().unwrap(),
    );
    assert!((g - sim_gain).abs() < 4.0 * sg, "{g} ± {sg} vs {sim_gain}");
    assert!((p - sim_deg).abs() < 4.0 * sp, "{p} ± {sp} vs {sim_deg}");
    // And it is the loop's response, not a unit one: above 1 and lagging at 20 Hz.
    assert!(g > 1.1 && p < -5.0, "{g} {p}");
}

/// The scatter [`ptsa_host_sim::lab::response::expected_scatter`] says a right fit leaves is
/// that of records counted from the simulated closed loop: over sines of 1 to 100 Hz and
/// 300 to 10 000 cm/s², gates of whole limit cycles (64, 320, 1280 ticks), of a cycle and
/// one tick (321) or a half cycle more (352, where the gates cut the limit cycle most), each
/// started 0, 16 and 32 ticks into a cycle, the residual RMS of the fit at the right
/// frequency over the estimate lies between 0.03 and 1.8 (the formula's own bound over the
/// start phase is `√3`), far below [`ptsa_host_sim::lab::response::SCATTER_LIMIT`]; and the
/// estimate follows the gates (half-cycle gates scatter about ten times more than
/// whole-cycle ones of about the same length), so it is no constant. Run with `--nocapture` for the
/// figures.
#[test]
fn the_expected_scatter_is_that_of_the_simulated_loop() {
    use ptsa_host_sim::lab::response;
    let instr = ptsa_host_sim::Instrument::kearfott_2401();
    let mut ratios: Vec<f64> = Vec::new();
    let mut by_gate: Vec<(u64, f64)> = Vec::new();
    // The smallest ratio of gates of whole limit cycles.
    let mut whole = f64::INFINITY;
    for f in [1.0, 5.0, 20.0, 100.0] {
        for amp in [300.0, 2000.0, 10_000.0] {
            for gate in [64u64, 320, 321, 352, 1280] {
                #[allow(clippy::cast_precision_loss)]
                let tau = gate as f64 / CLOCK_HZ;
                let x = std::f64::consts::PI * f * tau;
                // Gates that average the sine away, or too few per period: not a record.
                if x.sin() / x < 0.3 || f > 0.4 / tau {
                    continue;
                }
                for offset in [0, 16, 32] {
                    // At least 0.5 s and two periods.
                    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                    let n = ((0.5f64.max(2.0 / f) / tau).ceil() as usize).max(50);
                    let (gates, _) = sim_gates(f, amp, gate, n, offset);
                    let fit = response::fit(&gates, f, amp, 0.0, SF, CLOCK_HZ).unwrap();
                    let e = response::expected_scatter(&gates, &fit, instr.sf_cm_s2, 64);
                    let ratio = fit.rms_cm_s2 / e.rms_cm_s2;
                    ratios.push(ratio);
                    if gate % 64 == 0 {
                        whole = whole.min(ratio);
                    }
                    if (f, amp, offset) == (20.0, 2000.0, 0) {
                        by_gate.push((gate, e.rms_cm_s2 / e.pulse_cm_s2));
                    }
                    assert!(
                        (0.03..1.8).contains(&ratio),
                        "{f} Hz, {amp} cm/s², {gate} ticks from {offset}: RMS {} against {e:?}",
                        fit.rms_cm_s2
                    );
                }
            }
        }
    }
    ratios.sort_by(f64::total_cmp);
    let q = |p: f64| {
        #[allow(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            clippy::cast_precision_loss
        )]
        ratios[((ratios.len() - 1) as f64 * p) as usize]
    };
    eprintln!(
        "{} records: residual RMS over the expected scatter min {:.3}, median {:.3}, 95 % {:.3}, max {:.3} (gates of whole cycles: min {whole:.3}); expected scatter in pulses at 20 Hz, 2000 cm/s², by gate: {by_gate:?}",
        ratios.len(),
        q(0.0),
        q(0.5),
        q(0.95),
        q(1.0)
    );
    let pulses = |t: u64| by_gate.iter().find(|g| g.0 == t).unwrap().1;
    assert!(pulses(352) > 5.0 * pulses(320), "{by_gate:?}");
}

/// `ptsa response --counts rec.csv --sine-hz F --sine-cm-s2 A` and `extra`.
fn run_args<'a>(file: &'a str, f: &'a str, amp: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec![
        "response",
        "--counts",
        file,
        "--sine-hz",
        f,
        "--sine-cm-s2",
        amp,
    ];
    a.extend_from_slice(extra);
    a
}

/// Run `args` in a folder holding `rec.csv` = `text`; it must succeed. Returns the JSON
/// (`--json` is added), stderr and the folder's `out` listing.
fn accepted(text: &str, args: &[&str]) -> (serde_json::Value, String, Vec<String>) {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("rec.csv"), text).unwrap();
    let mut a = args.to_vec();
    a.push("--json");
    let o = ptsa_in(tmp.path(), &a);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(0), "{args:?}: {err}");
    assert_clean(&err);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    (v, err, names(&tmp.path().join("out")))
}

/// The texts of the JSON's "warnings".
fn warnings(v: &serde_json::Value) -> Vec<String> {
    v["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap().to_string())
        .collect()
}

/// A 20 Hz record reduced at 21 Hz has no sine there: refused (exit 1, nothing written,
/// nothing on stdout) with the frequency that fits, and with --force written with the
/// refusal as a warning (stderr and JSON). A gain of 1200 from an amplitude typed in g
/// (2 for 1960.8 cm/s²) is refused naming the amplitude in cm/s²; forced, it is written with
/// that warning.
#[test]
fn a_fit_beyond_physical_sense_is_refused_unless_forced() {
    let rec = sim_record(20.0, 1960.8, 320, 200);
    let err = refused_with(
        &[("rec.csv", &rec)],
        &run_args("rec.csv", "21", "1960.8", &[]),
        1,
        &[
            "error: rec.csv: gain ",
            "at --sine-hz 21: the uncertainty is larger than the gain, so the record shows no sine at 21 Hz; the record's sine is near 20.0 Hz (residual RMS ",
            "): --sine-hz 20.0; --force writes the row anyway",
        ],
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    let (v, err, out) = accepted(&rec, &run_args("rec.csv", "21", "1960.8", &["--force"]));
    let w = warnings(&v);
    assert!(
        w.len() == 1
            && w[0].contains("the record's sine is near 20.0 Hz")
            && w[0].ends_with("(written because of --force)"),
        "{w:?}"
    );
    assert!(err.contains(&format!("warning: {}", w[0])), "{err}");
    assert_eq!(out, ["rec-response.png", "rec-response.svg"]);

    let err = refused_with(
        &[("rec.csv", &rec)],
        &run_args("rec.csv", "20", "2", &[]),
        1,
        &[
            "error: rec.csv: gain 12",
            "at --sine-hz 20 is above 2, more than a loop the simulator accepts can give (the instrument file's loop predicts 1.196, ",
            "; if 2 was in g, --sine-cm-s2 1960.8; --force writes the row anyway",
        ],
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    let (v, _, _) = accepted(&rec, &run_args("rec.csv", "20", "2", &["--force"]));
    let w = warnings(&v);
    assert!(
        w.len() == 1 && w[0].contains("if 2 was in g, --sine-cm-s2 1960.8"),
        "{w:?}"
    );
    assert!(v["measured_gain"].as_f64().unwrap() > 1000.0, "{v}");
    // The same record with its amplitude right: nothing to say.
    let (v, err, _) = accepted(&rec, &run_args("rec.csv", "20", "1960.8", &[]));
    assert!(warnings(&v).is_empty() && !err.contains("warning"), "{err}");
    let g = v["measured_gain"].as_f64().unwrap();
    let pg = v["predicted_gain"].as_f64().unwrap();
    assert!((g / pg - 1.0).abs() < 0.05, "{g} against the loop's {pg}");
}

/// A fit far from the loop's prediction, but within physical sense, is written with a
/// warning (stderr and JSON) that names the likely slip: an amplitude typed in mm/s², an
/// input phase 90° off; a record that scatters far more than counting leaves is named as
/// such, with the frequency that fits when there is one (20.5 Hz stated for a 20 Hz record)
/// and without when there is none (a noisy input).
#[test]
fn a_fit_far_from_the_loop_or_from_a_sine_warns() {
    let rec = sim_record(20.0, 2000.0, 320, 200);
    let one = |args: &[&str], needles: &[&str]| {
        let (v, err, out) = accepted(&rec, args);
        let w = warnings(&v);
        assert_eq!(w.len(), 1, "{args:?}: {w:?}");
        for n in needles {
            assert!(w[0].contains(n), "{args:?}: `{n}` not in {w:?}");
        }
        assert!(err.contains(&format!("warning: {}", w[0])), "{err}");
        assert_eq!(out, ["rec-response.png", "rec-response.svg"]);
    };
    one(
        &run_args("rec.csv", "20", "20000", &[]),
        &[
            "rec.csv: gain 0.122",
            "at 20 Hz is far from the loop: the instrument file's loop predicts 1.196, 1.083 to 1.376 over its tolerance box",
            "if 20000 was in mm/s², --sine-cm-s2 2000",
        ],
    );
    one(
        &run_args("rec.csv", "20", "2000", &["--input-phase-deg", "90"]),
        &[
            "rec.csv: phase -105.",
            "deg at 20 Hz is far from the loop's -13.1 deg",
            "check --input-phase-deg (the input's phase at time_s = 0, now 90)",
        ],
    );
    one(
        &run_args("rec.csv", "20.5", "2000", &[]),
        &[
            "rec.csv: the gates scatter about the fitted sine with RMS ",
            "times the ",
            "cm/s² that counting leaves (pulses of 132 cm/s² in gates of 320 ticks",
            "the record is not a clean sine at 20.5 Hz; the record's sine is near 20.0 Hz",
        ],
    );
    // White noise of 600 cm/s² per gate on a 20 Hz response: no other frequency helps.
    let noisy = record(5, 200, 320, 20.0, 2000.0, 0.0, 1.2, -15.0, 0.0, 600.0);
    let (v, _, _) = accepted(&noisy, &run_args("rec.csv", "20", "2000", &[]));
    let w = warnings(&v);
    assert!(
        w.len() == 1
            && w[0].contains("the gates scatter about the fitted sine")
            && w[0].contains("no other frequency fits far better: a noisy or distorted input"),
        "{w:?}"
    );
}
