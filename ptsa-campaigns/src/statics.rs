//! The hidden-statics campaign: the model equation's static terms hidden as physics in the
//! closed loop's plant and recovered blind from tumbles and a centrifuge.
//!
//! A set is a design of absolute rows ([`StaticDesign`]: an 8-, 12- or 24-point tumble about
//! OA or PA, or a 50 cm centrifuge at 2, 5 and 10 g, IA in and out, after an 8-point tumble)
//! measured on an instrument with one static effect ([`StaticKind`]), or none:
//!
//! | kind | physics, written here from its equation | the candidate that names it |
//! |---|---|---|
//! | IA tilted toward PA by δ (about OA) | the sensed specific force is `a·IA'`, `IA' = cos δ·IA + sin δ·PA`: an extra torque `P·(a·IA' − a_IA)` | `misalignment.delta_p_rad` = δ (first order; the `−δ²/2·a_IA` rest is below 1e-3 ppm here) |
//! | IA tilted toward OA by δ (about PA) | the same with OA | `misalignment.delta_o_rad` = δ |
//! | quadratic torquer/pendulum term | a torque `P·k2·a_IA²` | `nonlinearity` = k2 |
//! | cubic term | a torque `P·k3·a_IA³` | `cubic` = k3 |
//! | bias change | a constant torque `P·Δb` | `bias` = Δb |
//! | scale-factor error | the instrument file's `torquer.current_scale_factor_ma_per_g` changed by Δc in the generator's instrument only, the regulated current held | `scale_factor` = 1e6·Δc/c ppm, or `torquer_sf` = Δc mA/g |
//! | unperturbed | nothing | nothing |
//!
//! The torques enter the plant of eq. 4.2 through [`ExtraPhysics`], from the case inputs the
//! plant itself feels; nothing here calls the candidate code (`CandidateId::term_cm_s2`,
//! `Effects` with a coefficient, a signature). The scale-factor error's truth follows from
//! charge balance: the loop indicates `mean(T_ext)/F·SF`, the torque at full current is
//! `F = (P/c)·I` with the regulated current `I = SF·c₀/g` held, so the indication is
//! `(a_IA + A_b)·c/c₀`: a scale-factor change of `1e6·Δc/c₀` ppm, plus a bias change of
//! `A_b·Δc/c₀` (18.7 cm/s² × Δc/c₀, a fraction of one standard error at these strengths, and
//! orthogonal to `a_IA` once the drift is partialled out in these designs: it does not bias
//! the scale factor's estimate).
//!
//! * **Measurement**: each row is one closed-loop run ([`simulate_condition_with`], or
//!   [`simulate_condition`] of the changed instrument) with its own pickoff-noise seed, plus
//!   Gaussian noise of one sigma per set, uniform in 0.005–0.02 cm/s², from the seeded
//!   `ChaCha8` generator (the loop's own scatter on these rows is about 1e-4 cm/s²).
//!   `sigma_cm_s2` is written in three sets of four; in the fourth the pipeline estimates it.
//! * **Strength**: the coefficient is `±s·SE`, `s` uniform in 2–24, where SE is the hidden
//!   coefficient's standard error alone in the design with the drift in row order partialled
//!   out (the only nuisance term the pipeline fits to absolute rows without `time_s`), from
//!   the design simulated noise-free in the closed loop by central differences of the hidden
//!   physics. Designs are drawn (uniformly among the four, the tumble axis at random) until
//!   the effect has at least [`MIN_PARTIAL`] of its column outside the drift and
//!   `(s + 4)·SE` lies within the instrument file's plausibility bound; where none does in
//!   [`MAX_DESIGN_DRAWS`] draws (the cubic's 1e-10 s⁴/cm² at the larger sigmas, in tumbles) the
//!   design that allows the most is taken at the largest plausible strength (at least 2 SE),
//!   marked `capped`. The design mix per kind is in the table.
//! * **Analysis**: [`discover`] with the closed-loop simulator of the shipped instrument and
//!   its whole vocabulary, the loop's parameters included (their signatures are central
//!   differences through the loop; on these static rows the whole analysis takes 0.01–0.1 s,
//!   so nothing is left out for speed), or with the additive terms only (`with_parameters`
//!   false) for comparison.
//! * **Scored** as the other campaigns: named exactly (an accepted candidate selected), or as
//!   a confounded partner of what is selected (`Selected::confounded`); coverage
//!   `|z| ≤ 1.96` among exact namings at ≥ 6 SE, with the truth in the named candidate's
//!   unit; a confident misnaming is a selection that neither is nor names the truth; any
//!   selection in an unperturbed set is a false selection.
//!
//! Testable or not ([`testability`], printed with the full campaign): a tilt toward PA is
//! seen only about OA (`a_PA = 0` in a tumble about PA and on the centrifuge), a tilt toward
//! OA only about PA or on the centrifuge; the cubic's column is three quarters outside the
//! drift in every tumble but its plausibility bound (1e-10 s⁴/cm²) allows 6 SE in an 8-point
//! tumble only at the smaller sigmas, so most cubic sets are drawn on the centrifuge. A
//! centrifuge alone (OA up, `a_OA = g` on every row) cannot tell a bias change from a tilt
//! toward OA, `cross_axis_oo` or (whole vocabulary) `pickoff_phase`, nor a scale-factor
//! change from anisoelasticity (`a_IA·a_OA = g·a_IA`) or `torquer_sf`; the campaign's
//! centrifuge design therefore starts with an 8-point tumble, after which a bias is
//! testable on its own, the scale factor stays indistinguishable from anisoelasticity (the
//! centrifuge's rows, up to 10 g, dominate both columns: |cos| > 0.99) and, with the tumble about
//! OA, the tilt toward OA from `cross_axis_oo` (both are the centrifuge rows' constant). In
//! every tumble about PA the bias is indistinguishable from `pickoff_phase` (the loop bias a
//! demodulator phase error makes, `−K·θ0/P`, is constant where `a_PA = 0`), and everywhere
//! the scale factor from `torquer_sf`. These are named as partners and scored as such.
//!
//! # Asserted
//!
//! [`Run::failures`] of [`Statics`]: no refusal; a selection that neither is nor names the
//! truth in at most 5 % of the hidden sets, any selection in at most 5 % of the unperturbed
//! sets (one-sided binomial tests at 1 %), coverage in the 99 % band of Binomial(n, 0.95)
//! from 20 exact namings, and exact-or-partner naming at ≥ 6 SE in ≥ 95 % of the hidden
//! sets, pooled over the four designs. The CI subset (`hidden_statics_ci`, 30 sets per kind
//! in each vocabulary) asserts the same, detection less one binomial standard error.
//!
//! # Where it is weak
//!
//! Measured (`cargo xtask hidden --statics [--additive] --sets 200`, seed 4242;
//! `docs/method/discovery.md`, "Hidden-statics tests"): every asserted rate is met in both
//! vocabularies, detection at ≥ 6 SE 96.4 % (additive) and 96.3 % (whole; 96.8 % and 97.0 %
//! before the hysteresis and temperature candidates), but the 8-point
//! tumble alone reaches only 90 % (98–100 % in the other designs). Eight rows hold the drift
//! and six independent columns of the vocabulary (1, sin φ, cos φ, sin 2φ, cos 2φ, sin 3φ),
//! so each selection step's reference model (the current model plus the remaining
//! candidates with an independent column) keeps 2 residual degrees of freedom
//! (`discovery::fit::MIN_REFERENCE_DOF`). A stated sigma those residuals do not reject is
//! pooled with them as worth 2 degrees of freedom (`discovery::fit::STATED_SIGMA_DOF`), so
//! the test is about F(1, 4), not F(1, 2), which a 6-SE effect passed in a quarter of the
//! sets; with the sigma estimated (a quarter of the sets) the test stays F(1, 2), and 14 of
//! the 8-point tumble's 22 misses (whole vocabulary) are those. The misses are not silent: nearly all come with
//! the unexplained-structure warning (column `warned`), whose test does not use that
//! reference model.
//!
//! Where the bias and `pickoff_phase` are indistinguishable (every tumble about PA) the
//! pipeline may select `pickoff_phase` and name the bias as its partner (scored as a
//! partner naming): 23 of 200 bias-change sets with the whole vocabulary.

