//! Work bounded and shown: `discover` and `predict` estimate their closed-loop work before
//! any run and refuse it beyond the limit without `--force`; `discover` holds its search of
//! the loop's parameters, whose length is known only once one is selected, to the same
//! limit; a long run writes plain progress lines on stderr when it is not a terminal, and a
//! short one stays quiet.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

mod common;
use common::{assert_clean_of, names, refused_in_folder, stderr};

/// A shipped data file.
fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../data")
        .join(name)
}

/// `ptsa args` in `dir` with the environment variables `env` (stderr a pipe).
fn ptsa_env(dir: &Path, env: &[(&str, &str)], args: &[&str]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_ptsa"));
    c.current_dir(dir).args(args);
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().unwrap()
}

/// One oscillating difference row at 1 µHz: a window of one period, 10⁶ s, 6.4e10 ticks
/// per run (beyond ten minutes at the estimate's rates even on 4 cores).
const SLOW: &str = "label,freq_hz,lin_ia_cm_s2,measured_cm_s2\nslow,1e-6,100,0.1\n";

#[test]
fn discover_and_predict_refuse_work_beyond_the_limit_before_running() {
    let t = Instant::now();
    refused_in_folder(
        &[("slow.csv", SLOW.as_bytes())],
        &["discover", "--data", "{dir}/slow.csv", "--out", "{dir}/out"],
        1,
        &[
            "discover would run about",
            "clock ticks, roughly",
            "on this machine, and up to",
            "if a parameter of the loop is selected",
            "expected at most about 10 min",
            "pass --no-limit",
        ],
        &[],
    );
    refused_in_folder(
        &[("slow.csv", SLOW.as_bytes())],
        &["predict", "--data", "{dir}/slow.csv"],
        1,
        &[
            "predict would run about 6.40e10 clock ticks",
            "expected at most about 10 min",
            "pass --no-limit",
        ],
        &[],
    );
    assert!(t.elapsed() < Duration::from_secs(5), "{:?}", t.elapsed());
}

/// A 20-row response table selects the damping; its certain part is about a second, but
/// the check of the other parameters through the closed loop may take half a minute: with
/// a limit of 8 s (`PTSA_LIMIT_S`), it is refused when the selection is known, before the
/// search, and nothing is written.
#[test]
fn discover_holds_the_search_of_the_parameters_to_the_limit() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("response.csv");
    std::fs::copy(data("synthetic-response.case.csv"), &file).unwrap();
    let before = std::fs::read(&file).unwrap();
    let o = ptsa_env(
        tmp.path(),
        &[("PTSA_LIMIT_S", "8")],
        &[
            "discover",
            "--data",
            "response.csv",
            "--out",
            "out",
            "--write-instrument",
            "fitted.toml",
        ],
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    for needle in [
        "error: response.csv: the closed-loop search of the loop's parameters would run about",
        "more (",
        "clock ticks) after",
        "so far; expected at most about 8 s in all (pass --no-limit to run it anyway)",
    ] {
        assert!(err.contains(needle), "`{needle}` not in: {err}");
    }
    assert_eq!(
        err.lines().filter(|l| l.starts_with("error:")).count(),
        1,
        "{err}"
    );
    assert_clean_of(&err, &[]);
    assert!(o.stdout.is_empty());
    assert_eq!(names(tmp.path()), ["response.csv"]);
    assert_eq!(std::fs::read(&file).unwrap(), before);
}

/// With stderr a pipe, progress lines come every `PTSA_PROGRESS_S` seconds (10 by
/// default, shortened here so that a run of a fraction of a second shows them), with the
/// fraction of the estimated work, the stage and the time, then a line of the time and
/// the ticks against the estimate; at the default a short run says nothing of it.
#[test]
fn a_log_gets_progress_lines_and_a_short_run_stays_quiet() {
    let tmp = tempfile::tempdir().unwrap();
    let f = data("synthetic-48.case.csv");
    let f = f.to_str().unwrap();
    let args = ["discover", "--data", f, "--no-plots", "--json"];
    let o = ptsa_env(tmp.path(), &[("PTSA_PROGRESS_S", "0.01")], &args);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("progress:")).collect();
    assert!(!lines.is_empty(), "{err}");
    for l in &lines {
        assert!(
            l.starts_with("progress: discover: ")
                && l.contains("% of the estimated work done")
                && l.ends_with(" s elapsed"),
            "{l}"
        );
    }
    assert!(
        lines.iter().any(|l| l.contains("(baseline)")
            || l.contains("(the loop parameters' central differences)")),
        "{err}"
    );
    assert!(
        err.lines()
            .any(|l| l.starts_with("discover: ") && l.contains(" closed-loop ticks (estimated ")),
        "{err}"
    );
    // stdout is still one JSON object.
    let _: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();

    let o = ptsa_env(tmp.path(), &[], &args);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("progress:"), "{err}");
    assert!(!err.contains("closed-loop ticks"), "{err}");
}

/// A malformed limit or interval is named and the default used.
#[test]
fn a_malformed_limit_is_named_and_the_default_used() {
    let tmp = tempfile::tempdir().unwrap();
    let o = ptsa_env(
        tmp.path(),
        &[("PTSA_LIMIT_S", "ten"), ("PTSA_PROGRESS_S", "-1")],
        &[
            "discover",
            "--data",
            data("r890-table-6.1.case.csv").to_str().unwrap(),
            "--no-plots",
        ],
    );
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("warning: PTSA_LIMIT_S=ten: expected a positive number of seconds; using 600"),
        "{err}"
    );
    assert!(
        err.contains(
            "warning: PTSA_PROGRESS_S=-1: expected a positive number of seconds; using 10"
        ),
        "{err}"
    );
}
