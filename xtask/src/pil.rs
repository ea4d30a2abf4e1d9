//! `cargo xtask pil`: processor in the loop. The firmware's `pil` image runs the production
//! tick handler on QEMU's emulated STM32F405 around the pendulum, which it steps in `f64`
//! from the host's discrete-time matrices (`ptsa static --pil-params`); the gates the
//! firmware counted come back as `{"ticks", "pulses"}`.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

use crate::constants::DEFAULT_INSTRUMENT;
use crate::firmware::{cargo_firmware, firmware_target_dir, qemu};
use crate::needs::{self, Need};
use crate::util::{self, Error};

/// `cargo xtask pil --help`.
pub const USAGE: &str = "\
pil --accel-cm-s2 A --seconds S --warmup-s W [--instrument FILE] [--json] [--compare]
    [--sine-hz F --sine-cm-s2 B | --step-cm-s2 B --step-at-s T] [--gate-s G] [--log FILE]
pil --ci
    Processor in the loop on QEMU's netduinoplus2: the firmware's `pil` image runs the
    production tick handler (ADC word -> ptsa-core tick -> H-bridge -> gate bottom half)
    around the pendulum, which the emulated MCU steps in f64 from the host's discrete-time
    matrices (`ptsa static --pil-params`), the ADC sample converted by the board's
    converter model. The loop settles for W s and counts S s along IA at A cm/s²
    (bias off, as `ptsa static` without --with-bias); prints the firmware's counts, and
    the speed (emulated ticks per host second) on stderr.
    The instrument file (default data/kearfott-2401-discovery.toml) must describe the
    converter the firmware was built for (firmware/src/constants.rs); its pickoff noise is
    drawn by the image from the host's seeded table (seed 1, as `ptsa static`'s default).
    --accel-cm-s2 A  acceleration along IA, cm/s² (the constant part with a sine, the
                     value before a step)
    --seconds S      the counted time, s (at least one limit cycle)
    --warmup-s W     settling before it, s (0 or more)
    --sine-hz F      add a sine along IA of F Hz, phase 0 at the loop's reset ...
    --sine-cm-s2 B   ... and amplitude B cm/s² (needs --gate-s)
    --step-cm-s2 B   the acceleration becomes B cm/s² ...
    --step-at-s T    ... T s after the loop's reset, settling included (needs --gate-s)
    --gate-s G       the gate of the reports, s (dividing S and W; default with a constant
                     input: their greatest common divisor)
    --instrument F   the instrument file
    --log FILE       write the image's output (its numbered gate reports after the
                     settling, `ptsa record --from FILE` reads them) to FILE (a new one)
    --json           print exactly {\"ticks\": T, \"pulses\": P}, the sums of the reports
    --compare        also run `ptsa static --record` with the same arguments and fail unless
                     every gate's pulses and ticks are the firmware's, bit for bit (and, with
                     a constant input, `ptsa static --json`'s ticks and pulses)
    --ci             the short cases `cargo xtask ci` runs, each compared with the host:
                     1234.5 cm/s², 0.1 s after 0.1 s, the board's file made noiseless; the
                     same with its noise; a 50 Hz, 3000 cm/s² sine, gates of 5 ms, 0.1 s
                     after 0.05 s, noiseless
    Needs qemu-system-arm and the thumbv7em-none-eabihf target; it builds the release
    `ptsa` and the firmware's `pil` image.";

/// What the command needs from the machine.
pub const NEEDS: [Need; 2] = [Need::Thumb, Need::Qemu];

/// One PIL run's request.
#[derive(Debug, Clone)]
pub struct Pil {
    /// Acceleration along IA, cm/s² (as typed, passed to `ptsa` unchanged).
    pub accel: String,
    /// Counted seconds (as typed).
    pub seconds: String,
    /// Settling seconds (as typed).
    pub warmup: String,
    /// Instrument file.
    pub instrument: String,
    /// The moving input's and the gate's flags for `ptsa static` (`--sine-hz F ...`), as
    /// typed.
    pub moving: Vec<String>,
    /// Run the release `ptsa` (the command), or the test profile's (CI, which has built it
    /// for the host tests).
    pub release: bool,
}

/// What the firmware counted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Counts {
    /// Ticks of the gates after the settling.
    pub ticks: u64,
    /// Data pulses in them.
    pub pulses: u64,
}

/// `cargo xtask pil ...`.
pub fn run(args: &[String]) -> Result<(), Error> {
    if args.len() == 1 && args[0] == "--ci" {
        needs::check(&NEEDS, None)?;
        println!("{}", ci()?);
        return Ok(());
    }
    let mut accel = None;
    let mut seconds = None;
    let mut warmup = None;
    let mut instrument = DEFAULT_INSTRUMENT.to_string();
    let (mut json, mut compare) = (false, false);
    let mut moving = Vec::new();
    let mut log = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |what: &str| {
            it.next()
                .cloned()
                .ok_or_else(|| Error::Usage(format!("{a} needs {what}")))
        };
        match a.as_str() {
            "--accel-cm-s2" => accel = Some(number(&value("an acceleration, cm/s²")?, a)?),
            "--seconds" => seconds = Some(number(&value("a time, s")?, a)?),
            "--warmup-s" => warmup = Some(number(&value("a time, s")?, a)?),
            "--instrument" => instrument = value("an instrument file")?,
            "--sine-hz" | "--sine-cm-s2" | "--step-cm-s2" | "--step-at-s" | "--gate-s" => {
                let v = number(&value("a number")?, a)?;
                moving.extend([a.clone(), v]);
            }
            "--log" => {
                let path = PathBuf::from(value("a file")?);
                if path.exists() {
                    return Err(Error::Usage(format!(
                        "--log {}: the file exists; expected a new file (remove it first)",
                        path.display()
                    )));
                }
                log = Some(path);
            }
            "--json" => json = true,
            "--compare" => compare = true,
            other => return Err(Error::Usage(format!("unknown option `{other}`"))),
        }
    }
    let need = |v: Option<String>, flag: &str| {
        v.ok_or_else(|| Error::Usage(format!("{flag} is required")))
    };
    let req = Pil {
        accel: need(accel, "--accel-cm-s2")?,
        seconds: need(seconds, "--seconds")?,
        warmup: need(warmup, "--warmup-s")?,
        instrument,
        moving,
        release: true,
    };
    needs::check(&NEEDS, None)?;
    let root = util::root();
    build_ptsa(&root, true)?;
    let (counts, speed, output) = run_pil(&root, &req)?;
    if let Some(path) = &log {
        util::write_atomic(path, &output)?;
        eprintln!("pil: the image's output in {}", path.display());
    }
    eprintln!(
        "pil: {} emulated ticks in {:.2} s of host time: {:.0} emulated ticks per host second; \
         {} guest instructions, {:.0} per tick",
        speed.ticks,
        speed.seconds,
        speed.ticks_per_s(),
        speed.instructions,
        speed.instructions_per_tick()
    );
    if compare {
        let n = compare_gates(&root, &req, &output).map_err(Error::Failed)?;
        eprintln!("pil: the same {n} gates as `ptsa static --record`, bit for bit");
        if req.moving.is_empty() {
            let host = host_static(&root, &req)?;
            if host != counts {
                return Err(Error::Failed(format!(
                    "the firmware counted {counts:?}, `ptsa static` {host:?}: not bit for bit"
                )));
            }
            eprintln!("pil: the same counts as `ptsa static` ({host:?})");
        }
    }
    if json {
        println!(
            "{{\"ticks\":{},\"pulses\":{}}}",
            counts.ticks, counts.pulses
        );
    } else {
        println!(
            "pil: T = {} ticks, P = {} pulses (the firmware's gates after {} s of settling)",
            counts.ticks, counts.pulses, req.warmup
        );
    }
    Ok(())
}

