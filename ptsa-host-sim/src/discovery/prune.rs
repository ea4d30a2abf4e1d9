//! The prune: a second selected parameter that only took up the first's curvature is
//! dropped.

use rayon::prelude::*;

use super::fit::Step;
use super::problem::{Problem, Selected};
use super::refine::refine;
use super::search::{Scorer, not_worse, worse_p};
use crate::model::effects::Effects;

/// Drop selected parameters the data do not need once the others are refined through the
/// closed loop: the selection tests each parameter by its sensitivity at the file's value,
/// and a change far beyond the band (the damping off by half its value) leaves a curvature
/// that a second parameter's sensitivity takes up; refined together, the two settle in a
/// wrong valley. So while two or more parameters are selected, each is dropped in turn and
/// the others refined without it ([`refine`], Gauss–Newton); the one whose absence costs
/// least goes if the χ² is not significantly worse ([`not_worse`], at α/m).
/// Returns whether something was dropped (each drop a step in `steps`).
pub(crate) fn prune(p: &Problem<'_>, selected: &mut Vec<Selected>, steps: &mut Vec<Step>) -> bool {
    let (rows, data, f, sim, alpha) = p.parts();
    #[allow(clippy::cast_precision_loss)]
    let level = alpha / f.family_size().max(1) as f64;
    let theta = |sel: &[Selected]| {
        let mut t = Effects::NONE;
        for s in sel.iter().filter(|s| s.id.parameter_key().is_some()) {
            t.set(s.id, s.coef);
        }
        t
    };
    let mut dropped = false;
    loop {
        let params: Vec<usize> = (0..selected.len())
            .filter(|&k| selected[k].id.parameter_key().is_some())
            .collect();
        if params.len() < 2 {
            return dropped;
        }
        let scorer = Scorer::new(rows, data, f, selected, sim);
        let Some(chi) = scorer.chi2(&theta(selected)) else {
            return dropped;
        };
        let dof = data
            .n()
            .saturating_sub(scorer.linear.len() + params.len())
            .max(1);
        let best = params
            .par_iter()
            .filter_map(|&j| {
                let mut reduced = selected.clone();
                reduced.remove(j);
                refine(p, &mut reduced);
                scorer.chi2(&theta(&reduced)).map(|c| (c, reduced))
            })
            .collect::<Vec<_>>()
            .into_iter()
            .min_by(|a, b| a.0.total_cmp(&b.0));
        match best {
            Some((c, reduced)) if not_worse(c, chi, dof, f.stated(), level) => {
                if let Some(gone) = selected
                    .iter()
                    .find(|s| !reduced.iter().any(|r| r.id == s.id))
                {
                    steps.push(Step {
                        added: false,
                        id: gone.id,
                        delta_chi2: c - chi,
                        p_value: worse_p(c, chi, dof, f.stated()),
                        threshold: level,
                        replaces: None,
                        note: Some(format!(
                            "refined through the simulator without {}, the other parameters fit the data not significantly worse: it only took up their curvature",
                            gone.id.info().name
                        )),
                    });
                }
                *selected = reduced;
                dropped = true;
            }
            _ => return dropped,
        }
    }
}
