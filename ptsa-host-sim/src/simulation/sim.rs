//! The closed loop: `ptsa-core` (the firmware's own code) tick by tick against the plant,
//! and the estimator of the mean indicated acceleration.
//!
//! # Timing
//! At clock edge `k` the ADC samples the demodulated pickoff; [`ptsa_core::Ptsa::tick`]
//! decides the polarity of the next clock interval, which the H-bridge applies from edge
//! `k+1` (one interval of computation delay, as in the PTSA: "the polarity of current
//! change occurs ... when the next 64 kHz clock pulse occurs").
//!
//! # The estimator (charge balance)
//! Integrating eq. 4.2 over a window `[t0, t1]` of length `W`:
//!
//! ```text
//! ∫ T_ext dt = F·∫ i dt + I·Δθ' + C·Δθ,      ∫ i dt = T·Σu − τ·Δi
//! ```
//!
//! where `T_ext` is every torque except the torquer's (`P·a_IA`, bias, spring, cross
//! coupling, anisoinertia, stops, effects). The long-run mean of the pulse output converges
//! to `mean(T_ext)/P`, so the estimate
//!
//! ```text
//! â = SF·(Σu/N − τ·Δi/W + (I·Δθ' + C·Δθ)/(F·W))      (F = torque at full current)
//! ```
//!
//! is what an infinitely long count would indicate for the conditions of the window: the
//! plain count `SF·(2P/T − 1)` plus the sigma-delta residual (the charge stored in the
//! pendulum and the torquer at the ends of the window). It is exact for the simulated
//! system; windows of whole oscillation periods remove the oscillating part of `T_ext`.

use std::num::Wrapping;

use ptsa_core::{Config, Polarity, Ptsa, State};
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::{RngCore, SeedableRng};

use crate::model::condition::{CaseInputs, Condition, IA, OA, PA, Prepared};
use crate::model::effects::{Effects, Signature};
use crate::model::instrument::Instrument;
use crate::model::plant::{NX, Plant};
use crate::simulation::kernel::{self, DynLanes, DynState, StaticLanes, StaticState};

/// Options of a simulated run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimOptions {
    /// Seed of the pickoff noise.
    pub seed: u64,
    /// Settling time before the measurement window, s.
    pub warmup_s: f64,
    /// Shortest measurement window, s; a dynamic condition gets the smallest whole number
    /// of oscillation periods at least this long (and at least one period).
    pub min_window_s: f64,
    /// Pickoff noise on (as in the instrument file) or off.
    pub noise: bool,
    /// Also measure the component of the pulse output at this harmonic of the condition's
    /// frequency (1 or 2; 0 = none).
    pub harmonic: u32,
    /// The loop configuration (default: `Config::DEFAULT`).
    pub config: Config,
}

impl SimOptions {
    /// Settling ticks before a measurement: `warmup_s` at the clock `clock_hz`, rounded.
    #[must_use]
    pub fn warmup_ticks(&self, clock_hz: f64) -> u64 {
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let t = (self.warmup_s * clock_hz).round().max(0.0) as u64;
        t
    }
}

impl Default for SimOptions {
    fn default() -> Self {
        Self {
            seed: 1,
            warmup_s: 0.1,
            min_window_s: 0.1,
            noise: true,
            harmonic: 0,
            config: Config::DEFAULT,
        }
    }
}

/// What a run measured over its window.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SimResult {
    /// Mean indicated acceleration over the window, cm/s² (charge-balance estimate, see the
    /// module docs): what a long count would indicate, `SF·(2P/T − 1)` in the limit, with
    /// the configured SF (equal to the true one for the shipped instrument).
    pub indicated_cm_s2: f64,
    /// Plain count over the window, `SF·(2P/T − 1)` with the configured SF, cm/s².
    pub count_cm_s2: f64,
    /// Clock ticks in the window (`T`).
    pub ticks: u64,
    /// Data pulses in the window (`P`, as the core counted them).
    pub pulses: u64,
    /// Window length, s.
    pub window_s: f64,
    /// RMS of the pendulum angle over the window, rad.
    pub theta_rms_rad: f64,
    /// Largest `|θ|` over the window, rad.
    pub theta_max_rad: f64,
    /// Complete limit cycles in the window.
    pub cycles: u64,
    /// Cycles with exactly two current reversals.
    pub cycles_two_reversals: u64,
    /// Ticks on a mechanical stop.
    pub stop_ticks: u64,
    /// Amplitude of the indicated acceleration at the requested harmonic, cm/s² (0 if none).
    pub harmonic_amp_cm_s2: f64,
    /// Phase of that component, degrees, relative to `sin(h·ωt)`.
    pub harmonic_deg: f64,
    /// Amplitude at the requested harmonic of the rebalanced torque over `P` (the
    /// charge-balance signal `(F·i + I·θ'' + C·θ')/P`, i.e. every torque on the pendulum
    /// but the torquer's, free of the pulse train's quantization), cm/s².
    pub harmonic_torque_amp_cm_s2: f64,
    /// Phase of that component, degrees, relative to `sin(h·ωt)`.
    pub harmonic_torque_deg: f64,
}

/// A condition minus its reference (as `measured_cm_s2` is defined).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SimDifference {
    /// The condition's run.
    pub condition: SimResult,
    /// The reference's run.
    pub reference: SimResult,
    /// `condition.indicated_cm_s2 − reference.indicated_cm_s2`, cm/s².
    pub difference_cm_s2: f64,
}

/// The per-tick noise source: wyrand (one multiply per draw) indexing a table of 4096
/// standard-normal values drawn once (Box-Muller from `ChaCha8`, normalised to mean 0 and
/// variance 1), all from the seed. Cheap enough for the hot loop; the table's 4096 levels
/// are far finer than the ADC's.
#[derive(Clone, Debug)]
pub(crate) struct NoiseSource {
    state: u64,
    table: std::sync::Arc<[f64; NOISE_TABLE]>,
}

const NOISE_TABLE: usize = 4096;

