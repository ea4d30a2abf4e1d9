//! The closed loop's tick of a static condition, once, for `L` loops side by side.
//!
//! [`static_tick`] is the whole tick (the ADC's code of the demodulated pickoff, the core's
//! decision through [`ptsa_core::Ptsa::tick_lanes`], the plant's exact step with the applied
//! polarity, a tick on a stop, the per-tick statistics) over `L` lanes in structure of
//! arrays. The single loop runs it with one lane (`ClosedLoop::run`'s static path); the batch
//! engine with 8 (`batch`), inside [`dispatch`], so that the compiler may put 4 or 8 lanes
//! in one SIMD instruction on the CPU it runs on. Every step is a loop over the lanes with the
//! same operations in the same order for every `L` (no fused multiply-add: Rust never
//! contracts `a·b + c`), so a lane's result does not depend on `L` or on the CPU: bit for bit
//! the single loop's.

use ptsa_core::{LaneTicks, Lanes, Ptsa};

use crate::model::condition::{IA, OA, PA};
use crate::model::plant::{NX, Plant, ZohLanes};
use crate::simulation::sim::{
    Acc, Adc, ClosedLoop, DynParams, DynRun, StaticParams, StaticRunState, TickInputs,
    torque_of_inputs,
};

/// Run `f` with the SIMD instruction sets of this CPU enabled for everything inlined into
/// it (runtime detection by `pulp`: AVX2 where present, the baseline SSE2 otherwise). `f`'s
/// `with_simd` and the functions on the tick path are `#[inline(always)]` so that they are
/// compiled inside.
#[inline]
pub(crate) fn dispatch<F: pulp::WithSimd>(f: F) -> F::Output {
    pulp::Arch::new().dispatch(f)
}

