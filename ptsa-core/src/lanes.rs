//! The tick, once, for `L` loops side by side.
//!
//! [`Ptsa::tick_regs`] is the loop's per-tick arithmetic (compensator, ramp, quantizer,
//! counters; ARITHMETIC.md's "Tick order") written over the lane operations of a
//! [`LaneOps`] on a state of `L` lanes, [`Regs`]: the common path of a tick has no branch per
//! lane (range tests as masks, the quantizer's latch as selects), so that several lanes run
//! per SIMD instruction. The rare steps (the integrator and junction clamps, the quantizer's
//! switch, the end of a limit cycle, the end of a gate) run only when some lane needs them,
//! each behind one test that the compiler is told seldom holds (`cold_path`), and the ramp
//! compare only while some lane has not switched in its cycle. With one lane those tests
//! are the scalar loop's own branches and the rare steps stay out of its straight-line
//! path; with many, one test serves all lanes (lanes started together are in step, so a
//! cycle or gate end is the same branch for all of them).
//!
//! [`Lanes`] is the state in the plain lane operations [`Each`] (one array element per
//! lane), and [`Ptsa::tick_lanes`] the tick on it. [`Ptsa::tick`], the form the firmware
//! runs, *is* that function with one lane: a [`State`] is a [`Lanes<1>`] (the firmware's
//! instruction budget and the golden vectors check that nothing else changed). A host that
//! runs many independent loops (`ptsa-sim`'s batch engine) runs them through the same
//! definition with its own lane operations: eight lanes in AVX-512 registers, or [`Each`]
//! with `L` = 4 or 8, vectorised by the compiler.

use core::num::Wrapping;

use crate::counter::Gate;
use crate::lane_ops::{Each, LaneOps};
use crate::ptsa::{Polarity, Ptsa, State, Tick};
use crate::{COEF_FRAC, INTEGRATOR_LIMIT, LEAD_LIMIT, POLE_FRAC, RAMP_AMPLITUDE};

/// The state of `L` loops, structure of arrays, in the plain form [`Each`]: lane `l` of every
/// field is one [`State`] ([`Lanes::get`], [`Lanes::set`]). Plain data.
pub type Lanes<const L: usize> = Regs<L, Each<L>>;

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
        State(Regs {
            e_prev: [self.e_prev[l]],
            lead: [self.lead[l]],
            integ: [self.integ[l]],
            carry: [self.carry[l]],
            ticks: [self.ticks[l]],
            pulses: [self.pulses[l]],
            switched: [self.switched[l]],
            latched: [self.latched[l]],
            cycle_pulses: [self.cycle_pulses[l]],
            gate_open: [self.gate_open[l]],
            gate_start: [self.gate_start[l]],
            sat_integrator: [self.sat_integrator[l]],
            sat_output: [self.sat_output[l]],
            sat_carry: [self.sat_carry[l]],
        })
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
        Wrapping(self.pulses[l].cast_unsigned())
    }
}

/// The fields of two [`Lanes`] in declaration order, for the trait impls the derive cannot
/// give a struct generic over [`LaneOps`].
macro_rules! lanes_fields {
    ($m:ident) => {
        $m!(
            e_prev,
            lead,
            integ,
            carry,
            ticks,
            pulses,
            switched,
            latched,
            cycle_pulses,
            gate_open,
            gate_start,
            sat_integrator,
            sat_output,
            sat_carry
        )
    };
}

impl<const L: usize> PartialEq for Lanes<L> {
    fn eq(&self, other: &Self) -> bool {
        macro_rules! all_eq {
            ($($f:ident),*) => { true $(&& self.$f == other.$f)* };
        }
        lanes_fields!(all_eq)
    }
}

impl<const L: usize> Eq for Lanes<L> {}

impl<const L: usize> core::hash::Hash for Lanes<L> {
    fn hash<H: core::hash::Hasher>(&self, state: &mut H) {
        macro_rules! hash_all {
            ($($f:ident),*) => { $(self.$f.hash(state);)* };
        }
        lanes_fields!(hash_all);
    }
}

