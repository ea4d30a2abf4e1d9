//! The report's experiments reproduce what the simulation was configured with.

use ptsa_host_sim::lab::fixtures::TwoAxisKind;
use ptsa_host_sim::report::experiments::appendix_a::{self, TwoAxisPlan};
use ptsa_host_sim::report::experiments::{anisoinertia, monte_carlo, oa_coupling, tumble};
use ptsa_host_sim::report::r890;
use ptsa_host_sim::{CandidateId, Effects, Instrument, SimOptions};

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
        let t = tumble::run(&instr, &opts, 1.0).unwrap().tumble;
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

/// Table 6.1: with the report's anisoinertia the table follows `k·w_IA·w_PA`; the baseline
/// (`I_PA = I_IA`, CG on the axis) shows nothing.
#[test]
fn anisoinertia_table_follows_the_coefficient() {
    let i = Instrument::kearfott_2401();
    let s62 = r890::section_6_2().unwrap();
    let r =
        anisoinertia::run(&i, &SimOptions::default(), s62.anisoinertia_g_cm2, [0.0; 3]).unwrap();
    for row in &r.rows {
        assert!((row.simulated - row.predicted).abs() < 0.01, "{row:?}");
        assert!(row.baseline.abs() < 0.01, "{row:?}");
    }
    let k = r.k_simulated_cm;
    assert!(
        (k - s62.anisoinertia_g_cm2 / i.pendulosity_g_cm()).abs() < 0.01,
        "{k}"
    );
    assert!((k - s62.coefficient_cm).abs() < 0.1);
    // A negative I_PA − I_IA gives a negative coefficient (the report's magnitudes lose the
    // sign; the simulated rows' correlation with w_IA·w_PA keeps it).
    let r = anisoinertia::run(&i, &SimOptions::default(), -3.4, [0.0; 3]).unwrap();
    let k = r.k_simulated_cm;
    assert!((k + 3.4 / i.pendulosity_g_cm()).abs() < 0.01, "{k}");
}

/// Tables 6.2/6.3: no rectified OA coupling.
#[test]
fn oa_coupling_is_null() {
    let r = oa_coupling::run(
        &Instrument::kearfott_2401(),
        &SimOptions::default(),
        [0.0; 3],
    )
    .unwrap();
    assert_eq!(r.rows.iter().filter(|r| r.simulated.is_some()).count(), 17);
    for x in r.rows.iter().filter_map(|r| r.simulated) {
        assert!(x.abs() < 0.01, "{x}");
    }
    // The report's values are shown as dynamic − static (negated).
    assert_eq!(r.rows[0].report, Some(0.03));
}

/// Appendix A: the closed loop's rectified error follows the linear loop model (within the
/// model's neglect of the quantizer) and an injected anisoelastic coefficient shows up at
/// `k·a_IA·a_OA/2·cos(Δφ)`.
#[test]
fn appendix_a_follows_the_linear_model() {
    let i = Instrument::kearfott_2401();
    let o = SimOptions::default();
    let r = appendix_a::run(&i, &o, &TwoAxisPlan::report(TwoAxisKind::Vibropendulous)).unwrap();
    for row in &r.rows {
        let (sim, pred) = (row.simulated_dc, row.predicted_dc);
        assert!(
            (sim - pred).abs() < 0.2 * pred.abs() + 0.015,
            "{sim} vs {pred}"
        );
    }
    let plan = TwoAxisPlan {
        effects: Effects::only(CandidateId::Anisoelasticity, 1e-5),
        ..TwoAxisPlan::report(TwoAxisKind::Anisoelastic)
    };
    let r = appendix_a::run(&i, &o, &plan).unwrap();
    for row in &r.rows {
        let (sim, pred) = (row.simulated_dc, row.predicted_dc);
        assert!(
            pred.abs() > 0.05 || (row.psi_deg - 90.0).abs() < 1e-9,
            "{pred}"
        );
        assert!(
            (sim - pred).abs() < 0.01 + 0.01 * pred.abs(),
            "{sim} vs {pred}"
        );
    }
}

/// Monte Carlo over every corner of the tolerance box: the loop keeps healthy margins, the
/// worst corners run two reversals per cycle, and what they indicate beyond the input is
/// their scale-factor change.
#[test]
fn tolerance_box_is_stable() {
    let i = Instrument::kearfott_2401();
    let r = monte_carlo::run(&i, &SimOptions::default(), 256).unwrap();
    println!("{}", r.output.notes.join("\n"));
    assert!(
        r.worst_phase_margin_deg > 45.0,
        "{}",
        r.worst_phase_margin_deg
    );
    assert!(r.worst_gain_margin_db > 10.0, "{}", r.worst_gain_margin_db);
    assert!(
        r.output.notes[0].contains("all stable"),
        "{}",
        r.output.notes[0]
    );
    for c in &r.checks {
        assert!(c.error_cm_s2.abs() > 1.0, "{c:?}");
        assert!(c.residual_cm_s2.abs() < 0.01, "{c:?}");
    }
}

/// Tables, CSV and plots are written under names that say what they hold (atomically, no
/// temporary files left behind).
#[test]
fn outputs_are_written() {
    let dir = tempfile::tempdir().unwrap();
    let r = oa_coupling::run(
        &Instrument::kearfott_2401(),
        &SimOptions {
            min_window_s: 0.02,
            warmup_s: 0.02,
            ..SimOptions::default()
        },
        [0.0; 3],
    )
    .unwrap();
    let files = r.output.write_files(dir.path()).unwrap();
    assert_eq!(files.len(), 6, "{files:?}");
    for f in &files {
        assert!(std::fs::metadata(f).unwrap().len() > 0, "{}", f.display());
    }
    let csv = std::fs::read_to_string(dir.path().join("oa-coupling-table-6-2.csv")).unwrap();
    assert!(csv.starts_with("freq Hz,amp mrad,report dynamic-static cm/s^2"));
    assert!(csv.contains("5,,,,"), "missing rows stay empty: {csv}");
    assert!(dir.path().join("oa-coupling-table-6-3.svg").exists());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 6);
}

/// The limit-cycle figure shows the errors within the range on their own axis (a few
/// cm/s² at most) and the saturated inputs beyond full scale (errors of thousands of cm/s²)
/// in a second panel, so that they do not squash the first.
#[test]
fn limit_cycle_figure_keeps_saturated_points_on_their_own_axis() {
    use ptsa_host_sim::report::experiments::limit_cycle;
    let r = limit_cycle::run(
        &Instrument::kearfott_2401(),
        &SimOptions {
            warmup_s: 0.02,
            ..SimOptions::default()
        },
    )
    .unwrap();
    let fig = &r.output.plots[0];
    assert_eq!(fig.panels.len(), 2, "{fig:?}");
    let points = |k: usize| -> Vec<(f64, f64)> {
        fig.panels[k]
            .series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .collect()
    };
    let (within, beyond) = (points(0), points(1));
    assert!(!within.is_empty() && !beyond.is_empty());
    assert!(
        within.iter().all(|p| p.0 <= 1.0 && p.1.abs() < 100.0),
        "{within:?}"
    );
    assert!(
        beyond.iter().all(|p| p.0 > 1.0 && p.1.abs() > 500.0),
        "{beyond:?}"
    );
    assert_eq!(
        within.len() + beyond.len(),
        2 * limit_cycle::FRACTIONS.len()
    );
}
