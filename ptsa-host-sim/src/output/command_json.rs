//! The objects `predict`, `response`, `record` and `correct` print with `--json`, as types
//! whose doc comments are the reference (`docs/reference/json.md`). Each is printed through
//! a `serde_json::Value`, so its keys come in the order of their names, as `discover`'s and
//! `noise`'s do. `static --json` prints [`crate::simulation::sim::StaticRun`].

use schemars::JsonSchema;
use serde::Serialize;

use crate::discovery::correct::Corrected;

/// `ptsa predict --json`.
#[derive(Serialize, JsonSchema)]
pub struct PredictJson {
    /// One per row of the data, in its order.
    pub rows: Vec<PredictedRow>,
    /// The simulator: `closed-loop`, `analytic`, or `loop-less analytic` for an instrument
    /// file without a PTSA loop.
    pub simulator: String,
}

/// One row of `predict --json`.
#[derive(Serialize, JsonSchema)]
pub struct PredictedRow {
    /// The row's label.
    pub label: String,
    /// The reading predicted, cm/s² (a difference row's: condition − reference); null for a
    /// response row.
    pub predicted_cm_s2: Option<f64>,
    /// A response row's closed-loop gain predicted (indicated / input); absent on other rows.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub predicted_gain: Option<Option<f64>>,
    /// A response row's phase predicted, degrees; absent on other rows.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub predicted_phase_deg: Option<Option<f64>>,
}

/// `ptsa response --json`: the case-frame row made from a counter record, with the fit and
/// its checks.
#[derive(Serialize, JsonSchema)]
pub struct ResponseJson {
    /// The row's label.
    pub label: String,
    /// Its kind: `response`.
    pub kind: String,
    /// The sine's frequency, Hz.
    pub freq_hz: f64,
    /// The sine's amplitude along IA, cm/s².
    pub lin_ia_cm_s2: f64,
    /// The closed-loop gain measured (indicated / input amplitude).
    pub measured_gain: Option<f64>,
    /// The phase measured (indicated against input), degrees.
    pub measured_phase_deg: Option<f64>,
    /// The gain's 1-sigma uncertainty.
    pub sigma_gain: Option<f64>,
    /// The phase's 1-sigma uncertainty, degrees.
    pub sigma_phase_deg: Option<f64>,
    /// The gates fitted.
    pub gates: usize,
    /// The gate length, s.
    pub gate_s: f64,
    /// The record's mean acceleration, cm/s².
    pub mean_cm_s2: f64,
    /// The residuals' RMS after the sine's fit, cm/s².
    pub rms_cm_s2: f64,
    /// The RMS a right fit leaves (the charge held at the gates' boundaries and the limit
    /// cycle's ripple), cm/s².
    pub expected_rms_cm_s2: f64,
    /// The instrument file's loop's gain at `freq_hz`, `L/(1 + L)`; null without a loop.
    pub predicted_gain: Option<f64>,
    /// The instrument file's loop's phase at `freq_hz`, degrees; null without a loop.
    pub predicted_phase_deg: Option<f64>,
    /// What the run warned of, each as printed on stderr.
    pub warnings: Vec<String>,
}

/// `ptsa record --json`: the firmware's log turned into a counter record.
#[derive(Serialize, JsonSchema)]
pub struct RecordJson {
    /// The log's name (`stdin` for -).
    pub from: String,
    /// The record written (`--output`); null when none.
    pub out: Option<String>,
    /// The axis taken from a triad's log (`--axis`); null for a single-axis log.
    pub axis: Option<u64>,
    /// The log's lines.
    pub lines: usize,
    /// The log's lines that are not gate reports (skipped).
    pub skipped_lines: usize,
    /// The record's rows (the log's gate reports).
    pub reports: usize,
    /// The gates the reports hold, merged ones counted each.
    pub gates: usize,
    /// The first report's sequence number.
    pub first_seq: u64,
    /// The last report's sequence number.
    pub last_seq: u64,
    /// Each gap in the sequence numbers.
    pub gaps: Vec<GapJson>,
    /// The gates lost in the gaps.
    pub lost_gates: u64,
    /// Reports that merged gates the firmware could not report one by one.
    pub merged_reports: usize,
    /// The gates the merged reports hold.
    pub merged_gates: u64,
    /// The line of a report dropped because the log ends inside it; null when none.
    pub cut_last_line: Option<usize>,
    /// The instrument file's clock, Hz.
    pub clock_hz: f64,
    /// From the first gate's start to the last one's end, s.
    pub span_s: f64,
    /// What the run warned of, each as printed on stderr.
    pub warnings: Vec<String>,
}

