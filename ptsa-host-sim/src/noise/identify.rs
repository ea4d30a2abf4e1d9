//! What the simulation gets wrong about noise (`ptsa noise --counts FILE --identify`): the
//! measured Allan variance modelled as the simulated loop's, with the candidate noises
//! **inside** the loop, at the record's gate, length and mean; each candidate tested under
//! Holm's step-down at 5 % familywise.
//!
//! The model, at each octave τ the measured record has:
//!
//! ```text
//! AVAR_measured(τ) = AVAR_sim(τ; u, N, K)
//! ```
//!
//! `AVAR_sim(τ; u, N, K)` is the Allan variance of the instrument file's loop simulated at
//! rest for as long as the record, at the acceleration along IA that gives its mean (as
//! `--compare`), averaged over [`SEEDS`] records (seeds `seed + s`), with
//!
//! * `u`, the pickoff noise `noise_uv_rms` (µV rms), at [`PICKOFF_GRID_UV`] and the file's
//!   own value;
//! * `N`, a white acceleration noise (cm/s²/√Hz, two-sided: `N²/τ` alone) and `K`, a bias
//!   random walk (cm/s²·√Hz: `K²τ/3` alone), **entering the plant's input** along IA, held
//!   over each gate ([`super::InputNoise`]): the loop counts them, so they dither its count
//!   pattern as they would in the instrument. Their grid is set by the record: `N²` at
//!   [`WHITE_FRACTIONS`] of the largest `N²` its curve allows (`min τ·hi²`, `hi` the upper
//!   end of each τ's 95 % interval), `K²` at [`WALK_FRACTIONS`] of `min 3·hi²/τ`,
//!
//! interpolated multilinearly in `(u², N², K²)` (noise powers) between the grid's nodes, τ
//! by τ. Nodes are simulated when a step needs them, all of a step's at once on the batch
//! engine (lanes of their own instrument, seed and input accelerations), the same seeds at
//! every node (common random numbers: the interpolation is smooth in the noises), drawn
//! from the seed given mixed with the record's counts ([`record_seed`]). Each
//! record's Allan variance has its drawn input's own Allan variance replaced by that
//! variance's expectation ([`InputNoise::expected_avar`], a control variate: what is left
//! varies as the loop does, not as one draw of `N` and `K`), and each seed's input sits
//! at the measured mean moved by a fixed draw times the mean's own error (the added
//! noises' [`InputNoise::mean_sd`] and the counting's): the count pattern depends on the
//! input, which the record gives only to that error.
//!
//! A record longer than [`LOOP_GATES`] has its records simulated shortened: the loop for
//! its first [`LOOP_GATES`] gates, its part carried beyond as white phase noise, the added
//! noises drawn for the whole length (`Grid::points`).
//!
//! The points are compared on the log scale: the residuals `ln M − ln S` (measured,
//! simulated mean), each log's bias (half its variance) taken out, `χ² = rᵀ C⁻¹ r` with `C`
//! their covariance across the τ: a parametric bootstrap, [`REPLICAS`] records simulated
//! at the noises fitted so far (the correlations between τ shrunk halfway to none), held
//! fixed while a profile compares values and re-evaluated at the fit until it settles.
//! Neither the chi-squared EDF of the record's own noise type nor independent octave
//! points describe a loop's record: its count pattern repeats from record to record far
//! closer than a random noise's EDF says at short τ, varies more in the middle, and where
//! the added noises dominate their few degrees of freedom and the overlap of the long τ
//! rule (measured in docs/method/noise.md).
//!
//! The candidates are selected forward with Holm's thresholds (as discover selects): at
//! step `j` each candidate left is tested given those already selected by the drop of the
//! profiled `χ²` it brings (the noises selected free on the grid, the others at the file's
//! loop: `u` the file's, `N = K = 0`): for `N` and `K`, which cannot be negative, `z = √Δχ²`
//! against the one-sided normal (half a χ²₁); for the pickoff noise, `Δχ²` against χ²₁. The
//! most significant is selected if its p is at most [`ALPHA`]`/(3 − j)`; the first that is
//! not ends the selection. The selected ones are fitted together on a mesh of their values,
//! with the bias random walk free beside them where it was not selected (a nuisance, never
//! reported: a walk too weak to be selected still lifts the longest τ), and each reported
//! with its profile's 95 % interval: the values whose `χ²`, minimised over the others (the
//! walk included), is within `t²·s·b²` of the minimum. `b` is the joint fit's Birge ratio
//! `√(χ²/dof)` when above 1. `s` (`Grid::interval_scales`) is the sandwich variance of the
//! weighted fit over the variance the profile assumes, with the covariance of [`REPLICAS`]
//! records simulated at the fit apart from the weights' (their own seeds), and `t` Student's
//! two-sided 95 % point for their `REPLICAS − 1` degrees of freedom: weights estimated from
//! 24 records are noisy, and a fit weighted by a noisy inverse covariance varies more than
//! its own `χ²` says (the profile's `3.84·b²` held the value in 273 of 300 campaign records;
//! `scripts/interval_model.py` shows the same in a linear model, docs/method/noise.md). A selected
//! white noise or walk whose interval reaches its grid's top gets nodes above it
//! ([`ABOVE_TOP`], at most [`EXTENSIONS`] times) and is fitted again; an interval that
//! still reaches the top is open above.
#![allow(
    clippy::cast_precision_loss,
    reason = "gate counts and grid indices, far below 2^52, as f64"
)]

use std::collections::HashMap;

use statrs::distribution::{ContinuousCDF as _, Normal};

use super::allan;
use super::terms::Term;
use super::{Analysis, InputNoise, Record};
use crate::model::instrument::Instrument;
use crate::simulation::batch::{Engine, RecordJob};
use crate::simulation::sim::SimOptions;

/// The pickoff noises the loop is simulated at, µV rms (the file's own value is added).
pub const PICKOFF_GRID_UV: [f64; 6] = [0.0, 0.5, 1.0, 2.0, 4.0, 8.0];

/// The white acceleration noise's grid: `N²` as fractions of the record's largest.
pub const WHITE_FRACTIONS: [f64; 8] = [
    0.0,
    1.0 / 256.0,
    1.0 / 64.0,
    1.0 / 16.0,
    0.125,
    0.25,
    0.5,
    1.0,
];

/// The bias random walk's grid: `K²` as fractions of the record's largest.
pub const WALK_FRACTIONS: [f64; 6] = [0.0, 1.0 / 64.0, 1.0 / 16.0, 0.25, 0.5, 1.0];

/// The nodes added above a white noise's or a walk's grid when its interval reaches the
/// top: `N²` (`K²`) at these multiples of the top.
pub const ABOVE_TOP: [f64; 2] = [2.0, 4.0];

/// Times a grid is extended by [`ABOVE_TOP`] at most (its top then 16 times the record's
/// largest `N²`, `K²`).
pub const EXTENSIONS: usize = 2;

/// Simulated records averaged at each node of the grid (seeds `seed`, `seed + 1`, …).
pub const SEEDS: u64 = 2;

/// The model and the test, in words (`--json`'s `identification.test`).
pub const TEST: &str = "AVAR_measured = AVAR_sim(noise_uv_rms, N, K): the loop simulated with the pickoff noise and with N (white acceleration noise) and K (bias random walk) entering the plant's input, averaged over seeds_per_node records, multilinear in the squares between the grid's nodes; the grid's records with their drawn input's own Allan variance replaced by its expectation, their inputs spread over the measured mean's error; compared as ln AVAR with each log's bias (half its variance) taken out, chi2 = r' C^-1 r with C the covariance of ln AVAR across the tau of records simulated at the noises fitted so far (correlations shrunk by half, re-evaluated until the fit settles); forward selection with Holm thresholds (0.05/3, 0.05/2, 0.05): each candidate left tested given those selected by its drop of the profiled chi2 (N, K: its root, one-sided normal; pickoff: against chi2(1)); 95 % intervals from the joint profile: the values whose profiled chi2 is within t^2 s b^2 of its least, t Student's two-sided 95 % point for the check's replicas less one degree of freedom, s (interval_scale, over 3.84 b^2) the sandwich variance of the weighted fit over the variance the profile assumes, with the covariance of records simulated at the fit apart from the weights', b the joint fit's Birge ratio above 1";

