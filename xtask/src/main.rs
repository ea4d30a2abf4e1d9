//! Project automation. `cargo xtask <command> [options]`; `cargo xtask help` (or `--help`,
//! `-h`) prints what follows, `cargo xtask <command> --help` one command's part:
//!
//! * `ci [--no-firmware]` — everything CI runs: format and lint checks, rustdoc, ptsa-core
//!   as a crates.io package (`cargo package --list`, `cargo publish --dry-run`), the golden
//!   vectors, the C twin (also once in a fresh `CARGO_TARGET_DIR`), host tests, the
//!   thumbv7em cross build of ptsa-core, and (unless `--no-firmware`) the firmware under QEMU.
//! * `golden [--overwrite | --c-twin]` — regenerate `tests/golden/*` and check that the files
//!   are what the generator makes; `--overwrite` re-records them, `--c-twin` instead checks
//!   the C twin against every vector.
//! * `constants [--instrument FILE] [--check]` — write (or check) the firmware's generated
//!   constants, `firmware/src/constants.rs`, from an instrument file.
//! * `firmware [--vector NAME]...` — build the firmware and run the golden vectors (all, or
//!   the named ones) and the budgets on the emulated Cortex-M4.
//! * `pil --accel-cm-s2 A --seconds S --warmup-s W [--instrument FILE] [--json] [--compare]`
//!   — processor in the loop: the firmware's production tick handler around the pendulum
//!   stepped on the emulated MCU; the gates it counted.
//! * `hidden [--parameters | --statics [--additive] | --lab | --sigma | --calibration |
//!   --triad | --stability] [--sets N] [--seed S] [--analytic]` — the full hidden-effect campaign of the
//!   discovery pipeline, or with `--parameters` the hidden-parameter one, with `--statics` the
//!   hidden-statics one, with `--lab` the lab one, with `--sigma` the understated-sigma one,
//!   with `--calibration` the calibration-coverage one, with `--triad` the triad
//!   calibration's, with `--stability` the stability stage's false alarms, with
//!   `--noise-terms` the static records' noise terms.
//! * `figures [ID ...] [--list] [--rescore-seed S | --no-rescore]` — run the measurements
//!   the docs quote, each asserting its claim, and write `docs/figures/ID.md` for each.
//!
//! Before its first step, each command looks for everything it needs from the machine
//! (`needs`: QEMU, the thumbv7em target, rustfmt, clippy, a C compiler, python3 and its packages) and, if anything is
//! missing, names each missing thing with the command that installs it and exits 1. xtask
//! never installs anything itself; only `.ci/run`, on a throwaway CI machine, does.
//!
//! Exit status: 0 on success (and for help), 1 when a check fails or something the command
//! needs is missing, 2 for an unknown command or option (after printing the usage).

use std::process::ExitCode;

use util::Error;

mod ci;
mod constants;
mod figures;
mod firmware;
mod golden;
mod hidden;
mod needs;
mod pil;
mod python;
mod report_data;
mod util;

/// The commands: name and usage (first line the synopsis, then what it does).
const COMMANDS: [(&str, &str); 9] = [
    ("ci", ci::USAGE),
    ("golden", golden::USAGE),
    ("constants", constants::USAGE),
    ("firmware", firmware::USAGE),
    ("pil", pil::USAGE),
    ("python", python::USAGE),
    ("hidden", hidden::USAGE),
    ("figures", figures::USAGE),
    ("report-data", report_data::USAGE),
];

/// Top-level usage: every command with its options.
fn usage() -> String {
    let mut s = String::from(
        "usage: cargo xtask <command> [options]\n\
         \x20      cargo xtask help [<command>]   (also --help, -h; <command> --help)\n\n\
         commands:\n",
    );
    for (_, text) in COMMANDS {
        for line in text.lines() {
            s.push_str("  ");
            s.push_str(line);
            s.push('\n');
        }
        s.push('\n');
    }
    s.push_str(
        "before any work, each command looks for what it needs (QEMU, the thumbv7em target,\n\
         rustfmt, clippy, a C compiler, python3 and its packages) and, if any is missing, says how to install it and\n\
         stops; xtask installs nothing (only .ci/run does, on a throwaway CI machine)\n\n\
         exit status: 0 passed, 1 a check failed or something needed is missing, 2 unknown\n\
         command or option\n",
    );
    s
}

fn is_help(arg: &str) -> bool {
    matches!(arg, "--help" | "-h")
}

fn command_usage(cmd: &str) -> Option<&'static str> {
    COMMANDS
        .iter()
        .find(|(name, _)| *name == cmd)
        .map(|(_, text)| *text)
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some((cmd, rest)) = args.split_first() else {
        eprint!("{}", usage());
        return ExitCode::from(2);
    };
    if is_help(cmd) || (cmd == "help" && rest.is_empty()) {
        print!("{}", usage());
        return ExitCode::SUCCESS;
    }
    if cmd == "help" {
        return match command_usage(&rest[0]) {
            Some(text) if rest.len() == 1 => {
                println!("{text}");
                ExitCode::SUCCESS
            }
            _ => {
                eprintln!(
                    "xtask help: expected one of ci, golden, constants, firmware, pil, python, hidden, figures, report-data"
                );
                eprint!("{}", usage());
                ExitCode::from(2)
            }
        };
    }
    let Some(text) = command_usage(cmd) else {
        eprintln!("xtask: unknown command `{cmd}`");
        eprint!("{}", usage());
        return ExitCode::from(2);
    };
    if rest.iter().any(|a| is_help(a)) {
        println!("{text}");
        return ExitCode::SUCCESS;
    }
    let result = match cmd.as_str() {
        "ci" => ci::run(rest),
        "golden" => golden::run(rest),
        "constants" => constants::run(rest),
        "firmware" => firmware::run(rest),
        "pil" => pil::run(rest),
        "python" => python::run(rest),
        "hidden" => hidden::run(rest),
        "figures" => figures::run(rest),
        "report-data" => report_data::run(rest),
        other => Err(Error::Usage(format!("unknown command `{other}`"))),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Error::Usage(e)) => {
            eprintln!("xtask {cmd}: {e}");
            eprintln!("{text}");
            ExitCode::from(2)
        }
        Err(Error::Failed(e)) => {
            eprintln!("xtask {cmd}: {e}");
            ExitCode::FAILURE
        }
    }
}
