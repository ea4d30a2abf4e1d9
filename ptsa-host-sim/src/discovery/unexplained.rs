//! Structure that no candidate explains, tested after the selection and said out loud.
//!
//! The tests, on the model with its nuisance terms and the *plausible* selected terms (an
//! implausible selection does not count as an explanation):
//!
//! * **lack of fit** against pure error, where rows are replicated: `F = (SS_lof/df_lof) /
//!   (SS_pe/df_pe)`, which does not rely on the stated sigmas at all;
//! * **a search of the residuals against the library** ([`super::library`]), one test per
//!   family: the generic basis (every input's time average and those of their pairwise
//!   products, condition minus reference), the history (the previous row's inputs, their
//!   change, the sign of the last move along IA), time shapes beyond the linear drift, the
//!   products of three inputs, and the products with the row before. Each element is added
//!   to the model in turn and tested like a selection step ([`super::fit`]); each family has its
//!   own Bonferroni control over its elements.
//!
//! The tests are combined by a weighted Bonferroni (the lack of fit and the generic basis
//! weigh 1, the history, time shapes and products ½, the products with the row before ¼:
//! [`Family::weight`]), so the earlier tests keep most of the
//! level; `hint` names the element the residual follows best, or the lack of fit. When
//! structure is detected, `proposals` gives the strongest elements significant under the
//! same control, with their coefficients and units: forms to look at, never named causes.

use super::data::{Data, replicate_sets};
use super::fit::{Fitted, step_p};
use super::library::{Family, RowInputs};
use super::observation::Quantity;
use super::problem::Problem;
use super::report::{MAX_PROPOSALS, Proposal, TermReport, Unexplained, UnexplainedTest};
use crate::stats::{birge_ratio, f_sf, lsq, norm};

/// Elements of a family (beyond the generic basis, which is searched whole) fitted
/// exactly after the cheap screen by their χ² drop: the strongest few decide the family's
/// smallest p-value (exactly so with stated sigmas, where the p-value falls with the χ²
/// drop; with estimated sigmas the minimum over these is at least the minimum over all, so
/// the test stays valid).
const EXACT_PER_FAMILY: usize = 8;

/// `|cos|` of two elements' partial columns above which the data cannot tell them apart.
const SAME_COS: f64 = 0.999;

/// `|cos|` of two elements' partial columns from which one that fits not significantly
/// worse in the other's place (the swap's χ² increase has p > α) is named as
/// indistinguishable from it, as the selection names a partner.
const PARTNER_COS: f64 = 0.5;

/// Share of an element's part outside the model on one row above which it tests that row
/// (the outlier stage's question), not a shape: left out of its family (the generic basis
/// keeps its earlier elements).
const ONE_ROW_SHARE: f64 = 0.5;

/// One element tried.
struct Tried {
    shape: usize,
    p: f64,
    delta: f64,
    coef: f64,
    se: f64,
    partial: Vec<f64>,
}

/// An orthonormal basis of the span of `cols` (modified Gram–Schmidt, twice).
pub(crate) fn orthonormal(cols: &[&[f64]]) -> Vec<Vec<f64>> {
    let mut q: Vec<Vec<f64>> = Vec::new();
    for c in cols {
        let mut v = c.to_vec();
        let n0 = norm(&v);
        for _ in 0..2 {
            for b in &q {
                let d: f64 = b.iter().zip(&v).map(|(x, y)| x * y).sum();
                for (x, y) in v.iter_mut().zip(b) {
                    *x -= d * y;
                }
            }
        }
        let n = norm(&v);
        if n > 1e-10 * n0.max(f64::MIN_POSITIVE) {
            q.push(v.iter().map(|x| x / n).collect());
        }
    }
    q
}

/// `v` less its projection on the orthonormal `q`.
pub(crate) fn partial(v: &[f64], q: &[Vec<f64>]) -> Vec<f64> {
    let mut r = v.to_vec();
    for b in q {
        let d: f64 = b.iter().zip(&r).map(|(x, y)| x * y).sum();
        for (x, y) in r.iter_mut().zip(b) {
            *x -= d * y;
        }
    }
    r
}

/// Run the tests on the problem's full-data model, and the user's terms (`--term`).
#[must_use]
pub(crate) fn test(p: &Problem<'_>) -> Unexplained {
    let mut u = search(p.data, p.f, p.opts.alpha);
    if !p.opts.terms.is_empty() {
        u.terms = user_terms(p);
    }
    u
}

