//! The hidden-parameter campaign: the loop's own parameters identified blind through the
//! closed loop.
//!
//! A set is a frequency-response table (and, in one design, saturation rows) measured on an
//! instrument whose file differs from the shipped one in one parameter (damping, spring,
//! inertia, pendulosity, torquer scale factor, torquer lag, pickoff gain or pickoff phase),
//! or in none. The analysis ([`discover`](ptsa_host_sim::discovery::discover) with the
//! closed-loop simulator of the *shipped* file) never sees the perturbed file; it must name
//! the parameter, or say that it is indistinguishable from the one it names.
//!
//! * **Measurement**: each row is one closed-loop run of the perturbed instrument with its
//!   own noise seed (its sine started at a phase drawn from the seed, as the analysis's own
//!   runs); its stated sigma is what a laboratory would state, the scatter of one run at
//!   that condition (the sample standard deviation of [`CALIBRATION_RUNS`] runs of the
//!   shipped instrument with other seeds, floored at 1e-4 in gain, 0.01° in phase and
//!   0.01 cm/s²; with 8 runs the χ² of a right model averaged 1.4 times its dof).
//! * **Strength**: the offset's effect is `s` noise standard deviations in χ² distance, `s`
//!   uniform in 2–24 ([`Seen::change_for`]): `±s·SE` where the parameter shows to first
//!   order (SE its standard error alone in this design, from central differences of the
//!   closed loop a quarter of a tolerance half-width either side, each the mean of 8 runs,
//!   against the stated sigmas, with the loop noise's expected share of the information
//!   taken off), `±√(2s/‖∂²y/∂p²/σ‖)` where it shows only to second order (the pickoff
//!   phase, whose response is even about 0°; scored on `|change|`). A parameter a design
//!   does not see (a change of its whole tolerance band is less than 1 SE: the spring, the
//!   inertia and the torquer lag in both designs) is not hidden there and is listed.
//!   The "2–10 tolerance widths" would put every parameter at hundreds of standard
//!   errors (a 20-frequency table measures the damping to 0.3 %), where nothing can fail,
//!   and some below zero; the strength in SE is what decides detection, so it is drawn,
//!   and the offset in tolerance half-widths is reported beside it.
//! * **Scored**: named exactly (selected), or as a confounded partner of what is selected;
//!   coverage of `|fitted − true| ≤ 1.96·SE` among exact namings at ≥ 6 SE; any selection in
//!   an unperturbed set is a false selection.
//!
//! Asserted in the full campaign (`cargo xtask hidden --parameters`): exact-or-partner
//! naming at ≥ 6 SE in ≥ 95 % of the sets, coverage in the 99 % band of Binomial(n, 0.95)
//! when there are at least 20 exact namings, confident misnamings and false selections on
//! unperturbed sets each consistent with at most 5 % (one-sided binomial test at 1 %). The
//! CI subset (1 set per parameter in the 10-frequency design with saturation rows) asserts
//! the same, detection less one binomial standard error. What the full campaign measures is in `docs/method/discovery.md`
//! ("Where it fails").

use std::fmt::Write as _;
use std::sync::OnceLock;

use ptsa_host_sim::discovery::Selected;
use ptsa_host_sim::discovery::sim::{ClosedLoopSimulator, runs_of};
use ptsa_host_sim::discovery::{Options, Simulator};
use ptsa_host_sim::model::condition::{IA, RowKind};
use ptsa_host_sim::{CandidateId, Condition, Effects, Instrument, SimOptions};

use rand::Rng as _;

use super::campaign::{
    Campaign, Columns, Count, Naming, Outcome, Run, at_most_rate, coverage_in_band, detected,
};
use super::{Draw, rng};

/// Runs of the shipped instrument behind each row's stated sigma.
pub const CALIBRATION_RUNS: u64 = 32;

