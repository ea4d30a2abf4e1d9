//! The tick, once, for `L` loops side by side.
//!
//! [`Ptsa::tick_lanes`] is the loop's per-tick arithmetic (compensator, ramp, quantizer,
//! counters; ARITHMETIC.md's "Tick order") written over `L` lanes in structure of arrays,
//! [`Lanes`]: the common path of a tick is a loop over the lanes with no branch inside it
//! (range tests as `&`/`|`, the quantizer's latch as selects), so that a compiler can run
//! several lanes per SIMD instruction. The rare steps (the integrator and junction clamps,
//! the quantizer's switch, the end of a limit cycle, the end of a gate) run only when some
//! lane needs them, each behind one test that the compiler is told seldom holds
//! (`cold_path`), and the ramp compare only while some lane has not switched in its cycle.
//! With one lane those tests are the scalar loop's own branches and the rare steps stay out
//! of its straight-line path; with many, one test serves all lanes (lanes started together
//! are in step, so a cycle or gate end is the same branch for all of them).
//!
//! [`Ptsa::tick`], the form the firmware runs, *is* this function with one lane: a [`State`]
//! is a [`Lanes<1>`] (the firmware's instruction budget and the golden vectors check that
//! nothing else changed). A host that
//! runs many independent loops (`ptsa-host-sim`'s batch engine) runs them through the same
//! definition with `L` = 4 or 8.

#![allow(
    clippy::manual_clamp,
    reason = "max/min, not clamp: the same values without clamp's `min <= max` panic path"
)]
#![allow(
    clippy::needless_range_loop,
    reason = "a lane index walks several arrays in step: the structure of arrays"
)]
#![allow(
    clippy::needless_bitwise_bool,
    clippy::manual_range_contains,
    reason = "branch-free on purpose: `&` and `|` on lanes vectorise, `&&` would branch"
)]

use core::num::Wrapping;

use crate::counter::Gate;
use crate::ptsa::{Polarity, Ptsa, State, Tick};
use crate::{COEF_FRAC, INTEGRATOR_LIMIT, LEAD_LIMIT, POLE_FRAC, RAMP_AMPLITUDE};

/// The state of `L` loops, structure of arrays: lane `l` of every field is one [`State`]
/// ([`Lanes::get`], [`Lanes::set`]). Plain data.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Lanes<const L: usize> {
    pub(crate) e_prev: [i32; L],
    pub(crate) lead: [i32; L],
    pub(crate) integ: [i64; L],
    pub(crate) carry: [i32; L],
    pub(crate) ticks: [u32; L],
    pub(crate) pulses: [u32; L],
    pub(crate) switched: [bool; L],
    pub(crate) latched: [i32; L],
    pub(crate) cycle_pulses: [u16; L],
    pub(crate) gate_open: [u32; L],
    pub(crate) gate_start: [u32; L],
    pub(crate) sat_integrator: [u32; L],
    pub(crate) sat_output: [u32; L],
    pub(crate) sat_carry: [u32; L],
}

impl<const L: usize> Lanes<L> {
    /// `L` loops after reset ([`State::INITIAL`] in every lane).
    pub const INITIAL: Self = Self {
        e_prev: [0; L],
        lead: [0; L],
        integ: [0; L],
        carry: [0; L],
        ticks: [0; L],
        pulses: [0; L],
        switched: [false; L],
        latched: [0; L],
        cycle_pulses: [0; L],
        gate_open: [0; L],
        gate_start: [0; L],
        sat_integrator: [0; L],
        sat_output: [0; L],
        sat_carry: [0; L],
    };