impl NoiseSource {
    /// The source of `seed`: its table and the generator's first state.
    pub(crate) fn new(seed: u64) -> Self {
        let mut c = ChaCha8Rng::seed_from_u64(seed);
        // Built on the heap: 32 KiB is too much for a stack frame (`large_stack_arrays`).
        let mut t = vec![0.0f64; NOISE_TABLE];
        let unit = |x: u64| {
            #[allow(clippy::cast_precision_loss)]
            let u = ((x >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
            u
        };
        for pair in t.chunks_mut(2) {
            let (u1, u2) = (unit(c.next_u64()), unit(c.next_u64()));
            let r = (-2.0 * u1.ln()).sqrt();
            let (s, co) = (std::f64::consts::TAU * u2).sin_cos();
            pair[0] = r * co;
            if pair.len() > 1 {
                pair[1] = r * s;
            }
        }
        #[allow(clippy::cast_precision_loss)]
        let n = NOISE_TABLE as f64;
        let mean = t.iter().sum::<f64>() / n;
        let sd = (t.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt();
        for x in &mut t {
            *x = (*x - mean) / sd;
        }
        let table = std::sync::Arc::<[f64]>::from(t)
            .try_into()
            .expect("the table has NOISE_TABLE entries");
        Self {
            state: c.next_u64(),
            table,
        }
    }
    /// Whether `other` draws the same numbers from now on (the same generator state and the
    /// same table).
    pub(crate) fn same_stream(&self, other: &NoiseSource) -> bool {
        self.state == other.state
            && (std::sync::Arc::ptr_eq(&self.table, &other.table)
                || self
                    .table
                    .iter()
                    .zip(other.table.iter())
                    .all(|(a, b)| a.to_bits() == b.to_bits()))
    }

    /// One standard-normal draw.
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    pub(crate) fn normal(&mut self) -> f64 {
        self.state = self.state.wrapping_add(0xa076_1d64_78bd_642f);
        let t = u128::from(self.state) * u128::from(self.state ^ 0xe703_7ed1_a0b4_28db);
        #[allow(clippy::cast_possible_truncation)]
        let r = ((t >> 64) as u64) ^ (t as u64);
        let j = (r >> 52) as usize;
        self.table[j & (NOISE_TABLE - 1)]
    }
}

/// Running totals of the loop (differenced into window results).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Totals {
    /// Ticks run.
    pub ticks: u64,
    /// Sum of the applied commands `u = ±1`.
    pub sum_u: i64,
    /// Pulses the core counted.
    pub pulses: u64,
    /// Sum of `θ²`, rad².
    pub sum_theta2: f64,
    /// Largest `|θ|`, rad.
    pub max_theta: f64,
    /// Completed limit cycles.
    pub cycles: u64,
    /// Cycles with exactly two reversals.
    pub cycles_two: u64,
    /// Ticks on a stop.
    pub stop_ticks: u64,
    /// `Σ u·sin(hωt)`, `Σ u·cos(hωt)` at the requested harmonic.
    pub harm: [f64; 2],
    /// The same sums of the per-tick charge-balance signal, cm/s².
    pub harm_q: [f64; 2],
}

impl Totals {
    /// Every total as bits (the floating-point ones by `to_bits`), in field order: two
    /// runs' totals are the same bit for bit when these are equal.
    #[must_use]
    pub fn bits(&self) -> Vec<u64> {
        let Totals {
            ticks,
            sum_u,
            pulses,
            sum_theta2,
            max_theta,
            cycles,
            cycles_two,
            stop_ticks,
            harm,
            harm_q,
        } = *self;
        #[allow(clippy::cast_sign_loss, reason = "the bits of the signed sum")]
        let mut v = vec![
            ticks,
            sum_u as u64,
            pulses,
            sum_theta2.to_bits(),
            max_theta.to_bits(),
            cycles,
            cycles_two,
            stop_ticks,
        ];
        v.extend(harm.iter().chain(&harm_q).map(|x| x.to_bits()));
        v
    }
}

/// One tick as seen by an observer (for waveforms and traces).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TickView {
    /// Tick index since the loop was built.
    pub k: u64,
    /// Plant state after the tick: `[θ (rad), θ' (rad/s), i (fraction of full current),
    /// y (rad)]`.
    pub x: [f64; NX],
    /// ADC code sampled at the start of the tick.
    pub code: i16,
    /// Command applied over this tick, ±1.
    pub u: f64,
    /// Polarity decided for the next interval.
    pub decided: Polarity,
}

/// The ADC: demodulated pickoff (rad) to a code, with the quadrature leak and noise.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Adc {
    /// Codes per rad.
    pub(crate) gain: f64,
    /// Offset (quadrature leak), codes.
    pub(crate) offset: f64,
    /// Noise, codes rms.
    pub(crate) noise: f64,
}

impl Adc {
    /// The additive term of one sample: offset, the rounding half and a noise draw (none
    /// without noise). Drawn apart from the plant state (ahead, in blocks, or shared between
    /// the lanes of a batch), so that the chain from the plant state to the code is one
    /// multiply-add ([`Adc::quantize`]).
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    pub(crate) fn bias(&self, rng: &mut NoiseSource) -> f64 {
        let mut bias = self.offset + 32768.5;
        if self.noise != 0.0 {
            bias += self.noise * rng.normal();
        }
        bias
    }

    /// The code of `y` with the additive term `bias` (see [`Adc::bias`]).
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    pub(crate) fn quantize(&self, y: f64, bias: f64) -> i16 {
        Self::quantize_with(self.gain, y, bias)
    }

    /// The code of `y` with the gain `gain` (codes per rad) and the additive term `bias`.
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    pub(crate) fn quantize_with(gain: f64, y: f64, bias: f64) -> i16 {
        // Round half up and clip to the i16 range without a libm call: `as u16` truncates
        // toward zero and saturates to `0..=65535` (NaN to 0), the same as an explicit clamp
        // before the cast but with one max/min pair instead of two.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let z = (y * gain + bias) as u16;
        #[allow(clippy::cast_possible_wrap)]
        let z = (z ^ 0x8000) as i16;
        z
    }
}

/// Per-run accumulators, kept in registers in the hot loops and merged into [`Totals`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Acc {
    pub(crate) ticks: u64,
    pub(crate) sum_u: i64,
    pub(crate) sum_theta2: f64,
    pub(crate) max_theta: f64,
    pub(crate) cycles: u64,
    pub(crate) cycles_two: u64,
    pub(crate) stop: u64,
    pub(crate) rev: u32,
    pub(crate) prev_positive: bool,
}

/// The θ-independent torque of the inputs, dyn·cm, for pendulosity `p` (g·cm), bias
/// (cm/s²), inertia (dyn·cm·s²) and anisoinertia `di` (g·cm²), the effect terms' extra
/// indicated acceleration `eff` (cm/s²) and the inputs `[a_IA (cm/s²), ω'_OA (rad/s²), ω_IA,
/// ω_PA (rad/s)]`: `P·(a_IA + bias + eff) − I·ω'_OA + ΔI·ω_IA·ω_PA`. The one expression of
/// [`ClosedLoop::static_torque`] and of the dynamic tick's lanes.
#[allow(clippy::inline_always, reason = "per-tick path")]
#[inline(always)]
pub(crate) fn torque_of_inputs(
    [p, bias, inertia, di]: [f64; 4],
    eff: f64,
    [a_ia, dw_oa, w_ia, w_pa]: [f64; 4],
) -> f64 {
    p * (a_ia + bias + eff) - inertia * dw_oa + di * w_ia * w_pa
}

