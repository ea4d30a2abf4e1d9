//! Loop configuration and its validation.

use fixed::types::extra::{U16, U24};
use fixed::{FixedI32, FixedU32};

use crate::{LEAD_LIMIT, MAX_TICKS_PER_CYCLE, POLE_FRAC, Ptsa, RAMP_AMPLITUDE};

/// Per-sample gain, Q15.16: comparator LSBs per pickoff LSB (`b0`, `b1`, `ki`).
pub type Coef = FixedI32<U16>;

/// Lead pole, Q15.16: dimensionless, `|a1| < 1` for a stable section (resolution 2^-16,
/// i.e. a pole frequency resolved to 0.1% at 200 Hz on a 64 kHz clock).
pub type Pole = FixedI32<U16>;

/// A comparator-domain value, Q7.24: `1.0` is the ramp amplitude, i.e. the loop's full scale.
pub type Level = FixedI32<U24>;

/// Configuration of the PTSA digital loop.
///
/// All coefficients are exact fixed-point values; [`Config::build`] checks them and derives
/// the constants of the tick. See `ARITHMETIC.md` for the equations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Clock ticks per limit cycle `N`: a power of two from 2 to
    /// [`MAX_TICKS_PER_CYCLE`]. 64 gives the PTSA's 1 kHz cycle on a 64 kHz clock.
    pub ticks_per_cycle: u16,
    /// Lead section, gain on the newest sample.
    pub b0: Coef,
    /// Lead section, gain on the previous sample.
    pub b1: Coef,
    /// Lead section, feedback on its previous output (the pole).
    pub a1: Pole,
    /// Integral gain per tick.
    pub ki: Coef,
    /// Preset of the counting gate in clock ticks (`T` of eqs. 6.1-6.4), at least 1.
    pub gate_ticks: u32,
    /// Carry each cycle's quantization residual into the next cycle (first-order noise
    /// shaping of the duty cycle). Off in the PTSA hardware; off by default.
    pub noise_shaping: bool,
}

/// Why a [`Config`] was refused.
///
/// Non-exhaustive: a later version may refuse a configuration for a new reason, so a
/// `match` on it needs a wildcard arm.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ConfigError {
    /// `ticks_per_cycle` is not a power of two in `2..=4096`.
    TicksPerCycle(u16),
    /// `|a1| >= 1`: the lead section is not stable on its own.
    UnstableLead,
    /// `b0 + b1 < 0` or `ki < 0`: the compensator would feed back positively at DC.
    WrongSign,
    /// The lead section could exceed [`LEAD_LIMIT`] for some input stream.
    LeadOverflow {
        /// Worst-case bound of the lead output, in comparator LSBs.
        bound: u64,
    },
    /// `gate_ticks` is zero.
    EmptyGate,
}

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::TicksPerCycle(n) => write!(
                f,
                "ticks_per_cycle = {n}: expected a power of two from 2 to {MAX_TICKS_PER_CYCLE}"
            ),
            Self::UnstableLead => write!(f, "lead pole |a1| >= 1: the section is unstable"),
            Self::WrongSign => write!(
                f,
                "b0 + b1 < 0 or ki < 0: the compensator would feed back positively"
            ),
            Self::LeadOverflow { bound } => write!(
                f,
                "lead section can reach {bound} comparator LSB, above the limit {LEAD_LIMIT}"
            ),
            Self::EmptyGate => write!(f, "gate_ticks = 0: the gate must be at least one tick"),
        }
    }
}

impl core::error::Error for ConfigError {}

impl Config {
    /// The default loop: 64 ticks per cycle, 100 Hz crossover on the Kearfott 2401 at the
    /// documented pickoff scale, 1 s gate at 64 kHz, no noise shaping.
    ///
    /// The coefficients are the output of the design in `ptsa-sim` (`ptsa design`),
    /// rounded to their formats; a test there recomputes them and checks these literals.
    pub const DEFAULT: Config = Config {
        ticks_per_cycle: 64,
        b0: Coef::from_bits(DEFAULT_B0_BITS),
        b1: Coef::from_bits(DEFAULT_B1_BITS),
        a1: Pole::from_bits(DEFAULT_A1_BITS),
        ki: Coef::from_bits(DEFAULT_KI_BITS),
        gate_ticks: 64_000,
        noise_shaping: false,
    };

    /// Validate and build the loop.
    ///
    /// # Errors
    /// A [`ConfigError`] saying which rule the configuration breaks. Never panics.
    pub fn build(self) -> Result<Ptsa, ConfigError> {
        Ptsa::new(self)
    }

