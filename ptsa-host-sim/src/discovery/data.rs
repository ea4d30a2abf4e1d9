//! The measured rows as the method sees them: one observation per measured value (a
//! difference or absolute row's value, a response row's gain and phase, [`Quantity`]), its
//! residual to explain (measured − baseline), stated sigma, block, time, variance group and
//! replicate set, the signature of every candidate and the library of shapes (the generic
//! basis of the case inputs, the history, time shapes, products) used to look for
//! unexplained structure.

use std::collections::BTreeMap;

use super::library::{Family, Shape, shapes};
use super::observation::{Observation, Quantity};
use super::sim::{Simulator, effect_cm_s2, gross_effect_cm_s2};
use crate::model::condition::Condition;
use crate::model::effects::{CandidateId, Effects};

/// How the drift term's time is measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeUnit {
    /// The case frame's `time_s`, s.
    Seconds,
    /// Row order (no `time_s` column), rows.
    Row,
}

/// One candidate's signature over the fitted rows.
#[derive(Clone, Debug)]
pub struct Signature {
    /// The candidate.
    pub id: CandidateId,
    /// Predicted condition − reference difference per unit coefficient, cm/s² per unit.
    pub col: Vec<f64>,
    /// Identically zero here (every entry cancels to rounding between condition and
    /// reference).
    pub null: bool,
}

/// The fitted observations: one per difference or absolute row with a measurement, one or
/// two (gain, phase) per response row.
#[derive(Clone, Debug)]
pub struct Data {
    /// Index of each observation's row in the caller's rows.
    pub rows: Vec<usize>,
    /// What each observation is.
    pub quantity: Vec<Quantity>,
    /// Measured values (cm/s², or a gain, or degrees).
    pub y: Vec<f64>,
    /// Baseline (simulated) values, in the same units.
    pub base: Vec<f64>,
    /// Stated sigmas (the row's `sigma_*`, else the explicit `--sigma` for cm/s² values).
    pub stated: Vec<Option<f64>>,
    /// The simulator's own scatter of each observation's prediction (the standard error of
    /// its mean of runs; 0 where the simulator gives none).
    pub sim_sigma: Vec<f64>,
    /// The 1-sigma error each observation has from its row's orientation error
    /// (`sigma_angle_urad`, [`Condition::fixture_sigma_cm_s2`]) and, for a reading given
    /// as counts, from the counting ([`Condition::counting_sigma_cm_s2`]), in quadrature,
    /// cm/s²; 0 without. Included in a stated sigma (in quadrature); added to an estimated
    /// one ([`super::fit`]).
    pub fixture: Vec<f64>,
    /// Whether each observation takes its block's bias shift (a difference row's value).
    pub shift: Vec<bool>,
    /// Whether each observation takes the drift (a difference or absolute row's value).
    pub drifts: Vec<bool>,
    /// Block of each observation (index into `block_names`).
    pub block: Vec<usize>,
    /// Block names (`"all"` when the file has no `block` column).
    pub block_names: Vec<String>,
    /// Time of each observation's row, in `time_unit`.
    pub time: Vec<f64>,
    /// What `time` is.
    pub time_unit: TimeUnit,
    /// Variance group of each observation (index into `group_names`): block × kind.
    pub group: Vec<usize>,
    /// Variance group names.
    pub group_names: Vec<String>,
    /// Replicate set of each observation: the same quantity of rows with identical
    /// conditions (and block) share it.
    pub replicate: Vec<usize>,
    /// Signatures of the candidates asked for, in registry order.
    pub signatures: Vec<Signature>,
    /// The generic basis: `(name, column)` (the library's [`Family::Basis`]).
    pub features: Vec<(String, Vec<f64>)>,
    /// The library the residuals are searched against ([`super::library::shapes`]): the
    /// generic basis, the history, time shapes and products up to third order.
    pub shapes: Vec<Shape>,
}

impl Data {
    /// Number of observations.
    #[must_use]
    pub fn n(&self) -> usize {
        self.y.len()
    }