/// The constants of a static condition's tick for `L` lanes (one instrument, condition and
/// ADC per lane; one core configuration for all of them).
#[derive(Clone, Copy, Debug)]
pub(crate) struct StaticLanes<'a, const L: usize> {
    /// The core's configuration, shared.
    pub(crate) ptsa: Ptsa,
    /// The free region's transition of each lane.
    pub(crate) free: ZohLanes<L>,
    /// The free region's plant input of each lane with the positive polarity applied, and
    /// the bits that flip it to the negative one (so that the polarity selects it without a
    /// branch).
    pub(crate) add_pos: [[f64; L]; NX],
    pub(crate) add_flip: [[u64; L]; NX],
    /// Stop angle of each lane, rad.
    pub(crate) theta_stop: [f64; L],
    /// ADC gain of each lane, codes per rad.
    pub(crate) gain: [f64; L],
    /// Each lane's plant and plant inputs by region and polarity (`add[region][polarity]`,
    /// polarity 0 = positive): the stops, a rare and cold path.
    pub(crate) plant: [&'a Plant; L],
    pub(crate) add: [&'a [[[f64; NX]; 2]; 3]; L],
}

impl<'a, const L: usize> StaticLanes<'a, L> {
    /// The constants of lane `l` from its plant, plant inputs and ADC.
    #[allow(clippy::needless_range_loop)]
    pub(crate) fn new(
        ptsa: Ptsa,
        plant: [&'a Plant; L],
        add: [&'a [[[f64; NX]; 2]; 3]; L],
        adc: [&Adc; L],
    ) -> Self {
        let mut add_pos = [[0.0; L]; NX];
        let mut add_flip = [[0u64; L]; NX];
        for l in 0..L {
            for j in 0..NX {
                add_pos[j][l] = add[l][0][0][j];
                add_flip[j][l] = add[l][0][0][j].to_bits() ^ add[l][0][1][j].to_bits();
            }
        }
        Self {
            ptsa,
            free: ZohLanes::new(std::array::from_fn(|l| &plant[l].zoh[0])),
            add_pos,
            add_flip,
            theta_stop: std::array::from_fn(|l| plant[l].theta_stop),
            gain: std::array::from_fn(|l| adc[l].gain),
            plant,
            add,
        }
    }
}

/// The per-tick statistics of `L` lanes ([`Acc`]'s fields, structure of arrays): ticks,
/// applied-command sum, `Σθ²` (rad²) and `max |θ|` (rad), limit cycles and those with two
/// reversals, ticks on a stop, reversals in the current cycle, the last decided polarity.
#[derive(Clone, Copy, Debug)]
pub(crate) struct AccLanes<const L: usize> {
    ticks: [u64; L],
    sum_u: [i64; L],
    sum_theta2: [f64; L],
    max_theta: [f64; L],
    cycles: [u64; L],
    cycles_two: [u64; L],
    pub(crate) stop: [u64; L],
    rev: [u32; L],
    prev_positive: [bool; L],
}

impl<const L: usize> AccLanes<L> {
    /// The statistics of `L` runs, lane `l` from `acc[l]`.
    pub(crate) fn load(acc: [&Acc; L]) -> Self {
        Self {
            ticks: acc.map(|a| a.ticks),
            sum_u: acc.map(|a| a.sum_u),
            sum_theta2: acc.map(|a| a.sum_theta2),
            max_theta: acc.map(|a| a.max_theta),
            cycles: acc.map(|a| a.cycles),
            cycles_two: acc.map(|a| a.cycles_two),
            stop: acc.map(|a| a.stop),
            rev: acc.map(|a| a.rev),
            prev_positive: acc.map(|a| a.prev_positive),
        }
    }

    /// Lane `l`'s statistics.
    pub(crate) fn get(&self, l: usize) -> Acc {
        Acc {
            ticks: self.ticks[l],
            sum_u: self.sum_u[l],
            sum_theta2: self.sum_theta2[l],
            max_theta: self.max_theta[l],
            cycles: self.cycles[l],
            cycles_two: self.cycles_two[l],
            stop: self.stop[l],
            rev: self.rev[l],
            prev_positive: self.prev_positive[l],
        }
    }

    /// One tick of every lane: the applied polarity (`applied_positive`), the decided one,
    /// the pendulum angle after the tick (rad), whether the tick closed a limit cycle. The
    /// statistics' one definition, branch-free so that the lanes share SIMD instructions.
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    pub(crate) fn tick(
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

/// What a static tick changes in `L` lanes: the plant state `x[j][lane]`, the cores, the
/// applied polarity (all ones where negative) and the statistics.
#[derive(Clone, Copy, Debug)]
pub(crate) struct StaticState<const L: usize> {
    pub(crate) x: [[f64; L]; NX],
    pub(crate) core: Lanes<L>,
    pub(crate) neg: [u64; L],
    pub(crate) acc: AccLanes<L>,
}

/// The mask of `neg` for an applied polarity: all ones where negative.
#[allow(clippy::inline_always, reason = "per-tick path")]
#[inline(always)]
pub(crate) fn neg_mask(negative: bool) -> u64 {
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
pub(crate) fn static_tick<const L: usize, const STATS: bool>(
    p: &StaticLanes<'_, L>,
    s: &mut StaticState<L>,
    bias: &[f64; L],
) -> ([i16; L], LaneTicks<L>) {
    let mut codes = [0i16; L];
    for l in 0..L {
        codes[l] = Adc::quantize_with(p.gain[l], s.x[3][l], bias[l]);
    }
    let t = p.ptsa.tick_lanes(&mut s.core, &codes);
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
                let r = p.plant[l].region(xl[0]);
                let yl = p.plant[l].zoh[r].step(&xl, &p.add[l][r][usize::from(s.neg[l] != 0)]);
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
        s.acc.tick(&applied, &t.positive, &s.x[0], &t.cycle_end);
    }
    for l in 0..L {
        s.neg[l] = neg_mask(!t.positive[l]);
    }
    (codes, t)
}

impl<const L: usize> StaticState<L> {
    /// The state of `L` static runs in progress, lane `l` from `runs[l]`.
    #[allow(clippy::needless_range_loop)]
    pub(crate) fn load(runs: [&StaticRunState; L]) -> Self {
        let mut x = [[0.0; L]; NX];
        for l in 0..L {
            for j in 0..NX {
                x[j][l] = runs[l].x[j];
            }
        }
        Self {
            x,
            core: Lanes::new(&std::array::from_fn(|l| runs[l].core)),
            neg: std::array::from_fn(|l| neg_mask(runs[l].ui != 0)),
            acc: AccLanes::load(std::array::from_fn(|l| &runs[l].acc)),
        }
    }

    /// Lane `l` back into `runs[l]`.
    #[allow(clippy::needless_range_loop)]
    pub(crate) fn store(&self, runs: [&mut StaticRunState; L]) {
        for (l, r) in runs.into_iter().enumerate() {
            for j in 0..NX {
                r.x[j] = self.x[j][l];
            }
            r.core = self.core.get(l);
            r.ui = usize::from(self.neg[l] != 0);
            r.acc = self.acc.get(l);
        }
    }
}

impl<'a> StaticLanes<'a, 1> {
    /// The constants of one static run.
    pub(crate) fn one_of(p: &'a StaticParams) -> Self {
        Self::new(p.ptsa, [&p.plant], [&p.add], [&p.adc])
    }
}

/// The constants of a dynamic condition's tick for `L` lanes (one loop per lane, with its
/// instrument, condition, effects and ADC; one core configuration for all of them).
#[derive(Clone, Copy, Debug)]
pub(crate) struct DynLanes<'a, const L: usize> {
    /// The core's configuration, shared.
    pub(crate) ptsa: Ptsa,
    /// The free region's transition of each lane, and its responses to the command and to
    /// the disturbance torque.
    pub(crate) free: ZohLanes<L>,
    pub(crate) gu: [[f64; L]; NX],
    pub(crate) gd: [[f64; L]; NX],
    /// The free region's constant torque of each lane (0), dyn·cm.
    pub(crate) stop0: [f64; L],
    /// Stop angle of each lane, rad.
    pub(crate) theta_stop: [f64; L],
    /// ADC gain of each lane, codes per rad.
    pub(crate) gain: [f64; L],
    /// Pendulosity (g·cm), anisoinertia (g·cm²), and the `a_PA` (cm/s²) and `W_IA² − W_PA²`
    /// (rad²/s²) folded into each lane's `K_eff`.
    pub(crate) pendulosity: [f64; L],
    pub(crate) anisoinertia: [f64; L],
    /// Bias (cm/s²) and inertia (dyn·cm·s²) of each lane (see `sim::torque_of_inputs`),
    /// whether it has effect terms (the others add the empty sum, `empty`), whether any has.
    pub(crate) bias: [f64; L],
    pub(crate) inertia: [f64; L],
    pub(crate) effects: [bool; L],
    pub(crate) any_effects: bool,
    pub(crate) empty: f64,
    pub(crate) a_pa0: [f64; L],
    pub(crate) wq0: [f64; L],
    /// Each lane's loop and tick constants: the static torque of the inputs, the stops, the
    /// added physics and the harmonic sums (rare or per-lane paths).
    pub(crate) lp: [&'a ClosedLoop; L],
    pub(crate) dp: [&'a DynParams; L],
    /// Some lane has physics added from outside the vocabulary; some lane sums a harmonic.
    pub(crate) physics: bool,
    pub(crate) harmonic: bool,
}

impl<'a, const L: usize> DynLanes<'a, L> {
    /// The constants of lane `l` from its loop `lp[l]` and tick constants `dp[l]` (all with
    /// the core configuration of `dp[0]`).
    #[allow(clippy::needless_range_loop)]
    pub(crate) fn new(lp: [&'a ClosedLoop; L], dp: [&'a DynParams; L]) -> Self {
        debug_assert!(dp.iter().all(|p| p.ptsa == dp[0].ptsa));
        let mut gu = [[0.0; L]; NX];
        let mut gd = [[0.0; L]; NX];
        for l in 0..L {
            let z = &lp[l].plant.zoh[0];
            for j in 0..NX {
                gu[j][l] = z.gu[j];
                gd[j][l] = z.gd[j];
            }
        }
        Self {
            ptsa: dp[0].ptsa,
            free: ZohLanes::new(std::array::from_fn(|l| &lp[l].plant.zoh[0])),
            gu,
            gd,
            stop0: std::array::from_fn(|l| lp[l].plant.stop_torque[0]),
            theta_stop: std::array::from_fn(|l| lp[l].plant.theta_stop),
            gain: std::array::from_fn(|l| dp[l].adc.gain),
            pendulosity: std::array::from_fn(|l| dp[l].p),
            anisoinertia: std::array::from_fn(|l| dp[l].di),
            bias: std::array::from_fn(|l| lp[l].instr.bias_cm_s2),
            inertia: std::array::from_fn(|l| lp[l].instr.inertia_dyn_cm_s2),
            any_effects: lp.iter().any(|l| !l.effect_terms.is_empty()),
            effects: std::array::from_fn(|l| !lp[l].effect_terms.is_empty()),
            empty: std::iter::empty::<f64>().sum(),
            a_pa0: std::array::from_fn(|l| lp[l].a_pa0),
            wq0: std::array::from_fn(|l| lp[l].wq0),
            physics: lp.iter().any(|l| l.physics.is_some()),
            harmonic: dp.iter().any(|p| p.harmonic != 0),
            lp,
            dp,
        }
    }
}

/// What a dynamic tick changes in `L` lanes: the plant state `x[j][lane]`, the cores, the
/// applied command (±1), the statistics, the harmonic sums and the absolute tick index.
#[derive(Clone, Copy, Debug)]
pub(crate) struct DynState<const L: usize> {
    pub(crate) x: [[f64; L]; NX],
    pub(crate) core: Lanes<L>,
    pub(crate) u: [f64; L],
    pub(crate) acc: AccLanes<L>,
    pub(crate) harm: [[f64; 2]; L],
    pub(crate) harm_q: [[f64; 2]; L],
    pub(crate) k: [u64; L],
}

impl<const L: usize> DynState<L> {
    /// The state of `L` dynamic runs in progress, lane `l` from `runs[l]`.
    #[allow(clippy::needless_range_loop)]
    pub(crate) fn load(runs: [&DynRun; L]) -> Self {
        let mut x = [[0.0; L]; NX];
        for l in 0..L {
            for j in 0..NX {
                x[j][l] = runs[l].x[j];
            }
        }
        Self {
            x,
            core: Lanes::new(&std::array::from_fn(|l| runs[l].core)),
            u: std::array::from_fn(|l| runs[l].u),
            acc: AccLanes::load(std::array::from_fn(|l| &runs[l].acc)),
            harm: std::array::from_fn(|l| runs[l].harm),
            harm_q: std::array::from_fn(|l| runs[l].harm_q),
            k: std::array::from_fn(|l| runs[l].k),
        }
    }

    /// Lane `l` back into `runs[l]` (all but the noise generator and the phasor, which the
    /// caller keeps).
    #[allow(clippy::needless_range_loop)]
    pub(crate) fn store(&self, runs: [&mut DynRun; L]) {
        for (l, r) in runs.into_iter().enumerate() {
            for j in 0..NX {
                r.x[j] = self.x[j][l];
            }
            r.core = self.core.get(l);
            r.u = self.u[l];
            r.acc = self.acc.get(l);
            r.harm = self.harm[l];
            r.harm_q = self.harm_q[l];
            r.k = self.k[l];
        }
    }

    /// Lane `l`'s plant state.
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    pub(crate) fn lane_x(&self, l: usize) -> [f64; NX] {
        [self.x[0][l], self.x[1][l], self.x[2][l], self.x[3][l]]
    }
}

/// One tick of `L` lanes of dynamic conditions (or static ones with a harmonic requested):
/// sample each lane's pickoff with the ADC's additive term `bias[l]` (see [`Adc::bias`]), let
/// the cores decide, form each lane's disturbance torque from its inputs at mid-tick `ti[l]`
/// (the phasor and the condition's inputs, `ClosedLoop::dynamic_inputs`: the static torque
/// of the inputs, the θ-dependent part of `a_PA` and of `W_IA² − W_PA²` beyond what `K_eff`
/// holds, the stop torque, added physics), step the plants with the applied commands, sum
/// the requested harmonic and the statistics; the decided polarities become the applied
/// commands. Returns the codes and what the cores decided.
#[allow(clippy::inline_always, reason = "per-tick path")]
#[inline(always)]
#[allow(clippy::needless_range_loop)]
pub(crate) fn dynamic_tick<const L: usize>(
    p: &DynLanes<'_, L>,
    s: &mut DynState<L>,
    bias: &[f64; L],
    ti: &[&TickInputs; L],
) -> ([i16; L], LaneTicks<L>) {
    let mut codes = [0i16; L];
    for l in 0..L {
        codes[l] = Adc::quantize_with(p.gain[l], s.x[3][l], bias[l]);
    }
    let t = p.ptsa.tick_lanes(&mut s.core, &codes);
    // The torque of the inputs and of θ's coupling to them (the stops' apart).
    let base = input_torque(p, &s.x[0], ti);
    let mut d = [0.0; L];
    for l in 0..L {
        d[l] = base[l] + p.stop0[l];
    }
    let mut extra = [0.0; L];
    if p.physics {
        for l in 0..L {
            if let Some(ph) = &p.lp[l].physics {
                #[allow(clippy::cast_precision_loss)]
                let t_mid = (s.k[l] as f64 + 0.5) * p.dp[l].t_s;
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
                let plant = &p.lp[l].plant;
                let xl = s.lane_x(l);
                let r = plant.region(xl[0]);
                let z = &plant.zoh[r];
                let mut dl = base[l] + plant.stop_torque[r];
                if p.lp[l].physics.is_some() {
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
            let q = p.dp[l];
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
    s.acc.tick(&applied, &t.positive, &s.x[0], &t.cycle_end);
    for l in 0..L {
        s.k[l] += 1;
        s.u[l] = if t.positive[l] { 1.0 } else { -1.0 };
    }
    (codes, t)
}

/// The disturbance torque of each lane's inputs at mid-tick `ti[l]` with the pendulum at
/// `theta[l]` (rad), dyn·cm, the stops' apart: `ClosedLoop::static_torque` and θ's coupling
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
                eff[l] = p.lp[l].effects_cm_s2(&ti[l].inp);
            }
        }
    }
    // `ClosedLoop::static_torque`, its constants per lane, and θ's coupling to `a_PA` and
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
