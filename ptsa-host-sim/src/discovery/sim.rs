//! What the discovery pipeline needs from a simulator, and the two it can use.

use std::borrow::Cow;

use super::observation::Observation;
use crate::model::condition::{Condition, IA, PA, RowKind};
use crate::model::effects::Effects;
use crate::model::instrument::Instrument;

/// A model of the instrument that predicts a row's `measured_cm_s2`: for a `difference`
/// row the mean indicated acceleration in the condition minus that in its reference
/// condition, for an `absolute` row the mean indicated acceleration itself, cm/s².
pub trait Simulator: Sync {
    /// Short name for reports (`"closed-loop"`, `"analytic"`).
    fn name(&self) -> &'static str;
    /// Local gravity of the simulated instrument, cm/s² (what `g_*` = 1 means).
    fn g_cm_s2(&self) -> f64;
    /// The instrument simulated, if the simulator has one (for parameter candidates).
    fn instrument(&self) -> Option<&Instrument> {
        None
    }
    /// Predicted condition-minus-reference difference with the given extra effects, cm/s².
    fn difference_cm_s2(&self, cond: &Condition, effects: &Effects) -> f64;
    /// Predicted mean indicated acceleration in the condition with the given extra effects,
    /// `SF·(2P/T − 1)` with the nominal SF in the limit of a long gate, cm/s².
    fn absolute_cm_s2(&self, cond: &Condition, effects: &Effects) -> f64;
    /// Predicted response to the row's sine along IA: `[gain, phase_deg]` (output amplitude
    /// over input amplitude, output phase minus input phase).
    fn response(&self, cond: &Condition, effects: &Effects) -> [f64; 2];
    /// The prediction of a row's `measured_cm_s2` (a difference or absolute row), cm/s²;
    /// for a response row, its gain.
    fn predict_cm_s2(&self, cond: &Condition, effects: &Effects) -> f64 {
        match self.observe(cond, effects) {
            Observation::Value(v) => v,
            Observation::Response { gain, .. } => gain,
        }
    }
    /// Every observation of a row: its value for a difference or absolute row, its gain
    /// and phase for a response row.
    fn observe(&self, cond: &Condition, effects: &Effects) -> Observation {
        match cond.kind {
            RowKind::Difference => Observation::Value(self.difference_cm_s2(cond, effects)),
            RowKind::Absolute => Observation::Value(self.absolute_cm_s2(cond, effects)),
            RowKind::Response => {
                let [gain, phase_deg] = self.response(cond, effects);
                Observation::Response { gain, phase_deg }
            }
        }
    }
    /// [`Simulator::observe`] of every `(row, effects)` pair, in order. The closed loop
    /// runs them all at once on the batch engine ([`crate::simulation::batch`]), bit for bit the same.
    fn observe_all(&self, jobs: &[(&Condition, &Effects)]) -> Vec<Observation> {
        use rayon::prelude::*;
        jobs.par_iter().map(|(c, e)| self.observe(c, e)).collect()
    }
    /// The same simulator with its runs' seeds moved by `offset` (an independent draw of
    /// its scatter), if it has a scatter; `None` for a deterministic model.
    fn reseeded(&self, offset: u64) -> Option<Box<dyn Simulator>> {
        let _ = offset;
        None
    }
    /// The 1 σ scatter of the baseline prediction of each of a row's observations (as
    /// [`Simulator::observe`]), from the simulator's own noise: 0 for a deterministic model.
    /// The analysis adds it to a stated sigma in quadrature.
    fn observe_sigma(&self, cond: &Condition) -> Observation {
        Observation::uniform(cond.kind, 0.0)
    }
    /// The linear loop model's closed-loop response `L/(1 + L)` at `f_hz` with the
    /// parameter changes of `effects`: `[gain, phase_deg]` (for Bode plots), if the
    /// simulator has a loop.
    fn linear_response(&self, f_hz: f64, effects: &Effects) -> Option<[f64; 2]> {
        let _ = (f_hz, effects);
        None
    }
    /// The closed-loop ticks of one [`Simulator::observe`] of a row (none for a model that
    /// runs no loop), for the estimate of a discovery's work (`discovery::cost`).
    fn cost(&self, cond: &Condition) -> crate::simulation::work::Ticks {
        let _ = cond;
        crate::simulation::work::Ticks::ZERO
    }
    /// The closed-loop ticks of one [`Simulator::observe_all`] of `rows` with one set of
    /// effects (a pass over the rows): what the rows' [`Simulator::cost`]s add up to, less
    /// the runs that rows share (the closed loop runs a reference shared by many rows
    /// once).
    fn pass_cost(&self, rows: &[&Condition]) -> crate::simulation::work::Ticks {
        rows.iter().map(|r| self.cost(r)).sum()
    }
    /// The closed-loop ticks of [`Simulator::observe_sigma`] of a row.
    fn sigma_cost(&self, cond: &Condition) -> crate::simulation::work::Ticks {
        let _ = cond;
        crate::simulation::work::Ticks::ZERO
    }
}

/// `L/(1 + L)` of `instr` with `effects`' parameter changes, `[gain, phase_deg]`.
fn closed_loop_linear(
    instr: &Instrument,
    config: &ptsa_core::Config,
    f_hz: f64,
    effects: &Effects,
) -> [f64; 2] {
    let instr = effects.apply_parameters(instr);
    let l = crate::model::design::loop_gain(&instr, config, f_hz);
    let h = l / (1.0 + l);
    [h.norm(), h.arg().to_degrees()]
}

