//! Board glue for running [`ptsa_core`] on an STM32F405/407 (thumbv7em-none-eabihf).
//!
//! Everything the loop decides lives in `ptsa-core`; this crate only
//!
//! * sets up the clocks ([`clocks_160mhz`]), the pickoff ADC, the two H-bridge legs and the
//!   64 kHz tick timer ([`Board::new`]),
//! * holds the interrupt's context ([`TICK`]) and the gate queue ([`GATES`]) shared with the
//!   main loop, and
//! * services one tick ([`on_tick`]): read the ADC, call [`ptsa_core::Ptsa::tick`], drive the
//!   legs through [`ptsa_core::HBridge`], hand a closed gate to the bottom half
//!   ([`on_gate`], which queues it).
//!
//! The images' `HardFault` handler, panic path and [`rt::exit`] are in [`rt`], each image
//! choosing with [`image_runtime!`] whether it reports over defmt or semihosting.
//!
//! The strapdown triad (three loops in one tick handler, its own images `triad`,
//! `triad_golden`, `triad_budget`) is in [`triad`], its test images' helpers in
//! [`triadtest`].
//!
//! The production image `ptsa` and the QEMU test image `budget` have the same `TIM2`
//! handler (`on_tick`, differing only in the address the pickoff word is read from), so what
//! the test image measures is what runs on the board.
//!
//! # Pins and units
//!
//! | signal | pin | detail |
//! |---|---|---|
//! | pickoff | PA1 = ADC1 channel 1 | 12 bit, left-aligned; 0 V = code −32768, mid-scale (`V_REF`/2) = 0, `V_REF` = +32752 (steps of 16 LSB of the `i16` sample) |
//! | H-bridge leg A | PD12 (green LED on the STM32F4DISCOVERY) | high while the polarity is `Positive` |
//! | H-bridge leg B | PD14 (red LED on the STM32F4DISCOVERY) | high while the polarity is `Negative` |
//!
//! The tick timer is TIM2, update interrupt at [`TICK_HZ`] = 64 000 Hz. On the board the
//! core runs at [`SYSCLK_HZ`] = 160 MHz from the 8 MHz HSE crystal (168 MHz is not usable:
//! TIM2's 84 MHz kernel clock is not a multiple of 64 kHz), so TIM2 counts at 80 MHz and a
//! tick is 1250 timer counts = 2500 core cycles. Under QEMU (`qemu` feature) the timer
//! kernel clock is QEMU's fixed 1 GHz ([`TIMER_CLOCK_HZ`]).
//!
//! ADC1 converts continuously (15 + 12 ADC clocks = 1.35 µs per conversion at 20 MHz); the
//! tick interrupt reads the newest result, so its sample is at most 1.35 µs old. (QEMU's ADC
//! model does not convert continuously: under QEMU the data register reads 0.)
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]

use core::cell::RefCell;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use critical_section::Mutex;
use embedded_hal::digital::{ErrorType, OutputPin};
use ptsa_core::{Gate, GateFifo, HBridge, Ptsa, State};

pub use stm32f4::stm32f405 as pac;

pub mod constants;
pub mod rt;
pub mod testimage;
pub mod triad;
pub mod triadtest;

/// Tick (clock) frequency of the PTSA loop, in hertz (generated from the instrument file:
/// [`constants::TICK_HZ`]).
pub const TICK_HZ: u32 = constants::TICK_HZ;

/// Core clock on the board, in hertz.
pub const SYSCLK_HZ: u32 = 160_000_000;

/// TIM2's kernel clock, in hertz: `2 × PCLK1` = 80 MHz on the board; QEMU's timers count at
/// a fixed 1 GHz of virtual time.
#[cfg(not(feature = "qemu"))]
pub const TIMER_CLOCK_HZ: u32 = SYSCLK_HZ / 2;
/// TIM2's kernel clock, in hertz: `2 × PCLK1` = 80 MHz on the board; QEMU's timers count at
/// a fixed 1 GHz of virtual time.
#[cfg(feature = "qemu")]
pub const TIMER_CLOCK_HZ: u32 = 1_000_000_000;

/// TIM2 auto-reload value: timer counts per tick minus one.
pub const TICK_RELOAD: u32 = TIMER_CLOCK_HZ / TICK_HZ - 1;
const _: () = assert!(
    TIMER_CLOCK_HZ.is_multiple_of(TICK_HZ),
    "the tick must be an exact division"
);

