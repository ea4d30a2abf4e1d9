//! A strapdown triad on one processor: three PTSA loops, one per accelerometer axis, in one
//! 64 kHz `TIM2` interrupt.
//!
//! Each axis is the single-axis loop over again: its own [`ptsa_core::Ptsa`] (configuration)
//! and [`ptsa_core::State`], its own ADC and H-bridge; the tick handler [`on_tick_triad`]
//! reads the three pickoff samples, runs the three loops one after the other, drives the
//! three bridges and hands closed gates to the bottom half [`on_gate_triad`], which queues
//! each axis's gates in its own [`ptsa_core::GateFifo`] ([`TRIAD_GATES`]), numbered per
//! axis.
//!
//! # Pins
//!
//! | axis | pickoff | H-bridge leg A | H-bridge leg B |
//! |---|---|---|---|
//! | 0 | PA1 = ADC1 channel 1 | PD12 (green LED on the STM32F4DISCOVERY) | PD14 (red LED) |
//! | 1 | PA2 = ADC2 channel 2 | PD13 (orange LED) | PD15 (blue LED) |
//! | 2 | PA3 = ADC3 channel 3 | PD8 | PD9 |
//!
//! Axis 0 is wired as the single-axis image. The three ADCs run independently, each in
//! continuous conversion of its one channel (15-cycle sampling, ADCCLK 20 MHz, 1.35 µs per
//! conversion, left-aligned), as the single-axis ADC1 does; the handler reads their three
//! data registers, so each sample is at most 1.35 µs old and the three are at most 1.35 µs
//! apart (a tenth of a tick). (The STM32F4's triple regular-simultaneous mode would sample
//! the three at the same instant; this image does not use it. Under QEMU the data registers
//! read 0.) On the Discovery board PA1–PA3 and PD8/PD9 are free header pins; check them
//! against another board's schematic.

use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, Ordering};

use critical_section::Mutex;
use ptsa_core::{Gate, GateFifo, HBridge, Ptsa, State, Tick};

use crate::{GATE_IRQ, Leg, TICK_RELOAD, pac, second_gpiod_handle, start_adc};

/// Axes of the triad.
pub const AXES: usize = 3;

/// Entries of each axis's gate queue.
pub const TRIAD_GATE_QUEUE: usize = 8;

/// The three axes' gate queues: the bottom half pushes, the main loop pops.
pub static TRIAD_GATES: Mutex<RefCell<[GateFifo<TRIAD_GATE_QUEUE>; AXES]>> =
    Mutex::new(RefCell::new([const { GateFifo::new() }; AXES]));

/// The triad interrupt's context, installed by `main` before the interrupt is unmasked.
pub static TRIAD: Mutex<RefCell<Option<TriadContext>>> = Mutex::new(RefCell::new(None));

/// Test images only: the three pickoff words [`on_tick_triad`] reads instead of the ADCs'
/// data registers when `INJECT` is set (left-aligned offset binary, as the ADC delivers).
pub static INJECTED3: [AtomicU32; AXES] = [const { AtomicU32::new(0) }; AXES];

/// Test images only: what each axis's loop decided on the last tick and its state after it,
/// stored by [`on_tick_triad`] when `RECORD` is set.
pub static RECORDED: Mutex<RefCell<Option<Recorded>>> = Mutex::new(RefCell::new(None));

/// Each axis's tick and its state after it ([`RECORDED`]).
pub type Recorded = [(Tick, State); AXES];

/// Axis 1's legs.
type Bridge1 = HBridge<Leg<13>, Leg<15>>;
/// Axis 2's legs.
type Bridge2 = HBridge<Leg<8>, Leg<9>>;

/// Everything the triad's tick interrupt owns.
pub struct TriadContext {
    /// The three loops (one configuration each).
    pub ptsa: [Ptsa; AXES],
    /// Their states.
    pub state: [State; AXES],
    bridge0: HBridge<crate::LegA, crate::LegB>,
    bridge1: Bridge1,
    bridge2: Bridge2,
    adc1: pac::ADC1,
    adc2: pac::ADC2,
    adc3: pac::ADC3,
    timer: pac::TIM2,
}

/// The triad's peripherals, set up.
pub struct TriadBoard {
    /// The tick interrupt's context (install it in [`TRIAD`]).
    pub tick: TriadContext,
    /// The TIM5 stopwatch, as [`crate::Board::stopwatch`].
    pub stopwatch: pac::TIM5,
}

