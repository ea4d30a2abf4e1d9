//! The mirror check: whether the data give the sign of a parameter's change.

use super::problem::{Problem, Selected};
use super::search::{Scorer, not_worse};
use crate::model::effects::Effects;

/// For every selected parameter, whether the opposite change (the fitted value mirrored
/// about the file's) fits the data not significantly worse ([`not_worse`]):
/// then the response is even about the file's value and the data give the size of the
/// change, not its sign (a pickoff phase error enters as its cosine). One closed-loop pass
/// over the rows per selected parameter.
pub(crate) fn mirror(p: &Problem<'_>, selected: &mut [Selected]) {
    let (rows, data, f, sim, alpha) = p.parts();
    let params: Vec<usize> = (0..selected.len())
        .filter(|&k| selected[k].id.parameter_key().is_some() && selected[k].coef != 0.0)
        .collect();
    if params.is_empty() {
        return;
    }
    let scorer = Scorer::new(rows, data, f, selected, sim);
    let mut theta = Effects::NONE;
    for &k in &params {
        theta.set(selected[k].id, selected[k].coef);
    }
    let Some(chi) = scorer.chi2(&theta) else {
        return;
    };
    #[allow(clippy::cast_precision_loss)]
    let level = alpha / f.family_size().max(1) as f64;
    let dof = data
        .n()
        .saturating_sub(scorer.linear.len() + params.len())
        .max(1);
    for &k in &params {
        let mut m = theta;
        m.set(selected[k].id, -selected[k].coef);
        selected[k].mirror = scorer
            .chi2(&m)
            .is_some_and(|c| not_worse(c, chi, dof, f.stated(), level));
    }
}
