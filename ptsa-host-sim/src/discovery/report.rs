//! The `--json` object of `ptsa discover` and every part of it: each key, its unit and its
//! meaning (the contract: keys are added, never renamed or removed). Types only, and no
//! stage of the method: the stages fill them, [`super::assemble`] puts the object together,
//! [`super::verdict`] writes its sentences.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::model::condition::Condition;
use crate::model::effects::CandidateId;

/// RMS and χ² of a set of residuals.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
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
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
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
    /// Every coefficient the same, within its errors, on disjoint parts of the data (first
    /// and second half in time, rows approached from below and from above, blocks;
    /// familywise over the terms and splits tested): `true` tested and consistent;
    /// `false` a coefficient disagrees between parts, so its value depends on when or how
    /// it was measured and it is not given as the cause; `null` no split could test it
    /// (`stability.not_tested` says why).
    pub stable: Option<bool>,
    /// The tests behind `stable`.
    pub stability: StabilityReport,
    /// Forms outside the vocabulary that these data cannot tell a coefficient of this
    /// effect from (empty: none): in its place the fit is not significantly worse and the
    /// two share the part of the data that decides. Not tested as causes of their own;
    /// the effect is named with them.
    pub rivals: Vec<Rival>,
    /// For `warm_up`: its time constant estimated over τ (the profile of the model's χ²,
    /// the other terms refitted at each τ) and the amplitude there (absent for other
    /// effects). The coefficient above is at the grid's τ the selection took.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time_constant: Option<TimeConstantReport>,
    /// For a bias fitted with the warm-up as the level its transient settles to, not
    /// selected on its own test: `"warm_up"` (absent otherwise). No cause of its own.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub companion_of: Option<String>,
}

/// The warm-up's time constant, in the `--json` shape.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct TimeConstantReport {
    /// The estimate of τ, s.
    pub tau_s: f64,
    /// Its 95 % profile-likelihood interval, s; `null` on a side the data do not bound
    /// (the interval reaches τ = 1/64 or 2 times the run's span).
    pub interval_95_s: [Option<f64>; 2],
    /// The amplitude `A` of `A·e^(−t/τ)` at the estimate, cm/s².
    pub amplitude_cm_s2: f64,
    /// Its standard error with τ's uncertainty in it, cm/s².
    pub amplitude_se_cm_s2: f64,
    /// The grid's coefficient the model holds (`a_span4_cm_s2`, ...).
    pub grid_key: String,
}

/// A form outside the vocabulary that could stand in a selected term's place, in the
/// `--json` shape (`discovery/rivals.rs`).
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct Rival {
    /// The form, as `unexplained.proposals` and `--term` write it (`a_PA^3`,
    /// `exp(-t/360 s)`, `sign_delta_a_IA`).
    pub form: String,
    /// The library family it comes from (`products`, `time_shapes`, `history`,
    /// `tumble_harmonics`).
    pub family: &'static str,
    /// `|cos|` of its column with the term's, both off the rest of the model.
    pub cos: f64,
    /// The p-value of the swap's χ² increase (one degree of freedom per term the form
    /// replaces, on the model's noise scale): above the level, the swap is not
    /// significantly worse.
    pub p_value: f64,
    /// The other selected term (its key) the form replaces together with this one, when
    /// it stands in the place of the two at once (`null`: in this term's place alone).
    pub together_with: Option<String>,
}

/// The refits of an effect's coefficients on disjoint parts of the data, in the `--json`
/// shape.
#[derive(Clone, Debug, Default, Serialize, schemars::JsonSchema)]
pub struct StabilityReport {
    /// One test per coefficient and split that could be made.
    pub tests: Vec<SplitTest>,
    /// The splits that could not test a coefficient, and why, in words.
    pub not_tested: Vec<String>,
}