    /// Residual to explain, `measured − baseline`.
    #[must_use]
    pub fn resid(&self, i: usize) -> f64 {
        self.y[i] - self.base[i]
    }

    /// The same observations without those at the indices `drop` (rows set aside as
    /// suspected gross errors): every per-observation column loses them, a signature or a
    /// generic-basis column that is zero on the rest becomes one without a signature (or is
    /// left out), and the rest keep their blocks, variance groups, replicate sets and
    /// times (the drift's time of a row is where it was measured, whatever is set aside).
    #[must_use]
    pub fn without(&self, drop: &[usize]) -> Data {
        fn pick<T: Clone>(v: &[T], keep: &[usize]) -> Vec<T> {
            keep.iter().map(|&i| v[i].clone()).collect()
        }
        let keep: Vec<usize> = (0..self.n()).filter(|i| !drop.contains(i)).collect();
        Data {
            rows: pick(&self.rows, &keep),
            quantity: pick(&self.quantity, &keep),
            y: pick(&self.y, &keep),
            base: pick(&self.base, &keep),
            stated: pick(&self.stated, &keep),
            sim_sigma: pick(&self.sim_sigma, &keep),
            fixture: pick(&self.fixture, &keep),
            shift: pick(&self.shift, &keep),
            drifts: pick(&self.drifts, &keep),
            block: pick(&self.block, &keep),
            block_names: self.block_names.clone(),
            time: pick(&self.time, &keep),
            time_unit: self.time_unit,
            group: pick(&self.group, &keep),
            group_names: self.group_names.clone(),
            replicate: pick(&self.replicate, &keep),
            signatures: self
                .signatures
                .iter()
                .map(|s| {
                    let col = pick(&s.col, &keep);
                    let null = s.null || col.iter().all(|&x| x == 0.0);
                    Signature {
                        id: s.id,
                        col,
                        null,
                    }
                })
                .collect(),
            features: self
                .features
                .iter()
                .map(|(n, c)| (n.clone(), pick(c, &keep)))
                .filter(|(_, c)| c.iter().any(|&x| x != 0.0))
                .collect(),
            shapes: self
                .shapes
                .iter()
                .map(|s| Shape {
                    col: pick(&s.col, &keep),
                    ..s.clone()
                })
                .filter(|s| s.col.iter().any(|&x| x != 0.0))
                .collect(),
        }
    }

    /// The same observations with the signature of [`CandidateId::WarmUp`] at time
    /// constant `tau_s` (its column is zero until one is given): each observation's
    /// analytic effect ([`effect_cm_s2`]) of a unit transient `e^(−t/τ)` in its row of
    /// `rows` (the rows the data were built from, with their history).
    #[must_use]
    pub fn with_warm_up(&self, rows: &[Condition], tau_s: f64, g_cm_s2: f64) -> Data {
        let mut d = self.clone();
        let e = Effects::only(CandidateId::WarmUp, 1.0).with_warm_up_tau_s(tau_s);
        for s in d
            .signatures
            .iter_mut()
            .filter(|s| s.id == CandidateId::WarmUp)
        {
            s.col = (0..self.n())
                .map(|k| match self.quantity[k] {
                    Quantity::Value => effect_cm_s2(&rows[self.rows[k]], &e, g_cm_s2),
                    _ => 0.0,
                })
                .collect();
            s.null = s.col.iter().all(|&x| x == 0.0);
        }
        d
    }
}

/// The excitation of a row, for its variance group.
fn excitation(c: &Condition) -> &'static str {
    if c.is_static() {
        "static"
    } else {
        "oscillating"
    }
}

/// Index of `key` in `names`, appended if new.
fn intern(names: &mut Vec<String>, key: String) -> usize {
    if let Some(i) = names.iter().position(|n| *n == key) {
        i
    } else {
        names.push(key);
        names.len() - 1
    }
}

