//! The physics hidden in a set, written here from the equations and entered into the closed
//! loop through channels that share no code with the candidate vocabulary of
//! `ptsa_host_sim::model::effects` (whose signatures the analyser fits):
//!
//! | effect | channel |
//! |---|---|
//! | anisoinertia | the instrument's `anisoinertia_g_cm2` (`I_PA − I_IA` of eq. 4.2, which the plant models, `θ` term included) |
//! | lever arm `r` | constant rates: the centripetal acceleration `w × (w × r)` added to the row's gravity (all three axes, so the plant's cross-coupling `−P·a_PA·θ` sees it too), condition and reference simulated separately; oscillations: the rest of `dw × r + w × (w × r)` along IA as a torque `P·a_IA` through [`ExtraPhysics`], from this module's own sines and cosines of the row's phases |
//! | products of the inputs (vibropendulosity, anisoelasticity, nonlinearity, sculling, and the out-of-vocabulary terms) | a torque `P·k·(product)` through [`ExtraPhysics`], from the [`CaseInputs`] the plant itself feels |
//! | bias shift, drift | the instrument's `bias_cm_s2`, different in a row's condition run and its reference run |
//!
//! [`Generator::QuasiStatic`] is this module's own quasi-static model of the same physics
//! (the time average over a period, by its own sampling of its own kinematics, no loop): the
//! fast generator of `--analytic` campaigns and of the stress tests.

use std::f64::consts::TAU;
use std::sync::Arc;

use ptsa_host_sim::model::condition::{CaseInputs, Condition};
use ptsa_host_sim::model::instrument::Instrument;
use ptsa_host_sim::model::plant::NX;
use ptsa_host_sim::simulation::sim::{
    ExtraPhysics, SimOptions, simulate_condition, simulate_condition_with,
};

const IA: usize = 0;
const PA: usize = 1;
const OA: usize = 2;

/// `a × b`.
#[must_use]
pub fn cross3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Kinematic acceleration of a point at `r` (cm) from the centre of rotation of a body
/// turning at `w` (rad/s) with angular acceleration `dw` (rad/s²): `dw × r + w × (w × r)`.
#[must_use]
pub fn lever_arm_accel(w: [f64; 3], dw: [f64; 3], r: [f64; 3]) -> [f64; 3] {
    let a = cross3(dw, r);
    let b = cross3(w, cross3(w, r));
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// A product of the case inputs, as an extra specific force along IA per unit coefficient.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Product {
    /// `a_IA·a_PA` (vibropendulosity), s²/cm.
    AiaApa,
    /// `a_IA·a_OA` (anisoelasticity), s²/cm.
    AiaAoa,
    /// `a_IA²` (nonlinearity), s²/cm.
    AiaAia,
    /// `dw_OA·a_PA` (sculling), s².
    DwoaApa,
    /// `a_PA²` (cross-axis), s²/cm.
    ApaApa,
    /// `w_OA·a_PA` (a rate–acceleration cross term; not in the vocabulary), s.
    WoaApa,
    /// A constant (a bias change), cm/s².
    One,
    /// `1e-6·a_IA` (a scale-factor change in ppm).
    AiaPpm,
    /// `a_PA` (IA tilted toward PA), rad.
    Apa,
    /// `a_OA` (IA tilted toward OA), rad.
    Aoa,
    /// `a_IA³`, s⁴/cm².
    AiaCubed,
    /// `a_OA²` (cross-axis), s²/cm.
    AoaAoa,
    /// `a_PA·a_OA` (cross-axis), s²/cm.
    ApaAoa,
}

impl Product {
    /// The product at one instant.
    #[must_use]
    pub fn eval(self, i: &CaseInputs) -> f64 {
        let a = i.a_cm_s2;
        match self {
            Product::AiaApa => a[IA] * a[PA],
            Product::AiaAoa => a[IA] * a[OA],
            Product::AiaAia => a[IA] * a[IA],
            Product::DwoaApa => i.dw_rad_s2[OA] * a[PA],
            Product::ApaApa => a[PA] * a[PA],
            Product::WoaApa => i.w_rad_s[OA] * a[PA],
            Product::One => 1.0,
            Product::AiaPpm => 1e-6 * a[IA],
            Product::Apa => a[PA],
            Product::Aoa => a[OA],
            Product::AiaCubed => a[IA] * a[IA] * a[IA],
            Product::AoaAoa => a[OA] * a[OA],
            Product::ApaAoa => a[PA] * a[OA],
        }
    }

