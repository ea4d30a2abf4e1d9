//! The warm-up's time constant, estimated: the profile of the final model's χ² over τ.
//!
//! The selection tests the transient `A·e^(−t/τ)` at the grid's time constants (1/16 to
//! 1/2 of the run's span, [`CandidateId::profiled`]) and keeps the one that fits best. Once
//! it is selected, τ is estimated here between and beyond those points: with every other
//! term of the final model held in it (refitted at each τ), χ²(τ) is minimised over τ from
//! [`fit::RATE_RANGE`], and the 95 % interval is the set of τ whose χ² lies within
//! χ²₁(0.95) = 3.84 of the least (times the Birge ratio² when the residuals reject the
//! sigmas), the likelihood-ratio interval of a one-parameter profile. The amplitude at the
//! estimate is refitted with the derivative of the transient in τ beside it, so that its
//! standard error holds τ's uncertainty (the Gauss–Newton covariance at the optimum).
//!
//! [`estimate`] then makes the selection again with [`CandidateId::WarmUp`], the transient
//! at the estimate, beside the grid, until τ settles: the model's other coefficients, the
//! re-simulation, the stability refits and the calibration go with the estimated τ.
//!
//! The column at any rate `r` = span/τ is exact from the grid's longest time constant's
//! column (`fit::time_on_span`): `e^(−x·r) = (e^(−x·r₀))^(r/r₀)`, `x` the time since
//! power-on over the span.

use super::data::Data;
use super::fit::{self, Fitted, Settings};
use crate::model::condition::{Condition, warm_up_span_s};
use crate::model::effects::CandidateId;
use crate::stats::{birge_ratio, lsq, norm};

/// Relative change of τ below which the estimate and the selection made with it have
/// settled.
pub const SETTLED: f64 = 1e-3;

/// Rounds of estimate and selection at most.
pub const ROUNDS: usize = 4;

/// When `f` selects the warm-up: its time constant estimated ([`time_constant`]), and the
/// selection made again with [`CandidateId::WarmUp`] at that τ beside the grid, until τ
/// settles (within [`SETTLED`], at most [`ROUNDS`] rounds; a round whose selection loses
/// the warm-up is not kept): the data with the column at the final τ (`None`: unchanged),
/// the final fit, and the estimate (its τ the column's when the fit holds
/// [`CandidateId::WarmUp`]).
/// Selected at a grid point only, a transient far above the noise would leave the grid's
/// mismatch (up to 9 % of it at the grid's steps) for other terms to take.
#[must_use]
pub fn estimate(
    rows: &[Condition],
    data: &Data,
    f: Fitted,
    settings: Settings,
    g_cm_s2: f64,
) -> (Option<Data>, Fitted, Option<TimeConstant>) {
    let Some(span) = warm_up_span_s(rows) else {
        return (None, f, None);
    };
    let all: Vec<usize> = (0..data.n()).collect();
    let (mut cur, mut f, mut column_tau) = (None::<Data>, f, None::<f64>);
    for _ in 0..ROUNDS {
        let d = cur.as_ref().unwrap_or(data);
        let Some(tc) = time_constant(d, &f, span) else {
            break;
        };
        if f.selected.contains(&CandidateId::WarmUp)
            && column_tau.is_some_and(|t| (tc.tau_s / t - 1.0).abs() <= SETTLED)
        {
            break;
        }
        let next = data.with_warm_up(rows, tc.tau_s, g_cm_s2);
        let g = fit::fit(&next, &all, settings);
        // A selection at the estimate that no longer holds the warm-up (a transient near
        // the level of the test, whose τ moved to where it is less significant) keeps the
        // round before.
        if !g.selected.iter().any(|id| id.profiled()) {
            break;
        }
        f = g;
        cur = Some(next);
        column_tau = Some(tc.tau_s);
    }
    let d = cur.as_ref().unwrap_or(data);
    let tc = time_constant(d, &f, span).map(|mut t| {
        // The model's column is at the τ of the last round: that is the estimate its
        // coefficients go with.
        if let Some(c) = column_tau.filter(|_| t.selected == CandidateId::WarmUp) {
            t.tau_s = c;
            if let Some((a, _)) = f.candidate(CandidateId::WarmUp) {
                t.amplitude_cm_s2 = a;
            }
        }
        t
    });
    (cur, f, tc)
}

/// χ²₁'s 95 % point: the profile interval's threshold.
const CHI2_1_95: f64 = 3.841_458_820_694_124;

