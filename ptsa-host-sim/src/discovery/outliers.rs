//! Suspected gross errors: rows whose value is far beyond what the model and the noise allow
//! (a cell left empty and read as 0, a value in another unit, a slip of the pen, a disturbed
//! run), found before any term is selected to explain them.
//!
//! **The test of one row** is its externally studentized residual against the model
//! **selected without it**: the whole stepwise fit ([`fit::fit`]: nuisance terms, noise,
//! selection) on the other rows, then the row's value against that model's prediction,
//! `t = (z_i − x_iβ̂) / (s·√(1 + x_i C x_iᵀ))` in the weighted units of the fit (`z` the
//! residual to explain over its sigma, `x_i` the row's design row, `C` the coefficients'
//! covariance for unit variance, `s²` the other rows' residual variance on `ν` degrees of
//! freedom). For a fixed model this is the classical externally studentized residual
//! `e_i / (s_(i)·√(1 − h_ii))`, and `t ~ t_ν` when the row is no outlier; the held-out row
//! plays no part in choosing the model, so the selection does not change that. The test is
//! scale-free: a stated sigma wrong by a common factor changes nothing.
//!
//! Why the model without the row: a gross error in a row is a column that is 1 on that row
//! and 0 elsewhere, and the vocabulary can sometimes build it. A 48-point tumble with one
//! `g_ia` cell empty puts that row off the circle `a_IA² + a_PA² = g²` on which every other
//! row lies, so `K_2·a_IA² + K_pp·a_PA² + K_0` with `K_2 = K_pp = −K_0/g²` is zero on every
//! other row and not on that one: with those three terms selected the row's leverage is 1,
//! its residual 0, and no test of the residuals of the selected model can see it. Selected
//! without the row, the model holds none of them, and the row's prediction misses by what
//! the empty cell did (950 cm/s²).
//!
//! **The family**: every fitted `measured_cm_s2` value whose removal leaves each nuisance
//! term something to fit (a difference row alone in its block is not testable: its block's
//! shift fits it whatever it holds). Response rows' gains and phases are not tested (they
//! stay in the fit). A row is flagged when `m·p ≤` [`ALPHA`] (Bonferroni over the `m` rows
//! of the family; `p` two-sided from `t_ν`), so under the model the chance that any row of
//! a clean set is flagged is at most [`ALPHA`]. The rows tested are those that could hide:
//! the [`SCREEN_TOP`] largest externally studentized residuals of the model selected with
//! every row, and every row whose leverage there is at least [`SCREEN_LEVERAGE`] (a row
//! that selected terms fit by leverage); the Bonferroni factor counts the whole family, so
//! the screen only saves work and never raises the false-alarm rate.
//!
//! **Several rows**: the most significant row is set aside and the search repeated on the
//! rest (the selection redone without it), up to [`MAX_OUTLIERS`] rows; a set with no
//! outlier is flagged only at the first round, so the familywise rate stays [`ALPHA`]. One
//! gross row at a time fails when several gross rows pull the model (and, estimated, the
//! noise) their way: five rows of a 24-point tumble typed in g make the model selected
//! without any one of them absurd, and right rows then look wrong. Rows that look like a
//! slip whatever the model (their own value a known unit's multiple of the baseline,
//! `slips::row_slips`) are therefore tested first, all together: each against the model
//! selected without every one of them, at the same familywise level.
//!
//! Where it fails (measured in `docs/method/discovery.md`): the test assumes the model selected
//! without the row describes the other rows up to noise of the stated relative sizes. Noise
//! that grows from row to row within one variance group without `sigma_cm_s2` saying so,
//! or a real effect the vocabulary lacks (or the selection misses) concentrated on a few
//! rows, makes a row look like a gross error; and a row whose information no other row
//! repeats (leverage 1 with every term it needs) can never be told from a real effect.

use rayon::prelude::*;

use super::data::Data;
use super::fit::{self, Fitted, Settings};
use super::observation::Quantity;
use super::problem::{Options, plausible};
use super::sim::Simulator;
use super::slips::row_slips;
use crate::model::caseframe::EmptyCells;
use crate::model::condition::Condition;
use crate::model::effects::CandidateId;
use crate::stats::{lsq, norm, t_two_sided};