    /// `L` loops in `states`, lane `l` from `states[l]`.
    #[must_use]
    #[inline(always)]
    #[allow(
        clippy::inline_always,
        reason = "tick path: the firmware's TIM2 handler"
    )]
    pub fn new(states: &[State; L]) -> Self {
        let mut s = Self::INITIAL;
        for (l, st) in states.iter().enumerate() {
            s.set(l, st);
        }
        s
    }

    /// Lane `l` as a [`State`].
    ///
    /// # Panics
    /// If `l >= L`.
    #[must_use]
    #[inline(always)]
    #[allow(
        clippy::inline_always,
        reason = "tick path: the firmware's TIM2 handler"
    )]
    pub fn get(&self, l: usize) -> State {
        let mut one = Lanes::<1>::INITIAL;
        one.e_prev[0] = self.e_prev[l];
        one.lead[0] = self.lead[l];
        one.integ[0] = self.integ[l];
        one.carry[0] = self.carry[l];
        one.ticks[0] = self.ticks[l];
        one.pulses[0] = self.pulses[l];
        one.switched[0] = self.switched[l];
        one.latched[0] = self.latched[l];
        one.cycle_pulses[0] = self.cycle_pulses[l];
        one.gate_open[0] = self.gate_open[l];
        one.gate_start[0] = self.gate_start[l];
        one.sat_integrator[0] = self.sat_integrator[l];
        one.sat_output[0] = self.sat_output[l];
        one.sat_carry[0] = self.sat_carry[l];
        State(one)
    }

    /// Make lane `l` the state `s`.
    ///
    /// # Panics
    /// If `l >= L`.
    #[inline(always)]
    #[allow(
        clippy::inline_always,
        reason = "tick path: the firmware's TIM2 handler"
    )]
    pub fn set(&mut self, l: usize, s: &State) {
        let one = &s.0;
        self.e_prev[l] = one.e_prev[0];
        self.lead[l] = one.lead[0];
        self.integ[l] = one.integ[0];
        self.carry[l] = one.carry[0];
        self.ticks[l] = one.ticks[0];
        self.pulses[l] = one.pulses[0];
        self.switched[l] = one.switched[0];
        self.latched[l] = one.latched[0];
        self.cycle_pulses[l] = one.cycle_pulses[0];
        self.gate_open[l] = one.gate_open[0];
        self.gate_start[l] = one.gate_start[0];
        self.sat_integrator[l] = one.sat_integrator[0];
        self.sat_output[l] = one.sat_output[0];
        self.sat_carry[l] = one.sat_carry[0];
    }

    /// The free-running pulse count of lane `l` (see [`State::total_pulses`]).
    #[must_use]
    #[inline(always)]
    #[allow(clippy::inline_always, reason = "per-tick path of the host's lanes")]
    pub fn total_pulses(&self, l: usize) -> Wrapping<u32> {
        Wrapping(self.pulses[l])
    }
}

/// What one tick decided in each of `L` lanes ([`Ptsa::tick_lanes`]); lane `l` as a [`Tick`]
/// is [`LaneTicks::get`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LaneTicks<const L: usize> {
    /// Polarity decided for the next interval: `true` = [`Polarity::Positive`].
    pub positive: [bool; L],
    /// Whether the tick closed a limit cycle.
    pub cycle_end: [bool; L],
    /// With `cycle_end`: that cycle's positive ticks, `0..=N`.
    pub cycle_pulses: [u16; L],
    /// Whether the tick closed a gate.
    pub gate_end: [bool; L],
    /// With `gate_end`: the gate's pulse count.
    pub gate_pulses: [u32; L],
    /// The gate length, ticks.
    pub gate_ticks: u32,
}

impl<const L: usize> LaneTicks<L> {
    /// Lane `l` as a [`Tick`].
    ///
    /// # Panics
    /// If `l >= L`.
    #[must_use]
    #[inline(always)]
    #[allow(
        clippy::inline_always,
        reason = "tick path: the firmware's TIM2 handler"
    )]
    pub fn get(&self, l: usize) -> Tick {
        Tick {
            polarity: Polarity::from(self.positive[l]),
            cycle_pulses: if self.cycle_end[l] {
                Some(self.cycle_pulses[l])
            } else {
                None
            },
            gate: if self.gate_end[l] {
                Some(Gate {
                    pulses: self.gate_pulses[l],
                    ticks: self.gate_ticks,
                })
            } else {
                None
            },
        }
    }
}

/// Whether any of `m` is true.
#[inline(always)]
#[allow(clippy::inline_always, reason = "tick path")]
fn any<const L: usize>(m: &[bool; L]) -> bool {
    m.iter().fold(false, |a, &b| a | b)
}

/// Marks the path that calls it as seldom taken, as `core::hint::cold_path` does from Rust
/// 1.95 on (this crate's MSRV is older): rustc weighs a branch into a block that calls a
/// `#[cold]` function as unlikely, and the compiler keeps such a step behind its branch
/// instead of computing it on every tick.
#[cold]
const fn cold_path() {}

/// The signed integers of the tick's two clamps.
trait Signed:
    Copy + PartialOrd + core::ops::Neg<Output = Self> + core::ops::BitXor<Output = Self>
{
    /// All ones where negative, else zero.
    fn sign_mask(self) -> Self;
    /// `self − rhs`; never overflows here (a limit and a sign mask).
    fn minus(self, rhs: Self) -> Self;
}

impl Signed for i32 {
    #[inline(always)]
    #[allow(clippy::inline_always, reason = "tick path")]
    fn sign_mask(self) -> Self {
        self >> 31
    }
    #[inline(always)]
    #[allow(clippy::inline_always, reason = "tick path")]
    fn minus(self, rhs: Self) -> Self {
        self.wrapping_sub(rhs)
    }
}

impl Signed for i64 {
    #[inline(always)]
    #[allow(clippy::inline_always, reason = "tick path")]
    fn sign_mask(self) -> Self {
        self >> 63
    }
    #[inline(always)]
    #[allow(clippy::inline_always, reason = "tick path")]
    fn minus(self, rhs: Self) -> Self {
        self.wrapping_sub(rhs)
    }
}

