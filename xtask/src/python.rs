//! `cargo xtask python`: the Python package `ptsa` (python/) assembled in cargo's target
//! directory and tested there with pytest against the command line built from the same
//! tree.
//!
//! Nothing is installed: the package is put together in `target/python/site` and that
//! folder is put on `PYTHONPATH` for pytest only. By default its native module is the
//! cdylib cargo builds in the test profile, whose crates `cargo test` has already
//! compiled (seconds, in CI); `--wheel` builds the wheel with maturin in the release
//! profile, as `pip install ./python` does (minutes), and unpacks it there instead. The
//! Python is `$PTSA_PYTHON` (default `python3`), with numpy, pandas, pytest, matplotlib
//! and Ray (and maturin for `--wheel`).

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::needs::{self, Need};
use crate::util::{self, Error};

/// `cargo xtask python --help`.
pub const USAGE: &str = "\
python [--wheel]
    The Python package in python/ put together in target/python/site (nothing is
    installed) and its tests (python/tests, pytest) run against `ptsa` built from this
    tree. Its native module is cargo's build of python/ in the test profile (what
    `cargo test` has compiled already); --wheel: the wheel maturin builds in the release
    profile, as `pip install ./python` does, unpacked there instead (minutes more).
    The Python is $PTSA_PYTHON (default python3); it needs numpy, pandas, pytest,
    matplotlib and Ray (and maturin for --wheel), and if any is missing this says how to
    install them and stops.";

/// What the step needs from the machine (and `--wheel` maturin besides).
pub const NEEDS: [Need; 1] = [Need::PythonPackages];

/// Build, unpack and test the package.
///
/// # Errors
/// Bad arguments; a missing need; the build, the unpacking or a test fails.
pub fn run(args: &[String]) -> Result<(), Error> {
    let wheel = match args {
        [] => false,
        [a] if a == "--wheel" => true,
        [a] => return Err(Error::Usage(format!("unknown option `{a}`"))),
        _ => return Err(Error::Usage("expected at most --wheel".into())),
    };
    needs::check(&NEEDS, None)?;
    if wheel {
        needs::check(&[Need::Maturin], None)?;
    }
    let root = util::root();
    let target = util::target_dir()?;
    let python = python();
    let profile = if wheel { "release" } else { "test" };
    let ptsa = build_cli(&root, profile, &target)?;
    let site = target.join("python").join("site");
    if site.exists() {
        std::fs::remove_dir_all(&site).map_err(|e| format!("{}: {e}", site.display()))?;
    }
    if wheel {
        build_and_unpack(&root, &python, &target, &site)?;
    } else {
        assemble(&root, &target, &site)?;
    }
    test(&root, &python, &site, &ptsa)
}

/// The package from its sources: python/ptsa's files, and the cdylib cargo builds in the
/// test profile as its native module `_ptsa`.
fn assemble(root: &Path, target: &Path, site: &Path) -> Result<(), String> {
    util::run(
        root,
        &util::cargo(),
        &["build", "--profile", "test", "-p", "ptsa-python"],
    )?;
    let pkg = site.join("ptsa");
    std::fs::create_dir_all(&pkg).map_err(|e| format!("{}: {e}", pkg.display()))?;
    let src = root.join("python").join("ptsa");
    for e in std::fs::read_dir(&src).map_err(|e| format!("{}: {e}", src.display()))? {
        let p = e.map_err(|e| format!("{}: {e}", src.display()))?.path();
        if p.is_file() {
            let to = pkg.join(p.file_name().unwrap_or_default());
            std::fs::copy(&p, &to)
                .map_err(|e| format!("{} -> {}: {e}", p.display(), to.display()))?;
        }
    }
    let lib = target.join("debug").join("lib_ptsa.so");
    let to = pkg.join("_ptsa.abi3.so");
    std::fs::copy(&lib, &to).map_err(|e| format!("{} -> {}: {e}", lib.display(), to.display()))?;
    Ok(())
}

/// `$PTSA_PYTHON`, else `python3`.
pub fn python() -> String {
    std::env::var("PTSA_PYTHON").unwrap_or_else(|_| "python3".into())
}

/// The command line the tests compare with, built in `profile`; its path.
fn build_cli(root: &Path, profile: &str, target: &Path) -> Result<PathBuf, String> {
    let cargo = util::cargo();
    util::run(
        root,
        &cargo,
        &[
            "build",
            "--profile",
            profile,
            "-p",
            "ptsa-host-sim",
            "--bin",
            "ptsa",
        ],
    )?;
    let dir = if profile == "release" {
        "release"
    } else {
        "debug"
    };
    Ok(target.join(dir).join("ptsa"))
}

/// The wheel built by maturin in the release profile into `target/python/wheels`, then
/// unpacked into `site`.
fn build_and_unpack(root: &Path, python: &str, target: &Path, site: &Path) -> Result<(), String> {
    let wheels = target.join("python").join("wheels");
    if wheels.exists() {
        std::fs::remove_dir_all(&wheels).map_err(|e| format!("{}: {e}", wheels.display()))?;
    }
    let wheels_s = wheels.to_string_lossy().into_owned();
    util::run(
        &root.join("python"),
        python,
        &[
            "-m",
            "maturin",
            "build",
            "--release",
            "--interpreter",
            python,
            "--out",
            &wheels_s,
        ],
    )?;
    let wheel = std::fs::read_dir(&wheels)
        .map_err(|e| format!("{}: {e}", wheels.display()))?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|x| x == "whl"))
        .ok_or_else(|| format!("maturin wrote no wheel into {}", wheels.display()))?;
    let (wheel_s, site_s) = (
        wheel.to_string_lossy().into_owned(),
        site.to_string_lossy().into_owned(),
    );
    util::run(root, python, &["-m", "zipfile", "-e", &wheel_s, &site_s])
}

/// pytest on python/tests with the unpacked package first on the path.
fn test(root: &Path, python: &str, site: &Path, ptsa: &Path) -> Result<(), Error> {
    eprintln!(
        "+ PYTHONPATH={} {python} -m pytest python/tests",
        site.display()
    );
    let status = Command::new(python)
        .args([
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            "python/tests",
        ])
        .env("PYTHONPATH", site)
        .env("PTSA_BIN", ptsa)
        .current_dir(root)
        .status()
        .map_err(|e| format!("cannot start `{python}`: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("the Python package's tests failed ({status})").into())
    }
}