/// Quasi-static model: the instrument indicates exactly the time average of the specific
/// force along IA, its bias (the instrument file's and the loop's own) and the effect terms
/// ([`Effects::indicated_cm_s2`]) over one oscillation period, with no loop dynamics; so the
/// baseline (no effects) predicts 0 for every difference row.
///
/// For terms linear in their coefficients this is exact: every term is a product of at most
/// two sinusoids at one frequency, i.e. a trigonometric polynomial of degree ≤ 2, and the
/// mean of such a polynomial over `N ≥ 3` equally spaced samples of one period is exact.
#[derive(Clone, Debug)]
pub struct AnalyticSimulator {
    /// Local gravity, cm/s² (the instrument file's).
    pub g_cm_s2: f64,
    /// Bias of the instrument, cm/s² (the file's `A_b`; the loop's own bias is added per row
    /// from `loop_bias_per_pa` below).
    pub bias_cm_s2: f64,
    /// The loop's own bias at zero `a_PA` and its change per cm/s² of `a_PA`
    /// ([`Instrument::loop_bias_cm_s2`] is linear in `a_PA`).
    pub loop_bias: [f64; 2],
    /// The instrument and its compensator, for the linear loop model of response rows.
    pub loop_model: Box<(Instrument, ptsa_core::Config)>,
    /// The instrument file's nominal model-equation terms (`[model_equation]`,
    /// [`Instrument::with_nominal_terms`]): part of the baseline, added to every row's
    /// effects.
    pub nominal: Effects,
}

impl AnalyticSimulator {
    /// The analytic model of `instr`.
    #[must_use]
    pub fn for_instrument(instr: &Instrument) -> Self {
        let b0 = instr.loop_bias_cm_s2(0.0);
        let config = if instr.has_loop {
            crate::model::design::check_loop(instr).map_or(ptsa_core::Config::DEFAULT, |c| c.config)
        } else {
            ptsa_core::Config::DEFAULT
        };
        Self {
            g_cm_s2: instr.g_cm_s2,
            bias_cm_s2: instr.bias_cm_s2,
            loop_bias: [b0, instr.loop_bias_cm_s2(1.0) - b0],
            loop_model: Box::new((instr.clone(), config)),
            nominal: instr.nominal,
        }
    }

    /// `effects` with the nominal terms of the instrument file added.
    fn total(&self, effects: &Effects) -> Effects {
        let mut e = *effects;
        for (id, c) in self.nominal.nonzero() {
            e.add(id, c);
        }
        e
    }
}

/// The effects' part of the analytic model's prediction of a row (what the signatures are
/// made of) with local gravity `g_cm_s2`, cm/s²: the condition's mean effect minus its
/// reference's for a difference row, the mean effect for an absolute row, 0 for a response
/// row.
#[must_use]
pub fn effect_cm_s2(cond: &Condition, effects: &Effects, g_cm_s2: f64) -> f64 {
    match cond.kind {
        RowKind::Difference => {
            mean_effect_cm_s2(cond, effects, g_cm_s2)
                - mean_effect_cm_s2(&cond.reference(), effects, g_cm_s2)
        }
        RowKind::Absolute => mean_effect_cm_s2(cond, effects, g_cm_s2),
        RowKind::Response => 0.0,
    }
}

/// Samples per period (exact for degree < 8; the terms have degree ≤ 2).
const SAMPLES: usize = 8;
/// [`SAMPLES`] as a float.
const SAMPLES_F: f64 = 8.0;

/// Mean of the effect terms over one period of `cond` (one sample if static), cm/s², with
/// local gravity `g_cm_s2`.
#[must_use]
pub fn mean_effect_cm_s2(cond: &Condition, effects: &Effects, g_cm_s2: f64) -> f64 {
    let warm_up = effects.warm_up_cm_s2(cond.history.t_on_s);
    if cond.is_static() {
        return effects.indicated_cm_s2(&cond.inputs_at(0.0, g_cm_s2)) + warm_up;
    }
    let period = 1.0 / cond.freq_hz;
    #[allow(clippy::cast_precision_loss)]
    let dt = period / SAMPLES as f64;
    (0..SAMPLES)
        .map(|k| {
            #[allow(clippy::cast_precision_loss)]
            let t = k as f64 * dt;
            effects.indicated_cm_s2(&cond.inputs_at(t, g_cm_s2))
        })
        .sum::<f64>()
        / SAMPLES_F
        + warm_up
}

/// Mean of `|each term|`-ish magnitude used to tell an exactly cancelling column from a real
/// one: the mean absolute effect in the condition plus that in the reference, cm/s² (local
/// gravity `g_cm_s2`).
#[must_use]
pub fn gross_effect_cm_s2(cond: &Condition, effects: &Effects, g_cm_s2: f64) -> f64 {
    let r = cond.reference();
    let n = if cond.is_static() { 1 } else { SAMPLES };
    let period = if cond.freq_hz > 0.0 {
        1.0 / cond.freq_hz
    } else {
        0.0
    };
    #[allow(clippy::cast_precision_loss)]
    let nf = n as f64;
    let mut s = 0.0;
    for k in 0..n {
        #[allow(clippy::cast_precision_loss)]
        let t = k as f64 * period / nf;
        s += effects.indicated_cm_s2(&cond.inputs_at(t, g_cm_s2)).abs();
    }
    match cond.kind {
        RowKind::Difference => s / nf + effects.indicated_cm_s2(&r.inputs_at(0.0, g_cm_s2)).abs(),
        RowKind::Absolute | RowKind::Response => s / nf,
    }
}