/// The parameters hidden, in table order.
pub const PARAMETERS: [CandidateId; 8] = [
    CandidateId::ParamDamping,
    CandidateId::ParamSpring,
    CandidateId::ParamInertia,
    CandidateId::ParamPendulosity,
    CandidateId::ParamTorquerSf,
    CandidateId::ParamTorquerLag,
    CandidateId::ParamPickoffGain,
    CandidateId::ParamPickoffPhase,
];

/// A design's rows, without measurements.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum ParamDesign {
    /// 20 frequencies from 2 to 400 Hz at 2000 cm/s² along IA.
    Response20,
    /// 10 of those frequencies and 3 saturation rows (absolute rows under vibration along
    /// IA at 1.2, 1.5 and 2 times the loop's full scale, 50 Hz).
    Response10Saturation,
}

impl ParamDesign {
    /// Both, in order.
    pub const ALL: [ParamDesign; 2] = [ParamDesign::Response20, ParamDesign::Response10Saturation];

    /// Name in tables.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            ParamDesign::Response20 => "20 freq",
            ParamDesign::Response10Saturation => "10 freq + 3 sat",
        }
    }

    /// The rows, unmeasured.
    #[must_use]
    pub fn rows(self, instr: &Instrument) -> Vec<Condition> {
        const F20: [f64; 20] = [
            2.0, 5.0, 10.0, 15.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 100.0, 120.0,
            150.0, 180.0, 220.0, 260.0, 300.0, 400.0,
        ];
        let response = |f: f64| {
            let mut c = Condition {
                label: format!("{f} Hz"),
                kind: RowKind::Response,
                freq_hz: f,
                ..Condition::default()
            };
            c.lin_cm_s2[IA] = 2000.0;
            c
        };
        match self {
            ParamDesign::Response20 => F20.iter().map(|&f| response(f)).collect(),
            ParamDesign::Response10Saturation => {
                let mut v: Vec<Condition> = F20.iter().step_by(2).map(|&f| response(f)).collect();
                for x in [1.2, 1.5, 2.0] {
                    let mut c = Condition {
                        label: format!("saturation {x} FS at 50 Hz"),
                        kind: RowKind::Absolute,
                        freq_hz: 50.0,
                        ..Condition::default()
                    };
                    c.g[IA] = 1.0;
                    c.lin_cm_s2[IA] = x * instr.actual_sf_cm_s2();
                    v.push(c);
                }
                v
            }
        }
    }
}

/// Each `(row, seed)` measured once: `[value]` or `[gain, phase_deg]`, all on the batch
/// engine ([`runs_of`]; bit for bit the single runs).
fn measure_rows(instr: &Instrument, jobs: &[(&Condition, u64)]) -> Vec<Vec<f64>> {
    let runs: Vec<(&Condition, &Effects, u64)> =
        jobs.iter().map(|&(r, s)| (r, &Effects::NONE, s)).collect();
    runs_of(instr, &runs, &SimOptions::default())
}

/// Each of `rows` measured with seeds `first`, `first + 1`, ... (`n` runs): per row, its
/// runs.
fn repeated(instr: &Instrument, rows: &[Condition], first: u64, n: u64) -> Vec<Vec<Vec<f64>>> {
    let jobs: Vec<(&Condition, u64)> = rows
        .iter()
        .flat_map(|r| (0..n).map(move |j| (r, first + j)))
        .collect();
    let all = measure_rows(instr, &jobs);
    #[allow(clippy::cast_possible_truncation)]
    all.chunks(n as usize).map(<[Vec<f64>]>::to_vec).collect()
}

