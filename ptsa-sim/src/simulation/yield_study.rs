//! The production yield over the instrument file's tolerance box (`ptsa monte-carlo
//! --yield N`): instruments drawn from the box, each run through the closed loop across
//! ±full scale, and the fraction that meets a stated specification.
//!
//! Instrument `k` is drawn from its own random stream (`ChaCha8`, the study's seed, stream
//! `k`): every toleranced parameter uniform between its limits, then the seed of its
//! pickoff noise. So an instrument's result depends on the seed and its index only, never
//! on how the study is cut into pieces ([`units`] on any range) or how many workers run
//! them; [`summary`] of the pieces joined is the study's.
//!
//! Each instrument keeps the nominal compensator (`opts.config`) and the nominal scale
//! factor for reading its counts, as a production line would with one firmware image and
//! one data sheet. Its figures are those of a fitted line through its mean indicated value
//! at each input: the scale-factor error, the bias, the largest departure from the line,
//! and the gate-to-gate scatter at rest; and the margins of its linearised loop.

use std::collections::BTreeMap;
use std::ops::Range;

use rand::{Rng as _, SeedableRng as _};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::lab::response::Gate;
use crate::model::design::margins;
use crate::model::instrument::Instrument;
use crate::simulation::batch::{Engine, RecordJob};
use crate::simulation::sim::SimOptions;

/// The default inputs, fractions of full scale.
pub const DEFAULT_FRACTIONS: [f64; 7] = [-0.9, -0.6, -0.3, 0.0, 0.3, 0.6, 0.9];
/// The default gate, s.
pub const DEFAULT_GATE_S: f64 = 0.1;
/// The default number of gates at each input.
pub const DEFAULT_GATES: u64 = 8;
/// Most instruments in one study.
pub const MAX_INSTRUMENTS: u64 = 1_000_000;
/// Fewest and most gates at each input.
pub const GATES: std::ops::RangeInclusive<u64> = 2..=10_000;
/// The default smallest phase margin, degrees (R-890's design goal).
pub const DEFAULT_PM_DEG: f64 = 45.0;
/// The default smallest gain margin, dB (R-890's design goal).
pub const DEFAULT_GM_DB: f64 = 6.0;

/// What the study runs and what it asks of each instrument.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Plan {
    /// Instruments drawn.
    pub instruments: u64,
    /// Seed of the draws (instrument `k` is stream `k` of it).
    pub seed: u64,
    /// Inputs along IA, fractions of the nominal full scale (−1 to 1).
    pub fractions_of_full_scale: Vec<f64>,
    /// The gate, s.
    pub gate_s: f64,
    /// Gates at each input, after the settling.
    pub gates: u64,
    /// Settling from reset before the first gate, s.
    pub warmup_s: f64,
    /// The specification an instrument must meet to count towards the yield.
    pub spec: Spec,
}

impl Plan {
    /// The plan's own checks (the command line's and the Python package's): 1 to
    /// [`MAX_INSTRUMENTS`] instruments, [`GATES`] gates, at least two different inputs from
    /// −1 to 1 of full scale, a gate more than 0 s, a settling of 0 s or more, and limits
    /// of 0 or more.
    ///
    /// # Errors
    /// The first value out of range: its name, the value and what was expected.
    pub fn check(&self) -> Result<(), String> {
        if !(1..=MAX_INSTRUMENTS).contains(&self.instruments) {
            return Err(format!(
                "instruments {}: expected a whole number from 1 to {MAX_INSTRUMENTS}",
                self.instruments
            ));
        }
        if !GATES.contains(&self.gates) {
            return Err(format!(
                "gates {}: expected a whole number from {} to {} (the noise at rest is their standard deviation)",
                self.gates,
                GATES.start(),
                GATES.end()
            ));
        }
        let f = &self.fractions_of_full_scale;
        if let Some(x) = f.iter().find(|x| !(-1.0..=1.0).contains(*x)) {
            return Err(format!(
                "fractions: {x}; expected fractions of full scale from -1 to 1"
            ));
        }
        if !f
            .iter()
            .any(|x| f.first().is_some_and(|y| x.total_cmp(y).is_ne()))
        {
            return Err(format!(
                "fractions: {f:?}; expected at least two different inputs (a line is fitted through them)"
            ));
        }
        if !(self.gate_s > 0.0 && self.gate_s.is_finite()) {
            return Err(format!(
                "gate_s {}: expected a gate more than 0 s",
                self.gate_s
            ));
        }
        if !(self.warmup_s >= 0.0 && self.warmup_s.is_finite()) {
            return Err(format!(
                "warmup_s {}: expected a settling of 0 s or more",
                self.warmup_s
            ));
        }
        self.spec.check()
    }
}

