//! Every key `ptsa discover --json` prints on the shipped files is one the report types
//! define, so `docs/reference/json.md` (written from them) describes it: the R-890 tables,
//! the synthetic tumble and response rows, the counted tumble, a public MEMS record and
//! the triad stream.

mod common;

use std::path::Path;

use common::ptsa_in;
use ptsa_host_sim::output::json_reference::{
    command_schema, discover_schema, noise_schema, printed_paths, schema_paths, triad_schema,
    undocumented,
};

fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
}

#[test]
fn every_key_discover_prints_is_in_the_reference() {
    let single = discover_schema();
    let mut seen = std::collections::BTreeSet::new();
    for args in [
        &["--data", "data/r890-table-6.1.case.csv"][..],
        &["--data", "data/r890-table-6.2.case.csv"],
        &["--data", "data/r890-table-6.3.case.csv"],
        &["--data", "data/synthetic-48.case.csv"],
        &["--data", "data/synthetic-response.case.csv"],
        &["--data", "data/examples/tumble-counts.csv", "--analytic"],
        &[
            "--data",
            "data/public/mpu9250-trials-1-3-x.case.csv",
            "--instrument",
            "mems",
        ],
    ] {
        let mut all = vec!["discover", "--json", "--no-plots"];
        all.extend(args);
        let o = ptsa_in(root(), &all);
        assert!(o.status.success(), "{args:?}");
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let missing = undocumented(&single, &v);
        assert!(
            missing.is_empty(),
            "{args:?}: not in the report types: {missing:?}"
        );
        seen.extend(v.as_object().unwrap().keys().cloned());
    }
    // Every top-level key of the types is printed.
    let props = single["properties"].as_object().unwrap();
    let never: Vec<&String> = props.keys().filter(|k| !seen.contains(*k)).collect();
    assert!(never.is_empty(), "never printed: {never:?}");

    let o = ptsa_in(
        root(),
        &[
            "discover",
            "--data",
            "data/examples/triad-stream.csv",
            "--instrument",
            "mems",
            "--json",
            "--no-plots",
        ],
    );
    assert!(o.status.success());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let keys: Vec<&String> = v.as_object().unwrap().keys().collect();
    assert_eq!(keys, ["data", "instrument", "stream", "triad"]);
    let missing = undocumented(&triad_schema(), &v["triad"]);
    assert!(
        missing.is_empty(),
        "triad: not in the report types: {missing:?}"
    );
}