/// The measured observations of a row: `(quantity, measured, stated sigma)` (a response
/// row's gain and phase each where measured).
fn observations(r: &Condition, default_sigma: Option<f64>) -> Vec<(Quantity, f64, Option<f64>)> {
    match r.kind {
        crate::model::condition::RowKind::Response => {
            let mut v = Vec::new();
            if let Some(gain) = r.measured_gain {
                v.push((Quantity::Gain, gain, r.sigma_gain));
            }
            if let Some(ph) = r.measured_phase_deg {
                v.push((Quantity::Phase, ph, r.sigma_phase_deg));
            }
            v
        }
        _ => r
            .measured_cm_s2
            .map(|m| vec![(Quantity::Value, m, r.sigma_cm_s2.or(default_sigma))])
            .unwrap_or_default(),
    }
}

/// Each fitted observation's value in `per_row` (the observations of the caller's rows, by
/// row; `None` for a row not observed), in the order of `d`'s observations; `None` when a
/// row's observation is missing or lacks the quantity (a simulator's observation of
/// another kind than the row's).
#[must_use]
pub fn column_of(d: &Data, per_row: &[Option<Observation>]) -> Option<Vec<f64>> {
    (0..d.n())
        .map(|k| per_row.get(d.rows[k])?.as_ref()?.get(d.quantity[k]))
        .collect()
}

/// A phase measured as `y` degrees, moved by whole turns to within half a turn of `base`.
fn unwrap_phase(y: f64, base: f64) -> f64 {
    y - 360.0 * ((y - base) / 360.0).round()
}

/// The simulator's value of each of `d`'s observations with `effects` (each measured row of
/// `rows` observed once), in `d`'s order; `None` when an observation lacks its quantity.
#[must_use]
pub fn predicted(
    rows: &[Condition],
    d: &Data,
    sim: &dyn Simulator,
    effects: &Effects,
) -> Option<Vec<f64>> {
    let mut measured: Vec<usize> = d.rows.clone();
    measured.dedup();
    let jobs: Vec<(&Condition, &Effects)> = measured.iter().map(|&i| (&rows[i], effects)).collect();
    let mut per_row: Vec<Option<Observation>> = vec![None; rows.len()];
    for (&i, o) in measured.iter().zip(sim.observe_all(&jobs)) {
        per_row[i] = Some(o);
    }
    column_of(d, &per_row)
}

/// Build the observations of the rows with a measurement. `observed[i]` is the simulator's
/// baseline observation of row `i` ([`Simulator::observe`]); `default_sigma` the explicit
/// `--sigma`, if any.
///
/// # Errors
/// `time_s` given on some measured rows but not on others; the simulator's observation of
/// a measured row is not of the row's kind (no gain and phase for a response row, no
/// value for another).
pub fn build(
    rows: &[Condition],
    observed: &[Observation],
    default_sigma: Option<f64>,
    candidates: &[CandidateId],
    sim: &dyn Simulator,
) -> anyhow::Result<Data> {
    let fitted: Vec<usize> = (0..rows.len()).filter(|&i| rows[i].is_measured()).collect();
    let mut d = Data::empty(time_unit(rows, &fitted)?);
    d.observe(rows, &fitted, observed, default_sigma, sim)?;
    let g = sim.g_cm_s2();
    let value: Vec<bool> = d.quantity.iter().map(|&q| q == Quantity::Value).collect();
    d.signatures = all_signatures(rows, &d, &value, candidates, sim);
    d.shapes = shapes(
        rows,
        g,
        &d.rows,
        &value,
        &d.time,
        &d.drifts,
        d.time_unit == TimeUnit::Seconds,
    );
    d.features = d
        .shapes
        .iter()
        .filter(|s| s.family == Family::Basis)
        .map(|s| (s.name.clone(), s.col.clone()))
        .collect();
    Ok(d)
}

