//! What each command needs from the machine, checked before it does any work.
//!
//! xtask never installs anything: no `apt-get`, no `rustup target add`. A command first
//! looks for everything it will need (programs on `PATH`, the Cortex-M4F standard library in
//! the toolchain, rustfmt and clippy) and, when something is missing, stops before its first
//! step with one line per missing thing saying how to install it, so that one run tells all
//! that is missing. Only `.ci/run`, which runs on a throwaway CI machine, installs packages.

use std::ffi::OsString;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use crate::ci::THUMB;
use crate::util;

/// Something a command needs from the machine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Need {
    /// rustfmt, as `cargo fmt` (a rustup component).
    Rustfmt,
    /// clippy, as `cargo clippy` (a rustup component).
    Clippy,
    /// The toolchain's standard library for [`THUMB`] (a rustup target).
    Thumb,
    /// A C compiler for the C twin: `$CC`, default `cc`.
    CCompiler,
    /// QEMU's Arm system emulator, `qemu-system-arm` (a Debian package).
    Qemu,
    /// Python 3, which remakes the README's example files in a host test.
    Python,
    /// The Python (`$PTSA_PYTHON`, default `python3`) that tests the package `ptsa`, with
    /// numpy, pandas, pytest, matplotlib and Ray importable.
    PythonPackages,
    /// maturin in that Python, which builds the package's wheel.
    Maturin,
}

/// The parts of the machine the checks look at.
pub struct Machine {
    /// Directories searched for programs (`PATH`).
    pub path: OsString,
    /// The C compiler the C twin is built with (`$CC`, default `cc`).
    pub cc: String,
    /// The toolchain's root (`rustc --print sysroot`), or why it could not be had.
    pub sysroot: Result<PathBuf, String>,
    /// The toolchain by rustup's name (`$RUSTUP_TOOLCHAIN`, else `stable`, the channel
    /// `rust-toolchain.toml` names), for the rustup commands in the hints.
    pub toolchain: String,
    /// `cargo` as the caller invoked it, to try `cargo fmt` and `cargo clippy`.
    pub cargo: String,
}

impl Machine {
    /// This machine, as this process sees it. Runs `rustc --print sysroot` only when `needs`
    /// has [`Need::Thumb`].
    pub fn this(needs: &[Need]) -> Self {
        let sysroot = if needs.contains(&Need::Thumb) {
            sysroot()
        } else {
            Err("not looked at".into())
        };
        Self {
            path: std::env::var_os("PATH").unwrap_or_default(),
            cc: c_compiler(),
            sysroot,
            toolchain: std::env::var("RUSTUP_TOOLCHAIN").unwrap_or_else(|_| "stable".into()),
            cargo: util::cargo(),
        }
    }

    /// `None` when `need` is there; otherwise what is wrong, then how to install it.
    pub fn missing(&self, need: Need) -> Option<(String, String)> {
        let problem = match need {
            Need::Rustfmt => self.cargo_subcommand("fmt"),
            Need::Clippy => self.cargo_subcommand("clippy"),
            Need::Thumb => self.thumb_problem(),
            Need::CCompiler => {
                self.program_problem(&self.cc, "the C compiler for the C twin", "--version")
            }
            Need::Qemu => self.program_problem(
                "qemu-system-arm",
                "QEMU's Arm emulator, which runs the firmware",
                "--version",
            ),
            Need::Python => self.program_problem(
                "python3",
                "Python 3, which remakes the README's example files (scripts/examples.py)",
                "--version",
            ),
            Need::PythonPackages => python_packages_problem(&PYTHON_PACKAGES),
            Need::Maturin => python_packages_problem(&["maturin"]),
        }?;
        Some((problem, self.remedy(need)))
    }

    /// How to install `need`, as a command to run.
    fn remedy(&self, need: Need) -> String {
        let tc = &self.toolchain;
        let rustup = if self.find("rustup").is_some() {
            ""
        } else {
            " (rustup is not on PATH: if this toolchain is not rustup's, add it the way the \
             toolchain was installed)"
        };
        match need {
            Need::Rustfmt => {
                format!("install it with `rustup component add --toolchain {tc} rustfmt`{rustup}")
            }
            Need::Clippy => {
                format!("install it with `rustup component add --toolchain {tc} clippy`{rustup}")
            }
            Need::Thumb => {
                format!("install it with `rustup target add --toolchain {tc} {THUMB}`{rustup}")
            }
            Need::CCompiler if self.cc == "cc" => {
                "install Debian's package gcc (it provides `cc`): `sudo apt-get install gcc`, \
                 or set CC to a C11 compiler"
                    .into()
            }
            Need::CCompiler => format!(
                "install `{}`, or set CC to a C11 compiler that is installed (unset, CC means \
                 `cc`, which Debian's package gcc provides)",
                self.cc
            ),
            Need::Qemu => "install Debian's package qemu-system-arm (7.2 is the version \
                           tested): `sudo apt-get install qemu-system-arm`"
                .into(),
            Need::Python => {
                "install Debian's package python3: `sudo apt-get install python3`".into()
            }
            Need::PythonPackages | Need::Maturin => "install them into a virtual environment \
                and name its Python: `python3 -m venv .venv && .venv/bin/pip install maturin \
                numpy pandas pytest matplotlib ray`, then `export PTSA_PYTHON=$PWD/.venv/bin/python`"
                .into(),
        }
    }

