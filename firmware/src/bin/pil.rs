//! Test image for QEMU (`netduinoplus2`): processor in the loop. The production tick
//! handler closes the loop around the pendulum, which this image steps on the emulated MCU.
//!
//! Semihosting command line: `pil <params>`, a file that `ptsa static --pil-params` writes
//! (the host's discrete-time plant, ADC, noise, input and loop constants of one run, every
//! `f64` as its bits; `ptsa_host_sim::simulation::pil::pil_params` documents the format).
//! Per tick, in the host's order (`static_phase` and `kernel::dynamic_tick` in the host
//! simulator):
//!
//! 1. the board's ADC model: the sample `AdcFormat::sample_masked(mask, x[3]·gain + bias)`,
//!    the conversion the host uses (`bias` plus the noise's scale times the next draw of
//!    the host's seeded generator when the params give noise: wyrand indexing the host's
//!    4096-entry table, 32 KiB on this image's stack), turned into the data-register word
//!    the converter would hold (`constants::ADC.word_of_sample`) and stored where the
//!    handler reads its pickoff word;
//! 2. the real `TIM2` interrupt is pended: its handler is the production one
//!    ([`ptsa_firmware::on_tick`], unchanged; it reads the word through
//!    `constants::ADC.sample_of_word`), followed by one store that publishes the core's
//!    pulse counter, from which the plant side learns the decided polarity; a closed gate
//!    goes through the production bottom half (`EXTI0`) into `GATES`;
//! 3. the plant steps in `f64` (software floating point on the Cortex-M4F, IEEE 754 like
//!    the host's) with the polarity applied over this tick, the one decided at the tick
//!    before, with the terms in the host's order: for a constant input or a step
//!    `x = Φ_r x + add_r[applied]` (the step's `add` from its tick on); for a sine the
//!    phasor (the host's exact value at every 4096th tick, rotated by one tick's rotation
//!    in between), the torque `p·(a0 + (lin_s·s + lin_c·c) + bias + eff) + stop_torque_r`
//!    and `x = Φ_r x + (gu_r·u + gd_r·d)`.
//!
//! Gates of the params' `gate` ticks tile the run from its first tick; after the settling
//! each is printed as the production image prints it (`ptsa record` reads these lines),
//!
//! `gate seq=<n> P=<pulses> T=<ticks> gates=<merged> tick=<ticks at its close>`
//!
//! and at the end
//!
//! `pil ticks=<T> pulses=<P> gates=<n> gate_ticks=<G> instructions=<guest instructions of
//! the whole run, plant and gate printing included>`
//!
//! (the sums of the reported gates), then the image exits QEMU with status 0, or 1 with a
//! message on standard error.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m_rt::entry;
use ptsa_core::adc::AdcFormat;
use ptsa_core::{Coef, Config, Pole};
use ptsa_firmware::constants::ADC;
use ptsa_firmware::rt::exit;
use ptsa_firmware::testimage::{Failure, PATH, for_each_line, next_path};
use ptsa_firmware::{
    Board, GATES, INJECTED, TICK, TickContext, on_tick, pac, pac::interrupt, stopwatch, unmask_tick,
};
use semihosting::{eprintln, println};

// Reports on semihosting standard error; HardFault exits 70, a panic 101.
ptsa_firmware::image_runtime!(semihosting, "pil");

/// Plant states.
const NX: usize = 4;

/// The core's free-running pulse counter after the last tick, published by the handler.
static PULSES: AtomicU32 = AtomicU32::new(0);

/// Entries of the host's noise table (`NoiseSource`).
const NOISE_TABLE: usize = 4096;
/// Ticks between the host's exact phasors (`PHASOR_BLOCK`).
const PHASOR_BLOCK: u32 = 4096;
/// Exact phasors the image holds (`PIL_MAX_PHASORS` on the host).
const MAX_PHASORS: usize = 256;