/// The warm-up's time constant and its amplitude there.
#[derive(Clone, Debug)]
pub struct TimeConstant {
    /// The candidate selected: a grid point, or [`CandidateId::WarmUp`] at the estimate.
    pub selected: CandidateId,
    /// The grid's time constant when `grid` is a grid point, s.
    pub grid_tau_s: Option<f64>,
    /// The estimate of τ, s (or in the span's unit when the span is not known in s).
    pub tau_s: f64,
    /// The 95 % profile interval of τ, s; a side `None` when the interval reaches the end
    /// of [`fit::RATE_RANGE`] on that side (the data do not bound it there).
    pub interval_s: (Option<f64>, Option<f64>),
    /// The amplitude `A` of `A·e^(−t/τ)` at the estimate, cm/s².
    pub amplitude_cm_s2: f64,
    /// Its standard error with τ's uncertainty in it, cm/s².
    pub amplitude_se_cm_s2: f64,
}

/// The profile of the warm-up selected in `f`, if one is; `span_s` the run's span
/// ([`crate::model::condition::warm_up_span_s`]).
#[must_use]
pub fn time_constant(data: &Data, f: &Fitted, span_s: f64) -> Option<TimeConstant> {
    let j = f.selected.iter().position(|id| id.profiled())?;
    let selected = f.selected[j];
    // x = t/span of each fitted row (None where the transient cancels: difference rows).
    let x = fit::time_on_span(data, &f.subset)?;
    let nn = f.n_nuisance();
    let all = f.unit_columns();
    if all.len() != nn + f.selected.len() {
        return None;
    }
    let others: Vec<&[f64]> = all
        .iter()
        .enumerate()
        .filter(|&(k, _)| k != nn + j)
        .map(|(_, c)| *c)
        .collect();
    let z = f.weighted_target();
    let weighted = |g: &dyn Fn(f64) -> f64| -> (Vec<f64>, f64) {
        let v: Vec<f64> = x
            .iter()
            .enumerate()
            .map(|(k, x)| x.map_or(0.0, g) * f.weight(k))
            .collect();
        let s = norm(&v);
        (v.iter().map(|a| a / s.max(f64::MIN_POSITIVE)).collect(), s)
    };
    let chi2 = |r: f64| -> f64 {
        let (u, _) = weighted(&|x| (-x * r).exp());
        let mut cols = others.clone();
        cols.push(&u);
        lsq(&z, &cols).map_or(f64::INFINITY, |g| g.chi2)
    };
    let dof = f.subset.len().saturating_sub(others.len() + 2);
    let (r, (r_lo, r_hi)) = search(&chi2, dof)?;
    // The amplitude at r, with the transient's derivative in τ beside it.
    let (u, su) = weighted(&|x| (-x * r).exp());
    let (du, _) = weighted(&|x| -x * (-x * r).exp());
    let mut cols = others.clone();
    cols.push(&u);
    cols.push(&du);
    let fit = lsq(&z, &cols)?;
    let p = cols.len() - 2;
    let n = f.subset.len();
    let birge = birge_ratio(fit.chi2, n.saturating_sub(cols.len()));
    let classical = fit.cov[(p, p)].max(0.0).sqrt() * birge;
    let robust = if f.stated() { 0.0 } else { fit.se_hc3[p] };
    Some(TimeConstant {
        selected,
        grid_tau_s: selected.profile_rate().map(|r| span_s / r),
        tau_s: span_s / r,
        // A larger rate is a shorter τ.
        interval_s: (r_hi.map(|r| span_s / r), r_lo.map(|r| span_s / r)),
        amplitude_cm_s2: fit.beta[p] / su,
        amplitude_se_cm_s2: classical.max(robust) / su,
    })
}

/// The ends of an interval, each `None` where the data do not bound it.
type Interval = (Option<f64>, Option<f64>);

/// The rate `r` of least `chi2(r)` ([`fit::rate_profile`]) and the ends of its 95 % profile
/// interval, `None` at an end of [`fit::RATE_RANGE`]; `dof` the residual degrees of freedom
/// of the model with the transient (for the Birge ratio).
fn search(chi2: &dyn Fn(f64) -> f64, dof: usize) -> Option<(f64, Interval)> {
    let p = fit::rate_profile(chi2, fit::RATE_POINTS)?;
    let scale = birge_ratio(p.chi2, dof).powi(2);
    let within = |c: f64| c - p.chi2 <= CHI2_1_95 * scale;
    // The interval's ends: where the profile crosses the threshold, by bisection between
    // the estimate and the first grid point outside; None at the range's end.
    let crossing = |inside: f64, outside: f64| -> f64 {
        let (mut i, mut o) = (inside, outside);
        for _ in 0..50 {
            let m = 0.5 * (i + o);
            if within(chi2(m.exp())) {
                i = m;
            } else {
                o = m;
            }
        }
        0.5 * (i + o)
    };
    let below = p.grid[..p.best].iter().rev().find(|g| !within(g.1));
    let above = p.grid[p.best + 1..].iter().find(|g| !within(g.1));
    let side = |out: Option<&(f64, f64)>| out.map(|&(o, _)| crossing(p.ln_r, o).exp());
    Some((p.ln_r.exp(), (side(below), side(above))))
}