/// Familywise level of the outlier test: at most this fraction of clean data sets has a
/// row flagged (a gross error is many noise standard deviations; a false alarm sets a good
/// row aside, so the level is stricter than the selection's 5 %).
pub const ALPHA: f64 = 0.01;

/// Most rows set aside as suspected gross errors; more than this and the model, not a few
/// rows, is what fails (a warning says so).
pub const MAX_OUTLIERS: usize = 3;

/// Rows with the largest externally studentized residuals in the model selected with every
/// row that are tested without themselves.
pub const SCREEN_TOP: usize = 5;

/// Leverage in the model selected with every row from which a row is tested without
/// itself, whatever its residual (selected terms may fit it by leverage alone).
pub const SCREEN_LEVERAGE: f64 = 0.5;

/// The test of one observation against a model fitted without it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeldOut {
    /// Externally studentized residual.
    pub t: f64,
    /// Its degrees of freedom (the model's residual degrees of freedom).
    pub dof: usize,
    /// `measured − (baseline + the model's prediction)`, in the observation's unit.
    pub error: f64,
    /// Its standard error, the same unit: the noise and the prediction's uncertainty.
    pub error_se: f64,
    /// Two-sided `P(|t_ν| ≥ |t|)`.
    pub p: f64,
}

/// The externally studentized residual of observation `i` of `data` against `f`, a model
/// fitted to rows that do not include it. `None` when it cannot be tested: the model holds
/// no block shift for a row that takes one, no sigma for its variance group, no residual
/// degree of freedom, or fits the other rows to rounding.
#[must_use]
pub fn held_out(data: &Data, f: &Fitted, i: usize) -> Option<HeldOut> {
    let sigma = f.sigma_at(data, i).filter(|s| *s > 0.0)?;
    let x = f.unit_row(data, i, sigma)?;
    let zz: f64 = f.weighted_target().iter().map(|v| v * v).sum();
    if f.fit.chi2 <= 1e-24 * zz {
        return None;
    }
    let (s2, dof) = scale(data, f, i)?;
    let pred: f64 = x.iter().zip(&f.fit.beta).map(|(a, b)| a * b).sum();
    let mut q = 0.0;
    for (j, a) in x.iter().enumerate() {
        for (k, b) in x.iter().enumerate() {
            q += a * f.fit.cov[(j, k)] * b;
        }
    }
    let var = s2 * (1.0 + q.max(0.0));
    if !(var > 0.0 && var.is_finite()) {
        return None;
    }
    let e = data.resid(i) / sigma - pred;
    let t = e / var.sqrt();
    #[allow(clippy::cast_precision_loss)]
    let p = t_two_sided(t, dof as f64);
    Some(HeldOut {
        t,
        dof,
        error: e * sigma,
        error_se: var.sqrt() * sigma,
        p,
    })
}

/// The residual variance (weighted, so 1 for right sigmas) against which observation `i` is
/// judged in the fit `f`, and its degrees of freedom: with stated sigmas the whole fit's
/// (only their common scale is unknown); with estimated ones that of `i`'s variance group
/// alone (its rows' squared residuals over `Σ(1 − h)`), since each group's sigma is its own
/// estimate, and a group of a few rows knows it poorly: its rows' residuals have heavier
/// tails than the whole fit's degrees of freedom would say. `None` without a degree of
/// freedom.
fn scale(data: &Data, f: &Fitted, i: usize) -> Option<(f64, usize)> {
    if f.stated() {
        let dof = f.dof();
        #[allow(clippy::cast_precision_loss)]
        return (dof > 0).then(|| (f.fit.chi2 / dof as f64, dof));
    }
    let (mut ss, mut nu) = (0.0, 0.0);
    for (k, &j) in f.subset.iter().enumerate() {
        if data.group[j] == data.group[i] && j != i {
            ss += f.fit.resid[k] * f.fit.resid[k];
            nu += 1.0 - f.fit.leverage[k];
        }
    }
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let dof = nu.floor() as usize;
    (dof > 0 && ss > 0.0).then(|| (ss / nu, dof))
}

