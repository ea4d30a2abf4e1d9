//! `cargo xtask figures [ID ...] [--list] [--rescore-seed S | --no-rescore]`: the
//! measurements that the docs quote, each run by a command that asserts its claim, written
//! as one generated page per figure in `docs/figures/` with the command, the date, the
//! commit, the machine and what the command printed, and an index page listing them.
//!
//! A seeded campaign runs twice: at its published seed, and re-scored at a seed chosen on
//! the day of the run (`YYYYMMDD`), which no one can have tuned the method on. Both must
//! pass. A figure whose command fails writes no page (the page before stays), and the run
//! ends with an error naming it.

use std::io::{BufRead as _, BufReader, Write as _};
use std::path::{Path, PathBuf};
use std::process::Command;

use std::fmt::Write as _;

use crate::hidden;
use crate::util::{self, Error};

/// `cargo xtask figures --help`.
pub const USAGE: &str = "\
figures [ID ...] [--list] [--rescore-seed S | --no-rescore]
    Runs the measurements the docs quote, each by a command that asserts its claim (a
    campaign's rates by binomial tests against their goals; the firmware's budgets), and
    writes docs/figures/ID.md for each: the command, the date, the commit, the machine,
    and what the command printed. docs/figures/README.md lists them all. A figure whose
    command fails keeps its old page, and the run fails naming it.
    ID ...       the figures to run (default: every one; --list names them)
    --list       print each figure's id, command and claim, and stop
    --rescore-seed S  re-score each seeded campaign at seed S, a whole number (default:
                 today's date as YYYYMMDD, a seed chosen after the method was fixed)
    --no-rescore run each campaign at its published seed only (half the time)
    The full run takes about an hour on 2 cores; the campaigns' CI-sized subsets run in
    every `cargo xtask ci`.";

/// How a figure is measured.
enum Measure {
    /// `cargo xtask hidden ARGS` (its seed replaced when re-scored).
    Hidden(&'static [&'static str]),
    /// `cargo xtask ARGS`, keeping the lines of its report (`ok`, `FAIL`, totals).
    Xtask(&'static [&'static str]),
    /// `cargo test -p PACKAGE --test FILE NAME -- --exact --nocapture`: one test of the
    /// workspace, which CI runs as it is, asserting the claim and printing the figures.
    Test {
        package: &'static str,
        file: &'static str,
        name: &'static str,
    },
    /// `ENV cargo test --release -p PACKAGE --test FILE NAME -- --exact --ignored
    /// --nocapture`: a campaign kept out of CI as an ignored test, set up by `env`, and
    /// re-scored with `seed_var` set to the re-scoring seed.
    Ignored {
        package: &'static str,
        file: &'static str,
        name: &'static str,
        env: &'static [(&'static str, &'static str)],
        seed_var: &'static str,
    },
    /// `cargo COMMAND ARGS` (`ptsa bench`, or `xtask python --bench` for the Python
    /// package's Ray campaigns), keeping its `bench:` lines; the ratio printed after
    /// `ratio` must be at least `min`.
    Bench {
        command: &'static [&'static str],
        args: &'static [&'static str],
        ratio: &'static str,
        min: f64,
    },
}

/// One published figure: what it supports and how it is measured.
struct Figure {
    /// The page's name, `docs/figures/ID.md`.
    id: &'static str,
    /// What is measured, in a few words.
    title: &'static str,
    /// The claim the command asserts.
    claim: &'static str,
    /// The pages that quote it.
    quoted_in: &'static str,
    measure: Measure,
    /// The CI-sized subset that runs in every `cargo xtask ci`: a test file (from the
    /// repository's root) and a test, or `("xtask ci", step)` for a step of its own.
    ci: (&'static str, &'static str),
}