/// Records simulated at most by one identification, for the work estimate: every node of
/// the grid, [`SEEDS`] each, and the weights' [`REPLICAS`] at the file's loop and at each
/// re-evaluation of a fit (one settled fit per step and the joint fit, each at most
/// [`REWEIGHTS`]` + 1` times).
pub const MAX_RECORDS: u64 = (PICKOFF_GRID_UV.len() as u64 + 1)
    * (WHITE_FRACTIONS.len() + EXTENSIONS * ABOVE_TOP.len()) as u64
    * (WALK_FRACTIONS.len() + EXTENSIONS * ABOVE_TOP.len()) as u64
    * SEEDS
    + (1 + (KINDS.len() + 1 + EXTENSIONS) as u64 * (REWEIGHTS as u64 + 1)) * REPLICAS
    + (1 + EXTENSIONS as u64) * REPLICAS;

/// The longest record the loop is simulated for, gates (2¹³: 82 s of 10 ms gates). A
/// longer record's simulated records run the loop for this many gates and take the rest from
/// the loop's physics (`Grid::points`): the counts integrate the input to within the
/// charge the loop holds, which is bounded, so beyond the count pattern's own time scale the
/// loop adds to the Allan variance a part that falls as `1/τ²` (white phase noise), while the
/// input's noises (`N`, `K`) are drawn for the record's whole length without the loop.
pub const LOOP_GATES: u64 = 1 << 13;

/// A shortened simulation's loop part is read up to `m ≤ gates / LOOP_SPLIT` (16 averaging
/// windows at least) and carried beyond as `1/τ²` from there.
pub const LOOP_SPLIT: usize = 4;

/// The octaves below the split whose loop part, as `L·m²`, sets its level beyond
/// (`Grid::points`).
pub const LOOP_TAIL_OCTAVES: usize = 4;

/// Mesh points per free noise in the profile: one, two or three noises free.
const MESH: [usize; 3] = [321, 241, 49];

/// Lanes per call of the batch engine (bounds the input accelerations held at once).
const JOBS_PER_CALL: usize = 16;

/// Familywise level of the candidates' Holm step-down.
pub const ALPHA: f64 = 0.05;

/// Times the joint fit's weights are re-evaluated at its values at most.
pub const REWEIGHTS: usize = 4;

/// Records simulated at a point of the noises for the weights (the covariance of the
/// points' `ln AVAR`; module docs).
pub const REPLICAS: u64 = 24;

/// Added to the seed for the weights' records (apart from the grid's).
const REPLICA_SEED: u64 = 0x005E_ED0F_A11A;

/// How much of the replicas' correlation between two τ is kept (the rest shrunk to 0).
pub const SHRINK: f64 = 0.5;

/// Added to the seed for the records that check the fit's intervals ([`Grid::spread`]),
/// apart from the grid's and the weights'.
const CHECK_SEED: u64 = 0x00C4_EC4E_D5EE;

/// Mixed into the seed for the grid's input offsets.
const GRID_SEED: u64 = 0x6121_D5EE_D000;

/// The least variance of a τ's `ln AVAR` (a 1 % deviation): at short τ the count pattern
/// repeats to a part in a thousand from record to record, closer than the grid's
/// interpolation between its nodes can follow.
const MIN_LOG_VARIANCE: f64 = 1e-4;

/// `χ²₁(0.95)`: the profile's 95 % interval.
const CHI2_1_95: f64 = 3.841_458_820_694_124;

/// The intervals' level.
const INTERVAL_LEVEL: f64 = 0.95;

/// A candidate beyond the simulated loop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// White acceleration noise `N` at the plant's input (alone, AVAR = N²/τ).
    WhiteAcceleration,
    /// Bias random walk `K` at the plant's input (alone, AVAR = K²τ/3).
    RandomWalk,
    /// The pickoff noise `noise_uv_rms` other than the file's.
    Pickoff,
}

impl Kind {
    /// Its JSON key.
    #[must_use]
    pub fn key(self) -> &'static str {
        match self {
            Kind::WhiteAcceleration => "white_acceleration",
            Kind::RandomWalk => "bias_random_walk",
            Kind::Pickoff => "pickoff_noise",
        }
    }

    /// The noise term of [`super::terms`] it is, for `N` and `K`.
    #[must_use]
    pub fn term(self) -> Option<Term> {
        match self {
            Kind::WhiteAcceleration => Some(Term::VelocityRandomWalk),
            Kind::RandomWalk => Some(Term::AccelerationRandomWalk),
            Kind::Pickoff => None,
        }
    }

    /// Its units and the factor from the first (cgs, or µV for the pickoff noise).
    #[must_use]
    pub fn units(self) -> Vec<(&'static str, f64)> {
        self.term()
            .map_or_else(|| vec![("uV rms", 1.0)], Term::units)
    }
}

/// All candidates, in the report's order.
pub const KINDS: [Kind; 3] = [Kind::WhiteAcceleration, Kind::RandomWalk, Kind::Pickoff];

/// One candidate's test and, when selected, its value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// Which.
    pub kind: Kind,
    /// Its test statistic at the last step it was tested: `z = √Δχ²` for `N` and `K`, `Δχ²`
    /// for the pickoff noise.
    pub statistic: f64,
    /// Its p-value.
    pub p: f64,
    /// Selected by Holm's step-down at [`ALPHA`].
    pub selected: bool,
    /// When selected: the value and its 95 % interval, in the first unit of
    /// [`Kind::units`] (`N` in cm/s²/√Hz, `K` in cm/s²·√Hz, the pickoff noise in µV).
    pub value: Option<(f64, f64, f64)>,
    /// The interval reaches the grid's top (open above).
    pub open_above: bool,
    /// When selected: the factor its interval's threshold was of the profile's own
    /// `3.84·b²`, `t²·s/3.84` (the module's docs; 1 where `s` was not computed).
    pub interval_scale: f64,
}

/// The identification.
#[derive(Clone, Debug)]
pub struct Identification {
    /// The acceleration along IA simulated, cm/s².
    pub input_cm_s2: f64,
    /// The file's pickoff noise, µV.
    pub file_uv: f64,
    /// The pickoff noises of the grid, µV (sorted).
    pub grid_uv: Vec<f64>,
    /// The white acceleration noises of the grid, cm/s²/√Hz.
    pub grid_white: Vec<f64>,
    /// The bias random walks of the grid, cm/s²·√Hz.
    pub grid_walk: Vec<f64>,
    /// Records simulated (nodes × [`SEEDS`], and [`REPLICAS`] for each point the weights
    /// or the intervals' check were evaluated at).
    pub simulated_records: usize,
    /// The octave τ used, s.
    pub taus: Vec<f64>,
    /// Gates each simulated record ran the loop for: the record's own, or [`LOOP_GATES`]
    /// for a longer record.
    pub simulated_gates: u64,
    /// For a record longer than [`LOOP_GATES`]: the longest τ, s, whose loop part was
    /// simulated; beyond it the loop's part is carried as `1/τ²` ([`LOOP_GATES`]).
    pub loop_split_tau_s: Option<f64>,
    /// `χ²` of the file's loop alone, and its degrees of freedom (the τ).
    pub chi2_file: f64,
    /// The candidates in [`KINDS`]' order.
    pub candidates: Vec<Candidate>,
}

