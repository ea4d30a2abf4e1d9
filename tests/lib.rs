//! Shared helpers for the workspace-level tests: the golden-vector files. (The hidden-effect
//! generator and campaigns the `hidden_*` tests run are the crate `ptsa-campaigns`.) Test
//! support only; nothing here is part of `ptsa-core`'s or `ptsa-host-sim`'s interface.

use std::path::{Path, PathBuf};

/// The `tests/golden` directory.
#[must_use]
pub fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("golden")
}

/// Every golden case as `(name, input path, expected-output path)`, sorted by name.
///
/// # Panics
/// If the directory cannot be read, or an `.in` has no `.out` beside it.
#[must_use]
pub fn golden_cases() -> Vec<(String, PathBuf, PathBuf)> {
    let dir = golden_dir();
    let mut v: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "in"))
        .map(|p| {
            let name = p
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            let out = p.with_extension("out");
            assert!(out.exists(), "{} has no expected output", p.display());
            (name, p, out)
        })
        .collect();
    v.sort();
    v
}

/// Compare expected and actual golden output line by line. `None` when identical, else a
/// message naming the first differing line (= tick number, counted from 1) with both texts.
#[must_use]
pub fn first_difference(expected: &str, got: &str) -> Option<String> {
    if expected == got {
        return None;
    }
    let mut e = expected.lines();
    let mut g = got.lines();
    let mut line = 0usize;
    loop {
        line += 1;
        match (e.next(), g.next()) {
            (Some(a), Some(b)) if a == b => {}
            (None, None) => {
                return Some("outputs differ in line endings or a trailing newline".into());
            }
            (a, b) => {
                let what = if a.is_some_and(|a| a.starts_with("end")) {
                    "final state".to_string()
                } else {
                    format!("tick {line}")
                };
                return Some(format!(
                    "first difference at line {line} ({what}): expected `{}`, got `{}`",
                    a.unwrap_or("<end of file>"),
                    b.unwrap_or("<end of file>")
                ));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::first_difference;

    #[test]
    fn difference_names_the_line() {
        assert_eq!(first_difference("+\n-\n", "+\n-\n"), None);
        let d = first_difference("+\n- c32\n", "+\n+ c33\n").unwrap();
        assert!(d.contains("line 2 (tick 2)"), "{d}");
        assert!(first_difference("+\n", "+\n+\n").is_some());
    }
}
