//! The loop's own parameters identified through the closed loop from a frequency-response
//! table made with a perturbed instrument file the analysis never sees.

use ptsa_host_sim::discovery::sim::{ClosedLoopSimulator, response_of};
use ptsa_host_sim::discovery::{Options, discover, show};
use ptsa_host_sim::model::condition::{IA, RowKind};
use ptsa_host_sim::{CandidateId, Condition, Effects, Instrument, SimOptions};

/// The frequencies of the table, Hz.
const FREQS: [f64; 20] = [
    2.0, 5.0, 10.0, 15.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 100.0, 120.0, 150.0,
    180.0, 220.0, 260.0, 300.0, 400.0,
];

/// Runs of the shipped instrument behind each row's stated sigma: enough that the sigma is
/// known (with 8, the χ² of a right model averages 1.4 times its degrees of freedom).
const SIGMA_RUNS: u64 = 32;

/// A frequency-response table of `instr` measured with noise seed `seed`; each row's
/// sigma is what a laboratory would state, the scatter of one run of this instrument at
/// that frequency (the sample standard deviation of [`SIGMA_RUNS`] runs with other seeds).
fn table(instr: &Instrument, seed: u64) -> Vec<Condition> {
    FREQS
        .iter()
        .map(|&f| {
            let mut c = Condition {
                label: format!("{f} Hz"),
                kind: RowKind::Response,
                freq_hz: f,
                ..Condition::default()
            };
            c.lin_cm_s2[IA] = 2000.0;
            let runs: Vec<[f64; 2]> = (0..SIGMA_RUNS)
                .map(|j| {
                    let o = SimOptions {
                        seed: 1000 + j,
                        ..SimOptions::default()
                    };
                    response_of(instr, &c, &Effects::NONE, &o)
                })
                .collect();
            #[allow(clippy::cast_precision_loss)]
            let n = SIGMA_RUNS as f64;
            let sd = |k: usize| {
                let m = runs.iter().map(|r| r[k]).sum::<f64>() / n;
                (runs.iter().map(|r| (r[k] - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
            };
            let opts = SimOptions {
                seed,
                ..SimOptions::default()
            };
            let [g, p] = response_of(instr, &c, &Effects::NONE, &opts);
            c.measured_gain = Some(g);
            c.measured_phase_deg = Some(p);
            c.sigma_gain = Some(sd(0).max(1e-4));
            c.sigma_phase_deg = Some(sd(1).max(0.01));
            c
        })
        .collect()
}

#[test]
fn damping_off_by_two_tolerances_is_named() {
    let nominal = Instrument::kearfott_2401();
    let mut truth = nominal.clone();
    let c = nominal.get("pendulum.damping_dyn_cm_s").unwrap();
    truth.set("pendulum.damping_dyn_cm_s", c * 1.5).unwrap();
    let rows = table(&truth, 99);
    let sim = ClosedLoopSimulator {
        instrument: nominal.clone(),
        options: SimOptions::default(),
    };
    let t0 = std::time::Instant::now();
    let d = discover(&rows, &sim, &Options::for_instrument(&nominal)).unwrap();
    eprintln!(
        "{}\n{:.2} s",
        show::text_report("response", &d),
        t0.elapsed().as_secs_f64()
    );
    let named: Vec<CandidateId> = d.selected.iter().map(|s| s.id).collect();
    assert_eq!(named.first(), Some(&CandidateId::ParamDamping), "{named:?}");
    // The damping's response is not even: the mirrored value is rejected.
    assert_eq!(
        d.selected[0].parameter.as_ref().and_then(|p| p.mirror),
        None
    );
    // The Bode figure: gain, phase and their residuals against frequency, with the linear
    // model drawn with and without the fitted damping; no cm/s² figure for these rows.
    assert!(show::figure("t", &d).is_none());
    let fig = show::response_figure("t", &d).unwrap();
    assert_eq!(fig.stem, "t-bode");
    assert_eq!(fig.panels.len(), 4);
    let names: Vec<&str> = fig.panels[0]
        .series
        .iter()
        .map(|s| s.name.as_str())
        .collect();
    assert!(
        names.contains(&"linear model, fitted parameters"),
        "{names:?}"
    );
    assert_eq!(fig.panels[0].series[0].points.len(), 20);
}

/// `ptsa discover --data response.case.csv --no-plots --write-instrument FILE` in `dir`;
/// it must succeed. Returns its stderr.
fn write_instrument(dir: &std::path::Path, file: &str) -> String {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_ptsa"))
        .current_dir(dir)
        .args([
            "discover",
            "--data",
            "response.case.csv",
            "--no-plots",
            "--write-instrument",
            file,
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{err}");
    err
}

/// The same through the binary: `--write-instrument` writes the shipped file with the
/// identified damping and nothing else changed, and the written file reads back.
#[test]
fn write_instrument_holds_the_identified_damping() {
    let nominal = Instrument::kearfott_2401();
    let mut truth = nominal.clone();
    let c = nominal.get("pendulum.damping_dyn_cm_s").unwrap();
    truth.set("pendulum.damping_dyn_cm_s", c * 1.5).unwrap();
    let rows = table(&truth, 99);
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("response.case.csv");
    std::fs::write(
        &data,
        ptsa_host_sim::model::caseframe::to_csv(&rows, &["damping +50 %"]),
    )
    .unwrap();
    let err = write_instrument(tmp.path(), "fitted.toml");
    assert!(err.contains("wrote fitted.toml"), "{err}");
    let text = std::fs::read_to_string(tmp.path().join("fitted.toml")).unwrap();
    let fitted = Instrument::parse(&text, "fitted.toml").unwrap();
    let got = fitted.get("pendulum.damping_dyn_cm_s").unwrap();
    assert!((got / (1.5 * c) - 1.0).abs() < 0.01, "{got}");
    for key in [
        "pendulum.spring_dyn_cm_per_rad",
        "pendulum.inertia_oa_g_cm2",
        "torquer.time_constant_us",
    ] {
        assert_eq!(fitted.get(key), nominal.get(key), "{key}");
    }
    assert!(text.contains("# ptsa discover --data response.case.csv: fitted"));
    // Unperturbed data select no parameter: nothing is written.
    std::fs::write(
        &data,
        ptsa_host_sim::model::caseframe::to_csv(&table(&nominal, 99), &[]),
    )
    .unwrap();
    let err = write_instrument(tmp.path(), "none.toml");
    assert!(err.contains("none.toml not written"), "{err}");
    assert!(!tmp.path().join("none.toml").exists());
}

/// `data/synthetic-response.case.csv` is what [`table`] makes for the shipped instrument
/// with its damping 1.5 times the file's (seed 99; the closed loop is deterministic for a
/// given seed). With `PTSA_WRITE_REPORT_DATA=1` the test rewrites it instead.
#[test]
fn synthetic_response_file_is_what_the_generator_makes() {
    let mut truth = Instrument::kearfott_2401();
    let c = truth.get("pendulum.damping_dyn_cm_s").unwrap();
    truth.set("pendulum.damping_dyn_cm_s", c * 1.5).unwrap();
    let text = ptsa_host_sim::model::caseframe::to_csv(
        &table(&truth, 99),
        &[
            "Synthetic example, not measured: a 20-frequency response table (2000 cm/s^2 along IA) of the",
            "closed loop with the damping 1.5 times the instrument file's (114 600 dyn·cm·s), noise seed 99;",
            "sigmas are the scatter of one run of this instrument at each frequency (32 other seeds).",
            "Generated by the test synthetic_response_file_is_what_the_generator_makes (ptsa-host-sim/tests/identify.rs); do not edit.",
        ],
    );
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../data/synthetic-response.case.csv");
    if std::env::var_os("PTSA_WRITE_REPORT_DATA").is_some() {
        std::fs::write(&path, &text).unwrap();
    }
    let shipped = std::fs::read_to_string(&path).unwrap();
    assert_eq!(
        shipped, text,
        "data/synthetic-response.case.csv differs from the generator"
    );
}

/// In a tumble a scale-factor change and a torquer scale-factor change are the same
/// column; the model-equation term is named, the parameter said to be indistinguishable
/// (the closed loop's sensitivity to the parameter carries a little noise, which must not
/// decide between them). Six noise draws of a 24-point tumble with a bias, a scale-factor
/// change, a misalignment and a nonlinearity.
#[test]
fn a_tumble_names_the_scale_factor_before_the_torquer_parameter() {
    use ptsa_host_sim::discovery::sim::Simulator as _;
    use ptsa_host_sim::lab::plan::{self, Axis};
    use rand::SeedableRng as _;
    use rand_distr::Distribution as _;
    let nominal = Instrument::kearfott_2401();
    let sim = ClosedLoopSimulator {
        instrument: nominal.clone(),
        options: SimOptions::default(),
    };
    let truth = Effects::only(CandidateId::Bias, 2.0)
        .with(CandidateId::ScaleFactor, 300.0)
        .with(CandidateId::MisalignmentP, 2e-4)
        .with(CandidateId::Nonlinearity, 1e-7);
    let noise = rand_distr::Normal::new(0.0, 0.02).unwrap();
    for seed in 1..=6 {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut rows = plan::tumble(24, Axis::Oa);
        for r in &mut rows {
            r.measured_cm_s2 = Some(sim.absolute_cm_s2(r, &truth) + noise.sample(&mut rng));
            r.sigma_cm_s2 = Some(0.02);
        }
        let d = discover(&rows, &sim, &Options::for_instrument(&nominal)).unwrap();
        let named: Vec<CandidateId> = d.selected.iter().map(|s| s.id).collect();
        assert!(
            named.contains(&CandidateId::ScaleFactor)
                && !named.contains(&CandidateId::ParamTorquerSf),
            "seed {seed}: {named:?}\n{}",
            show::text_report("tumble", &d)
        );
    }
}

/// A demodulator phase error of 15° (tolerance ±10°) acts as `cos φ` on the pickoff's gain
/// and has no first-order effect at the file's 0°, so its central-difference signature is
/// the loop's noise and the selection names another parameter; the check of the other
/// parameters over their bands (`discovery::check`) must name the phase, selected
/// or as an indistinguishable partner of what is selected.
#[test]
fn a_pickoff_phase_error_is_named_though_it_has_no_first_order_effect() {
    let nominal = Instrument::kearfott_2401();
    let mut truth = nominal.clone();
    truth.set("pickoff.phase_angle_deg", 15.0).unwrap();
    let rows = table(&truth, 7);
    let sim = ClosedLoopSimulator {
        instrument: nominal.clone(),
        options: SimOptions::default(),
    };
    let d = discover(&rows, &sim, &Options::for_instrument(&nominal)).unwrap();
    eprintln!("{}", show::text_report("response", &d));
    let phase = CandidateId::ParamPickoffPhase;
    assert!(
        d.selected
            .iter()
            .any(|s| s.id == phase || s.confounded.iter().any(|(o, _)| *o == phase)),
        "{:?}",
        d.selected
            .iter()
            .map(|s| (s.id, s.coef, s.confounded.clone()))
            .collect::<Vec<_>>()
    );
}

/// A pickoff phase error acts mostly as its cosine (its sine only leaks the small
/// quadrature): when the phase alone is the candidate, it is found by the scan, its size
/// within 3 standard errors; either the report says that the mirrored value fits as well
/// (the data give the size of the change, not its sign) or the sign it gives is right.
#[test]
fn a_pickoff_phase_error_is_reported_with_its_sign_only_when_the_data_give_it() {
    let nominal = Instrument::kearfott_2401();
    let mut truth = nominal.clone();
    truth.set("pickoff.phase_angle_deg", -20.0).unwrap();
    let rows = table(&truth, 11);
    let sim = ClosedLoopSimulator {
        instrument: nominal.clone(),
        options: SimOptions::default(),
    };
    let opts = Options {
        candidates: vec![CandidateId::ParamPickoffPhase],
        ..Options::for_instrument(&nominal)
    };
    let d = discover(&rows, &sim, &opts).unwrap();
    let text = show::text_report("response", &d);
    eprintln!("{text}");
    let s = d
        .selected
        .iter()
        .find(|s| s.id == CandidateId::ParamPickoffPhase)
        .expect("the phase is named");
    let p = s.parameter.as_ref().unwrap();
    assert!(
        (p.fitted.abs() - 20.0).abs() <= 3.0 * p.sigma,
        "{} ± {}",
        p.fitted,
        p.sigma
    );
    if let Some(m) = p.mirror {
        assert!((m + p.fitted).abs() < 1e-9, "{m} against {}", p.fitted);
        assert!(text.contains("not its sign"), "{text}");
    } else {
        assert!(p.fitted < 0.0, "the sign is given, and wrong: {}", p.fitted);
        assert!(!text.contains("not its sign"), "{text}");
    }
}

/// When the instrument file gives the amplifier gain a tolerance, it is a candidate. In a
/// response table the loop gain shows, the product of the pendulosity, the pickoff scale
/// factor and the amplifier gain, and the damping moves the response much the same way at
/// this size; so an amplifier gain 8 % low must be named, selected or as an
/// indistinguishable partner of what is selected, and when one of the three gains is the
/// one selected, its relative change is the 8 % within 3 standard errors.
#[test]
fn an_amplifier_gain_error_is_named_with_its_indistinguishable_twins() {
    const FILE: &str = include_str!("../../data/kearfott-2401.toml");
    let src = FILE.replace(
        "amplifier_gain = 100.0",
        "amplifier_gain = { value = 100.0, tol_pct = 20.0 }\nadc_offset_mv = { value = 0.0, tol_abs = 2.0 }",
    );
    assert_ne!(src, FILE);
    let nominal = Instrument::parse(&src, "toleranced.toml").unwrap();
    let mut truth = nominal.clone();
    truth.set("electronics.amplifier_gain", 92.0).unwrap();
    let rows = table(&truth, 21);
    let sim = ClosedLoopSimulator {
        instrument: nominal.clone(),
        options: SimOptions::default(),
    };
    let d = discover(&rows, &sim, &Options::for_instrument(&nominal)).unwrap();
    let text = show::text_report("response", &d);
    eprintln!("{text}");
    let amp = CandidateId::ParamAmplifierGain;
    let s = d
        .selected
        .iter()
        .find(|s| s.id == amp || s.confounded.iter().any(|(c, _)| *c == amp))
        .unwrap_or_else(|| panic!("the amplifier gain is not named: {text}"));
    let gains = [
        amp,
        CandidateId::ParamPickoffGain,
        CandidateId::ParamPendulosity,
    ];
    if gains.contains(&s.id) {
        let p = s.parameter.as_ref().unwrap();
        let rel = p.fitted / p.nominal;
        assert!(
            (rel - 0.92).abs() <= 3.0 * p.sigma / p.nominal,
            "{} ± {} against 0.92 of {}",
            p.fitted,
            p.sigma,
            p.nominal
        );
    }
}

/// One run's scatter of a response row, by frequency: where the input frequency divides the
/// 1 kHz limit cycle evenly (100, 200, 250, 500 Hz ... and 400 Hz, which repeats every
/// 5 ms), the start phase of the sine against the loop's clock decides much of what a run
/// measures, and the phase scatters several times more than at the neighbouring
/// frequencies. Prints the table `docs/method/discovery.md` quotes (32 runs per frequency).
#[test]
fn a_response_scatters_most_where_the_frequency_divides_the_limit_cycle() {
    use rayon::prelude::*;
    let instr = Instrument::kearfott_2401();
    let freqs = [90.0, 100.0, 120.0, 260.0, 300.0, 380.0, 400.0];
    let sd: Vec<[f64; 2]> = freqs
        .par_iter()
        .map(|&f| {
            let mut c = Condition {
                kind: RowKind::Response,
                freq_hz: f,
                ..Condition::default()
            };
            c.lin_cm_s2[IA] = 2000.0;
            let runs: Vec<[f64; 2]> = (0..32)
                .map(|j| {
                    let o = SimOptions {
                        seed: 500 + j,
                        ..SimOptions::default()
                    };
                    response_of(&instr, &c, &Effects::NONE, &o)
                })
                .collect();
            let n = 32.0;
            let m = |k: usize| runs.iter().map(|r| r[k]).sum::<f64>() / n;
            let s = |k: usize| {
                let mk = m(k);
                (runs.iter().map(|r| (r[k] - mk).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
            };
            [s(0), s(1)]
        })
        .collect();
    eprintln!("frequency, Hz | one run's sd: gain, phase deg");
    for (f, s) in freqs.iter().zip(&sd) {
        eprintln!("{f:>13} | {:.5}, {:.3}", s[0], s[1]);
    }
    let phase = |f: f64| sd[freqs.iter().position(|&x| (x - f).abs() < 1e-9).unwrap()][1];
    assert!(phase(100.0) > 3.0 * phase(90.0).max(phase(120.0)), "{sd:?}");
    assert!(phase(300.0) > 3.0 * phase(260.0), "{sd:?}");
    assert!(phase(400.0) > 3.0 * phase(380.0), "{sd:?}");
}
