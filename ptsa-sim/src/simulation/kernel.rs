//! The closed loop's tick, once, for `L` loops side by side: [`static_tick`] for a static
//! condition, [`dynamic_tick`] for a dynamic one.
//!
//! [`static_tick`] is the whole tick (the ADC's code of the demodulated pickoff, the core's
//! decision through [`ptsa_core::Ptsa::tick_regs`], the plant's exact step with the applied
//! polarity, a tick on a stop, the per-tick statistics) over `L` lanes in structure of
//! arrays. A kernel's lanes are `L` loops' configurations (`[&LoopConfig; L]`, packed once
//! into [`StaticLanes`] or [`DynLanes`]) and states (`[&mut LoopState; L]`, loaded into
//! [`StaticState`] or [`DynState`] for a run and stored back at its end), the cores' state in
//! the types of a [`ptsa_core::LaneOps`]: [`ptsa_core::Each`] (arrays) or, for eight lanes,
//! `avx512::Avx512` or `avx2::Avx2` (registers; `simd` says which the CPU runs). The single
//! loop runs it with one lane (`ClosedLoop::run`'s static path); the batch engine with 8 by
//! default (`batch`), compiled for the CPU's SIMD instructions (`simd::dispatch`), so that 4
//! (AVX2) or 8 (AVX-512) lanes share one SIMD instruction. Every step is a loop over the lanes
//! with the same operations in the same order for every `L` (no fused multiply-add: Rust
//! never contracts `a·b + c`; the ADC's conversion is the same floor and clamp by another
//! instruction sequence on several lanes, `ptsa_core::adc::AdcFormat::sample_lanes`), so a
//! lane's result does not depend on `L` or on the CPU: bit for bit the single loop's.

use ptsa_core::{Each, LaneOps, Lanes, Ptsa, RegTicks, Regs};

use super::config::{Adc, LoopConfig, TickInputs, torque_of_inputs};
use super::state::LoopState;
use crate::model::condition::{IA, OA, PA};
use crate::model::plant::{NX, ZohLanes};

/// The constants of a static condition's tick for `L` lanes (one loop configuration per
/// lane; one core configuration for all of them), packed as structure of arrays.
#[derive(Clone, Copy, Debug)]
pub(super) struct StaticLanes<'a, const L: usize> {
    /// The core's configuration, shared.
    ptsa: Ptsa,
    /// The free region's transition of each lane.
    free: ZohLanes<L>,
    /// The free region's plant input of each lane with the positive polarity applied, and
    /// the bits that flip it to the negative one (so that the polarity selects it without a
    /// branch).
    add_pos: [[f64; L]; NX],
    add_flip: [[u64; L]; NX],
    /// Stop angle of each lane, rad.
    theta_stop: [f64; L],
    /// ADC gain of each lane, codes per rad, and its converter's mask.
    gain: [f64; L],
    mask: [u16; L],
    /// Each lane's configuration: its plant and plant inputs by region and polarity for
    /// the stops, a rare and cold path.
    cfg: [&'a LoopConfig; L],
}