    /// Worst-case `|lead|` in comparator LSBs over every input stream (see ARITHMETIC.md,
    /// "Bounds"): the l1 norm of the section's impulse response times the largest
    /// `|e| = 2^15`, plus the accumulated rounding `1/2 / (1 - |a1|)`:
    /// `|b0|·2^15 + |b0·a1 + b1|·2^15 / (1 - |a1|) + 1/2 / (1 - |a1|)`, rounded up.
    ///
    /// Returns `None` when `|a1| >= 1`, where no bound exists.
    ///
    /// ```
    /// use ptsa_core::{Coef, Config, Pole};
    /// // A pure gain of 1 comparator LSB per pickoff LSB: |lead| <= 32768 (+1 for rounding).
    /// let c = Config { b0: Coef::ONE, b1: Coef::ZERO, a1: Pole::ZERO, ..Config::DEFAULT };
    /// assert_eq!(c.lead_bound(), Some(32769));
    /// ```
    #[must_use]
    pub fn lead_bound(&self) -> Option<u64> {
        let a = i128::from(self.a1.to_bits());
        let one = 1i128 << POLE_FRAC;
        if a.abs() >= one {
            return None;
        }
        let b0 = i128::from(self.b0.to_bits());
        let b1 = i128::from(self.b1.to_bits());
        // F = POLE_FRAC = COEF_FRAC = 16.
        let tail = (b0 * a + (b1 << POLE_FRAC)).unsigned_abs(); // |b0·a1 + b1|, Q2F
        let d = (one - a.abs()).unsigned_abs(); // 1 - |a1|, QF
        let b0 = b0.unsigned_abs(); // |b0|, QF
        // bound = 2^15·(b0/2^F + tail/2^2F / (d/2^F)) + 2^-1 / (d/2^F)
        //       = (b0·d + tail + 2^F) / (2·d)      (with F = 16, 2^15 = 2^(F-1))
        let num = b0 * d + tail + (1u128 << POLE_FRAC);
        let bound = num.div_ceil(2 * d);
        Some(u64::try_from(bound).unwrap_or(u64::MAX))
    }

    pub(crate) fn validate(&self) -> Result<(), ConfigError> {
        let n = self.ticks_per_cycle;
        if !(2..=MAX_TICKS_PER_CYCLE).contains(&n) || !n.is_power_of_two() {
            return Err(ConfigError::TicksPerCycle(n));
        }
        let bound = self.lead_bound().ok_or(ConfigError::UnstableLead)?;
        if i64::from(self.b0.to_bits()) + i64::from(self.b1.to_bits()) < 0 || self.ki < 0 {
            return Err(ConfigError::WrongSign);
        }
        if bound > LEAD_LIMIT as u64 {
            return Err(ConfigError::LeadOverflow { bound });
        }
        if self.gate_ticks == 0 {
            return Err(ConfigError::EmptyGate);
        }
        Ok(())
    }

    /// Half of one ramp step, `h = R / N`, in comparator LSBs.
    pub(crate) fn half_step(&self) -> i32 {
        RAMP_AMPLITUDE / i32::from(self.ticks_per_cycle)
    }

    /// The duty cycle the quantizer produces for a constant level `v` (compensator output
    /// plus carry), as a count of positive ticks in one cycle:
    /// `n = clamp(floor((v + h·(N+1)) / (2h)), 0, N)` with `h = R/N`.
    ///
    /// ```
    /// use ptsa_core::{Config, Level};
    /// let c = Config::DEFAULT;
    /// assert_eq!(c.positive_ticks_for(Level::ZERO), 32);
    /// assert_eq!(c.positive_ticks_for(Level::ONE), 64);
    /// assert_eq!(c.positive_ticks_for(-Level::ONE), 0);
    /// // Half a step below the midpoint of 33 and 32 ticks rounds up (ties to +inf).
    /// assert_eq!(c.positive_ticks_for(Level::from_num(1.0 / 64.0)), 33);
    /// assert_eq!(c.positive_ticks_for(Level::from_bits((1 << 18) - 1)), 32);
    /// ```
    #[must_use]
    pub fn positive_ticks_for(&self, v: Level) -> u16 {
        let h = i64::from(self.half_step());
        let n = i64::from(self.ticks_per_cycle);
        let k = (i64::from(v.to_bits()) + h * (n + 1)).div_euclid(2 * h);
        u16::try_from(k.clamp(0, n)).unwrap_or(0)
    }

    /// Limit-cycle frequency in hertz as an exact ratio for a given clock: `clock_hz / N`.
    #[must_use]
    pub fn cycle_frequency(&self, clock_hz: u32) -> FixedU32<U16> {
        FixedU32::<U16>::from_num(clock_hz) / u32::from(self.ticks_per_cycle)
    }
}

impl Default for Config {
    fn default() -> Self {
        Self::DEFAULT
    }
}

// Default compensator, Q15.16 bits. Recomputed and checked by `ptsa-sim`'s
// design test; do not edit by hand (run `ptsa design --print-core-constants`).
const DEFAULT_B0_BITS: i32 = 362_602_752;
const DEFAULT_B1_BITS: i32 = -360_827_191;
const DEFAULT_A1_BITS: i32 = 64_262;
const DEFAULT_KI_BITS: i32 = 224_131;
