//! One synthetic measured set: a design, what is hidden in it, the noise, and the
//! measured values made by a [`Generator`] (the closed loop with the physics injected, or
//! this crate's own quasi-static model of it). Nothing here calls the candidate code of
//! `ptsa_host_sim` (`Effects` with a coefficient, its terms or signatures, the analytic
//! simulator); the hidden coefficient's size in standard errors comes from simulating the
//! design with a unit physical effect.

use ptsa_host_sim::model::condition::Condition;
use ptsa_host_sim::model::effects::{Bound, CandidateId};
use rand::RngCore as _;
use rayon::prelude::*;

use super::designs::Design;
use super::physics::{Generator, Injection, Motion, Physics, Product, peak_extra_ia};
use super::{Draw, Rng, rng};

/// Out-of-vocabulary physics: products of the inputs that no candidate of
/// `ptsa_host_sim::model::effects::REGISTRY` spans (its products are `a_IA·a_PA`, `a_IA·a_OA`,
/// `a_IA²`, `dw_OA·a_PA`, the model equation's `1`, `a_IA`, `a_PA`, `a_OA`, `a_IA³`, `a_PA²`,
/// `a_OA²`, `a_PA·a_OA`, and the lever arm's and anisoinertia's rate terms). Keep this the
/// one list: when the vocabulary grows to cover a term, move it out of here and into
/// [`candidate_physics`].
///
/// Each term is hidden twice: [`Kind::OutOfVocabulary`] in designs where at least
/// [`MIN_PARTIAL`] of its column lies outside the span of the nuisance terms and every
/// candidate (so the data can tell it from the vocabulary), and [`Kind::Aliased`] in designs
/// where less than [`ALIASED`] does (the data are those of an in-vocabulary set).
pub const OUT_OF_VOCABULARY: &[Product] = &[Product::WoaApa];

/// What a set hides.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Kind {
    /// One candidate's physics.
    Candidate(CandidateId),
    /// Physics no candidate spans ([`OUT_OF_VOCABULARY`]), in a design that can tell it
    /// from the vocabulary.
    OutOfVocabulary(Product),
    /// The same physics in a design where the vocabulary spans it: no analyser can tell it
    /// from a candidate, and the right answer is a warning the pipeline does not give today.
    /// Reported, not asserted.
    Aliased(Product),
    /// A bias change between the condition runs and their reference run, per block.
    BiasShift,
    /// A bias growing with the row's time.
    Drift,
    /// Nothing; one noise sigma per set.
    Null,
    /// Nothing; noise 0.05 cm/s² on rate-table rows and 0.5 on oscillating rows, sigma not
    /// written.
    NullHetGroups,
    /// Nothing; noise `0.02 + 0.4·|w_IA·w_PA|/max` cm/s², sigma not written.
    NullHetRate,
}

/// How a kind is scored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    /// A candidate is hidden: detection power and coverage.
    Candidate,
    /// Something the pipeline must not name with confidence: misnaming rate.
    NotNameable,
    /// Nothing is hidden: false selections.
    Null,
    /// Out-of-vocabulary physics the design aliases with the vocabulary: confident
    /// misnamings, reported only.
    Aliased,
}

impl Kind {
    /// Every kind, in table order.
    #[must_use]
    pub fn all() -> Vec<Kind> {
        let mut v: Vec<Kind> = CandidateId::ALL
            .iter()
            .filter(|&&c| hidden_in_difference_data(c))
            .map(|&c| Kind::Candidate(c))
            .collect();
        v.extend(OUT_OF_VOCABULARY.iter().map(|&p| Kind::OutOfVocabulary(p)));
        v.extend(OUT_OF_VOCABULARY.iter().map(|&p| Kind::Aliased(p)));
        v.extend([
            Kind::BiasShift,
            Kind::Drift,
            Kind::Null,
            Kind::NullHetGroups,
            Kind::NullHetRate,
        ]);
        v
    }