/// Every published figure.
const FIGURES: &[Figure] = &[
    Figure {
        id: "hidden-effects",
        title: "discovery: every candidate effect hidden as physics in the closed loop",
        claim: "each null kind: a false selection in at most 5 % of sets; each kind nothing can name: a confident misnaming in at most 5 %; the candidates pooled: named at 8 SE in at least 95 %, coverage in the 99 % binomial band",
        quoted_in: "docs/method/discovery.md",
        measure: Measure::Hidden(&["--sets", "200", "--seed", "7"]),
        ci: ("tests/hidden_effects.rs", "hidden_effects_ci"),
    },
    Figure {
        id: "hidden-effects-analytic",
        title: "discovery: the same campaign on the quasi-static generator, 1000 sets per kind",
        claim: "the same assertions as hidden-effects, with the power of 1000 sets per kind",
        quoted_in: "docs/method/discovery.md",
        measure: Measure::Hidden(&["--sets", "1000", "--analytic", "--seed", "4242"]),
        ci: ("tests/hidden_effects.rs", "hidden_effects_ci"),
    },
    Figure {
        id: "hidden-parameters",
        title: "discovery: a loop parameter changed in the instrument file, identified blind",
        claim: "pooled over parameters and designs: false selections and misnamings each in at most 5 % of sets; named at 6 SE in at least 95 %; coverage in the 99 % binomial band",
        quoted_in: "docs/method/discovery.md",
        measure: Measure::Hidden(&["--parameters", "--sets", "10", "--seed", "4242"]),
        ci: ("tests/hidden_params.rs", "hidden_parameters_ci"),
    },
    Figure {
        id: "hidden-statics",
        title: "discovery: IA tilts, quadratic and cubic terms, bias and scale-factor changes in the plant",
        claim: "pooled over kinds and designs: false and wrong selections each in at most 5 % of sets; named at 6 SE in at least 95 %; coverage in the 99 % binomial band",
        quoted_in: "docs/method/discovery.md",
        measure: Measure::Hidden(&["--statics", "--sets", "200", "--seed", "4242"]),
        ci: ("tests/hidden_statics.rs", "hidden_statics_ci"),
    },
    Figure {
        id: "hidden-lab",
        title: "discovery: a lab's effects (hysteresis, temperature, warm-up, out-of-vocabulary terms)",
        claim: "each null and declared-fixture kind: false selections in at most 5 % of sets; hysteresis, temperature and warm-up named at 6 and 10 SE in at least 95 %; pooled coverage in the 99 % binomial band",
        quoted_in: "docs/method/discovery.md",
        measure: Measure::Hidden(&["--lab", "--analytic", "--sets", "140", "--seed", "4242"]),
        ci: ("tests/hidden_lab.rs", "hidden_lab_ci"),
    },
    Figure {
        id: "hidden-sigma",
        title: "discovery: a stated sigma too small by 1 to 4 times",
        claim: "nulls whose sigma is stated right or 2 times too small, on each design: false selections in at most 5 % of sets (the other factors and the power are printed)",
        quoted_in: "docs/method/discovery.md",
        measure: Measure::Hidden(&["--sigma", "--sets", "600", "--seed", "4242"]),
        ci: ("tests/hidden_sigma.rs", "hidden_sigma_ci"),
    },
    Figure {
        id: "hidden-calibration",
        title: "calibration: the k = 2 intervals of K_0, K_1, delta_o, delta_p, K_2",
        claim: "the k = 2 intervals, pooled over terms and designs, cover the truth 95 +- 2.5 % of the time, over all sets and over the sets given as counts",
        quoted_in: "docs/method/discovery.md",
        measure: Measure::Hidden(&["--calibration", "--sets", "2000", "--seed", "4242"]),
        ci: ("tests/hidden_calibration.rs", "hidden_calibration_ci"),
    },
    Figure {
        id: "hidden-triad",
        title: "triad: 8 to 37 positions, on a fixture and placed by hand",
        claim: "each of six designs: pooled coverage of the 95 % intervals within 95 +- 2.5 % and the 99 % binomial band; sets with a warning in at most 5 %; no refusal",
        quoted_in: "docs/method/discovery.md",
        measure: Measure::Hidden(&["--triad", "--sets", "600", "--seed", "4242"]),
        ci: ("tests/hidden_triad.rs", "hidden_triad_ci"),
    },
    Figure {
        id: "hidden-stability",
        title: "discovery: constant truths marked unstable",
        claim: "sets with a selected term marked unstable: at most the 99.5 % quantile of Binomial(n, 5 %) (126 of 2000)",
        quoted_in: "docs/method/discovery.md",
        measure: Measure::Hidden(&["--stability", "--sets", "2000", "--seed", "4242"]),
        ci: ("tests/hidden_stability.rs", "hidden_stability_ci"),
    },
    Figure {
        id: "hidden-noise-terms",
        title: "noise: which of IEEE Std 952's terms a static record holds (--identify)",
        claim: "a term not in the record in at most 5 % of records; 95 % intervals that cover",
        quoted_in: "docs/method/noise.md, docs/guide/static-record.md",
        measure: Measure::Hidden(&["--noise-terms", "--sets", "200", "--seed", "4242"]),
        ci: ("tests/hidden_terms.rs", "hidden_terms_ci"),
    },
    Figure {
        id: "identify-noise",
        title: "noise: the white acceleration noise N beyond the file's loop, identified with --identify",
        claim: "over 60 one-minute records with N = 0.1 cm/s²/√Hz, K = 0.005 cm/s²·√Hz and an untold pickoff noise of 0.2-2 µV added to the loop: N selected in at least 95 % of them; N's 95 % intervals cover 0.1 at a rate inside the central 99 % of Binomial(n, 0.95), n the records where N is selected",
        quoted_in: "docs/method/noise.md",
        measure: Measure::Ignored {
            package: "ptsa-host-sim",
            file: "cli_noise",
            name: "identify_campaign",
            env: &[("PTSA_CAMPAIGN", "60,6000,0.005,1000,0.2-2,added")],
            seed_var: "PTSA_CAMPAIGN_SEED",
        },
        ci: (
            "ptsa-host-sim/tests/cli_noise.rs",
            "identify_campaign_small",
        ),
    },
    Figure {
        id: "firmware",
        title: "firmware: golden vectors and instruction, flash, RAM and stack budgets under QEMU",
        claim: "every vector bit-exact on the emulated Cortex-M4; every budget within its limit",
        quoted_in: "docs/method/firmware.md, README.md",
        measure: Measure::Xtask(&["firmware"]),
        ci: ("xtask ci", "firmware"),
    },
    Figure {
        id: "pil",
        title: "processor in the loop: the production interrupt handler on the emulated MCU around the host's pendulum",
        claim: "in each case (static, static with the board's noise, a sine with 5 ms gates) the firmware's gates are the host's bit for bit, and in the static cases its counts are `ptsa static`'s",
        quoted_in: "docs/method/firmware.md",
        measure: Measure::Xtask(&["pil", "--ci"]),
        ci: ("xtask ci", "processor in the loop"),
    },
    Figure {
        id: "report-programme",
        title: "the report's test programme: the tumble, Tables 6.1-6.3 and Table 2.1's tolerance box",
        claim: "the tumble recovers the configured SF within 1 ppm and A_b within 0.001 cm/s²; Table 6.1's error is k·ω_IA·ω_PA within 0.1 % (under 0.001 cm/s² where that is 0) and its mean at 45° within 0.3 cm/s² of the report's; Tables 6.2/6.3 rectify under 0.01 cm/s² and the report's rows are consistent with zero at their 0.3 cm/s² uncertainty (χ² under its 95 % point); every corner of Table 2.1's box keeps 45° and 6 dB of margin, and the 8 worst count right after their own SF",
        quoted_in: "docs/method/host-sim.md",
        measure: Measure::Test {
            package: "ptsa-host-sim",
            file: "published",
            name: "the_report_programme_reproduces_r890",
        },
        ci: (
            "ptsa-host-sim/tests/published.rs",
            "the_report_programme_reproduces_r890",
        ),
    },
    Figure {
        id: "discovery-report-data",
        title: "discovery on R-890's Tables 6.1-6.3 and on response rows with a hidden damping",
        claim: "Table 6.1: anisoinertia alone selected, its interval of 2 standard errors holding the report's k = 3.0 cm; Tables 6.2/6.3: nothing selected; each extended fit's χ² p-value above 0.05; the synthetic response rows: the damping alone named, its 2-standard-error interval holding the 114 600 dyn·cm·s written",
        quoted_in: "docs/method/discovery.md",
        measure: Measure::Test {
            package: "ptsa-host-sim",
            file: "published",
            name: "discovery_reads_the_reports_tables_as_the_report_did",
        },
        ci: (
            "ptsa-host-sim/tests/published.rs",
            "discovery_reads_the_reports_tables_as_the_report_did",
        ),
    },
    Figure {
        id: "bench-c",
        title: "speed: the closed loop in Rust against the same loop in plain C",
        claim: "the Rust loop runs at least 0.85 times as fast as the plain C loop (ticks per second, median of 5 runs in alternation), both giving the same pulses bit for bit",
        quoted_in: "docs/method/host-sim.md",
        measure: Measure::Bench {
            command: &["ptsa", "bench"],
            args: &["--compare-c", "--runs", "5"],
            ratio: "bench: Rust / C = ",
            min: 0.85,
        },
        ci: (
            "ptsa-host-sim/tests/cli.rs",
            "bench_compare_c_gives_the_same_pulses_bit_for_bit",
        ),
    },
    Figure {
        id: "bench-batch",
        title: "speed: the batch engine against the single loop, 16 static conditions",
        claim: "the batch engine (8 lanes, one thread) runs at least 1.5 times the single loop's ticks per second (median of 5 runs), with the same pulses",
        quoted_in: "docs/method/host-sim.md",
        measure: Measure::Bench {
            command: &["ptsa", "bench"],
            args: &["--batch", "16", "--lanes", "8", "--runs", "5"],
            ratio: "bench: batch / single = ",
            min: 1.5,
        },
        ci: (
            "ptsa-host-sim/tests/cli.rs",
            "bench_batch_prints_both_rates",
        ),
    },
    Figure {
        id: "bench-shared",
        title: "speed: the batch engine against the single loop, one oscillating condition with 16 instruments (discovery's parameter sides)",
        claim: "the batch engine (8 lanes, one thread) runs at least 2 times the single loop's ticks per second (median of 5 runs) on a CPU with AVX2 or AVX-512, with the same results bit for bit",
        quoted_in: "docs/method/host-sim.md",
        measure: Measure::Bench {
            command: &["ptsa", "bench"],
            args: &[
                "--batch",
                "16",
                "--dynamic",
                "--shared-condition",
                "--lanes",
                "8",
                "--runs",
                "5",
            ],
            ratio: "bench: batch / single = ",
            min: 2.0,
        },
        ci: (
            "ptsa-host-sim/tests/cli.rs",
            "bench_batch_dynamic_prints_both_rates",
        ),
    },
    Figure {
        id: "bench-ray",
        title: "speed: the yield study as Ray tasks on 1 and on 2 workers (the Python package, built as `pip install ./python` builds it)",
        claim: "2 workers run the study at least 1.5 times as fast as 1 (median of 3 runs each)",
        quoted_in: "docs/method/host-sim.md",
        measure: Measure::Bench {
            command: &["xtask", "python", "--bench"],
            args: &[
                "--yield",
                "1024",
                "--repeats",
                "3",
                "--task-size",
                "64",
                "--expect-speedup",
                "1.5",
            ],
            ratio: "bench: 1 worker / 2 workers = ",
            min: 1.5,
        },
        ci: (
            "python/tests/test_campaign.py",
            "test_on_a_local_ray_the_json_is_the_command_lines",
        ),
    },
];