    /// The first executable file called `name` in [`Machine::path`] (or `name` itself when it
    /// is a path).
    pub fn find(&self, name: &str) -> Option<PathBuf> {
        if name.contains('/') {
            return is_executable(Path::new(name)).then(|| PathBuf::from(name));
        }
        std::env::split_paths(&self.path)
            .filter(|dir| !dir.as_os_str().is_empty())
            .map(|dir| dir.join(name))
            .find(|p| is_executable(p))
    }

    /// Why `program` (`what`) cannot be used: not on `PATH`, or it does not run
    /// (`program probe_arg` fails).
    fn program_problem(&self, program: &str, what: &str, probe_arg: &str) -> Option<String> {
        let Some(found) = self.find(program) else {
            let place = if program.contains('/') {
                "does not exist or is not executable"
            } else {
                "is not on PATH"
            };
            return Some(format!("`{program}` ({what}) {place}"));
        };
        let out = Command::new(&found)
            .arg(probe_arg)
            .env("PATH", &self.path)
            .stdin(Stdio::null())
            .output();
        match out {
            Ok(o) if o.status.success() => None,
            Ok(o) => Some(format!(
                "`{program}` ({what}) is at {} but `{program} {probe_arg}` failed ({}{})",
                found.display(),
                o.status,
                first_line(&o.stderr)
            )),
            Err(e) => Some(format!(
                "`{program}` ({what}) is at {} but does not start: {e}",
                found.display()
            )),
        }
    }

    /// Why `cargo <sub>` does not run, if it does not.
    fn cargo_subcommand(&self, sub: &str) -> Option<String> {
        let out = Command::new(&self.cargo)
            .args([sub, "--version"])
            .current_dir(util::root())
            .stdin(Stdio::null())
            .output();
        match out {
            Ok(o) if o.status.success() => None,
            Ok(o) => Some(format!(
                "`cargo {sub}` does not run (`cargo {sub} --version`: {}{})",
                o.status,
                first_line(&o.stderr)
            )),
            Err(e) => Some(format!("cannot start `{}`: {e}", self.cargo)),
        }
    }

    /// Why the toolchain has no standard library for [`THUMB`], if it has none: no
    /// `libcore-*.rlib` in `<sysroot>/lib/rustlib/<target>/lib`.
    fn thumb_problem(&self) -> Option<String> {
        let root = match &self.sysroot {
            Ok(root) => root,
            Err(e) => return Some(format!("the {THUMB} target could not be looked for: {e}")),
        };
        let lib = root.join("lib").join("rustlib").join(THUMB).join("lib");
        let has_core = std::fs::read_dir(&lib).is_ok_and(|entries| {
            entries.filter_map(Result::ok).any(|e| {
                let name = e.file_name();
                let name = name.to_string_lossy();
                name.starts_with("libcore-") && name.ends_with(".rlib")
            })
        });
        (!has_core).then(|| {
            format!(
                "the {THUMB} target (the Cortex-M4F's standard library) is not installed \
                 (no libcore in {})",
                lib.display()
            )
        })
    }
}

/// The Python packages the package `ptsa` is tested with.
pub const PYTHON_PACKAGES: [&str; 5] = ["numpy", "pandas", "pytest", "matplotlib", "ray"];

/// Why `$PTSA_PYTHON` (default `python3`) cannot build and test the package `ptsa`: it does
/// not start, or some of `packages` cannot be imported.
fn python_packages_problem(packages: &[&str]) -> Option<String> {
    let python = crate::python::python();
    let probe = format!(
        "import importlib.util, sys; m = [n for n in {packages:?} if importlib.util.find_spec(n) is None]; print(' '.join(m)); sys.exit(1 if m else 0)"
    );
    match Command::new(&python)
        .args(["-c", &probe])
        .stdin(Stdio::null())
        .output()
    {
        Ok(o) if o.status.success() => None,
        Ok(o) => Some(format!(
            "`{python}` (the Python of $PTSA_PYTHON, default python3) lacks {}",
            String::from_utf8_lossy(&o.stdout).trim()
        )),
        Err(e) => Some(format!(
            "`{python}` (the Python of $PTSA_PYTHON, default python3) does not start: {e}"
        )),
    }
}

