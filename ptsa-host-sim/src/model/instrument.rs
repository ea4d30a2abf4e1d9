//! The instrument file (`data/kearfott-2401.toml`): Table 2.1 of R-890 with tolerances, and
//! the PTSA electronics, validated on load; or, for an accelerometer without a PTSA loop
//! (`data/navigation.toml`, `data/mems.toml`), only what a calibration needs: its name and
//! class, its reading's unit and nominal scale, its nominal bias, local gravity, the nominal
//! terms of its IEEE 1293 model equation (`[model_equation]`, which a file with a loop may
//! give too) and the plausibility bounds.

use std::fmt;
use std::path::Path;

use serde::Deserialize;
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use toml::Spanned;

use ptsa_core::adc::{AdcFormat, Alignment, Coding};

use crate::model::effects::{CandidateId, Effects};

/// The shipped instrument file, compiled in.
pub const KEARFOTT_2401_TOML: &str = include_str!("../../../data/kearfott-2401.toml");
/// The shipped file of a navigation-grade servo (force-rebalance) accelerometer: no PTSA
/// loop, the bounds of that class.
pub const NAVIGATION_TOML: &str = include_str!("../../../data/navigation.toml");
/// The shipped file of one axis of a consumer MEMS accelerometer: no PTSA loop, the bounds
/// of that class.
pub const MEMS_TOML: &str = include_str!("../../../data/mems.toml");

/// The shipped instrument files, by the name `--instrument` and `ptsa instrument new
/// --class` take: `(name, path in the repository, text)`. The first is the default.
pub const SHIPPED: &[(&str, &str, &str)] = &[
    (
        "kearfott-2401",
        "data/kearfott-2401.toml",
        KEARFOTT_2401_TOML,
    ),
    ("navigation", "data/navigation.toml", NAVIGATION_TOML),
    ("mems", "data/mems.toml", MEMS_TOML),
];

/// The shipped instrument file named `name` ([`SHIPPED`]): its path in the repository and
/// its text.
#[must_use]
pub fn shipped(name: &str) -> Option<(&'static str, &'static str)> {
    SHIPPED
        .iter()
        .find(|(n, _, _)| *n == name)
        .map(|&(_, path, text)| (path, text))
}

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

/// `[board]`: the electronics between the demodulated pickoff and the tick, as a board
/// builds them (optional; without it the loop reads the design's signed 16-bit converter).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [board] table")]
struct BoardT {
    name: Option<Spanned<String>>,
    adc_bits: Spanned<Num>,
    adc_reference_v: Spanned<Num>,
    adc_coding: Spanned<String>,
    adc_alignment: Spanned<String>,
    front_end_gain: Spanned<Num>,
    front_end_offset_v: Spanned<Num>,
    torquer_current_ma: Option<Spanned<Num>>,
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
    expecting = "tables [pendulum], [pickoff], [torquer], [electronics] and [stops] (and optionally [board], [instrument], [model_equation] and [plausibility])"
)]
struct FileT {
    pendulum: PendulumT,
    pickoff: PickoffT,
    torquer: TorquerT,
    electronics: ElectronicsT,
    stops: StopsT,
    board: Option<BoardT>,
    instrument: Option<IdentT>,
    model_equation: Option<ModelEquationT>,
    plausibility: Option<PlausibilityT>,
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
struct LooplessT {
    instrument: IdentT,
    model_equation: Option<ModelEquationT>,
    plausibility: Option<PlausibilityT>,
}

/// `[instrument]`: what the instrument is and how its reading is scaled. Optional in a file
/// with a loop (whose bias and local gravity are in `[electronics]`), required without one.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "an [instrument] table")]
struct IdentT {
    name: Option<Spanned<String>>,
    class: Option<Spanned<String>>,
    reading_unit: Option<Spanned<String>>,
    scale_factor_per_g: Option<Spanned<Num>>,
    bias_cm_s2: Option<Spanned<Num>>,
    local_gravity_cm_s2: Option<Spanned<Num>>,
}

/// `[model_equation]`: key = number, each key one of [`MODEL_EQUATION`].
type ModelEquationT = std::collections::BTreeMap<Spanned<String>, Spanned<Num>>;

/// The unit of a raw reading (a case-frame `reading_unit`, an instrument file's
/// `instrument.reading_unit`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReadingUnit {
    /// Volts (an analogue output).
    Volt,
    /// Milliamperes (a servo accelerometer's current output).
    MilliAmp,
    /// Least significant bits of a digital output.
    Lsb,
    /// g, local gravity (the instrument file's `local_gravity_cm_s2`).
    G,
    /// m/s².
    MPerS2,
    /// cm/s².
    CmPerS2,
}

impl ReadingUnit {
    /// Every unit, in the order messages list them.
    pub const ALL: &[ReadingUnit] = &[
        ReadingUnit::Volt,
        ReadingUnit::MilliAmp,
        ReadingUnit::Lsb,
        ReadingUnit::G,
        ReadingUnit::MPerS2,
        ReadingUnit::CmPerS2,
    ];

    /// Its name as written in files: `V`, `mA`, `LSB`, `g`, `m/s²`, `cm/s²`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            ReadingUnit::Volt => "V",
            ReadingUnit::MilliAmp => "mA",
            ReadingUnit::Lsb => "LSB",
            ReadingUnit::G => "g",
            ReadingUnit::MPerS2 => "m/s²",
            ReadingUnit::CmPerS2 => "cm/s²",
        }
    }

    /// The unit written `s` (its name, or `m/s2`, `m/s^2`, `cm/s2`, `cm/s^2`).
    #[must_use]
    pub fn parse(s: &str) -> Option<Self> {
        let s = s.trim();
        let s = s.replace("s^2", "s²").replace("s2", "s²");
        ReadingUnit::ALL.iter().copied().find(|u| u.name() == s)
    }

    /// The names of every unit, for messages: `V, mA, LSB, g, m/s², cm/s²`.
    #[must_use]
    pub fn names() -> String {
        ReadingUnit::ALL
            .iter()
            .map(|u| u.name())
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// A unit of acceleration, converted by its definition (g with the file's local
    /// gravity); the others (V, mA, LSB) only through a nominal scale factor.
    #[must_use]
    pub fn is_physical(self) -> bool {
        matches!(
            self,
            ReadingUnit::G | ReadingUnit::MPerS2 | ReadingUnit::CmPerS2
        )
    }
}