impl Identification {
    /// The candidate of `kind`.
    #[must_use]
    pub fn get(&self, kind: Kind) -> Option<&Candidate> {
        self.candidates.iter().find(|c| c.kind == kind)
    }
}

/// A node of the grid: indices into the pickoff, white and walk axes.
type Node = [usize; 3];

/// The grid, its simulated nodes, and the measured points.
struct Grid<'a> {
    instr: &'a Instrument,
    opts: &'a SimOptions,
    input_cm_s2: f64,
    gate_ticks: u64,
    gates: u64,
    /// Gates the loop is simulated for: the record's, at most [`LOOP_GATES`] (or what the
    /// caller set).
    loop_gates: u64,
    tau0_s: f64,
    /// The error the counting leaves in the record's mean, cm/s²: the charge the loop
    /// holds at either end, up to a pulse each, over the record's span (`pulse/(T·√6)`, the
    /// difference of two uniform fractions of a pulse).
    counting_sd_cm_s2: f64,
    /// The measured record's τ: (m, τ, AVAR).
    measured: Vec<(usize, f64, f64)>,
    /// The axes' values: u (µV), N (cm/s²/√Hz), K (cm/s²·√Hz).
    axes: [Vec<f64>; 3],
    /// The file's node (its pickoff noise, no N, no K).
    base: Node,
    /// Per node, per measured τ: the simulated mean AVAR (all seeds, control variate).
    curves: HashMap<Node, Vec<f64>>,
    /// Per point of the noises (their bits): the weights.
    weights: HashMap<[u64; 3], Weights>,
    /// Per point of the noises (their bits): the covariance the intervals are checked
    /// against ([`Grid::spread`]).
    spreads: HashMap<[u64; 3], Vec<f64>>,
}

/// One simulated record: the loop with a pickoff noise of `uv` µV rms and `noise` at its
/// input around `input_cm_s2`, the pickoff noise drawn from `seed`, the input noise from
/// `!seed`.
#[derive(Clone, Copy)]
struct Lane {
    uv: f64,
    noise: InputNoise,
    input_cm_s2: f64,
    seed: u64,
}

/// How the points are weighed: each τ's bias correction of `ln M − ln S` (half the
/// difference of the logs' variances) and the inverse of their covariance across the τ.
#[derive(Clone, Debug, PartialEq)]
struct Weights {
    /// Per τ: the bias of `ln M − ln S` to take out.
    bias: Vec<f64>,
    /// The inverse covariance of `ln M − ln S` over the τ, row-major.
    inverse: Vec<f64>,
}

impl Weights {
    /// Independent points: variances `measured` of `ln M` and `simulated` of `ln S`.
    #[cfg(test)]
    fn diagonal(measured: &[f64], simulated: &[f64]) -> Self {
        let n = measured.len();
        let mut inverse = vec![0.0; n * n];
        for k in 0..n {
            inverse[k * n + k] = 1.0 / (measured[k] + simulated[k]);
        }
        Self {
            bias: measured
                .iter()
                .zip(simulated)
                .map(|(m, s)| (m - s) / 2.0)
                .collect(),
            inverse,
        }
    }
}