use std::fmt::Write as _;
use std::sync::Arc;

use ptsa_host_sim::discovery::Selected;
use ptsa_host_sim::discovery::sim::ClosedLoopSimulator;
use ptsa_host_sim::discovery::{Options, Simulator, discover};
use ptsa_host_sim::lab::plan::{self, Axis};
use ptsa_host_sim::model::condition::{CaseInputs, Condition, IA, OA, PA};
use ptsa_host_sim::model::instrument::TORQUER_SF;
use ptsa_host_sim::model::plant::NX;
use ptsa_host_sim::simulation::sim::{
    ExtraPhysics, SimOptions, simulate_condition, simulate_condition_with,
};
use ptsa_host_sim::{CandidateId, Effects, Instrument};
use rand::RngCore as _;
use rayon::prelude::*;

use super::campaign::{
    Campaign, Columns, Count, Naming, Outcome, Run, at_most_rate, coverage_in_band, detected,
};
use super::generate::residualize;
use super::{Draw, Rng, rng};

/// What a set hides.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum StaticKind {
    /// IA tilted toward PA by δ (about OA), rad.
    TiltTowardPa,
    /// IA tilted toward OA by δ (about PA), rad.
    TiltTowardOa,
    /// A torque `P·k2·a_IA²`, k2 in s²/cm.
    Quadratic,
    /// A torque `P·k3·a_IA³`, k3 in s⁴/cm².
    Cubic,
    /// A constant torque `P·Δb`, Δb in cm/s².
    BiasChange,
    /// The torquer's current scale factor changed by Δc mA/g (the regulated current held).
    ScaleFactorError,
    /// Nothing.
    Unperturbed,
}

impl StaticKind {
    /// Every kind, in table order.
    pub const ALL: [StaticKind; 7] = [
        StaticKind::TiltTowardPa,
        StaticKind::TiltTowardOa,
        StaticKind::Quadratic,
        StaticKind::Cubic,
        StaticKind::BiasChange,
        StaticKind::ScaleFactorError,
        StaticKind::Unperturbed,
    ];

