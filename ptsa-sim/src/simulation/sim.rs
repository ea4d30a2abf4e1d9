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

use ptsa_core::{Config, Each, Polarity};

pub use super::config::ExtraPhysics;
use super::config::{Adc, LoopConfig};
use super::kernel::{self, DynLanes, DynState, StaticLanes, StaticState};
use super::noise::NoiseSource;
use super::state::LoopState;
pub use super::state::Totals;
use crate::model::condition::Condition;
use crate::model::effects::Effects;
use crate::model::instrument::Instrument;
use crate::model::plant::{NX, Plant};
use ptsa_core::{Ptsa, State};

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

/// The closed loop: instrument plant, ADC, `ptsa-core` loop; its configuration (built once,
/// read by every tick) and its state (what a tick changes). The public face of the two:
/// the batch engine runs the same configuration and state through the same kernels.
#[derive(Clone, Debug)]
pub struct ClosedLoop {
    pub(super) cfg: LoopConfig,
    pub(super) st: LoopState,
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
    pub(super) fn with_noise(
        instr: &Instrument,
        cond: &Condition,
        effects: &Effects,
        opts: &SimOptions,
        rng: NoiseSource,
    ) -> Self {
        let cfg = LoopConfig::new(
            instr,
            cond,
            effects,
            &opts.config,
            opts.noise,
            opts.harmonic,
        );
        let st = LoopState::new(cfg.ptsa.initial_state(), rng);
        Self { cfg, st }
    }

    /// Change the condition (and effects) from the next tick on, keeping every state.
    pub fn set_condition(&mut self, cond: &Condition, effects: &Effects) {
        self.cfg.set_condition(cond, effects);
        // The phasor is the new condition's from the next dynamic run on.
        self.st.phasor_k = u64::MAX;
    }

    /// Add physics from outside the vocabulary ([`ExtraPhysics`]) from the next tick on;
    /// the loop then runs its general (per-tick) path.
    #[must_use]
    pub fn with_physics(mut self, physics: std::sync::Arc<dyn ExtraPhysics>) -> Self {
        self.cfg.set_physics(physics);
        self
    }

    /// Plant state `[θ, θ', i, y]`.
    #[must_use]
    pub fn state(&self) -> [f64; NX] {
        self.st.x
    }

    /// Running totals.
    #[must_use]
    pub fn totals(&self) -> Totals {
        self.st.totals
    }

    /// The core's state.
    #[must_use]
    pub fn core(&self) -> &State {
        &self.st.core
    }

    /// The instrument.
    #[must_use]
    pub fn instrument(&self) -> &Instrument {
        &self.cfg.instr
    }

