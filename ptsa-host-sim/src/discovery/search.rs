//! The closed-loop search the stages after the linear selection share
//! ([`super::check`], [`super::prune`], [`super::scan`], [`super::mirror`]): the χ² of the
//! data with the loop's parameters at given values, the additive selected terms and the
//! nuisance terms refitted linearly (`Scorer`), and the best change of one parameter over
//! and beyond its tolerance band (`best_change`).
//!
//! The search: the grid [`GRID`], grown outward while an end is the best on its side (at
//! most [`GRID_EXTENSIONS`] times), then [`GOLDEN_STEPS`] golden-section steps between the
//! neighbours of the grid's best point and of the best on the other side of the file's
//! value, for parameters within [`REACH`]. Cost: about fifteen to thirty closed-loop passes
//! over the rows per other parameter, only when a parameter is selected (or scanned for,
//! when none is).
//!
//! Measured: `docs/method/discovery.md`, "Where it fails" (`cargo xtask hidden --parameters`).

use super::data::{self, Data};
use super::fit::{self, Fitted};
use super::problem::Selected;
use super::sim::Simulator;
use crate::model::condition::Condition;
use crate::model::effects::{CandidateId, Effects};
use crate::stats::{chi2_sf, f_sf, lsq, norm};

/// χ² by which another parameter must fit better than the selected one to be named in its
/// place (a likelihood ratio of e^1.5; below it the two are partners and the selection's
/// choice stands, so that the closed loop's own scatter does not flip names).
pub const SWAP_MARGIN: f64 = 3.0;

/// Golden-section steps after the grid (the bracket shrinks to 0.618^n of two grid
/// intervals: 0.8 %, for the pendulosity about a third of its standard error in a
/// 20-frequency table, where six steps left three and cost partners their χ²).
pub const GOLDEN_STEPS: usize = 10;

/// Times the grid of a search may grow outward by half again on a side whose end is the
/// best there (to 2·1.5³ ≈ 6.8 times the distance to the band's edge).
pub const GRID_EXTENSIONS: usize = 3;

/// Offset of the seeds of the fresh evaluations of the check (the module docs) from the
/// simulator's own.
pub const FRESH_SEEDS: u64 = 1000;

/// How far above the selected parameter's χ² another's best grid point may lie and still be
/// searched between grid points: the grid's spacing, half the distance to the band's edge,
/// is at most about fourteen standard errors of the best-measured parameter, so the least
/// χ² between grid points is at most about 200 below the grid's best; beyond twice that the
/// other parameter can be neither better nor a partner.
pub const REACH: f64 = 400.0;

/// Grid of changes tried for a parameter, as multiples of the distance from the file's
/// value to the band's edge on that side.
pub const GRID: [f64; 6] = [-2.0, -1.0, -0.5, 0.5, 1.0, 2.0];

/// The χ² of the data with the parameters at `theta` (the additive selected terms and the
/// nuisance terms refitted linearly), or `None` if an observation is not finite.
pub(crate) struct Scorer<'a> {
    rows: &'a [Condition],
    data: &'a Data,
    pub(crate) sim: &'a dyn Simulator,
    sigma: &'a [f64],
    /// Unit columns of the additive selected terms and the nuisance terms (weighted).
    pub(crate) linear: Vec<Vec<f64>>,
}

impl<'a> Scorer<'a> {
    /// The scorer of `data`, with the additive selected terms and the nuisance terms as the
    /// linear part.
    pub(crate) fn new(
        rows: &'a [Condition],
        data: &'a Data,
        f: &'a Fitted,
        selected: &[Selected],
        sim: &'a dyn Simulator,
    ) -> Self {
        let all: Vec<usize> = (0..data.n()).collect();
        let (_, nuis, _) = fit::nuisance_columns(data, &all);
        let sigma = &f.sigma;
        let w = |c: &[f64]| -> Vec<f64> {
            let v: Vec<f64> = c.iter().zip(sigma).map(|(x, s)| x / s).collect();
            let s = norm(&v).max(f64::MIN_POSITIVE);
            v.iter().map(|x| x / s).collect()
        };
        let mut linear: Vec<Vec<f64>> = selected
            .iter()
            .filter(|s| s.id.parameter_key().is_none())
            .filter_map(|s| data.signatures.iter().find(|g| g.id == s.id))
            .map(|g| w(&g.col))
            .collect();
        linear.extend(nuis.iter().map(|c| w(c)));
        Scorer {
            rows,
            data,
            sim,
            sigma,
            linear,
        }
    }
}

