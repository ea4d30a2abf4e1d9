//! The firmware's processor-in-the-loop image (`cargo xtask pil`, `firmware/src/bin/pil.rs`):
//! the parameters of one run ([`pil_params`]: the host's discrete-time plant, ADC, noise and
//! input, every `f64` as its bits) and the gates the host's own closed loop counts in the
//! same run ([`pil_gates`]), which the image's must equal bit for bit.
//!
//! The input along IA is constant, a sine (the host's dynamic tick: the phasor exact at
//! every `PHASOR_BLOCK`-th (4096th) tick of the absolute index, rotated tick by tick in between; the
//! host gives the image the exact phasors and the rotation, the image rotates in `f64`) or a
//! step (the static tick with the plant inputs of the new acceleration from the step's tick
//! on, as `ClosedLoop::set_condition` does on the host).

use std::fmt::Write as _;

use super::config::PHASOR_BLOCK;
use super::sim::{ClosedLoop, SimOptions};
use crate::lab::response::Gate;
use crate::model::condition::IA;
use crate::model::effects::Effects;
use crate::model::instrument::Instrument;

/// The most exact phasors a sine run may need (the image's table): runs of up to
/// `PIL_MAX_PHASORS · PHASOR_BLOCK` ticks (16.4 s at 64 kHz).
pub const PIL_MAX_PHASORS: u64 = 256;

/// The input along IA of a processor-in-the-loop run, cm/s²; time from the loop's reset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PilInput {
    /// A constant acceleration.
    Static {
        /// cm/s².
        accel_cm_s2: f64,
    },
    /// `accel + amp·sin(2π·freq·t)`, the sine's phase 0 at the loop's reset (the host's
    /// condition with `lin_cm_s2[IA] = amp`, `lin_deg = 0`).
    Sine {
        /// The constant part, cm/s².
        accel_cm_s2: f64,
        /// Hz (more than 0).
        freq_hz: f64,
        /// cm/s².
        amp_cm_s2: f64,
    },
    /// `accel` until tick `at_tick` (counted from 0 at the loop's first tick), `to` from it on.
    Step {
        /// Before the step, cm/s².
        accel_cm_s2: f64,
        /// From the step on, cm/s².
        to_cm_s2: f64,
        /// The first tick with the new acceleration.
        at_tick: u64,
    },
}

impl PilInput {
    /// The host's condition at the loop's reset.
    fn condition(&self, g_cm_s2: f64) -> crate::model::condition::Condition {
        match *self {
            Self::Static { accel_cm_s2 } | Self::Step { accel_cm_s2, .. } => {
                crate::lab::fixtures::along_ia(accel_cm_s2, g_cm_s2)
            }
            Self::Sine {
                accel_cm_s2,
                freq_hz,
                amp_cm_s2,
            } => {
                let mut c = crate::lab::fixtures::along_ia(accel_cm_s2, g_cm_s2);
                c.freq_hz = freq_hz;
                c.lin_cm_s2[IA] = amp_cm_s2;
                c
            }
        }
    }
}

/// One processor-in-the-loop run: the input, the settling ticks, the counted ticks after
/// them and the gate (both a whole number of gates; gates tile the run from its first tick).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PilRun {
    /// The input.
    pub input: PilInput,
    /// Settling ticks (not reported).
    pub warmup: u64,
    /// Counted ticks.
    pub ticks: u64,
    /// Ticks per gate.
    pub gate: u64,
}

impl PilRun {
    /// The run's checks: a gate of 1 to 2³² − 1 ticks that divides the settling and the
    /// counted ticks, a step inside the run, a sine short enough for the image's phasors.
    ///
    /// # Errors
    /// What is wrong, in words.
    pub fn check(&self) -> Result<(), String> {
        let total = self.warmup + self.ticks;
        if self.gate == 0 || self.gate > u64::from(u32::MAX) {
            return Err(format!(
                "a gate of {} ticks; expected 1 to {}",
                self.gate,
                u32::MAX
            ));
        }
        if !self.warmup.is_multiple_of(self.gate) || !self.ticks.is_multiple_of(self.gate) {
            return Err(format!(
                "a gate of {} ticks does not divide the settling ({} ticks) and the counted time ({} ticks); expected whole gates",
                self.gate, self.warmup, self.ticks
            ));
        }
        if total > u64::from(u32::MAX) {
            return Err(format!(
                "{total} ticks; expected at most {} (the image counts ticks in 32 bits)",
                u32::MAX
            ));
        }
        match self.input {
            PilInput::Step { at_tick, .. } if at_tick >= total => Err(format!(
                "a step at tick {at_tick}, after the run's {total} ticks; expected it inside the run"
            )),
            PilInput::Sine { .. } if total.div_ceil(PHASOR_BLOCK) > PIL_MAX_PHASORS => {
                Err(format!(
                    "a sine over {total} ticks; the image holds the phasors of at most {} ticks",
                    PIL_MAX_PHASORS * PHASOR_BLOCK
                ))
            }
            _ => Ok(()),
        }
    }
}

