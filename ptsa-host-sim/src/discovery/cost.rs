//! What a discovery costs, counted before it runs: the closed-loop runs of its steps
//! (`docs/method/discovery.md`, "Speed") as [`Ticks`], and its least squares as seconds.
//!
//! Always run: every row's baseline; the simulator's own scatter of each measured response
//! row (its runs once more); when the measured rows can show the loop's parameters (any
//! row but a static difference), every parameter's central differences (two passes over
//! the measured rows each); the re-simulation with what is found (one pass over all rows).
//! A pass runs each distinct run once ([`Simulator::pass_cost`]): rows that share a
//! reference condition share its run.
//!
//! Run only when the data call for it (bounded here from above, [`Cost::search`]): when a
//! parameter of the loop is selected, Gauss–Newton (at most
//! [`super::refine::GAUSS_NEWTON_STEPS`] steps of `1 + 2k` passes for
//! `k` parameters), the prune of a second parameter, the check of every other parameter in
//! its place (a grid, its extensions and two golden-section searches, [`SEARCH_PASSES`]
//! passes each, and a fresh evaluation), the mirror check and the secant signatures; with
//! response rows and no parameter selected, the scan of every parameter (as many passes as
//! the check's search) when the model fails its χ² test.

use super::problem::{Options, Selected};
use super::refine::GAUSS_NEWTON_STEPS;
use super::search::{GOLDEN_STEPS, GRID, GRID_EXTENSIONS};
use super::sim::Simulator;
use crate::model::condition::{Condition, RowKind};
use crate::model::effects::CandidateId;
use crate::simulation::work::Ticks;

/// Most closed-loop passes over the measured rows of one parameter's search in
/// [`super::search`]: the grid with the file's value, its extensions, and two golden-section
/// searches of two starting points and [`GOLDEN_STEPS`] steps each.
pub const SEARCH_PASSES: usize = GRID.len() + 1 + GRID_EXTENSIONS + 2 * (2 + GOLDEN_STEPS);

/// Seconds of least squares per observation and candidate (the stepwise selection, its
/// cross-validation folds and the search of the residuals), measured with the analytic
/// simulator (`docs/method/discovery.md`, "Speed"), on the slow side.
pub const LSQ_S_PER_OBSERVATION_CANDIDATE: f64 = 4e-6;

/// A discovery's work, counted before it runs.
#[derive(Clone, Copy, Debug, Default)]
pub struct Cost {
    /// Closed-loop ticks that always run (see the module docs).
    pub ticks: Ticks,
    /// One closed-loop pass over the measured rows.
    pub pass: Ticks,
    /// Parameters of the loop among the candidates that the simulator can vary.
    pub parameters: usize,
    /// The parameters' central differences run (some measured row is not a static
    /// difference).
    pub differences: bool,
    /// Measured response rows (the scan may run).
    pub response: bool,
    /// Observations fitted (a response row's gain and phase count two).
    pub observations: usize,
    /// Candidates tested.
    pub candidates: usize,
}

impl Cost {
    /// The cost of discovering in `rows` with `sim` over `candidates`.
    #[must_use]
    pub fn of(rows: &[Condition], sim: &dyn Simulator, candidates: &[CandidateId]) -> Cost {
        // The runs as `discover` makes them: each row with what it takes from the others
        // (two rows at one position approached from either side are two runs).
        let rows = &crate::model::condition::with_history(rows, sim.g_cm_s2())[..];
        let measured: Vec<&Condition> = rows.iter().filter(|r| r.is_measured()).collect();
        let all: Ticks = sim.pass_cost(&rows.iter().collect::<Vec<_>>());
        let pass: Ticks = sim.pass_cost(&measured);
        let sigma: Ticks = measured.iter().map(|r| sim.sigma_cost(r)).sum();
        let differences = measured
            .iter()
            .any(|r| r.kind != RowKind::Difference || !r.is_static());
        let parameters = candidates
            .iter()
            .filter(|&&id| id.parameter_key().is_some() && super::data::step(sim, id).1 != 0.0)
            .count();
        let observations = measured
            .iter()
            .map(|r| {
                if r.kind == RowKind::Response {
                    usize::from(r.measured_gain.is_some())
                        + usize::from(r.measured_phase_deg.is_some())
                } else {
                    1
                }
            })
            .sum();
        #[allow(clippy::cast_precision_loss)]
        let central = if differences {
            pass.times(2.0 * parameters as f64)
        } else {
            Ticks::ZERO
        };
        Cost {
            ticks: all + sigma + central + all,
            pass,
            parameters,
            differences,
            response: measured.iter().any(|r| r.kind == RowKind::Response),
            observations,
            candidates: candidates.len(),
        }
    }

