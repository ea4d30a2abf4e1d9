//! The discovery method (`docs/discovery.md`): baseline by the simulator, the model with its
//! nuisance terms and selected candidates ([`super::fit`]), confounding, plausibility,
//! unexplained structure ([`super::unexplained`]), the gain out of sample
//! ([`super::crossval`]) and the re-simulated extended model.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::Serialize;

use super::advice::{self, Advice};
use super::crossval::{self, Gain};
use super::data::{self, Data, Quantity, TimeUnit};
use super::fit::{self, Fitted, NoiseSource, Nuisance, Settings};
use super::outliers;
use super::sim::Simulator;
use super::slips;
use super::unexplained::{self, Unexplained};
use crate::model::caseframe::EmptyCells;
use crate::model::condition::Condition;
use crate::model::effects::{CandidateId, Effects, N_CANDIDATES, resolve_candidates};
use crate::model::instrument::Instrument;
use crate::stats::{abs_cos, chi2_sf, lsq, norm, residualize};

pub use super::fit::Step;

/// Resolve a `--candidates` list: effect names (`lever_arm` = its three components) or
/// candidate names (`lever_arm.r_pa_cm`), comma separated. Empty = all.
///
/// # Errors
/// An unknown name (the message lists the known ones).
pub fn parse_candidates(list: &str) -> anyhow::Result<Vec<CandidateId>> {
    let mut out = std::collections::BTreeSet::new();
    for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        out.extend(resolve_candidates(item).map_err(anyhow::Error::msg)?);
    }
    if out.is_empty() {
        return Ok(CandidateId::ALL.to_vec());
    }
    Ok(out.into_iter().collect())
}

/// Settings of the method.
#[derive(Clone, Debug)]
pub struct Options {
    /// Familywise error rate across all candidates (0.05), and the level of the test for
    /// unexplained structure.
    pub alpha: f64,
    /// `|cos|` above which two signatures are indistinguishable (0.99).
    pub confound_cos: f64,
    /// Sigma for rows without `sigma_cm_s2` (`--sigma`), cm/s²; `None`: estimate it.
    pub default_sigma_cm_s2: Option<f64>,
    /// The candidates tested (default: all).
    pub candidates: Vec<CandidateId>,
    /// Plausibility bound of each candidate's coefficient, in its unit (index
    /// [`CandidateId::index`]); from the instrument file's `[plausibility]`.
    pub limits: [f64; N_CANDIDATES],
    /// Seed of the cross-validation folds and the bootstrap.
    pub seed: u64,
    /// Keep the rows the outlier test flags in the fit (`--keep-outliers`): they are still
    /// reported, but not set aside.
    pub keep_outliers: bool,
    /// Analyse values that look like another unit's or the sign's multiple of the
    /// simulated ones as they are (`--units-as-given`), with a warning, instead of refusing
    /// them: an instrument mounted with its input axis reversed reads the negative of its
    /// simulation.
    pub units_as_given: bool,
}

impl Options {
    /// The default options with the plausibility bounds of `instr`.
    #[must_use]
    pub fn for_instrument(instr: &Instrument) -> Self {
        let mut limits = [0.0; N_CANDIDATES];
        for &id in CandidateId::ALL {
            limits[id.index()] = id.info().bound.limit(instr);
        }
        Options {
            alpha: 0.05,
            confound_cos: 0.99,
            default_sigma_cm_s2: None,
            candidates: CandidateId::ALL.to_vec(),
            limits,
            seed: 1,
            keep_outliers: false,
            units_as_given: false,
        }
    }
}

impl Default for Options {
    /// The options with the shipped instrument's plausibility bounds.
    fn default() -> Self {
        Self::for_instrument(&Instrument::kearfott_2401())
    }
}

/// RMS and χ² of a set of residuals.
#[derive(Clone, Debug, Serialize)]
pub struct FitSummary {
    /// Root mean square of `measured − simulated` over the rows measured in cm/s²
    /// (difference and absolute rows), cm/s²; `null` when there are none (response rows
    /// only).
    pub rms_cm_s2: f64,
    /// Root mean square of `(measured − simulated)/sigma` over every observation (a
    /// response row's gain and phase included), dimensionless.
    pub rms_normalised: f64,
    /// `Σ ((measured − simulated)/sigma)²`.
    pub chi2: f64,
    /// Degrees of freedom: fitted rows minus fitted coefficients (nuisance terms included).
    pub dof: usize,
    /// `P(χ²_dof ≥ chi2)`: below 0.05 the rest is not consistent with the sigmas used.
    pub p_value: f64,
}

/// One selected effect, in the `--json` shape.
#[derive(Clone, Debug, Serialize)]
pub struct EffectReport {
    /// Effect name.
    pub name: String,
    /// Fitted coefficients of the selected components, keyed as in the vocabulary.
    pub coefficients: BTreeMap<String, f64>,
    /// Their standard errors.
    pub stderr: BTreeMap<String, f64>,
    /// Every candidate (component names for `lever_arm`) indistinguishable from a selected
    /// component in this data set.
    pub confounded_with: Vec<String>,
    /// Every coefficient within its plausibility bound (the instrument file's
    /// `[plausibility]`); `false`: the data's structure is real but this cause is unlikely.
    pub plausible: bool,
    /// The bounds, keyed as the coefficients.
    pub bounds: BTreeMap<String, f64>,
    /// For a parameter of the instrument file: its fitted value against the file's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub parameter: Option<ParameterValue>,
    /// For a parameter found by a search through the closed loop whose best lies at the end
    /// of the search grid: that end and what it means (`null` otherwise).
    pub search_limit: Option<SearchLimit>,
}

/// Where a search through the closed loop stopped, in the `--json` shape.
#[derive(Clone, Debug, Serialize)]
pub struct SearchLimit {
    /// The candidate whose search it is.
    pub name: String,
    /// The parameter's value at the end of the grid, in the instrument file's unit.
    pub value: f64,
    /// In words.
    pub note: String,
}

/// A row set aside as a suspected gross error (or kept with `--keep-outliers`), in the
/// `--json` shape.
#[derive(Clone, Debug, Serialize)]
pub struct OutlierReport {
    /// The row's label.
    pub row: String,
    /// `measured − expected`, cm/s²: the row's value against the model selected without
    /// it (baseline, nuisance terms and selected terms).
    pub residual_cm_s2: f64,
    /// The familywise p-value: the row's two-sided p-value times the number of rows tested
    /// (Bonferroni), at most 1; a row is flagged at 0.01 or less.
    pub p_value: f64,
    /// The externally studentized residual.
    pub studentized: f64,
    /// Its degrees of freedom.
    pub dof: usize,
    /// The rows the test was over (the Bonferroni factor).
    pub rows_tested: usize,
    /// The measured value, cm/s².
    pub measured_cm_s2: f64,
    /// What the model selected without the row expects, cm/s², and its 1 σ (the noise and
    /// the prediction's uncertainty).
    pub expected_cm_s2: f64,
    /// 1 σ of `residual_cm_s2`, cm/s².
    pub sigma_cm_s2: f64,
    /// The likely cause, in words (an empty input cell read as 0, a unit or sign slip,
    /// another row's value, or none found).
    pub cause: String,
    /// `true` with `--keep-outliers`: reported but fitted; `false`: set aside.
    pub kept: bool,
}

/// One step of the selection, in the `--json` shape.
#[derive(Clone, Debug, Serialize)]
pub struct StepReport {
    /// `add`, `drop` or `swap`.
    pub action: &'static str,
    /// The candidate added, dropped or swapped in.
    pub name: String,
    /// For a swap, the candidate it replaced.
    pub replaces: Option<String>,
    /// The change of χ² the step is worth.
    pub delta_chi2: f64,
    /// Its p-value.
    pub p_value: f64,
    /// The level it was held against.
    pub threshold: f64,
    /// How it was decided, when not by the linear stepwise test.
    pub note: Option<String>,
}

/// The nuisance terms' values, in the `--json` shape.
#[derive(Clone, Debug, Default, Serialize)]
pub struct NuisanceReport {
    /// Bias shift of each block (rows sharing a reference run), cm/s².
    pub bias_shift_cm_s2: BTreeMap<String, f64>,
    /// Linear drift per second of `time_s`, cm/s² per s (when the file has `time_s`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drift_cm_s2_per_s: Option<f64>,
    /// Linear drift per row (when the file has no `time_s`), cm/s² per row.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drift_cm_s2_per_row: Option<f64>,
    /// Standard errors: `bias_shift_cm_s2` (per block) and the drift's key.
    pub stderr: BTreeMap<String, serde_json::Value>,
}