    /// As written in tables.
    #[must_use]
    pub fn formula(self) -> &'static str {
        match self {
            Product::AiaApa => "k·a_IA·a_PA",
            Product::AiaAoa => "k·a_IA·a_OA",
            Product::AiaAia => "k·a_IA²",
            Product::DwoaApa => "k·dw_OA·a_PA",
            Product::ApaApa => "k·a_PA²",
            Product::WoaApa => "k·w_OA·a_PA",
            Product::One => "k",
            Product::AiaPpm => "k·1e-6·a_IA",
            Product::Apa => "k·a_PA",
            Product::Aoa => "k·a_OA",
            Product::AiaCubed => "k·a_IA³",
            Product::AoaAoa => "k·a_OA²",
            Product::ApaAoa => "k·a_PA·a_OA",
        }
    }
}

/// Physics in the instrument beyond the baseline model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Physics {
    /// `I_PA − I_IA`, g·cm² (the instrument parameter).
    Anisoinertia {
        /// `I_PA − I_IA`, g·cm².
        delta_i_g_cm2: f64,
    },
    /// The proof mass sits at `r` (cm, case axes) from the centre of rotation.
    LeverArm {
        /// Offset, cm.
        r_cm: [f64; 3],
    },
    /// An extra specific force `k·product` along IA.
    Product {
        /// The product.
        term: Product,
        /// Its coefficient.
        k: f64,
    },
}

impl Physics {
    /// The same physics `c` times as large.
    #[must_use]
    pub fn scaled(self, c: f64) -> Physics {
        match self {
            Physics::Anisoinertia { delta_i_g_cm2 } => Physics::Anisoinertia {
                delta_i_g_cm2: c * delta_i_g_cm2,
            },
            Physics::LeverArm { r_cm } => Physics::LeverArm {
                r_cm: r_cm.map(|x| c * x),
            },
            Physics::Product { term, k } => Physics::Product { term, k: c * k },
        }
    }
}

/// A row's motion from its case-frame columns (`docs/reference/case-frame-format.md`), evaluated with this
/// module's own trigonometry: gravity `g` (in g) fixed in the laboratory, constant rates,
/// linear vibration `amp·sin(ωt + phase)`, small angular oscillation
/// `φ = amp·sin(ωt + phase)` whose rate adds to the constant rates and which tilts gravity
/// in the case frame, `g_case = g − φ × g`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Motion {
    /// Angular frequency, rad/s (0 = no oscillation).
    pub omega: f64,
    /// Gravity's specific force, cm/s².
    pub g_cm_s2: [f64; 3],
    /// Constant rates, rad/s.
    pub w0: [f64; 3],
    /// Linear vibration amplitude, cm/s², and phase, rad.
    pub lin: [(f64, f64); 3],
    /// Angular oscillation amplitude, rad, and phase, rad.
    pub ang: [(f64, f64); 3],
}

impl Motion {
    /// The motion of `row` with local gravity `g_cm_s2`.
    #[must_use]
    pub fn of(row: &Condition, g_cm_s2: f64) -> Motion {
        let osc = row.freq_hz > 0.0;
        let pair = |amp: f64, deg: f64| {
            if osc {
                (amp, deg.to_radians())
            } else {
                (0.0, 0.0)
            }
        };
        Motion {
            omega: TAU * row.freq_hz,
            g_cm_s2: row.g.map(|x| x * g_cm_s2),
            w0: row.w_rad_s,
            lin: std::array::from_fn(|j| pair(row.lin_cm_s2[j], row.lin_deg[j])),
            ang: std::array::from_fn(|j| pair(row.ang_mrad[j] * 1e-3, row.ang_deg[j])),
        }
    }

    /// Whether anything oscillates.
    #[must_use]
    pub fn oscillates(&self) -> bool {
        self.omega > 0.0 && self.lin.iter().chain(&self.ang).any(|&(a, _)| a != 0.0)
    }

    /// Angle, rate and angular acceleration of the oscillation at `t`, and the total rate.
    fn angles(&self, t: f64) -> ([f64; 3], [f64; 3], [f64; 3]) {
        let w = self.omega;
        let mut phi = [0.0; 3];
        let mut rate = self.w0;
        let mut dw = [0.0; 3];
        for j in 0..3 {
            let (amp, ph) = self.ang[j];
            if amp != 0.0 {
                let (s, c) = (w * t + ph).sin_cos();
                phi[j] = amp * s;
                rate[j] += amp * w * c;
                dw[j] = -amp * w * w * s;
            }
        }
        (phi, rate, dw)
    }

    /// Rate and angular acceleration at `t`.
    #[must_use]
    pub fn rates(&self, t: f64) -> ([f64; 3], [f64; 3]) {
        let (_, w, dw) = self.angles(t);
        (w, dw)
    }