/// A sine input: the phasor's rotation and exact values, the input and torque constants,
/// each region's responses to the command and the torque (`ptsa_host_sim::simulation::pil`).
struct Sine {
    sr: f64,
    cr: f64,
    a0: f64,
    lin_s: f64,
    lin_c: f64,
    p: f64,
    bias: f64,
    eff: f64,
    gu: [[f64; NX]; 3],
    gd: [[f64; NX]; 3],
    stop_torque: [f64; 3],
    phasors: [(f64, f64); MAX_PHASORS],
    n_phasors: usize,
}

/// What the params file gives.
struct Params {
    config: Option<Config>,
    gain: f64,
    bias: f64,
    mask: u16,
    theta_stop: f64,
    u0_positive: bool,
    phi: [[[f64; NX]; NX]; 3],
    add: [[[f64; NX]; 2]; 3],
    x0: [f64; NX],
    warmup: u32,
    ticks: u32,
    gate: u32,
    seen: u32,
    /// The noise in units of the sample (0: none), the generator's state, its table.
    noise: f64,
    noise_state: u64,
    table: [f64; NOISE_TABLE],
    table_seen: [u8; NOISE_TABLE / 8],
    /// A step: its tick and the plant inputs from it on.
    step_at: Option<u32>,
    step_add: [[[f64; NX]; 2]; 3],
    sine: Option<Sine>,
}

impl Params {
    #[allow(
        clippy::large_stack_arrays,
        reason = "the 32 KiB noise table on the stack of `run`, in 128 KiB of RAM that nothing else uses"
    )]
    fn new() -> Self {
        Self {
            config: None,
            gain: 0.0,
            bias: 0.0,
            mask: 0,
            theta_stop: 0.0,
            u0_positive: true,
            phi: [[[0.0; NX]; NX]; 3],
            add: [[[0.0; NX]; 2]; 3],
            x0: [0.0; NX],
            warmup: 0,
            ticks: 0,
            gate: 0,
            seen: 0,
            noise: 0.0,
            noise_state: 0,
            table: [0.0; NOISE_TABLE],
            table_seen: [0; NOISE_TABLE / 8],
            step_at: None,
            step_add: [[[0.0; NX]; 2]; 3],
            sine: None,
        }
    }

    /// The sine's constants, made on its first line.
    fn sine(&mut self) -> &mut Sine {
        self.sine.get_or_insert(Sine {
            sr: 0.0,
            cr: 0.0,
            a0: 0.0,
            lin_s: 0.0,
            lin_c: 0.0,
            p: 0.0,
            bias: 0.0,
            eff: 0.0,
            gu: [[0.0; NX]; 3],
            gd: [[0.0; NX]; 3],
            stop_torque: [0.0; 3],
            phasors: [(0.0, 0.0); MAX_PHASORS],
            n_phasors: 0,
        })
    }
}

#[entry]
fn main() -> ! {
    match run() {
        Ok(()) => exit(0),
        Err(Failure) => exit(1),
    }
}

fn fail(what: &str) -> Failure {
    eprintln!("pil: {}", what);
    Failure
}

fn hex(t: Option<&str>) -> Result<f64, Failure> {
    let t = t.ok_or_else(|| fail("a value is missing"))?;
    u64::from_str_radix(t, 16)
        .map(f64::from_bits)
        .map_err(|_| fail("bad hexadecimal f64"))
}

fn int<T: core::str::FromStr>(t: Option<&str>) -> Result<T, Failure> {
    t.ok_or_else(|| fail("a value is missing"))?
        .parse()
        .map_err(|_| fail("bad integer"))
}

fn four<'a>(it: &mut impl Iterator<Item = &'a str>) -> Result<[f64; NX], Failure> {
    Ok([
        hex(it.next())?,
        hex(it.next())?,
        hex(it.next())?,
        hex(it.next())?,
    ])
}

