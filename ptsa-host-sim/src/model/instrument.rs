//! The instrument file (`data/kearfott-2401.toml`): Table 2.1 of R-890 with tolerances, and
//! the PTSA electronics, validated on load.

use std::fmt;
use std::path::Path;

use serde::Deserialize;
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use toml::Spanned;

/// The shipped instrument file, compiled in.
pub const KEARFOTT_2401_TOML: &str = include_str!("../../../data/kearfott-2401.toml");

/// Why an instrument file was refused: where and what was expected.
///
/// Displayed as `file:line:column: message`, or `file: message` when the error has no
/// position (the file could not be read).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{file}{}: {message}", position_text(*.line, *.column))]
pub struct InstrumentError {
    /// File name (or `<builtin>`).
    pub file: String,
    /// 1-based line; 0 when the error has no position in the file.
    pub line: usize,
    /// 1-based column, counted in characters; 0 when the error has no position.
    pub column: usize,
    /// What was wrong and what was expected.
    pub message: String,
}

impl InstrumentError {
    /// The 1-based (line, column) of the error, `None` when it has no position in the file
    /// (the file could not be read).
    #[must_use]
    pub fn position(&self) -> Option<(usize, usize)> {
        (self.line > 0).then_some((self.line, self.column))
    }
}

/// `:line:column` after the file name, or nothing for an error without a position.
fn position_text(line: usize, column: usize) -> String {
    if line == 0 {
        String::new()
    } else {
        format!(":{line}:{column}")
    }
}

/// A number in the file: a TOML float or integer. It has its own visitor so that a value of
/// another type is reported in the file's terms ("expected a number, found the string
/// "fast"") rather than serde's ("invalid type: string, expected f64").
#[derive(Debug, Clone, Copy)]
struct Num(f64);

impl<'de> Deserialize<'de> for Num {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(NumVisitor)
    }
}

struct NumVisitor;

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
struct Param {
    value: Spanned<Num>,
    tol_pct: Option<Num>,
    tol_abs: Option<Num>,
    min: Option<Num>,
    max: Option<Num>,
}

/// A bare number (no tolerance: the value is taken as exact and never identified) or a
/// toleranced parameter's table: `electronics.amplifier_gain`, which files older than its
/// tolerance give as a number.
#[derive(Debug, Clone)]
enum NumOrParam {
    Num(Num),
    Param(Param),
}

impl<'de> Deserialize<'de> for NumOrParam {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(NumOrParamVisitor)
    }
}

