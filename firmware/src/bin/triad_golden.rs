//! Test image for QEMU (`netduinoplus2`): bit-exactness of the strapdown triad, three
//! golden vectors at once, one per axis, through the triad's `TIM2` interrupt.
//!
//! Semihosting command line: `triad_golden <in0> <out0> <in1> <out1> <in2> <out2>`. Each
//! axis's loop is configured by its vector's first `config` line; every tick the image
//! stores the three axes' next samples where the handler reads them and pends the real
//! `TIM2` interrupt, whose handler is [`ptsa_firmware::triad::on_tick_triad`] with the
//! samples from RAM and its ticks recorded; each axis's output (the golden format) goes to
//! its file, for the host to compare with the first run of the vector's `.out`. Exits QEMU
//! with status 0, or 1 with a message on standard error.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use cortex_m_rt::entry;
use ptsa_firmware::rt::exit;
use ptsa_firmware::testimage::{Failure, PATH, next_path, section_config};
use ptsa_firmware::triad::{TRIAD, TriadBoard, TriadContext, on_gate_triad, on_tick_triad};
use ptsa_firmware::triadtest::triad_golden_pass;
use ptsa_firmware::{pac, pac::interrupt, unmask};
use semihosting::eprintln;

// Reports on semihosting standard error; HardFault exits 70, a panic 101.
ptsa_firmware::image_runtime!(semihosting, "triad_golden");

#[entry]
fn main() -> ! {
    match run() {
        Ok(()) => exit(0),
        Err(Failure) => exit(1),
    }
}

fn run() -> Result<(), Failure> {
    let Ok(args) = semihosting::experimental::env::args::<{ 6 * PATH }>() else {
        eprintln!("triad_golden: cannot read the semihosting command line");
        return Err(Failure);
    };
    let mut it = (&args).into_iter();
    let _program = it.next();
    let (i0, o0) = (
        next_path(&mut it, "input 0")?,
        next_path(&mut it, "output 0")?,
    );
    let (i1, o1) = (
        next_path(&mut it, "input 1")?,
        next_path(&mut it, "output 1")?,
    );
    let (i2, o2) = (
        next_path(&mut it, "input 2")?,
        next_path(&mut it, "output 2")?,
    );
    let ptsa = [
        section_config(i0.as_cstr(), 0)?,
        section_config(i1.as_cstr(), 0)?,
        section_config(i2.as_cstr(), 0)?,
    ];
    let Some(dp) = pac::Peripherals::take() else {
        eprintln!("triad_golden: peripherals already taken");
        return Err(Failure);
    };
    let board = TriadBoard::new(dp, ptsa);
    critical_section::with(|cs| TRIAD.borrow(cs).replace(Some(board.tick)));
    unmask(pac::Interrupt::TIM2);
    triad_golden_pass(
        [i0.as_cstr(), i1.as_cstr(), i2.as_cstr()],
        [o0.as_cstr(), o1.as_cstr(), o2.as_cstr()],
    )
}

/// The triad's bottom half (masked here: closed gates are queued by the tick itself).
#[interrupt]
fn EXTI0() {
    on_gate_triad();
}

/// The triad's tick handler, fed from RAM, recording each axis's tick.
#[interrupt]
fn TIM2() {
    static mut CONTEXT: Option<TriadContext> = None;
    on_tick_triad::<true, true>(CONTEXT);
}
