//! The design of the default compensator (`Config::DEFAULT` in `ptsa-core`), and the
//! frequency-domain loop analysis used for stability margins.
//!
//! Near the 100 Hz crossover the Kearfott 2401 is a damping-dominated integrator
//! (`I/C = 183 µs`, i.e. the inertia pole is at 868 Hz; the flexure pole at 3.2 mHz), so the
//! design plant from the comparator level (`2^24` LSB = full torque) to the pickoff ADC code
//! is `G0 / s` with `G0 = P·SF / (C·θ_lsb) / 2^24` (ADC LSB per second per comparator LSB).
//! A PI + lead compensator puts the crossover at `ω_c = 2π·100 rad/s`, the lead zero at
//! `ω_c/2`, its pole at `2ω_c`, the integral corner at `ω_c/4`, and is discretised at
//! 64 kHz by pole-zero matching (unity gain at DC for the lead section).

use std::f64::consts::TAU;

use ptsa_core::{Coef, Config, Pole};

use crate::model::instrument::Instrument;

/// Every intermediate number of the design, SI/cgs units in the names.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Design {
    /// Pendulum angle per ADC LSB, rad: `2.5 V / 2^15 / (10 V/rad · 100)`.
    pub theta_lsb_rad: f64,
    /// Pendulosity `m·l`, g·cm (`1100 dyn·cm/g / 980.4 cm/s²`).
    pub pendulosity_g_cm: f64,
    /// Scale factor, cm/s² at full torque.
    pub sf_cm_s2: f64,
    /// Damping coefficient, dyn·cm·s.
    pub damping_dyn_cm_s: f64,
    /// Plant gain at full torque, ADC LSB per second.
    pub g_fs_lsb_s: f64,
    /// Plant gain per comparator LSB, ADC LSB per second per comparator LSB.
    pub g0: f64,
    /// Crossover, rad/s.
    pub omega_c: f64,
    /// Lead zero, rad/s.
    pub omega_z: f64,
    /// Lead pole, rad/s.
    pub omega_p: f64,
    /// Integral corner, rad/s.
    pub omega_i: f64,
    /// Clock period, s.
    pub t_s: f64,
    /// Compensator gain, comparator LSB per ADC LSB.
    pub kc: f64,
    /// Lead zero, z-plane.
    pub z: f64,
    /// Lead pole, z-plane.
    pub p: f64,
    /// `b0`, comparator LSB per ADC LSB.
    pub b0: f64,
    /// `b1`, comparator LSB per ADC LSB.
    pub b1: f64,
    /// `a1`.
    pub a1: f64,
    /// `ki`, comparator LSB per ADC LSB per tick.
    pub ki: f64,
}

/// Magnitude of `lead(jω_c) + ω_i/(jω_c)` (complex arithmetic by hand).
fn comp_magnitude(w: f64, wz: f64, wp: f64, wi: f64) -> f64 {
    // lead = (1 + j w/wz) / (1 + j w/wp)
    let (nr, ni) = (1.0, w / wz);
    let (dr, di) = (1.0, w / wp);
    let den = dr * dr + di * di;
    let lr = (nr * dr + ni * di) / den;
    let li = (ni * dr - nr * di) / den;
    // + wi/(j w) = −j wi/w
    let (re, im) = (lr, li - wi / w);
    re.hypot(im)
}

impl Design {
    /// The design for the default Kearfott 2401 numbers (the ones `Config::DEFAULT` holds):
    /// ADC ±2.5 V on 16 bits, pickoff 10 V/rad, amplifier ×100, `P = 1100/980.4 g·cm`,
    /// `SF = 21121.1 cm/s²`, `C = 76400 dyn·cm·s`, 100 Hz crossover, 64 kHz clock.
    #[must_use]
    pub fn default_kearfott() -> Self {
        Self::new(
            2.5 / 32768.0 / (10.0 * 100.0),
            1100.0 / 980.4,
            21121.1,
            76400.0,
            100.0,
            1.0 / 64000.0,
        )
    }

    /// The design for a given instrument file (its nominal values).
    #[must_use]
    pub fn for_instrument(instr: &Instrument) -> Self {
        Self::new(
            instr.theta_lsb_rad(),
            instr.pendulosity_g_cm(),
            instr.sf_cm_s2,
            instr.damping_dyn_cm_s,
            100.0,
            1.0 / instr.clock_hz,
        )
    }