fn parse_line(p: &mut Params, line: &str) -> Result<(), Failure> {
    let mut it = line.split_ascii_whitespace();
    let Some(key) = it.next() else {
        return Ok(());
    };
    if key.starts_with('#') {
        return Ok(());
    }
    match key {
        "config" => {
            p.config = Some(Config {
                b0: Coef::from_bits(int(it.next())?),
                b1: Coef::from_bits(int(it.next())?),
                a1: Pole::from_bits(int(it.next())?),
                ki: Coef::from_bits(int(it.next())?),
                ticks_per_cycle: int(it.next())?,
                noise_shaping: int::<u8>(it.next())? != 0,
                gate_ticks: 1,
            });
            p.seen |= 1;
        }
        "adc" => {
            p.gain = hex(it.next())?;
            p.bias = hex(it.next())?;
            p.mask = int(it.next())?;
            p.seen |= 2;
        }
        "stop" => {
            p.theta_stop = hex(it.next())?;
            p.u0_positive = int::<i32>(it.next())? > 0;
            p.seen |= 4;
        }
        "x0" => {
            p.x0 = four(&mut it)?;
            p.seen |= 8;
        }
        "run" => {
            p.warmup = int(it.next())?;
            p.ticks = int(it.next())?;
            p.gate = int(it.next())?;
            p.seen |= 16;
        }
        k => return parse_more(p, k, &mut it),
    }
    Ok(())
}

/// The lines of the noise, the step and the sine, and the regions' rows.
fn parse_more<'a>(
    p: &mut Params,
    key: &str,
    it: &mut impl Iterator<Item = &'a str>,
) -> Result<(), Failure> {
    let region = |k: &str, prefix: &str| -> Option<usize> {
        k.strip_prefix(prefix)?.parse().ok().filter(|r| *r < 3)
    };
    match key {
        "noise" => {
            p.noise = hex(it.next())?;
            p.noise_state = int(it.next())?;
        }
        "ntab" => {
            let j: usize = int(it.next())?;
            let Some(chunk) = p.table.get_mut(8 * j..8 * j + 8) else {
                return Err(fail("noise table row out of range"));
            };
            for v in chunk {
                *v = hex(it.next())?;
            }
            p.table_seen[j] = 1;
        }
        "step" => p.step_at = Some(int(it.next())?),
        "sine" => {
            let v = [
                hex(it.next())?,
                hex(it.next())?,
                hex(it.next())?,
                hex(it.next())?,
                hex(it.next())?,
                hex(it.next())?,
                hex(it.next())?,
                hex(it.next())?,
            ];
            let q = p.sine();
            [q.sr, q.cr, q.a0, q.lin_s, q.lin_c, q.p, q.bias, q.eff] = v;
        }
        "stoptorque" => {
            let v = [hex(it.next())?, hex(it.next())?, hex(it.next())?];
            p.sine().stop_torque = v;
        }
        "phasor" => {
            let m: usize = int(it.next())?;
            let v = (hex(it.next())?, hex(it.next())?);
            let q = p.sine();
            *q.phasors
                .get_mut(m)
                .ok_or_else(|| fail("too many phasors for the image's table"))? = v;
            q.n_phasors = q.n_phasors.max(m + 1);
        }
        k => {
            if let Some(r) = region(k, "phi") {
                let i: usize = int(it.next())?;
                *p.phi[r]
                    .get_mut(i)
                    .ok_or_else(|| fail("Φ row out of range"))? = four(it)?;
                p.seen |= 1 << (5 + 4 * r + i.min(3));
            } else if let Some(r) = region(k, "add") {
                let u: usize = int(it.next())?;
                *p.add[r]
                    .get_mut(u)
                    .ok_or_else(|| fail("polarity out of range"))? = four(it)?;
                p.seen |= 1 << (17 + 2 * r + u.min(1));
            } else if let Some(r) = region(k, "stepadd") {
                let u: usize = int(it.next())?;
                *p.step_add[r]
                    .get_mut(u)
                    .ok_or_else(|| fail("polarity out of range"))? = four(it)?;
            } else if let Some(r) = region(k, "gu") {
                p.sine().gu[r] = four(it)?;
            } else if let Some(r) = region(k, "gd") {
                p.sine().gd[r] = four(it)?;
            } else {
                return Err(fail("unknown keyword in the params file"));
            }
        }
    }
    Ok(())
}