    /// Name in tables.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            StaticKind::TiltTowardPa => "IA tilt to PA",
            StaticKind::TiltTowardOa => "IA tilt to OA",
            StaticKind::Quadratic => "quadratic",
            StaticKind::Cubic => "cubic",
            StaticKind::BiasChange => "bias change",
            StaticKind::ScaleFactorError => "scale factor",
            StaticKind::Unperturbed => "unperturbed",
        }
    }

    /// The hidden coefficient's unit.
    #[must_use]
    pub fn unit(self) -> &'static str {
        match self {
            StaticKind::TiltTowardPa | StaticKind::TiltTowardOa => "rad",
            StaticKind::Quadratic => "s²/cm",
            StaticKind::Cubic => "s⁴/cm²",
            StaticKind::BiasChange => "cm/s²",
            StaticKind::ScaleFactorError => "mA/g",
            StaticKind::Unperturbed => "",
        }
    }

    /// The candidates that name it (empty: nothing is hidden).
    #[must_use]
    pub fn names(self) -> &'static [CandidateId] {
        match self {
            StaticKind::TiltTowardPa => &[CandidateId::MisalignmentP],
            StaticKind::TiltTowardOa => &[CandidateId::MisalignmentO],
            StaticKind::Quadratic => &[CandidateId::Nonlinearity],
            StaticKind::Cubic => &[CandidateId::Cubic],
            StaticKind::BiasChange => &[CandidateId::Bias],
            StaticKind::ScaleFactorError => {
                &[CandidateId::ScaleFactor, CandidateId::ParamTorquerSf]
            }
            StaticKind::Unperturbed => &[],
        }
    }

    /// The true value of candidate `id` (one of [`StaticKind::names`]) for a hidden
    /// coefficient `x` in this kind's unit, in the candidate's unit; `c0` is the file's
    /// current scale factor, mA/g.
    #[must_use]
    pub fn truth_as(self, id: CandidateId, x: f64, c0: f64) -> Option<f64> {
        match (self, id) {
            (StaticKind::ScaleFactorError, CandidateId::ScaleFactor) => Some(1e6 * x / c0),
            (StaticKind::ScaleFactorError, CandidateId::ParamTorquerSf) => Some(x),
            (k, id) if k.names().contains(&id) => Some(x),
            _ => None,
        }
    }

    /// The largest plausible hidden coefficient, in this kind's unit: the named candidate's
    /// bound from the instrument file (the scale factor's ppm as a change of `c`).
    fn bound(self, instr: &Instrument) -> f64 {
        let b = |id: CandidateId| id.info().bound.limit(instr);
        match self {
            StaticKind::ScaleFactorError => {
                b(CandidateId::ScaleFactor) * 1e-6 * instr.current_sf_ma_per_g
            }
            StaticKind::Unperturbed => f64::INFINITY,
            k => b(k.names()[0]),
        }
    }
}

/// A design of absolute rows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum StaticDesign {
    /// A tumble of `positions` equally spaced positions about `axis` (OA or PA).
    Tumble {
        /// 8, 12 or 24.
        positions: usize,
        /// OA or PA.
        axis: Axis,
    },
    /// An 8-point tumble about `axis`, then a 50 cm centrifuge at 2, 5 and 10 g, IA in and
    /// out (14 rows).
    CentrifugeTumble {
        /// The tumble's axis.
        axis: Axis,
    },
}

/// The centrifuge's arm, cm.
pub const CENTRIFUGE_ARM_CM: f64 = 50.0;
/// The centrifuge's g levels.
pub const CENTRIFUGE_G: [f64; 3] = [2.0, 5.0, 10.0];