impl Simulator for AnalyticSimulator {
    fn name(&self) -> &'static str {
        if self.loop_model.0.has_loop {
            "analytic"
        } else {
            "loop-less analytic"
        }
    }

    fn g_cm_s2(&self) -> f64 {
        self.g_cm_s2
    }

    fn difference_cm_s2(&self, cond: &Condition, effects: &Effects) -> f64 {
        // The analytic model runs no closed loop, so each row is where a host's Ctrl-C may
        // stop it (one atomic load).
        crate::simulation::work::checkpoint();
        effect_cm_s2(cond, &self.total(effects), self.g_cm_s2)
    }

    fn absolute_cm_s2(&self, cond: &Condition, effects: &Effects) -> f64 {
        crate::simulation::work::checkpoint();
        // Every oscillation averages to zero in the specific force; the mean is gravity
        // plus a centrifuge arm's push.
        let m = cond.prepare(self.g_cm_s2).mean_inputs();
        m.a_cm_s2[IA]
            + self.bias_cm_s2
            + self.loop_bias[0]
            + self.loop_bias[1] * m.a_cm_s2[PA]
            + mean_effect_cm_s2(cond, &self.total(effects), self.g_cm_s2)
    }

    fn instrument(&self) -> Option<&Instrument> {
        Some(&self.loop_model.0)
    }

    fn response(&self, cond: &Condition, effects: &Effects) -> [f64; 2] {
        // The linear loop model L/(1 + L) of the instrument's loop (with its parameter
        // changes); an instrument without a loop is taken as quasi-static: it follows the
        // input (gain 1, phase 0).
        let (instr, config) = &*self.loop_model;
        if !instr.has_loop {
            return [1.0, 0.0];
        }
        closed_loop_linear(instr, config, cond.freq_hz, effects)
    }

    fn linear_response(&self, f_hz: f64, effects: &Effects) -> Option<[f64; 2]> {
        let (instr, config) = &*self.loop_model;
        instr
            .has_loop
            .then(|| closed_loop_linear(instr, config, f_hz, effects))
    }
}

/// The closed loop ([`crate::simulation::sim::simulate_difference`]: ptsa-core tick by tick against the
/// plant of eq. 4.2, Table 2.1's parameters) behind [`Simulator`]. Effects enter the plant
/// as an extra torque `P·effects.indicated_cm_s2(inputs)`.
#[derive(Clone, Debug)]
pub struct ClosedLoopSimulator {
    /// The instrument (default: the shipped Kearfott 2401 file).
    pub instrument: crate::model::instrument::Instrument,
    /// Run options (seed of the pickoff noise, warm-up, window).
    pub options: crate::simulation::sim::SimOptions,
}

impl ClosedLoopSimulator {
    /// The shipped instrument with default options and noise seed `seed`.
    #[must_use]
    pub fn kearfott_2401(seed: u64) -> Self {
        ClosedLoopSimulator {
            instrument: crate::model::instrument::Instrument::kearfott_2401(),
            options: crate::simulation::sim::SimOptions {
                seed,
                ..crate::simulation::sim::SimOptions::default()
            },
        }
    }
}

impl ClosedLoopSimulator {
    /// The response rows among `jobs`, [`RUN_CHUNK`] runs at a time through [`runs_of`]:
    /// the mean of each row's [`RESPONSE_SEEDS`] runs, by the row's index in `jobs`.
    fn observe_responses(&self, jobs: &[(&Condition, &Effects)]) -> Vec<(usize, Observation)> {
        let seed = self.options.seed;
        let rows: Vec<usize> = (0..jobs.len())
            .filter(|&k| jobs[k].0.kind == RowKind::Response)
            .collect();
        #[allow(clippy::cast_possible_truncation)]
        let seeds = RESPONSE_SEEDS as usize;
        let per = (RUN_CHUNK / seeds).max(1);
        let mut out = Vec::with_capacity(rows.len());
        for chunk in rows.chunks(per) {
            let runs: Vec<(&Condition, &Effects, u64)> = chunk
                .iter()
                .flat_map(|&k| {
                    let (c, e) = jobs[k];
                    (0..RESPONSE_SEEDS).map(move |j| (c, e, seed.wrapping_add(j)))
                })
                .collect();
            let res = observe_runs(&self.instrument, &runs, &self.options);
            // Each row's runs in turn, every one a response (the rows are response rows).
            for (&k, rs) in chunk.iter().zip(res.chunks(seeds)) {
                let r: Vec<[f64; 2]> = rs
                    .iter()
                    .filter_map(|o| match *o {
                        Observation::Response { gain, phase_deg } => Some([gain, phase_deg]),
                        Observation::Value(_) => None,
                    })
                    .collect();
                let [gain, phase_deg] = mean_of_runs(&r).0;
                out.push((k, Observation::Response { gain, phase_deg }));
            }
        }
        out
    }
}

/// Runs of one batch-engine call of [`ClosedLoopSimulator::observe_all`]: enough to keep
/// every core busy, few enough that their loops take a few megabytes.
pub const RUN_CHUNK: usize = 2048;

/// One distinct run of [`distinct_runs`]: its condition (a row's, or a reference built
/// from one) and effects.
pub type Run<'a> = (Cow<'a, Condition>, &'a Effects);

