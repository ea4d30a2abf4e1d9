//! Test image for QEMU (`netduinoplus2`): processor in the loop. The production tick
//! handler closes the loop around the pendulum, which this image steps on the emulated MCU.
//!
//! Semihosting command line: `pil <params>`, a file that `ptsa static --pil-params` writes
//! (the host's discrete-time plant, ADC and loop constants of one static run, every `f64`
//! as its bits; `ptsa_host_sim::simulation::sim::static_pil_params` documents the format).
//! Per tick, in the host's order (`static_phase` in the host simulator):
//!
//! 1. the board's ADC model: the sample `AdcFormat::sample_masked(mask, x[3]·gain + bias)`,
//!    the conversion the host uses, turned into the data-register word the converter would
//!    hold (`constants::ADC.word_of_sample`) and stored where the handler reads its pickoff
//!    word;
//! 2. the real `TIM2` interrupt is pended: its handler is the production one
//!    ([`ptsa_firmware::on_tick`], unchanged; it reads the word through
//!    `constants::ADC.sample_of_word`), followed by one store that publishes the core's
//!    pulse counter, from which the plant side learns the decided polarity; a closed gate
//!    goes through the production bottom half (`EXTI0`) into `GATES`;
//! 3. the plant steps in `f64` (software floating point on the Cortex-M4F, IEEE 754 like
//!    the host's) with the polarity applied over this tick, the one decided at the tick
//!    before: `x = Φ_r x + add_r[applied]`, with the terms in the host's order.
//!
//! The loop's gate is the greatest common divisor of the settling and the measured ticks, so
//! that gates close at the end of the settling and at the end of the run; the image sums
//! the gates after the settling and prints
//!
//! `pil ticks=<T> pulses=<P> gates=<n> gate_ticks=<G> instructions=<guest instructions of
//! the whole run, plant and gate printing included>`
//!
//! and, for each gate, `gate <k> P=<pulses> T=<ticks>` (k from 1), then exits QEMU with
//! status 0, or 1 with a message on standard error.
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

/// What the params file gives.
#[derive(Default)]
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
    seen: u32,
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
    let region = |k: &str, prefix: &str| -> Option<usize> {
        k.strip_prefix(prefix)?.parse().ok().filter(|r| *r < 3)
    };
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
            p.seen |= 16;
        }
        k => {
            if let Some(r) = region(k, "phi") {
                let i: usize = int(it.next())?;
                *p.phi[r]
                    .get_mut(i)
                    .ok_or_else(|| fail("Φ row out of range"))? = four(&mut it)?;
                p.seen |= 1 << (5 + 4 * r + i.min(3));
            } else if let Some(r) = region(k, "add") {
                let u: usize = int(it.next())?;
                *p.add[r]
                    .get_mut(u)
                    .ok_or_else(|| fail("polarity out of range"))? = four(&mut it)?;
                p.seen |= 1 << (17 + 2 * r + u.min(1));
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

fn gcd(a: u32, b: u32) -> u32 {
    if b == 0 { a } else { gcd(b, a % b) }
}

fn run() -> Result<(), Failure> {
    let Ok(args) = semihosting::experimental::env::args::<{ 2 * PATH }>() else {
        return Err(fail("cannot read the semihosting command line"));
    };
    let mut it = (&args).into_iter();
    let _program = it.next();
    let input = next_path(&mut it, "params")?;
    let mut p = Params::default();
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
    if p.ticks == 0 {
        return Err(fail("a gate of 0 ticks"));
    }
    let gate = gcd(p.warmup, p.ticks);
    let Some(config) = p.config else {
        return Err(fail("no config line"));
    };
    let ptsa = Config {
        gate_ticks: gate,
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

    let total = p.warmup + p.ticks;
    let skip = p.warmup / gate;
    let mut x = p.x0;
    let mut positive = p.u0_positive;
    let mut pulses_before = PULSES.load(Ordering::Relaxed);
    let (mut sum_p, mut sum_t, mut gates, mut closed) = (0u64, 0u64, 0u32, 0u32);
    // Guest instructions of the whole loop (TIM5 counts one per instruction under
    // `-icount shift=0`), summed tick by tick so that the 32-bit counter may wrap.
    let mut instructions = 0u64;
    let mut last = stopwatch(&watch);
    for _ in 0..total {
        let sample = AdcFormat::sample_masked(p.mask, x[3] * p.gain + p.bias);
        INJECTED.store(ADC.word_of_sample(sample), Ordering::Relaxed);
        cortex_m::peripheral::NVIC::pend(pac::Interrupt::TIM2);
        // The pended interrupt (and the bottom half it may pend) has run before the next
        // instruction after this barrier.
        cortex_m::asm::isb();
        let pulses = PULSES.load(Ordering::Relaxed);
        let decided_positive = pulses != pulses_before;
        pulses_before = pulses;
        let u = usize::from(!positive);
        x = if x[0].abs() <= p.theta_stop {
            step(&p.phi[0], &x, &p.add[0][u])
        } else {
            let r = if x[0] > 0.0 { 1 } else { 2 };
            step(&p.phi[r], &x, &p.add[r][u])
        };
        positive = decided_positive;
        while let Some(g) = critical_section::with(|cs| GATES.borrow_ref_mut(cs).pop()) {
            closed += 1;
            if closed > skip {
                println!("gate {} P={} T={}", closed - skip, g.pulses, g.ticks);
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
        sum_t, sum_p, gates, gate, instructions
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
