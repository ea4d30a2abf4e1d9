//! The closed loop's state: everything a tick changes, plain data ([`LoopState`]), and the
//! running totals it keeps ([`Totals`]).

use std::num::Wrapping;

use ptsa_core::State;

use super::config::LoopConfig;
use super::noise::NoiseSource;
use crate::model::plant::NX;

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

/// The state of a closed loop: the noise generator, the core, the running totals (with the
/// reversals of the current limit cycle and the polarity decided last), the plant state, the
/// applied command, the absolute tick index and the phasor of a dynamic condition.
#[derive(Clone, Debug)]
pub(super) struct LoopState {
    pub(super) rng: NoiseSource,
    pub(super) core: State,
    pub(super) totals: Totals,
    /// Current reversals in the current limit cycle.
    pub(super) reversals: u32,
    /// The polarity decided last is positive.
    pub(super) prev_positive: bool,
    /// Plant state `[θ, θ', i, y]`.
    pub(super) x: [f64; NX],
    /// Command applied in the current interval (decided at the previous tick), ±1.
    pub(super) u: f64,
    /// Ticks since the loop was built.
    pub(super) k: u64,
    /// The phasor `sin, cos(ωt)` at tick `phasor_k` (see [`LoopConfig::phasor`]); made so
    /// at the start of a dynamic run when `phasor_k` is not `k` (a static run or a new
    /// condition in between).
    pub(super) phasor: (f64, f64),
    pub(super) phasor_k: u64,
}

/// Where a run started: the core's pulse count and the applied polarity (true = positive),
/// from which a run without per-tick statistics gets its ticks and applied-command sum
/// ([`LoopState::end_run`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct RunStart {
    pulses0: Wrapping<u32>,
    first: bool,
}

impl LoopState {
    /// A loop at rest: the core `core` (after reset), pendulum at null, current at zero, the
    /// positive polarity applied, noise from `rng`.
    pub(super) fn new(core: State, rng: NoiseSource) -> Self {
        Self {
            rng,
            core,
            totals: Totals::default(),
            reversals: 0,
            prev_positive: true,
            x: [0.0; NX],
            u: 1.0,
            k: 0,
            phasor: (0.0, 1.0),
            phasor_k: u64::MAX,
        }
    }

    /// The start of a run.
    pub(super) fn run_start(&self) -> RunStart {
        RunStart {
            pulses0: self.core.total_pulses(),
            first: self.u > 0.0,
        }
    }

    /// The end of a run of `n` ticks that started at `start`. A static run's kernels do not
    /// count the tick index (they add `n` here); without `stats` the run kept no per-tick
    /// statistics: its ticks and applied-command sum come from the core's count, the applied
    /// polarities being the decided ones shifted by one tick: `Σu = 2·(decided + first −
    /// last) − n` with `decided` the pulses since the start, `first` and `last` the applied
    /// polarities at the start and the end (true = positive).
    pub(super) fn end_run(&mut self, start: RunStart, n: u64, dynamic: bool, stats: bool) {
        if !dynamic {
            self.k += n;
        }
        if !stats {
            let decided = i64::from((self.core.total_pulses() - start.pulses0).0);
            #[allow(clippy::cast_possible_wrap)]
            let n_i = n as i64;
            self.totals.ticks += n;
            self.totals.sum_u +=
                2 * (decided + i64::from(start.first) - i64::from(self.u > 0.0)) - n_i;
        }
        self.totals.pulses = u64::from(self.core.total_pulses().0);
    }

    /// Make the phasor that of tick `k` for the condition of `cfg`, unless it is.
    pub(super) fn sync_phasor(&mut self, cfg: &LoopConfig) {
        if self.phasor_k != self.k {
            self.phasor = cfg.phasor(self.k);
            self.phasor_k = self.k;
        }
    }
}
