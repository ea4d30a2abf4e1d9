//! The candidate registry: every error term the baseline model leaves out and `ptsa discover`
//! may name, in one table.
//!
//! Each [`Candidate`] is one coefficient: its effect name and coefficient key (both part of
//! the `--json` contract), the coefficient's unit (cgs), the term it adds to the indicated
//! acceleration, and how its signature is computed. [`Effects`] holds one value per
//! candidate and is indexed by the typed [`CandidateId`], never by a bare number; everything
//! that names, sets, fits or prints a candidate goes through [`CandidateId::info`].
//!
//! Adding a term of the model equation is one [`CandidateId`] variant and one [`REGISTRY`]
//! entry (and, for a term that needs new inputs, the case-frame columns that carry them).

use serde::Serialize;

use crate::model::condition::{CaseInputs, IA, OA, PA, cross};
use crate::model::instrument::{self, Parameter};

/// How a candidate's signature (its effect per unit coefficient on a row) is computed.
#[derive(Clone, Copy, Debug)]
pub enum Signature {
    /// An extra indicated acceleration that is linear in the coefficient: `term(inputs)` is
    /// its value for a unit coefficient at one instant, cm/s². The loop indicates its time
    /// average (an extra torque `P·term` on the pendulum, eq. 4.2).
    Term(fn(&CaseInputs) -> f64),
    /// A parameter of the instrument file (its entry of [`crate::model::instrument::PARAMETERS`]):
    /// the coefficient is the change from the file's value, in the file's unit, and the
    /// signature is the closed loop's sensitivity to it, by finite differences through the
    /// simulator.
    Parameter(&'static Parameter),
}

/// Where a candidate stands in the IEEE Std 1293 model equation of a pendulous
/// accelerometer's static output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelTerm {
    /// A first-order term (bias, scale factor, misalignment): when two candidates fit the
    /// data exactly as well, the selection takes one of these before any other (the simpler
    /// explanation); absolute rows can test it.
    FirstOrder,
    /// A higher-order static term (the products of two accelerations, the cubic): absolute
    /// rows can test it, and discovery's advice proposes rows when they cannot.
    HigherOrder,
    /// Not a term of the static model equation: an angular-rate or dynamic term
    /// (anisoinertia, lever arm, sculling) or a parameter of the loop.
    Outside,
}

/// Which plausibility bound of the instrument file ([`crate::model::instrument::Plausibility`])
/// limits a candidate's coefficient.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bound {
    /// `lever_arm_cm`.
    LeverArm,
    /// `anisoinertia_g_cm2`, divided by the pendulosity into the coefficient's cm.
    Anisoinertia,
    /// `second_order_s2_cm`.
    SecondOrder,
    /// `sculling_s2`.
    Sculling,
    /// `bias_cm_s2`.
    Bias,
    /// `scale_factor_ppm`.
    ScaleFactor,
    /// `misalignment_rad`.
    Misalignment,
    /// `cubic_s4_cm2`.
    Cubic,
    /// `hysteresis_cm_s2`.
    Hysteresis,
    /// `bias_per_c_cm_s2`.
    BiasPerDegree,
    /// `scale_factor_per_c_ppm`.
    ScaleFactorPerDegree,
    /// `warm_up_cm_s2`.
    WarmUp,
    /// The parameter's tolerance band in the instrument file.
    Tolerance,
}

impl Bound {
    /// The largest plausible magnitude of the coefficient, in the candidate's unit.
    #[must_use]
    pub fn limit(self, instr: &crate::model::instrument::Instrument) -> f64 {
        let p = &instr.plausibility;
        match self {
            Bound::LeverArm => p.lever_arm_cm,
            Bound::Anisoinertia => p.anisoinertia_g_cm2 / instr.pendulosity_g_cm(),
            Bound::SecondOrder => p.second_order_s2_cm,
            Bound::Sculling => p.sculling_s2,
            Bound::Bias => p.bias_cm_s2,
            Bound::ScaleFactor => p.scale_factor_ppm,
            Bound::Misalignment => p.misalignment_rad,
            Bound::Cubic => p.cubic_s4_cm2,
            Bound::Hysteresis => p.hysteresis_cm_s2,
            Bound::BiasPerDegree => p.bias_per_c_cm_s2,
            Bound::ScaleFactorPerDegree => p.scale_factor_per_c_ppm,
            Bound::WarmUp => p.warm_up_cm_s2,
            Bound::Tolerance => f64::INFINITY,
        }
    }
}

/// One candidate coefficient of the vocabulary.
#[derive(Clone, Copy, Debug)]
pub struct Candidate {
    /// Its typed name.
    pub id: CandidateId,
    /// Effect name in the JSON (`anisoinertia`, `lever_arm`, ...).
    pub effect: &'static str,
    /// Coefficient key, units in the name (`k_ai_cm`, `r_pa_cm`, ...).
    pub key: &'static str,
    /// Name in lists and `confounded_with`: the effect name, or `effect.key` for the
    /// components of a multi-coefficient effect (`lever_arm.r_pa_cm`).
    pub name: &'static str,
    /// Unit of the coefficient (cgs, as in the report).
    pub unit: &'static str,
    /// The term, as written in the docs.
    pub formula: &'static str,
    /// How its signature is computed.
    pub signature: Signature,
    /// Its plausibility bound.
    pub bound: Bound,
    /// Its symbol and unit in an IEEE Std 1293 model equation, and the factor from the
    /// coefficient's cgs unit to that unit for local gravity `g` (cm/s²).
    pub ieee: (&'static str, &'static str, fn(f64) -> f64),
    /// Where it stands in the static model equation.
    pub model_term: ModelTerm,
}

