//! Nothing the user owns is lost: no output replaces an input (whatever the spelling: the
//! same path, a symbolic or a hard link), an existing single-file output is replaced only
//! with `--force` (and then the warning says how many measured rows went), an interrupted
//! run leaves no temporaries and the old output as it was, a killed run's leftovers are
//! swept by the next one, and files get the process umask's modes.
//!
//! Every data-loss case compares the input file's bytes before and after.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::{names, ptsa_in, stderr};

/// A 48-row tumble with its measured values, as a lab's only copy would be.
const MEASURED: &[u8] = include_bytes!("../../data/synthetic-48.case.csv");
/// The shipped instrument file.
const INSTRUMENT: &[u8] = include_bytes!("../../data/kearfott-2401.toml");

/// Options that keep the report programme fast.
const FAST: [&str; 4] = ["--window-s", "0.01", "--warmup-s", "0.01"];

/// A fresh folder holding `files`.
fn folder(files: &[(&str, &[u8])]) -> tempfile::TempDir {
    let tmp = tempfile::tempdir().unwrap();
    for (n, b) in files {
        std::fs::write(tmp.path().join(n), b).unwrap();
    }
    tmp
}

/// Run `args` in `dir`: it must be refused with exit 1 and every one of `needles` in its
/// message, print nothing on stdout, leave `dir`'s names as they were and every file of
/// `kept` byte for byte.
fn refused_keeping(dir: &Path, args: &[&str], needles: &[&str], kept: &[(&str, &[u8])]) {
    let before = names(dir);
    let o = ptsa_in(dir, args);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "ptsa {args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "ptsa {args:?}: `{n}` not in: {err}");
    }
    common::assert_clean_of(&err, &[]);
    assert!(o.stdout.is_empty(), "ptsa {args:?} printed on stdout");
    assert_eq!(names(dir), before, "ptsa {args:?} wrote something");
    for (n, b) in kept {
        assert_eq!(std::fs::read(dir.join(n)).unwrap(), *b, "{n} changed");
    }
}

/// Run `args` in `dir`; it must succeed. Returns stderr.
fn succeeds(dir: &Path, args: &[&str]) -> String {
    let o = ptsa_in(dir, args);
    let err = stderr(&o);
    assert!(o.status.success(), "ptsa {args:?}: {err}");
    common::assert_clean_of(&err, &[]);
    err
}

/// `discover --out .` beside its own data file: the data file is kept byte for byte and the
/// outputs are named apart from it (`<stem>-discover.*`).
#[test]
fn discover_beside_its_data_keeps_the_data() {
    let tmp = folder(&[("mydata.csv", MEASURED)]);
    let d = tmp.path();
    let err = succeeds(
        d,
        &[
            "discover",
            "--data",
            "mydata.csv",
            "--out",
            ".",
            "--analytic",
        ],
    );
    assert!(err.contains("mydata-discover.csv"), "{err}");
    assert_eq!(std::fs::read(d.join("mydata.csv")).unwrap(), MEASURED);
    assert_eq!(
        names(d),
        [
            "mydata-discover.csv",
            "mydata-discover.png",
            "mydata-discover.svg",
            "mydata.csv"
        ]
    );
}

