//! The per-tick loop: compensator, ramp, forced-binary quantizer and pulse counter.

use core::num::Wrapping;

use crate::counter::Gate;
use crate::{
    COEF_FRAC, Config, ConfigError, INTEGRATOR_LIMIT, LEAD_LIMIT, Level, POLE_FRAC, RAMP_AMPLITUDE,
};

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
/// two) and gate timer, so a tick updates as few fields as possible.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct State {
    /// Previous compensator input `e[n-1]` (pickoff LSB).
    e_prev: i32,
    /// Lead output `lead[n-1]`, comparator LSB.
    lead: i32,
    /// Integrator, comparator LSB with `COEF_FRAC` extra fraction bits.
    integ: i64,
    /// Noise-shaping carry, comparator LSB, `|carry| <= h`.
    carry: i32,
    /// Free-running tick count (wraps; read as differences). `ticks mod N` is the index of
    /// the interval the next tick decides.
    ticks: Wrapping<u32>,
    /// Free-running pulse count (wraps; read as differences).
    pulses: Wrapping<u32>,
    /// Whether this cycle's current has switched to negative.
    switched: bool,
    /// Quantizer level `v = u + carry` latched at the switching tick.
    latched: i32,
    /// Positive ticks of the current cycle (set when it switches), or of the last closed
    /// cycle once it closes.
    cycle_pulses: u16,
    /// Value of `ticks` when the open gate opened.
    gate_open: Wrapping<u32>,
    /// Value of `pulses` when the open gate opened.
    gate_start: Wrapping<u32>,
    /// Saturation events.
    sat: Saturations,
}

impl State {
    /// The state after reset: filters at zero, at the start of a cycle and of a gate.
    pub const INITIAL: State = State {
        e_prev: 0,
        lead: 0,
        integ: 0,
        carry: 0,
        ticks: Wrapping(0),
        pulses: Wrapping(0),
        switched: false,
        latched: 0,
        cycle_pulses: 0,
        gate_open: Wrapping(0),
        gate_start: Wrapping(0),
        sat: Saturations {
            integrator: 0,
            output: 0,
            carry: 0,
        },
    };

    /// Return to [`State::INITIAL`].
    pub fn reset(&mut self) {
        *self = Self::INITIAL;
    }

    /// Saturation counters.
    #[must_use]
    pub fn saturations(&self) -> Saturations {
        self.sat
    }

    /// Free-running tick count since reset, modulo 2^32.
    #[must_use]
    pub fn total_ticks(&self) -> Wrapping<u32> {
        self.ticks
    }

    /// Free-running pulse count since reset, modulo 2^32. Read it as a difference of two
    /// readings less than 2^32 ticks apart: the wrap is then harmless.
    #[must_use]
    pub fn total_pulses(&self) -> Wrapping<u32> {
        self.pulses
    }

    /// Integrator value as a fraction of full scale.
    #[must_use]
    pub fn integrator(&self) -> Level {
        // |integ| <= INTEGRATOR_LIMIT, so the shifted value fits in i32.
        Level::from_bits(i32::try_from(self.integ >> COEF_FRAC).unwrap_or(0))
    }

    /// FNV-1a (64-bit) digest of the whole state, fields in declaration order, each as its
    /// little-endian bytes (`switched` as one byte, 1 = true).
    #[must_use]
    pub fn digest(&self) -> u64 {
        let mut h = Fnv::new();
        h.bytes(&self.e_prev.to_le_bytes());
        h.bytes(&self.lead.to_le_bytes());
        h.bytes(&self.integ.to_le_bytes());
        h.bytes(&self.carry.to_le_bytes());
        h.bytes(&self.ticks.0.to_le_bytes());
        h.bytes(&self.pulses.0.to_le_bytes());
        h.bytes(&[u8::from(self.switched)]);
        h.bytes(&self.latched.to_le_bytes());
        h.bytes(&self.cycle_pulses.to_le_bytes());
        h.bytes(&self.gate_open.0.to_le_bytes());
        h.bytes(&self.gate_start.0.to_le_bytes());
        h.bytes(&self.sat.integrator.to_le_bytes());
        h.bytes(&self.sat.output.to_le_bytes());
        h.bytes(&self.sat.carry.to_le_bytes());
        h.0
    }
}

