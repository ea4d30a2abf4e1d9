//! The object `ptsa noise --json` prints, as types. Their doc comments are the reference
//! (`docs/reference/json.md`, written from them through their JSON Schema); the keys are
//! printed in the order of their names. Accelerations are input-referred, in cm/s².

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::Serialize;

use super::allan::Point;
use super::{Analysis, Compared, identify, identify_terms};

/// `ptsa noise --json`: the record's figures, one point per τ, the noise terms.
#[derive(Serialize, JsonSchema)]
pub struct NoiseJson {
    /// The record: its file's name, or `simulated (INSTRUMENT, seed N)`.
    pub record: String,
    /// The record's gates (a counter record) or samples (readings).
    pub gates: usize,
    /// The gate or sample interval τ₀, s.
    pub gate_s: f64,
    /// The record's length, `gates · gate_s`, s.
    pub span_s: f64,
    /// The record's mean acceleration, cm/s².
    pub mean_cm_s2: f64,
    /// A counter record's nominal scale factor, the counts read with it, cm/s²; null for
    /// readings.
    pub sf_cm_s2: Option<f64>,
    /// A counter record's data pulse as a velocity step, `2·SF/f_clock`, cm/s; null for
    /// readings.
    pub pulse_cm_s: Option<f64>,
    /// The unit readings were given in (`LSB`, `mA`, `cm/s²`, …); null for counts.
    pub reading_unit: Option<String>,
    /// The confidence level of `points[].ci_lo`/`ci_hi` (`--confidence`), 0 to 1.
    pub confidence: f64,
    /// The τ grid (`--taus`): `octave`, `decade`, `all`, or `listed` for a list of times.
    pub taus: String,
    /// The lag-1 autocorrelation of the gates' accelerations (near −0.5 for a counter's
    /// quantization: adjacent gates share the charge at their common boundary).
    pub lag1_autocorrelation: f64,
    /// How the intervals' equivalent degrees of freedom are computed, in words.
    pub edf_method: String,
    /// How the noise type at each τ is identified, in words.
    pub noise_id_method: String,
    /// One per τ, shortest first.
    pub points: Vec<PointJson>,
    /// The IEEE Std 952 terms fitted to the Allan variance, by name: `quantization`,
    /// `velocity_random_walk`, `bias_instability`, `acceleration_random_walk`, and
    /// `rate_ramp` for readings.
    pub terms: BTreeMap<String, TermJson>,
    /// The terms' fit: its χ².
    pub terms_fit_chi2: f64,
    /// The terms' fit: its degrees of freedom.
    pub terms_fit_dof: usize,
    /// What the run warned of, each as printed on stderr.
    pub warnings: Vec<String>,
    /// With `--compare`: the record against the simulated loop (absent without it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub comparison: Option<ComparisonJson>,
    /// With `--identify` on a counter record: the noises beyond the instrument file's loop
    /// (absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub identification: Option<IdentificationJson>,
    /// With `--readings --identify`: which IEEE Std 952 terms the record holds (absent
    /// otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub terms_identification: Option<TermsIdentificationJson>,
}