/// The final model's unit columns, every selected term's among them: a term beyond its
/// plausibility bound stays in the model these tests read (a bound flags, it does not
/// remove; docs/method/discovery.md).
fn kept(f: &Fitted) -> Vec<&[f64]> {
    f.unit_columns()
}

/// One column added to the model `keep` (fit `base` of the weighted target `z`) and tested
/// like a selection step: its p-value, χ² drop, coefficient and standard error per unit of
/// `raw`'s column (`None` when the column is 0 here or in the model's span).
fn added(
    f: &Fitted,
    z: &[f64],
    keep: &[&[f64]],
    base_chi2: f64,
    raw: &[f64],
) -> Option<(f64, f64, f64, f64)> {
    let w: Vec<f64> = f
        .subset
        .iter()
        .enumerate()
        .map(|(j, &i)| raw[i] * f.weight(j))
        .collect();
    let scale = norm(&w);
    if scale == 0.0 || keep.len() + 2 > z.len() {
        return None;
    }
    let unit: Vec<f64> = w.iter().map(|x| x / scale).collect();
    if norm(&partial(&unit, &orthonormal(keep))) < 1e-6 {
        return None;
    }
    let mut trial = keep.to_vec();
    trial.push(&unit);
    let g = lsq(z, &trial)?;
    let j = trial.len() - 1;
    let p = step_p(&g, &trial, j, base_chi2, f.stated(), None);
    let se = coefficient_se(f, &g, j, z.len() - trial.len());
    Some((
        p,
        (base_chi2 - g.chi2).max(0.0),
        g.beta[j] / scale,
        se / scale,
    ))
}

/// The standard error of coefficient `j` of a trial fit, as the selection gives it: the
/// classical one scaled by the Birge ratio with stated sigmas, else the larger of the
/// classical one at the residuals' scale and HC3.
fn coefficient_se(f: &Fitted, g: &crate::stats::LsqFit, j: usize, dof: usize) -> f64 {
    let classical = g.cov[(j, j)].max(0.0).sqrt();
    if f.stated() {
        classical * birge_ratio(g.chi2, dof)
    } else {
        #[allow(clippy::cast_precision_loss)]
        let s = (g.chi2 / dof.max(1) as f64).sqrt();
        (classical * s).max(g.se_hc3[j])
    }
}

/// The user's terms, each added to the model (nuisance terms and plausible selected terms)
/// and tested like a selection step, Bonferroni over the terms.
fn user_terms(p: &Problem<'_>) -> Vec<TermReport> {
    let (data, f, alpha) = (p.data, p.f, p.opts.alpha);
    let keep = kept(f);
    let z = f.weighted_target();
    let base = lsq(&z, &keep);
    let inputs = RowInputs::of(p.rows, p.sim.g_cm_s2());
    let m = p.opts.terms.len();
    p.opts
        .terms
        .iter()
        .map(|t| {
            let mut col = t.column(&inputs, &data.rows);
            for (x, q) in col.iter_mut().zip(&data.quantity) {
                if *q != Quantity::Value {
                    *x = 0.0;
                }
            }
            let fit = base
                .as_ref()
                .and_then(|b| added(f, &z, &keep, b.chi2, &col));
            #[allow(clippy::cast_precision_loss)]
            let p_adj = fit.map(|(pv, ..)| (pv * m as f64).min(1.0));
            TermReport {
                key: format!("term:{}", t.text),
                unit: t.unit(),
                testable: fit.is_some(),
                coefficient: fit.map(|x| x.2),
                se: fit.map(|x| x.3),
                p_value: p_adj,
                significant: p_adj.is_some_and(|x| x <= alpha),
            }
        })
        .collect()
}

/// A test of the residuals: what it found, the hint it gives, its weight in the
/// familywise level.
type Test = (UnexplainedTest, String, f64);