impl StaticDesign {
    /// The design families of the table, in order.
    pub const FAMILIES: [&'static str; 4] = ["t8", "t12", "t24", "cf+t8"];

    /// Its family's index in [`StaticDesign::FAMILIES`].
    #[must_use]
    pub fn family(self) -> usize {
        match self {
            StaticDesign::Tumble { positions: 8, .. } => 0,
            StaticDesign::Tumble { positions: 12, .. } => 1,
            StaticDesign::Tumble { .. } => 2,
            StaticDesign::CentrifugeTumble { .. } => 3,
        }
    }

    /// Name in tables.
    #[must_use]
    pub fn name(self) -> String {
        let ax = |a: Axis| if a == Axis::Oa { "OA" } else { "PA" };
        match self {
            StaticDesign::Tumble { positions, axis } => {
                format!("{positions}-pt tumble {}", ax(axis))
            }
            StaticDesign::CentrifugeTumble { axis } => {
                format!("centrifuge + 8-pt {}", ax(axis))
            }
        }
    }

    /// The rows, unmeasured.
    #[must_use]
    pub fn rows(self, g_cm_s2: f64) -> Vec<Condition> {
        match self {
            StaticDesign::Tumble { positions, axis } => plan::tumble(positions, axis),
            StaticDesign::CentrifugeTumble { axis } => {
                let mut v = plan::tumble(8, axis);
                v.extend(plan::centrifuge(CENTRIFUGE_ARM_CM, &CENTRIFUGE_G, g_cm_s2));
                v
            }
        }
    }

    /// One of the four families at random, the tumble about OA or PA at random.
    fn draw(rng: &mut Rng) -> Self {
        let axis = if rng.uniform() < 0.5 {
            Axis::Oa
        } else {
            Axis::Pa
        };
        match rng.int(0, 3) {
            0 => StaticDesign::Tumble { positions: 8, axis },
            1 => StaticDesign::Tumble {
                positions: 12,
                axis,
            },
            2 => StaticDesign::Tumble {
                positions: 24,
                axis,
            },
            _ => StaticDesign::CentrifugeTumble { axis },
        }
    }

    /// Every design, for the testability table.
    #[must_use]
    pub fn all() -> Vec<StaticDesign> {
        let mut v = Vec::new();
        for positions in [8, 12, 24] {
            for axis in [Axis::Oa, Axis::Pa] {
                v.push(StaticDesign::Tumble { positions, axis });
            }
        }
        for axis in [Axis::Oa, Axis::Pa] {
            v.push(StaticDesign::CentrifugeTumble { axis });
        }
        v
    }
}

/// A static law of extra torque on the pendulum, as an extra specific force along IA.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Law {
    /// IA rotated by `delta_rad` toward case axis `toward`: `a·IA' − a_IA`.
    Tilt { toward: usize, delta_rad: f64 },
    /// `k·a_IA^n`.
    Power { k: f64, n: i32 },
    /// `Δb`.
    Constant { db: f64 },
}

impl Law {
    /// The extra specific force along IA for the specific force `a` (case axes), cm/s².
    fn extra_cm_s2(self, a: [f64; 3]) -> f64 {
        match self {
            Law::Tilt { toward, delta_rad } => {
                let (s, c) = delta_rad.sin_cos();
                // IA' = cos δ·IA + sin δ·(toward); the sensed force is a·IA'.
                a[IA] * c + a[toward] * s - a[IA]
            }
            Law::Power { k, n } => k * a[IA].powi(n),
            Law::Constant { db } => db,
        }
    }
}

/// `P·law(a)` on the pendulum, from the inputs the plant feels.
#[derive(Debug)]
struct StaticTorque {
    p_g_cm: f64,
    law: Law,
}

impl ExtraPhysics for StaticTorque {
    fn torque_dyn_cm(&self, _t_s: f64, inputs: &CaseInputs, _x: &[f64; NX]) -> f64 {
        self.p_g_cm * self.law.extra_cm_s2(inputs.a_cm_s2)
    }
}

/// The specific force a static row applies, cm/s², by this module's own kinematics:
/// gravity, and a centrifuge arm's `|w|²·radius` along the part of IA perpendicular to the
/// spin axis (IA mounted pointing at the axis for a positive radius; `docs/reference/case-frame-format.md`).
#[must_use]
pub fn static_force(row: &Condition, g_cm_s2: f64) -> [f64; 3] {
    let mut a = row.g.map(|x| x * g_cm_s2);
    let w = row.w_rad_s;
    let w2: f64 = w.iter().map(|x| x * x).sum();
    if row.radius_cm != 0.0 && w2 > 0.0 {
        let wn = w2.sqrt();
        let mut u = [1.0, 0.0, 0.0];
        for (j, uj) in u.iter_mut().enumerate() {
            *uj -= w[IA] / wn * w[j] / wn;
        }
        let nu = u.iter().map(|x| x * x).sum::<f64>().sqrt();
        if nu > 1e-9 {
            for (aj, uj) in a.iter_mut().zip(u) {
                *aj += w2 * row.radius_cm * uj / nu;
            }
        }
    }
    a
}

/// The law of `kind` with hidden coefficient `x` (`None` for the scale-factor error, made
/// in the instrument, and for the unperturbed sets).
fn law(kind: StaticKind, x: f64) -> Option<Law> {
    match kind {
        StaticKind::TiltTowardPa => Some(Law::Tilt {
            toward: PA,
            delta_rad: x,
        }),
        StaticKind::TiltTowardOa => Some(Law::Tilt {
            toward: OA,
            delta_rad: x,
        }),
        StaticKind::Quadratic => Some(Law::Power { k: x, n: 2 }),
        StaticKind::Cubic => Some(Law::Power { k: x, n: 3 }),
        StaticKind::BiasChange => Some(Law::Constant { db: x }),
        StaticKind::ScaleFactorError | StaticKind::Unperturbed => None,
    }
}

