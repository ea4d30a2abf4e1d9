//! Every key `ptsa discover --json` prints on the shipped files is one the report types
//! define, so `docs/reference/json.md` (written from them) describes it: the R-890 tables,
//! the synthetic tumble and response rows, the counted tumble, a public MEMS record and
//! the triad stream.

mod common;

use std::path::Path;

use common::ptsa_in;
use ptsa_host_sim::output::json_reference::{
    discover_schema, noise_schema, triad_schema, undocumented,
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

/// Every key of an object in `v`, at any depth.
fn keys(v: &serde_json::Value, out: &mut std::collections::BTreeSet<String>) {
    match v {
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                out.insert(k.clone());
                keys(x, out);
            }
        }
        serde_json::Value::Array(a) => a.iter().for_each(|x| keys(x, out)),
        _ => {}
    }
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
        keys(&v, &mut seen);
    }
    let mut defined = std::collections::BTreeSet::new();
    properties(&schema, &mut defined);
    let never: Vec<&String> = defined.difference(&seen).collect();
    assert!(never.is_empty(), "defined but never printed: {never:?}");
}

/// Every property name of `schema` and of its definitions.
fn properties(schema: &serde_json::Value, out: &mut std::collections::BTreeSet<String>) {
    match schema {
        serde_json::Value::Object(m) => {
            if let Some(serde_json::Value::Object(p)) = m.get("properties") {
                out.extend(p.keys().cloned());
            }
            m.values().for_each(|x| properties(x, out));
        }
        serde_json::Value::Array(a) => a.iter().for_each(|x| properties(x, out)),
        _ => {}
    }
}