/// The held-out test of the observation at position `pos` of `rows` against the weighted
/// columns `cols` (over `rows`) fitted to the other rows: its externally studentized
/// residual and degrees of freedom, against the fit's scale with stated sigmas, else
/// against the scale of its variance group in that fit (as [`scale`]).
fn held_out_columns(
    data: &Data,
    rows: &[usize],
    z: &[f64],
    cols: &[&[f64]],
    pos: usize,
    stated: bool,
) -> Option<(f64, usize)> {
    let drop = |v: &[f64]| -> Vec<f64> {
        v.iter()
            .enumerate()
            .filter(|&(k, _)| k != pos)
            .map(|(_, x)| *x)
            .collect()
    };
    let others: Vec<usize> = rows
        .iter()
        .enumerate()
        .filter(|&(k, _)| k != pos)
        .map(|(_, &r)| r)
        .collect();
    let reduced: Vec<Vec<f64>> = cols.iter().map(|c| drop(c)).collect();
    let refs: Vec<&[f64]> = reduced.iter().map(Vec::as_slice).collect();
    let f = lsq(&drop(z), &refs)?;
    let x: Vec<f64> = cols.iter().map(|c| c[pos]).collect();
    let pred: f64 = x.iter().zip(&f.beta).map(|(a, b)| a * b).sum();
    let mut q = 0.0;
    for (j, a) in x.iter().enumerate() {
        for (k, b) in x.iter().enumerate() {
            q += a * f.cov[(j, k)] * b;
        }
    }
    let (s2, dof) = if stated {
        let dof = others.len().checked_sub(cols.len()).filter(|&d| d > 0)?;
        #[allow(clippy::cast_precision_loss)]
        let s2 = f.chi2 / dof as f64;
        (s2, dof)
    } else {
        let g = data.group[rows[pos]];
        let (mut ss, mut nu) = (0.0, 0.0);
        for (k, &j) in others.iter().enumerate() {
            if data.group[j] == g {
                ss += f.resid[k] * f.resid[k];
                nu += 1.0 - f.leverage[k];
            }
        }
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let dof = nu.floor() as usize;
        if dof == 0 {
            return None;
        }
        (ss / nu, dof)
    };
    let var = s2 * (1.0 + q.max(0.0));
    (var > 0.0 && var.is_finite()).then(|| ((z[pos] - pred) / var.sqrt(), dof))
}

/// What explains a row judged a gross error as physics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Explanation {
    /// A term of the vocabulary, with a plausible coefficient.
    Term(CandidateId),
    /// A term of the generic basis, shared with other rows.
    Basis,
}