struct NumOrParamVisitor;

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
struct PendulumT {
    pendulosity_dyn_cm_per_g: Spanned<Param>,
    freedom_mrad: Spanned<Param>,
    inertia_oa_g_cm2: Spanned<Param>,
    spring_dyn_cm_per_rad: Spanned<Param>,
    damping_dyn_cm_s: Spanned<Param>,
    anisoinertia_g_cm2: Spanned<Param>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [pickoff] table")]
struct PickoffT {
    scale_factor_v_per_rad: Spanned<Param>,
    quadrature_null_uv: Spanned<Param>,
    phase_angle_deg: Spanned<Param>,
    noise_uv_rms: Spanned<Param>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [torquer] table")]
struct TorquerT {
    current_scale_factor_ma_per_g: Spanned<Param>,
    time_constant_us: Spanned<Param>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "an [electronics] table")]
struct ElectronicsT {
    scale_factor_cm_s2: Spanned<Num>,
    bias_cm_s2: Spanned<Num>,
    amplifier_gain: Spanned<NumOrParam>,
    #[serde(default)]
    adc_offset_mv: Option<Spanned<Param>>,
    demodulator_bandwidth_hz: Spanned<Num>,
    adc_full_scale_v: Spanned<Num>,
    clock_hz: Spanned<Num>,
    local_gravity_cm_s2: Spanned<Num>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [stops] table")]
struct StopsT {
    stiffness_dyn_cm_per_rad: Spanned<Num>,
    damping_dyn_cm_s: Spanned<Num>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [plausibility] table")]
struct PlausibilityT {
    lever_arm_cm: Option<Spanned<Num>>,
    anisoinertia_g_cm2: Option<Spanned<Num>>,
    second_order_s2_cm: Option<Spanned<Num>>,
    sculling_s2: Option<Spanned<Num>>,
    bias_cm_s2: Option<Spanned<Num>>,
    scale_factor_ppm: Option<Spanned<Num>>,
    misalignment_rad: Option<Spanned<Num>>,
    cubic_s4_cm2: Option<Spanned<Num>>,
    hysteresis_cm_s2: Option<Spanned<Num>>,
    bias_per_c_cm_s2: Option<Spanned<Num>>,
    scale_factor_per_c_ppm: Option<Spanned<Num>>,
    warm_up_cm_s2: Option<Spanned<Num>>,
}

#[derive(Debug, Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "tables [pendulum], [pickoff], [torquer], [electronics] and [stops] (and optionally [plausibility])"
)]
struct FileT {
    pendulum: PendulumT,
    pickoff: PickoffT,
    torquer: TorquerT,
    electronics: ElectronicsT,
    stops: StopsT,
    plausibility: Option<PlausibilityT>,
}

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
enum Raw<'a> {
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
    expected: &'static str,
    /// Whether a value (in the file's unit) is in the valid range; the file is there for a
    /// range that depends on another entry, which is checked before it.
    valid: fn(f64, &FileT) -> bool,
    /// The entry in the parsed file.
    raw: fn(&FileT) -> Raw<'_>,
    /// The value from the instrument, in the file's unit.
    read: fn(&Instrument) -> f64,
    /// Set the instrument's field from a value in the file's unit.
    write: fn(&mut Instrument, f64),
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

/// The instrument and its electronics, in the simulator's units (cgs, rad, s, V).
#[derive(Debug, Clone, PartialEq)]
pub struct Instrument {
    /// Pendulosity, dyn·cm per g of input (Table 2.1: 1100).
    pub pendulosity_dyn_cm_per_g: f64,
    /// Mechanical freedom (stop position), rad.
    pub freedom_rad: f64,
    /// Output-axis inertia `I_OA`, g·cm² (dyn·cm·s²).
    pub inertia_dyn_cm_s2: f64,
    /// Flexure spring, dyn·cm/rad.
    pub spring_dyn_cm_rad: f64,
    /// Damping `C_OA`, dyn·cm·s.
    pub damping_dyn_cm_s: f64,
    /// Anisoinertia `I_PA − I_IA`, g·cm².
    pub anisoinertia_g_cm2: f64,
    /// Pickoff scale factor, V/rad.
    pub pickoff_v_per_rad: f64,
    /// Quadrature null, V (at the pickoff).
    pub quadrature_v: f64,
    /// Demodulator phase error, rad.
    pub phase_error_rad: f64,
    /// Pickoff-referred noise, V rms per sample.
    pub noise_v_rms: f64,
    /// Torquer current scale factor, mA per g.
    pub current_sf_ma_per_g: f64,
    /// Torquer current rise time constant, s.
    pub torquer_tau_s: f64,
    /// Regulated torquer current, mA: set at load time from the nominal values so that the
    /// full scale equals `sf_cm_s2` (`I = SF/g · current_sf`). Monte Carlo keeps it fixed.
    pub full_current_ma: f64,
    /// Target full scale of the loop (the measured SF), cm/s².
    pub sf_cm_s2: f64,
    /// Bias `A_b` as a torque `P·A_b` on the pendulum, cm/s².
    pub bias_cm_s2: f64,
    /// Amplifier gain, V/V.
    pub amp_gain: f64,
    /// Offset at the ADC's input, V (after the amplifier): a constant code offset, as the
    /// quadrature the pickoff phase leaks.
    pub adc_offset_v: f64,
    /// Demodulator low-pass corner, Hz.
    pub demod_bandwidth_hz: f64,
    /// ADC full scale, ±V.
    pub adc_full_scale_v: f64,
    /// Clock, Hz.
    pub clock_hz: f64,
    /// Local gravity, cm/s².
    pub g_cm_s2: f64,
    /// Stop contact stiffness, dyn·cm/rad.
    pub stop_stiffness_dyn_cm_rad: f64,
    /// Stop contact damping, dyn·cm·s.
    pub stop_damping_dyn_cm_s: f64,
    /// Tolerance box of every toleranced parameter.
    pub tolerances: Vec<Tolerance>,
    /// Plausibility bounds of the discovery candidates.
    pub plausibility: Plausibility,
}

/// The 1-based line and column (in characters) of byte `offset` of `src`.
fn line_col(src: &str, offset: usize) -> (usize, usize) {
    let mut at = offset.min(src.len());
    while !src.is_char_boundary(at) {
        at -= 1;
    }
    let before = &src[..at];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// A toml/serde message in the file's terms: serde's `invalid type: X, expected Y` becomes
/// `expected Y, found X` with X named as TOML names it (a table, an array, the number 3), and
/// `invalid length N, expected Y` (serde reads a struct from an array too, in key order)
/// becomes `expected Y, found an array of N values`.
fn user_message(message: &str) -> String {
    let message = message.trim();
    if let Some((n, expected)) = message
        .strip_prefix("invalid length ")
        .and_then(|rest| rest.split_once(", expected "))
    {
        let values = if n == "1" { "value" } else { "values" };
        return format!("expected {expected}, found an array of {n} {values}");
    }
    let Some((found, expected)) = message
        .strip_prefix("invalid type: ")
        .and_then(|rest| rest.rsplit_once(", expected "))
    else {
        return message.to_string();
    };
    let found = if let Some(s) = found.strip_prefix("string ") {
        format!("the string {s}")
    } else if let Some(n) = found
        .strip_prefix("floating point ")
        .or_else(|| found.strip_prefix("integer "))
    {
        let n = n.split(" as ").next().unwrap_or(n);
        format!("the number {}", n.trim_matches('`'))
    } else if let Some(b) = found.strip_prefix("boolean ") {
        b.to_string()
    } else {
        match found {
            "map" => "a table".to_string(),
            "sequence" => "an array".to_string(),
            other => other.to_string(),
        }
    };
    format!("expected {expected}, found {found}")
}

struct Ctx<'a> {
    file: &'a str,
    src: &'a str,
}

impl Ctx<'_> {
    fn err(&self, offset: usize, message: String) -> InstrumentError {
        let (line, column) = line_col(self.src, offset);
        InstrumentError {
            file: self.file.to_string(),
            line,
            column,
            message,
        }
    }

    /// Check a toleranced parameter: value in `range` (open/closed as the message says) and
    /// exactly one tolerance form, containing the nominal.
    fn param(
        &self,
        key: &'static str,
        p: &Spanned<Param>,
        ok: impl Fn(f64) -> bool,
        expected: &str,
        tolerances: &mut Vec<Tolerance>,
    ) -> Result<f64, InstrumentError> {
        let q = p.get_ref();
        let v = q.value.get_ref().0;
        if !v.is_finite() || !ok(v) {
            let at = q.value.span().start;
            return Err(self.err(at, format!("{key} = {v}: expected {expected}")));
        }
        let (lo, hi) = band(key, v, q).map_err(|m| self.err(p.span().start, m))?;
        if !lo.is_finite() || !hi.is_finite() || !ok(lo) || !ok(hi) {
            return Err(self.err(
                p.span().start,
                format!(
                    "{key}: tolerance band [{lo}, {hi}] leaves the valid range: expected {expected}"
                ),
            ));
        }
        tolerances.push(Tolerance {
            key,
            lo,
            nominal: v,
            hi,
        });
        Ok(v)
    }

    fn scalar(
        &self,
        key: &str,
        s: &Spanned<Num>,
        ok: impl Fn(f64) -> bool,
        expected: &str,
    ) -> Result<f64, InstrumentError> {
        let v = s.get_ref().0;
        if !v.is_finite() || !ok(v) {
            return Err(self.err(s.span().start, format!("{key} = {v}: expected {expected}")));
        }
        Ok(v)
    }

