//! `cargo xtask ci`: everything CI runs, in order, stopping at the first failure.

use std::process::Command;
use std::time::Instant;

use crate::needs::{self, Need};
use crate::util::{self, Error};
use crate::{firmware, golden};

/// `cargo xtask ci --help`.
pub const USAGE: &str = "\
ci [--no-firmware]
    Everything CI runs, in order, stopping at the first failure: rustfmt, clippy (all
    targets, warnings denied), rustdoc (warnings denied), the golden vectors, the C twin
    (in cargo's target directory, then again in a fresh temporary CARGO_TARGET_DIR), host
    tests and doctests, ptsa-core built for thumbv7em-none-eabihf with and without defmt,
    and the firmware checks of `firmware` (QEMU).
    Needs rustfmt, clippy, a C compiler, the thumbv7em-none-eabihf target and (unless
    --no-firmware) qemu-system-arm; it looks for all of them first and, if any is
    missing, says how to install each and stops (it installs nothing; `.ci/run` does, on
    a throwaway CI machine).
    --no-firmware  skip the firmware checks (no QEMU needed)";

/// The embedded target of the firmware and of the ptsa-core cross build (installed with the
/// toolchain: `rust-toolchain.toml`).
pub const THUMB: &str = "thumbv7em-none-eabihf";

/// Run everything CI runs.
pub fn run(args: &[String]) -> Result<(), Error> {
    let skip_firmware = match args {
        [] => false,
        [a] if a == "--no-firmware" => true,
        [a] => return Err(Error::Usage(format!("unknown option `{a}`"))),
        _ => return Err(Error::Usage("expected at most --no-firmware".into())),
    };
    // Everything the steps below need, looked for before the first one runs.
    let mut wanted = vec![Need::Rustfmt, Need::Clippy, Need::CCompiler, Need::Thumb];
    if !skip_firmware {
        for need in firmware::NEEDS {
            if !wanted.contains(&need) {
                wanted.push(need);
            }
        }
    }
    needs::check(
        &wanted,
        Some((
            Need::Qemu,
            "`cargo xtask ci --no-firmware` skips the firmware checks, and QEMU with them",
        )),
    )?;
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
        return Err(format!("cargo doc failed ({status})").into());
    }

    step("golden vectors are what the generator makes");
    golden::run(&[])?;

    step("C twin written from ARITHMETIC.md agrees with every golden vector");
    golden::check_c_twin()?;

    step("C twin again, with CARGO_TARGET_DIR set to a directory that does not exist yet");
    c_twin_in_fresh_target_dir()?;

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

/// Run `golden --c-twin` in a child xtask whose `CARGO_TARGET_DIR` is a directory that does
/// not exist yet (inside a fresh temporary one), so that xtask's own writes into cargo's
/// target directory keep working wherever that is. Cheap: the child is this executable,
/// and only the C twin is compiled there.
fn c_twin_in_fresh_target_dir() -> Result<(), String> {
    let exe = std::env::current_exe().map_err(|e| format!("cannot find xtask itself: {e}"))?;
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    let tmp = std::env::temp_dir().join(format!("ptsa-xtask-{}-{nanos}", std::process::id()));
    std::fs::create_dir(&tmp).map_err(|e| format!("cannot create {}: {e}", tmp.display()))?;
    let target = tmp.join("target");
    eprintln!(
        "+ CARGO_TARGET_DIR={} cargo xtask golden --c-twin",
        target.display()
    );
    let status = Command::new(exe)
        .args(["golden", "--c-twin"])
        .env("CARGO_TARGET_DIR", &target)
        .current_dir(util::root())
        .status();
    let written = target.join("c-twin").join("ptsa_twin").is_file();
    let _ = std::fs::remove_dir_all(&tmp);
    let status = status.map_err(|e| format!("cannot run xtask again: {e}"))?;
    if !status.success() {
        return Err(format!(
            "`golden --c-twin` with CARGO_TARGET_DIR={} failed ({status})",
            target.display()
        ));
    }
    if !written {
        return Err(format!(
            "`golden --c-twin` passed but did not build the twin in CARGO_TARGET_DIR={}",
            target.display()
        ));
    }
    Ok(())
}