/// One coefficient refitted on the parts of one split, in the `--json` shape.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct SplitTest {
    /// The candidate (component name for `lever_arm`).
    pub name: String,
    /// `time` (first and second half in time), `approach` (approached from below and from
    /// above) or `block`.
    pub split: &'static str,
    /// The coefficient on each part.
    pub parts: Vec<PartValue>,
    /// The drop of χ² (with the sigmas as used by the whole fit) from the model with one
    /// coefficient for every part to the model with one per part, the other terms split
    /// alike and the nuisance terms common. It is `Σ (c_p − c̄)²/se_p²` only when the
    /// parts' coefficients are uncorrelated: a nuisance term common to the parts (the drift
    /// in row order) correlates them, and then the parts' standard errors alone do not give
    /// it; `difference` does.
    pub chi2: f64,
    /// Its degrees of freedom (parts − 1).
    pub dof: usize,
    /// Its p-value (with stated sigmas the larger of the χ² and the F test against the
    /// parts' residual scale, as a selection step; with estimated sigmas the F test).
    pub p_value: f64,
    /// Two parts: the second part's coefficient minus the first's and its standard error
    /// from the parts' whole covariance, on the noise scale the p-value used (the sigmas
    /// as stated; with estimated sigmas, the split model's residual scale), so that
    /// `(difference/se)²` is the test's statistic (`chi2`, or with estimated sigmas the F
    /// statistic). `None` for more than two parts.
    pub difference: Option<[f64; 2]>,
    /// The test's statistic on the noise scale the p-value used (`chi2` with stated
    /// sigmas; with estimated sigmas `chi2` over the split model's residual variance, the
    /// F statistic times the dof): the figure that `p_value` is the tail of.
    pub statistic: f64,
    /// Holm's level it was held against (familywise over every test of every effect).
    pub threshold: f64,
    /// `false`: the parts disagree at that level.
    pub agrees: bool,
}

/// A coefficient on one part of the data, in the `--json` shape.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct PartValue {
    /// `first half in time`, `second half in time`, `approached from below`, `approached
    /// from above`, or `` block `name` ``.
    pub part: String,
    /// Observations in the part.
    pub rows: usize,
    /// The coefficient fitted on it, in the candidate's unit.
    pub coefficient: f64,
    /// Its standard error (with the sigmas as used by the whole fit).
    pub stderr: f64,
}

/// Where a search through the closed loop stopped, in the `--json` shape.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
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
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
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
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
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
#[derive(Clone, Debug, Default, Serialize, schemars::JsonSchema)]
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
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
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
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
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
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
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

/// The selection's terms as an IEEE Std 1293 model equation, in the `--json` shape: each
/// selected term's change from the instrument file as the selection's fit gives it, in the
/// reading's convention (the reading's own coefficient, not divided by the scale factor).
/// Not the calibration: the instrument's values are `calibration`'s.
#[derive(Clone, Debug, Default, Serialize, schemars::JsonSchema)]
pub struct ModelEquation {
    /// The selected terms in the standard's units.
    pub terms: Vec<Term>,
    /// Correlation matrix of the terms, in their order.
    pub correlation: Vec<Vec<f64>>,
}

/// One term of the instrument's own model equation (`calibration.terms`), in the `--json`
/// shape: its absolute value, not its change from the instrument file (the `model_equation`
/// object gives the changes).
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct CalibrationTerm {
    /// IEEE Std 1293 symbol: `K_0`, `K_1`, `K_2`, `K_3`, `δ_o`, `δ_p`, `K_ip`, `K_io`,
    /// `K_po`, `K_pp`, `K_oo`. `δ_p` is the misalignment itself, entering the equation as
    /// `− δ_p·a_o` (never the negated value).
    pub symbol: String,
    /// The candidate whose coefficient measures it (`bias`, `scale_factor`,
    /// `misalignment.delta_p_rad`, ...).
    pub candidate: String,
    /// The instrument's value, in `unit`: the instrument file's nominal value plus the
    /// change the data measure (or the nominal value when `measured` is false).
    pub value: f64,
    /// Its 1 σ, in `unit` (`null` when not measured).
    pub sigma: Option<f64>,
    /// The expanded uncertainty with coverage factor k = 2, `2·sigma`, in `unit` (`null`
    /// when not measured). About 95 % when the noise is stated or estimated with many
    /// degrees of freedom (`calibration.dof`).
    pub expanded_k2: Option<f64>,
    /// The standard's unit: µg, (pulse/s)/g, µg/g², µg/g³, µrad.
    pub unit: String,
    /// The instrument file's nominal value, in `unit`.
    pub nominal: f64,
    /// `value − nominal` in `change_unit` (`unit`, except `K_1`: ppm of its nominal).
    pub change: f64,
    /// Its 1 σ, in `change_unit`.
    pub change_sigma: Option<f64>,
    /// `unit`, or `ppm` for `K_1`.
    pub change_unit: String,
    /// The value in cgs (`K_0` in cm/s², `δ_o`, `δ_p` in rad, `K_2` in s²/cm, ...; `K_1` as
    /// the full scale in cm/s², the instrument file's `scale_factor_cm_s2` form).
    pub value_cgs: f64,
    /// Its 1 σ in `unit_cgs`.
    pub sigma_cgs: Option<f64>,
    /// The cgs unit.
    pub unit_cgs: String,
    /// `true`: the value comes from these data (its term was fitted); `false`: listed at
    /// its nominal value, not measured.
    pub measured: bool,
    /// `selected` (named by the selection and fitted), `fitted` (a core term, `K_0`, `K_1`,
    /// `δ_o`, `δ_p` or `K_2`, that the data test but the selection did not name: fitted
    /// beside the others, its change not significant), `not_significant` (another term
    /// tested and not named: nominal; `if_fitted` gives what the data say of it),
    /// `not_separable` (its column lies in the span of the fitted terms here,
    /// `confounded_with` names them: nominal), `not_measured` (the data do not test it, or
    /// it was not a candidate: nominal).
    pub status: &'static str,
    /// Marks on a measured value: `unstable` (differs between parts of the data),
    /// `rivaled` (a form outside the vocabulary could stand in its place), `implausible`
    /// (beyond the instrument file's plausibility bound), `confounded` (indistinguishable
    /// from `confounded_with` here). Empty: none.
    pub marks: Vec<&'static str>,
    /// The candidates it cannot be told from in these data (for a selected term, discovery's
    /// partners; for a `not_separable` one, the fitted terms whose columns make up its).
    pub confounded_with: Vec<String>,
    /// For a `not_significant` term: `[value, sigma]` in `unit` when it is fitted beside
    /// the others (`null` otherwise).
    pub if_fitted: Option<[f64; 2]>,
}