/// Where the noise came from, in the `--json` shape.
#[derive(Clone, Debug, Serialize)]
pub struct NoiseReport {
    /// `stated` (every row's `sigma_cm_s2` or `--sigma`), `replicates` (estimated from
    /// replicated rows) or `residuals` (estimated from the model's residuals).
    pub source: &'static str,
    /// Estimated sigma per variance group (`block/static`, `block/oscillating`), cm/s²
    /// (empty when stated).
    pub sigma_cm_s2: BTreeMap<String, f64>,
    /// What to keep in mind.
    pub caveat: Option<String>,
    /// With stated sigmas and values in cm/s² only: the stated sigmas over the scatter of
    /// the residuals (of the better-fitting, per degree of freedom, of the largest model,
    /// nuisance terms and every testable candidate, and the selected one); about 1 when they
    /// are right (`null` when a sigma is estimated or the data hold response rows).
    pub stated_over_scatter: Option<f64>,
}

/// One observation of a row in the result (a response row has two: its gain and its
/// phase; their values are in the `*_cm_s2` fields, in the unit `quantity` names).
#[derive(Clone, Debug, Serialize)]
pub struct RowResult {
    /// Row label (a response row's with ` (gain)` or ` (phase)`).
    pub label: String,
    /// A response row's input frequency, Hz (absent for other rows).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub freq_hz: Option<f64>,
    /// The row's kind (not in the JSON: `quantity` and `freq_hz` say it there).
    #[serde(skip)]
    pub kind: crate::model::condition::RowKind,
    /// `value_cm_s2`, `gain` or `phase_deg`.
    pub quantity: &'static str,
    /// Measured difference, cm/s² (None = not measured, not fitted).
    pub measured_cm_s2: Option<f64>,
    /// Sigma used, cm/s² (stated or estimated).
    pub sigma_cm_s2: f64,
    /// Baseline model's difference, cm/s².
    pub baseline_cm_s2: f64,
    /// `measured − baseline`, cm/s².
    pub residual_cm_s2: Option<f64>,
    /// Extended model's difference (re-simulated with the selected effects, plus the
    /// nuisance terms), cm/s².
    pub extended_cm_s2: f64,
    /// `measured − extended`, cm/s².
    pub residual_extended_cm_s2: Option<f64>,
    /// A suspected gross error (`outliers`): set aside from the fit unless
    /// `--keep-outliers`.
    pub outlier: bool,
}

/// One term of the model equation.
#[derive(Clone, Debug, Serialize)]
pub struct Term {
    /// Candidate name (`bias`, `scale_factor`, `misalignment.delta_p_rad`, ...).
    pub name: String,
    /// IEEE Std 1293 symbol (`K_0`, `K_1`, `δ_o`, ...; the lever arm and anisoinertia,
    /// which the standard's equation does not hold, by their own names).
    pub symbol: String,
    /// Value in `unit`; for a parameter of the loop (`damping`, ...), its fitted value,
    /// not the change from the instrument file.
    pub value: f64,
    /// The standard's unit (µg, ppm, µg/g², µrad, ...).
    pub unit: String,
    /// 1 σ, in `unit`.
    pub sigma: f64,
}

/// The fitted model as an IEEE Std 1293 model equation, in the `--json` shape.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ModelEquation {
    /// The selected terms in the standard's units.
    pub terms: Vec<Term>,
    /// Correlation matrix of the terms, in their order.
    pub correlation: Vec<Vec<f64>>,
}

/// The `--json` object.
#[derive(Clone, Debug, Serialize)]
pub struct JsonReport {
    /// Number of fitted observations (a row with a measurement, or a response row's gain
    /// and phase).
    pub rows: usize,
    /// Baseline model against the measurements.
    pub baseline: FitSummary,
    /// Selected effects (empty when nothing is significant).
    pub effects: Vec<EffectReport>,
    /// Extended model (baseline + nuisance terms + selected effects, re-simulated) against
    /// the measurements.
    pub extended: FitSummary,
    /// The selected terms as a model equation (IEEE Std 1293 units) with their correlation.
    pub model_equation: ModelEquation,
    /// Rows that would break each confounding (or test an untestable model-equation term).
    pub advice: Vec<Advice>,
    /// The nuisance terms (always in the model, never discoveries).
    pub nuisance: NuisanceReport,
    /// Structure that no candidate explains.
    pub unexplained: Unexplained,
    /// The gain out of sample.
    pub gain: Gain,
    /// The noise.
    pub noise: NoiseReport,
    /// The candidates tested (the family).
    pub family: Vec<String>,
    /// Candidates without a signature in these rows.
    pub not_testable: Vec<String>,
    /// Candidates whose signature the nuisance terms already span.
    pub not_testable_nuisance: Vec<String>,
    /// Groups of candidates indistinguishable here (before any fit).
    pub indistinguishable: Vec<Vec<String>>,
    /// Per-row values.
    pub table: Vec<RowResult>,
    /// The conclusion in one paragraph.
    pub verdict: String,
    /// Warnings (suspected gross errors, stated sigmas far from the scatter, too few rows,
    /// nothing testable, estimated noise, ...).
    pub warnings: Vec<String>,
    /// Rows flagged as suspected gross errors (empty when none).
    pub outliers: Vec<OutlierReport>,
    /// The selection's steps in order: the linear stepwise test's, then those of the
    /// searches through the closed loop (a swap, a scan, a prune).
    pub steps: Vec<StepReport>,
}

/// A parameter of the instrument file as fitted, in the file's unit.
#[derive(Clone, Debug, Serialize)]
pub struct ParameterValue {
    /// The instrument file's key (`pendulum.damping_dyn_cm_s`, ...).
    pub key: String,
    /// The file's value.
    pub nominal: f64,
    /// The fitted value (nominal plus the coefficient).
    pub fitted: f64,
    /// Its 1 σ.
    pub sigma: f64,
    /// The file's tolerance band, `[lo, hi]`.
    pub tolerance: [f64; 2],
    /// The fitted value lies in the band.
    pub within_tolerance: bool,
    /// The value mirrored about the file's (`2·nominal − fitted`) when it fits the data not
    /// significantly worse: the response is even about the file's value (a pickoff phase
    /// error enters as its cosine), so the data give the size of the change, not its sign.
    pub mirror: Option<f64>,
}

impl ParameterValue {
    /// `"damping 114 361 ± 511 dyn·cm·s, nominal 76 400, tolerance 45 840 to 106 960: out of
    /// tolerance"`, in words.
    #[must_use]
    pub fn sentence(&self, name: &str, unit: &str) -> String {
        let value = match self.mirror {
            Some(m) => format!(
                "{} {unit} or {} {unit} (the mirror image about the nominal fits as well: these data give the size of the change, not its sign)",
                super::show::estimate(self.fitted, self.sigma),
                super::show::estimate(m, self.sigma)
            ),
            None => format!("{} {unit}", super::show::estimate(self.fitted, self.sigma)),
        };
        format!(
            "{name} {value}, nominal {} {unit}, tolerance {} to {} {unit}: {}",
            self.nominal,
            self.tolerance[0],
            self.tolerance[1],
            if self.within_tolerance {
                "within tolerance"
            } else {
                "OUT OF TOLERANCE"
            }
        )
    }
}

/// One selected coefficient (typed form, for programs such as the hidden-effect tests).
#[derive(Clone, Debug)]
pub struct Selected {
    /// The candidate.
    pub id: CandidateId,
    /// Coefficient, in the candidate's unit.
    pub coef: f64,
    /// Standard error.
    pub stderr: f64,
    /// Within its plausibility bound (for a parameter: within its tolerance band).
    pub plausible: bool,
    /// For a parameter of the instrument file: its fitted value against the file's.
    pub parameter: Option<ParameterValue>,
    /// Candidates indistinguishable from this one here, with the factor `c` such that the
    /// other's signature ≈ `c ×` this one's (partialled on the nuisance and the other
    /// selected terms): those whose signature is parallel to it (`|cos| > confound_cos`),
    /// and those that would fit the data not significantly worse in its place (the swap's
    /// χ² increase has p > alpha/m, with `|cos| ≥ 0.5`).
    pub confounded: Vec<(CandidateId, f64)>,
    /// For a parameter: the opposite change fits the data not significantly worse
    /// (`discovery::alternatives::mirror`).
    pub mirror: bool,
    /// For a parameter found by a search through the closed loop: the change at the end of
    /// the search grid when its best lies there (`discovery::alternatives`).
    pub search_limit: Option<f64>,
}

