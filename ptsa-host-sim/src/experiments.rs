//! The report's test programme, each experiment as a function returning its tables and
//! plots ([`Output`]); `ptsa SUBCOMMAND` prints and writes them.

use std::f64::consts::TAU;

use rayon::prelude::*;

use crate::condition::{CaseInputs, Condition, Effects, IA, OA, PA};
use crate::design::{Cx, Design, loop_gain, margins};
use crate::fixtures::{self, TwoAxisKind};
use crate::instrument::Instrument;
use crate::output::{Cell, Output, Plot, Series, Table, num, text};
use crate::sim::{ClosedLoop, SimOptions, simulate_condition, simulate_difference};

/// Report figures that the experiments are compared with.
pub mod report {
    /// Section 6.1: scale factor, cm/s².
    pub const SF_CM_S2: f64 = 21121.1;
    /// Section 6.1: bias, cm/s².
    pub const BIAS_CM_S2: f64 = 18.7;
    /// Section 6.2: anisoinertia coefficient, cm.
    pub const K_AI_CM: f64 = 3.0;
    /// Section 6.2: anisoinertia `I_PA − I_IA`, g·cm².
    pub const ANISOINERTIA_G_CM2: f64 = 3.4;
    /// Table 6.1: IA position (deg) and `A_in` at 1.0 minus at 0.05 rad/s (cm/s²).
    pub const TABLE_6_1: [(f64, f64); 8] = [
        (45.0, 1.54),
        (90.0, 0.07),
        (135.0, -1.50),
        (180.0, -0.32),
        (225.0, 1.54),
        (270.0, 0.31),
        (315.0, -1.30),
        (360.0, 0.10),
    ];
    /// Table 6.2 (IA horizontal): Hz, mrad, static-dynamic difference cm/s² (None: system
    /// resonance, not measured).
    pub const TABLE_6_2: [(f64, Option<f64>, Option<f64>); 12] = [
        (1.0, Some(2.6), Some(-0.03)),
        (2.0, Some(4.4), Some(-0.07)),
        (5.0, None, None),
        (7.5, None, None),
        (10.0, None, None),
        (15.0, Some(4.0), Some(0.08)),
        (20.0, Some(2.0), Some(0.25)),
        (30.0, Some(1.0), Some(-0.21)),
        (50.0, Some(0.2), Some(0.31)),
        (60.0, Some(0.1), Some(-0.01)),
        (75.0, Some(0.1), Some(0.19)),
        (100.0, Some(0.1), Some(0.17)),
    ];
    /// Table 6.3 (IA vertical).
    pub const TABLE_6_3: [(f64, Option<f64>, Option<f64>); 10] = [
        (1.0, Some(9.0), Some(0.05)),
        (2.0, None, None),
        (5.0, None, None),
        (10.0, Some(10.0), Some(0.10)),
        (15.0, Some(3.3), Some(0.17)),
        (20.0, Some(2.0), Some(0.31)),
        (30.0, Some(1.0), Some(0.02)),
        (50.0, Some(0.2), Some(0.01)),
        (70.0, Some(0.1), Some(-0.14)),
        (100.0, Some(0.1), Some(-0.13)),
    ];
}

/// Tumble result: counts and eqs. 6.3/6.4.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tumble {
    /// Gate, ticks (`T`).
    pub ticks: u64,
    /// Pulses with IA up (`P1`).
    pub p1: u64,
    /// Pulses with IA down (`P2`).
    pub p2: u64,
    /// SF from the plain counts, eq. 6.3, cm/s².
    pub sf_count: f64,
    /// Bias from the plain counts, eq. 6.4, cm/s².
    pub bias_count: f64,
    /// `P1/T` from the charge-balance estimator (the count's limit), fraction.
    pub p1_frac: f64,
    /// `P2/T` likewise.
    pub p2_frac: f64,
    /// SF by eq. 6.3 from the estimator, cm/s².
    pub sf: f64,
    /// Bias by eq. 6.4 from the estimator, cm/s².
    pub bias: f64,
    /// The SF the simulation was configured with, cm/s².
    pub sf_configured: f64,
    /// The bias it was configured with (instrument A_b plus the loop's own), cm/s².
    pub bias_configured: f64,
}

/// Eqs. 6.3 and 6.4: `SF = g / (P1/T − P2/T)`, `A_b = SF·(P1/T + P2/T − 1)`.
#[must_use]
pub fn sf_and_bias(g: f64, p1_frac: f64, p2_frac: f64) -> (f64, f64) {
    let sf = g / (p1_frac - p2_frac);
    (sf, sf * (p1_frac + p2_frac - 1.0))
}