/// What one run of a figure's command gave.
struct Measured {
    /// The page's heading over what it printed.
    heading: String,
    /// The command as a person would type it.
    shown: String,
    /// What the command printed that the page keeps.
    text: String,
    /// Wall time, build included.
    seconds: f64,
}

/// Where and when the figures were measured.
struct Machine {
    date: String,
    commit: String,
    cpu: String,
    load: String,
    rustc: String,
}

/// `cargo xtask figures`.
pub fn run(args: &[String]) -> Result<(), Error> {
    let opts = parse(args)?;
    if opts.list {
        for f in FIGURES {
            println!("{:<24} {}\n{:<24} claim: {}", f.id, shown(f), "", f.claim);
        }
        return Ok(());
    }
    let dir = util::root().join("docs").join("figures");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut failed = Vec::new();
    let chosen: Vec<&Figure> = FIGURES
        .iter()
        .filter(|f| opts.ids.is_empty() || opts.ids.iter().any(|i| i == f.id))
        .collect();
    for (i, f) in chosen.iter().enumerate() {
        eprintln!("figures: [{}/{}] {}", i + 1, chosen.len(), f.id);
        let machine = machine();
        match measure_all(f, opts.rescore.as_ref()) {
            Ok(runs) => {
                let path = dir.join(format!("{}.md", f.id));
                util::write_atomic(&path, &page(f, &runs, &machine))?;
                eprintln!("figures: wrote {}", path.display());
            }
            Err(e) => {
                eprintln!("figures: {} FAILED: {e}", f.id);
                failed.push(f.id);
            }
        }
    }
    util::write_atomic(&dir.join("README.md"), &index(&dir))?;
    if failed.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{} failed (their pages were kept as they were): {}",
            failed.len(),
            failed.join(", ")
        )
        .into())
    }
}