/// The runs of one job of [`distinct_runs`]: the index of its condition's run and of its
/// reference's.
pub type RunSlots = (Option<usize>, Option<usize>);

/// The runs of difference and absolute rows that [`ClosedLoopSimulator::observe_all`] runs
/// for `jobs`, each distinct run once: the condition of every such row and the reference
/// of every difference row. Returns the distinct runs (condition, effects), in order of
/// first appearance, and for each job the index of its condition's run and of its
/// reference's (`None` for a response row, and for an absolute row's reference).
///
/// Two runs are the same when every input of the condition (its fields but the label and
/// the measurement), every coefficient of the effects and the seed are the same bits: they
/// give the same run bit for bit (the closed loop is deterministic), so sharing it changes
/// no value. Many rows share their reference (one gravity, no rates): a pass over a shaker's
/// or a rate table's rows runs it once instead of once a row.
#[must_use]
pub fn distinct_runs<'a>(
    jobs: &[(&'a Condition, &'a Effects)],
    seed: u64,
) -> (Vec<Run<'a>>, Vec<RunSlots>) {
    let mut runs: Vec<Run<'a>> = Vec::new();
    let mut index: std::collections::HashMap<Vec<u64>, usize> = std::collections::HashMap::new();
    let mut slot = |c: Cow<'a, Condition>, e: &'a Effects| -> usize {
        let next = runs.len();
        let k = *index.entry(run_key(&c, e, seed)).or_insert(next);
        if k == next {
            runs.push((c, e));
        }
        k
    };
    let slots = jobs
        .iter()
        .map(|&(c, e)| match c.kind {
            RowKind::Response => (None, None),
            RowKind::Absolute => (Some(slot(Cow::Borrowed(c), e)), None),
            RowKind::Difference => {
                let own = slot(Cow::Borrowed(c), e);
                (Some(own), Some(slot(Cow::Owned(c.reference()), e)))
            }
        })
        .collect();
    (runs, slots)
}