/// One closed-loop run of `row` with `kind`'s physics at coefficient `x`: the mean indicated
/// acceleration, `SF·(2P/T − 1)` with the file's SF in the limit, cm/s². `seed`: the
/// pickoff-noise seed (`None`: no pickoff noise).
///
/// # Panics
/// The instrument refuses its own torquer key (a bug).
#[must_use]
pub fn closed_loop_row(kind: StaticKind, x: f64, row: &Condition, seed: Option<u64>) -> f64 {
    let mut instr = Instrument::kearfott_2401();
    let opts = SimOptions {
        seed: seed.unwrap_or(1),
        noise: seed.is_some(),
        ..SimOptions::default()
    };
    if kind == StaticKind::ScaleFactorError {
        let c0 = instr.current_sf_ma_per_g;
        TORQUER_SF.set(&mut instr, c0 + x);
    }
    let none = Effects::NONE;
    match law(kind, x) {
        Some(l) => {
            let hook = Arc::new(StaticTorque {
                p_g_cm: instr.pendulosity_g_cm(),
                law: l,
            });
            simulate_condition_with(&instr, row, &none, &opts, hook)
        }
        None => simulate_condition(&instr, row, &none, &opts),
    }
    .indicated_cm_s2
}

/// Largest `|extra specific force|` of a unit coefficient of `kind` over `rows`, cm/s²
/// (own kinematics; the scale-factor error's is `|a_IA + A_b|/c₀` per mA/g).
fn unit_peak(kind: StaticKind, rows: &[Condition], instr: &Instrument) -> f64 {
    let g = instr.g_cm_s2;
    rows.iter()
        .map(|r| {
            let a = static_force(r, g);
            match law(kind, 1.0) {
                // A unit tilt's sine is not its first-order size: use the small-angle law.
                Some(Law::Tilt { toward, .. }) => a[toward].abs(),
                Some(l) => l.extra_cm_s2(a).abs(),
                None => (a[IA] + instr.bias_cm_s2).abs() / instr.current_sf_ma_per_g,
            }
        })
        .fold(0.0, f64::max)
}

/// The closed loop's sensitivity of every row to the hidden coefficient of `kind`, by
/// central differences of noise-free runs with a step that moves the largest row by
/// 20 cm/s² (the even part of a tilt, `−δ²/2·a_IA`, cancels in them).
#[must_use]
pub fn unit_column(kind: StaticKind, rows: &[Condition]) -> Vec<f64> {
    let instr = Instrument::kearfott_2401();
    let pk = unit_peak(kind, rows, &instr);
    if pk == 0.0 || kind == StaticKind::Unperturbed {
        return vec![0.0; rows.len()];
    }
    let h = 20.0 / pk;
    rows.par_iter()
        .map(|r| {
            (closed_loop_row(kind, h, r, None) - closed_loop_row(kind, -h, r, None)) / (2.0 * h)
        })
        .collect()
}

/// The nuisance term the pipeline fits to `n` absolute rows without `time_s`: a drift in
/// row order about its mean (when it leaves a degree of freedom).
#[must_use]
pub fn drift_basis(n: usize) -> Vec<Vec<f64>> {
    if n < 2 {
        return Vec::new();
    }
    #[allow(clippy::cast_precision_loss)]
    let m = (n - 1) as f64 / 2.0;
    #[allow(clippy::cast_precision_loss)]
    let drift = (0..n).map(|i| i as f64 - m).collect();
    vec![drift]
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// Designs drawn at most for one set.
pub const MAX_DESIGN_DRAWS: usize = 200;

/// Smallest part of the hidden effect's column outside the drift.
pub const MIN_PARTIAL: f64 = 0.3;

/// What a set hides.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct StaticTruth {
    /// The kind.
    pub kind: StaticKind,
    /// The hidden coefficient, in the kind's unit (0 unperturbed).
    pub coef: f64,
    /// `|coef|` in standard errors of it alone in this design.
    pub strength_se: f64,
    /// The design.
    pub design: StaticDesign,
    /// The noise sigma, cm/s².
    pub sigma: f64,
    /// `sigma_cm_s2` written.
    pub sigma_written: bool,
    /// No design allowed the drawn strength within the plausibility bound.
    pub capped: bool,
}

/// A set: measured rows and the truth.
#[derive(Clone, Debug)]
pub struct StaticSet {
    /// Absolute rows with `measured_cm_s2` (and `sigma_cm_s2` where written).
    pub rows: Vec<Condition>,
    /// What was hidden.
    pub truth: StaticTruth,
}

