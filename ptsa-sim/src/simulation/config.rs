//! The closed loop's configuration: everything a tick reads and never writes, built once
//! from the instrument file, the condition, the effects and the run's options
//! ([`LoopConfig`]), beside the state a tick changes (`state::LoopState`). The kernels take
//! `(&LoopConfig, &mut LoopState)`, or lanes of them.

use std::sync::Arc;

use ptsa_core::Ptsa;
use ptsa_core::adc::AdcFormat;

use super::noise::NoiseSource;
use crate::model::condition::{CaseInputs, Condition, IA, OA, PA, Prepared};
use crate::model::effects::{Effects, TermFn};
use crate::model::instrument::Instrument;
use crate::model::plant::{NX, Plant};

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

/// The ADC: demodulated pickoff (rad) to a code, with the quadrature leak and noise; the
/// design's signed 16-bit converter, or the board's (`[board]` of the instrument file) through
/// the conversion of [`ptsa_core::adc`].
#[derive(Clone, Copy, Debug)]
pub(super) struct Adc {
    /// Codes per rad, in units of the `i16` sample.
    pub(super) gain: f64,
    /// Offset (quadrature leak, the offset at the amplifier's output and, with a board, the
    /// front end's level shift), in units of the `i16` sample.
    pub(super) offset: f64,
    /// The constant that places the input in the converter's range and rounds: half a step
    /// of the converter, plus 2^15 for a bipolar (two's complement) range (32768.5 for the
    /// design's 16-bit converter).
    pub(super) round: f64,
    /// The bits of the sample the converter sets ([`AdcFormat::mask`]: 0xFFFF for 16 bits).
    pub(super) mask: u16,
    /// Noise, codes rms.
    pub(super) noise: f64,
}

impl Adc {
    /// The ADC of `instr`, with its noise or without.
    fn of(instr: &Instrument, noise: bool) -> Self {
        let lsb_v = instr.adc_full_scale_v / 32768.0;
        let noise = if noise { instr.noise_v_rms } else { 0.0 };
        let mut offset = (instr.quadrature_v * instr.phase_error_rad.sin() * instr.amp_gain
            + instr.adc_offset_v)
            / lsb_v;
        let (round, mask) = match &instr.board {
            None => (32768.5, AdcFormat::SIGNED_16.mask()),
            Some(b) => {
                offset += b.front_end_offset_v / b.reference_v * 65536.0;
                (b.round_term(), b.adc.mask())
            }
        };
        Self {
            gain: instr.lsb_per_rad() * instr.phase_error_rad.cos(),
            offset,
            round,
            mask,
            noise: noise * instr.amp_gain / lsb_v,
        }
    }

    /// The additive term of one sample: offset, the range's placement and rounding, and a
    /// noise draw (none without noise). Drawn apart from the plant state (ahead, in blocks,
    /// or shared between the lanes of a batch), so that the chain from the plant state to
    /// the code is one multiply-add ([`Adc::quantize`]).
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    pub(super) fn bias(&self, rng: &mut NoiseSource) -> f64 {
        let mut bias = self.offset + self.round;
        if self.noise != 0.0 {
            bias += self.noise * rng.normal();
        }
        bias
    }

    /// The code of `y` with the additive term `bias` (see [`Adc::bias`]).
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    pub(super) fn quantize(&self, y: f64, bias: f64) -> i16 {
        Self::quantize_with(self.gain, self.mask, y, bias)
    }

    /// The code of `y` with the gain `gain` (codes per rad), the converter's `mask` and the
    /// additive term `bias`: [`AdcFormat::sample_masked`] of `y·gain + bias`, the one
    /// conversion the firmware's processor-in-the-loop image uses too.
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    pub(super) fn quantize_with(gain: f64, mask: u16, y: f64, bias: f64) -> i16 {
        AdcFormat::sample_masked(mask, y * gain + bias)
    }

    /// [`Adc::quantize_with`] of `L` lanes: [`AdcFormat::sample_lanes`] of
    /// `y[l]·gain[l] + bias[l]`. (`quantize_with` is not this with one lane: written so, the
    /// single loop's fast path ran 6 % slower, `ptsa bench --ticks 32000000 --runs 5`, 1.87e8
    /// and 1.90e8 against 2.00e8 and 2.02e8 ticks/s; the batch tests hold the two equal.)
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    pub(super) fn quantize_lanes<const L: usize>(
        gain: &[f64; L],
        mask: &[u16; L],
        y: &[f64; L],
        bias: &[f64; L],
    ) -> [i16; L] {
        AdcFormat::sample_lanes(mask, &std::array::from_fn(|l| y[l] * gain[l] + bias[l]))
    }

    /// The constants as bits (to compare them exactly). The destructuring names every
    /// field, so one added here does not compile until it is part of the key.
    pub(super) fn bits(&self) -> [u64; 5] {
        let Adc {
            gain,
            offset,
            round,
            mask,
            noise,
        } = self;
        [
            gain.to_bits(),
            offset.to_bits(),
            round.to_bits(),
            u64::from(*mask),
            noise.to_bits(),
        ]
    }
}