/// The gates the host's closed loop counts in `run` (the instrument's bias, noise and
/// seed as given): those after the settling, `time_s` their start from the loop's first
/// tick (what `ptsa record` makes of the image's reports). The step is
/// `ClosedLoop::set_condition` at its tick; the static stretches run the fast path, the
/// sine the dynamic tick.
///
/// # Errors
/// [`PilRun::check`]'s.
pub fn pil_gates(instr: &Instrument, run: &PilRun, opts: &SimOptions) -> Result<Vec<Gate>, String> {
    run.check()?;
    let mut l = ClosedLoop::new(
        instr,
        &run.input.condition(instr.g_cm_s2),
        &Effects::NONE,
        opts,
    );
    let total = run.warmup + run.ticks;
    let mut out = Vec::new();
    let mut k = 0;
    while k < total {
        let end = k + run.gate;
        let p0 = l.core().total_pulses();
        match run.input {
            PilInput::Step {
                to_cm_s2, at_tick, ..
            } if (k..end).contains(&at_tick) => {
                l.run_fast(at_tick - k);
                l.set_condition(
                    &crate::lab::fixtures::along_ia(to_cm_s2, instr.g_cm_s2),
                    &Effects::NONE,
                );
                l.run_fast(end - at_tick);
            }
            _ => l.run_fast(run.gate),
        }
        if k >= run.warmup {
            #[allow(clippy::cast_precision_loss, reason = "ticks far below 2^52")]
            out.push(Gate {
                time_s: k as f64 / instr.clock_hz,
                pulses: u64::from((l.core().total_pulses() - p0).0),
                ticks: run.gate,
            });
        }
        k = end;
    }
    Ok(out)
}

/// `f64` as the 16 hexadecimal digits of its bits.
fn hex(v: f64) -> String {
    format!("{:016x}", v.to_bits())
}

/// A keyword and values as hexadecimal bits, one line.
fn line(s: &mut String, key: &str, values: &[f64]) {
    s.push_str(key);
    for v in values {
        s.push(' ');
        s.push_str(&hex(*v));
    }
    s.push('\n');
}

