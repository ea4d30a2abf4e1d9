//! The selected parameters of the instrument file refitted through the closed loop
//! (Gauss–Newton: the response is not linear in them), and, once the searches are done,
//! each one's fitted value against the file's.

use super::data;
use super::fit;
use super::problem::{Problem, Selected, within_tolerance};
use super::report::ParameterValue;
use super::sim::Simulator;
use crate::model::effects::{CandidateId, Effects};
use crate::stats::{lsq, norm};

/// Gauss–Newton on the selected parameters of the instrument file (the response is not
/// linear in them): from the linear fit, repeat (sensitivities at the current values, a
/// weighted least-squares step for the parameters with the additive terms and the nuisance
/// terms refitted) until the steps fall below [`GAUSS_NEWTON_TOLERANCE`] of their standard
/// errors, at most [`GAUSS_NEWTON_STEPS`] times. The coefficients and standard errors of
/// `selected` become those of the last step, or without convergence those of the iterate
/// with the least χ².
pub(crate) fn refine(p: &Problem<'_>, selected: &mut [Selected]) {
    let (rows, data, f, sim) = (p.rows, p.data, p.f, p.sim);
    let params: Vec<usize> = (0..selected.len())
        .filter(|&k| selected[k].id.parameter_key().is_some())
        .collect();
    if params.is_empty() {
        return;
    }
    let ids: Vec<CandidateId> = params.iter().map(|&k| selected[k].id).collect();
    let additive: Vec<usize> = (0..selected.len())
        .filter(|k| !params.contains(k))
        .collect();
    let n = data.n();
    let all: Vec<usize> = (0..n).collect();
    let (_, nuis, _) = fit::nuisance_columns(data, &all);
    let sigma = &f.sigma;
    let mut theta = Effects::NONE;
    for &k in &params {
        theta.set(selected[k].id, selected[k].coef);
    }
    let mut best: Option<(f64, Vec<Selected>)> = None;
    for _ in 0..GAUSS_NEWTON_STEPS {
        let pred = data::predicted(rows, data, sim, &theta);
        let jac = data::sensitivities(rows, data, &ids, sim, &theta);
        let Some(pred) = pred else { return };
        let z: Vec<f64> = (0..n).map(|k| (data.y[k] - pred[k]) / sigma[k]).collect();
        if z.iter().any(|x| !x.is_finite()) {
            return;
        }
        let mut cols: Vec<Vec<f64>> = jac.iter().map(|s| s.col.clone()).collect();
        for &k in &additive {
            if let Some(s) = data.signatures.iter().find(|s| s.id == selected[k].id) {
                cols.push(s.col.clone());
            }
        }
        cols.extend(nuis.iter().cloned());
        let (unit, scales) = weighted_unit_columns(&cols, sigma);
        let refs: Vec<&[f64]> = unit.iter().map(Vec::as_slice).collect();
        // χ² here: the residual with the additive and nuisance terms refitted, the
        // parameters as they stand.
        let here = lsq(&z, &refs[params.len()..])
            .map_or_else(|| z.iter().map(|x| x * x).sum(), |h| h.chi2);
        if best.as_ref().is_none_or(|(c, _)| here < *c) {
            best = Some((here, selected.to_vec()));
        }
        let Some(g) = lsq(&z, &refs) else { return };
        let birge = crate::stats::birge_ratio(g.chi2, n.saturating_sub(refs.len()));
        let step = Step {
            g: &g,
            scales: &scales,
            birge,
        };
        let done = step.parameters(p, selected, &params, &mut theta);
        step.additive(p, selected, params.len(), &additive);
        if done {
            return;
        }
    }
    // No convergence within the steps: the closed loop's response is rough on the scale of
    // the noise, so the iterates wander; keep the best one seen.
    if let Some((_, b)) = best {
        selected.clone_from_slice(&b);
    }
}