macro_rules! candidates {
    ($($id:ident = $effect:literal, $key:literal, $name:literal, $unit:expr, $formula:literal, $sig:expr, $bound:expr, $ieee:expr, $term:ident;)*) => {
        /// Typed name of a candidate coefficient (the order is the order of every listing,
        /// and the selection's tie-break after [`CandidateId::first_order`]).
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
        pub enum CandidateId {
            $(
                #[doc = concat!("`", $name, "` (`", $key, "`): ", $formula)]
                $id,
            )*
        }

        /// The registry: one entry per [`CandidateId`], in the same order.
        pub const REGISTRY: &[Candidate] = &[
            $(Candidate {
                id: CandidateId::$id,
                effect: $effect,
                key: $key,
                name: $name,
                unit: $unit,
                formula: $formula,
                signature: $sig,
                bound: $bound,
                ieee: $ieee,
                model_term: ModelTerm::$term,
            },)*
        ];

        impl CandidateId {
            /// Every candidate, in registry order.
            pub const ALL: &[CandidateId] = &[$(CandidateId::$id,)*];
        }
    };
}

/// Number of candidates.
pub const N_CANDIDATES: usize = CandidateId::ALL.len();

candidates! {
    Anisoinertia = "anisoinertia", "k_ai_cm", "anisoinertia", "cm",
        "k·w_IA·w_PA, k = (I_PA − I_IA)/(m·l)",
        Signature::Term(|i| i.w_rad_s[IA] * i.w_rad_s[PA]), Bound::Anisoinertia, ("K_ai", "µg/(rad/s)²", |g| 1e6 / g), Outside;
    LeverArmIa = "lever_arm", "r_ia_cm", "lever_arm.r_ia_cm", "cm",
        "IA component of dw × r + w × (w × r), r along IA",
        Signature::Term(|i| lever_arm_ia(i, IA)), Bound::LeverArm, ("r_IA", "cm", |_| 1.0), Outside;
    LeverArmPa = "lever_arm", "r_pa_cm", "lever_arm.r_pa_cm", "cm",
        "IA component of dw × r + w × (w × r), r along PA",
        Signature::Term(|i| lever_arm_ia(i, PA)), Bound::LeverArm, ("r_PA", "cm", |_| 1.0), Outside;
    LeverArmOa = "lever_arm", "r_oa_cm", "lever_arm.r_oa_cm", "cm",
        "IA component of dw × r + w × (w × r), r along OA",
        Signature::Term(|i| lever_arm_ia(i, OA)), Bound::LeverArm, ("r_OA", "cm", |_| 1.0), Outside;
    Vibropendulosity = "vibropendulosity", "k_ip_s2_cm", "vibropendulosity", "s²/cm",
        "k·a_IA·a_PA",
        Signature::Term(|i| i.a_cm_s2[IA] * i.a_cm_s2[PA]), Bound::SecondOrder, ("K_ip", "µg/g²", |g| g * 1e6), HigherOrder;
    Anisoelasticity = "anisoelasticity", "k_io_s2_cm", "anisoelasticity", "s²/cm",
        "k·a_IA·a_OA",
        Signature::Term(|i| i.a_cm_s2[IA] * i.a_cm_s2[OA]), Bound::SecondOrder, ("K_io", "µg/g²", |g| g * 1e6), HigherOrder;
    Nonlinearity = "nonlinearity", "k2_s2_cm", "nonlinearity", "s²/cm",
        "k·a_IA²",
        Signature::Term(|i| i.a_cm_s2[IA] * i.a_cm_s2[IA]), Bound::SecondOrder, ("K_2", "µg/g²", |g| g * 1e6), HigherOrder;
    Sculling = "sculling", "k_sc_s2", "sculling", "s²",
        "k·dw_OA·a_PA",
        Signature::Term(|i| i.dw_rad_s2[OA] * i.a_cm_s2[PA]), Bound::Sculling, ("K_sc", "µg/(g·rad/s²)", |_| 1e6), Outside;
    Bias = "bias", "k0_cm_s2", "bias", "cm/s²",
        "k (a change of the instrument file's bias A_b; absolute rows only)",
        Signature::Term(|_| 1.0), Bound::Bias, ("K_0", "µg", |g| 1e6 / g), FirstOrder;
    ScaleFactor = "scale_factor", "k1_ppm", "scale_factor", "ppm",
        "k·1e-6·a_IA (a change of the scale factor from the nominal SF)",
        Signature::Term(|i| 1e-6 * i.a_cm_s2[IA]), Bound::ScaleFactor, ("K_1", "ppm", |_| 1.0), FirstOrder;
    MisalignmentP = "misalignment", "delta_p_rad", "misalignment.delta_p_rad", "rad",
        "k·a_PA (IA tilted toward PA, about OA)",
        Signature::Term(|i| i.a_cm_s2[PA]), Bound::Misalignment, ("δ_o", "µrad", |_| 1e6), FirstOrder;
    MisalignmentO = "misalignment", "delta_o_rad", "misalignment.delta_o_rad", "rad",
        "k·a_OA (IA tilted toward OA, about PA)",
        Signature::Term(|i| i.a_cm_s2[OA]), Bound::Misalignment, ("−δ_p", "µrad", |_| 1e6), FirstOrder;
    Cubic = "cubic", "k3_s4_cm2", "cubic", "s⁴/cm²",
        "k·a_IA³",
        Signature::Term(|i| i.a_cm_s2[IA].powi(3)), Bound::Cubic, ("K_3", "µg/g³", |g| g * g * 1e6), HigherOrder;
    CrossAxisPp = "cross_axis_pp", "k_pp_s2_cm", "cross_axis_pp", "s²/cm",
        "k·a_PA²",
        Signature::Term(|i| i.a_cm_s2[PA] * i.a_cm_s2[PA]), Bound::SecondOrder, ("K_pp", "µg/g²", |g| g * 1e6), HigherOrder;
    CrossAxisOo = "cross_axis_oo", "k_oo_s2_cm", "cross_axis_oo", "s²/cm",
        "k·a_OA²",
        Signature::Term(|i| i.a_cm_s2[OA] * i.a_cm_s2[OA]), Bound::SecondOrder, ("K_oo", "µg/g²", |g| g * 1e6), HigherOrder;
    CrossAxisPo = "cross_axis_po", "k_po_s2_cm", "cross_axis_po", "s²/cm",
        "k·a_PA·a_OA",
        Signature::Term(|i| i.a_cm_s2[PA] * i.a_cm_s2[OA]), Bound::SecondOrder, ("K_po", "µg/g²", |g| g * 1e6), HigherOrder;
    Hysteresis = "hysteresis", "h_cm_s2", "hysteresis", "cm/s²",
        "h·s, s = +1 when the input along IA rose to the reading, −1 when it fell, 0 otherwise (absolute rows: `approach`, else the change since the previous row)",
        Signature::Term(|i| i.approach), Bound::Hysteresis, ("h", "µg", |g| 1e6 / g), Outside;
    TemperatureBias = "temperature", "k0_t_cm_s2_per_c", "temperature.k0_t_cm_s2_per_c", "cm/s²/°C",
        "k·ΔT, ΔT = temp_c − the rows' mean temp_c (a bias change per °C)",
        Signature::Term(|i| i.delta_t_c), Bound::BiasPerDegree, ("K_0,T", "µg/°C", |g| 1e6 / g), Outside;
    TemperatureScaleFactor = "temperature", "k1_t_ppm_per_c", "temperature.k1_t_ppm_per_c", "ppm/°C",
        "k·1e-6·ΔT·a_IA (a scale-factor change per °C)",
        Signature::Term(|i| 1e-6 * i.delta_t_c * i.a_cm_s2[IA]), Bound::ScaleFactorPerDegree, ("K_1,T", "ppm/°C", |_| 1.0), Outside;
    WarmUpSpan16 = "warm_up", "a_span16_cm_s2", "warm_up.a_span16_cm_s2", "cm/s²",
        "A·e^(−t/τ), t the time since power-on, τ = 1/16 of the run's span in time_s (rows with time_s only)",
        Signature::Term(|i| warm_up(i, 16.0)), Bound::WarmUp, ("A_wu(T/16)", "µg", |g| 1e6 / g), Outside;
    WarmUpSpan12 = "warm_up", "a_span12_cm_s2", "warm_up.a_span12_cm_s2", "cm/s²",
        "A·e^(−t/τ), τ = 1/12 of the run's span",
        Signature::Term(|i| warm_up(i, 12.0)), Bound::WarmUp, ("A_wu(T/12)", "µg", |g| 1e6 / g), Outside;
    WarmUpSpan8 = "warm_up", "a_span8_cm_s2", "warm_up.a_span8_cm_s2", "cm/s²",
        "A·e^(−t/τ), τ = 1/8 of the run's span",
        Signature::Term(|i| warm_up(i, 8.0)), Bound::WarmUp, ("A_wu(T/8)", "µg", |g| 1e6 / g), Outside;
    WarmUpSpan6 = "warm_up", "a_span6_cm_s2", "warm_up.a_span6_cm_s2", "cm/s²",
        "A·e^(−t/τ), τ = 1/6 of the run's span",
        Signature::Term(|i| warm_up(i, 6.0)), Bound::WarmUp, ("A_wu(T/6)", "µg", |g| 1e6 / g), Outside;
    WarmUpSpan4 = "warm_up", "a_span4_cm_s2", "warm_up.a_span4_cm_s2", "cm/s²",
        "A·e^(−t/τ), τ = 1/4 of the run's span",
        Signature::Term(|i| warm_up(i, 4.0)), Bound::WarmUp, ("A_wu(T/4)", "µg", |g| 1e6 / g), Outside;
    WarmUpSpan3 = "warm_up", "a_span3_cm_s2", "warm_up.a_span3_cm_s2", "cm/s²",
        "A·e^(−t/τ), τ = 1/3 of the run's span",
        Signature::Term(|i| warm_up(i, 3.0)), Bound::WarmUp, ("A_wu(T/3)", "µg", |g| 1e6 / g), Outside;
    WarmUpSpan2 = "warm_up", "a_span2_cm_s2", "warm_up.a_span2_cm_s2", "cm/s²",
        "A·e^(−t/τ), τ = 1/2 of the run's span",
        Signature::Term(|i| warm_up(i, 2.0)), Bound::WarmUp, ("A_wu(T/2)", "µg", |g| 1e6 / g), Outside;
    WarmUp = "warm_up", "a_cm_s2", "warm_up.a_cm_s2", "cm/s²",
        "A·e^(−t/τ), t the time since power-on, τ estimated from the data (the effects' `time_constant`; rows with time_s only)",
        Signature::Term(no_term), Bound::WarmUp, ("A_wu", "µg", |g| 1e6 / g), Outside;
    ParamDamping = "damping", "damping_dyn_cm_s", "damping", instrument::DAMPING.unit,
        "the damping C of eq. 4.2 (Table 2.1: 76 400 ± 40 %)",
        Signature::Parameter(&instrument::DAMPING), Bound::Tolerance, ("C", instrument::DAMPING.unit, |_| 1.0), Outside;
    ParamSpring = "spring", "spring_dyn_cm_per_rad", "spring", instrument::SPRING.unit,
        "the flexure spring K (Table 2.1: 1540 ± 40 %)",
        Signature::Parameter(&instrument::SPRING), Bound::Tolerance, ("K", instrument::SPRING.unit, |_| 1.0), Outside;
    ParamInertia = "inertia", "inertia_oa_g_cm2", "inertia", instrument::INERTIA.unit,
        "the output-axis inertia I_OA (Table 2.1: 14 ± 20 %)",
        Signature::Parameter(&instrument::INERTIA), Bound::Tolerance, ("I_OA", instrument::INERTIA.unit, |_| 1.0), Outside;
    ParamPendulosity = "pendulosity", "pendulosity_dyn_cm_per_g", "pendulosity", instrument::PENDULOSITY.unit,
        "the pendulosity P (Table 2.1: 1100 ± 15 %), with the regulated current held",
        Signature::Parameter(&instrument::PENDULOSITY), Bound::Tolerance, ("P", instrument::PENDULOSITY.unit, |_| 1.0), Outside;
    ParamTorquerSf = "torquer_sf", "current_scale_factor_ma_per_g", "torquer_sf", instrument::TORQUER_SF.unit,
        "the torquer's current scale factor (Table 2.1: 0.99 ± 0.03), with the regulated current held",
        Signature::Parameter(&instrument::TORQUER_SF), Bound::Tolerance, ("K_tq", instrument::TORQUER_SF.unit, |_| 1.0), Outside;
    ParamTorquerLag = "torquer_lag", "time_constant_us", "torquer_lag", instrument::TORQUER_TAU.unit,
        "the torquer current's rise time constant (Table 2.1: 0.2 to 20)",
        Signature::Parameter(&instrument::TORQUER_TAU), Bound::Tolerance, ("τ", instrument::TORQUER_TAU.unit, |_| 1.0), Outside;
    ParamPickoffGain = "pickoff_gain", "scale_factor_v_per_rad", "pickoff_gain", instrument::PICKOFF_SF.unit,
        "the pickoff scale factor (Table 2.1: 10 ± 20 %); the amplifier gain multiplies it and cannot be told from it",
        Signature::Parameter(&instrument::PICKOFF_SF), Bound::Tolerance, ("S_po", instrument::PICKOFF_SF.unit, |_| 1.0), Outside;
    ParamPickoffPhase = "pickoff_phase", "phase_angle_deg", "pickoff_phase", instrument::PHASE.unit,
        "the pickoff phase angle (Table 2.1: 0 ± 10): the ADC offset it makes of the quadrature null",
        Signature::Parameter(&instrument::PHASE), Bound::Tolerance, ("φ_po", instrument::PHASE.unit, |_| 1.0), Outside;
    ParamAmplifierGain = "amplifier_gain", "amplifier_gain", "amplifier_gain", instrument::AMPLIFIER_GAIN.unit,
        "the amplifier gain ahead of the ADC (a candidate when the instrument file gives it a tolerance; it multiplies the pickoff scale factor and cannot be told from it)",
        Signature::Parameter(&instrument::AMPLIFIER_GAIN), Bound::Tolerance, ("G_amp", instrument::AMPLIFIER_GAIN.unit, |_| 1.0), Outside;
    ParamAdcOffset = "adc_offset", "adc_offset_mv", "adc_offset", instrument::ADC_OFFSET.unit,
        "the offset at the ADC's input (a candidate when the instrument file gives electronics.adc_offset_mv with a tolerance): a constant code offset, as the quadrature a pickoff phase error leaks",
        Signature::Parameter(&instrument::ADC_OFFSET), Bound::Tolerance, ("V_adc", instrument::ADC_OFFSET.unit, |_| 1.0), Outside;
}

