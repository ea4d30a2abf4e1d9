//! `cargo xtask ci`: everything CI runs, in order, stopping at the first failure.

use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

use crate::needs::{self, Need};
use crate::util::{self, Error};
use crate::{firmware, golden, pil, python};

/// `cargo xtask ci --help`.
pub const USAGE: &str = "\
ci [--no-firmware]
    Everything CI runs, in order, stopping at the first failure: rustfmt, clippy (all
    targets, warnings denied), rustdoc (warnings denied), ptsa-core as a crates.io package
    (`cargo package --list`, its README's links in it, `cargo publish --dry-run`), the
    golden vectors, the C twin (in cargo's target directory, then again in a fresh
    temporary CARGO_TARGET_DIR), host tests and doctests, the Python package's tests
    (`python`), ptsa-core built for
    thumbv7em-none-eabihf without defmt (with defmt by the firmware's build, or on its
    own with --no-firmware), the firmware checks of `firmware`
    (QEMU) and the three short processor-in-the-loop cases of `pil --ci` (QEMU: a static
    input without and with the pickoff noise, a sine), whose gates must be the host's bit
    for bit. The host tests include the freshness check of the
    firmware's generated constants (`cargo xtask constants`).
    Needs rustfmt, clippy, a C compiler, python3 (and $PTSA_PYTHON with numpy, pandas,
    pytest, matplotlib and Ray), the thumbv7em-none-eabihf target and (unless
    --no-firmware) qemu-system-arm; it looks for all of them first and, if any is
    missing, says how to install each and stops (it installs nothing; `.ci/run` does, on
    a throwaway CI machine). The dry-run publish needs crates.io over the network.
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
    check_needs(skip_firmware)?;
    let ci = Steps {
        root: util::root(),
        cargo: util::cargo(),
        t0: Instant::now(),
    };

    ci.format_and_lints()?;

    ci.step("ptsa-core as a crates.io package (its files, then a dry-run publish that builds it)");
    package_ptsa_core(&ci.root, &ci.cargo)?;

    ci.step("golden vectors are what the generator makes");
    golden::run(&[])?;

    ci.step("C twin written from ARITHMETIC.md agrees with every golden vector");
    golden::check_c_twin()?;

    ci.step("C twin again, with CARGO_TARGET_DIR set to a directory that does not exist yet");
    c_twin_in_fresh_target_dir()?;

    ci.step("host tests (optimised test profile, overflow checks on)");
    // A test that cannot run on this machine (a SIMD level the CPU lacks) writes a line
    // here; the summary at the end lists it with the tests that are ignored by design.
    let skipped = util::target_dir()?.join("ci-skipped.txt");
    let _ = std::fs::remove_file(&skipped);
    host_tests(&ci.root, &ci.cargo, &skipped)?;

    ci.step("the Python package: python/tests (pytest) against the command line");
    python::run(&[])?;

    ci.cross_build(skip_firmware)?;

    if skip_firmware {
        eprintln!("\n(firmware checks skipped by --no-firmware)");
    } else {
        ci.step("firmware on the emulated STM32F405 (QEMU)");
        firmware::ci()?;
        ci.step(
            "processor in the loop (QEMU): static, static with noise, sine; gate for gate against the host",
        );
        eprintln!("{}", pil::ci()?);
    }

    eprintln!("\nci passed in {:.0} s", ci.t0.elapsed().as_secs_f64());
    eprintln!("{}", not_run(&ci.root, &ci.cargo, &skipped, skip_firmware));
    Ok(())
}

/// What the steps share: the workspace's root, the cargo that runs them, and when the run
/// began (each step's heading says the seconds since).
struct Steps {
    /// The workspace's root, where every cargo command runs.
    root: PathBuf,
    /// The cargo to run (`$CARGO`, else `cargo`).
    cargo: String,
    /// When the run began.
    t0: Instant,
}

impl Steps {
    /// The heading of the step `name`, with the seconds since the run began.
    fn step(&self, name: &str) {
        eprintln!("\n== {name} ({:.0} s)", self.t0.elapsed().as_secs_f64());
    }

    /// `cargo args` in the workspace's root, echoed; an error when it fails.
    fn run_cargo(&self, args: &[&str]) -> Result<(), String> {
        util::run(&self.root, &self.cargo, args)
    }

    /// The format and lint steps: rustfmt, clippy on all targets and rustdoc, warnings
    /// denied.
    fn format_and_lints(&self) -> Result<(), Error> {
        self.step("rustfmt");
        self.run_cargo(&["fmt", "--all", "--", "--check"])?;

        self.step("clippy (all targets, warnings denied)");
        self.run_cargo(&[
            "clippy",
            "--workspace",
            "--all-targets",
            "--",
            "-D",
            "warnings",
        ])?;

        self.step("rustdoc (warnings denied)");
        let status = Command::new(&self.cargo)
            .args(["doc", "--workspace", "--no-deps"])
            .env("RUSTDOCFLAGS", "-D warnings")
            .current_dir(&self.root)
            .status()
            .map_err(|e| format!("cannot run cargo doc: {e}"))?;
        if !status.success() {
            return Err(format!("cargo doc failed ({status})").into());
        }
        Ok(())
    }