/// An effect term per unit coefficient: extra indicated acceleration, cm/s².
type TermFn = fn(&CaseInputs) -> f64;

/// Physics added to the plant from outside the candidate vocabulary: what a caller (the
/// hidden-effect tests, which must not share code with the candidates) writes from the
/// equations. It is evaluated once per tick, at mid-tick, and its torque joins the
/// disturbance torque of eq. 4.2, held over the tick like every other.
pub trait ExtraPhysics: Send + Sync + std::fmt::Debug {
    /// Extra torque on the pendulum, dyn·cm, at `t_s` (s since the loop was built, mid-tick),
    /// given the case inputs at that time and the plant state `[θ (rad), θ' (rad/s),
    /// i (fraction of full current), y (rad)]` at the start of the tick.
    fn torque_dyn_cm(&self, t_s: f64, inputs: &CaseInputs, x: &[f64; NX]) -> f64;
}

/// The closed loop: instrument plant, ADC, `ptsa-core` loop, all state.
#[derive(Clone, Debug)]
pub struct ClosedLoop {
    pub(crate) instr: Instrument,
    pub(crate) ptsa: Ptsa,
    pub(crate) core: State,
    pub(crate) plant: Plant,
    pub(crate) prep: Prepared,
    /// The non-zero effect terms, `(term per unit coefficient, coefficient)`.
    pub(crate) effect_terms: Vec<(TermFn, f64)>,
    /// Physics added from outside the vocabulary.
    pub(crate) physics: Option<std::sync::Arc<dyn ExtraPhysics>>,
    pub(crate) dynamic: bool,
    /// Plant state.
    pub(crate) x: [f64; NX],
    /// Command applied in the current interval (decided at the previous tick).
    pub(crate) u: f64,
    pub(crate) k: u64,
    pub(crate) rng: NoiseSource,
    pub(crate) noise_codes: f64,
    pub(crate) code_per_rad: f64,
    pub(crate) code_offset: f64,
    /// Constant part of the disturbance torque, dyn·cm.
    pub(crate) d0: f64,
    /// `a_PA` and `W_IA² − W_PA²` folded into `K_eff`.
    pub(crate) a_pa0: f64,
    pub(crate) wq0: f64,
    pub(crate) p_gcm: f64,
    pub(crate) totals: Totals,
    pub(crate) prev_pol: Polarity,
    pub(crate) reversals: u32,
    pub(crate) harmonic: u32,
}

impl ClosedLoop {
    /// A loop at rest (reset core, pendulum at null, current at zero) in `cond`.
    /// Parameter changes in `effects` (candidates of the instrument file) are applied to the
    /// instrument first ([`Effects::apply_parameters`]).
    ///
    /// # Panics
    /// If `opts.config` is refused by `ptsa-core` (the default never is).
    #[must_use]
    pub fn new(instr: &Instrument, cond: &Condition, effects: &Effects, opts: &SimOptions) -> Self {
        Self::with_noise(instr, cond, effects, opts, NoiseSource::new(opts.seed))
    }

    /// [`ClosedLoop::new`] with the noise source of `opts.seed` given (the batch engine
    /// builds each seed's table once and shares it between lanes).
    pub(crate) fn with_noise(
        instr: &Instrument,
        cond: &Condition,
        effects: &Effects,
        opts: &SimOptions,
        rng: NoiseSource,
    ) -> Self {
        let changed;
        let instr = if effects.has_parameters() {
            changed = effects.apply_parameters(instr);
            &changed
        } else {
            instr
        };
        let ptsa = opts.config.build().expect("valid PTSA configuration");
        let lsb_v = instr.adc_full_scale_v / 32768.0;
        let noise = if opts.noise { instr.noise_v_rms } else { 0.0 };
        let mut s = Self {
            instr: instr.clone(),
            ptsa,
            core: ptsa.initial_state(),
            // Discretised for the condition's K_eff by `set_condition`.
            plant: Plant::default(),
            prep: Prepared::default(),
            effect_terms: Vec::new(),
            physics: None,
            dynamic: false,
            x: [0.0; NX],
            u: 1.0,
            k: 0,
            rng,
            noise_codes: noise * instr.amp_gain / lsb_v,
            code_per_rad: instr.lsb_per_rad() * instr.phase_error_rad.cos(),
            code_offset: (instr.quadrature_v * instr.phase_error_rad.sin() * instr.amp_gain
                + instr.adc_offset_v)
                / lsb_v,
            d0: 0.0,
            a_pa0: 0.0,
            wq0: 0.0,
            p_gcm: instr.pendulosity_g_cm(),
            totals: Totals::default(),
            prev_pol: Polarity::Positive,
            reversals: 0,
            harmonic: opts.harmonic,
        };
        s.set_condition(cond, effects);
        s
    }

    /// Change the condition (and effects) from the next tick on, keeping every state.
    pub fn set_condition(&mut self, cond: &Condition, effects: &Effects) {
        let instr = &self.instr;
        let prep = cond.prepare(instr.g_cm_s2);
        let m = prep.mean_inputs();
        let p = self.p_gcm;
        let di = instr.anisoinertia_g_cm2;
        self.a_pa0 = m.a_cm_s2[PA];
        self.wq0 = m.w_rad_s[IA].powi(2) - m.w_rad_s[PA].powi(2);
        let k_eff = instr.spring_dyn_cm_rad + p * self.a_pa0 - di * self.wq0;
        self.plant = Plant::new(instr, k_eff);
        self.prep = prep;
        self.effect_terms = effects
            .nonzero()
            .filter_map(|(id, c)| match id.info().signature {
                Signature::Term(f) => Some((f, c)),
                Signature::Parameter(_) => None,
            })
            .collect();
        self.dynamic = prep.is_dynamic() || self.physics.is_some();
        self.d0 = self.static_torque(&m);
    }

    /// The θ-independent torque for inputs `i`, dyn·cm.
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    pub(crate) fn static_torque(&self, i: &CaseInputs) -> f64 {
        torque_of_inputs(
            [
                self.p_gcm,
                self.instr.bias_cm_s2,
                self.instr.inertia_dyn_cm_s2,
                self.instr.anisoinertia_g_cm2,
            ],
            self.effects_cm_s2(i),
            [i.a_cm_s2[IA], i.dw_rad_s2[OA], i.w_rad_s[IA], i.w_rad_s[PA]],
        )
    }

    /// The effect terms' extra indicated acceleration for inputs `i`, cm/s².
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    pub(crate) fn effects_cm_s2(&self, i: &CaseInputs) -> f64 {
        self.effect_terms.iter().map(|&(f, c)| c * f(i)).sum()
    }

    /// Add physics from outside the vocabulary ([`ExtraPhysics`]) from the next tick on;
    /// the loop then runs its general (per-tick) path.
    #[must_use]
    pub fn with_physics(mut self, physics: std::sync::Arc<dyn ExtraPhysics>) -> Self {
        self.physics = Some(physics);
        self.dynamic = true;
        self
    }