/// The time the drifts run in: seconds where every measured row (`fitted`) gives
/// `time_s`, rows where none does.
///
/// # Errors
/// `time_s` given on some measured rows but not on others.
fn time_unit(rows: &[Condition], fitted: &[usize]) -> anyhow::Result<TimeUnit> {
    let with_time = fitted.iter().filter(|&&i| rows[i].time_s.is_some()).count();
    if with_time > 0 && with_time < fitted.len() {
        let i = fitted
            .iter()
            .find(|&&i| rows[i].time_s.is_none())
            .copied()
            .unwrap_or(0);
        anyhow::bail!(
            "`time_s` is given for {with_time} of the {} measured rows but not for row {} (`{}`); expected it on every measured row or on none (then the drift is fitted in row order)",
            fitted.len(),
            i + 1,
            rows[i].label
        );
    }
    Ok(if with_time > 0 {
        TimeUnit::Seconds
    } else {
        TimeUnit::Row
    })
}

/// Every candidate's signature over the observations of `d` (`value`: those that are
/// values): additive terms act on the values; parameters by the closed loop's sensitivity,
/// which shows only in oscillating, absolute or response rows (a static difference is exact
/// by charge balance whatever the loop). Sorted by candidate.
fn all_signatures(
    rows: &[Condition],
    d: &Data,
    value: &[bool],
    candidates: &[CandidateId],
    sim: &dyn Simulator,
) -> Vec<Signature> {
    let obs_rows: Vec<&Condition> = d.rows.iter().map(|&i| &rows[i]).collect();
    let (params, additive): (Vec<CandidateId>, Vec<CandidateId>) = candidates
        .iter()
        .partition(|id| id.parameter_key().is_some());
    let mut sigs = signatures(&obs_rows, &additive, sim.g_cm_s2());
    for s in &mut sigs {
        for (x, &v) in s.col.iter_mut().zip(value) {
            if !v {
                *x = 0.0;
            }
        }
        s.null = s.col.iter().all(|&x| x == 0.0);
    }
    let dynamic = d.rows.iter().any(|&i| {
        rows[i].kind != crate::model::condition::RowKind::Difference || !rows[i].is_static()
    });
    if dynamic {
        crate::simulation::work::set_stage("the loop parameters' central differences");
        sigs.extend(parameter_signatures(rows, d, &params, sim));
    } else {
        sigs.extend(params.iter().map(|&id| Signature {
            id,
            col: vec![0.0; d.n()],
            null: true,
        }));
    }
    sigs.sort_by_key(|s| s.id);
    sigs
}

impl Data {
    /// No observations yet, the drifts in `time_unit`.
    fn empty(time_unit: TimeUnit) -> Self {
        Self {
            rows: Vec::new(),
            quantity: Vec::new(),
            y: Vec::new(),
            base: Vec::new(),
            stated: Vec::new(),
            sim_sigma: Vec::new(),
            fixture: Vec::new(),
            shift: Vec::new(),
            drifts: Vec::new(),
            block: Vec::new(),
            block_names: Vec::new(),
            time: Vec::new(),
            time_unit,
            group: Vec::new(),
            group_names: Vec::new(),
            replicate: Vec::new(),
            signatures: Vec::new(),
            features: Vec::new(),
            shapes: Vec::new(),
        }
    }