impl Spec {
    /// Every limit given is a finite number, 0 or more.
    ///
    /// # Errors
    /// The first limit that is not: its name and value.
    pub fn check(&self) -> Result<(), String> {
        let limits = [
            ("spec_sf_ppm", self.sf_error_ppm),
            ("spec_bias_cm_s2", self.bias_cm_s2),
            ("spec_linearity_ppm_fs", self.linearity_ppm_fs),
            ("spec_noise_cm_s2", self.noise_cm_s2),
            ("spec_pm_deg", self.phase_margin_deg),
            ("spec_gm_db", self.gain_margin_db),
        ];
        for (name, v) in limits {
            if let Some(v) = v
                && !(v >= 0.0 && v.is_finite())
            {
                return Err(format!(
                    "{name} {v}: expected a limit, a finite number 0 or more"
                ));
            }
        }
        Ok(())
    }
}

/// Refuse an instrument file (`name`) without a tolerance box to draw from.
///
/// # Errors
/// The file has no `[tolerances]`.
pub fn check_box(instr: &Instrument, name: &str) -> Result<(), String> {
    if instr.tolerances.is_empty() {
        return Err(format!(
            "{name} has no [tolerances]; expected an instrument file with a tolerance box to draw from"
        ));
    }
    Ok(())
}

/// The instruments `units` are the study `plan`'s, each once: indices `0..instruments`.
///
/// # Errors
/// An index missing, repeated or beyond the plan.
pub fn check_units(plan: &Plan, units: &[Unit]) -> Result<(), String> {
    let mut seen = vec![false; usize::try_from(plan.instruments).unwrap_or(0)];
    for u in units {
        match usize::try_from(u.index).ok().and_then(|k| seen.get_mut(k)) {
            Some(s) if !*s => *s = true,
            Some(_) => return Err(format!("instrument {} is given twice", u.index)),
            None => {
                return Err(format!(
                    "instrument {} is beyond the plan's {}",
                    u.index, plan.instruments
                ));
            }
        }
    }
    match seen.iter().position(|s| !s) {
        Some(k) => Err(format!(
            "instrument {k} is missing: expected every index from 0 to {}",
            plan.instruments - 1
        )),
        None => Ok(()),
    }
}

/// A specification: each limit given is a bound on one figure; a limit left out (`null`)
/// is not checked.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Spec {
    /// Largest |scale-factor error|, ppm.
    pub sf_error_ppm: Option<f64>,
    /// Largest |bias|, cm/s².
    pub bias_cm_s2: Option<f64>,
    /// Largest departure from the fitted line, ppm of full scale.
    pub linearity_ppm_fs: Option<f64>,
    /// Largest gate-to-gate standard deviation at rest, cm/s².
    pub noise_cm_s2: Option<f64>,
    /// Smallest phase margin, degrees (R-890's design goal: 45).
    pub phase_margin_deg: Option<f64>,
    /// Smallest gain margin, dB (R-890's design goal: 6).
    pub gain_margin_db: Option<f64>,
}

impl Default for Spec {
    fn default() -> Self {
        Self {
            sf_error_ppm: None,
            bias_cm_s2: None,
            linearity_ppm_fs: None,
            noise_cm_s2: None,
            phase_margin_deg: Some(DEFAULT_PM_DEG),
            gain_margin_db: Some(DEFAULT_GM_DB),
        }
    }
}