impl Grid<'_> {
    /// The records of `lanes`, on the batch engine: per lane, per measured τ, the Allan
    /// variance of its counts and the same with the control variate (the drawn input's own
    /// Allan variance out, its expectation in: what is left varies as the loop does, not as
    /// one draw of the added noises). With `whole`, a shortened simulation's first value is
    /// the record's at its whole length ([`Grid::points`]); without, both are the control
    /// variate's (only that is read).
    fn simulate(&self, lanes: &[Lane], whole: bool) -> Vec<Vec<(f64, f64)>> {
        use rayon::prelude::*;
        let sim_gates = self.gates.min(self.loop_gates);
        let drawn_gates = if whole { self.gates } else { sim_gates };
        let looped = usize::try_from(sim_gates).unwrap_or(usize::MAX);
        let mut out = Vec::with_capacity(lanes.len());
        for chunk in lanes.chunks(JOBS_PER_CALL) {
            let instrs: Vec<Instrument> = chunk
                .iter()
                .map(|l| {
                    let mut i = self.instr.clone();
                    i.noise_v_rms = l.uv * 1e-6;
                    i
                })
                .collect();
            let accels: Vec<Vec<f64>> = chunk
                .par_iter()
                .map(|l| {
                    l.noise
                        .gate_accels(l.input_cm_s2, self.tau0_s, drawn_gates, !l.seed)
                })
                .collect();
            let jobs: Vec<RecordJob<'_>> = chunk
                .iter()
                .zip(&instrs)
                .zip(&accels)
                .map(|((l, instr), a)| RecordJob {
                    instr,
                    seed: l.seed,
                    accel_cm_s2: l.input_cm_s2,
                    gate_accels_cm_s2: &a[..a.len().min(looped)],
                })
                .collect();
            let counts =
                Engine::default().simulate_records(&jobs, self.opts, self.gate_ticks, sim_gates);
            out.par_extend(
                chunk
                    .par_iter()
                    .zip(&counts)
                    .zip(&accels)
                    .map(|((l, c), input)| self.points(l, c, input)),
            );
        }
        out
    }

    /// One simulated record's points: per measured τ, its Allan variance and its control
    /// variate's. A record simulated whole gives them as they are. A shortened one (the
    /// loop run for [`Grid::loop_gates`]) gives the loop's part `L(m)`, the counts' Allan
    /// variance less the drawn input's over the simulated gates, up to the split `m_s`
    /// (the longest τ with [`LOOP_SPLIT`] windows in them), and `c/m²` beyond, `c` the
    /// geometric mean of `L·m²` over the last [`LOOP_TAIL_OCTAVES`] octaves up to `m_s`;
    /// the control variate is `L(m)` plus the input's expected Allan variance, and the record's
    /// own value `L(m)` plus the Allan variance of the input drawn for the whole length
    /// (when it was: `input` as long as the record).
    fn points(&self, l: &Lane, counts: &[u32], input: &[f64]) -> Vec<(f64, f64)> {
        let y: Vec<f64> = super::record_gates(counts, self.gate_ticks, self.instr.clock_hz)
            .iter()
            .map(|g| g.indicated_cm_s2(self.instr.sf_cm_s2))
            .collect();
        let counted = allan::Sums::new(&y);
        let drawn = allan::Sums::new(&input[..input.len().min(y.len())]);
        let avar = |s: &allan::Sums, m: usize| s.avar(m).map_or(f64::NAN, |x| x.0);
        if y.len() as u64 == self.gates {
            return self
                .measured
                .iter()
                .map(|&(m, ..)| {
                    let a = avar(&counted, m);
                    let cv = match drawn.avar(m) {
                        Some((d, _)) if !input.is_empty() => {
                            (a - d + l.noise.expected_avar(self.tau0_s, m)).max(a * 1e-6)
                        }
                        _ => a,
                    };
                    (a, cv)
                })
                .collect();
        }
        let loop_part = |m: usize| {
            if input.is_empty() {
                avar(&counted, m)
            } else {
                avar(&counted, m) - avar(&drawn, m)
            }
        };
        let simulated: Vec<usize> = self
            .measured
            .iter()
            .map(|&(m, ..)| m)
            .filter(|&m| m * LOOP_SPLIT <= y.len())
            .collect();
        let split = simulated.last().copied();
        // `L·m²` over the last octaves simulated, their geometric mean: the count pattern's
        // part swings by a factor of about 8 between its tones' drops (docs/method/noise.md).
        let tail: Vec<f64> = simulated
            .iter()
            .rev()
            .take(LOOP_TAIL_OCTAVES)
            .map(|&m| loop_part(m) * (m as f64).powi(2))
            .filter(|x| *x > 0.0)
            .map(f64::ln)
            .collect();
        let level = if tail.is_empty() {
            0.0
        } else {
            (tail.iter().sum::<f64>() / tail.len() as f64).exp()
        };
        let record = (input.len() as u64 == self.gates).then(|| allan::Sums::new(input));
        self.measured
            .iter()
            .map(|&(m, ..)| {
                let part = match split {
                    Some(s) if m <= s => loop_part(m),
                    Some(_) => level / (m as f64).powi(2),
                    None => f64::NAN,
                };
                let expected = l.noise.expected_avar(self.tau0_s, m);
                let cv = (part + expected).max((part.abs() + expected) * 1e-6);
                let a = record.as_ref().map_or(cv, |r| {
                    let d = avar(r, m);
                    (d + part).max((d + part.abs()) * 1e-6)
                });
                (a, cv)
            })
            .collect()
    }

    /// Simulate the nodes not yet simulated, all at once: [`SEEDS`] records each (seeds
    /// `seed + s`, the same at every node), their control-variate Allan variances averaged.
    /// The count pattern at rest depends on the input (the fraction of a pulse a gate
    /// leaves over), and the record's true input is known only to its mean's error: each
    /// seed's input is the measured mean moved by a fixed draw times that error at the
    /// node (the added noises' [`InputNoise::mean_sd`] and the counting's), so that the
    /// curve is the pattern's expectation over where the input may be, not its value at
    /// the measured mean.
    fn ensure(&mut self, nodes: &[Node]) {
        let mut todo: Vec<Node> = nodes
            .iter()
            .copied()
            .filter(|n| !self.curves.contains_key(n))
            .collect();
        todo.sort_unstable();
        todo.dedup();
        if todo.is_empty() {
            return;
        }
        let (axes, seed, input) = (&self.axes, self.opts.seed, self.input_cm_s2);
        let counting_sd = self.counting_sd_cm_s2;
        let span = self.gates as f64 * self.tau0_s;
        let offsets = standard_normals(SEEDS, seed ^ GRID_SEED);
        let lanes: Vec<Lane> = todo
            .iter()
            .flat_map(|n| {
                let noise = InputNoise {
                    white_cm_s2_rthz: axes[1][n[1]],
                    walk_cm_s2_rthz: axes[2][n[2]],
                };
                let sd = noise.mean_sd(span).hypot(counting_sd);
                offsets.iter().zip(0..).map(move |(&z, s)| Lane {
                    uv: axes[0][n[0]],
                    noise,
                    input_cm_s2: input + sd * z,
                    seed: seed.wrapping_add(s),
                })
            })
            .collect();
        let records = self.simulate(&lanes, false);
        for (n, seeds) in todo
            .into_iter()
            .zip(records.chunks(usize::try_from(SEEDS).unwrap_or(1)))
        {
            let mean = (0..self.measured.len())
                .map(|k| seeds.iter().map(|r| r[k].1).sum::<f64>() / SEEDS as f64)
                .collect();
            self.curves.insert(n, mean);
        }
    }

    /// The weights at the noises `values` (u, N, K), from [`REPLICAS`] records simulated
    /// there (seeds apart from the grid's), each around the measured mean moved by a draw
    /// of that mean's own error (as [`Grid::ensure`]): the record's `ln M` varies across the
    /// τ as theirs do (their covariance, the correlations shrunk by [`SHRINK`]); the
    /// simulated mean's `ln S`, of [`SEEDS`] records with the control variate, as theirs
    /// with it over [`SEEDS`] (on the diagonal). A parametric bootstrap: the loop's count
    /// pattern, dithered by the noises, varies far from as a chi-squared EDF says (less at
    /// short τ, more in the middle), and where the added noises dominate their few degrees
    /// of freedom and the overlap of the long τ rule.
    fn weights(&mut self, values: [f64; 3]) -> Weights {
        let key = values.map(f64::to_bits);
        if let Some(w) = self.weights.get(&key) {
            return w.clone();
        }
        let (measured, simulated) = self.replicas(values, REPLICA_SEED);
        let n = self.measured.len();
        let var = |c: &[f64], k: usize| c[k * n + k].max(MIN_LOG_VARIANCE);
        // The record's covariance: the replicas' correlations shrunk halfway to none (24
        // records estimate them roughly), on their variances; the simulated mean's
        // variances over the seeds, its points taken as independent.
        let mut total = nalgebra::DMatrix::<f64>::zeros(n, n);
        for a in 0..n {
            for b in 0..n {
                let sd = (var(&measured, a) * var(&measured, b)).sqrt();
                let rho = if a == b {
                    1.0
                } else {
                    SHRINK * measured[a * n + b]
                        / (measured[a * n + a] * measured[b * n + b])
                            .sqrt()
                            .max(f64::MIN_POSITIVE)
                };
                total[(a, b)] = rho * sd;
            }
            total[(a, a)] += var(&simulated, a) / SEEDS as f64;
        }
        let inverse = total.clone().try_inverse().unwrap_or_else(|| {
            nalgebra::DMatrix::from_diagonal(&total.diagonal().map(|v| 1.0 / v))
        });
        let w = Weights {
            bias: (0..n)
                .map(|k| (var(&measured, k) - var(&simulated, k) / SEEDS as f64) / 2.0)
                .collect(),
            inverse: (0..n * n).map(|i| inverse[(i / n, i % n)]).collect(),
        };
        self.weights.insert(key, w.clone());
        w
    }

    /// [`REPLICAS`] records simulated at the noises `values` (u, N, K), seeds apart from
    /// the grid's by `offset`, each around the measured mean moved by a draw of that mean's
    /// own error (as [`Grid::ensure`]): the covariance across the τ of their `ln M` and of
    /// their control-variate `ln S`, row-major (divisor `REPLICAS − 1`).
    fn replicas(&self, values: [f64; 3], offset: u64) -> (Vec<f64>, Vec<f64>) {
        let noise = InputNoise {
            white_cm_s2_rthz: values[1],
            walk_cm_s2_rthz: values[2],
        };
        let sd = noise
            .mean_sd(self.gates as f64 * self.tau0_s)
            .hypot(self.counting_sd_cm_s2);
        let lanes: Vec<Lane> = standard_normals(REPLICAS, self.opts.seed ^ offset)
            .into_iter()
            .zip(0..)
            .map(|(z, r)| Lane {
                uv: values[0],
                noise,
                input_cm_s2: self.input_cm_s2 + sd * z,
                seed: self.opts.seed.wrapping_add(offset).wrapping_add(r),
            })
            .collect();
        let records = self.simulate(&lanes, true);
        let n = self.measured.len();
        let logs = |pick: fn(&(f64, f64)) -> f64| -> Vec<Vec<f64>> {
            records
                .iter()
                .map(|r| r.iter().map(|x| pick(x).ln()).collect())
                .collect()
        };
        let covariance = |x: &[Vec<f64>]| -> Vec<f64> {
            let mean: Vec<f64> = (0..n)
                .map(|k| x.iter().map(|r| r[k]).sum::<f64>() / x.len() as f64)
                .collect();
            let mut c = vec![0.0; n * n];
            for r in x {
                for a in 0..n {
                    for b in 0..n {
                        c[a * n + b] += (r[a] - mean[a]) * (r[b] - mean[b]) / (x.len() - 1) as f64;
                    }
                }
            }
            c
        };
        (covariance(&logs(|x| x.0)), covariance(&logs(|x| x.1)))
    }

    /// The covariance of `ln M − ln S` across the τ at the noises `values`, from
    /// [`REPLICAS`] records simulated apart from the weights' ([`CHECK_SEED`]), not
    /// shrunk: the record's `ln M` as they vary, the simulated mean's `ln S` as theirs over
    /// [`SEEDS`] (on the diagonal). What the fit's intervals are checked against
    /// ([`sandwich_scales`]).
    fn spread(&mut self, values: [f64; 3]) -> Vec<f64> {
        let key = values.map(f64::to_bits);
        if let Some(c) = self.spreads.get(&key) {
            return c.clone();
        }
        let (mut c, simulated) = self.replicas(values, CHECK_SEED);
        let n = self.measured.len();
        for k in 0..n {
            c[k * n + k] = c[k * n + k].max(MIN_LOG_VARIANCE) + simulated[k * n + k] / SEEDS as f64;
        }
        self.spreads.insert(key, c.clone());
        c
    }

    /// Per free noise of the fit `prof` (made with the weights `w`), the factor on its
    /// profile's threshold that makes its interval hold the fit's spread: the sandwich
    /// variance of the weighted fit, `A⁻¹ Jᵀ W Σ W J A⁻¹` with `A = Jᵀ W J`, over the
    /// variance the profile assumes, `A⁻¹`, on the diagonal ([`sandwich_scales`]). `J` is
    /// the slopes of `ln S` in the free noises at the fit (central differences of 5 % of
    /// the value; a noise at zero, on its grid's edge, is held fixed and gets `None`, the
    /// profile's threshold unscaled), `Σ`
    /// [`Grid::spread`] at the fit. `W` estimated from [`REPLICAS`] records is noisy, and
    /// a noisy `W` makes `A⁻¹` too small: in `scripts/interval_model.py`'s linear model, 24
    /// records and 12 τ leave the profile's intervals (with the Birge ratio) holding the
    /// value in 84–89 % of trials (docs/method/noise.md). `s` may be below 1 (a fit that varies
    /// less than its weights say); it is used as it comes.
    fn interval_scales(&mut self, free: &[usize], prof: &Profile, w: &Weights) -> Vec<Option<f64>> {
        let inner: Vec<(usize, usize)> = free
            .iter()
            .enumerate()
            .filter(|&(_, &a)| prof.values[a] > 0.0)
            .map(|(j, &a)| (j, a))
            .collect();
        // None for a noise fitted at 0; 1 for one whose sandwich cannot be formed.
        let mut scales: Vec<Option<f64>> = vec![None; free.len()];
        for &(j, _) in &inner {
            scales[j] = Some(1.0);
        }
        if inner.is_empty() {
            return scales;
        }
        let slopes: Vec<Vec<f64>> = inner
            .iter()
            .map(|&(_, a)| {
                let v = prof.values[a];
                let h = 0.05 * v;
                let (lo, hi) = if v + h <= self.top(a) {
                    (v - h, v + h)
                } else {
                    (v - 2.0 * h, v)
                };
                let at = |x: f64| {
                    let mut p = prof.values;
                    p[a] = x;
                    self.at(free, p)
                };
                at(hi)
                    .iter()
                    .zip(at(lo))
                    .map(|(u, d)| (u.ln() - d.ln()) / (hi - lo))
                    .collect()
            })
            .collect();
        let sigma = self.spread(prof.values);
        if let Some(s) = sandwich_scales(&slopes, &w.inverse, &sigma) {
            for (&(j, _), s) in inner.iter().zip(s) {
                if s.is_finite() && s > 0.0 {
                    scales[j] = Some(s);
                }
            }
        }
        scales
    }

    /// The largest value of an axis of the grid.
    fn top(&self, a: usize) -> f64 {
        self.axes[a].last().copied().unwrap_or(0.0)
    }

    /// The nodes a set of free axes needs: every node of their sub-grid, the other axes at
    /// the base.
    fn nodes(&self, free: &[usize]) -> Vec<Node> {
        let mut out = vec![self.base];
        for &a in free {
            out = out
                .iter()
                .flat_map(|n| {
                    (0..self.axes[a].len()).map(move |i| {
                        let mut m = *n;
                        m[a] = i;
                        m
                    })
                })
                .collect();
        }
        out
    }

    /// The simulated curve at `values` (u, N, K; the axes not in `free` at the base):
    /// multilinear in the squares between the nodes.
    fn at(&self, free: &[usize], values: [f64; 3]) -> Vec<f64> {
        // Per axis: (lower node, upper node, weight of the upper).
        let cell: Vec<(usize, usize, f64)> = (0..3)
            .map(|a| {
                if !free.contains(&a) {
                    return (self.base[a], self.base[a], 0.0);
                }
                let g = &self.axes[a];
                let v = values[a];
                let k = g
                    .windows(2)
                    .position(|w| v <= w[1])
                    .unwrap_or(g.len().saturating_sub(2));
                let (lo, hi) = (g[k], g[(k + 1).min(g.len() - 1)]);
                let t = if hi > lo {
                    ((v * v - lo * lo) / (hi * hi - lo * lo)).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                (k, (k + 1).min(g.len() - 1), t)
            })
            .collect();
        let mut out = vec![0.0; self.measured.len()];
        for corner in 0..8usize {
            let mut w = 1.0;
            let mut node = [0; 3];
            for a in 0..3 {
                let up = corner >> a & 1 == 1;
                let (lo, hi, t) = cell[a];
                if lo == hi && up {
                    w = 0.0;
                }
                node[a] = if up { hi } else { lo };
                w *= if up { t } else { 1.0 - t };
            }
            if w == 0.0 {
                continue;
            }
            let c = &self.curves[&node];
            for (o, &v) in out.iter_mut().zip(c) {
                *o += w * v;
            }
        }
        out
    }

    /// `χ²` of the measured points against the curve `sim`, on the log scale: the residuals
    /// `ln M − ln S` with each log's bias (`−v/2` for a log of variance `v`) taken out,
    /// `rᵀ C⁻¹ r` with their covariance `C` across the τ ([`Grid::weights`]), the weights
    /// held fixed while a profile compares values: weights that move with the model would
    /// pull the fit towards larger noises.
    fn chi2(&self, sim: &[f64], w: &Weights) -> f64 {
        let r: Vec<f64> = sim
            .iter()
            .zip(&self.measured)
            .zip(&w.bias)
            .map(|((&s, &(_, _, m)), &b)| m.ln() - s.ln() + b)
            .collect();
        let n = r.len();
        (0..n)
            .map(|i| r[i] * (0..n).map(|j| w.inverse[i * n + j] * r[j]).sum::<f64>())
            .sum()
    }

    /// The profile of a set of free axes on a mesh: the best `χ²`, its values, and per free
    /// axis the mesh's values with the least `χ²` at each (for the intervals).
    fn profile(&mut self, free: &[usize], w: &Weights) -> Profile {
        self.ensure(&self.nodes(free));
        let base = [
            self.axes[0][self.base[0]],
            self.axes[1][self.base[1]],
            self.axes[2][self.base[2]],
        ];
        if free.is_empty() {
            return Profile {
                chi2: self.chi2(&self.at(free, base), w),
                values: base,
                marginals: Vec::new(),
            };
        }
        let steps = MESH[free.len() - 1];
        let mesh: Vec<Vec<f64>> = free
            .iter()
            .map(|&a| {
                let top = self.top(a);
                (0..steps)
                    .map(|i| top * i as f64 / (steps - 1) as f64)
                    .collect()
            })
            .collect();
        let mut marginals: Vec<Vec<(f64, f64)>> = mesh
            .iter()
            .map(|m| m.iter().map(|&v| (v, f64::INFINITY)).collect())
            .collect();
        let mut best = (f64::INFINITY, base);
        let total = steps.pow(u32::try_from(free.len()).unwrap_or(1));
        for flat in 0..total {
            let mut v = base;
            let mut idx = [0usize; 3];
            let mut r = flat;
            for (j, &a) in free.iter().enumerate() {
                idx[j] = r % steps;
                r /= steps;
                v[a] = mesh[j][idx[j]];
            }
            let c = self.chi2(&self.at(free, v), w);
            if c < best.0 {
                best = (c, v);
            }
            for j in 0..free.len() {
                let e = &mut marginals[j][idx[j]].1;
                *e = e.min(c);
            }
        }
        Profile {
            chi2: best.0,
            values: best.1,
            marginals,
        }
    }
}