    /// The observations of the measured rows `fitted`, each with its baseline
    /// (`observed`), its sigmas, block, group, replicate set and time.
    ///
    /// # Errors
    /// The simulator's observation of a row is not of the row's kind.
    fn observe(
        &mut self,
        rows: &[Condition],
        fitted: &[usize],
        observed: &[Observation],
        default_sigma: Option<f64>,
        sim: &dyn Simulator,
    ) -> anyhow::Result<()> {
        let g = sim.g_cm_s2();
        // Replicate sets numbered in order of first appearance.
        let mut keys: std::collections::HashMap<Vec<u64>, usize> = std::collections::HashMap::new();
        let sim_sigmas: Vec<Observation> = {
            use rayon::prelude::*;
            fitted
                .par_iter()
                .map(|&i| sim.observe_sigma(&rows[i]))
                .collect()
        };
        for (k, &i) in fitted.iter().enumerate() {
            let r = &rows[i];
            let b = r.block.clone().unwrap_or_else(|| "all".to_string());
            let bi = intern(&mut self.block_names, b.clone());
            for (q, y, sigma) in observations(r, default_sigma) {
                let (Some(base), Some(own)) = (observed[i].get(q), sim_sigmas[k].get(q)) else {
                    anyhow::bail!(
                        "row {} (`{}`, {}): the {} simulator's observation has no {}; expected a value in cm/s² for a difference or absolute row, a gain and a phase for a response row",
                        i + 1,
                        r.label,
                        r.kind.name(),
                        sim.name(),
                        match q {
                            Quantity::Value => "value in cm/s²",
                            Quantity::Gain => "gain",
                            Quantity::Phase => "phase",
                        }
                    );
                };
                // A stated sigma is the measurement's; the simulator's own scatter, the
                // fixture's orientation error and the counting's error add to it.
                let fixture = if q == Quantity::Value {
                    r.fixture_sigma_cm_s2(g)
                        .hypot(r.counting_sigma_cm_s2.unwrap_or(0.0))
                } else {
                    0.0
                };
                self.sim_sigma.push(own);
                self.fixture.push(fixture);
                self.rows.push(i);
                self.quantity.push(q);
                self.y.push(if q == Quantity::Phase {
                    unwrap_phase(y, base)
                } else {
                    y
                });
                self.base.push(base);
                self.stated.push(sigma.map(|s| s.hypot(own).hypot(fixture)));
                self.shift.push(
                    q == Quantity::Value && r.kind == crate::model::condition::RowKind::Difference,
                );
                self.drifts.push(q == Quantity::Value);
                self.block.push(bi);
                let kind = match q {
                    Quantity::Value => excitation(r),
                    Quantity::Gain => "gain",
                    Quantity::Phase => "phase",
                };
                self.group
                    .push(intern(&mut self.group_names, format!("{b}/{kind}")));
                // Replicated rows: bit-identical inputs.
                let mut key = r.input_bits();
                key.push(bi as u64);
                key.push(q as u64);
                let next = keys.len();
                self.replicate.push(*keys.entry(key).or_insert(next));
                #[allow(clippy::cast_precision_loss)]
                self.time.push(r.time_s.unwrap_or(k as f64));
            }
        }
        Ok(())
    }
}

/// The closed loop's sensitivity of every observation to each parameter candidate, by
/// central differences through the simulator with a step of a tenth of the parameter's
/// tolerance half-width (noise as in the simulator). A parameter the simulator cannot vary
/// has a zero (not testable) signature.
fn parameter_signatures(
    rows: &[Condition],
    d: &Data,
    params: &[CandidateId],
    sim: &dyn Simulator,
) -> Vec<Signature> {
    sensitivities(rows, d, params, sim, &Effects::NONE)
}

/// Step of the parameters' central differences, in tolerance half-widths: large enough that
/// the closed loop's noise (a changed parameter decorrelates the limit cycle's beat even
/// with the same seed) does not pass for a sensitivity, small enough to stay local.
pub const SENSITIVITY_STEP: f64 = 0.25;

/// Fraction of an observation's noise that a parameter off by its whole tolerance must
/// move it by to have a signature.
pub const PARAMETER_MIN_MOVE: f64 = 0.5;