impl<'a, const L: usize> StaticLanes<'a, L> {
    /// The constants of `L` static loops, lane `l` of `cfg[l]` (all with the core
    /// configuration of `cfg[0]`).
    #[allow(clippy::needless_range_loop)]
    pub(super) fn new(cfg: [&'a LoopConfig; L]) -> Self {
        debug_assert!(cfg.iter().all(|c| c.ptsa == cfg[0].ptsa));
        let mut add_pos = [[0.0; L]; NX];
        let mut add_flip = [[0u64; L]; NX];
        for l in 0..L {
            for j in 0..NX {
                add_pos[j][l] = cfg[l].add[0][0][j];
                add_flip[j][l] = cfg[l].add[0][0][j].to_bits() ^ cfg[l].add[0][1][j].to_bits();
            }
        }
        Self {
            ptsa: cfg[0].ptsa,
            free: ZohLanes::new(std::array::from_fn(|l| &cfg[l].plant.zoh[0])),
            add_pos,
            add_flip,
            theta_stop: std::array::from_fn(|l| cfg[l].plant.theta_stop),
            gain: std::array::from_fn(|l| cfg[l].adc.gain),
            mask: std::array::from_fn(|l| cfg[l].adc.mask),
            cfg,
        }
    }
}

/// The per-tick statistics of `L` lanes (the loop state's [`Totals`](super::state::Totals)
/// that a tick changes, structure of arrays): ticks, applied-command sum, `Σθ²` (rad²) and
/// `max |θ|` (rad), limit cycles and those with two reversals, ticks on a stop, reversals in
/// the current cycle, the last decided polarity.
#[derive(Clone, Copy, Debug)]
struct AccLanes<const L: usize> {
    ticks: [u64; L],
    sum_u: [i64; L],
    sum_theta2: [f64; L],
    max_theta: [f64; L],
    cycles: [u64; L],
    cycles_two: [u64; L],
    stop: [u64; L],
    rev: [u32; L],
    prev_positive: [bool; L],
}

impl<const L: usize> AccLanes<L> {
    /// The statistics of `L` loops, lane `l` from `st[l]`.
    fn load(st: [&LoopState; L]) -> Self {
        Self {
            ticks: st.map(|s| s.totals.ticks),
            sum_u: st.map(|s| s.totals.sum_u),
            sum_theta2: st.map(|s| s.totals.sum_theta2),
            max_theta: st.map(|s| s.totals.max_theta),
            cycles: st.map(|s| s.totals.cycles),
            cycles_two: st.map(|s| s.totals.cycles_two),
            stop: st.map(|s| s.totals.stop_ticks),
            rev: st.map(|s| s.reversals),
            prev_positive: st.map(|s| s.prev_positive),
        }
    }

    /// Lane `l` back into `st`.
    fn store(&self, l: usize, st: &mut LoopState) {
        let t = &mut st.totals;
        t.ticks = self.ticks[l];
        t.sum_u = self.sum_u[l];
        t.sum_theta2 = self.sum_theta2[l];
        t.max_theta = self.max_theta[l];
        t.cycles = self.cycles[l];
        t.cycles_two = self.cycles_two[l];
        t.stop_ticks = self.stop[l];
        st.reversals = self.rev[l];
        st.prev_positive = self.prev_positive[l];
    }

