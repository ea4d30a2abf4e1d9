//! Test image for QEMU (`netduinoplus2`): runs one golden vector on the emulated Cortex-M4
//! and measures the tick interrupt.
//!
//! Arguments (semihosting command line): `golden <input> <output>`, paths relative to
//! QEMU's working directory.
//!
//! 1. **Bit-exactness**: streams `<input>` (a `tests/golden/*.in` file) in 1 KiB chunks
//!    through [`ptsa_core::trace::GoldenRunner`], the same code the host test uses, and
//!    writes the output text to `<output>` for the host to compare with the `.out` file.
//! 2. **Budget**: reads `<input>` again and, for every sample, pends the real `TIM2`
//!    interrupt (the production handler code with the sample injected instead of the ADC's,
//!    see [`ptsa_firmware::on_tick`]) between two reads of the TIM5 stopwatch. Under
//!    `-icount shift=0` one stopwatch count is one guest instruction, so the difference,
//!    minus the bracket's own cost (measured the same way with an empty handler), is the
//!    number of instructions of the whole interrupt handler. Prints
//!    `budget ticks=<n> max=<instructions> mean=<instructions, 2 decimals> overhead=<instructions>`.
//!
//! Exits QEMU with status 0, or 1 with a message on standard error.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use core::ffi::CStr;
use core::fmt;

use core::sync::atomic::Ordering;
use cortex_m_rt::{ExceptionFrame, entry, exception};
use ptsa_core::{Config, trace};

use ptsa_firmware::{
    Board, INJECTED, RELOAD, RESTART, TICK, TickContext, on_tick, pac, pac::interrupt, stopwatch,
    unmask,
};
use semihosting::fs::File;
use semihosting::io::{Read, Write};
use semihosting::{eprintln, println};

/// Input chunk size, bytes.
const CHUNK: usize = 1024;
/// Output buffer, bytes.
const OUT_BUF: usize = 4096;
/// Longest path accepted, bytes (with its NUL).
const PATH: usize = 256;

#[entry]
fn main() -> ! {
    match run() {
        Ok(()) => semihosting::process::exit(0),
        Err(Failure) => semihosting::process::exit(1),
    }
}

/// A failure; its message has already been printed on standard error.
struct Failure;

/// Print a message on semihosting standard error and make a [`Failure`].
macro_rules! fail {
    ($($arg:tt)*) => {{
        eprintln!("golden: {}", format_args!($($arg)*));
        Failure
    }};
}

fn run() -> Result<(), Failure> {
    let args = semihosting::experimental::env::args::<{ 2 * PATH }>()
        .map_err(|e| fail!("cannot read the command line: {:?}", e))?;
    let mut it = (&args).into_iter();
    let _program = it.next();
    let input = next_path(&mut it, "input")?;
    let output = next_path(&mut it, "output")?;

    let Some(dp) = pac::Peripherals::take() else {
        return Err(fail!("peripherals already taken"));
    };
    let ptsa = Config::DEFAULT
        .build()
        .map_err(|e| fail!("default configuration refused: {}", e))?;
    let board = Board::new(dp, ptsa);

    golden_pass(input.as_cstr(), output.as_cstr())?;

    let watch = board.stopwatch;
    critical_section::with(|cs| TICK.borrow(cs).replace(Some(board.tick)));
    unmask(pac::Interrupt::TIM2);
    unmask(pac::Interrupt::TIM3);
    budget_pass(input.as_cstr(), &watch)
}

/// A NUL-terminated path.
struct Path {
    buf: [u8; PATH],
    len: usize,
}

impl Path {
    fn as_cstr(&self) -> &CStr {
        CStr::from_bytes_with_nul(&self.buf[..=self.len]).unwrap_or(c"")
    }
}