    /// Ticks run since the loop was built.
    #[must_use]
    pub fn ticks(&self) -> u64 {
        self.st.k
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
        if self.cfg.dynamic {
            self.run(n);
        } else {
            let start = self.st.run_start();
            run_static_fast(&self.cfg, &mut self.st, n);
            self.st.end_run(start, n, false, false);
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
        let start = self.st.run_start();
        let dynamic = self.cfg.dynamic;
        if dynamic {
            self.run_dynamic::<F, OBSERVE>(n, obs);
        } else {
            self.run_static::<F, OBSERVE>(n, obs);
        }
        self.st.end_run(start, n, dynamic, true);
        crate::simulation::work::count(n, dynamic);
    }

    /// A static run with the per-tick statistics: [`kernel::static_tick`] with one lane.
    fn run_static<F: FnMut(&TickView), const OBSERVE: bool>(&mut self, n: u64, obs: &mut F) {
        let (cfg, st) = (&self.cfg, &mut self.st);
        let k0 = st.k;
        let lane = StaticLanes::new([cfg]);
        let o = Each::<1>;
        let mut s = StaticState::load(o, [&*st]);
        for i in 0..n {
            let u = s.u(0);
            let bias = [cfg.adc.bias(&mut st.rng)];
            let (code, t) = kernel::static_tick::<1, _, true>(o, &lane, &mut s, &bias);
            if OBSERVE {
                obs(&TickView {
                    k: k0 + i,
                    x: s.lane_x(0),
                    code: code[0],
                    u,
                    decided: Polarity::from(t.positive[0]),
                });
            }
        }
        s.store(o, [st]);
    }

    /// A dynamic run: [`kernel::dynamic_tick`] with one lane, the phasor and the inputs of
    /// each tick from [`LoopConfig::dynamic_inputs`].
    fn run_dynamic<F: FnMut(&TickView), const OBSERVE: bool>(&mut self, n: u64, obs: &mut F) {
        let (cfg, st) = (&self.cfg, &mut self.st);
        st.sync_phasor(cfg);
        let (o, lane) = (Each::<1>, DynLanes::new([cfg]));
        let mut s = DynState::load(o, [&*st]);
        let mut sc = st.phasor;
        for _ in 0..n {
            let bias = [cfg.adc.bias(&mut st.rng)];
            let ti = cfg.dynamic_inputs(s.k(0), &mut sc);
            let u = s.u(0);
            let (code, t) = kernel::dynamic_tick::<1, _>(o, &lane, &mut s, &bias, &[&ti]);
            if OBSERVE {
                obs(&TickView {
                    k: s.k(0) - 1,
                    x: s.lane_x(0),
                    code: code[0],
                    u,
                    decided: Polarity::from(t.positive[0]),
                });
            }
        }
        s.store(o, [&mut *st]);
        st.phasor = sc;
        st.phasor_k = st.k;
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
    /// dynamic condition, a core that is not at reset, or a board's converter of fewer than
    /// 16 bits (the C loop quantizes to 16).
    #[must_use]
    pub fn c_static_params(&self) -> Option<String> {
        use std::fmt::Write as _;
        let (cfg, st) = (&self.cfg, &self.st);
        if cfg.dynamic
            || st.core != cfg.ptsa.initial_state()
            || cfg.adc.mask != ptsa_core::adc::AdcFormat::SIGNED_16.mask()
        {
            return None;
        }
        let c = cfg.ptsa.config();
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
            cfg.adc.gain,
            cfg.adc.offset + cfg.adc.round,
            cfg.adc.noise,
            cfg.plant.theta_stop,
            if st.u > 0.0 { 1 } else { -1 }
        );
        let _ = writeln!(s, "{}", st.rng.state);
        for z in &cfg.plant.zoh[..2] {
            for row in &z.phi {
                let _ = writeln!(s, "{:e} {:e} {:e} {:e}", row[0], row[1], row[2], row[3]);
            }
        }
        for region in &cfg.add {
            for add in region {
                for a in add {
                    let _ = write!(s, "{a:e} ");
                }
                s.push('\n');
            }
        }
        for v in st.x {
            let _ = write!(s, "{v:e} ");
        }
        s.push('\n');
        for v in st.rng.table.iter() {
            let _ = writeln!(s, "{v:e}");
        }
        Some(s)
    }

    /// Run a measurement window of `n` ticks and return its result.
    #[must_use]
    pub fn measure(&mut self, n: u64) -> SimResult {
        let w = WindowStart::open(&mut self.st);
        self.run(n);
        w.close(&self.cfg, &self.st)
    }
}

/// Where a measurement window started ([`ClosedLoop::measure`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct WindowStart {
    t0: Totals,
    x0: [f64; NX],
    p0: std::num::Wrapping<u32>,
}

impl WindowStart {
    /// Open a window on the loop in `st` (the maximum of `|θ|` restarts).
    pub(super) fn open(st: &mut LoopState) -> Self {
        st.totals.max_theta = 0.0;
        Self {
            t0: st.totals,
            x0: st.x,
            p0: st.core.total_pulses(),
        }
    }