    /// Name in tables.
    #[must_use]
    pub fn name(self) -> String {
        match self {
            Kind::Candidate(c) => c.info().name.to_string(),
            Kind::OutOfVocabulary(p) => format!("oov {}", p.formula()),
            Kind::Aliased(p) => format!("oov {}, aliased", p.formula()),
            Kind::BiasShift => "bias shift per block".into(),
            Kind::Drift => "drift".into(),
            Kind::Null => "null".into(),
            Kind::NullHetGroups => "null, sigma by group".into(),
            Kind::NullHetRate => "null, sigma ~ |w_IA w_PA|".into(),
        }
    }

    /// How it is scored.
    #[must_use]
    pub fn class(self) -> Class {
        match self {
            Kind::Candidate(_) => Class::Candidate,
            Kind::OutOfVocabulary(_) | Kind::BiasShift | Kind::Drift => Class::NotNameable,
            Kind::Null | Kind::NullHetGroups | Kind::NullHetRate => Class::Null,
            Kind::Aliased(_) => Class::Aliased,
        }
    }
}

/// A candidate's physics for a unit coefficient in the candidate's unit, written here from
/// the equations (eq. 4.2, the kinematics of an offset proof mass, and the model equation's
/// products of the inputs); `None` for a parameter of the instrument file (hidden in the
/// file itself by the parameter campaign). The match is exhaustive: a candidate added to the
/// registry does not compile here until its physics is written.
#[must_use]
pub fn candidate_physics(id: CandidateId, p_g_cm: f64) -> Option<Physics> {
    let product = |term| Some(Physics::Product { term, k: 1.0 });
    match id {
        // k_ai = (I_PA − I_IA)/P.
        CandidateId::Anisoinertia => Some(Physics::Anisoinertia {
            delta_i_g_cm2: p_g_cm,
        }),
        CandidateId::LeverArmIa => Some(Physics::LeverArm {
            r_cm: [1.0, 0.0, 0.0],
        }),
        CandidateId::LeverArmPa => Some(Physics::LeverArm {
            r_cm: [0.0, 1.0, 0.0],
        }),
        CandidateId::LeverArmOa => Some(Physics::LeverArm {
            r_cm: [0.0, 0.0, 1.0],
        }),
        CandidateId::Vibropendulosity => product(Product::AiaApa),
        CandidateId::Anisoelasticity => product(Product::AiaAoa),
        CandidateId::Nonlinearity => product(Product::AiaAia),
        CandidateId::Sculling => product(Product::DwoaApa),
        CandidateId::Bias => product(Product::One),
        CandidateId::ScaleFactor => product(Product::AiaPpm),
        CandidateId::MisalignmentP => product(Product::Apa),
        CandidateId::MisalignmentO => product(Product::Aoa),
        CandidateId::Cubic => product(Product::AiaCubed),
        CandidateId::CrossAxisPp => product(Product::ApaApa),
        CandidateId::CrossAxisOo => product(Product::AoaAoa),
        CandidateId::CrossAxisPo => product(Product::ApaAoa),
        // Effects of a row's history, temperature and time since power-on: absolute rows of
        // a tumble, hidden by
        // the lab campaign (`super::lab`) from their own equations; nothing here in
        // difference data, where a hysteresis cancels against the reference run.
        CandidateId::Hysteresis
        | CandidateId::TemperatureBias
        | CandidateId::TemperatureScaleFactor
        | CandidateId::WarmUpSpan16
        | CandidateId::WarmUpSpan12
        | CandidateId::WarmUpSpan8
        | CandidateId::WarmUpSpan6
        | CandidateId::WarmUpSpan4
        | CandidateId::WarmUpSpan3
        | CandidateId::WarmUpSpan2
        | CandidateId::WarmUp
        | CandidateId::ParamDamping
        | CandidateId::ParamSpring
        | CandidateId::ParamInertia
        | CandidateId::ParamPendulosity
        | CandidateId::ParamTorquerSf
        | CandidateId::ParamTorquerLag
        | CandidateId::ParamPickoffGain
        | CandidateId::ParamPickoffPhase
        | CandidateId::ParamAmplifierGain
        | CandidateId::ParamAdcOffset => None,
    }
}