    /// The design from its inputs: angle per ADC LSB (rad), pendulosity (g·cm), scale factor
    /// (cm/s²), damping (dyn·cm·s), crossover (Hz), clock period (s).
    #[must_use]
    pub fn new(
        theta_lsb_rad: f64,
        pendulosity_g_cm: f64,
        sf_cm_s2: f64,
        damping_dyn_cm_s: f64,
        crossover_hz: f64,
        t_s: f64,
    ) -> Self {
        let g_fs_lsb_s = pendulosity_g_cm * sf_cm_s2 / (damping_dyn_cm_s * theta_lsb_rad);
        let g0 = g_fs_lsb_s / f64::from(1u32 << 24);
        let omega_c = TAU * crossover_hz;
        let omega_z = omega_c / 2.0;
        let omega_p = 2.0 * omega_c;
        let omega_i = omega_c / 4.0;
        let kc = omega_c / (g0 * comp_magnitude(omega_c, omega_z, omega_p, omega_i));
        let z = (-omega_z * t_s).exp();
        let p = (-omega_p * t_s).exp();
        let g = (1.0 - p) / (1.0 - z);
        Self {
            theta_lsb_rad,
            pendulosity_g_cm,
            sf_cm_s2,
            damping_dyn_cm_s,
            g_fs_lsb_s,
            g0,
            omega_c,
            omega_z,
            omega_p,
            omega_i,
            t_s,
            kc,
            z,
            p,
            b0: kc * g,
            b1: -kc * g * z,
            a1: p,
            ki: kc * omega_i * t_s,
        }
    }

    /// The four coefficients rounded to their formats: raw bits of `b0`, `b1` (Q15.16),
    /// `a1` (Q15.16), `ki` (Q15.16).
    #[must_use]
    #[allow(clippy::cast_possible_truncation)]
    pub fn bits(&self) -> [i32; 4] {
        [
            (self.b0 * 65536.0).round() as i32,
            (self.b1 * 65536.0).round() as i32,
            (self.a1 * f64::from(1u32 << ptsa_core::POLE_FRAC)).round() as i32,
            (self.ki * 65536.0).round() as i32,
        ]
    }

    /// A `Config` with these coefficients (other fields from `Config::DEFAULT`).
    #[must_use]
    pub fn config(&self) -> Config {
        let [b0, b1, a1, ki] = self.bits();
        Config {
            b0: Coef::from_bits(b0),
            b1: Coef::from_bits(b1),
            a1: Pole::from_bits(a1),
            ki: Coef::from_bits(ki),
            ..Config::DEFAULT
        }
    }

    /// The Rust source of the four `DEFAULT_*_BITS` constants of `ptsa-core/src/config.rs`.
    #[must_use]
    pub fn core_constants(&self) -> String {
        let [b0, b1, a1, ki] = self.bits();
        format!(
            "const DEFAULT_B0_BITS: i32 = {};\nconst DEFAULT_B1_BITS: i32 = {};\nconst DEFAULT_A1_BITS: i32 = {};\nconst DEFAULT_KI_BITS: i32 = {};\n",
            underscore(b0.into()),
            underscore(b1.into()),
            underscore(a1.into()),
            underscore(ki.into())
        )
    }
}

/// `1234567` → `1_234_567` (Rust literal style), as the generated constants write them.
#[must_use]
pub fn underscore(x: i64) -> String {
    let s = x.unsigned_abs().to_string();
    let mut out = String::new();
    for (i, ch) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push('_');
        }
        out.push(ch);
    }
    if x < 0 { format!("-{out}") } else { out }
}