/// Everything the method found.
#[derive(Clone, Debug)]
pub struct Discovery {
    /// Simulator used for baseline and extension.
    pub simulator: &'static str,
    /// The JSON summary.
    pub json: JsonReport,
    /// Selected coefficients.
    pub selected: Vec<Selected>,
    /// Per-row values (the same as `json.table`).
    pub table: Vec<RowResult>,
    /// The decisions in order: the linear stepwise test's, then those of the searches
    /// through the closed loop.
    pub steps: Vec<Step>,
    /// Candidates whose signature is identically zero in this data set (not testable).
    pub untestable: Vec<CandidateId>,
    /// Candidates the nuisance terms make untestable.
    pub untestable_nuisance: Vec<CandidateId>,
    /// Parameters the simulated instrument's file gives no tolerance (the amplifier gain
    /// and the ADC offset of the shipped file): never candidates, whatever the data
    /// (also in `untestable`).
    pub untoleranced: Vec<CandidateId>,
    /// Groups of testable candidates with pairwise `|cos| > confound_cos` (before any fit).
    pub confounded_groups: Vec<Vec<CandidateId>>,
    /// The family (testable candidates).
    pub family: Vec<CandidateId>,
    /// Number of hypotheses in the family.
    pub family_size: usize,
    /// The effects found, as coefficients for the plant.
    pub effects: Effects,
    /// The options used.
    pub options: Options,
    /// The linear loop model's response without and with the selected parameters, over
    /// the response rows' frequencies (empty without response rows or a loop model).
    pub bode: Vec<BodePoint>,
    /// Stated sigmas far from the scatter of the data, if so.
    pub sigma_slip: Option<slips::SigmaSlip>,
}

/// One frequency of [`Discovery::bode`].
#[derive(Clone, Copy, Debug)]
pub struct BodePoint {
    /// Frequency, Hz.
    pub freq_hz: f64,
    /// `[gain, phase_deg]` of the instrument file's loop.
    pub nominal: [f64; 2],
    /// The same with the selected parameters' fitted values.
    pub corrected: [f64; 2],
}

/// Statement of the test, printed with every result.
pub const TEST_STATEMENT: &str = "forward-backward stepwise selection against a model that \
always holds a bias shift per block and a linear drift; each step tests the best remaining \
candidate by the largest p-value of the F(1, n-p) test against the residual scale and \
either the chi-squared(1) test with the stated sigmas or, when the sigmas are estimated, the \
heteroscedasticity-robust (HC3) t test, at the Holm-Bonferroni level alpha/(m-k) \
(m = testable candidates, k = already selected), so the familywise error rate over all \
candidates is at most alpha = 0.05";

/// `P(χ²)` summary of `pred` against the measured observations (the RMS over the values in
/// cm/s², or over every observation when there are none).
fn summary(data: &Data, pred: &dyn Fn(usize) -> f64, sigma: &[f64], p: usize) -> FitSummary {
    let n = data.n();
    let res: Vec<f64> = (0..n).map(|i| data.y[i] - pred(i)).collect();
    let values: Vec<f64> = (0..n)
        .filter(|&i| data.quantity[i] == Quantity::Value)
        .map(|i| res[i])
        .collect();
    #[allow(clippy::cast_precision_loss)]
    let rms = if values.is_empty() {
        f64::NAN
    } else {
        (values.iter().map(|r| r * r).sum::<f64>() / values.len() as f64).sqrt()
    };
    let chi2: f64 = res.iter().zip(sigma).map(|(r, s)| (r / s).powi(2)).sum();
    #[allow(clippy::cast_precision_loss)]
    let rms_normalised = (chi2 / n.max(1) as f64).sqrt();
    let dof = n.saturating_sub(p);
    #[allow(clippy::cast_precision_loss)]
    let p_value = chi2_sf(chi2, dof as f64);
    FitSummary {
        rms_cm_s2: rms,
        rms_normalised,
        chi2,
        dof,
        p_value,
    }
}

/// Gauss–Newton on the selected parameters of the instrument file (the response is not
/// linear in them): from the linear fit, repeat (sensitivities at the current values, a
/// weighted least-squares step for the parameters with the additive terms and the nuisance
/// terms refitted) until the steps fall below [`GAUSS_NEWTON_TOLERANCE`] of their standard
/// errors, at most [`GAUSS_NEWTON_STEPS`] times. The coefficients and standard errors of
/// `selected` become those of the last step, or without convergence those of the iterate
/// with the least χ².
#[allow(clippy::too_many_lines)] // one Gauss-Newton iteration and its bookkeeping
fn refine_parameters(
    rows: &[Condition],
    data: &Data,
    f: &Fitted,
    selected: &mut [Selected],
    sim: &dyn Simulator,
    opts: &Options,
) {
    let params: Vec<usize> = (0..selected.len())
        .filter(|&k| selected[k].id.parameter_key().is_some())
        .collect();
    if params.is_empty() {
        return;
    }
    let ids: Vec<CandidateId> = params.iter().map(|&k| selected[k].id).collect();
    let additive: Vec<usize> = (0..selected.len())
        .filter(|k| !params.contains(k))
        .collect();
    let n = data.n();
    let all: Vec<usize> = (0..n).collect();
    let (_, nuis, _) = fit::nuisance_columns(data, &all);
    let sigma = &f.sigma;
    let mut theta = Effects::NONE;
    for &k in &params {
        theta.set(selected[k].id, selected[k].coef);
    }
    let slot = |k: usize| usize::from(data.quantity[k] == Quantity::Phase);
    let mut best: Option<(f64, Vec<Selected>)> = None;
    for _ in 0..GAUSS_NEWTON_STEPS {
        let pred: Vec<Vec<f64>> = {
            let mut rs: Vec<usize> = data.rows.clone();
            rs.dedup();
            let jobs: Vec<(&Condition, &Effects)> =
                rs.iter().map(|&i| (&rows[i], &theta)).collect();
            let mut by_row: Vec<Vec<f64>> = vec![Vec::new(); rows.len()];
            for (&i, v) in rs.iter().zip(sim.observe_all(&jobs)) {
                by_row[i] = v;
            }
            by_row
        };
        let jac = data::sensitivities(rows, data, &ids, sim, &theta);
        let z: Vec<f64> = (0..n)
            .map(|k| {
                (data.y[k] - pred[data.rows[k]].get(slot(k)).copied().unwrap_or(f64::NAN))
                    / sigma[k]
            })
            .collect();
        if z.iter().any(|x| !x.is_finite()) {
            return;
        }
        let w = |c: &[f64]| -> Vec<f64> { c.iter().zip(sigma).map(|(x, s)| x / s).collect() };
        let mut cols: Vec<Vec<f64>> = jac.iter().map(|s| w(&s.col)).collect();
        for &k in &additive {
            if let Some(s) = data.signatures.iter().find(|s| s.id == selected[k].id) {
                cols.push(w(&s.col));
            }
        }
        cols.extend(nuis.iter().map(|c| w(c)));
        let scales: Vec<f64> = cols
            .iter()
            .map(|c| norm(c).max(f64::MIN_POSITIVE))
            .collect();
        let unit: Vec<Vec<f64>> = cols
            .iter()
            .zip(&scales)
            .map(|(c, s)| c.iter().map(|x| x / s).collect())
            .collect();
        let refs: Vec<&[f64]> = unit.iter().map(Vec::as_slice).collect();
        // χ² here: the residual with the additive and nuisance terms refitted, the
        // parameters as they stand.
        let here = lsq(&z, &refs[params.len()..])
            .map_or_else(|| z.iter().map(|x| x * x).sum(), |h| h.chi2);
        if best.as_ref().is_none_or(|(c, _)| here < *c) {
            best = Some((here, selected.to_vec()));
        }
        let Some(g) = lsq(&z, &refs) else { return };
        let dof = n.saturating_sub(refs.len());
        let birge = crate::stats::birge_ratio(g.chi2, dof);
        let mut done = true;
        for (j, &k) in params.iter().enumerate() {
            let step = g.beta[j] / scales[j];
            let classical = g.cov[(j, j)].sqrt() * birge / scales[j];
            let se = if f.stated() {
                classical
            } else {
                classical.max(g.se_hc3[j] / scales[j])
            };
            theta.add(selected[k].id, step);
            selected[k].coef = theta.get(selected[k].id);
            selected[k].stderr = se;
            selected[k].plausible = within_tolerance(selected[k].id, selected[k].coef, sim);
            done &= step.abs() < GAUSS_NEWTON_TOLERANCE * se;
        }
        for (j, &k) in additive.iter().enumerate() {
            let c = params.len() + j;
            selected[k].coef = g.beta[c] / scales[c];
            selected[k].stderr = g.cov[(c, c)].sqrt() * birge / scales[c];
            selected[k].plausible = selected[k].coef.abs() <= opts.limits[selected[k].id.index()];
        }
        if done {
            return;
        }
    }
    // No convergence within the steps: the closed loop's response is rough on the scale of
    // the noise, so the iterates wander; keep the best one seen.
    if let Some((_, b)) = best {
        selected.clone_from_slice(&b);
    }
}