/// The search of the residuals: lack of fit and the library's families.
fn search(data: &Data, f: &Fitted, alpha: f64) -> Unexplained {
    let keep = kept(f);
    let z = f.weighted_target();
    let Some(base) = lsq(&z, &keep) else {
        return none();
    };
    let n = z.len();
    let mut tests: Vec<Test> = lack_of_fit(data, f, &base, n.saturating_sub(keep.len()))
        .into_iter()
        .collect();
    // The library, family by family.
    let q = orthonormal(&keep);
    let mut families: Vec<(Family, usize, Vec<Tried>)> = Vec::new();
    if keep.len() + 2 <= n {
        for family in Family::ALL {
            let mut screened = screen(data, f, family, &q, &base.resid);
            let tried = screened.len();
            if tried == 0 {
                continue;
            }
            if family != Family::Basis {
                screened.sort_by(|a, b| b.3.total_cmp(&a.3));
                screened.truncate(EXACT_PER_FAMILY);
            }
            let fitted = fit_each(f, &z, &keep, &q, base.chi2, screened);
            let Some(best) = fitted.iter().min_by(|a, b| a.p.total_cmp(&b.p)) else {
                continue;
            };
            #[allow(clippy::cast_precision_loss)]
            let p_adj = (best.p * tried as f64).min(1.0);
            let (detail, hint) = family_words(family, tried, &data.shapes[best.shape], best.p);
            tests.push((
                UnexplainedTest {
                    name: family.name(),
                    p_value: p_adj,
                    detail,
                },
                hint,
                family.weight(),
            ));
            families.push((family, tried, fitted));
        }
    }
    if tests.is_empty() {
        return none();
    }
    let total: f64 = tests.iter().map(|t| t.2).sum();
    let adjusted = |p: f64, w: f64| (p * total / w).min(1.0);
    let (t, hint, w) = tests
        .iter()
        .min_by(|a, b| adjusted(a.0.p_value, a.2).total_cmp(&adjusted(b.0.p_value, b.2)))
        .unwrap_or_else(|| unreachable!("tests is not empty"));
    let p = adjusted(t.p_value, *w);
    let detected = p <= alpha;
    let proposals = if detected {
        proposals(data, &families, total, alpha)
    } else {
        Vec::new()
    };
    Unexplained {
        detected,
        p_value: p,
        hint: hint.clone(),
        tests: tests.into_iter().map(|(t, _, _)| t).collect(),
        proposals,
        terms: Vec::new(),
    }
}

/// Lack of fit against pure error, where the replicated rows give at least 2 degrees of
/// freedom and the model's residual (`dof`) has more.
fn lack_of_fit(data: &Data, f: &Fitted, base: &crate::stats::LsqFit, dof: usize) -> Option<Test> {
    let sets = replicate_sets(data, &f.subset);
    let df_pe: usize = sets.iter().map(|s| s.len() - 1).sum();
    if df_pe < 2 || dof <= df_pe {
        return None;
    }
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
    Some((
        UnexplainedTest {
            name: "lack_of_fit",
            p_value: p,
            detail: format!(
                "replicated rows disagree with the model beyond their own scatter (F = {fstat:.2} for {df_lof} and {df_pe} dof)"
            ),
        },
        "the replicated rows' means (lack of fit against pure error)".to_string(),
        1.0,
    ))
}

/// The elements of `family` the residuals can test: per element, its index, weighted unit
/// column, scale and χ² drop by projection on the residuals `resid` (off the model's span
/// `q`); those inside the span, and outside the basis those on one row, left out.
fn screen(
    data: &Data,
    f: &Fitted,
    family: Family,
    q: &[Vec<f64>],
    resid: &[f64],
) -> Vec<(usize, Vec<f64>, f64, f64)> {
    let mut screened = Vec::new();
    for (k, s) in data.shapes.iter().enumerate() {
        if s.family != family {
            continue;
        }
        let w: Vec<f64> = f
            .subset
            .iter()
            .enumerate()
            .map(|(j, &i)| s.col[i] * f.weight(j))
            .collect();
        let scale = norm(&w);
        if scale == 0.0 {
            continue;
        }
        let unit: Vec<f64> = w.iter().map(|x| x / scale).collect();
        let part = partial(&unit, q);
        let pn = norm(&part);
        let one_row = family != Family::Basis
            && part.iter().fold(0.0_f64, |m, x| m.max(x * x)) > ONE_ROW_SHARE * pn * pn;
        if pn < 1e-6 || one_row {
            continue;
        }
        let d: f64 = part.iter().zip(resid).map(|(a, b)| a * b).sum();
        screened.push((k, unit, scale, (d / pn).powi(2)));
    }
    screened
}