/// Entries of the gate queue between the interrupt and the main loop. At the default 1 s
/// gate the main loop may fall 8 s behind before consecutive gates are merged (never lost).
pub const GATE_QUEUE: usize = 8;

/// Gate queue: the tick interrupt pushes, the main loop pops.
pub static GATES: Mutex<RefCell<GateFifo<GATE_QUEUE>>> = Mutex::new(RefCell::new(GateFifo::new()));

/// The tick interrupt's context, installed by `main` before the interrupt is unmasked; the
/// first tick moves it into the handler (see [`on_tick`]).
pub static TICK: Mutex<RefCell<Option<TickContext>>> = Mutex::new(RefCell::new(None));

/// One H-bridge leg: a push-pull output of port D, written through the atomic BSRR register.
pub struct Leg<const PIN: u8> {
    port: pac::GPIOD,
}

impl<const PIN: u8> ErrorType for Leg<PIN> {
    type Error = core::convert::Infallible;
}

impl<const PIN: u8> OutputPin for Leg<PIN> {
    #[allow(
        clippy::inline_always,
        reason = "tick path: a pin write inside the TIM2 handler"
    )]
    #[inline(always)]
    fn set_low(&mut self) -> Result<(), Self::Error> {
        self.port.bsrr().write(|w| w.br(PIN).set_bit());
        Ok(())
    }

    #[allow(
        clippy::inline_always,
        reason = "tick path: a pin write inside the TIM2 handler"
    )]
    #[inline(always)]
    fn set_high(&mut self) -> Result<(), Self::Error> {
        self.port.bsrr().write(|w| w.bs(PIN).set_bit());
        Ok(())
    }
}

/// Leg A of the H-bridge (PD12).
pub type LegA = Leg<12>;
/// Leg B of the H-bridge (PD14).
pub type LegB = Leg<14>;

/// Everything the tick interrupt owns.
pub struct TickContext {
    /// The validated loop.
    pub ptsa: Ptsa,
    /// Its state.
    pub state: State,
    /// The torquer's H-bridge.
    pub bridge: HBridge<LegA, LegB>,
    adc: pac::ADC1,
    timer: pac::TIM2,
}

/// The peripherals the firmware uses, set up.
pub struct Board {
    /// The tick interrupt's context (install it in [`TICK`]).
    pub tick: TickContext,
    /// A free-running 32-bit counter at [`TIMER_CLOCK_HZ`] (TIM5), for measurements. Under
    /// QEMU with `-icount shift=0` one count is one guest instruction.
    pub stopwatch: pac::TIM5,
    /// QEMU only: the virtual time, in ns since reset, at which TIM2's update generation
    /// (`EGR.UG`) was written. QEMU 7.2's STM32 timer model re-arms every period
    /// `ARR + this` ns after the last one instead of `ARR + 1` (see docs/method/firmware.md), so the
    /// host check needs it to predict the emulated tick. Read from TIM5 before anything has
    /// written TIM5, when its count is the virtual time since reset.
    #[cfg(feature = "qemu")]
    pub qemu_ug_ns: u32,
}