/// A number as typed (checked to be one, passed on as typed so that `ptsa` reads the same
/// text).
fn number(v: &str, flag: &str) -> Result<String, Error> {
    match v.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(v.to_string()),
        _ => Err(Error::Usage(format!("{flag} {v}: expected a number"))),
    }
}

/// The time a PIL run took.
#[derive(Debug, Clone, Copy)]
pub struct Speed {
    /// Ticks emulated (settling and gate).
    pub ticks: u64,
    /// Host seconds of the QEMU run.
    pub seconds: f64,
    /// Guest instructions of the image's loop (plant, ADC model, tick, gates).
    pub instructions: u64,
}

impl Speed {
    /// Emulated ticks per host second.
    #[must_use]
    #[allow(clippy::cast_precision_loss, reason = "tick counts far below 2^52")]
    pub fn ticks_per_s(&self) -> f64 {
        self.ticks as f64 / self.seconds
    }

    /// Guest instructions per emulated tick (times the 64 000 ticks of a second: per
    /// emulated second).
    #[must_use]
    #[allow(clippy::cast_precision_loss, reason = "counts far below 2^52")]
    pub fn instructions_per_tick(&self) -> f64 {
        self.instructions as f64 / self.ticks.max(1) as f64
    }
}

/// Build `ptsa` (quietly, once: the runs below use the binary) with the release or the
/// test profile. The test profile's is built as the host tests build it (the whole
/// workspace's test targets, so the same features), which in `cargo xtask ci`, right after
/// the host tests, is already done: `-p ptsa-host-sim --bin ptsa` alone would resolve other
/// features and rebuild every crate (about a minute of CI).
fn build_ptsa(root: &Path, release: bool) -> Result<(), String> {
    let args: &[&str] = if release {
        &[
            "build",
            "--release",
            "-q",
            "-p",
            "ptsa-host-sim",
            "--bin",
            "ptsa",
        ]
    } else {
        &["build", "--profile", "test", "-q", "--workspace", "--tests"]
    };
    util::run(root, &util::cargo(), args)
}