/// Each screened element fitted beside the model's columns `keep`: its p-value against
/// the model's `χ²`, its coefficient and standard error in the element's own unit.
fn fit_each(
    f: &Fitted,
    z: &[f64],
    keep: &[&[f64]],
    q: &[Vec<f64>],
    chi2: f64,
    screened: Vec<(usize, Vec<f64>, f64, f64)>,
) -> Vec<Tried> {
    let n = z.len();
    let mut fitted: Vec<Tried> = Vec::new();
    for (k, unit, scale, _) in screened {
        let mut trial = keep.to_vec();
        trial.push(&unit);
        let Some(g) = lsq(z, &trial) else { continue };
        let j = trial.len() - 1;
        let p = step_p(&g, &trial, j, chi2, f.stated(), None);
        let se = coefficient_se(f, &g, j, n - trial.len());
        fitted.push(Tried {
            shape: k,
            p,
            delta: (chi2 - g.chi2).max(0.0),
            coef: g.beta[j] / scale,
            se: se / scale,
            partial: partial(&unit, q),
        });
    }
    fitted
}

/// A family's test in words: what was tried and the strongest element (`detail`), and the
/// hint it gives.
fn family_words(
    family: Family,
    tried: usize,
    s: &super::library::Shape,
    p: f64,
) -> (String, String) {
    // What the family tried, and what the hint adds after the strongest element.
    let (what, after) = match family {
        Family::Basis => (
            "averages of the case inputs and their products".to_string(),
            "",
        ),
        Family::History => (
            "of the previous row's inputs, their changes since it and the sign of the last move along IA".to_string(),
            " (the row before)",
        ),
        Family::Time => (
            "shapes in time beyond the linear drift (t from the first row)".to_string(),
            " (a shape in time)",
        ),
        Family::Products => ("products of three of the case inputs".to_string(), ""),
        Family::HistoryProducts => (
            "products of the case inputs with the row before's (up to third order)".to_string(),
            " (with the row before)",
        ),
        Family::Harmonics => (
            format!(
                "harmonics of the tumble's angle from the {}th to what its positions resolve (IEEE Std 1293's Fourier analysis)",
                super::library::FIRST_HARMONIC
            ),
            " (a harmonic of the tumble's angle)",
        ),
    };
    let shown = if family == Family::Basis {
        &s.name
    } else {
        &s.form
    };
    (
        format!(
            "{tried} {what}; the strongest is {shown} (p = {p:.2e} before the Bonferroni factor)"
        ),
        format!("residual follows {shown}{after}"),
    )
}

/// The elements significant under the familywise control (the element's p-value times its
/// family's size, over the family's share of the level), strongest first; elements the
/// data cannot tell apart are one proposal, given by the simplest form.
fn proposals(
    data: &Data,
    families: &[(Family, usize, Vec<Tried>)],
    total: f64,
    alpha: f64,
) -> Vec<Proposal> {
    let mut sig: Vec<(&Tried, f64, Family)> = Vec::new();
    for (family, tried, fitted) in families {
        for t in fitted {
            #[allow(clippy::cast_precision_loss)]
            let p = (t.p * *tried as f64 * total / family.weight()).min(1.0);
            if p <= alpha {
                sig.push((t, p, *family));
            }
        }
    }
    sig.sort_by(|a, b| b.0.delta.total_cmp(&a.0.delta).then(a.1.total_cmp(&b.1)));
    // Groups: the strongest element and those the data cannot tell from it (parallel
    // partial columns, or a swap not significantly worse with |cos| ≥ 0.5).
    let mut groups: Vec<Vec<(&Tried, f64, Family)>> = Vec::new();
    for e in sig {
        let same = groups.iter_mut().find(|g| {
            let c = crate::stats::abs_cos(&g[0].0.partial, &e.0.partial);
            c > SAME_COS
                || (c >= PARTNER_COS
                    && crate::stats::chi2_sf((g[0].0.delta - e.0.delta).max(0.0), 1.0) > alpha)
        });
        match same {
            Some(g) => g.push(e),
            None => groups.push(vec![e]),
        }
    }
    groups
        .into_iter()
        .take(MAX_PROPOSALS)
        .map(|g| {
            let (t, p, family) = *g
                .iter()
                .min_by_key(|(t, _, _)| (data.shapes[t.shape].complexity, t.shape))
                .unwrap_or(&g[0]);
            let s = &data.shapes[t.shape];
            Proposal {
                form: s.form.clone(),
                coefficient: t.coef,
                unit: s.unit.clone(),
                se: t.se,
                p_value: p,
                family: family.name(),
                indistinguishable_from: g
                    .iter()
                    .filter(|(o, _, _)| o.shape != t.shape)
                    .map(|(o, _, _)| data.shapes[o.shape].form.clone())
                    .collect(),
            }
        })
        .collect()
}