/// The registry's term of [`CandidateId::WarmUp`], whose τ the [`Effects`] carry
/// ([`Effects::warm_up_cm_s2`], [`Effects::plant_terms`]): none on its own.
fn no_term(_: &CaseInputs) -> f64 {
    0.0
}

/// A term of the inputs at one instant, per unit coefficient, cm/s².
pub type TermFn = fn(&CaseInputs) -> f64;

/// A term that is 1 at every instant (its coefficient carries the value).
fn unit_term(_: &CaseInputs) -> f64 {
    1.0
}

/// A turn-on transient `e^(−t/τ)` with `τ` = the run's span over `per_span`, for a unit
/// amplitude (0 without a time since power-on: rows without `time_s`).
fn warm_up(i: &CaseInputs, per_span: f64) -> f64 {
    i.t_on_span.map_or(0.0, |t| (-t * per_span).exp())
}

/// IA component of `dw × r + w × (w × r)` for a unit `r` along case axis `axis`.
fn lever_arm_ia(i: &CaseInputs, axis: usize) -> f64 {
    let mut r = [0.0; 3];
    r[axis] = 1.0;
    cross(i.dw_rad_s2, r)[IA] + cross(i.w_rad_s, cross(i.w_rad_s, r))[IA]
}

impl CandidateId {
    /// Its registry entry.
    #[must_use]
    pub fn info(self) -> &'static Candidate {
        &REGISTRY[self.index()]
    }

    /// Position in [`CandidateId::ALL`] and [`REGISTRY`].
    #[must_use]
    pub fn index(self) -> usize {
        self as usize
    }

    /// The candidate named `name` (`anisoinertia`, `lever_arm.r_pa_cm`, ...).
    #[must_use]
    pub fn from_name(name: &str) -> Option<CandidateId> {
        REGISTRY.iter().find(|c| c.name == name).map(|c| c.id)
    }

    /// The candidates of effect `effect` (`lever_arm` has three).
    pub fn of_effect(effect: &str) -> impl Iterator<Item = CandidateId> + '_ {
        REGISTRY
            .iter()
            .filter(move |c| c.effect == effect)
            .map(|c| c.id)
    }

    /// Its extra indicated acceleration at one instant for a unit coefficient, cm/s² (0 for a
    /// parameter of the instrument file, which is not an additive term).
    #[must_use]
    pub fn term_cm_s2(self, i: &CaseInputs) -> f64 {
        match self.info().signature {
            Signature::Term(f) => f(i),
            Signature::Parameter(_) => 0.0,
        }
    }

    /// A first-order term of the IEEE 1293 model equation (bias, scale factor,
    /// misalignment): when two candidates fit the data exactly as well, the selection takes
    /// one of these before a second-order or dynamic term (the simpler explanation).
    #[must_use]
    pub fn first_order(self) -> bool {
        self.info().model_term == ModelTerm::FirstOrder
    }

    /// A static term of the IEEE 1293 model equation (first or higher order), which
    /// absolute rows can test.
    #[must_use]
    pub fn model_equation_term(self) -> bool {
        self.info().model_term != ModelTerm::Outside
    }

    /// The warm-up's transient `A·e^(−t/τ)`: one of the grid's time constants
    /// (registered in increasing τ, [`CandidateId::profile_rate`]) or the one estimated
    /// from the data ([`CandidateId::WarmUp`]). They are one hypothesis of the selection's
    /// family (its p-value corrected for the search over τ, `ptsa_host_sim::discovery::fit`),
    /// and at most one of them is selected.
    #[must_use]
    pub fn profiled(self) -> bool {
        self.info().bound == Bound::WarmUp
    }

    /// For a point of the warm-up's profile: the run's span over its time constant.
    #[must_use]
    pub fn profile_rate(self) -> Option<f64> {
        match self {
            CandidateId::WarmUpSpan16 => Some(16.0),
            CandidateId::WarmUpSpan12 => Some(12.0),
            CandidateId::WarmUpSpan8 => Some(8.0),
            CandidateId::WarmUpSpan6 => Some(6.0),
            CandidateId::WarmUpSpan4 => Some(4.0),
            CandidateId::WarmUpSpan3 => Some(3.0),
            CandidateId::WarmUpSpan2 => Some(2.0),
            _ => None,
        }
    }

    /// Order of simplicity when two candidates fit alike: 0 for a first-order
    /// model-equation term, 1 for another additive term, 2 for a parameter of the loop.
    #[must_use]
    pub fn rank(self) -> u8 {
        if self.first_order() {
            0
        } else if self.parameter_key().is_some() {
            2
        } else {
            1
        }
    }

    /// The instrument-file key of a parameter candidate.
    #[must_use]
    pub fn parameter_key(self) -> Option<&'static str> {
        self.parameter().map(|p| p.key)
    }

    /// The instrument-file entry of a parameter candidate.
    #[must_use]
    pub fn parameter(self) -> Option<&'static Parameter> {
        match self.info().signature {
            Signature::Parameter(p) => Some(p),
            Signature::Term(_) => None,
        }
    }
}

