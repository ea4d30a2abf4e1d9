//! Helpers shared by the xtask commands.

use std::fmt;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// Why a command did not succeed.
#[derive(Debug)]
pub enum Error {
    /// Wrong command line: `main` prints the message and the usage, and exits with 2.
    Usage(String),
    /// A check or a step failed: `main` prints the message and exits with 1.
    Failed(String),
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Usage(s) | Self::Failed(s) => f.write_str(s),
        }
    }
}

impl From<String> for Error {
    fn from(s: String) -> Self {
        Self::Failed(s)
    }
}

impl From<&str> for Error {
    fn from(s: &str) -> Self {
        Self::Failed(s.to_string())
    }
}

/// Write `text` to `path` whole: into a file beside it, then renamed over it.
///
/// # Errors
/// The file cannot be written or renamed: the path and the error.
pub fn write_atomic(path: &Path, text: &str) -> Result<(), String> {
    use std::io::Write as _;
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let mut tmp = tempfile::NamedTempFile::new_in(dir)
        .map_err(|e| format!("{}: cannot make a temporary file: {e}", dir.display()))?;
    tmp.write_all(text.as_bytes())
        .map_err(|e| format!("{}: {e}", tmp.path().display()))?;
    tmp.persist(path)
        .map(|_| ())
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// The workspace root (the parent of this crate's directory).
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// Cargo's target directory for this workspace, as `cargo metadata` reports it: it honours
/// `CARGO_TARGET_DIR` and `build.target-dir`. It need not exist yet: create what you write
/// into.
pub fn target_dir() -> Result<PathBuf, String> {
    static DIR: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    DIR.get_or_init(|| {
        let out = Command::new(cargo())
            .args(["metadata", "--format-version", "1", "--no-deps"])
            .current_dir(root())
            .output()
            .map_err(|e| format!("cannot run cargo metadata: {e}"))?;
        if !out.status.success() {
            return Err(format!(
                "cargo metadata failed ({}): {}",
                out.status,
                String::from_utf8_lossy(&out.stderr).trim()
            ));
        }
        let json: serde_json::Value = serde_json::from_slice(&out.stdout)
            .map_err(|e| format!("cargo metadata printed something that is not JSON: {e}"))?;
        json.get("target_directory")
            .and_then(serde_json::Value::as_str)
            .map(PathBuf::from)
            .ok_or_else(|| "no `target_directory` in cargo metadata's output".to_string())
    })
    .clone()
}

/// Run a command in `dir`, echoing it, and fail with its exit status.
pub fn run(dir: &Path, program: &str, args: &[&str]) -> Result<(), String> {
    eprintln!("+ {program} {}", args.join(" "));
    let status = Command::new(program)
        .args(args)
        .current_dir(dir)
        .status()
        .map_err(|e| format!("cannot start `{program}`: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("`{program} {}` failed ({status})", args.join(" ")))
    }
}

/// `cargo run --release -q -p ptsa-host-sim --bin ptsa -- ARGS` in the repository root,
/// announced on stderr: the release `ptsa`, built when it is not yet.
pub fn ptsa_release(args: &[&str]) -> Command {
    let cargo = cargo();
    let mut all = vec![
        "run",
        "--release",
        "-q",
        "-p",
        "ptsa-host-sim",
        "--bin",
        "ptsa",
        "--",
    ];
    all.extend_from_slice(args);
    eprintln!("+ {cargo} {}", all.join(" "));
    let mut c = Command::new(cargo);
    c.args(all).current_dir(root());
    c
}

/// `cargo` as the caller invoked it (respects `$CARGO`).
pub fn cargo() -> String {
    std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string())
}
