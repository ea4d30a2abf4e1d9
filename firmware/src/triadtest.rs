//! Helpers of the triad's QEMU test images (`triad_golden`, `triad_budget`): three golden
//! vectors streamed side by side, one per axis, through the triad's real `TIM2` interrupt
//! ([`crate::triad::on_tick_triad`]). Linked only into those images.
//!
//! Each axis takes the first run (up to its second `config` line, if any) of its vector;
//! an axis whose vector has ended is fed 0 and its output no longer written, until all
//! three have ended.

use core::ffi::CStr;
use core::sync::atomic::Ordering;

use ptsa_core::{State, trace};
use semihosting::fs::File;
use semihosting::io::Read;
use semihosting::{eprintln, println};

use crate::testimage::{Failure, Out};
use crate::triad::{AXES, INJECTED3, RECORDED, TRIAD_GATES};
use crate::{GATE_IRQ, pac, stopwatch, unmask};

/// Input chunk size, bytes.
const CHUNK: usize = 512;

/// Print a message and make a [`Failure`].
fn fail(args: core::fmt::Arguments<'_>) -> Failure {
    eprintln!("triad test image: {}", args);
    Failure
}

/// The samples of a golden vector's first run, one at a time.
pub struct Samples {
    file: File,
    chunk: [u8; CHUNK],
    pos: usize,
    len: usize,
    configs: usize,
    done: bool,
}

impl Samples {
    /// Open `path`.
    ///
    /// # Errors
    /// It cannot be opened (message printed).
    pub fn open(path: &CStr) -> Result<Self, Failure> {
        let file =
            File::open(path).map_err(|e| fail(format_args!("cannot open {path:?}: {e:?}")))?;
        Ok(Self {
            file,
            chunk: [0; CHUNK],
            pos: 0,
            len: 0,
            configs: 0,
            done: false,
        })
    }

    /// The next byte, `None` at the end of the file.
    fn byte(&mut self) -> Result<Option<u8>, Failure> {
        if self.pos == self.len {
            self.len = self
                .file
                .read(&mut self.chunk)
                .map_err(|e| fail(format_args!("cannot read: {e:?}")))?;
            self.pos = 0;
            if self.len == 0 {
                return Ok(None);
            }
        }
        self.pos += 1;
        Ok(Some(self.chunk[self.pos - 1]))
    }

    /// The next sample of the first run, `None` after it.
    ///
    /// # Errors
    /// A line too long, not UTF-8 or not a sample (message printed).
    pub fn next_sample(&mut self) -> Result<Option<i16>, Failure> {
        let mut line = [0u8; trace::MAX_LINE];
        while !self.done {
            let mut len = 0;
            let mut end = false;
            loop {
                match self.byte()? {
                    None => {
                        end = true;
                        break;
                    }
                    Some(b'\n') => break,
                    Some(b) if len < line.len() => {
                        line[len] = b;
                        len += 1;
                    }
                    Some(_) => return Err(fail(format_args!("input line too long"))),
                }
            }
            let text = core::str::from_utf8(&line[..len])
                .map_err(|_| fail(format_args!("input is not UTF-8")))?
                .trim();
            if end {
                self.done = true;
            }
            if text.is_empty() || text.starts_with('#') {
                continue;
            }
            if text.starts_with("config") {
                self.configs += 1;
                if self.configs > 1 {
                    self.done = true;
                }
                continue;
            }
            return text
                .parse()
                .map(Some)
                .map_err(|_| fail(format_args!("bad sample {text:?}")));
        }
        Ok(None)
    }
}

/// The next samples of the three axes (0 for an axis whose run has ended), and which axes
/// still run (bit `k` for axis `k`); stores the samples where the handler reads them.
fn next_samples(inputs: &mut [Samples; AXES], running: &mut u32) -> Result<(), Failure> {
    for (k, s) in inputs.iter_mut().enumerate() {
        let x = if *running & (1 << k) != 0 {
            s.next_sample()?.unwrap_or_else(|| {
                *running &= !(1 << k);
                0
            })
        } else {
            0
        };
        #[allow(clippy::cast_sign_loss)]
        INJECTED3[k].store(u32::from(x as u16 ^ 0x8000), Ordering::Relaxed);
    }
    Ok(())
}