fn none() -> Unexplained {
    Unexplained {
        detected: false,
        p_value: 1.0,
        hint: "none (nothing left to test)".into(),
        tests: Vec::new(),
        proposals: Vec::new(),
        terms: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use crate::discovery::library::parse_term;
    use crate::discovery::sim::{AnalyticSimulator, Simulator as _};
    use crate::discovery::{Options, discover};
    use crate::lab::plan::{Axis, tumble};
    use crate::model::condition::{Condition, PA};
    use crate::model::effects::Effects;
    use crate::model::instrument::Instrument;
    use rand::SeedableRng as _;
    use rand_distr::Distribution as _;

    /// A 48-point tumble about OA read by the analytic simulator, plus `extra(a_PA)` and
    /// Gaussian noise of `sigma` (seeded), `sigma_cm_s2` stated.
    fn tumble_with(seed: u64, sigma: f64, extra: impl Fn(f64) -> f64) -> Vec<Condition> {
        let sim = AnalyticSimulator::for_instrument(&Instrument::kearfott_2401());
        let g = Instrument::kearfott_2401().g_cm_s2;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let noise = rand_distr::Normal::new(0.0, sigma).unwrap();
        let mut rows = tumble(48, Axis::Oa);
        for r in &mut rows {
            let a_pa = r.g[PA] * g;
            r.measured_cm_s2 =
                Some(sim.absolute_cm_s2(r, &Effects::NONE) + extra(a_pa) + noise.sample(&mut rng));
            r.sigma_cm_s2 = Some(sigma);
        }
        rows
    }

    #[test]
    fn a_planted_cubic_in_a_pa_is_the_top_proposal() {
        // k·a_PA³ with k = −8e-11 s⁴/cm² (−0.075 cm/s² at a_PA = g), noise 0.01 cm/s²:
        // no candidate holds it; the misalignment toward PA takes its cos φ part, the
        // rest (cos 3φ) is left to the library.
        let k = -8e-11;
        let rows = tumble_with(7, 0.01, |a| k * a.powi(3));
        let sim = AnalyticSimulator::for_instrument(&Instrument::kearfott_2401());
        let d = discover(&rows, &sim, &Options::default()).unwrap();
        let u = &d.json.unexplained;
        assert!(u.detected, "{u:?}");
        let top = &u.proposals[0];
        assert_eq!(top.form, "a_PA^3", "{u:?}");
        assert_eq!(top.unit, "s⁴/cm²");
        assert!(top.p_value <= 0.05);
        assert!((top.coefficient - k).abs() < 4.0 * top.se, "{top:?}");
        // The forms the data cannot tell from it (given the misalignment) are named.
        assert!(
            top.indistinguishable_from
                .iter()
                .any(|f| f == "a_IA^2*a_PA"),
            "{top:?}"
        );
        // The same as a user's term: significant, with the same coefficient.
        let opts = Options {
            terms: vec![parse_term("a_pa^3").unwrap(), parse_term("w_oa").unwrap()],
            ..Options::default()
        };
        let d = discover(&rows, &sim, &opts).unwrap();
        let t = &d.json.unexplained.terms;
        assert_eq!(t[0].key, "term:a_pa^3");
        assert!(t[0].significant && (t[0].coefficient.unwrap() - k).abs() < 4.0 * t[0].se.unwrap());
        // No rate in a tumble: not testable.
        assert!(!t[1].testable && t[1].coefficient.is_none() && !t[1].significant);
    }

    #[test]
    fn null_tumbles_give_no_proposals() {
        // 20 null sets: the search fires at most at its familywise level (P(≥ 4 of 20) at
        // 5 % is 1.6 %), and a set where nothing is detected proposes nothing.
        let sim = AnalyticSimulator::for_instrument(&Instrument::kearfott_2401());
        let mut fired = 0;
        for seed in 0..20 {
            let rows = tumble_with(100 + seed, 0.02, |_| 0.0);
            let d = discover(&rows, &sim, &Options::default()).unwrap();
            let u = &d.json.unexplained;
            if u.detected {
                fired += 1;
            } else {
                assert!(u.proposals.is_empty(), "{u:?}");
            }
            // The history, time and product families are tested.
            for name in [
                "generic_basis",
                "history",
                "time_shapes",
                "products",
                "history_products",
            ] {
                assert!(u.tests.iter().any(|t| t.name == name), "{name}: {u:?}");
            }
        }
        assert!(fired <= 3, "{fired} of 20 null sets flagged");
    }
}