    /// One tick of every lane: the applied polarity (`applied_positive`), the decided one,
    /// the pendulum angle after the tick (rad), whether the tick closed a limit cycle. The
    /// statistics' one definition, branch-free so that the lanes share SIMD instructions.
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    fn tick(
        &mut self,
        applied_positive: &[bool; L],
        positive: &[bool; L],
        theta: &[f64; L],
        cycle_end: &[bool; L],
    ) {
        for l in 0..L {
            self.ticks[l] += 1;
            self.sum_u[l] += 2 * i64::from(applied_positive[l]) - 1;
            self.sum_theta2[l] += theta[l] * theta[l];
            self.max_theta[l] = self.max_theta[l].max(theta[l].abs());
            let rev = self.rev[l] + u32::from(positive[l] != self.prev_positive[l]);
            self.prev_positive[l] = positive[l];
            let end = cycle_end[l];
            self.cycles[l] += u64::from(end);
            self.cycles_two[l] += u64::from(end) * u64::from(rev == 2);
            self.rev[l] = if end { 0 } else { rev };
        }
    }
}

/// What a static tick changes in `L` lanes: the plant state `x[j][lane]`, the cores (in the
/// types of the lane operations `O`), the applied polarity (all ones where negative) and the
/// statistics.
#[derive(Clone, Copy)]
pub(super) struct StaticState<const L: usize, O: LaneOps<L> = Each<L>> {
    x: [[f64; L]; NX],
    core: Regs<L, O>,
    neg: [u64; L],
    acc: AccLanes<L>,
}

/// The mask of `neg` for an applied polarity: all ones where negative.
#[allow(clippy::inline_always, reason = "per-tick path")]
#[inline(always)]
fn neg_mask(negative: bool) -> u64 {
    u64::from(negative).wrapping_neg()
}

/// Whether the pendulum at `theta` is free of the stops at `±theta_stop`, as
/// `Plant::region` has it (NaN is not).
#[allow(clippy::inline_always, reason = "per-tick path")]
#[inline(always)]
fn free(theta: f64, theta_stop: f64) -> bool {
    theta.abs() <= theta_stop
}

/// One tick of `L` lanes of static conditions: sample each lane's pickoff with the ADC's
/// additive term `bias[l]` (offset, rounding and noise, see [`Adc::bias`]), let the cores
/// decide, step the plants with the applied polarities, count the ticks on a stop and, with
/// `STATS`, the per-tick statistics; the decided polarities become the applied ones. Returns
/// the codes and what the cores decided.
#[allow(clippy::inline_always, reason = "per-tick path")]
#[inline(always)]
#[allow(clippy::needless_range_loop)]
pub(super) fn static_tick<const L: usize, O: LaneOps<L>, const STATS: bool>(
    o: O,
    p: &StaticLanes<'_, L>,
    s: &mut StaticState<L, O>,
    bias: &[f64; L],
) -> ([i16; L], RegTicks<L, O>) {
    let codes = Adc::quantize_lanes(&p.gain, &p.mask, &s.x[3], bias);
    let t = p
        .ptsa
        .tick_regs(o, &mut s.core, o.load(codes.map(i32::from)));
    let mut add = [[0.0; L]; NX];
    for j in 0..NX {
        for l in 0..L {
            add[j][l] = f64::from_bits(p.add_pos[j][l].to_bits() ^ (p.add_flip[j][l] & s.neg[l]));
        }
    }
    let mut y = p.free.step(&s.x, &add);
    let mut off = false;
    for l in 0..L {
        off |= !free(s.x[0][l], p.theta_stop[l]);
    }
    if off {
        for l in 0..L {
            if !free(s.x[0][l], p.theta_stop[l]) {
                let xl = [s.x[0][l], s.x[1][l], s.x[2][l], s.x[3][l]];
                let plant = &p.cfg[l].plant;
                let r = plant.region(xl[0]);
                let yl = plant.zoh[r].step(&xl, &p.cfg[l].add[r][usize::from(s.neg[l] != 0)]);
                for j in 0..NX {
                    y[j][l] = yl[j];
                }
                s.acc.stop[l] += 1;
            }
        }
    }
    s.x = y;
    if STATS {
        let applied = std::array::from_fn(|l| s.neg[l] == 0);
        let (positive, cycle_end) = (o.store_mask(t.positive), o.store_mask(t.cycle_end));
        s.acc.tick(&applied, &positive, &s.x[0], &cycle_end);
    }
    s.neg = o.mask64(o.not_mask(t.positive));
    (codes, t)
}

impl<const L: usize, O: LaneOps<L>> StaticState<L, O> {
    /// The state of `L` static loops, lane `l` from `st[l]`, the cores in the types of `o`.
    #[allow(clippy::needless_range_loop)]
    pub(super) fn load(o: O, st: [&LoopState; L]) -> Self {
        let mut x = [[0.0; L]; NX];
        for l in 0..L {
            for j in 0..NX {
                x[j][l] = st[l].x[j];
            }
        }
        Self {
            x,
            core: Regs::load(o, &Lanes::new(&st.map(|s| s.core))),
            neg: st.map(|s| neg_mask(s.u < 0.0)),
            acc: AccLanes::load(st),
        }
    }

    /// Lane `l`'s plant state.
    pub(super) fn lane_x(&self, l: usize) -> [f64; NX] {
        [self.x[0][l], self.x[1][l], self.x[2][l], self.x[3][l]]
    }

    /// Lane `l`'s applied command, ±1.
    pub(super) fn u(&self, l: usize) -> f64 {
        if self.neg[l] == 0 { 1.0 } else { -1.0 }
    }