/// The θ-independent torque of the inputs, dyn·cm, for pendulosity `p` (g·cm), bias
/// (cm/s²), inertia (dyn·cm·s²) and anisoinertia `di` (g·cm²), the effect terms' extra
/// indicated acceleration `eff` (cm/s²) and the inputs `[a_IA (cm/s²), ω'_OA (rad/s²), ω_IA,
/// ω_PA (rad/s)]`: `P·(a_IA + bias + eff) − I·ω'_OA + ΔI·ω_IA·ω_PA`. The one expression of
/// [`LoopConfig::static_torque`] and of the dynamic tick's lanes.
#[allow(clippy::inline_always, reason = "per-tick path")]
#[inline(always)]
pub(super) fn torque_of_inputs(
    [p, bias, inertia, di]: [f64; 4],
    eff: f64,
    [a_ia, dw_oa, w_ia, w_pa]: [f64; 4],
) -> f64 {
    p * (a_ia + bias + eff) - inertia * dw_oa + di * w_ia * w_pa
}

/// Ticks between exact evaluations of a dynamic condition's phasor `sin, cos(ωt)`
/// ([`LoopConfig::dynamic_inputs`]): at every tick index that is a multiple of it, the phasor
/// is `sin_cos(ω·(k + ½)·t_s)`; in between, it is advanced by the rotation of one tick. A
/// function of the absolute tick index `k` alone.
pub(super) const PHASOR_BLOCK: u64 = 4096;

/// The phasor and the inputs of one dynamic tick ([`LoopConfig::dynamic_inputs`]).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct TickInputs {
    /// `sin(ωt)` at mid-tick.
    pub(super) s: f64,
    /// `cos(ωt)` at mid-tick.
    pub(super) c: f64,
    /// The condition's inputs there.
    pub(super) inp: CaseInputs,
}

/// A closed loop's configuration: the instrument (with the effects' parameter changes), the
/// core, the plant discretised for the condition, the condition, the effects and the added
/// physics, the ADC, and the constants of a static tick (the plant inputs by region and
/// polarity) and of a dynamic one. Built once ([`LoopConfig::new`]); a run only reads it.
#[derive(Clone, Debug)]
pub(super) struct LoopConfig {
    pub(super) instr: Instrument,
    pub(super) ptsa: Ptsa,
    /// The plant, discretised for the condition's `K_eff`.
    pub(super) plant: Plant,
    /// The `K_eff` (dyn·cm/rad) `plant` was discretised for (NaN before the first): a
    /// condition that leaves it as it was (a record's per-gate acceleration along IA) keeps
    /// the plant instead of computing its matrix exponentials again.
    plant_k_eff: f64,
    pub(super) prep: Prepared,
    /// The non-zero effect terms, `(term per unit coefficient, coefficient)`.
    pub(super) effect_terms: Vec<(TermFn, f64)>,
    /// Physics added from outside the vocabulary.
    pub(super) physics: Option<Arc<dyn ExtraPhysics>>,
    /// The loop ticks through the dynamic tick: a dynamic condition, added physics, or a
    /// harmonic requested.
    pub(super) dynamic: bool,
    /// The harmonic measured (0 = none).
    pub(super) harmonic: u32,
    pub(super) adc: Adc,
    /// Constant part of the disturbance torque, dyn·cm.
    pub(super) d0: f64,
    /// `a_PA` (cm/s²) and `W_IA² − W_PA²` (rad²/s²) folded into `K_eff`.
    pub(super) a_pa0: f64,
    pub(super) wq0: f64,
    /// Pendulosity, g·cm.
    pub(super) p: f64,
    /// The static plant inputs `add[region][polarity]` ([`add_vectors`]).
    pub(super) add: [[[f64; NX]; 2]; 3],
    /// The clock period, s; `ω` (rad/s) and the phasor's rotation per tick `sin, cos(ω·t_s)`.
    pub(super) t_s: f64,
    pub(super) w: f64,
    pub(super) sr: f64,
    pub(super) cr: f64,
    /// The actual scale factor (cm/s²), `τ/t_s`, `I/(P·t_s)`, `C/(P·t_s)`: the harmonic
    /// sums of the charge-balance signal.
    pub(super) sf: f64,
    pub(super) tau_t: f64,
    pub(super) ip: f64,
    pub(super) cp: f64,
}