    /// Estimated wall time of the part that always runs, s.
    #[must_use]
    pub fn seconds(&self) -> f64 {
        #[allow(clippy::cast_precision_loss)]
        let lsq = LSQ_S_PER_OBSERVATION_CANDIDATE
            * self.observations as f64
            * self.candidates.max(1) as f64;
        self.ticks.seconds() + lsq
    }

    /// At most how many closed-loop ticks the search of the loop's parameters adds when `k`
    /// of them are selected by the linear selection (see the module docs); 0 when no
    /// search can run (no parameter selected and no response rows, or no parameter).
    #[must_use]
    pub fn search(&self, k: usize) -> Ticks {
        #[allow(clippy::cast_precision_loss)]
        self.pass
            .times(search_passes(self.parameters, k, self.response) as f64)
    }
}

/// Before the search of the loop's parameters through the closed loop (the stages after
/// the linear selection): its work, bounded from above for the parameters among `selected`
/// ([`Cost::search`]), held against the limit of work (`simulation::work::ahead`), and the
/// progress's stage named, when a search can run.
///
/// # Errors
/// The search would take more than the limit (without `--no-limit`).
pub(crate) fn ahead_of_search(
    rows: &[Condition],
    sim: &dyn Simulator,
    opts: &Options,
    selected: &[Selected],
) -> anyhow::Result<()> {
    let k = selected
        .iter()
        .filter(|s| s.id.parameter_key().is_some())
        .count();
    let search = Cost::of(rows, sim, &opts.candidates).search(k);
    if search.total() > 0.0 {
        crate::simulation::work::ahead("the closed-loop search of the loop's parameters", search)?;
        crate::simulation::work::set_stage("search of the loop's parameters");
    }
    Ok(())
}

/// Most passes over the measured rows of the parameters' search with `p` parameters, `k`
/// of them selected by the linear selection, `response` rows present.
#[must_use]
pub fn search_passes(p: usize, k: usize, response: bool) -> usize {
    if p == 0 || (k == 0 && !response) {
        return 0;
    }
    let gauss_newton = |k: usize| GAUSS_NEWTON_STEPS * (1 + 2 * k);
    let check = |k: usize| k * (2 + (SEARCH_PASSES + 1) * p.saturating_sub(k));
    // Gauss–Newton, then again after the check; the mirror check and the secants.
    let after = |k: usize| 2 * gauss_newton(k) + check(k) + 1 + 2 * k;
    if k == 0 {
        // The scan: the model without a parameter, every parameter's search, the profile
        // of the best; then one parameter refined, checked and refined again.
        return 1 + p * SEARCH_PASSES + 2 + gauss_newton(1) + after(1);
    }
    // The prune, while two or more are selected: the χ² with all, and each dropped in turn
    // with the others refined.
    let prune: usize = (2..=k).map(|j| 1 + j * (gauss_newton(j - 1) + 1)).sum();
    after(k) + prune
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_search_is_bounded_by_its_parts() {
        assert_eq!(SEARCH_PASSES, 34);
        assert_eq!(search_passes(10, 0, false), 0);
        assert_eq!(search_passes(0, 1, true), 0);
        // One of ten selected: two Gauss–Newton runs of 8·3 passes, the check of nine others,
        // the mirror and the secant.
        assert_eq!(search_passes(10, 1, false), 2 * 24 + (2 + 35 * 9) + 3);
        assert!(search_passes(10, 0, true) > search_passes(10, 1, true));
    }
}