/// Make set `seed` hiding `kind`.
///
/// # Panics
/// No design of the campaign shows the effect outside the drift (a generator bug).
#[must_use]
pub fn generate(seed: u64, kind: StaticKind) -> StaticSet {
    let mut r = rng(seed);
    let instr = Instrument::kearfott_2401();
    let g = instr.g_cm_s2;
    let sigma = r.range(0.005, 0.02);
    let sigma_written = r.uniform() >= 0.25;
    let mut strength = r.range(2.0, 24.0);
    let sign = r.sign();
    let limit = kind.bound(&instr);
    let mut accepted: Option<(StaticDesign, Vec<Condition>, f64)> = None;
    let mut best: Option<(f64, StaticDesign, Vec<Condition>, f64)> = None;
    for _ in 0..MAX_DESIGN_DRAWS {
        let design = StaticDesign::draw(&mut r);
        let rows = design.rows(g);
        if kind == StaticKind::Unperturbed {
            accepted = Some((design, rows, 0.0));
            break;
        }
        let col = unit_column(kind, &rows);
        let part = norm(&residualize(&col, &drift_basis(rows.len())));
        if part == 0.0 || part < MIN_PARTIAL * norm(&col) {
            continue;
        }
        let allowed = limit * part / sigma - 4.0;
        if allowed < strength {
            if best.as_ref().is_none_or(|b| allowed > b.0) {
                best = Some((allowed, design, rows, part));
            }
            continue;
        }
        accepted = Some((design, rows, part));
        break;
    }
    let mut capped = false;
    if accepted.is_none()
        && let Some((allowed, design, rows, part)) = best
    {
        capped = true;
        strength = allowed.max(2.0);
        accepted = Some((design, rows, part));
    }
    let Some((design, mut rows, part)) = accepted else {
        panic!("seed {seed}: no design shows {}", kind.name());
    };
    let (coef, strength_se) = if kind == StaticKind::Unperturbed {
        (0.0, 0.0)
    } else {
        (sign * strength * sigma / part, strength)
    };
    let seeds: Vec<u64> = (0..rows.len()).map(|_| r.next_u64()).collect();
    let clean: Vec<f64> = rows
        .par_iter()
        .zip(&seeds)
        .map(|(row, &s)| closed_loop_row(kind, coef, row, Some(s)))
        .collect();
    for (row, y) in rows.iter_mut().zip(clean) {
        row.measured_cm_s2 = Some(y + sigma * r.normal());
        row.sigma_cm_s2 = sigma_written.then_some(sigma);
    }
    StaticSet {
        rows,
        truth: StaticTruth {
            kind,
            coef,
            strength_se,
            design,
            sigma,
            sigma_written,
            capped,
        },
    }
}

/// The pipeline's options: the whole vocabulary, or the additive terms only.
#[must_use]
pub fn options(with_parameters: bool) -> Options {
    let mut o = Options::for_instrument(&Instrument::kearfott_2401());
    if !with_parameters {
        o.candidates.retain(|c| c.parameter_key().is_none());
    }
    o
}

/// The hidden-statics campaign: the pipeline is the closed loop of the shipped file, with
/// its whole vocabulary or the additive terms only.
#[derive(Debug)]
pub struct Statics {
    /// The loop's parameters are candidates.
    pub with_parameters: bool,
    /// The pipeline's simulator.
    pub sim: ClosedLoopSimulator,
    /// The pipeline's options ([`options`]).
    pub options: Options,
    /// The file's current scale factor, mA/g.
    pub c0: f64,
}

impl Statics {
    /// The campaign with the whole vocabulary (`with_parameters`) or the additive terms.
    #[must_use]
    pub fn new(with_parameters: bool) -> Self {
        let nominal = Instrument::kearfott_2401();
        Statics {
            with_parameters,
            c0: nominal.current_sf_ma_per_g,
            sim: ClosedLoopSimulator {
                instrument: nominal,
                options: SimOptions::default(),
            },
            options: options(with_parameters),
        }
    }
}

/// Run `sets` sets of every kind (the unperturbed included).
#[must_use]
pub fn run(sets: usize, seed: u64, with_parameters: bool) -> Run<Statics> {
    Run::new(Statics::new(with_parameters), sets, seed)
}

/// Strength from which detection and coverage are asserted, SE.
pub const ASSERT_FROM_SE: f64 = Naming::FROM_SE;

/// A set's outcome.
pub type StaticOutcome = Outcome<StaticTruth>;

/// One kind's (or the hidden kinds') figures.
#[derive(Clone, Copy, Debug, Default)]
pub struct KindStats {
    /// Sets.
    pub sets: usize,
    /// How the hidden kinds were named (at ≥ 6 SE).
    pub naming: Naming,
    /// Hidden kinds: a selection, the truth neither selected nor a partner.
    pub misnamed: Count,
    /// Hidden kinds: the truth named, and a selection beside it that neither is nor names
    /// it.
    pub extra: Count,
    /// Hidden kinds: a selection that neither is nor names the truth (`misnamed` or
    /// `extra`); unperturbed: any selection. Asserted.
    pub wrong: Count,
    /// Among the misses at ≥ 6 SE: the unexplained-structure test fired.
    pub warned: Count,
    /// Sets whose strength was capped at the plausibility bound.
    pub capped: usize,
    /// Sets per design family ([`StaticDesign::FAMILIES`]).
    pub designs: [usize; 4],
    /// Sets with a row flagged as a suspected gross error (none is injected).
    pub outliers: Count,
}

impl KindStats {
    fn add(&mut self, o: &StaticOutcome) {
        let t = &o.truth;
        self.sets += 1;
        self.designs[t.design.family()] += 1;
        self.capped += usize::from(t.capped);
        self.outliers.add(!o.outliers.is_empty());
        if t.kind == StaticKind::Unperturbed {
            self.wrong.add(o.any_selection());
            return;
        }
        self.misnamed.add(o.misnamed());
        self.extra.add(o.extra > 0 && o.exact_or_partner());
        self.wrong.add(o.extra > 0);
        if self.naming.add(o, t.strength_se) {
            self.warned.add(o.unexplained);
        }
    }
}