impl Grid<'_> {
    /// The fit of the noises `free` from `start`, its weights ([`Grid::weights`])
    /// re-evaluated at its values until they settle (at most [`REWEIGHTS`] times): the fit
    /// and the weights it was made with.
    fn settle(&mut self, free: &[usize], start: [f64; 3]) -> (Profile, Weights) {
        let mut at = start;
        let mut w = self.weights(at);
        let mut prof = self.profile(free, &w);
        for _ in 0..REWEIGHTS {
            if prof.values.map(f64::to_bits) == at.map(f64::to_bits) {
                break;
            }
            at = prof.values;
            w = self.weights(at);
            prof = self.profile(free, &w);
        }
        (prof, w)
    }
}

/// The record's own part of the simulation seed: FNV-1a (64 bits) over every gate's pulses
/// and ticks, little-endian. [`identify`] draws its simulated records from the seed given
/// mixed with this, so that the records of two measurements never share their draws: the
/// grid's curves are the mean of [`SEEDS`] records a node, and with the same records
/// behind every identification their Monte Carlo error moves every estimate alike instead
/// of averaging out over a laboratory's records (docs/method/noise.md's campaign of 40 records:
/// `N` 6.6 % high on average with one seed for all, 5.6 % with each record's own, its
/// interval holding the value in 34, then 36, of 40). The same record with the same
/// `--seed` gives the same result.
#[must_use]
pub fn record_seed(record: &Record) -> u64 {
    let mut h = ptsa_core::Fnv::new();
    for g in &record.gates {
        h.bytes(&g.pulses.to_le_bytes());
        h.bytes(&g.ticks.to_le_bytes());
    }
    h.finish()
}