/// `refine_parameters` stops when every step is below this fraction of its standard
/// error: the closed loop's noise makes χ² rough on about half a standard error, so finer
/// steps only wander.
pub const GAUSS_NEWTON_TOLERANCE: f64 = 0.2;

/// `data` with each selected parameter's signature replaced by its secant: the closed
/// loop's observations with the fitted change alone, minus the baseline's, over the change
/// (the central-difference sensitivity at the file's value misjudges a change of tens of
/// per cent).
fn secant_signatures(
    rows: &[Condition],
    data: &Data,
    selected: &[Selected],
    baseline: &[Vec<f64>],
    sim: &dyn Simulator,
) -> Data {
    let mut out = data.clone();
    let slot = |q: Quantity| usize::from(q == Quantity::Phase);
    for s in selected {
        if s.id.parameter_key().is_none() || s.coef == 0.0 {
            continue;
        }
        let e = Effects::only(s.id, s.coef);
        let jobs: Vec<(&Condition, &Effects)> = rows.iter().map(|r| (r, &e)).collect();
        let obs = sim.observe_all(&jobs);
        let col: Vec<f64> = (0..data.n())
            .map(|k| {
                let (i, q) = (data.rows[k], slot(data.quantity[k]));
                let d = obs[i].get(q).copied().unwrap_or(f64::NAN)
                    - baseline[i].get(q).copied().unwrap_or(f64::NAN);
                d / s.coef
            })
            .collect();
        if col.iter().all(|x| x.is_finite())
            && let Some(sig) = out.signatures.iter_mut().find(|x| x.id == s.id)
        {
            sig.col = col;
            // A parameter found by the scan had no first-order signature; its secant is one.
            sig.null = false;
        }
    }
    out
}

/// Most Gauss–Newton steps of `refine_parameters`.
pub const GAUSS_NEWTON_STEPS: usize = 8;

/// Whether a parameter candidate's change keeps the parameter in its tolerance band.
fn within_tolerance(id: CandidateId, change: f64, sim: &dyn Simulator) -> bool {
    id.parameter_key()
        .and_then(|k| sim.instrument().and_then(|i| i.tolerance(k)))
        .is_none_or(|(lo, nom, hi)| (lo..=hi).contains(&(nom + change)))
}

/// The per-observation table: every observation of every row (measured or not; a row set
/// aside as a suspected gross error with its measurement and the model's values, marked).
#[allow(clippy::too_many_arguments)] // the model's pieces the table shows
fn row_table(
    rows: &[Condition],
    data: &Data,
    f: &Fitted,
    baseline: &[Vec<f64>],
    resim: &[Vec<f64>],
    extended: &[f64],
    opts: &Options,
    set_aside: &[SetAside],
) -> Vec<RowResult> {
    let mut out = Vec::new();
    // The observation of each (row, slot), if fitted.
    let mut fitted: Vec<[Option<usize>; 2]> = vec![[None; 2]; rows.len()];
    for k in (0..data.n()).rev() {
        fitted[data.rows[k]][usize::from(data.quantity[k] == Quantity::Phase)] = Some(k);
    }
    for (i, r) in rows.iter().enumerate() {
        for (o, &b) in baseline[i].iter().enumerate() {
            let (quantity, suffix) = match (r.kind, o) {
                (crate::model::condition::RowKind::Response, 0) => ("gain", " (gain)"),
                (crate::model::condition::RowKind::Response, _) => ("phase_deg", " (phase)"),
                _ => ("value_cm_s2", ""),
            };
            let k = fitted[i].get(o).copied().flatten();
            let aside = set_aside.iter().find(|a| a.row == i && o == 0);
            let (measured, sigma, ext) = match (k, aside) {
                (Some(k), _) => (Some(data.y[k]), f.sigma[k], extended[k]),
                (None, Some(a)) => (
                    Some(a.y),
                    a.stated
                        .or_else(|| {
                            f.group_sigma
                                .iter()
                                .find(|(g, _)| *g == a.group)
                                .map(|&(_, s)| s)
                        })
                        .unwrap_or(f64::NAN),
                    resim[i].get(o).copied().unwrap_or(f64::NAN)
                        + f.nuisance_for(a.block, a.shift, a.drifts, a.time),
                ),
                (None, None) => (
                    None,
                    r.sigma_cm_s2
                        .or(opts.default_sigma_cm_s2)
                        .unwrap_or(f64::NAN),
                    resim[i].get(o).copied().unwrap_or(f64::NAN),
                ),
            };
            debug_assert!(aside.is_none_or(|a| (a.base - b).abs() <= 1e-9 * a.base.abs().max(1.0)));
            out.push(RowResult {
                label: format!("{}{suffix}", r.label),
                freq_hz: (r.kind == crate::model::condition::RowKind::Response)
                    .then_some(r.freq_hz),
                kind: r.kind,
                quantity,
                measured_cm_s2: measured,
                sigma_cm_s2: sigma,
                baseline_cm_s2: b,
                residual_cm_s2: measured.map(|m| m - b),
                extended_cm_s2: ext,
                residual_extended_cm_s2: measured.map(|m| m - ext),
                outlier: aside.is_some(),
            });
        }
    }
    out
}

/// Confounding of every selected coefficient, and the plausibility verdict.
fn selected_report(data: &Data, f: &Fitted, opts: &Options, sim: &dyn Simulator) -> Vec<Selected> {
    let m = f.family.len();
    let cols = f.unit_columns();
    let nn = f.n_nuisance();
    let z = f.weighted_target();
    f.selected
        .iter()
        .enumerate()
        .map(|(k, &id)| {
            let (coef, stderr) = f.candidate(id).unwrap_or((0.0, 0.0));
            let others: Vec<&[f64]> = cols
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != nn + k)
                .map(|(_, c)| *c)
                .collect();
            let (ua, sa) = f.candidate_column(data, id).unwrap_or((&[], 1.0));
            let a = residualize(ua, &others);
            let mut confounded = Vec::new();
            for &o in &f.family {
                if o == id || f.selected.contains(&o) {
                    continue;
                }
                let Some((ub, sb)) = f.candidate_column(data, o) else {
                    continue;
                };
                let b = residualize(ub, &others);
                if norm(&b) < 1e-12 {
                    continue;
                }
                let cos = abs_cos(&a, &b);
                let structural = cos > opts.confound_cos;
                let statistical = cos >= 0.5 && {
                    let mut swapped = others.clone();
                    swapped.push(ub);
                    lsq(&z, &swapped).is_some_and(|g| {
                        let mut with = others.clone();
                        with.push(ua);
                        lsq(&z, &with).is_some_and(|w| {
                            #[allow(clippy::cast_precision_loss)]
                            let level = opts.alpha / m.max(1) as f64;
                            fit::step_p(&w, &with, with.len() - 1, g.chi2, f.stated(), None) > level
                        })
                    })
                };
                if structural || statistical {
                    let dot: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
                    let factor = dot / a.iter().map(|x| x * x).sum::<f64>() * sb / sa;
                    confounded.push((o, factor));
                }
            }
            Selected {
                id,
                coef,
                stderr,
                plausible: if id.parameter_key().is_some() {
                    within_tolerance(id, coef, sim)
                } else {
                    coef.abs() <= opts.limits[id.index()]
                },
                confounded,
                parameter: None,
                mirror: false,
                search_limit: None,
            }
        })
        .collect()
}

/// Fill in the parameter values of the selected parameters.
fn parameter_values(selected: &mut [Selected], sim: &dyn Simulator) {
    for s in selected {
        let Some(key) = s.id.parameter_key() else {
            continue;
        };
        let Some((lo, nom, hi)) = sim.instrument().and_then(|i| i.tolerance(key)) else {
            continue;
        };
        let fitted = nom + s.coef;
        s.parameter = Some(ParameterValue {
            key: key.to_string(),
            nominal: nom,
            fitted,
            sigma: s.stderr,
            tolerance: [lo, hi],
            within_tolerance: (lo..=hi).contains(&fitted),
            mirror: s.mirror.then_some(nom - s.coef),
        });
    }
}