/// The ±1 g tumble of section 6.1 over a gate of `gate_s` seconds, and a sweep of IA
/// through 360° in the vertical plane.
#[must_use]
pub fn tumble(instr: &Instrument, opts: &SimOptions, gate_s: f64) -> (Tumble, Output) {
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let ticks = ((gate_s * instr.clock_hz / 64.0).round().max(1.0) * 64.0) as u64;
    let run = |up: bool| {
        let c = fixtures::dividing_head(if up { 90.0 } else { 270.0 });
        let mut l = ClosedLoop::new(instr, &c, &Effects::default(), opts);
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        l.run((opts.warmup_s * instr.clock_hz) as u64);
        l.measure(ticks)
    };
    let (up, down) = rayon::join(|| run(true), || run(false));
    let g = instr.g_cm_s2;
    #[allow(clippy::cast_precision_loss)]
    let (c1, c2) = (
        up.pulses as f64 / ticks as f64,
        down.pulses as f64 / ticks as f64,
    );
    let (sf_count, bias_count) = sf_and_bias(g, c1, c2);
    let sfc = instr.sf_cm_s2;
    let f1 = 0.5 * (1.0 + up.indicated_cm_s2 / sfc);
    let f2 = 0.5 * (1.0 + down.indicated_cm_s2 / sfc);
    let (sf, bias) = sf_and_bias(g, f1, f2);
    let t = Tumble {
        ticks,
        p1: up.pulses,
        p2: down.pulses,
        sf_count,
        bias_count,
        p1_frac: f1,
        p2_frac: f2,
        sf,
        bias,
        sf_configured: instr.actual_sf_cm_s2(),
        bias_configured: instr.bias_cm_s2 + instr.loop_bias_cm_s2(0.0),
    };
    let mut tab = Table::new(
        &format!("Tumble (section 6.1), gate T = {ticks} ticks ({gate_s} s)"),
        &[
            "quantity",
            "plain count",
            "charge balance",
            "configured",
            "report",
        ],
    );
    #[allow(clippy::cast_precision_loss)]
    let rows = vec![
        vec![
            text("P1 (IA up), pulses"),
            num(t.p1 as f64, 0),
            num(f1 * ticks as f64, 3),
            Cell::Missing,
            Cell::Missing,
        ],
        vec![
            text("P2 (IA down), pulses"),
            num(t.p2 as f64, 0),
            num(f2 * ticks as f64, 3),
            Cell::Missing,
            Cell::Missing,
        ],
        vec![
            text("SF, cm/s^2 (eq. 6.3)"),
            num(sf_count, 2),
            num(sf, 4),
            num(t.sf_configured, 4),
            num(report::SF_CM_S2, 1),
        ],
        vec![
            text("A_b, cm/s^2 (eq. 6.4)"),
            num(bias_count, 3),
            num(bias, 4),
            num(t.bias_configured, 4),
            num(report::BIAS_CM_S2, 1),
        ],
    ];
    tab.rows = rows;
    // Sweep of IA through 360°.
    let angles: Vec<f64> = (0..24).map(|k| f64::from(k) * 15.0).collect();
    let sweep: Vec<(f64, f64)> = angles
        .par_iter()
        .map(|&a| {
            (
                a,
                simulate_condition(
                    instr,
                    &fixtures::dividing_head(a),
                    &Effects::default(),
                    opts,
                )
                .indicated_cm_s2,
            )
        })
        .collect();
    let mut tab2 = Table::new(
        "Tumble sweep: IA angle above horizontal",
        &[
            "IA deg",
            "indicated cm/s^2",
            "g sin(phi) + A_b cm/s^2",
            "difference cm/s^2",
        ],
    );
    for &(a, x) in &sweep {
        let e = g * a.to_radians().sin() + t.bias_configured;
        tab2.rows
            .push(vec![num(a, 0), num(x, 4), num(e, 4), num(x - e, 5)]);
    }
    let plot = Plot {
        title: "Tumble: indicated acceleration vs IA angle".into(),
        x_label: "IA angle above horizontal, deg".into(),
        y_label: "indicated, cm/s^2".into(),
        series: vec![
            Series::line(
                "g sin(phi) + A_b",
                (0..=360)
                    .map(|a| {
                        (
                            f64::from(a),
                            g * f64::from(a).to_radians().sin() + t.bias_configured,
                        )
                    })
                    .collect(),
            ),
            Series::markers("simulated", sweep.clone()),
        ],
        log_x: false,
    };
    // What the first plot cannot show at its 2000 cm/s^2 scale: the loop's error.
    let residual = Plot {
        title: "Tumble: indicated − (g sin(phi) + A_b) vs IA angle".into(),
        x_label: "IA angle above horizontal, deg".into(),
        y_label: "indicated − expected, cm/s^2".into(),
        series: vec![Series::markers(
            "simulated − expected",
            sweep
                .iter()
                .map(|&(a, x)| (a, x - (g * a.to_radians().sin() + t.bias_configured)))
                .collect(),
        )],
        log_x: false,
    };
    let notes = vec![format!(
        "tumble: SF {:.4} cm/s^2 (configured {:.4}, error {:.3} ppm), A_b {:.5} cm/s^2 (configured {:.5}); plain {} s counts give SF {:.2}, A_b {:.3}",
        sf,
        t.sf_configured,
        (sf / t.sf_configured - 1.0) * 1e6,
        bias,
        t.bias_configured,
        gate_s,
        sf_count,
        bias_count
    )];
    (
        t,
        Output {
            name: "tumble".into(),
            tables: vec![tab, tab2],
            plots: vec![plot, residual],
            notes,
        },
    )
}

