//! Test image for QEMU (`netduinoplus2`): instructions per tick of the production tick
//! interrupt, over one golden vector.
//!
//! Semihosting command line: `budget <input> [<section>]`: the run of `<input>` that starts
//! at its `<section>`-th `config` line (0-based, default 0; one QEMU run per run of the
//! vector, so that the handler never needs a reconfiguration path). For every sample of
//! that run the image pends
//! the real `TIM2` interrupt, whose handler is the production one
//! ([`ptsa_firmware::on_tick`]; the pickoff word comes from RAM instead of the ADC's data
//! register), between two reads of the TIM5 stopwatch. Under `-icount shift=0` one
//! stopwatch count is one guest instruction, so the difference, minus the bracket's own cost
//! (measured the same way around an empty handler), is the number of instructions of the
//! whole handler, prologue and return included. The gate bottom half (`EXTI0`) is run and
//! counted separately. This image links no `GoldenRunner`, so, as in the production image,
//! the loop's `tick` has a single caller and is inlined into the handler. Prints
//!
//! `budget section=<k> ticks=<n> max=<instr> max_plain=<instr> max_gate=<instr> bottom_half=<instr> mean=<instr> overhead=<instr>`
//!
//! and exits QEMU with status 0, or 1 with a message on standard error.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use cortex_m_rt::entry;
use ptsa_firmware::rt::exit;
use ptsa_firmware::testimage::{Failure, PATH, budget_pass, next_path, section_config};
use ptsa_firmware::{Board, TICK, TickContext, on_tick, pac, pac::interrupt, unmask};
use semihosting::eprintln;

// Reports on semihosting standard error; HardFault exits 70, a panic 101.
ptsa_firmware::image_runtime!(semihosting, "budget");

#[entry]
fn main() -> ! {
    match run() {
        Ok(()) => exit(0),
        Err(Failure) => exit(1),
    }
}

fn run() -> Result<(), Failure> {
    let Ok(args) = semihosting::experimental::env::args::<{ 2 * PATH }>() else {
        eprintln!("budget: cannot read the semihosting command line");
        return Err(Failure);
    };
    let mut it = (&args).into_iter();
    let _program = it.next();
    let input = next_path(&mut it, "input")?;
    let section = match it.next() {
        None => 0,
        Some(Ok(s)) => s.parse().map_err(|_| {
            eprintln!("budget: section must be a number, not {:?}", s);
            Failure
        })?,
        Some(Err(_)) => {
            eprintln!("budget: section is not UTF-8");
            return Err(Failure);
        }
    };
    let Some(dp) = pac::Peripherals::take() else {
        eprintln!("budget: peripherals already taken");
        return Err(Failure);
    };
    let ptsa = section_config(input.as_cstr(), section)?;
    let board = Board::new(dp, ptsa);
    let watch = board.stopwatch;
    critical_section::with(|cs| TICK.borrow(cs).replace(Some(board.tick)));
    // The bottom half stays masked: `budget_pass` runs and counts it separately.
    unmask(pac::Interrupt::TIM2);
    unmask(pac::Interrupt::TIM3);
    budget_pass(input.as_cstr(), section, &watch)
}

/// The tick's bottom half: queue a closed gate.
#[interrupt]
fn EXTI0() {
    ptsa_firmware::on_gate();
}

/// The production tick handler, fed from RAM.
#[interrupt]
fn TIM2() {
    static mut CONTEXT: Option<TickContext> = None;
    on_tick::<true>(CONTEXT);
}

/// The empty handler that calibrates the measurement bracket.
#[interrupt]
fn TIM3() {}
