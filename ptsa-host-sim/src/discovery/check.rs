//! Which other parameter of the loop could explain the data as well as a selected one
//! (the check).
//!
//! A parameter's signature in the selection is its central-difference sensitivity at the
//! instrument file's value. Some parameters act far from linearly over their tolerance band:
//! the pickoff's phase error acts as `cos φ` about φ = 0 (no first-order effect at all), and
//! in a response table the loop gain's three factors (pendulosity, pickoff scale factor,
//! amplifier gain) and the damping move the response alike. So for every selected
//! parameter, each other parameter of the instrument file is put in its place through the
//! closed loop, on a grid over and beyond its tolerance band (the other selected parameters
//! at their fitted values, the additive and nuisance terms refitted), and its best χ²
//! compared with the selected one's on a fresh evaluation with runs of other seeds (each
//! χ² found is the least of many noisy ones, and two seeds' χ² of one model differ by
//! about ten):
//!
//! * significantly better in the fresh evaluation (the selected one's χ² increase over it
//!   has p ≤ α/m, and by at least [`SWAP_MARGIN`]): the other parameter is named instead,
//!   and Gauss–Newton refines it from the search's best;
//! * not significantly worse on the mean of the two evaluations' differences (p > α/m by
//!   the selection's step test, the larger of the χ² and the F p-value, at its first Holm
//!   level): it is named as a partner ("indistinguishable here"), with the ratio of the two
//!   changes as its factor;
//! * otherwise the data tell them apart and nothing changes.
//!
//! The search and its χ²: [`super::search`].

use rayon::prelude::*;

use super::fit::Step;
use super::problem::{Problem, Selected};
use super::search::{
    FRESH_SEEDS, REACH, SWAP_MARGIN, Scorer, best_change, limit_note, not_worse, worse_p,
};
use super::sim::Simulator;
use crate::model::effects::{CandidateId, Effects};

/// For every selected parameter, the other parameters that explain the data as well
/// (added to its partners) or clearly better (named instead, with a step in `steps` that
/// says so); returns whether a name changed (the caller then refines the parameters
/// again).
pub(crate) fn check(p: &Problem<'_>, selected: &mut [Selected], steps: &mut Vec<Step>) -> bool {
    let (rows, data, f, sim, alpha) = p.parts();
    let params: Vec<usize> = (0..selected.len())
        .filter(|&k| selected[k].id.parameter_key().is_some())
        .collect();
    if params.is_empty() {
        return false;
    }
    let n = data.n();
    let scorer = Scorer::new(rows, data, f, selected, sim);
    let mut theta = Effects::NONE;
    for &k in &params {
        theta.set(selected[k].id, selected[k].coef);
    }
    let others: Vec<CandidateId> = data
        .signatures
        .iter()
        .map(|s| s.id)
        .filter(|id| id.parameter_key().is_some())
        .filter(|id| !params.iter().any(|&k| selected[k].id == *id))
        .collect();
    #[allow(clippy::cast_precision_loss)]
    let level = alpha / f.family.len().max(1) as f64;
    let dof = n.saturating_sub(scorer.linear.len() + params.len()).max(1);
    let reseeded = sim.reseeded(FRESH_SEEDS);
    let ctx = Context {
        scorer,
        fresh: reseeded
            .as_deref()
            .map(|s2| Scorer::new(rows, data, f, selected, s2)),
        others,
        level,
        dof,
        stated: f.stated(),
    };
    let mut changed = false;
    for &k in &params {
        let Some(t) = ctx.tried(&theta, selected, &params, k) else {
            continue;
        };
        match ctx.best_swap(&t) {
            Some(best) => {
                let (old, new, d) = (selected[k].id, best.0, best.1);
                ctx.swap(&mut selected[k], &t, best, steps, sim);
                theta.set(old, 0.0);
                theta.set(new, d);
                changed = true;
            }
            None => ctx.add_partners(&mut selected[k], &t),
        }
    }
    changed
}

/// What every selected parameter is checked with.
struct Context<'a> {
    /// The χ² of the search.
    scorer: Scorer<'a>,
    /// The fresh evaluation's, with runs of other seeds (none without a closed loop).
    fresh: Option<Scorer<'a>>,
    /// The other parameters of the instrument file with a signature here.
    others: Vec<CandidateId>,
    /// The test's level, `α/m`.
    level: f64,
    /// Residual degrees of freedom of the selection's fit.
    dof: usize,
    /// Whether the sigmas are stated.
    stated: bool,
}

/// One other parameter put in a selected one's place: its change, its χ² relative to the
/// selected one's (mean of both evaluations, and the fresh one alone).
type Tried = (CandidateId, f64, f64, f64);

/// The others tried in one selected parameter's place.
struct Trial {
    /// Each one found by the search: `(other, change, χ², where its search ended at its
    /// grid's end)`.
    found: Vec<(CandidateId, f64, f64, Option<f64>)>,
    /// Each as [`Tried`].
    tried: Vec<Tried>,
    /// The selected one's χ², first evaluation.
    chi_a: f64,
    /// The selected one's χ², fresh evaluation.
    chi_a2: f64,
}