/// Each row's stated sigmas (see the module docs), computed once per design.
fn calibration(design: ParamDesign) -> &'static Vec<Vec<f64>> {
    static CAL: [OnceLock<Vec<Vec<f64>>>; 2] = [OnceLock::new(), OnceLock::new()];
    let k = ParamDesign::ALL
        .iter()
        .position(|&d| d == design)
        .unwrap_or(0);
    CAL[k].get_or_init(|| {
        let instr = Instrument::kearfott_2401();
        let rows = design.rows(&instr);
        rows.iter()
            .zip(repeated(&instr, &rows, 7000, CALIBRATION_RUNS))
            .map(|(r, runs)| {
                let floor = if r.kind == RowKind::Response {
                    vec![1e-4, 0.01]
                } else {
                    vec![0.01]
                };
                #[allow(clippy::cast_precision_loss)]
                let n = runs.len() as f64;
                (0..runs[0].len())
                    .map(|q| {
                        let m = runs.iter().map(|v| v[q]).sum::<f64>() / n;
                        let var = runs.iter().map(|v| (v[q] - m).powi(2)).sum::<f64>() / (n - 1.0);
                        var.sqrt().max(floor[q])
                    })
                    .collect()
            })
            .collect()
    })
}

/// What a set hides.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct ParamTruth {
    /// The parameter, or `None` (unperturbed).
    pub id: Option<CandidateId>,
    /// Its true change from the file's value, in the file's unit.
    pub change: f64,
    /// `|change|` in standard errors of the parameter alone in this design.
    pub strength_se: f64,
    /// `|change|` in tolerance half-widths.
    pub tolerances: f64,
    /// The parameter shows only to second order ([`Seen::Even`]): its sign is not in the
    /// data, and it is scored on `|change|`.
    pub even: bool,
    /// The design.
    pub design: ParamDesign,
}

/// A set: rows with measurements and stated sigmas, and the truth.
#[derive(Clone, Debug)]
pub struct ParamSet {
    /// Rows.
    pub rows: Vec<Condition>,
    /// What was hidden.
    pub truth: ParamTruth,
}

/// Runs averaged per side of the strength's differences (`seen`).
pub const STRENGTH_RUNS: u64 = 8;

/// The step of the strength's differences (`seen`), in tolerance half-widths.
pub const STRENGTH_STEP: f64 = 0.25;

/// How a parameter shows in a design, from the closed loop about the file's value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Seen {
    /// To first order: the standard error of the parameter alone, in its unit.
    Linear(f64),
    /// Only to second order (the response is even about the file's value, as a pickoff
    /// phase error that enters as its cosine): `‖∂²y/∂p²/σ‖`, in σ per unit².
    Even(f64),
}

impl Seen {
    /// The change, in the parameter's unit, whose effect is `s` noise standard deviations
    /// in χ² distance (`s·SE` to first order; `√(2s/‖∂²y/∂p²/σ‖)` to second).
    #[must_use]
    pub fn change_for(self, s: f64) -> f64 {
        match self {
            Seen::Linear(se) => s * se,
            Seen::Even(c) => (2.0 * s / c).sqrt(),
        }
    }
}

/// Each row's mean observations.
type Means = Vec<Vec<f64>>;

/// The mean observations of `STRENGTH_RUNS` runs (seeds 11, 12, ...) of each row.
fn mean_rows(instr: &Instrument, rows: &[Condition]) -> Means {
    repeated(instr, rows, 11, STRENGTH_RUNS)
        .into_iter()
        .map(|runs| {
            #[allow(clippy::cast_precision_loss)]
            let n = runs.len() as f64;
            (0..runs[0].len())
                .map(|q| runs.iter().map(|v| v[q]).sum::<f64>() / n)
                .collect()
        })
        .collect()
}

/// `Σ (combination of the sides / σ)²` over every observation, less its expected share
/// of the runs' noise (`weight` = the sum of the squared combination coefficients, over
/// [`STRENGTH_RUNS`]); `None` when no more than that share again is left.
fn information(sides: &[&Vec<Vec<f64>>], coef: &[f64], cal: &[Vec<f64>]) -> Option<f64> {
    let mut sum = 0.0;
    let mut obs = 0usize;
    for (k, s) in cal.iter().enumerate() {
        for (q, sq) in s.iter().enumerate() {
            let v: f64 = sides.iter().zip(coef).map(|(x, c)| c * x[k][q]).sum();
            sum += (v / sq).powi(2);
            obs += 1;
        }
    }
    #[allow(clippy::cast_precision_loss)]
    let noise = obs as f64 * coef.iter().map(|c| c * c).sum::<f64>() / STRENGTH_RUNS as f64;
    let info = sum - noise;
    (info > noise && info.is_finite()).then_some(info)
}