/// An output that is an input, by the same path, a symbolic link or a hard link, is refused
/// before any work, even with `--force`, and the input is kept.
#[test]
fn no_output_is_an_input() {
    let tmp = folder(&[("m.csv", MEASURED), ("i.toml", INSTRUMENT)]);
    let d = tmp.path();
    std::os::unix::fs::symlink("m.csv", d.join("soft.csv")).unwrap();
    std::fs::hard_link(d.join("m.csv"), d.join("hard.csv")).unwrap();
    let kept: [(&str, &[u8]); 2] = [("m.csv", MEASURED), ("i.toml", INSTRUMENT)];
    for out in ["m.csv", "./m.csv", "soft.csv", "hard.csv"] {
        refused_keeping(
            d,
            &[
                "discover",
                "--data",
                "m.csv",
                "--analytic",
                "--no-plots",
                "--advice-out",
                out,
                "--force",
            ],
            &[
                &format!("--advice-out {out}: this is the file given to --data (m.csv)"),
                "an output never replaces an input",
            ],
            &kept,
        );
    }
    // The fitted instrument file over the instrument file in use.
    refused_keeping(
        d,
        &[
            "--instrument",
            "i.toml",
            "discover",
            "--data",
            "m.csv",
            "--analytic",
            "--no-plots",
            "--write-instrument",
            "i.toml",
            "--force",
        ],
        &["--write-instrument i.toml: this is the file given to --instrument (i.toml)"],
        &kept,
    );
    // A plan over the instrument file, and a plan over a data file named by a link.
    refused_keeping(
        d,
        &[
            "--instrument",
            "i.toml",
            "plan",
            "tumble",
            "--output",
            "i.toml",
            "--force",
        ],
        &["--output i.toml: this is the file given to --instrument"],
        &kept,
    );
    // `discover --out` whose plot would be another input (an instrument file that happens
    // to bear the name): refused before any work.
    std::fs::write(d.join("m-discover.svg"), INSTRUMENT).unwrap();
    refused_keeping(
        d,
        &[
            "--instrument",
            "m-discover.svg",
            "discover",
            "--data",
            "m.csv",
            "--out",
            ".",
            "--analytic",
        ],
        &["--out .: the output ./m-discover.svg would be the file given to --instrument"],
        &[("m-discover.svg", INSTRUMENT)],
    );
    // A report folder holding the instrument file would delete it.
    let r = d.join("report");
    std::fs::create_dir(&r).unwrap();
    std::fs::write(r.join("summary.md"), "earlier").unwrap();
    std::fs::write(r.join("design.txt"), "earlier").unwrap();
    std::fs::write(r.join("mine.toml"), INSTRUMENT).unwrap();
    let mut a = vec!["--instrument", "report/mine.toml", "--out", "report"];
    a.extend(FAST);
    refused_keeping(
        d,
        &a,
        &[
            "--out report: holds report/mine.toml (the file given to --instrument",
            "would delete it",
        ],
        &[("report/mine.toml", INSTRUMENT)],
    );
}

/// `plan --out` over a file of measurements: refused without `--force`; with it, the
/// warning says how many measured rows were replaced.
#[test]
fn plan_does_not_overwrite_measurements_unless_forced() {
    let tmp = folder(&[("filled.csv", MEASURED)]);
    let d = tmp.path();
    refused_keeping(
        d,
        &[
            "plan",
            "tumble",
            "--positions",
            "8",
            "--output",
            "filled.csv",
        ],
        &[
            "--output filled.csv: the file exists and is not replaced without --force",
            "expected a new file name, or --force to replace it",
        ],
        &[("filled.csv", MEASURED)],
    );
    let err = succeeds(
        d,
        &[
            "plan",
            "tumble",
            "--positions",
            "8",
            "--output",
            "filled.csv",
            "--force",
        ],
    );
    assert!(
        err.contains(
            "warning: --output filled.csv: replaced a case-frame file of 48 rows, 48 of them measured (--force)"
        ),
        "{err}"
    );
    // A file that is no case frame is described by its size.
    std::fs::write(d.join("notes.txt"), "one\ntwo\nthree").unwrap();
    let err = succeeds(d, &["plan", "tumble", "--output", "notes.txt", "--force"]);
    assert!(
        err.contains("replaced a file of 3 lines that is not a case-frame file"),
        "{err}"
    );
    // --advice-out and --trace are single-file outputs too.
    std::fs::write(d.join("advice.csv"), MEASURED).unwrap();
    refused_keeping(
        d,
        &[
            "discover",
            "--data",
            "filled.csv",
            "--analytic",
            "--no-plots",
            "--advice-out",
            "advice.csv",
        ],
        &["--advice-out advice.csv: the file exists and is not replaced without --force"],
        &[("advice.csv", MEASURED)],
    );
    refused_keeping(
        d,
        &[
            "static",
            "--accel-cm-s2",
            "0",
            "--seconds",
            "0.01",
            "--trace",
            "advice.csv",
        ],
        &["--trace advice.csv: the file exists and is not replaced without --force"],
        &[("advice.csv", MEASURED)],
    );
}

/// The mode bits of `p`.
fn mode(p: &Path) -> u32 {
    use std::os::unix::fs::PermissionsExt as _;
    std::fs::metadata(p).unwrap().permissions().mode() & 0o777
}

/// Run `ptsa args` in `dir` under `umask`; it must succeed.
fn under_umask(dir: &Path, umask: &str, args: &str) {
    let o = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "umask {umask} && exec \"{}\" {args}",
            env!("CARGO_BIN_EXE_ptsa")
        ))
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{args}: {}", stderr(&o));
}

