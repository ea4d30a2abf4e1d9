//! The instrument file's schema: its sections as TOML reads them (with the spans of their
//! values, for errors and rewriting), the table of toleranced parameters, the keys of the
//! model equation and the plausibility bounds.

use std::fmt;

use serde::Deserialize;
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use toml::Spanned;

use super::Instrument;
use crate::model::effects::CandidateId;

/// A number in the file: a TOML float or integer. It has its own visitor so that a value of
/// another type is reported in the file's terms ("expected a number, found the string
/// "fast"") rather than serde's ("invalid type: string, expected f64").
#[derive(Debug, Clone, Copy)]
pub(super) struct Num(pub(super) f64);

impl<'de> Deserialize<'de> for Num {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(NumVisitor)
    }
}

pub(super) struct NumVisitor;

// An integer reads as the float it is written as.
#[allow(clippy::cast_precision_loss)]
impl<'de> Visitor<'de> for NumVisitor {
    type Value = Num;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a number")
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Num, E> {
        Ok(Num(v))
    }

    // TOML integers stand for the same number as a float (`clock_hz = 64000`); the rounding
    // of integers beyond 2^53 is that of writing them as floats.
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Num, E> {
        Ok(Num(v as f64))
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Num, E> {
        Ok(Num(v as f64))
    }

    fn visit_i128<E: de::Error>(self, v: i128) -> Result<Num, E> {
        Ok(Num(v as f64))
    }

    fn visit_u128<E: de::Error>(self, v: u128) -> Result<Num, E> {
        Ok(Num(v as f64))
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<Num, E> {
        Err(E::custom(format!(
            "expected a number, found the string {v:?}"
        )))
    }

    fn visit_bool<E: de::Error>(self, v: bool) -> Result<Num, E> {
        Err(E::custom(format!("expected a number, found `{v}`")))
    }

    fn visit_seq<A: SeqAccess<'de>>(self, _: A) -> Result<Num, A::Error> {
        Err(de::Error::custom("expected a number, found an array"))
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Num, A::Error> {
        // The toml crate hands a date or time to a visitor as a one-entry map with a private
        // key; anything else is an inline table.
        let key: Option<String> = map.next_key()?;
        if key.as_deref() == Some("$__toml_private_datetime") {
            let date: String = map.next_value()?;
            return Err(de::Error::custom(format!(
                "expected a number, found the date/time {date}"
            )));
        }
        Err(de::Error::custom("expected a number, found a table"))
    }
}

/// A toleranced parameter as written in the file.
#[derive(Debug, Clone, Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a table { value = ..., tol_pct = ... }, { value = ..., tol_abs = ... } or { value = ..., min = ..., max = ... }"
)]
pub(super) struct Param {
    pub(super) value: Spanned<Num>,
    pub(super) tol_pct: Option<Num>,
    pub(super) tol_abs: Option<Num>,
    pub(super) min: Option<Num>,
    pub(super) max: Option<Num>,
}

/// A bare number (no tolerance: the value is taken as exact and never identified) or a
/// toleranced parameter's table: `electronics.amplifier_gain`, which files older than its
/// tolerance give as a number.
#[derive(Debug, Clone)]
pub(super) enum NumOrParam {
    Num(Num),
    Param(Param),
}

impl<'de> Deserialize<'de> for NumOrParam {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(NumOrParamVisitor)
    }
}

pub(super) struct NumOrParamVisitor;