/// The command line's choices.
struct Options {
    ids: Vec<String>,
    list: bool,
    rescore: Option<Rescore>,
}

/// The seed a campaign is re-scored at, and where it came from.
struct Rescore {
    seed: String,
    /// How the page says it was chosen.
    chosen: &'static str,
}

fn parse(args: &[String]) -> Result<Options, Error> {
    let mut o = Options {
        ids: Vec::new(),
        list: false,
        rescore: Some(Rescore {
            seed: today_seed(),
            chosen: "a seed chosen on the day of the run",
        }),
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--list" => o.list = true,
            "--no-rescore" => o.rescore = None,
            "--rescore-seed" => {
                let s = it
                    .next()
                    .ok_or_else(|| Error::Usage("--rescore-seed needs a number".into()))?;
                s.parse::<u64>().map_err(|_| {
                    Error::Usage(format!("--rescore-seed {s}: expected a whole number"))
                })?;
                o.rescore = Some(Rescore {
                    seed: s.clone(),
                    chosen: "the seed given with --rescore-seed",
                });
            }
            id if FIGURES.iter().any(|f| f.id == id) => o.ids.push(id.to_string()),
            other => {
                return Err(Error::Usage(format!(
                    "unknown figure or option `{other}` (`cargo xtask figures --list` names the figures)"
                )));
            }
        }
    }
    Ok(o)
}

/// Today's date (UTC) as the number `YYYYMMDD`.
fn today_seed() -> String {
    humantime::format_rfc3339_seconds(std::time::SystemTime::now())
        .to_string()
        .chars()
        .take(10)
        .filter(char::is_ascii_digit)
        .collect()
}

/// The figure's command as a person would type it.
fn shown(f: &Figure) -> String {
    match f.measure {
        Measure::Hidden(args) => format!("cargo xtask hidden {}", args.join(" ")),
        Measure::Xtask(args) => format!("cargo xtask {}", args.join(" ")),
        Measure::Test {
            package,
            file,
            name,
        } => format!("cargo test -p {package} --test {file} {name} -- --exact --nocapture"),
        Measure::Ignored { .. } => ignored_command(f, None).1,
        Measure::Bench { command, args, .. } => {
            format!("cargo {} {}", command.join(" "), args.join(" "))
        }
    }
}