/// The candidates a name stands for: an effect name (`lever_arm`: its three components) or
/// a candidate name (`lever_arm.r_pa_cm`).
///
/// # Errors
/// An unknown name; the message lists every known one.
pub fn resolve_candidates(name: &str) -> Result<Vec<CandidateId>, String> {
    let hits: Vec<CandidateId> = REGISTRY
        .iter()
        .filter(|c| c.effect == name || c.name == name)
        .map(|c| c.id)
        .collect();
    if hits.is_empty() {
        Err(format!(
            "unknown candidate `{name}`; expected one of: {}",
            candidate_names().join(", ")
        ))
    } else {
        Ok(hits)
    }
}

/// Every name [`resolve_candidates`] accepts: effect names and candidate names, sorted.
#[must_use]
pub fn candidate_names() -> Vec<&'static str> {
    let set: std::collections::BTreeSet<&str> =
        REGISTRY.iter().flat_map(|c| [c.effect, c.name]).collect();
    set.into_iter().collect()
}

impl std::fmt::Display for CandidateId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.info().name)
    }
}

impl Serialize for CandidateId {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.info().name)
    }
}

impl<'de> serde::Deserialize<'de> for CandidateId {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        CandidateId::from_name(&name)
            .ok_or_else(|| serde::de::Error::custom(format!("no candidate is called {name:?}")))
    }
}