/// The term that explains observation `i` (judged a gross error against `without`, the
/// model selected without it) as physics, `None` when none does. Added to
/// `without`'s terms, fitted to the other rows of `keep`, the term predicts `i` within
/// what the noise allows (its held-out test is not significant at `level`), and, fitted to
/// every row of `keep`, `i` included,
///
/// * a term of the vocabulary has a plausible coefficient, with a leverage of `i` below
///   0.999 (a term that fits the row by leverage alone explains nothing). A real effect
///   whose signature lies mostly on one row (a random-vibration row of a two-axis design
///   for vibropendulosity) looks like a gross error to the model selected without that
///   row, which cannot see the effect; it is told from one by its size, plausible for the
///   term that explains it;
/// * a term of the generic basis (structure the vocabulary lacks, which has no bound to
///   hold a coefficient against) leaves `i` a leverage below [`SHARED_LEVERAGE`]: other
///   rows carry enough of it to predict the row, so it follows a law of the inputs that
///   other rows follow too, which a lone slip does not.
fn explained(
    data: &Data,
    keep: &[usize],
    without: &Fitted,
    i: usize,
    level: f64,
    plausible: &dyn Fn(CandidateId, f64) -> bool,
) -> Option<Explanation> {
    let pos = keep.iter().position(|&k| k == i)?;
    let sigma: Vec<f64> = keep
        .iter()
        .map(|&k| without.sigma_at(data, k))
        .collect::<Option<Vec<f64>>>()?;
    let z: Vec<f64> = keep
        .iter()
        .zip(&sigma)
        .map(|(&k, s)| data.resid(k) / s)
        .collect();
    let weigh = |raw: &[f64]| -> (Vec<f64>, f64) {
        let w: Vec<f64> = raw.iter().zip(&sigma).map(|(x, s)| x / s).collect();
        let n = norm(&w);
        (w.iter().map(|x| x / n.max(f64::MIN_POSITIVE)).collect(), n)
    };
    let column = |id: CandidateId| -> Option<Vec<f64>> {
        let s = data.signatures.iter().find(|s| s.id == id)?;
        Some(keep.iter().map(|&k| s.col[k]).collect())
    };
    let (_, nraw, _) = fit::nuisance_columns(data, keep);
    let mut base: Vec<Vec<f64>> = nraw.iter().map(|c| weigh(c).0).collect();
    for &id in &without.selected {
        base.push(weigh(&column(id)?).0);
    }
    // The vocabulary's terms (with their bounds), then the generic basis (structure the
    // vocabulary lacks, shared with other rows).
    let terms: Vec<(Option<CandidateId>, Vec<f64>)> = data
        .signatures
        .iter()
        .filter(|s| !s.null && !without.selected.contains(&s.id))
        .map(|s| (Some(s.id), keep.iter().map(|&k| s.col[k]).collect()))
        .chain(
            data.features
                .iter()
                .map(|(_, c)| (None, keep.iter().map(|&k| c[k]).collect())),
        )
        .collect();
    for (id, raw) in &terms {
        let (u, scale) = weigh(raw);
        if scale == 0.0 {
            continue;
        }
        let mut cols: Vec<&[f64]> = base.iter().map(Vec::as_slice).collect();
        cols.push(&u);
        let Some(fit) = lsq(&z, &cols) else {
            continue;
        };
        let coef = fit.beta[cols.len() - 1] / scale;
        let ok = match id {
            Some(id) => plausible(*id, coef) && fit.leverage[pos] < 0.999,
            None => fit.leverage[pos] < SHARED_LEVERAGE,
        };
        if !ok {
            continue;
        }
        let Some((t, dof)) = held_out_columns(data, keep, &z, &cols, pos, without.stated()) else {
            continue;
        };
        #[allow(clippy::cast_precision_loss)]
        if t_two_sided(t, dof as f64) > level {
            return Some(id.map_or(Explanation::Basis, Explanation::Term));
        }
    }
    None
}

/// Largest leverage of a row in the fit with one generic-basis term that still counts as
/// structure shared with other rows (they carry at least 40 % of that term: two rows that
/// share it equally have about 0.5 each).
pub const SHARED_LEVERAGE: f64 = 0.6;

/// One row set aside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Found {
    /// The observation (index into the data).
    pub obs: usize,
    /// Its test against the model selected without it.
    pub test: HeldOut,
    /// Rows in the family when it was found (the Bonferroni factor).
    pub tested: usize,
    /// `min(1, tested·p)`: the familywise p-value.
    pub p_family: f64,
}

/// What the search found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Search {
    /// The rows set aside, most significant first.
    pub found: Vec<Found>,
    /// The next significant row once [`MAX_OUTLIERS`] were set aside (then more rows than
    /// that fail the model).
    pub beyond_cap: Option<Found>,
}

/// The observations of `keep` that form the family: values in cm/s², whose removal leaves
/// their block's shift another row and the model a residual degree of freedom.
fn family(data: &Data, keep: &[usize], n_nuisance: usize) -> Vec<usize> {
    if keep.len() < n_nuisance + 3 {
        return Vec::new();
    }
    keep.iter()
        .copied()
        .filter(|&i| data.quantity[i] == Quantity::Value)
        .filter(|&i| {
            !data.shift[i]
                || keep
                    .iter()
                    .filter(|&&j| j != i && data.shift[j] && data.block[j] == data.block[i])
                    .count()
                    >= 1
        })
        .collect()
}