    /// Plant state `[θ, θ', i, y]`.
    #[must_use]
    pub fn state(&self) -> [f64; NX] {
        self.x
    }

    /// Running totals.
    #[must_use]
    pub fn totals(&self) -> Totals {
        self.totals
    }

    /// The core's state.
    #[must_use]
    pub fn core(&self) -> &State {
        &self.core
    }

    /// The instrument.
    #[must_use]
    pub fn instrument(&self) -> &Instrument {
        &self.instr
    }

    /// Ticks run since the loop was built.
    #[must_use]
    pub fn ticks(&self) -> u64 {
        self.k
    }

    pub(crate) fn adc_params(&self) -> Adc {
        Adc {
            gain: self.code_per_rad,
            offset: self.code_offset,
            noise: self.noise_codes,
        }
    }

    /// The constants of a static tick (see [`kernel::static_tick`]).
    pub(crate) fn static_params(&self) -> StaticParams {
        StaticParams {
            ptsa: self.ptsa,
            plant: self.plant,
            add: add_vectors(&self.plant, self.d0),
            adc: self.adc_params(),
        }
    }

    pub(crate) fn acc(&self) -> Acc {
        Acc {
            ticks: 0,
            sum_u: 0,
            sum_theta2: self.totals.sum_theta2,
            max_theta: self.totals.max_theta,
            cycles: 0,
            cycles_two: 0,
            stop: 0,
            rev: self.reversals,
            prev_positive: self.prev_pol == Polarity::Positive,
        }
    }

    pub(crate) fn merge(&mut self, a: &Acc) {
        let t = &mut self.totals;
        t.ticks += a.ticks;
        t.sum_u += a.sum_u;
        // A running sum carried through the runs (not a sum of each run's sums), so that it
        // does not depend on how the ticks were cut into runs.
        t.sum_theta2 = a.sum_theta2;
        t.max_theta = a.max_theta;
        t.cycles += a.cycles;
        t.cycles_two += a.cycles_two;
        t.stop_ticks += a.stop;
        self.reversals = a.rev;
        self.prev_pol = if a.prev_positive {
            Polarity::Positive
        } else {
            Polarity::Negative
        };
        t.pulses = u64::from(self.core.total_pulses().0);
    }

    /// Run `n` ticks, calling `obs` after each.
    pub fn run_observed(&mut self, n: u64, mut obs: impl FnMut(&TickView)) {
        self.run_inner::<_, true>(n, &mut obs);
    }

    /// Run `n` ticks without the per-tick statistics (θ RMS and maximum, reversals per
    /// cycle): the pulse count, the tick count, the applied-command sum and the plant state
    /// stay exact, so [`ClosedLoop::measure`]'s estimate over a later window is unaffected.
    /// Dynamic conditions fall back to [`ClosedLoop::run`].
    pub fn run_fast(&mut self, n: u64) {
        if self.dynamic || self.harmonic != 0 {
            self.run(n);
        } else {
            self.run_static::<_, false, false>(n, &mut |_| {});
            crate::simulation::work::count(n, false);
        }
    }

    /// Run `n` ticks.
    pub fn run(&mut self, n: u64) {
        self.run_inner::<_, false>(n, &mut |_| {});
    }

    #[allow(clippy::inline_always, reason = "the tick loop, one copy per caller")]
    #[inline(always)]
    fn run_inner<F: FnMut(&TickView), const OBSERVE: bool>(&mut self, n: u64, obs: &mut F) {
        if self.dynamic || self.harmonic != 0 {
            self.run_dynamic::<F, OBSERVE>(n, obs);
            crate::simulation::work::count(n, true);
        } else {
            self.run_static::<F, OBSERVE, true>(n, obs);
            crate::simulation::work::count(n, false);
        }
    }

    fn run_static<F: FnMut(&TickView), const OBSERVE: bool, const STATS: bool>(
        &mut self,
        n: u64,
        obs: &mut F,
    ) {
        if !OBSERVE && !STATS {
            self.run_static_fast(n);
            return;
        }
        let mut r = self.static_run();
        let k0 = self.k;
        let p = r.p;
        let lane = StaticLanes::one_of(&p);
        let mut st = StaticState::load([&r]);
        for i in 0..n {
            let u = if st.neg[0] == 0 { 1.0 } else { -1.0 };
            let bias = [p.adc.bias(&mut r.rng)];
            let (code, t) = kernel::static_tick::<1, STATS>(&lane, &mut st, &bias);
            if OBSERVE {
                obs(&TickView {
                    k: k0 + i,
                    x: [st.x[0][0], st.x[1][0], st.x[2][0], st.x[3][0]],
                    code: code[0],
                    u,
                    decided: Polarity::from(t.positive[0]),
                });
            }
        }
        st.store([&mut r]);
        self.finish_static_run(&r, n, STATS);
    }

    /// The start of a static run (one call of [`ClosedLoop::run`] or
    /// [`ClosedLoop::run_fast`]): its constants and the loop's state.
    pub(crate) fn static_run(&self) -> StaticRunState {
        StaticRunState {
            p: self.static_params(),
            rng: self.rng.clone(),
            core: self.core,
            acc: self.acc(),
            x: self.x,
            ui: usize::from(self.u < 0.0),
            pulses0: self.core.total_pulses(),
            first: self.u > 0.0,
        }
    }

    /// The end of a static run of `n` ticks: its state back into the loop. Without `stats`
    /// the run kept no per-tick statistics: its ticks and applied-command sum come from the
    /// core's count (see [`fast_counts`]).
    pub(crate) fn finish_static_run(&mut self, r: &StaticRunState, n: u64, stats: bool) {
        let mut acc = r.acc;
        if !stats {
            fast_counts(&mut acc, r.pulses0, r.first, &r.core, r.ui == 0, n);
        }
        self.x = r.x;
        self.u = if r.ui == 0 { 1.0 } else { -1.0 };
        self.k += n;
        self.rng = r.rng.clone();
        self.core = r.core;
        self.merge(&acc);
    }

