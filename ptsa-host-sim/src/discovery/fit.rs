//! The model fitted to a subset of the rows (all of them, or a cross-validation fold's
//! training rows): the nuisance terms that are always in it, the noise it estimates when
//! the sigmas are not stated, and the forward–backward selection of candidates with
//! familywise error control.
//!
//! Everything is weighted least squares on `(measured − baseline)/σ`. The test of one step
//! (adding or keeping a candidate) takes the **largest** of up to three p-values, so that it
//! rejects only when each rejects:
//!
//! * with stated sigmas: `P(χ²₁ > Δχ²)` (the sigmas taken as known) and the F test
//!   `P(F(1, n−p) > Δχ²/s²)` (the noise scale estimated: exact whatever the sigmas' common
//!   scale);
//! * with estimated sigmas: the F test and the heteroscedasticity-robust (HC3) Wald test
//!   `P(|t_{n−p}| > |β/SE_HC3|)`, valid whatever the rows' variances.

use super::data::{Data, TimeUnit, replicate_sets};
use crate::model::effects::CandidateId;
use crate::stats::{
    LsqFit, abs_cos, birge_ratio, chi2_sf, f_sf, lsq, norm, normal_two_sided_quantile, residualize,
    sandwich_se, t_two_sided,
};

/// Statement of the test, printed with every result.
pub const TEST_STATEMENT: &str = "forward-backward stepwise selection against a model that \
always holds a bias shift per block and a linear drift; each step tests the best remaining \
candidate by the largest p-value of the F(1, n-p) test against the residual scale and \
either the chi-squared(1) test with the stated sigmas or, when the sigmas are estimated, the \
heteroscedasticity-robust (HC3) t test, at the Holm-Bonferroni level alpha/(m-k) \
(m = testable candidates, the warm-up's time constants one of them with its p-value \
corrected for the search over tau; k = already selected), so the familywise error rate over \
all candidates is at most alpha = 0.05";

/// Settings of the selection.
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    /// Familywise error rate across the candidates.
    pub alpha: f64,
    /// `|cos|` above which a signature is indistinguishable from the model's span.
    pub confound_cos: f64,
    /// Select candidates (`false`: the nuisance terms only, the baseline model).
    pub select: bool,
}

/// What a nuisance term is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Nuisance {
    /// A bias shift of block `b` (index into `Data::block_names`).
    Block(usize),
    /// A linear drift in time.
    Drift,
}

/// Where the sigmas came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoiseSource {
    /// Stated in the file (or by `--sigma`) for every row.
    Stated,
    /// Estimated from replicated rows (pure error) where the data have them, else from the
    /// residuals.
    Replicates,
    /// Estimated from the residuals of the model, per variance group.
    Residuals,
}

/// One decision of the stepwise procedure.
#[derive(Clone, Debug)]
pub struct Step {
    /// `true` = added, `false` = removed.
    pub added: bool,
    /// The candidate.
    pub id: CandidateId,
    /// Drop in χ² the candidate gives.
    pub delta_chi2: f64,
    /// Its p-value (the largest of the step's tests).
    pub p_value: f64,
    /// The Holm–Bonferroni threshold it was compared with.
    pub threshold: f64,
    /// The candidate `id` was put in place of, for a swap found through the closed loop
    /// (`discovery::check`).
    pub replaces: Option<CandidateId>,
    /// How the step was decided when not by the linear stepwise test (a search through
    /// the closed loop), in words.
    pub note: Option<String>,
}

/// A column of the weighted design, normalised, and its norm before.
#[derive(Clone, Debug)]
struct Col {
    unit: Vec<f64>,
    scale: f64,
}

/// The model fitted to a subset.
#[derive(Clone, Debug)]
pub struct Fitted {
    /// The rows (indices into the [`Data`]).
    pub subset: Vec<usize>,
    /// The nuisance terms in the model.
    pub nuisance: Vec<Nuisance>,
    /// Mean time of the subset (the drift's origin), in the data's time unit.
    pub t0: f64,
    /// Testable candidates (the family).
    pub family: Vec<CandidateId>,
    /// Candidates without a signature in these rows.
    pub untestable: Vec<CandidateId>,
    /// Candidates whose signature lies in the span of the nuisance terms.
    pub untestable_nuisance: Vec<CandidateId>,
    /// Selected candidates, in registry order.
    pub selected: Vec<CandidateId>,
    /// The decisions.
    pub steps: Vec<Step>,
    /// The bias brought into the model with the warm-up, as the level its transient settles
    /// to (not tested alone), if it was.
    pub companion: Option<CandidateId>,
    /// Sigma of each subset row, cm/s².
    pub sigma: Vec<f64>,
    /// Where the sigmas came from.
    pub noise: NoiseSource,
    /// Estimated sigma per variance group (empty when stated), cm/s².
    pub group_sigma: Vec<(usize, f64)>,
    /// Final weighted fit: nuisance columns first, then the selected ones.
    pub fit: LsqFit,
    /// Coefficients in physical units, same order as the fit's columns.
    pub coef: Vec<f64>,
    /// Their standard errors (scaled by the Birge ratio when χ² rejects the sigmas, see
    /// [`crate::stats::birge_ratio`], or HC3 when
    /// the sigmas are estimated, whichever is larger).
    pub se: Vec<f64>,
    /// Settings used.
    pub settings: Settings,
    cols: Vec<Col>,
    cand_cols: Vec<Option<Col>>,
}

/// Partial |cos| above which two candidates count as the same step (the simpler one,
/// [`CandidateId::rank`], is taken).
pub const EQUIVALENT_COS: f64 = 0.999;

/// Degrees of freedom a stated sigma counts for when the step test pools it with the
/// reference model's residual scale (only when those residuals do not reject it,
/// [`STATED_SIGMA_CHECK`]): a sigma known to about 50 % (the relative standard error of a
/// sigma estimated with ν degrees of freedom is about 1/√(2ν)), so that a stated sigma
/// half the true noise, which a reference with a few degrees of freedom often cannot
/// reject, is still within the error the pooling grants it. It was 8 (25 %): on R-890
/// Table 6.1's 8 rows a null set with its sigma stated 2× too small then selected an effect
/// in 63 of 600 sets (10.5 %); with 2, 30 of 600 (`ptsa-campaigns/src/sigma.rs`).
pub const STATED_SIGMA_DOF: f64 = 2.0;

/// Level of the χ² test (upper tail) by which the reference model's residuals reject a
/// stated sigma; a sigma not rejected is pooled ([`STATED_SIGMA_DOF`]).
pub const STATED_SIGMA_CHECK: f64 = 0.05;

/// Fewest residual degrees of freedom the step test's reference model keeps.
pub const MIN_REFERENCE_DOF: usize = 2;

/// The noise reference of a step: the residual scale and residuals of the largest model
/// that holds the step's (the current model and every remaining candidate that adds an
/// independent column), so that another effect still outside the trial model inflates
/// neither the F test's denominator nor the robust error ("masking").
pub(crate) struct Reference {
    /// Residual variance (weighted, so 1 for correct sigmas).
    pub s2: f64,
    /// Its degrees of freedom.
    pub dof: f64,
    /// Its residuals (weighted).
    pub resid: Vec<f64>,
}

impl Reference {
    /// The reference from a fit of the larger model, if it leaves at least two degrees of
    /// freedom.
    pub(crate) fn of(f: &LsqFit) -> Option<Self> {
        let n = f.resid.len();
        let p = f.beta.len();
        (n >= p + 2).then(|| {
            #[allow(clippy::cast_precision_loss)]
            let dof = (n - p) as f64;
            Reference {
                s2: f.chi2 / dof,
                dof,
                resid: f.resid.clone(),
            }
        })
    }
}

