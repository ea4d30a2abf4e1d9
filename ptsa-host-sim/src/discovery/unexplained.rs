//! Structure that no candidate explains, tested after the selection and said out loud.
//!
//! Two tests, on the model with its nuisance terms and the *plausible* selected terms (an
//! implausible selection does not count as an explanation):
//!
//! * **lack of fit** against pure error, where rows are replicated: `F = (SS_lof/df_lof) /
//!   (SS_pe/df_pe)`, which does not rely on the stated sigmas at all;
//! * **a search of the residuals against a generic basis of the case inputs**: every input's
//!   time average and the time averages of their pairwise products (condition minus
//!   reference), each added to the model in turn and tested like a selection step
//!   ([`super::fit`]), with its own Bonferroni control over the basis.
//!
//! The two are combined by Bonferroni; `hint` names the basis element the residual follows
//! best, or the lack of fit.

use super::data::{Data, replicate_sets};
use super::fit::{Fitted, step_p};
use super::problem::Selected;
use super::report::{Unexplained, UnexplainedTest};
use crate::stats::{f_sf, lsq, norm, residualize};

/// Run the tests on `f` (the full-data model).
#[must_use]
#[allow(clippy::too_many_lines)] // the tests in turn, on one fit
pub fn test(data: &Data, f: &Fitted, selected: &[Selected], alpha: f64) -> Unexplained {
    // The model without its implausible terms.
    let cols = f.unit_columns();
    let nn = f.n_nuisance();
    let keep: Vec<&[f64]> = cols
        .iter()
        .enumerate()
        .filter(|&(j, _)| j < nn || selected.get(j - nn).is_none_or(|s| s.plausible))
        .map(|(_, c)| *c)
        .collect();
    let z = f.weighted_target();
    let Some(base) = lsq(&z, &keep) else {
        return none();
    };
    let n = z.len();
    let mut tests = Vec::new();
    // Lack of fit against pure error.
    let sets = replicate_sets(data, &f.subset);
    let df_pe: usize = sets.iter().map(|s| s.len() - 1).sum();
    let dof = n.saturating_sub(keep.len());
    if df_pe >= 2 && dof > df_pe {
        let mut ss_pe = 0.0;
        for set in &sets {
            #[allow(clippy::cast_precision_loss)]
            let m = set.iter().map(|&i| base.resid[i]).sum::<f64>() / set.len() as f64;
            ss_pe += set
                .iter()
                .map(|&i| (base.resid[i] - m).powi(2))
                .sum::<f64>();
        }
        let ss_lof = (base.chi2 - ss_pe).max(0.0);
        let df_lof = dof - df_pe;
        #[allow(clippy::cast_precision_loss)]
        let fstat = (ss_lof / df_lof as f64) / (ss_pe / df_pe as f64).max(f64::MIN_POSITIVE);
        #[allow(clippy::cast_precision_loss)]
        let p = f_sf(fstat, df_lof as f64, df_pe as f64);
        tests.push((
            UnexplainedTest {
                name: "lack_of_fit",
                p_value: p,
                detail: format!(
                    "replicated rows disagree with the model beyond their own scatter (F = {fstat:.2} for {df_lof} and {df_pe} dof)"
                ),
            },
            "the replicated rows' means (lack of fit against pure error)".to_string(),
        ));
    }
    // The generic basis.
    let mut best: Option<(f64, &str)> = None;
    let mut tried = 0usize;
    for (name, raw) in &data.features {
        let w: Vec<f64> = f
            .subset
            .iter()
            .enumerate()
            .map(|(k, &i)| raw[i] * f.weight(k))
            .collect();
        let s = norm(&w);
        if s == 0.0 {
            continue;
        }
        let unit: Vec<f64> = w.iter().map(|x| x / s).collect();
        if norm(&residualize(&unit, &keep)) < 1e-6 || keep.len() + 2 > n {
            continue;
        }
        let mut trial = keep.clone();
        trial.push(&unit);
        let Some(g) = lsq(&z, &trial) else { continue };
        tried += 1;
        let p = step_p(&g, &trial, trial.len() - 1, base.chi2, f.stated(), None);
        if best.is_none_or(|(bp, _)| p < bp) {
            best = Some((p, name));
        }
    }
    if let Some((p, name)) = best {
        #[allow(clippy::cast_precision_loss)]
        let p_adj = (p * tried as f64).min(1.0);
        tests.push((
            UnexplainedTest {
                name: "generic_basis",
                p_value: p_adj,
                detail: format!(
                    "{tried} averages of the case inputs and their products; the strongest is {name} (p = {p:.2e} before the Bonferroni factor)"
                ),
            },
            format!("residual follows {name}"),
        ));
    }
    if tests.is_empty() {
        return none();
    }
    let (k, (t, hint)) = tests
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.0.p_value.total_cmp(&b.1.0.p_value))
        .unwrap_or_else(|| unreachable!("tests is not empty"));
    let _ = k;
    #[allow(clippy::cast_precision_loss)]
    let p = (t.p_value * tests.len() as f64).min(1.0);
    Unexplained {
        detected: p <= alpha,
        p_value: p,
        hint: hint.clone(),
        tests: tests.into_iter().map(|(t, _)| t).collect(),
    }
}

fn none() -> Unexplained {
    Unexplained {
        detected: false,
        p_value: 1.0,
        hint: "none (nothing left to test)".into(),
        tests: Vec::new(),
    }
}