/// Pairwise groups of the family with `|cos| > confound_cos` once the nuisance terms are
/// partialled out.
fn indistinguishable(data: &Data, f: &Fitted, opts: &Options) -> Vec<Vec<CandidateId>> {
    let basis: Vec<&[f64]> = f.unit_columns()[..f.n_nuisance()].to_vec();
    let partial: Vec<(CandidateId, Vec<f64>)> = f
        .family
        .iter()
        .filter_map(|&id| {
            f.candidate_column(data, id)
                .map(|(u, _)| (id, residualize(u, &basis)))
        })
        .collect();
    let mut groups: Vec<Vec<CandidateId>> = Vec::new();
    for (i, (a, ua)) in partial.iter().enumerate() {
        for (b, ub) in &partial[i + 1..] {
            if abs_cos(ua, ub) > opts.confound_cos {
                if let Some(g) = groups.iter_mut().find(|g| g.contains(a) || g.contains(b)) {
                    for x in [*a, *b] {
                        if !g.contains(&x) {
                            g.push(x);
                        }
                    }
                } else {
                    groups.push(vec![*a, *b]);
                }
            }
        }
    }
    groups
}

/// The nuisance terms' values and standard errors.
fn nuisance_report(data: &Data, f: &Fitted) -> NuisanceReport {
    let mut r = NuisanceReport::default();
    let mut se_blocks = serde_json::Map::new();
    for (j, t) in f.nuisance.iter().enumerate() {
        match *t {
            Nuisance::Block(b) => {
                let name = data.block_names[b].clone();
                r.bias_shift_cm_s2.insert(name.clone(), f.coef[j]);
                se_blocks.insert(name, f.se[j].into());
            }
            Nuisance::Drift => {
                let key = match data.time_unit {
                    TimeUnit::Seconds => {
                        r.drift_cm_s2_per_s = Some(f.coef[j]);
                        "drift_cm_s2_per_s"
                    }
                    TimeUnit::Row => {
                        r.drift_cm_s2_per_row = Some(f.coef[j]);
                        "drift_cm_s2_per_row"
                    }
                };
                r.stderr.insert(key.into(), f.se[j].into());
            }
        }
    }
    r.stderr.insert(
        "bias_shift_cm_s2".into(),
        serde_json::Value::Object(se_blocks),
    );
    r
}

fn noise_report(data: &Data, f: &Fitted) -> NoiseReport {
    let sigma_cm_s2 = f
        .group_sigma
        .iter()
        .map(|&(g, s)| (data.group_names[g].clone(), s))
        .collect();
    let (source, caveat) = match f.noise {
        NoiseSource::Stated => ("stated", None),
        NoiseSource::Replicates => (
            "replicates",
            Some("sigma estimated from the scatter of replicated rows (pure error) per variance group; groups without replicates use the model's residuals".to_string()),
        ),
        NoiseSource::Residuals => (
            "residuals",
            Some("sigma estimated from the model's residuals per variance group (no sigma_cm_s2 and no replicated rows): it holds whatever the model does not explain, so it can only be too large, and the tests use the heteroscedasticity-robust error as well".to_string()),
        ),
    };
    NoiseReport {
        source,
        sigma_cm_s2,
        caveat,
        stated_over_scatter: None,
    }
}

/// The selected terms in IEEE Std 1293 units, with the correlation of the final fit.
fn model_equation(f: &Fitted, selected: &[Selected], g_cm_s2: f64) -> ModelEquation {
    let nn = f.n_nuisance();
    let terms = selected
        .iter()
        .map(|s| {
            let c = s.id.info();
            let (symbol, unit, factor) = c.ieee;
            let k = factor(g_cm_s2);
            let (value, sigma) = s
                .parameter
                .as_ref()
                .map_or((s.coef * k, s.stderr * k), |p| (p.fitted, p.sigma));
            Term {
                name: c.name.to_string(),
                symbol: symbol.to_string(),
                value,
                unit: unit.to_string(),
                sigma,
            }
        })
        .collect();
    let m = selected.len();
    let cov = |i: usize, j: usize| f.fit.cov.get((nn + i, nn + j)).copied().unwrap_or(0.0);
    let correlation = (0..m)
        .map(|i| {
            (0..m)
                .map(|j| {
                    let d = (cov(i, i) * cov(j, j)).sqrt();
                    if d > 0.0 { cov(i, j) / d } else { f64::NAN }
                })
                .collect()
        })
        .collect();
    ModelEquation { terms, correlation }
}

/// Group selected coefficients by effect for the JSON.
fn effect_reports(selected: &[Selected], opts: &Options, sim: &dyn Simulator) -> Vec<EffectReport> {
    let mut reports: Vec<EffectReport> = Vec::new();
    for s in selected {
        let cand = s.id.info();
        let pos = reports
            .iter()
            .position(|r| r.name == cand.effect)
            .unwrap_or_else(|| {
                reports.push(EffectReport {
                    name: cand.effect.to_string(),
                    coefficients: BTreeMap::new(),
                    stderr: BTreeMap::new(),
                    confounded_with: vec![],
                    plausible: true,
                    bounds: BTreeMap::new(),
                    parameter: s.parameter.clone(),
                    search_limit: None,
                });
                reports.len() - 1
            });
        let r = &mut reports[pos];
        r.coefficients.insert(cand.key.to_string(), s.coef);
        r.stderr.insert(cand.key.to_string(), s.stderr);
        if s.parameter.is_none() {
            r.bounds
                .insert(cand.key.to_string(), opts.limits[s.id.index()]);
        }
        r.plausible &= s.plausible;
        if let Some(l) = s.search_limit {
            r.search_limit = Some(SearchLimit {
                name: cand.name.to_string(),
                value: s.parameter.as_ref().map_or(l, |p| p.nominal + l),
                note: super::alternatives::limit_note(s.id, l, sim),
            });
        }
        for &(o, _) in &s.confounded {
            let name = o.info().name.to_string();
            if !r.confounded_with.contains(&name) {
                r.confounded_with.push(name);
            }
        }
    }
    reports
}

fn names(ids: &[CandidateId]) -> Vec<String> {
    ids.iter().map(|i| i.info().name.to_string()).collect()
}

/// Run the method on `rows` with `sim` for baseline and re-simulation.
///
/// # Errors
/// No row has a measurement, `time_s` is given on some measured rows only, or the measured
/// values are a unit or sign slip's multiple of the simulated ones
/// ([`slips::unit_slip`]).
pub fn discover(
    rows: &[Condition],
    sim: &dyn Simulator,
    opts: &Options,
) -> anyhow::Result<Discovery> {
    discover_with(rows, &[], sim, opts)
}

/// A row set aside as a suspected gross error, with what the rest of the method needs of
/// it (it is no observation of the data the model is fitted to).
#[derive(Clone, Debug)]
struct SetAside {
    /// The search's finding (its `obs` indexes the data with every row).
    found: outliers::Found,
    /// The row (index into the caller's rows).
    row: usize,
    /// Its measured value and baseline, cm/s².
    y: f64,
    base: f64,
    /// Its block, whether it takes the block's shift and the drift, and its time.
    block: usize,
    shift: bool,
    drifts: bool,
    time: f64,
    /// Its stated sigma and variance group.
    stated: Option<f64>,
    group: usize,
}

