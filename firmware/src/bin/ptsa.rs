//! Production image: the PTSA loop at 64 kHz, gated counts reported over defmt (RTT).
//!
//! `TIM2` fires at 64 kHz and runs [`ptsa_firmware::on_tick`]; the main loop pops closed
//! gates from [`ptsa_firmware::GATES`] and logs each as one gate report,
//!
//! `gate seq=<n> P=<pulses> T=<ticks> gates=<merged> tick=<ticks at its close> stack=<bytes>`
//!
//! `seq` the number of the report's last gate (from 1), `P` data pulses over `T` clock
//! ticks, `gates` how many gates the queue merged into it (1 unless the main loop fell
//! behind), `tick` the ticks from the loop's first tick to the close of its last gate (a
//! `u64`, never wrapping) and the stack's high-water mark so far
//! ([`ptsa_firmware::stack_high_water_bytes`]). `ptsa record` turns these lines into a
//! counter record (docs/method/firmware.md).
//!
//! With the `qemu` feature (QEMU `netduinoplus2`, see docs/method/firmware.md) the clock set-up is
//! skipped, TIM2's registers are printed (`tim2 psc=<PSC> arr=<ARR> ug_ns=<virtual time of
//! the update generation, ns>`), each report is also printed as text through semihosting,
//! the same fields with the virtual time added (`gate seq=.. P=.. T=.. gates=.. tick=..
//! t_ns=<virtual time, ns> stack=..`), and after `QEMU_GATES` (3) reports the image exits
//! QEMU with status 0.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use cortex_m_rt::entry;
#[cfg(feature = "qemu")]
use ptsa_core::Config;
use ptsa_firmware::constants::CONFIG;
use ptsa_firmware::{Board, GATES, TICK, TickContext, on_tick, pac, pac::interrupt, unmask_tick};

/// Gates to report before exiting QEMU (`qemu` feature only). The test configuration uses a
/// 6400-tick (100 ms) gate so that this takes 0.3 s of virtual time.
#[cfg(feature = "qemu")]
const QEMU_GATES: u32 = 3;

// defmt over RTT; panics through panic-probe into the one HardFault handler.
ptsa_firmware::image_runtime!(defmt);

#[entry]
fn main() -> ! {
    // The loop designed for the board's instrument file (`cargo xtask constants`).
    #[cfg(not(feature = "qemu"))]
    let config = CONFIG;
    #[cfg(feature = "qemu")]
    let config = Config {
        gate_ticks: 6_400,
        ..CONFIG
    };
    let ptsa = match config.build() {
        Ok(p) => p,
        Err(e) => defmt::panic!("configuration refused: {}", e),
    };
    let Some(dp) = pac::Peripherals::take() else {
        defmt::panic!("peripherals already taken");
    };
    #[cfg(not(feature = "qemu"))]
    ptsa_firmware::clocks_160mhz(&dp.RCC, &dp.FLASH);
    let board = Board::new(dp, ptsa);
    #[cfg(feature = "qemu")]
    let board_stopwatch = board.stopwatch;
    #[cfg(feature = "qemu")]
    {
        let (psc, arr) = board.tick.timer_registers();
        semihosting::println!("tim2 psc={} arr={} ug_ns={}", psc, arr, board.qemu_ug_ns);
    }
    board.tick.start();
    critical_section::with(|cs| TICK.borrow(cs).replace(Some(board.tick)));
    unmask_tick();
    defmt::info!(
        "PTSA loop running: {} Hz tick, gate {} ticks",
        ptsa_firmware::TICK_HZ,
        config.gate_ticks
    );

    #[cfg(feature = "qemu")]
    let mut reported = 0u32;
    loop {
        let Some(count) = critical_section::with(|cs| GATES.borrow_ref_mut(cs).pop()) else {
            cortex_m::asm::wfi();
            continue;
        };
        let stack = ptsa_firmware::stack_high_water_bytes();
        defmt::info!(
            "gate seq={=u64} P={=u64} T={=u64} gates={=u32} tick={=u64} stack={=u32}",
            count.seq,
            count.pulses,
            count.ticks,
            count.gates,
            count.end_tick,
            stack
        );
        #[cfg(feature = "qemu")]
        {
            reported += 1;
            // Virtual time under `-icount shift=0`: TIM5 counts 1 GHz, i.e. nanoseconds.
            semihosting::println!(
                "gate seq={} P={} T={} gates={} tick={} t_ns={} stack={}",
                count.seq,
                count.pulses,
                count.ticks,
                count.gates,
                count.end_tick,
                ptsa_firmware::stopwatch(&board_stopwatch),
                stack
            );
            if reported == QEMU_GATES {
                ptsa_firmware::rt::exit(0);
            }
        }
    }
}

/// The tick's bottom half: queue a closed gate.
#[interrupt]
fn EXTI0() {
    ptsa_firmware::on_gate();
}

#[interrupt]
fn TIM2() {
    static mut CONTEXT: Option<TickContext> = None;
    on_tick::<false>(CONTEXT);
}
