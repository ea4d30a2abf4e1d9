//! The golden-vector text format, shared by the host tests and the firmware test image.
//!
//! **Input** (`tests/golden/NAME.in`): UTF-8 lines. `#` starts a comment line; blank lines
//! are ignored. One `config` line comes before the first sample:
//!
//! ```text
//! config n=64 b0=362602752 b1=-360827191 a1=64262 ki=224131 gate=640 shaping=0
//! ```
//!
//! (`b0`, `b1`, `ki` are the raw bits of Q15.16 values, `a1` of a Q15.16 value too, `gate` the
//! preset in ticks, `shaping` 0 or 1). Every other line is one pickoff sample, a decimal
//! `i16`. A later `config` line rebuilds the loop and resets the state.
//!
//! **Output** (`tests/golden/NAME.out`): one line per sample, the decided polarity `+` or
//! `-`, then ` c<n>` when the tick closed a limit cycle with `n` data pulses, then
//! ` g<P>/<T>` when it closed a gate. After each run (before a new `config`, and at the end):
//!
//! ```text
//! end ticks=<T> pulses=<P> sat=<integrator>,<output>,<carry> digest=<16 hex digits>
//! ```
//!
//! [`GoldenRunner`] turns an input byte stream into the output text; the host test and the
//! firmware both use it, so the only thing that can differ between them is the arithmetic.

use core::fmt::{self, Write};

use heapless::Vec;

use crate::{Coef, Config, ConfigError, Pole, Ptsa, State, Tick};

/// Longest input line accepted, in bytes.
pub const MAX_LINE: usize = 160;

/// What went wrong in an input stream, and on which line (1-based).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TraceError {
    /// 1-based line number.
    pub line: u32,
    /// What was wrong.
    pub kind: TraceErrorKind,
}

/// Kinds of [`TraceError`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TraceErrorKind {
    /// Not a decimal integer in `-32768..=32767`.
    BadSample,
    /// A sample before any `config` line.
    NoConfig,
    /// A `config` key is unknown, missing, repeated or has a bad value.
    BadConfig,
    /// The configuration parsed but was refused.
    Refused(ConfigError),
    /// Line longer than [`MAX_LINE`].
    LineTooLong,
    /// Not UTF-8.
    NotUtf8,
    /// The output sink failed.
    Write,
}

impl fmt::Display for TraceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: ", self.line)?;
        match self.kind {
            TraceErrorKind::BadSample => {
                f.write_str("expected a pickoff sample, a decimal integer in -32768..=32767")
            }
            TraceErrorKind::NoConfig => f.write_str("sample before the first `config` line"),
            TraceErrorKind::BadConfig => f.write_str(
                "expected `config n=<N> b0=<i32> b1=<i32> a1=<i32> ki=<i32> gate=<u32> shaping=<0|1>`",
            ),
            TraceErrorKind::Refused(e) => write!(f, "configuration refused: {e}"),
            TraceErrorKind::LineTooLong => write!(f, "line longer than {MAX_LINE} bytes"),
            TraceErrorKind::NotUtf8 => f.write_str("not UTF-8"),
            TraceErrorKind::Write => f.write_str("could not write the output"),
        }
    }
}

impl core::error::Error for TraceError {}

/// Parse a `config ...` line (without its line terminator).
///
/// ```
/// use ptsa_core::{trace, Config};
/// let mut line = heapless::String::<160>::new();
/// trace::write_config(&mut line, &Config::DEFAULT).unwrap();
/// assert_eq!(trace::parse_config(&line), Ok(Config::DEFAULT));
/// assert!(trace::parse_config("config n=64").is_err());
/// ```
///
/// # Errors
/// [`TraceErrorKind::BadConfig`] when a key is unknown, repeated or missing, or a value does
/// not parse.
pub fn parse_config(line: &str) -> Result<Config, TraceErrorKind> {
    let mut words = line.split_ascii_whitespace();
    if words.next() != Some("config") {
        return Err(TraceErrorKind::BadConfig);
    }
    let mut seen = [false; 7];
    let mut c = Config::DEFAULT;
    for w in words {
        let (key, value) = w.split_once('=').ok_or(TraceErrorKind::BadConfig)?;
        let bad = |_| TraceErrorKind::BadConfig;
        let slot = match key {
            "n" => {
                c.ticks_per_cycle = value.parse().map_err(bad)?;
                0
            }
            "b0" => {
                c.b0 = Coef::from_bits(value.parse().map_err(bad)?);
                1
            }
            "b1" => {
                c.b1 = Coef::from_bits(value.parse().map_err(bad)?);
                2
            }
            "a1" => {
                c.a1 = Pole::from_bits(value.parse().map_err(bad)?);
                3
            }
            "ki" => {
                c.ki = Coef::from_bits(value.parse().map_err(bad)?);
                4
            }
            "gate" => {
                c.gate_ticks = value.parse().map_err(bad)?;
                5
            }
            "shaping" => {
                c.noise_shaping = match value {
                    "0" => false,
                    "1" => true,
                    _ => return Err(TraceErrorKind::BadConfig),
                };
                6
            }
            _ => return Err(TraceErrorKind::BadConfig),
        };
        if core::mem::replace(&mut seen[slot], true) {
            return Err(TraceErrorKind::BadConfig);
        }
    }
    if seen.iter().all(|&s| s) {
        Ok(c)
    } else {
        Err(TraceErrorKind::BadConfig)
    }
}

