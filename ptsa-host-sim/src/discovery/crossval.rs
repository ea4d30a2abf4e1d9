//! The gain out of sample: k-fold cross-validation (leave-one-out up to
//! [`MAX_LEAVE_ONE_OUT`] rows, else [`FOLDS`] folds) that repeats the whole fit in every
//! fold — nuisance terms, noise estimate and selection — and predicts the held-out rows,
//! against the same with the nuisance terms only (the baseline model); and a bootstrap 95 %
//! interval of the gain over the held-out rows.
//!
//! The held-out predictions use the candidates' signatures (the linearised model, exact for
//! the additive terms: the loop indicates their time average); the full-data extended
//! model is re-simulated in the closed loop. A selected parameter of the loop (`damping`,
//! ...) enters as its secant, the closed loop's change from the instrument file's value to
//! the full-data fit divided by that change: exact at both ends, linear between, and its
//! direction taken from all rows (the held-out fold still refits its size).

use super::data::Data;
use super::fit::{self, Settings};
use super::observation::{Observation, Quantity};
use super::problem::{Problem, Selected};
use super::report::{FitSummary, Gain};
use crate::model::condition::Condition;
use crate::model::effects::Effects;
use rand::seq::SliceRandom as _;
use rand::{Rng as _, SeedableRng as _};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// Largest set cross-validated leave-one-out.
pub const MAX_LEAVE_ONE_OUT: usize = 30;
/// Folds beyond that.
pub const FOLDS: usize = 10;
/// Bootstrap resamples of the interval.
pub const BOOTSTRAP: usize = 2000;

/// The stage: the gain out of sample of the selected terms (a parameter by its secant,
/// [`secant_signatures`]), against the in-sample RMS of the extended model `extended` (in
/// cm/s², or normalised when the data hold response rows).
pub(crate) fn out_of_sample(
    p: &Problem<'_>,
    selected: &[Selected],
    baseline: &[Observation],
    extended: &FitSummary,
) -> Gain {
    gain(
        &secant_signatures(p, selected, baseline),
        p.opts.settings(),
        if p.data.quantity.iter().all(|&q| q == Quantity::Value) {
            extended.rms_cm_s2
        } else {
            extended.rms_normalised
        },
        p.opts.seed,
    )
}

/// `data` with each selected parameter's signature replaced by its secant: the closed
/// loop's observations with the fitted change alone, minus the baseline's, over the change
/// (the central-difference sensitivity at the file's value misjudges a change of tens of
/// per cent).
fn secant_signatures(p: &Problem<'_>, selected: &[Selected], baseline: &[Observation]) -> Data {
    let (rows, data, sim) = (p.rows, p.data, p.sim);
    let mut out = data.clone();
    for s in selected {
        if s.id.parameter_key().is_none() || s.coef == 0.0 {
            continue;
        }
        let e = Effects::only(s.id, s.coef);
        let jobs: Vec<(&Condition, &Effects)> = rows.iter().map(|r| (r, &e)).collect();
        let obs = sim.observe_all(&jobs);
        // An observation the simulator lacks, or a change that is not a finite number,
        // leaves the parameter its sensitivity.
        let col: Option<Vec<f64>> = (0..data.n())
            .map(|k| {
                let (i, q) = (data.rows[k], data.quantity[k]);
                let d = obs[i].get(q)? - baseline[i].get(q)?;
                Some(d / s.coef)
            })
            .collect();
        if let Some(col) = col.filter(|c| c.iter().all(|x| x.is_finite()))
            && let Some(sig) = out.signatures.iter_mut().find(|x| x.id == s.id)
        {
            sig.col = col;
            // A parameter found by the scan had no first-order signature; its secant is one.
            sig.null = false;
        }
    }
    out
}

