//! Production image of the strapdown triad: three PTSA loops (axes 0, 1, 2) in one 64 kHz
//! `TIM2` interrupt, gated counts reported over defmt (RTT), one report per axis and gate.
//!
//! `TIM2` runs [`ptsa_firmware::triad::on_tick_triad`]; the main loop pops each axis's
//! closed gates from [`ptsa_firmware::triad::TRIAD_GATES`] and logs them as the
//! single-axis image does, with the axis first:
//!
//! `gate axis=<k> seq=<n> P=<pulses> T=<ticks> gates=<merged> tick=<ticks at its close> stack=<bytes>`
//!
//! (`seq` and `tick` per axis; `ptsa record --axis K` takes one axis's reports). The pins
//! are in [`ptsa_firmware::triad`]. Every axis runs `Config::DEFAULT`; a real triad gives
//! each axis the configuration designed for its instrument.
//!
//! With the `qemu` feature the clock set-up is skipped, the gate is 6400 ticks (100 ms),
//! each report is also printed through semihosting (`t_ns=` added before `stack=`) and the
//! image exits QEMU with status 0 after `QEMU_GATES` (3) gates of every axis.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use cortex_m_rt::entry;
use ptsa_core::Config;
use ptsa_firmware::triad::{
    AXES, TRIAD, TRIAD_GATES, TriadBoard, TriadContext, on_gate_triad, on_tick_triad,
};
use ptsa_firmware::{pac, pac::interrupt, unmask_tick};

/// Gates of every axis to report before exiting QEMU (`qemu` feature only).
#[cfg(feature = "qemu")]
const QEMU_GATES: u64 = 3;

// defmt over RTT; panics through panic-probe into the one HardFault handler.
ptsa_firmware::image_runtime!(defmt);

#[entry]
fn main() -> ! {
    #[cfg(not(feature = "qemu"))]
    let config = Config::DEFAULT;
    #[cfg(feature = "qemu")]
    let config = Config {
        gate_ticks: 6_400,
        ..Config::DEFAULT
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
    let board = TriadBoard::new(dp, [ptsa; AXES]);
    #[cfg(feature = "qemu")]
    let board_stopwatch = board.stopwatch;
    board.tick.start();
    critical_section::with(|cs| TRIAD.borrow(cs).replace(Some(board.tick)));
    unmask_tick();
    defmt::info!(
        "PTSA triad running: {} axes, {} Hz tick, gate {} ticks",
        AXES,
        ptsa_firmware::TICK_HZ,
        config.gate_ticks
    );

    loop {
        let next = critical_section::with(|cs| {
            let mut q = TRIAD_GATES.borrow_ref_mut(cs);
            (0..AXES).find_map(|k| q[k].pop().map(|c| (k, c)))
        });
        let Some((axis, count)) = next else {
            cortex_m::asm::wfi();
            continue;
        };
        let stack = ptsa_firmware::stack_high_water_bytes();
        #[allow(clippy::cast_possible_truncation)]
        let axis = axis as u32;
        defmt::info!(
            "gate axis={=u32} seq={=u64} P={=u64} T={=u64} gates={=u32} tick={=u64} stack={=u32}",
            axis,
            count.seq,
            count.pulses,
            count.ticks,
            count.gates,
            count.end_tick,
            stack
        );
        #[cfg(feature = "qemu")]
        {
            semihosting::println!(
                "gate axis={} seq={} P={} T={} gates={} tick={} t_ns={} stack={}",
                axis,
                count.seq,
                count.pulses,
                count.ticks,
                count.gates,
                count.end_tick,
                ptsa_firmware::stopwatch(&board_stopwatch),
                stack
            );
            if axis as usize == AXES - 1 && count.seq >= QEMU_GATES {
                ptsa_firmware::rt::exit(0);
            }
        }
    }
}

/// The triad's bottom half: queue the closed gates.
#[interrupt]
fn EXTI0() {
    on_gate_triad();
}

#[interrupt]
fn TIM2() {
    static mut CONTEXT: Option<TriadContext> = None;
    on_tick_triad::<false, false>(CONTEXT);
}
