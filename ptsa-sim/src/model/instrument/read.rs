//! Reading and validating an instrument file: every refusal names the file, the line and
//! the column, and says what was expected.

use std::path::Path;

use ptsa_core::adc::{AdcFormat, Alignment, Coding};
use toml::Spanned;

use super::schema::{
    BoardT, ElectronicsT, FileT, IdentT, LOOP_SECTIONS, LooplessT, MODEL_EQUATION, ModelEquationT,
    Num, NumOrParam, PARAMETERS, Param, Parameter, PlausibilityT, Raw, positive,
};
use super::units::{ReadingScale, ReadingUnit};
use super::{Board, Instrument, Plausibility, Tolerance};
use crate::model::effects::{CandidateId, Effects};

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
pub(super) fn position_text(line: usize, column: usize) -> String {
    if line == 0 {
        String::new()
    } else {
        format!(":{line}:{column}")
    }
}

/// The 1-based line and column (in characters) of byte `offset` of `src`.
pub(super) fn line_col(src: &str, offset: usize) -> (usize, usize) {
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
pub(super) fn user_message(message: &str) -> String {
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

pub(super) struct Ctx<'a> {
    pub(super) file: &'a str,
    pub(super) src: &'a str,
}

impl Ctx<'_> {
    pub(super) fn err(&self, offset: usize, message: String) -> InstrumentError {
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
    pub(super) fn param(
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

    pub(super) fn scalar(
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
    pub(super) fn entry(
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
    pub(super) fn board(&self, b: &BoardT, e: &ElectronicsT) -> Result<Board, InstrumentError> {
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
    pub(super) fn ident(&self, t: &IdentT, instr: &mut Instrument) -> Result<(), InstrumentError> {
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
    pub(super) fn reading_scale(
        &self,
        t: &IdentT,
    ) -> Result<Option<ReadingScale>, InstrumentError> {
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
    pub(super) fn model_equation(
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
    pub(super) fn plausibility(
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
pub(super) fn band(key: &str, v: f64, q: &Param) -> Result<(f64, f64), String> {
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

/// An I/O error's message without the operating system's error number.
pub(super) fn io_message(e: &std::io::Error) -> String {
    let s = e.to_string();
    match s.rfind(" (os error ") {
        Some(i) if s.ends_with(')') => s[..i].to_string(),
        _ => s,
    }
}

impl Instrument {
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
}