/// One row of the anisoinertia experiment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnisoRow {
    /// IA position, deg.
    pub ia_deg: f64,
    /// Report's `A_in` difference, cm/s².
    pub report: f64,
    /// Simulated with the report's anisoinertia, cm/s².
    pub simulated: f64,
    /// Simulated baseline (`I_PA = I_IA`), cm/s².
    pub baseline: f64,
    /// `(I_PA − I_IA)/(m l)·(w_IA w_PA at 1.0 − at 0.05 rad/s)`, cm/s².
    pub predicted: f64,
}

/// Table 6.1's procedure: eight IA positions on the dividing head, rate table at 1.0 and
/// 0.05 rad/s, eq. 6.5; with the instrument's anisoinertia set to `aniso_g_cm2` and with
/// the baseline (0).
#[must_use]
pub fn anisoinertia(
    instr: &Instrument,
    opts: &SimOptions,
    aniso_g_cm2: f64,
    lever_cm: [f64; 3],
) -> (Vec<AnisoRow>, f64, Output) {
    let mut with = instr.clone();
    with.anisoinertia_g_cm2 = aniso_g_cm2;
    let mut base = instr.clone();
    base.anisoinertia_g_cm2 = 0.0;
    let k = aniso_g_cm2 / instr.pendulosity_g_cm();
    let rows: Vec<AnisoRow> = report::TABLE_6_1
        .par_iter()
        .map(|&(deg, rep)| {
            let s = fixtures::rate_table(deg, 1.0, 0.05, lever_cm);
            let e = s.effects(&Effects::default());
            let sim = simulate_difference(&with, &s.cond, &e, opts).difference_cm_s2;
            let b = simulate_difference(&base, &s.cond, &e, opts).difference_cm_s2;
            let w1 = s.cond.w_rad_s;
            let w0 = s.cond.ref_w_rad_s;
            let pred = k * (w1[IA] * w1[PA] - w0[IA] * w0[PA]);
            AnisoRow {
                ia_deg: deg,
                report: rep,
                simulated: sim,
                baseline: b,
                predicted: pred,
            }
        })
        .collect();
    // Coefficient as the report derives it: mean |A_in| at the 45° positions over w_IA·w_PA.
    let diag: Vec<f64> = rows
        .iter()
        .filter(|r| (r.ia_deg % 90.0 - 45.0).abs() < 1e-9)
        .map(|r| r.simulated.abs())
        .collect();
    #[allow(clippy::cast_precision_loss)]
    let mean = diag.iter().sum::<f64>() / diag.len() as f64;
    let k_sim = mean / (0.5 - 0.05f64.powi(2) * 0.5);
    let mut t = Table::new(
        &format!(
            "Table 6.1: error due to anisoinertia (I_PA - I_IA = {aniso_g_cm2} g cm^2, k = {k:.3} cm)"
        ),
        &[
            "IA deg",
            "report cm/s^2",
            "simulated cm/s^2",
            "baseline cm/s^2",
            "k w_IA w_PA cm/s^2",
        ],
    );
    for r in &rows {
        t.rows.push(vec![
            num(r.ia_deg, 0),
            num(r.report, 2),
            num(r.simulated, 3),
            num(r.baseline, 3),
            num(r.predicted, 3),
        ]);
    }
    let rep_diag: Vec<f64> = report::TABLE_6_1
        .iter()
        .filter(|r| (r.0 % 90.0 - 45.0).abs() < 1e-9)
        .map(|r| r.1.abs())
        .collect();
    #[allow(clippy::cast_precision_loss)]
    let rep_mean = rep_diag.iter().sum::<f64>() / rep_diag.len() as f64;
    let plot = Plot {
        title: "Table 6.1: anisoinertia error vs IA position".into(),
        x_label: "IA position, deg".into(),
        y_label: "A_in(1.0 rad/s) - A_in(0.05 rad/s), cm/s^2".into(),
        series: vec![
            Series::line(
                "k w_IA w_PA",
                (0..=360)
                    .map(|a| {
                        let x = f64::from(a).to_radians();
                        (f64::from(a), k * (1.0 - 0.0025) * x.sin() * x.cos())
                    })
                    .collect(),
            ),
            Series::markers(
                "simulated",
                rows.iter().map(|r| (r.ia_deg, r.simulated)).collect(),
            ),
            Series::markers(
                "report",
                rows.iter().map(|r| (r.ia_deg, r.report)).collect(),
            ),
            Series::markers(
                "baseline (I_PA = I_IA)",
                rows.iter().map(|r| (r.ia_deg, r.baseline)).collect(),
            ),
        ],
        log_x: false,
    };
    let notes = vec![format!(
        "anisoinertia: mean |A_in| at 45-deg positions: simulated {mean:.3} cm/s^2 (report {rep_mean:.3}); coefficient {k_sim:.3} cm (configured {k:.3}, report {})",
        report::K_AI_CM
    )];
    (
        rows,
        k_sim,
        Output {
            name: "anisoinertia".into(),
            tables: vec![t],
            plots: vec![plot],
            notes,
        },
    )
}

