//! Advice that breaks a confounding: for every group of candidates the data cannot tell
//! apart (and, on absolute data, every model-equation term they cannot test), the few rows
//! from a library of feasible extra rows that best separate them; and, when a selected
//! term could be a shape in time or the residual follows one ([`time_order`]), the
//! positions again in the reverse order.
//!
//! The library ([`library`]) holds what a lab can run: tumble positions about OA and PA,
//! rate-table positions at three rates, the two-axis oscillator's blocks and centrifuge
//! levels with IA in and out ([`crate::lab::plan`]). The search is greedy: each step adds the row
//! that most increases the smallest singular value of the group's weighted signatures, each
//! made orthogonal to the other selected terms' (columns scaled to unit norm over the data
//! and the library), until that value reaches [`GOOD`] or [`MAX_ROWS`] rows are added.
//! Candidates whose signatures coincide for every motion (`anisoinertia` and
//! `lever_arm.r_pa_cm`: both `w_IA·w_PA`) cannot be separated by any row; the advice says so
//! instead of proposing rows that do not help.

use super::data::{Data, signatures};
use super::fit::Fitted;
use super::problem::Selected;
pub use super::report::Advice;
use super::report::Unexplained;
use crate::lab::plan::{self, Axis};
use crate::model::condition::{Condition, RowKind};
use crate::model::effects::CandidateId;
use crate::stats::residualize;

/// Most rows proposed per group.
pub const MAX_ROWS: usize = 4;
/// The smallest singular value (of the columns scaled to norm 1 before being made orthogonal
/// to the other selected terms) at which a
/// group counts as separated.
pub const GOOD: f64 = 0.5;

/// The library of feasible extra rows.
#[must_use]
pub fn library(g_cm_s2: f64) -> Vec<Condition> {
    let mut rows = Vec::new();
    for axis in [Axis::Oa, Axis::Pa, Axis::Ia] {
        rows.extend(plan::tumble(24, axis));
    }
    for axis in [Axis::Oa, Axis::Pa] {
        for rate in [0.5, 1.0, 2.0] {
            rows.extend(plan::rate_table(24, axis, rate, 0.05, 0.0));
        }
    }
    rows.extend(plan::shaker(10.0, 300.0, 1.0, 8));
    rows.extend(plan::centrifuge(50.0, &[2.0, 5.0, 10.0], g_cm_s2));
    rows
}

/// Smallest singular value over largest (0 for an empty or all-zero matrix) and the
/// smallest singular value of the columns `cols` (each a column over the rows).
fn smallest_sv(cols: &[Vec<f64>]) -> f64 {
    let n = cols.first().map_or(0, Vec::len);
    if cols.is_empty() || n == 0 {
        return 0.0;
    }
    let a = nalgebra::DMatrix::from_fn(n, cols.len(), |i, j| cols[j][i]);
    a.singular_values().min()
}

/// The group's columns over the current rows (data rows then added rows), each made
/// orthogonal to the context's and divided by its norm before that (so 1 means "untouched
/// by the context"): the smallest singular value is then 0 for dependent or empty columns
/// and 1 for orthogonal ones untouched by the context.
fn group_columns(group: &[Vec<f64>], context: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let ctx: Vec<&[f64]> = context.iter().map(Vec::as_slice).collect();
    group
        .iter()
        .map(|c| {
            let n = c.iter().map(|x| x * x).sum::<f64>().sqrt();
            if n == 0.0 {
                return vec![0.0; c.len()];
            }
            residualize(c, &ctx).iter().map(|x| x / n).collect()
        })
        .collect()
}

/// Weighted signatures of `ids` over `rows` (unit coefficients, weight `1/sigma`).
fn weighted(rows: &[&Condition], ids: &[CandidateId], g: f64, sigma: f64) -> Vec<Vec<f64>> {
    signatures(rows, ids, g)
        .into_iter()
        .map(|s| s.col.iter().map(|x| x / sigma).collect())
        .collect()
}

/// The groups that need advice: every confounded group with a selected member, every
/// selected candidate's confounded partners, and, when the data hold absolute rows, every
/// model-equation term that is not testable.
fn groups(
    data: &Data,
    rows: &[Condition],
    f: &Fitted,
    selected: &[Selected],
    confounded: &[Vec<CandidateId>],
) -> Vec<Vec<CandidateId>> {
    let mut out: Vec<Vec<CandidateId>> = Vec::new();
    let mut push = |mut g: Vec<CandidateId>| {
        g.sort_unstable();
        g.dedup();
        if !g.is_empty() && !out.contains(&g) {
            out.push(g);
        }
    };
    for g in confounded {
        if g.iter().any(|c| selected.iter().any(|s| s.id == *c)) {
            push(g.clone());
        }
    }
    for s in selected {
        if !s.confounded.is_empty() {
            let mut g: Vec<CandidateId> = s.confounded.iter().map(|&(o, _)| o).collect();
            g.push(s.id);
            push(g);
        }
    }
    if data
        .rows
        .iter()
        .any(|&i| rows[i].kind == crate::model::condition::RowKind::Absolute)
    {
        for &c in f.untestable.iter().chain(&f.untestable_nuisance) {
            if c.model_equation_term() {
                push(vec![c]);
            }
        }
    }
    out
}