/// The members of `family` worth testing without themselves, from the model `full` fitted
/// to `keep`: the [`SCREEN_TOP`] largest externally studentized residuals and every row of
/// leverage [`SCREEN_LEVERAGE`] or more.
fn screen(data: &Data, keep: &[usize], full: &Fitted, family: &[usize]) -> Vec<usize> {
    let f = &full.fit;
    let n = keep.len();
    let p = f.beta.len();
    let mut high = Vec::new();
    let mut ranked: Vec<(f64, usize)> = Vec::new();
    for &i in family {
        let Some(k) = keep.iter().position(|&j| j == i) else {
            continue;
        };
        let h = f.leverage[k];
        if h >= SCREEN_LEVERAGE {
            high.push(i);
            continue;
        }
        let r = f.resid[k];
        #[allow(clippy::cast_precision_loss)]
        let s2 = if full.stated() {
            (f.chi2 - r * r / (1.0 - h)) / (n.saturating_sub(p + 1).max(1)) as f64
        } else {
            scale(data, full, i).map_or(f64::INFINITY, |(s2, _)| s2)
        };
        let t = r / (s2.max(f64::MIN_POSITIVE) * (1.0 - h)).sqrt();
        ranked.push((t.abs(), i));
    }
    ranked.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    high.extend(ranked.iter().take(SCREEN_TOP).map(|&(_, i)| i));
    high.sort_unstable();
    high.dedup();
    high
}

/// Look for suspected gross errors among the values of `data` (the procedure of the module
/// docs) at familywise level `alpha`, setting aside at most `cap` rows beyond the
/// `suspects` confirmed: observations that look like a slip whatever the model (a row
/// typed in another unit, [`super::slips::row_slips`]), each tested against the model
/// selected without all of them (several such rows would otherwise mask one another) at
/// the same familywise level over every row of the family.
///
/// A row judged a gross error that one more term of the vocabulary explains with a
/// plausible coefficient (`plausible(candidate, coefficient)`) is physics, not a gross
/// error (`explained`), unless it is among `suspects` or `recorded` (rows with an input
/// cell left empty and read as 0: evidence of a slip beside the numbers).
#[must_use]
pub fn search(
    data: &Data,
    settings: Settings,
    alpha: f64,
    cap: usize,
    suspects: &[usize],
    recorded: &[usize],
    plausible: &dyn Fn(CandidateId, f64) -> bool,
) -> Search {
    let mut keep: Vec<usize> = (0..data.n()).collect();
    let mut out = Search::default();
    if !suspects.is_empty() {
        let m = family(data, &keep, 0).len();
        let rest: Vec<usize> = keep
            .iter()
            .copied()
            .filter(|i| !suspects.contains(i))
            .collect();
        let without = fit::fit(data, &rest, settings);
        for &i in suspects {
            if let Some(test) = held_out(data, &without, i) {
                #[allow(clippy::cast_precision_loss)]
                let p_family = (test.p * m as f64).min(1.0);
                if p_family <= alpha {
                    out.found.push(Found {
                        obs: i,
                        test,
                        tested: m,
                        p_family,
                    });
                }
            }
        }
        out.found
            .sort_by(|a, b| a.p_family.total_cmp(&b.p_family).then(a.obs.cmp(&b.obs)));
        keep.retain(|i| !out.found.iter().any(|f| f.obs == *i));
    }
    let confirmed = out.found.len();
    loop {
        let full = fit::fit(data, &keep, settings);
        let members = family(data, &keep, full.n_nuisance());
        let m = members.len();
        if m == 0 {
            break;
        }
        let mut tests: Vec<(usize, HeldOut, Fitted)> = screen(data, &keep, &full, &members)
            .par_iter()
            .filter_map(|&i| {
                let rest: Vec<usize> = keep.iter().copied().filter(|&j| j != i).collect();
                let without = fit::fit(data, &rest, settings);
                held_out(data, &without, i).map(|h| (i, h, without))
            })
            .collect();
        tests.sort_by(|a, b| a.1.p.total_cmp(&b.1.p).then(a.0.cmp(&b.0)));
        #[allow(clippy::cast_precision_loss)]
        let level = alpha / m as f64;
        // The most significant row that no plausible term explains.
        let Some((obs, test, _)) = tests.iter().find(|(i, h, without)| {
            h.p <= level
                && (suspects.contains(i)
                    || recorded.contains(i)
                    || explained(data, &keep, without, *i, level, plausible).is_none())
        }) else {
            break;
        };
        let (obs, test) = (*obs, *test);
        #[allow(clippy::cast_precision_loss)]
        let p_family = (test.p * m as f64).min(1.0);
        let found = Found {
            obs,
            test,
            tested: m,
            p_family,
        };
        if out.found.len() >= confirmed + cap {
            out.beyond_cap = Some(found);
            break;
        }
        out.found.push(found);
        keep.retain(|&j| j != obs);
    }
    out
}