/// One row of the OA-coupling experiment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OaRow {
    /// IA vertical (Table 6.3) or horizontal (Table 6.2).
    pub ia_vertical: bool,
    /// Frequency, Hz.
    pub freq_hz: f64,
    /// Amplitude, mrad (None: not measured, system resonance).
    pub amp_mrad: Option<f64>,
    /// Report's difference, cm/s².
    pub report: Option<f64>,
    /// Simulated static minus dynamic output (the report's column), cm/s².
    pub simulated: Option<f64>,
    /// Largest `|θ|` during the run, rad.
    pub theta_max_rad: Option<f64>,
}

/// Tables 6.2 and 6.3: single-axis oscillation about OA, IA horizontal then vertical; the
/// output at rest minus the steady-state output in oscillation (the report's "static-dynamic
/// output difference").
#[must_use]
pub fn oa_coupling(
    instr: &Instrument,
    opts: &SimOptions,
    lever_cm: [f64; 3],
) -> (Vec<OaRow>, Output) {
    let mut cases: Vec<(bool, f64, Option<f64>, Option<f64>)> = Vec::new();
    for r in report::TABLE_6_2 {
        cases.push((false, r.0, r.1, r.2));
    }
    for r in report::TABLE_6_3 {
        cases.push((true, r.0, r.1, r.2));
    }
    let rows: Vec<OaRow> = cases
        .par_iter()
        .map(|&(v, f, amp, rep)| {
            let (sim, th) = match amp {
                Some(a) => {
                    let s = fixtures::angular_oscillator(f, a, v, lever_cm);
                    let d =
                        simulate_difference(instr, &s.cond, &s.effects(&Effects::default()), opts);
                    (Some(-d.difference_cm_s2), Some(d.condition.theta_max_rad))
                }
                None => (None, None),
            };
            OaRow {
                ia_vertical: v,
                freq_hz: f,
                amp_mrad: amp,
                report: rep,
                simulated: sim,
                theta_max_rad: th,
            }
        })
        .collect();
    let mut tables = Vec::new();
    let mut plots = Vec::new();
    for (v, title) in [
        (false, "Table 6.2: OA coupling, IA horizontal"),
        (true, "Table 6.3: OA coupling, IA vertical"),
    ] {
        let mut t = Table::new(
            title,
            &[
                "freq Hz",
                "amp mrad",
                "report static-dynamic cm/s^2",
                "simulated static-dynamic cm/s^2",
                "max |theta| urad",
            ],
        );
        let opt = |x: Option<f64>, d: usize| x.map_or(Cell::Missing, |x| num(x, d));
        for r in rows.iter().filter(|r| r.ia_vertical == v) {
            t.rows.push(vec![
                num(r.freq_hz, 1),
                opt(r.amp_mrad, 1),
                opt(r.report, 2),
                opt(r.simulated, 4),
                opt(r.theta_max_rad.map(|x| x * 1e6), 1),
            ]);
        }
        tables.push(t);
        plots.push(Plot {
            title: title.into(),
            x_label: "frequency, Hz".into(),
            y_label: "static - dynamic output, cm/s^2".into(),
            series: vec![
                Series::markers(
                    "report",
                    rows.iter()
                        .filter(|r| r.ia_vertical == v)
                        .filter_map(|r| r.report.map(|x| (r.freq_hz, x)))
                        .collect(),
                ),
                Series::line(
                    "simulated",
                    rows.iter()
                        .filter(|r| r.ia_vertical == v)
                        .filter_map(|r| r.simulated.map(|x| (r.freq_hz, x)))
                        .collect(),
                ),
            ],
            log_x: true,
        });
    }
    let max_sim = rows
        .iter()
        .filter_map(|r| r.simulated)
        .fold(0.0f64, |m, x| m.max(x.abs()));
    let rms_rep = {
        let v: Vec<f64> = rows.iter().filter_map(|r| r.report).collect();
        #[allow(clippy::cast_precision_loss)]
        let n = v.len() as f64;
        (v.iter().map(|x| x * x).sum::<f64>() / n).sqrt()
    };
    let notes = vec![format!(
        "oa-coupling: largest simulated |difference| {max_sim:.4} cm/s^2; report's rows scatter with RMS {rms_rep:.3} cm/s^2 (test uncertainty 0.3): no rectified OA coupling, as the report concluded"
    )];
    (
        rows,
        Output {
            name: "oa-coupling".into(),
            tables,
            plots,
            notes,
        },
    )
}