/// One instrument drawn and run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Unit {
    /// Its index in the study (its random stream).
    pub index: u64,
    /// Its toleranced parameters, by the instrument file's key, in the file's units.
    pub parameters: BTreeMap<String, f64>,
    /// Seed of its pickoff noise.
    pub noise_seed: u64,
    /// The fitted slope of indicated against input, minus 1, ppm.
    pub sf_error_ppm: f64,
    /// The fitted line at zero input, cm/s² (output-referred: the indicated value, read
    /// with the nominal scale factor).
    pub bias_cm_s2: f64,
    /// The largest |mean indicated − fitted line| over the inputs, ppm of full scale.
    pub linearity_ppm_fs: f64,
    /// The standard deviation of the gates at the input nearest zero, cm/s².
    pub noise_cm_s2: f64,
    /// Phase margin of its linearised loop, degrees (`null` when the loop gain never
    /// crosses 1: no margin to read, and the instrument breaks a phase-margin limit).
    pub phase_margin_deg: Option<f64>,
    /// Gain margin, dB (`null` when the phase never reaches −180° below Nyquist: an
    /// unbounded margin, which meets any gain-margin limit).
    pub gain_margin_db: Option<f64>,
}

/// Instrument `index` of the study of `seed`: its parameters drawn uniformly inside the
/// box, then its pickoff noise's seed.
#[must_use]
pub fn draw(
    nominal: &Instrument,
    seed: u64,
    index: u64,
) -> (Instrument, BTreeMap<String, f64>, u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(index);
    let mut instr = nominal.clone();
    let mut parameters = BTreeMap::new();
    for t in &nominal.tolerances {
        let v = t.lo + (t.hi - t.lo) * rng.random::<f64>();
        // Every key comes from the file's own tolerance list, so `set` knows it.
        let _ = instr.set(t.key, v);
        parameters.insert(t.key.to_string(), v);
    }
    (instr, parameters, rng.random::<u64>())
}

/// The instruments `range` of the study `plan` of `nominal`, run by the batch engine: every
/// instrument at every input in one batch.
#[must_use]
pub fn units(nominal: &Instrument, opts: &SimOptions, plan: &Plan, range: Range<u64>) -> Vec<Unit> {
    let drawn: Vec<_> = range.clone().map(|k| draw(nominal, plan.seed, k)).collect();
    let fs = nominal.sf_cm_s2;
    let inputs: Vec<f64> = plan
        .fractions_of_full_scale
        .iter()
        .map(|f| f * fs)
        .collect();
    let jobs: Vec<RecordJob<'_>> = drawn
        .iter()
        .flat_map(|(instr, _, noise_seed)| {
            inputs.iter().map(move |&a| RecordJob {
                instr,
                seed: *noise_seed,
                accel_cm_s2: a,
                gate_accels_cm_s2: &[],
            })
        })
        .collect();
    let opts = SimOptions {
        warmup_s: plan.warmup_s,
        ..*opts
    };
    let ticks = gate_ticks(plan.gate_s, nominal.clock_hz);
    let counts = Engine::default().simulate_records(&jobs, &opts, ticks, plan.gates);
    drawn
        .into_par_iter()
        .zip(range.collect::<Vec<_>>())
        .zip(counts.par_chunks(inputs.len()))
        .map(|(((instr, parameters, noise_seed), index), counts)| {
            let m = margins(&instr, &opts.config);
            let f = figures(&inputs, counts, ticks, fs);
            Unit {
                index,
                parameters,
                noise_seed,
                sf_error_ppm: f.sf_error_ppm,
                bias_cm_s2: f.bias_cm_s2,
                linearity_ppm_fs: f.linearity_ppm_fs,
                noise_cm_s2: f.noise_cm_s2,
                phase_margin_deg: m.phase_margin_deg.is_finite().then_some(m.phase_margin_deg),
                gain_margin_db: m.gain_margin_db.is_finite().then_some(m.gain_margin_db),
            }
        })
        .collect()
}

/// The gate in whole clock ticks.
#[must_use]
pub fn gate_ticks(gate_s: f64, clock_hz: f64) -> u64 {
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let t = (gate_s * clock_hz).round() as u64;
    t
}