fn next_path<'a, I>(it: &mut I, what: &str) -> Result<Path, Failure>
where
    I: Iterator<Item = Result<&'a str, core::str::Utf8Error>>,
{
    let s = it
        .next()
        .ok_or_else(|| fail!("usage: golden <input> <output> (missing {})", what))?
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
struct Out {
    file: File,
    buf: [u8; OUT_BUF],
    len: usize,
    failed: bool,
}

impl Out {
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

/// Bit-exactness: input through `GoldenRunner`, output to a file.
fn golden_pass(input: &CStr, output: &CStr) -> Result<(), Failure> {
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

/// Budget: every sample of the input through the real interrupt, counted.
fn budget_pass(input: &CStr, watch: &pac::TIM5) -> Result<(), Failure> {
    // The bracket's own cost: the same sequence around an empty handler (whose body is one
    // instruction, `bx lr`).
    let mut overhead = u32::MAX;
    for _ in 0..16 {
        let t0 = stopwatch(watch);
        cortex_m::peripheral::NVIC::pend(pac::Interrupt::TIM3);
        let t1 = stopwatch(watch);
        overhead = overhead.min(t1.wrapping_sub(t0).saturating_sub(1));
    }

    let mut inp = File::open(input).map_err(|e| fail!("cannot open {:?}: {:?}", input, e))?;
    let mut chunk = [0u8; CHUNK];
    let mut line = [0u8; trace::MAX_LINE];
    let mut len = 0usize;
    let mut stats = Stats::default();
    loop {
        let n = inp
            .read(&mut chunk)
            .map_err(|e| fail!("cannot read {:?}: {:?}", input, e))?;
        for &b in &chunk[..n] {
            if b == b'\n' {
                measure_line(&line[..len], watch, overhead, &mut stats)?;
                len = 0;
            } else if len < line.len() {
                line[len] = b;
                len += 1;
            }
        }
        if n == 0 {
            measure_line(&line[..len], watch, overhead, &mut stats)?;
            break;
        }
    }
    let mean100 = (stats.sum * 100).checked_div(stats.ticks).unwrap_or(0);
    println!(
        "budget ticks={} max={} max_plain={} max_gate={} mean={}.{:02} overhead={}",
        stats.ticks,
        stats.max,
        stats.max_plain,
        stats.max_gate,
        mean100 / 100,
        mean100 % 100,
        overhead
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
}

fn measure_line(
    line: &[u8],
    watch: &pac::TIM5,
    overhead: u32,
    stats: &mut Stats,
) -> Result<(), Failure> {
    let text = core::str::from_utf8(line)
        .map_err(|_| fail!("input is not UTF-8"))?
        .trim();
    if text.is_empty() || text.starts_with('#') {
        return Ok(());
    }
    if text.starts_with("config") {
        let c = trace::parse_config(text).map_err(|e| fail!("bad config: {:?}", e))?;
        let p = c.build().map_err(|e| fail!("config refused: {}", e))?;
        critical_section::with(|cs| RESTART.borrow(cs).set(Some(p)));
        INJECTED.store(RELOAD, Ordering::Relaxed);
        cortex_m::peripheral::NVIC::pend(pac::Interrupt::TIM2);
        return Ok(());
    }
    let x: i16 = text.parse().map_err(|_| fail!("bad sample {:?}", text))?;
    #[allow(clippy::cast_sign_loss)]
    INJECTED.store(u32::from(x as u16), Ordering::Relaxed);
    let t0 = stopwatch(watch);
    cortex_m::peripheral::NVIC::pend(pac::Interrupt::TIM2);
    let t1 = stopwatch(watch);
    let n = t1.wrapping_sub(t0).saturating_sub(overhead);
    if critical_section::with(|cs| ptsa_firmware::GATES.borrow_ref_mut(cs).pop()).is_some() {
        stats.max_gate = stats.max_gate.max(n);
    } else {
        stats.max_plain = stats.max_plain.max(n);
    }
    stats.ticks += 1;
    stats.sum += u64::from(n);
    stats.max = stats.max.max(n);
    Ok(())
}

#[interrupt]
fn TIM2() {
    static mut CONTEXT: Option<TickContext> = None;
    on_tick::<true>(CONTEXT);
}

/// The empty handler that calibrates the measurement bracket.
#[interrupt]
fn TIM3() {}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo<'_>) -> ! {
    eprintln!("golden: panic: {}", info);
    semihosting::process::exit(101)
}

// cortex-m-rt requires the HardFault handler to be an `unsafe fn`.
#[allow(unsafe_code)]
#[exception]
unsafe fn HardFault(ef: &ExceptionFrame) -> ! {
    eprintln!("golden: HardFault at pc={:#010x}", ef.pc());
    semihosting::process::exit(70)
}