/// [`discover`], with the reader's record of the input cells that were empty and read as 0
/// (`caseframe::Frame::empty`), which names the likely cause of a suspected gross error.
///
/// # Errors
/// As [`discover`].
#[allow(clippy::too_many_lines)] // the method's steps, in order
pub fn discover_with(
    rows: &[Condition],
    empty: &[EmptyCells],
    sim: &dyn Simulator,
    opts: &Options,
) -> anyhow::Result<Discovery> {
    if !rows.iter().any(Condition::is_measured) {
        anyhow::bail!(
            "no row has a measurement (`measured_cm_s2`, or `measured_gain`/`measured_phase_deg` in a response row): nothing to fit"
        );
    }
    // 1. Baseline: every row's observations (measured or not, for the table).
    crate::simulation::work::set_stage("baseline");
    let baseline: Vec<Vec<f64>> = {
        let jobs: Vec<(&Condition, &Effects)> = rows.iter().map(|r| (r, &Effects::NONE)).collect();
        sim.observe_all(&jobs)
    };
    let every = data::build(
        rows,
        &baseline,
        opts.default_sigma_cm_s2,
        &opts.candidates,
        sim,
    )?;
    // Values in another unit, or with the sign reversed: not physics.
    let unit_slip = slips::unit_slip(&every, sim.g_cm_s2());
    if let Some(slip) = unit_slip.as_ref().filter(|_| !opts.units_as_given) {
        anyhow::bail!("{}", slip.message());
    }
    let settings = Settings {
        alpha: opts.alpha,
        confound_cos: opts.confound_cos,
        select: true,
    };
    // 2. Suspected gross errors, found before the selection can explain them.
    let recorded: Vec<usize> = (0..every.n())
        .filter(|&k| {
            every.quantity[k] == Quantity::Value
                && empty
                    .iter()
                    .any(|e| e.row == every.rows[k] && !e.columns.is_empty())
        })
        .collect();
    let plausible = |id: CandidateId, coef: f64| {
        if id.parameter_key().is_some() {
            within_tolerance(id, coef, sim)
        } else {
            coef.abs() <= opts.limits[id.index()]
        }
    };
    let search = outliers::search(
        &every,
        settings,
        outliers::ALPHA,
        outliers::MAX_OUTLIERS,
        &slips::row_slips(&every, sim.g_cm_s2()),
        &recorded,
        &plausible,
    );
    let set_aside: Vec<SetAside> = search
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
    let beyond_cap = search
        .beyond_cap
        .map(|b| (rows[every.rows[b.obs]].label.clone(), b));
    let data = if opts.keep_outliers || set_aside.is_empty() {
        every
    } else {
        let drop: Vec<usize> = set_aside.iter().map(|a| a.found.obs).collect();
        every.without(&drop)
    };
    let n = data.n();
    let all: Vec<usize> = (0..n).collect();
    // 3. The model: nuisance terms, noise, selection.
    crate::simulation::work::set_stage("selection");
    let f = fit::fit(&data, &all, settings);
    let mut steps = f.steps.clone();
    let mut selected = selected_report(&data, &f, opts, sim);
    let k = selected
        .iter()
        .filter(|s| s.id.parameter_key().is_some())
        .count();
    let search = super::cost::Cost::of(rows, sim, &opts.candidates).search(k);
    if search.total() > 0.0 {
        crate::simulation::work::ahead("the closed-loop search of the loop's parameters", search)?;
        crate::simulation::work::set_stage("search of the loop's parameters");
    }
    refine_parameters(rows, &data, &f, &mut selected, sim, opts);
    let problem = super::alternatives::Problem {
        rows,
        data: &data,
        f: &f,
        sim,
        alpha: opts.alpha,
    };
    super::alternatives::prune(
        &problem,
        &mut selected,
        &|s| {
            refine_parameters(rows, &data, &f, s, sim, opts);
        },
        &mut steps,
    );
    if super::alternatives::scan(&problem, &mut selected, &mut steps) {
        refine_parameters(rows, &data, &f, &mut selected, sim, opts);
    }
    if super::alternatives::check(&problem, &mut selected, &mut steps) {
        refine_parameters(rows, &data, &f, &mut selected, sim, opts);
    }
    super::alternatives::mirror(&problem, &mut selected);
    parameter_values(&mut selected, sim);
    // A search's end counts only where the refined value still lies.
    for s in &mut selected {
        if let Some(l) = s.search_limit
            && (s.coef - l).abs() > (0.01 * l.abs()).max(s.stderr)
        {
            s.search_limit = None;
        }
    }
    let mut effects = Effects::NONE;
    for s in &selected {
        effects.add(s.id, s.coef);
    }
    // 4. Extend and re-simulate; the nuisance terms are part of the fitted model.
    crate::simulation::work::set_stage("re-simulation");
    let resim: Vec<Vec<f64>> = if effects.is_zero() {
        baseline.clone()
    } else {
        let jobs: Vec<(&Condition, &Effects)> = rows.iter().map(|r| (r, &effects)).collect();
        sim.observe_all(&jobs)
    };
    let slot = |q: Quantity| usize::from(q == Quantity::Phase);
    let extended: Vec<f64> = (0..n)
        .map(|k| {
            let v = resim[data.rows[k]]
                .get(slot(data.quantity[k]))
                .copied()
                .unwrap_or(f64::NAN);
            if data.quantity[k] == Quantity::Phase {
                v
            } else {
                v + f.nuisance_at(&data, k)
            }
        })
        .collect();
    let base_summary = summary(&data, &|k| data.base[k], &f.sigma, 0);
    let ext_summary = summary(&data, &|k| extended[k], &f.sigma, f.fit.beta.len());
    // 5. What is left, and the gain out of sample.
    crate::simulation::work::set_stage("cross-validation");
    let unexplained = unexplained::test(&data, &f, &selected, opts.alpha);
    let gain = crossval::gain(
        &secant_signatures(rows, &data, &selected, &baseline, sim),
        settings,
        if data.quantity.iter().all(|&q| q == Quantity::Value) {
            ext_summary.rms_cm_s2
        } else {
            ext_summary.rms_normalised
        },
        opts.seed,
    );
    let groups = indistinguishable(&data, &f, opts);
    let advice = advice::advise(&data, rows, &f, &selected, &groups, sim.g_cm_s2());
    let outliers_json = outlier_reports(rows, empty, &data, &f, &set_aside, opts, sim.g_cm_s2());
    let table = row_table(
        rows, &data, &f, &baseline, &resim, &extended, opts, &set_aside,
    );
    let scatter = slips::sigma_check(&data, &f, opts.default_sigma_cm_s2, sim.g_cm_s2());
    let sigma_slip = scatter.clone().filter(|s| s.far);
    let mut warnings = slip_warnings(
        &outliers_json,
        beyond_cap.as_ref().map(|(l, b)| (l.as_str(), *b)),
        sigma_slip.as_ref(),
        &selected,
        sim,
    );
    if let Some(slip) = &unit_slip {
        warnings.insert(0, slip.kept_message());
    }
    warnings.extend(self::warnings(&data, &f, &selected));
    let effects_json = effect_reports(&selected, opts, sim);
    let mut noise = noise_report(&data, &f);
    noise.stated_over_scatter = scatter.as_ref().map(|s| s.factor);
    let mut d = Discovery {
        simulator: sim.name(),
        json: JsonReport {
            rows: n,
            baseline: base_summary,
            effects: effects_json,
            extended: ext_summary,
            model_equation: model_equation(&f, &selected, sim.g_cm_s2()),
            advice,
            nuisance: nuisance_report(&data, &f),
            unexplained,
            gain,
            noise,
            family: names(&f.family),
            not_testable: names(&f.untestable),
            not_testable_nuisance: names(&f.untestable_nuisance),
            indistinguishable: groups.iter().map(|g| names(g)).collect(),
            table: table.clone(),
            verdict: String::new(),
            warnings,
            outliers: outliers_json,
            steps: steps.iter().map(step_report).collect(),
        },
        selected,
        table,
        steps,
        untestable: f.untestable.clone(),
        untestable_nuisance: f.untestable_nuisance.clone(),
        untoleranced: sim.instrument().map_or_else(Vec::new, |i| {
            f.untestable
                .iter()
                .copied()
                .filter(|id| id.parameter_key().is_some_and(|k| i.tolerance(k).is_none()))
                .collect()
        }),
        confounded_groups: groups,
        family_size: f.family.len(),
        family: f.family.clone(),
        effects,
        options: opts.clone(),
        bode: bode(rows, sim, &effects),
        sigma_slip,
    };
    d.json.verdict = verdict(&d);
    Ok(d)
}

/// The outlier search's findings in the `--json` shape, with their likely causes.
fn outlier_reports(
    rows: &[Condition],
    empty: &[EmptyCells],
    data: &Data,
    f: &Fitted,
    set_aside: &[SetAside],
    opts: &Options,
    g: f64,
) -> Vec<OutlierReport> {
    set_aside
        .iter()
        .map(|a| {
            let t = &a.found.test;
            let expected = a.y - t.error;
            let others: Vec<(&str, f64)> = (0..data.n())
                .filter(|&k| data.quantity[k] == Quantity::Value && data.rows[k] != a.row)
                .map(|k| {
                    (
                        rows[data.rows[k]].label.as_str(),
                        data.base[k] + f.predict(data, k),
                    )
                })
                .collect();
            OutlierReport {
                row: rows[a.row].label.clone(),
                residual_cm_s2: t.error,
                p_value: a.found.p_family,
                studentized: t.t,
                dof: t.dof,
                rows_tested: a.found.tested,
                measured_cm_s2: a.y,
                expected_cm_s2: expected,
                sigma_cm_s2: t.error_se,
                cause: slips::cause(
                    a.y,
                    expected,
                    t.error_se,
                    empty.iter().find(|e| e.row == a.row),
                    &others,
                    g,
                ),
                kept: opts.keep_outliers,
            }
        })
        .collect()
}