/// An instrument's line figures.
struct Figures {
    sf_error_ppm: f64,
    bias_cm_s2: f64,
    linearity_ppm_fs: f64,
    noise_cm_s2: f64,
}

/// The line through the mean indicated value (read with `sf_cm_s2`) at each input, and the
/// scatter of the gates at the input nearest zero.
fn figures(inputs: &[f64], counts: &[Vec<u32>], ticks: u64, sf_cm_s2: f64) -> Figures {
    let indicated = |c: &Vec<u32>| -> Vec<f64> {
        c.iter()
            .map(|&p| {
                Gate {
                    time_s: 0.0,
                    pulses: u64::from(p),
                    ticks,
                }
                .indicated_cm_s2(sf_cm_s2)
            })
            .collect()
    };
    let means: Vec<f64> = counts.iter().map(|c| mean(&indicated(c))).collect();
    let (x0, y0) = (mean(inputs), mean(&means));
    let sxx: f64 = inputs.iter().map(|x| (x - x0).powi(2)).sum();
    let sxy: f64 = inputs
        .iter()
        .zip(&means)
        .map(|(x, y)| (x - x0) * (y - y0))
        .sum();
    let slope = sxy / sxx;
    let bias = y0 - slope * x0;
    let worst = inputs
        .iter()
        .zip(&means)
        .map(|(x, y)| (y - bias - slope * x).abs())
        .fold(0.0, f64::max);
    let rest = inputs
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .map_or(0, |(k, _)| k);
    Figures {
        sf_error_ppm: (slope - 1.0) * 1e6,
        bias_cm_s2: bias,
        linearity_ppm_fs: worst / sf_cm_s2 * 1e6,
        noise_cm_s2: sd(&indicated(&counts[rest])),
    }
}

/// The mean (0 for none).
fn mean(v: &[f64]) -> f64 {
    #[allow(clippy::cast_precision_loss)]
    let n = v.len().max(1) as f64;
    v.iter().sum::<f64>() / n
}

/// The sample standard deviation (0 for fewer than two).
fn sd(v: &[f64]) -> f64 {
    if v.len() < 2 {
        return 0.0;
    }
    let m = mean(v);
    #[allow(clippy::cast_precision_loss)]
    let n = v.len() as f64;
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
}

/// Which limits of `spec` a unit breaks, by the figure's name.
#[must_use]
pub fn broken(spec: &Spec, u: &Unit) -> Vec<&'static str> {
    use std::cmp::Ordering::{Equal, Greater, Less};
    // A figure that is not a number (a gain margin never reached is +inf, which is fine)
    // breaks every limit on it.
    let above = |v: f64, lim: Option<f64>| {
        lim.is_some_and(|l| !matches!(v.abs().partial_cmp(&l), Some(Less | Equal)))
    };
    let below = |v: f64, lim: Option<f64>| {
        lim.is_some_and(|l| !matches!(v.partial_cmp(&l), Some(Greater | Equal)))
    };
    [
        ("sf_error_ppm", above(u.sf_error_ppm, spec.sf_error_ppm)),
        ("bias_cm_s2", above(u.bias_cm_s2, spec.bias_cm_s2)),
        (
            "linearity_ppm_fs",
            above(u.linearity_ppm_fs, spec.linearity_ppm_fs),
        ),
        ("noise_cm_s2", above(u.noise_cm_s2, spec.noise_cm_s2)),
        (
            "phase_margin_deg",
            below(
                u.phase_margin_deg.unwrap_or(f64::NAN),
                spec.phase_margin_deg,
            ),
        ),
        (
            "gain_margin_db",
            below(
                u.gain_margin_db.unwrap_or(f64::INFINITY),
                spec.gain_margin_db,
            ),
        ),
    ]
    .into_iter()
    .filter(|(_, b)| *b)
    .map(|(n, _)| n)
    .collect()
}

/// One figure's distribution over the instruments that have it (a margin that is `null`
/// is left out).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Distribution {
    /// Instruments counted (those with a finite value).
    pub n: u64,
    /// Smallest.
    pub min: f64,
    /// 5th percentile (nearest rank).
    pub p05: f64,
    /// Median (nearest rank, the upper middle of an even count).
    pub median: f64,
    /// 95th percentile (nearest rank).
    pub p95: f64,
    /// Largest.
    pub max: f64,
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation.
    pub sd: f64,
}