/// A port-D leg on pin `PIN`.
fn leg<const PIN: u8>() -> Leg<PIN> {
    Leg {
        port: second_gpiod_handle(),
    }
}

impl TriadBoard {
    /// Set up GPIO, the three ADCs, TIM2 (stopped) and TIM5 (running). Call
    /// [`crate::clocks_160mhz`] first on the board; nothing here waits on a flag.
    #[must_use]
    pub fn new(dp: pac::Peripherals, ptsa: [Ptsa; AXES]) -> Self {
        let rcc = &dp.RCC;
        rcc.ahb1enr()
            .modify(|_, w| w.gpioaen().enabled().gpioden().enabled());
        rcc.apb1enr()
            .modify(|_, w| w.tim2en().enabled().tim5en().enabled());
        rcc.apb2enr()
            .modify(|_, w| w.adc1en().enabled().adc2en().enabled().adc3en().enabled());
        // RM0090 errata: allow two bus cycles after enabling a peripheral clock.
        let _ = rcc.apb2enr().read();

        dp.GPIOA
            .moder()
            .modify(|_, w| w.moder1().analog().moder2().analog().moder3().analog());
        dp.GPIOD.moder().modify(|_, w| {
            w.moder8()
                .output()
                .moder9()
                .output()
                .moder12()
                .output()
                .moder13()
                .output()
                .moder14()
                .output()
                .moder15()
                .output()
        });
        let Ok(bridge0) = HBridge::new(leg::<12>(), leg::<14>());
        let Ok(bridge1) = HBridge::new(leg::<13>(), leg::<15>());
        let Ok(bridge2) = HBridge::new(leg::<8>(), leg::<9>());

        dp.ADC_COMMON.ccr().modify(|_, w| w.adcpre().div4());
        dp.ADC1.smpr2().modify(|_, w| w.smp1().cycles15());
        dp.ADC2.smpr2().modify(|_, w| w.smp2().cycles15());
        dp.ADC3.smpr2().modify(|_, w| w.smp3().cycles15());
        start_adc(&dp.ADC1, 1);
        start_adc(&dp.ADC2, 2);
        start_adc(&dp.ADC3, 3);

        let tim = dp.TIM2;
        tim.psc().write(|w| w.psc().set(0));
        tim.arr().write(|w| w.arr().set(TICK_RELOAD));
        tim.egr().write(|w| w.ug().update());
        tim.sr().write(|w| w.uif().clear_bit());
        tim.dier().write(|w| w.uie().enabled());

        let sw = dp.TIM5;
        sw.psc().write(|w| w.psc().set(0));
        sw.arr().write(|w| w.arr().set(u32::MAX));
        sw.egr().write(|w| w.ug().update());
        sw.cr1().write(|w| w.cen().enabled());

        Self {
            tick: TriadContext {
                ptsa,
                state: ptsa.map(|p| p.initial_state()),
                bridge0,
                bridge1,
                bridge2,
                adc1: dp.ADC1,
                adc2: dp.ADC2,
                adc3: dp.ADC3,
                timer: tim,
            },
            stopwatch: sw,
        }
    }
}

impl TriadContext {
    /// Start the tick timer (the interrupt fires once [`crate::unmask_tick`] has run).
    pub fn start(&self) {
        self.timer.cr1().write(|w| w.cen().enabled());
    }
}

/// Closed gates waiting for the bottom half, per axis, and the axes whose slot is full
/// (bit `k` for axis `k`). Written only by `TIM2`, read only by the bottom half (same
/// priority: neither preempts the other).
static CLOSED_PULSES: [AtomicU32; AXES] = [const { AtomicU32::new(0) }; AXES];
static CLOSED_TICKS: [AtomicU32; AXES] = [const { AtomicU32::new(0) }; AXES];
static CLOSED_MASK: AtomicU32 = AtomicU32::new(0);

/// The pickoff word as an `i16` sample, through the board's converter
/// ([`crate::constants::ADC`], the single axis's conversion).
#[allow(clippy::inline_always, reason = "tick path: inside the TIM2 handler")]
#[inline(always)]
fn sample(raw: u32) -> i16 {
    crate::constants::ADC.sample_of_word(raw)
}