impl Run<Statics> {
    /// The figures of `kind`.
    #[must_use]
    pub fn kind_stats(&self, kind: StaticKind) -> KindStats {
        self.stats(|o| o.truth.kind == kind, KindStats::add)
    }

    /// The hidden kinds together, in the design families `families`.
    #[must_use]
    pub fn hidden_stats(&self, families: &[usize]) -> KindStats {
        self.stats(
            |o| {
                o.truth.kind != StaticKind::Unperturbed
                    && families.contains(&o.truth.design.family())
            },
            KindStats::add,
        )
    }
}

/// The design families over which detection is asserted (pooled): all of them.
const DETECTION_SCOPE: [usize; 4] = [0, 1, 2, 3];

/// The names of the design families `scope`.
fn families(scope: &[usize]) -> String {
    scope
        .iter()
        .map(|&i| StaticDesign::FAMILIES[i])
        .collect::<Vec<_>>()
        .join(", ")
}

impl Campaign for Statics {
    type Kind = StaticKind;
    type Truth = StaticTruth;

    fn kinds(&self) -> Vec<StaticKind> {
        StaticKind::ALL.to_vec()
    }

    fn generate(&self, seed: u64, kind: StaticKind) -> (Vec<Condition>, StaticTruth) {
        let set = generate(seed, kind);
        (set.rows, set.truth)
    }

    fn names<'a>(&self, truth: &'a StaticTruth) -> &'a [CandidateId] {
        truth.kind.names()
    }

    fn z(&self, t: &StaticTruth, s: &Selected) -> Option<f64> {
        t.kind
            .truth_as(s.id, t.coef, self.c0)
            .map(|truth| (s.coef - truth) / s.stderr)
    }

    fn pipeline(&self) -> (&dyn Simulator, &Options) {
        (&self.sim, &self.options)
    }

    fn title(&self, run: &Run<Self>) -> String {
        format!(
            "hidden-statics campaign: {} sets per kind, seed {}; data: closed loop with the physics in the plant + noise 0.005-0.02 cm/s²; \
             pipeline: closed loop of the shipped file, {}; {:.1} s",
            run.sets,
            run.seed,
            if self.with_parameters {
                "whole vocabulary (loop parameters included)"
            } else {
                "additive terms only"
            },
            run.seconds
        )
    }

    fn columns(&self) -> Columns {
        Naming::columns(vec![
            vec![("misnamed", 8), ("extra", 8), ("wrong", 8)],
            vec![("warned", 8)],
            vec![("capped", 6)],
            vec![("t8/t12/t24/cf+t8", 16)],
            vec![("outliers", 8)],
        ])
    }

    fn rows(&self, run: &Run<Self>) -> Vec<(String, Vec<String>)> {
        let row = |name: String, k: KindStats, null: bool| {
            let dash = |c: Count| if null { "-".to_string() } else { c.cell() };
            let mut cells = vec![k.sets.to_string()];
            cells.extend(k.naming.cells(dash));
            cells.extend([
                dash(k.misnamed),
                dash(k.extra),
                k.wrong.marked(),
                dash(k.warned),
                if null {
                    "-".to_string()
                } else {
                    k.capped.to_string()
                },
                k.designs.map(|x| x.to_string()).join("/"),
                k.outliers.cell(),
            ]);
            (name, cells)
        };
        let mut v: Vec<(String, Vec<String>)> = StaticKind::ALL
            .iter()
            .filter(|&&kind| kind != StaticKind::Unperturbed)
            .map(|&kind| row(kind.name().to_string(), run.kind_stats(kind), false))
            .collect();
        v.push(row(
            "all hidden".into(),
            run.hidden_stats(&DETECTION_SCOPE),
            false,
        ));
        v.push(row(
            "unperturbed".into(),
            run.kind_stats(StaticKind::Unperturbed),
            true,
        ));
        for (f, name) in StaticDesign::FAMILIES.iter().enumerate() {
            v.push(row(format!("  in {name}"), run.hidden_stats(&[f]), false));
            v.push(row(
                format!("  unpert. {name}"),
                run.stats(
                    |o| o.truth.kind == StaticKind::Unperturbed && o.truth.design.family() == f,
                    KindStats::add,
                ),
                true,
            ));
        }
        v
    }

    fn legend(&self, _run: &Run<Self>, ci: bool) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "ex>=6: an accepted name selected (scale factor: scale_factor or torquer_sf), among the sets of >= 6 SE; e|p: exactly or\n\
             only as a confounded partner; partner: only as a partner (all strengths); coverage: |z| <= 1.96 among exact namings at\n\
             >= 6 SE; misnamed: a selection, the truth neither selected nor a partner; extra: the truth named and a selection beside\n\
             it that neither is nor names it; wrong: either (unperturbed: any selection; ! when P(>= k of n) at 5% is below 0.01);\n\
             warned: misses at >= 6 SE with the unexplained-structure warning; capped: strength cut to the plausibility bound;\n\
             t8/t12/t24/cf+t8: sets per design (8-, 12-, 24-point tumble, centrifuge after an 8-point tumble), and per design below;\n\
             outliers: sets with a row flagged as a suspected gross error (none is injected).\n\
             Asserted: wrong over all hidden kinds and over the unperturbed sets consistent with at most 5%; coverage in the 99% band\n\
             of Binomial(n, 0.95) from 20 exact namings; e|p>=6 >= 95%{} over {}.",
            if ci {
                " less one binomial standard error"
            } else {
                ""
            },
            families(&DETECTION_SCOPE)
        );
        s
    }

    fn checks(&self, run: &Run<Self>, ci: bool) -> Vec<String> {
        let h = run.hidden_stats(&DETECTION_SCOPE);
        let detection = format!(
            "named (exactly or as a partner) at >= 6 SE in {}",
            families(&DETECTION_SCOPE)
        );
        [
            at_most_rate(
                "false selections on unperturbed sets",
                run.kind_stats(StaticKind::Unperturbed).wrong,
            ),
            at_most_rate(
                "misnamings (a selection that neither is nor names the truth)",
                h.wrong,
            ),
            coverage_in_band(h.naming.coverage, 20),
            detected(&detection, h.naming.either, ci),
        ]
        .into_iter()
        .flatten()
        .collect()
    }

    fn notable(&self, o: &StaticOutcome) -> Option<&'static str> {
        let strong = o.truth.strength_se >= ASSERT_FROM_SE;
        if o.error.is_some() {
            Some("refused")
        } else if o.truth.kind == StaticKind::Unperturbed {
            o.any_selection().then_some("false selection")
        } else if o.misnamed() {
            Some("misnamed")
        } else if strong && !o.exact_or_partner() {
            Some("missed")
        } else if o.extra > 0 {
            Some("extra selection")
        } else if strong && o.z.is_some_and(|z| z.abs() > 1.96) {
            Some("|z| > 1.96")
        } else if !o.outliers.is_empty() {
            Some("outlier flagged")
        } else {
            None
        }
    }

    fn line(&self, o: &StaticOutcome) -> String {
        let t = &o.truth;
        let sel = super::campaign::selection_text(&o.selected);
        format!(
            "{:<14} seed {:<12} {:>5.1} SE{} {:.3e} {:<6} {:<20} sigma {:.4}{} -> [{}]{}{}{}",
            t.kind.name(),
            o.seed,
            t.strength_se,
            if t.capped { "*" } else { " " },
            t.coef,
            t.kind.unit(),
            t.design.name(),
            t.sigma,
            if t.sigma_written { "" } else { " (est.)" },
            sel,
            o.unexplained_note(),
            o.z.map_or(String::new(), |z| format!("  z {z:+.2}")),
            o.outliers_and_error("  "),
        )
    }
}