/// The figure's runs: at its published seed, and at `rescore` when it has a seed.
fn measure_all(f: &Figure, rescore: Option<&Rescore>) -> Result<Vec<Measured>, String> {
    match f.measure {
        Measure::Hidden(args) => {
            let args: Vec<String> = args.iter().map(|s| (*s).to_string()).collect();
            if let Some(r) = rescore.filter(|r| with_seed(&args, Some(&r.seed)) == args) {
                return Err(format!(
                    "the re-scoring seed {} is the published one: nothing would be re-scored",
                    r.seed
                ));
            }
            let mut runs = vec![campaign(&args, None)?];
            if let Some(r) = rescore {
                let mut run = campaign(&args, Some(&r.seed))?;
                run.heading = format!("Re-scored at seed {}, {}", r.seed, r.chosen);
                runs.push(run);
            }
            Ok(runs)
        }
        Measure::Xtask(args) => {
            let (all, seconds) = capture(cargo(&["xtask"], args))?;
            Ok(vec![Measured {
                heading: "What it printed".into(),
                shown: shown(f),
                text: report_lines(&all),
                seconds,
            }])
        }
        Measure::Test {
            package,
            file,
            name,
        } => {
            let args = [file, name, "--", "--exact", "--nocapture"];
            let cmd = cargo(&["test", "-p", package, "--test"], &args);
            Ok(vec![one_test(cmd, &shown(f))?])
        }
        Measure::Ignored { env, .. } => {
            let published = |s: &str| env.iter().any(|(_, v)| v.contains(&format!(",{s},")));
            if let Some(r) = rescore.filter(|r| published(&r.seed)) {
                return Err(format!(
                    "the re-scoring seed {} is the published one: nothing would be re-scored",
                    r.seed
                ));
            }
            let (cmd, shown) = ignored_command(f, None);
            let mut runs = vec![one_test(cmd, &shown)?];
            if let Some(r) = rescore {
                let (cmd, shown) = ignored_command(f, Some(&r.seed));
                let mut run = one_test(cmd, &shown)?;
                run.heading = format!("Re-scored at seed {}, {}", r.seed, r.chosen);
                runs.push(run);
            }
            Ok(runs)
        }
        Measure::Bench {
            command,
            args,
            ratio,
            min,
        } => {
            let (all, seconds) = capture(cargo(command, args))?;
            let text = bench_lines(&all);
            at_least(&text, ratio, min)?;
            Ok(vec![Measured {
                heading: "What it printed".into(),
                shown: shown(f),
                text,
                seconds,
            }])
        }
    }
}

/// `cargo COMMAND ARGS` in the repository's root.
fn cargo(command: &[&str], args: &[&str]) -> Command {
    let mut cmd = Command::new(util::cargo());
    cmd.args(command).args(args).current_dir(util::root());
    cmd
}

/// One campaign run, its seed replaced by `seed` when given.
fn campaign(args: &[String], seed: Option<&str>) -> Result<Measured, String> {
    let args = with_seed(args, seed);
    let c = hidden::parse(&args).map_err(|e| e.to_string())?;
    let (cmd, env_form) = hidden::command(&c);
    eprintln!("+ {env_form}");
    let mut run = one_test(cmd, &env_form)?;
    run.shown = format!("cargo xtask hidden {}", args.join(" "));
    Ok(run)
}

/// A command that runs one test under libtest (`--exact`): what the test printed, provided
/// exactly one test ran, passed and printed something.
fn one_test(cmd: Command, shown: &str) -> Result<Measured, String> {
    let (all, seconds) = capture(cmd)?;
    let text = test_output(&all);
    if !all
        .lines()
        .any(|l| l.starts_with("test result: ok. 1 passed"))
        || text.is_empty()
    {
        return Err(format!(
            "`{shown}` ran no test, or one that printed nothing: no page for it"
        ));
    }
    Ok(Measured {
        heading: "What it printed".into(),
        shown: shown.to_string(),
        text,
        seconds,
    })
}

/// An ignored campaign's command and its form as a person would type it, with `seed_var`
/// set to `seed` when given.
fn ignored_command(f: &Figure, seed: Option<&str>) -> (Command, String) {
    let Measure::Ignored {
        package,
        file,
        name,
        env,
        seed_var,
    } = f.measure
    else {
        unreachable!("only an ignored campaign has this command")
    };
    let args = [
        "--release",
        "-p",
        package,
        "--test",
        file,
        name,
        "--",
        "--exact",
        "--ignored",
        "--nocapture",
    ];
    let mut cmd = cargo(&["test"], &args);
    // The published run at its own seed, whatever the shell holds.
    cmd.env_remove(seed_var);
    let mut shown = String::new();
    for (k, v) in env.iter().chain(seed.map(|s| (seed_var, s)).as_ref()) {
        cmd.env(k, v);
        let _ = write!(shown, "{k}={v} ");
    }
    let _ = write!(shown, "cargo test {}", args.join(" "));
    (cmd, shown)
}

/// `args` with the value of `--seed` replaced by `seed` (or `--seed seed` appended).
fn with_seed(args: &[String], seed: Option<&str>) -> Vec<String> {
    let mut out = args.to_vec();
    if let Some(s) = seed {
        match out.iter().position(|a| a == "--seed") {
            Some(i) if i + 1 < out.len() => out[i + 1] = s.to_string(),
            _ => out.extend(["--seed".to_string(), s.to_string()]),
        }
    }
    out
}

