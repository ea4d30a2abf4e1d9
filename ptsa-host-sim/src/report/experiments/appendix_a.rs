//! Appendix A: the multi-axis test plan on the two-axis oscillator: vibropendulosity
//! (Fig. A.2), anisoelasticity (Fig. A.4) and sculling (Fig. A.5), each as a sweep of the
//! phase ψ between the two axes, against a linear-model prediction.

use std::f64::consts::TAU;

use anyhow::Result;
use rayon::prelude::*;

use crate::lab::fixtures::{self, TwoAxisKind};
use crate::model::condition::{CaseInputs, Condition, IA, OA, PA};
use crate::model::design::{Cx, loop_gain, pendulum};
use crate::model::effects::Effects;
use crate::model::instrument::Instrument;
use crate::output::{Figure, Output, Plot, Series, Table, num};
use crate::report::{Experiment, Finding, Setup, Sink, ticks_only};
use crate::simulation::sim::{SimOptions, simulate_difference};
use crate::simulation::work::Estimate;

/// The set-up of one Appendix A sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwoAxisPlan {
    /// Which figure's set-up.
    pub kind: TwoAxisKind,
    /// Oscillation frequency, Hz.
    pub freq_hz: f64,
    /// Y-axis amplitude `θ_my`, mrad.
    pub theta_my_mrad: f64,
    /// Z-axis amplitude `θ_mz`, mrad.
    pub theta_mz_mrad: f64,
    /// Radius of the proof mass from the oscillator axes, cm.
    pub r_cm: f64,
    /// Effects put into the simulated instrument (the model has none by itself).
    pub effects: Effects,
}

impl TwoAxisPlan {
    /// Default frequency, Hz.
    pub const FREQ_HZ: f64 = 100.0;
    /// Default amplitude of each axis, mrad.
    pub const THETA_MRAD: f64 = 1.0;
    /// Default radius, cm.
    pub const R_CM: f64 = 10.0;

    /// The plan the report's programme runs for `kind`: 100 Hz, 1 mrad on each axis, 10 cm,
    /// no effects.
    #[must_use]
    pub fn report(kind: TwoAxisKind) -> Self {
        Self {
            kind,
            freq_hz: Self::FREQ_HZ,
            theta_my_mrad: Self::THETA_MRAD,
            theta_mz_mrad: Self::THETA_MRAD,
            r_cm: Self::R_CM,
            effects: Effects::NONE,
        }
    }
}

/// One phase of the sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct PhaseRow {
    /// Phase ψ, deg.
    pub psi_deg: f64,
    /// Simulated rectified (DC) error, condition − reference, cm/s².
    pub simulated_dc: f64,
    /// Simulated 2ω amplitude of the rebalanced torque over `P`, cm/s².
    pub simulated_2w: f64,
    /// Linear-model DC prediction, cm/s².
    pub predicted_dc: f64,
    /// Linear-model 2ω amplitude, cm/s².
    pub predicted_2w: f64,
    /// The row's condition.
    pub condition: Condition,
}

/// What [`run`] returns.
#[derive(Clone, Debug, PartialEq)]
pub struct AppendixRun {
    /// Rows, ψ = 0°, 15°, …, 180°.
    pub rows: Vec<PhaseRow>,
    /// Largest |simulated − predicted| DC error, cm/s².
    pub worst_dc: f64,
    /// Tables, figures, notes.
    pub output: Output,
}

/// The name of a set-up's effect (and of its files).
#[must_use]
pub fn name(kind: TwoAxisKind) -> &'static str {
    match kind {
        TwoAxisKind::Vibropendulous => "vibropendulosity",
        TwoAxisKind::Anisoelastic => "anisoelasticity",
        TwoAxisKind::Sculling => "sculling",
    }
}

/// The set-up's condition at phase `psi`, deg.
fn condition(plan: &TwoAxisPlan, psi: f64) -> crate::Condition {
    fixtures::two_axis(
        plan.kind,
        plan.freq_hz,
        plan.theta_my_mrad,
        plan.theta_mz_mrad,
        psi,
        plan.r_cm,
    )
}

/// The phases ψ of the sweep, deg.
fn psis() -> Vec<f64> {
    (0..=12).map(|k| f64::from(k) * 15.0).collect()
}

/// The closed-loop ticks [`run`] runs: a difference at every ψ, with the second harmonic
/// measured (so on the dynamic path).
#[must_use]
pub fn work(
    instr: &Instrument,
    opts: &SimOptions,
    plan: &TwoAxisPlan,
) -> crate::simulation::work::Ticks {
    let o = SimOptions {
        harmonic: 2,
        ..*opts
    };
    psis()
        .into_iter()
        .map(|psi| {
            let c = condition(plan, psi);
            crate::simulation::work::difference(instr, &c, &o)
        })
        .sum()
}