/// The nominal scale of an instrument's raw reading: `per_g` reading units per g of input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReadingScale {
    /// The reading's unit (V, mA or LSB).
    pub unit: ReadingUnit,
    /// Nominal scale factor, reading units per g (local gravity).
    pub per_g: f64,
}

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

/// The board's front end (`[board]` of the instrument file): the converter that delivers the
/// tick's sample and the analogue stage in front of it. The amplifier's output
/// (`electronics.amplifier_gain` times the demodulated pickoff, plus
/// `electronics.adc_offset_mv`) goes through the front end, `v_pin = front_end_gain · v +
/// front_end_offset_v`, into the converter ([`ptsa_core::adc`]). The converter's range then
/// spans ±`adc_reference_v / 2 / front_end_gain` at the amplifier's output: the file's
/// `electronics.adc_full_scale_v` must say the same (it is the full scale the compensator is
/// designed for).
#[derive(Debug, Clone, PartialEq)]
pub struct Board {
    /// `board.name`, if given.
    pub name: Option<String>,
    /// Resolution, coding and alignment of the converter.
    pub adc: AdcFormat,
    /// Width of the converter's input range, V (`0..V_REF` offset binary, `±V_REF/2` two's
    /// complement).
    pub reference_v: f64,
    /// Gain from the amplifier's output to the converter's pin, V/V.
    pub front_end_gain: f64,
    /// Voltage at the converter's pin for 0 V at the amplifier's output, V (the level
    /// shift: `V_REF/2` centres a unipolar converter).
    pub front_end_offset_v: f64,
    /// The torquer current the board's current source is set to, mA, when the file gives it
    /// (it then sets [`Instrument::full_current_ma`]).
    pub torquer_current_ma: Option<f64>,
}

impl Board {
    /// The constant of the conversion that places the input in the converter's range and
    /// rounds, in units of the `i16` sample: half a step, plus 2^15 for a bipolar range.
    #[must_use]
    pub fn round_term(&self) -> f64 {
        let half = f64::from(self.adc.step()) / 2.0;
        match self.adc.coding() {
            Coding::OffsetBinary => half,
            Coding::TwosComplement => 32768.0 + half,
        }
    }

    /// The converter's full scale at the amplifier's output, ±V:
    /// `adc_reference_v / 2 / front_end_gain`.
    #[must_use]
    pub fn full_scale_v(&self) -> f64 {
        self.reference_v / 2.0 / self.front_end_gain
    }
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
    /// Whether the command line set the local gravity (`--local-gravity`), not the file.
    pub gravity_from_command_line: bool,
    /// Stop contact stiffness, dyn·cm/rad.
    pub stop_stiffness_dyn_cm_rad: f64,
    /// Stop contact damping, dyn·cm·s.
    pub stop_damping_dyn_cm_s: f64,
    /// Tolerance box of every toleranced parameter.
    pub tolerances: Vec<Tolerance>,
    /// Plausibility bounds of the discovery candidates.
    pub plausibility: Plausibility,
    /// The board's front end (`[board]`), if the file describes one: the host loop then
    /// quantizes the pickoff as that converter does.
    pub board: Option<Board>,
    /// Whether the file describes a PTSA loop (Table 2.1's sections): without one, every
    /// loop field above is 0, nothing can run the closed loop, and no loop parameter is a
    /// discovery candidate.
    pub has_loop: bool,
    /// `instrument.name`, if the file gives one.
    pub name: Option<String>,
    /// `instrument.class`, if the file gives one.
    pub class: Option<String>,
    /// The nominal scale of the raw reading (`instrument.reading_unit`,
    /// `instrument.scale_factor_per_g`), if the file gives one.
    pub reading_scale: Option<ReadingScale>,
    /// The nominal model-equation terms of `[model_equation]` as candidate coefficients
    /// (0 for every other candidate): the baseline model includes them
    /// ([`Instrument::with_nominal_terms`]).
    pub nominal: Effects,
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

