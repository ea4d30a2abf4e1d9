//! Checks of the paths the program will write, made before any work runs: a run that
//! cannot write its files is refused at once, with nothing written, instead of failing after
//! the simulation with the operating system's words; an output is never one of the run's
//! inputs (after links are resolved), and an existing single-file output is replaced only
//! with `--force`.

use std::path::Path;

use anyhow::{Result, bail};
use ptsa_host_sim::output::fs::{input_inside, input_named, protect};

/// Record the files the run reads (`flag` names each in messages): no output may replace
/// them, whatever the command (checked here before any work, and again by every write in
/// `ptsa_host_sim::output::fs`).
pub fn inputs<'a>(files: impl IntoIterator<Item = (&'a str, Option<&'a Path>)>) {
    for (flag, p) in files {
        if let Some(p) = p {
            protect(p, &format!("the file given to {flag} ({})", p.display()));
        }
    }
}

/// Refuse `path` (an output of `flag`) when it is an input of the run.
///
/// # Errors
/// `path` is the same file as an input.
pub fn not_an_input(flag: &str, path: &Path) -> Result<()> {
    if let Some(what) = input_named(path) {
        bail!(
            "{flag} {}: this is {what}; an output never replaces an input (expected another name for the output)",
            path.display()
        );
    }
    Ok(())
}

/// Outputs named `names` inside the folder `dir` (of `flag`): [`folder`]'s checks, and none
/// of them may be an input of the run.
///
/// # Errors
/// As [`folder`] and [`not_an_input`].
pub fn folder_with(flag: &str, dir: &Path, names: &[String]) -> Result<()> {
    folder(flag, dir)?;
    for n in names {
        let p = dir.join(n);
        if let Some(what) = input_named(&p) {
            bail!(
                "{flag} {}: the output {} would be {what}; an output never replaces an input (expected another folder)",
                dir.display(),
                p.display()
            );
        }
    }
    Ok(())
}

/// A single file to write (`plan --out`, `--advice-out`, `--write-instrument`, `--trace`):
/// [`file()`]'s checks; never an input of the run, even with `--force`; an existing file only
/// with `force` (the user's measurements are often in just such a file). Returns whether an
/// existing file will be replaced.
///
/// # Errors
/// As [`file()`]; the path is an input; it exists and `force` is off.
pub fn output_file(flag: &str, path: &Path, force: bool) -> Result<bool> {
    file(flag, path)?;
    not_an_input(flag, path)?;
    if std::fs::symlink_metadata(path).is_err() {
        return Ok(false);
    }
    if !force {
        bail!(
            "{flag} {}: the file exists and is not replaced without --force (expected a new file name, or --force to replace it)",
            path.display()
        );
    }
    Ok(true)
}

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

/// A folder for a message saying what was written: as given, and for a relative path also
/// where it is (`report (/home/lab/ptsa/report)`), since outputs go below the current folder,
/// which may be a sub-folder of the workspace (`cd ptsa-host-sim && cargo ptsa`).
pub fn shown(p: &Path) -> String {
    if p.is_absolute() {
        return p.display().to_string();
    }
    match std::path::absolute(p) {
        Ok(a) => format!("{} ({})", p.display(), a.display()),
        Err(_) => p.display().to_string(),
    }
}

/// What a file about to be replaced holds, for the warning of a forced replacement: the
/// measured rows of a case-frame file (a day's measurements are often in just such a file),
/// or its size in lines.
pub fn what_is_replaced(path: &Path) -> String {
    match ptsa_host_sim::model::caseframe::read(path) {
        Ok(rows) => {
            let m = rows.iter().filter(|r| r.is_measured()).count();
            format!(
                "a case-frame file of {}, {m} of them measured",
                ptsa_host_sim::output::count(rows.len() as u64, "row"),
            )
        }
        Err(_) => match std::fs::read(path) {
            Ok(b) => format!(
                "a file of {} that is not a case-frame file",
                ptsa_host_sim::output::count(
                    String::from_utf8_lossy(&b).lines().count() as u64,
                    "line"
                )
            ),
            Err(_) => "a file that cannot be read".to_string(),
        },
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
    if let Some((p, what)) = input_inside(path) {
        bail!(
            "{flag} {}: holds {} ({what}); the report replaces its folder as a whole and would delete it (expected another folder)",
            path.display(),
            p.display()
        );
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