/// A row set aside as a suspected gross error, with what the rest of the method needs of
/// it (it is no observation of the data the model is fitted to).
#[derive(Clone, Debug)]
pub(crate) struct SetAside {
    /// The search's finding (its `obs` indexes the data with every row).
    pub found: Found,
    /// The row (index into the caller's rows).
    pub row: usize,
    /// Its measured value and baseline, cm/s².
    pub y: f64,
    pub base: f64,
    /// Its block, whether it takes the block's shift and the drift, and its time.
    pub block: usize,
    pub shift: bool,
    pub drifts: bool,
    pub time: f64,
    /// Its stated sigma and variance group.
    pub stated: Option<f64>,
    pub group: usize,
}

/// The data with the suspected gross errors set aside (unless `--keep-outliers`), and
/// what the rest of the method needs of them.
#[derive(Clone, Debug)]
pub(crate) struct Screened {
    /// The observations the model is fitted to.
    pub data: Data,
    /// The rows the search flagged (set aside, or kept with `--keep-outliers`).
    pub set_aside: Vec<SetAside>,
    /// The next row that still looks like a gross error once [`MAX_OUTLIERS`] were set
    /// aside, with its label.
    pub beyond_cap: Option<(String, Found)>,
}

/// The stage: [`search`] over every measured observation of `every` (`rows`' data; rows
/// with an input cell left empty and read as 0, `empty`, and rows that look like a unit
/// slip whatever the model are suspects), and the data without the rows it flags unless
/// `opts.keep_outliers`.
pub(crate) fn gross_errors(
    rows: &[Condition],
    empty: &[EmptyCells],
    every: Data,
    sim: &dyn Simulator,
    opts: &Options,
) -> Screened {
    let recorded: Vec<usize> = (0..every.n())
        .filter(|&k| {
            every.quantity[k] == Quantity::Value
                && empty
                    .iter()
                    .any(|e| e.row == every.rows[k] && !e.columns.is_empty())
        })
        .collect();
    let found = search(
        &every,
        opts.settings(),
        ALPHA,
        MAX_OUTLIERS,
        &row_slips(&every, sim.g_cm_s2()),
        &recorded,
        &|id, coef| plausible(id, coef, sim, opts),
    );
    let set_aside: Vec<SetAside> = found
        .found
        .iter()
        .map(|&found| {
            let k = found.obs;
            SetAside {
                found,
                row: every.rows[k],
                y: every.y[k],
                base: every.base[k],
                block: every.block[k],
                shift: every.shift[k],
                drifts: every.drifts[k],
                time: every.time[k],
                stated: every.stated[k],
                group: every.group[k],
            }
        })
        .collect();
    let beyond_cap = found
        .beyond_cap
        .map(|b| (rows[every.rows[b.obs]].label.clone(), b));
    let data = if opts.keep_outliers || set_aside.is_empty() {
        every
    } else {
        let drop: Vec<usize> = set_aside.iter().map(|a| a.found.obs).collect();
        every.without(&drop)
    };
    Screened {
        data,
        set_aside,
        beyond_cap,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::discovery::data::{Data, TimeUnit};

    /// Six difference rows of one block measured at times 0–5 with sigma 1 stated: the
    /// nuisance terms alone (a bias shift and a drift) are the straight line `a + b·t`.
    fn line_data(y: &[f64]) -> Data {
        let n = y.len();
        Data {
            rows: (0..n).collect(),
            quantity: vec![Quantity::Value; n],
            y: y.to_vec(),
            base: vec![0.0; n],
            stated: vec![Some(1.0); n],
            sim_sigma: vec![0.0; n],
            fixture: vec![0.0; n],
            shift: vec![true; n],
            drifts: vec![true; n],
            block: vec![0; n],
            block_names: vec!["all".into()],
            #[allow(clippy::cast_precision_loss)]
            time: (0..n).map(|k| k as f64).collect(),
            time_unit: TimeUnit::Seconds,
            group: vec![0; n],
            group_names: vec!["all/static".into()],
            replicate: (0..n).collect(),
            signatures: Vec::new(),
            features: Vec::new(),
            shapes: Vec::new(),
        }
    }

    fn line() -> Settings {
        Settings {
            alpha: 0.05,
            confound_cos: 0.99,
            select: false,
        }
    }

    /// The held-out test of the last of six points against the line through the other five,
    /// worked by hand, and against the classical formula from the fit of all six:
    ///
    /// y = 1.0, 1.3, 0.8, 1.1, 0.9 at t = 0..4: t̄ = 2, Sₜₜ = 10, Σ(t − t̄)·y = −0.4, slope
    /// −0.04, intercept 1.02 + 0.08 = 1.10; residuals −0.10, 0.24, −0.22, 0.12, −0.04, sum of
    /// squares 0.132, s² = 0.132/3 = 0.044 on 3 degrees of freedom. At t = 5 the line gives
    /// 0.90, so the sixth point, 4.0, misses by 3.1; the variance factor of that prediction
    /// is 1 + 1/5 + (5 − 2)²/10 = 2.1, so t = 3.1/√(0.044·2.1) = 3.1/0.303974 = 10.198251.
    ///
    /// All six: slope 0.402857, intercept 0.509524, residual of the sixth e = 1.476190,
    /// leverage h = 1/6 + 2.5²/17.5 = 0.523810, residual sum of squares 4.708190, so
    /// s²₍₆₎ = (4.708190 − e²/(1 − h))/(6 − 2 − 1) = 0.044 and e/√(s²₍₆₎·(1 − h)) is the same
    /// 10.198251.
    ///
    /// Two-sided p on 3 degrees of freedom in closed form, with u = t/√3:
    /// `1 − (2/π)·(atan u + u/(1 + u²))`.
    #[test]
    fn held_out_t_is_the_classical_externally_studentized_residual() {
        let y = [1.0, 1.3, 0.8, 1.1, 0.9, 4.0];
        let data = line_data(&y);
        let f = fit::fit(&data, &[0, 1, 2, 3, 4], line());
        let h = held_out(&data, &f, 5).unwrap();
        assert_eq!(h.dof, 3);
        assert!((h.t - 10.198_251).abs() < 1e-6, "{h:?}");
        assert!((h.error - 3.1).abs() < 1e-12, "{h:?}");
        assert!((h.error_se - 0.303_974).abs() < 1e-6, "{h:?}");
        // The classical formula from the fit of all six rows.
        let all = fit::fit(&data, &[0, 1, 2, 3, 4, 5], line());
        let (e, lev) = (all.fit.resid[5], all.fit.leverage[5]);
        assert!((e - 1.476_190).abs() < 1e-6 && (lev - 0.523_810).abs() < 1e-6);
        assert!((all.fit.chi2 - 4.708_190).abs() < 1e-6);
        let s2 = (all.fit.chi2 - e * e / (1.0 - lev)) / 3.0;
        assert!((s2 - 0.044).abs() < 1e-12, "{s2}");
        let classical = e / (s2 * (1.0 - lev)).sqrt();
        assert!(
            (h.t - classical).abs() < 1e-9 * classical,
            "{} {classical}",
            h.t
        );
        let u = h.t / 3f64.sqrt();
        let p = 1.0 - 2.0 / std::f64::consts::PI * (u.atan() + u / (1.0 + u * u));
        assert!((h.p - p).abs() < 1e-9, "{} {p}", h.p);
    }

    /// The same six points searched: the sixth is the one flagged, with the Bonferroni
    /// factor of the six rows tested; without it nothing is flagged.
    #[test]
    fn the_search_flags_the_gross_point_and_only_it() {
        let y = [1.0, 1.3, 0.8, 1.1, 0.9, 40.0];
        let s = search(
            &line_data(&y),
            line(),
            ALPHA,
            MAX_OUTLIERS,
            &[],
            &[],
            &|_, _| true,
        );
        assert_eq!(s.found.len(), 1, "{s:?}");
        assert_eq!(s.found[0].obs, 5);
        assert_eq!(s.found[0].tested, 6);
        assert!((s.found[0].p_family - 6.0 * s.found[0].test.p).abs() < 1e-15);
        assert!(s.beyond_cap.is_none());
        let clean = search(
            &line_data(&y[..5]),
            line(),
            ALPHA,
            MAX_OUTLIERS,
            &[],
            &[],
            &|_, _| true,
        );
        assert!(clean.found.is_empty(), "{clean:?}");
    }
}