    /// `[board]`: every entry in range, and the converter's full scale at the amplifier's
    /// output the same as `electronics.adc_full_scale_v`.
    fn board(&self, b: &BoardT, e: &ElectronicsT) -> Result<Board, InstrumentError> {
        let bits = self.scalar(
            "board.adc_bits",
            &b.adc_bits,
            |x| x.fract() == 0.0 && (1.0..=16.0).contains(&x),
            "a whole number of bits from 1 to 16",
        )?;
        let word = |key: &str, v: &Spanned<String>, options: &[&str]| {
            let t = v.get_ref().trim();
            options.iter().position(|o| *o == t).ok_or_else(|| {
                self.err(
                    v.span().start,
                    format!(
                        "board.{key} = {:?}: expected one of {}",
                        v.get_ref(),
                        options
                            .iter()
                            .map(|o| format!("\"{o}\""))
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                )
            })
        };
        let coding = if word(
            "adc_coding",
            &b.adc_coding,
            &["offset_binary", "twos_complement"],
        )? == 0
        {
            Coding::OffsetBinary
        } else {
            Coding::TwosComplement
        };
        let alignment = if word("adc_alignment", &b.adc_alignment, &["left", "right"])? == 0 {
            Alignment::Left
        } else {
            Alignment::Right
        };
        let reference_v = self.scalar(
            "board.adc_reference_v",
            &b.adc_reference_v,
            positive,
            "a reference > 0 V",
        )?;
        let front_end_gain = self.scalar(
            "board.front_end_gain",
            &b.front_end_gain,
            positive,
            "a gain > 0 V/V",
        )?;
        let front_end_offset_v = self.scalar(
            "board.front_end_offset_v",
            &b.front_end_offset_v,
            |x| x.abs() < reference_v,
            "an offset within the converter's reference, |offset| < board.adc_reference_v",
        )?;
        let torquer_current_ma = b
            .torquer_current_ma
            .as_ref()
            .map(|t| self.scalar("board.torquer_current_ma", t, positive, "a current > 0 mA"))
            .transpose()?;
        let name = match &b.name {
            Some(n) if n.get_ref().trim().is_empty() => {
                return Err(self.err(
                    n.span().start,
                    "board.name: expected a non-empty string".to_string(),
                ));
            }
            n => n.as_ref().map(|n| n.get_ref().trim().to_string()),
        };
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let adc = AdcFormat::new(bits as u8, coding, alignment)
            .ok_or_else(|| self.err(b.adc_bits.span().start, "board.adc_bits".into()))?;
        let board = Board {
            name,
            adc,
            reference_v,
            front_end_gain,
            front_end_offset_v,
            torquer_current_ma,
        };
        let fs = board.full_scale_v();
        let file_fs = e.adc_full_scale_v.get_ref().0;
        if (fs - file_fs).abs() > 1e-6 * fs {
            return Err(self.err(
                e.adc_full_scale_v.span().start,
                format!(
                    "electronics.adc_full_scale_v = {file_fs} V disagrees with [board]: its converter spans ±{fs:.6} V at the amplifier's output (board.adc_reference_v / 2 / board.front_end_gain = {reference_v} / 2 / {front_end_gain}); expected them equal (the compensator is designed for this full scale): set adc_full_scale_v = {fs:.6}, or board.front_end_gain = {:.6} for this full scale",
                    reference_v / 2.0 / file_fs
                ),
            ));
        }
        Ok(board)
    }

    /// `[instrument]`: the name, class and reading scale; without a loop also the bias and
    /// local gravity (required then, refused in a file with a loop, which has them in
    /// `[electronics]`).
    fn ident(&self, t: &IdentT, instr: &mut Instrument) -> Result<(), InstrumentError> {
        let text =
            |key: &str, v: &Option<Spanned<String>>| -> Result<Option<String>, InstrumentError> {
                match v {
                    Some(s) if s.get_ref().trim().is_empty() => Err(self.err(
                        s.span().start,
                        format!("instrument.{key}: expected a non-empty string"),
                    )),
                    Some(s) => Ok(Some(s.get_ref().trim().to_string())),
                    None => Ok(None),
                }
            };
        instr.name = text("name", &t.name)?;
        instr.class = text("class", &t.class)?;
        let table_at = t
            .name
            .as_ref()
            .or(t.class.as_ref())
            .map_or(0, |s| s.span().start);
        if !instr.has_loop {
            for (key, v) in [("name", &instr.name), ("class", &instr.class)] {
                if v.is_none() {
                    return Err(self.err(
                        table_at,
                        format!("instrument.{key}: missing; a file without a PTSA loop names its instrument and its class (e.g. class = \"mems\")"),
                    ));
                }
            }
        }
        instr.reading_scale = self.reading_scale(t)?;
        for (key, v) in [
            ("bias_cm_s2", &t.bias_cm_s2),
            ("local_gravity_cm_s2", &t.local_gravity_cm_s2),
        ] {
            match v {
                Some(s) if instr.has_loop => {
                    return Err(self.err(
                        s.span().start,
                        format!("instrument.{key}: a file with a PTSA loop gives it as electronics.{key}; expected it there only"),
                    ));
                }
                None if !instr.has_loop => {
                    return Err(self.err(
                        table_at,
                        format!("instrument.{key}: missing; a file without a PTSA loop gives its nominal bias (cm/s²) and local gravity (cm/s²) in [instrument]"),
                    ));
                }
                _ => {}
            }
        }
        if let (Some(b), Some(g)) = (&t.bias_cm_s2, &t.local_gravity_cm_s2) {
            instr.g_cm_s2 = self.scalar(
                "instrument.local_gravity_cm_s2",
                g,
                |x| x > 0.0,
                "gravity > 0 cm/s²",
            )?;
            let limit = 10.0 * instr.g_cm_s2;
            instr.bias_cm_s2 = self.scalar(
                "instrument.bias_cm_s2",
                b,
                |x| x.abs() < limit,
                "|bias| below 10 g (10 × local gravity)",
            )?;
        }
        Ok(())
    }

    /// `instrument.reading_unit` and `instrument.scale_factor_per_g`: both or neither.
    fn reading_scale(&self, t: &IdentT) -> Result<Option<ReadingScale>, InstrumentError> {
        match (&t.reading_unit, &t.scale_factor_per_g) {
            (Some(u), Some(sf)) => {
                let unit = ReadingUnit::parse(u.get_ref()).ok_or_else(|| {
                    self.err(
                        u.span().start,
                        format!(
                            "instrument.reading_unit = {:?}: expected one of V, mA, LSB",
                            u.get_ref()
                        ),
                    )
                })?;
                if unit.is_physical() {
                    return Err(self.err(
                        u.span().start,
                        format!(
                            "instrument.reading_unit = {:?}: a reading in {} is converted by its definition; expected the unit of a scale factor: V, mA or LSB",
                            u.get_ref(),
                            unit.name()
                        ),
                    ));
                }
                let per_g = self.scalar(
                    "instrument.scale_factor_per_g",
                    sf,
                    |x| x > 0.0,
                    &format!("a nominal scale factor > 0 {} per g", unit.name()),
                )?;
                Ok(Some(ReadingScale { unit, per_g }))
            }
            (Some(s), None) => Err(self.err(
                    s.span().start,
                    "instrument.reading_unit without instrument.scale_factor_per_g: expected both (the reading's unit and its nominal scale factor, units per g)".to_string(),
            )),
            (None, Some(s)) => Err(self.err(
                    s.span().start,
                    "instrument.scale_factor_per_g without instrument.reading_unit: expected both (the reading's unit and its nominal scale factor, units per g)".to_string(),
            )),
            (None, None) => Ok(None),
        }
    }

    /// `[model_equation]` (optional, every key optional): the nominal terms, into
    /// `instr.nominal` as candidate coefficients.
    fn model_equation(
        &self,
        t: Option<&ModelEquationT>,
        instr: &mut Instrument,
    ) -> Result<(), InstrumentError> {
        let Some(t) = t else {
            return Ok(());
        };
        for (k, v) in t {
            let Some(m) = MODEL_EQUATION.iter().find(|m| m.key == k.get_ref()) else {
                let keys: Vec<&str> = MODEL_EQUATION.iter().map(|m| m.key).collect();
                return Err(self.err(
                    k.span().start,
                    format!(
                        "model_equation.{}: not a term of the model equation; expected one of {}",
                        k.get_ref(),
                        keys.join(", ")
                    ),
                ));
            };
            let key = format!("model_equation.{}", m.key);
            let x = if m.id == CandidateId::ScaleFactor {
                self.scalar(&key, v, |x| x.abs() < 1e6, "|K_1| < 1e6 ppm")?
            } else if m.unit == "rad" {
                self.scalar(&key, v, |x| x.abs() < 1.0, "|misalignment| < 1 rad")?
            } else {
                self.scalar(&key, v, |_| true, &format!("a number, {}", m.unit))?
            };
            instr.nominal.set(m.id, m.sign * x);
        }
        Ok(())
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
        let toml_err = |e: toml::de::Error| {
            let at = e.span().map_or(0, |s| s.start);
            cx.err(at, user_message(e.message()))
        };
        let table: toml::Table = toml::from_str(src).map_err(toml_err)?;
        let mut instr = Self::zeroed();
        let missing: Vec<String> = LOOP_SECTIONS
            .iter()
            .filter(|s| !table.contains_key(**s))
            .map(|s| format!("[{s}]"))
            .collect();
        if missing.len() < LOOP_SECTIONS.len() {
            let f: FileT = toml::from_str(src).map_err(|e| {
                // A section of the wrong type or a bad key is serde's to place; a missing
                // section is named with the others.
                if missing.is_empty() || !e.message().starts_with("missing field") {
                    toml_err(e)
                } else {
                    cx.err(
                        0,
                        format!(
                            "a file with a PTSA loop has [pendulum], [pickoff], [torquer], [electronics] and [stops]; {} missing (a file without a loop has none of them)",
                            missing.join(", ")
                        ),
                    )
                }
            })?;
            let mut tol = Vec::new();
            for p in PARAMETERS {
                let v = cx.entry(p, &f, &mut tol)?;
                p.set(&mut instr, v);
            }
            instr.full_current_ma = instr.sf_cm_s2 / instr.g_cm_s2 * instr.current_sf_ma_per_g;
            if let Some(b) = &f.board {
                let board = cx.board(b, &f.electronics)?;
                if let Some(ma) = board.torquer_current_ma {
                    instr.full_current_ma = ma;
                }
                instr.adc_full_scale_v = board.full_scale_v();
                instr.board = Some(board);
            }
            instr.tolerances = tol;
            instr.plausibility =
                cx.plausibility(f.plausibility.as_ref(), instr.inertia_dyn_cm_s2)?;
            if let Some(id) = &f.instrument {
                cx.ident(id, &mut instr)?;
            }
            cx.model_equation(f.model_equation.as_ref(), &mut instr)?;
        } else {
            if !table.contains_key("instrument") {
                return Err(cx.err(
                    0,
                    "expected the tables [pendulum], [pickoff], [torquer], [electronics] and [stops] of a PTSA loop, or, for an accelerometer without one, an [instrument] table (name, class, bias_cm_s2, local_gravity_cm_s2)".to_string(),
                ));
            }
            let f: LooplessT = toml::from_str(src).map_err(toml_err)?;
            instr.has_loop = false;
            cx.ident(&f.instrument, &mut instr)?;
            // No pendulum: the anisoinertia's bound (I_PA − I_IA over m·l) has no default.
            instr.plausibility = cx.plausibility(f.plausibility.as_ref(), f64::INFINITY)?;
            cx.model_equation(f.model_equation.as_ref(), &mut instr)?;
        }
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
            gravity_from_command_line: false,
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
            board: None,
            has_loop: true,
            name: None,
            class: None,
            reading_scale: None,
            nominal: Effects::NONE,
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

    /// The text of an instrument file with its local gravity (`electronics.` or
    /// `instrument.local_gravity_cm_s2`) set to `g_cm_s2`, a comment `note` above it; the
    /// rest of the text as it was. Every value of the file that is per g is then per g of
    /// this gravity, as if the file had said it.
    ///
    /// # Errors
    /// The file is not a valid instrument file, `g_cm_s2` is not a gravity it accepts, or
    /// it has no local gravity to set (a loop-less file that gives none).
    pub fn rewrite_gravity(
        src: &str,
        file: &str,
        g_cm_s2: f64,
        note: &str,
    ) -> Result<String, InstrumentError> {
        let src = src.strip_prefix('\u{feff}').unwrap_or(src);
        let instr = Self::parse(src, file)?;
        let cx = Ctx { file, src };
        let span = if instr.has_loop {
            let f: FileT = toml::from_str(src).map_err(|e| cx.err(0, user_message(e.message())))?;
            f.electronics.local_gravity_cm_s2.span()
        } else {
            let f: LooplessT =
                toml::from_str(src).map_err(|e| cx.err(0, user_message(e.message())))?;
            f.instrument
                .local_gravity_cm_s2
                .map(|g| g.span())
                .ok_or_else(|| cx.err(0, "instrument.local_gravity_cm_s2: missing; expected the local gravity to replace".to_string()))?
        };
        let line_start = src[..span.start].rfind('\n').map_or(0, |i| i + 1);
        let mut out = src.to_string();
        out.replace_range(span, &format!("{g_cm_s2:?}"));
        out.insert_str(line_start, &format!("# {}\n", note.replace('\n', " ")));
        let back = Self::parse(&out, file)?;
        if (back.g_cm_s2 - g_cm_s2).abs() > 1e-12 * g_cm_s2.abs() {
            return Err(cx.err(
                0,
                format!("local_gravity_cm_s2: the rewritten file does not give {g_cm_s2} back"),
            ));
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
        if !self.has_loop {
            return 0.0;
        }
        let theta0 = -self.quadrature_v * self.phase_error_rad.tan() / self.pickoff_v_per_rad;
        let p = self.pendulosity_g_cm();
        -(self.spring_dyn_cm_rad + p * a_pa_cm_s2) * theta0 / p
    }

    /// The nominal value of candidate `id`'s term in this instrument's model equation, in
    /// the candidate's unit and sign (so that the instrument's own coefficient is this
    /// nominal value plus the change `ptsa discover` reports):
    ///
    /// * `bias`: the file's bias `A_b` (`electronics.bias_cm_s2`, or `instrument.bias_cm_s2`
    ///   without a loop), cm/s²;
    /// * `scale_factor`: `model_equation.k1_ppm`, ppm from the nominal scale factor (0 when
    ///   absent; the nominal scale factor itself is `electronics.scale_factor_cm_s2` for the
    ///   loop's pulses, [`Instrument::reading_scale`] for a raw reading);
    /// * `misalignment.delta_p_rad` (the coefficient of `a_PA`): `model_equation.delta_o_rad`;
    ///   `misalignment.delta_o_rad` (the coefficient of `a_OA`): minus
    ///   `model_equation.delta_p_rad` (the IEEE equation's `− δ_p·a_o`), rad;
    /// * `nonlinearity`, `cubic`, `vibropendulosity`, `anisoelasticity`, `cross_axis_*`:
    ///   `k2_s2_cm`, `k3_s4_cm2`, `k_ip_s2_cm`, `k_io_s2_cm`, `k_pp_s2_cm`, `k_oo_s2_cm`,
    ///   `k_po_s2_cm`;
    /// * every other candidate (dynamic terms, loop parameters): 0 (a loop parameter's
    ///   nominal is its file value, [`Instrument::get`]).
    #[must_use]
    pub fn nominal_model_term(&self, id: CandidateId) -> f64 {
        if id == CandidateId::Bias {
            self.bias_cm_s2
        } else {
            self.nominal.get(id)
        }
    }

    /// `effects` plus the nominal model-equation terms of `[model_equation]`: what the
    /// simulators put into a run (the baseline, `Effects::NONE`, becomes the nominal
    /// terms).
    #[must_use]
    pub fn with_nominal_terms(&self, effects: &Effects) -> Effects {
        let mut e = *effects;
        for (id, c) in self.nominal.nonzero() {
            e.add(id, c);
        }
        e
    }

    /// The file's name for the instrument: `instrument.name`, or for a file with a loop
    /// and no name, the PTSA loop's.
    #[must_use]
    pub fn display_name(&self) -> &str {
        self.name
            .as_deref()
            .unwrap_or(if self.has_loop { "PTSA loop" } else { "" })
    }

    /// A raw reading `value` in `unit`, in cm/s²: a unit of acceleration by its definition
    /// (g with the file's local gravity), V, mA or LSB through the file's nominal scale
    /// factor when the file gives one in that unit.
    ///
    /// # Errors
    /// A reading in V, mA or LSB when the file gives no scale in that unit (the message
    /// names the keys to add).
    pub fn reading_to_cm_s2(&self, value: f64, unit: ReadingUnit) -> Result<f64, String> {
        match unit {
            ReadingUnit::CmPerS2 => Ok(value),
            ReadingUnit::MPerS2 => Ok(value * 100.0),
            ReadingUnit::G => Ok(value * self.g_cm_s2),
            _ => match self.reading_scale {
                Some(sc) if sc.unit == unit => Ok(value / sc.per_g * self.g_cm_s2),
                Some(sc) => Err(format!(
                    "a reading in {} needs a nominal scale factor in {} per g; the instrument file gives one in {} per g (instrument.reading_unit = \"{}\")",
                    unit.name(),
                    unit.name(),
                    sc.unit.name(),
                    sc.unit.name()
                )),
                None => Err(format!(
                    "a reading in {} needs the instrument file's nominal scale factor: expected instrument.reading_unit = \"{}\" and instrument.scale_factor_per_g (in {} per g) in its [instrument] table",
                    unit.name(),
                    unit.name(),
                    unit.name()
                )),
            },
        }
    }

    /// The text of instrument file `src` with new nominal model-equation terms, everything
    /// else kept: each `(id, value, note)` sets candidate `id`'s nominal
    /// ([`Instrument::nominal_model_term`], in the candidate's unit and sign) to `value`:
    /// the bias into its key (`electronics.bias_cm_s2`, or `instrument.bias_cm_s2` without
    /// a loop), the others into `[model_equation]` under the file's key and IEEE sign
    /// (the section is added at the end of the file when absent, a key after its header
    /// when absent), with `# note` on the line above. The result is parsed again and must
    /// give each value back.
    ///
    /// # Errors
    /// `src` is not a valid instrument file, `id` is not a term of the model equation, or
    /// the new text does not give the values back.
    pub fn rewrite_model_equation(
        src: &str,
        file: &str,
        changes: &[(CandidateId, f64, String)],
    ) -> Result<String, InstrumentError> {
        let src = src.strip_prefix('\u{feff}').unwrap_or(src);
        let before = Self::parse(src, file)?;
        let cx = Ctx { file, src };
        let fail = |message: String| InstrumentError {
            file: file.to_string(),
            line: 0,
            column: 0,
            message,
        };
        // The spans of the bias and of the section's keys.
        let (bias_span, section): (std::ops::Range<usize>, Option<ModelEquationT>) = if before
            .has_loop
        {
            let f: FileT = toml::from_str(src).map_err(|e| cx.err(0, user_message(e.message())))?;
            (f.electronics.bias_cm_s2.span(), f.model_equation)
        } else {
            let f: LooplessT =
                toml::from_str(src).map_err(|e| cx.err(0, user_message(e.message())))?;
            let b = f
                .instrument
                .bias_cm_s2
                .as_ref()
                .map(Spanned::span)
                .ok_or_else(|| fail("instrument.bias_cm_s2: missing".to_string()))?;
            (b, f.model_equation)
        };
        let line_start = |at: usize| src[..at].rfind('\n').map_or(0, |i| i + 1);
        let mut edits: Vec<(std::ops::Range<usize>, String)> = Vec::new();
        let mut appended = String::new();
        // Where a key absent from an existing section goes: after its header line.
        let header_end = src
            .match_indices("[model_equation]")
            .find(|&(i, _)| src[line_start(i)..i].trim().is_empty())
            .map(|(i, _)| src[i..].find('\n').map_or(src.len(), |n| i + n + 1));
        for (id, v, note) in changes {
            let note = note.replace('\n', " ");
            if *id == CandidateId::Bias {
                let ls = line_start(bias_span.start);
                edits.push((ls..ls, format!("# {note}\n")));
                edits.push((bias_span.clone(), format!("{v:?}")));
                continue;
            }
            let m = MODEL_EQUATION
                .iter()
                .find(|m| m.id == *id)
                .ok_or_else(|| fail(format!("{id}: not a term of the model equation")))?;
            let x = m.sign * v + 0.0;
            let existing = section
                .as_ref()
                .and_then(|t| t.iter().find(|(k, _)| k.get_ref() == m.key));
            if let Some((_, val)) = existing {
                let ls = line_start(val.span().start);
                edits.push((ls..ls, format!("# {note}\n")));
                edits.push((val.span(), format!("{x:?}")));
            } else if let Some(at) = header_end.filter(|_| section.is_some()) {
                // After the header, in the order of the changes (one edit per place).
                match edits.iter_mut().find(|(r, _)| *r == (at..at)) {
                    Some((_, t)) => {
                        let _ = std::fmt::Write::write_fmt(
                            t,
                            format_args!("# {note}\n{} = {x:?}\n", m.key),
                        );
                    }
                    None => edits.push((at..at, format!("# {note}\n{} = {x:?}\n", m.key))),
                }
            } else {
                let _ = std::fmt::Write::write_fmt(
                    &mut appended,
                    format_args!("# {note}\n{} = {x:?}\n", m.key),
                );
            }
        }
        edits.sort_by_key(|(r, _)| std::cmp::Reverse((r.start, r.end)));
        let mut out = src.to_string();
        for (r, t) in edits {
            out.replace_range(r, &t);
        }
        if !appended.is_empty() {
            if !out.ends_with('\n') {
                out.push('\n');
            }
            out.push_str(
                "\n[model_equation]\n# The instrument's nominal IEEE 1293 model-equation terms (cgs units, IEEE signs;\n# 0 when absent): the baseline model includes them.\n",
            );
            out.push_str(&appended);
        }
        let back = Self::parse(&out, file)?;
        for (id, v, _) in changes {
            let b = back.nominal_model_term(*id);
            if (b - v).abs() > 1e-12 * v.abs().max(1e-300) {
                return Err(fail(format!(
                    "{id}: the rewritten file does not give {v} back"
                )));
            }
        }
        Ok(out)
    }
}

impl Instrument {
    /// The shipped instrument file named `name` ([`SHIPPED`]), parsed.
    ///
    /// # Errors
    /// An unknown name (the message lists the shipped ones).
    ///
    /// # Panics
    /// Never for a shipped file (a unit test parses each).
    pub fn shipped(name: &str) -> Result<Self, String> {
        let (path, text) = shipped(name).ok_or_else(|| {
            let names: Vec<&str> = SHIPPED.iter().map(|s| s.0).collect();
            format!(
                "`{name}` is not a shipped instrument; expected one of {}",
                names.join(", ")
            )
        })?;
        Ok(Self::parse(text, path).expect("a shipped instrument file is valid"))
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

    /// Each shipped file parses, under its name; the two classes without a loop have no
    /// loop field, no tolerance, their reading scale and their own bounds; an unknown name
    /// is refused listing the shipped ones.
    #[test]
    #[allow(
        clippy::float_cmp,
        reason = "values read as written, and sums exact in binary"
    )]
    fn the_shipped_instruments_parse_by_name() {
        let k = Instrument::shipped("kearfott-2401").unwrap();
        assert_eq!(k, Instrument::kearfott_2401());
        assert!(k.has_loop && k.reading_scale.is_none() && k.nominal.is_zero());
        for (name, unit, per_g, sf_ppm) in [
            ("navigation", ReadingUnit::MilliAmp, 1.33, 1e5),
            ("mems", ReadingUnit::Lsb, 16384.0, 5e4),
        ] {
            let i = Instrument::shipped(name).unwrap();
            assert!(!i.has_loop, "{name}");
            assert!(i.tolerances.is_empty(), "{name}");
            assert_eq!(i.class.as_deref(), Some(name));
            assert_eq!(i.reading_scale, Some(ReadingScale { unit, per_g }));
            assert_eq!(i.plausibility.scale_factor_ppm, sf_ppm, "{name}");
            assert_eq!(i.pendulosity_dyn_cm_per_g, 0.0);
            assert_eq!(i.loop_bias_cm_s2(500.0), 0.0);
            assert!((i.g_cm_s2 - 980.665).abs() < 1e-12);
        }
        let e = Instrument::shipped("adxl").unwrap_err();
        assert_eq!(
            e,
            "`adxl` is not a shipped instrument; expected one of kearfott-2401, navigation, mems"
        );
    }

    /// The text of the shipped MEMS file with `from` replaced by `to` (exactly once).
    fn mems_with(from: &str, to: &str) -> String {
        assert_eq!(MEMS_TOML.matches(from).count(), 1, "{from}");
        MEMS_TOML.replace(from, to)
    }

    /// The line (1-based) of `text` that starts with `key`.
    fn line_in(text: &str, key: &str) -> usize {
        text.lines().position(|l| l.starts_with(key)).unwrap() + 1
    }

    /// A file without a loop is validated like one with: every refusal names the key, the
    /// line and what was expected.
    #[test]
    fn a_file_without_a_loop_is_refused_with_its_position() {
        let cases: &[(&str, &str, &str, &str)] = &[
            (
                "reading_unit = \"LSB\"",
                "reading_unit = \"g\"",
                "reading_unit",
                "instrument.reading_unit = \"g\": a reading in g is converted by its definition; expected the unit of a scale factor: V, mA or LSB",
            ),
            (
                "reading_unit = \"LSB\"",
                "reading_unit = \"counts\"",
                "reading_unit",
                "instrument.reading_unit = \"counts\": expected one of V, mA, LSB",
            ),
            (
                "reading_unit = \"LSB\"\n",
                "",
                "scale_factor_per_g",
                "instrument.scale_factor_per_g without instrument.reading_unit: expected both",
            ),
            (
                "scale_factor_per_g = 16384.0",
                "scale_factor_per_g = -16384.0",
                "scale_factor_per_g",
                "instrument.scale_factor_per_g = -16384: expected a nominal scale factor > 0 LSB per g",
            ),
            (
                "local_gravity_cm_s2 = 980.665",
                "local_gravity_cm_s2 = 0.0",
                "local_gravity_cm_s2",
                "instrument.local_gravity_cm_s2 = 0: expected gravity > 0 cm/s²",
            ),
            (
                "k2_s2_cm = 0.0",
                "k2_s2 = 0.0",
                "k2_s2",
                "model_equation.k2_s2: not a term of the model equation; expected one of k1_ppm, delta_o_rad,",
            ),
            (
                "k2_s2_cm = 0.0",
                "delta_p_rad = 2.0",
                "delta_p_rad",
                "model_equation.delta_p_rad = 2: expected |misalignment| < 1 rad",
            ),
            (
                "k2_s2_cm = 0.0",
                "k2_s2_cm = \"small\"",
                "k2_s2_cm",
                "expected a number, found the string \"small\"",
            ),
        ];
        for (from, to, key, message) in cases {
            let text = mems_with(from, to);
            let e = Instrument::parse(&text, "m.toml").unwrap_err();
            assert!(e.message.contains(message), "{to}: {e}");
            assert_eq!(e.line, line_in(&text, key), "{to}: {e}");
            assert!(e.column >= 1, "{e}");
        }
        // Without its name or its bias: the table's first key's line.
        let e = Instrument::parse(&mems_with("bias_cm_s2 = 0.0\n", ""), "m.toml").unwrap_err();
        assert!(
            e.message
                .starts_with("instrument.bias_cm_s2: missing; a file without a PTSA loop"),
            "{e}"
        );
        assert_eq!(e.line, line_in(MEMS_TOML, "name ="), "{e}");
        // A loop's section in it: then every loop section is required.
        let e = Instrument::parse(&format!("{MEMS_TOML}\n[stops]\n"), "m.toml").unwrap_err();
        assert_eq!(
            e.message,
            "a file with a PTSA loop has [pendulum], [pickoff], [torquer], [electronics] and [stops]; [pendulum], [pickoff], [torquer], [electronics] missing (a file without a loop has none of them)"
        );
        // No [instrument] and no loop.
        let e = Instrument::parse("[plausibility]\nbias_cm_s2 = 1.0\n", "p.toml").unwrap_err();
        assert!(
            e.message
                .contains("or, for an accelerometer without one, an [instrument] table"),
            "{e}"
        );
        // A file with a loop keeps its bias and gravity in [electronics].
        let e = Instrument::parse(
            &format!("{KEARFOTT_2401_TOML}\n[instrument]\nname = \"k\"\nbias_cm_s2 = 1.0\n"),
            "k.toml",
        )
        .unwrap_err();
        assert!(
            e.message.starts_with(
                "instrument.bias_cm_s2: a file with a PTSA loop gives it as electronics.bias_cm_s2"
            ),
            "{e}"
        );
    }

    /// `[model_equation]`'s keys are the nominal values of their candidates, `δ_p` under the
    /// IEEE sign (the candidate of `a_OA` is `−δ_p`); the bias is the file's `A_b`.
    #[test]
    #[allow(
        clippy::float_cmp,
        reason = "values read as written, and sums exact in binary"
    )]
    fn model_equation_keys_are_the_nominal_terms() {
        let mut text = format!("{KEARFOTT_2401_TOML}\n[model_equation]\n");
        for (k, m) in MODEL_EQUATION.iter().enumerate() {
            let _ =
                std::fmt::Write::write_fmt(&mut text, format_args!("{} = {}e-7\n", m.key, k + 1));
        }
        let i = Instrument::parse(&text, "k.toml").unwrap();
        for (k, m) in MODEL_EQUATION.iter().enumerate() {
            let x: f64 = format!("{}e-7", k + 1).parse().unwrap();
            assert_eq!(i.nominal_model_term(m.id), m.sign * x, "{}", m.key);
        }
        assert_eq!(
            i.nominal_model_term(CandidateId::MisalignmentO),
            -3e-7,
            "delta_p_rad"
        );
        assert_eq!(i.nominal_model_term(CandidateId::Bias), 18.7);
        assert_eq!(i.nominal_model_term(CandidateId::Anisoinertia), 0.0);
        let e = i.with_nominal_terms(&Effects::only(CandidateId::Nonlinearity, 1.0));
        assert_eq!(e.get(CandidateId::Nonlinearity), 1.0 + 4e-7);
        assert_eq!(e.get(CandidateId::Cubic), 5e-7);
    }