/// The observations' sensitivities to each parameter around the effects `at` (central
/// differences, step [`SENSITIVITY_STEP`] tolerance half-widths); `null` when the
/// parameter, off by its whole tolerance, moves no observation by
/// [`PARAMETER_MIN_MOVE`] of its noise.
pub fn sensitivities(
    rows: &[Condition],
    d: &Data,
    params: &[CandidateId],
    sim: &dyn Simulator,
    at: &Effects,
) -> Vec<Signature> {
    let mut measured: Vec<usize> = d.rows.clone();
    measured.dedup();
    // Each parameter's tolerance half-width and step: inside the band on both sides (an
    // asymmetric band, the torquer lag's 0.2 to 20 µs about 2 µs, would otherwise step
    // below zero).
    let steps: Vec<(f64, f64)> = params.iter().map(|&id| step(sim, id)).collect();
    // Every parameter's two sides at every measured row, in one batch.
    let sides: Vec<Effects> = params
        .iter()
        .zip(&steps)
        .flat_map(|(&id, &(_, h))| {
            let (mut plus, mut minus) = (*at, *at);
            plus.add(id, h);
            minus.add(id, -h);
            [plus, minus]
        })
        .collect();
    let jobs: Vec<(&Condition, &Effects)> = params
        .iter()
        .enumerate()
        .filter(|(p, _)| steps[*p].1 != 0.0)
        .flat_map(|(p, _)| {
            let sides = &sides;
            measured
                .iter()
                .flat_map(move |&i| [(&rows[i], &sides[2 * p]), (&rows[i], &sides[2 * p + 1])])
        })
        .collect();
    let mut obs = sim.observe_all(&jobs).into_iter();
    let scale = scales(d);
    params
        .iter()
        .zip(&steps)
        .map(|(&id, &(half, h))| {
            if h == 0.0 {
                return Signature {
                    id,
                    col: vec![0.0; d.n()],
                    null: true,
                };
            }
            // Each measured row's two sides, by the row's index.
            let mut per_row: Vec<Option<(Observation, Observation)>> = vec![None; rows.len()];
            for &i in &measured {
                let up = obs.next();
                let dn = obs.next();
                per_row[i] = up.zip(dn);
            }
            // An observation whose difference is not a finite number (or that a side lacks)
            // has no sensitivity.
            let col: Vec<f64> = (0..d.n())
                .map(|k| {
                    let q = d.quantity[k];
                    per_row[d.rows[k]]
                        .and_then(|(up, dn)| Some((up.get(q)? - dn.get(q)?) / (2.0 * h)))
                        .filter(|x| x.is_finite())
                        .unwrap_or(0.0)
                })
                .collect();
            // A signature only if the parameter, off by its whole tolerance, moves some
            // observation by half that observation's noise: below that the difference is the
            // closed loop's own scatter (about 1e-4 cm/s² in a static row), which would
            // otherwise pass for a sensitivity and crowd the family.
            let moves = (0..d.n()).any(|k| col[k].abs() * half >= PARAMETER_MIN_MOVE * scale[k]);
            let null = !moves || noise_only(d, &scale, &col, h, half);
            Signature { id, col, null }
        })
        .collect()
}

/// A parameter's tolerance half-width and the step of its central differences (0 when the
/// simulator's instrument gives it no tolerance, or its value sits on the band's edge).
pub(crate) fn step(sim: &dyn Simulator, id: CandidateId) -> (f64, f64) {
    let key = id.parameter_key().unwrap_or_default();
    sim.instrument()
        .and_then(|i| i.tolerance(key))
        .map_or((0.0, 0.0), |(lo, nom, hi)| {
            let half = (hi - nom).max(nom - lo);
            (
                half,
                (SENSITIVITY_STEP * half).min(0.9 * (hi - nom).min(nom - lo)),
            )
        })
}

/// Significance level below which a parameter's central difference counts as more than
/// the simulator's own scatter (see `sensitivities`).
pub const SENSITIVITY_ALPHA: f64 = 1e-3;