/// The sweep over ψ for one set-up.
///
/// # Errors
/// None today (kept for symmetry with the other experiments).
pub fn run(instr: &Instrument, opts: &SimOptions, plan: &TwoAxisPlan) -> Result<AppendixRun> {
    let psis = psis();
    let o = SimOptions {
        harmonic: 2,
        ..*opts
    };
    let rows: Vec<PhaseRow> = psis
        .par_iter()
        .map(|&psi| {
            let c = condition(plan, psi);
            let d = simulate_difference(instr, &c, &plan.effects, &o);
            let p = predict_rectified(instr, opts, &c, &plan.effects);
            PhaseRow {
                psi_deg: psi,
                simulated_dc: d.difference_cm_s2,
                simulated_2w: d.condition.harmonic_torque_amp_cm_s2,
                predicted_dc: p.dc_cm_s2,
                predicted_2w: p.amp_2w_cm_s2,
                condition: c,
            }
        })
        .collect();
    let name = name(plan.kind);
    let c0 = &rows[0].condition;
    let mut t = Table::new(
        name,
        &format!(
            "Appendix A, {name}: {} Hz, theta_my {} mrad, theta_mz {} mrad, r {} cm (a_IA {:.1}, a_PA {:.1}, a_OA {:.1} cm/s^2 amplitude)",
            plan.freq_hz,
            plan.theta_my_mrad,
            plan.theta_mz_mrad,
            plan.r_cm,
            c0.lin_cm_s2[IA],
            c0.lin_cm_s2[PA],
            c0.lin_cm_s2[OA]
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
            num(r.psi_deg, 0),
            num(r.simulated_dc, 4),
            num(r.predicted_dc, 4),
            num(r.simulated_2w, 4),
            num(r.predicted_2w, 4),
        ]);
    }
    let plot = Plot {
        title: format!("Appendix A: {name}, rectified error vs phase"),
        x_label: "phase psi, deg".into(),
        y_label: "rectified error, cm/s^2".into(),
        series: vec![
            Series::line(
                "predicted (linear loop model)",
                rows.iter().map(|r| (r.psi_deg, r.predicted_dc)).collect(),
            ),
            Series::markers(
                "simulated (closed loop)",
                rows.iter().map(|r| (r.psi_deg, r.simulated_dc)).collect(),
            ),
        ],
        zero_line: true,
        ..Plot::default()
    };
    let worst = rows
        .iter()
        .map(|r| (r.simulated_dc - r.predicted_dc).abs())
        .fold(0.0, f64::max);
    let notes = vec![format!(
        "{name}: largest |simulated - predicted| rectified error {worst:.4} cm/s^2"
    )];
    Ok(AppendixRun {
        rows,
        worst_dc: worst,
        output: Output {
            tables: vec![t],
            plots: vec![Figure::single(name, plot)],
            notes,
        },
    })
}

/// A linear-model prediction of a two-axis row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prediction {
    /// Rectified (DC) indicated error, condition − reference, cm/s².
    pub dc_cm_s2: f64,
    /// Amplitude of its 2ω component, cm/s².
    pub amp_2w_cm_s2: f64,
}

/// Linear-model prediction of the rectified (DC) indicated error and its 2ω amplitude for a
/// two-axis condition: the pendulum's closed-loop response `θ = pend/(1 + L)·T` to the
/// oscillating torque `T = P·a_IA − I·dW_OA` (`L` the loop gain with the run's
/// configuration `opts.config`), rectified by the cross-coupling torque `−P·a_PA·θ`
/// (eq. 4.2), plus the effect terms, averaged over a period.
#[must_use]
pub fn predict_rectified(
    instr: &Instrument,
    opts: &SimOptions,
    cond: &Condition,
    effects: &Effects,
) -> Prediction {
    let f = cond.freq_hz;
    let prep = cond.prepare(instr.g_cm_s2);
    let m = prep.inputs(0.0, 0.0);
    let p = instr.pendulosity_g_cm();
    // The oscillating torque's sine and cosine coefficients.
    let torque = |i: &CaseInputs| {
        p * (i.a_cm_s2[IA] - m.a_cm_s2[IA]) - instr.inertia_dyn_cm_s2 * i.dw_rad_s2[OA]
    };
    let (ts, tc) = (
        torque(&prep.inputs(1.0, 0.0)),
        torque(&prep.inputs(0.0, 1.0)),
    );
    // x(t) = Re(X e^{jωt}) with X = x_c − j x_s.
    let x = Cx::new(tc, -ts);
    let l = loop_gain(instr, &opts.config, f);
    let th = pendulum(instr, f) / (1.0 + l) * x;
    // θ(t) = th_c cos + th_s sin with th_c = Re(th), th_s = −Im(th).
    let (th_c, th_s) = (th.re, -th.im);
    let n = 64;
    let mut dc = 0.0;
    let (mut h_s, mut h_c) = (0.0, 0.0);
    for k in 0..n {
        let ph = TAU * f64::from(k) / f64::from(n);
        let (sn, cs) = ph.sin_cos();
        let i = prep.inputs(sn, cs);
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
    Prediction {
        dc_cm_s2: dc / nf - static_eff,
        amp_2w_cm_s2: 2.0 * h_s.hypot(h_c) / nf,
    }
}

/// The step of the report programme for one set-up (see [`crate::report::Experiment`]).
#[derive(Clone, Copy, Debug)]
pub struct Step(pub TwoAxisKind);

impl Experiment for Step {
    fn name(&self) -> &'static str {
        name(self.0)
    }

    fn work(&self, s: Setup<'_>) -> Result<Estimate> {
        Ok(ticks_only(work(
            s.instr,
            s.opts,
            &TwoAxisPlan::report(self.0),
        )))
    }

    fn run(&self, s: Setup<'_>, to: &mut Sink<'_>) -> Result<Finding> {
        let r = run(s.instr, s.opts, &TwoAxisPlan::report(self.0))?;
        to.emit(&r.output)?;
        Ok(Finding::TwoAxis(self.0, r))
    }
}
