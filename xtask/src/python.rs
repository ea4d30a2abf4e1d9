//! `cargo xtask python`: the Python package `ptsa` (python/) assembled in cargo's target
//! directory and tested there with pytest against the command line built from the same
//! tree.
//!
//! Nothing is installed: the package is put together in `target/python/site` and that
//! folder is put on `PYTHONPATH` for pytest only. By default its native module is the
//! cdylib of the workspace's test build, exactly as the host tests built it (nothing
//! compiled again, in CI); `--wheel` builds the wheel with maturin in the release
//! profile, as `pip install ./python` does (minutes), and unpacks it there instead. The
//! Python is `$PTSA_PYTHON` (default `python3`), with numpy, pandas, pytest, matplotlib
//! and Ray (and maturin for `--wheel`).

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::needs::{self, Need};
use crate::util::{self, Error};

/// `cargo xtask python --help`.
pub const USAGE: &str = "\
python [--wheel] [--bench [ARGS...]]
    The Python package in python/ put together in target/python/site (nothing is
    installed) and its tests (python/tests, pytest) run against `ptsa` built from this
    tree. Its native module is python/'s cdylib from `cargo build --profile test
    --workspace --all-targets` (what the host tests have compiled already, so after them
    only the cdylib is linked); --wheel: the wheel maturin builds in the release profile, as
    `pip install ./python` does, unpacked there instead (minutes more).
    --bench: instead of the tests, `python -m ptsa.campaign bench ARGS` on the wheel (the
    yield study on a local Ray of 1 and of 2 CPUs: medians and speed-up; --bench implies
    --wheel, the build a user installs).
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
    let (wheel, bench) = parse(args)?;
    needs::check(&NEEDS, None)?;
    if wheel {
        needs::check(&[Need::Maturin], None)?;
    }
    let root = util::root();
    let target = util::target_dir()?;
    let python = python();
    let site = target.join("python").join("site");
    if site.exists() {
        std::fs::remove_dir_all(&site).map_err(|e| format!("{}: {e}", site.display()))?;
    }
    let ptsa = if wheel {
        build_and_unpack(&root, &python, &target, &site)?;
        build_cli(&root, &target)?
    } else {
        let built = test_build(&root)?;
        assemble(&root, &built.cdylib, &site)?;
        built.ptsa
    };
    match bench {
        Some(args) => run_bench(&root, &python, &site, args),
        None => test(&root, &python, &site, &ptsa),
    }
}

/// `--wheel` and `--bench ARGS` (which implies `--wheel`).
fn parse(args: &[String]) -> Result<(bool, Option<&[String]>), Error> {
    let mut wheel = false;
    for (k, a) in args.iter().enumerate() {
        match a.as_str() {
            "--wheel" => wheel = true,
            "--bench" => return Ok((true, Some(&args[k + 1..]))),
            _ => {
                return Err(Error::Usage(format!(
                    "unknown option `{a}`: expected --wheel or --bench [ARGS...]"
                )));
            }
        }
    }
    Ok((wheel, None))
}

/// `python -m ptsa.campaign bench ARGS` on the package in `site`.
fn run_bench(root: &Path, python: &str, site: &Path, args: &[String]) -> Result<(), Error> {
    let mut argv = vec!["-m", "ptsa.campaign", "bench"];
    argv.extend(args.iter().map(String::as_str));
    run_python(root, python, site, &argv, &[])
        .map_err(|status| format!("the Ray benchmark failed ({status})").into())
}

/// `python ARGV` with the package in `site` first on the path and `env` set, echoed first.
fn run_python(
    root: &Path,
    python: &str,
    site: &Path,
    argv: &[&str],
    env: &[(&str, &Path)],
) -> Result<(), String> {
    eprintln!(
        "+ PYTHONPATH={} {python} {}",
        site.display(),
        argv.join(" ")
    );
    let status = Command::new(python)
        .args(argv)
        .env("PYTHONPATH", site)
        .envs(env.iter().copied())
        .current_dir(root)
        .status()
        .map_err(|e| format!("cannot start `{python}`: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(status.to_string())
    }
}

/// The test build's artifacts the package needs.
struct TestBuild {
    /// The native module: python/'s cdylib.
    cdylib: PathBuf,
    /// The command line the tests compare with.
    ptsa: PathBuf,
}

/// The workspace's test build as `cargo test --workspace --all-targets` makes it (the
/// same packages, targets, features and profile, so that after the host tests only
/// python/'s cdylib is linked: `cargo test` builds it as a test harness alone), and the two
/// artifacts the package's tests need, from cargo's messages.
fn test_build(root: &Path) -> Result<TestBuild, String> {
    let cargo = util::cargo();
    let args = [
        "build",
        "--profile",
        "test",
        "--workspace",
        "--all-targets",
        "--message-format=json-render-diagnostics",
    ];
    eprintln!("+ {cargo} {}", args.join(" "));
    let out = Command::new(&cargo)
        .args(args)
        .current_dir(root)
        .stderr(std::process::Stdio::inherit())
        .output()
        .map_err(|e| format!("cannot start `{cargo}`: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "`{cargo} {}` failed ({})",
            args.join(" "),
            out.status
        ));
    }
    let (mut cdylib, mut ptsa) = (None, None);
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let Ok(m) = serde_json::from_str::<serde_json::Value>(line) else {
            continue;
        };
        if m["reason"] != "compiler-artifact" || m["profile"]["test"] == true {
            continue;
        }
        let kinds = &m["target"]["kind"];
        let first = |key: &str| m[key].as_array()?.first()?.as_str().map(PathBuf::from);
        if kinds
            .as_array()
            .is_some_and(|k| k.iter().any(|k| k == "cdylib"))
            && m["target"]["name"] == "_ptsa"
        {
            cdylib = first("filenames");
        } else if m["target"]["name"] == "ptsa" && kinds[0] == "bin" {
            ptsa = m["executable"].as_str().map(PathBuf::from);
        }
    }
    Ok(TestBuild {
        cdylib: cdylib.ok_or("cargo's test build made no cdylib for python/ (_ptsa)")?,
        ptsa: ptsa.ok_or("cargo's test build made no `ptsa` executable")?,
    })
}

/// The package from its sources: python/ptsa's files, and `cdylib` as its native module
/// `_ptsa`.
fn assemble(root: &Path, cdylib: &Path, site: &Path) -> Result<(), String> {
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
    let to = pkg.join("_ptsa.abi3.so");
    std::fs::copy(cdylib, &to)
        .map_err(|e| format!("{} -> {}: {e}", cdylib.display(), to.display()))?;
    Ok(())
}

/// `$PTSA_PYTHON`, else `python3`.
pub fn python() -> String {
    std::env::var("PTSA_PYTHON").unwrap_or_else(|_| "python3".into())
}

/// The release command line the wheel's tests compare with; its path.
fn build_cli(root: &Path, target: &Path) -> Result<PathBuf, String> {
    util::run(
        root,
        &util::cargo(),
        &["build", "--release", "-p", "ptsa-host-sim", "--bin", "ptsa"],
    )?;
    Ok(target.join("release").join("ptsa"))
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
    let argv = [
        "-m",
        "pytest",
        "-q",
        "-p",
        "no:cacheprovider",
        "python/tests",
    ];
    run_python(root, python, site, &argv, &[("PTSA_BIN", ptsa)])
        .map_err(|status| format!("the Python package's tests failed ({status})").into())
}