const _: () = {
    // The registry and the enum are generated together; check the order once more.
    let mut k = 0;
    while k < REGISTRY.len() {
        assert!(REGISTRY[k].id as usize == k);
        k += 1;
    }
};

/// Coefficients of the candidate effects, one per [`CandidateId`] (all zero in the
/// baseline model), each in its candidate's unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Effects {
    coef: [f64; N_CANDIDATES],
    /// The time constant of [`CandidateId::WarmUp`]'s transient, s (0: none given, and
    /// the term is 0).
    warm_up_tau_s: f64,
}

impl Default for Effects {
    /// [`Effects::NONE`].
    fn default() -> Self {
        Self::NONE
    }
}

impl Effects {
    /// No effect: the baseline model.
    pub const NONE: Effects = Effects {
        coef: [0.0; N_CANDIDATES],
        warm_up_tau_s: 0.0,
    };

    /// These effects with the time constant of [`CandidateId::WarmUp`] set to `tau_s`, s.
    #[must_use]
    pub fn with_warm_up_tau_s(mut self, tau_s: f64) -> Self {
        self.warm_up_tau_s = tau_s;
        self
    }

    /// The time constant of [`CandidateId::WarmUp`], s (0: none).
    #[must_use]
    pub fn warm_up_tau_s(&self) -> f64 {
        self.warm_up_tau_s
    }