/// The candidates this (difference-data) campaign hides: those with physics here whose
/// difference column is not identically zero or a multiple of another's in every design.
/// The model equation's static terms (bias, scale factor, misalignment) cancel between a
/// condition and its reference, and the cubic's difference under vibration along IA is the
/// nonlinearity's; they are hidden in absolute data by the hidden-statics campaign
/// ([`super::statics`]).
#[must_use]
pub fn hidden_in_difference_data(id: CandidateId) -> bool {
    candidate_physics(id, 1.0).is_some()
        && !matches!(
            id,
            CandidateId::Bias
                | CandidateId::ScaleFactor
                | CandidateId::MisalignmentP
                | CandidateId::MisalignmentO
                | CandidateId::Cubic
        )
}

/// What was hidden in a set.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Truth {
    /// The kind.
    pub kind: Kind,
    /// The hidden candidate, if the kind is one.
    pub candidate: Option<CandidateId>,
    /// Its coefficient in the candidate's unit (out of vocabulary: `k`; drift: cm/s² per
    /// s; else 0).
    pub coef: f64,
    /// `|coef|` in standard errors of that coefficient in this design with the nuisance
    /// terms the pipeline always fits (block shifts, drift), with the true noise (0 for the
    /// nulls).
    pub strength_se: f64,
    /// The design.
    pub design: Design,
    /// Rows.
    pub rows: usize,
    /// The noise, as text (`0.21`, `0.05/0.5`, ...).
    pub sigma: String,
    /// `sigma_cm_s2` written.
    pub sigma_written: bool,
    /// Blocks written (1 = no `block` column).
    pub blocks: usize,
    /// `time_s` written.
    pub time_written: bool,
    /// No design allowed the drawn strength at a plausible size: the strength is the
    /// largest plausible one of the best design.
    pub capped: bool,
    /// Out of vocabulary: the part of the effect's column outside the span of the nuisance
    /// terms and every candidate's physics, over its part outside the nuisance terms.
    pub outside_vocabulary: Option<f64>,
}

/// A synthetic measured set.
#[derive(Clone, Debug)]
pub struct HiddenSet {
    /// Rows in the case frame, with `measured_cm_s2` (and `sigma_cm_s2`, `block`, `time_s`
    /// where written).
    pub rows: Vec<Condition>,
    /// What was hidden.
    pub truth: Truth,
}

/// Options of the generator beyond the kind.
#[derive(Clone, Copy, Debug)]
pub struct GenOptions {
    /// True noise over the stated sigma (1: the stated sigma is right).
    pub noise_factor: f64,
    /// Force `sigma_cm_s2` written (`Some(true)`), left out (`Some(false)`), or a quarter
    /// of the sets without it (`None`).
    pub write_sigma: Option<bool>,
}