/// `$CC`, default `cc` (what the C twin is built with).
pub fn c_compiler() -> String {
    std::env::var("CC")
        .ok()
        .filter(|s| !s.trim().is_empty())
        .unwrap_or_else(|| "cc".into())
}

/// `rustc --print sysroot` of the toolchain cargo uses (`$RUSTC`, else `rustc`, run from the
/// workspace root so that `rust-toolchain.toml` applies).
fn sysroot() -> Result<PathBuf, String> {
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let out = Command::new(&rustc)
        .args(["--print", "sysroot"])
        .current_dir(util::root())
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("cannot run `{rustc} --print sysroot`: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "`{rustc} --print sysroot` failed ({}{})",
            out.status,
            first_line(&out.stderr)
        ));
    }
    let s = String::from_utf8_lossy(&out.stdout).trim().to_string();
    if s.is_empty() {
        return Err(format!("`{rustc} --print sysroot` printed nothing"));
    }
    Ok(PathBuf::from(s))
}

/// `: <first line>` of a program's stderr, or nothing when it is empty.
fn first_line(stderr: &[u8]) -> String {
    String::from_utf8_lossy(stderr)
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty())
        .map_or_else(String::new, |l| format!(": {l}"))
}

fn is_executable(p: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        std::fs::metadata(p).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
    }
    #[cfg(not(unix))]
    {
        p.is_file()
    }
}

/// The message for what is missing (`None` when nothing is): a first line that says nothing
/// was run or installed, then one line per missing thing with how to install it, then
/// `note` (a way around, if the command has one).
pub fn report(missing: &[(String, String)], note: Option<&str>) -> Option<String> {
    if missing.is_empty() {
        return None;
    }
    let n = missing.len();
    let mut s = format!(
        "{n} thing{} this command needs {} missing; nothing was run (xtask installs nothing):",
        if n == 1 { "" } else { "s" },
        if n == 1 { "is" } else { "are" }
    );
    for (problem, remedy) in missing {
        let _ = write!(s, "\n  {problem}: {remedy}");
    }
    if let Some(note) = note {
        let _ = write!(s, "\n  ({note})");
    }
    Some(s)
}

/// Check `needs` on `machine`: `Err` with [`report`]'s message if anything is missing. The
/// note of `note` is added when its need is among the missing (a way around it).
pub fn check_on(
    machine: &Machine,
    needs: &[Need],
    note: Option<(Need, &str)>,
) -> Result<(), String> {
    let mut noted = None;
    let mut missing = Vec::new();
    for &need in needs {
        if let Some(m) = machine.missing(need) {
            missing.push(m);
            if let Some((n, text)) = note
                && n == need
            {
                noted = Some(text);
            }
        }
    }
    report(&missing, noted).map_or(Ok(()), Err)
}