/// Whether a central difference `col` (step `h` either side) is no more than the
/// simulator's scatter of its two means, where the simulator states one (`sim_sigma`). The
/// differences over each observation's noise scale, `N = Σ (2h·col/s)²`, are held against
/// what the scatter alone would give, `D = Σ 2·sim_sigma²/s²`, estimated from
/// [`RESPONSE_SEEDS`](super::sim::RESPONSE_SEEDS) runs per row; `N/D` is tested as
/// `F(ν, (runs − 1)·ν)` with Satterthwaite's `ν = (Σa)²/Σa²`, `a = sim_sigma²/s²`, at
/// [`SENSITIVITY_ALPHA`]. A parameter whose response is even about the file's value (a
/// pickoff phase error, which enters as its cosine) has only scatter here: it is no
/// first-order candidate, and only the searches through the closed loop
/// (`discovery::check`, `discovery::scan`) can name it. An observation
/// without a simulator scatter (a static value) counts as a signal when it moves: the
/// [`PARAMETER_MIN_MOVE`] rule decides there.
fn noise_only(d: &Data, scale: &[f64], col: &[f64], h: f64, half: f64) -> bool {
    let noisy: Vec<usize> = (0..d.n()).filter(|&k| d.sim_sigma[k] > 0.0).collect();
    let moved = |k: usize| col[k].abs() * half >= PARAMETER_MIN_MOVE * scale[k];
    if noisy.is_empty() || (0..d.n()).any(|k| d.sim_sigma[k] == 0.0 && moved(k)) {
        return false;
    }
    let (mut num, mut a_sum, mut a2_sum) = (0.0, 0.0, 0.0);
    for &k in &noisy {
        let s = scale[k];
        num += (2.0 * h * col[k] / s).powi(2);
        let a = (d.sim_sigma[k] / s).powi(2);
        a_sum += a;
        a2_sum += a * a;
    }
    if a_sum <= 0.0 {
        return false;
    }
    let nu = a_sum * a_sum / a2_sum;
    #[allow(clippy::cast_precision_loss)]
    let dof_d = (super::sim::RESPONSE_SEEDS - 1) as f64 * nu;
    crate::stats::f_sf(num / (2.0 * a_sum), nu, dof_d) > SENSITIVITY_ALPHA
}

/// The noise scale of every observation: its stated sigma, else the median absolute
/// deviation (× 1.4826) of the residuals of its quantity (computed once per quantity).
fn scales(d: &Data) -> Vec<f64> {
    let mut mad: Vec<(Quantity, f64)> = Vec::new();
    (0..d.n())
        .map(|k| {
            if let Some(s) = d.stated[k] {
                return s;
            }
            let q = d.quantity[k];
            if let Some(&(_, s)) = mad.iter().find(|(x, _)| *x == q) {
                return s;
            }
            let mut r: Vec<f64> = (0..d.n())
                .filter(|&j| d.quantity[j] == q)
                .map(|j| d.resid(j))
                .collect();
            r.sort_by(f64::total_cmp);
            let med = r[r.len() / 2];
            let mut dev: Vec<f64> = r.iter().map(|x| (x - med).abs()).collect();
            dev.sort_by(f64::total_cmp);
            let s = (1.4826 * dev[dev.len() / 2]).max(f64::MIN_POSITIVE);
            mad.push((q, s));
            s
        })
        .collect()
}

/// Signature columns: the analytic effect of each row with a unit coefficient (a difference
/// or an absolute value by the row's kind; exact for these linear terms: the loop indicates
/// their time average), and whether the column is identically zero here (every entry cancels
/// to rounding against the gross size of the term in the condition and its reference).
#[must_use]
pub fn signatures(rows: &[&Condition], candidates: &[CandidateId], g_cm_s2: f64) -> Vec<Signature> {
    candidates
        .iter()
        .map(|&id| {
            let e = Effects::only(id, 1.0);
            // Entries that cancel to rounding (a mean of a sinusoid over its samples) are 0.
            let col: Vec<f64> = rows
                .iter()
                .map(|r| {
                    let x = effect_cm_s2(r, &e, g_cm_s2);
                    if x.abs() <= 1e-9 * gross_effect_cm_s2(r, &e, g_cm_s2) {
                        0.0
                    } else {
                        x
                    }
                })
                .collect();
            let null = col.iter().all(|&x| x == 0.0);
            Signature { id, col, null }
        })
        .collect()
}

/// Rows per replicate set, for sets of two or more.
#[must_use]
pub fn replicate_sets(data: &Data, subset: &[usize]) -> Vec<Vec<usize>> {
    let mut sets: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for &i in subset {
        sets.entry(data.replicate[i]).or_default().push(i);
    }
    sets.into_values().filter(|s| s.len() > 1).collect()
}