impl<'de> Visitor<'de> for NumOrParamVisitor {
    type Value = NumOrParam;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a number, or a table { value = ..., tol_pct = ... }")
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<NumOrParam, E> {
        NumVisitor.visit_f64(v).map(NumOrParam::Num)
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<NumOrParam, E> {
        NumVisitor.visit_i64(v).map(NumOrParam::Num)
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<NumOrParam, E> {
        NumVisitor.visit_u64(v).map(NumOrParam::Num)
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<NumOrParam, E> {
        NumVisitor.visit_str(v).map(NumOrParam::Num)
    }

    fn visit_bool<E: de::Error>(self, v: bool) -> Result<NumOrParam, E> {
        NumVisitor.visit_bool(v).map(NumOrParam::Num)
    }

    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<NumOrParam, A::Error> {
        Param::deserialize(de::value::MapAccessDeserializer::new(map)).map(NumOrParam::Param)
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [pendulum] table")]
pub(super) struct PendulumT {
    pub(super) pendulosity_dyn_cm_per_g: Spanned<Param>,
    pub(super) freedom_mrad: Spanned<Param>,
    pub(super) inertia_oa_g_cm2: Spanned<Param>,
    pub(super) spring_dyn_cm_per_rad: Spanned<Param>,
    pub(super) damping_dyn_cm_s: Spanned<Param>,
    pub(super) anisoinertia_g_cm2: Spanned<Param>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [pickoff] table")]
pub(super) struct PickoffT {
    pub(super) scale_factor_v_per_rad: Spanned<Param>,
    pub(super) quadrature_null_uv: Spanned<Param>,
    pub(super) phase_angle_deg: Spanned<Param>,
    pub(super) noise_uv_rms: Spanned<Param>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [torquer] table")]
pub(super) struct TorquerT {
    pub(super) current_scale_factor_ma_per_g: Spanned<Param>,
    pub(super) time_constant_us: Spanned<Param>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "an [electronics] table")]
pub(super) struct ElectronicsT {
    pub(super) scale_factor_cm_s2: Spanned<Num>,
    pub(super) bias_cm_s2: Spanned<Num>,
    pub(super) amplifier_gain: Spanned<NumOrParam>,
    #[serde(default)]
    pub(super) adc_offset_mv: Option<Spanned<Param>>,
    pub(super) demodulator_bandwidth_hz: Spanned<Num>,
    pub(super) adc_full_scale_v: Spanned<Num>,
    pub(super) clock_hz: Spanned<Num>,
    pub(super) local_gravity_cm_s2: Spanned<Num>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [stops] table")]
pub(super) struct StopsT {
    pub(super) stiffness_dyn_cm_per_rad: Spanned<Num>,
    pub(super) damping_dyn_cm_s: Spanned<Num>,
}

/// `[board]`: the electronics between the demodulated pickoff and the tick, as a board
/// builds them (optional; without it the loop reads the design's signed 16-bit converter).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [board] table")]
pub(super) struct BoardT {
    pub(super) name: Option<Spanned<String>>,
    pub(super) adc_bits: Spanned<Num>,
    pub(super) adc_reference_v: Spanned<Num>,
    pub(super) adc_coding: Spanned<String>,
    pub(super) adc_alignment: Spanned<String>,
    pub(super) front_end_gain: Spanned<Num>,
    pub(super) front_end_offset_v: Spanned<Num>,
    pub(super) torquer_current_ma: Option<Spanned<Num>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [plausibility] table")]
pub(super) struct PlausibilityT {
    pub(super) lever_arm_cm: Option<Spanned<Num>>,
    pub(super) anisoinertia_g_cm2: Option<Spanned<Num>>,
    pub(super) second_order_s2_cm: Option<Spanned<Num>>,
    pub(super) sculling_s2: Option<Spanned<Num>>,
    pub(super) bias_cm_s2: Option<Spanned<Num>>,
    pub(super) scale_factor_ppm: Option<Spanned<Num>>,
    pub(super) misalignment_rad: Option<Spanned<Num>>,
    pub(super) cubic_s4_cm2: Option<Spanned<Num>>,
    pub(super) hysteresis_cm_s2: Option<Spanned<Num>>,
    pub(super) bias_per_c_cm_s2: Option<Spanned<Num>>,
    pub(super) scale_factor_per_c_ppm: Option<Spanned<Num>>,
    pub(super) warm_up_cm_s2: Option<Spanned<Num>>,
}

#[derive(Debug, Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "tables [pendulum], [pickoff], [torquer], [electronics] and [stops] (and optionally [board], [instrument], [model_equation] and [plausibility])"
)]
pub(super) struct FileT {
    pub(super) pendulum: PendulumT,
    pub(super) pickoff: PickoffT,
    pub(super) torquer: TorquerT,
    pub(super) electronics: ElectronicsT,
    pub(super) stops: StopsT,
    pub(super) board: Option<BoardT>,
    pub(super) instrument: Option<IdentT>,
    pub(super) model_equation: Option<ModelEquationT>,
    pub(super) plausibility: Option<PlausibilityT>,
}

/// The sections of a file with a PTSA loop (Table 2.1 and the loop's electronics): a file
/// that has none of them describes an instrument without a loop.
pub const LOOP_SECTIONS: &[&str] = &["pendulum", "pickoff", "torquer", "electronics", "stops"];

/// A file without a PTSA loop: `[instrument]` (required), `[model_equation]` and
/// `[plausibility]`.
#[derive(Debug, Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "tables [instrument] (and optionally [model_equation] and [plausibility])"
)]
pub(super) struct LooplessT {
    pub(super) instrument: IdentT,
    pub(super) model_equation: Option<ModelEquationT>,
    pub(super) plausibility: Option<PlausibilityT>,
}

/// `[instrument]`: what the instrument is and how its reading is scaled. Optional in a file
/// with a loop (whose bias and local gravity are in `[electronics]`), required without one.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "an [instrument] table")]
pub(super) struct IdentT {
    pub(super) name: Option<Spanned<String>>,
    pub(super) class: Option<Spanned<String>>,
    pub(super) reading_unit: Option<Spanned<String>>,
    pub(super) scale_factor_per_g: Option<Spanned<Num>>,
    pub(super) bias_cm_s2: Option<Spanned<Num>>,
    pub(super) local_gravity_cm_s2: Option<Spanned<Num>>,
}

/// `[model_equation]`: key = number, each key one of [`MODEL_EQUATION`].
pub(super) type ModelEquationT = std::collections::BTreeMap<Spanned<String>, Spanned<Num>>;

/// One key of `[model_equation]`: a nominal term of the instrument's IEEE Std 1293 model
/// equation, in the file's cgs unit and under the IEEE sign, and the discovery candidate it
/// is the nominal value of (the candidate's coefficient is `sign` × the file's value).
#[derive(Debug, Clone, Copy)]
pub struct ModelEquationKey {
    /// Key in `[model_equation]`.
    pub key: &'static str,
    /// Unit in the file.
    pub unit: &'static str,
    /// IEEE 1293 symbol.
    pub symbol: &'static str,
    /// What it is.
    pub description: &'static str,
    /// The candidate.
    pub id: CandidateId,
    /// The candidate's coefficient over the file's value: 1, or −1 for `δ_p` (the IEEE
    /// equation has `− δ_p·a_o`; the candidate `misalignment.delta_o_rad` is the coefficient
    /// of `a_OA`).
    pub sign: f64,
}

/// The keys of `[model_equation]`, in the order a written section lists them. Every key is
/// optional (0 when absent); the baseline model (both simulators) includes them, so that a
/// discovery's coefficients are changes from them.
pub const MODEL_EQUATION: &[ModelEquationKey] = &[
    ModelEquationKey {
        key: "k1_ppm",
        unit: "ppm",
        symbol: "K_1",
        description: "scale-factor error from the nominal scale factor",
        id: CandidateId::ScaleFactor,
        sign: 1.0,
    },
    ModelEquationKey {
        key: "delta_o_rad",
        unit: "rad",
        symbol: "δ_o",
        description: "IA misalignment about OA (toward PA): the term + δ_o·a_p",
        id: CandidateId::MisalignmentP,
        sign: 1.0,
    },
    ModelEquationKey {
        key: "delta_p_rad",
        unit: "rad",
        symbol: "δ_p",
        description: "IA misalignment about PA (toward OA): the term − δ_p·a_o",
        id: CandidateId::MisalignmentO,
        sign: -1.0,
    },
    ModelEquationKey {
        key: "k2_s2_cm",
        unit: "s²/cm",
        symbol: "K_2",
        description: "second-order nonlinearity, K_2·a_i²",
        id: CandidateId::Nonlinearity,
        sign: 1.0,
    },
    ModelEquationKey {
        key: "k3_s4_cm2",
        unit: "s⁴/cm²",
        symbol: "K_3",
        description: "third-order nonlinearity, K_3·a_i³",
        id: CandidateId::Cubic,
        sign: 1.0,
    },
    ModelEquationKey {
        key: "k_ip_s2_cm",
        unit: "s²/cm",
        symbol: "K_ip",
        description: "cross-coupling K_ip·a_i·a_p",
        id: CandidateId::Vibropendulosity,
        sign: 1.0,
    },
    ModelEquationKey {
        key: "k_io_s2_cm",
        unit: "s²/cm",
        symbol: "K_io",
        description: "cross-coupling K_io·a_i·a_o",
        id: CandidateId::Anisoelasticity,
        sign: 1.0,
    },
    ModelEquationKey {
        key: "k_pp_s2_cm",
        unit: "s²/cm",
        symbol: "K_pp",
        description: "cross-axis K_pp·a_p²",
        id: CandidateId::CrossAxisPp,
        sign: 1.0,
    },
    ModelEquationKey {
        key: "k_oo_s2_cm",
        unit: "s²/cm",
        symbol: "K_oo",
        description: "cross-axis K_oo·a_o²",
        id: CandidateId::CrossAxisOo,
        sign: 1.0,
    },
    ModelEquationKey {
        key: "k_po_s2_cm",
        unit: "s²/cm",
        symbol: "K_po",
        description: "cross-axis K_po·a_p·a_o",
        id: CandidateId::CrossAxisPo,
        sign: 1.0,
    },
];

/// How an entry of the instrument file is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Form {
    /// A toleranced table `{ value = ..., tol_pct | tol_abs | min and max }`, required.
    Toleranced,
    /// A bare number (exact, never identified) or a toleranced table: files older than the
    /// entry's tolerance give a number.
    NumberOrToleranced,
    /// A toleranced table that may be left out (then 0, exact).
    OptionalToleranced,
    /// A bare number: exact, never identified.
    Number,
}

impl Form {
    /// Whether the entry can carry a tolerance, and so be set, read, rewritten
    /// (`--write-instrument`) and fitted by `ptsa discover`.
    #[must_use]
    pub const fn can_be_toleranced(self) -> bool {
        !matches!(self, Form::Number)
    }
}

/// Where a [`Parameter`] is in the parsed file, in the type its [`Form`] is read as.
pub(super) enum Raw<'a> {
    Param(&'a Spanned<Param>),
    Optional(Option<&'a Spanned<Param>>),
    NumOrParam(&'a Spanned<NumOrParam>),
    Num(&'a Spanned<Num>),
}

/// One numeric entry of the `[pendulum]`, `[pickoff]`, `[torquer]`, `[electronics]` and
/// `[stops]` tables of the instrument file: its key (also its tolerance's key), unit, form,
/// valid range, and the [`Instrument`] field it sets. [`PARAMETERS`] lists them all; parsing,
/// [`Instrument::get`], [`Instrument::set`], [`Instrument::rewrite`] and the tolerance box
/// all go through that one table, and the loop-parameter candidates of
/// [`crate::model::effects::REGISTRY`] refer to its entries.
#[derive(Clone, Copy)]
pub struct Parameter {
    /// Key in the file, `section.key`, units in the name.
    pub key: &'static str,
    /// Unit in the file.
    pub unit: &'static str,
    /// What it is.
    pub description: &'static str,
    /// How it is written.
    pub form: Form,
    /// The valid range, as the refusal says it ("expected ...").
    pub(super) expected: &'static str,
    /// Whether a value (in the file's unit) is in the valid range; the file is there for a
    /// range that depends on another entry, which is checked before it.
    pub(super) valid: fn(f64, &FileT) -> bool,
    /// The entry in the parsed file.
    pub(super) raw: fn(&FileT) -> Raw<'_>,
    /// The value from the instrument, in the file's unit.
    pub(super) read: fn(&Instrument) -> f64,
    /// Set the instrument's field from a value in the file's unit.
    pub(super) write: fn(&mut Instrument, f64),
}

impl fmt::Debug for Parameter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Parameter")
            .field("key", &self.key)
            .field("unit", &self.unit)
            .field("form", &self.form)
            .finish_non_exhaustive()
    }
}

impl Parameter {
    /// The valid range, as the refusal says it ("a pendulosity > 0 dyn·cm/g").
    #[must_use]
    pub fn expected(&self) -> &'static str {
        self.expected
    }

    /// Its value in `instr`, in the file's unit.
    #[must_use]
    pub fn get(&self, instr: &Instrument) -> f64 {
        (self.read)(instr)
    }

    /// Set it in `instr` from a value in the file's unit.
    pub fn set(&self, instr: &mut Instrument, v: f64) {
        (self.write)(instr, v);
    }
}

/// `pendulum.pendulosity_dyn_cm_per_g`.
pub const PENDULOSITY: Parameter = Parameter {
    key: "pendulum.pendulosity_dyn_cm_per_g",
    unit: "dyn·cm/g",
    description: "pendulosity P, torque per g of input (Table 2.1: 1100)",
    form: Form::Toleranced,
    expected: "a pendulosity > 0 dyn·cm/g",
    valid: |x, _| positive(x),
    raw: |f| Raw::Param(&f.pendulum.pendulosity_dyn_cm_per_g),
    read: |i| i.pendulosity_dyn_cm_per_g,
    write: |i, v| i.pendulosity_dyn_cm_per_g = v,
};
/// `pendulum.freedom_mrad`.
pub const FREEDOM: Parameter = Parameter {
    key: "pendulum.freedom_mrad",
    unit: "mrad",
    description: "mechanical freedom: the stops' position",
    form: Form::Toleranced,
    expected: "0 < freedom < 2.5 mrad (the ADC's full scale)",
    valid: |x, _| x > 0.0 && x < 2.5,
    raw: |f| Raw::Param(&f.pendulum.freedom_mrad),
    read: |i| i.freedom_rad * 1e3,
    write: |i, v| i.freedom_rad = v * 1e-3,
};
/// `pendulum.inertia_oa_g_cm2`.
pub const INERTIA: Parameter = Parameter {
    key: "pendulum.inertia_oa_g_cm2",
    unit: "g·cm²",
    description: "output-axis inertia I_OA (Table 2.1: 14)",
    form: Form::Toleranced,
    expected: "an inertia > 0 g·cm²",
    valid: |x, _| positive(x),
    raw: |f| Raw::Param(&f.pendulum.inertia_oa_g_cm2),
    read: |i| i.inertia_dyn_cm_s2,
    write: |i, v| i.inertia_dyn_cm_s2 = v,
};
/// `pendulum.spring_dyn_cm_per_rad`.
pub const SPRING: Parameter = Parameter {
    key: "pendulum.spring_dyn_cm_per_rad",
    unit: "dyn·cm/rad",
    description: "flexure spring K (Table 2.1: 1540)",
    form: Form::Toleranced,
    expected: "a spring rate >= 0 dyn·cm/rad",
    valid: |x, _| non_negative(x),
    raw: |f| Raw::Param(&f.pendulum.spring_dyn_cm_per_rad),
    read: |i| i.spring_dyn_cm_rad,
    write: |i, v| i.spring_dyn_cm_rad = v,
};
/// `pendulum.damping_dyn_cm_s`.
pub const DAMPING: Parameter = Parameter {
    key: "pendulum.damping_dyn_cm_s",
    unit: "dyn·cm·s",
    description: "damping C_OA of eq. 4.2 (Table 2.1: 76 400)",
    form: Form::Toleranced,
    expected: "a damping > 0 dyn·cm·s",
    valid: |x, _| positive(x),
    raw: |f| Raw::Param(&f.pendulum.damping_dyn_cm_s),
    read: |i| i.damping_dyn_cm_s,
    write: |i, v| i.damping_dyn_cm_s = v,
};
/// `pendulum.anisoinertia_g_cm2`.
pub const ANISOINERTIA: Parameter = Parameter {
    key: "pendulum.anisoinertia_g_cm2",
    unit: "g·cm²",
    description: "anisoinertia I_PA − I_IA",
    form: Form::Toleranced,
    expected: "|I_PA − I_IA| < 100 g·cm²",
    valid: |x, _| x.abs() < 100.0,
    raw: |f| Raw::Param(&f.pendulum.anisoinertia_g_cm2),
    read: |i| i.anisoinertia_g_cm2,
    write: |i, v| i.anisoinertia_g_cm2 = v,
};
/// `pickoff.scale_factor_v_per_rad`.
pub const PICKOFF_SF: Parameter = Parameter {
    key: "pickoff.scale_factor_v_per_rad",
    unit: "V/rad",
    description: "pickoff scale factor (Table 2.1: 10)",
    form: Form::Toleranced,
    expected: "a pickoff scale factor > 0 V/rad",
    valid: |x, _| positive(x),
    raw: |f| Raw::Param(&f.pickoff.scale_factor_v_per_rad),
    read: |i| i.pickoff_v_per_rad,
    write: |i, v| i.pickoff_v_per_rad = v,
};
/// `pickoff.quadrature_null_uv`.
pub const QUADRATURE: Parameter = Parameter {
    key: "pickoff.quadrature_null_uv",
    unit: "µV",
    description: "quadrature null at the pickoff",
    form: Form::Toleranced,
    expected: "a quadrature null >= 0 µV",
    valid: |x, _| non_negative(x),
    raw: |f| Raw::Param(&f.pickoff.quadrature_null_uv),
    read: |i| i.quadrature_v * 1e6,
    write: |i, v| i.quadrature_v = v * 1e-6,
};
/// `pickoff.phase_angle_deg`.
pub const PHASE: Parameter = Parameter {
    key: "pickoff.phase_angle_deg",
    unit: "deg",
    description: "demodulator phase error against the pickoff",
    form: Form::Toleranced,
    expected: "|phase angle| < 60 deg",
    valid: |x, _| x.abs() < 60.0,
    raw: |f| Raw::Param(&f.pickoff.phase_angle_deg),
    read: |i| i.phase_error_rad.to_degrees(),
    write: |i, v| i.phase_error_rad = v.to_radians(),
};
/// `pickoff.noise_uv_rms`.
pub const NOISE: Parameter = Parameter {
    key: "pickoff.noise_uv_rms",
    unit: "µV rms",
    description: "pickoff-referred noise per sample",
    form: Form::Toleranced,
    expected: "a noise >= 0 µV rms",
    valid: |x, _| non_negative(x),
    raw: |f| Raw::Param(&f.pickoff.noise_uv_rms),
    read: |i| i.noise_v_rms * 1e6,
    write: |i, v| i.noise_v_rms = v * 1e-6,
};
/// `torquer.current_scale_factor_ma_per_g`.
pub const TORQUER_SF: Parameter = Parameter {
    key: "torquer.current_scale_factor_ma_per_g",
    unit: "mA/g",
    description: "torquer current scale factor (Table 2.1: 0.99)",
    form: Form::Toleranced,
    expected: "a current scale factor > 0 mA/g",
    valid: |x, _| positive(x),
    raw: |f| Raw::Param(&f.torquer.current_scale_factor_ma_per_g),
    read: |i| i.current_sf_ma_per_g,
    write: |i, v| i.current_sf_ma_per_g = v,
};
/// `torquer.time_constant_us`.
pub const TORQUER_TAU: Parameter = Parameter {
    key: "torquer.time_constant_us",
    unit: "µs",
    description: "torquer current rise time constant (Table 2.1: 0.2 to 20)",
    form: Form::Toleranced,
    expected: "a time constant > 0 µs",
    valid: |x, _| positive(x),
    raw: |f| Raw::Param(&f.torquer.time_constant_us),
    read: |i| i.torquer_tau_s * 1e6,
    write: |i, v| i.torquer_tau_s = v * 1e-6,
};
/// `electronics.scale_factor_cm_s2`.
pub const SCALE_FACTOR: Parameter = Parameter {
    key: "electronics.scale_factor_cm_s2",
    unit: "cm/s²",
    description: "the loop's target full scale (the measured SF)",
    form: Form::Number,
    expected: "a scale factor > 0 cm/s²",
    valid: |x, _| positive(x),
    raw: |f| Raw::Num(&f.electronics.scale_factor_cm_s2),
    read: |i| i.sf_cm_s2,
    write: |i, v| i.sf_cm_s2 = v,
};
/// `electronics.bias_cm_s2`.
pub const BIAS: Parameter = Parameter {
    key: "electronics.bias_cm_s2",
    unit: "cm/s²",
    description: "bias A_b, a torque P·A_b on the pendulum",
    form: Form::Number,
    expected: "|bias| below the scale factor",
    valid: |x, f| x.abs() < f.electronics.scale_factor_cm_s2.get_ref().0,
    raw: |f| Raw::Num(&f.electronics.bias_cm_s2),
    read: |i| i.bias_cm_s2,
    write: |i, v| i.bias_cm_s2 = v,
};
/// `electronics.amplifier_gain`.
pub const AMPLIFIER_GAIN: Parameter = Parameter {
    key: "electronics.amplifier_gain",
    unit: "V/V",
    description: "amplifier gain ahead of the ADC",
    form: Form::NumberOrToleranced,
    expected: "a gain > 0",
    valid: |x, _| positive(x),
    raw: |f| Raw::NumOrParam(&f.electronics.amplifier_gain),
    read: |i| i.amp_gain,
    write: |i, v| i.amp_gain = v,
};
/// `electronics.demodulator_bandwidth_hz`.
pub const DEMODULATOR_BANDWIDTH: Parameter = Parameter {
    key: "electronics.demodulator_bandwidth_hz",
    unit: "Hz",
    description: "demodulator low-pass corner",
    form: Form::Number,
    expected: "a bandwidth > 0 Hz",
    valid: |x, _| positive(x),
    raw: |f| Raw::Num(&f.electronics.demodulator_bandwidth_hz),
    read: |i| i.demod_bandwidth_hz,
    write: |i, v| i.demod_bandwidth_hz = v,
};
/// `electronics.adc_full_scale_v`.
pub const ADC_FULL_SCALE: Parameter = Parameter {
    key: "electronics.adc_full_scale_v",
    unit: "V",
    description: "ADC full scale, ±",
    form: Form::Number,
    expected: "a full scale > 0 V",
    valid: |x, _| positive(x),
    raw: |f| Raw::Num(&f.electronics.adc_full_scale_v),
    read: |i| i.adc_full_scale_v,
    write: |i, v| i.adc_full_scale_v = v,
};
/// `electronics.clock_hz`.
pub const CLOCK: Parameter = Parameter {
    key: "electronics.clock_hz",
    unit: "Hz",
    description: "the loop's clock",
    form: Form::Number,
    expected: "a clock >= 1000 Hz",
    valid: |x, _| x >= 1000.0,
    raw: |f| Raw::Num(&f.electronics.clock_hz),
    read: |i| i.clock_hz,
    write: |i, v| i.clock_hz = v,
};
/// `electronics.local_gravity_cm_s2`.
pub const LOCAL_GRAVITY: Parameter = Parameter {
    key: "electronics.local_gravity_cm_s2",
    unit: "cm/s²",
    description: "local gravity",
    form: Form::Number,
    expected: "gravity > 0 cm/s²",
    valid: |x, _| positive(x),
    raw: |f| Raw::Num(&f.electronics.local_gravity_cm_s2),
    read: |i| i.g_cm_s2,
    write: |i, v| i.g_cm_s2 = v,
};
/// `electronics.adc_offset_mv`.
pub const ADC_OFFSET: Parameter = Parameter {
    key: "electronics.adc_offset_mv",
    unit: "mV",
    description: "offset at the ADC's input, after the amplifier",
    form: Form::OptionalToleranced,
    expected: "an offset within the ADC's full scale, mV",
    valid: |x, f| x.abs() < 1e3 * f.electronics.adc_full_scale_v.get_ref().0,
    raw: |f| Raw::Optional(f.electronics.adc_offset_mv.as_ref()),
    read: |i| i.adc_offset_v * 1e3,
    write: |i, v| i.adc_offset_v = v * 1e-3,
};
/// `stops.stiffness_dyn_cm_per_rad`.
pub const STOP_STIFFNESS: Parameter = Parameter {
    key: "stops.stiffness_dyn_cm_per_rad",
    unit: "dyn·cm/rad",
    description: "stop contact stiffness",
    form: Form::Number,
    expected: "a stiffness > 0 dyn·cm/rad",
    valid: |x, _| positive(x),
    raw: |f| Raw::Num(&f.stops.stiffness_dyn_cm_per_rad),
    read: |i| i.stop_stiffness_dyn_cm_rad,
    write: |i, v| i.stop_stiffness_dyn_cm_rad = v,
};
/// `stops.damping_dyn_cm_s`.
pub const STOP_DAMPING: Parameter = Parameter {
    key: "stops.damping_dyn_cm_s",
    unit: "dyn·cm·s",
    description: "stop contact damping",
    form: Form::Number,
    expected: "a damping >= 0 dyn·cm·s",
    valid: |x, _| non_negative(x),
    raw: |f| Raw::Num(&f.stops.damping_dyn_cm_s),
    read: |i| i.stop_damping_dyn_cm_s,
    write: |i, v| i.stop_damping_dyn_cm_s = v,
};

/// Every numeric entry of the file outside `[plausibility]`, in the order they are checked
/// (the file's order; an entry whose range depends on another comes after it). The
/// tolerance box ([`Instrument::tolerances`]) follows this order.
pub const PARAMETERS: &[Parameter] = &[
    PENDULOSITY,
    FREEDOM,
    INERTIA,
    SPRING,
    DAMPING,
    ANISOINERTIA,
    PICKOFF_SF,
    QUADRATURE,
    PHASE,
    NOISE,
    TORQUER_SF,
    TORQUER_TAU,
    SCALE_FACTOR,
    BIAS,
    AMPLIFIER_GAIN,
    DEMODULATOR_BANDWIDTH,
    ADC_FULL_SCALE,
    CLOCK,
    LOCAL_GRAVITY,
    ADC_OFFSET,
    STOP_STIFFNESS,
    STOP_DAMPING,
];

/// The entry of [`PARAMETERS`] with file key `key` that can carry a tolerance (the keys
/// [`Instrument::get`], [`Instrument::set`] and [`Instrument::rewrite`] accept).
#[must_use]
pub fn toleranceable(key: &str) -> Option<&'static Parameter> {
    PARAMETERS
        .iter()
        .find(|p| p.key == key && p.form.can_be_toleranced())
}

/// The largest magnitude of each kind of candidate coefficient that is physically plausible
/// for this instrument (`[plausibility]` of the instrument file; every key optional). A
/// coefficient that `ptsa discover` selects beyond its bound is reported with
/// `"plausible": false`: the data's structure is real, but this cause is unlikely.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plausibility {
    /// Offset of the proof mass from where the fixture puts it, per component, cm (default
    /// 3: the case's own size, Fig. 2.1).
    pub lever_arm_cm: f64,
    /// `|I_PA − I_IA|`, g·cm² (default: the float's output-axis inertia, Table 2.1's 14).
    pub anisoinertia_g_cm2: f64,
    /// Second-order coefficients (vibropendulosity, anisoelasticity, nonlinearity and the
    /// other products of two accelerations), s²/cm (default 1e-4, about 0.1 g/g²: two orders
    /// of magnitude beyond catalogue values).
    pub second_order_s2_cm: f64,
    /// Sculling coefficient, s² (default 1e-4).
    pub sculling_s2: f64,
    /// A change of the bias from the file's `A_b`, cm/s² (default 50, about 0.05 g).
    pub bias_cm_s2: f64,
    /// A change of the scale factor, ppm (default 10 000, 1 %).
    pub scale_factor_ppm: f64,
    /// A misalignment of IA, rad (default 0.01; the report puts them below 1 arc minute).
    pub misalignment_rad: f64,
    /// The cubic coefficient, s⁴/cm² (default 1e-10, about 0.1 g/g³).
    pub cubic_s4_cm2: f64,
    /// A hysteresis, half the gap between the readings approached from below and from
    /// above, cm/s² (default 1, about 1 mg).
    pub hysteresis_cm_s2: f64,
    /// A bias change per °C, cm/s² per °C (default 1, about 1 mg/°C).
    pub bias_per_c_cm_s2: f64,
    /// A scale-factor change per °C, ppm per °C (default 1000).
    pub scale_factor_per_c_ppm: f64,
    /// The amplitude of a turn-on transient at power-on, cm/s² (default 5, about 5 mg).
    pub warm_up_cm_s2: f64,
}

/// One parameter's tolerance band (for Monte Carlo over the tolerance box).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Parameter key, as in the file (`section.key`).
    pub key: &'static str,
    /// Lower limit, in the file's unit.
    pub lo: f64,
    /// Nominal, in the file's unit.
    pub nominal: f64,
    /// Upper limit, in the file's unit.
    pub hi: f64,
}

/// A range check of the parameter table: above 0.
pub(super) fn positive(x: f64) -> bool {
    x > 0.0
}

/// A range check of the parameter table: 0 or above.
pub(super) fn non_negative(x: f64) -> bool {
    x >= 0.0
}
