//! Project automation. `cargo xtask <command>`:
//!
//! * `ci` — everything CI runs: format and lint checks, rustdoc, host tests, the
//!   thumbv7em cross build of ptsa-core, and the firmware under QEMU.
//! * `golden [--overwrite]` — regenerate `tests/golden/*.in` and check (or, with
//!   `--overwrite`, re-record) `tests/golden/*.out`.
//! * `firmware [--overwrite]` — build the firmware and run the golden vectors and budgets on
//!   the emulated Cortex-M4.
//! * `hidden [--sets N]` — the full hidden-effect campaign of the discovery pipeline.

use std::process::ExitCode;

mod ci;
mod firmware;
mod golden;
mod hidden;
mod util;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some((cmd, rest)) = args.split_first() else {
        eprintln!("usage: cargo xtask <ci|golden|firmware|hidden> [options]");
        return ExitCode::from(2);
    };
    let result = match cmd.as_str() {
        "ci" => ci::run(rest),
        "golden" => golden::run(rest),
        "firmware" => firmware::run(rest),
        "hidden" => hidden::run(rest),
        other => Err(format!(
            "unknown command `{other}`; expected ci, golden, firmware or hidden"
        )),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask {cmd}: {e}");
            ExitCode::FAILURE
        }
    }
}