/// How parameter `id` shows in `rows` with sigmas `cal`: central differences of the
/// closed loop [`STRENGTH_STEP`] tolerance half-widths either side of the file's value give
/// its standard error alone; when they see nothing, the second difference over 0.9 of the
/// narrower side of the band tells whether the parameter shows to second order. Each side
/// is the mean of [`STRENGTH_RUNS`] runs with the same seeds; the loop's noise passes into
/// the differences (a changed parameter decorrelates the limit cycle's beat even with the
/// same seed), so its expected share of the information is taken off. `None` when nothing
/// is left: the rows do not see the parameter.
fn seen(instr: &Instrument, id: CandidateId, rows: &[Condition], cal: &[Vec<f64>]) -> Option<Seen> {
    let key = id.parameter_key()?;
    let (lo, nom, hi) = instr.tolerance(key)?;
    let side = |h: f64| -> Option<(Means, Means)> {
        let (mut up, mut dn) = (instr.clone(), instr.clone());
        up.set(key, nom + h).ok()?;
        dn.set(key, nom - h).ok()?;
        Some((mean_rows(&up, rows), mean_rows(&dn, rows)))
    };
    // Both sides inside the band (an asymmetric band would otherwise step below zero).
    let narrow = 0.9 * (hi - nom).min(nom - lo);
    let h = (STRENGTH_STEP * (hi - nom).max(nom - lo)).min(narrow);
    let (a, b) = side(h)?;
    let d = 1.0 / (2.0 * h);
    if let Some(info) = information(&[&a, &b], &[d, -d], cal) {
        return Some(Seen::Linear(1.0 / info.sqrt()));
    }
    let (a, b) = side(narrow)?;
    let m = mean_rows(instr, rows);
    let c = 1.0 / (narrow * narrow);
    information(&[&a, &b, &m], &[c, c, -2.0 * c], cal).map(|i| Seen::Even(i.sqrt()))
}

/// [`seen`] for the shipped instrument, `id` and `design`, computed once per pair.
fn seen_in(id: CandidateId, design: ParamDesign) -> Option<Seen> {
    type Cache = std::sync::Mutex<Vec<((CandidateId, ParamDesign), Option<Seen>)>>;
    static CACHE: OnceLock<Cache> = OnceLock::new();
    let cache = CACHE.get_or_init(Cache::default);
    if let Some((_, v)) = cache.lock().ok()?.iter().find(|(k, _)| *k == (id, design)) {
        return *v;
    }
    let nominal = Instrument::kearfott_2401();
    let v = seen(&nominal, id, &design.rows(&nominal), calibration(design)).filter(|how| {
        // A change of the whole tolerance band is not 1 SE: unseen.
        let key = id.parameter_key().unwrap_or_default();
        let (lo, nom, hi) = nominal.tolerance(key).unwrap_or((0.0, 0.0, 0.0));
        how.change_for(1.0) <= (hi - nom).max(nom - lo)
    });
    if let Ok(mut c) = cache.lock() {
        c.push(((id, design), v));
    }
    v
}