/// p-value of a step from the fit with the term (`with`, the term at position `j`, design
/// `cols`) and the χ² without it; `reference` is the larger model's noise (else the trial's
/// own residuals are used).
pub(crate) fn step_p(
    with: &LsqFit,
    cols: &[&[f64]],
    j: usize,
    chi2_without: f64,
    stated: bool,
    reference: Option<&Reference>,
) -> f64 {
    let n = with.resid.len();
    let p = with.beta.len();
    if n <= p {
        return 1.0;
    }
    #[allow(clippy::cast_precision_loss)]
    let own = Reference {
        s2: with.chi2 / (n - p) as f64,
        dof: (n - p) as f64,
        resid: Vec::new(),
    };
    let r = reference.unwrap_or(&own);
    let delta = (chi2_without - with.chi2).max(0.0);
    if stated {
        scaled_p(delta, 1.0, true, r)
    } else {
        let p_f = scaled_p(delta, 1.0, false, r);
        let se = if r.resid.is_empty() {
            with.se_hc3[j]
        } else {
            sandwich_se(cols, &r.resid).map_or(with.se_hc3[j], |s| s[j])
        };
        let t = with.beta[j] / se.max(f64::MIN_POSITIVE);
        t_two_sided(t, r.dof).max(p_f)
    }
}

/// The p-value of `q`, a statistic that is χ²(`df`) when the sigmas are right and nothing
/// is there to find, on the noise scale of the reference `r` (the residuals of a model
/// that holds what `q` tests): the F test `P(F(df, ν) > (q/df)/s²)` against the
/// reference's scale `s²` on its `ν` degrees of freedom, exact whatever the sigmas'
/// common scale; with stated sigmas (`stated`) also the χ² test of `q`, the larger p-value
/// deciding. A stated sigma the reference's residuals do not reject (χ² at
/// [`STATED_SIGMA_CHECK`]) is pooled with their scale as if it were an estimate with
/// [`STATED_SIGMA_DOF`] degrees of freedom, so that a small design's few residual degrees
/// of freedom no longer make the test F(1, 2); a rejected one is replaced by the
/// residuals' scale alone.
pub(crate) fn scaled_p(q: f64, df: f64, stated: bool, r: &Reference) -> f64 {
    let q = q.max(0.0);
    if stated {
        let consistent = chi2_sf(r.dof * r.s2, r.dof) >= STATED_SIGMA_CHECK;
        let (s2, dof) = if consistent {
            (
                (r.dof * r.s2 + STATED_SIGMA_DOF) / (r.dof + STATED_SIGMA_DOF),
                r.dof + STATED_SIGMA_DOF,
            )
        } else {
            (r.s2, r.dof)
        };
        let p_f = f_sf(q / df / s2.max(f64::MIN_POSITIVE), df, dof);
        chi2_sf(q, df).max(p_f)
    } else {
        f_sf(q / df / r.s2.max(f64::MIN_POSITIVE), df, r.dof)
    }
}

/// Number of hypotheses in a family of candidates: each candidate once, the members of a
/// profile ([`CandidateId::profiled`], the warm-up at the grid's time constants) together
/// once.
#[must_use]
pub fn family_size(family: &[CandidateId]) -> usize {
    family.iter().filter(|c| !c.profiled()).count()
        + usize::from(family.iter().any(|c| c.profiled()))
}

/// The length, in radians, of the curve the profile's members trace on the unit sphere once
/// `basis` is partialled out: the sum of the angles between neighbours in τ (members whose
/// column `basis` spans are left out). The grid's steps in τ (a factor of 1.5 at most) are
/// short against the curve's bends, so the polygon is its length to well under a percent.
fn profile_length(profile: &[usize], cand: &[Option<Col>], basis: &[&[f64]]) -> f64 {
    let units: Vec<Vec<f64>> = profile
        .iter()
        .filter_map(|&k| cand[k].as_ref())
        .map(|c| residualize(&c.unit, basis))
        .filter(|u| norm(u) > 1e-9)
        .collect();
    units
        .windows(2)
        .map(|w| abs_cos(&w[0], &w[1]).min(1.0).acos())
        .sum()
}

/// The p-value of the best member of a profile, `p` its own, corrected for the search over
/// the profile's parameter along a curve of `length` radians: the Hotelling–Weyl tube bound
/// `P(max |Z(τ)| ≥ z) ≤ 2(1 − Φ(z)) + (L/π)·e^(−z²/2)` for a Gaussian statistic on a
/// unit-speed curve of length L, with `z` the normal deviate of `p`. For a t statistic with
/// ν degrees of freedom the second term is `(L/π)·(1 + t²/ν)^(−ν/2)`, smaller at the same
/// p-value, so the Gaussian form is conservative for the F and t tests of the step too. It
/// bounds the maximum over the whole curve, so over the grid's points as well; with one
/// member (`L` = 0) it is `p`.
fn profile_p(p: f64, length: f64) -> f64 {
    if !(p > 0.0 && p < 1.0) || length <= 0.0 {
        return p;
    }
    let z = normal_two_sided_quantile(p);
    (p + length / std::f64::consts::PI * (-0.5 * z * z).exp()).min(1.0)
}