/// One τ of the Allan, modified Allan and Hadamard deviations, with their intervals.
#[derive(Serialize, JsonSchema)]
pub struct PointJson {
    /// τ = m·τ₀, s.
    pub tau_s: f64,
    /// The overlapping Allan deviation, cm/s².
    pub adev_cm_s2: f64,
    /// Its 95 % interval's lower end, cm/s².
    pub ci95_lo: f64,
    /// Its 95 % interval's upper end, cm/s².
    pub ci95_hi: f64,
    /// Its interval's lower end at `confidence`, cm/s².
    pub ci_lo: f64,
    /// Its interval's upper end at `confidence`, cm/s².
    pub ci_hi: f64,
    /// Its equivalent degrees of freedom.
    pub edf: f64,
    /// The averaging factor m (τ in gates).
    pub m: usize,
    /// The number of second differences averaged.
    pub n_pairs: usize,
    /// The modified Allan deviation, cm/s²; null where the record is too short for it.
    pub mdev_cm_s2: Option<f64>,
    /// Its 95 % interval's lower end, cm/s².
    pub mdev_ci95_lo: Option<f64>,
    /// Its 95 % interval's upper end, cm/s².
    pub mdev_ci95_hi: Option<f64>,
    /// Its interval's lower end at `confidence`, cm/s².
    pub mdev_ci_lo: Option<f64>,
    /// Its interval's upper end at `confidence`, cm/s².
    pub mdev_ci_hi: Option<f64>,
    /// Its equivalent degrees of freedom.
    pub mdev_edf: Option<f64>,
    /// The overlapping Hadamard deviation, cm/s²; null where 3m ≥ gates (the record too
    /// short for it at this τ).
    pub hdev_cm_s2: Option<f64>,
    /// Its interval's lower end at `confidence`, cm/s².
    pub hdev_ci_lo: Option<f64>,
    /// Its interval's upper end at `confidence`, cm/s².
    pub hdev_ci_hi: Option<f64>,
    /// Its equivalent degrees of freedom.
    pub hdev_edf: Option<f64>,
    /// The noise type α its interval assumed (down to −4: the lag-1 autocorrelation after
    /// up to three differences).
    pub hdev_alpha: Option<i32>,
    /// The power-law noise type α at this τ (2 white phase … −2 random walk of frequency,
    /// in the frequency-noise convention of Stable32).
    pub alpha: i32,
    /// Where α came from: `lag-1 acf` (identified at this τ), `inherited` (from a shorter
    /// τ, too few averages here) or `assumed`.
    pub alpha_source: String,
    /// The log-log slope of the Allan deviation to the next τ; null at the last.
    pub slope_to_next: Option<f64>,
}

/// One IEEE Std 952 term fitted to the Allan variance.
#[derive(Serialize, JsonSchema)]
pub struct TermJson {
    /// Its symbol (`Q`, `N`, `B`, `K`, `R`).
    pub symbol: String,
    /// Its slope in a log-log plot of the Allan deviation.
    pub adev_slope: f64,
    /// Whether the fit resolved it (a positive coefficient).
    pub resolved: bool,
    /// Its value in each unit it is usually quoted in.
    pub values: Vec<ValueSigma>,
}

/// A value in one unit, with its standard error.
#[derive(Serialize, JsonSchema)]
pub struct ValueSigma {
    /// The unit, e.g. `cm/s^2/rtHz` or `ug/rtHz`.
    pub unit: String,
    /// The value; null when not resolved.
    pub value: Option<f64>,
    /// Its standard error; null when not resolved.
    pub sigma: Option<f64>,
}

/// A value in one unit, with its 95 % interval.
#[derive(Serialize, JsonSchema)]
pub struct ValueCi {
    /// The unit.
    pub unit: String,
    /// The value; null when not estimated.
    pub value: Option<f64>,
    /// Its 95 % interval `[low, high]`; null when not estimated.
    pub ci95: Option<[f64; 2]>,
}