/// Check `needs` on this machine (see [`check_on`]).
pub fn check(needs: &[Need], note: Option<(Need, &str)>) -> Result<(), String> {
    check_on(&Machine::this(needs), needs, note)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tests of this module one at a time: each writes shell scripts and runs them, and
    /// a script written while another thread forks can be held open by the child until it
    /// execs, so running it fails with ETXTBSY ("text file busy"), i.e. it looks missing.
    static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

    fn serial() -> std::sync::MutexGuard<'static, ()> {
        SERIAL
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// A scratch directory, removed when dropped.
    struct Scratch(PathBuf);

    impl Scratch {
        fn new(tag: &str) -> Self {
            let nanos = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.subsec_nanos());
            let dir = std::env::temp_dir().join(format!(
                "ptsa-xtask-needs-{tag}-{}-{nanos}",
                std::process::id()
            ));
            std::fs::create_dir_all(&dir).unwrap();
            Self(dir)
        }

        /// An executable shell script `name` in the directory that prints `out` and exits 0.
        fn program(&self, name: &str, out: &str) -> PathBuf {
            use std::os::unix::fs::PermissionsExt as _;
            let p = self.0.join(name);
            std::fs::write(&p, format!("#!/bin/sh\necho '{out}'\n")).unwrap();
            std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o755)).unwrap();
            p
        }
    }

    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn machine(bin: &Path, sysroot: &Path) -> Machine {
        Machine {
            path: std::env::join_paths([bin]).unwrap(),
            cc: "cc".into(),
            sysroot: Ok(sysroot.to_path_buf()),
            toolchain: "stable-x86_64-unknown-linux-gnu".into(),
            cargo: "cargo".into(),
        }
    }

    #[test]
    fn what_is_missing_is_named_with_how_to_install_it() {
        let _serial = serial();
        let bin = Scratch::new("bin");
        let sysroot = Scratch::new("sysroot");
        bin.program("cc", "cc (fake) 1.0");
        let m = machine(&bin.0, &sysroot.0);
        let needs = [Need::CCompiler, Need::Thumb, Need::Qemu];

        let msg = check_on(&m, &needs, Some((Need::Qemu, "a way around"))).unwrap_err();
        let lines: Vec<&str> = msg.lines().collect();
        assert_eq!(lines.len(), 4, "{msg}");
        assert!(
            lines[0].starts_with("2 things this command needs are missing"),
            "{msg}"
        );
        assert!(lines[0].contains("xtask installs nothing"), "{msg}");
        // In the order asked for; the C compiler, which is there, is not named.
        assert!(lines[1].contains("thumbv7em-none-eabihf target"), "{msg}");
        assert!(
            lines[1].contains(
                "`rustup target add --toolchain stable-x86_64-unknown-linux-gnu \
                 thumbv7em-none-eabihf`"
            ),
            "{msg}"
        );
        assert!(lines[1].contains("(rustup is not on PATH"), "{msg}");
        assert!(lines[2].starts_with("  `qemu-system-arm` ("), "{msg}");
        assert!(lines[2].contains("is not on PATH"), "{msg}");
        assert!(
            lines[2].contains("Debian's package qemu-system-arm")
                && lines[2].contains("`sudo apt-get install qemu-system-arm`"),
            "{msg}"
        );
        assert_eq!(lines[3], "  (a way around)");
        assert!(!msg.contains("C compiler"), "{msg}");

        // Install them (fakes): nothing is missing any more.
        bin.program("qemu-system-arm", "QEMU emulator version 7.2.0");
        bin.program("rustup", "rustup 1.0");
        let lib = sysroot.0.join("lib/rustlib/thumbv7em-none-eabihf/lib");
        std::fs::create_dir_all(&lib).unwrap();
        std::fs::write(lib.join("libcore-0123abcd.rlib"), b"").unwrap();
        assert_eq!(check_on(&m, &needs, None), Ok(()));
    }

    #[test]
    fn a_program_that_does_not_run_or_is_not_executable_is_missing() {
        use std::os::unix::fs::PermissionsExt as _;
        let _serial = serial();
        let bin = Scratch::new("broken");
        let sysroot = Scratch::new("sysroot-broken");
        // On PATH but fails: said so, with its first line of stderr.
        let qemu = bin.0.join("qemu-system-arm");
        std::fs::write(&qemu, "#!/bin/sh\necho 'missing libfoo.so' >&2\nexit 127\n").unwrap();
        std::fs::set_permissions(&qemu, std::fs::Permissions::from_mode(0o755)).unwrap();
        // A CC that is a file without the executable bit.
        let cc = bin.0.join("my-cc");
        std::fs::write(&cc, "").unwrap();
        let mut m = machine(&bin.0, &sysroot.0);
        m.cc = cc.display().to_string();
        let msg = check_on(&m, &[Need::Qemu, Need::CCompiler], None).unwrap_err();
        assert!(msg.starts_with("2 things"), "{msg}");
        assert!(
            msg.contains(
                "`qemu-system-arm --version` failed (exit status: 127: missing libfoo.so)"
            ),
            "{msg}"
        );
        assert!(msg.contains("does not exist or is not executable"), "{msg}");
        assert!(
            msg.contains("or set CC to a C11 compiler that is installed"),
            "{msg}"
        );
        // One missing thing: singular. A note about something that is there is left out.
        let msg = check_on(&m, &[Need::Qemu], Some((Need::Thumb, "a way around"))).unwrap_err();
        assert!(
            msg.starts_with("1 thing this command needs is missing"),
            "{msg}"
        );
        assert_eq!(msg.lines().count(), 2, "{msg}");
    }

    #[test]
    fn a_sysroot_that_could_not_be_had_is_reported_not_hidden() {
        let _serial = serial();
        let bin = Scratch::new("nosysroot");
        let mut m = machine(&bin.0, &bin.0);
        m.sysroot = Err("cannot run `rustc --print sysroot`: not found".into());
        let msg = check_on(&m, &[Need::Thumb], None).unwrap_err();
        assert!(
            msg.contains("could not be looked for: cannot run `rustc"),
            "{msg}"
        );
        assert!(msg.contains("rustup target add"), "{msg}");
    }
}
