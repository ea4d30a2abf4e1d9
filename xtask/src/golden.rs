//! Golden vectors: `cargo xtask golden [--overwrite | --c-twin]`.
//!
//! Every case is an input stream made here by deterministic code (integer arithmetic and a
//! seeded xorshift generator, so it is the same on every machine) and written to
//! `tests/golden/<case>.in`. The expected output `tests/golden/<case>.out` is what
//! `ptsa_core::trace::GoldenRunner` produces for it. Without `--overwrite` this command
//! regenerates both in memory and fails on any difference from the files; with
//! `--overwrite` it re-records them. The test `ptsa-tests/golden` checks the files on every
//! `cargo test`, and the firmware runs the same inputs on the emulated Cortex-M4.

use std::fmt::Write as _;
use std::fs;

use ptsa_core::trace::{self, GoldenRunner};
use ptsa_core::{Coef, Config, Polarity, Pole};

use crate::needs::{self, Need};
use crate::util::{self, Error};

/// `cargo xtask golden --help`.
pub const USAGE: &str = "\
golden [--overwrite | --c-twin]
    Regenerate every golden vector in memory (inputs from deterministic generators,
    outputs from ptsa-core) and fail if tests/golden/*.in or *.out differ from it.
    --overwrite  re-record tests/golden/* instead (after an intended change), including
                 the host closed-loop vector the simulator records
    --c-twin     instead build the C twin (ptsa-core/c-twin, written from ARITHMETIC.md)
                 with $CC (default cc) into cargo's target directory and check it against
                 every vector; if that compiler is missing, say how to install one and
                 stop (xtask installs nothing)";

/// One golden case: a name, a description, and its input text.
struct Case {
    name: &'static str,
    about: &'static str,
    config: Config,
    samples: Vec<i16>,
}

/// Cycles' worth of ticks at the default 64 ticks per cycle.
const fn cycles(n: usize) -> usize {
    n * 64
}

/// Gate of ten limit cycles, so the short cases close several gates.
const GATE: u32 = 640;

fn base() -> Config {
    Config {
        gate_ticks: GATE,
        ..Config::DEFAULT
    }
}

/// Deterministic xorshift64* generator.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn i16(&mut self) -> i16 {
        // The top 16 bits, as two's complement.
        let [.., hi, top] = self.next().to_le_bytes();
        i16::from_le_bytes([hi, top])
    }
    /// Sum of four uniform draws in `±span`: a bell-shaped integer noise.
    fn bell(&mut self, span: i32) -> i32 {
        (0..4)
            .map(|_| (self.next() >> 33) as i32 % (2 * span + 1) - span)
            .sum::<i32>()
            / 2
    }
}

fn constant(v: i16, n: usize) -> Vec<i16> {
    vec![v; n]
}

fn square(period: usize, amp: i16, n: usize) -> Vec<i16> {
    (0..n)
        .map(|i| {
            if (2 * i / period).is_multiple_of(2) {
                amp
            } else {
                -amp
            }
        })
        .collect()
}

/// Closed loop around a toy integrating pendulum (integer model): each tick the pickoff
/// angle, in 2^-16 LSB, moves by `accel - sign(polarity)·STEP`, where STEP is the full-torque
/// rate of the Kearfott 2401 at the default pickoff scale (63.5 LSB per tick). Returns the
/// pickoff samples the loop saw. `accel_at(tick)` is in units of full scale × 2^16 (Q16).
fn toy_loop(config: Config, n: usize, accel_at: impl Fn(usize) -> i64) -> Vec<i16> {
    const STEP: i64 = 4_161_536; // 63.5 · 2^16
    let ptsa = config.build().expect("golden configuration is valid");
    let mut s = ptsa.initial_state();
    let mut theta: i64 = 0;
    let mut polarity = Polarity::Positive;
    let mut out = Vec::with_capacity(n);
    for t in 0..n {
        theta += accel_at(t) * STEP / 65_536 - i64::from(polarity.sign()) * STEP;
        let x = i16::try_from(theta >> 16).unwrap_or(if theta < 0 { i16::MIN } else { i16::MAX });
        out.push(x);
        polarity = ptsa.tick(&mut s, x).polarity;
    }
    out
}

fn case(name: &'static str, about: &'static str, config: Config, samples: Vec<i16>) -> Case {
    Case {
        name,
        about,
        config,
        samples,
    }
}

/// The low 16 bits of `x` as an `i16` (two's complement wrap-around, as the recorded
/// vectors were made).
fn low_16_bits(x: i32) -> i16 {
    let [lo, hi, ..] = x.to_le_bytes();
    i16::from_le_bytes([lo, hi])
}

/// Every case, in order. The generator `rng` is drawn from in this order too.
fn cases() -> Vec<Case> {
    let mut rng = Rng(0x9497_4688_36e9_f7ca);
    let mut v = open_loop_cases();
    v.extend(noise_cases(&mut rng));
    v.extend(closed_loop_cases());
    v.push(short_cycle_case(&mut rng));
    v
}

/// Constants, steps, a ramp and square waves, in open loop.
fn open_loop_cases() -> Vec<Case> {
    let steps: Vec<i16> = [0i16, 1500, -1500, 200, -32768, 0]
        .iter()
        .flat_map(|&x| constant(x, cycles(8) + 13))
        .collect();
    let n: i32 = 1 << 14;
    let ramp: Vec<i16> = (0..n)
        .map(|i| i16::try_from(i * 65_535 / (n - 1) - 32_768).expect("the i16 range"))
        .collect();
    vec![
        case(
            "zero",
            "null pickoff: crossing at mid-cycle, 32 of 64",
            base(),
            constant(0, cycles(40)),
        ),
        case(
            "small_pos",
            "constant +25 LSB (open loop: the integrator ramps, the duty creeps up)",
            base(),
            constant(25, cycles(128)),
        ),
        case(
            "small_neg",
            "constant -25 LSB",
            base(),
            constant(-25, cycles(128)),
        ),
        case(
            "full_scale_pos",
            "constant +32767 LSB: beyond full scale, saturation",
            base(),
            constant(i16::MAX, cycles(20)),
        ),
        case(
            "full_scale_neg",
            "constant -32768 LSB: beyond full scale, saturation",
            base(),
            constant(i16::MIN, cycles(20)),
        ),
        case(
            "steps",
            "steps of several sizes, not aligned to cycles",
            base(),
            steps,
        ),
        case(
            "slow_ramp",
            "slow ramp across the whole i16 range",
            base(),
            ramp,
        ),
        case(
            "square_64",
            "square wave at the limit-cycle frequency (64 ticks)",
            base(),
            square(64, 1000, cycles(32)),
        ),
        case(
            "square_62",
            "square wave just above the limit-cycle frequency",
            base(),
            square(62, 1000, cycles(32)),
        ),
        case(
            "square_66",
            "square wave just below the limit-cycle frequency",
            base(),
            square(66, 1000, cycles(32)),
        ),
        case(
            "square_128",
            "square wave at half the limit-cycle frequency",
            base(),
            square(128, 1000, cycles(32)),
        ),
        case(
            "square_192",
            "square wave at a third of the limit-cycle frequency",
            base(),
            square(192, 1000, cycles(32)),
        ),
        case(
            "square_32",
            "square wave at twice the limit-cycle frequency",
            base(),
            square(32, 1000, cycles(32)),
        ),
    ]
}

/// Pseudo-random pickoff noise, uniform and bell-shaped.
fn noise_cases(rng: &mut Rng) -> Vec<Case> {
    let uniform: Vec<i16> = (0..cycles(64)).map(|_| rng.i16()).collect();
    let bell: Vec<i16> = (0..cycles(64))
        .map(|_| i16::try_from(rng.bell(800)).expect("|bell(800)| <= 1600"))
        .collect();
    vec![
        case(
            "noise_full",
            "uniform pseudo-random i16 (seeded xorshift64*)",
            base(),
            uniform,
        ),
        case(
            "noise_small",
            "bell-shaped pseudo-random noise of about ±800 LSB",
            base(),
            bell,
        ),
    ]
}

/// The toy pendulum in closed loop, and the noise-shaping quantizer.
fn closed_loop_cases() -> Vec<Case> {
    let recover = toy_loop(base(), cycles(200), |t| match t {
        t if t < cycles(50) => 19_661,   // +0.3 FS
        t if t < cycles(100) => 98_304,  // 1.5 FS: over range, saturates
        t if t < cycles(110) => -98_304, // -1.5 FS
        _ => -13_107,                    // -0.2 FS: recovery
    });
    let closed = toy_loop(base(), cycles(150), |t| {
        40_000 + i64::try_from(t * 37 % 2_000).expect("below 2000") - 1_000
    });
    let shaping = Config {
        noise_shaping: true,
        ..base()
    };
    let shaping_ramp: Vec<i16> = (0..cycles(128))
        .map(|i| i16::try_from(i * 4).expect("below 2^15") - 16_384)
        .collect();
    let shaping_closed = toy_loop(shaping, cycles(100), |t| {
        if t < cycles(50) { 7_000 } else { -52_000 }
    });
    vec![
        case(
            "saturate_recover",
            "closed loop (toy pendulum): +0.3, +1.5, -1.5, then -0.2 of full scale",
            base(),
            recover,
        ),
        case(
            "closed_loop_toy",
            "closed loop (toy pendulum) at +0.61 of full scale with a sawtooth disturbance",
            base(),
            closed,
        ),
        case(
            "shaping_ramp",
            "noise-shaping quantizer over a slow ramp",
            shaping,
            shaping_ramp,
        ),
        case(
            "shaping_closed_loop",
            "noise-shaping quantizer in the toy closed loop",
            shaping,
            shaping_closed,
        ),
    ]
}

/// A short limit cycle with a negative lead pole and loud noise (which wraps in `i16`).
fn short_cycle_case(rng: &mut Rng) -> Case {
    let short = Config {
        ticks_per_cycle: 8,
        gate_ticks: 1000,
        b0: Coef::from_num(40.0),
        b1: Coef::from_num(-30.0),
        a1: Pole::from_num(-0.5),
        ki: Coef::from_num(0.25),
        noise_shaping: true,
    };
    let noise: Vec<i16> = (0..4000).map(|_| low_16_bits(rng.bell(20_000))).collect();
    case(
        "short_cycle",
        "8 ticks per cycle, negative lead pole, gate not a multiple of the cycle",
        short,
        noise,
    )
}

fn input_text(c: &Case) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# ptsa golden vector `{}`: {}", c.name, c.about);
    let _ = writeln!(
        s,
        "# generated by `cargo xtask golden --overwrite`; one pickoff sample (ADC LSB) per line"
    );
    let _ = trace::write_config(&mut s, &c.config);
    s.push('\n');
    for x in &c.samples {
        let _ = writeln!(s, "{x}");
    }
    s
}

/// The expected output for an input text, as the host computes it.
pub fn output_text(input: &str) -> Result<String, String> {
    let mut out = String::new();
    let mut r = GoldenRunner::new();
    r.feed(input.as_bytes(), &mut out)
        .map_err(|e| e.to_string())?;
    r.finish(&mut out).map_err(|e| e.to_string())?;
    Ok(out)
}

/// `cargo xtask golden [--overwrite | --c-twin]`.
pub fn run(args: &[String]) -> Result<(), Error> {
    let overwrite = match args {
        [] => false,
        [a] if a == "--overwrite" => true,
        [a] if a == "--c-twin" => {
            needs::check(&[Need::CCompiler], None)?;
            return Ok(check_c_twin()?);
        }
        [a] => return Err(Error::Usage(format!("unknown option `{a}`"))),
        _ => {
            return Err(Error::Usage(
                "expected at most one of --overwrite, --c-twin".into(),
            ));
        }
    };
    let dir = util::root().join("tests").join("golden");
    fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut stale = Vec::new();
    let cases = cases();
    for c in &cases {
        let input = input_text(c);
        let output = output_text(&input)?;
        for (ext, text) in [("in", &input), ("out", &output)] {
            let path = dir.join(format!("{}.{ext}", c.name));
            let same = fs::read_to_string(&path).is_ok_and(|old| &old == text);
            if same {
                continue;
            }
            if overwrite {
                util::write_atomic(&path, text)?;
                eprintln!("wrote {}", path.display());
            } else {
                stale.push(path.display().to_string());
            }
        }
    }
    if overwrite {
        // The host closed-loop vector comes from the simulator, which records it itself.
        let status = std::process::Command::new(util::cargo())
            .args([
                "test",
                "-q",
                "-p",
                "ptsa-host-sim",
                "--test",
                "golden_trace",
            ])
            .env("PTSA_WRITE_GOLDEN", "1")
            .current_dir(util::root())
            .status()
            .map_err(|e| format!("cannot run cargo: {e}"))?;
        if !status.success() {
            return Err("recording tests/golden/host_closed_loop.* failed".into());
        }
    }
    if stale.is_empty() {
        eprintln!(
            "{} golden cases up to date in {}",
            cases.len(),
            dir.display()
        );
        Ok(())
    } else {
        Err(format!(
            "golden files differ from what the code generates (re-record with `cargo xtask golden --overwrite` if the change is intended):\n  {}",
            stale.join("\n  ")
        )
        .into())
    }
}

/// Build the independent C twin (`ptsa-core/c-twin/ptsa_twin.c`, written from ARITHMETIC.md)
/// with the system C compiler into `<cargo's target directory>/c-twin/` and check it against
/// every golden vector.
pub fn check_c_twin() -> Result<(), String> {
    use std::process::{Command, Stdio};
    let root = util::root();
    let src = root.join("ptsa-core").join("c-twin").join("ptsa_twin.c");
    let out_dir = util::target_dir()?.join("c-twin");
    fs::create_dir_all(&out_dir)
        .map_err(|e| format!("cannot create {}: {e}", out_dir.display()))?;
    let exe = out_dir.join("ptsa_twin");
    let cc = needs::c_compiler();
    util::run(
        &root,
        &cc,
        &[
            "-O2",
            "-std=c11",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-o",
            &exe.to_string_lossy(),
            &src.to_string_lossy(),
        ],
    )?;
    let dir = root.join("tests").join("golden");
    let mut names: Vec<_> = fs::read_dir(&dir)
        .map_err(|e| format!("{}: {e}", dir.display()))?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "in"))
        .collect();
    names.sort();
    let mut failed = Vec::new();
    for input in &names {
        let expected = fs::read_to_string(input.with_extension("out"))
            .map_err(|e| format!("{}: {e}", input.display()))?;
        let out = Command::new(&exe)
            .stdin(fs::File::open(input).map_err(|e| format!("{}: {e}", input.display()))?)
            .stderr(Stdio::inherit())
            .output()
            .map_err(|e| format!("cannot run the C twin: {e}"))?;
        let got = String::from_utf8_lossy(&out.stdout);
        if !out.status.success() || got != expected {
            let line = expected
                .lines()
                .zip(got.lines())
                .position(|(a, b)| a != b)
                .map_or_else(|| "length".to_string(), |i| format!("line {}", i + 1));
            failed.push(format!("{} (first difference: {line})", input.display()));
        }
    }
    eprintln!(
        "C twin: {} passed, {} failed",
        names.len() - failed.len(),
        failed.len()
    );
    if failed.is_empty() {
        Ok(())
    } else {
        Err(format!("C twin disagrees with:\n  {}", failed.join("\n  ")))
    }
}