/// `values` for each of `units` (name and factor from the estimate's own unit) of an
/// estimate `(value, low, high)`.
#[must_use]
pub fn values_ci(units: Vec<(&'static str, f64)>, value: Option<(f64, f64, f64)>) -> Vec<ValueCi> {
    units
        .into_iter()
        .map(|(unit, k)| ValueCi {
            unit: unit.to_string(),
            value: value.map(|v| v.0 * k),
            ci95: value.map(|v| [v.1 * k, v.2 * k]),
        })
        .collect()
}

/// `--compare`: the record's Allan deviation against the simulated loop's.
#[derive(Serialize, JsonSchema)]
pub struct ComparisonJson {
    /// The acceleration along IA simulated, cm/s².
    pub input_cm_s2: f64,
    /// The simulated record's mean, cm/s².
    pub simulated_mean_cm_s2: f64,
    /// The familywise level of the test over the τ.
    pub familywise_alpha: f64,
    /// The test, in words.
    pub test: String,
    /// One per τ.
    pub points: Vec<ComparedJson>,
    /// How many τ differ.
    pub differing: usize,
}

/// One τ of `--compare`.
#[derive(Serialize, JsonSchema)]
pub struct ComparedJson {
    /// τ, s.
    pub tau_s: f64,
    /// The record's Allan deviation, cm/s².
    pub measured_adev_cm_s2: f64,
    /// Its 95 % interval, cm/s².
    pub measured_ci95: [f64; 2],
    /// The simulated loop's Allan deviation, cm/s².
    pub simulated_adev_cm_s2: f64,
    /// Its 95 % interval, cm/s².
    pub simulated_ci95: [f64; 2],
    /// The test's statistic.
    pub z: f64,
    /// Its two-sided p-value.
    pub p: f64,
    /// Whether this τ differs (Holm at `familywise_alpha`).
    pub differs: bool,
}

impl ComparisonJson {
    /// The comparison of `points` for a loop simulated at `input_cm_s2`.
    #[must_use]
    pub fn new(input_cm_s2: f64, simulated_mean_cm_s2: f64, points: &[Compared]) -> Self {
        let ci = |p: &Point| [p.ci95_lo, p.ci95_hi];
        Self {
            input_cm_s2,
            simulated_mean_cm_s2,
            familywise_alpha: super::COMPARE_ALPHA,
            test: super::COMPARE_TEST.to_string(),
            points: points
                .iter()
                .map(|c| ComparedJson {
                    tau_s: c.measured.tau_s,
                    measured_adev_cm_s2: c.measured.adev,
                    measured_ci95: ci(&c.measured),
                    simulated_adev_cm_s2: c.simulated.adev,
                    simulated_ci95: ci(&c.simulated),
                    z: c.z,
                    p: c.p,
                    differs: c.differs,
                })
                .collect(),
            differing: points.iter().filter(|c| c.differs).count(),
        }
    }
}

/// `--identify` on a counter record: the pickoff noise, white acceleration noise `N` and bias
/// random walk `K` beyond the instrument file's loop.
#[derive(Serialize, JsonSchema)]
pub struct IdentificationJson {
    /// The acceleration along IA simulated, cm/s².
    pub input_cm_s2: f64,
    /// The instrument file's pickoff noise, µV rms.
    pub file_noise_uv_rms: f64,
    /// The grid's pickoff noises, µV rms.
    pub pickoff_grid_uv_rms: Vec<f64>,
    /// The grid's white acceleration noises N, cm/s²/√Hz.
    pub white_acceleration_grid_cm_s2_rthz: Vec<f64>,
    /// The grid's bias random walks K, cm/s²·√Hz (cm/s^2.5).
    pub bias_random_walk_grid_cm_s2_rthz: Vec<f64>,
    /// Records simulated per node of the grid.
    pub seeds_per_node: u64,
    /// Records simulated in all.
    pub simulated_records: usize,
    /// The gates each simulated record ran the loop for.
    pub simulated_record_gates: u64,
    /// The τ up to which the loop was simulated, s; null unless the record is longer.
    pub loop_simulated_to_tau_s: Option<f64>,
    /// The τ compared, s.
    pub taus_s: Vec<f64>,
    /// χ² of the file's loop alone.
    pub chi2_file: f64,
    /// The familywise level of the selection.
    pub familywise_alpha: f64,
    /// The model and the test, in words.
    pub test: String,
    /// One per candidate noise.
    pub candidates: Vec<NoiseCandidateJson>,
    /// The candidates selected, by name.
    pub selected: Vec<String>,
}

/// One candidate of `identification`.
#[derive(Serialize, JsonSchema)]
pub struct NoiseCandidateJson {
    /// Its name: `pickoff_noise`, `white_acceleration` or `bias_random_walk`.
    pub candidate: String,
    /// Its test statistic (N, K: the root of the profiled χ²'s drop; pickoff: the drop).
    pub statistic: f64,
    /// Its p-value.
    pub p: f64,
    /// Whether it was selected.
    pub selected: bool,
    /// Its value and 95 % interval in each unit it is quoted in.
    pub values: Vec<ValueCi>,
    /// Whether its interval reaches the grid's top (its upper end is then a bound).
    pub open_above: bool,
    /// When selected: the factor its interval's threshold was of the profile's own
    /// `3.84·b²`, `t²·s/3.84` (t Student's 95 % point, s the sandwich variance over the
    /// variance the profile assumes; 1 where s was not computed).
    pub interval_scale: f64,
}

impl IdentificationJson {
    /// The object for `id`.
    #[must_use]
    pub fn new(id: &identify::Identification) -> Self {
        Self {
            input_cm_s2: id.input_cm_s2,
            file_noise_uv_rms: id.file_uv,
            pickoff_grid_uv_rms: id.grid_uv.clone(),
            white_acceleration_grid_cm_s2_rthz: id.grid_white.clone(),
            bias_random_walk_grid_cm_s2_rthz: id.grid_walk.clone(),
            seeds_per_node: identify::SEEDS,
            simulated_records: id.simulated_records,
            simulated_record_gates: id.simulated_gates,
            loop_simulated_to_tau_s: id.loop_split_tau_s,
            taus_s: id.taus.clone(),
            chi2_file: id.chi2_file,
            familywise_alpha: identify::ALPHA,
            test: identify::TEST.to_string(),
            candidates: id
                .candidates
                .iter()
                .map(|c| NoiseCandidateJson {
                    candidate: c.kind.key().to_string(),
                    statistic: c.statistic,
                    p: c.p,
                    selected: c.selected,
                    values: values_ci(c.kind.units(), c.value),
                    open_above: c.open_above,
                    interval_scale: c.interval_scale,
                })
                .collect(),
            selected: id
                .candidates
                .iter()
                .filter(|c| c.selected)
                .map(|c| c.kind.key().to_string())
                .collect(),
        }
    }
}

/// `--readings --identify`: which IEEE Std 952 terms the record holds.
#[derive(Serialize, JsonSchema)]
pub struct TermsIdentificationJson {
    /// The τ fitted, s.
    pub taus_s: Vec<f64>,
    /// The joint fit's χ².
    pub chi2: f64,
    /// Its degrees of freedom.
    pub dof: usize,
    /// Records drawn in all, to weigh the fit.
    pub replicas: usize,
    /// Rounds of drawing.
    pub rounds: usize,
    /// The familywise level of the selection.
    pub familywise_alpha: f64,
    /// The test, in words.
    pub test: String,
    /// One per term.
    pub candidates: Vec<TermCandidateJson>,
    /// The terms selected, by name.
    pub selected: Vec<String>,
}

/// One term of `terms_identification`.
#[derive(Serialize, JsonSchema)]
pub struct TermCandidateJson {
    /// Its name (as in `terms`).
    pub term: String,
    /// Its symbol.
    pub symbol: String,
    /// Its test statistic; null where it was not tested.
    pub z: Option<f64>,
    /// Its p-value; null where it was not tested.
    pub p: Option<f64>,
    /// Whether it was selected.
    pub selected: bool,
    /// Its value and 95 % interval in each unit it is quoted in.
    pub values: Vec<ValueCi>,
}

impl TermsIdentificationJson {
    /// The object for `id`.
    #[must_use]
    pub fn new(id: &identify_terms::Identification) -> Self {
        Self {
            taus_s: id.taus.clone(),
            chi2: id.chi2,
            dof: id.dof,
            replicas: id.replicas,
            rounds: id.rounds,
            familywise_alpha: identify_terms::ALPHA,
            test: identify_terms::TEST.to_string(),
            candidates: id
                .candidates
                .iter()
                .map(|c| TermCandidateJson {
                    term: c.term.key().to_string(),
                    symbol: c.term.symbol().to_string(),
                    z: c.z,
                    p: c.p,
                    selected: c.selected,
                    values: values_ci(c.term.units(), c.value),
                })
                .collect(),
            selected: id
                .candidates
                .iter()
                .filter(|c| c.selected)
                .map(|c| c.term.key().to_string())
                .collect(),
        }
    }
}

impl Analysis {
    /// The object `ptsa noise --json` prints, without the parts of `--compare` and
    /// `--identify`.
    #[must_use]
    pub fn json(&self, record: &str, warnings: &[String]) -> NoiseJson {
        let pair = |c: Option<(f64, f64)>| (c.map(|c| c.0), c.map(|c| c.1));
        let points = self
            .points
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let (mdev_ci95_lo, mdev_ci95_hi) = pair(p.mdev_ci95);
                let (mdev_ci_lo, mdev_ci_hi) = pair(p.mdev_ci);
                let (hdev_ci_lo, hdev_ci_hi) = pair(p.hdev_ci);
                PointJson {
                    tau_s: p.tau_s,
                    adev_cm_s2: p.adev,
                    ci95_lo: p.ci95_lo,
                    ci95_hi: p.ci95_hi,
                    ci_lo: p.ci.0,
                    ci_hi: p.ci.1,
                    edf: p.edf,
                    m: p.m,
                    n_pairs: p.n_pairs,
                    mdev_cm_s2: p.mdev,
                    mdev_ci95_lo,
                    mdev_ci95_hi,
                    mdev_ci_lo,
                    mdev_ci_hi,
                    mdev_edf: p.mdev_edf,
                    hdev_cm_s2: p.hdev,
                    hdev_ci_lo,
                    hdev_ci_hi,
                    hdev_edf: p.hdev_edf,
                    hdev_alpha: p.hdev.map(|_| p.alpha_h),
                    alpha: p.alpha,
                    alpha_source: p.alpha_source.name().to_string(),
                    slope_to_next: self.slope(k),
                }
            })
            .collect();
        let terms = self
            .terms
            .iter()
            .map(|f| {
                let values = f
                    .term
                    .units()
                    .into_iter()
                    .map(|(unit, factor)| ValueSigma {
                        unit: unit.to_string(),
                        value: f.value.map(|v| v.0 * factor),
                        sigma: f.value.map(|v| v.1 * factor),
                    })
                    .collect();
                let term = TermJson {
                    symbol: f.term.symbol().to_string(),
                    adev_slope: f.term.slope(),
                    resolved: f.value.is_some(),
                    values,
                };
                (f.term.key().to_string(), term)
            })
            .collect();
        #[allow(clippy::cast_precision_loss)] // a record's gates are far below 2^52
        let span_s = self.tau0_s * self.gates as f64;
        NoiseJson {
            record: record.to_string(),
            gates: self.gates,
            gate_s: self.tau0_s,
            span_s,
            mean_cm_s2: self.mean_cm_s2,
            sf_cm_s2: self.sf_cm_s2,
            pulse_cm_s: self.pulse_cm_s,
            reading_unit: self.reading_unit.map(str::to_string),
            confidence: self.settings.confidence,
            taus: super::taus_name(&self.settings.taus).to_string(),
            lag1_autocorrelation: self.lag1,
            edf_method: super::EDF_METHOD.to_string(),
            noise_id_method: super::NOISE_ID_METHOD.to_string(),
            points,
            terms,
            terms_fit_chi2: self.fit_chi2,
            terms_fit_dof: self.fit_dof,
            warnings: warnings.to_vec(),
            comparison: None,
            identification: None,
            terms_identification: None,
        }
    }
}