impl Default for GenOptions {
    fn default() -> Self {
        Self {
            noise_factor: 1.0,
            write_sigma: None,
        }
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// `v` minus its projection on the span of `basis` (Gram–Schmidt, twice for accuracy).
#[must_use]
pub fn residualize(v: &[f64], basis: &[Vec<f64>]) -> Vec<f64> {
    let mut q: Vec<Vec<f64>> = Vec::new();
    for b in basis {
        let mut u = b.clone();
        for _ in 0..2 {
            for e in &q {
                let d: f64 = u.iter().zip(e).map(|(x, y)| x * y).sum();
                for (x, y) in u.iter_mut().zip(e) {
                    *x -= d * y;
                }
            }
        }
        let n = norm(&u);
        if n > 1e-12 * norm(b).max(f64::MIN_POSITIVE) {
            q.push(u.iter().map(|x| x / n).collect());
        }
    }
    let mut r = v.to_vec();
    for _ in 0..2 {
        for e in &q {
            let d: f64 = r.iter().zip(e).map(|(x, y)| x * y).sum();
            for (x, y) in r.iter_mut().zip(e) {
                *x -= d * y;
            }
        }
    }
    r
}

/// Blocks and times of the rows.
#[derive(Clone, Debug)]
struct Layout {
    /// Block of each row.
    block: Vec<usize>,
    blocks: usize,
    /// Time of each row, s (the drift's clock).
    time: Vec<f64>,
    time_written: bool,
}

impl Layout {
    fn single(n: usize) -> Self {
        #[allow(clippy::cast_precision_loss)]
        let time = (0..n).map(|i| (i + 1) as f64).collect();
        Layout {
            block: vec![0; n],
            blocks: 1,
            time,
            time_written: false,
        }
    }

    /// Contiguous blocks of at least three rows each, 2–4 of them (one if there are fewer
    /// than six rows).
    fn blocks(rng: &mut Rng, n: usize) -> Self {
        let mut l = Layout::single(n);
        let b = rng.int(2, 4).min(n / 3).max(1);
        // Three rows per block, the rest spread at random.
        let mut size = vec![3usize; b];
        for _ in 0..n.saturating_sub(3 * b) {
            size[rng.int(0, b - 1)] += 1;
        }
        let mut i = 0;
        for (k, &m) in size.iter().enumerate() {
            for blk in &mut l.block[i..(i + m).min(n)] {
                *blk = k;
            }
            i += m;
        }
        l.blocks = b;
        l
    }

    /// Rows measured every 30–120 s; `time_s` written (with jitter) in half the sets.
    fn timed(rng: &mut Rng, n: usize) -> Self {
        let mut l = Layout::single(n);
        let dt = rng.range(30.0, 120.0);
        l.time_written = rng.uniform() < 0.5;
        for (i, t) in l.time.iter_mut().enumerate() {
            #[allow(clippy::cast_precision_loss)]
            let base = (i + 1) as f64 * dt;
            *t = if l.time_written {
                base + rng.range(-0.3, 0.3) * dt
            } else {
                base
            };
        }
        l
    }

    /// The nuisance columns the pipeline fits: a bias per block, and a drift in `time_s`
    /// (or row order) when it leaves a degree of freedom.
    fn basis(&self) -> Vec<Vec<f64>> {
        let n = self.block.len();
        let mut v: Vec<Vec<f64>> = (0..self.blocks)
            .map(|b| {
                self.block
                    .iter()
                    .map(|&x| if x == b { 1.0 } else { 0.0 })
                    .collect()
            })
            .collect();
        if n > self.blocks + 1 {
            #[allow(clippy::cast_precision_loss)]
            let t: Vec<f64> = if self.time_written {
                self.time.clone()
            } else {
                (0..n).map(|i| i as f64).collect()
            };
            #[allow(clippy::cast_precision_loss)]
            let m = t.iter().sum::<f64>() / n as f64;
            v.push(t.iter().map(|x| x - m).collect());
        }
        v
    }
}

/// Designs drawn at most for one set.
const MAX_DESIGN_DRAWS: usize = 200;

/// Smallest part of the hidden effect's column outside the nuisance terms' span (the
/// pipeline cannot test a candidate below `sqrt(1 − 0.99²)` = 0.14), and of an
/// out-of-vocabulary effect's outside the vocabulary's.
pub const MIN_PARTIAL: f64 = 0.3;

/// Largest part of an aliased effect's column outside the vocabulary's span: the
/// pipeline's own threshold of indistinguishable signatures, `sqrt(1 − 0.99²)`.
pub const ALIASED: f64 = 0.141;

fn pick_design(rng: &mut Rng, kind: Kind) -> (Design, Option<usize>) {
    let u = rng.uniform();
    match kind {
        Kind::NullHetGroups => (
            if u < 0.75 {
                Design::Combined
            } else {
                Design::FortyEight
            },
            None,
        ),
        Kind::NullHetRate => (
            if u < 0.5 {
                Design::RateTable
            } else {
                Design::Combined
            },
            Some(1),
        ),
        _ => (
            if u < 0.3 {
                Design::RateTable
            } else if u < 0.6 {
                Design::TwoAxis
            } else if u < 0.9 {
                Design::Combined
            } else {
                Design::FortyEight
            },
            None,
        ),
    }
}

/// Largest plausible magnitude of the hidden coefficient: the candidate's bound from the
/// instrument file, and for the out-of-vocabulary terms the second-order bound (`a_PA²`)
/// or 1 s (`w_OA·a_PA`: no bound in the instrument file; 1 s keeps the term below a few
/// hundred cm/s² in these designs, in the loop's linear range).
fn bound(kind: Kind, instr: &ptsa_host_sim::Instrument) -> f64 {
    let b = |b: Bound| b.limit(instr);
    match kind {
        Kind::Candidate(c) => b(c.info().bound),
        Kind::OutOfVocabulary(Product::WoaApa) | Kind::Aliased(Product::WoaApa) => 1.0,
        Kind::OutOfVocabulary(_) | Kind::Aliased(_) => b(Bound::SecondOrder),
        _ => f64::INFINITY,
    }
}

/// Peak of the unit effect over the rows (condition and reference), cm/s².
fn peak(rows: &[Condition], unit: &Physics, g: f64, p: f64) -> f64 {
    rows.iter()
        .flat_map(|r| [Motion::of(r, g), Motion::of(&r.reference(), g)])
        .map(|m| peak_extra_ia(unit, &m, p))
        .fold(0.0, f64::max)
}

/// The effect of a unit physical coefficient on every row, by `source` without pickoff noise:
/// the difference of a run with a coefficient scaled to a peak of 20 cm/s² and one without,
/// over the scale.
fn unit_column(source: &Generator, rows: &[Condition], unit: &Physics) -> Vec<f64> {
    let instr = source.instrument();
    let pk = peak(rows, unit, instr.g_cm_s2, instr.pendulosity_g_cm());
    let c = if pk > 0.0 { 20.0 / pk } else { 1.0 };
    let with = Injection {
        physics: Some(unit.scaled(c)),
        ..Injection::default()
    };
    rows.par_iter()
        .map(|r| {
            (source.difference_cm_s2(r, &with, None)
                - source.difference_cm_s2(r, &Injection::default(), None))
                / c
        })
        .collect()
}

/// The part of `unit`'s column outside the span of the nuisance terms and every
/// candidate's physics (this module's own, [`candidate_physics`], by the quasi-static model
/// `quasi`), over its part outside the nuisance terms: 0 when the vocabulary spans the
/// effect in this design (no analyser can tell them apart), 1 when it is orthogonal to it.
fn outside_vocabulary(
    quasi: &Generator,
    rows: &[Condition],
    layout: &Layout,
    unit: &Physics,
) -> f64 {
    let p = quasi.instrument().pendulosity_g_cm();
    let col = unit_column(quasi, rows, unit);
    let mut basis = layout.basis();
    let within = norm(&residualize(&col, &basis));
    for &c in CandidateId::ALL {
        if let Some(ph) = candidate_physics(c, p) {
            basis.push(unit_column(quasi, rows, &ph));
        }
    }
    if within == 0.0 {
        0.0
    } else {
        norm(&residualize(&col, &basis)) / within
    }
}

/// Build one set of `kind` from `seed` with `source`.
///
/// # Panics
/// If no design of the generator shows the effect at a plausible size (a generator bug).
#[must_use]
#[allow(clippy::too_many_lines)]
pub fn generate(seed: u64, kind: Kind, source: &Generator, opts: &GenOptions) -> HiddenSet {
    let mut rng = rng(seed);
    let instr = source.instrument().clone();
    let p = instr.pendulosity_g_cm();
    let sigma = rng.range(0.1, 0.3);
    let write_sigma = match kind {
        Kind::NullHetGroups | Kind::NullHetRate => false,
        _ => opts.write_sigma.unwrap_or_else(|| rng.uniform() >= 0.25),
    };
    let mut strength = rng.range(2.0, 24.0);
    let sign = rng.sign();
    let unit = match kind {
        Kind::Candidate(c) => candidate_physics(c, p),
        Kind::OutOfVocabulary(term) | Kind::Aliased(term) => {
            Some(Physics::Product { term, k: 1.0 })
        }
        _ => None,
    };
    let quasi = Generator::QuasiStatic(instr.clone());
    let limit = bound(kind, &instr);
    // Draw designs until the effect shows outside the nuisance terms at a plausible size:
    // `(strength + 4)·SE` within the bound, so that the estimate stays within it too (judged
    // on the quick quasi-static column; the size is then set on `source`'s own); an
    // out-of-vocabulary effect must also lie outside the vocabulary's span (or, aliased,
    // inside it). Where no design allows the drawn strength (sculling's bound of 1e-4 s² is
    // tight for these designs), the design that allows the most is taken at the largest
    // plausible strength (at least 2 SE); where none has the required aliasing, the one
    // closest to it. Either way the set is marked `capped`.
    let mut accepted = None;
    let mut best: Option<(f64, Design, Vec<Condition>, Layout)> = None;
    let mut closest: Option<(f64, Design, Vec<Condition>, Layout)> = None;
    for _ in 0..MAX_DESIGN_DRAWS {
        let (design, plane) = pick_design(&mut rng, kind);
        let rows = design.rows(&mut rng, plane);
        let layout = match kind {
            Kind::BiasShift => Layout::blocks(&mut rng, rows.len()),
            Kind::Drift => Layout::timed(&mut rng, rows.len()),
            _ => Layout::single(rows.len()),
        };
        if let Some(u) = &unit {
            let col = unit_column(&quasi, &rows, u);
            let part = norm(&residualize(&col, &layout.basis()));
            if part == 0.0 || part < MIN_PARTIAL * norm(&col) {
                continue;
            }
            // How far the design is from the aliasing the kind needs (0 = as needed).
            let miss = match kind {
                Kind::OutOfVocabulary(_) => {
                    (MIN_PARTIAL - outside_vocabulary(&quasi, &rows, &layout, u)).max(0.0)
                }
                Kind::Aliased(_) => {
                    (outside_vocabulary(&quasi, &rows, &layout, u) - ALIASED).max(0.0)
                }
                _ => 0.0,
            };
            if miss > 0.0 {
                if closest.as_ref().is_none_or(|c| miss < c.0) {
                    closest = Some((miss, design, rows, layout));
                }
                continue;
            }
            let allowed = limit * part / sigma - 4.0;
            if allowed < strength {
                if best.as_ref().is_none_or(|b| allowed > b.0) {
                    best = Some((allowed, design, rows, layout));
                }
                continue;
            }
        }
        accepted = Some((design, rows, layout));
        break;
    }
    let mut capped = false;
    if accepted.is_none() {
        capped = true;
        if let Some((allowed, design, rows, layout)) = best {
            strength = allowed.max(2.0);
            accepted = Some((design, rows, layout));
        } else if let Some((_, design, rows, layout)) = closest {
            accepted = Some((design, rows, layout));
        }
    }
    let Some((design, mut rows, layout)) = accepted else {
        panic!("seed {seed}: no design shows {}", kind.name());
    };
    let n = rows.len();
    let outside_vocabulary = match (kind, &unit) {
        (Kind::OutOfVocabulary(_) | Kind::Aliased(_), Some(u)) => {
            Some(outside_vocabulary(&quasi, &rows, &layout, u))
        }
        _ => None,
    };
    // Size of the hidden effect in standard errors, from the generator's own unit column.
    let (physics, coef, strength_se) = match &unit {
        Some(u) => {
            let col = unit_column(source, &rows, u);
            let part = norm(&residualize(&col, &layout.basis()));
            assert!(part > 0.0, "seed {seed}: {} has no column", kind.name());
            let coef = sign * strength * sigma / part;
            (Some(u.scaled(coef)), coef, strength)
        }
        None => (None, 0.0, 0.0),
    };
    // Per-row bias of the condition and reference runs.
    let mut bias_c = vec![0.0; n];
    let (coef, strength_se) = match kind {
        Kind::BiasShift => {
            for b in 0..layout.blocks {
                let nb = layout.block.iter().filter(|&&x| x == b).count();
                #[allow(clippy::cast_precision_loss)]
                let shift = rng.sign() * rng.range(2.0, 24.0) * sigma / (nb as f64).sqrt();
                for (i, &x) in layout.block.iter().enumerate() {
                    if x == b {
                        bias_c[i] = shift;
                    }
                }
            }
            (0.0, 0.0)
        }
        Kind::Drift => {
            #[allow(clippy::cast_precision_loss)]
            let m = layout.time.iter().sum::<f64>() / n as f64;
            let spread = norm(&layout.time.iter().map(|t| t - m).collect::<Vec<_>>());
            let d = sign * strength * sigma / spread;
            // The reference run is measured at t = 0, each condition at its own time.
            for (b, t) in bias_c.iter_mut().zip(&layout.time) {
                *b = d * t;
            }
            (d, strength)
        }
        _ => (coef, strength_se),
    };
    // Noise of each row.
    let nf = opts.noise_factor;
    let (row_sigma, sigma_text): (Vec<f64>, String) = match kind {
        Kind::NullHetGroups => (
            rows.iter()
                .map(|r| {
                    if Motion::of(r, 1.0).oscillates() {
                        0.5
                    } else {
                        0.05
                    }
                })
                .collect(),
            "0.05/0.5".into(),
        ),
        Kind::NullHetRate => {
            let s: Vec<f64> = rows
                .iter()
                .map(|r| (r.w_rad_s[0] * r.w_rad_s[1]).abs())
                .collect();
            let mx = s.iter().copied().fold(0.0, f64::max).max(f64::MIN_POSITIVE);
            (
                s.iter().map(|x| 0.02 + 0.4 * x / mx).collect(),
                "0.02+0.4|wIA wPA|".into(),
            )
        }
        _ => (vec![sigma; n], format!("{sigma:.2}")),
    };
    let seeds: Vec<u64> = (0..n).map(|_| rng.next_u64()).collect();
    let clean: Vec<f64> = rows
        .par_iter()
        .enumerate()
        .map(|(i, r)| {
            let inj = Injection {
                physics,
                bias_condition_cm_s2: bias_c[i],
                bias_reference_cm_s2: 0.0,
            };
            source.difference_cm_s2(r, &inj, Some(seeds[i]))
        })
        .collect();
    for (i, r) in rows.iter_mut().enumerate() {
        r.measured_cm_s2 = Some(clean[i] + nf * row_sigma[i] * rng.normal());
        r.sigma_cm_s2 = write_sigma.then_some(row_sigma[i]);
        if layout.blocks > 1 {
            r.block = Some(format!("run {}", layout.block[i] + 1));
        }
        if layout.time_written {
            r.time_s = Some(layout.time[i]);
        }
    }
    HiddenSet {
        rows,
        truth: Truth {
            kind,
            candidate: match kind {
                Kind::Candidate(c) => Some(c),
                _ => None,
            },
            coef,
            strength_se,
            design,
            rows: n,
            sigma: sigma_text,
            sigma_written: write_sigma,
            blocks: layout.blocks,
            time_written: layout.time_written,
            capped,
            outside_vocabulary,
        },
    }
}