impl Scorer<'_> {
    /// The χ² at `theta`, or `None` if an observation is not finite.
    pub(crate) fn chi2(&self, theta: &Effects) -> Option<f64> {
        let p = data::predicted(self.rows, self.data, self.sim, theta)?;
        let z: Vec<f64> = (0..self.data.n())
            .map(|k| (self.data.y[k] - p[k]) / self.sigma[k])
            .collect();
        if z.iter().any(|x| !x.is_finite()) {
            return None;
        }
        let refs: Vec<&[f64]> = self.linear.iter().map(Vec::as_slice).collect();
        Some(lsq(&z, &refs).map_or_else(|| z.iter().map(|x| x * x).sum(), |g| g.chi2))
    }
}

/// The best change of `id` in place of the parameters left in `rest`, over the grid and a
/// golden-section search between the grid's best point's neighbours: `(change, χ², limit)`,
/// `limit` the change at the end of the grid when the best lies there (within
/// [`AT_LIMIT`] of the last interval): the grid could not go further (its extensions used
/// up, or the parameter would leave [`MIN_FRACTION`] of its value), so the data may want
/// more than the search could give.
pub(crate) fn best_change(
    scorer: &Scorer<'_>,
    rest: &Effects,
    id: CandidateId,
    reach: f64,
) -> Option<(f64, f64, Option<f64>)> {
    let key = id.parameter_key()?;
    let (lo, nom, hi) = scorer.sim.instrument()?.tolerance(key)?;
    // Changes that keep a positive parameter positive (the torquer lag's band is 0.2 to
    // 20 µs about 2 µs).
    let valid = |d: f64| !(nom > 0.0 && lo >= 0.0) || nom + d >= MIN_FRACTION * nom;
    let mut grid: Vec<f64> = GRID
        .iter()
        .map(|&s| {
            if s < 0.0 {
                -s * (lo - nom)
            } else {
                s * (hi - nom)
            }
        })
        .filter(|&d| d != 0.0 && valid(d))
        .collect();
    grid.push(0.0);
    grid.sort_by(f64::total_cmp);
    grid.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * (hi - lo).abs());
    let score = |d: f64| {
        let mut t = *rest;
        t.add(id, d);
        scorer.chi2(&t)
    };
    let mut chi: Vec<Option<f64>> = grid.iter().map(|&d| score(d)).collect();
    extend(&mut grid, &mut chi, &score, &valid);
    let (i, c) = chi
        .iter()
        .enumerate()
        .filter_map(|(i, c)| c.map(|c| (i, c)))
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    // Golden-section search between the grid's best point's neighbours (the χ² of a
    // parameter acting as cos φ is far from a parabola in it), and between those of the
    // best grid point on the other side of the file's value too (an even response with a
    // small odd part has a valley on each side), unless the grid's best is beyond reach.
    let best = (grid[i], c);
    if c > reach {
        return Some((best.0, best.1, grid_end(&grid, best.0)));
    }
    let zero = grid.iter().position(|&d| d == 0.0).unwrap_or(0);
    let other = chi
        .iter()
        .enumerate()
        .filter(|&(j, _)| j != zero && (j < zero) != (i < zero) && i != zero)
        .filter_map(|(j, c)| c.map(|c| (j, c)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .filter(|&(_, c)| c <= reach)
        .map(|(j, _)| j);
    let mut best = best;
    for j in std::iter::once(i).chain(other) {
        let g = golden(&grid, j, &score);
        if g.1 < best.1 {
            best = g;
        }
    }
    Some((best.0, best.1, grid_end(&grid, best.0)))
}

/// While an end of the grid is the best on its side, the grid goes on outward by half
/// again (a change beyond twice the distance to the band's edge: a 21° phase error against
/// a ±10° band), at most [`GRID_EXTENSIONS`] times a side; `chi` the grid's χ² by `score`,
/// a change kept only where `valid`.
fn extend(
    grid: &mut Vec<f64>,
    chi: &mut Vec<Option<f64>>,
    score: &dyn Fn(f64) -> Option<f64>,
    valid: &dyn Fn(f64) -> bool,
) {
    for _ in 0..GRID_EXTENSIONS {
        let mut grew = false;
        for end in [0, grid.len() - 1] {
            let inner = if end == 0 { 1 } else { end - 1 };
            let better = match (chi[end], chi.get(inner).copied().flatten()) {
                (Some(a), Some(b)) => a < b,
                _ => false,
            };
            let d = 1.5 * grid[end];
            if better && grid[end] != 0.0 && valid(d) {
                let c = score(d);
                if end == 0 {
                    grid.insert(0, d);
                    chi.insert(0, c);
                } else {
                    grid.push(d);
                    chi.push(c);
                }
                grew = true;
                break;
            }
        }
        if !grew {
            break;
        }
    }
}

/// Golden-section search of `score` between the neighbours of `grid[i]`,
/// [`GOLDEN_STEPS`] steps: the best change and its χ².
fn golden(grid: &[f64], i: usize, score: &dyn Fn(f64) -> Option<f64>) -> (f64, f64) {
    let (mut lo_x, mut hi_x) = (grid[i.saturating_sub(1)], grid[(i + 1).min(grid.len() - 1)]);
    let r = 0.5 * (5f64.sqrt() - 1.0);
    let mut x1 = hi_x - r * (hi_x - lo_x);
    let mut x2 = lo_x + r * (hi_x - lo_x);
    let mut f1 = score(x1).unwrap_or(f64::INFINITY);
    let mut f2 = score(x2).unwrap_or(f64::INFINITY);
    for _ in 0..GOLDEN_STEPS {
        if f1 < f2 {
            hi_x = x2;
            (x2, f2) = (x1, f1);
            x1 = hi_x - r * (hi_x - lo_x);
            f1 = score(x1).unwrap_or(f64::INFINITY);
        } else {
            lo_x = x1;
            (x1, f1) = (x2, f2);
            x2 = lo_x + r * (hi_x - lo_x);
            f2 = score(x2).unwrap_or(f64::INFINITY);
        }
    }
    if f1 < f2 { (x1, f1) } else { (x2, f2) }
}

/// The end of `grid` that `x` lies at (within [`AT_LIMIT`] of the last interval), if any.
fn grid_end(grid: &[f64], x: f64) -> Option<f64> {
    let last = grid.len().checked_sub(1)?;
    [(0, 1.min(last)), (last, last.saturating_sub(1))]
        .into_iter()
        .find(|&(e, inner)| {
            grid[e] != 0.0 && (x - grid[e]).abs() <= AT_LIMIT * (grid[e] - grid[inner]).abs()
        })
        .map(|(e, _)| grid[e])
}

/// Fraction of the last grid interval within which a search's best counts as lying at the
/// grid's end (the golden-section search brackets it to 0.8 % of two intervals).
pub const AT_LIMIT: f64 = 0.02;

/// Smallest value, as a fraction of the file's, a positive parameter is searched down to.
pub const MIN_FRACTION: f64 = 0.05;

/// In words, where the search of `id` stopped: the change `limit` at its grid's end.
#[must_use]
pub fn limit_note(id: CandidateId, limit: f64, sim: &dyn Simulator) -> String {
    let c = id.info();
    match id
        .parameter_key()
        .and_then(|k| sim.instrument()?.tolerance(k))
    {
        Some((lo, nom, hi)) => {
            let at = nom + limit;
            let side = if limit < 0.0 { nom - lo } else { hi - nom };
            let why = if limit < 0.0
                && nom > 0.0
                && lo >= 0.0
                && nom + 1.5 * limit < MIN_FRACTION * nom
            {
                format!("further would take it below {MIN_FRACTION} of its value")
            } else {
                format!(
                    "the grid reaches {} times the distance to the band's edge and no further",
                    crate::output::significant(limit.abs() / side, 4)
                )
            };
            format!(
                "{} = {} {} ({} × the file's {}) is the end of the search grid ({why}): the data may want a larger change than the search could try, and the comparison with the other parameters is made at that end",
                c.name,
                crate::output::significant(at, 4),
                c.unit,
                crate::output::significant(at / nom, 4),
                crate::output::significant(nom, 4)
            )
        }
        None => format!(
            "{} = {} {} is the end of the search grid: the data may want a larger change",
            c.name,
            crate::output::significant(limit, 4),
            c.unit
        ),
    }
}

/// Whether χ² `c` is not significantly worse than `chi`, by the selection's step test (the
/// larger of the χ² p-value with stated sigmas and the F test against the residual scale
/// with `dof` degrees of freedom) at `level`.
pub(crate) fn not_worse(c: f64, chi: f64, dof: usize, stated: bool, level: f64) -> bool {
    worse_p(c, chi, dof, stated) > level
}

/// The p-value of χ² `c` being worse than `chi` by the test of [`not_worse`].
pub(crate) fn worse_p(c: f64, chi: f64, dof: usize, stated: bool) -> f64 {
    let delta = (c - chi).max(0.0);
    #[allow(clippy::cast_precision_loss)]
    let dof = dof as f64;
    let s2 = (chi / dof).max(f64::MIN_POSITIVE);
    let p_f = f_sf(delta / s2, 1.0, dof);
    if stated {
        chi2_sf(delta, 1.0).max(p_f)
    } else {
        p_f
    }
}