/// `Φ x + add` with the terms in the host's order (`Zoh::step`: the structural zeros of Φ
/// skipped).
fn step(phi: &[[f64; NX]; NX], x: &[f64; NX], add: &[f64; NX]) -> [f64; NX] {
    [
        add[0] + (phi[0][0] * x[0] + phi[0][1] * x[1]) + phi[0][2] * x[2],
        add[1] + (phi[1][0] * x[0] + phi[1][1] * x[1]) + phi[1][2] * x[2],
        add[2] + phi[2][2] * x[2],
        add[3] + (phi[3][0] * x[0] + phi[3][1] * x[1]) + (phi[3][2] * x[2] + phi[3][3] * x[3]),
    ]
}

/// One standard-normal draw of the host's noise source (`NoiseSource::normal`): wyrand's
/// step indexing the table.
fn normal(state: &mut u64, table: &[f64; NOISE_TABLE]) -> f64 {
    *state = state.wrapping_add(0xa076_1d64_78bd_642f);
    let t = u128::from(*state) * u128::from(*state ^ 0xe703_7ed1_a0b4_28db);
    #[allow(clippy::cast_possible_truncation)]
    let r = ((t >> 64) as u64) ^ (t as u64);
    #[allow(clippy::cast_possible_truncation)]
    let j = (r >> 52) as usize;
    table[j & (NOISE_TABLE - 1)]
}

/// The plant's region of the angle `theta`: 0 free (`|θ| ≤ θ_s`), 1 above, 2 below
/// (`Plant::region`).
fn region_of(theta: f64, theta_stop: f64) -> usize {
    if theta.abs() <= theta_stop {
        0
    } else if theta > 0.0 {
        1
    } else {
        2
    }
}

/// One sine tick's plant step (`kernel::dynamic_tick` for an input along IA alone): the
/// phasor `sc` used and advanced, the torque of the input, `Φ_r x + (gu_r·u + gd_r·d)`.
fn sine_step(
    q: &Sine,
    phi: &[[[f64; NX]; NX]; 3],
    theta_stop: f64,
    k: u32,
    sc: &mut (f64, f64),
    x: &[f64; NX],
    positive: bool,
) -> [f64; NX] {
    if k.is_multiple_of(PHASOR_BLOCK) {
        *sc = q.phasors[(k / PHASOR_BLOCK) as usize];
    }
    let (s, c) = *sc;
    *sc = (s * q.cr + c * q.sr, c * q.cr - s * q.sr);
    let a = q.a0 + (q.lin_s * s + q.lin_c * c);
    let base = q.p * (a + q.bias + q.eff);
    let r = region_of(x[0], theta_stop);
    let d = base + q.stop_torque[r];
    let u = if positive { 1.0 } else { -1.0 };
    let add = [
        q.gu[r][0] * u + q.gd[r][0] * d,
        q.gu[r][1] * u + q.gd[r][1] * d,
        q.gu[r][2] * u + q.gd[r][2] * d,
        q.gu[r][3] * u + q.gd[r][3] * d,
    ];
    step(&phi[r], x, &add)
}

/// The params file named on the command line, read and checked.
fn load() -> Result<Params, Failure> {
    let Ok(args) = semihosting::experimental::env::args::<{ 2 * PATH }>() else {
        return Err(fail("cannot read the semihosting command line"));
    };
    let mut it = (&args).into_iter();
    let _program = it.next();
    let input = next_path(&mut it, "params")?;
    let mut p = Params::new();
    for_each_line(input.as_cstr(), |line| {
        parse_line(&mut p, line).map(|()| true)
    })?;
    if p.seen != (1 << 23) - 1 {
        return Err(fail(
            "the params file lacks a line (config, adc, stop, phi, add, x0, run)",
        ));
    }
    if p.mask != ADC.mask() {
        return Err(fail(
            "the params' converter is not the firmware's (constants::ADC): run the PIL with \
             the board's instrument file, or `cargo xtask constants --instrument FILE` first",
        ));
    }
    if p.noise != 0.0 && p.table_seen.contains(&0) {
        return Err(fail("the params give noise without its whole table (ntab)"));
    }
    if p.gate == 0 || !p.ticks.is_multiple_of(p.gate) || !p.warmup.is_multiple_of(p.gate) {
        return Err(fail(
            "the gate does not divide the settling and the counted ticks",
        ));
    }
    let blocks = (p.warmup + p.ticks).div_ceil(PHASOR_BLOCK);
    if let Some(q) = &p.sine
        && u32::try_from(q.n_phasors).is_ok_and(|n| n < blocks)
    {
        return Err(fail("a sine without the phasors of every block of the run"));
    }
    Ok(p)
}