impl LoopConfig {
    /// The configuration of `instr` (with `effects`' parameter changes applied,
    /// [`Effects::apply_parameters`]) in `cond` with `effects`' terms, the core configuration
    /// `core`, the pickoff noise on or off, the harmonic measured (0 = none).
    ///
    /// # Panics
    /// If `core` is refused by `ptsa-core` (the default never is).
    pub(super) fn new(
        instr: &Instrument,
        cond: &Condition,
        effects: &Effects,
        core: &ptsa_core::Config,
        noise: bool,
        harmonic: u32,
    ) -> Self {
        let instr = if effects.has_parameters() {
            effects.apply_parameters(instr)
        } else {
            instr.clone()
        };
        let ptsa = core.build().expect("valid PTSA configuration");
        let t_s = 1.0 / instr.clock_hz;
        let p = instr.pendulosity_g_cm();
        let mut c = Self {
            adc: Adc::of(&instr, noise),
            ptsa,
            // Discretised for the condition's K_eff by `set_condition`.
            plant: Plant::default(),
            plant_k_eff: f64::NAN,
            prep: Prepared::default(),
            effect_terms: Vec::new(),
            physics: None,
            dynamic: false,
            harmonic,
            d0: 0.0,
            a_pa0: 0.0,
            wq0: 0.0,
            p,
            add: [[[0.0; NX]; 2]; 3],
            t_s,
            w: 0.0,
            sr: 0.0,
            cr: 1.0,
            sf: instr.actual_sf_cm_s2(),
            tau_t: instr.torquer_tau_s / t_s,
            ip: instr.inertia_dyn_cm_s2 / (p * t_s),
            cp: instr.damping_dyn_cm_s / (p * t_s),
            instr,
        };
        c.set_condition(cond, effects);
        c
    }

    /// The same loop in `cond` with `effects`' terms (the instrument as it is: parameter
    /// changes are applied once, by [`LoopConfig::new`]).
    pub(super) fn set_condition(&mut self, cond: &Condition, effects: &Effects) {
        let instr = &self.instr;
        let prep = cond.prepare(instr.g_cm_s2);
        let m = prep.mean_inputs();
        let p = self.p;
        let di = instr.anisoinertia_g_cm2;
        self.a_pa0 = m.a_cm_s2[PA];
        self.wq0 = m.w_rad_s[IA].powi(2) - m.w_rad_s[PA].powi(2);
        let k_eff = instr.spring_dyn_cm_rad + p * self.a_pa0 - di * self.wq0;
        if k_eff.to_bits() != self.plant_k_eff.to_bits() {
            self.plant = Plant::new(instr, k_eff);
            self.plant_k_eff = k_eff;
        }
        self.prep = prep;
        // The instrument file's nominal model-equation terms are part of the baseline.
        self.effect_terms = instr
            .with_nominal_terms(effects)
            .plant_terms(cond.history.t_on_s);
        self.d0 = self.static_torque(&m);
        self.add = add_vectors(&self.plant, self.d0);
        self.w = prep.omega;
        (self.sr, self.cr) = (self.w * self.t_s).sin_cos();
        self.set_dynamic();
    }

    /// Add physics from outside the vocabulary.
    pub(super) fn set_physics(&mut self, physics: Arc<dyn ExtraPhysics>) {
        self.physics = Some(physics);
        self.set_dynamic();
    }

    fn set_dynamic(&mut self) {
        self.dynamic = self.prep.is_dynamic() || self.physics.is_some() || self.harmonic != 0;
    }

    /// The θ-independent torque for inputs `i`, dyn·cm.
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    pub(super) fn static_torque(&self, i: &CaseInputs) -> f64 {
        torque_of_inputs(
            [
                self.p,
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
    pub(super) fn effects_cm_s2(&self, i: &CaseInputs) -> f64 {
        self.effect_terms.iter().map(|&(f, c)| c * f(i)).sum()
    }

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

    /// The phasor at tick `k`: exact at the start of its [`PHASOR_BLOCK`], advanced tick by
    /// tick from there (what [`LoopConfig::dynamic_inputs`] makes of it).
    pub(super) fn phasor(&self, k: u64) -> (f64, f64) {
        let start = k - k % PHASOR_BLOCK;
        let mut sc = self.phasor_at(start);
        for _ in start..k {
            sc = self.rotate(sc);
        }
        sc
    }

    /// The first part of a dynamic tick: the phasor `sc = (sin, cos)(ωt)` at mid-tick of
    /// tick `k` (exact every [`PHASOR_BLOCK`] ticks of the absolute index, else as given:
    /// [`LoopConfig::phasor`]`(k)`) and the condition's inputs there; advances `sc` to the
    /// next tick. It depends on the condition, the clock, `k` and `sc` only, so lanes in step
    /// with the same ones may share it.
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    pub(super) fn dynamic_inputs(&self, k: u64, sc: &mut (f64, f64)) -> TickInputs {
        if k.is_multiple_of(PHASOR_BLOCK) {
            *sc = self.phasor_at(k);
        }
        let (s, c) = *sc;
        let inp = self.prep.inputs(s, c);
        *sc = self.rotate(*sc);
        TickInputs { s, c, inp }
    }
}

/// The plant inputs of a static condition, `add[region][polarity] = Γu·u + Γd·(d0 + stop
/// torque)` with polarity 0 = `u = +1`, 1 = `u = −1` (region 0 free, 1 and 2 on the stops).
#[allow(clippy::needless_range_loop)]
fn add_vectors(plant: &Plant, d0: f64) -> [[[f64; NX]; 2]; 3] {
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