    /// ptsa-core built for the Cortex-M4F without defmt, and with it when the firmware,
    /// which builds it so, is skipped.
    fn cross_build(&self, skip_firmware: bool) -> Result<(), Error> {
        // With defmt it is built again by the firmware (its dependency has the feature on),
        // so only without the firmware checks is that build a step of its own.
        self.step(if skip_firmware {
            "ptsa-core for the Cortex-M4F, with and without defmt"
        } else {
            "ptsa-core for the Cortex-M4F without defmt (with it: in the firmware's build)"
        });
        self.run_cargo(&["build", "-p", "ptsa-core", "--target", THUMB])?;
        if skip_firmware {
            self.run_cargo(&[
                "build",
                "-p",
                "ptsa-core",
                "--target",
                THUMB,
                "--features",
                "defmt",
            ])?;
        }
        Ok(())
    }
}

/// The workspace's tests and doctests, with `PTSA_SKIPPED` naming `skipped`.
fn host_tests(
    root: &std::path::Path,
    cargo: &str,
    skipped: &std::path::Path,
) -> Result<(), String> {
    for args in [
        &["test", "--workspace", "--all-targets"][..],
        &["test", "--workspace", "--doc"],
    ] {
        eprintln!(
            "+ PTSA_SKIPPED={} {cargo} {}",
            skipped.display(),
            args.join(" ")
        );
        let status = Command::new(cargo)
            .args(args)
            .env("PTSA_SKIPPED", skipped)
            .current_dir(root)
            .status()
            .map_err(|e| format!("cannot start `{cargo}`: {e}"))?;
        if !status.success() {
            return Err(format!("`{cargo} {}` failed ({status})", args.join(" ")));
        }
    }
    Ok(())
}

/// What this run did not run, and why: the tests that could not run on this machine, the
/// tests ignored by design (the campaigns, run by `cargo xtask hidden` and
/// `cargo test -- --ignored NAME`), the firmware when skipped.
fn not_run(
    root: &std::path::Path,
    cargo: &str,
    skipped: &std::path::Path,
    no_firmware: bool,
) -> String {
    let mut lines: Vec<String> = std::fs::read_to_string(skipped)
        .unwrap_or_default()
        .lines()
        .map(|l| format!("  skipped, {l}"))
        .collect();
    lines.sort();
    lines.dedup();
    let listed = Command::new(cargo)
        .args([
            "test",
            "-q",
            "--workspace",
            "--all-targets",
            "--",
            "--list",
            "--ignored",
        ])
        .current_dir(root)
        .stderr(std::process::Stdio::null())
        .output();
    let mut ignored: Vec<String> = match listed {
        Ok(o) => String::from_utf8_lossy(&o.stdout)
            .lines()
            .filter_map(|l| l.strip_suffix(": test"))
            .map(str::to_string)
            .collect(),
        Err(e) => vec![format!("(cannot list them: {e})")],
    };
    ignored.sort();
    ignored.dedup();
    if !ignored.is_empty() {
        lines.push(format!(
            "  ignored by design ({}; the campaigns run in CI as smaller subsets; the full runs are `cargo xtask hidden ...`, the others `cargo test --release -- --ignored NAME`): {}",
            ignored.len(),
            ignored.join(", ")
        ));
    }
    if no_firmware {
        lines.push("  the firmware checks and processor in the loop (--no-firmware)".into());
    }
    if lines.is_empty() {
        "not run: nothing".into()
    } else {
        format!("not run in this run:\n{}", lines.join("\n"))
    }
}

