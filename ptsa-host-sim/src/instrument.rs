//! The instrument file (`data/kearfott-2401.toml`): Table 2.1 of R-890 with tolerances, and
//! the PTSA electronics, validated on load.

use std::path::Path;

use serde::Deserialize;
use toml::Spanned;

/// The shipped instrument file, compiled in.
pub const KEARFOTT_2401_TOML: &str = include_str!("../../data/kearfott-2401.toml");

/// Why an instrument file was refused: where and what was expected.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{file}:{line}:{column}: {message}")]
pub struct InstrumentError {
    /// File name (or `<builtin>`).
    pub file: String,
    /// 1-based line.
    pub line: usize,
    /// 1-based column.
    pub column: usize,
    /// What was wrong and what was expected.
    pub message: String,
}

/// A toleranced parameter as written in the file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct Param {
    value: Spanned<f64>,
    tol_pct: Option<f64>,
    tol_abs: Option<f64>,
    min: Option<f64>,
    max: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PendulumT {
    pendulosity_dyn_cm_per_g: Spanned<Param>,
    freedom_mrad: Spanned<Param>,
    inertia_oa_g_cm2: Spanned<Param>,
    spring_dyn_cm_per_rad: Spanned<Param>,
    damping_dyn_cm_s: Spanned<Param>,
    anisoinertia_g_cm2: Spanned<Param>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PickoffT {
    scale_factor_v_per_rad: Spanned<Param>,
    quadrature_null_uv: Spanned<Param>,
    phase_angle_deg: Spanned<Param>,
    noise_uv_rms: Spanned<Param>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TorquerT {
    current_scale_factor_ma_per_g: Spanned<Param>,
    time_constant_us: Spanned<Param>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ElectronicsT {
    scale_factor_cm_s2: Spanned<f64>,
    bias_cm_s2: Spanned<f64>,
    amplifier_gain: Spanned<f64>,
    demodulator_bandwidth_hz: Spanned<f64>,
    adc_full_scale_v: Spanned<f64>,
    clock_hz: Spanned<f64>,
    local_gravity_cm_s2: Spanned<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct StopsT {
    stiffness_dyn_cm_per_rad: Spanned<f64>,
    damping_dyn_cm_s: Spanned<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileT {
    pendulum: PendulumT,
    pickoff: PickoffT,
    torquer: TorquerT,
    electronics: ElectronicsT,
    stops: StopsT,
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
}

fn line_col(src: &str, offset: usize) -> (usize, usize) {
    let before = &src[..offset.min(src.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
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
        let v = *p.get_ref().value.get_ref();
        let at = p.get_ref().value.span().start;
        if !v.is_finite() || !ok(v) {
            return Err(self.err(at, format!("{key} = {v}: expected {expected}")));
        }
        let q = p.get_ref();
        let forms = usize::from(q.tol_pct.is_some())
            + usize::from(q.tol_abs.is_some())
            + usize::from(q.min.is_some() || q.max.is_some());
        let tspan = p.span().start;
        if forms != 1 {
            return Err(self.err(
                tspan,
                format!(
                    "{key}: expected exactly one tolerance form: tol_pct, tol_abs, or min and max"
                ),
            ));
        }
        let (lo, hi) = if let Some(t) = q.tol_pct {
            if !(0.0..100.0).contains(&t) {
                return Err(self.err(
                    tspan,
                    format!("{key}: tol_pct = {t}: expected 0 <= tol_pct < 100"),
                ));
            }
            let a = v * (1.0 - t / 100.0);
            let b = v * (1.0 + t / 100.0);
            (a.min(b), a.max(b))
        } else if let Some(t) = q.tol_abs {
            if t < 0.0 || !t.is_finite() {
                return Err(self.err(
                    tspan,
                    format!("{key}: tol_abs = {t}: expected a finite value >= 0"),
                ));
            }
            (v - t, v + t)
        } else {
            match (q.min, q.max) {
                (Some(a), Some(b)) if a <= v && v <= b => (a, b),
                (Some(a), Some(b)) => {
                    return Err(self.err(
                        tspan,
                        format!("{key}: min = {a}, max = {b}: expected min <= value ({v}) <= max"),
                    ));
                }
                _ => {
                    return Err(self.err(tspan, format!("{key}: expected both min and max")));
                }
            }
        };
        if !ok(lo) || !ok(hi) {
            return Err(self.err(
                tspan,
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
        s: &Spanned<f64>,
        ok: impl Fn(f64) -> bool,
        expected: &str,
    ) -> Result<f64, InstrumentError> {
        let v = *s.get_ref();
        if !v.is_finite() || !ok(v) {
            return Err(self.err(s.span().start, format!("{key} = {v}: expected {expected}")));
        }
        Ok(v)
    }
}

fn positive(x: f64) -> bool {
    x > 0.0
}
fn non_negative(x: f64) -> bool {
    x >= 0.0
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
    /// Unreadable file, TOML syntax, unknown or missing keys, or a value out of range; the
    /// error names the file, line and column and says what was expected.
    pub fn load(path: &Path) -> Result<Self, InstrumentError> {
        let name = path.display().to_string();
        let src = std::fs::read_to_string(path).map_err(|e| InstrumentError {
            file: name.clone(),
            line: 0,
            column: 0,
            message: format!("cannot read: {e}"),
        })?;
        Self::parse(&src, &name)
    }

    /// Parse and validate instrument-file text; `file` names it in errors.
    ///
    /// # Errors
    /// See [`Instrument::load`].
    pub fn parse(src: &str, file: &str) -> Result<Self, InstrumentError> {
        let cx = Ctx { file, src };
        let f: FileT = toml::from_str(src).map_err(|e| {
            let at = e.span().map_or(0, |s| s.start);
            cx.err(at, e.message().trim().to_string())
        })?;
        let mut tol = Vec::new();
        let t = &mut tol;
        let p = &f.pendulum;
        let pendulosity = cx.param(
            "pendulum.pendulosity_dyn_cm_per_g",
            &p.pendulosity_dyn_cm_per_g,
            positive,
            "a pendulosity > 0 dyn·cm/g",
            t,
        )?;
        let freedom = cx.param(
            "pendulum.freedom_mrad",
            &p.freedom_mrad,
            |x| x > 0.0 && x < 2.5,
            "0 < freedom < 2.5 mrad (the ADC's full scale)",
            t,
        )?;
        let inertia = cx.param(
            "pendulum.inertia_oa_g_cm2",
            &p.inertia_oa_g_cm2,
            positive,
            "an inertia > 0 g·cm²",
            t,
        )?;
        let spring = cx.param(
            "pendulum.spring_dyn_cm_per_rad",
            &p.spring_dyn_cm_per_rad,
            non_negative,
            "a spring rate >= 0 dyn·cm/rad",
            t,
        )?;
        let damping = cx.param(
            "pendulum.damping_dyn_cm_s",
            &p.damping_dyn_cm_s,
            positive,
            "a damping > 0 dyn·cm·s",
            t,
        )?;
        let aniso = cx.param(
            "pendulum.anisoinertia_g_cm2",
            &p.anisoinertia_g_cm2,
            |x| x.abs() < 100.0,
            "|I_PA − I_IA| < 100 g·cm²",
            t,
        )?;
        let k = &f.pickoff;
        let po = cx.param(
            "pickoff.scale_factor_v_per_rad",
            &k.scale_factor_v_per_rad,
            positive,
            "a pickoff scale factor > 0 V/rad",
            t,
        )?;
        let quad = cx.param(
            "pickoff.quadrature_null_uv",
            &k.quadrature_null_uv,
            non_negative,
            "a quadrature null >= 0 µV",
            t,
        )?;
        let phase = cx.param(
            "pickoff.phase_angle_deg",
            &k.phase_angle_deg,
            |x| x.abs() < 60.0,
            "|phase angle| < 60 deg",
            t,
        )?;
        let noise = cx.param(
            "pickoff.noise_uv_rms",
            &k.noise_uv_rms,
            non_negative,
            "a noise >= 0 µV rms",
            t,
        )?;
        let q = &f.torquer;
        let csf = cx.param(
            "torquer.current_scale_factor_ma_per_g",
            &q.current_scale_factor_ma_per_g,
            positive,
            "a current scale factor > 0 mA/g",
            t,
        )?;
        let tau = cx.param(
            "torquer.time_constant_us",
            &q.time_constant_us,
            positive,
            "a time constant > 0 µs",
            t,
        )?;
        let e = &f.electronics;
        let sf = cx.scalar(
            "electronics.scale_factor_cm_s2",
            &e.scale_factor_cm_s2,
            positive,
            "a scale factor > 0 cm/s²",
        )?;
        let bias = cx.scalar(
            "electronics.bias_cm_s2",
            &e.bias_cm_s2,
            |x| x.abs() < sf,
            "|bias| below the scale factor",
        )?;
        let amp = cx.scalar(
            "electronics.amplifier_gain",
            &e.amplifier_gain,
            positive,
            "a gain > 0",
        )?;
        let bw = cx.scalar(
            "electronics.demodulator_bandwidth_hz",
            &e.demodulator_bandwidth_hz,
            positive,
            "a bandwidth > 0 Hz",
        )?;
        let fs = cx.scalar(
            "electronics.adc_full_scale_v",
            &e.adc_full_scale_v,
            positive,
            "a full scale > 0 V",
        )?;
        let clock = cx.scalar(
            "electronics.clock_hz",
            &e.clock_hz,
            |x| x >= 1000.0,
            "a clock >= 1000 Hz",
        )?;
        let g = cx.scalar(
            "electronics.local_gravity_cm_s2",
            &e.local_gravity_cm_s2,
            positive,
            "gravity > 0 cm/s²",
        )?;
        let s = &f.stops;
        let ks = cx.scalar(
            "stops.stiffness_dyn_cm_per_rad",
            &s.stiffness_dyn_cm_per_rad,
            positive,
            "a stiffness > 0 dyn·cm/rad",
        )?;
        let cs = cx.scalar(
            "stops.damping_dyn_cm_s",
            &s.damping_dyn_cm_s,
            non_negative,
            "a damping >= 0 dyn·cm·s",
        )?;
        Ok(Self {
            pendulosity_dyn_cm_per_g: pendulosity,
            freedom_rad: freedom * 1e-3,
            inertia_dyn_cm_s2: inertia,
            spring_dyn_cm_rad: spring,
            damping_dyn_cm_s: damping,
            anisoinertia_g_cm2: aniso,
            pickoff_v_per_rad: po,
            quadrature_v: quad * 1e-6,
            phase_error_rad: phase.to_radians(),
            noise_v_rms: noise * 1e-6,
            current_sf_ma_per_g: csf,
            torquer_tau_s: tau * 1e-6,
            full_current_ma: sf / g * csf,
            sf_cm_s2: sf,
            bias_cm_s2: bias,
            amp_gain: amp,
            demod_bandwidth_hz: bw,
            adc_full_scale_v: fs,
            clock_hz: clock,
            g_cm_s2: g,
            stop_stiffness_dyn_cm_rad: ks,
            stop_damping_dyn_cm_s: cs,
            tolerances: tol,
        })
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

    /// Set one toleranced parameter by its file key, in the file's unit. The regulated
    /// current is not re-derived (the PTSA keeps its setting).
    ///
    /// # Errors
    /// Unknown key.
    pub fn set(&mut self, key: &str, v: f64) -> Result<(), String> {
        match key {
            "pendulum.pendulosity_dyn_cm_per_g" => self.pendulosity_dyn_cm_per_g = v,
            "pendulum.freedom_mrad" => self.freedom_rad = v * 1e-3,
            "pendulum.inertia_oa_g_cm2" => self.inertia_dyn_cm_s2 = v,
            "pendulum.spring_dyn_cm_per_rad" => self.spring_dyn_cm_rad = v,
            "pendulum.damping_dyn_cm_s" => self.damping_dyn_cm_s = v,
            "pendulum.anisoinertia_g_cm2" => self.anisoinertia_g_cm2 = v,
            "pickoff.scale_factor_v_per_rad" => self.pickoff_v_per_rad = v,
            "pickoff.quadrature_null_uv" => self.quadrature_v = v * 1e-6,
            "pickoff.phase_angle_deg" => self.phase_error_rad = v.to_radians(),
            "pickoff.noise_uv_rms" => self.noise_v_rms = v * 1e-6,
            "torquer.current_scale_factor_ma_per_g" => self.current_sf_ma_per_g = v,
            "torquer.time_constant_us" => self.torquer_tau_s = v * 1e-6,
            _ => return Err(format!("unknown parameter {key}")),
        }
        Ok(())
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
}