impl<const L: usize> core::fmt::Debug for Lanes<L> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        macro_rules! debug_all {
            ($($fd:ident),*) => { f.debug_struct("Lanes")$(.field(stringify!($fd), &self.$fd))*.finish() };
        }
        lanes_fields!(debug_all)
    }
}

#[cfg(feature = "defmt")]
impl<const L: usize> defmt::Format for Lanes<L> {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(
            f,
            "Lanes {{ e_prev: {}, lead: {}, integ: {}, carry: {}, ticks: {}, pulses: {}, switched: {}, latched: {}, cycle_pulses: {}, gate_open: {}, gate_start: {}, sat_integrator: {}, sat_output: {}, sat_carry: {} }}",
            self.e_prev,
            self.lead,
            self.integ,
            self.carry,
            self.ticks,
            self.pulses,
            self.switched,
            self.latched,
            self.cycle_pulses,
            self.gate_open,
            self.gate_start,
            self.sat_integrator,
            self.sat_output,
            self.sat_carry
        );
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

/// The state of `L` loops in the types of a [`LaneOps`] `O`; in the plain form, [`Lanes`].
/// The counters (`ticks`, `pulses`, the gate's marks, the saturation counts) are their `u32`
/// bits, the cycle's count of positive ticks its `u16` widened. A host that runs many ticks
/// in another form loads its lanes once ([`Regs::load`]) and stores them at the end
/// ([`Regs::store`]).
#[derive(Clone, Copy)]
pub struct Regs<const L: usize, O: LaneOps<L>> {
    pub(crate) e_prev: O::I32,
    pub(crate) lead: O::I32,
    pub(crate) integ: O::I64,
    pub(crate) carry: O::I32,
    pub(crate) ticks: O::I32,
    pub(crate) pulses: O::I32,
    pub(crate) switched: O::Mask,
    pub(crate) latched: O::I32,
    pub(crate) cycle_pulses: O::I32,
    pub(crate) gate_open: O::I32,
    pub(crate) gate_start: O::I32,
    pub(crate) sat_integrator: O::I32,
    pub(crate) sat_output: O::I32,
    pub(crate) sat_carry: O::I32,
}

impl<const L: usize, O: LaneOps<L>> Regs<L, O> {
    /// The lanes of `s` in the types of `o`.
    #[must_use]
    #[inline(always)]
    #[allow(clippy::inline_always, reason = "tick path")]
    pub fn load(o: O, s: &Lanes<L>) -> Self {
        Self {
            e_prev: o.load(s.e_prev),
            lead: o.load(s.lead),
            integ: o.load64(s.integ),
            carry: o.load(s.carry),
            ticks: o.load(s.ticks),
            pulses: o.load(s.pulses),
            switched: o.load_mask(s.switched),
            latched: o.load(s.latched),
            cycle_pulses: o.load(s.cycle_pulses),
            gate_open: o.load(s.gate_open),
            gate_start: o.load(s.gate_start),
            sat_integrator: o.load(s.sat_integrator),
            sat_output: o.load(s.sat_output),
            sat_carry: o.load(s.sat_carry),
        }
    }