impl Board {
    /// Set up GPIO, ADC, TIM2 (stopped) and TIM5 (running). Call [`clocks_160mhz`] first on
    /// the board; nothing here waits on a flag, so it also runs under QEMU.
    #[must_use]
    pub fn new(dp: pac::Peripherals, ptsa: Ptsa) -> Self {
        let rcc = &dp.RCC;
        rcc.ahb1enr()
            .modify(|_, w| w.gpioaen().enabled().gpioden().enabled());
        rcc.apb1enr()
            .modify(|_, w| w.tim2en().enabled().tim5en().enabled());
        rcc.apb2enr().modify(|_, w| w.adc1en().enabled());
        // RM0090 errata: allow two bus cycles after enabling a peripheral clock.
        let _ = rcc.apb2enr().read();

        // PA1 analog; PD12, PD14 push-pull outputs, low.
        dp.GPIOA.moder().modify(|_, w| w.moder1().analog());
        dp.GPIOD
            .moder()
            .modify(|_, w| w.moder12().output().moder14().output());
        let b: LegB = Leg {
            port: second_gpiod_handle(),
        };
        let a: LegA = Leg { port: dp.GPIOD };
        let Ok(bridge) = HBridge::new(a, b);

        // ADC1: ADCCLK = PCLK2 / 4 = 20 MHz, channel 1, 15-cycle sampling, left-aligned.
        dp.ADC_COMMON.ccr().modify(|_, w| w.adcpre().div4());
        dp.ADC1.smpr2().modify(|_, w| w.smp1().cycles15());
        start_adc(&dp.ADC1, 1);

        // TIM2: update event every tick; interrupt enabled; counter not started yet.
        let tim = dp.TIM2;
        tim.psc().write(|w| w.psc().set(0));
        tim.arr().write(|w| w.arr().set(TICK_RELOAD));
        #[cfg(feature = "qemu")]
        let qemu_ug_ns = dp.TIM5.cnt().read().bits();
        tim.egr().write(|w| w.ug().update());
        tim.sr().write(|w| w.uif().clear_bit());
        tim.dier().write(|w| w.uie().enabled());

        // TIM5: free-running stopwatch.
        let sw = dp.TIM5;
        sw.psc().write(|w| w.psc().set(0));
        sw.arr().write(|w| w.arr().set(u32::MAX));
        sw.egr().write(|w| w.ug().update());
        sw.cr1().write(|w| w.cen().enabled());

        Self {
            tick: TickContext {
                ptsa,
                state: ptsa.initial_state(),
                bridge,
                adc: dp.ADC1,
                timer: tim,
            },
            stopwatch: sw,
            #[cfg(feature = "qemu")]
            qemu_ug_ns,
        }
    }
}

impl TickContext {
    /// Start the tick timer (the interrupt fires once [`unmask_tick`] has run).
    pub fn start(&self) {
        self.timer.cr1().write(|w| w.cen().enabled());
    }

    /// TIM2's prescaler and auto-reload registers as the hardware holds them: the tick is
    /// [`TIMER_CLOCK_HZ`] / ((PSC + 1) (ARR + 1)).
    #[must_use]
    pub fn timer_registers(&self) -> (u32, u32) {
        (
            self.timer.psc().read().bits(),
            self.timer.arr().read().bits(),
        )
    }
}

/// Read the stopwatch (TIM5 counter).
#[allow(
    clippy::inline_always,
    reason = "one load, so the measurement bracket counts no call"
)]
#[inline(always)]
#[must_use]
pub fn stopwatch(tim5: &pac::TIM5) -> u32 {
    tim5.cnt().read().bits()
}

/// A further handle on port D for a leg (leg B here; every leg of the triad, `triad`).
#[allow(unsafe_code)]
fn second_gpiod_handle() -> pac::GPIOD {
    // SAFETY: the legs only write BSRR, whose writes are atomic and touch only the bits
    // written as 1: each leg its own pin's set and reset bits (single axis: leg A bits 12
    // and 28, leg B bits 14 and 30; the triad adds pins 13, 15, 8 and 9, bits 13/29, 15/31,
    // 8/24, 9/25). Nothing else in the firmware uses port D after `Board::new` or
    // `TriadBoard::new` has configured MODER.
    unsafe { pac::GPIOD::steal() }
}

/// Start the ADC converting its one regular channel `channel` continuously, left-aligned
/// (the single axis's ADC1 and each of the triad's three).
fn start_adc(adc: &pac::adc1::RegisterBlock, channel: u8) {
    select_channel(adc, channel);
    adc.cr2()
        .write(|w| w.adon().enabled().align().left().cont().continuous());
    adc.cr2().write(|w| {
        w.adon()
            .enabled()
            .align()
            .left()
            .cont()
            .continuous()
            .swstart()
            .start()
    });
}

/// Select the ADC's one regular channel, `channel` (1, 2 or 3: `ADC123_IN1`..`IN3`).
#[allow(unsafe_code)]
fn select_channel(adc: &pac::adc1::RegisterBlock, channel: u8) {
    debug_assert!((1..=3).contains(&channel));
    // SAFETY: SQ1 is a 5-bit channel number; every caller passes a constant 1, 2 or 3,
    // valid regular channels (ADC123_IN1..IN3).
    adc.sqr3().write(|w| unsafe { w.sq1().bits(channel) });
}

/// Unmask an interrupt in the NVIC.
///
/// `cortex_m::peripheral::NVIC::unmask` is `unsafe` because unmasking can break a
/// mask-based critical section; this firmware uses only `critical-section`'s PRIMASK-based
/// one, so unmasking is sound.
#[allow(unsafe_code)]
pub fn unmask(irq: pac::Interrupt) {
    // SAFETY: no mask-based critical section exists in this firmware (see above).
    unsafe { cortex_m::peripheral::NVIC::unmask(irq) }
}

