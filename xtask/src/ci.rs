//! `cargo xtask ci`: everything CI runs, in order, stopping at the first failure.

use std::process::Command;
use std::time::Instant;

use crate::{firmware, golden, util};

/// The embedded target of the firmware and of the ptsa-core cross build (installed with the
/// toolchain: `rust-toolchain.toml`).
pub const THUMB: &str = "thumbv7em-none-eabihf";

/// Run everything CI runs.
pub fn run(args: &[String]) -> Result<(), String> {
    let skip_firmware = match args {
        [] => false,
        [a] if a == "--no-firmware" => true,
        _ => return Err("usage: cargo xtask ci [--no-firmware]".into()),
    };
    let root = util::root();
    let cargo = util::cargo();
    let t0 = Instant::now();
    let step = |name: &str| eprintln!("\n== {name} ({:.0} s)", t0.elapsed().as_secs_f64());

    step("rustfmt");
    util::run(&root, &cargo, &["fmt", "--all", "--", "--check"])?;

    step("clippy (all targets, warnings denied)");
    util::run(
        &root,
        &cargo,
        &[
            "clippy",
            "--workspace",
            "--all-targets",
            "--",
            "-D",
            "warnings",
        ],
    )?;

    step("rustdoc (warnings denied)");
    let status = Command::new(&cargo)
        .args(["doc", "--workspace", "--no-deps"])
        .env("RUSTDOCFLAGS", "-D warnings")
        .current_dir(&root)
        .status()
        .map_err(|e| format!("cannot run cargo doc: {e}"))?;
    if !status.success() {
        return Err(format!("cargo doc failed ({status})"));
    }

    step("golden vectors are what the generator makes");
    golden::run(&[])?;

    step("C twin written from ARITHMETIC.md agrees with every golden vector");
    golden::check_c_twin()?;

    step("host tests (optimised test profile, overflow checks on)");
    util::run(&root, &cargo, &["test", "--workspace", "--all-targets"])?;
    util::run(&root, &cargo, &["test", "--workspace", "--doc"])?;

    step("ptsa-core for the Cortex-M4F, with and without defmt");
    util::run(
        &root,
        &cargo,
        &["build", "-p", "ptsa-core", "--target", THUMB],
    )?;
    util::run(
        &root,
        &cargo,
        &[
            "build",
            "-p",
            "ptsa-core",
            "--target",
            THUMB,
            "--features",
            "defmt",
        ],
    )?;

    if skip_firmware {
        eprintln!("\n(firmware checks skipped by --no-firmware)");
    } else {
        step("firmware on the emulated STM32F405 (QEMU)");
        firmware::ci()?;
    }

    eprintln!("\nci passed in {:.0} s", t0.elapsed().as_secs_f64());
    Ok(())
}