    /// [`CandidateId::WarmUp`]'s transient for a unit amplitude at `t_on_s` after
    /// power-on (0 without a time or a time constant).
    fn warm_up_unit(&self, t_on_s: Option<f64>) -> f64 {
        match t_on_s {
            Some(t) if self.warm_up_tau_s > 0.0 => (-t / self.warm_up_tau_s).exp(),
            _ => 0.0,
        }
    }

    /// The additive terms as `(term, coefficient)` for the loop's plant at a row whose time
    /// since power-on is `t_on_s`: each candidate's own term, and [`CandidateId::WarmUp`]
    /// at these effects' τ as a constant over the row (its amplitude times `e^(−t/τ)`: a
    /// row's run is short against τ). Parameters are not terms.
    #[must_use]
    pub fn plant_terms(&self, t_on_s: Option<f64>) -> Vec<(TermFn, f64)> {
        self.nonzero()
            .filter_map(|(id, c)| match id.info().signature {
                Signature::Term(_) if id == CandidateId::WarmUp => {
                    Some((unit_term as TermFn, c * self.warm_up_unit(t_on_s)))
                }
                Signature::Term(f) => Some((f, c)),
                Signature::Parameter(_) => None,
            })
            .collect()
    }

    /// Only `id` set to `value`.
    #[must_use]
    pub fn only(id: CandidateId, value: f64) -> Self {
        Self::NONE.with(id, value)
    }

    /// These effects with `id` set to `value`.
    #[must_use]
    pub fn with(mut self, id: CandidateId, value: f64) -> Self {
        self.coef[id.index()] = value;
        self
    }

    /// The coefficient of `id`.
    #[must_use]
    pub fn get(&self, id: CandidateId) -> f64 {
        self.coef[id.index()]
    }

    /// Set the coefficient of `id`.
    pub fn set(&mut self, id: CandidateId, value: f64) {
        self.coef[id.index()] = value;
    }

    /// Add `value` to the coefficient of `id`.
    pub fn add(&mut self, id: CandidateId, value: f64) {
        self.coef[id.index()] += value;
    }

    /// The lever arm `r` (IA, PA, OA), cm.
    #[must_use]
    pub fn lever_arm_cm(&self) -> [f64; 3] {
        [
            self.get(CandidateId::LeverArmIa),
            self.get(CandidateId::LeverArmPa),
            self.get(CandidateId::LeverArmOa),
        ]
    }

    /// Add a lever arm `r` (IA, PA, OA), cm.
    pub fn add_lever_arm_cm(&mut self, r: [f64; 3]) {
        self.add(CandidateId::LeverArmIa, r[IA]);
        self.add(CandidateId::LeverArmPa, r[PA]);
        self.add(CandidateId::LeverArmOa, r[OA]);
    }

    /// Whether every coefficient is zero.
    #[must_use]
    pub fn is_zero(&self) -> bool {
        self.coef.iter().all(|&c| c == 0.0)
    }