/// Advice for the fit `f` of `data` (the rows `rows`), with local gravity `g`.
#[must_use]
pub fn advise(
    data: &Data,
    rows: &[Condition],
    f: &Fitted,
    selected: &[Selected],
    confounded: &[Vec<CandidateId>],
    g: f64,
) -> Vec<Advice> {
    let fitted: Vec<&Condition> = data.rows.iter().map(|&i| &rows[i]).collect();
    let mut sig: Vec<f64> = f.sigma.clone();
    sig.sort_by(f64::total_cmp);
    let sigma = sig.get(sig.len() / 2).copied().unwrap_or(1.0);
    let lib = library(g);
    let lib_refs: Vec<&Condition> = lib.iter().collect();
    groups(data, rows, f, selected, confounded)
        .into_iter()
        .map(|group| {
            // The context: the other selected terms.
            let ctx_ids: Vec<CandidateId> = selected
                .iter()
                .map(|s| s.id)
                .filter(|id| !group.contains(id))
                .collect();
            let data_g: Vec<Vec<f64>> = fitted_weighted(&fitted, &group, g, &f.sigma);
            let data_c: Vec<Vec<f64>> = fitted_weighted(&fitted, &ctx_ids, g, &f.sigma);
            let lib_g = weighted(&lib_refs, &group, g, sigma);
            let lib_c = weighted(&lib_refs, &ctx_ids, g, sigma);
            let build = |added: &[usize]| -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
                let extend = |d: &[Vec<f64>], l: &[Vec<f64>]| -> Vec<Vec<f64>> {
                    d.iter()
                        .zip(l)
                        .map(|(dc, lc)| {
                            let mut v = dc.clone();
                            v.extend(added.iter().map(|&k| lc[k]));
                            v
                        })
                        .collect()
                };
                (extend(&data_g, &lib_g), extend(&data_c, &lib_c))
            };
            let score = |added: &[usize]| {
                let (gc, cc) = build(added);
                smallest_sv(&group_columns(&gc, &cc))
            };
            let start = score(&[]);
            // A term made testable needs at least two rows of its own.
            let min_rows = if group.len() == 1 { 2 } else { 1 };
            let (added, best) = pick_rows(&score, &lib_g, start, min_rows);
            let rows: Vec<Condition> = added.iter().map(|&k| lib[k].clone()).collect();
            advice(&group, rows, (start, best), sigma)
        })
        .collect()
}

/// The library's rows added one at a time, each the one that lifts `score` (the smallest
/// singular value of the group's scaled signatures, `start` with none) most, until it
/// reaches [`GOOD`] with at least `min_rows` rows, or [`MAX_ROWS`], or no row helps; the
/// rows (indices into the library, whose group signatures are `lib_g`) and the score.
fn pick_rows(
    score: &dyn Fn(&[usize]) -> f64,
    lib_g: &[Vec<f64>],
    start: f64,
    min_rows: usize,
) -> (Vec<usize>, f64) {
    let rows = lib_g.first().map_or(0, Vec::len);
    let mut added: Vec<usize> = Vec::new();
    let mut best = start;
    while added.len() < MAX_ROWS && (best < GOOD || added.len() < min_rows) {
        let mut pick: Option<(usize, f64)> = None;
        for k in 0..rows {
            // A row where every member's signature is 0 cannot help.
            if added.contains(&k) || lib_g.iter().all(|c| c[k] == 0.0) {
                continue;
            }
            let mut trial = added.clone();
            trial.push(k);
            let s = score(&trial);
            if pick.is_none_or(|(_, ps)| s > ps * (1.0 + 1e-9)) {
                pick = Some((k, s));
            }
        }
        match pick {
            Some((k, s))
                if s > best * (1.0 + 1e-6) + 1e-9 || (added.len() < min_rows && s > 1e-6) =>
            {
                added.push(k);
                best = s;
            }
            _ => break,
        }
    }
    (added, best)
}

/// The advice for `group`: the `rows` picked, with the score before and after them
/// (`scores`), the data's median sigma `sigma`; or why no row of the library helps.
fn advice(group: &[CandidateId], rows: Vec<Condition>, scores: (f64, f64), sigma: f64) -> Advice {
    let (start, best) = scores;
    let names: Vec<String> = group.iter().map(|c| c.info().name.to_string()).collect();
    let what = if group.len() == 1 {
        format!("to test {}", names[0])
    } else {
        format!("to tell {} apart", and_list(&names))
    };
    if rows.is_empty() || best < 1e-6 {
        return Advice {
            separates: names,
            add_rows: Vec::new(),
            note: format!(
                "{what}, no row of the library helps: {}",
                if group == [CandidateId::Anisoinertia, CandidateId::LeverArmPa] {
                    "their mean signatures are the same, w_IA·w_PA, for every motion; separate them outside these data, by centring the proof mass on the table axis as R-890 did (so that the lever arm is known to be 0), or by the response at the oscillation frequency to angular acceleration about OA"
                } else {
                    "their mean signatures stay dependent (or zero) for every tumble position, rate, vibration and centrifuge level of the library"
                }
            ),
            rows: Vec::new(),
        };
    }
    Advice {
        separates: names,
        add_rows: rows
            .iter()
            .map(crate::model::caseframe::to_object)
            .collect(),
        note: format!(
            "{what}, add these {} row{} (measured at about the data's {sigma:.3} cm/s²): the smallest singular value of the group's scaled signatures goes from {start:.3} to {best:.3}{}",
            rows.len(),
            if rows.len() == 1 { "" } else { "s" },
            if best >= GOOD {
                ""
            } else {
                " (still short of a clean separation)"
            }
        ),
        rows,
    }
}