fn run() -> Result<(), Failure> {
    let p = load()?;
    let total = p.warmup + p.ticks;
    let Some(config) = p.config else {
        return Err(fail("no config line"));
    };
    let ptsa = Config {
        gate_ticks: p.gate,
        ..config
    }
    .build()
    .map_err(|_| fail("the loop's configuration is refused by ptsa-core"))?;
    let Some(dp) = pac::Peripherals::take() else {
        return Err(fail("peripherals already taken"));
    };
    // TIM2 is set up but never started: the loop below pends its interrupt once per tick.
    let board = Board::new(dp, ptsa);
    let watch = board.stopwatch;
    critical_section::with(|cs| TICK.borrow(cs).replace(Some(board.tick)));
    unmask_tick();
    // The first interrupt moves the context into the handler and returns without a tick.
    cortex_m::peripheral::NVIC::pend(pac::Interrupt::TIM2);

    let skip = u64::from(p.warmup / p.gate);
    let mut x = p.x0;
    let mut positive = p.u0_positive;
    let mut pulses_before = PULSES.load(Ordering::Relaxed);
    let mut state = p.noise_state;
    let mut sc = (0.0, 0.0);
    let (mut sum_p, mut sum_t, mut gates) = (0u64, 0u64, 0u32);
    // Guest instructions of the whole loop (TIM5 counts one per instruction under
    // `-icount shift=0`), summed tick by tick so that the 32-bit counter may wrap.
    let mut instructions = 0u64;
    let mut last = stopwatch(&watch);
    for k in 0..total {
        let mut bias = p.bias;
        if p.noise != 0.0 {
            bias += p.noise * normal(&mut state, &p.table);
        }
        let sample = AdcFormat::sample_masked(p.mask, x[3] * p.gain + bias);
        INJECTED.store(ADC.word_of_sample(sample), Ordering::Relaxed);
        cortex_m::peripheral::NVIC::pend(pac::Interrupt::TIM2);
        // The pended interrupt (and the bottom half it may pend) has run before the next
        // instruction after this barrier.
        cortex_m::asm::isb();
        let pulses = PULSES.load(Ordering::Relaxed);
        let decided_positive = pulses != pulses_before;
        pulses_before = pulses;
        x = if let Some(q) = &p.sine {
            sine_step(q, &p.phi, p.theta_stop, k, &mut sc, &x, positive)
        } else {
            let add = match p.step_at {
                Some(at) if k >= at => &p.step_add,
                _ => &p.add,
            };
            let r = region_of(x[0], p.theta_stop);
            step(&p.phi[r], &x, &add[r][usize::from(!positive)])
        };
        positive = decided_positive;
        while let Some(g) = critical_section::with(|cs| GATES.borrow_ref_mut(cs).pop()) {
            if g.seq > skip {
                println!(
                    "gate seq={} P={} T={} gates={} tick={}",
                    g.seq, g.pulses, g.ticks, g.gates, g.end_tick
                );
                sum_p += g.pulses;
                sum_t += g.ticks;
                gates += 1;
            }
        }
        let now = stopwatch(&watch);
        instructions += u64::from(now.wrapping_sub(last));
        last = now;
    }
    println!(
        "pil ticks={} pulses={} gates={} gate_ticks={} instructions={}",
        sum_t, sum_p, gates, p.gate, instructions
    );
    Ok(())
}

/// The tick's bottom half: queue a closed gate.
#[interrupt]
fn EXTI0() {
    ptsa_firmware::on_gate();
}

/// The production tick handler, fed from RAM, then the core's pulse counter published.
#[interrupt]
fn TIM2() {
    static mut CONTEXT: Option<TickContext> = None;
    on_tick::<true>(CONTEXT);
    if let Some(c) = CONTEXT.as_ref() {
        PULSES.store(c.state.total_pulses().0, Ordering::Relaxed);
    }
}