    /// The non-zero coefficients, in registry order.
    pub fn nonzero(&self) -> impl Iterator<Item = (CandidateId, f64)> + '_ {
        CandidateId::ALL
            .iter()
            .map(|&id| (id, self.get(id)))
            .filter(|&(_, c)| c != 0.0)
    }

    /// Whether any parameter of the instrument file is changed.
    #[must_use]
    pub fn has_parameters(&self) -> bool {
        self.nonzero().any(|(id, _)| id.parameter_key().is_some())
    }

    /// `instr` with the parameter changes applied (each coefficient added to the file value
    /// of its key).
    #[must_use]
    pub fn apply_parameters(
        &self,
        instr: &crate::model::instrument::Instrument,
    ) -> crate::model::instrument::Instrument {
        let mut out = instr.clone();
        for (id, c) in self.nonzero() {
            if let Some(p) = id.parameter() {
                p.set(&mut out, p.get(instr) + c);
            }
        }
        out
    }

    /// These effects without the parameter changes (the additive terms only).
    #[must_use]
    pub fn additive(&self) -> Effects {
        let mut e = *self;
        for &id in CandidateId::ALL {
            if id.parameter_key().is_some() {
                e.set(id, 0.0);
            }
        }
        e
    }

    /// Sum of the effect terms at one instant: extra indicated acceleration along IA, cm/s²
    /// (all but [`CandidateId::WarmUp`]'s, [`Effects::warm_up_cm_s2`]).
    #[must_use]
    pub fn indicated_cm_s2(&self, i: &CaseInputs) -> f64 {
        self.nonzero().map(|(id, c)| c * id.term_cm_s2(i)).sum()
    }

    /// [`CandidateId::WarmUp`]'s extra indicated acceleration at a row `t_on_s` after
    /// power-on ([`crate::model::condition::History::t_on_s`]), cm/s²: constant over the
    /// row, so not a term of the instant's inputs ([`Effects::indicated_cm_s2`] leaves it
    /// out).
    #[must_use]
    pub fn warm_up_cm_s2(&self, t_on_s: Option<f64>) -> f64 {
        self.get(CandidateId::WarmUp) * self.warm_up_unit(t_on_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::condition::Condition;

    #[test]
    fn names_keys_and_order_are_the_contract() {
        let names: Vec<&str> = REGISTRY.iter().map(|c| c.name).collect();
        assert_eq!(
            names,
            [
                "anisoinertia",
                "lever_arm.r_ia_cm",
                "lever_arm.r_pa_cm",
                "lever_arm.r_oa_cm",
                "vibropendulosity",
                "anisoelasticity",
                "nonlinearity",
                "sculling",
                "bias",
                "scale_factor",
                "misalignment.delta_p_rad",
                "misalignment.delta_o_rad",
                "cubic",
                "cross_axis_pp",
                "cross_axis_oo",
                "cross_axis_po",
                "hysteresis",
                "temperature.k0_t_cm_s2_per_c",
                "temperature.k1_t_ppm_per_c",
                "warm_up.a_span16_cm_s2",
                "warm_up.a_span12_cm_s2",
                "warm_up.a_span8_cm_s2",
                "warm_up.a_span6_cm_s2",
                "warm_up.a_span4_cm_s2",
                "warm_up.a_span3_cm_s2",
                "warm_up.a_span2_cm_s2",
                "warm_up.a_cm_s2",
                "damping",
                "spring",
                "inertia",
                "pendulosity",
                "torquer_sf",
                "torquer_lag",
                "pickoff_gain",
                "pickoff_phase",
                "amplifier_gain",
                "adc_offset"
            ]
        );
        for c in REGISTRY {
            assert_eq!(CandidateId::from_name(c.name), Some(c.id));
            assert!(c.name == c.effect || c.name == format!("{}.{}", c.effect, c.key));
        }
        assert_eq!(CandidateId::of_effect("lever_arm").count(), 3);
        assert_eq!(CandidateId::of_effect("temperature").count(), 2);
        assert_eq!(CandidateId::of_effect("warm_up").count(), 8);
        assert!(CandidateId::of_effect("warm_up").all(CandidateId::profiled));
        assert_eq!(CandidateId::ALL.iter().filter(|c| c.profiled()).count(), 8);
        // Each point's column is e^(−x·rate), in increasing τ (decreasing rate).
        let mut last = f64::INFINITY;
        for id in CandidateId::of_effect("warm_up").filter(|&c| c != CandidateId::WarmUp) {
            let r = id.profile_rate().unwrap();
            assert!(r < last, "{id:?}");
            last = r;
            let i = CaseInputs {
                t_on_span: Some(0.3),
                ..CaseInputs::default()
            };
            assert!(
                (id.term_cm_s2(&i) - (-0.3 * r).exp()).abs() < 1e-15,
                "{id:?}"
            );
        }
    }

    /// Where each candidate stands in the model equation is part of the method: the
    /// first-order terms win the selection's ties, and the static terms (first and higher
    /// order) get advice when absolute rows cannot test them. A new candidate is classified
    /// in its registry entry (the `candidates!` macro takes no entry without it); this list
    /// makes the classification a deliberate choice.
    #[test]
    fn model_equation_terms_are_the_static_terms() {
        let of = |t: ModelTerm| -> Vec<&str> {
            REGISTRY
                .iter()
                .filter(|c| c.model_term == t)
                .map(|c| c.name)
                .collect()
        };
        assert_eq!(
            of(ModelTerm::FirstOrder),
            [
                "bias",
                "scale_factor",
                "misalignment.delta_p_rad",
                "misalignment.delta_o_rad"
            ]
        );
        assert_eq!(
            of(ModelTerm::HigherOrder),
            [
                "vibropendulosity",
                "anisoelasticity",
                "nonlinearity",
                "cubic",
                "cross_axis_pp",
                "cross_axis_oo",
                "cross_axis_po"
            ]
        );
        for c in REGISTRY {
            // A loop parameter is not a term of the model equation; every first-order term
            // has the first-order bounds, and the first-order bounds only first-order terms.
            if c.id.parameter().is_some() {
                assert_eq!(c.model_term, ModelTerm::Outside, "{}", c.name);
                assert_eq!(c.bound, Bound::Tolerance, "{}", c.name);
            }
            assert_eq!(
                c.model_term == ModelTerm::FirstOrder,
                matches!(
                    c.bound,
                    Bound::Bias | Bound::ScaleFactor | Bound::Misalignment
                ),
                "{}",
                c.name
            );
            assert_eq!(c.id.first_order(), c.model_term == ModelTerm::FirstOrder);
            assert_eq!(c.id.rank() == 0, c.id.first_order());
        }
    }

    /// The loop-parameter candidates are entries of the instrument file's parameter table:
    /// their coefficient key is the file key's name and their unit the file's; every
    /// parameter that can carry a tolerance is a candidate or is left out for a reason
    /// given here (a new toleranced parameter fails this test until it is decided).
    #[test]
    fn parameter_candidates_are_entries_of_the_instrument_table() {
        for c in REGISTRY {
            let Some(p) = c.id.parameter() else {
                continue;
            };
            assert!(
                crate::model::instrument::PARAMETERS
                    .iter()
                    .any(|q| q.key == p.key),
                "{}",
                c.name
            );
            assert!(p.form.can_be_toleranced(), "{}", c.name);
            assert_eq!(
                p.key.split_once('.').map(|k| k.1),
                Some(c.key),
                "{}",
                c.name
            );
            assert_eq!((c.unit, c.ieee.1), (p.unit, p.unit), "{}", c.name);
            assert_eq!(c.id.parameter_key(), Some(p.key));
        }
        let candidates: Vec<&str> = REGISTRY
            .iter()
            .filter_map(|c| c.id.parameter_key())
            .collect();
        let not_candidates: Vec<&str> = crate::model::instrument::PARAMETERS
            .iter()
            .filter(|p| p.form.can_be_toleranced() && !candidates.contains(&p.key))
            .map(|p| p.key)
            .collect();
        assert_eq!(
            not_candidates,
            [
                // The stops: the loop keeps the pendulum far from them.
                "pendulum.freedom_mrad",
                // The `anisoinertia` candidate is this term, additive.
                "pendulum.anisoinertia_g_cm2",
                // Acts only with a phase angle, their product the offset (`pickoff_phase`).
                "pickoff.quadrature_null_uv",
                // Noise adds scatter, not a mean effect.
                "pickoff.noise_uv_rms",
            ]
        );
    }

    #[test]
    fn anisoinertia_at_45_degrees_matches_the_report_arithmetic() {
        // Table 6.1 geometry: IA 45° above horizontal, table rate 1 rad/s about the vertical.
        let phi = 45f64.to_radians();
        let c = Condition {
            g: [phi.sin(), phi.cos(), 0.0],
            w_rad_s: [phi.sin(), phi.cos(), 0.0],
            ..Condition::default()
        };
        let e = Effects::only(CandidateId::Anisoinertia, 3.0);
        let x = e.indicated_cm_s2(&c.inputs_at(0.0, 980.4));
        assert!((x - 1.5).abs() < 1e-12, "{x}");
    }

    #[test]
    fn lever_arm_along_pa_gives_centripetal_ia_term() {
        // w about IA and PA, r along PA: w × (w × r) = w (w·r) − r |w|²; IA part = w_IA w_PA r_PA.
        let c = Condition {
            w_rad_s: [0.6, 0.8, 0.0],
            ..Condition::default()
        };
        let e = Effects::only(CandidateId::LeverArmPa, 2.0);
        let x = e.indicated_cm_s2(&c.inputs_at(0.0, 980.4));
        assert!((x - 0.6 * 0.8 * 2.0).abs() < 1e-12, "{x}");
    }

    #[test]
    fn every_candidate_has_a_signature_or_a_parameter() {
        let i = CaseInputs {
            a_cm_s2: [310.0, -120.0, 45.0],
            w_rad_s: [0.3, -0.7, 1.1],
            dw_rad_s2: [2.0, -5.0, 7.0],
            approach: -1.0,
            delta_t_c: 2.5,
            t_on_span: Some(0.1),
        };
        let instr = crate::model::instrument::Instrument::kearfott_2401();
        for &id in CandidateId::ALL {
            if let Some(key) = id.parameter_key() {
                // A parameter: a key the instrument file has, with a tolerance band (the
                // shipped file gives the amplifier gain and the ADC offset none: Table 2.1
                // does not).
                assert!(instr.get(key).is_some(), "{id}");
                assert_eq!(
                    instr.tolerance(key).is_some(),
                    !matches!(
                        id,
                        CandidateId::ParamAmplifierGain | CandidateId::ParamAdcOffset
                    ),
                    "{id}"
                );
                assert!(Effects::only(id, 1.0).indicated_cm_s2(&i) == 0.0, "{id}");
                continue;
            }
            if id == CandidateId::WarmUp {
                // Its term is the row's, 600 s after power-on with τ = 300 s.
                let e = Effects::only(id, 1.0).with_warm_up_tau_s(300.0);
                let one = e.warm_up_cm_s2(Some(600.0));
                assert!((one - (-2.0f64).exp()).abs() < 1e-15);
                assert!(e.indicated_cm_s2(&i) == 0.0);
                // Without a time constant or a time, none.
                assert!(Effects::only(id, 1.0).warm_up_cm_s2(Some(600.0)) == 0.0);
                assert!(e.warm_up_cm_s2(None) == 0.0);
                let t = e.plant_terms(Some(600.0));
                assert_eq!(t.len(), 1);
                assert!(((t[0].0)(&i) * t[0].1 - one).abs() < 1e-15);
                continue;
            }
            let one = Effects::only(id, 1.0).indicated_cm_s2(&i);
            assert!(one != 0.0, "{id} has no term at these inputs");
        }
    }
}

/// `docs/reference/candidates.md`, written from [`REGISTRY`]: the page a reader looks up a
/// candidate in, checked by a test so that it cannot drift from the code.
#[cfg(test)]
mod reference {
    use super::*;
    use std::fmt::Write as _;

    fn page() -> String {
        let mut out = format!(
            "# Reference: discovery's candidates\n\n\
             The {N_CANDIDATES} candidates of `ptsa discover`, in the registry's order (the order of \
             every listing). Generated from `model/effects.rs` by the test \
             `model::effects::reference::the_candidates_page_is_current` \
             (`PTSA_WRITE_REFERENCE=1 cargo test -p ptsa-sim --lib reference` writes it \
             again). `name` is what `--candidates` takes and the JSON's `confounded_with` \
             lists; `effect` and `key` are the JSON's effect name and coefficient key (cgs, the \
             unit in the key); the IEEE Std 1293 symbol and unit are the calibration's.\n\n\
             | name | effect | key | unit | IEEE symbol | IEEE unit | term | in the model equation |\n\
             |---|---|---|---|---|---|---|---|\n"
        );
        for c in REGISTRY {
            let (symbol, ieee_unit, _) = c.ieee;
            let place = match c.model_term {
                ModelTerm::FirstOrder => "first order",
                ModelTerm::HigherOrder => "higher order",
                ModelTerm::Outside => match c.signature {
                    Signature::Parameter(_) => "a loop parameter (closed loop)",
                    Signature::Term(_) => "outside (rates, time, history)",
                },
            };
            let _ = writeln!(
                out,
                "| `{}` | `{}` | `{}` | {} | {symbol} | {ieee_unit} | {} | {place} |",
                c.name,
                c.effect,
                c.key,
                c.unit,
                c.formula.replace('|', "\\|")
            );
        }
        out
    }

    #[test]
    fn the_candidates_page_is_current() {
        assert!(
            crate::text::reference_page_is_current("candidates.md", &page()),
            "docs/reference/candidates.md is not what the registry holds: \
             PTSA_WRITE_REFERENCE=1 cargo test -p ptsa-sim --lib reference"
        );
    }
}