    /// [`ClosedLoop::run_static`] without statistics or observer, split by the applied
    /// polarity: one inner loop per polarity, each with its plant input as a loop
    /// invariant, left when the core decides the other polarity. The arithmetic is that of
    /// `run_static` (same operations in the same order), so the pulses and the state are
    /// bit-identical; what changes is that the polarity reaches the plant through a
    /// predicted branch instead of a data dependency, which takes the core's decision off
    /// the per-tick dependency chain (the predictor misses at the two switches of a limit
    /// cycle, not on the ticks between them).
    fn run_static_fast(&mut self, n: u64) {
        let add = add_vectors(&self.plant, self.d0);
        let ptsa = self.ptsa;
        let plant = self.plant;
        let adc = self.adc_params();
        let mut rng = self.rng.clone();
        let mut core = self.core;
        let mut acc = self.acc();
        let mut x = self.x;
        let mut positive = self.u > 0.0;
        // The ADC's additive term of each tick (offset and noise), drawn a block ahead: the
        // same draws in the same order, off the loop's registers.
        let mut bias = [0.0f64; BIAS_BLOCK];
        let mut left = n;
        while left > 0 {
            #[allow(clippy::cast_possible_truncation)]
            let m = left.min(BIAS_BLOCK as u64) as usize;
            for b in &mut bias[..m] {
                *b = adc.bias(&mut rng);
            }
            fast_block(
                &ptsa,
                &plant,
                &add,
                &adc,
                &bias[..m],
                &mut core,
                &mut x,
                &mut positive,
                &mut acc.stop,
            );
            left -= m as u64;
        }
        fast_counts(
            &mut acc,
            self.core.total_pulses(),
            self.u > 0.0,
            &core,
            positive,
            n,
        );
        self.x = x;
        self.u = if positive { 1.0 } else { -1.0 };
        self.k += n;
        self.rng = rng;
        self.core = core;
        self.merge(&acc);
    }

    /// A dynamic run: [`kernel::dynamic_tick`] with one lane, the phasor and the inputs of
    /// each tick from [`ClosedLoop::dynamic_inputs`].
    fn run_dynamic<F: FnMut(&TickView), const OBSERVE: bool>(&mut self, n: u64, obs: &mut F) {
        let p = self.dyn_params();
        let mut r = self.dyn_run();
        let lane = DynLanes::new([&*self], [&p]);
        let mut st = DynState::load([&r]);
        let mut sc = (r.s, r.c);
        for j in 0..n {
            let bias = [p.adc.bias(&mut r.rng)];
            let ti = self.dynamic_inputs(&p, st.k[0], r.j + j, &mut sc);
            let u = st.u[0];
            let (code, t) = kernel::dynamic_tick::<1>(&lane, &mut st, &bias, &[&ti]);
            if OBSERVE {
                obs(&TickView {
                    k: st.k[0] - 1,
                    x: st.lane_x(0),
                    code: code[0],
                    u,
                    decided: Polarity::from(t.positive[0]),
                });
            }
        }
        st.store([&mut r]);
        (r.s, r.c) = sc;
        r.j += n;
        self.finish_dyn_run(&r);
    }

    /// The constants of a dynamic tick (see [`kernel::dynamic_tick`]).
    pub(crate) fn dyn_params(&self) -> DynParams {
        let t_s = 1.0 / self.instr.clock_hz;
        let w = self.prep.omega;
        let (sr, cr) = (w * t_s).sin_cos();
        let p = self.p_gcm;
        DynParams {
            ptsa: self.ptsa,
            t_s,
            w,
            sr,
            cr,
            p,
            di: self.instr.anisoinertia_g_cm2,
            harmonic: self.harmonic,
            sf: self.instr.actual_sf_cm_s2(),
            tau_t: self.instr.torquer_tau_s / t_s,
            ip: self.instr.inertia_dyn_cm_s2 / (p * t_s),
            cp: self.instr.damping_dyn_cm_s / (p * t_s),
            adc: self.adc_params(),
        }
    }

    /// The start of a dynamic run (one call of [`ClosedLoop::run`]): the loop's state.
    pub(crate) fn dyn_run(&self) -> DynRun {
        DynRun {
            rng: self.rng.clone(),
            core: self.core,
            acc: self.acc(),
            x: self.x,
            u: self.u,
            k: self.k,
            j: 0,
            s: 0.0,
            c: 1.0,
            harm: self.totals.harm,
            harm_q: self.totals.harm_q,
        }
    }

    /// The end of a dynamic run: its state back into the loop.
    pub(crate) fn finish_dyn_run(&mut self, r: &DynRun) {
        self.x = r.x;
        self.u = r.u;
        self.k = r.k;
        self.rng = r.rng.clone();
        self.core = r.core;
        self.totals.harm = r.harm;
        self.totals.harm_q = r.harm_q;
        self.merge(&r.acc);
    }

    /// The first part of a dynamic tick: the phasor `sc = (sin, cos)(ωt)` at mid-tick of
    /// tick `k`, the `j`-th of its run (exact every [`PHASOR_BLOCK`] ticks of the absolute
    /// index, made so at `j = 0` inside a block, else as given),
    /// and the condition's inputs there; advances `sc` to the next tick. It depends on the
    /// condition, the clock and `k`, `j`, `sc` only, so lanes in step with the same ones may
    /// share it.
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    pub(crate) fn dynamic_inputs(
        &self,
        p: &DynParams,
        k: u64,
        j: u64,
        sc: &mut (f64, f64),
    ) -> TickInputs {
        if k.is_multiple_of(PHASOR_BLOCK) {
            *sc = p.phasor_at(k);
        } else if j == 0 {
            // A run starting inside a block: the phasor a run from the block's start would
            // have here, so that the result does not depend on how the ticks were cut into
            // runs.
            let start = k - k % PHASOR_BLOCK;
            *sc = p.phasor_at(start);
            for _ in start..k {
                *sc = p.rotate(*sc);
            }
        }
        let (s, c) = *sc;
        let inp = self.prep.inputs(s, c);
        *sc = p.rotate(*sc);
        TickInputs { s, c, inp }
    }