/// The `ptsa` of this workspace, release or test profile (whose directory is `debug`).
fn ptsa_exe(release: bool) -> Result<PathBuf, String> {
    Ok(util::target_dir()?
        .join(if release { "release" } else { "debug" })
        .join(format!("ptsa{}", std::env::consts::EXE_SUFFIX)))
}

/// `ptsa --instrument F static --accel-cm-s2 A --seconds S --warmup-s W` and `more`.
fn ptsa_static(root: &Path, req: &Pil, more: &[&str]) -> Result<String, String> {
    let exe = ptsa_exe(req.release)?;
    let mut args = vec![
        "--instrument",
        &req.instrument,
        "static",
        "--accel-cm-s2",
        &req.accel,
        "--seconds",
        &req.seconds,
        "--warmup-s",
        &req.warmup,
    ];
    if !more.contains(&"--json") {
        args.extend(req.moving.iter().map(String::as_str));
    }
    args.extend_from_slice(more);
    eprintln!("+ ptsa {}", args.join(" "));
    let out = Command::new(&exe)
        .args(&args)
        .current_dir(root)
        .stderr(Stdio::inherit())
        .output()
        .map_err(|e| format!("cannot run {}: {e}", exe.display()))?;
    if !out.status.success() {
        return Err(format!("`ptsa {}` failed ({})", args.join(" "), out.status));
    }
    String::from_utf8(out.stdout).map_err(|_| "ptsa printed something that is not UTF-8".into())
}

/// `ptsa static ... --json`'s ticks and pulses.
pub fn host_static(root: &Path, req: &Pil) -> Result<Counts, String> {
    let text = ptsa_static(root, req, &["--json"])?;
    let field = |k: &str| -> Result<u64, String> {
        let at = text
            .find(&format!("\"{k}\":"))
            .ok_or_else(|| format!("no `{k}` in ptsa's JSON: {text}"))?;
        text[at + k.len() + 3..]
            .chars()
            .take_while(char::is_ascii_digit)
            .collect::<String>()
            .parse()
            .map_err(|_| format!("bad `{k}` in ptsa's JSON: {text}"))
    };
    Ok(Counts {
        ticks: field("ticks")?,
        pulses: field("pulses")?,
    })
}

