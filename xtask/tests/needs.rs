//! `cargo xtask` looks for what a command needs before doing anything, names what is missing
//! with the command that installs it, exits 1, and installs nothing itself.
//!
//! Each test runs the xtask executable with a `PATH` that cannot hold `qemu-system-arm` (the
//! directories of this `PATH` that hold it are left out), in front of which fake `apt-get`,
//! `apt`, `sudo`, `dpkg` and `id` record every call (`id` answers 0: root, as on the lab
//! machine where xtask used to run `apt-get install` itself).

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A scratch directory with the recording fakes, removed when dropped.
struct Fakes(PathBuf);

impl Fakes {
    fn new(tag: &str) -> Self {
        use std::os::unix::fs::PermissionsExt as _;
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        let dir = std::env::temp_dir().join(format!(
            "ptsa-xtask-test-{tag}-{}-{nanos}",
            std::process::id()
        ));
        std::fs::create_dir_all(&dir).unwrap();
        let log = dir.join("calls");
        for name in ["apt-get", "apt", "sudo", "dpkg", "id"] {
            // Shell built-ins only: the PATH may lack the usual tools.
            let answer = if name == "id" { "echo 0\n" } else { "" };
            let script = format!("#!/bin/sh\necho \"$0 $*\" >> '{}'\n{answer}", log.display());
            let p = dir.join(name);
            std::fs::write(&p, script).unwrap();
            std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o755)).unwrap();
        }
        Self(dir)
    }

    /// What the fakes were asked to do (empty when nothing called them).
    fn calls(&self) -> String {
        std::fs::read_to_string(self.0.join("calls")).unwrap_or_default()
    }

    /// The fakes' directory, then this process's `PATH` without the directories that hold
    /// `qemu-system-arm`.
    fn path_without_qemu(&self) -> OsString {
        let here = std::env::var_os("PATH").unwrap_or_default();
        let dirs = std::iter::once(self.0.clone())
            .chain(std::env::split_paths(&here).filter(|d| !d.join("qemu-system-arm").exists()));
        let path = std::env::join_paths(dirs).unwrap();
        assert!(
            std::env::split_paths(&path).all(|d| !d.join("qemu-system-arm").exists()),
            "the test PATH must not hold qemu-system-arm"
        );
        path
    }

    /// Run `cargo xtask <args>` (the built executable) with that `PATH`.
    fn xtask(&self, args: &[&str], env: &[(&str, &str)]) -> Output {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_xtask"));
        cmd.args(args)
            .env("PATH", self.path_without_qemu())
            .env_remove("CC");
        for (k, v) in env {
            cmd.env(k, v);
        }
        cmd.output().unwrap()
    }
}

impl Drop for Fakes {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Exit 1, the first line says nothing was run or installed, no command was started (xtask
/// echoes each as `+ ...`), and no package tool was called.
fn assert_stopped_before_work(out: &Output, fakes: &Fakes, cmd: &str) -> String {
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    let first = err.lines().next().unwrap_or("");
    assert!(first.starts_with(&format!("xtask {cmd}: ")), "{err}");
    assert!(
        first.contains("missing; nothing was run (xtask installs nothing)"),
        "{err}"
    );
    assert!(!err.lines().any(|l| l.starts_with("+ ")), "{err}");
    assert!(!err.contains("\n=="), "a step started: {err}");
    assert_eq!(text(&out.stdout), "", "{err}");
    assert_eq!(fakes.calls(), "", "xtask called a package tool");
    err
}

#[test]
fn firmware_without_qemu_says_how_to_install_it_and_installs_nothing() {
    let fakes = Fakes::new("firmware");
    let out = fakes.xtask(&["firmware", "--vector", "zero"], &[]);
    let err = assert_stopped_before_work(&out, &fakes, "firmware");
    let qemu = err
        .lines()
        .find(|l| l.contains("`qemu-system-arm` (QEMU's Arm emulator"))
        .unwrap_or_else(|| panic!("no line for QEMU: {err}"));
    assert!(qemu.contains("is not on PATH"), "{err}");
    assert!(
        qemu.ends_with(
            "install Debian's package qemu-system-arm (7.2 is the version tested): \
             `sudo apt-get install qemu-system-arm`"
        ),
        "{err}"
    );
    // `ci`'s way around is not offered by `firmware`.
    assert!(!err.contains("--no-firmware"), "{err}");
}

#[test]
fn ci_without_qemu_stops_before_its_first_step_and_offers_no_firmware() {
    let fakes = Fakes::new("ci");
    let out = fakes.xtask(&["ci"], &[]);
    let err = assert_stopped_before_work(&out, &fakes, "ci");
    assert!(
        err.contains("`qemu-system-arm` (QEMU's Arm emulator"),
        "{err}"
    );
    assert!(
        err.lines().last().unwrap_or("")
            == "  (`cargo xtask ci --no-firmware` skips the firmware checks, and QEMU with them)",
        "{err}"
    );
    // Every missing thing is on its own line, each named once.
    let lines: Vec<&str> = err.lines().skip(1).collect();
    let unique: std::collections::HashSet<&str> = lines.iter().copied().collect();
    assert_eq!(lines.len(), unique.len(), "{err}");
}

#[test]
fn c_twin_with_a_missing_compiler_names_it_and_the_cc_variable() {
    let fakes = Fakes::new("cc");
    let missing = Path::new("/nonexistent/ptsa-cc");
    let cc = missing.display().to_string();
    let out = fakes.xtask(&["golden", "--c-twin"], &[("CC", &cc)]);
    let err = assert_stopped_before_work(&out, &fakes, "golden");
    assert!(
        err.contains(&format!(
            "`{cc}` (the C compiler for the C twin) does not exist or is not executable: \
             install `{cc}`, or set CC to a C11 compiler that is installed"
        )),
        "{err}"
    );
}