/// The warnings of the slips, first in the report: each suspected gross error, more of
/// them than the search sets aside, stated sigmas far from the scatter, a search through
/// the closed loop that ended at its grid's end.
fn slip_warnings(
    outliers: &[OutlierReport],
    beyond_cap: Option<(&str, outliers::Found)>,
    sigma: Option<&slips::SigmaSlip>,
    selected: &[Selected],
    sim: &dyn Simulator,
) -> Vec<String> {
    let mut w = Vec::new();
    for o in outliers {
        w.push(format!(
            "row `{}` is a suspected gross error: measured {} cm/s², but the model selected without it expects {} (residual {} cm/s², {} σ; p = {} over the {} rows tested, familywise); likely cause: {}; {}",
            o.row,
            crate::output::significant(o.measured_cm_s2, 6),
            super::show::estimate(o.expected_cm_s2, o.sigma_cm_s2),
            crate::output::significant(o.residual_cm_s2, 4),
            crate::output::significant(o.studentized.abs(), 3),
            super::show::pfmt(o.p_value),
            o.rows_tested,
            o.cause,
            if o.kept {
                "kept in the fit (--keep-outliers)"
            } else {
                "the selection is made without it (--keep-outliers keeps it)"
            }
        ));
    }
    if let Some((label, b)) = beyond_cap {
        w.push(format!(
            "more than {} rows look like gross errors: after setting aside {}, row `{label}` still does (p = {}): the model, not a few rows, fails these data; check the file as a whole (a unit or sign slip in part of it, a shifted column, the wrong instrument file)",
            outliers::MAX_OUTLIERS,
            outliers
                .iter()
                .map(|o| format!("`{}`", o.row))
                .collect::<Vec<_>>()
                .join(", "),
            super::show::pfmt(b.p_family)
        ));
    }
    if let Some(s) = sigma {
        w.push(s.message());
    }
    for s in selected {
        if let Some(l) = s.search_limit {
            w.push(super::alternatives::limit_note(s.id, l, sim));
        }
    }
    w
}

/// A step in the `--json` shape.
fn step_report(s: &Step) -> StepReport {
    StepReport {
        action: match (s.added, s.replaces) {
            (_, Some(_)) => "swap",
            (true, None) => "add",
            (false, None) => "drop",
        },
        name: s.id.info().name.to_string(),
        replaces: s.replaces.map(|r| r.info().name.to_string()),
        delta_chi2: s.delta_chi2,
        p_value: s.p_value,
        threshold: s.threshold,
        note: s.note.clone(),
    }
}

/// Points of the linear loop model's Bode plot, 80 per the response rows' frequency span
/// (a factor of 2 beyond it either side), log-spaced.
fn bode(rows: &[Condition], sim: &dyn Simulator, effects: &Effects) -> Vec<BodePoint> {
    let f: Vec<f64> = rows
        .iter()
        .filter(|r| r.kind == crate::model::condition::RowKind::Response && r.freq_hz > 0.0)
        .map(|r| r.freq_hz)
        .collect();
    let (Some(lo), Some(hi)) = (
        f.iter().copied().reduce(f64::min),
        f.iter().copied().reduce(f64::max),
    ) else {
        return Vec::new();
    };
    let (lo, hi) = ((lo / 2.0).ln(), (hi * 2.0).ln());
    (0..80)
        .filter_map(|k| {
            let freq_hz = (lo + (hi - lo) * f64::from(k) / 79.0).exp();
            Some(BodePoint {
                freq_hz,
                nominal: sim.linear_response(freq_hz, &Effects::NONE)?,
                corrected: sim.linear_response(freq_hz, effects)?,
            })
        })
        .collect()
}

/// What the user must know before reading the result.
fn warnings(data: &Data, f: &Fitted, selected: &[Selected]) -> Vec<String> {
    let mut w = Vec::new();
    let n = data.n();
    if n < f.n_nuisance() + 2 {
        w.push(format!(
            "too few measured rows: {n} row{} against {} nuisance term{} (bias shifts and drift): nothing beyond them can be tested",
            if n == 1 { "" } else { "s" },
            f.n_nuisance(),
            if f.n_nuisance() == 1 { "" } else { "s" }
        ));
    }
    if f.family.is_empty() && selected.is_empty() {
        w.push(format!(
            "nothing could be tested: no candidate has a signature in these rows outside the nuisance terms (not testable: {})",
            names(&[f.untestable.clone(), f.untestable_nuisance.clone()].concat()).join(", ")
        ));
    }
    if f.family.is_empty() && !selected.is_empty() {
        w.push(format!(
            "no candidate has a first-order signature in these rows (not testable to first order: {}); the loop's parameters were scanned through the closed loop over their tolerance bands, and what is selected comes from that scan",
            names(&[f.untestable.clone(), f.untestable_nuisance.clone()].concat()).join(", ")
        ));
    }
    if f.noise == NoiseSource::Residuals {
        w.push("no sigma_cm_s2 and no replicated rows: the noise is estimated from the residuals (see noise.caveat)".to_string());
    }
    for s in selected.iter().filter(|s| !s.plausible) {
        let (name, unit) = (s.id.info().name, s.id.info().unit);
        w.push(if let Some(p) = &s.parameter {
            format!(
                "{name} = {} {unit} lies outside the instrument file's tolerance ({} to {} {unit}): either this instrument is out of its specification, or another cause imitates the change",
                super::show::estimate(p.fitted, p.sigma),
                crate::output::significant(p.tolerance[0], 6),
                crate::output::significant(p.tolerance[1], 6)
            )
        } else {
            format!(
                "{name} = {} {unit} is beyond its plausibility bound: the data's structure is real, but this cause is unlikely",
                super::show::estimate(s.coef, s.stderr)
            )
        });
    }
    w
}

