//! What a discovery found, typed ([`Discovery`]): the selected terms, the selection's
//! steps, the family, the effects for the plant, the Bode points, and the `--json` object
//! ([`super::report::JsonReport`]).

use super::fit::Step;
use super::problem::{Options, Selected};
use super::report::{JsonReport, RowResult};
use super::slips;
use crate::model::effects::{CandidateId, Effects};

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
    /// Number of hypotheses in the family (the warm-up's time constants count once).
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