/// The order in which [`ClosedLoopSimulator::observe_all`] hands `runs` to the batch
/// engine, [`RUN_CHUNK`] at a time: the runs of one condition next to each other (by
/// [`Condition::input_bits`], stable), whatever the order of the jobs. A pass over the
/// parameters' sides lists each parameter's rows in turn; in that order a call of 2048 runs
/// held two sides of each of 1000 rows, and the engine, which computes a condition's phasor
/// and inputs once for the lanes in step that share it, computed them for every second
/// lane. Each run is independent of the others in its call, so the order moves no value.
#[must_use]
pub fn by_condition(runs: &[Run<'_>]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..runs.len()).collect();
    order.sort_by_cached_key(|&k| runs[k].0.input_bits());
    order
}

/// What makes one closed-loop run of [`distinct_runs`]: every input of the condition
/// ([`Condition::input_bits`]), every coefficient of the effects, and the noise seed, as
/// bits (`-0.0` and `0.0` are different keys; a NaN never meets another).
fn run_key(c: &Condition, e: &Effects, seed: u64) -> Vec<u64> {
    let mut k = c.input_bits();
    k.push(seed);
    k.extend(
        crate::model::effects::CandidateId::ALL
            .iter()
            .map(|&id| e.get(id).to_bits()),
    );
    k
}

impl Simulator for ClosedLoopSimulator {
    fn name(&self) -> &'static str {
        "closed-loop"
    }

    fn g_cm_s2(&self) -> f64 {
        self.instrument.g_cm_s2
    }

    fn instrument(&self) -> Option<&Instrument> {
        Some(&self.instrument)
    }

    fn difference_cm_s2(&self, cond: &Condition, effects: &Effects) -> f64 {
        crate::simulation::sim::simulate_difference(&self.instrument, cond, effects, &self.options)
            .difference_cm_s2
    }

    fn absolute_cm_s2(&self, cond: &Condition, effects: &Effects) -> f64 {
        crate::simulation::sim::simulate_condition(&self.instrument, cond, effects, &self.options)
            .indicated_cm_s2
    }

    /// The mean over [`RESPONSE_SEEDS`] noise seeds (from the options' seed on) of
    /// [`response_of`]: one run's gain and phase scatter with the pickoff noise and the
    /// limit cycle's beat against the input about as much as a measured row's.
    fn response(&self, cond: &Condition, effects: &Effects) -> [f64; 2] {
        response_runs(&self.instrument, cond, effects, &self.options).0
    }

    fn reseeded(&self, offset: u64) -> Option<Box<dyn Simulator>> {
        Some(Box::new(ClosedLoopSimulator {
            instrument: self.instrument.clone(),
            options: crate::simulation::sim::SimOptions {
                seed: self.options.seed.wrapping_add(offset),
                ..self.options
            },
        }))
    }

    /// Every run of every row on the batch engine: a response row's [`RESPONSE_SEEDS`] runs
    /// through [`runs_of`], a difference row's condition and reference and an absolute
    /// row's run each once ([`distinct_runs`]: rows that share a reference, or replicated
    /// rows, share its run); the lanes are the single loop's runs bit for bit, so this is
    /// [`Simulator::observe`] row by row. Taken [`RUN_CHUNK`] runs at a time, so that the
    /// loops in memory at once do not grow with the table (each run is independent of the
    /// others in its call).
    fn observe_all(&self, jobs: &[(&Condition, &Effects)]) -> Vec<Observation> {
        let seed = self.options.seed;
        let (runs, slots) = distinct_runs(jobs, seed);
        let order = by_condition(&runs);
        let mut value: Vec<f64> = vec![0.0; runs.len()];
        for chunk in order.chunks(RUN_CHUNK) {
            let batch: Vec<crate::simulation::batch::Job<'_>> = chunk
                .iter()
                .map(|&k| crate::simulation::batch::Job {
                    instr: &self.instrument,
                    cond: runs[k].0.as_ref(),
                    effects: *runs[k].1,
                    seed,
                })
                .collect();
            let res = crate::simulation::batch::simulate_jobs(&batch, &self.options);
            for (&k, r) in chunk.iter().zip(&res) {
                value[k] = r.indicated_cm_s2;
            }
        }
        // The response rows' observations, in the order of their jobs: each job takes its
        // own (a response row has no run of its own in `slots`) or its value.
        let mut responses = self.observe_responses(jobs).into_iter().peekable();
        slots
            .iter()
            .enumerate()
            .map(|(k, &(own, reference))| {
                if let Some((_, o)) = responses.next_if(|(j, _)| *j == k) {
                    return o;
                }
                // Summed from 0 as `runs_of` sums them (the same bits, the sign of a zero
                // included).
                let mut v = 0.0;
                if let Some(o) = own {
                    v += value[o];
                }
                if let Some(r) = reference {
                    v -= value[r];
                }
                Observation::Value(v)
            })
            .collect()
    }

    fn linear_response(&self, f_hz: f64, effects: &Effects) -> Option<[f64; 2]> {
        Some(closed_loop_linear(
            &self.instrument,
            &self.options.config,
            f_hz,
            effects,
        ))
    }

    /// A response row's [`RESPONSE_SEEDS`] runs, a difference row's condition and
    /// reference, an absolute row's run.
    fn cost(&self, cond: &Condition) -> crate::simulation::work::Ticks {
        let (i, o) = (&self.instrument, &self.options);
        match cond.kind {
            RowKind::Response => (0..RESPONSE_SEEDS)
                .map(|j| {
                    crate::simulation::work::condition(
                        i,
                        &started(cond, o.seed.wrapping_add(j)),
                        &response_options(o),
                    )
                })
                .sum(),
            RowKind::Difference => crate::simulation::work::difference(i, cond, o),
            RowKind::Absolute => crate::simulation::work::condition(i, cond, o),
        }
    }

    /// Each distinct run of the rows once ([`distinct_runs`]), and every response row's
    /// runs.
    fn pass_cost(&self, rows: &[&Condition]) -> crate::simulation::work::Ticks {
        let none = Effects::NONE;
        let jobs: Vec<(&Condition, &Effects)> = rows.iter().map(|&r| (r, &none)).collect();
        let (runs, _) = distinct_runs(&jobs, self.options.seed);
        let plain: crate::simulation::work::Ticks = runs
            .iter()
            .map(|(c, _)| crate::simulation::work::condition(&self.instrument, c, &self.options))
            .sum();
        plain
            + rows
                .iter()
                .filter(|r| r.kind == RowKind::Response)
                .map(|r| self.cost(r))
                .sum()
    }

    /// A response row's [`RESPONSE_SEEDS`] runs again; nothing for the other rows.
    fn sigma_cost(&self, cond: &Condition) -> crate::simulation::work::Ticks {
        if cond.kind == RowKind::Response {
            self.cost(cond)
        } else {
            crate::simulation::work::Ticks::ZERO
        }
    }

    /// For a response row, the standard error of [`ClosedLoopSimulator::response`]'s mean:
    /// the sample standard deviation of the [`RESPONSE_SEEDS`] runs over their square root.
    fn observe_sigma(&self, cond: &Condition) -> Observation {
        if cond.kind == RowKind::Response {
            let [gain, phase_deg] =
                response_runs(&self.instrument, cond, &Effects::NONE, &self.options).1;
            Observation::Response { gain, phase_deg }
        } else {
            Observation::Value(0.0)
        }
    }
}

/// Runs averaged per simulated response row (seeds `seed`, `seed + 1`, ...).
pub const RESPONSE_SEEDS: u64 = 4;

/// The mean `[gain, phase_deg]` of [`RESPONSE_SEEDS`] runs and its standard errors.
fn response_runs(
    instr: &Instrument,
    cond: &Condition,
    effects: &Effects,
    opts: &crate::simulation::sim::SimOptions,
) -> ([f64; 2], [f64; 2]) {
    let runs: Vec<[f64; 2]> = (0..RESPONSE_SEEDS)
        .map(|j| {
            let o = crate::simulation::sim::SimOptions {
                seed: opts.seed.wrapping_add(j),
                ..*opts
            };
            response_of(instr, cond, effects, &o)
        })
        .collect();
    mean_of_runs(&runs)
}