/// Write the `config ...` line for `c` (no line terminator).
///
/// # Errors
/// Those of the sink.
pub fn write_config<W: Write>(w: &mut W, c: &Config) -> fmt::Result {
    write!(
        w,
        "config n={} b0={} b1={} a1={} ki={} gate={} shaping={}",
        c.ticks_per_cycle,
        c.b0.to_bits(),
        c.b1.to_bits(),
        c.a1.to_bits(),
        c.ki.to_bits(),
        c.gate_ticks,
        u8::from(c.noise_shaping)
    )
}

/// Write one tick's output line, with its `\n`.
///
/// ```
/// use ptsa_core::{trace, Gate, Polarity, Tick};
/// let mut s = heapless::String::<32>::new();
/// let t = Tick { polarity: Polarity::Negative, cycle_pulses: Some(32),
///                gate: Some(Gate { pulses: 320, ticks: 640 }) };
/// trace::write_tick(&mut s, &t).unwrap();
/// assert_eq!(s, "- c32 g320/640\n");
/// ```
///
/// # Errors
/// Those of the sink.
pub fn write_tick<W: Write>(w: &mut W, t: &Tick) -> fmt::Result {
    w.write_char(match t.polarity {
        crate::Polarity::Positive => '+',
        crate::Polarity::Negative => '-',
    })?;
    if let Some(n) = t.cycle_pulses {
        write!(w, " c{n}")?;
    }
    if let Some(g) = t.gate {
        write!(w, " g{}/{}", g.pulses, g.ticks)?;
    }
    w.write_char('\n')
}

/// Write the `end ...` summary line of a run, with its `\n`.
///
/// # Errors
/// Those of the sink.
pub fn write_end<W: Write>(w: &mut W, s: &State) -> fmt::Result {
    let sat = s.saturations();
    writeln!(
        w,
        "end ticks={} pulses={} sat={},{},{} digest={:016x}",
        s.total_ticks(),
        s.total_pulses(),
        sat.integrator,
        sat.output,
        sat.carry,
        s.digest()
    )
}

/// Streams a golden input through the loop and writes the golden output.
///
/// ```
/// use ptsa_core::trace::GoldenRunner;
/// let input = b"# two ticks\nconfig n=2 b0=0 b1=0 a1=0 ki=0 gate=2 shaping=0\n0\n0\n";
/// let mut out = String::new();
/// let mut r = GoldenRunner::new();
/// r.feed(input, &mut out).unwrap();
/// r.finish(&mut out).unwrap();
/// assert_eq!(out.lines().take(2).collect::<Vec<_>>(), ["+", "- c1 g1/2"]);
/// assert!(out.lines().nth(2).unwrap().starts_with("end ticks=2 pulses=1 "));
/// ```
#[derive(Debug, Default)]
pub struct GoldenRunner {
    run: Option<(Ptsa, State)>,
    line: Vec<u8, MAX_LINE>,
    overlong: bool,
    line_no: u32,
}

impl GoldenRunner {
    /// A runner that has seen nothing yet.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Feed the next bytes of the input (any split into chunks gives the same output).
    ///
    /// # Errors
    /// The first malformed line, with its number.
    pub fn feed<W: Write>(&mut self, bytes: &[u8], out: &mut W) -> Result<(), TraceError> {
        for &b in bytes {
            if b == b'\n' {
                self.end_line(out)?;
            } else if self.line.push(b).is_err() {
                self.overlong = true;
            }
        }
        Ok(())
    }

    /// Process a last line without terminator and write the final `end` line.
    ///
    /// # Errors
    /// As [`GoldenRunner::feed`].
    pub fn finish<W: Write>(&mut self, out: &mut W) -> Result<(), TraceError> {
        if !self.line.is_empty() || self.overlong {
            self.end_line(out)?;
        }
        self.close_run(out)
    }

    /// The loop state of the current run, if one has started.
    #[must_use]
    pub fn state(&self) -> Option<&State> {
        self.run.as_ref().map(|(_, s)| s)
    }

    fn close_run<W: Write>(&mut self, out: &mut W) -> Result<(), TraceError> {
        if let Some((_, s)) = self.run.take() {
            write_end(out, &s).map_err(|_| self.err(TraceErrorKind::Write))?;
        }
        Ok(())
    }

    fn err(&self, kind: TraceErrorKind) -> TraceError {
        TraceError {
            line: self.line_no,
            kind,
        }
    }

    fn end_line<W: Write>(&mut self, out: &mut W) -> Result<(), TraceError> {
        self.line_no += 1;
        let overlong = core::mem::take(&mut self.overlong);
        let bytes = core::mem::take(&mut self.line);
        if overlong {
            return Err(self.err(TraceErrorKind::LineTooLong));
        }
        let text = core::str::from_utf8(&bytes).map_err(|_| self.err(TraceErrorKind::NotUtf8))?;
        let text = text.trim();
        if text.is_empty() || text.starts_with('#') {
            return Ok(());
        }
        if text.starts_with("config") {
            let c = parse_config(text).map_err(|k| self.err(k))?;
            let p = c
                .build()
                .map_err(|e| self.err(TraceErrorKind::Refused(e)))?;
            self.close_run(out)?;
            self.run = Some((p, p.initial_state()));
            return Ok(());
        }
        let x: i16 = text
            .parse()
            .map_err(|_| self.err(TraceErrorKind::BadSample))?;
        let line_no = self.line_no;
        let (p, s) = self.run.as_mut().ok_or(TraceError {
            line: line_no,
            kind: TraceErrorKind::NoConfig,
        })?;
        let t = p.tick(s, x);
        write_tick(out, &t).map_err(|_| self.err(TraceErrorKind::Write))
    }
}