/// Sine/cosine coefficients of the oscillating part of the inputs (the `inputs` of a
/// prepared condition are linear in `sin ωt`, `cos ωt`).
fn phasors(cond: &Condition) -> (CaseInputs, CaseInputs, CaseInputs) {
    let p = cond.prepare();
    let m = p.inputs(0.0, 0.0);
    let s = p.inputs(1.0, 0.0);
    let c = p.inputs(0.0, 1.0);
    (m, s, c)
}

/// Linear-model prediction of the rectified (DC) indicated error and its 2ω amplitude for a
/// two-axis condition: the pendulum's closed-loop response `θ = pend/(1 + L)·T` to the
/// oscillating torque `T = P·a_IA − I·dW_OA`, rectified by the cross-coupling torque
/// `−P·a_PA·θ` (eq. 4.2), plus the effect terms, averaged over a period.
#[must_use]
pub fn predict_rectified(instr: &Instrument, cond: &Condition, effects: &Effects) -> (f64, f64) {
    let f = cond.freq_hz;
    let (m, s, c) = phasors(cond);
    let p = instr.pendulosity_g_cm();
    // Torque phasor (sin-based: x(t) = Re(X e^{jωt}) with X = x_s − j x_c... we use
    // x(t) = x_s sin + x_c cos and the response H: sin → Re/Im rotation).
    let torque = |i: &CaseInputs, mean: bool| {
        let a = if mean {
            0.0
        } else {
            p * (i.a_cm_s2[IA] - m.a_cm_s2[IA])
        };
        a - instr.inertia_dyn_cm_s2 * i.dw_rad_s2[OA]
    };
    let ts = torque(&s, false);
    let tc = torque(&c, false);
    // x(t) = Re(X e^{jωt}) with X = x_c − j x_s.
    let x = Cx::new(tc, -ts);
    let w = TAU * f;
    let jw = Cx::new(0.0, w);
    let pend = Cx::new(1.0, 0.0)
        / (jw * jw * Cx::new(instr.inertia_dyn_cm_s2, 0.0)
            + jw * Cx::new(instr.damping_dyn_cm_s, 0.0)
            + Cx::new(instr.spring_dyn_cm_rad, 0.0));
    let l = loop_gain(instr, &ptsa_core::Config::DEFAULT, f);
    let th = pend / (Cx::new(1.0, 0.0) + l) * x;
    // θ(t) = th_c cos + th_s sin with th_c = Re(th), th_s = −Im(th).
    let (th_c, th_s) = (th.re, -th.im);
    let n = 64;
    let mut dc = 0.0;
    let (mut h_s, mut h_c) = (0.0, 0.0);
    for k in 0..n {
        let ph = TAU * f64::from(k) / f64::from(n);
        let (sn, cs) = ph.sin_cos();
        let i = cond.prepare().inputs(sn, cs);
        let theta = th_s * sn + th_c * cs;
        let v = -(i.a_cm_s2[PA]) * theta + effects.indicated_cm_s2(&i);
        dc += v;
        let (s2, c2) = (2.0 * ph).sin_cos();
        h_s += v * s2;
        h_c += v * c2;
    }
    let nf = f64::from(n);
    // The static part of −a_PA·θ has zero mean (θ oscillates); the effects' static part is
    // cancelled by the reference in a difference, so remove it here.
    let static_eff = effects.indicated_cm_s2(&m);
    (dc / nf - static_eff, 2.0 * h_s.hypot(h_c) / nf)
}

