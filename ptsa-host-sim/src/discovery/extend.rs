//! The selected effects put back into the simulator: every row re-simulated with them, and
//! each fitted observation's extended value (the re-simulation plus the nuisance terms),
//! with the baseline's and the extended model's fit to the measurements.

use super::data::{self, Data};
use super::observation::{Observation, Quantity};
use super::problem::{Problem, Selected};
use super::report::FitSummary;
use crate::model::condition::Condition;
use crate::model::effects::Effects;
use crate::stats::chi2_sf;

/// The extended model: the effects found, every row re-simulated with them, and each
/// fitted observation's extended value.
#[derive(Clone, Debug)]
pub(crate) struct Extended {
    /// The selected coefficients as effects for the plant.
    pub effects: Effects,
    /// Every row's observations re-simulated with `effects` (the baseline's when there
    /// are none), each of the kind of the row's baseline.
    pub resim: Vec<Observation>,
    /// Each fitted observation's extended value: the re-simulation plus, for a value in
    /// cm/s², the nuisance terms.
    pub values: Vec<f64>,
    /// The baseline model against the measurements.
    pub baseline_fit: FitSummary,
    /// The extended model against the measurements.
    pub fit: FitSummary,
}

/// The selected terms back into the simulator (extra torque `P·term` each tick of the
/// closed loop), every row re-simulated; the nuisance terms are part of the fitted model.
///
/// # Errors
/// The simulator's re-simulation of a row is not of the kind of its baseline (a value
/// against a gain and a phase).
pub(crate) fn extend(
    p: &Problem<'_>,
    selected: &[Selected],
    baseline: &[Observation],
) -> anyhow::Result<Extended> {
    let (rows, data, f, sim) = (p.rows, p.data, p.f, p.sim);
    let n = data.n();
    let effects = Selected::effects(selected);
    let resim: Vec<Observation> = if effects.is_zero() {
        baseline.to_vec()
    } else {
        let jobs: Vec<(&Condition, &Effects)> = rows.iter().map(|r| (r, &effects)).collect();
        sim.observe_all(&jobs)
    };
    let per_row: Vec<Option<Observation>> = resim.iter().copied().map(Some).collect();
    let (Some(predicted), None) = (
        data::column_of(data, &per_row),
        (0..rows.len()).find(|&i| !resim[i].same_kind(&baseline[i])),
    ) else {
        anyhow::bail!(
            "the {} simulator's re-simulation of a row is not of the kind of its baseline",
            sim.name()
        );
    };
    let extended: Vec<f64> = (0..n)
        .map(|k| {
            let v = predicted[k];
            if data.quantity[k] == Quantity::Phase {
                v
            } else {
                v + f.nuisance_at(data, k)
            }
        })
        .collect();
    let baseline_fit = summary(data, &|k| data.base[k], &f.sigma, 0);
    let extended_fit = summary(data, &|k| extended[k], &f.sigma, f.fit.beta.len());
    Ok(Extended {
        effects,
        resim,
        values: extended,
        baseline_fit,
        fit: extended_fit,
    })
}

/// `P(χ²)` summary of `pred` against the measured observations (the RMS over the values in
/// cm/s², or over every observation when there are none).
fn summary(data: &Data, pred: &dyn Fn(usize) -> f64, sigma: &[f64], p: usize) -> FitSummary {
    let n = data.n();
    let res: Vec<f64> = (0..n).map(|i| data.y[i] - pred(i)).collect();
    let values: Vec<f64> = (0..n)
        .filter(|&i| data.quantity[i] == Quantity::Value)
        .map(|i| res[i])
        .collect();
    #[allow(clippy::cast_precision_loss)]
    let rms = if values.is_empty() {
        f64::NAN
    } else {
        (values.iter().map(|r| r * r).sum::<f64>() / values.len() as f64).sqrt()
    };
    let chi2: f64 = res.iter().zip(sigma).map(|(r, s)| (r / s).powi(2)).sum();
    #[allow(clippy::cast_precision_loss)]
    let rms_normalised = (chi2 / n.max(1) as f64).sqrt();
    let dof = n.saturating_sub(p);
    #[allow(clippy::cast_precision_loss)]
    let p_value = chi2_sf(chi2, dof as f64);
    FitSummary {
        rms_cm_s2: rms,
        rms_normalised,
        chi2,
        dof,
        p_value,
    }
}