/// The instrument's own model equation with its uncertainties (`calibration`), in the
/// `--json` shape.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct Calibration {
    /// The model equation (IEEE Std 1293, pendulous accelerometer), symbols only.
    pub equation: String,
    /// How the scale factor `K_1` is expressed, in words.
    pub scale_factor: String,
    /// Every term of the model equation, in the equation's order.
    pub terms: Vec<CalibrationTerm>,
    /// Correlation matrix of the terms, in their order (`null` where either term is not
    /// measured).
    pub correlation: Vec<Vec<Option<f64>>>,
    /// Residual degrees of freedom of the calibration's fit.
    pub dof: usize,
    /// Where the noise came from (`stated`, `replicates`, `residuals`; as `noise.source`).
    pub noise: &'static str,
    /// What to keep in mind (terms of the fit outside the model equation, a noise estimated
    /// with few degrees of freedom).
    pub notes: Vec<String>,
    /// The calibration's design: each absolute static row's gravity along IA, PA, OA (g),
    /// in the file's order. `ptsa correct` needs it to tell, at a record's row, how much of
    /// a term the calibration did not apply its partners took up (docs/method/discovery.md,
    /// `ptsa correct`).
    pub design_g: Vec<[f64; 3]>,
    /// The local gravity every value in g (µg, µg/g², ...) is taken in, cm/s²: what
    /// `g_ia` = 1 means.
    pub local_gravity_cm_s2: f64,
    /// Where [`Calibration::local_gravity_cm_s2`] came from, in words (the instrument file's
    /// key, `--local-gravity`, or standard gravity of a shipped class).
    pub gravity_source: String,
    /// `K_0` output-referred: the reading's offset at zero input (the instrument file's
    /// `bias_cm_s2`, a data sheet's "zero-g offset"), `K_0·K_1/K_1,nominal` where
    /// `K_1,nominal` is the file's nominal scale factor before `k1_ppm`. `K_0` of `terms`
    /// is input-referred (the input that reads as zero).
    pub reading_offset: ReadingOffset,
    /// The calibration's fit as changes from the instrument file, in the reading's
    /// convention: what `--write-instrument` adds to the file's values and what `ptsa
    /// correct` applies. Every term of `terms` that is measured is derived from these.
    pub changes: CalibrationChanges,
    /// Selected terms the calibration leaves out (rivaled or implausible, outside the core
    /// terms `K_0`, `K_1`, `δ_o`, `δ_p`, `K_2`), each with what it would change if it were
    /// real (docs/method/discovery.md, "A doubtful term").
    pub doubtful: Vec<DoubtfulTerm>,
}

/// `K_0` as the reading's offset (`calibration.reading_offset`).
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct ReadingOffset {
    /// The offset, µg of the local gravity (output-referred).
    pub value: f64,
    /// Its 1 σ, µg (`null` when `K_0` is not measured).
    pub sigma: Option<f64>,
    /// The same in cm/s² of reading.
    pub value_cgs: f64,
    /// Its 1 σ, cm/s².
    pub sigma_cgs: Option<f64>,
    /// Whether it differs from the input-referred `K_0` by more than `K_0`'s 1 σ (then
    /// the two must not be confused: the text and the sheet give both).
    pub differs: bool,
}