/// The shapes whose order in time the rows' positions cannot tell from the terms of the
/// positions: the rivals from the time shapes and the history of the selected terms, and
/// the unexplained search's top proposal when it is one; with the terms they stand beside.
fn time_shaped(selected: &[Selected], unexplained: &Unexplained) -> (Vec<String>, Vec<String>) {
    let in_time = |family: &str| family == "time_shapes" || family.starts_with("history");
    let mut terms = Vec::new();
    let mut forms: Vec<String> = Vec::new();
    for s in selected {
        let rivals: Vec<&str> = s
            .rivals
            .iter()
            .filter(|r| in_time(r.family))
            .map(|r| r.form.as_str())
            .collect();
        if !rivals.is_empty() {
            terms.push(s.id.info().name.to_string());
            forms.extend(rivals.iter().map(|f| (*f).to_string()));
        }
    }
    if unexplained.detected
        && let Some(p) = unexplained.proposals.first().filter(|p| in_time(p.family))
    {
        forms.push(p.form.clone());
    }
    // Each form once, in the order first met.
    let mut seen = Vec::new();
    forms.retain(|f| {
        let new = !seen.contains(f);
        seen.push(f.clone());
        new
    });
    (terms, forms)
}

/// Advice when a selected term could be a shape in time, or the residual follows one
/// (`time_shaped`): the measured positions again in the reverse order, with the first
/// repeated at the end. A term of the positions reads the same both ways; a drift, a
/// warm-up or an effect of the row before does not.
#[must_use]
pub fn time_order(
    rows: &[Condition],
    selected: &[Selected],
    unexplained: &Unexplained,
) -> Option<Advice> {
    let (terms, forms) = time_shaped(selected, unexplained);
    if forms.is_empty() {
        return None;
    }
    let mut measured: Vec<&Condition> = rows
        .iter()
        .filter(|r| r.kind == RowKind::Absolute && r.is_static() && r.is_measured())
        .collect();
    let timed = measured.iter().all(|r| r.time_s.is_some());
    if timed {
        measured.sort_by(|a, b| a.time_s.unwrap_or(0.0).total_cmp(&b.time_s.unwrap_or(0.0)));
    }
    let first = *measured.first()?;
    let again = |r: &Condition, how: &str| Condition {
        label: format!("{} (again, {how})", r.label),
        kind: RowKind::Absolute,
        g: r.g,
        ..Condition::default()
    };
    let mut out: Vec<Condition> = measured
        .iter()
        .rev()
        .map(|r| again(r, "reverse order"))
        .collect();
    out.push(again(first, "first position repeated at the end"));
    let what = if terms.is_empty() {
        "the residual follows a shape in the order the rows were measured".to_string()
    } else {
        format!(
            "{} cannot be told here from {} (a shape in the order the rows were measured)",
            and_list(&terms),
            and_list(&forms)
        )
    };
    Some(Advice {
        separates: terms.into_iter().chain(forms).collect(),
        add_rows: out.iter().map(crate::model::caseframe::to_object).collect(),
        note: format!(
            "{what}: measure the {} positions again in the reverse order, and the first once more at the end ({} rows): a term of the positions reads the same both ways, a drift, a warm-up or an effect of the row before does not{}",
            measured.len(),
            out.len(),
            if timed {
                ""
            } else {
                "; these rows give no time_s, so their order stands in for time: give time_s (and power_on_s) to test a warm-up"
            }
        ),
        rows: out,
    })
}

/// Weighted signatures over the fitted rows (each row its own sigma).
fn fitted_weighted(
    rows: &[&Condition],
    ids: &[CandidateId],
    g: f64,
    sigma: &[f64],
) -> Vec<Vec<f64>> {
    signatures(rows, ids, g)
        .into_iter()
        .map(|s| s.col.iter().zip(sigma).map(|(x, s)| x / s).collect())
        .collect()
}

/// The advised rows of every piece of advice, once each.
#[must_use]
pub fn all_rows(advice: &[Advice]) -> Vec<Condition> {
    let mut out: Vec<Condition> = Vec::new();
    for r in advice.iter().flat_map(|a| &a.rows) {
        if !out.contains(r) {
            out.push(r.clone());
        }
    }
    out
}

/// `a`, `a and b`, `a, b and c`.
fn and_list(names: &[String]) -> String {
    match names {
        [] => String::new(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} and {last}", init.join(", ")),
    }
}