    /// The static loop's constants and state, for an external implementation of the same
    /// loop to run it from here bit for bit: this loop's static condition as the input of
    /// `ptsa-host-sim/benches/c_static/static_loop.c` (the plain C loop that
    /// `ptsa bench --compare-c` builds, checks and times), whitespace-separated numbers
    /// (floats in shortest round-trip form, so that C's `strtod` reads the same bits): the
    /// core's constants, the ADC's gain, bias and noise, the stop angle, the applied
    /// polarity, the noise generator's state, Φ of the free and the stop regions, the
    /// per-region, per-polarity plant inputs, the plant state and the noise table. It lives
    /// here, not with the benchmark, because it reads the loop's internals. `None` for a
    /// dynamic condition or a core that is not at reset.
    #[must_use]
    pub fn c_static_params(&self) -> Option<String> {
        use std::fmt::Write as _;
        if self.dynamic || self.harmonic != 0 || self.core != self.ptsa.initial_state() {
            return None;
        }
        let c = self.ptsa.config();
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{} {} {} {} {} {} {}",
            c.b0.to_bits(),
            c.b1.to_bits(),
            c.a1.to_bits(),
            c.ki.to_bits(),
            c.ticks_per_cycle,
            c.gate_ticks,
            u8::from(c.noise_shaping)
        );
        let _ = writeln!(
            s,
            "{:e} {:e} {:e} {:e} {}",
            self.code_per_rad,
            self.code_offset + 32768.5,
            self.noise_codes,
            self.plant.theta_stop,
            if self.u > 0.0 { 1 } else { -1 }
        );
        let _ = writeln!(s, "{}", self.rng.state);
        for z in &self.plant.zoh[..2] {
            for row in &z.phi {
                let _ = writeln!(s, "{:e} {:e} {:e} {:e}", row[0], row[1], row[2], row[3]);
            }
        }
        for r in 0..3 {
            let z = &self.plant.zoh[r];
            let d = self.d0 + self.plant.stop_torque[r];
            for sign in [1.0, -1.0] {
                for j in 0..NX {
                    let a = if sign > 0.0 { z.gu[j] } else { -z.gu[j] } + z.gd[j] * d;
                    let _ = write!(s, "{a:e} ");
                }
                s.push('\n');
            }
        }
        for v in self.x {
            let _ = write!(s, "{v:e} ");
        }
        s.push('\n');
        for v in self.rng.table.iter() {
            let _ = writeln!(s, "{v:e}");
        }
        Some(s)
    }

    /// Run a measurement window of `n` ticks and return its result.
    #[must_use]
    pub fn measure(&mut self, n: u64) -> SimResult {
        let w = self.window_start();
        self.run(n);
        self.window_end(&w)
    }

    /// The start of a measurement window (the maximum of `|θ|` restarts).
    pub(crate) fn window_start(&mut self) -> WindowStart {
        self.totals.max_theta = 0.0;
        WindowStart {
            t0: self.totals,
            x0: self.x,
            p0: self.core.total_pulses(),
        }
    }

    /// The result of the window opened by `w`, now.
    pub(crate) fn window_end(&self, w: &WindowStart) -> SimResult {
        let t1 = self.totals;
        let x1 = self.x;
        let pulses = u64::from((self.core.total_pulses() - w.p0).0);
        self.window_result(&w.t0, &t1, &w.x0, &x1, pulses)
    }

    /// The start of a gate of `ptsa static` ([`run_static`]).
    pub(crate) fn gate_start(&self) -> GateStart {
        GateStart {
            p0: self.core.total_pulses(),
            s0: self.core.saturations(),
            stop0: self.totals.stop_ticks,
        }
    }

    /// The result of the gate of `ticks` ticks opened by `g`, now.
    pub(crate) fn gate_end(&self, g: &GateStart, ticks: u64) -> StaticRun {
        let pulses = u64::from((self.core.total_pulses() - g.p0).0);
        let s1 = self.core.saturations();
        #[allow(clippy::cast_precision_loss)]
        let x = self.instr.sf_cm_s2 * (2.0 * pulses as f64 / ticks as f64 - 1.0);
        StaticRun {
            ticks,
            pulses,
            indicated_cm_s2: x,
            saturated: s1.integrator != g.s0.integrator
                || s1.output != g.s0.output
                || self.totals.stop_ticks != g.stop0
                || pulses == 0
                || pulses == ticks,
        }
    }

    fn window_result(
        &self,
        t0: &Totals,
        t1: &Totals,
        x0: &[f64; NX],
        x1: &[f64; NX],
        pulses: u64,
    ) -> SimResult {
        let i = &self.instr;
        let t_s = 1.0 / i.clock_hz;
        let n = t1.ticks - t0.ticks;
        #[allow(clippy::cast_precision_loss)]
        let nf = n as f64;
        let w = nf * t_s;
        #[allow(clippy::cast_precision_loss)]
        let mean_u = (t1.sum_u - t0.sum_u) as f64 / nf;
        // Limit of the count's duty 2P/T − 1 (torque fraction), then eq. 6.1 with the
        // configured SF, like the count itself.
        let duty = mean_u - i.torquer_tau_s * (x1[2] - x0[2]) / w
            + (i.inertia_dyn_cm_s2 * (x1[1] - x0[1]) + i.damping_dyn_cm_s * (x1[0] - x0[0]))
                / (i.full_torque_dyn_cm() * w);
        let indicated = i.sf_cm_s2 * duty;
        #[allow(clippy::cast_precision_loss)]
        let count = i.sf_cm_s2 * (2.0 * pulses as f64 / nf - 1.0);
        let hs = t1.harm[0] - t0.harm[0];
        let hc = t1.harm[1] - t0.harm[1];
        let qs = t1.harm_q[0] - t0.harm_q[0];
        let qc = t1.harm_q[1] - t0.harm_q[1];
        SimResult {
            indicated_cm_s2: indicated,
            count_cm_s2: count,
            ticks: n,
            pulses,
            window_s: w,
            theta_rms_rad: ((t1.sum_theta2 - t0.sum_theta2) / nf).sqrt(),
            theta_max_rad: t1.max_theta,
            cycles: t1.cycles - t0.cycles,
            cycles_two_reversals: t1.cycles_two - t0.cycles_two,
            stop_ticks: t1.stop_ticks - t0.stop_ticks,
            harmonic_amp_cm_s2: 2.0 * i.sf_cm_s2 * hs.hypot(hc) / nf,
            harmonic_deg: hc.atan2(hs).to_degrees(),
            harmonic_torque_amp_cm_s2: 2.0 * qs.hypot(qc) / nf,
            harmonic_torque_deg: qc.atan2(qs).to_degrees(),
        }
    }
}

/// The plant inputs of a static condition, `add[region][polarity] = Γu·u + Γd·(d0 + stop
/// torque)` with polarity 0 = `u = +1`, 1 = `u = −1` (region 0 free, 1 and 2 on the stops).
#[allow(clippy::needless_range_loop)]
pub(crate) fn add_vectors(plant: &Plant, d0: f64) -> [[[f64; NX]; 2]; 3] {
    let mut add = [[[0.0; NX]; 2]; 3];
    for (r, a) in add.iter_mut().enumerate() {
        let z = &plant.zoh[r];
        let d = d0 + plant.stop_torque[r];
        for j in 0..NX {
            a[0][j] = z.gu[j] + z.gd[j] * d;
            a[1][j] = -z.gu[j] + z.gd[j] * d;
        }
    }
    add
}

/// What a tick of a static condition needs besides the state: the core, the plant (its
/// stops are the rare, cold path), the free region's matrices by value (so they can live in
/// registers), the plant inputs of [`add_vectors`] and the ADC.
#[derive(Clone, Copy, Debug)]
pub(crate) struct StaticParams {
    pub(crate) ptsa: Ptsa,
    pub(crate) plant: Plant,
    pub(crate) add: [[[f64; NX]; 2]; 3],
    pub(crate) adc: Adc,
}

