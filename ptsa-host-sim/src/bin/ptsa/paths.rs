//! Checks of the paths the program will write, made before any work runs: a run that
//! cannot write its files is refused at once, with nothing written, instead of failing after
//! the simulation with the operating system's words.

use std::path::Path;

use anyhow::{Result, bail};

/// The nearest part of `path` (itself or a parent) that exists and is not a folder, if any:
/// nothing can be created below a file.
fn file_in_the_way(path: &Path) -> Option<&Path> {
    for a in path.ancestors() {
        if a.as_os_str().is_empty() {
            break;
        }
        match std::fs::metadata(a) {
            Ok(m) if m.is_dir() => return None,
            Ok(_) => return Some(a),
            Err(_) => {}
        }
    }
    None
}

/// A folder to write files into (`--out`): it may exist or not, but neither it nor a
/// parent of it may be a file.
///
/// # Errors
/// The path, or a parent of it, is a file.
pub fn folder(flag: &str, path: &Path) -> Result<()> {
    match file_in_the_way(path) {
        Some(f) if f == path => bail!(
            "{flag} {}: this is a file; expected a folder (or a name for a new one)",
            path.display()
        ),
        Some(f) => bail!(
            "{flag} {}: {} is a file; expected a folder there",
            path.display(),
            f.display()
        ),
        None => Ok(()),
    }
}

/// A file to write (`--trace`): it may exist (it is replaced) but not be a folder, and no
/// parent of it may be a file.
///
/// # Errors
/// The path is a folder, or a parent of it is a file.
pub fn file(flag: &str, path: &Path) -> Result<()> {
    if path.is_dir() {
        bail!(
            "{flag} {}: this is a folder; expected a file name",
            path.display()
        );
    }
    match path.parent().and_then(file_in_the_way) {
        Some(f) => bail!(
            "{flag} {}: {} is a file; expected a folder there",
            path.display(),
            f.display()
        ),
        None => Ok(()),
    }
}

/// The report folder, which the report replaces as a whole: besides [`folder`]'s checks,
/// an existing folder must be empty or an earlier report (it holds `summary.md` and
/// `design.txt`), so that no other folder is ever deleted by mistake (`--out .`,
/// `--out data`, a folder of the user's own files).
///
/// # Errors
/// The path is a file, below a file, or an existing folder that is neither empty nor an
/// earlier report.
pub fn report_folder(flag: &str, path: &Path) -> Result<()> {
    folder(flag, path)?;
    if !path.is_dir() {
        return Ok(());
    }
    let empty = std::fs::read_dir(path).map_or(true, |mut d| d.next().is_none());
    let earlier = path.join("summary.md").is_file() && path.join("design.txt").is_file();
    if !empty && !earlier {
        bail!(
            "{flag} {}: an existing folder that is not an earlier report (it has no summary.md and design.txt); the report replaces its folder as a whole and would delete what is in it: expected a new folder, an empty one or an earlier report",
            path.display()
        );
    }
    Ok(())
}

/// An error's text without the operating system's error numbers (` (os error 2)`), which
/// say nothing more than the words before them.
pub fn without_os_error_numbers(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let mut rest = s;
    while let Some(i) = rest.find(" (os error ") {
        out.push_str(&rest[..i]);
        let tail = &rest[i + " (os error ".len()..];
        let digits = tail.bytes().take_while(u8::is_ascii_digit).count();
        if digits > 0 && tail[digits..].starts_with(')') {
            rest = &tail[digits + 1..];
        } else {
            out.push_str(" (os error ");
            rest = tail;
        }
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn os_error_numbers_are_dropped() {
        assert_eq!(
            without_os_error_numbers(
                "cannot read x: No such file or directory (os error 2): Is a directory (os error 21)"
            ),
            "cannot read x: No such file or directory: Is a directory"
        );
        assert_eq!(without_os_error_numbers("a (os error x)"), "a (os error x)");
        assert_eq!(without_os_error_numbers("plain"), "plain");
    }
}