/// The selected profile member swapped for the one of `profile` (every testable time
/// constant) that fits best with the other selected terms, if another fits better: the new
/// set, and `(new, old, Δχ²)`. `chi2` gives the χ² of a set of candidates.
fn reprofile(
    set: &[usize],
    profile: &[usize],
    cur: &LsqFit,
    chi2: impl Fn(&[usize]) -> Option<f64>,
) -> Option<(Vec<usize>, (usize, usize, f64))> {
    let &old = set.iter().find(|k| profile.contains(k))?;
    let (new, c) = profile
        .iter()
        .filter(|&&k| k != old)
        .filter_map(|&k| {
            let mut s: Vec<usize> = set.iter().copied().filter(|&j| j != old).collect();
            s.push(k);
            s.sort_unstable();
            Some((k, chi2(&s)?))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    // Better by more than rounding.
    (c < cur.chi2 - 1e-9 * cur.chi2.max(1.0)).then(|| {
        let mut s: Vec<usize> = set.iter().copied().filter(|&j| j != old).collect();
        s.push(new);
        s.sort_unstable();
        (s, (new, old, cur.chi2 - c))
    })
}

/// The time since power-on over the run's span of each row of `subset`, read back from the
/// warm-up's longest grid time constant's signature (`e^(−x·r₀)`, exact, and far from
/// underflow); `None` for a row where the transient cancels (a difference row), and `None`
/// altogether without the warm-up's grid in the data.
pub(crate) fn time_on_span(data: &Data, subset: &[usize]) -> Option<Vec<Option<f64>>> {
    let (s, r0) = data
        .signatures
        .iter()
        .filter_map(|s| Some((s, s.id.profile_rate()?)))
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    Some(
        subset
            .iter()
            .map(|&i| (s.col[i] > 0.0).then(|| -s.col[i].ln() / r0))
            .collect(),
    )
}

/// The rates `r` = span/τ the warm-up's time constant is searched over: τ from twice the
/// run's span to 1/64 of it (a transient over within the first row or two of a 24-row run).
pub const RATE_RANGE: (f64, f64) = (0.5, 64.0);

/// Points of the estimate's logarithmic grid over [`RATE_RANGE`] ([`super::profile`]),
/// and the golden-section steps of its refinement about its best.
pub const RATE_POINTS: (usize, usize) = (97, 40);

/// Points of the grid of the selection's own searches over τ (a term's test against the
/// model without it at its best τ), and their golden-section steps: coarser than the
/// estimate's, as only the least χ² is wanted (near the least, χ² is flat in ln r, and 16
/// steps bracket it to 0.05 % of two grid steps).
const TEST_RATE_POINTS: (usize, usize) = (25, 16);

/// A χ² profile over the rate `r` = span/τ: its least value and where.
pub(crate) struct RateProfile {
    /// `ln r` at the least χ².
    pub ln_r: f64,
    /// The least χ².
    pub chi2: f64,
    /// The grid `(ln r, χ²)` it was found from, in increasing r.
    pub grid: Vec<(f64, f64)>,
    /// The grid's best point.
    pub best: usize,
}

/// The least `chi2(r)` over [`RATE_RANGE`]: a logarithmic grid of `points`, then `steps` of
/// golden-section between the best point's neighbours.
pub(crate) fn rate_profile(
    chi2: &dyn Fn(f64) -> f64,
    (points, steps): (usize, usize),
) -> Option<RateProfile> {
    let (lo, hi) = (RATE_RANGE.0.ln(), RATE_RANGE.1.ln());
    #[allow(clippy::cast_precision_loss)]
    let at = |k: usize| lo + (hi - lo) * k as f64 / (points - 1) as f64;
    let grid: Vec<(f64, f64)> = (0..points).map(|k| (at(k), chi2(at(k).exp()))).collect();
    let best = (0..points).min_by(|&a, &b| grid[a].1.total_cmp(&grid[b].1))?;
    let (mut a, mut b) = (at(best.saturating_sub(1)), at((best + 1).min(points - 1)));
    let g = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..steps {
        let (c, d) = (b - g * (b - a), a + g * (b - a));
        if chi2(c.exp()) < chi2(d.exp()) {
            b = d;
        } else {
            a = c;
        }
    }
    let ln_r = 0.5 * (a + b);
    Some(RateProfile {
        ln_r,
        chi2: chi2(ln_r.exp()).min(grid[best].1),
        grid,
        best,
    })
}

/// The design of a subset with given sigmas.
struct Design {
    sigma: Vec<f64>,
    z: Vec<f64>,
}

impl Design {
    fn col(&self, raw: &[f64]) -> Col {
        let w: Vec<f64> = raw.iter().zip(&self.sigma).map(|(x, s)| x / s).collect();
        let scale = norm(&w);
        let unit = if scale > 0.0 {
            w.iter().map(|x| x / scale).collect()
        } else {
            w
        };
        Col { unit, scale }
    }

    fn fit(&self, cols: &[&Col]) -> Option<LsqFit> {
        let c: Vec<&[f64]> = cols.iter().map(|c| c.unit.as_slice()).collect();
        lsq(&self.z, &c)
    }
}

/// Raw nuisance columns of a subset: one bias shift per block of difference rows present
/// (a shift between a condition and its reference run; absolute rows have none: their bias
/// is the candidate `bias`), and the drift when the times differ (dropped when it leaves no
/// residual degree of freedom).
pub(crate) fn nuisance_columns(
    data: &Data,
    subset: &[usize],
) -> (Vec<Nuisance>, Vec<Vec<f64>>, f64) {
    let mut terms = Vec::new();
    let mut cols = Vec::new();
    let mut blocks: Vec<usize> = subset
        .iter()
        .filter(|&&i| data.shift[i])
        .map(|&i| data.block[i])
        .collect();
    blocks.sort_unstable();
    blocks.dedup();
    for &b in &blocks {
        terms.push(Nuisance::Block(b));
        cols.push(
            subset
                .iter()
                .map(|&i| {
                    if data.block[i] == b && data.shift[i] {
                        1.0
                    } else {
                        0.0
                    }
                })
                .collect(),
        );
    }
    let drifting: Vec<f64> = subset
        .iter()
        .filter(|&&i| data.drifts[i])
        .map(|&i| data.time[i])
        .collect();
    #[allow(clippy::cast_precision_loss)]
    let t0 = drifting.iter().sum::<f64>() / drifting.len().max(1) as f64;
    let drift: Vec<f64> = subset
        .iter()
        .map(|&i| {
            if data.drifts[i] {
                data.time[i] - t0
            } else {
                0.0
            }
        })
        .collect();
    // Keep the drift only if it is not in the blocks' span and leaves a residual dof.
    let in_span = {
        let c: Vec<&[f64]> = cols.iter().map(Vec::as_slice).collect();
        norm(&residualize(&drift, &c)) <= 1e-9 * norm(&drift).max(f64::MIN_POSITIVE)
    };
    if !in_span && norm(&drift) > 0.0 && subset.len() > blocks.len() + 1 {
        terms.push(Nuisance::Drift);
        cols.push(drift);
    }
    (terms, cols, t0)
}

/// Sigmas of a subset: stated, else estimated per variance group from replicated rows
/// (pure error) or from `resid` (the current model's residuals, cm/s², with leverage `lev`).
fn estimate_sigma(
    data: &Data,
    subset: &[usize],
    resid: Option<(&[f64], &[f64])>,
) -> (Vec<f64>, NoiseSource, Vec<(usize, f64)>) {
    if subset.iter().all(|&i| data.stated[i].is_some()) {
        let s = subset
            .iter()
            .map(|&i| data.stated[i].unwrap_or(1.0))
            .collect();
        return (s, NoiseSource::Stated, Vec::new());
    }
    let (pure, source) = pure_variances(data, subset);
    let r = ResidualSquares::of(data, subset, resid, pure.len());
    let pooled = r.pooled();
    // Each group's own residual variance where it has the degrees of freedom, else the
    // pooled one. (Shrinking every group towards the pooled variance, with the weight of 4
    // degrees of freedom, was tried: it lifted the false selections on nulls whose groups
    // differ tenfold in noise from 2 % to 11 % in a 1000-set campaign, by pulling the noisy
    // group's sigma down.)
    let var: Vec<f64> = pure
        .iter()
        .enumerate()
        .map(|(g, p)| p.unwrap_or_else(|| r.group(g).unwrap_or(pooled)))
        .collect();
    let floor = pooled.max(f64::MIN_POSITIVE) * 1e-6;
    let group_sigma: Vec<(usize, f64)> = (0..var.len())
        .filter(|&g| subset.iter().any(|&i| data.group[i] == g))
        .map(|g| (g, var[g].max(floor).sqrt()))
        .collect();
    let sigma = subset
        .iter()
        .map(|&i| {
            data.stated[i]
                .unwrap_or_else(|| (var[data.group[i]].max(floor) + data.fixture[i].powi(2)).sqrt())
                .max(f64::MIN_POSITIVE)
        })
        .collect();
    (sigma, source, group_sigma)
}

/// Each group's variance from its replicates where they have two degrees of freedom or
/// more (pure error), and where the noise then comes from.
fn pure_variances(data: &Data, subset: &[usize]) -> (Vec<Option<f64>>, NoiseSource) {
    let mut ss = vec![0.0; data.group_names.len()];
    let mut df = vec![0.0; data.group_names.len()];
    // A row's known orientation error (`data.fixture`) is taken out of the replicates'
    // scatter: that of a set of n about its mean holds (1 − 1/n)·Σ fixture² (and out of
    // the residuals' below, by `variance_beside`).
    for set in replicate_sets(data, subset) {
        #[allow(clippy::cast_precision_loss)]
        let n = set.len() as f64;
        let m = set.iter().map(|&i| data.resid(i)).sum::<f64>() / n;
        for &i in &set {
            ss[data.group[i]] +=
                (data.resid(i) - m).powi(2) - (1.0 - 1.0 / n) * data.fixture[i].powi(2);
            df[data.group[i]] += 1.0;
        }
        df[data.group[set[0]]] -= 1.0;
    }
    let mut source = NoiseSource::Residuals;
    let mut pure: Vec<Option<f64>> = vec![None; data.group_names.len()];
    for g in 0..pure.len() {
        if df[g] >= 2.0 {
            pure[g] = Some(ss[g] / df[g]);
            source = NoiseSource::Replicates;
        }
    }
    (pure, source)
}

/// The residuals' squares per group, for the variances the replicates do not give.
struct ResidualSquares {
    /// Per group: the sum of squares and its degrees of freedom.
    ss: Vec<f64>,
    df: Vec<f64>,
    /// Each residual's square scaled to its variance (`e²/(1 − h)`), with its group and
    /// its row's orientation error squared.
    scaled: Vec<(usize, f64, f64)>,
}

impl ResidualSquares {
    /// From the fit's residuals and leverages `resid`, or without a fit the rows' own
    /// residuals against the baseline; `groups` groups.
    fn of(data: &Data, subset: &[usize], resid: Option<(&[f64], &[f64])>, groups: usize) -> Self {
        let mut r = Self {
            ss: vec![0.0; groups],
            df: vec![0.0; groups],
            scaled: Vec::new(),
        };
        for (k, &i) in subset.iter().enumerate() {
            let g = data.group[i];
            let (e2, dof, scaled) = match resid {
                Some((e, lev)) => (
                    e[k] * e[k],
                    1.0 - lev[k],
                    e[k] * e[k] / (1.0 - lev[k]).max(1e-9),
                ),
                None => (data.resid(i).powi(2), 1.0, data.resid(i).powi(2)),
            };
            r.ss[g] += e2;
            r.df[g] += dof;
            r.scaled.push((g, scaled, data.fixture[i].powi(2)));
        }
        r
    }

    /// Whether the rows (of group `g`, or all) declare an orientation error.
    fn declared(&self, g: Option<usize>) -> bool {
        self.scaled
            .iter()
            .any(|&(h, _, f2)| f2 > 0.0 && g.is_none_or(|g| g == h))
    }

    /// The variance of group `g`'s rows (or all), beside their orientation errors.
    fn variance(&self, g: Option<usize>) -> f64 {
        variance_beside(
            &self
                .scaled
                .iter()
                .filter(move |&&(h, _, _)| g.is_none_or(|g| g == h))
                .map(|&(_, r, f2)| (r, f2)),
        )
    }

    /// The variance of all the rows.
    fn pooled(&self) -> f64 {
        if self.declared(None) {
            self.variance(None)
        } else {
            self.ss.iter().sum::<f64>() / self.df.iter().sum::<f64>().max(1e-9)
        }
    }

    /// Group `g`'s own variance, where it has two degrees of freedom or more.
    fn group(&self, g: usize) -> Option<f64> {
        (self.df[g] >= 2.0).then(|| {
            if self.declared(Some(g)) {
                self.variance(Some(g))
            } else {
                self.ss[g] / self.df[g]
            }
        })
    }
}

/// The variance `v` of the noise beside known variances: the maximum-likelihood `v` of
/// residuals `rᵢ` (squared, scaled to their variance) distributed as `N(0, v + fᵢ²)`, from
/// pairs `(rᵢ, fᵢ²)`. The likelihood equation `Σ (rᵢ − v − fᵢ²)/(v + fᵢ²)² = 0` is solved by
/// its fixed point `v = Σ wᵢ²·(rᵢ − fᵢ²) / Σ wᵢ²`, `wᵢ = 1/(v + fᵢ²)`: the rows with the
/// smallest known variance weigh the most, as they know `v` best. Never below a millionth
/// of the mean `rᵢ` (a noise the data cannot tell from 0).
fn variance_beside(pairs: &(impl Iterator<Item = (f64, f64)> + Clone)) -> f64 {
    let (mut n, mut sum_r, mut sum_d) = (0.0, 0.0, 0.0);
    for (r, f2) in pairs.clone() {
        n += 1.0;
        sum_r += r;
        sum_d += r - f2;
    }
    if n == 0.0 {
        return 0.0;
    }
    let floor = (sum_r / n).max(f64::MIN_POSITIVE) * 1e-6;
    let mut v = (sum_d / n).max(floor);
    for _ in 0..200 {
        let (mut num, mut den) = (0.0, 0.0);
        for (r, f2) in pairs.clone() {
            let w2 = (v + f2).powi(-2);
            num += w2 * (r - f2);
            den += w2;
        }
        let next = (num / den).max(floor);
        let done = (next - v).abs() <= 1e-12 * v;
        v = next;
        if done {
            break;
        }
    }
    v
}

/// Fit the model to `subset`: nuisance terms, noise, stepwise selection over `family`.
#[must_use]
pub fn fit(data: &Data, subset: &[usize], settings: Settings) -> Fitted {
    let mut s = Selection::new(data, subset, settings);
    for _ in 0..s.max_rounds() {
        if !s.next_round() {
            break;
        }
    }
    s.finish()
}

/// The sigmas' design of `subset`: each row's residual over its sigma.
fn design(data: &Data, subset: &[usize], sigma: Vec<f64>) -> Design {
    let z = subset
        .iter()
        .zip(&sigma)
        .map(|(&i, s)| data.resid(i) / s)
        .collect();
    Design { sigma, z }
}

/// The noise estimate: the sigmas, where they came from, and each variance group's.
type Noise = (Vec<f64>, NoiseSource, Vec<(usize, f64)>);

/// [`fit`]'s stepwise selection as its state and named steps: set up ([`Selection::new`]),
/// one round at a time ([`Selection::next_round`]: a re-profiled time constant, else a
/// term added, else a term dropped), then the model ([`Selection::finish`]).
struct Selection<'a> {
    data: &'a Data,
    subset: &'a [usize],
    settings: Settings,
    /// The nuisance terms, their raw columns and the drift's origin.
    nuisance: Vec<Nuisance>,
    nraw: Vec<Vec<f64>>,
    t0: f64,
    /// Every row states its sigma.
    stated: bool,
    /// The least part of a column outside the span it is tested beside.
    min_partial: f64,
    noise: Noise,
    d: Design,
    /// The weighted nuisance columns and each candidate's (`None`: no signature here).
    ncols: Vec<Col>,
    cand: Vec<Option<Col>>,
    /// The testable candidates (indices into the signatures), ties to the first-order
    /// terms; the untestable ones, without a signature or inside the nuisance span.
    family: Vec<usize>,
    untestable: Vec<CandidateId>,
    untestable_nuisance: Vec<CandidateId>,
    /// The family's size as hypotheses ([`family_size`]).
    m: usize,
    /// The warm-up grid's testable members in increasing τ, and every testable time
    /// constant (the estimated one too).
    profile: Vec<usize>,
    members: Vec<usize>,
    /// The time since power-on over the span of each row.
    on_span: Option<Vec<Option<f64>>>,
    /// The bias a transient is measured from, and the bias when it came in with one.
    bias: Option<usize>,
    companion: Option<usize>,
    set: Vec<usize>,
    steps: Vec<Step>,
    visited: std::collections::BTreeSet<Vec<usize>>,
}

/// What a round knows of the current model before it tries a step.
struct Round {
    cur: Vec<Col>,
    fit: LsqFit,
    /// The larger model's noise the step tests are scaled by.
    reference: Option<Reference>,
    /// The selected time constant, the least χ² over τ of the current model, and how much
    /// better that is than the model at its column's τ.
    warm: Option<usize>,
    best: Option<f64>,
    slack: f64,
    /// The bias (its index) and the current model's fit with it, when a warm-up's trial
    /// brings it.
    with_bias: Option<(usize, LsqFit)>,
}

impl<'a> Selection<'a> {
    /// The nuisance-only model, its noise (reweighted twice when estimated), the columns
    /// and the family.
    fn new(data: &'a Data, subset: &'a [usize], settings: Settings) -> Self {
        let (nuisance, nraw, t0) = nuisance_columns(data, subset);
        let noise = estimate_sigma(data, subset, None);
        let d = design(data, subset, noise.0.clone());
        let mut s = Selection {
            data,
            subset,
            settings,
            nuisance,
            nraw,
            t0,
            stated: subset.iter().all(|&i| data.stated[i].is_some()),
            min_partial: (1.0 - settings.confound_cos * settings.confound_cos)
                .max(0.0)
                .sqrt(),
            noise,
            d,
            ncols: Vec::new(),
            cand: Vec::new(),
            family: Vec::new(),
            untestable: Vec::new(),
            untestable_nuisance: Vec::new(),
            m: 0,
            profile: Vec::new(),
            members: Vec::new(),
            on_span: time_on_span(data, subset),
            bias: None,
            companion: None,
            set: Vec::new(),
            steps: Vec::new(),
            visited: std::collections::BTreeSet::from([Vec::new()]),
        };
        if !s.stated {
            // Two reweighting passes under the nuisance-only model.
            for _ in 0..2 {
                let ncols: Vec<Col> = s.nraw.iter().map(|r| s.d.col(r)).collect();
                if let Some(f) = s.d.fit(&ncols.iter().collect::<Vec<_>>()) {
                    s.renoise(&f);
                }
            }
        }
        (s.ncols, s.cand) = s.columns();
        s.classify();
        s
    }

    /// The noise estimated again from the residuals of `f`, and the design with it.
    fn renoise(&mut self, f: &LsqFit) {
        let e: Vec<f64> = f
            .resid
            .iter()
            .zip(&self.d.sigma)
            .map(|(z, s)| z * s)
            .collect();
        self.noise = estimate_sigma(self.data, self.subset, Some((&e, &f.leverage)));
        self.d = design(self.data, self.subset, self.noise.0.clone());
    }

    /// The weighted nuisance columns and candidate columns of the current design.
    fn columns(&self) -> (Vec<Col>, Vec<Option<Col>>) {
        let ncols: Vec<Col> = self.nraw.iter().map(|r| self.d.col(r)).collect();
        let cand: Vec<Option<Col>> = self
            .data
            .signatures
            .iter()
            .map(|s| {
                let raw: Vec<f64> = self.subset.iter().map(|&i| s.col[i]).collect();
                (!s.null)
                    .then(|| self.d.col(&raw))
                    .filter(|c| c.scale > 0.0)
            })
            .collect();
        (ncols, cand)
    }

    /// Testability (a signature, and a part outside the nuisance span), the family in its
    /// order, its size, the warm-up's members and the bias.
    fn classify(&mut self) {
        let data = self.data;
        let basis: Vec<&[f64]> = self.ncols.iter().map(|c| c.unit.as_slice()).collect();
        for (k, s) in data.signatures.iter().enumerate() {
            match &self.cand[k] {
                // The warm-up at an estimated τ has a column only once one is estimated
                // (`Data::with_warm_up`); before, it is no candidate at all.
                None if s.id == CandidateId::WarmUp => {}
                None => self.untestable.push(s.id),
                Some(c) if norm(&residualize(&c.unit, &basis)) < self.min_partial => {
                    self.untestable_nuisance.push(s.id);
                }
                Some(_) => self.family.push(k),
            }
        }
        // Exact ties go to the first-order terms, then to registry order.
        self.family
            .sort_by_key(|&k| (!data.signatures[k].id.first_order(), k));
        if !self.settings.select {
            self.family.clear();
        }
        let ids: Vec<CandidateId> = self.family.iter().map(|&k| data.signatures[k].id).collect();
        self.m = family_size(&ids);
        // The grid's testable members in increasing τ (registry order), for the length of
        // the profile's curve (the warm-up at an estimated τ lies on it) and the
        // re-profiling.
        self.profile = self
            .family
            .iter()
            .copied()
            .filter(|&k| data.signatures[k].id.profile_rate().is_some())
            .collect();
        self.profile.sort_unstable();
        self.members = self
            .family
            .iter()
            .copied()
            .filter(|&k| self.profiled(k))
            .collect();
        // A warm-up is tested with the bias in the model, and brought into it with the
        // warm-up when not selected already (its companion: dropped with it, not tested
        // alone while it is in).
        self.bias = self
            .family
            .iter()
            .copied()
            .find(|&k| data.signatures[k].id == CandidateId::Bias);
    }

    /// At most this many rounds.
    fn max_rounds(&self) -> usize {
        4 * self.m + 4 + 2 * self.profile.len()
    }

    fn profiled(&self, k: usize) -> bool {
        self.data.signatures[k].id.profiled()
    }

    /// The nuisance columns and those of the candidates `set`.
    fn cols_of(&self, set: &[usize]) -> Vec<Col> {
        let mut v: Vec<Col> = self.ncols.clone();
        v.extend(set.iter().filter_map(|&k| self.cand[k].clone()));
        v
    }

    /// The fit of the nuisance terms and the candidates `set`.
    fn fit_of(&self, set: &[usize]) -> Option<LsqFit> {
        let c = self.cols_of(set);
        self.d.fit(&c.iter().collect::<Vec<_>>())
    }

    /// One round: `false` when the selection has settled.
    fn next_round(&mut self) -> bool {
        let cur = self.cols_of(&self.set);
        let Some(fit) = self.d.fit(&cur.iter().collect::<Vec<_>>()) else {
            return false;
        };
        if self.reprofiled(&fit) {
            return true;
        }
        let round = self.round(cur, fit);
        if self.added(&round) {
            return true;
        }
        !self.set.is_empty() && self.dropped(&round)
    }

    /// The profile's time constant, re-profiled given the other selected terms: a
    /// transient first entered at the τ that fitted what an earlier selection left may fit
    /// better at another once that selection is in (and the earlier one may then go,
    /// backward). Whether it moved.
    fn reprofiled(&mut self, cur: &LsqFit) -> bool {
        let Some((next, step)) = reprofile(&self.set, &self.members, cur, |s: &[usize]| {
            self.fit_of(s).map(|f| f.chi2)
        }) else {
            return false;
        };
        if !self.visited.insert(next.clone()) {
            return false;
        }
        self.set = next;
        self.steps.push(Step {
            added: true,
            id: self.data.signatures[step.0].id,
            delta_chi2: step.2,
            p_value: chi2_sf(step.2, 1.0),
            threshold: 1.0,
            replaces: Some(self.data.signatures[step.1].id),
            note: Some(
                "the warm-up's time constant re-profiled with the other selected terms in the model: not a test (the time constants are one hypothesis, already selected); the one that fits best is the estimate, and p is that of its gain in chi2"
                    .to_string(),
            ),
        });
        true
    }

    /// The round's reference, the warm-up's best τ and the bias's fit.
    fn round(&self, cur: Vec<Col>, fit: LsqFit) -> Round {
        let reference = self.reference(&cur, &fit);
        let warm = self.set.iter().copied().find(|&j| self.profiled(j));
        let best = warm.and_then(|j| self.best_tau(&others_of(&self.set, j)));
        let slack = best.map_or(0.0, |c| (fit.chi2 - c).max(0.0));
        // The warm-up's trials hold the bias (its companion) when the model does not.
        let with_bias = self
            .bias
            .filter(|b| !self.set.contains(b) && !self.profile.is_empty())
            .and_then(|b| {
                let c = self.cand[b].as_ref()?;
                let mut t: Vec<&Col> = cur.iter().collect();
                t.push(c);
                self.d.fit(&t).map(|f| (b, f))
            });
        Round {
            cur,
            fit,
            reference,
            warm,
            best,
            slack,
            with_bias,
        }
    }

    /// The reference: the current model plus the remaining candidates that add an
    /// independent column, those nearest the current residual first, while it keeps
    /// [`MIN_REFERENCE_DOF`] residual degrees of freedom (without a cap a small design runs
    /// out of them and the test falls back to the trial's own residuals, which hold every
    /// other real effect).
    fn reference(&self, cur: &[Col], fit: &LsqFit) -> Option<Reference> {
        let n = self.subset.len();
        let mut big: Vec<&[f64]> = cur.iter().map(|c| c.unit.as_slice()).collect();
        let mut rest: Vec<(f64, usize)> = self
            .family
            .iter()
            .filter(|k| !self.set.contains(k))
            .filter_map(|&k| {
                let c = self.cand[k].as_ref()?;
                let d: f64 = c.unit.iter().zip(&fit.resid).map(|(a, b)| a * b).sum();
                Some((d.abs(), k))
            })
            .collect();
        rest.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        // One time constant of the profile at most (the nearest): its members are one
        // hypothesis, and each further τ would take a degree of freedom from the reference.
        let mut profile_held = self.set.iter().any(|&j| self.profiled(j));
        for &(_, k) in &rest {
            if big.len() + MIN_REFERENCE_DOF >= n {
                break;
            }
            if self.profiled(k) && profile_held {
                continue;
            }
            if let Some(c) = &self.cand[k]
                && norm(&residualize(&c.unit, &big)) >= self.min_partial
            {
                big.push(&c.unit);
                profile_held |= self.profiled(k);
            }
        }
        lsq(&self.d.z, &big).and_then(|f| Reference::of(&f))
    }

    /// With a warm-up in the model, a term is tested between the models with and without
    /// it each at the transient's best τ (a profile-likelihood test): at the column's τ the
    /// term could take up the transient's mismatch, and without it the transient could fit
    /// better at another τ. The least χ² over τ of the terms `others` and the transient.
    fn best_tau(&self, others: &[usize]) -> Option<f64> {
        let x = self.on_span.as_ref()?;
        let c = self.cols_of(others);
        let chi2 = |r: f64| -> f64 {
            let raw: Vec<f64> = x
                .iter()
                .map(|x| x.map_or(0.0, |x| (-x * r).exp()))
                .collect();
            let u = self.d.col(&raw);
            let mut with_u: Vec<&Col> = c.iter().collect();
            with_u.push(&u);
            self.d.fit(&with_u).map_or(f64::INFINITY, |g| g.chi2)
        };
        rate_profile(&chi2, TEST_RATE_POINTS).map(|p| p.chi2)
    }

    /// Forward: each candidate outside the model with its p-value and its drop in χ²; the
    /// profile's members are one hypothesis, the best of them tested with its p-value
    /// corrected for the search over τ.
    fn trials(&self, r: &Round) -> Vec<(usize, f64, f64)> {
        let n = self.subset.len();
        let basis: Vec<&[f64]> = r.cur.iter().map(|c| c.unit.as_slice()).collect();
        let cur_refs: Vec<&Col> = r.cur.iter().collect();
        let profile_in = self.set.iter().any(|&j| self.profiled(j));
        let with_bias = r
            .with_bias
            .as_ref()
            .and_then(|(b, f)| Some((self.cand[*b].as_ref()?, f)));
        let mut trials: Vec<(usize, f64, f64)> = Vec::new();
        for &k in &self.family {
            if self.set.contains(&k) || r.cur.len() + 2 > n || (profile_in && self.profiled(k)) {
                continue;
            }
            let Some(c) = &self.cand[k] else { continue };
            if norm(&residualize(&c.unit, &basis)) < self.min_partial {
                continue;
            }
            let mut trial = cur_refs.clone();
            let mut without = r.fit.chi2;
            if self.profiled(k)
                && let Some((b, fb)) = with_bias
            {
                if r.cur.len() + 3 > n {
                    continue;
                }
                trial.push(b);
                without = fb.chi2;
            }
            trial.push(c);
            let Some(f) = self.d.fit(&trial) else {
                continue;
            };
            if let (Some(j), Some(w)) = (r.warm, r.best)
                && !self.profiled(k)
            {
                // The trial at the transient's best τ against the model at its own.
                let mut s = others_of(&self.set, j);
                s.push(k);
                s.sort_unstable();
                if let Some(b) = self.best_tau(&s) {
                    without = w + (f.chi2 - b).max(0.0);
                }
            }
            let tcols: Vec<&[f64]> = trial.iter().map(|c| c.unit.as_slice()).collect();
            let p = step_p(
                &f,
                &tcols,
                trial.len() - 1,
                without,
                self.stated,
                r.reference.as_ref(),
            );
            trials.push((k, p, r.fit.chi2 - f.chi2));
        }
        if trials.iter().any(|t| self.profiled(t.0)) {
            let mut held = basis.clone();
            if let Some((b, _)) = with_bias {
                held.push(&b.unit);
            }
            let length = profile_length(&self.profile, &self.cand, &held);
            for t in trials.iter_mut().filter(|t| self.profiled(t.0)) {
                t.1 = profile_p(t.1, length);
            }
        }
        trials
    }

    /// The trial with the least p-value; among the candidates these data cannot tell from
    /// it (partial columns parallel to within 0.1 %), the simplest: a model-equation term
    /// before another additive term, an additive term before a parameter of the loop (whose
    /// closed-loop sensitivity carries a little noise that would otherwise decide).
    fn best_trial(&self, trials: &[(usize, f64, f64)], cur: &[Col]) -> Option<(usize, f64, f64)> {
        let mut best: Option<(usize, f64, f64)> = None;
        for &t in trials {
            if best.is_none_or(|(_, bp, _)| t.1 < bp * (1.0 - 1e-9)) {
                best = Some(t);
            }
        }
        let (kb, ..) = best?;
        let Some(cb) = &self.cand[kb] else {
            return best;
        };
        let basis: Vec<&[f64]> = cur.iter().map(|c| c.unit.as_slice()).collect();
        let ub = residualize(&cb.unit, &basis);
        let rank = |k: usize| (self.data.signatures[k].id.rank(), k);
        for &t in trials {
            let Some(c) = &self.cand[t.0] else { continue };
            if rank(t.0) < rank(best.map_or(kb, |b| b.0))
                && abs_cos(&residualize(&c.unit, &basis), &ub) > EQUIVALENT_COS
            {
                best = Some(t);
            }
        }
        best
    }

    /// Hypotheses rejected so far (a companion bias was not tested).
    fn held(&self) -> usize {
        self.set.len() - usize::from(self.companion.is_some())
    }

    /// Forward: the best trial added if it passes its Holm level (with the bias it brings,
    /// for a warm-up), and the noise estimated again. Whether one was.
    fn added(&mut self, r: &Round) -> bool {
        #[allow(clippy::cast_precision_loss)]
        let thr_add = self.settings.alpha / (self.m - self.held()).max(1) as f64;
        let trials = self.trials(r);
        let Some((k, p, delta)) = self.best_trial(&trials, &r.cur).filter(|t| t.1 <= thr_add)
        else {
            return false;
        };
        let mut next = self.set.clone();
        next.push(k);
        let brings = self
            .bias
            .filter(|b| self.profiled(k) && r.with_bias.is_some() && !self.set.contains(b));
        next.extend(brings);
        next.sort_unstable();
        if !self.visited.insert(next.clone()) {
            return false;
        }
        self.set = next;
        let id = self.data.signatures[k].id;
        if let Some(b) = brings {
            self.companion = Some(b);
            self.steps.push(Step {
                added: true,
                id: self.data.signatures[b].id,
                delta_chi2: 0.0,
                p_value: p,
                threshold: thr_add,
                replaces: None,
                note: Some(format!(
                    "brought with {}: the level a transient settles to, which it is measured from; not tested alone, and dropped with it",
                    id.info().name
                )),
            });
        }
        self.steps.push(Step {
            added: true,
            id,
            delta_chi2: delta,
            p_value: p,
            threshold: thr_add,
            replaces: None,
            note: None,
        });
        if !self.stated
            && let Some(f) = self.fit_of(&self.set)
        {
            // Re-estimate the noise with the new model.
            self.renoise(&f);
            (self.ncols, self.cand) = self.columns();
        }
        true
    }

    /// Backward: the weakest term of the model with its p-value and its rise in χ² when
    /// dropped.
    fn weakest(&self, r: &Round) -> Option<(usize, f64, f64)> {
        let basis: Vec<&[f64]> = r.cur.iter().map(|c| c.unit.as_slice()).collect();
        let nn = self.ncols.len();
        let mut worst: Option<(usize, f64, f64)> = None;
        for (pos, &k) in self.set.iter().enumerate() {
            if Some(k) == self.companion {
                continue;
            }
            let rest = others_of(&self.set, k);
            let rc = self.cols_of(&rest);
            let Some(fr) = self.d.fit(&rc.iter().collect::<Vec<_>>()) else {
                continue;
            };
            let without = self.without_term(k, &rest, fr.chi2, r.slack);
            let mut p = step_p(
                &r.fit,
                &basis,
                nn + pos,
                without,
                self.stated,
                r.reference.as_ref(),
            );
            if self.profiled(k) {
                let without: Vec<&[f64]> = rc.iter().map(|c| c.unit.as_slice()).collect();
                p = profile_p(p, profile_length(&self.profile, &self.cand, &without));
            }
            if worst.is_none_or(|(_, wp, _)| p > wp * (1.0 + 1e-9)) {
                worst = Some((k, p, without - r.fit.chi2));
            }
        }
        worst
    }

    /// The χ² of the model without term `k` (`rest` the others, `chi2` their fit's). With a
    /// warm-up in the model, its τ may fit better at another time constant without the
    /// term: the term is tested against the best of them and of every τ between and beyond
    /// the grid's (a profile-likelihood test), the model with the term at its best τ too
    /// (`slack`), so that the two are compared alike.
    fn without_term(&self, k: usize, rest: &[usize], chi2: f64, slack: f64) -> f64 {
        let mut without = chi2;
        if self.profiled(k) {
            return without;
        }
        let Some(&j) = rest.iter().find(|&&j| self.profiled(j)) else {
            return without;
        };
        let alt = others_of(rest, j);
        let c = self.cols_of(&alt);
        for &o in self.members.iter().filter(|&&o| o != j) {
            let mut with_o: Vec<&Col> = c.iter().collect();
            with_o.extend(self.cand[o].as_ref());
            if let Some(g) = self.d.fit(&with_o) {
                without = without.min(g.chi2);
            }
        }
        if let Some(c) = self.best_tau(&alt) {
            without = without.min(c);
        }
        without + slack
    }

    /// Backward: the weakest term dropped if it no longer passes its level (with the bias
    /// a warm-up brought). Whether one was.
    fn dropped(&mut self, r: &Round) -> bool {
        #[allow(clippy::cast_precision_loss)]
        let thr_keep = self.settings.alpha / (self.m + 1 - self.held()).max(1) as f64;
        let Some((k, p, delta)) = self.weakest(r).filter(|w| w.1 > thr_keep) else {
            return false;
        };
        let goes = self.companion.filter(|_| self.profiled(k));
        let next: Vec<usize> = self
            .set
            .iter()
            .copied()
            .filter(|&j| j != k && Some(j) != goes)
            .collect();
        if !self.visited.insert(next.clone()) {
            return false;
        }
        self.set = next;
        let id = self.data.signatures[k].id;
        if let Some(b) = goes {
            self.companion = None;
            self.steps.push(Step {
                added: false,
                id: self.data.signatures[b].id,
                delta_chi2: 0.0,
                p_value: p,
                threshold: thr_keep,
                replaces: None,
                note: Some(format!("dropped with {}, which brought it", id.info().name)),
            });
        }
        self.steps.push(Step {
            added: false,
            id,
            delta_chi2: delta,
            p_value: p,
            threshold: thr_keep,
            replaces: None,
            note: None,
        });
        true
    }

    /// The selected model fitted, with its coefficients and standard errors.
    fn finish(self) -> Fitted {
        let n = self.subset.len();
        let cols = self.cols_of(&self.set);
        let refs: Vec<&Col> = cols.iter().collect();
        let fit = self.d.fit(&refs).unwrap_or_else(|| {
            // Rank-deficient nuisance (cannot happen with the guards above): no model.
            lsq(&self.d.z, &[]).unwrap_or_else(|| unreachable!("an empty fit always succeeds"))
        });
        let dof = n.saturating_sub(fit.beta.len());
        let birge = birge_ratio(fit.chi2, dof);
        let (coef, se): (Vec<f64>, Vec<f64>) = cols
            .iter()
            .enumerate()
            .map(|(j, c)| {
                let b = fit.beta.get(j).copied().unwrap_or(0.0) / c.scale;
                let classical = fit.cov.get((j, j)).copied().unwrap_or(0.0).sqrt() * birge;
                let robust = if self.stated {
                    0.0
                } else {
                    fit.se_hc3.get(j).copied().unwrap_or(0.0)
                };
                (b, classical.max(robust) / c.scale)
            })
            .unzip();
        let id = |k: &usize| self.data.signatures[*k].id;
        let fitted_cols = if fit.beta.len() == cols.len() {
            cols
        } else {
            Vec::new()
        };
        Fitted {
            subset: self.subset.to_vec(),
            nuisance: self.nuisance,
            t0: self.t0,
            family: self.family.iter().map(id).collect(),
            untestable: self.untestable,
            untestable_nuisance: self.untestable_nuisance,
            selected: self.set.iter().map(id).collect(),
            steps: self.steps,
            companion: self.companion.as_ref().map(id),
            sigma: self.d.sigma.clone(),
            noise: self.noise.1,
            group_sigma: self.noise.2,
            coef,
            se,
            settings: self.settings,
            fit,
            cols: fitted_cols,
            cand_cols: self.cand,
        }
    }
}

/// `s` without `j`.
fn others_of(s: &[usize], j: usize) -> Vec<usize> {
    s.iter().copied().filter(|&i| i != j).collect()
}

impl Fitted {
    /// Number of hypotheses in the family ([`family_size`]): the level a candidate is
    /// tested at alone is α over it.
    #[must_use]
    pub fn family_size(&self) -> usize {
        family_size(&self.family)
    }

    /// Number of nuisance terms.
    #[must_use]
    pub fn n_nuisance(&self) -> usize {
        self.nuisance.len()
    }

    /// Coefficient of the selected candidate `id`, with its standard error.
    #[must_use]
    pub fn candidate(&self, id: CandidateId) -> Option<(f64, f64)> {
        let k = self.selected.iter().position(|&s| s == id)?;
        let j = self.nuisance.len() + k;
        Some((self.coef[j], self.se[j]))
    }

    /// The nuisance part of the model at data row `i` (it need not be in the subset), cm/s²:
    /// the row's block shift (0 for a block the subset does not hold) plus the drift.
    #[must_use]
    pub fn nuisance_at(&self, data: &Data, i: usize) -> f64 {
        self.nuisance_for(data.block[i], data.shift[i], data.drifts[i], data.time[i])
    }

    /// The nuisance part of the model for an observation of block `block` (index into
    /// `Data::block_names`) that takes the block's shift (`shift`) and the drift (`drifts`)
    /// at time `time`, cm/s².
    #[must_use]
    pub fn nuisance_for(&self, block: usize, shift: bool, drifts: bool, time: f64) -> f64 {
        self.nuisance
            .iter()
            .enumerate()
            .map(|(j, t)| match *t {
                Nuisance::Block(b) if block == b && shift => self.coef[j],
                Nuisance::Drift if drifts => self.coef[j] * (time - self.t0),
                Nuisance::Block(_) | Nuisance::Drift => 0.0,
            })
            .sum()
    }

    /// The model's prediction of data row `i`'s residual to explain (measured − baseline),
    /// cm/s²: nuisance plus the selected candidates' signatures.
    #[must_use]
    pub fn predict(&self, data: &Data, i: usize) -> f64 {
        let mut v = self.nuisance_at(data, i);
        for (k, &id) in self.selected.iter().enumerate() {
            if let Some(s) = data.signatures.iter().find(|s| s.id == id) {
                v += self.coef[self.nuisance.len() + k] * s.col[i];
            }
        }
        v
    }

    /// The sigma the model gives observation `i` of `data`, which need not be in the
    /// subset: its own in the subset, else its stated sigma, else its variance group's
    /// estimate with its orientation error added (`None` when the subset holds no row of
    /// that group).
    #[must_use]
    pub fn sigma_at(&self, data: &Data, i: usize) -> Option<f64> {
        if let Some(k) = self.subset.iter().position(|&j| j == i) {
            return Some(self.sigma[k]);
        }
        data.stated[i].or_else(|| {
            self.group_sigma
                .iter()
                .find(|(g, _)| *g == data.group[i])
                .map(|&(_, s)| s.hypot(data.fixture[i]))
        })
    }

    /// Observation `i`'s row of the final model's design in the fit's coordinates (the
    /// unit-norm columns, the row weighted by `1/sigma`), for an observation that need not
    /// be in the subset; `None` when it takes a block shift the model does not hold (then
    /// nothing in the model predicts it).
    #[must_use]
    pub fn unit_row(&self, data: &Data, i: usize, sigma: f64) -> Option<Vec<f64>> {
        if self.cols.len() != self.fit.beta.len()
            || (data.shift[i] && !self.nuisance.contains(&Nuisance::Block(data.block[i])))
        {
            return None;
        }
        let nn = self.nuisance.len();
        let mut x: Vec<f64> = self
            .nuisance
            .iter()
            .map(|t| match *t {
                Nuisance::Block(b) if data.block[i] == b && data.shift[i] => 1.0,
                Nuisance::Drift if data.drifts[i] => data.time[i] - self.t0,
                Nuisance::Block(_) | Nuisance::Drift => 0.0,
            })
            .collect();
        for &id in &self.selected {
            x.push(data.signatures.iter().find(|s| s.id == id)?.col[i]);
        }
        for (j, v) in x.iter_mut().enumerate() {
            let scale = self.cols[j].scale;
            *v = if scale > 0.0 { *v / sigma / scale } else { 0.0 };
        }
        debug_assert_eq!(x.len(), nn + self.selected.len());
        Some(x)
    }

    /// The weighted, unit-norm design columns of the final model (nuisance then selected).
    pub(crate) fn unit_columns(&self) -> Vec<&[f64]> {
        self.cols.iter().map(|c| c.unit.as_slice()).collect()
    }

    /// A candidate's weighted column in this design: `(unit column, scale)`.
    pub(crate) fn candidate_column(&self, data: &Data, id: CandidateId) -> Option<(&[f64], f64)> {
        let k = data.signatures.iter().position(|s| s.id == id)?;
        self.cand_cols[k]
            .as_ref()
            .map(|c| (c.unit.as_slice(), c.scale))
    }

    /// Weight (`1/σ`) the subset row at position `k` carries.
    #[must_use]
    pub fn weight(&self, k: usize) -> f64 {
        1.0 / self.sigma[k]
    }

    /// Whether the sigmas were stated.
    #[must_use]
    pub fn stated(&self) -> bool {
        self.noise == NoiseSource::Stated
    }

    /// Residual degrees of freedom.
    #[must_use]
    pub fn dof(&self) -> usize {
        self.subset.len().saturating_sub(self.fit.beta.len())
    }

    /// The p-value of adding a weighted column `v` (cm/s²/σ per unit, any scale) to the final
    /// model, by the same rule as a selection step.
    #[must_use]
    pub fn add_p(&self, v: &[f64]) -> Option<f64> {
        let s = norm(v);
        if s == 0.0 {
            return None;
        }
        let unit: Vec<f64> = v.iter().map(|x| x / s).collect();
        let mut cols = self.unit_columns();
        if norm(&residualize(&unit, &cols)) < 1e-6 {
            return None;
        }
        cols.push(&unit);
        let zfull = self.weighted_target();
        let f = lsq(&zfull, &cols)?;
        Some(step_p(
            &f,
            &cols,
            cols.len() - 1,
            self.fit.chi2,
            self.stated(),
            None,
        ))
    }

    /// The weighted target `(measured − baseline)/σ` of the subset.
    pub(crate) fn weighted_target(&self) -> Vec<f64> {
        // z = fitted + residual.
        let cols = self.unit_columns();
        (0..self.subset.len())
            .map(|i| {
                self.fit.resid[i]
                    + cols
                        .iter()
                        .zip(&self.fit.beta)
                        .map(|(c, b)| c[i] * b)
                        .sum::<f64>()
            })
            .collect()
    }

    /// The time unit of the drift.
    #[must_use]
    pub fn time_unit(data: &Data) -> TimeUnit {
        data.time_unit
    }
}

#[cfg(test)]
mod tests {
    use super::{Reference, STATED_SIGMA_DOF, step_p};
    use crate::stats::{f_sf, lsq};

    /// A 6-SE step (Δχ² = 36) tested against a reference model with 2 residual degrees of
    /// freedom, as in an 8-point tumble: with a stated sigma those residuals do not reject,
    /// it passes Holm's first level 0.05/7 (it would not as F(1, 2)); with a stated sigma
    /// they reject (χ²₂ = 40), the residuals' scale alone decides and it does not pass;
    /// with the sigma estimated, F(1, 2) decides.
    #[test]
    fn a_small_design_pools_a_stated_sigma_it_does_not_reject() {
        let z = [0.3, -0.1, 0.2, -0.4, 0.1, 0.0, -0.2, 0.1];
        let ones = [1.0; 8];
        let with = lsq(&z, &[&ones]).unwrap();
        let level = 0.05 / 7.0;
        let reference = |s2: f64| Reference {
            s2,
            dof: 2.0,
            resid: Vec::new(),
        };
        let without = with.chi2 + 36.0;
        assert!(f_sf(36.0, 1.0, 2.0) > level);
        let pooled = step_p(&with, &[&ones], 0, without, true, Some(&reference(1.0)));
        assert!(pooled < level, "{pooled}");
        let expected = f_sf(36.0, 1.0, 2.0 + STATED_SIGMA_DOF);
        assert!(
            (pooled - expected).abs() <= 1e-12 * expected,
            "{pooled} {expected}"
        );
        let rejected = step_p(&with, &[&ones], 0, without, true, Some(&reference(20.0)));
        assert!(rejected > level, "{rejected}");
        let estimated = step_p(&with, &[&ones], 0, without, false, Some(&reference(1.0)));
        assert!(estimated > level, "{estimated}");
    }

    /// The profile's correction holds the familywise level it claims on null data, and
    /// no more than it must: pure noise on 24 rows, with a constant and a drift in the
    /// model, tested against the warm-up's seven time constants (the registry's grid, in
    /// increasing τ). The best member's own p-value (no correction) selects about twice
    /// as often as α; Bonferroni over the seven holds α with room to spare; the tube bound
    /// holds it closer to α than Bonferroni does.
    #[test]
    fn the_profile_correction_holds_the_level_on_noise() {
        use super::{Col, profile_length, profile_p};
        use crate::model::effects::CandidateId;
        use crate::stats::{chi2_sf, norm, residualize};
        use rand::SeedableRng as _;
        use rand_distr::Distribution as _;
        let n = 24;
        #[allow(clippy::cast_precision_loss)]
        let x: Vec<f64> = (0..n).map(|k| k as f64 / (n - 1) as f64).collect();
        let unit = |v: Vec<f64>| {
            let s = norm(&v);
            Col {
                unit: v.iter().map(|a| a / s).collect(),
                scale: s,
            }
        };
        let c = unit(vec![1.0; n]);
        let t = unit(x.iter().map(|x| x - 0.5).collect());
        let basis: Vec<&[f64]> = vec![&c.unit, &t.unit];
        let cand: Vec<Option<Col>> = CandidateId::of_effect("warm_up")
            .filter_map(CandidateId::profile_rate)
            .map(|r| Some(unit(x.iter().map(|x| (-x * r).exp()).collect())))
            .collect();
        assert_eq!(cand.len(), 7);
        let profile: Vec<usize> = (0..cand.len()).collect();
        let length = profile_length(&profile, &cand, &basis);
        assert!(length > 0.3 && length < 3.0, "{length}");
        let parts: Vec<Vec<f64>> = cand
            .iter()
            .map(|c| {
                let r = residualize(&c.as_ref().unwrap().unit, &basis);
                let s = norm(&r);
                r.iter().map(|a| a / s).collect()
            })
            .collect();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
        let normal = rand_distr::Normal::new(0.0, 1.0).unwrap();
        let draws = 20_000;
        let (mut raw, mut bonferroni, mut tube) = (0, 0, 0);
        for _ in 0..draws {
            let z: Vec<f64> = (0..n).map(|_| normal.sample(&mut rng)).collect();
            let p = parts
                .iter()
                .map(|u| {
                    let d: f64 = u.iter().zip(&z).map(|(a, b)| a * b).sum();
                    chi2_sf(d * d, 1.0)
                })
                .fold(1.0, f64::min);
            raw += usize::from(p <= 0.05);
            bonferroni += usize::from(7.0 * p <= 0.05);
            tube += usize::from(profile_p(p, length) <= 0.05);
        }
        #[allow(clippy::cast_precision_loss)]
        let rate = |k: usize| k as f64 / f64::from(draws);
        eprintln!(
            "curve length {length:.3} rad; false selections: best member alone {}, Bonferroni {}, tube {}",
            rate(raw),
            rate(bonferroni),
            rate(tube)
        );
        // 0.05 + 3 binomial standard errors (0.0015 at 20 000 draws).
        assert!(rate(tube) <= 0.0546, "tube {}", rate(tube));
        assert!(rate(raw) > 0.08, "raw {}", rate(raw));
        assert!(
            rate(tube) > rate(bonferroni) && rate(tube) > 0.04,
            "tube {} Bonferroni {}",
            rate(tube),
            rate(bonferroni)
        );
    }
}
