//! The linear selection read as selected terms: each one's partners, the candidates the
//! data cannot tell from it (a signature parallel to its own, or one that fits not
//! significantly worse in its place), and its plausibility; and the groups of candidates
//! indistinguishable before any fit.

use super::data::Data;
use super::fit::{self, Fitted};
use super::problem::{Options, Selected, within_tolerance};
use super::sim::Simulator;
use crate::model::effects::CandidateId;
use crate::stats::{abs_cos, lsq, norm, residualize};

/// Confounding of every selected coefficient, and the plausibility verdict.
pub(crate) fn selected(
    data: &Data,
    f: &Fitted,
    opts: &Options,
    sim: &dyn Simulator,
) -> Vec<Selected> {
    let m = f.family_size();
    let cols = f.unit_columns();
    let nn = f.n_nuisance();
    let z = f.weighted_target();
    f.selected
        .iter()
        .enumerate()
        .map(|(k, &id)| {
            let (coef, stderr) = f.candidate(id).unwrap_or((0.0, 0.0));
            let others: Vec<&[f64]> = cols
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != nn + k)
                .map(|(_, c)| *c)
                .collect();
            let (ua, sa) = f.candidate_column(data, id).unwrap_or((&[], 1.0));
            let a = residualize(ua, &others);
            let mut confounded = Vec::new();
            // A companion bias is fitted with the warm-up, not named: it has no partners.
            let companion = f.companion == Some(id);
            for &o in f.family.iter().filter(|_| !companion) {
                // Another time constant of a selected warm-up is the same effect, not a
                // partner (of the warm-up, or of the bias it is measured from).
                if o == id
                    || f.selected.contains(&o)
                    || (o.profiled() && f.selected.iter().any(|s| s.profiled()))
                {
                    continue;
                }
                let Some((ub, sb)) = f.candidate_column(data, o) else {
                    continue;
                };
                let b = residualize(ub, &others);
                if norm(&b) < 1e-12 {
                    continue;
                }
                let cos = abs_cos(&a, &b);
                let structural = cos > opts.confound_cos;
                let statistical = cos >= 0.5 && {
                    let mut swapped = others.clone();
                    swapped.push(ub);
                    lsq(&z, &swapped).is_some_and(|g| {
                        let mut with = others.clone();
                        with.push(ua);
                        lsq(&z, &with).is_some_and(|w| {
                            #[allow(clippy::cast_precision_loss)]
                            let level = opts.alpha / m.max(1) as f64;
                            fit::step_p(&w, &with, with.len() - 1, g.chi2, f.stated(), None) > level
                        })
                    })
                };
                if structural || statistical {
                    let dot: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
                    let factor = dot / a.iter().map(|x| x * x).sum::<f64>() * sb / sa;
                    confounded.push((o, factor));
                }
            }
            Selected {
                id,
                coef,
                stderr,
                plausible: if id.parameter_key().is_some() {
                    within_tolerance(id, coef, sim)
                } else {
                    coef.abs() <= opts.limits[id.index()]
                },
                confounded,
                parameter: None,
                mirror: false,
                search_limit: None,
                stable: None,
                rivals: Vec::new(),
                time_constant: None,
                companion: f.companion == Some(id),
            }
        })
        .collect()
}

/// Pairwise groups of the family with `|cos| > confound_cos` once the nuisance terms are
/// partialled out.
pub(crate) fn indistinguishable(data: &Data, f: &Fitted, opts: &Options) -> Vec<Vec<CandidateId>> {
    let basis: Vec<&[f64]> = f.unit_columns()[..f.n_nuisance()].to_vec();
    let partial: Vec<(CandidateId, Vec<f64>)> = f
        .family
        .iter()
        .filter_map(|&id| {
            f.candidate_column(data, id)
                .map(|(u, _)| (id, residualize(u, &basis)))
        })
        .collect();
    let mut groups: Vec<Vec<CandidateId>> = Vec::new();
    for (i, (a, ua)) in partial.iter().enumerate() {
        for (b, ub) in &partial[i + 1..] {
            if !(a.profiled() && b.profiled()) && abs_cos(ua, ub) > opts.confound_cos {
                if let Some(g) = groups.iter_mut().find(|g| g.contains(a) || g.contains(b)) {
                    for x in [*a, *b] {
                        if !g.contains(&x) {
                            g.push(x);
                        }
                    }
                } else {
                    groups.push(vec![*a, *b]);
                }
            }
        }
    }
    groups
}