/// Unmask the tick interrupt (TIM2) and its bottom half ([`GATE_IRQ`]).
pub fn unmask_tick() {
    unmask(GATE_IRQ);
    unmask(pac::Interrupt::TIM2);
}

/// Switch the core to 160 MHz from the 8 MHz HSE crystal: PLL M = 8, N = 320, P = 2
/// (VCO 320 MHz), Q = 7; AHB = 160 MHz, APB1 = 40 MHz (timers 80 MHz), APB2 = 80 MHz;
/// 5 flash wait states with prefetch and caches.
///
/// Waits on the RCC's ready flags: **do not call under QEMU**, whose RCC is unimplemented
/// (reads as zero). The `qemu` feature leaves the chip on its reset clock instead.
#[allow(unsafe_code)]
pub fn clocks_160mhz(rcc: &pac::RCC, flash: &pac::FLASH) {
    rcc.cr().modify(|_, w| w.hseon().on());
    while rcc.cr().read().hserdy().is_not_ready() {}
    rcc.pllcfgr().write(|w| {
        // SAFETY: PLLM = 8 (valid 2..=63) gives a 1 MHz PLL input; PLLN = 320 (valid
        // 50..=432) a 320 MHz VCO (valid 100..=432 MHz).
        unsafe { w.pllm().bits(8).plln().bits(320) };
        // SAFETY: PLLQ = 7 is in its valid range 2..=15.
        unsafe { w.pllq().bits(7) };
        w.pllp().div2().pllsrc().hse()
    });
    rcc.cr().modify(|_, w| w.pllon().on());
    while rcc.cr().read().pllrdy().is_not_ready() {}
    flash.acr().write(|w| {
        w.latency()
            .ws5()
            .prften()
            .enabled()
            .icen()
            .enabled()
            .dcen()
            .enabled()
    });
    rcc.cfgr()
        .modify(|_, w| w.hpre().div1().ppre1().div4().ppre2().div2().sw().pll());
    while !rcc.cfgr().read().sws().is_pll() {}
}

/// The word cortex-m-rt paints the stack with before `main` (feature `paint-stack`).
pub const STACK_PAINT: u32 = 0xCCCC_CCCC;

// The two symbols cortex-m-rt's linker script defines; only their addresses are used.
#[allow(unsafe_code)]
unsafe extern "C" {
    /// Top of the stack (first address above it), from cortex-m-rt's `link.x`.
    safe static _stack_start: u32;
    /// Bottom of the stack region (lowest address it may grow to), from `link.x`.
    safe static _stack_end: u32;
}

/// Deepest stack use so far, in bytes: the distance from the top of the stack to the
/// lowest word that no longer holds [`STACK_PAINT`].
///
/// cortex-m-rt's `paint-stack` feature fills the whole stack region (from the end of
/// `.bss`/`.uninit` to the top of RAM) with [`STACK_PAINT`] before `main`; every push
/// scrubs the paint. The scan runs from the bottom of the region upwards and stops at the
/// first scrubbed word, so it reads the high-water mark of everything that has run since
/// reset: `main`, the tick interrupt, the gate bottom half and exception stacking. A
/// pushed word that happens to equal the paint could hide the deepest word (at most an
/// underestimate of 4 bytes per such word at the very bottom, none in practice).
///
/// Cost: one load per word of unused stack (about 32 000 on the 128 KiB part, some 0.4 ms
/// at 160 MHz). Call it from thread mode, never from the tick interrupt.
#[must_use]
pub fn stack_high_water_bytes() -> u32 {
    let top = (&raw const _stack_start) as usize;
    let bottom = (&raw const _stack_end) as usize;
    let mut p = bottom.next_multiple_of(4);
    while p < top && read_word(p) == STACK_PAINT {
        p += 4;
    }
    #[allow(clippy::cast_possible_truncation)]
    let used = (top - p) as u32;
    used
}

#[allow(unsafe_code)]
fn read_word(addr: usize) -> u32 {
    // SAFETY: `addr` is word-aligned and inside the stack region [_stack_end, _stack_start)
    // of RAM, which is always mapped and readable; a volatile read of a `u32` has no
    // validity requirement and does not create a reference into the frames that own it.
    unsafe { core::ptr::read_volatile(addr as *const u32) }
}

