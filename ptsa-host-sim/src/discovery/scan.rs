//! The scan: with response rows, stated sigmas the model fails and no parameter selected,
//! every parameter of the loop searched over its band through the closed loop (one acting
//! far from linearly has no usable sensitivity at the file's value, so the linear selection
//! passes it by).

use rayon::prelude::*;

use super::fit::Step;
use super::observation::Quantity;
use super::problem::{Problem, Selected};
use super::search::{SWAP_MARGIN, Scorer, best_change, limit_note};
use crate::model::effects::{CandidateId, Effects};
use crate::stats::{chi2_sf, f_sf};

/// With dynamic data (gain or phase observations), stated sigmas that the model without a
/// parameter fails (χ² test at α/m), and no parameter selected: the best
/// single parameter over its band, through the closed loop (as in [`super::check`]), against the
/// model without one; selected if it fits significantly better (the step test at α/m, m
/// the family and the parameters outside it, and by at least [`SWAP_MARGIN`] in χ²). A parameter acting far
/// from linearly (a torquer lag near the clock period, a phase error about 0°) may have no
/// usable sensitivity at the file's value, so the linear selection passes it by. Returns
/// whether one was selected (the caller then refines it and runs [`super::check`]), with a step in
/// `steps` that says so.
pub(crate) fn scan(p: &Problem<'_>, selected: &mut Vec<Selected>, steps: &mut Vec<Step>) -> bool {
    let (rows, data, f, sim, alpha) = p.parts();
    let dynamic = data
        .quantity
        .iter()
        .any(|&q| matches!(q, Quantity::Gain | Quantity::Phase));
    if !dynamic || selected.iter().any(|s| s.id.parameter_key().is_some()) {
        return false;
    }
    // Every parameter of the file, testable by its linear signature or not.
    let family: Vec<CandidateId> = data
        .signatures
        .iter()
        .map(|s| s.id)
        .filter(|id| id.parameter_key().is_some())
        .collect();
    let extra = family.iter().filter(|id| !f.family.contains(id)).count();
    if family.is_empty() {
        return false;
    }
    let scorer = Scorer::new(rows, data, f, selected, sim);
    let Some(chi_0) = scorer.chi2(&Effects::NONE) else {
        return false;
    };
    // The gate: only stated sigmas that the model without a parameter fails (χ² at α/m,
    // m the family and the parameters outside it). The scan takes the least of about a
    // hundred closed-loop χ² values, each with the loop's own scatter in it, which on data
    // the model already fits finds an "improvement" of ten or more (at α, 7 of 20
    // unperturbed sets then selected a parameter, at the gate of α 4 of 20); the gate keeps
    // its false selections within α/m.
    #[allow(clippy::cast_precision_loss)]
    let dof_0 = data.n().saturating_sub(scorer.linear.len()).max(1) as f64;
    #[allow(clippy::cast_precision_loss)]
    let level = alpha / (f.family_size() + extra).max(1) as f64;
    if !f.stated() || chi2_sf(chi_0, dof_0) >= level {
        return false;
    }
    let Some((id, d, chi, limit)) = family
        .par_iter()
        .filter_map(|&b| {
            best_change(&scorer, &Effects::NONE, b, f64::INFINITY).map(|(d, c, l)| (b, d, c, l))
        })
        .collect::<Vec<_>>()
        .into_iter()
        .min_by(|x, y| x.2.total_cmp(&y.2))
    else {
        return false;
    };
    let n = data.n();
    #[allow(clippy::cast_precision_loss)]
    let dof = n.saturating_sub(scorer.linear.len() + 1).max(1) as f64;
    let s2 = (chi / dof).max(f64::MIN_POSITIVE);
    let delta = chi_0 - chi;
    let p_f = f_sf(delta.max(0.0) / s2, 1.0, dof);
    let p = if f.stated() {
        chi2_sf(delta.max(0.0), 1.0).max(p_f)
    } else {
        p_f
    };
    if delta < SWAP_MARGIN || p > level {
        return false;
    }
    steps.push(Step {
        added: true,
        id,
        delta_chi2: delta,
        p_value: p,
        threshold: level,
        replaces: None,
        note: Some(format!(
            "no candidate passed the linear test and the model fails its chi2 test; the simulator, scanned over every parameter's band, fits the data best with {}{}",
            id.info().name,
            limit.map_or_else(String::new, |l| format!(
                "; its best lies at the end of the search grid: {}",
                limit_note(id, l, sim)
            ))
        )),
    });
    selected.push(Selected {
        id,
        coef: d,
        stderr: profile_se(&scorer, id, d, chi, dof),
        plausible: true,
        parameter: None,
        confounded: Vec::new(),
        mirror: false,
        search_limit: limit,
        stable: None,
        rivals: Vec::new(),
        time_constant: None,
        companion: false,
    });
    true
}

/// The standard error of a change `d` of `id` from the curvature of its χ² profile (steps
/// of a quarter of the distance to the band's edge, the χ² rescaled when it exceeds its
/// degrees of freedom): the fallback when Gauss–Newton cannot refine it.
fn profile_se(scorer: &Scorer<'_>, id: CandidateId, d: f64, chi: f64, dof: f64) -> f64 {
    let Some((lo, nom, hi)) = id
        .parameter_key()
        .and_then(|k| scorer.sim.instrument()?.tolerance(k))
    else {
        return f64::INFINITY;
    };
    let h = 0.25 * if d >= 0.0 { hi - nom } else { nom - lo };
    let score = |x: f64| {
        let mut t = Effects::NONE;
        t.add(id, x);
        scorer.chi2(&t)
    };
    match (score(d + h), score(d - h)) {
        (Some(cp), Some(cm)) if cp + cm - 2.0 * chi > 0.0 => {
            let curvature = (cp + cm - 2.0 * chi) / (h * h);
            (2.0 / curvature).sqrt() * (chi / dof).max(1.0).sqrt()
        }
        _ => f64::INFINITY,
    }
}