/// Appendix A sweep over the phase ψ for one set-up.
#[must_use]
#[allow(clippy::too_many_arguments)]
pub fn appendix_a(
    instr: &Instrument,
    opts: &SimOptions,
    kind: TwoAxisKind,
    freq_hz: f64,
    theta_my_mrad: f64,
    theta_mz_mrad: f64,
    r_cm: f64,
    effects: &Effects,
) -> Output {
    let psis: Vec<f64> = (0..=12).map(|k| f64::from(k) * 15.0).collect();
    let o = SimOptions {
        harmonic: 2,
        ..*opts
    };
    let rows: Vec<(f64, f64, f64, f64, f64, Condition)> = psis
        .par_iter()
        .map(|&psi| {
            let c = fixtures::two_axis(kind, freq_hz, theta_my_mrad, theta_mz_mrad, psi, r_cm);
            let d = simulate_difference(instr, &c, effects, &o);
            let (pdc, p2) = predict_rectified(instr, &c, effects);
            (
                psi,
                d.difference_cm_s2,
                d.condition.harmonic_torque_amp_cm_s2,
                pdc,
                p2,
                c,
            )
        })
        .collect();
    let name = match kind {
        TwoAxisKind::Vibropendulous => "vibropendulosity",
        TwoAxisKind::Anisoelastic => "anisoelasticity",
        TwoAxisKind::Sculling => "sculling",
    };
    let c0 = &rows[0].5;
    let mut t = Table::new(
        &format!(
            "Appendix A, {name}: {freq_hz} Hz, theta_my {theta_my_mrad} mrad, theta_mz {theta_mz_mrad} mrad, r {r_cm} cm (a_IA {:.1}, a_PA {:.1}, a_OA {:.1} cm/s^2 amplitude)",
            c0.lin_cm_s2[IA], c0.lin_cm_s2[PA], c0.lin_cm_s2[OA]
        ),
        &[
            "psi deg",
            "simulated DC cm/s^2",
            "predicted DC cm/s^2",
            "simulated 2w amp (torque) cm/s^2",
            "predicted 2w amp cm/s^2",
        ],
    );
    for r in &rows {
        t.rows.push(vec![
            num(r.0, 0),
            num(r.1, 4),
            num(r.3, 4),
            num(r.2, 4),
            num(r.4, 4),
        ]);
    }
    let plot = Plot {
        title: format!("Appendix A: {name}, rectified error vs phase"),
        x_label: "phase psi, deg".into(),
        y_label: "rectified error, cm/s^2".into(),
        series: vec![
            Series::line(
                "predicted (linear loop model)",
                rows.iter().map(|r| (r.0, r.3)).collect(),
            ),
            Series::markers(
                "simulated (closed loop)",
                rows.iter().map(|r| (r.0, r.1)).collect(),
            ),
        ],
        log_x: false,
    };
    let worst = rows.iter().map(|r| (r.1 - r.3).abs()).fold(0.0, f64::max);
    let notes = vec![format!(
        "{name}: largest |simulated - predicted| rectified error {worst:.4} cm/s^2"
    )];
    Output {
        name: name.into(),
        tables: vec![t],
        plots: vec![plot],
        notes,
    }
}