    /// Lane `l` back into `st[l]` (all but the noise generator, which the caller draws
    /// from, and the tick index, which [`LoopState::end_run`] advances).
    #[allow(clippy::needless_range_loop)]
    pub(super) fn store(&self, o: O, st: [&mut LoopState; L]) {
        let core = self.core.store(o);
        for (l, s) in st.into_iter().enumerate() {
            for j in 0..NX {
                s.x[j] = self.x[j][l];
            }
            s.core = core.get(l);
            s.u = self.u(l);
            self.acc.store(l, s);
        }
    }
}

/// The constants of a dynamic condition's tick for `L` lanes (one loop configuration per
/// lane; one core configuration for all of them), packed as structure of arrays.
#[derive(Clone, Copy, Debug)]
pub(super) struct DynLanes<'a, const L: usize> {
    /// The core's configuration, shared.
    ptsa: Ptsa,
    /// The free region's transition of each lane, and its responses to the command and to
    /// the disturbance torque.
    free: ZohLanes<L>,
    gu: [[f64; L]; NX],
    gd: [[f64; L]; NX],
    /// The free region's constant torque of each lane (0), dyn·cm.
    stop0: [f64; L],
    /// Stop angle of each lane, rad.
    theta_stop: [f64; L],
    /// ADC gain of each lane, codes per rad, and its converter's mask.
    gain: [f64; L],
    mask: [u16; L],
    /// Pendulosity (g·cm), anisoinertia (g·cm²), and the `a_PA` (cm/s²) and `W_IA² − W_PA²`
    /// (rad²/s²) folded into each lane's `K_eff`.
    pendulosity: [f64; L],
    anisoinertia: [f64; L],
    /// Bias (cm/s²) and inertia (dyn·cm·s²) of each lane (see `config::torque_of_inputs`),
    /// whether it has effect terms (the others add the empty sum, `empty`), whether any has.
    bias: [f64; L],
    inertia: [f64; L],
    effects: [bool; L],
    any_effects: bool,
    empty: f64,
    a_pa0: [f64; L],
    wq0: [f64; L],
    /// Each lane's configuration: the effect terms, the stops, the added physics and the
    /// harmonic sums (rare or per-lane paths).
    cfg: [&'a LoopConfig; L],
    /// Some lane has physics added from outside the vocabulary; some lane sums a harmonic.
    physics: bool,
    harmonic: bool,
}

impl<'a, const L: usize> DynLanes<'a, L> {
    /// The constants of `L` dynamic loops, lane `l` of `cfg[l]` (all with the core
    /// configuration of `cfg[0]`).
    #[allow(clippy::needless_range_loop)]
    pub(super) fn new(cfg: [&'a LoopConfig; L]) -> Self {
        debug_assert!(cfg.iter().all(|c| c.ptsa == cfg[0].ptsa));
        let mut gu = [[0.0; L]; NX];
        let mut gd = [[0.0; L]; NX];
        for l in 0..L {
            let z = &cfg[l].plant.zoh[0];
            for j in 0..NX {
                gu[j][l] = z.gu[j];
                gd[j][l] = z.gd[j];
            }
        }
        Self {
            ptsa: cfg[0].ptsa,
            free: ZohLanes::new(std::array::from_fn(|l| &cfg[l].plant.zoh[0])),
            gu,
            gd,
            stop0: cfg.map(|c| c.plant.stop_torque[0]),
            theta_stop: cfg.map(|c| c.plant.theta_stop),
            gain: cfg.map(|c| c.adc.gain),
            mask: cfg.map(|c| c.adc.mask),
            pendulosity: cfg.map(|c| c.p),
            anisoinertia: cfg.map(|c| c.instr.anisoinertia_g_cm2),
            bias: cfg.map(|c| c.instr.bias_cm_s2),
            inertia: cfg.map(|c| c.instr.inertia_dyn_cm_s2),
            any_effects: cfg.iter().any(|c| !c.effect_terms.is_empty()),
            effects: cfg.map(|c| !c.effect_terms.is_empty()),
            empty: std::iter::empty::<f64>().sum(),
            a_pa0: cfg.map(|c| c.a_pa0),
            wq0: cfg.map(|c| c.wq0),
            physics: cfg.iter().any(|c| c.physics.is_some()),
            harmonic: cfg.iter().any(|c| c.harmonic != 0),
            cfg,
        }
    }
}

/// What a dynamic tick changes in `L` lanes: the plant state `x[j][lane]`, the cores (in the
/// types of the lane operations `O`), the applied command (±1), the statistics, the
/// harmonic sums and the absolute tick index.
#[derive(Clone, Copy)]
pub(super) struct DynState<const L: usize, O: LaneOps<L> = Each<L>> {
    x: [[f64; L]; NX],
    core: Regs<L, O>,
    u: [f64; L],
    acc: AccLanes<L>,
    harm: [[f64; 2]; L],
    harm_q: [[f64; 2]; L],
    k: [u64; L],
}

impl<const L: usize, O: LaneOps<L>> DynState<L, O> {
    /// The state of `L` dynamic loops, lane `l` from `st[l]`, the cores in the types of `o`.
    #[allow(clippy::needless_range_loop)]
    pub(super) fn load(o: O, st: [&LoopState; L]) -> Self {
        let mut x = [[0.0; L]; NX];
        for l in 0..L {
            for j in 0..NX {
                x[j][l] = st[l].x[j];
            }
        }
        Self {
            x,
            core: Regs::load(o, &Lanes::new(&st.map(|s| s.core))),
            u: st.map(|s| s.u),
            acc: AccLanes::load(st),
            harm: st.map(|s| s.totals.harm),
            harm_q: st.map(|s| s.totals.harm_q),
            k: st.map(|s| s.k),
        }
    }