    /// One entry of [`PARAMETERS`], checked: in range, and a toleranced one's band (pushed
    /// onto `tolerances`) within the range too. An optional entry left out is 0.
    fn entry(
        &self,
        p: &Parameter,
        f: &FileT,
        tolerances: &mut Vec<Tolerance>,
    ) -> Result<f64, InstrumentError> {
        let ok = |x: f64| (p.valid)(x, f);
        match (p.raw)(f) {
            Raw::Param(q) => self.param(p.key, q, ok, p.expected, tolerances),
            Raw::Optional(q) => q.map_or(Ok(0.0), |q| {
                self.param(p.key, q, ok, p.expected, tolerances)
            }),
            Raw::Num(n) => self.scalar(p.key, n, ok, p.expected),
            Raw::NumOrParam(g) => match g.get_ref() {
                NumOrParam::Num(n) => {
                    self.scalar(p.key, &Spanned::new(g.span(), *n), ok, p.expected)
                }
                NumOrParam::Param(q) => self.param(
                    p.key,
                    &Spanned::new(g.span(), q.clone()),
                    ok,
                    p.expected,
                    tolerances,
                ),
            },
        }
    }

    /// `[plausibility]` (optional, every key optional): the bounds, with defaults.
    fn plausibility(
        &self,
        p: Option<&PlausibilityT>,
        inertia_g_cm2: f64,
    ) -> Result<Plausibility, InstrumentError> {
        let get = |key: &str, v: Option<&Spanned<Num>>, default: f64, unit: &str| {
            v.map_or(Ok(default), |s| {
                self.scalar(key, s, positive, &format!("a bound > 0 {unit}"))
            })
        };
        Ok(Plausibility {
            lever_arm_cm: get(
                "plausibility.lever_arm_cm",
                p.and_then(|p| p.lever_arm_cm.as_ref()),
                3.0,
                "cm",
            )?,
            anisoinertia_g_cm2: get(
                "plausibility.anisoinertia_g_cm2",
                p.and_then(|p| p.anisoinertia_g_cm2.as_ref()),
                inertia_g_cm2,
                "g·cm²",
            )?,
            second_order_s2_cm: get(
                "plausibility.second_order_s2_cm",
                p.and_then(|p| p.second_order_s2_cm.as_ref()),
                1e-4,
                "s²/cm",
            )?,
            sculling_s2: get(
                "plausibility.sculling_s2",
                p.and_then(|p| p.sculling_s2.as_ref()),
                1e-4,
                "s²",
            )?,
            bias_cm_s2: get(
                "plausibility.bias_cm_s2",
                p.and_then(|p| p.bias_cm_s2.as_ref()),
                50.0,
                "cm/s²",
            )?,
            scale_factor_ppm: get(
                "plausibility.scale_factor_ppm",
                p.and_then(|p| p.scale_factor_ppm.as_ref()),
                1e4,
                "ppm",
            )?,
            misalignment_rad: get(
                "plausibility.misalignment_rad",
                p.and_then(|p| p.misalignment_rad.as_ref()),
                0.01,
                "rad",
            )?,
            cubic_s4_cm2: get(
                "plausibility.cubic_s4_cm2",
                p.and_then(|p| p.cubic_s4_cm2.as_ref()),
                1e-10,
                "s⁴/cm²",
            )?,
            hysteresis_cm_s2: get(
                "plausibility.hysteresis_cm_s2",
                p.and_then(|p| p.hysteresis_cm_s2.as_ref()),
                1.0,
                "cm/s²",
            )?,
            bias_per_c_cm_s2: get(
                "plausibility.bias_per_c_cm_s2",
                p.and_then(|p| p.bias_per_c_cm_s2.as_ref()),
                1.0,
                "cm/s² per °C",
            )?,
            scale_factor_per_c_ppm: get(
                "plausibility.scale_factor_per_c_ppm",
                p.and_then(|p| p.scale_factor_per_c_ppm.as_ref()),
                1000.0,
                "ppm per °C",
            )?,
            warm_up_cm_s2: get(
                "plausibility.warm_up_cm_s2",
                p.and_then(|p| p.warm_up_cm_s2.as_ref()),
                5.0,
                "cm/s²",
            )?,
        })
    }
}

/// The tolerance band `(lo, hi)` of parameter `key` with nominal `v`, from its one
/// tolerance form; `Err` is the message.
fn band(key: &str, v: f64, q: &Param) -> Result<(f64, f64), String> {
    let forms = usize::from(q.tol_pct.is_some())
        + usize::from(q.tol_abs.is_some())
        + usize::from(q.min.is_some() || q.max.is_some());
    if forms != 1 {
        return Err(format!(
            "{key}: expected exactly one tolerance form: tol_pct, tol_abs, or min and max"
        ));
    }
    if let Some(Num(t)) = q.tol_pct {
        if !(0.0..100.0).contains(&t) {
            return Err(format!("{key}: tol_pct = {t}: expected 0 <= tol_pct < 100"));
        }
        let a = v * (1.0 - t / 100.0);
        let b = v * (1.0 + t / 100.0);
        return Ok((a.min(b), a.max(b)));
    }
    if let Some(Num(t)) = q.tol_abs {
        if t < 0.0 || !t.is_finite() {
            return Err(format!(
                "{key}: tol_abs = {t}: expected a finite value >= 0"
            ));
        }
        return Ok((v - t, v + t));
    }
    match (q.min, q.max) {
        (Some(Num(a)), Some(Num(b))) if a <= v && v <= b => Ok((a, b)),
        (Some(Num(a)), Some(Num(b))) => Err(format!(
            "{key}: min = {a}, max = {b}: expected min <= value ({v}) <= max"
        )),
        _ => Err(format!("{key}: expected both min and max")),
    }
}

fn positive(x: f64) -> bool {
    x > 0.0
}
fn non_negative(x: f64) -> bool {
    x >= 0.0
}

/// An I/O error's message without the operating system's error number.
fn io_message(e: &std::io::Error) -> String {
    let s = e.to_string();
    match s.rfind(" (os error ") {
        Some(i) if s.ends_with(')') => s[..i].to_string(),
        _ => s,
    }
}

impl Instrument {
    /// The shipped Kearfott 2401 file (compiled in).
    ///
    /// # Panics
    /// Never for the shipped file (a unit test parses it).
    #[must_use]
    pub fn kearfott_2401() -> Self {
        Self::parse(KEARFOTT_2401_TOML, "data/kearfott-2401.toml")
            .expect("the shipped instrument file is valid")
    }