/// The image's gate reports (`gate seq=.. P=.. T=.. gates=.. tick=..`) against `ptsa static
/// --record`'s gates of the same run: the same number, each with the same pulses and
/// ticks, none merged. Returns how many.
fn compare_gates(root: &Path, req: &Pil, output: &str) -> Result<usize, String> {
    let dir = firmware_target_dir()?.join("pil");
    let host = dir.join("host.csv");
    let host_arg = host.to_str().ok_or("the target directory is not UTF-8")?;
    ptsa_static(root, req, &["--record", host_arg, "--force"])?;
    let text = std::fs::read_to_string(&host)
        .map_err(|e| format!("cannot read {}: {e}", host.display()))?;
    let want: Vec<(u64, u64)> = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("time_s"))
        .map(|l| {
            let mut f = l.split(',').skip(1).map(str::parse::<u64>);
            match (f.next(), f.next()) {
                (Some(Ok(p)), Some(Ok(t))) => Ok((p, t)),
                _ => Err(format!("{}: not a gate line: `{l}`", host.display())),
            }
        })
        .collect::<Result<_, _>>()?;
    let got = image_gates(output)?;
    if got.iter().any(|g| g.2 != 1) {
        return Err("the image merged gates (its queue overflowed)".into());
    }
    let got: Vec<(u64, u64)> = got.iter().map(|g| (g.0, g.1)).collect();
    if let Some(i) = (0..want.len().min(got.len())).find(|&i| want[i] != got[i]) {
        return Err(format!(
            "gate {} after the settling: the firmware counted P = {}, T = {}; `ptsa static --record` P = {}, T = {}: not bit for bit",
            i + 1,
            got[i].0,
            got[i].1,
            want[i].0,
            want[i].1
        ));
    }
    if want.len() != got.len() {
        return Err(format!(
            "the firmware reported {} gates, `ptsa static --record` {}",
            got.len(),
            want.len()
        ));
    }
    Ok(want.len())
}

/// The image's gate reports: pulses, ticks and merged gates of each.
fn image_gates(output: &str) -> Result<Vec<(u64, u64, u64)>, String> {
    output
        .lines()
        .filter(|l| l.starts_with("gate seq="))
        .map(|l| {
            let field = |k: &str| -> Result<u64, String> {
                l.split_whitespace()
                    .find_map(|w| w.strip_prefix(k)?.strip_prefix('=')?.parse().ok())
                    .ok_or_else(|| format!("no `{k}` in `{l}`"))
            };
            Ok((field("P")?, field("T")?, field("gates")?))
        })
        .collect()
}

/// Write the parameters, build the image, run it on QEMU: the firmware's counts, the run's
/// speed and the image's output (its gate reports).
pub fn run_pil(root: &Path, req: &Pil) -> Result<(Counts, Speed, String), String> {
    let dir = firmware_target_dir()?.join("pil");
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let params = dir.join("params.txt");
    let params_arg = params.to_str().ok_or("the target directory is not UTF-8")?;
    if params_arg.contains(char::is_whitespace) {
        return Err(format!(
            "path `{params_arg}` contains white space (semihosting splits on it)"
        ));
    }
    ptsa_static(root, req, &["--pil-params", params_arg, "--force"])?;
    let fw = root.join("firmware");
    let fw_target = firmware_target_dir()?;
    cargo_firmware(&fw, &fw_target, &["build", "--release", "--bin", "pil"])?;
    let elf = fw_target
        .join(crate::firmware::TARGET)
        .join("release")
        .join("pil");
    let semihosting = format!("enable=on,target=native,arg=pil,arg={params_arg}");
    let t0 = Instant::now();
    let run = qemu(root, &elf, &["-semihosting-config", &semihosting])?;
    let seconds = t0.elapsed().as_secs_f64();
    if !run.status_ok {
        return Err(format!(
            "the pil image failed ({}): {}",
            run.status,
            run.stderr.trim()
        ));
    }
    let (counts, _gate, instructions) = parse_pil(&run.stdout)?;
    let text = std::fs::read_to_string(&params)
        .map_err(|e| format!("cannot read {}: {e}", params.display()))?;
    let warmup: u64 = text
        .lines()
        .find_map(|l| l.strip_prefix("run "))
        .and_then(|l| l.split_whitespace().next()?.parse().ok())
        .ok_or("no `run` line in the params file")?;
    Ok((
        counts,
        Speed {
            ticks: warmup + counts.ticks,
            seconds,
            instructions,
        },
        run.stdout,
    ))
}

/// `pil ticks=<T> pulses=<P> gates=<n> gate_ticks=<G> instructions=<I>`: the counts, the
/// gate length and the guest instructions.
fn parse_pil(stdout: &str) -> Result<(Counts, u64, u64), String> {
    let line = stdout
        .lines()
        .find(|l| l.starts_with("pil "))
        .ok_or_else(|| format!("no `pil` line in the image's output: {stdout:?}"))?;
    let field = |k: &str| -> Result<u64, String> {
        line.split_whitespace()
            .find_map(|w| w.strip_prefix(k)?.strip_prefix('=')?.parse().ok())
            .ok_or_else(|| format!("no `{k}` in `{line}`"))
    };
    Ok((
        Counts {
            ticks: field("ticks")?,
            pulses: field("pulses")?,
        },
        field("gate_ticks")?,
        field("instructions")?,
    ))
}