    /// The window's result, now: the charge-balance estimate (see the module docs) and the
    /// window's statistics.
    pub(super) fn close(&self, cfg: &LoopConfig, st: &LoopState) -> SimResult {
        let (t0, t1) = (&self.t0, &st.totals);
        let (x0, x1) = (&self.x0, &st.x);
        let pulses = u64::from((st.core.total_pulses() - self.p0).0);
        let i = &cfg.instr;
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

/// Where a gate of [`run_static`] started.
#[derive(Clone, Copy, Debug)]
pub(super) struct GateStart {
    p0: std::num::Wrapping<u32>,
    s0: ptsa_core::Saturations,
    stop0: u64,
}

impl GateStart {
    /// Open a gate on the loop in `st`.
    pub(super) fn open(st: &LoopState) -> Self {
        Self {
            p0: st.core.total_pulses(),
            s0: st.core.saturations(),
            stop0: st.totals.stop_ticks,
        }
    }

    /// The result of the gate of `ticks` ticks, now.
    pub(super) fn close(&self, cfg: &LoopConfig, st: &LoopState, ticks: u64) -> StaticRun {
        let pulses = u64::from((st.core.total_pulses() - self.p0).0);
        let s1 = st.core.saturations();
        #[allow(clippy::cast_precision_loss)]
        let x = cfg.instr.sf_cm_s2 * (2.0 * pulses as f64 / ticks as f64 - 1.0);
        StaticRun {
            ticks,
            pulses,
            indicated_cm_s2: x,
            saturated: s1.integrator != self.s0.integrator
                || s1.output != self.s0.output
                || st.totals.stop_ticks != self.stop0
                || pulses == 0
                || pulses == ticks,
        }
    }
}

/// A static run of `n` ticks without statistics or observer, split by the applied
/// polarity ([`fast_block`]), its ADC terms drawn a block ahead; the caller ends it
/// ([`LoopState::end_run`]: the ticks and the applied-command sum from the core's count).
/// The arithmetic is that of [`kernel::static_tick`] (same operations in the same order), so
/// the pulses and the state are bit-identical; what changes is that the polarity reaches the
/// plant through a predicted branch instead of a data dependency, which takes the core's
/// decision off the per-tick dependency chain (the predictor misses at the two switches of a
/// limit cycle, not on the ticks between them). This is why the single loop's fast path is
/// not `kernel::static_tick` with one lane: run that way it executes 121 instructions per
/// tick instead of 115 (callgrind) but takes 17 % longer (`ptsa bench --compare-c`:
/// 1.18e8 against 1.43e8 ticks/s, Rust / C 0.94 against 1.13), the branch-free polarity
/// select putting the core's decision back on the chain.
fn run_static_fast(cfg: &LoopConfig, st: &mut LoopState, n: u64) {
    // The ADC's additive term of each tick (offset and noise), drawn a block ahead: the
    // same draws in the same order, off the loop's registers; each block runs with the
    // constants and the state in locals ([`static_block_fast`]).
    let mut bias = [0.0f64; BIAS_BLOCK];
    let mut left = n;
    while left > 0 {
        #[allow(clippy::cast_possible_truncation)]
        let m = left.min(BIAS_BLOCK as u64) as usize;
        for b in &mut bias[..m] {
            *b = cfg.adc.bias(&mut st.rng);
        }
        static_block_fast(cfg, st, &bias[..m]);
        left -= m as u64;
    }
}

/// One block of a static run without statistics: [`run_static_fast`]'s loop over the ADC
/// terms `bias`, the constants and the state in locals (each block of the single loop, and
/// the batch engine's one-lane-at-a-time path).
pub(super) fn static_block_fast(cfg: &LoopConfig, st: &mut LoopState, bias: &[f64]) {
    let ptsa = cfg.ptsa;
    let plant = cfg.plant;
    let add = cfg.add;
    let adc = cfg.adc;
    let mut core = st.core;
    let mut x = st.x;
    let mut stop = st.totals.stop_ticks;
    let mut positive = st.u > 0.0;
    fast_block(
        &ptsa,
        &plant,
        &add,
        &adc,
        bias,
        &mut core,
        &mut x,
        &mut positive,
        &mut stop,
    );
    st.u = if positive { 1.0 } else { -1.0 };
    st.core = core;
    st.x = x;
    st.totals.stop_ticks = stop;
}

/// One tick per entry of `bias` (the ADC's additive terms, see [`Adc::bias`]) of a static
/// run without statistics, split by the applied polarity `positive` (see
/// [`run_static_fast`]): the body of the single loop's fast path and of the batch
/// engine's static lanes. Adds the ticks on a stop to `stop`.
#[allow(clippy::inline_always, reason = "per-tick path")]
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn fast_block(
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

/// Ticks of [[`run_static_fast`]]'s blocks of ADC bias terms.
pub(super) const BIAS_BLOCK: usize = 512;

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
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, schemars::JsonSchema)]
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
    let g = GateStart::open(&l.st);
    run(&mut l, ticks);
    g.close(&l.cfg, &l.st, ticks)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::condition::OA;

    /// The phasor a dynamic run starts from is the condition's own at the absolute tick
    /// index (`LoopConfig::phasor`), after a new condition or a static run in between, not
    /// the one the state carried.
    #[test]
    fn a_dynamic_run_starts_from_its_conditions_phasor() {
        let instr = Instrument::kearfott_2401();
        let osc = |f: f64| {
            let mut c = Condition {
                g: [0.0, 1.0, 0.0],
                freq_hz: f,
                ..Condition::default()
            };
            c.ang_mrad[OA] = 2.0;
            c
        };
        let opts = SimOptions::default();
        let mut l = ClosedLoop::new(&instr, &osc(20.0), &Effects::NONE, &opts);
        let same = |l: &ClosedLoop| {
            let want = l.cfg.phasor(l.st.k);
            (l.st.phasor.0.to_bits(), l.st.phasor.1.to_bits())
                == (want.0.to_bits(), want.1.to_bits())
        };
        l.run(1_000);
        assert!(same(&l), "after a dynamic run");
        l.set_condition(&osc(37.0), &Effects::NONE);
        l.run(0);
        assert!(same(&l), "after a new condition inside a phasor block");
        l.set_condition(&Condition::default(), &Effects::NONE);
        l.run(777);
        l.set_condition(&osc(37.0), &Effects::NONE);
        l.run(5);
        assert!(same(&l), "after a static run");
    }
}