impl Context<'_> {
    /// Whether a χ² `c` is not significantly worse than `chi`.
    fn similar(&self, c: f64, chi: f64) -> bool {
        not_worse(c, chi, self.dof, self.stated, self.level)
    }

    /// Every other parameter put in selected parameter `k`'s place (`theta` the selected
    /// parameters' values) and evaluated again with other seeds; `None` when the selected
    /// model itself cannot be evaluated.
    fn tried(
        &self,
        theta: &Effects,
        selected: &[Selected],
        params: &[usize],
        k: usize,
    ) -> Option<Trial> {
        let chi_a = self.scorer.chi2(theta)?;
        let mut rest = *theta;
        rest.set(selected[k].id, 0.0);
        let found: Vec<(CandidateId, f64, f64, Option<f64>)> = self
            .others
            .par_iter()
            .filter(|&&b| !params.iter().any(|&j| selected[j].id == b))
            .filter_map(|&b| {
                best_change(&self.scorer, &rest, b, chi_a + REACH).map(|(d, c, l)| (b, d, c, l))
            })
            .collect();
        // Each χ² found is the least of some thirty evaluations with the loop's scatter in
        // them, and the selected parameter's the least of Gauss–Newton's iterates: both
        // biased low, by different amounts, and two seeds' χ² of one model differ by about
        // ten. So a swap needs a fresh evaluation of both points with runs of other seeds
        // (`Simulator::reseeded`) to agree, and a partner is judged on the mean of the two
        // evaluations' differences.
        let (chi_a2, fresh_c): (f64, Vec<f64>) = match &self.fresh {
            Some(f2) => {
                let chi_a2 = f2.chi2(theta)?;
                let again: Vec<f64> = found
                    .par_iter()
                    .map(|&(b, d, c, _)| {
                        if c > chi_a + REACH {
                            return c - chi_a + chi_a2;
                        }
                        let mut t = rest;
                        t.add(b, d);
                        f2.chi2(&t).unwrap_or(f64::INFINITY)
                    })
                    .collect();
                (chi_a2, again)
            }
            None => (chi_a, found.iter().map(|x| x.2).collect()),
        };
        let tried = found
            .iter()
            .zip(&fresh_c)
            .map(|(&(b, d, c1, _), &c2)| (b, d, 0.5 * ((c1 - chi_a) + (c2 - chi_a2)), c2 - chi_a2))
            .collect();
        Some(Trial {
            found,
            tried,
            chi_a,
            chi_a2,
        })
    }

    /// The other that fits clearly better in the fresh evaluation, if any.
    fn best_swap(&self, t: &Trial) -> Option<Tried> {
        t.tried
            .iter()
            .copied()
            .min_by(|x, y| x.3.total_cmp(&y.3))
            .filter(|&(_, _, _, dc)| dc < -SWAP_MARGIN && !self.similar(t.chi_a2, t.chi_a2 + dc))
    }

    /// Name `best` instead of `s`, with its step; the others as good as it its partners.
    fn swap(
        &self,
        s: &mut Selected,
        t: &Trial,
        best: Tried,
        steps: &mut Vec<Step>,
        sim: &dyn Simulator,
    ) {
        let (b, d, mean_b, dc) = best;
        let old = s.id;
        let limit = t.found.iter().find(|x| x.0 == b).and_then(|x| x.3);
        steps.push(swap_step(
            old,
            b,
            -dc,
            worse_p(t.chi_a2, t.chi_a2 + dc, self.dof, self.stated),
            self.level,
            limit.map(|l| limit_note(b, l, sim)),
        ));
        s.search_limit = limit;
        s.id = b;
        s.coef = d;
        s.confounded
            .retain(|(o, _)| *o != b && o.parameter_key().is_none());
        for &(o, od, mean_o, _) in &t.tried {
            if o != b && self.similar(t.chi_a + mean_o, t.chi_a + mean_b) {
                s.confounded.push((o, od / d));
            }
        }
    }

    /// The others not significantly worse than `s`, added to its partners.
    fn add_partners(&self, s: &mut Selected, t: &Trial) {
        for &(o, od, mean_o, _) in &t.tried {
            if self.similar(t.chi_a + mean_o, t.chi_a) && !s.confounded.iter().any(|(c, _)| *c == o)
            {
                let factor = if s.coef == 0.0 { 0.0 } else { od / s.coef };
                s.confounded.push((o, factor));
            }
        }
    }
}

/// The step of a swap of `old` for `new`, worth `delta` in χ² in the fresh evaluation
/// with p-value `p` at `level`; `limit`: where the search of `new` ended, if at its grid's
/// end.
fn swap_step(
    old: CandidateId,
    new: CandidateId,
    delta: f64,
    p: f64,
    level: f64,
    limit: Option<String>,
) -> Step {
    Step {
        added: true,
        id: new,
        delta_chi2: delta,
        p_value: p,
        threshold: level,
        replaces: Some(old),
        note: Some(format!(
            "{} was selected by its sensitivity at the instrument file's value; put through the simulator over and beyond its band in its place, {} fits the data better by delta chi2 {delta:.1} in a fresh evaluation with other seeds (the swap needs p <= {} and at least {SWAP_MARGIN}), so {} is named instead{}",
            old.info().name,
            new.info().name,
            crate::output::significant(level, 2),
            new.info().name,
            limit.map_or_else(String::new, |l| format!(
                "; its best lies at the end of the search grid: {l}"
            ))
        )),
    }
}