impl std::fmt::Display for Design {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [b0, b1, a1, ki] = self.bits();
        writeln!(
            f,
            "PTSA compensator design (Kearfott 2401, pole-zero matched at 1/T)"
        )?;
        writeln!(
            f,
            "  theta_lsb        = {:.6e} rad per ADC LSB",
            self.theta_lsb_rad
        )?;
        writeln!(f, "  P (m*l)          = {:.6} g*cm", self.pendulosity_g_cm)?;
        writeln!(
            f,
            "  SF               = {:.1} cm/s^2 at full torque",
            self.sf_cm_s2
        )?;
        writeln!(
            f,
            "  C                = {:.1} dyn*cm*s",
            self.damping_dyn_cm_s
        )?;
        writeln!(
            f,
            "  G_fs = P*SF/(C*theta_lsb) = {:.6e} LSB/s at full torque",
            self.g_fs_lsb_s
        )?;
        writeln!(
            f,
            "  G0 = G_fs/2^24   = {:.6e} LSB/s per comparator LSB",
            self.g0
        )?;
        writeln!(
            f,
            "  w_c = {:.3} rad/s (100 Hz), w_z = w_c/2, w_p = 2 w_c, w_i = w_c/4",
            self.omega_c
        )?;
        writeln!(
            f,
            "  Kc               = {:.6} comparator LSB per ADC LSB",
            self.kc
        )?;
        writeln!(
            f,
            "  z = exp(-w_z T)  = {:.9}, p = exp(-w_p T) = {:.9}",
            self.z, self.p
        )?;
        writeln!(
            f,
            "  b0 = {:.6} ({b0}), b1 = {:.6} ({b1})",
            self.b0, self.b1
        )?;
        writeln!(
            f,
            "  a1 = {:.9} ({a1}), ki = {:.6} ({ki})",
            self.a1, self.ki
        )
    }
}

/// Complex numbers of the loop analysis.
pub type Cx = num_complex::Complex64;

/// Stability margins of the linearised loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Margins {
    /// Gain crossover, Hz.
    pub crossover_hz: f64,
    /// Phase margin, degrees.
    pub phase_margin_deg: f64,
    /// Gain margin, dB (at the −180° crossing below Nyquist; infinite if none).
    pub gain_margin_db: f64,
}

/// Open-loop gain `L(jω)` of the linearised loop at `f_hz`: the compensator `D(z)` as the
/// core implements it (exact rounded coefficients), the quantizer as a unit gain from
/// comparator level to mean torque fraction, one clock of computation delay plus the
/// zero-order hold, the torquer current lag, the pendulum `1/(I s² + C s + K)`, the pickoff
/// and amplifier, the demodulator low-pass and the ADC.
#[must_use]
pub fn loop_gain(instr: &Instrument, cfg: &Config, f_hz: f64) -> Cx {
    let t = 1.0 / instr.clock_hz;
    let w = TAU * f_hz;
    let s = Cx::new(0.0, w);
    let zinv = Cx::cis(-w * t);
    let one = Cx::new(1.0, 0.0);
    let b0 = cfg.b0.to_num::<f64>();
    let b1 = cfg.b1.to_num::<f64>();
    let a1 = cfg.a1.to_num::<f64>();
    let ki = cfg.ki.to_num::<f64>();
    let lead = (b0 + b1 * zinv) / (one - a1 * zinv);
    let integ = ki / (one - zinv);
    let d = lead + integ; // comparator LSB per ADC LSB
    // Level → torque: 2^24 comparator LSB = full torque P·SF (dyn·cm).
    let torque_per_lsb = instr.full_torque_dyn_cm() / f64::from(1u32 << 24);
    // ZOH + one tick of delay: e^{-sT}·(1 − e^{-sT})/(sT)
    let zoh = (one - zinv) / (s * t);
    let delay = zinv * zoh;
    let current = one / (one + s * instr.torquer_tau_s);
    let pend = pendulum(instr, f_hz);
    let wd = TAU * instr.demod_bandwidth_hz;
    let demod = wd / (s + wd);
    let pick = instr.lsb_per_rad() * instr.phase_error_rad.cos();
    d * (torque_per_lsb * pick) * delay * current * pend * demod
}

/// The pendulum's response `1/(I s² + C s + K)` at `f_hz`, rad per dyn·cm.
#[must_use]
pub fn pendulum(instr: &Instrument, f_hz: f64) -> Cx {
    let s = Cx::new(0.0, TAU * f_hz);
    1.0 / (s * s * instr.inertia_dyn_cm_s2 + s * instr.damping_dyn_cm_s + instr.spring_dyn_cm_rad)
}