    /// These lanes as [`Lanes`].
    #[must_use]
    #[inline(always)]
    #[allow(clippy::inline_always, reason = "tick path")]
    pub fn store(&self, o: O) -> Lanes<L> {
        Regs {
            e_prev: o.store(self.e_prev),
            lead: o.store(self.lead),
            integ: o.store64(self.integ),
            carry: o.store(self.carry),
            ticks: o.store(self.ticks),
            pulses: o.store(self.pulses),
            switched: o.store_mask(self.switched),
            latched: o.store(self.latched),
            cycle_pulses: o.store(self.cycle_pulses),
            gate_open: o.store(self.gate_open),
            gate_start: o.store(self.gate_start),
            sat_integrator: o.store(self.sat_integrator),
            sat_output: o.store(self.sat_output),
            sat_carry: o.store(self.sat_carry),
        }
    }
}

/// What one tick decided in each of `L` lanes, in the types of a [`LaneOps`] `O`
/// ([`Ptsa::tick_regs`]); as [`LaneTicks`], [`RegTicks::lanes`].
#[derive(Clone, Copy, Debug)]
pub struct RegTicks<const L: usize, O: LaneOps<L>> {
    /// Polarity decided for the next interval: set = [`Polarity::Positive`].
    pub positive: O::Mask,
    /// Whether the tick closed a limit cycle.
    pub cycle_end: O::Mask,
    /// With `cycle_end`: that cycle's positive ticks, `0..=N`.
    pub cycle_pulses: O::I32,
    /// Whether the tick closed a gate.
    pub gate_end: O::Mask,
    /// With `gate_end`: the gate's pulse count (`u32` bits).
    pub gate_pulses: O::I32,
    /// The gate length, ticks.
    pub gate_ticks: u32,
}

impl<const L: usize, O: LaneOps<L>> RegTicks<L, O> {
    /// As [`LaneTicks`].
    #[must_use]
    #[inline(always)]
    #[allow(clippy::inline_always, reason = "tick path")]
    pub fn lanes(&self, o: O) -> LaneTicks<L> {
        #[allow(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "0..=N"
        )]
        let cycle_pulses = o.store(self.cycle_pulses).map(|c| c as u16);
        LaneTicks {
            positive: o.store_mask(self.positive),
            cycle_end: o.store_mask(self.cycle_end),
            cycle_pulses,
            gate_end: o.store_mask(self.gate_end),
            gate_pulses: o.store(self.gate_pulses).map(i32::cast_unsigned),
            gate_ticks: self.gate_ticks,
        }
    }
}

/// Marks the path that calls it as seldom taken, as `core::hint::cold_path` does from Rust
/// 1.95 on (this crate's MSRV is older): rustc weighs a branch into a block that calls a
/// `#[cold]` function as unlikely, and the compiler keeps such a step behind its branch
/// instead of computing it on every tick.
#[cold]
const fn cold_path() {}

/// Whether `a` lies outside `-limit..=limit`.
#[inline(always)]
#[allow(clippy::inline_always, reason = "tick path")]
fn beyond<const L: usize, O: LaneOps<L>>(o: O, a: O::I32, limit: i32) -> O::Mask {
    o.or_mask(o.gt(a, o.splat(limit)), o.lt(a, o.splat(-limit)))
}

/// Whether `a` lies outside `-limit..=limit`.
#[inline(always)]
#[allow(clippy::inline_always, reason = "tick path")]
fn beyond64<const L: usize, O: LaneOps<L>>(o: O, a: O::I64, limit: i64) -> O::Mask {
    o.or_mask(o.gt64(a, o.splat64(limit)), o.lt64(a, o.splat64(-limit)))
}

/// `a` clamped to `-limit..=limit` where `beyond` says that it lies outside, else `a`. Once
/// the clamp is known to act, the bound is the limit with `a`'s sign: `(limit ^ m) − m` with
/// `m` the sign mask of `a` (`-limit` = `!limit + 1`).
#[inline(always)]
#[allow(clippy::inline_always, reason = "tick path")]
fn limit<const L: usize, O: LaneOps<L>>(o: O, a: O::I32, beyond: O::Mask, limit: i32) -> O::I32 {
    let m = o.sra::<31>(a);
    let bound = o.sub(o.xor(o.splat(limit), m), m);
    o.select(beyond, bound, a)
}