    /// What the instrument feels at `t`.
    #[must_use]
    pub fn inputs(&self, t: f64) -> CaseInputs {
        let (phi, w, dw) = self.angles(t);
        let tilt = cross3(phi, self.g_cm_s2);
        let mut a = [0.0; 3];
        for j in 0..3 {
            let (amp, ph) = self.lin[j];
            a[j] = self.g_cm_s2[j] - tilt[j];
            if amp != 0.0 {
                a[j] += amp * (self.omega * t + ph).sin();
            }
        }
        CaseInputs {
            a_cm_s2: a,
            w_rad_s: w,
            dw_rad_s2: dw,
            // Nothing of a row's history: the lab campaign (`super::lab`) writes its own.
            ..CaseInputs::default()
        }
    }

    /// `n` equally spaced instants over one period (one instant if nothing oscillates).
    fn instants(&self, n: u32) -> Vec<f64> {
        if !self.oscillates() {
            return vec![0.0];
        }
        let period = TAU / self.omega;
        (0..n)
            .map(|k| period * f64::from(k) / f64::from(n))
            .collect()
    }
}

/// Samples per period of the quasi-static averages: exact for trigonometric polynomials of
/// degree < 16 (the physics here has degree ≤ 2).
const SAMPLES: u32 = 16;

/// The lever arm's torque beyond the constant rates' centripetal part (which enters through
/// the row's gravity): `P·[dw × r + w × (w × r) − w0 × (w0 × r)]_IA` with the row's own
/// oscillation.
#[derive(Debug)]
struct LeverArmTorque {
    p_g_cm: f64,
    r_cm: [f64; 3],
    motion: Motion,
    steady_ia: f64,
}

impl ExtraPhysics for LeverArmTorque {
    fn torque_dyn_cm(&self, t_s: f64, _inputs: &CaseInputs, _x: &[f64; NX]) -> f64 {
        let (w, dw) = self.motion.rates(t_s);
        self.p_g_cm * (lever_arm_accel(w, dw, self.r_cm)[IA] - self.steady_ia)
    }
}

/// `P·k·product(inputs)`.
#[derive(Debug)]
struct ProductTorque {
    p_g_cm: f64,
    k: f64,
    term: Product,
}

impl ExtraPhysics for ProductTorque {
    fn torque_dyn_cm(&self, _t_s: f64, inputs: &CaseInputs, _x: &[f64; NX]) -> f64 {
        self.p_g_cm * self.k * self.term.eval(inputs)
    }
}

/// What acts in one set: physics, and the instrument bias of a row's condition and reference
/// runs (added to the instrument file's).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Injection {
    /// Physics beyond the baseline model.
    pub physics: Option<Physics>,
    /// Extra bias in the condition's run, cm/s².
    pub bias_condition_cm_s2: f64,
    /// Extra bias in the reference's run, cm/s².
    pub bias_reference_cm_s2: f64,
}

/// How the measured values are made.
#[derive(Clone, Debug)]
pub enum Generator {
    /// The closed loop of the instrument (ptsa-core against the plant of eq. 4.2), with the
    /// physics in it.
    ClosedLoop(Instrument),
    /// This module's quasi-static model: the time average of the physics over one period
    /// (own sampling), condition minus reference, no loop dynamics.
    QuasiStatic(Instrument),
}

impl Generator {
    /// The closed loop of the shipped instrument.
    #[must_use]
    pub fn closed_loop() -> Self {
        Generator::ClosedLoop(Instrument::kearfott_2401())
    }

    /// The quasi-static model of the shipped instrument.
    #[must_use]
    pub fn quasi_static() -> Self {
        Generator::QuasiStatic(Instrument::kearfott_2401())
    }

    /// The instrument.
    #[must_use]
    pub fn instrument(&self) -> &Instrument {
        match self {
            Generator::ClosedLoop(i) | Generator::QuasiStatic(i) => i,
        }
    }

    /// Short name.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Generator::ClosedLoop(_) => "closed loop with injected physics",
            Generator::QuasiStatic(_) => "own quasi-static model",
        }
    }

    /// Row `row`'s condition-minus-reference difference with `inj`, cm/s². `seed` is the
    /// loop's pickoff-noise seed (`None`: no pickoff noise); the quasi-static model has none.
    #[must_use]
    pub fn difference_cm_s2(&self, row: &Condition, inj: &Injection, seed: Option<u64>) -> f64 {
        match self {
            Generator::ClosedLoop(instr) => closed_loop_difference(instr, row, inj, seed),
            Generator::QuasiStatic(instr) => quasi_static_difference(instr, row, inj),
        }
    }
}