/// The calibration's fitted changes (`calibration.changes`).
#[derive(Clone, Debug, Default, Serialize, schemars::JsonSchema)]
pub struct CalibrationChanges {
    /// The candidates fitted (the model equation's terms and any fitted beside them), in
    /// the fit's order.
    pub candidates: Vec<String>,
    /// Each one's change from the instrument file's nominal value, in `units`: the change
    /// of the reading's own coefficient (a scale factor in ppm of the nominal, a bias in
    /// cm/s² of reading).
    pub values: Vec<f64>,
    /// Each one's 1 σ, in `units`.
    pub sigmas: Vec<f64>,
    /// Each one's unit (the candidate's).
    pub units: Vec<String>,
    /// Their covariance, in `units`.
    pub covariance: Vec<Vec<f64>>,
    /// The warm-up's time constant, s, when `warm_up.a_cm_s2` is among the candidates.
    pub warm_up_tau_s: Option<f64>,
}

/// A selected term the calibration leaves out (`calibration.doubtful`).
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct DoubtfulTerm {
    /// The candidate (`cross_axis_oo`, `hysteresis`, ...).
    pub candidate: String,
    /// Its IEEE Std 1293 symbol, `null` for a term outside the model equation.
    pub symbol: Option<String>,
    /// Why it is left out: `rivaled` (a form outside the vocabulary fits in its place
    /// not significantly worse), `implausible` (beyond the instrument file's bound).
    pub why: Vec<&'static str>,
    /// `[value, sigma]` in `unit` if it were real, fitted beside the calibration's terms
    /// (absolute for a model-equation term); `null` when it cannot be fitted beside them.
    pub if_real: Option<[f64; 2]>,
    /// The unit of `if_real` (the standard's for a model-equation term, else the
    /// candidate's).
    pub unit: String,
    /// The calibration's core terms as they would be with it in the fit.
    pub core_with_it: Vec<CoreValue>,
    /// The fitted terms its column cannot be told from, when `if_real` is `null`.
    pub not_separable_from: Vec<String>,
}

/// A core term's value in another fit (`calibration.doubtful[].core_with_it`).
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct CoreValue {
    /// `K_0`, `K_1`, `δ_o`, `δ_p` or `K_2`.
    pub symbol: String,
    /// The value, in `unit`.
    pub value: f64,
    /// Its 1 σ.
    pub sigma: f64,
    /// As the term's in `calibration.terms`.
    pub unit: String,
}

/// The `--json` object.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
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
    /// The instrument's own model equation: every term's absolute value (the file's nominal
    /// value plus the measured change), its 1 σ and k = 2 uncertainty, the correlation
    /// (`null` when the simulator has no instrument file).
    pub calibration: Option<Calibration>,
    /// Rows that would break each confounding (or test an untestable model-equation term).
    pub advice: Vec<Advice>,
    /// The nuisance terms (always in the model, never discoveries).
    pub nuisance: NuisanceReport,
    /// Structure that no candidate explains.
    pub unexplained: Unexplained,
    /// Whether the final model fits these data at all, whatever the library search finds.
    pub fit_check: FitCheck,
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
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
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

/// One piece of advice, in the `--json` shape.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct Advice {
    /// The candidates to separate (or to make testable).
    pub separates: Vec<String>,
    /// The rows to add, as objects with case-frame column keys.
    pub add_rows: Vec<serde_json::Map<String, serde_json::Value>>,
    /// What adding them achieves, or why no row helps.
    pub note: String,
    /// The rows to add, as conditions.
    #[serde(skip)]
    pub rows: Vec<Condition>,
}

/// What the tests found, in the `--json` shape.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct Unexplained {
    /// Structure found at the level `alpha` (familywise over the tests).
    pub detected: bool,
    /// Its p-value (weighted Bonferroni over the tests run: the lack of fit and the generic
    /// basis weigh 1, the history, time shapes, products and a tumble's harmonics ½ each,
    /// the products with the row before ¼).
    pub p_value: f64,
    /// `residual follows <input or product>`, or the lack of fit, or `none`.
    pub hint: String,
    /// The tests run, each with its own p-value.
    pub tests: Vec<UnexplainedTest>,
    /// When structure is detected: the strongest forms of the library that the residual
    /// follows, each significant under the same familywise control (strongest first, at
    /// most [`MAX_PROPOSALS`]); never a named cause. Empty when nothing is detected.
    pub proposals: Vec<Proposal>,
    /// The user's terms (`--term`), each tested after the selection like a selection step
    /// against the model (nuisance terms and plausible selected terms), Bonferroni over
    /// the terms; empty without `--term`. They are not part of `detected` or `p_value`.
    pub terms: Vec<TermReport>,
}

