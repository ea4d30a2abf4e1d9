//! Section 6.2 and Table 6.1: the accelerometer on the dividing head on the rate table, IA
//! at eight positions 45° apart, the table at 1.0 and 0.05 rad/s; eq. 6.5 is the difference.

use anyhow::Result;
use rayon::prelude::*;

use crate::lab::fixtures;
use crate::model::condition::{IA, PA};
use crate::model::effects::Effects;
use crate::model::instrument::Instrument;
use crate::output::{Figure, Output, Plot, Series, Table, num, opt};
use crate::report::r890;
use crate::report::{Experiment, Finding, Setup, Sink, ticks_only};
use crate::simulation::sim::{SimOptions, simulate_difference};
use crate::simulation::work::Estimate;

/// One row of the anisoinertia experiment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnisoRow {
    /// IA position, deg.
    pub ia_deg: f64,
    /// Report's `A_in` difference, cm/s² (if tabulated).
    pub report: Option<f64>,
    /// Simulated with the given anisoinertia, cm/s².
    pub simulated: f64,
    /// Simulated baseline (`I_PA = I_IA`), cm/s².
    pub baseline: f64,
    /// `(I_PA − I_IA)/(m l)·(w_IA w_PA at 1.0 − at 0.05 rad/s)`, cm/s².
    pub predicted: f64,
}

/// What [`run`] returns.
#[derive(Clone, Debug, PartialEq)]
pub struct AnisoRun {
    /// One row per IA position of Table 6.1.
    pub rows: Vec<AnisoRow>,
    /// The coefficient as the report derives it from the simulated table (mean `|A_in|` at the
    /// 45° positions over `w_IA·w_PA`), cm.
    pub k_simulated_cm: f64,
    /// The configured coefficient `(I_PA − I_IA)/(m·l)`, cm.
    pub k_configured_cm: f64,
    /// Tables, figures, notes.
    pub output: Output,
}

/// The closed-loop ticks [`run`] runs: each row of Table 6.1 as a difference, with and
/// without the anisoinertia.
///
/// # Errors
/// The report's transcription is malformed.
pub fn work(
    instr: &Instrument,
    opts: &SimOptions,
    lever_cm: [f64; 3],
) -> Result<crate::simulation::work::Ticks> {
    let s62 = r890::section_6_2()?;
    Ok(r890::table_6_1()?
        .iter()
        .map(|r| {
            let s =
                fixtures::rate_table(r.ia_deg, s62.rate_rad_s, s62.reference_rate_rad_s, lever_cm);
            crate::simulation::work::difference(instr, &s.cond, opts).times(2.0)
        })
        .sum())
}

/// Table 6.1's procedure with the instrument's anisoinertia set to `aniso_g_cm2` (g·cm²)
/// and with the baseline (0); `lever_cm` is the CG's offset from the table axis (IA, PA, OA),
/// cm.
///
/// # Errors
/// The report's transcriptions are malformed.
pub fn run(
    instr: &Instrument,
    opts: &SimOptions,
    aniso_g_cm2: f64,
    lever_cm: [f64; 3],
) -> Result<AnisoRun> {
    let s62 = r890::section_6_2()?;
    let rows = simulate_table(instr, opts, aniso_g_cm2, lever_cm, &s62)?;
    let k = aniso_g_cm2 / instr.pendulosity_g_cm();
    let (w1, w0) = (s62.rate_rad_s, s62.reference_rate_rad_s);
    let (sim_mean, rep_mean, k_sim) = coefficient_as_reported(&rows, w1, w0);
    let t = error_table(&rows, aniso_g_cm2, k);
    let plot = error_plot(&rows, k, w1, w0);
    let notes = vec![format!(
        "anisoinertia: mean |A_in| at 45-deg positions: simulated {sim_mean:.3} cm/s^2 (report {rep_mean:.3}); coefficient {k_sim:.3} cm (configured {k:.3}, report {})",
        s62.coefficient_cm
    )];
    Ok(AnisoRun {
        rows,
        k_simulated_cm: k_sim,
        k_configured_cm: k,
        output: Output {
            tables: vec![t],
            plots: vec![Figure::single("anisoinertia-table-6-1", plot)],
            notes,
        },
    })
}

/// Each row of Table 6.1 simulated as a difference (the table at section 6.2's rate, minus
/// at its reference rate) with the anisoinertia `aniso_g_cm2` and with the baseline (0),
/// beside the report's value and eq. 6.5's prediction.
///
/// # Errors
/// The report's transcription of Table 6.1 is malformed.
fn simulate_table(
    instr: &Instrument,
    opts: &SimOptions,
    aniso_g_cm2: f64,
    lever_cm: [f64; 3],
    s62: &r890::Section62,
) -> Result<Vec<AnisoRow>> {
    let table = r890::table_6_1()?;
    let mut with = instr.clone();
    with.anisoinertia_g_cm2 = aniso_g_cm2;
    let mut base = instr.clone();
    base.anisoinertia_g_cm2 = 0.0;
    let k = aniso_g_cm2 / instr.pendulosity_g_cm();
    let (w1, w0) = (s62.rate_rad_s, s62.reference_rate_rad_s);
    Ok(table
        .par_iter()
        .map(|r| {
            let s = fixtures::rate_table(r.ia_deg, w1, w0, lever_cm);
            let e = s.effects(&Effects::NONE);
            let sim = simulate_difference(&with, &s.cond, &e, opts).difference_cm_s2;
            let b = simulate_difference(&base, &s.cond, &e, opts).difference_cm_s2;
            let c = s.cond.w_rad_s;
            let rf = s.cond.ref_w_rad_s;
            AnisoRow {
                ia_deg: r.ia_deg,
                report: r.a_in_cm_s2,
                simulated: sim,
                baseline: b,
                predicted: k * (c[IA] * c[PA] - rf[IA] * rf[PA]),
            }
        })
        .collect())
}