/// Waveforms (Fig. 3.2) for a constant input, and the small-signal frequency response
/// measured by simulation against the linear model `L/(1 + L)`.
#[must_use]
pub fn waveform(instr: &Instrument, opts: &SimOptions, accel_cm_s2: f64, cycles: u64) -> Output {
    let cond = Condition {
        g: [accel_cm_s2 / instr.g_cm_s2, 0.0, 0.0],
        ..Condition::default()
    };
    let mut l = ClosedLoop::new(instr, &cond, &Effects::default(), opts);
    l.run(6400);
    let t_us = 1e6 / instr.clock_hz;
    let mut trace = Table::new(
        &format!("Waveform: {accel_cm_s2} cm/s^2 along IA, {cycles} limit cycles"),
        &[
            "t us",
            "command",
            "current mA",
            "pulse",
            "theta urad",
            "ADC code",
        ],
    );
    let mut cur = Vec::new();
    let mut cmd = Vec::new();
    let mut th = Vec::new();
    let k0 = l.ticks();
    let i_fs = instr.full_current_ma;
    // Sub-sample the current inside each tick for the plot (exact first-order rise).
    let a = (-1.0 / (instr.clock_hz * instr.torquer_tau_s)).exp();
    let mut prev_i = l.state()[2];
    l.run_observed(cycles * 64, |v| {
        #[allow(clippy::cast_precision_loss)]
        let t = (v.k - k0) as f64 * t_us;
        for s in 0..8 {
            let frac = f64::from(s) / 8.0;
            let decay = a.powf(frac);
            let i = v.u + (prev_i - v.u) * decay;
            cur.push((t + frac * t_us, i * i_fs));
        }
        prev_i = v.x[2];
        cmd.push((t, v.u * i_fs));
        cmd.push((t + t_us, v.u * i_fs));
        th.push((t + t_us, v.x[0] * 1e6));
        trace.rows.push(vec![
            num(t, 3),
            num(v.u, 0),
            num(v.x[2] * i_fs, 4),
            num(if v.u > 0.0 { 1.0 } else { 0.0 }, 0),
            num(v.x[0] * 1e6, 3),
            num(f64::from(v.code), 0),
        ]);
    });
    // Frequency response: 10 cm/s² sine along IA, component of the pulse output at f.
    let freqs = [
        1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 150.0, 200.0, 300.0, 400.0,
    ];
    let amp = 2000.0;
    let o = SimOptions {
        harmonic: 1,
        min_window_s: 1.0,
        ..*opts
    };
    let resp: Vec<(f64, f64, f64, f64, f64)> = freqs
        .par_iter()
        .map(|&f| {
            let mut c = Condition {
                freq_hz: f,
                ..Condition::default()
            };
            c.lin_cm_s2[IA] = amp;
            let r = simulate_condition(instr, &c, &Effects::default(), &o);
            let l = loop_gain(instr, &opts.config, f);
            let h = l / (Cx::new(1.0, 0.0) + l);
            (
                f,
                20.0 * (r.harmonic_amp_cm_s2 / amp).log10(),
                r.harmonic_deg,
                20.0 * h.abs().log10(),
                h.arg().to_degrees(),
            )
        })
        .collect();
    let mut ft = Table::new(
        "Small-signal frequency response of the pulse output, indicated / input (2000 cm/s^2 sine along IA, 1 s windows; smaller inputs see the 1-count dead band)",
        &[
            "freq Hz",
            "simulated dB",
            "simulated deg",
            "model dB",
            "model deg",
        ],
    );
    for r in &resp {
        ft.rows.push(vec![
            num(r.0, 0),
            num(r.1, 2),
            num(r.2, 1),
            num(r.3, 2),
            num(r.4, 1),
        ]);
    }
    // The limit cycle across and beyond the range (no bias, 1 s windows).
    let mut nb = instr.clone();
    nb.bias_cm_s2 = 0.0;
    let fracs = [
        0.0, 0.5, 0.9, 0.95, 0.96875, 0.975, 0.985, 0.994, 1.0, 1.05, 1.3,
    ];
    let lc: Vec<(f64, crate::sim::SimResult)> = fracs
        .par_iter()
        .map(|&fr| {
            let a = fr * nb.sf_cm_s2;
            let c = Condition {
                g: [a / nb.g_cm_s2, 0.0, 0.0],
                ..Condition::default()
            };
            (
                a,
                simulate_condition(
                    &nb,
                    &c,
                    &Effects::default(),
                    &SimOptions {
                        min_window_s: 1.0,
                        ..*opts
                    },
                ),
            )
        })
        .collect();
    let mut lt = Table::new(
        "Limit cycle across the range (no bias, 1 s windows): cycles with two reversals, pendulum excursion, plain count and estimate",
        &[
            "input cm/s^2",
            "fraction of SF",
            "cycles",
            "2 reversals",
            "max |theta| urad",
            "stop ticks",
            "1 s count cm/s^2",
            "estimate cm/s^2",
        ],
    );
    for (a, r) in &lc {
        #[allow(clippy::cast_precision_loss)]
        lt.rows.push(vec![
            num(*a, 1),
            num(a / nb.sf_cm_s2, 5),
            num(r.cycles as f64, 0),
            num(r.cycles_two_reversals as f64, 0),
            num(r.theta_max_rad * 1e6, 1),
            num(r.stop_ticks as f64, 0),
            num(r.count_cm_s2, 3),
            num(r.indicated_cm_s2, 4),
        ]);
    }
    let m = margins(instr, &opts.config);
    let notes = vec![format!(
        "waveform: loop crossover {:.1} Hz, phase margin {:.1} deg, gain margin {:.1} dB (linear model)",
        m.crossover_hz, m.phase_margin_deg, m.gain_margin_db
    )];
    let p1 = Plot {
        title: format!("Fig. 3.2: torquer current and pulse train, {accel_cm_s2} cm/s^2"),
        x_label: "time, us".into(),
        y_label: "current, mA / pendulum angle, urad".into(),
        series: vec![
            Series::line("torquer current, mA", cur),
            Series::line("command (pulse train), mA", cmd),
            Series::line("theta, urad", th),
        ],
        log_x: false,
    };
    let p2 = Plot {
        title: "Closed-loop frequency response (indicated / input)".into(),
        x_label: "frequency, Hz".into(),
        y_label: "gain, dB".into(),
        series: vec![
            Series::line("model L/(1+L)", resp.iter().map(|r| (r.0, r.3)).collect()),
            Series::markers("simulated", resp.iter().map(|r| (r.0, r.1)).collect()),
        ],
        log_x: true,
    };
    Output {
        name: "waveform".into(),
        tables: vec![ft, trace, lt],
        plots: vec![p1, p2],
        notes,
    }
}

