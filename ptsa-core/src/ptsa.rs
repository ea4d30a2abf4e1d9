//! The per-tick loop: compensator, ramp, forced-binary quantizer and pulse counter.

use core::num::Wrapping;

use crate::counter::Gate;
use crate::lanes::Lanes;
use crate::{COEF_FRAC, Config, ConfigError, Level};

/// Sense of the torquer current for one clock tick.
///
/// `Positive` is the polarity whose ticks are data pulses. Its torque rebalances a positive
/// acceleration along IA: it drives the pendulum angle, and so the pickoff, negative.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Polarity {
    /// Data-pulse polarity (H-bridge leg A high, leg B low).
    Positive,
    /// The other polarity (leg A low, leg B high).
    Negative,
}

impl Polarity {
    /// `+1` or `-1`.
    #[must_use]
    pub const fn sign(self) -> i32 {
        match self {
            Self::Positive => 1,
            Self::Negative => -1,
        }
    }
}

impl From<bool> for Polarity {
    /// `true` is [`Polarity::Positive`], `false` [`Polarity::Negative`] (as embedded-hal's
    /// `PinState` maps `true` to `High`).
    ///
    /// ```
    /// use ptsa_core::Polarity;
    /// assert_eq!(Polarity::from(true), Polarity::Positive);
    /// assert_eq!(Polarity::from(false), Polarity::Negative);
    /// let positive_ticks = [true, true, false];
    /// assert_eq!(Polarity::from(positive_ticks[2]).sign(), -1);
    /// ```
    fn from(positive: bool) -> Self {
        if positive {
            Self::Positive
        } else {
            Self::Negative
        }
    }
}

impl core::ops::Not for Polarity {
    type Output = Self;

    /// The opposite polarity.
    ///
    /// ```
    /// use ptsa_core::Polarity;
    /// assert_eq!(!Polarity::Positive, Polarity::Negative);
    /// assert_eq!(!Polarity::Negative, Polarity::Positive);
    /// assert_eq!((!Polarity::Positive).sign(), -Polarity::Positive.sign());
    /// ```
    fn not(self) -> Self {
        match self {
            Self::Positive => Self::Negative,
            Self::Negative => Self::Positive,
        }
    }
}

/// Saturation events, each counted once per tick in which the clamp acted. Like the
/// free-running counts they wrap modulo 2^32; read them as differences.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Saturations {
    /// Integrator clamped to `±1.0` full scale (anti-windup acted).
    pub integrator: u32,
    /// Summing junction clamped to `±1.0` full scale.
    pub output: u32,
    /// Noise-shaping carry clamped to `±h` (only with `noise_shaping`).
    pub carry: u32,
}

/// Everything one tick decides.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Tick {
    /// Torquer polarity for the next clock interval.
    pub polarity: Polarity,
    /// When this tick decided the last interval of a limit cycle: that cycle's count of
    /// positive ticks (data pulses), `0..=N`.
    pub cycle_pulses: Option<u16>,
    /// When this tick closed a gate: its pulse and tick counts.
    pub gate: Option<Gate>,
}

/// The loop's mutable state. Plain data: `Clone`, `Eq`, and a documented [`State::digest`].
///
/// One free-running tick count serves as clock, cycle phase (`ticks mod N`, N a power of
/// two) and gate timer, so a tick updates as few fields as possible. A `State` is one lane of
/// [`Lanes`] (the fields are listed there, in [`State::digest`]'s order): the tick is written
/// once, for any number of loops side by side, and one loop is one lane.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct State(pub(crate) Lanes<1>);

impl State {
    /// The state after reset: filters at zero, at the start of a cycle and of a gate.
    pub const INITIAL: State = State(Lanes::INITIAL);

    /// Return to [`State::INITIAL`].
    pub fn reset(&mut self) {
        *self = Self::INITIAL;
    }