/// Bit-exactness of the three axes: each axis's ticks written to its output file in the
/// golden format (`trace::write_tick` per sample, `trace::write_end` after its run), to be
/// compared with the first run of its vector's `.out`. The interrupt's context must be
/// installed in [`crate::triad::TRIAD`] and `TIM2` unmasked; the image's handler records
/// (`RECORD = true`).
///
/// # Errors
/// On any I/O or parse error (message printed).
pub fn triad_golden_pass(inputs: [&CStr; AXES], outputs: [&CStr; AXES]) -> Result<(), Failure> {
    let mut samples = [
        Samples::open(inputs[0])?,
        Samples::open(inputs[1])?,
        Samples::open(inputs[2])?,
    ];
    let mut outs = [
        Out::create(outputs[0])?,
        Out::create(outputs[1])?,
        Out::create(outputs[2])?,
    ];
    // The first interrupt moves the context into the handler and returns without a tick.
    cortex_m::peripheral::NVIC::pend(pac::Interrupt::TIM2);
    // Each axis's state after its latest tick, for its `end` line.
    let mut last: [Option<State>; AXES] = [None; AXES];
    let mut running = 0b111;
    loop {
        let before = running;
        next_samples(&mut samples, &mut running)?;
        for (k, out) in outs.iter_mut().enumerate() {
            if (before & !running) & (1 << k) != 0 {
                let Some(state) = &last[k] else {
                    return Err(fail(format_args!("axis {k}'s vector has no samples")));
                };
                trace::write_end(out, state)
                    .map_err(|_| fail(format_args!("cannot write axis {k}'s output")))?;
            }
        }
        if running == 0 {
            break;
        }
        cortex_m::peripheral::NVIC::pend(pac::Interrupt::TIM2);
        let Some(rec) = critical_section::with(|cs| RECORDED.borrow(cs).take()) else {
            return Err(fail(format_args!("the tick handler recorded nothing")));
        };
        for (k, (out, (tick, state))) in outs.iter_mut().zip(rec).enumerate() {
            if running & (1 << k) != 0 {
                trace::write_tick(out, &tick)
                    .map_err(|_| fail(format_args!("cannot write axis {k}'s output")))?;
                last[k] = Some(state);
            }
        }
    }
    for (k, o) in outs.iter_mut().enumerate() {
        if !o.finish() {
            return Err(fail(format_args!("cannot write axis {k}'s output")));
        }
    }
    Ok(())
}

/// Instructions per tick of the triad's handler over three vectors, as
/// `crate::testimage::budget_pass` measures the single axis: prints the same `budget …`
/// line (`section=0`). `TIM2` and `TIM3` unmasked, `EXTI0` masked; the handler does not
/// record (`RECORD = false`).
///
/// # Errors
/// On any I/O or parse error (message printed).
pub fn triad_budget_pass(inputs: [&CStr; AXES], watch: &pac::TIM5) -> Result<(), Failure> {
    let mut samples = [
        Samples::open(inputs[0])?,
        Samples::open(inputs[1])?,
        Samples::open(inputs[2])?,
    ];
    cortex_m::peripheral::NVIC::pend(pac::Interrupt::TIM2);
    let mut overhead = u32::MAX;
    for _ in 0..16 {
        let t0 = stopwatch(watch);
        cortex_m::peripheral::NVIC::pend(pac::Interrupt::TIM3);
        let t1 = stopwatch(watch);
        overhead = overhead.min(t1.wrapping_sub(t0).saturating_sub(1));
    }
    let c0 = stopwatch(watch);
    cortex_m::asm::delay(10_000);
    let calibration = stopwatch(watch).wrapping_sub(c0);
    let (mut ticks, mut sum) = (0u64, 0u64);
    let (mut max, mut max_plain, mut max_gate, mut max_bottom) = (0u32, 0u32, 0u32, 0u32);
    let mut running = 0b111;
    loop {
        next_samples(&mut samples, &mut running)?;
        if running == 0 {
            break;
        }
        let t0 = stopwatch(watch);
        cortex_m::peripheral::NVIC::pend(pac::Interrupt::TIM2);
        let t1 = stopwatch(watch);
        let n = t1.wrapping_sub(t0).saturating_sub(overhead);
        if cortex_m::peripheral::NVIC::is_pending(GATE_IRQ) {
            let t2 = stopwatch(watch);
            unmask(GATE_IRQ);
            let t3 = stopwatch(watch);
            cortex_m::peripheral::NVIC::mask(GATE_IRQ);
            max_gate = max_gate.max(n);
            max_bottom = max_bottom.max(t3.wrapping_sub(t2).saturating_sub(overhead));
            critical_section::with(|cs| {
                for q in TRIAD_GATES.borrow_ref_mut(cs).iter_mut() {
                    q.pop();
                }
            });
        } else {
            max_plain = max_plain.max(n);
        }
        ticks += 1;
        sum += u64::from(n);
        max = max.max(n);
    }
    let mean100 = (sum * 100).checked_div(ticks).unwrap_or(0);
    println!(
        "budget section=0 ticks={} max={} max_plain={} max_gate={} bottom_half={} mean={}.{:02} overhead={} calibration={}",
        ticks,
        max,
        max_plain,
        max_gate,
        max_bottom,
        mean100 / 100,
        mean100 % 100,
        overhead,
        calibration
    );
    Ok(())
}
