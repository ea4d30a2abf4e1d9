//! The report's experiments reproduce what the simulation was configured with.

use ptsa_host_sim::experiments::{self, report};
use ptsa_host_sim::fixtures::TwoAxisKind;
use ptsa_host_sim::{Effects, Instrument, SimOptions};

/// The tumble (eqs. 6.3/6.4 on the charge-balance counts) recovers the configured SF to
/// 1 ppm and bias to 0.01 cm/s², for the shipped instrument and for one with a different
/// torquer (so SF ≠ 21121.1), another bias, and the loop's own bias from a quadrature leak.
#[test]
fn tumble_recovers_configured_sf_and_bias() {
    let nominal = Instrument::kearfott_2401();
    let mut odd = nominal.clone();
    odd.set("torquer.current_scale_factor_ma_per_g", 1.01)
        .unwrap();
    odd.set("pickoff.phase_angle_deg", 10.0).unwrap();
    odd.bias_cm_s2 = -7.25;
    assert!(
        odd.loop_bias_cm_s2(0.0).abs() > 1e-3,
        "the leak must give a loop bias"
    );
    for (instr, seed) in [(nominal, 1), (odd, 7)] {
        let opts = SimOptions {
            seed,
            ..SimOptions::default()
        };
        let (t, _) = experiments::tumble(&instr, &opts, 1.0);
        let sf_ppm = (t.sf / t.sf_configured - 1.0) * 1e6;
        assert!(
            sf_ppm.abs() < 1.0,
            "SF {} vs {}: {sf_ppm} ppm",
            t.sf,
            t.sf_configured
        );
        assert!(
            (t.bias - t.bias_configured).abs() < 0.01,
            "bias {} vs {}",
            t.bias,
            t.bias_configured
        );
        // The plain 1 s counts are within their resolution (one pulse in ~3000 for SF).
        assert!((t.sf_count / t.sf_configured - 1.0).abs() < 2.0 / 2900.0);
    }
}

/// Table 6.1: with the report's anisoinertia the table follows k·w_IA·w_PA; the baseline
/// (I_PA = I_IA, CG on the axis) shows nothing.
#[test]
fn anisoinertia_table_follows_the_coefficient() {
    let i = Instrument::kearfott_2401();
    let (rows, k, _) = experiments::anisoinertia(
        &i,
        &SimOptions::default(),
        report::ANISOINERTIA_G_CM2,
        [0.0; 3],
    );
    for r in &rows {
        assert!((r.simulated - r.predicted).abs() < 0.01, "{r:?}");
        assert!(r.baseline.abs() < 0.01, "{r:?}");
    }
    assert!(
        (k - report::ANISOINERTIA_G_CM2 / i.pendulosity_g_cm()).abs() < 0.01,
        "{k}"
    );
    assert!((k - report::K_AI_CM).abs() < 0.1);
}

/// Tables 6.2/6.3: no rectified OA coupling.
#[test]
fn oa_coupling_is_null() {
    let (rows, _) = experiments::oa_coupling(
        &Instrument::kearfott_2401(),
        &SimOptions::default(),
        [0.0; 3],
    );
    assert_eq!(rows.iter().filter(|r| r.simulated.is_some()).count(), 17);
    for r in rows.iter().filter_map(|r| r.simulated) {
        assert!(r.abs() < 0.01, "{r}");
    }
}

/// Appendix A: the closed loop's rectified error follows the linear loop model (within the
/// model's neglect of the quantizer) and an injected anisoelastic coefficient shows up at
/// k·a_IA·a_OA/2·cos(Δφ).
#[test]
fn appendix_a_follows_the_linear_model() {
    let i = Instrument::kearfott_2401();
    let o = SimOptions::default();
    let out = experiments::appendix_a(
        &i,
        &o,
        TwoAxisKind::Vibropendulous,
        100.0,
        1.0,
        1.0,
        10.0,
        &Effects::default(),
    );
    let t = &out.tables[0];
    for row in &t.rows {
        let (ptsa_host_sim::output::Cell::Num(sim, _), ptsa_host_sim::output::Cell::Num(pred, _)) =
            (&row[1], &row[2])
        else {
            panic!("numbers expected");
        };
        assert!(
            (sim - pred).abs() < 0.2 * pred.abs() + 0.015,
            "{sim} vs {pred}"
        );
    }
    let e = Effects {
        k_io_s2_cm: 1e-5,
        ..Effects::default()
    };
    let out = experiments::appendix_a(&i, &o, TwoAxisKind::Anisoelastic, 100.0, 1.0, 1.0, 10.0, &e);
    for row in &out.tables[0].rows {
        let (ptsa_host_sim::output::Cell::Num(sim, _), ptsa_host_sim::output::Cell::Num(pred, _)) =
            (&row[1], &row[2])
        else {
            panic!("numbers expected");
        };
        assert!(
            (sim - pred).abs() < 0.01 + 0.01 * pred.abs(),
            "{sim} vs {pred}"
        );
    }
}

/// Monte Carlo over every corner of the tolerance box: the loop keeps healthy margins and
/// the worst corners run two reversals per cycle.
#[test]
fn tolerance_box_is_stable() {
    let i = Instrument::kearfott_2401();
    let (pm, gm, out) = experiments::monte_carlo(&i, &SimOptions::default(), 256);
    println!("{}", out.notes.join("\n"));
    assert!(pm > 45.0, "worst phase margin {pm}");
    assert!(gm > 10.0, "worst gain margin {gm}");
    assert!(out.notes[0].contains("all stable"), "{}", out.notes[0]);
}

/// Tables, CSV and plots are written (atomically, no temporary files left behind).
#[test]
fn outputs_are_written() {
    let dir = std::env::temp_dir().join(format!("ptsa-out-test-{}", std::process::id()));
    let (_, out) = experiments::oa_coupling(
        &Instrument::kearfott_2401(),
        &SimOptions {
            min_window_s: 0.02,
            warmup_s: 0.02,
            ..SimOptions::default()
        },
        [0.0; 3],
    );
    let files = out.emit(&dir, false).unwrap();
    assert!(
        files
            .iter()
            .any(|f| f.extension().is_some_and(|e| e == "csv"))
    );
    for f in &files {
        assert!(std::fs::metadata(f).unwrap().len() > 0, "{}", f.display());
    }
    let csv = std::fs::read_to_string(dir.join("oa-coupling.csv")).unwrap();
    assert!(csv.starts_with("freq Hz,amp mrad,report static-dynamic cm/s^2"));
    assert!(csv.contains("5,,,,"), "missing rows stay empty: {csv}");
    let leftovers = std::fs::read_dir(&dir)
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .contains(".tmp")
        })
        .count();
    assert_eq!(leftovers, 0);
    let _ = std::fs::remove_dir_all(&dir);
}