impl Default for State {
    fn default() -> Self {
        Self::INITIAL
    }
}

struct Fnv(u64);

impl Fnv {
    const fn new() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= u64::from(x);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

/// A validated loop configuration with its derived constants. Immutable; the mutable part
/// is a [`State`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Ptsa {
    config: Config,
    n: u16,
    /// `N − 1`: `ticks & mask` is the interval index within the cycle.
    mask: u32,
    /// `h = R / N`: half a ramp step, comparator LSB.
    h: i32,
    b0: i32,
    b1: i32,
    a1: i32,
    ki: i32,
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
        let k = (s.ticks.0 & self.mask) as u16;
        k
    }

    /// The polarity most recently decided for `s` (`Positive` before the first tick).
    #[must_use]
    pub fn polarity(&self, s: &State) -> Polarity {
        let last_positive = if s.ticks.0 & self.mask == 0 {
            // The last interval closed a cycle: positive only if the whole cycle was.
            s.ticks.0 == 0 || s.cycle_pulses == self.n
        } else {
            !s.switched
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

    /// Compensator: lead section plus integrator, summed and clamped. Returns `u`.
    #[allow(
        clippy::inline_always,
        reason = "tick path: inlined into the firmware's TIM2 handler"
    )]
    #[inline(always)]
    fn compensate(&self, s: &mut State, x: i16) -> i32 {
        let e = i32::from(x);
        // Lead: acc (2^-16 LSB) = b0·e + b1·e' + a1·lead'; lead = round(acc / 2^16).
        let acc = i64::from(self.b0) * i64::from(e)
            + i64::from(self.b1) * i64::from(s.e_prev)
            + i64::from(self.a1) * i64::from(s.lead);
        let lead = (acc + (1 << (POLE_FRAC - 1))) >> POLE_FRAC;
        // |lead| <= LEAD_LIMIT = 2^30 is proven for every configuration `Ptsa::new` accepts
        // (ARITHMETIC.md, "Bounds"); the property tests run with this assertion enabled.
        debug_assert!(
            lead.abs() <= i64::from(LEAD_LIMIT),
            "lead bound violated: {lead}"
        );
        #[allow(
            clippy::cast_possible_truncation,
            reason = "|lead| <= 2^30, asserted above"
        )]
        let lead = lead as i32;
        s.lead = lead;
        s.e_prev = e;
        // Integrator with clamp (anti-windup).
        // Written as branches, each saturated arm counting its event (same values as a clamp
        // plus a count of `clamped != unclamped`).
        let integ = s.integ + i64::from(self.ki) * i64::from(e);
        s.integ = if integ > INTEGRATOR_LIMIT {
            s.sat.integrator = s.sat.integrator.wrapping_add(1);
            INTEGRATOR_LIMIT
        } else if integ < -INTEGRATOR_LIMIT {
            s.sat.integrator = s.sat.integrator.wrapping_add(1);
            -INTEGRATOR_LIMIT
        } else {
            integ
        };
        // Summing junction: |lead| <= 2^30 and |integ >> 16| <= 2^24, so no i32 overflow.
        #[allow(clippy::cast_possible_truncation, reason = "|integ >> 16| <= 2^24")]
        let sum = lead + (s.integ >> COEF_FRAC) as i32;
        if sum > RAMP_AMPLITUDE {
            s.sat.output = s.sat.output.wrapping_add(1);
            RAMP_AMPLITUDE
        } else if sum < -RAMP_AMPLITUDE {
            s.sat.output = s.sat.output.wrapping_add(1);
            -RAMP_AMPLITUDE
        } else {
            sum
        }
    }

    /// End of a limit cycle with `n` positive ticks: update the carry from the latched level.
    #[allow(
        clippy::inline_always,
        reason = "tick path: inlined into the firmware's TIM2 handler"
    )]
    #[inline(always)]
    fn close_cycle(&self, s: &mut State, n: u16) -> u16 {
        if self.config.noise_shaping {
            // Level whose ideal duty is n/N: y = h·(2n − N).
            let y = self.h * (2 * i32::from(n) - i32::from(self.n));
            let c = s.latched - y;
            // max/min rather than clamp: same result, and no "min <= max" panic path.
            s.carry = c.max(-self.h).min(self.h);
            s.sat.carry = s.sat.carry.wrapping_add(u32::from(s.carry != c));
        }
        s.switched = false;
        s.cycle_pulses = n;
        n
    }

    /// After `ticks` has advanced: the gate's counts if this tick closed it.
    #[allow(
        clippy::inline_always,
        reason = "tick path: inlined into the firmware's TIM2 handler"
    )]
    #[inline(always)]
    fn close_gate(&self, s: &mut State) -> Option<Gate> {
        if (s.ticks - s.gate_open).0 != self.config.gate_ticks {
            return None;
        }
        let g = Gate {
            pulses: (s.pulses - s.gate_start).0,
            ticks: self.config.gate_ticks,
        };
        s.gate_open = s.ticks;
        s.gate_start = s.pulses;
        Some(g)
    }

    /// One 64 kHz clock tick: take the newest pickoff sample `x` (ADC LSB) and decide the
    /// torquer polarity for the next clock interval.
    ///
    /// The order of operations is ARITHMETIC.md's "Tick order"; it never panics and never
    /// overflows for any `x` and any valid configuration.
    #[inline]
    #[allow(
        clippy::many_single_char_names,
        reason = "ARITHMETIC.md's notation: s, x, u, k, v"
    )]
    pub fn tick(&self, s: &mut State, x: i16) -> Tick {
        let u = self.compensate(s, x);
        let k = self.phase(s);
        let v = u + s.carry;
        if !s.switched && v + self.ramp(k) < 0 {
            s.switched = true;
            s.latched = v;
            s.cycle_pulses = k;
        }
        let positive = !s.switched;
        s.ticks += 1;
        s.pulses += u32::from(positive);
        let cycle_pulses = if s.ticks.0 & self.mask == 0 {
            let n = if positive {
                s.latched = v;
                self.n
            } else {
                s.cycle_pulses
            };
            Some(self.close_cycle(s, n))
        } else {
            None
        };
        Tick {
            polarity: if positive {
                Polarity::Positive
            } else {
                Polarity::Negative
            },
            cycle_pulses,
            gate: self.close_gate(s),
        }
    }

    /// Block form: run `input` through the loop and write one [`Tick`] per sample to `out`,
    /// which must have the same length.
    ///
    /// A second formulation of [`Ptsa::tick`], kept bit-identical by test: it steps the ramp
    /// by `−2h` instead of computing `h·(N − 1 − 2k)`, and counts the cycle's positive ticks
    /// one by one instead of taking them from the switching index.
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
    #[allow(
        clippy::many_single_char_names,
        reason = "ARITHMETIC.md's notation: s, x, u, k, v"
    )]
    pub fn process_block(&self, s: &mut State, input: &[i16], out: &mut [Tick]) {
        debug_assert_eq!(
            input.len(),
            out.len(),
            "process_block: input and output slices differ in length"
        );
        let mut k = self.phase(s);
        let mut ramp = self.ramp(k);
        // Positive ticks of the current cycle so far.
        let mut positive_ticks = if s.switched { s.cycle_pulses } else { k };
        for (&x, o) in input.iter().zip(out.iter_mut()) {
            let u = self.compensate(s, x);
            let v = u + s.carry;
            if !s.switched && v + ramp < 0 {
                s.switched = true;
                s.latched = v;
                s.cycle_pulses = positive_ticks;
            }
            let positive = !s.switched;
            positive_ticks += u16::from(positive);
            o.polarity = if positive {
                Polarity::Positive
            } else {
                Polarity::Negative
            };
            s.ticks += 1;
            s.pulses += u32::from(positive);
            k += 1;
            ramp -= 2 * self.h;
            o.cycle_pulses = None;
            if k == self.n {
                if positive {
                    s.latched = v;
                }
                o.cycle_pulses = Some(self.close_cycle(s, positive_ticks));
                k = 0;
                ramp = self.ramp(0);
                positive_ticks = 0;
            }
            o.gate = self.close_gate(s);
        }
    }
}
