//! Test image for QEMU (`netduinoplus2`): instructions per tick of the strapdown triad's
//! tick interrupt, three golden vectors at once, one per axis.
//!
//! Semihosting command line: `triad_budget <in0> <in1> <in2>`. As the single-axis `budget`
//! image: every tick pends the real `TIM2` interrupt, whose handler is the triad image's
//! ([`ptsa_firmware::triad::on_tick_triad`], samples from RAM instead of the three ADC data
//! registers, nothing recorded), between two reads of the TIM5 stopwatch; under
//! `-icount shift=0` the difference minus the bracket's own cost is the number of
//! instructions of the whole handler. The bottom half is run and counted separately. Prints
//! the `budget …` line of the single-axis image (`section=0`) and exits QEMU with status 0,
//! or 1 with a message on standard error.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use cortex_m_rt::entry;
use ptsa_firmware::rt::exit;
use ptsa_firmware::testimage::{Failure, PATH, next_path, section_config};
use ptsa_firmware::triad::{TRIAD, TriadBoard, TriadContext, on_gate_triad, on_tick_triad};
use ptsa_firmware::triadtest::triad_budget_pass;
use ptsa_firmware::{pac, pac::interrupt, unmask};
use semihosting::eprintln;

// Reports on semihosting standard error; HardFault exits 70, a panic 101.
ptsa_firmware::image_runtime!(semihosting, "triad_budget");

#[entry]
fn main() -> ! {
    match run() {
        Ok(()) => exit(0),
        Err(Failure) => exit(1),
    }
}

fn run() -> Result<(), Failure> {
    let Ok(args) = semihosting::experimental::env::args::<{ 3 * PATH }>() else {
        eprintln!("triad_budget: cannot read the semihosting command line");
        return Err(Failure);
    };
    let mut it = (&args).into_iter();
    let _program = it.next();
    let i0 = next_path(&mut it, "input 0")?;
    let i1 = next_path(&mut it, "input 1")?;
    let i2 = next_path(&mut it, "input 2")?;
    let ptsa = [
        section_config(i0.as_cstr(), 0)?,
        section_config(i1.as_cstr(), 0)?,
        section_config(i2.as_cstr(), 0)?,
    ];
    let Some(dp) = pac::Peripherals::take() else {
        eprintln!("triad_budget: peripherals already taken");
        return Err(Failure);
    };
    let board = TriadBoard::new(dp, ptsa);
    let watch = board.stopwatch;
    critical_section::with(|cs| TRIAD.borrow(cs).replace(Some(board.tick)));
    // The bottom half stays masked: `triad_budget_pass` runs and counts it separately.
    unmask(pac::Interrupt::TIM2);
    unmask(pac::Interrupt::TIM3);
    triad_budget_pass([i0.as_cstr(), i1.as_cstr(), i2.as_cstr()], &watch)
}

/// The triad's bottom half: queue the closed gates.
#[interrupt]
fn EXTI0() {
    on_gate_triad();
}

/// The triad's production tick handler, fed from RAM.
#[interrupt]
fn TIM2() {
    static mut CONTEXT: Option<TriadContext> = None;
    on_tick_triad::<true, false>(CONTEXT);
}

/// The empty handler that calibrates the measurement bracket.
#[interrupt]
fn TIM3() {}
