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
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, text).map_err(|e| format!("{}: {e}", tmp.display()))?;
    std::fs::rename(&tmp, path).map_err(|e| format!("{}: {e}", path.display()))
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
        let json = String::from_utf8(out.stdout)
            .map_err(|_| "cargo metadata printed something that is not UTF-8".to_string())?;
        top_level_string(&json, "target_directory")
            .map(PathBuf::from)
            .ok_or_else(|| "no `target_directory` in cargo metadata's output".to_string())
    })
    .clone()
}

/// The string value of `key` in the outermost object of the JSON text `json` (keys of
/// nested objects, such as a package's `metadata`, are skipped), unescaped.
fn top_level_string(json: &str, key: &str) -> Option<String> {
    let mut chars = json.char_indices().peekable();
    let mut depth = 0usize;
    while let Some((_, c)) = chars.next() {
        match c {
            '{' | '[' => depth += 1,
            '}' | ']' => depth = depth.checked_sub(1)?,
            '"' => {
                let s = json_string(&mut chars)?;
                if depth != 1 || s != key {
                    continue;
                }
                // A key is followed by `:`; the same text as a value is followed by `,` or `}`.
                while chars.next_if(|(_, c)| c.is_whitespace()).is_some() {}
                if chars.next_if(|&(_, c)| c == ':').is_none() {
                    continue;
                }
                while chars.next_if(|(_, c)| c.is_whitespace()).is_some() {}
                chars.next_if(|&(_, c)| c == '"')?;
                return json_string(&mut chars);
            }
            _ => {}
        }
    }
    None
}

/// The rest of a JSON string whose opening quote has been read, unescaped; `None` if it is
/// malformed.
fn json_string(chars: &mut impl Iterator<Item = (usize, char)>) -> Option<String> {
    let mut s = String::new();
    loop {
        let (_, c) = chars.next()?;
        match c {
            '"' => return Some(s),
            '\\' => {
                let (_, e) = chars.next()?;
                s.push(match e {
                    '"' | '\\' | '/' => e,
                    'b' => '\u{8}',
                    'f' => '\u{c}',
                    'n' => '\n',
                    'r' => '\r',
                    't' => '\t',
                    'u' => {
                        let unit = |chars: &mut dyn Iterator<Item = (usize, char)>| {
                            let hex: String = chars.take(4).map(|(_, c)| c).collect();
                            u32::from_str_radix(&hex, 16)
                                .ok()
                                .filter(|_| hex.len() == 4)
                        };
                        let hi = unit(chars)?;
                        if (0xd800..0xdc00).contains(&hi) {
                            // A surrogate pair: `\uD8xx\uDCxx`.
                            let (_, '\\') = chars.next()? else {
                                return None;
                            };
                            let (_, 'u') = chars.next()? else { return None };
                            let lo = unit(chars)?;
                            if !(0xdc00..0xe000).contains(&lo) {
                                return None;
                            }
                            char::from_u32(0x1_0000 + ((hi - 0xd800) << 10) + (lo - 0xdc00))?
                        } else {
                            char::from_u32(hi)?
                        }
                    }
                    _ => return None,
                });
            }
            c => s.push(c),
        }
    }
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

#[cfg(test)]
mod tests {
    use super::top_level_string;

    #[test]
    fn target_directory_is_read_from_the_top_level_only() {
        let json = r#"{"packages":[{"name":"a","metadata":{"target_directory":"/nested"}}],
            "target_directory" : "/w/t\"a\\b\/c \u00e9\ud83d\ude00","workspace_root":"/w"}"#;
        assert_eq!(
            top_level_string(json, "target_directory").as_deref(),
            Some("/w/t\"a\\b/c é😀")
        );
        assert_eq!(
            top_level_string(json, "workspace_root").as_deref(),
            Some("/w")
        );
        // A value equal to the key is not a key.
        let json = r#"{"x":"target_directory","target_directory":"/t"}"#;
        assert_eq!(
            top_level_string(json, "target_directory").as_deref(),
            Some("/t")
        );
        assert_eq!(top_level_string(r#"{"a":1}"#, "target_directory"), None);
        assert_eq!(
            top_level_string(r#"{"target_directory":"/t"#, "target_directory"),
            None
        );
        assert_eq!(
            top_level_string(r#"{"target_directory":"\q"}"#, "target_directory"),
            None
        );
    }
}