/// The conclusion in one paragraph: what was named (and how plausible), what stays
/// unexplained, and the cross-validated gain.
#[must_use]
pub fn verdict(d: &Discovery) -> String {
    let j = &d.json;
    let mut v = String::new();
    if !j.outliers.is_empty() {
        let one = j.outliers.len() == 1;
        let rows: Vec<String> = j.outliers.iter().map(|o| format!("`{}`", o.row)).collect();
        let causes: Vec<&str> = j
            .outliers
            .iter()
            .map(|o| o.cause.split([':', ';']).next().unwrap_or_default())
            .collect();
        let _ = write!(
            v,
            "{} {} {} a suspected gross error{} ({}); {}. ",
            if one { "Row" } else { "Rows" },
            rows.join(", "),
            if one { "is" } else { "are" },
            if one { "" } else { "s" },
            causes.join("; "),
            match (d.options.keep_outliers, one) {
                (true, _) => "kept in the fit (--keep-outliers)",
                (false, true) => "set aside: what follows is without it",
                (false, false) => "set aside: what follows is without them",
            }
        );
    }
    if let Some(sg) = &d.sigma_slip {
        let _ = write!(
            v,
            "The stated sigmas are {} times the scatter of the residuals: {} ",
            crate::output::significant(sg.factor, 2),
            if sg.factor >= 1.0 {
                "too large to see effects of the size of the scatter."
            } else {
                "too small, or the data hold structure no candidate explains."
            }
        );
    }
    if d.family.is_empty() && d.selected.is_empty() {
        v.push_str("Nothing could be tested in these rows (no candidate has a signature here).");
    } else if d.selected.is_empty() {
        let _ = write!(
            v,
            "No candidate of the {} tested ({}) is significant at familywise 5 %.",
            d.family_size,
            names(&d.family).join(", ")
        );
    } else {
        let named: Vec<String> = d
            .selected
            .iter()
            .map(|s| {
                let c = s.id.info();
                if let Some(p) = &s.parameter {
                    let mut t = p.sentence(c.name, c.unit);
                    if !s.confounded.is_empty() {
                        let o: Vec<&str> = s.confounded.iter().map(|(o, _)| o.info().name).collect();
                        let _ = write!(t, " (indistinguishable here from {})", o.join(", "));
                    }
                    return t;
                }
                let mut t = format!(
                    "{} = {} {}",
                    if c.name.contains('.') { c.name.to_string() } else { format!("{} {}", c.name, c.key) },
                    super::show::estimate(s.coef, s.stderr),
                    c.unit
                );
                if !s.plausible {
                    t.push_str(" (implausible: beyond its bound, so the cause is unlikely although the structure is real)");
                }
                if !s.confounded.is_empty() {
                    let o: Vec<&str> = s.confounded.iter().map(|(o, _)| o.info().name).collect();
                    let _ = write!(t, " (indistinguishable here from {})", o.join(", "));
                }
                t
            })
            .collect();
        let _ = write!(v, "Selected: {}.", named.join("; "));
    }
    if j.unexplained.detected {
        let _ = write!(
            v,
            " The simulation still gets something wrong that no candidate explains: {} (p = {:.2e}).",
            j.unexplained.hint, j.unexplained.p_value
        );
    }
    let g = &j.gain;
    let _ = write!(
        v,
        " Out of sample ({}): RMS {:.3} {u} with the selected terms against {:.3} for the baseline with its nuisance terms; gain {:.3} {u}, 95 % interval [{:.3}, {:.3}].",
        g.method,
        g.rms_cross_validated_cm_s2,
        g.baseline_rms_cross_validated_cm_s2,
        g.baseline_rms_cross_validated_cm_s2 - g.rms_cross_validated_cm_s2,
        g.ci95_rms_cm_s2[0],
        g.ci95_rms_cm_s2[1],
        u = g.unit
    );
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::discovery::show;
    use crate::discovery::sim::AnalyticSimulator;
    use crate::report::r890;

    fn analytic() -> AnalyticSimulator {
        AnalyticSimulator::for_instrument(&Instrument::kearfott_2401())
    }

    #[test]
    fn a_parameter_whose_mirror_fits_is_given_without_its_sign() {
        let mut p = ParameterValue {
            key: "pickoff.phase_angle_deg".into(),
            nominal: 0.0,
            fitted: 15.0,
            sigma: 0.5,
            tolerance: [-10.0, 10.0],
            within_tolerance: false,
            mirror: None,
        };
        let one = p.sentence("pickoff_phase", "deg");
        assert!(
            one.starts_with("pickoff_phase 15.00 ± 0.50 deg, nominal 0 deg"),
            "{one}"
        );
        p.mirror = Some(-15.0);
        let both = p.sentence("pickoff_phase", "deg");
        assert!(
            both.starts_with(
                "pickoff_phase 15.00 ± 0.50 deg or -15.00 ± 0.50 deg (the mirror image"
            ),
            "{both}"
        );
        assert!(both.contains("not its sign"), "{both}");
    }

    #[test]
    fn table_6_1_names_anisoinertia_confounded_with_the_pa_lever_arm() {
        let rows = r890::table_6_1_case().unwrap();
        let d = discover(&rows, &analytic(), &Options::default()).unwrap();
        eprintln!("{}", show::text_report("table 6.1", &d));
        assert_eq!(d.json.effects.len(), 1);
        let e = &d.json.effects[0];
        assert_eq!(e.name, "anisoinertia");
        assert!(e.plausible);
        assert_eq!(e.confounded_with, vec!["lever_arm.r_pa_cm".to_string()]);
        let k = e.coefficients["k_ai_cm"];
        // The 45° rows' mean 1.47 cm/s² over w_IA·w_PA = 0.5·(1 − 0.05²) is 2.947 cm; with
        // the bias shift and the drift in the model the estimate moves by a fifth of its
        // standard error (the drift in row order is not quite orthogonal to the signature).
        assert!(
            (k - 1.47 / (0.5 * (1.0 - 0.0025))).abs() < 0.25 * e.stderr["k_ai_cm"],
            "{k}"
        );
        assert!(d.json.extended.rms_cm_s2 < 0.25 * d.json.baseline.rms_cm_s2);
        assert!(d.json.extended.p_value > 0.05);
        assert!(!d.json.unexplained.detected);
    }

    #[test]
    fn tables_6_2_and_6_3_are_null() {
        for rows in [
            r890::table_6_2_case().unwrap(),
            r890::table_6_3_case().unwrap(),
        ] {
            let d = discover(&rows, &analytic(), &Options::default()).unwrap();
            eprintln!("{}", show::text_report("oa coupling", &d));
            assert!(d.json.effects.is_empty());
        }
    }

    #[test]
    fn the_report_story_holds_with_the_closed_loop() {
        let sim = crate::discovery::sim::closed_loop(1);
        let d = discover(&r890::table_6_1_case().unwrap(), &*sim, &Options::default()).unwrap();
        eprintln!("{}", show::text_report("table 6.1 (closed loop)", &d));
        assert_eq!(d.json.effects.len(), 1);
        assert_eq!(d.json.effects[0].name, "anisoinertia");
        assert!((d.json.effects[0].coefficients["k_ai_cm"] - 2.95).abs() < 0.1);
        for rows in [
            r890::table_6_2_case().unwrap(),
            r890::table_6_3_case().unwrap(),
        ] {
            let d = discover(&rows, &*sim, &Options::default()).unwrap();
            eprintln!("{}", show::text_report("oa coupling (closed loop)", &d));
            assert!(d.json.effects.is_empty());
        }
    }

    #[test]
    fn a_bias_shift_between_blocks_is_a_nuisance_not_a_discovery() {
        // Table 6.1's rows, half of them with a 0.8 cm/s² shifted reference run: the shift
        // is absorbed by the block terms, anisoinertia is still named, nothing else.
        let mut rows = r890::table_6_1_case().unwrap();
        for (k, r) in rows.iter_mut().enumerate() {
            r.block = Some(if k % 2 == 0 { "a" } else { "b" }.into());
            if k % 2 == 1 {
                r.measured_cm_s2 = r.measured_cm_s2.map(|m| m + 0.8);
            }
        }
        let d = discover(&rows, &analytic(), &Options::default()).unwrap();
        eprintln!("{}", show::text_report("blocks", &d));
        let names: Vec<&str> = d.json.effects.iter().map(|e| e.name.as_str()).collect();
        assert_eq!(names, ["anisoinertia"]);
        let b = &d.json.nuisance.bias_shift_cm_s2;
        assert!((b["b"] - b["a"] - 0.8).abs() < 0.4, "{b:?}");
    }

    #[test]
    fn an_exact_tie_goes_to_the_first_order_term() {
        // IA up and IA down: a bias and the nonlinearity k·a_IA² (g² in both positions) fit
        // a common offset exactly as well; the simpler term, the bias, is named, the other
        // said to be indistinguishable from it.
        use rand::SeedableRng as _;
        use rand_distr::Distribution as _;
        let sim = analytic();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let noise = rand_distr::Normal::new(0.0, 0.02).unwrap();
        let truth = Effects::only(CandidateId::Bias, 0.5);
        let rows: Vec<Condition> = (0..12)
            .map(|k| {
                let mut r = Condition {
                    label: format!("p{k}"),
                    kind: crate::model::condition::RowKind::Absolute,
                    g: [if k % 2 == 0 { 1.0 } else { -1.0 }, 0.0, 0.0],
                    sigma_cm_s2: Some(0.02),
                    ..Condition::default()
                };
                r.measured_cm_s2 = Some(sim.absolute_cm_s2(&r, &truth) + noise.sample(&mut rng));
                r
            })
            .collect();
        let d = discover(&rows, &sim, &Options::default()).unwrap();
        eprintln!("{}", show::text_report("tie", &d));
        let names: Vec<&str> = d.json.effects.iter().map(|e| e.name.as_str()).collect();
        assert_eq!(names, ["bias"]);
        assert!(
            d.json.effects[0]
                .confounded_with
                .iter()
                .any(|n| n == "nonlinearity"),
            "{:?}",
            d.json.effects[0].confounded_with
        );
    }

    #[test]
    fn a_24_point_tumble_gives_the_model_equation() {
        use rand::SeedableRng as _;
        use rand_distr::Distribution as _;
        let sim = analytic();
        let mut rows = crate::lab::plan::tumble(24, crate::lab::plan::Axis::Oa);
        let truth = Effects::NONE
            .with(CandidateId::Bias, 2.0)
            .with(CandidateId::ScaleFactor, 300.0)
            .with(CandidateId::MisalignmentP, 2e-4);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let noise = rand_distr::Normal::new(0.0, 0.05).unwrap();
        for r in &mut rows {
            r.measured_cm_s2 = Some(sim.absolute_cm_s2(r, &truth) + noise.sample(&mut rng));
            r.sigma_cm_s2 = Some(0.05);
        }
        let d = discover(&rows, &sim, &Options::default()).unwrap();
        eprintln!("{}", show::text_report("24-point tumble", &d));
        let got: Vec<CandidateId> = d.selected.iter().map(|s| s.id).collect();
        for id in [
            CandidateId::Bias,
            CandidateId::ScaleFactor,
            CandidateId::MisalignmentP,
        ] {
            assert!(got.contains(&id), "{got:?}");
        }
        let me = &d.json.model_equation;
        let k0 = me.terms.iter().find(|t| t.symbol == "K_0").unwrap();
        assert!(
            (k0.value - 2.0 / 980.4 * 1e6).abs() < 4.0 * k0.sigma,
            "{k0:?}"
        );
        assert_eq!(me.correlation.len(), me.terms.len());
        // In a tumble about OA, a_OA is 0: the OA misalignment is not testable.
        assert!(d.untestable.contains(&CandidateId::MisalignmentO));
    }
}