/// Make set `seed` hiding `id` (or nothing) in `design`.
///
/// # Panics
/// The shipped file refuses a value of its own band (a bug).
#[must_use]
pub fn generate(seed: u64, id: Option<CandidateId>, design: ParamDesign) -> ParamSet {
    let mut r = rng(seed);
    let nominal = Instrument::kearfott_2401();
    let cal = calibration(design);
    let mut rows = design.rows(&nominal);
    let mut truth_instr = nominal.clone();
    let mut truth = ParamTruth {
        id,
        change: 0.0,
        strength_se: 0.0,
        tolerances: 0.0,
        even: false,
        design,
    };
    if let Some(id) = id {
        let key = id.parameter_key().expect("a parameter");
        let (lo, nom, hi) = nominal.tolerance(key).expect("a toleranced parameter");
        let half = (hi - nom).max(nom - lo);
        let how = seen_in(id, design).expect("a parameter this design sees");
        let s = r.range(2.0, 24.0);
        let mut change = r.sign() * how.change_for(s);
        // Keep it physical: never through zero for a positive quantity.
        if nom > 0.0 && nom + change <= 0.1 * nom {
            change = -change;
        }
        truth_instr
            .set(key, nom + change)
            .expect("a settable parameter");
        truth.change = change;
        truth.strength_se = s;
        truth.tolerances = change.abs() / half;
        truth.even = matches!(how, Seen::Even(_));
    }
    let noise_seed = r.random::<u64>();
    let jobs: Vec<(&Condition, u64)> = rows
        .iter()
        .enumerate()
        .map(|(k, row)| (row, noise_seed.wrapping_add(k as u64)))
        .collect();
    let measured = measure_rows(&truth_instr, &jobs);
    for ((row, m), s) in rows.iter_mut().zip(&measured).zip(cal) {
        if row.kind == RowKind::Response {
            row.measured_gain = Some(m[0]);
            row.measured_phase_deg = Some(m[1]);
            row.sigma_gain = Some(s[0]);
            row.sigma_phase_deg = Some(s[1]);
        } else {
            row.measured_cm_s2 = Some(m[0]);
            row.sigma_cm_s2 = Some(s[0]);
        }
    }
    ParamSet { rows, truth }
}

/// A set's outcome.
pub type ParamOutcome = Outcome<ParamTruth>;

/// Strength from which detection and coverage are asserted, SE.
pub const ASSERT_FROM_SE: f64 = Naming::FROM_SE;

/// What a set is seeded by: the parameter hidden (or none) and the design.
pub type ParamKind = (Option<CandidateId>, ParamDesign);

/// The hidden-parameter campaign: the pipeline is the closed loop of the shipped file with
/// its whole vocabulary; a parameter is hidden only in the designs that see it.
#[derive(Debug)]
pub struct Params {
    /// The designs of the campaign.
    pub designs: Vec<ParamDesign>,
    /// Parameters a design does not see (not hidden there).
    pub unseen: Vec<(CandidateId, ParamDesign)>,
    /// The pipeline's simulator.
    pub sim: ClosedLoopSimulator,
    /// The pipeline's options.
    pub options: Options,
}

impl Params {
    /// The campaign in every design; finds the parameters each design does not see.
    #[must_use]
    pub fn new() -> Self {
        Self::in_designs(&ParamDesign::ALL)
    }

    /// The campaign in `designs` only.
    #[must_use]
    pub fn in_designs(designs: &[ParamDesign]) -> Self {
        let nominal = Instrument::kearfott_2401();
        Params {
            designs: designs.to_vec(),
            unseen: PARAMETERS
                .iter()
                .flat_map(|&id| designs.iter().map(move |&d| (id, d)))
                .filter(|&(id, d)| seen_in(id, d).is_none())
                .collect(),
            options: Options::for_instrument(&nominal),
            sim: ClosedLoopSimulator {
                instrument: nominal,
                options: SimOptions::default(),
            },
        }
    }
}

impl Default for Params {
    fn default() -> Self {
        Self::new()
    }
}

/// Run `sets` sets of every parameter and `sets` unperturbed sets in each design.
#[must_use]
pub fn run(sets: usize, seed: u64) -> Run<Params> {
    Run::new(Params::new(), sets, seed)
}