/// `a` clamped to `-limit..=limit` where `beyond` says that it lies outside, else `a`. Once
/// the clamp is known to act, the bound is the limit with `a`'s sign: `(limit ^ m) − m` with
/// `m` the sign mask of `a` (`-limit` = `!limit + 1`).
#[inline(always)]
#[allow(clippy::inline_always, reason = "tick path")]
fn limit<T: Signed>(a: T, beyond: bool, limit: T) -> T {
    let m = a.sign_mask();
    let bound = (limit ^ m).minus(m);
    if beyond { bound } else { a }
}

/// Whether `a` lies outside `-limit..=limit`.
#[inline(always)]
#[allow(clippy::inline_always, reason = "tick path")]
fn beyond<T: Signed>(a: T, limit: T) -> bool {
    (a > limit) | (a < -limit)
}

impl Ptsa {
    /// One 64 kHz clock tick of `L` loops: lane `l` takes the pickoff sample `x[l]` (ADC
    /// LSB) and decides its torquer polarity for the next interval, exactly as
    /// [`Ptsa::tick`] does for one loop (which is this function with `L = 1`).
    ///
    /// ```
    /// use ptsa_core::{Config, Lanes};
    /// let ptsa = Config::DEFAULT.build().unwrap();
    /// let (mut one, mut four) = (ptsa.initial_state(), Lanes::new(&[ptsa.initial_state(); 4]));
    /// for k in 0..1000i16 {
    ///     let x = [k, -k, 3 * k, 0];
    ///     let t = ptsa.tick_lanes(&mut four, &x);
    ///     assert_eq!(t.get(1), ptsa.tick(&mut one, -k));
    /// }
    /// assert_eq!(four.get(1), one);
    /// ```
    #[inline(always)]
    #[allow(
        clippy::inline_always,
        reason = "tick path: inlined into the firmware's TIM2 handler and the host's lanes"
    )]
    pub fn tick_lanes<const L: usize>(&self, s: &mut Lanes<L>, x: &[i16; L]) -> LaneTicks<L> {
        let u = self.compensate_lanes(s, x);
        let (v, positive) = self.quantize_lanes(s, &u);
        // The end of a limit cycle and the end of a gate, each a rare step.
        let mut cycle_end = [false; L];
        for l in 0..L {
            cycle_end[l] = s.ticks[l] & self.mask == 0;
        }
        if any(&cycle_end) {
            cold_path();
            self.close_cycles(s, &v, &positive, &cycle_end);
        }
        let mut gate_end = [false; L];
        let mut gate_pulses = [0u32; L];
        let gate_ticks = self.config.gate_ticks;
        for l in 0..L {
            gate_end[l] = s.ticks[l].wrapping_sub(s.gate_open[l]) == gate_ticks;
        }
        if any(&gate_end) {
            cold_path();
            for l in 0..L {
                let g = gate_end[l];
                gate_pulses[l] = s.pulses[l].wrapping_sub(s.gate_start[l]);
                s.gate_open[l] = if g { s.ticks[l] } else { s.gate_open[l] };
                s.gate_start[l] = if g { s.pulses[l] } else { s.gate_start[l] };
            }
        }
        LaneTicks {
            positive,
            cycle_end,
            cycle_pulses: s.cycle_pulses,
            gate_end,
            gate_pulses,
            gate_ticks,
        }
    }

    /// The compensator (ARITHMETIC.md's steps 2–4): lead section plus integrator, summed
    /// and clamped; returns the junction's output `u` of each lane.
    #[inline(always)]
    #[allow(clippy::inline_always, reason = "tick path")]
    fn compensate_lanes<const L: usize>(&self, s: &mut Lanes<L>, x: &[i16; L]) -> [i32; L] {
        let mut lead = [0i32; L];
        let mut over = [false; L];
        for l in 0..L {
            let e = i32::from(x[l]);
            // Lead: acc (2^-16 LSB) = b0·e + b1·e' + a1·lead'; lead = round(acc / 2^16).
            let acc = i64::from(self.b0) * i64::from(e)
                + i64::from(self.b1) * i64::from(s.e_prev[l])
                + i64::from(self.a1) * i64::from(s.lead[l]);
            let wide = (acc + (1 << (POLE_FRAC - 1))) >> POLE_FRAC;
            // |lead| <= LEAD_LIMIT = 2^30 is proven for every configuration `Ptsa::new`
            // accepts (ARITHMETIC.md, "Bounds"); the property tests run with this assertion.
            debug_assert!(
                wide.abs() <= i64::from(LEAD_LIMIT),
                "lead bound violated: {wide}"
            );
            #[allow(
                clippy::cast_possible_truncation,
                reason = "|lead| <= 2^30, asserted above"
            )]
            let narrow = wide as i32;
            lead[l] = narrow;
            s.lead[l] = narrow;
            s.e_prev[l] = e;
            let integ = s.integ[l] + i64::from(self.ki) * i64::from(e);
            s.integ[l] = integ;
            over[l] = beyond(integ, INTEGRATOR_LIMIT);
        }
        // Integrator clamp (anti-windup), counting a tick in which it acted.
        if any(&over) {
            cold_path();
            for l in 0..L {
                s.integ[l] = limit(s.integ[l], over[l], INTEGRATOR_LIMIT);
                s.sat_integrator[l] = s.sat_integrator[l].wrapping_add(u32::from(over[l]));
            }
        }
        let mut u = [0i32; L];
        for l in 0..L {
            // Summing junction: |lead| <= 2^30 and |integ >> 16| <= 2^24, no i32 overflow.
            #[allow(clippy::cast_possible_truncation, reason = "|integ >> 16| <= 2^24")]
            let sum = lead[l] + (s.integ[l] >> COEF_FRAC) as i32;
            u[l] = sum;
            over[l] = beyond(sum, RAMP_AMPLITUDE);
        }
        if any(&over) {
            cold_path();
            for l in 0..L {
                u[l] = limit(u[l], over[l], RAMP_AMPLITUDE);
                s.sat_output[l] = s.sat_output[l].wrapping_add(u32::from(over[l]));
            }
        }
        u
    }

    /// Ramp, forced-binary quantizer and counters (steps 5–6): the first interval of the
    /// cycle in which `v + r[k] < 0` switches the current negative for the rest of the
    /// cycle. Returns each lane's level `v = u + carry` and whether its next interval is
    /// positive; the tick and pulse counts have advanced.
    #[inline(always)]
    #[allow(clippy::inline_always, reason = "tick path")]
    #[allow(
        clippy::many_single_char_names,
        reason = "ARITHMETIC.md's notation: u, v, k"
    )]
    fn quantize_lanes<const L: usize>(
        &self,
        s: &mut Lanes<L>,
        u: &[i32; L],
    ) -> ([i32; L], [bool; L]) {
        let mut v = [0i32; L];
        let mut k = [0u16; L];
        let mut open = [false; L];
        for l in 0..L {
            #[allow(clippy::cast_possible_truncation, reason = "mask < 4096")]
            let kl = (s.ticks[l] & self.mask) as u16;
            k[l] = kl;
            v[l] = u[l] + s.carry[l];
            open[l] = !s.switched[l];
        }
        // Only a lane that has not switched in this cycle compares with the ramp.
        if any(&open) {
            let mut switch = [false; L];
            for l in 0..L {
                switch[l] = open[l] & (v[l] + self.ramp(k[l]) < 0);
            }
            if any(&switch) {
                cold_path();
                for l in 0..L {
                    let w = switch[l];
                    s.latched[l] = if w { v[l] } else { s.latched[l] };
                    s.cycle_pulses[l] = if w { k[l] } else { s.cycle_pulses[l] };
                    s.switched[l] |= w;
                }
            }
        }
        let mut positive = [false; L];
        for l in 0..L {
            positive[l] = !s.switched[l];
            s.ticks[l] = s.ticks[l].wrapping_add(1);
            s.pulses[l] = s.pulses[l].wrapping_add(u32::from(positive[l]));
        }
        (v, positive)
    }

    /// The end of a limit cycle in the lanes of `end` (the others keep their state): the
    /// cycle's count of positive ticks (all `N` when it never switched, which latches the
    /// level `v` of its last tick), and with noise shaping the carry from the latched level.
    #[inline(always)]
    #[allow(clippy::inline_always, reason = "tick path")]
    fn close_cycles<const L: usize>(
        &self,
        s: &mut Lanes<L>,
        v: &[i32; L],
        positive: &[bool; L],
        end: &[bool; L],
    ) {
        for l in 0..L {
            let (e, p) = (end[l], positive[l]);
            if e & p {
                s.latched[l] = v[l];
            }
            let latched = s.latched[l];
            let n = if p { self.n } else { s.cycle_pulses[l] };
            if self.config.noise_shaping {
                // Level whose ideal duty is n/N: y = h·(2n − N).
                let y = self.h * (2 * i32::from(n) - i32::from(self.n));
                let c = latched - y;
                let carry = c.max(-self.h).min(self.h);
                s.carry[l] = if e { carry } else { s.carry[l] };
                s.sat_carry[l] = s.sat_carry[l].wrapping_add(u32::from(e & (carry != c)));
            }
            s.switched[l] &= !e;
            s.cycle_pulses[l] = if e { n } else { s.cycle_pulses[l] };
        }
    }
}