    /// Saturation counters.
    #[must_use]
    pub fn saturations(&self) -> Saturations {
        Saturations {
            integrator: self.0.sat_integrator[0].cast_unsigned(),
            output: self.0.sat_output[0].cast_unsigned(),
            carry: self.0.sat_carry[0].cast_unsigned(),
        }
    }

    /// Free-running tick count since reset, modulo 2^32.
    #[must_use]
    pub fn total_ticks(&self) -> Wrapping<u32> {
        Wrapping(self.0.ticks[0].cast_unsigned())
    }

    /// Free-running pulse count since reset, modulo 2^32. Read it as a difference of two
    /// readings less than 2^32 ticks apart: the wrap is then harmless.
    #[must_use]
    pub fn total_pulses(&self) -> Wrapping<u32> {
        Wrapping(self.0.pulses[0].cast_unsigned())
    }

    /// Integrator value as a fraction of full scale.
    #[must_use]
    pub fn integrator(&self) -> Level {
        // |integ| <= INTEGRATOR_LIMIT, so the shifted value fits in i32.
        Level::from_bits(i32::try_from(self.0.integ[0] >> COEF_FRAC).unwrap_or(0))
    }

    /// FNV-1a (64-bit) digest of the whole state, fields in declaration order (`e_prev`,
    /// `lead`, `integ`, `carry`, `ticks`, `pulses`, `switched`, `latched`, `cycle_pulses`,
    /// `gate_open`, `gate_start`, the integrator, output and carry saturation counts), each
    /// as its little-endian bytes (`switched` as one byte, 1 = true).
    #[must_use]
    pub fn digest(&self) -> u64 {
        let s = &self.0;
        let mut h = Fnv::new();
        h.bytes(&s.e_prev[0].to_le_bytes());
        h.bytes(&s.lead[0].to_le_bytes());
        h.bytes(&s.integ[0].to_le_bytes());
        h.bytes(&s.carry[0].to_le_bytes());
        h.bytes(&s.ticks[0].to_le_bytes());
        h.bytes(&s.pulses[0].to_le_bytes());
        h.bytes(&[u8::from(s.switched[0])]);
        h.bytes(&s.latched[0].to_le_bytes());
        // 0..=N: the count's `u16` (the counters' `i32` lanes hold their `u32` bits).
        #[allow(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "0..=N"
        )]
        h.bytes(&(s.cycle_pulses[0] as u16).to_le_bytes());
        h.bytes(&s.gate_open[0].to_le_bytes());
        h.bytes(&s.gate_start[0].to_le_bytes());
        h.bytes(&s.sat_integrator[0].to_le_bytes());
        h.bytes(&s.sat_output[0].to_le_bytes());
        h.bytes(&s.sat_carry[0].to_le_bytes());
        h.finish()
    }
}

impl Default for State {
    fn default() -> Self {
        Self::INITIAL
    }
}

/// FNV-1a, 64 bits: the digest of [`State::digest`], for anything that wants the same
/// stable, dependency-free hash of bytes (the host's simulation seed of a record).
#[derive(Clone, Copy, Debug)]
pub struct Fnv(u64);

impl Fnv {
    /// The empty digest (the FNV-1a offset basis).
    #[must_use]
    pub const fn new() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }

    /// Fold `b` in, byte by byte.
    pub fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= u64::from(x);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    /// The digest of everything folded in so far.
    #[must_use]
    pub const fn finish(self) -> u64 {
        self.0
    }
}

impl Default for Fnv {
    fn default() -> Self {
        Self::new()
    }
}

/// A validated loop configuration with its derived constants. Immutable; the mutable part
/// is a [`State`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Ptsa {
    pub(crate) config: Config,
    pub(crate) n: u16,
    /// `N − 1`: `ticks & mask` is the interval index within the cycle.
    pub(crate) mask: u32,
    /// `h = R / N`: half a ramp step, comparator LSB.
    pub(crate) h: i32,
    pub(crate) b0: i32,
    pub(crate) b1: i32,
    pub(crate) a1: i32,
    pub(crate) ki: i32,
}