/// Service one tick of the triad (the body of its `TIM2` interrupt): acknowledge the
/// timer, read the three samples, run the three loops, drive the three bridges, hand
/// closed gates to [`on_gate_triad`].
///
/// `ctx` is the handler's own `static mut`; the first interrupt moves the context in from
/// [`TRIAD`] and returns. With `INJECT` (test images) the samples come from [`INJECTED3`];
/// with `RECORD` (the golden test image only) each axis's tick and state are stored in
/// [`RECORDED`].
#[allow(
    clippy::inline_always,
    reason = "the whole tick inlined into each image's TIM2 handler"
)]
#[inline(always)]
pub fn on_tick_triad<const INJECT: bool, const RECORD: bool>(ctx: &mut Option<TriadContext>) {
    let Some(c) = ctx.as_mut() else {
        install(ctx);
        return;
    };
    c.timer.sr().write(|w| w.uif().clear_bit());
    let raw = if INJECT {
        [
            INJECTED3[0].load(Ordering::Relaxed),
            INJECTED3[1].load(Ordering::Relaxed),
            INJECTED3[2].load(Ordering::Relaxed),
        ]
    } else {
        [
            c.adc1.dr().read().bits(),
            c.adc2.dr().read().bits(),
            c.adc3.dr().read().bits(),
        ]
    };
    // A gate the bottom half has not taken yet (cannot happen: the pended bottom half runs
    // before the next tick) is queued before this tick's gates, in order: nothing is lost,
    // and the hand-overs below need not look at the slots.
    if CLOSED_MASK.load(Ordering::Relaxed) != 0 {
        queue_left_over();
    }
    // Each axis's closed gate is handed over right after its tick (fewer values kept
    // across the other axes' ticks: 14 instructions fewer on the worst tick than after all
    // three); the bottom half is pended once.
    let mut closed = 0;
    let t0 = c.ptsa[0].tick(&mut c.state[0], sample(raw[0]));
    let Ok(()) = c.bridge0.set(t0.polarity);
    if let Some(g) = t0.gate {
        closed |= hand_over(0, g);
    }
    let t1 = c.ptsa[1].tick(&mut c.state[1], sample(raw[1]));
    let Ok(()) = c.bridge1.set(t1.polarity);
    if let Some(g) = t1.gate {
        closed |= hand_over(1, g);
    }
    let t2 = c.ptsa[2].tick(&mut c.state[2], sample(raw[2]));
    let Ok(()) = c.bridge2.set(t2.polarity);
    if let Some(g) = t2.gate {
        closed |= hand_over(2, g);
    }
    if RECORD {
        let rec = [(t0, c.state[0]), (t1, c.state[1]), (t2, c.state[2])];
        critical_section::with(|cs| RECORDED.borrow(cs).replace(Some(rec)));
    }
    if closed != 0 {
        CLOSED_MASK.store(closed, Ordering::Relaxed);
        cortex_m::peripheral::NVIC::pend(GATE_IRQ);
    }
}

/// Put axis `k`'s closed gate in its slot (empty: the tick emptied every slot first);
/// returns its bit for the mask.
#[allow(clippy::inline_always, reason = "tick path: inside the TIM2 handler")]
#[inline(always)]
fn hand_over(k: usize, g: Gate) -> u32 {
    CLOSED_PULSES[k].store(g.pulses, Ordering::Relaxed);
    CLOSED_TICKS[k].store(g.ticks, Ordering::Relaxed);
    1 << k
}

/// Move axis `k`'s waiting gate into its queue and clear its bit.
#[cold]
#[inline(never)]
fn queue_waiting(k: usize) {
    let g = Gate {
        pulses: CLOSED_PULSES[k].load(Ordering::Relaxed),
        ticks: CLOSED_TICKS[k].load(Ordering::Relaxed),
    };
    CLOSED_MASK.store(
        CLOSED_MASK.load(Ordering::Relaxed) & !(1 << k),
        Ordering::Relaxed,
    );
    critical_section::with(|cs| TRIAD_GATES.borrow_ref_mut(cs)[k].push(g));
}

/// [`on_gate_triad`] from the tick, off its straight-line path.
#[cold]
#[inline(never)]
fn queue_left_over() {
    on_gate_triad();
}

/// The triad's bottom half (body of the [`GATE_IRQ`] handler): queue every waiting gate,
/// axis 0 first.
pub fn on_gate_triad() {
    let mask = CLOSED_MASK.load(Ordering::Relaxed);
    for k in 0..AXES {
        if mask & (1 << k) != 0 {
            queue_waiting(k);
        }
    }
}

/// Move the context in from [`TRIAD`].
#[cold]
#[inline(never)]
fn install(ctx: &mut Option<TriadContext>) {
    critical_section::with(|cs| {
        if let Some(c) = TRIAD.borrow_ref_mut(cs).take() {
            *ctx = Some(c);
        }
    });
}
