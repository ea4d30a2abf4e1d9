//! Helpers of the QEMU test images (`golden`, `budget`): semihosting arguments and files,
//! the golden pass and the instruction-count pass. Linked only into those images.

use core::ffi::CStr;
use core::fmt;
use core::sync::atomic::Ordering;

use ptsa_core::{Ptsa, trace};
use semihosting::fs::File;
use semihosting::io::{Read, Write};
use semihosting::{eprintln, println};

use crate::{GATE_IRQ, INJECTED, pac, stopwatch, unmask};

/// Input chunk size, bytes.
const CHUNK: usize = 1024;
/// Output buffer, bytes.
const OUT_BUF: usize = 4096;
/// Longest path accepted, bytes (with its NUL).
pub const PATH: usize = 256;

/// A failure; its message has already been printed on standard error.
pub struct Failure;

/// Print a message on semihosting standard error and make a [`Failure`].
macro_rules! fail {
    ($($arg:tt)*) => {{
        eprintln!("test image: {}", format_args!($($arg)*));
        Failure
    }};
}

/// A NUL-terminated path.
pub struct Path {
    buf: [u8; PATH],
    len: usize,
}

impl Path {
    /// The path as a C string.
    #[must_use]
    pub fn as_cstr(&self) -> &CStr {
        CStr::from_bytes_with_nul(&self.buf[..=self.len]).unwrap_or(c"")
    }
}

/// The next command-line argument as a path.
///
/// # Errors
/// When it is missing or malformed (message printed).
pub fn next_path<'a, I>(it: &mut I, what: &str) -> Result<Path, Failure>
where
    I: Iterator<Item = Result<&'a str, core::str::Utf8Error>>,
{
    let s = it
        .next()
        .ok_or_else(|| fail!("missing the {} path argument", what))?
        .map_err(|_| fail!("{} path is not UTF-8", what))?;
    let mut p = Path {
        buf: [0; PATH],
        len: s.len(),
    };
    if s.len() >= PATH || s.bytes().any(|b| b == 0) {
        return Err(fail!("{} path too long or malformed", what));
    }
    p.buf[..s.len()].copy_from_slice(s.as_bytes());
    Ok(p)
}

/// Buffered semihosting file as a `fmt::Write` sink.
pub(crate) struct Out {
    file: File,
    buf: [u8; OUT_BUF],
    len: usize,
    failed: bool,
}

impl Out {
    /// Create the file `path` (also for the triad's test image, `triadtest`).
    pub(crate) fn create(path: &CStr) -> Result<Self, Failure> {
        let file = File::create(path).map_err(|e| fail!("cannot create {:?}: {:?}", path, e))?;
        Ok(Self {
            file,
            buf: [0; OUT_BUF],
            len: 0,
            failed: false,
        })
    }

    /// Write out what is buffered; whether every write succeeded.
    pub(crate) fn finish(&mut self) -> bool {
        self.flush();
        !self.failed
    }

    fn flush(&mut self) {
        if self.len > 0 && self.file.write_all(&self.buf[..self.len]).is_err() {
            self.failed = true;
        }
        self.len = 0;
    }
}

impl fmt::Write for Out {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        for chunk in s.as_bytes().chunks(OUT_BUF) {
            if self.len + chunk.len() > OUT_BUF {
                self.flush();
            }
            self.buf[self.len..self.len + chunk.len()].copy_from_slice(chunk);
            self.len += chunk.len();
        }
        if self.failed { Err(fmt::Error) } else { Ok(()) }
    }
}

/// Bit-exactness: `input` through [`trace::GoldenRunner`], output to the file `output`.
///
/// # Errors
/// On any I/O or trace error (message printed).
pub fn golden_pass(input: &CStr, output: &CStr) -> Result<(), Failure> {
    let mut inp = File::open(input).map_err(|e| fail!("cannot open {:?}: {:?}", input, e))?;
    let file = File::create(output).map_err(|e| fail!("cannot create {:?}: {:?}", output, e))?;
    let mut out = Out {
        file,
        buf: [0; OUT_BUF],
        len: 0,
        failed: false,
    };
    let mut runner = trace::GoldenRunner::new();
    let mut chunk = [0u8; CHUNK];
    loop {
        let n = inp
            .read(&mut chunk)
            .map_err(|e| fail!("cannot read {:?}: {:?}", input, e))?;
        if n == 0 {
            break;
        }
        runner
            .feed(&chunk[..n], &mut out)
            .map_err(|e| fail!("{:?}: {}", input, e))?;
    }
    runner
        .finish(&mut out)
        .map_err(|e| fail!("{:?}: {}", input, e))?;
    out.flush();
    if out.failed {
        return Err(fail!("cannot write {:?}", output));
    }
    Ok(())
}

/// Calls `f` with every line of `input` (without its `\n`), in order; stops early when `f`
/// returns `Ok(false)`.
///
/// # Errors
/// The file cannot be opened or read, is not UTF-8, has a line longer than
/// [`trace::MAX_LINE`], or `f` fails (message printed).
pub fn for_each_line(
    input: &CStr,
    mut f: impl FnMut(&str) -> Result<bool, Failure>,
) -> Result<(), Failure> {
    let mut inp = File::open(input).map_err(|e| fail!("cannot open {:?}: {:?}", input, e))?;
    let mut chunk = [0u8; CHUNK];
    let mut line = [0u8; trace::MAX_LINE];
    let mut len = 0usize;
    loop {
        let n = inp
            .read(&mut chunk)
            .map_err(|e| fail!("cannot read {:?}: {:?}", input, e))?;
        for &b in &chunk[..n] {
            if b == b'\n' {
                let text =
                    core::str::from_utf8(&line[..len]).map_err(|_| fail!("input is not UTF-8"))?;
                if !f(text)? {
                    return Ok(());
                }
                len = 0;
            } else if len < line.len() {
                line[len] = b;
                len += 1;
            } else {
                return Err(fail!("input line longer than {} bytes", trace::MAX_LINE));
            }
        }
        if n == 0 {
            let text =
                core::str::from_utf8(&line[..len]).map_err(|_| fail!("input is not UTF-8"))?;
            f(text)?;
            return Ok(());
        }
    }
}