/// What each design can test: for every design and hidden kind, the part of the effect's
/// closed-loop column outside the drift (over its whole norm; `-` when the column is zero),
/// and the groups of candidates the pipeline finds indistinguishable there before any fit
/// (`Discovery::confounded_groups`, on the design's noise-free rows); and a centrifuge alone
/// for comparison.
#[must_use]
pub fn testability(with_parameters: bool) -> String {
    let instr = Instrument::kearfott_2401();
    let g = instr.g_cm_s2;
    let sim = ClosedLoopSimulator {
        instrument: instr.clone(),
        options: SimOptions::default(),
    };
    let mut designs: Vec<(String, Vec<Condition>)> = StaticDesign::all()
        .into_iter()
        .map(|d| (d.name(), d.rows(g)))
        .collect();
    designs.push((
        "centrifuge alone".into(),
        plan::centrifuge(CENTRIFUGE_ARM_CM, &CENTRIFUGE_G, g),
    ));
    let kinds: Vec<StaticKind> = StaticKind::ALL
        .iter()
        .copied()
        .filter(|&k| k != StaticKind::Unperturbed)
        .collect();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "testability: part of each effect's column outside the drift in row order; groups the pipeline cannot tell apart there"
    );
    let _ = write!(s, "{:<24}", "design");
    for k in &kinds {
        let _ = write!(s, " {:>13}", k.name());
    }
    let _ = writeln!(s, "  indistinguishable");
    for (name, rows) in designs {
        let _ = write!(s, "{name:<24}");
        for &k in &kinds {
            let col = unit_column(k, &rows);
            let n = norm(&col);
            if n == 0.0 {
                let _ = write!(s, " {:>13}", "-");
            } else {
                let part = norm(&residualize(&col, &drift_basis(rows.len()))) / n;
                let _ = write!(s, " {part:>13.2}");
            }
        }
        let mut measured = rows.clone();
        for r in &mut measured {
            r.measured_cm_s2 = Some(closed_loop_row(StaticKind::Unperturbed, 0.0, r, None));
            r.sigma_cm_s2 = Some(0.01);
        }
        let groups = discover(&measured, &sim, &options(with_parameters)).map_or_else(
            |e| format!("error: {e}"),
            |d| {
                d.confounded_groups
                    .iter()
                    .map(|gr| {
                        gr.iter()
                            .map(|c| c.info().name)
                            .collect::<Vec<_>>()
                            .join(" = ")
                    })
                    .collect::<Vec<_>>()
                    .join("; ")
            },
        );
        let _ = writeln!(s, "  {groups}");
    }
    s
}
