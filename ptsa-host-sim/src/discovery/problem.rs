//! What the stages of the method share: the options ([`Options`]), the selected terms they
//! read and change ([`Selected`]), and the problem they all work on once the linear
//! selection is made (`Problem`: the rows, their observations, the linear fit, the
//! simulator). No stage is imported here.

use super::data::Data;
use super::fit::{Fitted, Settings};
use super::profile::TimeConstant;
use super::report::{ParameterValue, Rival};
use super::sim::Simulator;
use crate::model::condition::Condition;
use crate::model::effects::{CandidateId, Effects, N_CANDIDATES, resolve_candidates};
use crate::model::instrument::Instrument;

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
    /// The user's own terms (`--term`), tested after the selection
    /// ([`super::unexplained`]).
    pub terms: Vec<super::library::Term>,
}

impl Options {
    /// The default options with the plausibility bounds of `instr`, and its candidates:
    /// every one, but the loop's parameters when the file has no loop.
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
            // Without a loop in the file, no loop parameter is a candidate.
            candidates: CandidateId::ALL
                .iter()
                .copied()
                .filter(|id| instr.has_loop || id.parameter().is_none())
                .collect(),
            limits,
            seed: 1,
            keep_outliers: false,
            units_as_given: false,
            terms: Vec::new(),
        }
    }

    /// The settings of the linear fit and its selection.
    #[must_use]
    pub fn settings(&self) -> Settings {
        Settings {
            alpha: self.alpha,
            confound_cos: self.confound_cos,
            select: true,
        }
    }
}

impl Default for Options {
    /// The options with the shipped instrument's plausibility bounds.
    fn default() -> Self {
        Self::for_instrument(&Instrument::kearfott_2401())
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
    /// ([`super::mirror`]).
    pub mirror: bool,
    /// For a parameter found by a search through the closed loop: the change at the end of
    /// the search grid when its best lies there ([`super::search`]).
    pub search_limit: Option<f64>,
    /// The coefficient is the same on disjoint parts of the data (`super::stability`):
    /// `Some(false)` its value depends on when or how it was measured; `None` not tested.
    pub stable: Option<bool>,
    /// Forms outside the vocabulary that these data cannot tell it from (`super::rivals`;
    /// empty: none, or not looked for).
    pub rivals: Vec<Rival>,
    /// For the warm-up: its time constant estimated over τ and the amplitude there
    /// ([`super::profile`]).
    pub time_constant: Option<TimeConstant>,
    /// The bias fitted with the warm-up as the level its transient settles to, not
    /// selected on its own test ([`super::fit::Fitted::companion`]): no cause of its own.
    pub companion: bool,
}

impl Selected {
    /// These selections as effects for the plant: their coefficients, and the warm-up's
    /// estimated time constant ([`Selected::time_constant`]).
    #[must_use]
    pub fn effects(selected: &[Selected]) -> Effects {
        let mut e = Effects::NONE;
        for s in selected {
            e.add(s.id, s.coef);
            if let Some(t) = &s.time_constant {
                e = e.with_warm_up_tau_s(t.tau_s);
            }
        }
        e
    }
}

/// What every stage after the linear selection works on: the rows, their observations,
/// the linear fit, the simulator and the options.
#[derive(Clone, Copy)]
pub(crate) struct Problem<'a> {
    /// The caller's rows.
    pub rows: &'a [Condition],
    /// Their observations.
    pub data: &'a Data,
    /// The linear fit (nuisance terms, noise, family).
    pub f: &'a Fitted,
    /// The simulator.
    pub sim: &'a dyn Simulator,
    /// The method's settings (the familywise α, the plausibility bounds, ...).
    pub opts: &'a Options,
}

impl<'a> Problem<'a> {
    /// Rows, data, fit, simulator and α.
    pub(crate) fn parts(
        &self,
    ) -> (
        &'a [Condition],
        &'a Data,
        &'a Fitted,
        &'a dyn Simulator,
        f64,
    ) {
        (self.rows, self.data, self.f, self.sim, self.opts.alpha)
    }
}

/// Whether a parameter candidate's change keeps the parameter in its tolerance band.
pub(crate) fn within_tolerance(id: CandidateId, change: f64, sim: &dyn Simulator) -> bool {
    id.parameter_key()
        .and_then(|k| sim.instrument().and_then(|i| i.tolerance(k)))
        .is_none_or(|(lo, nom, hi)| (lo..=hi).contains(&(nom + change)))
}

/// Whether a coefficient is plausible: for a parameter of the instrument file, its change
/// keeps it within the file's tolerance band; for another candidate, it lies within its
/// plausibility bound (`opts.limits`).
pub(crate) fn plausible(id: CandidateId, coef: f64, sim: &dyn Simulator, opts: &Options) -> bool {
    if id.parameter_key().is_some() {
        within_tolerance(id, coef, sim)
    } else {
        coef.abs() <= opts.limits[id.index()]
    }
}