/// Test images only: the pickoff word [`on_tick`] reads instead of the ADC's data register
/// when `INJECT` is set, as the ADC would deliver it (for the board's left-aligned offset
/// binary converter, [`constants::ADC`], the `i16` sample XOR `0x8000`).
pub static INJECTED: AtomicU32 = AtomicU32::new(0);

/// A gate closed by the tick interrupt, waiting for [`on_gate`] to queue it: pulses,
/// ticks, and whether the slot is full. Written only by `TIM2`, read only by the bottom half,
/// which have the same priority and so never preempt each other.
static CLOSED_PULSES: AtomicU32 = AtomicU32::new(0);
static CLOSED_TICKS: AtomicU32 = AtomicU32::new(0);
static CLOSED_FULL: AtomicBool = AtomicBool::new(false);

/// Interrupt that queues closed gates (the tick interrupt's bottom half): an otherwise
/// unused vector, pended by software. It has the same (default) priority as `TIM2`, so it
/// tail-chains right after the tick that closed the gate, and neither preempts the other.
pub const GATE_IRQ: pac::Interrupt = pac::Interrupt::EXTI0;

/// Service one tick (the body of the `TIM2` interrupt): acknowledge the timer, read the
/// newest pickoff sample, run the loop, drive the bridge, hand a
/// closed gate to [`on_gate`].
///
/// `ctx` is the handler's own `static mut` (cortex-m-rt hands it out as `&mut`). The first
/// interrupt moves the context in from [`TICK`], where `main` installed it, and returns.
///
/// With `INJECT = true` (test images only) the pickoff word comes from [`INJECTED`] instead
/// of the ADC's data register; nothing else differs.
#[allow(
    clippy::inline_always,
    reason = "the whole tick inlined into each image's TIM2 handler"
)]
#[inline(always)]
pub fn on_tick<const INJECT: bool>(ctx: &mut Option<TickContext>) {
    let Some(c) = ctx.as_mut() else {
        install(ctx);
        return;
    };
    c.timer.sr().write(|w| w.uif().clear_bit());
    let raw = if INJECT {
        INJECTED.load(Ordering::Relaxed)
    } else {
        c.adc.dr().read().bits()
    };
    // The board's converter ([`constants::ADC`]): on the STM32F4, a left-aligned 12-bit
    // code in bits 15..4, offset binary, so this is `raw ^ 0x8000` as `i16`.
    let x = constants::ADC.sample_of_word(raw);
    let t = c.ptsa.tick(&mut c.state, x);
    let Ok(()) = c.bridge.set(t.polarity);
    if let Some(g) = t.gate {
        close_gate(g);
    }
}

/// Hand a closed gate to the bottom half and pend it.
#[allow(clippy::inline_always, reason = "tick path: inside the TIM2 handler")]
#[inline(always)]
fn close_gate(g: Gate) {
    if CLOSED_FULL.load(Ordering::Relaxed) {
        // Cannot happen: the pended bottom half (lower vector number, same priority) runs
        // before the next tick. Should it not have, queue the waiting gate here, in order:
        // nothing is lost.
        queue_waiting_gate();
    }
    CLOSED_PULSES.store(g.pulses, Ordering::Relaxed);
    CLOSED_TICKS.store(g.ticks, Ordering::Relaxed);
    CLOSED_FULL.store(true, Ordering::Relaxed);
    cortex_m::peripheral::NVIC::pend(GATE_IRQ);
}

/// Move the gate waiting in the slot into [`GATES`] and empty the slot.
#[cold]
#[inline(never)]
fn queue_waiting_gate() {
    let g = Gate {
        pulses: CLOSED_PULSES.load(Ordering::Relaxed),
        ticks: CLOSED_TICKS.load(Ordering::Relaxed),
    };
    CLOSED_FULL.store(false, Ordering::Relaxed);
    critical_section::with(|cs| GATES.borrow_ref_mut(cs).push(g));
}

/// The bottom half (body of the [`GATE_IRQ`] handler): move a closed gate into [`GATES`].
pub fn on_gate() {
    if CLOSED_FULL.load(Ordering::Relaxed) {
        queue_waiting_gate();
    }
}

/// Move the context in from [`TICK`].
#[cold]
#[inline(never)]
fn install(ctx: &mut Option<TickContext>) {
    critical_section::with(|cs| {
        if let Some(c) = TICK.borrow_ref_mut(cs).take() {
            *ctx = Some(c);
        }
    });
}