/// The constants of a dynamic tick (see [`kernel::dynamic_tick`]): the core, the clock
/// period `t_s` (s), `ω` (rad/s) and the phasor's rotation per tick `sin, cos(ω·t_s)`,
/// pendulosity `p` (g·cm), anisoinertia `di` (g·cm²), the requested harmonic, the actual
/// scale factor (cm/s²), `τ/t_s`, `I/(P·t_s)`, `C/(P·t_s)` and the ADC.
#[derive(Clone, Copy, Debug)]
pub(crate) struct DynParams {
    pub(crate) ptsa: Ptsa,
    pub(crate) t_s: f64,
    pub(crate) w: f64,
    pub(crate) sr: f64,
    pub(crate) cr: f64,
    pub(crate) p: f64,
    pub(crate) di: f64,
    pub(crate) harmonic: u32,
    pub(crate) sf: f64,
    pub(crate) tau_t: f64,
    pub(crate) ip: f64,
    pub(crate) cp: f64,
    pub(crate) adc: Adc,
}

/// Ticks between exact evaluations of a dynamic condition's phasor `sin, cos(ωt)`
/// ([`ClosedLoop::dynamic_inputs`]): at every tick index that is a multiple of it, the phasor
/// is `sin_cos(ω·(k + ½)·t_s)`; in between, it is advanced by the rotation of one tick. A
/// function of the absolute tick index `k` alone.
pub(crate) const PHASOR_BLOCK: u64 = 4096;

impl DynParams {
    /// The exact phasor `sin, cos(ωt)` at mid-tick of tick `k`.
    #[inline]
    fn phasor_at(&self, k: u64) -> (f64, f64) {
        #[allow(clippy::cast_precision_loss)]
        let t_mid = (k as f64 + 0.5) * self.t_s;
        (self.w * t_mid).sin_cos()
    }

    /// The phasor `(s, c)` advanced by one tick.
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    fn rotate(&self, (s, c): (f64, f64)) -> (f64, f64) {
        (s * self.cr + c * self.sr, c * self.cr - s * self.sr)
    }
}

/// The phasor and the inputs of one dynamic tick ([`ClosedLoop::dynamic_inputs`]).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct TickInputs {
    /// `sin(ωt)` at mid-tick.
    pub(crate) s: f64,
    /// `cos(ωt)` at mid-tick.
    pub(crate) c: f64,
    /// The condition's inputs there.
    pub(crate) inp: CaseInputs,
}

/// The state of a dynamic run in progress (one call of [`ClosedLoop::run`]): everything a
/// tick changes, and `j`, the ticks run since the call (at `j = 0` the phasor is made what a
/// run from the start of its [`PHASOR_BLOCK`] would have).
#[derive(Clone, Debug)]
pub(crate) struct DynRun {
    pub(crate) rng: NoiseSource,
    pub(crate) core: State,
    pub(crate) acc: Acc,
    pub(crate) x: [f64; NX],
    pub(crate) u: f64,
    pub(crate) k: u64,
    pub(crate) j: u64,
    pub(crate) s: f64,
    pub(crate) c: f64,
    pub(crate) harm: [f64; 2],
    pub(crate) harm_q: [f64; 2],
}

/// The state of a static run in progress (one call of [`ClosedLoop::run`] or
/// [`ClosedLoop::run_fast`]): its constants, everything a tick changes, and the core's pulse
/// count and the applied polarity at the start (for [`fast_counts`]).
#[derive(Clone, Debug)]
pub(crate) struct StaticRunState {
    pub(crate) p: StaticParams,
    pub(crate) rng: NoiseSource,
    pub(crate) core: State,
    pub(crate) acc: Acc,
    pub(crate) x: [f64; NX],
    /// Applied polarity, 0 = positive (the index into `p.add`).
    pub(crate) ui: usize,
    pub(crate) pulses0: Wrapping<u32>,
    pub(crate) first: bool,
}

/// The ticks and the applied-command sum of a run of `n` ticks without per-tick statistics,
/// from the core's count: the applied polarities are the decided ones shifted by one tick,
/// so `Σu = 2·(decided + first − last) − n` with `decided` the pulses since `pulses0`,
/// `first` and `last` the applied polarities at the start and the end (true = positive).
pub(crate) fn fast_counts(
    acc: &mut Acc,
    pulses0: Wrapping<u32>,
    first: bool,
    core: &State,
    last: bool,
    n: u64,
) {
    let decided = i64::from((core.total_pulses() - pulses0).0);
    #[allow(clippy::cast_possible_wrap)]
    let n_i = n as i64;
    acc.ticks = n;
    acc.sum_u = 2 * (decided + i64::from(first) - i64::from(last)) - n_i;
}

/// Where a measurement window started ([`ClosedLoop::measure`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct WindowStart {
    t0: Totals,
    x0: [f64; NX],
    p0: Wrapping<u32>,
}

/// Where a gate of [`run_static`] started.
#[derive(Clone, Copy, Debug)]
pub(crate) struct GateStart {
    p0: Wrapping<u32>,
    s0: ptsa_core::Saturations,
    stop0: u64,
}

/// One tick per entry of `bias` (the ADC's additive terms, see [`Adc::bias`]) of a static
/// run without statistics, split by the applied polarity `positive` (see
/// `ClosedLoop::run_static_fast`): the body of the single loop's fast path and of the batch
/// engine's static lanes. Adds the ticks on a stop to `stop`.
#[allow(clippy::inline_always, reason = "per-tick path")]
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn fast_block(
    ptsa: &Ptsa,
    plant: &Plant,
    add: &[[[f64; NX]; 2]; 3],
    adc: &Adc,
    bias: &[f64],
    core: &mut State,
    x: &mut [f64; NX],
    positive: &mut bool,
    stop: &mut u64,
) {
    let m = bias.len();
    let mut i = 0;
    while i < m {
        let (run, next) = if *positive {
            static_phase::<true>(ptsa, plant, add, adc, &bias[i..m], core, x)
        } else {
            static_phase::<false>(ptsa, plant, add, adc, &bias[i..m], core, x)
        };
        #[allow(clippy::cast_possible_truncation)]
        let ticks = run.ticks as usize;
        i += ticks;
        *stop += run.stop;
        *positive = next;
    }
}

/// Ticks and stop ticks of one [`static_phase`].
struct PhaseRun {
    ticks: u64,
    stop: u64,
}

/// Ticks of [`ClosedLoop::run_static_fast`]'s blocks of ADC bias terms.
pub(crate) const BIAS_BLOCK: usize = 512;