    /// Raw readings: units of acceleration by their definition (g with the file's local
    /// gravity), V, mA or LSB only through the file's scale in that unit.
    #[test]
    #[allow(
        clippy::float_cmp,
        reason = "values read as written, and sums exact in binary"
    )]
    fn readings_are_converted_through_the_nominal_scale() {
        let m = Instrument::shipped("mems").unwrap();
        let g = 980.665;
        assert_eq!(m.reading_to_cm_s2(16384.0, ReadingUnit::Lsb), Ok(g));
        assert_eq!(m.reading_to_cm_s2(-0.5, ReadingUnit::G), Ok(-0.5 * g));
        assert_eq!(m.reading_to_cm_s2(9.5, ReadingUnit::MPerS2), Ok(950.0));
        assert_eq!(m.reading_to_cm_s2(3.0, ReadingUnit::CmPerS2), Ok(3.0));
        let e = m.reading_to_cm_s2(1.0, ReadingUnit::Volt).unwrap_err();
        assert!(
            e.contains("a reading in V needs a nominal scale factor in V per g"),
            "{e}"
        );
        let k = Instrument::kearfott_2401();
        let e = k.reading_to_cm_s2(1.0, ReadingUnit::MilliAmp).unwrap_err();
        assert!(
            e.contains(
                "expected instrument.reading_unit = \"mA\" and instrument.scale_factor_per_g"
            ),
            "{e}"
        );
        for u in ReadingUnit::ALL {
            assert_eq!(ReadingUnit::parse(u.name()), Some(*u));
        }
        assert_eq!(ReadingUnit::parse("m/s2"), Some(ReadingUnit::MPerS2));
        assert_eq!(ReadingUnit::parse("cm/s^2"), Some(ReadingUnit::CmPerS2));
        assert_eq!(ReadingUnit::parse("counts"), None);
    }

    /// `rewrite_model_equation` sets each term (the bias in its key; the others in
    /// `[model_equation]`, added when absent), keeps every line it does not set, and the
    /// result reads back with the new values.
    #[test]
    #[allow(
        clippy::float_cmp,
        reason = "values read as written, and sums exact in binary"
    )]
    fn rewrite_model_equation_sets_the_terms_and_keeps_the_rest() {
        let changes = vec![
            (CandidateId::Bias, 20.5, "fitted bias".to_string()),
            (CandidateId::ScaleFactor, 400.0, "fitted K1".to_string()),
            (CandidateId::MisalignmentO, -2.5e-4, "fitted".to_string()),
            (CandidateId::Nonlinearity, 3e-8, "fitted K2".to_string()),
        ];
        for (src, bias_key) in [
            (KEARFOTT_2401_TOML, "bias_cm_s2 = 20.5"),
            (MEMS_TOML, "bias_cm_s2 = 20.5"),
        ] {
            let out = Instrument::rewrite_model_equation(src, "f.toml", &changes).unwrap();
            let back = Instrument::parse(&out, "f.toml").unwrap();
            for (id, v, _) in &changes {
                assert_eq!(back.nominal_model_term(*id), *v, "{id}");
            }
            // δ_p is written under its own sign: the candidate's −2.5e-4 is δ_p = 2.5e-4.
            assert!(out.contains("\ndelta_p_rad = 0.00025\n"), "{out}");
            assert!(
                out.contains(&format!("# fitted bias\n{bias_key}\n")),
                "{out}"
            );
            // Every line of the source is still there, but the values set.
            let kept: Vec<&str> = out.lines().collect();
            for l in src.lines() {
                let set = l.starts_with("bias_cm_s2 = 0.0")
                    || l.starts_with("bias_cm_s2 = 18.7")
                    || l.starts_with("k2_s2_cm");
                assert!(set || kept.contains(&l), "lost: {l}");
            }
            let before = Instrument::parse(src, "f.toml").unwrap();
            assert_eq!(back.plausibility, before.plausibility);
            assert_eq!(back.tolerances, before.tolerances);
        }
        // Not a term of the model equation.
        let e = Instrument::rewrite_model_equation(
            MEMS_TOML,
            "f.toml",
            &[(CandidateId::Anisoinertia, 1.0, String::new())],
        )
        .unwrap_err();
        assert!(
            e.message.contains("not a term of the model equation"),
            "{e}"
        );
    }
}
