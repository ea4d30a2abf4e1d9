//! What the CLI tests share: running the `ptsa` binary in a folder, reading its output, and
//! the checks every refusal must pass.

#![allow(dead_code)] // each test binary uses its own part

use std::path::Path;
use std::process::{Command, Output};

/// Runs `ptsa args` with `dir` as its working directory.
pub fn ptsa_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ptsa"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

/// Its stderr, as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Its stdout, as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Runs `ptsa args` in `dir`, which must succeed and print one JSON object: the object.
pub fn json_in(dir: &Path, args: &[&str]) -> serde_json::Value {
    let o = ptsa_in(dir, args);
    assert_eq!(o.status.code(), Some(0), "ptsa {args:?}: {}", stderr(&o));
    serde_json::from_str(&stdout(&o)).unwrap_or_else(|e| panic!("{e}: {}", stdout(&o)))
}

/// A JSON array of numbers.
pub fn numbers(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("not an array: {v}"))
        .iter()
        .map(|x| x.as_f64().unwrap_or_else(|| panic!("not a number: {x}")))
        .collect()
}

/// The names in `dir`, sorted.
pub fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Nothing a user should ever see in a message: a panic, Rust's or the OS's internals, nor
/// any of `also`.
pub fn assert_clean_of(err: &str, also: &[&str]) {
    for bad in [
        "panicked",
        "RUST_BACKTRACE",
        "os error",
        "invalid digit",
        "ParseIntError",
        "ParseFloatError",
    ]
    .iter()
    .chain(also)
    {
        assert!(!err.contains(bad), "`{bad}` in: {err}");
    }
}

/// Run `args` in a fresh folder holding `files` (name, contents); `{dir}` in an argument
/// stands for that folder. It must be refused with exit `code`, a message on stderr holding
/// every one of `needles` and none of `forbidden` (beyond [`assert_clean_of`]'s), nothing
/// on stdout, and the folder must hold only `files` after. Returns stderr.
pub fn refused_in_folder(
    files: &[(&str, &[u8])],
    args: &[&str],
    code: i32,
    needles: &[&str],
    forbidden: &[&str],
) -> String {
    let tmp = tempfile::tempdir().unwrap();
    for (n, b) in files {
        std::fs::write(tmp.path().join(n), b).unwrap();
    }
    let before = names(tmp.path());
    let d = tmp.path().to_str().unwrap();
    let args: Vec<String> = args.iter().map(|a| a.replace("{dir}", d)).collect();
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = ptsa_in(tmp.path(), &args);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(code), "ptsa {args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "ptsa {args:?}: `{n}` not in: {err}");
    }
    assert_clean_of(&err, forbidden);
    assert!(o.stdout.is_empty(), "ptsa {args:?} printed {}", stdout(&o));
    assert_eq!(names(tmp.path()), before, "ptsa {args:?} wrote something");
    err
}

/// A seeded normal draw (splitmix64, Box–Muller): the tests' own noise, independent of the
/// simulator's.
pub struct Normal(pub u64);

impl Normal {
    pub fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        #[allow(clippy::cast_precision_loss)]
        let u = ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
        u
    }

    pub fn draw(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}