/// Run `cmd` with its stdout and stderr in one pipe, echoed to ours as it goes (the
/// progress); what it printed and the wall time, or why it failed.
fn capture(mut cmd: Command) -> Result<(String, f64), String> {
    let (reader, writer) = std::io::pipe().map_err(|e| format!("cannot make a pipe: {e}"))?;
    let err = writer
        .try_clone()
        .map_err(|e| format!("cannot make a pipe: {e}"))?;
    cmd.stdout(writer).stderr(err);
    let t0 = std::time::Instant::now();
    let mut child = cmd
        .spawn()
        .map_err(|e| format!("cannot start cargo: {e}"))?;
    drop(cmd);
    let read = echo_and_keep(reader);
    if read.is_err() {
        let _ = child.kill();
    }
    let status = child.wait().map_err(|e| e.to_string())?;
    let all = read?;
    let seconds = t0.elapsed().as_secs_f64();
    if status.success() {
        Ok((all, seconds))
    } else {
        Err(format!(
            "the command failed ({status}): a claim not met, or the build failed (above)"
        ))
    }
}

/// Everything `reader` gives, echoed to our stderr line by line as it comes (bytes that are
/// not UTF-8 replaced).
fn echo_and_keep(reader: std::io::PipeReader) -> Result<String, String> {
    let mut reader = BufReader::new(reader);
    let mut all = String::new();
    let mut line = Vec::new();
    let mut echo = std::io::stderr().lock();
    loop {
        line.clear();
        let n = reader
            .read_until(b'\n', &mut line)
            .map_err(|e| format!("reading the command's output: {e}"))?;
        if n == 0 {
            return Ok(all);
        }
        let text = String::from_utf8_lossy(&line);
        let _ = echo.write_all(text.as_bytes());
        all.push_str(&text);
    }
}

/// What a test printed under libtest: the lines between `running 1 test` and
/// `test result:`, without the harness's own lines; a line rewritten with `\r` keeps its
/// last state.
fn test_output(all: &str) -> String {
    let mut keep = false;
    let mut out = Vec::new();
    for line in all.lines() {
        let mut line = line.rsplit('\r').next().unwrap_or(line);
        // With one test thread, libtest writes `test NAME ... ` before the test's output
        // and `ok` on a line of its own after it.
        if keep
            && line.starts_with("test ")
            && let Some((_, rest)) = line.split_once(" ... ")
        {
            line = rest;
        }
        if keep && line == "ok" {
            continue;
        }
        if line.starts_with("running ") && line.ends_with(" test") {
            keep = true;
        } else if line.starts_with("test result:") {
            keep = false;
        } else if keep
            && !(line.starts_with("test ")
                && (line.ends_with(" ... ok") || line.contains("has been running for over")))
        {
            out.push(line);
        }
    }
    while out.last().is_some_and(|l| l.trim().is_empty()) {
        out.pop();
    }
    out.join("\n")
}