/// The parameters of `run` for the processor-in-the-loop image: text lines, each a keyword
/// and its values, every `f64` as the 16 hexadecimal digits of its bits (so that the image
/// reads the very bits the host steps with), `#` starting a comment:
///
/// * `config b0 b1 a1 ki ticks_per_cycle noise_shaping` (the core's configuration: raw bits
///   in decimal, `noise_shaping` 0 or 1);
/// * `adc gain bias mask`: the ADC's gain (units of the sample per rad), the additive term of
///   every sample (offset, range and rounding: `Adc::bias` without its noise) and the
///   converter's mask (decimal);
/// * `stop theta_stop u0`: the stop angle (rad) and the command applied at reset (1 or −1);
/// * `phi<r> <i>` and 4 values: row `i` of Φ of region `r` (0 free, 1 and 2 the stops);
/// * `add<r> <u>` and 4 values: region `r`'s plant input with the polarity `u` applied (0
///   positive, 1 negative);
/// * `x0`: the plant state at reset (4);
/// * `run warmup ticks gate`: the settling ticks, the counted ticks and the gate's ticks;
/// * with pickoff noise: `noise scale state` (the noise in units of the sample, the
///   generator's state in decimal) and `ntab <j>` with 8 values: entries `8j..8j+7` of the
///   generator's table (`NoiseSource`);
/// * a step: `step at_tick` and `stepadd<r> <u>` as `add`, the plant inputs from that tick
///   on;
/// * a sine: `sine sr cr a0 lin_s lin_c p bias eff` (the phasor's rotation per tick, the
///   constant, sine and cosine parts of `a_IA` in cm/s², the pendulosity, the bias in
///   cm/s², the effect terms' sum: none, the empty sum), `gu<r>`, `gd<r>` (4 values each:
///   region `r`'s responses to the command and to the torque), `stoptorque` (3 values, one
///   per region, dyn·cm) and `phasor <m> s c`: the exact phasor at tick `m·4096`.
///
/// A static tick of the image is `kernel::static_tick`'s and `static_phase`'s: the sample
/// `AdcFormat::sample_masked(mask, x[3]·gain + bias)` (`bias` plus `scale` times the next
/// noise draw with noise), the core's tick, then `x = Φ_r x + add_r[applied]` with `r` the
/// region of `x[0]` before the step (free while `|x[0]| ≤ theta_stop`), the terms of `Φ x`
/// in `Zoh::step`'s order. A sine tick is `kernel::dynamic_tick`'s: the phasor `(s, c)`,
/// `a = a0 + (lin_s·s + lin_c·c)`, `d = p·(a + bias + eff) + stoptorque_r` (the terms the
/// host adds beyond these are zeros for an input along IA alone), `x = Φ_r x + (gu_r·u +
/// gd_r·d)`.
///
/// # Errors
/// [`PilRun::check`]'s; a sine with the instrument's model-equation terms (the image
/// computes none).
pub fn pil_params(instr: &Instrument, run: &PilRun, opts: &SimOptions) -> Result<String, String> {
    run.check()?;
    let cond = run.input.condition(instr.g_cm_s2);
    let l = ClosedLoop::new(instr, &cond, &Effects::NONE, opts);
    let (cfg, st) = (&l.cfg, &l.st);
    let c = cfg.ptsa.config();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# ptsa static --pil-params: {:?} along IA, bias {} cm/s^2; f64 as hex bits",
        run.input, instr.bias_cm_s2
    );
    let _ = writeln!(
        s,
        "config {} {} {} {} {} {}",
        c.b0.to_bits(),
        c.b1.to_bits(),
        c.a1.to_bits(),
        c.ki.to_bits(),
        c.ticks_per_cycle,
        u8::from(c.noise_shaping)
    );
    let _ = writeln!(
        s,
        "adc {} {} {}",
        hex(cfg.adc.gain),
        hex(cfg.adc.offset + cfg.adc.round),
        cfg.adc.mask
    );
    let _ = writeln!(
        s,
        "stop {} {}",
        hex(cfg.plant.theta_stop),
        if st.u > 0.0 { 1 } else { -1 }
    );
    for (r, z) in cfg.plant.zoh.iter().enumerate() {
        for (i, row) in z.phi.iter().enumerate() {
            line(&mut s, &format!("phi{r} {i}"), row);
        }
    }
    for (r, region) in cfg.add.iter().enumerate() {
        for (u, add) in region.iter().enumerate() {
            line(&mut s, &format!("add{r} {u}"), add);
        }
    }
    line(&mut s, "x0", &st.x);
    let _ = writeln!(s, "run {} {} {}", run.warmup, run.ticks, run.gate);
    if cfg.adc.noise != 0.0 {
        let _ = writeln!(s, "noise {} {}", hex(cfg.adc.noise), st.rng.state);
        for (j, chunk) in st.rng.table.chunks(8).enumerate() {
            line(&mut s, &format!("ntab {j}"), chunk);
        }
    }
    match run.input {
        PilInput::Static { .. } => {}
        PilInput::Step {
            to_cm_s2, at_tick, ..
        } => {
            let mut after = l.clone();
            after.set_condition(
                &crate::lab::fixtures::along_ia(to_cm_s2, instr.g_cm_s2),
                &Effects::NONE,
            );
            if after.cfg.plant != cfg.plant {
                return Err(
                    "the step changes the plant's matrices; expected a step along IA alone".into(),
                );
            }
            let _ = writeln!(s, "step {at_tick}");
            for (r, region) in after.cfg.add.iter().enumerate() {
                for (u, add) in region.iter().enumerate() {
                    line(&mut s, &format!("stepadd{r} {u}"), add);
                }
            }
        }
        PilInput::Sine { .. } => sine_params(&mut s, &l, run.warmup + run.ticks)?,
    }
    Ok(s)
}

/// The sine's lines of [`pil_params`] for a loop `l` of `total` ticks.
fn sine_params(s: &mut String, l: &ClosedLoop, total: u64) -> Result<(), String> {
    let cfg = &l.cfg;
    if !cfg.effect_terms.is_empty() {
        return Err(format!(
            "the processor-in-the-loop image computes no model-equation terms under a sine; expected an instrument file without nominal terms (this one has {})",
            cfg.effect_terms.len()
        ));
    }
    let p = &cfg.prep;
    let eff = cfg.effects_cm_s2(&p.mean_inputs());
    line(
        s,
        "sine",
        &[
            cfg.sr,
            cfg.cr,
            p.g[IA],
            p.lin_s[IA],
            p.lin_c[IA],
            cfg.p,
            cfg.instr.bias_cm_s2,
            eff,
        ],
    );
    for (r, z) in cfg.plant.zoh.iter().enumerate() {
        line(s, &format!("gu{r}"), &z.gu);
        line(s, &format!("gd{r}"), &z.gd);
    }
    line(s, "stoptorque", &cfg.plant.stop_torque);
    for m in 0..total.div_ceil(PHASOR_BLOCK) {
        let (sn, cs) = cfg.phasor(m * PHASOR_BLOCK);
        line(s, &format!("phasor {m}"), &[sn, cs]);
    }
    Ok(())
}