/// Monte Carlo over the tolerance box: every corner of the box (all toleranced parameters
/// at a limit) when there are at most 14 of them, else `samples` random corners; margins of
/// the linearised loop for each, and a closed-loop check of the worst ones.
#[must_use]
pub fn monte_carlo(instr: &Instrument, opts: &SimOptions, samples: usize) -> (f64, f64, Output) {
    let tol = instr.tolerances.clone();
    let n = tol.len();
    let corners: Vec<u64> = if n <= 14 {
        (0..(1u64 << n)).collect()
    } else {
        let mut x = opts.seed | 1;
        (0..samples)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                x
            })
            .collect()
    };
    let build = |bits: u64| {
        let mut i = instr.clone();
        for (k, t) in tol.iter().enumerate() {
            let v = if bits >> k & 1 == 1 { t.hi } else { t.lo };
            let _ = i.set(t.key, v);
        }
        i
    };
    let mut res: Vec<(u64, f64, f64, f64)> = corners
        .par_iter()
        .map(|&b| {
            let m = margins(&build(b), &opts.config);
            (b, m.phase_margin_deg, m.gain_margin_db, m.crossover_hz)
        })
        .collect();
    res.sort_by(|a, b| a.1.total_cmp(&b.1));
    let worst_pm = res.first().map_or(f64::NAN, |r| r.1);
    let worst_gm = res.iter().map(|r| r.2).fold(f64::INFINITY, f64::min);
    // Closed-loop check of the 8 worst corners: 0.5 g and 0.9 FS inputs.
    let check: Vec<(u64, f64, f64, bool)> = res
        .iter()
        .take(8)
        .collect::<Vec<_>>()
        .par_iter()
        .map(|r| {
            let i = build(r.0);
            let a = 0.9 * i.actual_sf_cm_s2() - i.bias_cm_s2;
            let c = Condition {
                g: [a / i.g_cm_s2, 0.0, 0.0],
                ..Condition::default()
            };
            let s = simulate_condition(&i, &c, &Effects::default(), opts);
            let ok = s.cycles == s.cycles_two_reversals && s.stop_ticks == 0;
            (
                r.0,
                s.indicated_cm_s2 - (a + i.bias_cm_s2 + i.loop_bias_cm_s2(0.0)),
                s.theta_max_rad,
                ok,
            )
        })
        .collect();
    let mut t = Table::new(
        &format!(
            "Monte Carlo over the Table 2.1 tolerance box: {} corners, worst 8",
            res.len()
        ),
        &[
            "corner",
            "phase margin deg",
            "gain margin dB",
            "crossover Hz",
            "closed loop at 0.9 FS",
            "error cm/s^2",
            "max |theta| urad",
        ],
    );
    for (r, c) in res.iter().zip(&check) {
        t.rows.push(vec![
            text(format!("{:#06x}", r.0)),
            num(r.1, 2),
            num(r.2, 2),
            num(r.3, 1),
            text(if c.3 { "2 reversals/cycle" } else { "FAILED" }),
            num(c.1, 4),
            num(c.2 * 1e6, 1),
        ]);
    }
    let mut keys = Table::new(
        "Corner bits (bit k set = parameter k at its upper limit)",
        &["bit", "parameter", "low", "nominal", "high"],
    );
    for (k, tl) in tol.iter().enumerate() {
        keys.rows.push(vec![
            num(f64::from(u32::try_from(k).unwrap_or(0)), 0),
            text(tl.key),
            num(tl.lo, 4),
            num(tl.nominal, 4),
            num(tl.hi, 4),
        ]);
    }
    #[allow(clippy::cast_precision_loss)]
    let hist: Vec<(f64, f64)> = res
        .iter()
        .enumerate()
        .map(|(k, r)| (k as f64, r.1))
        .collect();
    let nominal = margins(instr, &opts.config);
    let notes = vec![format!(
        "monte-carlo: {} corners; worst phase margin {worst_pm:.2} deg, worst gain margin {worst_gm:.2} dB (nominal {:.2} deg, {:.2} dB at {:.1} Hz); closed loop of the 8 worst corners: {}",
        res.len(),
        nominal.phase_margin_deg,
        nominal.gain_margin_db,
        nominal.crossover_hz,
        if check.iter().all(|c| c.3) {
            "all stable, two reversals per cycle"
        } else {
            "SOME FAILED"
        }
    )];
    let plot = Plot {
        title: "Phase margin over the tolerance-box corners (sorted)".into(),
        x_label: "corner rank".into(),
        y_label: "phase margin, deg".into(),
        series: vec![Series::line("phase margin", hist)],
        log_x: false,
    };
    (
        worst_pm,
        worst_gm,
        Output {
            name: "monte-carlo".into(),
            tables: vec![t, keys],
            plots: vec![plot],
            notes,
        },
    )
}

/// The design (text) for an instrument.
#[must_use]
pub fn design_text(instr: &Instrument) -> String {
    let d = Design::for_instrument(instr);
    let m = margins(instr, &d.config());
    format!(
        "{d}  margins (linearised loop incl. delay, current lag, demodulator): crossover {:.1} Hz, phase margin {:.1} deg, gain margin {:.1} dB\n",
        m.crossover_hz, m.phase_margin_deg, m.gain_margin_db
    )
}