/// Every key `noise --json` prints is one the types of `noise/json.rs` define (so
/// docs/reference/json.md, written from them, describes it), and every key they define is
/// printed by one of these runs: readings with `--identify`, a counter record with
/// `--compare` and with `--identify`, the simulated loop.
#[test]
fn every_key_noise_prints_is_in_the_reference() {
    let schema = noise_schema();
    let tmp = tempfile::tempdir().unwrap();
    let rec = tmp.path().join("rec.csv");
    let rec = rec.to_str().unwrap();
    let o = ptsa_in(
        root(),
        &["noise", "--simulate", "--seconds", "20", "--output", rec],
    );
    assert!(o.status.success(), "{}", common::stderr(&o));
    let readings = "data/examples/static-readings.csv";
    let mut seen = std::collections::BTreeSet::new();
    for args in [
        &["--readings", readings, "--unit", "g", "--identify"][..],
        &["--counts", rec, "--compare"],
        &["--counts", rec, "--identify"],
        &["--simulate", "--seconds", "2"],
    ] {
        let mut all = vec!["noise", "--json"];
        all.extend(args);
        let o = ptsa_in(root(), &all);
        assert!(o.status.success(), "{args:?}: {}", common::stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let missing = undocumented(&schema, &v);
        assert!(
            missing.is_empty(),
            "{args:?}: not in noise/json.rs: {missing:?}"
        );
        seen.extend(printed_paths(&schema, &v));
    }
    let defined = schema_paths(&schema);
    let never: Vec<&String> = defined.difference(&seen).collect();
    assert!(never.is_empty(), "defined but never printed: {never:?}");
}

/// A report line of the single-axis firmware.
fn report(seq: u64, p: u64, t: u64, gates: u64, tick: u64) -> String {
    format!("gate seq={seq} P={p} T={t} gates={gates} tick={tick} t_ns=0 stack=544\n")
}

/// The inputs the other commands' runs read, made in `d`: a calibration of each kind, a
/// counter record, a log with a gap and a merged report.
fn other_inputs(d: &Path) {
    let made = |args: &str| {
        let args: Vec<&str> = args.split_whitespace().collect();
        let o = ptsa_in(d, &args);
        assert!(o.status.success(), "{args:?}: {}", common::stderr(&o));
        o.stdout
    };
    let data = root().join("data").display().to_string();
    let sn3 = made(&format!(
        "discover --data {data}/examples/tumble-counts.csv --analytic --no-plots --json"
    ));
    std::fs::write(d.join("sn3.json"), sn3).unwrap();
    made(&format!(
        "discover --data {data}/examples/triad-stream.csv --instrument mems --local-gravity 980.4 --no-plots --positions-out positions.csv --write-instrument triad.toml"
    ));
    made("noise --simulate --seconds 4 --gate-s 0.01 --output rec.csv");
    let mut log = String::from("boot\n");
    for (seq, gates, tick) in [(1, 1, 1000), (2, 1, 2000), (5, 1, 5000), (7, 2, 7000)] {
        log += &report(seq, 100 * seq, 1000 * gates, gates, tick);
    }
    std::fs::write(d.join("run.log"), log).unwrap();
}

/// Every key `static`, `predict`, `response`, `record` and `correct` print with `--json` is
/// one their types define (so docs/reference/json.md describes it), and every key a type
/// defines is printed by one of these runs.
#[test]
fn every_key_the_other_commands_print_is_in_the_reference() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    other_inputs(d);
    let data = root().join("data").display().to_string();
    let runs = [
        ("static", "static --accel-cm-s2 1000 --seconds 0.1".to_string()),
        ("static", "static --accel-cm-s2 1000,-2000 --seconds 0.1".into()),
        ("predict", format!("predict --data {data}/synthetic-response.case.csv")),
        ("predict", format!("predict --data {data}/r890-table-6.1.case.csv")),
        (
            "response",
            "response --counts rec.csv --sine-hz 20 --sine-cm-s2 2000 --force".into(),
        ),
        ("record", "record --from run.log --output r.csv --allow-gaps".into()),
        (
            "correct",
            format!("correct --calibration sn3.json --data {data}/examples/check-counts.csv"),
        ),
        (
            "correct triad",
            "correct --calibration triad.toml --data positions.csv --instrument mems --local-gravity 980.4 --sigma 0.07".into(),
        ),
        (
            "monte-carlo --yield",
            "monte-carlo --yield 4 --gates 2 --spec-sf-ppm 1000 --spec-bias-cm-s2 30 --spec-linearity-ppm-fs 100 --spec-noise-cm-s2 10".into(),
        ),
    ];
    let mut seen: std::collections::BTreeMap<&str, std::collections::BTreeSet<String>> =
        std::collections::BTreeMap::new();
    for (name, args) in &runs {
        let mut all: Vec<&str> = args.split_whitespace().collect();
        all.push("--json");
        let o = ptsa_in(d, &all);
        assert!(o.status.success(), "{all:?}: {}", common::stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let schema = command_schema(name).unwrap();
        for item in v.as_array().cloned().unwrap_or_else(|| vec![v.clone()]) {
            let missing = undocumented(&schema, &item);
            assert!(missing.is_empty(), "{all:?}: not in its type: {missing:?}");
            seen.entry(name)
                .or_default()
                .extend(printed_paths(&schema, &item));
        }
    }
    for (name, printed) in seen {
        let defined = schema_paths(&command_schema(name).unwrap());
        let never: Vec<&String> = defined.difference(&printed).collect();
        assert!(
            never.is_empty(),
            "{name}: defined but never printed: {never:?}"
        );
    }
}