/// Everything the steps of `ci` need, looked for before the first one runs.
fn check_needs(skip_firmware: bool) -> Result<(), Error> {
    let mut wanted = vec![
        Need::Rustfmt,
        Need::Clippy,
        Need::CCompiler,
        Need::Thumb,
        Need::Python,
        Need::PythonPackages,
    ];
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

/// `cargo package -p ptsa-core --list` (and every file its README links to is in the list),
/// then `cargo publish --dry-run -p ptsa-core` (packs, builds the packed crate on its own,
/// checks its dependencies against crates.io; uploads nothing).
///
/// On a tree whose ptsa-core has uncommitted changes (a developer's, before committing) both
/// get `--allow-dirty`, with a warning: cargo refuses such a tree otherwise. CI's fresh
/// checkout is clean, so there the package is made from the commit, without the flag.
fn package_ptsa_core(root: &std::path::Path, cargo: &str) -> Result<(), String> {
    let dirty = uncommitted(root, &["ptsa-core", "Cargo.toml"]);
    let allow: &[&str] = if dirty.is_empty() {
        &[]
    } else {
        eprintln!(
            "warning: uncommitted changes in {} (and maybe more): packaging the working tree \
             with --allow-dirty (a clean checkout, as in CI, needs no flag)",
            dirty.join(", ")
        );
        &["--allow-dirty"]
    };
    let list_args = [&["package", "-p", "ptsa-core", "--list"][..], allow].concat();
    eprintln!("+ {cargo} {}", list_args.join(" "));
    let out = Command::new(cargo)
        .args(&list_args)
        .current_dir(root)
        .stderr(std::process::Stdio::inherit())
        .output()
        .map_err(|e| format!("cannot run cargo package: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "`cargo {}` failed ({})",
            list_args.join(" "),
            out.status
        ));
    }
    let list = String::from_utf8_lossy(&out.stdout);
    let readme_path = root.join("ptsa-core").join("README.md");
    let readme = std::fs::read_to_string(&readme_path)
        .map_err(|e| format!("cannot read {}: {e}", readme_path.display()))?;
    let absent = links_not_in_package(&readme, &list);
    if !absent.is_empty() {
        return Err(format!(
            "ptsa-core/README.md links to {} but the package does not contain {} (link by \
             repository path instead, or include the file)",
            absent.join(", "),
            if absent.len() == 1 { "it" } else { "them" }
        ));
    }
    eprintln!(
        "ptsa-core package: {} files, README's links all inside",
        list.lines().count()
    );
    let publish_args = [&["publish", "--dry-run", "-p", "ptsa-core"][..], allow].concat();
    util::run(root, cargo, &publish_args)
}

/// Paths among `paths` (relative to `root`) with uncommitted changes or untracked files, by
/// `git status --porcelain`; none when git is not there or `root` is not a repository.
fn uncommitted(root: &std::path::Path, paths: &[&str]) -> Vec<String> {
    let out = Command::new("git")
        .args(["status", "--porcelain", "--untracked-files=all", "--"])
        .args(paths)
        .current_dir(root)
        .stderr(std::process::Stdio::null())
        .output();
    match out {
        Ok(o) if o.status.success() => String::from_utf8_lossy(&o.stdout)
            .lines()
            .filter_map(|l| l.get(3..))
            .map(str::to_string)
            .collect(),
        _ => Vec::new(),
    }
}

/// The relative link targets of a Markdown text (`[text](target)`, without an anchor) that
/// are not lines of `list` (`cargo package --list`'s output). Links with a scheme
/// (`https:`, `mailto:`) and anchors within the page are not files of the package.
fn links_not_in_package(markdown: &str, list: &str) -> Vec<String> {
    let files: Vec<&str> = list.lines().map(str::trim).collect();
    let mut absent = Vec::new();
    let mut rest = markdown;
    while let Some(i) = rest.find("](") {
        rest = &rest[i + 2..];
        let Some(end) = rest.find(')') else { break };
        let target = rest[..end].split('#').next().unwrap_or("").trim();
        rest = &rest[end..];
        if target.is_empty() || target.contains(':') {
            continue;
        }
        let path = target.trim_start_matches("./");
        if !files.contains(&path) && !absent.iter().any(|a: &String| a == path) {
            absent.push(path.to_string());
        }
    }
    absent
}

#[cfg(test)]
mod tests {
    use super::links_not_in_package;

    #[test]
    fn readme_links_are_checked_against_the_package_list() {
        let md = "See [ARITHMETIC.md](ARITHMETIC.md), [twin](./c-twin/ptsa_twin.c#L3), \
                  [site](https://example.org/x), [top](#the-tick-api), [v](../tests/golden) \
                  and [again](ARITHMETIC.md) and [gone](docs/x.md).";
        let list = "Cargo.toml\nARITHMETIC.md\nc-twin/ptsa_twin.c\nsrc/lib.rs\n";
        assert_eq!(
            links_not_in_package(md, list),
            ["../tests/golden", "docs/x.md"]
        );
        assert!(links_not_in_package("no links [here] (at all)", list).is_empty());
    }

    #[test]
    fn the_shipped_readme_links_only_to_files_that_exist_in_the_crate() {
        // The list here is the crate's files on disk: `ci` checks against cargo's own list.
        let dir = crate::util::root().join("ptsa-core");
        let md = std::fs::read_to_string(dir.join("README.md")).unwrap();
        let mut files = String::new();
        for link in links_not_in_package(&md, "") {
            assert!(dir.join(&link).is_file(), "README links to missing {link}");
            files.push_str(&link);
            files.push('\n');
        }
        assert!(links_not_in_package(&md, &files).is_empty());
        assert!(files.contains("ARITHMETIC.md"), "{files}");
    }
}