impl Distribution {
    /// The distribution of `v` (finite values only).
    fn of(v: &[f64]) -> Self {
        let mut s: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
        s.sort_by(f64::total_cmp);
        let at = |q: f64| -> f64 {
            if s.is_empty() {
                return f64::NAN;
            }
            #[allow(
                clippy::cast_possible_truncation,
                clippy::cast_sign_loss,
                clippy::cast_precision_loss
            )]
            let k = ((q * s.len() as f64).ceil() as usize).clamp(1, s.len());
            s[k - 1]
        };
        Self {
            n: s.len() as u64,
            min: at(0.0),
            p05: at(0.05),
            median: s.get(s.len() / 2).copied().unwrap_or(f64::NAN),
            p95: at(0.95),
            max: s.last().copied().unwrap_or(f64::NAN),
            mean: mean(&s),
            sd: sd(&s),
        }
    }
}

/// What `ptsa monte-carlo --yield N --json` prints.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct YieldJson {
    /// What was run and the specification.
    pub plan: Plan,
    /// The nominal full scale the inputs are fractions of, cm/s².
    pub full_scale_cm_s2: f64,
    /// The toleranced parameters and their limits, by key: `[lo, nominal, hi]`.
    pub box_limits: BTreeMap<String, [f64; 3]>,
    /// Instruments that meet every limit of the specification.
    pub within_spec: u64,
    /// `within_spec / instruments`.
    pub yield_fraction: f64,
    /// The yield's 95 % Clopper–Pearson interval, `[lo, hi]`.
    pub yield_ci95: [f64; 2],
    /// How many instruments break each limit, by figure.
    pub broken: BTreeMap<String, u64>,
    /// Each figure's distribution over the instruments, by figure.
    pub distributions: BTreeMap<String, Distribution>,
    /// Every instrument, by index.
    pub units: Vec<Unit>,
}

/// One figure of a unit.
type Figure = fn(&Unit) -> f64;