/// An xtask check's report: its `ok` and `FAIL` lines, its totals, and the processor in
/// the loop's lines.
fn report_lines(all: &str) -> String {
    all.lines()
        .filter(|l| {
            l.starts_with("ok ")
                || l.starts_with("FAIL ")
                || l.ends_with(" failed")
                || l.starts_with("processor in the loop (QEMU), ")
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// A benchmark's report: its `bench:` lines.
fn bench_lines(all: &str) -> String {
    all.lines()
        .filter(|l| l.starts_with("bench"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// The number after `key` in `text` is at least `min`; else why not.
fn at_least(text: &str, key: &str, min: f64) -> Result<f64, String> {
    let value = text
        .lines()
        .find_map(|l| l.strip_prefix(key))
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|v| v.parse::<f64>().ok())
        .ok_or_else(|| format!("no `{key}` followed by a number in the output"))?;
    if value >= min {
        Ok(value)
    } else {
        Err(format!("{key}{value}: below the claimed {min}"))
    }
}

/// The machine, the commit and the time, read now.
fn machine() -> Machine {
    let read = |p: &str| std::fs::read_to_string(p).unwrap_or_default();
    let cpu = read("/proc/cpuinfo")
        .lines()
        .find_map(|l| l.strip_prefix("model name"))
        .map_or_else(
            || std::env::consts::ARCH.to_string(),
            |m| m.trim_start_matches([' ', '\t', ':']).to_string(),
        );
    let cores = std::thread::available_parallelism().map_or(0, std::num::NonZero::get);
    let load = read("/proc/loadavg")
        .split_whitespace()
        .take(3)
        .collect::<Vec<_>>()
        .join(" ");
    let first_line = |program: &str, args: &[&str]| {
        Command::new(program)
            .args(args)
            .current_dir(util::root())
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| {
                String::from_utf8_lossy(&o.stdout)
                    .lines()
                    .next()
                    .unwrap_or("")
                    .to_string()
            })
            .unwrap_or_default()
    };
    // Prose (the docs, the pages this run writes, any Markdown file) does not make the tree
    // dirty: it changes nothing the commands measure.
    let status = Command::new("git")
        .args(["status", "--porcelain", "--untracked-files=no", "--", "."])
        .args([":!docs", ":!*.md"])
        .current_dir(util::root())
        .output()
        .ok()
        .filter(|o| o.status.success());
    let commit = match (
        first_line("git", &["rev-parse", "--short=12", "HEAD"]),
        status,
    ) {
        (c, Some(o)) if !c.is_empty() => {
            let dirty = !o.stdout.is_empty();
            format!(
                "{c}{}",
                if dirty {
                    " with uncommitted changes"
                } else {
                    ""
                }
            )
        }
        _ => "unknown (git did not say)".to_string(),
    };
    Machine {
        date: humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string(),
        commit,
        cpu: format!("{cpu}, {cores} cores"),
        load: if load.is_empty() {
            "unknown".into()
        } else {
            load
        },
        rustc: first_line("rustc", &["-V"]),
    }
}

/// A figure's generated page.
fn page(f: &Figure, runs: &[Measured], m: &Machine) -> String {
    let mut s = format!(
        "# {}\n\n<!-- generated by `cargo xtask figures {}`: do not edit by hand -->\n\n\
         **Claim, asserted by the command:** {}.\n\n**Quoted in:** {}.\n\n",
        f.title, f.id, f.claim, f.quoted_in
    );
    s.push_str("| | |\n|---|---|\n");
    for (i, r) in runs.iter().enumerate() {
        let what = if i == 0 { "command" } else { "re-scored" };
        let _ = writeln!(
            s,
            "| {what} | `{}` ({:.0} s, build included) |",
            r.shown, r.seconds
        );
    }
    let _ = write!(
        s,
        "| result | passed: the command exited 0 |\n| started | {} |\n| commit | {} |\n\
         | machine | {}; load average {} at the start |\n| toolchain | {} |\n\
         | in every CI run | {} |\n",
        m.date,
        m.commit,
        m.cpu,
        m.load,
        m.rustc,
        ci_command(f)
    );
    for r in runs {
        let _ = write!(s, "\n## {}\n\n```text\n{}\n```\n", r.heading, r.text);
    }
    s
}

/// The command that runs a figure's CI subset, as a person would type it.
fn ci_command(f: &Figure) -> String {
    let (path, test) = f.ci;
    if path == "xtask ci" {
        return format!("`cargo xtask ci` runs `{test}` whole");
    }
    if Path::new(path).extension().is_some_and(|e| e == "py") {
        return format!("`cargo xtask python` runs `{test}` in `{path}` (a smaller subset)");
    }
    if let Measure::Test { name, .. } = f.measure
        && name == test
    {
        return "the same test, as it is".to_string();
    }
    let (package, file) = match path.split_once("/tests/") {
        Some((package, file)) => (package, file),
        None => ("ptsa-tests", path.trim_start_matches("tests/")),
    };
    format!(
        "`cargo test -p {package} --test {} {test}` (a smaller subset)",
        file.trim_end_matches(".rs")
    )
}

/// The index page: every figure, its claim, its command and when its page was measured.
fn index(dir: &Path) -> String {
    let mut s = String::from(
        "# Measured figures, generated\n\n\
         <!-- generated by `cargo xtask figures`: do not edit by hand -->\n\n\
         Each page below was written by `cargo xtask figures ID`, which runs a command that\n\
         asserts the claim and records what it printed, the date, the commit and the machine.\n\
         `cargo xtask figures` re-measures them all.\n\n\
         A rate \"in at most 5 %\" is asserted by a one-sided binomial test at the 1 % level:\n\
         the run fails when P(X >= k) for the count k under a 5 % rate is below 0.01. The\n\
         99 % binomial band is the central 99 % of Binomial(n, 0.95) for n intervals; a run\n\
         outside it fails. A seeded campaign is also re-scored at a seed chosen on the day\n\
         of the run, and must pass there too.\n\n\
         | figure | claim | command | measured |\n|---|---|---|---|\n",
    );
    for f in FIGURES {
        let path: PathBuf = dir.join(format!("{}.md", f.id));
        let (name, date) = match measured_on(&path) {
            Some(d) => (format!("[{}]({}.md)", f.id, f.id), d),
            None => (f.id.to_string(), "not yet".to_string()),
        };
        let _ = writeln!(s, "| {name} | {} | `{}` | {date} |", f.claim, shown(f));
    }
    s
}

/// The `measured` date of a page, if the page exists.
fn measured_on(path: &Path) -> Option<String> {
    let text = std::fs::read_to_string(path).ok()?;
    text.lines()
        .find_map(|l| l.strip_prefix("| started | "))
        .map(|d| d.trim_end_matches(" |").chars().take(10).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The index as `cargo xtask figures` writes it; `PTSA_WRITE_REFERENCE=1 cargo test -p
    /// xtask index` writes it again (after a page was removed, or a figure added).
    #[test]
    fn the_index_is_current() {
        let dir = util::root().join("docs").join("figures");
        // Set at all, as ptsa-host-sim's reference pages take it.
        if std::env::var_os("PTSA_WRITE_REFERENCE").is_some() {
            util::write_atomic(&dir.join("README.md"), &index(&dir)).expect("written");
        }
        let on_disk = std::fs::read_to_string(dir.join("README.md")).unwrap_or_default();
        assert_eq!(
            on_disk,
            index(&dir),
            "docs/figures/README.md is not what `cargo xtask figures` writes: PTSA_WRITE_REFERENCE=1 cargo test -p xtask index writes it again"
        );
    }

    /// A page written before its figure's claim or command changed is stale: run the
    /// figure again.
    #[test]
    fn every_page_holds_its_figures_claim_and_command() {
        let dir = util::root().join("docs").join("figures");
        for f in FIGURES {
            let Ok(page) = std::fs::read_to_string(dir.join(format!("{}.md", f.id))) else {
                continue;
            };
            assert!(
                page.contains(&format!("**Claim, asserted by the command:** {}.", f.claim))
                    && page.contains(&format!("`{}`", shown(f))),
                "docs/figures/{}.md is stale (its claim or command changed): run `cargo xtask figures {}`",
                f.id,
                f.id
            );
        }
    }

    #[test]
    fn every_campaign_has_a_figure_and_every_figure_its_ci_subset() {
        let root = util::root();
        for f in FIGURES {
            if let Measure::Hidden(args) = f.measure {
                let args: Vec<String> = args.iter().map(|s| (*s).to_string()).collect();
                assert!(hidden::parse(&args).is_ok(), "{}: {args:?}", f.id);
            }
            if f.ci.0 != "xtask ci" {
                let file = root.join(f.ci.0);
                let text = std::fs::read_to_string(&file).expect("the test file");
                let test = if Path::new(f.ci.0).extension().is_some_and(|e| e == "py") {
                    format!("\ndef {}(", f.ci.1)
                } else {
                    format!("#[test]\nfn {}() {{", f.ci.1)
                };
                assert!(
                    text.contains(&test),
                    "{}: no test `{}` that runs in CI in {}",
                    f.id,
                    f.ci.1,
                    file.display()
                );
            }
        }
        for name in hidden::campaign_names() {
            assert!(
                FIGURES.iter().any(|f| match f.measure {
                    Measure::Hidden(args) => {
                        let args: Vec<String> = args.iter().map(|s| (*s).to_string()).collect();
                        hidden::parse(&args).is_ok_and(|c| c.name() == name)
                    }
                    Measure::Xtask(_)
                    | Measure::Test { .. }
                    | Measure::Ignored { .. }
                    | Measure::Bench { .. } => false,
                }),
                "the campaign {name} has no published figure"
            );
        }
    }

    #[test]
    fn the_test_output_is_what_the_test_printed() {
        let all = "   Compiling x\n     Running tests/a.rs\n\nrunning 1 test\nset 1\rset 2\n| a | b |\ntest a_campaign has been running for over 60 seconds\ntest a_campaign ... ok\n\ntest result: ok. 1 passed\n";
        assert_eq!(test_output(all), "set 2\n| a | b |");
        let one_thread = "running 1 test\ntest a_campaign ... | a | b |\nline\nok\n\ntest result: ok. 1 passed\n";
        assert_eq!(test_output(one_thread), "| a | b |\nline");
        assert_eq!(
            report_lines("+ build\nok   vector a\nFAIL budget\nnoise\n2 passed, 1 failed\n"),
            "ok   vector a\nFAIL budget\n2 passed, 1 failed"
        );
    }

    #[test]
    fn a_ratio_below_its_claim_fails() {
        let text = "bench: x\nbench: Rust / C = 0.924\n";
        assert_eq!(at_least(text, "bench: Rust / C = ", 0.85), Ok(0.924));
        assert!(at_least(text, "bench: Rust / C = ", 0.95).is_err());
        assert!(at_least("bench: x", "bench: Rust / C = ", 0.5).is_err());
        let figure = |id: &str| FIGURES.iter().find(|f| f.id == id).unwrap();
        assert_eq!(
            ci_command(figure("hidden-lab")),
            "`cargo test -p ptsa-tests --test hidden_lab hidden_lab_ci` (a smaller subset)"
        );
        assert_eq!(
            ci_command(figure("bench-c")),
            "`cargo test -p ptsa-host-sim --test cli bench_compare_c_gives_the_same_pulses_bit_for_bit` (a smaller subset)"
        );
        assert_eq!(
            ci_command(figure("report-programme")),
            "the same test, as it is"
        );
    }

    #[test]
    fn a_rescore_replaces_the_seed() {
        let args: Vec<String> = ["--lab", "--seed", "7"].map(String::from).to_vec();
        assert_eq!(
            with_seed(&args, Some("20261129")),
            ["--lab", "--seed", "20261129"]
        );
        assert_eq!(with_seed(&args[..1], Some("5")), ["--lab", "--seed", "5"]);
        assert_eq!(with_seed(&args, None), args);
    }

    #[test]
    fn the_rescore_seed_is_a_date() {
        let s = today_seed();
        assert_eq!(s.len(), 8, "{s}");
        assert!(s.starts_with("20"), "{s}");
    }
}