/// `count` standard normal draws from `seed`: where each simulated record's input sits
/// around the measured mean, in units of its error.
fn standard_normals(count: u64, seed: u64) -> Vec<f64> {
    use rand::SeedableRng as _;
    use rand_distr::Distribution as _;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (0..count)
        .map(|_| rand_distr::StandardNormal.sample(&mut rng))
        .collect()
}

/// A profile's result.
struct Profile {
    chi2: f64,
    values: [f64; 3],
    /// Per free axis: (value, least χ² at it).
    marginals: Vec<Vec<(f64, f64)>>,
}

/// The profile's 95 % interval of one free noise: the least and the largest of its mesh
/// values whose least `χ²` is within `threshold` of the minimum `best`.
fn interval(marginal: &[(f64, f64)], best: f64, threshold: f64) -> Option<(f64, f64)> {
    let mut inside = marginal
        .iter()
        .filter(|x| x.1 - best <= threshold)
        .map(|x| x.0);
    let lo = inside.next()?;
    Some((lo, inside.next_back().unwrap_or(lo)))
}

/// The profile's thresholds of the fit `prof` of the noises `free` (made with the weights
/// `w`), one per free noise: `t²·s·b²`, `t` the two-sided 95 % point of Student's t with
/// `REPLICAS − 1` degrees of freedom (the check's covariance is estimated from
/// [`REPLICAS`] records), `s` the noise's [`Grid::interval_scales`], `b²` the squared
/// Birge ratio ([`birge_sq`]); `s = 1` where the sandwich cannot be formed (slopes that do
/// not determine the fit), and `3.84·b²` for a noise fitted at zero.
fn thresholds(g: &mut Grid<'_>, free: &[usize], prof: &Profile, w: &Weights) -> Vec<f64> {
    let b2 = birge_sq(g, free, prof);
    let t2 =
        crate::stats::t_two_sided_quantile(1.0 - INTERVAL_LEVEL, (REPLICAS - 1) as f64).powi(2);
    g.interval_scales(free, prof, w)
        .into_iter()
        .map(|s| s.map_or(CHI2_1_95 * b2, |s| t2 * s * b2))
        .collect()
}

/// Per column of `slopes` (the derivatives of the model's `n` points in each parameter),
/// the ratio of the parameter's sandwich variance to its naive one in a fit weighted by
/// `w` (`n × n`, row-major) of points whose covariance is `sigma` (`n × n`): with `A = Jᵀ W
/// J`, the diagonal of `A⁻¹ (Jᵀ W Σ W J) A⁻¹` over that of `A⁻¹`. 1 when `W = Σ⁻¹`; `None`
/// when `A` is singular.
fn sandwich_scales(slopes: &[Vec<f64>], w: &[f64], sigma: &[f64]) -> Option<Vec<f64>> {
    let q = slopes.len();
    let n = slopes.first().map_or(0, Vec::len);
    let j = nalgebra::DMatrix::from_fn(n, q, |i, c| slopes[c][i]);
    let w = nalgebra::DMatrix::from_row_slice(n, n, w);
    let sigma = nalgebra::DMatrix::from_row_slice(n, n, sigma);
    let wj = &w * &j;
    let naive = (j.transpose() * &wj).try_inverse()?;
    let meat = wj.transpose() * sigma * &wj;
    let sandwich = &naive * meat * &naive;
    Some((0..q).map(|c| sandwich[(c, c)] / naive[(c, c)]).collect())
}

/// The squared Birge ratio of a fit of the noises `free`, at least 1.
fn birge_sq(g: &Grid<'_>, free: &[usize], prof: &Profile) -> f64 {
    let dof = g.measured.len().saturating_sub(free.len()).max(1) as f64;
    (prof.chi2 / dof).max(1.0)
}

/// The axis of a candidate.
fn axis(kind: Kind) -> usize {
    match kind {
        Kind::Pickoff => 0,
        Kind::WhiteAcceleration => 1,
        Kind::RandomWalk => 2,
    }
}

/// Identify, for the record `record` analysed as `measured`, the candidates beyond the
/// instrument file's loop (`opts`: seed, settling, configuration of the simulations).
/// `progress(done, total)` counts the selection's steps.
#[must_use]
pub fn identify(
    instr: &Instrument,
    opts: &SimOptions,
    record: &Record,
    measured: &Analysis,
    progress: &mut dyn FnMut(usize, usize),
) -> Identification {
    identify_looped(instr, opts, record, measured, LOOP_GATES, progress)
}

/// [`identify`] with the loop simulated for at most `loop_gates` gates of each simulated
/// record (`identify` uses [`LOOP_GATES`]): a campaign sets it low to measure what the
/// shortened simulation does to the intervals on records it can also simulate whole.
#[must_use]
pub fn identify_looped(
    instr: &Instrument,
    opts: &SimOptions,
    record: &Record,
    measured: &Analysis,
    loop_gates: u64,
    progress: &mut dyn FnMut(usize, usize),
) -> Identification {
    let mixed = SimOptions {
        seed: opts.seed ^ record_seed(record),
        ..*opts
    };
    let mut g = Grid::new(instr, &mixed, record, measured, loop_gates);
    g.first_step();
    let base_values = g.axes_values(g.base);
    let w = g.weights(base_values);
    let chi2_file = g.profile(&[], &w).chi2;
    let mut candidates: Vec<Candidate> = KINDS
        .iter()
        .map(|&kind| Candidate {
            kind,
            statistic: f64::NAN,
            p: 1.0,
            selected: false,
            value: None,
            open_above: false,
            interval_scale: 1.0,
        })
        .collect();
    let (chosen, current) = select(&mut g, &mut candidates, base_values, progress);
    if !chosen.is_empty() {
        joint_fit(&mut g, &chosen, current, &mut candidates);
    }
    g.identification(chi2_file, candidates)
}