/// The study's report from its instruments (in any order; sorted by index here). It takes
/// them over, so that a large study is held once.
#[must_use]
pub fn summary(nominal: &Instrument, plan: &Plan, mut units: Vec<Unit>) -> YieldJson {
    units.sort_by_key(|u| u.index);
    let mut broken_by: BTreeMap<String, u64> = BTreeMap::new();
    let mut within = 0;
    for u in &units {
        let b = broken(&plan.spec, u);
        if b.is_empty() {
            within += 1;
        }
        for name in b {
            *broken_by.entry(name.to_string()).or_default() += 1;
        }
    }
    let n = units.len() as u64;
    let figures: [(&str, Figure); 6] = [
        ("sf_error_ppm", |u| u.sf_error_ppm),
        ("bias_cm_s2", |u| u.bias_cm_s2),
        ("linearity_ppm_fs", |u| u.linearity_ppm_fs),
        ("noise_cm_s2", |u| u.noise_cm_s2),
        ("phase_margin_deg", |u| {
            u.phase_margin_deg.unwrap_or(f64::NAN)
        }),
        ("gain_margin_db", |u| {
            u.gain_margin_db.unwrap_or(f64::INFINITY)
        }),
    ];
    let distributions = figures
        .iter()
        .map(|(name, f)| {
            let v: Vec<f64> = units.iter().map(f).collect();
            ((*name).to_string(), Distribution::of(&v))
        })
        .collect();
    #[allow(clippy::cast_precision_loss)]
    let fraction = within as f64 / n.max(1) as f64;
    let (lo, hi) = crate::stats::clopper_pearson(within, n, 0.95);
    YieldJson {
        plan: plan.clone(),
        full_scale_cm_s2: nominal.sf_cm_s2,
        box_limits: nominal
            .tolerances
            .iter()
            .map(|t| (t.key.to_string(), [t.lo, t.nominal, t.hi]))
            .collect(),
        within_spec: within,
        yield_fraction: fraction,
        yield_ci95: [lo, hi],
        broken: broken_by,
        distributions,
        units,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(instruments: u64, gate_s: f64) -> Plan {
        Plan {
            instruments,
            seed: 7,
            fractions_of_full_scale: DEFAULT_FRACTIONS.to_vec(),
            gate_s,
            gates: 8,
            warmup_s: 0.2,
            spec: Spec::default(),
        }
    }

    fn opts(instr: &Instrument) -> SimOptions {
        SimOptions {
            config: crate::model::design::check_loop(instr).unwrap().config,
            ..SimOptions::default()
        }
    }

    #[test]
    fn an_instrument_is_the_same_whichever_piece_of_the_study_runs_it() {
        let i = Instrument::kearfott_2401();
        let (p, o) = (plan(6, 0.01), opts(&Instrument::kearfott_2401()));
        let whole = units(&i, &o, &p, 0..6);
        let mut pieces = units(&i, &o, &p, 4..6);
        pieces.extend(units(&i, &o, &p, 0..4));
        assert_eq!(summary(&i, &p, whole.clone()), summary(&i, &p, pieces));
        assert_ne!(whole[0].parameters, whole[1].parameters);
    }

    #[test]
    fn the_scale_factor_error_is_the_nominal_over_the_drawn_full_scale() {
        // A drawn torquer current or scale changes the full scale g·I/k; the counts read
        // with the nominal scale factor then give indicated = input · SF_nominal/SF_drawn.
        let i = Instrument::kearfott_2401();
        let p = plan(6, 0.5);
        let us = units(&i, &opts(&i), &p, 0..6);
        let mut spread: f64 = 0.0;
        for u in &us {
            let (drawn, _, _) = draw(&i, p.seed, u.index);
            let want = (i.sf_cm_s2 / drawn.actual_sf_cm_s2() - 1.0) * 1e6;
            spread = spread.max(want.abs());
            assert!(
                (u.sf_error_ppm - want).abs() < 100.0,
                "{}: {} against {want}",
                u.index,
                u.sf_error_ppm
            );
        }
        assert!(
            spread > 1000.0,
            "the box moves the full scale: {spread} ppm"
        );
    }

    #[test]
    fn a_margin_that_is_not_a_number_is_null_read_back_and_judged() {
        let u = Unit {
            index: 0,
            parameters: BTreeMap::new(),
            noise_seed: 1,
            sf_error_ppm: 10.0,
            bias_cm_s2: 0.5,
            linearity_ppm_fs: 3.0,
            noise_cm_s2: 0.1,
            phase_margin_deg: None,
            gain_margin_db: None,
        };
        let back: Unit = serde_json::from_str(&serde_json::to_string(&u).unwrap()).unwrap();
        assert_eq!(back, u);
        // No crossover: no phase margin to meet the limit with; no -180°: any gain margin.
        assert_eq!(broken(&Spec::default(), &u), vec!["phase_margin_deg"]);
        let p = plan(1, 0.01);
        let y = summary(&Instrument::kearfott_2401(), &p, vec![u]);
        assert_eq!(y.distributions["gain_margin_db"].n, 0);
        assert_eq!(y.within_spec, 0);
    }

    #[test]
    fn a_plan_and_its_pieces_are_checked() {
        let mut p = plan(4, 0.01);
        assert!(p.check().is_ok());
        p.fractions_of_full_scale = vec![0.5, 0.5];
        assert!(p.check().unwrap_err().contains("two different inputs"));
        let mut p = plan(4, 0.01);
        p.gates = 1;
        assert!(p.check().unwrap_err().starts_with("gates 1"));
        let i = Instrument::kearfott_2401();
        let p = plan(3, 0.01);
        let us = units(&i, &opts(&i), &p, 0..3);
        assert!(check_units(&p, &us).is_ok());
        assert!(
            check_units(&p, &us[..2])
                .unwrap_err()
                .contains("instrument 2 is missing")
        );
        let twice = [us[0].clone(), us[0].clone(), us[1].clone()];
        assert!(check_units(&p, &twice).unwrap_err().contains("given twice"));
    }
}