/// Phase and gain margins of [`loop_gain`], found on a log grid from 1 Hz to Nyquist and
/// refined by bisection.
#[must_use]
pub fn margins(instr: &Instrument, cfg: &Config) -> Margins {
    let nyq = instr.clock_hz / 2.0 * 0.999;
    let n = 1000;
    let f_at = |k: usize| {
        #[allow(clippy::cast_precision_loss)]
        let x = k as f64 / n as f64;
        10f64.powf(x * nyq.log10())
    };
    let mut crossover = f64::NAN;
    let mut gm = f64::INFINITY;
    let mut prev_f = f_at(0);
    let mut prev = loop_gain(instr, cfg, prev_f);
    // Unwrapped phase tracking for the −180° crossing.
    let mut prev_phase = prev.arg();
    for k in 1..=n {
        let f = f_at(k);
        let l = loop_gain(instr, cfg, f);
        if crossover.is_nan() && prev.norm() >= 1.0 && l.norm() < 1.0 {
            let (mut lo, mut hi) = (prev_f, f);
            for _ in 0..60 {
                let mid = (lo * hi).sqrt();
                if loop_gain(instr, cfg, mid).norm() >= 1.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            crossover = (lo * hi).sqrt();
        }
        let mut ph = l.arg();
        while ph - prev_phase > std::f64::consts::PI {
            ph -= TAU;
        }
        while ph - prev_phase < -std::f64::consts::PI {
            ph += TAU;
        }
        // Crossing of −180° (mod 360°) from above, with gain below... record the first
        // crossing with |L| < 1 (above crossover); below it, integrator phase is −90°..−180°.
        let target = -std::f64::consts::PI;
        if prev_phase > target && ph <= target && f > 1.0 && gm.is_infinite() {
            // Refine: the phase is continuous between neighbouring grid points.
            let unwrap = |x: f64| {
                let mut p = x;
                while p - prev_phase > std::f64::consts::PI {
                    p -= TAU;
                }
                while p - prev_phase < -std::f64::consts::PI {
                    p += TAU;
                }
                p
            };
            let (mut lo, mut hi) = (prev_f, f);
            for _ in 0..40 {
                let mid = (lo * hi).sqrt();
                if unwrap(loop_gain(instr, cfg, mid).arg()) > target {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            gm = -20.0 * loop_gain(instr, cfg, (lo * hi).sqrt()).norm().log10();
        }
        prev_phase = ph;
        prev = l;
        prev_f = f;
    }
    let pm = if crossover.is_nan() {
        f64::NAN
    } else {
        180.0 + loop_gain(instr, cfg, crossover).arg().to_degrees()
    };
    Margins {
        crossover_hz: crossover,
        phase_margin_deg: pm,
        gain_margin_db: gm,
    }
}

/// The ADC must cover the pendulum's swing in one limit cycle (at full torque, half a cycle
/// each way), or it clips inside every cycle and the loop is not the linear one designed.
fn adc_covers_limit_cycle(instr: &Instrument, limit_cycle_hz: f64) -> Result<(), String> {
    let half = 0.5 / limit_cycle_hz;
    let tau = instr.inertia_dyn_cm_s2 / instr.damping_dyn_cm_s;
    let swing_rad = instr.full_torque_dyn_cm() / instr.damping_dyn_cm_s
        * (half - tau * (1.0 - (-half / tau).exp()));
    let full_scale_rad = 32768.0 * instr.theta_lsb_rad();
    if full_scale_rad >= swing_rad {
        return Ok(());
    }
    Err(format!(
        "the ADC's full scale is ±{:.3} µrad of pendulum angle (electronics.adc_full_scale_v / (pickoff.scale_factor_v_per_rad × electronics.amplifier_gain)), less than the pendulum's swing in one limit cycle, about {:.1} µrad peak to peak: the ADC would clip inside every limit cycle and the loop is not the linear one designed; expected electronics.amplifier_gain at most {:.0} (it is {}) or a larger electronics.adc_full_scale_v",
        full_scale_rad * 1e6,
        swing_rad * 1e6,
        (instr.amp_gain * full_scale_rad / swing_rad).floor(),
        instr.amp_gain
    ))
}

/// Smallest phase margin of a loop the simulator accepts, degrees.
pub const MIN_PHASE_MARGIN_DEG: f64 = 30.0;
/// Smallest gain margin of a loop the simulator accepts, dB.
pub const MIN_GAIN_MARGIN_DB: f64 = 6.0;
/// The crossover must stay below the limit-cycle frequency divided by this (the quantizer
/// acts as a gain only well below the limit cycle).
pub const LIMIT_CYCLE_TO_CROSSOVER: f64 = 4.0;

/// The loop an instrument file gives: the compensator designed for it (the configuration the
/// simulator runs) and its margins.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopCheck {
    /// The compensator for this instrument (`Config::DEFAULT` for the shipped file).
    pub config: Config,
    /// Margins of the linearised loop.
    pub margins: Margins,
    /// Limit-cycle frequency, Hz (clock / ticks per cycle).
    pub limit_cycle_hz: f64,
}

/// Design the compensator for `instr` and check that the loop is one the simulator can run:
/// ptsa-core accepts the coefficients, the loop has a gain crossover, the crossover lies
/// below the limit-cycle frequency over [`LIMIT_CYCLE_TO_CROSSOVER`], the ADC covers the
/// pendulum's swing in a limit cycle, and the phase and gain margins are at least
/// [`MIN_PHASE_MARGIN_DEG`] and [`MIN_GAIN_MARGIN_DB`].
///
/// # Errors
/// The reason the loop is refused, in the instrument file's terms.
pub fn check_loop(instr: &Instrument) -> Result<LoopCheck, String> {
    let d = Design::for_instrument(instr);
    let config = d.config();
    config.build().map_err(|e| {
        format!(
            "the compensator designed for this instrument (b0 {:.3}, b1 {:.3}, a1 {:.6}, ki {:.5}) is refused by ptsa-core: {e}",
            d.b0, d.b1, d.a1, d.ki
        )
    })?;
    let m = margins(instr, &config);
    let lc = instr.clock_hz / f64::from(config.ticks_per_cycle);
    if !m.crossover_hz.is_finite() {
        return Err("the loop has no gain crossover below the Nyquist frequency".into());
    }
    if m.crossover_hz > lc / LIMIT_CYCLE_TO_CROSSOVER {
        return Err(format!(
            "the loop's crossover ({:.1} Hz) is not well below its limit cycle ({lc:.1} Hz = clock_hz / {} ticks): expected a crossover below {:.1} Hz (raise electronics.clock_hz)",
            m.crossover_hz,
            config.ticks_per_cycle,
            lc / LIMIT_CYCLE_TO_CROSSOVER
        ));
    }
    adc_covers_limit_cycle(instr, lc)?;
    if !(m.phase_margin_deg >= MIN_PHASE_MARGIN_DEG && m.gain_margin_db >= MIN_GAIN_MARGIN_DB) {
        return Err(format!(
            "the loop is unstable or nearly so: phase margin {:.1} deg, gain margin {:.1} dB at {:.1} Hz crossover; expected at least {MIN_PHASE_MARGIN_DEG} deg and {MIN_GAIN_MARGIN_DB} dB",
            m.phase_margin_deg, m.gain_margin_db, m.crossover_hz
        ));
    }
    Ok(LoopCheck {
        config,
        margins: m,
        limit_cycle_hz: lc,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn design_reproduces_core_default_constants() {
        let d = Design::default_kearfott();
        assert_eq!(d.bits(), [362_602_752, -360_827_191, 64_262, 224_131]);
        assert_eq!(d.config(), Config::DEFAULT);
    }

    #[test]
    fn instrument_file_design_matches_default() {
        let i = Instrument::kearfott_2401();
        assert_eq!(Design::for_instrument(&i).config(), Config::DEFAULT);
    }

    #[test]
    fn default_loop_has_healthy_margins() {
        let i = Instrument::kearfott_2401();
        let m = margins(&i, &Config::DEFAULT);
        assert!((m.crossover_hz - 100.0).abs() < 15.0, "{m:?}");
        assert!(m.phase_margin_deg > 35.0, "{m:?}");
        assert!(m.gain_margin_db > 6.0, "{m:?}");
    }

    #[test]
    fn the_shipped_loop_is_accepted_and_nonsense_refused() {
        let i = Instrument::kearfott_2401();
        let c = check_loop(&i).unwrap();
        assert_eq!(c.config, Config::DEFAULT);
        assert!((c.limit_cycle_hz - 1000.0).abs() < 1e-9);
        let mut slow = i.clone();
        slow.clock_hz = 1000.0;
        let e = check_loop(&slow).unwrap_err();
        assert!(e.contains("limit cycle") || e.contains("refused"), "{e}");
    }

    #[test]
    fn underscore_formats_like_rust() {
        assert_eq!(underscore(362_602_752), "362_602_752");
        assert_eq!(underscore(-360_827_191), "-360_827_191");
        assert_eq!(underscore(224_131), "224_131");
        assert_eq!(underscore(5), "5");
    }
}