/// Files and folders get the process umask's modes (0644 and 0755 under 022), and a file
/// replaced with --force keeps its own mode.
#[test]
fn files_get_the_umask_modes() {
    let tmp = folder(&[]);
    let d = tmp.path();
    under_umask(d, "022", "plan tumble --out a.csv");
    assert_eq!(mode(&d.join("a.csv")), 0o644);
    under_umask(d, "077", "plan tumble --out b.csv");
    assert_eq!(mode(&d.join("b.csv")), 0o600);
    under_umask(d, "022", &format!("--out report {}", FAST.join(" ")));
    assert_eq!(mode(&d.join("report")), 0o755);
    for f in ["summary.md", "design.txt", "tumble-sf-bias.csv"] {
        assert_eq!(mode(&d.join("report").join(f)), 0o644, "{f}");
    }
    let png = std::fs::read_dir(d.join("report"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "png"))
        .unwrap();
    assert_eq!(mode(&png), 0o644, "{}", png.display());
    {
        use std::os::unix::fs::PermissionsExt as _;
        std::fs::set_permissions(d.join("a.csv"), std::fs::Permissions::from_mode(0o640)).unwrap();
    }
    under_umask(d, "022", "plan tumble --positions 8 --out a.csv --force");
    assert_eq!(mode(&d.join("a.csv")), 0o640);
}

/// The names in `dir` that start with `.ptsa-` (this program's temporaries).
fn temporaries(dir: &Path) -> Vec<String> {
    names(dir)
        .into_iter()
        .filter(|n| n.starts_with(".ptsa-"))
        .collect()
}

/// SIGINT or SIGTERM during the report: the staging folder is removed, the earlier report
/// is as it was, and the exit status is 128 + the signal's number.
#[test]
fn an_interrupted_report_leaves_nothing_behind() {
    for (signal, code) in [("INT", 130), ("TERM", 143)] {
        let tmp = folder(&[]);
        let d = tmp.path();
        let mut a = vec!["--out", "report"];
        a.extend(FAST);
        succeeds(d, &a);
        let earlier = std::fs::read(d.join("report/summary.md")).unwrap();
        let listing = names(&d.join("report"));
        // A run long enough to be caught while it stages.
        let child = Command::new(env!("CARGO_BIN_EXE_ptsa"))
            .args(["--out", "report", "--window-s", "0.5", "--warmup-s", "0.2"])
            .current_dir(d)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let t0 = Instant::now();
        while temporaries(d).is_empty() {
            assert!(
                t0.elapsed() < Duration::from_mins(1),
                "no staging folder appeared"
            );
            std::thread::sleep(Duration::from_millis(5));
        }
        std::thread::sleep(Duration::from_millis(100));
        let k = Command::new("kill")
            .args([format!("-{signal}"), child.id().to_string()])
            .status()
            .unwrap();
        assert!(k.success());
        let o = child.wait_with_output().unwrap();
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(code), "SIG{signal}: {err}");
        assert!(
            err.contains(&format!("interrupted by SIG{signal}")),
            "{err}"
        );
        assert_eq!(temporaries(d), Vec::<String>::new(), "SIG{signal}");
        assert_eq!(names(d), ["report"]);
        assert_eq!(names(&d.join("report")), listing);
        assert_eq!(std::fs::read(d.join("report/summary.md")).unwrap(), earlier);
    }
}

/// A killed run's temporaries (its process gone) are removed by the next run that writes
/// beside them; those of a live process, and other files, are kept.
#[test]
fn stale_temporaries_of_dead_runs_are_swept() {
    let tmp = folder(&[(".ptsa-notes", b"not ours")]);
    let d = tmp.path();
    // Process ids beyond Linux's largest (2^22) never run.
    for dead in [".ptsa-staging-4000000-abc", ".ptsa-old-4000001-abc"] {
        std::fs::create_dir_all(d.join(dead).join("old")).unwrap();
        std::fs::write(d.join(dead).join("old/x.csv"), "x").unwrap();
    }
    std::fs::write(d.join(".ptsa-4000002-abc.csv"), "x").unwrap();
    // This test's own process is alive.
    let alive = format!(".ptsa-staging-{}-abc", std::process::id());
    std::fs::create_dir(d.join(&alive)).unwrap();
    succeeds(d, &["plan", "tumble", "--output", "plan.csv"]);
    assert_eq!(
        names(d),
        [".ptsa-notes".to_string(), alive, "plan.csv".to_string()]
    );
}