/// [`run`] in `designs` only.
#[must_use]
pub fn run_in(sets: usize, seed: u64, designs: &[ParamDesign]) -> Run<Params> {
    Run::new(Params::in_designs(designs), sets, seed)
}

/// One parameter's (or the unperturbed sets') figures.
#[derive(Clone, Copy, Debug, Default)]
pub struct ParamStats {
    /// How the hidden parameter was named (at ≥ 6 SE).
    pub naming: Naming,
    /// A selection, the hidden parameter neither selected nor named as a partner.
    pub misnamed: Count,
    /// Sets with a selection.
    pub any: Count,
}

impl ParamStats {
    fn add(&mut self, o: &ParamOutcome) {
        self.any.add(o.any_selection());
        if o.hidden {
            self.misnamed.add(o.misnamed());
            self.naming.add(o, o.truth.strength_se);
        }
    }
}

impl Campaign for Params {
    type Kind = ParamKind;
    type Truth = ParamTruth;
    /// Each set measures its rows on the batch engine, every core busy.
    const PARALLEL: bool = false;

    /// Every parameter, then none, each in both designs.
    fn kinds(&self) -> Vec<ParamKind> {
        PARAMETERS
            .iter()
            .map(|&id| Some(id))
            .chain(std::iter::once(None))
            .flat_map(|k| self.designs.iter().map(move |&d| (k, d)))
            .collect()
    }

    fn hidden(&self, (k, d): ParamKind) -> bool {
        k.is_none_or(|id| !self.unseen.contains(&(id, d)))
    }

    fn generate(&self, seed: u64, (k, d): ParamKind) -> (Vec<Condition>, ParamTruth) {
        let set = generate(seed, k, d);
        (set.rows, set.truth)
    }