/// The mean `[gain, phase_deg]` of runs and its standard errors (the sample standard
/// deviation over the square root of the number of runs).
fn mean_of_runs(runs: &[[f64; 2]]) -> ([f64; 2], [f64; 2]) {
    // The phase about the first run's, so that runs either side of ±180° average right.
    let p0 = runs[0][1];
    let rel = |p: f64| (p - p0 + 540.0).rem_euclid(360.0) - 180.0;
    #[allow(clippy::cast_precision_loss)]
    let n = runs.len() as f64;
    let mean = [
        runs.iter().map(|r| r[0]).sum::<f64>() / n,
        p0 + runs.iter().map(|r| rel(r[1])).sum::<f64>() / n,
    ];
    let se = |k: usize, m: f64| {
        let d = |r: &[f64; 2]| {
            if k == 0 {
                r[0] - m
            } else {
                rel(r[1]) - (m - p0)
            }
        };
        (runs.iter().map(|r| d(r).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt()
    };
    (mean, [se(0, mean[0]), se(1, mean[1])])
}

/// Shortest window of a simulated response row, s (the output's component at the input's
/// frequency needs enough limit cycles to stand out of the pulse train's quantization).
pub const RESPONSE_WINDOW_S: f64 = 0.5;

/// The closed loop's response to a response row's sine along IA: `[gain, phase_deg]`, the
/// component of the indicated output at the row's frequency over the input's amplitude, and
/// its phase minus the input's, over a window of whole periods at least
/// [`RESPONSE_WINDOW_S`] long.
#[must_use]
pub fn response_of(
    instr: &Instrument,
    cond: &Condition,
    effects: &Effects,
    opts: &crate::simulation::sim::SimOptions,
) -> [f64; 2] {
    let c = started(cond, opts.seed);
    let r = crate::simulation::sim::simulate_condition(instr, &c, effects, &response_options(opts));
    response_from(cond, &c, &r)
}

/// The options of a response run: the first harmonic measured, the window at least
/// [`RESPONSE_WINDOW_S`].
fn response_options(
    opts: &crate::simulation::sim::SimOptions,
) -> crate::simulation::sim::SimOptions {
    crate::simulation::sim::SimOptions {
        harmonic: 1,
        min_window_s: opts.min_window_s.max(RESPONSE_WINDOW_S),
        ..*opts
    }
}

/// `cond` with its sine started at the phase drawn from `seed` and the row's frequency. A
/// laboratory's sine is not synchronised to the loop's clock, so the beat of the input
/// against the limit cycle and the 64 kHz clock is part of the run-to-run scatter, not a
/// fixed error that moves erratically with every parameter. The frequency enters the draw so
/// that the runs of different rows start at unrelated phases: with the same few phases for
/// every row, a simulated table's errors (and its runs' scatter) would be alike from row to
/// row, and the χ² of a right model would not be χ².
fn started(cond: &Condition, seed: u64) -> Condition {
    use rand::{Rng as _, SeedableRng as _};
    let stream = seed ^ START_PHASE_STREAM ^ cond.freq_hz.to_bits().rotate_left(29);
    let start_deg: f64 = rand_chacha::ChaCha8Rng::seed_from_u64(stream).random_range(0.0..360.0);
    let mut c = cond.clone();
    c.lin_deg[IA] += start_deg;
    c
}

/// One closed-loop run of each `(row, effects, seed)` of `instr` with `opts` (its seed
/// replaced), all on the batch engine ([`crate::simulation::batch`]) in two calls (response runs have
/// their own window and harmonic): `[gain, phase_deg]` for a response row, as
/// [`response_of`]; `[indicated cm/s²]` for an absolute row and `[difference cm/s²]` for a
/// difference row (the condition minus its reference), as
/// [`crate::simulation::sim::simulate_condition`] and [`crate::simulation::sim::simulate_difference`]; bit for
/// bit those single runs. In the flat form [`Observation::values`] (the hidden-effect
/// campaigns' tables take it).
#[must_use]
pub fn runs_of(
    instr: &Instrument,
    jobs: &[(&Condition, &Effects, u64)],
    opts: &crate::simulation::sim::SimOptions,
) -> Vec<Vec<f64>> {
    observe_runs(instr, jobs, opts)
        .iter()
        .map(Observation::values)
        .collect()
}

/// [`runs_of`], each run as an [`Observation`].
#[must_use]
pub fn observe_runs(
    instr: &Instrument,
    jobs: &[(&Condition, &Effects, u64)],
    opts: &crate::simulation::sim::SimOptions,
) -> Vec<Observation> {
    let ropts = response_options(opts);
    // Response runs with their conditions started at their phases.
    let shifted: Vec<(usize, Condition)> = jobs
        .iter()
        .enumerate()
        .filter(|(_, (c, _, _))| c.kind == RowKind::Response)
        .map(|(k, &(c, _, seed))| (k, started(c, seed)))
        .collect();
    let rjobs: Vec<crate::simulation::batch::Job<'_>> = shifted
        .iter()
        .map(|(k, c)| crate::simulation::batch::Job {
            instr,
            cond: c,
            effects: *jobs[*k].1,
            seed: jobs[*k].2,
        })
        .collect();
    // The other rows' conditions, then the difference rows' references.
    let refs: Vec<(usize, Condition)> = jobs
        .iter()
        .enumerate()
        .filter(|(_, (c, _, _))| c.kind == RowKind::Difference)
        .map(|(k, (c, _, _))| (k, c.reference()))
        .collect();
    let mut ojobs = Vec::new();
    let mut slots: Vec<(usize, bool)> = Vec::new();
    for (k, &(c, e, seed)) in jobs.iter().enumerate() {
        if c.kind != RowKind::Response {
            ojobs.push(crate::simulation::batch::Job {
                instr,
                cond: c,
                effects: *e,
                seed,
            });
            slots.push((k, false));
        }
    }
    for (k, r) in &refs {
        ojobs.push(crate::simulation::batch::Job {
            instr,
            cond: r,
            effects: *jobs[*k].1,
            seed: jobs[*k].2,
        });
        slots.push((*k, true));
    }
    let rres = crate::simulation::batch::simulate_jobs(&rjobs, &ropts);
    let ores = crate::simulation::batch::simulate_jobs(&ojobs, opts);
    let mut value = vec![0.0; jobs.len()];
    for ((k, reference), res) in slots.iter().zip(&ores) {
        if *reference {
            value[*k] -= res.indicated_cm_s2;
        } else {
            value[*k] += res.indicated_cm_s2;
        }
    }
    // A response row's run is among `shifted`'s (in the order of the jobs); every other
    // row's is its value.
    let mut responses = shifted.iter().zip(&rres).peekable();
    (0..jobs.len())
        .map(|k| match responses.next_if(|((j, _), _)| *j == k) {
            Some(((_, c), r)) => {
                let [gain, phase_deg] = response_from(jobs[k].0, c, r);
                Observation::Response { gain, phase_deg }
            }
            None => Observation::Value(value[k]),
        })
        .collect()
}

/// `[gain, phase_deg]` of the run `r` of `started` (the row `cond` started at its phase).
fn response_from(
    cond: &Condition,
    started: &Condition,
    r: &crate::simulation::sim::SimResult,
) -> [f64; 2] {
    let amp = cond.lin_cm_s2[IA].abs();
    let mut ph = (r.harmonic_deg - started.lin_deg[IA]) % 360.0;
    if ph > 180.0 {
        ph -= 360.0;
    } else if ph <= -180.0 {
        ph += 360.0;
    }
    [r.harmonic_amp_cm_s2 / amp, ph]
}

/// Mixed into a run's seed to draw its input's start phase in [`response_of`].
const START_PHASE_STREAM: u64 = 0x5747_2d70_6861_7365;

/// The closed-loop simulator of the shipped instrument, boxed.
#[must_use]
pub fn closed_loop(seed: u64) -> Box<dyn Simulator> {
    Box::new(ClosedLoopSimulator::kearfott_2401(seed))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::effects::CandidateId;

    #[test]
    fn rectified_vibropendulosity_is_half_the_amplitude_product_times_cos_phase() {
        let sim = AnalyticSimulator::for_instrument(&Instrument::kearfott_2401());
        let g = sim.g_cm_s2;
        let c = Condition {
            g: [1.0, 0.0, 0.0],
            freq_hz: 10.0,
            lin_cm_s2: [200.0, 300.0, 0.0],
            lin_deg: [0.0, 60.0, 0.0],
            ..Condition::default()
        };
        let e = Effects::only(CandidateId::Vibropendulosity, 1e-4);
        let d = sim.difference_cm_s2(&c, &e);
        let want = 1e-4 * 200.0 * 300.0 * 60f64.to_radians().cos() / 2.0;
        assert!((d - want).abs() < 1e-12, "{d} {want}");
        // Gravity alone cancels against the reference.
        let e2 = Effects::only(CandidateId::Nonlinearity, 1e-6);
        let d2 = sim.difference_cm_s2(&c, &e2);
        assert!((d2 - 1e-6 * 200.0 * 200.0 / 2.0).abs() < 1e-9 * g, "{d2}");
    }

    /// The instrument file's nominal model-equation terms are in both simulators' baseline
    /// exactly as the same coefficients given as effects: bit for bit, a static absolute
    /// row and a shaker difference row, analytic and closed loop; the file without them
    /// reads differently.
    #[test]
    fn nominal_model_terms_enter_the_baseline_as_effects_do() {
        let plain = Instrument::kearfott_2401();
        let text = format!(
            "{}\n[model_equation]\nk2_s2_cm = 2e-6\ndelta_p_rad = 1e-3\nk1_ppm = 300.0\n",
            crate::model::instrument::KEARFOTT_2401_TOML
        );
        let with = Instrument::parse(&text, "k.toml").unwrap();
        let as_effects = Effects::only(CandidateId::Nonlinearity, 2e-6)
            .with(CandidateId::MisalignmentO, -1e-3)
            .with(CandidateId::ScaleFactor, 300.0);
        let rows = [
            Condition {
                kind: RowKind::Absolute,
                g: [0.6, 0.0, 0.8],
                ..Condition::default()
            },
            Condition {
                g: [1.0, 0.0, 0.0],
                freq_hz: 20.0,
                lin_cm_s2: [300.0, 0.0, 0.0],
                ..Condition::default()
            },
        ];
        let analytic = |i: &Instrument| AnalyticSimulator::for_instrument(i);
        let closed = |i: &Instrument| ClosedLoopSimulator {
            instrument: i.clone(),
            options: crate::simulation::sim::SimOptions {
                min_window_s: 0.05,
                warmup_s: 0.02,
                ..crate::simulation::sim::SimOptions::default()
            },
        };
        for r in &rows {
            let a = analytic(&with).predict_cm_s2(r, &Effects::NONE);
            let b = analytic(&plain).predict_cm_s2(r, &as_effects);
            assert_eq!(a.to_bits(), b.to_bits(), "{r:?}: {a} {b}");
            assert!(
                (a - analytic(&plain).predict_cm_s2(r, &Effects::NONE)).abs() > 1e-3,
                "{r:?}"
            );
            let c = closed(&with).predict_cm_s2(r, &Effects::NONE);
            let d = closed(&plain).predict_cm_s2(r, &as_effects);
            assert_eq!(c.to_bits(), d.to_bits(), "{r:?}: {c} {d}");
        }
    }

    /// Rows share a run only when every input, the effects and the seed are the same bits:
    /// three shaker rows share their reference; a gravity of `-0.0` instead of `0.0` along
    /// PA makes another reference; other effects make other runs.
    #[test]
    fn runs_are_shared_only_when_identical() {
        let mut rows = Vec::new();
        for f in [10.0, 20.0, 30.0] {
            let mut c = Condition {
                g: [1.0, 0.0, 0.0],
                freq_hz: f,
                label: format!("{f} Hz"),
                ..Condition::default()
            };
            c.lin_cm_s2[IA] = 300.0;
            rows.push(c);
        }
        let mut c = rows[0].clone();
        c.g[PA] = -0.0;
        rows.push(c);
        let none = Effects::NONE;
        let damp = Effects::only(CandidateId::ParamDamping, 5000.0);
        let jobs: Vec<(&Condition, &Effects)> = rows.iter().map(|r| (r, &none)).collect();
        let (runs, slots) = distinct_runs(&jobs, 1);
        // Four conditions, two references.
        assert_eq!(runs.len(), 6, "{runs:?}");
        assert_eq!(slots[0].1, slots[1].1);
        assert_eq!(slots[0].1, slots[2].1);
        assert_ne!(slots[0].1, slots[3].1);
        assert_ne!(slots[0].0, slots[3].0);
        let mut jobs = jobs;
        jobs.push((&rows[0], &damp));
        assert_eq!(distinct_runs(&jobs, 1).0.len(), 8);
        assert_eq!(distinct_runs(&jobs[..1], 1).0.len(), 2);
    }

    /// Runs of one condition are handed to the engine side by side, in the order of their
    /// first appearance, whatever the jobs' order: three rows' parameter sides listed
    /// parameter by parameter (as `data::sensitivities` lists them) come out row by row.
    #[test]
    fn runs_of_one_condition_go_to_the_engine_together() {
        let rows: Vec<Condition> = [10.0, 20.0, 30.0]
            .iter()
            .map(|&f| {
                let mut c = Condition {
                    kind: RowKind::Absolute,
                    g: [1.0, 0.0, 0.0],
                    freq_hz: f,
                    ..Condition::default()
                };
                c.lin_cm_s2[IA] = 300.0;
                c
            })
            .collect();
        let sides = [
            Effects::only(CandidateId::ParamDamping, 5000.0),
            Effects::only(CandidateId::ParamDamping, -5000.0),
            Effects::only(CandidateId::ParamSpring, 1.0),
            Effects::only(CandidateId::ParamSpring, -1.0),
        ];
        let jobs: Vec<(&Condition, &Effects)> = sides
            .iter()
            .flat_map(|e| rows.iter().map(move |r| (r, e)))
            .collect();
        let (runs, _) = distinct_runs(&jobs, 1);
        assert_eq!(runs.len(), 12);
        let order = by_condition(&runs);
        let freqs: Vec<f64> = order.iter().map(|&k| runs[k].0.freq_hz).collect();
        for g in freqs.chunks(4) {
            assert!(
                g.iter().all(|&f| f.to_bits() == g[0].to_bits()),
                "{freqs:?}"
            );
        }
        // Within a condition, the jobs' order (stable).
        for g in order.chunks(4) {
            assert!(g.windows(2).all(|w| w[0] < w[1]), "{order:?}");
        }
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..12).collect::<Vec<_>>());
    }

    /// The batched `observe_all` of the closed loop is `observe` row by row, bit for bit:
    /// response rows (each of its runs with its start phase), a difference row with a
    /// vibration, an absolute row, with and without a parameter change.
    #[test]
    #[allow(clippy::float_cmp)]
    fn observe_all_is_observe_bit_for_bit() {
        let sim = ClosedLoopSimulator {
            instrument: Instrument::kearfott_2401(),
            options: crate::simulation::sim::SimOptions {
                seed: 5,
                warmup_s: 0.02,
                min_window_s: 0.02,
                ..crate::simulation::sim::SimOptions::default()
            },
        };
        let mut rows = Vec::new();
        for f in [20.0, 150.0] {
            let mut c = Condition {
                kind: RowKind::Response,
                freq_hz: f,
                ..Condition::default()
            };
            c.lin_cm_s2[IA] = 2000.0;
            rows.push(c);
        }
        let mut d = Condition {
            g: [1.0, 0.0, 0.0],
            freq_hz: 50.0,
            ..Condition::default()
        };
        d.lin_cm_s2[IA] = 500.0;
        rows.push(d.clone());
        // A second difference row with the same reference (its run shared), and an absolute
        // row twice (replicates: one run).
        let mut d2 = d.clone();
        d2.freq_hz = 80.0;
        d2.label = "another".into();
        rows.push(d2);
        d.kind = RowKind::Absolute;
        rows.push(d.clone());
        rows.push(d);
        let none = Effects::NONE;
        let damp = Effects::only(CandidateId::ParamDamping, 5000.0);
        let jobs: Vec<(&Condition, &Effects)> =
            rows.iter().flat_map(|r| [(r, &none), (r, &damp)]).collect();
        let all = sim.observe_all(&jobs);
        for ((c, e), got) in jobs.iter().zip(&all) {
            let want = sim.observe(c, e);
            assert!(got.same_kind(&want), "{got:?} against {want:?}");
            assert_eq!(
                got.values().iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                want.values()
                    .iter()
                    .map(|x| x.to_bits())
                    .collect::<Vec<_>>(),
                "{:?} at {} Hz: {got:?} against {want:?}",
                c.kind,
                c.freq_hz
            );
        }
    }
}