impl<'a> Grid<'a> {
    /// The grid for `record` analysed as `measured`: the input along IA that gives its mean,
    /// its octave τ, the pickoff axis with the file's value, and the white and walk axes set
    /// by the record's upper bounds; nothing simulated yet.
    fn new(
        instr: &'a Instrument,
        opts: &'a SimOptions,
        record: &Record,
        measured: &Analysis,
        loop_gates: u64,
    ) -> Self {
        let file_uv = instr.noise_v_rms * 1e6;
        let mut grid_uv: Vec<f64> = PICKOFF_GRID_UV.to_vec();
        if !grid_uv.iter().any(|&u| (u - file_uv).abs() < 1e-9) {
            grid_uv.push(file_uv);
        }
        grid_uv.sort_by(f64::total_cmp);
        let base_u = grid_uv
            .iter()
            .position(|&u| (u - file_uv).abs() < 1e-9)
            .unwrap_or(0);
        let pts: Vec<(usize, f64, f64)> = measured
            .points
            .iter()
            .filter(|p| p.adev > 0.0 && p.adev.is_finite())
            .map(|p| (p.m, p.tau_s, p.adev * p.adev))
            .collect();
        let n2_max = measured
            .points
            .iter()
            .map(|p| p.ci95_hi * p.ci95_hi * p.tau_s)
            .fold(f64::INFINITY, f64::min);
        let k2_max = measured
            .points
            .iter()
            .map(|p| 3.0 * p.ci95_hi * p.ci95_hi / p.tau_s)
            .fold(f64::INFINITY, f64::min);
        let scaled = |f: &[f64], top: f64| -> Vec<f64> {
            f.iter().map(|x| (x * top).max(0.0).sqrt()).collect()
        };
        Grid {
            instr,
            opts,
            input_cm_s2: measured.mean_cm_s2 - instr.bias_cm_s2 - instr.loop_bias_cm_s2(0.0),
            gate_ticks: record.gates[0].ticks,
            gates: record.gates.len() as u64,
            loop_gates: loop_gates.max(1),
            counting_sd_cm_s2: measured.pulse_cm_s.unwrap_or(0.0)
                / (record.gates.len() as f64 * record.tau0_s * 6f64.sqrt()),
            tau0_s: record.tau0_s,
            measured: pts,
            axes: [
                grid_uv,
                scaled(&WHITE_FRACTIONS, n2_max),
                scaled(&WALK_FRACTIONS, k2_max),
            ],
            base: [base_u, 0, 0],
            curves: HashMap::new(),
            weights: HashMap::new(),
            spreads: HashMap::new(),
        }
    }

    /// The first step's nodes (each noise alone), simulated all at once; the τ kept are
    /// those with a positive simulated AVAR at every one of them.
    fn first_step(&mut self) {
        let first: Vec<Node> = (0..3).flat_map(|a| self.nodes(&[a])).collect();
        self.ensure(&first);
        let keep: Vec<usize> = (0..self.measured.len())
            .filter(|&i| self.curves.values().all(|c| c[i].is_finite() && c[i] > 0.0))
            .collect();
        self.measured = keep.iter().map(|&i| self.measured[i]).collect();
        self.curves = self
            .curves
            .iter()
            .map(|(n, c)| (*n, keep.iter().map(|&i| c[i]).collect()))
            .collect();
    }

    /// The noises (u, N, K) at `node`.
    fn axes_values(&self, node: Node) -> [f64; 3] {
        [
            self.axes[0][node[0]],
            self.axes[1][node[1]],
            self.axes[2][node[2]],
        ]
    }

    /// The identification: the grid as it ended, the records it simulated, the τ it used.
    fn identification(&self, chi2_file: f64, candidates: Vec<Candidate>) -> Identification {
        let [grid_uv, grid_white, grid_walk] = self.axes.clone();
        Identification {
            input_cm_s2: self.input_cm_s2,
            file_uv: self.instr.noise_v_rms * 1e6,
            grid_uv,
            grid_white,
            grid_walk,
            simulated_records: usize::try_from(
                self.curves.len() as u64 * SEEDS
                    + (self.weights.len() + self.spreads.len()) as u64 * REPLICAS,
            )
            .unwrap_or(usize::MAX),
            taus: self.measured.iter().map(|x| x.1).collect(),
            simulated_gates: self.gates.min(self.loop_gates),
            loop_split_tau_s: (self.loop_gates < self.gates)
                .then(|| {
                    self.measured
                        .iter()
                        .filter(|x| x.0 as u64 * LOOP_SPLIT as u64 <= self.loop_gates)
                        .map(|x| x.1)
                        .next_back()
                })
                .flatten(),
            chi2_file,
            candidates,
        }
    }
}

/// Forward selection with Holm's thresholds from the file's loop (`base_values`); each
/// step's weights are those of the model selected so far, at its fitted values, for the
/// model and every extension alike. Returns the axes selected and the values fitted last.
fn select(
    g: &mut Grid<'_>,
    candidates: &mut [Candidate],
    base_values: [f64; 3],
    progress: &mut dyn FnMut(usize, usize),
) -> (Vec<usize>, [f64; 3]) {
    let normal = Normal::standard();
    let mut chosen: Vec<usize> = Vec::new();
    let mut current = base_values;
    for step in 0..KINDS.len() {
        progress(step, KINDS.len());
        let (prof, w) = g.settle(&chosen, current);
        current = prof.values;
        let base = prof.chi2;
        let mut tested: Vec<(usize, f64, f64, [f64; 3])> = Vec::new();
        for (i, c) in candidates.iter().enumerate().filter(|(_, c)| !c.selected) {
            let mut free = chosen.clone();
            free.push(axis(c.kind));
            free.sort_unstable();
            let prof = g.profile(&free, &w);
            let d = (base - prof.chi2).max(0.0);
            let (stat, p) = if c.kind == Kind::Pickoff {
                (d, crate::stats::chi2_sf(d, 1.0))
            } else {
                let z = d.sqrt();
                (z, if z.is_finite() { normal.sf(z) } else { 1.0 })
            };
            tested.push((i, stat, p, prof.values));
        }
        for &(i, stat, p, _) in &tested {
            candidates[i].statistic = stat;
            candidates[i].p = p;
        }
        let Some(&(i, _, p, values)) = tested.iter().min_by(|a, b| a.2.total_cmp(&b.2)) else {
            break;
        };
        if p <= ALPHA / (KINDS.len() - step) as f64 {
            candidates[i].selected = true;
            chosen.push(axis(candidates[i].kind));
            chosen.sort_unstable();
            current = values;
        } else {
            break;
        }
    }
    progress(KINDS.len(), KINDS.len());
    (chosen, current)
}