/// Extra specific force along IA that `physics` gives in `motion` at `t` (quasi-static
/// model), cm/s².
fn extra_ia(physics: &Physics, motion: &Motion, p_g_cm: f64, t: f64) -> f64 {
    match *physics {
        Physics::Anisoinertia { delta_i_g_cm2 } => {
            let (w, _) = motion.rates(t);
            delta_i_g_cm2 / p_g_cm * w[IA] * w[PA]
        }
        Physics::LeverArm { r_cm } => {
            let (w, dw) = motion.rates(t);
            lever_arm_accel(w, dw, r_cm)[IA]
        }
        Physics::Product { term, k } => k * term.eval(&motion.inputs(t)),
    }
}

/// Time average of the extra specific force along IA over one period of `motion`, cm/s².
#[must_use]
pub fn mean_extra_ia(physics: &Physics, motion: &Motion, p_g_cm: f64) -> f64 {
    let ts = motion.instants(SAMPLES);
    #[allow(clippy::cast_precision_loss)]
    let n = ts.len() as f64;
    ts.iter()
        .map(|&t| extra_ia(physics, motion, p_g_cm, t))
        .sum::<f64>()
        / n
}

/// Largest `|extra specific force along IA|` over one period of `motion`, cm/s².
#[must_use]
pub fn peak_extra_ia(physics: &Physics, motion: &Motion, p_g_cm: f64) -> f64 {
    motion
        .instants(SAMPLES)
        .iter()
        .map(|&t| extra_ia(physics, motion, p_g_cm, t).abs())
        .fold(0.0, f64::max)
}

fn quasi_static_difference(instr: &Instrument, row: &Condition, inj: &Injection) -> f64 {
    let g = instr.g_cm_s2;
    let p = instr.pendulosity_g_cm();
    let mut d = inj.bias_condition_cm_s2 - inj.bias_reference_cm_s2;
    if let Some(ph) = &inj.physics {
        d += mean_extra_ia(ph, &Motion::of(row, g), p)
            - mean_extra_ia(ph, &Motion::of(&row.reference(), g), p);
    }
    d
}

/// One run of the closed loop: `cond` with extra bias `bias` and `physics`.
fn closed_loop_run(
    instr: &Instrument,
    cond: &Condition,
    bias: f64,
    physics: Option<&Physics>,
    opts: &SimOptions,
) -> f64 {
    let mut instr = instr.clone();
    instr.bias_cm_s2 += bias;
    let p = instr.pendulosity_g_cm();
    let g = instr.g_cm_s2;
    let mut cond = cond.clone();
    let mut hook: Option<Arc<dyn ExtraPhysics>> = None;
    match physics {
        None => {}
        Some(&Physics::Anisoinertia { delta_i_g_cm2 }) => {
            instr.anisoinertia_g_cm2 += delta_i_g_cm2;
        }
        Some(&Physics::LeverArm { r_cm }) => {
            // The constant rates' centripetal acceleration through the row's gravity.
            let steady = lever_arm_accel(cond.w_rad_s, [0.0; 3], r_cm);
            for (gj, sj) in cond.g.iter_mut().zip(steady) {
                *gj += sj / g;
            }
            let motion = Motion::of(&cond, g);
            if motion.oscillates() {
                hook = Some(Arc::new(LeverArmTorque {
                    p_g_cm: p,
                    r_cm,
                    motion,
                    steady_ia: steady[IA],
                }));
            }
        }
        Some(&Physics::Product { term, k }) => {
            hook = Some(Arc::new(ProductTorque { p_g_cm: p, k, term }));
        }
    }
    let none = ptsa_host_sim::Effects::NONE;
    match hook {
        Some(h) => simulate_condition_with(&instr, &cond, &none, opts, h),
        None => simulate_condition(&instr, &cond, &none, opts),
    }
    .indicated_cm_s2
}

fn closed_loop_difference(
    instr: &Instrument,
    row: &Condition,
    inj: &Injection,
    seed: Option<u64>,
) -> f64 {
    let opts = |s: u64| SimOptions {
        seed: s,
        noise: seed.is_some(),
        ..SimOptions::default()
    };
    let s = seed.unwrap_or(1);
    let c = closed_loop_run(
        instr,
        row,
        inj.bias_condition_cm_s2,
        inj.physics.as_ref(),
        &opts(s),
    );
    let r = closed_loop_run(
        instr,
        &row.reference(),
        inj.bias_reference_cm_s2,
        inj.physics.as_ref(),
        &opts(s ^ 0x9e37_79b9_7f4a_7c15),
    );
    c - r
}