/// Cross-validate the fit of `data`.
#[must_use]
pub fn gain(data: &Data, settings: Settings, rms_in_sample: f64, seed: u64) -> Gain {
    let (folds, method) = split_folds(data.n(), seed);
    let normalise = data.quantity.iter().any(|&q| q != Quantity::Value);
    let errors = held_out_errors(data, settings, &folds, normalise);
    let cv = rms(errors.iter().map(|e| e.0));
    let cv_base = rms(errors.iter().map(|e| e.1));
    Gain {
        rms_in_sample_cm_s2: rms_in_sample,
        rms_cross_validated_cm_s2: cv,
        baseline_rms_cross_validated_cm_s2: cv_base,
        ci95_rms_cm_s2: bootstrap_ci95(&errors, seed),
        method,
        unit: if normalise { "σ" } else { "cm/s²" }.to_string(),
    }
}

/// The folds of `n` rows and the method in words: leave-one-out up to
/// [`MAX_LEAVE_ONE_OUT`] rows, else [`FOLDS`] folds of the rows shuffled with `seed`.
fn split_folds(n: usize, seed: u64) -> (Vec<Vec<usize>>, String) {
    if n <= MAX_LEAVE_ONE_OUT {
        (
            (0..n).map(|i| vec![i]).collect::<Vec<_>>(),
            "leave-one-out".to_string(),
        )
    } else {
        let mut order: Vec<usize> = (0..n).collect();
        order.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
        let mut f = vec![Vec::new(); FOLDS];
        for (k, &i) in order.iter().enumerate() {
            f[k % FOLDS].push(i);
        }
        (f, format!("{FOLDS}-fold"))
    }
}

/// Every held-out row's prediction error, fold by fold, with the whole fit repeated on the
/// rest: `(with selection, with the nuisance terms only)`, over the row's 1 σ when
/// `normalise` (else in cm/s²).
fn held_out_errors(
    data: &Data,
    settings: Settings,
    folds: &[Vec<usize>],
    normalise: bool,
) -> Vec<(f64, f64)> {
    let n = data.n();
    folds
        .par_iter()
        .flat_map_iter(|held| {
            let mut out = vec![false; n];
            for &i in held {
                out[i] = true;
            }
            let train: Vec<usize> = (0..n).filter(|&i| !out[i]).collect();
            let with = fit::fit(data, &train, settings);
            let without = fit::fit(
                data,
                &train,
                Settings {
                    select: false,
                    ..settings
                },
            );
            held.iter()
                .map(|&i| {
                    let r = data.resid(i);
                    // The observation's stated 1 σ, else its group's estimate in the fold (with its
                    // orientation error).
                    let s = if normalise {
                        data.stated[i]
                            .or_else(|| {
                                without
                                    .group_sigma
                                    .iter()
                                    .find(|(g, _)| *g == data.group[i])
                                    .map(|&(_, s)| s.hypot(data.fixture[i]))
                            })
                            .unwrap_or(1.0)
                    } else {
                        1.0
                    };
                    (
                        (r - with.predict(data, i)) / s,
                        (r - without.predict(data, i)) / s,
                    )
                })
                .collect::<Vec<_>>()
        })
        .collect()
}

/// The root mean square of `v` (0 when empty).
fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (s, k) = v.fold((0.0, 0usize), |(s, k), e| (s + e * e, k + 1));
    #[allow(clippy::cast_precision_loss)]
    let r = (s / k.max(1) as f64).sqrt();
    r
}

/// The bootstrap 95 % interval of the gain (the baseline's RMS minus the selection's) over
/// the held-out rows' `errors`, [`BOOTSTRAP`] resamples drawn with `seed`; zeros when there
/// are no errors.
fn bootstrap_ci95(errors: &[(f64, f64)], seed: u64) -> [f64; 2] {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed);
    let m = errors.len();
    let mut gains: Vec<f64> = (0..BOOTSTRAP)
        .map(|_| {
            let idx: Vec<usize> = (0..m).map(|_| rng.random_range(0..m.max(1))).collect();
            rms(idx.iter().map(|&k| errors[k].1)) - rms(idx.iter().map(|&k| errors[k].0))
        })
        .collect();
    gains.sort_by(f64::total_cmp);
    let at = |q: f64| {
        #[allow(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            clippy::cast_precision_loss
        )]
        let k = ((q * (gains.len() - 1) as f64).round() as usize).min(gains.len() - 1);
        gains[k]
    };
    if m > 0 {
        [at(0.025), at(0.975)]
    } else {
        [0.0, 0.0]
    }
}