/// A user's term (`--term`), in the `--json` shape.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct TermReport {
    /// `term:` and the text as given (`term:a_pa^3`).
    pub key: String,
    /// The coefficient's unit, derived from the inputs' (cm/s² over the term's unit).
    pub unit: String,
    /// The term has a column here outside the model's span (`false`: 0 in every fitted
    /// row, or a combination of the model's terms; then the next three are `null`).
    pub testable: bool,
    /// Its coefficient added to the model, in `unit`.
    pub coefficient: Option<f64>,
    /// Its standard error, in `unit`.
    pub se: Option<f64>,
    /// Its p-value as a selection step, times the number of terms (at most 1).
    pub p_value: Option<f64>,
    /// `p_value` ≤ the level `alpha`.
    pub significant: bool,
}

/// The most proposals reported.
pub const MAX_PROPOSALS: usize = 5;

/// A form the residual follows, in the `--json` shape: a proposal, not a cause.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct Proposal {
    /// The form (`a_PA^3`, `a_IA*w_PA`, `delta_a_IA`, `sign_delta_a_IA`, `t^2`,
    /// `exp(-t/90 s)`); a product's form is valid `--term` text.
    pub form: String,
    /// Its coefficient added to the model (nuisance terms and plausible selected terms),
    /// in `unit`.
    pub coefficient: f64,
    /// The coefficient's unit, derived from the inputs' (cm/s² over the form's unit).
    pub unit: String,
    /// The coefficient's standard error, in `unit`.
    pub se: f64,
    /// Its familywise p-value: the element's p-value times its family's size, over the
    /// family's share of the level (≤ the level `alpha` for every proposal).
    pub p_value: f64,
    /// Its family: `generic_basis`, `history`, `time_shapes`, `products`,
    /// `history_products` or `tumble_harmonics`.
    pub family: &'static str,
    /// Other forms of the library these data cannot tell from it (partial columns parallel
    /// to |cos| > 0.999); the form given is the simplest.
    pub indistinguishable_from: Vec<String>,
}

/// Whether the final model fits the data (`fit_check`): the extended model's χ² with the
/// stated sigmas, or, with the noise estimated, the replicated rows' lack of fit.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct FitCheck {
    /// `true`: it fits (p ≥ 0.05); `false`: it does not; `null`: these data cannot tell
    /// (the noise estimated from the residuals, no replicated rows).
    pub fits: Option<bool>,
    /// `chi2_stated` (the extended model's χ² with the stated sigmas), `lack_of_fit` (the
    /// replicated rows' means against their pure error) or `none`.
    pub test: &'static str,
    /// Its p-value (`null` with `none`).
    pub p_value: Option<f64>,
    /// The statistic in words (`χ² 82.02 for 23 dof`), empty with `none`.
    pub statistic: String,
}

/// One test.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct UnexplainedTest {
    /// `lack_of_fit`, `generic_basis`, `history`, `time_shapes`, `products`,
    /// `history_products` or `tumble_harmonics`.
    pub name: &'static str,
    /// Its p-value (for a family of the library: Bonferroni over its elements).
    pub p_value: f64,
    /// What it looked at.
    pub detail: String,
}

/// The gain, in the `--json` shape.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct Gain {
    /// RMS of `measured − extended` on the rows that were fitted, in `unit`.
    pub rms_in_sample_cm_s2: f64,
    /// RMS of the held-out rows' `measured − prediction` with the selection repeated in every
    /// fold, in `unit`.
    pub rms_cross_validated_cm_s2: f64,
    /// The same for the baseline model (nuisance terms only), in `unit`.
    pub baseline_rms_cross_validated_cm_s2: f64,
    /// Bootstrap 95 % interval of the cross-validated RMS gain (baseline minus selected),
    /// cm/s².
    pub ci95_rms_cm_s2: [f64; 2],
    /// `leave-one-out` or `10-fold`.
    pub method: String,
    /// Unit of the four RMS figures: `cm/s²`, or `σ` when the data hold response rows (each
    /// error is then divided by its observation's 1 σ, so that a gain, a phase in degrees
    /// and an acceleration can share one RMS).
    pub unit: String,
}

/// The names of candidates, as the JSON gives them.
#[must_use]
pub fn names(ids: &[CandidateId]) -> Vec<String> {
    ids.iter().map(|i| i.info().name.to_string()).collect()
}