/// CI's processor-in-the-loop cases, each run on the image and compared with the host gate
/// by gate (and, for a constant input, with `ptsa static --json`): 1234.5 cm/s², 0.1 s of
/// settling and 0.1 s counted, on the board's file made noiseless and on the board's file
/// with its noise (seed 1); a 50 Hz, 3000 cm/s² sine, gates of 5 ms, 0.1 s after 0.05 s,
/// noiseless. The noiseless copy of the board's file is written into the firmware's target
/// directory. Uses the test profile's `ptsa`, which the host tests have built.
pub fn ci() -> Result<String, String> {
    let root = util::root();
    build_ptsa(&root, false)?;
    let text = std::fs::read_to_string(root.join(DEFAULT_INSTRUMENT))
        .map_err(|e| format!("cannot read {DEFAULT_INSTRUMENT}: {e}"))?;
    let noisy = "noise_uv_rms = { value = 0.5,";
    if !text.contains(noisy) {
        return Err(format!(
            "{DEFAULT_INSTRUMENT} has no line `{noisy} ...`: update xtask's PIL case"
        ));
    }
    let dir = firmware_target_dir()?.join("pil");
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let quiet = dir.join("quiet.toml");
    std::fs::write(&quiet, text.replace(noisy, "noise_uv_rms = { value = 0.0,"))
        .map_err(|e| format!("cannot write {}: {e}", quiet.display()))?;
    let quiet = quiet.to_string_lossy().into_owned();
    let case = |accel: &str, seconds: &str, warmup: &str, instrument: &str, moving: &[&str]| Pil {
        accel: accel.into(),
        seconds: seconds.into(),
        warmup: warmup.into(),
        instrument: instrument.into(),
        moving: moving.iter().map(|m| (*m).to_string()).collect(),
        release: false,
    };
    let cases = [
        (
            "1234.5 cm/s², 0.1 s after 0.1 s, noiseless",
            case("1234.5", "0.1", "0.1", &quiet, &[]),
        ),
        (
            "the same with the board's pickoff noise",
            case("1234.5", "0.1", "0.1", DEFAULT_INSTRUMENT, &[]),
        ),
        (
            "a 50 Hz, 3000 cm/s² sine, 5 ms gates, 0.1 s after 0.05 s, noiseless",
            case(
                "0",
                "0.1",
                "0.05",
                &quiet,
                &[
                    "--sine-hz",
                    "50",
                    "--sine-cm-s2",
                    "3000",
                    "--gate-s",
                    "0.005",
                ],
            ),
        ),
    ];
    let mut lines = Vec::new();
    for (what, req) in &cases {
        let (counts, speed, output) = run_pil(&root, req)?;
        let n = compare_gates(&root, req, &output)
            .map_err(|e| format!("processor in the loop, {what}: {e}"))?;
        if req.moving.is_empty() {
            let host = host_static(&root, req)?;
            if counts != host {
                return Err(format!(
                    "processor in the loop, {what}: the firmware counted {counts:?}, `ptsa static` {host:?}"
                ));
            }
        }
        lines.push(format!(
            "processor in the loop (QEMU), {what}: P = {} in T = {}, {n} gate(s) as the host's bit for bit ({:.0} emulated ticks per host second, {:.0} guest instructions per tick)",
            counts.pulses,
            counts.ticks,
            speed.ticks_per_s(),
            speed.instructions_per_tick()
        ));
    }
    Ok(lines.join("\n"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_image_line_parses() {
        let (c, g, i) = parse_pil(
            "gate seq=1 P=3 T=8 gates=1 tick=8\npil ticks=6400 pulses=3352 gates=1 gate_ticks=6400 instructions=9\n",
        )
        .unwrap();
        assert_eq!(
            c,
            Counts {
                ticks: 6400,
                pulses: 3352
            }
        );
        assert_eq!((g, i), (6400, 9));
        assert!(parse_pil("gate seq=1 P=3 T=8 gates=1 tick=8\n").is_err());
        assert!(parse_pil("pil ticks=1 gates=1 gate_ticks=1").is_err());
    }

    #[test]
    fn numbers_are_checked_and_passed_as_typed() {
        assert_eq!(number("1234.50", "--x").unwrap(), "1234.50");
        assert!(number("fast", "--x").is_err());
        assert!(number("inf", "--x").is_err());
    }
}