/// The columns, each divided by the rows' sigmas, then scaled to unit length; the scales.
fn weighted_unit_columns(cols: &[Vec<f64>], sigma: &[f64]) -> (Vec<Vec<f64>>, Vec<f64>) {
    let weighted: Vec<Vec<f64>> = cols
        .iter()
        .map(|c| c.iter().zip(sigma).map(|(x, s)| x / s).collect())
        .collect();
    let scales: Vec<f64> = weighted
        .iter()
        .map(|c| norm(c).max(f64::MIN_POSITIVE))
        .collect();
    let unit = weighted
        .iter()
        .zip(&scales)
        .map(|(c, s)| c.iter().map(|x| x / s).collect())
        .collect();
    (unit, scales)
}

/// One Gauss–Newton step's weighted least squares: its fit, the columns' scales and the
/// Birge ratio its standard errors take.
struct Step<'a> {
    g: &'a crate::stats::LsqFit,
    scales: &'a [f64],
    birge: f64,
}

impl Step<'_> {
    /// The parameters (the first columns) moved by their steps, with their standard errors;
    /// whether every step fell below [`GAUSS_NEWTON_TOLERANCE`] of its standard error.
    fn parameters(
        &self,
        p: &Problem<'_>,
        selected: &mut [Selected],
        params: &[usize],
        theta: &mut Effects,
    ) -> bool {
        let (g, scales) = (self.g, self.scales);
        let mut done = true;
        for (j, &k) in params.iter().enumerate() {
            let step = g.beta[j] / scales[j];
            let classical = g.cov[(j, j)].sqrt() * self.birge / scales[j];
            let se = if p.f.stated() {
                classical
            } else {
                classical.max(g.se_hc3[j] / scales[j])
            };
            theta.add(selected[k].id, step);
            selected[k].coef = theta.get(selected[k].id);
            selected[k].stderr = se;
            selected[k].plausible = within_tolerance(selected[k].id, selected[k].coef, p.sim);
            done &= step.abs() < GAUSS_NEWTON_TOLERANCE * se;
        }
        done
    }

    /// The additive terms (the columns after the `first` parameters'), refitted.
    fn additive(
        &self,
        p: &Problem<'_>,
        selected: &mut [Selected],
        first: usize,
        additive: &[usize],
    ) {
        let (g, scales) = (self.g, self.scales);
        for (j, &k) in additive.iter().enumerate() {
            let c = first + j;
            selected[k].coef = g.beta[c] / scales[c];
            selected[k].stderr = g.cov[(c, c)].sqrt() * self.birge / scales[c];
            selected[k].plausible = selected[k].coef.abs() <= p.opts.limits[selected[k].id.index()];
        }
    }
}

/// `refine` stops when every step is below this fraction of its standard
/// error: the closed loop's noise makes χ² rough on about half a standard error, so finer
/// steps only wander.
pub const GAUSS_NEWTON_TOLERANCE: f64 = 0.2;

/// Most Gauss–Newton steps of `refine`.
pub const GAUSS_NEWTON_STEPS: usize = 8;

/// After the searches: each selected parameter's fitted value against the file's (with
/// its mirror image when the mirror check found one), and a search's end kept only where
/// the refined value still lies.
pub(crate) fn settle(selected: &mut [Selected], sim: &dyn Simulator) {
    parameter_values(selected, sim);
    // A search's end counts only where the refined value still lies.
    for s in selected {
        if let Some(l) = s.search_limit
            && (s.coef - l).abs() > (0.01 * l.abs()).max(s.stderr)
        {
            s.search_limit = None;
        }
    }
}

/// Fill in the parameter values of the selected parameters.
fn parameter_values(selected: &mut [Selected], sim: &dyn Simulator) {
    for s in selected {
        let Some(key) = s.id.parameter_key() else {
            continue;
        };
        let Some((lo, nom, hi)) = sim.instrument().and_then(|i| i.tolerance(key)) else {
            continue;
        };
        let fitted = nom + s.coef;
        s.parameter = Some(ParameterValue {
            key: key.to_string(),
            nominal: nom,
            fitted,
            sigma: s.stderr,
            tolerance: [lo, hi],
            within_tolerance: (lo..=hi).contains(&fitted),
            mirror: s.mirror.then_some(nom - s.coef),
        });
    }
}