/// Ticks with the applied polarity `POSITIVE` until the core decides the other one (that
/// tick included) or one tick per entry of `bias` (the ADC's additive terms, see
/// [`Adc::bias`]) has run; returns the run and the polarity decided last.
#[allow(clippy::inline_always, reason = "per-tick path")]
#[inline(always)]
fn static_phase<const POSITIVE: bool>(
    ptsa: &Ptsa,
    plant: &Plant,
    add: &[[[f64; NX]; 2]; 3],
    adc: &Adc,
    bias: &[f64],
    core: &mut State,
    x: &mut [f64; NX],
) -> (PhaseRun, bool) {
    let ui = usize::from(!POSITIVE);
    let free = plant.zoh[0];
    let add0 = add[0][ui];
    let theta_stop = plant.theta_stop;
    let mut xs = *x;
    let mut run = PhaseRun { ticks: 0, stop: 0 };
    let mut next = POSITIVE;
    for &b in bias {
        let code = adc.quantize(xs[3], b);
        let tick = ptsa.tick(core, code);
        if xs[0].abs() <= theta_stop {
            xs = free.step(&xs, &add0);
        } else {
            let r = plant.region(xs[0]);
            xs = plant.zoh[r].step(&xs, &add[r][ui]);
            run.stop += 1;
        }
        run.ticks += 1;
        next = tick.polarity == Polarity::Positive;
        if next != POSITIVE {
            break;
        }
    }
    *x = xs;
    (run, next)
}

/// Ticks of the measurement window for `cond`: whole limit cycles for a static condition,
/// whole oscillation periods (at least one, at least `min_window_s`) for a dynamic one.
#[must_use]
pub fn window_ticks(instr: &Instrument, cond: &Condition, opts: &SimOptions) -> u64 {
    let clock = instr.clock_hz;
    let n_cycle = f64::from(opts.config.ticks_per_cycle);
    let ticks =
        if cond.prepare(instr.g_cm_s2).is_dynamic() || (opts.harmonic != 0 && cond.freq_hz > 0.0) {
            let periods = (opts.min_window_s * cond.freq_hz).ceil().max(1.0);
            (periods * clock / cond.freq_hz).round()
        } else {
            (opts.min_window_s * clock / n_cycle).ceil().max(1.0) * n_cycle
        };
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let t = ticks as u64;
    t.max(1)
}

/// Simulate one condition: settle for `opts.warmup_s`, then measure over a window of whole
/// limit cycles or whole oscillation periods. Effects enter the plant as an extra torque
/// `P·effects.indicated_cm_s2(inputs)` on the pendulum.
#[must_use]
pub fn simulate_condition(
    instr: &Instrument,
    cond: &Condition,
    effects: &Effects,
    opts: &SimOptions,
) -> SimResult {
    let mut l = ClosedLoop::new(instr, cond, effects, opts);
    l.run(opts.warmup_ticks(instr.clock_hz));
    l.measure(window_ticks(instr, cond, opts))
}

/// [`simulate_condition`] with physics added from outside the vocabulary (see
/// [`ExtraPhysics`]).
#[must_use]
pub fn simulate_condition_with(
    instr: &Instrument,
    cond: &Condition,
    effects: &Effects,
    opts: &SimOptions,
    physics: std::sync::Arc<dyn ExtraPhysics>,
) -> SimResult {
    let mut l = ClosedLoop::new(instr, cond, effects, opts).with_physics(physics);
    l.run(opts.warmup_ticks(instr.clock_hz));
    l.measure(window_ticks(instr, cond, opts))
}

/// Simulate a condition and its reference ([`Condition::reference`]) with the same options
/// and effects; the difference is what `measured_cm_s2` measures.
#[must_use]
pub fn simulate_difference(
    instr: &Instrument,
    cond: &Condition,
    effects: &Effects,
    opts: &SimOptions,
) -> SimDifference {
    let c = simulate_condition(instr, cond, effects, opts);
    let r = simulate_condition(instr, &cond.reference(), effects, opts);
    SimDifference {
        condition: c,
        reference: r,
        difference_cm_s2: c.indicated_cm_s2 - r.indicated_cm_s2,
    }
}

/// Result of `ptsa static` (the JSON object of `ptsa static --json`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct StaticRun {
    /// Clock ticks (`T`).
    pub ticks: u64,
    /// Data pulses (`P`).
    pub pulses: u64,
    /// `SF·(2P/T − 1)` with the configured SF, cm/s².
    pub indicated_cm_s2: f64,
    /// The loop left its linear range during the gate: the integrator or the summing
    /// junction clamped, the pendulum reached a mechanical stop, or the count sat at a rail
    /// (`P = 0` or `P = T`). The indicated value is then not the input.
    pub saturated: bool,
}

/// The plain closed loop with a constant acceleration `accel_cm_s2` along IA (no gravity,
/// no rates; the instrument's bias and noise apply): after `opts.warmup_s` of settling from
/// reset, one gate of `ticks` ticks; the core's pulse count over the gate and eq. 6.1's
/// value `SF·(2P/T − 1)` with the configured SF.
///
/// Settling first matters: from reset the loop stores about eight pulses' worth of charge
/// in the pendulum (the limit-cycle ripple and the integrator build-up) before it is in its
/// periodic regime.
#[must_use]
pub fn run_static(
    instr: &Instrument,
    accel_cm_s2: f64,
    ticks: u64,
    opts: &SimOptions,
) -> StaticRun {
    run_static_with(instr, accel_cm_s2, ticks, opts, None, &mut |_, _| {})
}

/// Ticks between two calls of a progress callback.
pub const PROGRESS_CHUNK: u64 = 1 << 22;

/// `ticks` must stay below 2³² (the core's free-running counters are 32-bit, so a longer
/// gate's pulse count would wrap; callers refuse such gates).
///
/// [`run_static`] with an observer called on every tick from reset (settling and gate) and
/// `progress(done, total)` called every [`PROGRESS_CHUNK`] ticks. The result is the same
/// with or without them, tick for tick: the observed and the fast paths are bit-identical
/// (a test checks it), and running in chunks changes nothing.
pub fn run_static_with(
    instr: &Instrument,
    accel_cm_s2: f64,
    ticks: u64,
    opts: &SimOptions,
    mut obs: Option<&mut dyn FnMut(&TickView)>,
    progress: &mut dyn FnMut(u64, u64),
) -> StaticRun {
    let cond = crate::lab::fixtures::along_ia(accel_cm_s2, instr.g_cm_s2);
    let mut l = ClosedLoop::new(instr, &cond, &Effects::NONE, opts);
    let settle = opts.warmup_ticks(instr.clock_hz);
    let total = settle + ticks;
    let mut done = 0;
    let mut run = |l: &mut ClosedLoop, n: u64| {
        let mut left = n;
        while left > 0 {
            let k = left.min(PROGRESS_CHUNK);
            match obs.as_deref_mut() {
                Some(f) => l.run_observed(k, |v| f(v)),
                None => l.run_fast(k),
            }
            left -= k;
            done += k;
            progress(done, total);
        }
    };
    run(&mut l, settle);
    let g = l.gate_start();
    run(&mut l, ticks);
    l.gate_end(&g, ticks)
}