    /// Lane `l` back into `st[l]` (all but the noise generator and the phasor, which the
    /// caller draws from and advances).
    #[allow(clippy::needless_range_loop)]
    pub(super) fn store(&self, o: O, st: [&mut LoopState; L]) {
        let core = self.core.store(o);
        for (l, s) in st.into_iter().enumerate() {
            for j in 0..NX {
                s.x[j] = self.x[j][l];
            }
            s.core = core.get(l);
            s.u = self.u[l];
            self.acc.store(l, s);
            s.totals.harm = self.harm[l];
            s.totals.harm_q = self.harm_q[l];
            s.k = self.k[l];
        }
    }

    /// Lane `l`'s applied command, ±1.
    pub(super) fn u(&self, l: usize) -> f64 {
        self.u[l]
    }

    /// Lane `l`'s tick index.
    pub(super) fn k(&self, l: usize) -> u64 {
        self.k[l]
    }

    /// Lane `l`'s plant state.
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    pub(super) fn lane_x(&self, l: usize) -> [f64; NX] {
        [self.x[0][l], self.x[1][l], self.x[2][l], self.x[3][l]]
    }
}

/// One tick of `L` lanes of dynamic conditions (or static ones with a harmonic requested):
/// sample each lane's pickoff with the ADC's additive term `bias[l]` (see [`Adc::bias`]), let
/// the cores decide, form each lane's disturbance torque from its inputs at mid-tick `ti[l]`
/// (the phasor and the condition's inputs, `LoopConfig::dynamic_inputs`: the static torque
/// of the inputs, the θ-dependent part of `a_PA` and of `W_IA² − W_PA²` beyond what `K_eff`
/// holds, the stop torque, added physics), step the plants with the applied commands, sum
/// the requested harmonic and the statistics; the decided polarities become the applied
/// commands. Returns the codes and what the cores decided.
#[allow(clippy::inline_always, reason = "per-tick path")]
#[inline(always)]
#[allow(clippy::needless_range_loop)]
pub(super) fn dynamic_tick<const L: usize, O: LaneOps<L>>(
    o: O,
    p: &DynLanes<'_, L>,
    s: &mut DynState<L, O>,
    bias: &[f64; L],
    ti: &[&TickInputs; L],
) -> ([i16; L], RegTicks<L, O>) {
    let codes = Adc::quantize_lanes(&p.gain, &p.mask, &s.x[3], bias);
    let t = p
        .ptsa
        .tick_regs(o, &mut s.core, o.load(codes.map(i32::from)));
    // The torque of the inputs and of θ's coupling to them (the stops' apart).
    let base = input_torque(p, &s.x[0], ti);
    let mut d = [0.0; L];
    for l in 0..L {
        d[l] = base[l] + p.stop0[l];
    }
    let mut extra = [0.0; L];
    if p.physics {
        for l in 0..L {
            if let Some(ph) = &p.cfg[l].physics {
                #[allow(clippy::cast_precision_loss)]
                let t_mid = (s.k[l] as f64 + 0.5) * p.cfg[l].t_s;
                extra[l] = ph.torque_dyn_cm(t_mid, &ti[l].inp, &s.lane_x(l));
                d[l] += extra[l];
            }
        }
    }
    let mut a = [[0.0; L]; NX];
    for j in 0..NX {
        for l in 0..L {
            a[j][l] = p.gu[j][l] * s.u[l] + p.gd[j][l] * d[l];
        }
    }
    let mut y = p.free.step(&s.x, &a);
    let mut off = false;
    for l in 0..L {
        off |= !free(s.x[0][l], p.theta_stop[l]);
    }
    if off {
        for l in 0..L {
            if !free(s.x[0][l], p.theta_stop[l]) {
                let plant = &p.cfg[l].plant;
                let xl = s.lane_x(l);
                let r = plant.region(xl[0]);
                let z = &plant.zoh[r];
                let mut dl = base[l] + plant.stop_torque[r];
                if p.cfg[l].physics.is_some() {
                    dl += extra[l];
                }
                let al: [f64; NX] = std::array::from_fn(|j| z.gu[j] * s.u[l] + z.gd[j] * dl);
                let yl = z.step(&xl, &al);
                for j in 0..NX {
                    y[j][l] = yl[j];
                }
                s.acc.stop[l] += 1;
            }
        }
    }
    if p.harmonic {
        for l in 0..L {
            let q = p.cfg[l];
            if q.harmonic == 0 {
                continue;
            }
            let (sn, cs) = (ti[l].s, ti[l].c);
            let (hs, hc) = if q.harmonic == 1 {
                (sn, cs)
            } else {
                (2.0 * sn * cs, cs * cs - sn * sn)
            };
            let u = s.u[l];
            s.harm[l][0] += u * hs;
            s.harm[l][1] += u * hc;
            let torque = q.sf * (u - q.tau_t * (y[2][l] - s.x[2][l]))
                + q.ip * (y[1][l] - s.x[1][l])
                + q.cp * (y[0][l] - s.x[0][l]);
            s.harm_q[l][0] += torque * hs;
            s.harm_q[l][1] += torque * hc;
        }
    }
    s.x = y;
    let applied = std::array::from_fn(|l| s.u[l] > 0.0);
    let (positive, cycle_end) = (o.store_mask(t.positive), o.store_mask(t.cycle_end));
    s.acc.tick(&applied, &positive, &s.x[0], &cycle_end);
    // ±1: the sign bit of 1.0 set where the decided polarity is negative.
    let neg = o.mask64(o.not_mask(t.positive));
    for l in 0..L {
        s.k[l] += 1;
        s.u[l] = f64::from_bits(1f64.to_bits() | (neg[l] & (1 << 63)));
    }
    (codes, t)
}

/// The disturbance torque of each lane's inputs at mid-tick `ti[l]` with the pendulum at
/// `theta[l]` (rad), dyn·cm, the stops' apart: `LoopConfig::static_torque` and θ's coupling
/// to `a_PA` and `W_IA² − W_PA²` beyond what `K_eff` holds (see [`dynamic_tick`]).
#[allow(clippy::inline_always, reason = "per-tick path")]
#[inline(always)]
#[allow(clippy::needless_range_loop)]
fn input_torque<const L: usize>(
    p: &DynLanes<'_, L>,
    theta: &[f64; L],
    ti: &[&TickInputs; L],
) -> [f64; L] {
    // The inputs the torque needs, lane by lane, then the torque in structure of arrays.
    let mut a_ia = [0.0; L];
    let mut a_pa = [0.0; L];
    let mut dw_oa = [0.0; L];
    let mut w_ia = [0.0; L];
    let mut w_pa = [0.0; L];
    for l in 0..L {
        let inp = &ti[l].inp;
        a_ia[l] = inp.a_cm_s2[IA];
        a_pa[l] = inp.a_cm_s2[PA];
        dw_oa[l] = inp.dw_rad_s2[OA];
        w_ia[l] = inp.w_rad_s[IA];
        w_pa[l] = inp.w_rad_s[PA];
    }
    let mut eff = [p.empty; L];
    if p.any_effects {
        for l in 0..L {
            if p.effects[l] {
                eff[l] = p.cfg[l].effects_cm_s2(&ti[l].inp);
            }
        }
    }
    // `LoopConfig::static_torque`, its constants per lane, and θ's coupling to `a_PA` and
    // `W_IA² − W_PA²` beyond what `K_eff` holds.
    let mut base = [0.0; L];
    for l in 0..L {
        let wq = w_ia[l] * w_ia[l] - w_pa[l] * w_pa[l];
        base[l] = torque_of_inputs(
            [p.pendulosity[l], p.bias[l], p.inertia[l], p.anisoinertia[l]],
            eff[l],
            [a_ia[l], dw_oa[l], w_ia[l], w_pa[l]],
        ) + theta[l]
            * (-p.pendulosity[l] * (a_pa[l] - p.a_pa0[l]) + p.anisoinertia[l] * (wq - p.wq0[l]));
    }
    base
}