/// A gap in a log's gate reports.
#[derive(Serialize, JsonSchema)]
pub struct GapJson {
    /// The log's line before it.
    pub after_line: usize,
    /// The log's line after it.
    pub before_line: usize,
    /// The first sequence number missing.
    pub first_missing: u64,
    /// The last sequence number missing.
    pub last_missing: u64,
    /// The gates missing.
    pub missing_gates: u64,
    /// The clock ticks missing.
    pub missing_ticks: u64,
}

/// `ptsa correct --json` on a single-axis file: each row's specific force along IA.
#[derive(Serialize, JsonSchema)]
pub struct CorrectJson {
    /// The data file corrected.
    pub data: String,
    /// The calibration applied: its file, or `the instrument file NAME` when none was
    /// given (the file's nominal terms).
    pub calibration: String,
    /// The instrument file.
    pub instrument: String,
    /// The instrument file's local gravity, cm/s².
    pub g_cm_s2: f64,
    /// One per row of the data: `label` and `line`, and the other keys only for a row
    /// with a reading.
    pub rows: Vec<CorrectedRow>,
    /// What the run warned of, each as printed on stderr.
    pub warnings: Vec<String>,
}

/// One row of `correct --json`: its label and line, and with a reading the correction.
#[derive(Serialize, JsonSchema)]
pub struct CorrectedRow {
    /// The row's label.
    pub label: String,
    /// The row's line in the data file.
    pub line: usize,
    /// With a reading: the row corrected (its keys beside `label` and `line`).
    #[serde(flatten)]
    pub corrected: Option<Corrected>,
}

/// `ptsa correct --json` on a triad file: each row's specific force in the triad's frame.
#[derive(Serialize, JsonSchema)]
pub struct TriadCorrectJson {
    /// The data file corrected.
    pub data: String,
    /// The calibration file applied.
    pub calibration: String,
    /// The instrument file.
    pub instrument: String,
    /// The calibration's local gravity, cm/s².
    pub g_cm_s2: f64,
    /// The calibration's orientations, which give `f`'s frame: `exact` (the block's frame)
    /// or `approximate` (the triad's own).
    pub frame: String,
    /// One per row of the data: `label` and `line`, and the other keys only for a row
    /// with three readings.
    pub rows: Vec<TriadCorrectedRow>,
    /// What the run warned of, each as printed on stderr.
    pub warnings: Vec<String>,
}

/// One row of a triad's `correct --json`.
#[derive(Serialize, JsonSchema)]
pub struct TriadCorrectedRow {
    /// The row's label.
    pub label: String,
    /// The row's line in the data file.
    pub line: usize,
    /// With three readings: the row corrected (its keys beside `label` and `line`).
    #[serde(flatten)]
    pub corrected: Option<TriadCorrected>,
}

/// A triad's row corrected.
#[derive(Serialize, JsonSchema)]
pub struct TriadCorrected {
    /// The three axes' readings, cm/s².
    pub reading_cm_s2: [Option<f64>; 3],
    /// The readings' 1-sigma noise, cm/s².
    pub sigma_reading_cm_s2: [f64; 3],
    /// The specific force, cm/s², in `frame`.
    pub f_cm_s2: [f64; 3],
    /// `f_cm_s2` in g (of `g_cm_s2`).
    pub f_g: [f64; 3],
    /// `f`'s magnitude, cm/s².
    pub f_magnitude_cm_s2: f64,
    /// The magnitude's 1-sigma uncertainty, cm/s².
    pub sigma_f_magnitude_cm_s2: f64,
    /// `f`'s covariance, cm²/s⁴ (3×3, whole): `covariance_noise_cm2_s4` plus
    /// `covariance_calibration_cm2_s4`.
    pub covariance_cm2_s4: [[f64; 3]; 3],
    /// The part of `f`'s covariance from the readings' noise, cm²/s⁴.
    pub covariance_noise_cm2_s4: [[f64; 3]; 3],
    /// The part of `f`'s covariance from the calibration's, cm²/s⁴ (shared by every row
    /// corrected with the same calibration).
    pub covariance_calibration_cm2_s4: [[f64; 3]; 3],
}