/// The loop configured by the `section`-th (0-based) `config` line of `input`.
///
/// # Errors
/// When there is no such line or it is malformed or refused (message printed).
pub fn section_config(input: &CStr, section: usize) -> Result<Ptsa, Failure> {
    let mut seen = 0usize;
    let mut found = None;
    for_each_line(input, |text| {
        let text = text.trim();
        if text.starts_with("config") {
            if seen == section {
                let c = trace::parse_config(text).map_err(|e| fail!("bad config: {:?}", e))?;
                found = Some(c.build().map_err(|e| fail!("config refused: {}", e))?);
                return Ok(false);
            }
            seen += 1;
        }
        Ok(true)
    })?;
    found.ok_or_else(|| fail!("no config line number {} in {:?}", section, input))
}

/// Budget: every sample of the `section`-th run of `input` through the real `TIM2`
/// interrupt, counted with the stopwatch `watch`; prints the `budget ...` line. The
/// interrupt's context must have been installed in [`crate::TICK`] with that run's
/// configuration, and `TIM2` and `TIM3` unmasked, `EXTI0` masked.
///
/// # Errors
/// On any I/O or parse error (message printed).
pub fn budget_pass(input: &CStr, section: usize, watch: &pac::TIM5) -> Result<(), Failure> {
    // The first interrupt moves the context into the handler and returns without a tick.
    cortex_m::peripheral::NVIC::pend(pac::Interrupt::TIM2);
    // The bracket's own cost: the same sequence around an empty handler (whose body is one
    // instruction, `bx lr`).
    let mut overhead = u32::MAX;
    for _ in 0..16 {
        let t0 = stopwatch(watch);
        cortex_m::peripheral::NVIC::pend(pac::Interrupt::TIM3);
        let t1 = stopwatch(watch);
        overhead = overhead.min(t1.wrapping_sub(t0).saturating_sub(1));
    }
    // The stopwatch must count guest instructions (`-icount shift=0`, 1 GHz timers):
    // `delay(10_000)` is 10 001 iterations of `subs; bne`, 20 002 instructions, plus a few
    // for the call and alignment. The host checks this figure.
    let c0 = stopwatch(watch);
    cortex_m::asm::delay(10_000);
    let calibration = stopwatch(watch).wrapping_sub(c0);
    let mut stats = Stats::default();
    let mut configs = 0usize;
    for_each_line(input, |text| {
        let text = text.trim();
        if text.is_empty() || text.starts_with('#') {
            return Ok(true);
        }
        if text.starts_with("config") {
            configs += 1;
            // Stop at the end of the wanted run.
            return Ok(configs <= section + 1);
        }
        if configs == section + 1 {
            let x: i16 = text.parse().map_err(|_| fail!("bad sample {:?}", text))?;
            measure_tick(x, watch, overhead, &mut stats);
        }
        Ok(true)
    })?;
    let mean100 = (stats.sum * 100).checked_div(stats.ticks).unwrap_or(0);
    println!(
        "budget section={} ticks={} max={} max_plain={} max_gate={} bottom_half={} mean={}.{:02} overhead={} calibration={}",
        section,
        stats.ticks,
        stats.max,
        stats.max_plain,
        stats.max_gate,
        stats.max_bottom,
        mean100 / 100,
        mean100 % 100,
        overhead,
        calibration
    );
    Ok(())
}

#[derive(Default)]
struct Stats {
    ticks: u64,
    sum: u64,
    max: u32,
    max_gate: u32,
    max_plain: u32,
    max_bottom: u32,
}

fn measure_tick(x: i16, watch: &pac::TIM5, overhead: u32, stats: &mut Stats) {
    // The word the ADC would deliver: left-aligned offset binary.
    #[allow(clippy::cast_sign_loss)]
    INJECTED.store(u32::from(x as u16 ^ 0x8000), Ordering::Relaxed);
    let t0 = stopwatch(watch);
    cortex_m::peripheral::NVIC::pend(pac::Interrupt::TIM2);
    let t1 = stopwatch(watch);
    let n = t1.wrapping_sub(t0).saturating_sub(overhead);
    if cortex_m::peripheral::NVIC::is_pending(GATE_IRQ) {
        // A gate closed: run the bottom half now, counted on its own (the bracket includes
        // the unmask call, so this figure is an upper bound).
        let t2 = stopwatch(watch);
        unmask(GATE_IRQ);
        let t3 = stopwatch(watch);
        cortex_m::peripheral::NVIC::mask(GATE_IRQ);
        stats.max_gate = stats.max_gate.max(n);
        stats.max_bottom = stats
            .max_bottom
            .max(t3.wrapping_sub(t2).saturating_sub(overhead));
        critical_section::with(|cs| crate::GATES.borrow_ref_mut(cs).pop());
    } else {
        stats.max_plain = stats.max_plain.max(n);
    }
    stats.ticks += 1;
    stats.sum += u64::from(n);
    stats.max = stats.max.max(n);
}