/// [`limit`] of 64-bit lanes.
#[inline(always)]
#[allow(clippy::inline_always, reason = "tick path")]
fn limit64<const L: usize, O: LaneOps<L>>(o: O, a: O::I64, beyond: O::Mask, limit: i64) -> O::I64 {
    let m = o.sra64::<63>(a);
    let bound = o.sub64(o.xor64(o.splat64(limit), m), m);
    o.select64(beyond, bound, a)
}

impl Ptsa {
    /// One 64 kHz clock tick of `L` loops: lane `l` takes the pickoff sample `x[l]` (ADC
    /// LSB) and decides its torquer polarity for the next interval, exactly as
    /// [`Ptsa::tick`] does for one loop (which is this function with `L = 1`):
    /// [`Ptsa::tick_regs`] with [`Each`].
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
        let o = Each::<L>;
        self.tick_regs(o, s, x.map(i32::from)).lanes(o)
    }

    /// One 64 kHz clock tick of the lanes of `s` in the types of `o`, each taking its
    /// pickoff sample from `x` (ADC LSB, `i16` values): the loop's per-tick arithmetic
    /// (compensator, ramp, quantizer, counters; ARITHMETIC.md's "Tick order"), the one
    /// definition [`Ptsa::tick`] and [`Ptsa::tick_lanes`] run. The common path has no branch
    /// per lane (range tests as masks, the quantizer's latch as selects); the rare steps (the
    /// integrator and junction clamps, the quantizer's switch, the end of a limit cycle, the
    /// end of a gate) run only when some lane needs them, each behind one test that the
    /// compiler is told seldom holds, and the ramp compare only while some lane has not
    /// switched in its cycle. With one lane those tests are the scalar loop's own branches;
    /// with many, one test serves all lanes (lanes started together are in step, so a
    /// cycle or gate end is the same branch for all of them).
    #[inline(always)]
    #[allow(
        clippy::inline_always,
        reason = "tick path: inlined into the firmware's TIM2 handler and the host's lanes"
    )]
    pub fn tick_regs<const L: usize, O: LaneOps<L>>(
        &self,
        o: O,
        s: &mut Regs<L, O>,
        x: O::I32,
    ) -> RegTicks<L, O> {
        let u = self.compensate(o, s, x);
        let (v, positive) = self.quantize(o, s, u);
        // The end of a limit cycle and the end of a gate, each a rare step.
        #[allow(clippy::cast_possible_wrap, reason = "mask < 4096")]
        let cycle_end = o.eq(o.and(s.ticks, o.splat(self.mask as i32)), o.splat(0));
        if o.any(cycle_end) {
            cold_path();
            self.close_cycles(o, s, v, positive, cycle_end);
        }
        let gate_ticks = self.config.gate_ticks;
        let gate_end = o.eq(
            o.sub(s.ticks, s.gate_open),
            o.splat(gate_ticks.cast_signed()),
        );
        let mut gate_pulses = o.splat(0);
        if o.any(gate_end) {
            cold_path();
            gate_pulses = o.sub(s.pulses, s.gate_start);
            s.gate_open = o.select(gate_end, s.ticks, s.gate_open);
            s.gate_start = o.select(gate_end, s.pulses, s.gate_start);
        }
        RegTicks {
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
    fn compensate<const L: usize, O: LaneOps<L>>(
        &self,
        o: O,
        s: &mut Regs<L, O>,
        e: O::I32,
    ) -> O::I32 {
        // Lead: acc (2^-16 LSB) = b0·e + b1·e' + a1·lead'; lead = round(acc / 2^16).
        let acc = o.add64(
            o.add64(o.mul_wide(e, self.b0), o.mul_wide(s.e_prev, self.b1)),
            o.mul_wide(s.lead, self.a1),
        );
        let wide = o.sra64::<POLE_FRAC>(o.add64(acc, o.splat64(1 << (POLE_FRAC - 1))));
        // |lead| <= LEAD_LIMIT = 2^30 is proven for every configuration `Ptsa::new`
        // accepts (ARITHMETIC.md, "Bounds"); the property tests run with this assertion.
        debug_assert!(
            o.store64(wide)
                .iter()
                .all(|w| w.abs() <= i64::from(LEAD_LIMIT)),
            "lead bound violated"
        );
        // |lead| <= 2^30, asserted above: the low 32 bits are the value.
        let lead = o.low32(wide);
        s.lead = lead;
        s.e_prev = e;
        s.integ = o.add64(s.integ, o.mul_wide(e, self.ki));
        // Integrator clamp (anti-windup), counting a tick in which it acted.
        let over = beyond64(o, s.integ, INTEGRATOR_LIMIT);
        if o.any(over) {
            cold_path();
            s.integ = limit64(o, s.integ, over, INTEGRATOR_LIMIT);
            s.sat_integrator = o.count(s.sat_integrator, over);
        }
        // Summing junction: |lead| <= 2^30 and |integ >> 16| <= 2^24, no i32 overflow.
        let sum = o.add(lead, o.low32(o.sra64::<COEF_FRAC>(s.integ)));
        let over = beyond(o, sum, RAMP_AMPLITUDE);
        if o.any(over) {
            cold_path();
            s.sat_output = o.count(s.sat_output, over);
            return limit(o, sum, over, RAMP_AMPLITUDE);
        }
        sum
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
    fn quantize<const L: usize, O: LaneOps<L>>(
        &self,
        o: O,
        s: &mut Regs<L, O>,
        u: O::I32,
    ) -> (O::I32, O::Mask) {
        #[allow(clippy::cast_possible_wrap, reason = "mask < 4096")]
        let k = o.and(s.ticks, o.splat(self.mask as i32));
        let v = o.add(u, s.carry);
        // Only a lane that has not switched in this cycle compares with the ramp.
        let open = o.not_mask(s.switched);
        if o.any(open) {
            // r[k] = h·(N − 1 − 2k) (`Ptsa::ramp`).
            let ramp = o.mul(
                o.splat(self.h),
                o.sub(o.splat(i32::from(self.n) - 1), o.add(k, k)),
            );
            let switch = o.and_mask(open, o.lt(o.add(v, ramp), o.splat(0)));
            if o.any(switch) {
                cold_path();
                s.latched = o.select(switch, v, s.latched);
                s.cycle_pulses = o.select(switch, k, s.cycle_pulses);
                s.switched = o.or_mask(s.switched, switch);
            }
        }
        let positive = o.not_mask(s.switched);
        s.ticks = o.add(s.ticks, o.splat(1));
        s.pulses = o.count(s.pulses, positive);
        (v, positive)
    }

    /// The end of a limit cycle in the lanes of `end` (the others keep their state): the
    /// cycle's count of positive ticks (all `N` when it never switched, which latches the
    /// level `v` of its last tick), and with noise shaping the carry from the latched level.
    #[inline(always)]
    #[allow(clippy::inline_always, reason = "tick path")]
    fn close_cycles<const L: usize, O: LaneOps<L>>(
        &self,
        o: O,
        s: &mut Regs<L, O>,
        v: O::I32,
        positive: O::Mask,
        end: O::Mask,
    ) {
        s.latched = o.select(o.and_mask(end, positive), v, s.latched);
        let full = o.splat(i32::from(self.n));
        let n = o.select(positive, full, s.cycle_pulses);
        if self.config.noise_shaping {
            // Level whose ideal duty is n/N: y = h·(2n − N).
            let y = o.mul(o.splat(self.h), o.sub(o.add(n, n), full));
            let c = o.sub(s.latched, y);
            let carry = o.min(o.max(c, o.splat(-self.h)), o.splat(self.h));
            s.carry = o.select(end, carry, s.carry);
            let clamped = o.and_not_mask(end, o.eq(carry, c));
            s.sat_carry = o.count(s.sat_carry, clamped);
        }
        s.switched = o.and_not_mask(s.switched, end);
        s.cycle_pulses = o.select(end, n, s.cycle_pulses);
    }
}