/// The joint fit of the `chosen` axes from `current`, with the bias random walk free as a
/// nuisance where it was not selected: a walk too weak to be selected from the record still
/// lifts its longest τ, which the others would otherwise take (N 5.6 % high over the
/// campaign's records with K = 0.005, 2 % with none; docs/method/noise.md). Its grid is simulated
/// already: the selection's last step tested it given the others. Each selected candidate
/// gets its value and interval.
fn joint_fit(g: &mut Grid<'_>, chosen: &[usize], current: [f64; 3], candidates: &mut [Candidate]) {
    let mut free = chosen.to_vec();
    if !free.contains(&axis(Kind::RandomWalk)) {
        free.push(axis(Kind::RandomWalk));
        free.sort_unstable();
    }
    let (mut prof, mut w) = g.settle(&free, current);
    // A selected white noise or walk whose interval reaches its grid's top (set from the
    // record's upper bounds, the least over τ: one τ low by chance sets it low) gets nodes
    // above it, and the fit is redone, at most [`EXTENSIONS`] times.
    let mut limits = thresholds(g, &free, &prof, &w);
    for _ in 0..EXTENSIONS {
        let short: Vec<usize> = free
            .iter()
            .enumerate()
            .filter(|&(j, &a)| {
                let top = g.top(a);
                a != axis(Kind::Pickoff)
                    && chosen.contains(&a)
                    && interval(&prof.marginals[j], prof.chi2, limits[j])
                        .is_some_and(|(_, hi)| hi >= top)
            })
            .map(|(_, &a)| a)
            .collect();
        if short.is_empty() {
            break;
        }
        for &a in &short {
            let top = g.top(a);
            g.axes[a].extend(ABOVE_TOP.iter().map(|f| top * f.sqrt()));
        }
        (prof, w) = g.settle(&free, prof.values);
        limits = thresholds(g, &free, &prof, &w);
    }
    let b2 = birge_sq(g, &free, &prof);
    for (j, &a) in free.iter().enumerate() {
        if !chosen.contains(&a) {
            continue;
        }
        let v = prof.values[a];
        let (lo, hi) = interval(&prof.marginals[j], prof.chi2, limits[j]).unwrap_or((v, v));
        let top = g.top(a);
        if let Some(c) = candidates.iter_mut().find(|c| axis(c.kind) == a) {
            c.value = Some((v, lo, hi));
            c.open_above = hi >= top;
            c.interval_scale = limits[j] / (CHI2_1_95 * b2);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid of hand-made curves (one τ): `AVAR = 1 + u² + 2N² + 3K²` at every node, so
    /// multilinear interpolation in the squares is exact.
    fn hand_grid<'a>(instr: &'a Instrument, opts: &'a SimOptions, m: f64) -> Grid<'a> {
        let axes: [Vec<f64>; 3] = [
            vec![0.0, 0.5, 1.0, 2.0],
            vec![0.0, 0.1, 0.3],
            vec![0.0, 0.01, 0.02],
        ];
        let mut curves = HashMap::new();
        for i in 0..4 {
            for j in 0..3 {
                for k in 0..3 {
                    let v = 1.0
                        + axes[0][i].powi(2)
                        + 2.0 * axes[1][j].powi(2)
                        + 3.0 * axes[2][k].powi(2);
                    curves.insert([i, j, k], vec![v]);
                }
            }
        }
        Grid {
            instr,
            opts,
            input_cm_s2: 0.0,
            gate_ticks: 640,
            gates: 100,
            loop_gates: LOOP_GATES,
            counting_sd_cm_s2: 0.0,
            tau0_s: 0.01,
            measured: vec![(1, 0.01, m)],
            axes,
            base: [1, 0, 0],
            curves,
            weights: HashMap::new(),
            spreads: HashMap::new(),
        }
    }

    /// Interpolation in the squares: exact for a curve linear in them, at nodes and between;
    /// the axes not free stay at the base (u = 0.5, N = K = 0).
    #[test]
    fn curves_interpolate_in_noise_power() {
        let (instr, opts) = (Instrument::kearfott_2401(), SimOptions::default());
        let g = hand_grid(&instr, &opts, 1.0);
        let f = |u: f64, n: f64, k: f64| 1.0 + u * u + 2.0 * n * n + 3.0 * k * k;
        for v in [
            [0.7, 0.2, 0.015],
            [2.0, 0.3, 0.02],
            [0.0, 0.0, 0.0],
            [1.3, 0.05, 0.001],
        ] {
            let got = g.at(&[0, 1, 2], v)[0];
            assert!((got - f(v[0], v[1], v[2])).abs() < 1e-12, "{v:?}: {got}");
        }
        let got = g.at(&[1], [1.7, 0.2, 0.015])[0];
        assert!((got - f(0.5, 0.2, 0.0)).abs() < 1e-12, "{got}");
    }

    /// The profile finds the values that give the measured point (a χ² of nearly 0: the
    /// logs' bias corrections, half their variances, differ by 0.001), and its marginal of
    /// each free noise is least there.
    #[test]
    fn the_profile_finds_the_measured_value() {
        let (instr, opts) = (Instrument::kearfott_2401(), SimOptions::default());
        let nu = Weights::diagonal(&[0.004], &[0.002]);
        // 1 + 1.5² = 3.25: u = 1.5 with N = K = 0.
        let mut g = hand_grid(&instr, &opts, 3.25);
        let p = g.profile(&[0], &nu);
        assert!(
            p.chi2 < 2e-4 && (p.values[0] - 1.5).abs() < 0.01,
            "{:?} {}",
            p.values,
            p.chi2
        );
        let best = p.marginals[0]
            .iter()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        assert!((best.0 - 1.5).abs() < 0.01, "{best:?}");
        // 1 + 0.25 + 2·0.2² = 1.33: N = 0.2 at the base's u.
        let mut g = hand_grid(&instr, &opts, 1.33);
        let p = g.profile(&[1], &nu);
        assert!(
            p.chi2 < 2e-4 && (p.values[1] - 0.2).abs() < 0.002,
            "{:?} {}",
            p.values,
            p.chi2
        );
        // At the base (u = 0.5, N = 0), the logs' variances 0.004 and 0.002:
        // (ln(1.33/1.25) + 0.002 − 0.001)² / (0.004 + 0.002) = 0.063035² / 0.006 = 0.66224.
        let c = g.profile(&[], &nu).chi2;
        assert!((c - 0.66224).abs() < 1e-4, "{c}");
    }

    /// The sandwich's ratio against its definition: two parameters fitted by weighted least
    /// squares to 12 points correlated as neighbouring octaves are (`ρ = 0.6^|a−b|`,
    /// variances rising 1.35 times an octave), weighted as if independent; the spread of
    /// 20 000 fits of drawn points over the variance the weights claim is the ratio, within
    /// its standard error (1 %); 1 exactly when the weights are the inverse covariance.
    #[test]
    fn sandwich_scales_are_the_fits_spread() {
        use nalgebra::{DMatrix, DVector};
        use rand::SeedableRng as _;
        use rand_distr::Distribution as _;
        const N: i32 = 12;
        let n = N.unsigned_abs() as usize;
        let sd: Vec<f64> = (0..N).map(|k| 0.05 * 1.35f64.powi(k)).collect();
        let sigma = DMatrix::from_fn(n, n, |a, b| {
            sd[a] * sd[b] * 0.6f64.powi(a.abs_diff(b).try_into().unwrap())
        });
        let slopes: Vec<Vec<f64>> = vec![
            (0..N).map(|k| (0.15 * f64::from(k)).min(1.0)).collect(),
            (0..N)
                .map(|k| if k >= 9 { 0.25 * f64::from(k - 8) } else { 0.0 })
                .collect(),
        ];
        let flat = |m: &DMatrix<f64>| -> Vec<f64> {
            (0..m.nrows() * m.ncols())
                .map(|i| m[(i / m.ncols(), i % m.ncols())])
                .collect()
        };
        let exact = flat(&sigma.clone().try_inverse().unwrap());
        for s in sandwich_scales(&slopes, &exact, &flat(&sigma)).unwrap() {
            assert!((s - 1.0).abs() < 1e-9, "{s}");
        }
        let w = DMatrix::from_diagonal(&sigma.diagonal().map(|v| 1.0 / v));
        let scales = sandwich_scales(&slopes, &flat(&w), &flat(&sigma)).unwrap();
        let j = DMatrix::from_fn(n, 2, |i, c| slopes[c][i]);
        let naive = (j.transpose() * &w * &j).try_inverse().unwrap();
        let solve = &naive * j.transpose() * &w;
        let chol = sigma.clone().cholesky().unwrap().l();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let draws = 20_000;
        let mut sq = [0.0; 2];
        for _ in 0..draws {
            let z = DVector::from_fn(n, |_, _| rand_distr::StandardNormal.sample(&mut rng));
            let beta = &solve * (&chol * z);
            for c in 0..2 {
                sq[c] += beta[c] * beta[c] / f64::from(draws);
            }
        }
        for c in 0..2 {
            let drawn = sq[c] / naive[(c, c)];
            assert!(
                (drawn / scales[c] - 1.0).abs() < 0.03,
                "parameter {c}: drawn {drawn}, sandwich {}",
                scales[c]
            );
            assert!(
                scales[c] > 1.5,
                "independent weights understate it: {}",
                scales[c]
            );
        }
    }
}