impl Ptsa {
    /// Validate `config` and derive the tick's constants.
    ///
    /// # Errors
    /// See [`ConfigError`].
    pub fn new(config: Config) -> Result<Self, ConfigError> {
        config.validate()?;
        Ok(Self {
            config,
            n: config.ticks_per_cycle,
            mask: u32::from(config.ticks_per_cycle) - 1,
            h: config.half_step(),
            b0: config.b0.to_bits(),
            b1: config.b1.to_bits(),
            a1: config.a1.to_bits(),
            ki: config.ki.to_bits(),
        })
    }

    /// The configuration this loop was built from.
    #[must_use]
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The reset state.
    #[must_use]
    pub fn initial_state(&self) -> State {
        State::INITIAL
    }

    /// Index of the interval the next tick of `s` decides within the limit cycle, `0..N`.
    #[must_use]
    pub fn phase(&self, s: &State) -> u16 {
        #[allow(clippy::cast_possible_truncation, reason = "mask < 4096")]
        let k = (s.0.ticks[0].cast_unsigned() & self.mask) as u16;
        k
    }

    /// The polarity most recently decided for `s` (`Positive` before the first tick).
    #[must_use]
    pub fn polarity(&self, s: &State) -> Polarity {
        let last_positive = if s.0.ticks[0].cast_unsigned() & self.mask == 0 {
            // The last interval closed a cycle: positive only if the whole cycle was.
            s.0.ticks[0] == 0 || s.0.cycle_pulses[0] == i32::from(self.n)
        } else {
            !s.0.switched[0]
        };
        if last_positive {
            Polarity::Positive
        } else {
            Polarity::Negative
        }
    }

    /// Ramp value for interval `k` of the cycle: `r[k] = h·(N − 1 − 2k)`, from `R − h` down
    /// to `−R + h`, comparator LSB.
    #[must_use]
    pub fn ramp(&self, k: u16) -> i32 {
        self.h * (i32::from(self.n) - 1 - 2 * i32::from(k))
    }

    /// One 64 kHz clock tick: take the newest pickoff sample `x` (ADC LSB) and decide the
    /// torquer polarity for the next clock interval.
    ///
    /// The order of operations is ARITHMETIC.md's "Tick order"; it never panics and never
    /// overflows for any `x` and any valid configuration.
    #[inline(always)]
    #[allow(
        clippy::inline_always,
        reason = "the tick path: the firmware's TIM2 handler and the host's loops, where a call \
                  per tick with the lanes' result in memory cost a fifth of the host's speed"
    )]
    pub fn tick(&self, s: &mut State, x: i16) -> Tick {
        // The tick is written once, for any number of loops side by side (`lanes.rs`); a
        // `State` is one lane.
        self.tick_lanes(&mut s.0, &[x]).get(0)
    }

    /// Block form: run `input` through the loop and write one [`Tick`] per sample to `out`,
    /// which must have the same length; the same as [`Ptsa::tick`] sample by sample.
    ///
    /// ```
    /// use ptsa_core::{Config, Polarity, Tick};
    /// let ptsa = Config::DEFAULT.build().unwrap();
    /// let mut state = ptsa.initial_state();
    /// let input = [0i16; 64];
    /// let mut out = [Tick { polarity: Polarity::Negative, cycle_pulses: None, gate: None }; 64];
    /// ptsa.process_block(&mut state, &input, &mut out);
    /// assert_eq!(out[63].cycle_pulses, Some(32));
    /// ```
    ///
    /// # Panics
    /// In builds with debug assertions, if `input.len() != out.len()`. Without them the
    /// loop runs over the shorter of the two and leaves the rest of `out` untouched.
    pub fn process_block(&self, s: &mut State, input: &[i16], out: &mut [Tick]) {
        debug_assert_eq!(
            input.len(),
            out.len(),
            "process_block: input and output slices differ in length"
        );
        for (&x, o) in input.iter().zip(out.iter_mut()) {
            *o = self.tick(s, x);
        }
    }
}