/// The coefficient as the report derives it from `rows` (table rates `w1`, reference `w0`,
/// rad/s): `(simulated mean |A_in| at 45°, the report's, the simulated coefficient)`, cm/s²
/// and cm.
fn coefficient_as_reported(rows: &[AnisoRow], w1: f64, w0: f64) -> (f64, f64, f64) {
    // w_IA·w_PA at a 45° position, measurement minus reference.
    let w45 = 0.5 * (w1 * w1 - w0 * w0);
    let is45 = |deg: f64| (deg % 90.0 - 45.0).abs() < 1e-9;
    let sim_mean = mean(
        &rows
            .iter()
            .filter(|r| is45(r.ia_deg))
            .map(|r| r.simulated.abs())
            .collect::<Vec<_>>(),
    );
    let rep_mean = mean(
        &rows
            .iter()
            .filter(|r| is45(r.ia_deg))
            .filter_map(|r| r.report.map(f64::abs))
            .collect::<Vec<_>>(),
    );
    // As the report derives it (the mean magnitude at 45°), with the sign of the simulated
    // rows' correlation with w_IA·w_PA, which the magnitudes lose.
    // (w_IA·w_PA goes as sin 2φ with the IA position φ on the table.)
    let sign = rows
        .iter()
        .map(|r| r.simulated * (2.0 * r.ia_deg).to_radians().sin())
        .sum::<f64>()
        .signum();
    (sim_mean, rep_mean, sign * sim_mean / w45)
}

/// The mean of `v` (0 when empty).
fn mean(v: &[f64]) -> f64 {
    #[allow(clippy::cast_precision_loss)]
    let n = v.len().max(1) as f64;
    v.iter().sum::<f64>() / n
}

/// Table 6.1's figure: `rows` simulated, the report's, the baseline, and `k·w_IA·w_PA`
/// (coefficient `k`, cm; table rate `w1`, reference `w0`, rad/s) over the IA position.
fn error_plot(rows: &[AnisoRow], k: f64, w1: f64, w0: f64) -> Plot {
    Plot {
        title: "Table 6.1: anisoinertia error vs IA position".into(),
        x_label: "IA position, deg".into(),
        y_label: "A_in(1.0 rad/s) - A_in(0.05 rad/s), cm/s^2".into(),
        series: vec![
            Series::line(
                "k w_IA w_PA",
                (0..=360)
                    .map(|a| {
                        let x = f64::from(a).to_radians();
                        (f64::from(a), k * (w1 * w1 - w0 * w0) * x.sin() * x.cos())
                    })
                    .collect(),
            ),
            Series::markers(
                "simulated",
                rows.iter().map(|r| (r.ia_deg, r.simulated)).collect(),
            ),
            Series::crosses(
                "report",
                rows.iter()
                    .filter_map(|r| r.report.map(|x| (r.ia_deg, x)))
                    .collect(),
            ),
            Series::triangles(
                "baseline (I_PA = I_IA)",
                rows.iter().map(|r| (r.ia_deg, r.baseline)).collect(),
            ),
        ],
        ..Plot::default()
    }
}

/// Table 6.1 of `rows`, for anisoinertia `aniso_g_cm2` (g·cm²) and its coefficient `k` (cm).
fn error_table(rows: &[AnisoRow], aniso_g_cm2: f64, k: f64) -> Table {
    let mut t = Table::new(
        "anisoinertia-table-6-1",
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
    for r in rows {
        t.rows.push(vec![
            num(r.ia_deg, 0),
            opt(r.report, 2),
            num(r.simulated, 3),
            num(r.baseline, 3),
            num(r.predicted, 3),
        ]);
    }
    t
}

/// The step of the report programme (see [`crate::report::Experiment`]).
#[derive(Clone, Copy, Debug)]
pub struct Step;

impl Experiment for Step {
    fn name(&self) -> &'static str {
        "anisoinertia"
    }

    fn work(&self, s: Setup<'_>) -> Result<Estimate> {
        Ok(ticks_only(work(s.instr, s.opts, [0.0; 3])?))
    }

    fn run(&self, s: Setup<'_>, to: &mut Sink<'_>) -> Result<Finding> {
        let k = crate::report::r890::section_6_2()?.anisoinertia_g_cm2;
        let r = run(s.instr, s.opts, k, [0.0; 3])?;
        to.emit(&r.output)?;
        Ok(Finding::Anisoinertia(r))
    }
}