    fn names<'a>(&self, truth: &'a ParamTruth) -> &'a [CandidateId] {
        truth.id.as_slice()
    }

    fn z(&self, t: &ParamTruth, s: &Selected) -> Option<f64> {
        Some(if t.even {
            (s.coef.abs() - t.change.abs()) / s.stderr
        } else {
            (s.coef - t.change) / s.stderr
        })
    }

    fn pipeline(&self) -> (&dyn Simulator, &Options) {
        (&self.sim, &self.options)
    }

    fn title(&self, run: &Run<Self>) -> String {
        format!(
            "hidden-parameter campaign: {} sets per parameter and design ({}), seed {}; data: closed loop of the perturbed file; pipeline: closed loop of the shipped file; {:.1} s",
            run.sets,
            self.designs
                .iter()
                .map(|d| d.name())
                .collect::<Vec<_>>()
                .join(", "),
            run.seed,
            run.seconds
        )
    }

    fn columns(&self) -> Columns {
        Naming::columns(vec![
            vec![("misnamed", 8)],
            vec![("any sel", 8)],
            vec![("tol widths", 14)],
        ])
    }

    fn rows(&self, run: &Run<Self>) -> Vec<(String, Vec<String>)> {
        let mut ids: Vec<Option<CandidateId>> = PARAMETERS
            .iter()
            .filter(|&&id| run.outcomes.iter().any(|o| o.truth.id == Some(id)))
            .map(|&id| Some(id))
            .collect();
        ids.push(None);
        ids.into_iter()
            .map(|id| {
                let of = |o: &ParamOutcome| o.truth.id == id;
                let st: ParamStats = run.stats(of, ParamStats::add);
                let n = run.outcomes.iter().filter(|o| of(o)).count();
                let tol: Vec<f64> = run
                    .outcomes
                    .iter()
                    .filter(|o| of(o) && o.hidden)
                    .map(|o| o.truth.tolerances)
                    .collect();
                let range = if tol.is_empty() {
                    "-".to_string()
                } else {
                    format!(
                        "{:.1e}–{:.1e}",
                        tol.iter().copied().fold(f64::INFINITY, f64::min),
                        tol.iter().copied().fold(0.0, f64::max)
                    )
                };
                let count = |c: Count| {
                    if id.is_some() {
                        c.fraction()
                    } else {
                        "-".to_string()
                    }
                };
                let mut cells = vec![n.to_string()];
                cells.extend(st.naming.cells(count));
                cells.extend([count(st.misnamed), st.any.fraction(), range]);
                (
                    id.map_or("unperturbed", |i| i.info().name).to_string(),
                    cells,
                )
            })
            .collect()
    }

    fn legend(&self, run: &Run<Self>, ci: bool) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "sets with a row flagged as a suspected gross error (none is injected): {} of {}",
            run.outcomes
                .iter()
                .filter(|o| !o.outliers.is_empty())
                .count(),
            run.outcomes.len()
        );
        if !self.unseen.is_empty() {
            let names: Vec<String> = self
                .unseen
                .iter()
                .map(|(c, d)| format!("{} ({})", c.info().name, d.name()))
                .collect();
            let _ = writeln!(
                s,
                "not hidden where the design does not see the parameter (a change of its whole tolerance band is less than 1 SE): {}",
                names.join(", ")
            );
        }
        let _ = writeln!(
            s,
            "ex>=6: selected, among sets of >= 6 SE; e|p: selected or named as a confounded partner; coverage: |z| <= 1.96 among\n\
             exact namings at >= 6 SE; any sel: sets with a selection (unperturbed: false selections); tol widths: the hidden\n\
             change in tolerance half-widths. Asserted: e|p>=6 >= 95% over all parameters{}; coverage in the 99% band of\n\
             Binomial(n, 0.95) from 20 namings; false selections consistent with at most 5% (one-sided binomial test at 1%).",
            if ci {
                " (less one binomial standard error)"
            } else {
                ""
            }
        );
        s.push_str(&run.notable());
        s
    }

    /// Confident misnamings and false selections on the unperturbed sets each consistent
    /// with at most 5 %, detection at ≥ 6 SE (less one binomial standard error in CI) and
    /// coverage (from 20 exact namings, which the CI subset does not reach).
    fn checks(&self, run: &Run<Self>, ci: bool) -> Vec<String> {
        let nulls: ParamStats = run.stats(|o| !o.hidden, ParamStats::add);
        let hidden: ParamStats = run.stats(|o| o.hidden, ParamStats::add);
        [
            at_most_rate("false selections on unperturbed sets", nulls.any),
            at_most_rate(
                "confident misnamings (a selection, the hidden parameter neither selected nor named as a partner)",
                hidden.misnamed,
            ),
            detected(
                "named (exactly or as a partner) at >= 6 SE",
                hidden.naming.either,
                ci,
            ),
            coverage_in_band(hidden.naming.coverage, 20),
        ]
        .into_iter()
        .flatten()
        .collect()
    }

    fn notable(&self, o: &ParamOutcome) -> Option<&'static str> {
        let strong = o.truth.strength_se >= ASSERT_FROM_SE;
        if o.hidden && strong && !o.exact_or_partner() {
            Some("missed")
        } else if strong && o.z.is_some_and(|z| z.abs() > 1.96) {
            Some("|z| > 1.96")
        } else if !o.hidden && o.any_selection() {
            Some("false selection")
        } else if o.error.is_some() {
            Some("refused")
        } else {
            None
        }
    }

    fn line(&self, o: &ParamOutcome) -> String {
        let names: Vec<&str> = o.selected.iter().map(|s| s.id.info().name).collect();
        format!(
            "{:<14} seed {:<12} {:>5.1} SE  {:<16} -> [{}]{}",
            o.truth.id.map_or("unperturbed", |i| i.info().name),
            o.seed,
            o.truth.strength_se,
            o.truth.design.name(),
            names.join(", "),
            o.z.map_or(String::new(), |z| format!("  z {z:+.2}"))
        )
    }
}