    /// Load and validate an instrument file.
    ///
    /// # Errors
    /// Unreadable file (the error has no position: `file: cannot read: ...`), text that is
    /// not UTF-8, TOML syntax, unknown or missing keys, a value of the wrong type, or a
    /// value out of range; the error names the file, line and column and says what was
    /// expected.
    pub fn load(path: &Path) -> Result<Self, InstrumentError> {
        let name = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|e| InstrumentError {
            file: name.clone(),
            line: 0,
            column: 0,
            message: format!("cannot read: {}", io_message(&e)),
        })?;
        Self::parse_bytes(&bytes, &name)
    }

    /// Parse and validate the bytes of an instrument file; `file` names it in errors.
    ///
    /// # Errors
    /// Bytes that are not UTF-8 (the error names the line and column of the first bad byte
    /// and its byte offset), or see [`Instrument::parse`].
    pub fn parse_bytes(src: &[u8], file: &str) -> Result<Self, InstrumentError> {
        match std::str::from_utf8(src) {
            Ok(text) => Self::parse(text, file),
            Err(e) => {
                let off = e.valid_up_to();
                let valid = std::str::from_utf8(&src[..off]).unwrap_or_default();
                let byte = src.get(off).copied().unwrap_or_default();
                let (line, column) = line_col(valid, off);
                Err(InstrumentError {
                    file: file.to_string(),
                    line,
                    column,
                    message: format!(
                        "the file is not UTF-8 text: byte 0x{byte:02X} at byte offset {off} \
                         is not valid UTF-8; expected UTF-8 text"
                    ),
                })
            }
        }
    }

    /// Parse and validate instrument-file text; `file` names it in errors. A leading UTF-8
    /// byte-order mark is ignored.
    ///
    /// # Errors
    /// TOML syntax, unknown or missing keys, a value of the wrong type, or a value out of
    /// range; the error names the file, line and column and says what was expected.
    pub fn parse(src: &str, file: &str) -> Result<Self, InstrumentError> {
        let src = src.strip_prefix('\u{feff}').unwrap_or(src);
        let cx = Ctx { file, src };
        let f: FileT = toml::from_str(src).map_err(|e| {
            let at = e.span().map_or(0, |s| s.start);
            cx.err(at, user_message(e.message()))
        })?;
        let mut tol = Vec::new();
        let mut instr = Self::zeroed();
        for p in PARAMETERS {
            let v = cx.entry(p, &f, &mut tol)?;
            p.set(&mut instr, v);
        }
        instr.full_current_ma = instr.sf_cm_s2 / instr.g_cm_s2 * instr.current_sf_ma_per_g;
        instr.tolerances = tol;
        instr.plausibility = cx.plausibility(f.plausibility.as_ref(), instr.inertia_dyn_cm_s2)?;
        Ok(instr)
    }

    /// Every field 0 and no tolerance: the blank [`Instrument::parse`] fills in.
    fn zeroed() -> Self {
        Self {
            pendulosity_dyn_cm_per_g: 0.0,
            freedom_rad: 0.0,
            inertia_dyn_cm_s2: 0.0,
            spring_dyn_cm_rad: 0.0,
            damping_dyn_cm_s: 0.0,
            anisoinertia_g_cm2: 0.0,
            pickoff_v_per_rad: 0.0,
            quadrature_v: 0.0,
            phase_error_rad: 0.0,
            noise_v_rms: 0.0,
            current_sf_ma_per_g: 0.0,
            torquer_tau_s: 0.0,
            full_current_ma: 0.0,
            sf_cm_s2: 0.0,
            bias_cm_s2: 0.0,
            amp_gain: 0.0,
            adc_offset_v: 0.0,
            demod_bandwidth_hz: 0.0,
            adc_full_scale_v: 0.0,
            clock_hz: 0.0,
            g_cm_s2: 0.0,
            stop_stiffness_dyn_cm_rad: 0.0,
            stop_damping_dyn_cm_s: 0.0,
            tolerances: Vec::new(),
            plausibility: Plausibility {
                lever_arm_cm: 0.0,
                anisoinertia_g_cm2: 0.0,
                second_order_s2_cm: 0.0,
                sculling_s2: 0.0,
                bias_cm_s2: 0.0,
                scale_factor_ppm: 0.0,
                misalignment_rad: 0.0,
                cubic_s4_cm2: 0.0,
                hysteresis_cm_s2: 0.0,
                bias_per_c_cm_s2: 0.0,
                scale_factor_per_c_ppm: 0.0,
                warm_up_cm_s2: 0.0,
            },
        }
    }

    /// The text of instrument file `src` with new values for toleranced parameters,
    /// everything else (comments, order, other entries) kept: each `(key, value, note)`
    /// rewrites that entry's inline table with the new `value` in the same tolerance form
    /// (`tol_pct` and `tol_abs` keep their figure, so a percentage band now centres on the
    /// new value; a `min`/`max` band is widened to hold it) and puts `# note` on the line
    /// above. The result is parsed again and must give each value back exactly.
    ///
    /// # Errors
    /// `src` is not a valid instrument file, a key is not a toleranced parameter, or the
    /// new text does not give the values back (a value the file refuses, e.g. a negative
    /// inertia).
    pub fn rewrite(
        src: &str,
        file: &str,
        changes: &[(&str, f64, String)],
    ) -> Result<String, InstrumentError> {
        let src = src.strip_prefix('\u{feff}').unwrap_or(src);
        Self::parse(src, file)?;
        let cx = Ctx { file, src };
        let f: FileT = toml::from_str(src).map_err(|e| cx.err(0, user_message(e.message())))?;
        let entry = |key: &str| -> Option<(std::ops::Range<usize>, &Param)> {
            match (toleranceable(key)?.raw)(&f) {
                Raw::Param(p) => Some((p.span(), p.get_ref())),
                Raw::Optional(p) => p.map(|p| (p.span(), p.get_ref())),
                Raw::NumOrParam(g) => match g.get_ref() {
                    NumOrParam::Param(q) => Some((g.span(), q)),
                    NumOrParam::Num(_) => None,
                },
                Raw::Num(_) => None,
            }
        };
        let mut edits: Vec<(std::ops::Range<usize>, String)> = Vec::new();
        for (key, v, note) in changes {
            let e = entry(key).ok_or_else(|| InstrumentError {
                file: file.to_string(),
                line: 0,
                column: 0,
                message: format!("{key}: not a toleranced parameter of the file"),
            })?;
            let (span, q) = e;
            let table = if let Some(Num(t)) = q.tol_pct {
                format!("{{ value = {v:?}, tol_pct = {t:?} }}")
            } else if let Some(Num(t)) = q.tol_abs {
                format!("{{ value = {v:?}, tol_abs = {t:?} }}")
            } else {
                let (lo, hi) = (q.min.map_or(*v, |n| n.0), q.max.map_or(*v, |n| n.0));
                format!(
                    "{{ value = {v:?}, min = {:?}, max = {:?} }}",
                    lo.min(*v),
                    hi.max(*v)
                )
            };
            let line_start = src[..span.start].rfind('\n').map_or(0, |i| i + 1);
            let indent: String = src[line_start..]
                .chars()
                .take_while(|c| *c == ' ' || *c == '\t')
                .collect();
            let note = note.replace('\n', " ");
            edits.push((line_start..line_start, format!("{indent}# {note}\n")));
            edits.push((span.start..span.end, table));
        }
        edits.sort_by_key(|(r, _)| std::cmp::Reverse((r.start, r.end)));
        let mut out = src.to_string();
        for (r, t) in edits {
            out.replace_range(r, &t);
        }
        let back = Self::parse(&out, file)?;
        for (key, v, _) in changes {
            if back
                .get(key)
                .is_none_or(|b| (b - v).abs() > 1e-12 * v.abs().max(1e-300))
            {
                return Err(InstrumentError {
                    file: file.to_string(),
                    line: 0,
                    column: 0,
                    message: format!("{key}: the rewritten file does not give {v} back"),
                });
            }
        }
        Ok(out)
    }

    /// Pendulosity `m·l`, g·cm: torque per unit specific force, dyn·cm per cm/s².
    #[must_use]
    pub fn pendulosity_g_cm(&self) -> f64 {
        self.pendulosity_dyn_cm_per_g / self.g_cm_s2
    }

    /// Torquer torque constant, dyn·cm per mA: `pendulosity / current scale factor`.
    #[must_use]
    pub fn torquer_dyn_cm_per_ma(&self) -> f64 {
        self.pendulosity_dyn_cm_per_g / self.current_sf_ma_per_g
    }

    /// Torque at full current, dyn·cm (`= P·SF` for the nominal instrument).
    #[must_use]
    pub fn full_torque_dyn_cm(&self) -> f64 {
        self.torquer_dyn_cm_per_ma() * self.full_current_ma
    }

    /// The loop's actual full scale, cm/s²: full torque over pendulosity (`= g·I/current_sf`).
    #[must_use]
    pub fn actual_sf_cm_s2(&self) -> f64 {
        self.full_torque_dyn_cm() / self.pendulosity_g_cm()
    }

    /// ADC codes per radian of pendulum angle: `pickoff · gain / (FS / 2^15)`.
    #[must_use]
    pub fn lsb_per_rad(&self) -> f64 {
        self.pickoff_v_per_rad * self.amp_gain / (self.adc_full_scale_v / 32768.0)
    }

    /// Pendulum angle per ADC LSB, rad (76.294 nrad nominal).
    #[must_use]
    pub fn theta_lsb_rad(&self) -> f64 {
        1.0 / self.lsb_per_rad()
    }

    /// Set one parameter that can carry a tolerance ([`toleranceable`]) by its file key, in
    /// the file's unit. The regulated current is not re-derived (the PTSA keeps its
    /// setting).
    ///
    /// # Errors
    /// Unknown key.
    pub fn set(&mut self, key: &str, v: f64) -> Result<(), String> {
        let p = toleranceable(key).ok_or_else(|| format!("unknown parameter {key}"))?;
        p.set(self, v);
        Ok(())
    }

    /// One toleranced parameter by its file key, in the file's unit (the inverse of
    /// [`Instrument::set`]); `None` for an unknown key.
    #[must_use]
    pub fn get(&self, key: &str) -> Option<f64> {
        toleranceable(key).map(|p| p.get(self))
    }

    /// The tolerance band of a parameter by its file key, `(lo, nominal, hi)` in the file's
    /// unit.
    #[must_use]
    pub fn tolerance(&self, key: &str) -> Option<(f64, f64, f64)> {
        self.tolerances
            .iter()
            .find(|t| t.key == key)
            .map(|t| (t.lo, t.nominal, t.hi))
    }

    /// The loop's own bias, cm/s²: the quadrature leak through a demodulator phase error
    /// puts the null at `θ0 = −V_q·tan(φ)/S`, where the spring and the `−P·a_PA·θ` term
    /// (with `a_pa_cm_s2` along PA) push `−(K + P·a_PA)·θ0/P` into the indicated output. It is
    /// zero for the nominal file (phase error 0).
    #[must_use]
    pub fn loop_bias_cm_s2(&self, a_pa_cm_s2: f64) -> f64 {
        let theta0 = -self.quadrature_v * self.phase_error_rad.tan() / self.pickoff_v_per_rad;
        let p = self.pendulosity_g_cm();
        -(self.spring_dyn_cm_rad + p * a_pa_cm_s2) * theta0 / p
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The value of `key` (`section.name`) as written in `src`: a bare number or a table's
    /// `value`; `None` when the file leaves it out.
    fn written(src: &str, key: &str) -> Option<f64> {
        let t: toml::Table = toml::from_str(src).unwrap();
        let (section, name) = key.split_once('.').unwrap();
        let v = t.get(section)?.get(name)?;
        let v = v.get("value").unwrap_or(v);
        v.as_float()
    }

    /// The shipped file with the amplifier gain and the ADC offset given tolerances, so that
    /// every entry that can carry one does.
    fn every_entry_toleranced() -> String {
        KEARFOTT_2401_TOML.replace(
            "amplifier_gain = 100.0",
            "amplifier_gain = { value = 100.0, tol_pct = 5.0 }\nadc_offset_mv = { value = 0.5, tol_abs = 2.0 }",
        )
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * a.abs().max(b.abs())
    }

    /// The table is the file: every numeric entry of the shipped file's tables (but
    /// `[plausibility]`) is in [`PARAMETERS`] once, and every entry of the table is in the
    /// file (or may be left out), read in the type its form says.
    #[test]
    fn every_entry_of_the_file_is_in_the_parameter_table_once() {
        let keys: Vec<&str> = PARAMETERS.iter().map(|p| p.key).collect();
        for (k, key) in keys.iter().enumerate() {
            assert!(!keys[..k].contains(key), "{key} is in PARAMETERS twice");
        }
        let t: toml::Table = toml::from_str(KEARFOTT_2401_TOML).unwrap();
        for (section, entries) in &t {
            if section == "plausibility" {
                continue;
            }
            for name in entries.as_table().unwrap().keys() {
                let key = format!("{section}.{name}");
                assert!(keys.contains(&key.as_str()), "{key} is not in PARAMETERS");
            }
        }
        let src = every_entry_toleranced();
        let f: FileT = toml::from_str(&src).unwrap();
        for p in PARAMETERS {
            let form = match (p.raw)(&f) {
                Raw::Param(_) => Form::Toleranced,
                Raw::Optional(_) => Form::OptionalToleranced,
                Raw::NumOrParam(_) => Form::NumberOrToleranced,
                Raw::Num(_) => Form::Number,
            };
            assert_eq!(form, p.form, "{}", p.key);
            assert!(
                written(KEARFOTT_2401_TOML, p.key).is_some() || p.form == Form::OptionalToleranced,
                "{} is not in the shipped file",
                p.key
            );
        }
    }

    /// Every parameter of the table round-trips: parse reads the file's value into the
    /// field `get` reads back, `set` then `get` gives a new value back, and for an entry
    /// that can carry a tolerance, `rewrite` writes it to the file and parse reads it back.
    /// An entry that cannot is not settable, and a changed value in the file is read.
    #[test]
    fn every_parameter_round_trips_parse_set_get_write() {
        let src = every_entry_toleranced();
        let shipped = Instrument::parse(&src, "t.toml").unwrap();
        for p in PARAMETERS {
            let v0 = written(&src, p.key).unwrap();
            assert!(close(p.get(&shipped), v0), "{}: parse", p.key);
            // A new value inside every range (away from 0 and from the nominal).
            let v = if v0 == 0.0 { 0.25 } else { v0 * 1.01 };
            let mut i = shipped.clone();
            p.set(&mut i, v);
            assert!(close(p.get(&i), v), "{}: set, get", p.key);
            if p.form.can_be_toleranced() {
                let mut j = shipped.clone();
                j.set(p.key, v).unwrap();
                assert_eq!(j, i, "{}", p.key);
                assert!(close(j.get(p.key).unwrap(), v), "{}", p.key);
                let (lo, nom, hi) = shipped.tolerance(p.key).unwrap();
                assert!(lo <= nom && nom <= hi && close(nom, v0), "{}", p.key);
                let out = Instrument::rewrite(&src, "t.toml", &[(p.key, v, "new".into())]).unwrap();
                let back = Instrument::parse(&out, "t.toml").unwrap();
                assert!(close(p.get(&back), v), "{}: rewrite", p.key);
                assert_eq!(written(&out, p.key), Some(v), "{}", p.key);
                for q in PARAMETERS.iter().filter(|q| q.key != p.key) {
                    let (a, b) = (q.get(&back), q.get(&shipped));
                    assert_eq!(a.to_bits(), b.to_bits(), "{} moved {}", p.key, q.key);
                }
            } else {
                assert!(shipped.clone().set(p.key, v).is_err(), "{}", p.key);
                assert_eq!(shipped.get(p.key), None, "{}", p.key);
                assert_eq!(shipped.tolerance(p.key), None, "{}", p.key);
                let (section, name) = p.key.split_once('.').unwrap();
                let mut t: toml::Table = toml::from_str(&src).unwrap();
                t[section][name] = toml::Value::Float(v);
                let back = Instrument::parse(&toml::to_string(&t).unwrap(), "t.toml").unwrap();
                assert!(
                    close(p.get(&back), v),
                    "{}: parse of a changed value",
                    p.key
                );
            }
        }
        // The tolerance box holds exactly the toleranced entries, in the table's order.
        let tol: Vec<&str> = shipped.tolerances.iter().map(|t| t.key).collect();
        let table: Vec<&str> = PARAMETERS
            .iter()
            .filter(|p| p.form.can_be_toleranced())
            .map(|p| p.key)
            .collect();
        assert_eq!(tol, table);
    }

    /// Each entry's range is checked under its own key, with its own expectation.
    #[test]
    fn every_parameter_is_refused_out_of_range_under_its_key() {
        let src = every_entry_toleranced();
        for p in PARAMETERS {
            let (section, name) = p.key.split_once('.').unwrap();
            let mut t: toml::Table = toml::from_str(&src).unwrap();
            let bad = toml::Value::Float(-1e9);
            match t[section][name].as_table_mut() {
                Some(table) => {
                    table.insert("value".into(), bad);
                }
                None => t[section][name] = bad,
            }
            let e = Instrument::parse(&toml::to_string(&t).unwrap(), "t.toml").unwrap_err();
            assert_eq!(
                e.message,
                format!("{} = -1000000000: expected {}", p.key, p.expected),
                "{e}"
            );
        }
    }

    #[test]
    fn rewrite_changes_only_the_named_entries() {
        let src = KEARFOTT_2401_TOML;
        let out = Instrument::rewrite(
            src,
            "k.toml",
            &[
                ("pendulum.damping_dyn_cm_s", 114_361.25, "fitted".into()),
                ("torquer.time_constant_us", 38.5, "lag fitted".into()),
            ],
        )
        .unwrap();
        let i = Instrument::parse(&out, "k.toml").unwrap();
        assert_eq!(i.get("pendulum.damping_dyn_cm_s"), Some(114_361.25));
        assert!((i.get("torquer.time_constant_us").unwrap() - 38.5).abs() < 1e-12);
        // tol_pct keeps its percentage around the new value; min/max widens to hold it.
        let (lo, _, hi) = i.tolerance("pendulum.damping_dyn_cm_s").unwrap();
        assert!((lo - 0.6 * 114_361.25).abs() < 1e-6 && (hi - 1.4 * 114_361.25).abs() < 1e-6);
        assert_eq!(
            i.tolerance("torquer.time_constant_us"),
            Some((0.2, 38.5, 38.5))
        );
        // Everything else is the same text, line for line, plus the two notes.
        let removed: Vec<&str> = src
            .lines()
            .filter(|l| !out.lines().any(|o| o == *l))
            .collect();
        assert_eq!(removed.len(), 2, "{removed:?}");
        assert!(out.contains("# fitted\ndamping_dyn_cm_s = { value = 114361.25, tol_pct = 40.0 }"));
        assert_eq!(out.lines().count(), src.lines().count() + 2);
        // No change, no difference; a refused value is an error, not a bad file.
        assert_eq!(Instrument::rewrite(src, "k.toml", &[]).unwrap(), src);
        let e = Instrument::rewrite(
            src,
            "k.toml",
            &[("pendulum.inertia_oa_g_cm2", -1.0, String::new())],
        )
        .unwrap_err();
        assert!(e.message.contains("inertia"), "{e}");
        assert!(Instrument::rewrite(src, "k.toml", &[("no.such", 1.0, String::new())]).is_err());
    }

    /// The amplifier gain is a bare number (exact, not identified) or a toleranced table;
    /// the ADC offset is optional (0 without a tolerance) or a toleranced table; both are
    /// set, read and rewritten like the other parameters.
    #[test]
    fn amplifier_gain_and_adc_offset_take_a_tolerance_when_the_file_gives_one() {
        let shipped = Instrument::kearfott_2401();
        assert_eq!(shipped.tolerance("electronics.amplifier_gain"), None);
        assert_eq!(shipped.tolerance("electronics.adc_offset_mv"), None);
        assert_eq!(shipped.get("electronics.adc_offset_mv"), Some(0.0));
        let src = KEARFOTT_2401_TOML
            .replace(
                "amplifier_gain = 100.0",
                "amplifier_gain = { value = 100.0, tol_pct = 5.0 }\nadc_offset_mv = { value = 0.5, tol_abs = 2.0 }",
            );
        let mut i = Instrument::parse(&src, "t.toml").unwrap();
        let (lo, nom, hi) = i.tolerance("electronics.amplifier_gain").unwrap();
        assert!(
            (lo - 95.0).abs() < 1e-9 && (nom - 100.0).abs() < 1e-12 && (hi - 105.0).abs() < 1e-9
        );
        assert_eq!(
            i.tolerance("electronics.adc_offset_mv"),
            Some((-1.5, 0.5, 2.5))
        );
        assert!((i.adc_offset_v - 0.5e-3).abs() < 1e-15);
        i.set("electronics.amplifier_gain", 90.0).unwrap();
        assert!((i.lsb_per_rad() / shipped.lsb_per_rad() - 0.9).abs() < 1e-12);
        let out = Instrument::rewrite(
            &src,
            "t.toml",
            &[("electronics.amplifier_gain", 97.5, "fitted".into())],
        )
        .unwrap();
        let r = Instrument::parse(&out, "t.toml").unwrap();
        assert_eq!(r.get("electronics.amplifier_gain"), Some(97.5));
        // Errors name the line and what was expected.
        let e = Instrument::parse(
            &KEARFOTT_2401_TOML.replace("amplifier_gain = 100.0", "amplifier_gain = \"high\""),
            "m.toml",
        )
        .unwrap_err();
        assert_eq!(e.line, line_of("amplifier_gain"), "{e}");
        assert!(e.message.contains("expected a number"), "{e}");
        let e = Instrument::parse(
            &KEARFOTT_2401_TOML.replace(
                "amplifier_gain = 100.0",
                "amplifier_gain = 100.0\nadc_offset_mv = { value = 4000.0, tol_abs = 1.0 }",
            ),
            "m.toml",
        )
        .unwrap_err();
        assert!(
            e.message.contains("electronics.adc_offset_mv = 4000"),
            "{e}"
        );
        assert!(e.message.contains("within the ADC's full scale"), "{e}");
    }

    #[test]
    fn shipped_file_parses_with_the_table_values() {
        let i = Instrument::kearfott_2401();
        assert!((i.pendulosity_g_cm() - 1.122).abs() < 1e-3);
        assert!((i.actual_sf_cm_s2() - 21121.1).abs() < 1e-9);
        assert!((i.theta_lsb_rad() - 76.294e-9).abs() < 1e-12);
        assert!((i.full_current_ma - 21.328).abs() < 1e-3);
        assert_eq!(i.tolerances.len(), 12);
    }

    #[test]
    fn errors_name_line_column_and_expectation() {
        let bad = KEARFOTT_2401_TOML.replace(
            "inertia_oa_g_cm2 = { value = 14.0,",
            "inertia_oa_g_cm2 = { value = -14.0,",
        );
        let e = Instrument::parse(&bad, "x.toml").unwrap_err();
        assert_eq!(e.file, "x.toml");
        let line = KEARFOTT_2401_TOML
            .lines()
            .position(|l| l.starts_with("inertia_oa_g_cm2"))
            .unwrap()
            + 1;
        assert_eq!(e.line, line, "{e}");
        assert!(e.column > 20, "{e}");
        assert!(e.message.contains("expected an inertia > 0"), "{e}");

        let typo = KEARFOTT_2401_TOML.replace("bias_cm_s2 =", "bias_cm_s =");
        let e = Instrument::parse(&typo, "y.toml").unwrap_err();
        assert!(e.message.contains("bias_cm_s"), "{e}");
        assert!(e.line > 1, "{e}");

        let syntax = KEARFOTT_2401_TOML.replace("clock_hz = 64000.0", "clock_hz = 64000.0.0");
        assert!(Instrument::parse(&syntax, "z.toml").is_err());
    }

    /// The error for the shipped file with `from` replaced by `to` (exactly once).
    fn mutated(from: &str, to: &str) -> InstrumentError {
        assert_eq!(KEARFOTT_2401_TOML.matches(from).count(), 1, "{from}");
        Instrument::parse(&KEARFOTT_2401_TOML.replace(from, to), "m.toml").unwrap_err()
    }

    /// The 1-based line of the shipped file that starts with `key`.
    fn line_of(key: &str) -> usize {
        KEARFOTT_2401_TOML
            .lines()
            .position(|l| l.starts_with(key))
            .unwrap()
            + 1
    }

    /// No Rust or serde vocabulary in a user message.
    fn assert_user_terms(e: &InstrumentError) {
        for word in [
            "f64",
            "i64",
            "i128",
            "struct",
            "Param",
            "PendulumT",
            "map",
            "sequence",
            "invalid type",
        ] {
            assert!(!e.message.contains(word), "`{word}` in: {e}");
        }
    }

    #[test]
    fn a_missing_file_is_reported_without_a_position() {
        let e = Instrument::load(Path::new("nonexist.toml")).unwrap_err();
        assert_eq!(e.position(), None);
        assert_eq!(e.file, "nonexist.toml");
        let m = e.to_string();
        assert!(m.starts_with("nonexist.toml: cannot read: "), "{m}");
        assert!(!m.contains("os error") && !m.contains(":0"), "{m}");
        #[cfg(unix)]
        assert_eq!(m, "nonexist.toml: cannot read: No such file or directory");
    }

    #[test]
    fn a_number_of_the_wrong_type_is_named_in_toml_terms() {
        let line = line_of("clock_hz");
        for (value, found) in [
            ("\"fast\"", "the string \"fast\""),
            ("true", "`true`"),
            ("[64000]", "an array"),
            ("{ value = 64000 }", "a table"),
            ("1979-05-27", "the date/time 1979-05-27"),
        ] {
            let e = mutated("clock_hz = 64000.0", &format!("clock_hz = {value}"));
            assert_eq!(
                e.message,
                format!("expected a number, found {found}"),
                "{e}"
            );
            assert_eq!(e.position(), Some((line, 12)), "{e}");
            assert_user_terms(&e);
        }
        let e = mutated(
            "time_constant_us = { value = 2.0,",
            "time_constant_us = { value = \"fast\",",
        );
        assert_eq!(
            e.to_string(),
            format!(
                "m.toml:{}:30: expected a number, found the string \"fast\"",
                line_of("time_constant_us")
            )
        );
        let e = mutated("tol_abs = 10.0", "tol_abs = \"10 %\"");
        assert_eq!(e.message, "expected a number, found the string \"10 %\"");
        // An integer is a number.
        let i = Instrument::parse(
            &KEARFOTT_2401_TOML.replace("clock_hz = 64000.0", "clock_hz = 64000"),
            "m.toml",
        )
        .unwrap();
        assert_eq!(i.clock_hz.to_bits(), 64000.0_f64.to_bits());
    }

    #[test]
    fn a_toleranced_entry_of_the_wrong_type_names_the_table_forms() {
        let e = mutated(
            "inertia_oa_g_cm2 = { value = 14.0, tol_pct = 20.0 }",
            "inertia_oa_g_cm2 = 14.0",
        );
        assert_eq!(
            e.to_string(),
            format!(
                "m.toml:{}:20: expected a table {{ value = ..., tol_pct = ... }}, \
                 {{ value = ..., tol_abs = ... }} or {{ value = ..., min = ..., max = ... }}, \
                 found the number 14.0",
                line_of("inertia_oa_g_cm2")
            )
        );
        assert_user_terms(&e);
        // A section of the wrong type.
        for (line, message) in [
            ("stops = 3", "expected a [stops] table, found the number 3"),
            (
                "pickoff = \"x\"",
                "expected a [pickoff] table, found the string \"x\"",
            ),
            (
                "pendulum = []",
                "expected a [pendulum] table, found an array of 0 values",
            ),
            (
                "electronics = [1.0]",
                "expected an [electronics] table, found an array of 1 value",
            ),
        ] {
            let e = Instrument::parse(&format!("# c\n{line}\n"), "s.toml").unwrap_err();
            assert_eq!((e.message.as_str(), e.line), (message, 2), "{e}");
            assert_user_terms(&e);
        }
    }

    #[test]
    fn serde_messages_are_reworded_in_the_file_terms() {
        assert_eq!(
            user_message("invalid type: sequence, expected a [stops] table"),
            "expected a [stops] table, found an array"
        );
        assert_eq!(
            user_message("invalid type: map, expected x, y"),
            "expected x, y, found a table"
        );
        assert_eq!(
            user_message("invalid type: integer `99` as i128, expected a number"),
            "expected a number, found the number 99"
        );
        assert_eq!(
            user_message("invalid type: boolean `false`, expected a table"),
            "expected a table, found `false`"
        );
        assert_eq!(
            user_message(" missing field `value`\n"),
            "missing field `value`"
        );
    }

    #[test]
    fn byte_order_mark_and_non_utf8_text() {
        let with_bom = format!("\u{feff}{KEARFOTT_2401_TOML}");
        assert_eq!(
            Instrument::parse(&with_bom, "b.toml").unwrap(),
            Instrument::kearfott_2401()
        );
        // Columns on the first line do not count the byte-order mark.
        let e = Instrument::parse(&format!("\u{feff}x = 1\n{KEARFOTT_2401_TOML}"), "b.toml")
            .unwrap_err();
        assert_eq!(e.position(), Some((1, 1)), "{e}");
        let mut bytes = KEARFOTT_2401_TOML.as_bytes().to_vec();
        let at = KEARFOTT_2401_TOML.find("ml = 1.12").unwrap();
        bytes[at] = 0xB5;
        let e = Instrument::parse_bytes(&bytes, "l.toml").unwrap_err();
        let (line, column) = line_col(KEARFOTT_2401_TOML, at);
        assert_eq!(
            e.to_string(),
            format!(
                "l.toml:{line}:{column}: the file is not UTF-8 text: byte 0xB5 at byte offset \
                 {at} is not valid UTF-8; expected UTF-8 text"
            )
        );
    }

    #[test]
    fn an_infinite_tolerance_band_is_refused() {
        let e = mutated("max = 20.0 }", "max = inf }");
        assert_eq!(
            e.message,
            "torquer.time_constant_us: tolerance band [0.2, inf] leaves the valid range: \
             expected a time constant > 0 µs"
        );
    }

    #[test]
    fn positions_are_found_inside_multi_byte_characters() {
        assert_eq!(line_col("aµb\nc", 2), (1, 2));
        assert_eq!(line_col("aµb\nc", 5), (2, 1));
        assert_eq!(line_col("aµb", 99), (1, 4));
    }
}
