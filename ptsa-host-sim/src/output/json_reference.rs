//! `docs/reference/json.md`: every key of `ptsa discover --json` (a single-axis file, and a
//! triad file's `"triad"`), of `ptsa noise --json` and of the other commands' `--json`
//! (`static`, `predict`, `response`, `record`, `correct`), its type and its meaning, written
//! from the report types' doc comments through their JSON Schema (`schemars`). The test
//! below checks the page is current; `tests/json_reference.rs` runs both commands on the
//! shipped files and checks that every key printed is one of the schema's
//! ([`undocumented`]).

use std::fmt::Write as _;

use serde_json::Value;

use crate::discovery::report::JsonReport;
use crate::noise::json::NoiseJson;
use crate::triad::report::TriadJson;

/// The schema of `discover --json` for a single-axis file.
#[must_use]
pub fn discover_schema() -> Value {
    schemars::schema_for!(JsonReport).to_value()
}

/// The schema of a triad file's `"triad"` object.
#[must_use]
pub fn triad_schema() -> Value {
    schemars::schema_for!(TriadJson).to_value()
}

/// The schema of `noise --json`.
#[must_use]
pub fn noise_schema() -> Value {
    schemars::schema_for!(NoiseJson).to_value()
}

/// The schema of each other command's `--json`, by the command's name: `static`,
/// `predict`, `response`, `record`, `correct` (a single-axis file), `correct triad` and
/// `monte-carlo --yield`.
#[must_use]
pub fn command_schema(command: &str) -> Option<Value> {
    use crate::output::command_json as c;
    let s = match command {
        "static" => schemars::schema_for!(crate::simulation::sim::StaticRun),
        "predict" => schemars::schema_for!(c::PredictJson),
        "response" => schemars::schema_for!(c::ResponseJson),
        "record" => schemars::schema_for!(c::RecordJson),
        "correct" => schemars::schema_for!(c::CorrectJson),
        "correct triad" => schemars::schema_for!(c::TriadCorrectJson),
        "monte-carlo --yield" => {
            schemars::schema_for!(crate::simulation::yield_study::YieldJson)
        }
        _ => return None,
    };
    Some(s.to_value())
}

/// The other commands' sections of the page: heading, what is printed, the schema's name.
const COMMANDS: [(&str, &str, &str); 7] = [
    (
        "`ptsa static --json`",
        "One object for one acceleration; a list of them, in the order given, for several.",
        "static",
    ),
    (
        "`ptsa predict --json`",
        "One object: the prediction of each row of the data.",
        "predict",
    ),
    (
        "`ptsa response --json`",
        "One object: the response row made from the counter record, with its fit and checks.",
        "response",
    ),
    (
        "`ptsa record --json`",
        "One object: what the firmware's log held and the counter record made from it.",
        "record",
    ),
    (
        "`ptsa correct --json`, a single-axis file",
        "One object: each row's specific force along IA, with its uncertainty.",
        "correct",
    ),
    (
        "`ptsa correct --json`, a triad file",
        "One object: each row's specific force in the triad's frame, with its covariance.",
        "correct triad",
    ),
    (
        "`ptsa monte-carlo --yield N --json`",
        "One object: the yield study's plan, its yield with a 95 % interval, each figure's distribution and every instrument drawn.",
        "monte-carlo --yield",
    ),
];

/// `node` with its `$ref` resolved in the root's `$defs`.
fn resolve<'a>(root: &'a Value, node: &'a Value) -> &'a Value {
    match node.get("$ref").and_then(Value::as_str) {
        Some(r) => r
            .strip_prefix("#/$defs/")
            .and_then(|name| root.get("$defs")?.get(name))
            .map_or(node, |d| resolve(root, d)),
        None => node,
    }
}

/// What a value of `node` is, in words, and the object schema its keys are read from (an
/// object, or the objects of an array or a map), if any.
fn kind<'a>(root: &'a Value, node: &'a Value) -> (String, Option<&'a Value>) {
    let node = resolve(root, node);
    if let Some(alts) = node.get("anyOf").and_then(Value::as_array) {
        let (parts, inner): (Vec<String>, Vec<Option<&Value>>) =
            alts.iter().map(|a| kind(root, a)).unzip();
        return (parts.join(" or "), inner.into_iter().flatten().next());
    }
    let types: Vec<&str> = match node.get("type") {
        Some(Value::String(t)) => vec![t.as_str()],
        Some(Value::Array(ts)) => ts.iter().filter_map(Value::as_str).collect(),
        _ => vec![],
    };
    if types == ["null"] {
        return ("null".to_string(), None);
    }
    let nullable = types.contains(&"null");
    let (word, inner) = match types.iter().find(|t| **t != "null").copied() {
        Some("array") => {
            let items = node
                .get("items")
                .or_else(|| node.get("prefixItems").and_then(|p| p.get(0)));
            let (w, i) = items.map_or(("any".to_string(), None), |it| kind(root, it));
            let n = node.get("minItems").and_then(Value::as_u64);
            let fixed = n.filter(|&n| Some(n) == node.get("maxItems").and_then(Value::as_u64));
            (
                match fixed {
                    Some(n) => format!("[{n}] of {w}"),
                    None => format!("list of {w}"),
                },
                i,
            )
        }
        Some("object") if node.get("properties").is_some() => ("object".to_string(), Some(node)),
        Some("object") => match node.get("additionalProperties") {
            Some(v) if v.is_object() => {
                let (w, i) = kind(root, v);
                (format!("map of name → {w}"), i)
            }
            _ => ("object".to_string(), None),
        },
        Some(t) => (t.to_string(), None),
        None => ("any".to_string(), None),
    };
    (
        if nullable {
            format!("{word} or null")
        } else {
            word
        },
        inner,
    )
}

/// One row per key of the object `node` and, after each, its nested keys, `path` before.
fn rows(out: &mut String, root: &Value, node: &Value, path: &str) {
    let Some(props) = node.get("properties").and_then(Value::as_object) else {
        return;
    };
    for (key, sub) in props {
        let (word, inner) = kind(root, sub);
        let what = sub
            .get("description")
            .or_else(|| resolve(root, sub).get("description"))
            .and_then(Value::as_str)
            .unwrap_or("");
        let full = format!("{path}{key}");
        let _ = writeln!(
            out,
            "| `{full}` | {word} | {} |",
            what.split_whitespace()
                .collect::<Vec<_>>()
                .join(" ")
                .replace("[`", "`")
                .replace("`]", "`")
                .replace('|', "\\|")
        );
        if let Some(inner) = inner {
            let nested = if word.starts_with("list") || word.starts_with('[') {
                format!("{full}[].")
            } else if word.starts_with("map") {
                format!("{full}.NAME.")
            } else {
                format!("{full}.")
            };
            rows(out, root, inner, &nested);
        }
    }
}

/// The page.
///
/// # Panics
/// Never: every section of `COMMANDS` names a schema [`command_schema`] has.
#[must_use]
pub fn page() -> String {
    let mut out = String::from(
        "# Reference: the keys of `--json`\n\n\
         Generated from the report types' doc comments (`discovery/report.rs`, \
         `triad/report.rs`, `noise/json.rs`, `output/command_json.rs`) by the test \
         `output::json_reference::tests::the_json_page_is_current` \
         (`PTSA_WRITE_REFERENCE=1 cargo test -p ptsa-host-sim --lib reference` writes it \
         again); `tests/json_reference.rs` checks that every key the commands print on the \
         shipped files is here. Units are in the keys' names (`_cm_s2` cm/s², `_ppm`, \
         `_rad`, `_s`, `_ug` µg) or said. `a[].b` is the key `b` of each element of the \
         list `a`; `a.NAME.b` of each value of the map `a`. The options of every command \
         are in [options.md](options.md).\n\n\
         ## A single-axis file\n\n\
         `ptsa discover --data FILE --json` prints one object:\n\n\
         | key | type | meaning |\n|---|---|---|\n",
    );
    let d = discover_schema();
    rows(&mut out, &d, &d, "");
    out.push_str(
        "\n## A triad file\n\n\
         `ptsa discover --data TRIAD --json` prints `{\"data\", \"instrument\", \"triad\"}` \
         (the two files' names and the calibration below), and `\"stream\"` when the file \
         was a raw stream cut into positions (docs/method/discovery.md, \"A raw stream\"). \
         `\"triad\"`:\n\n\
         | key | type | meaning |\n|---|---|---|\n",
    );
    let t = triad_schema();
    rows(&mut out, &t, &t, "triad.");
    out.push_str(
        "\n## A static record: `ptsa noise --json`\n\n\
         `ptsa noise --counts FILE --json` (or `--readings FILE`, or `--simulate`) prints \
         one object. Its keys are printed in the order of their names; an accelerometer's \
         figures are input-referred, in cm/s²:\n\n\
         | key | type | meaning |\n|---|---|---|\n",
    );
    let n = noise_schema();
    rows(&mut out, &n, &n, "");
    for (heading, what, name) in COMMANDS {
        let _ = write!(
            out,
            "\n## {heading}\n\n{what}\n\n| key | type | meaning |\n|---|---|---|\n"
        );
        let schema = command_schema(name).expect("every section's schema");
        rows(&mut out, &schema, &schema, "");
    }
    out
}

/// The keys of `value` (at any depth) that `schema` does not define, each as its path.
/// A map's keys are its own (any name); an object's must be the schema's properties.
#[must_use]
pub fn undocumented(schema: &Value, value: &Value) -> Vec<String> {
    let mut out = Paths::default();
    walk(schema, schema, value, "", &mut out);
    out.missing
}

/// The paths of the keys `value` holds that `schema` defines, as the page writes them
/// (`a[].b`, `a.NAME.b`).
#[must_use]
pub fn printed_paths(schema: &Value, value: &Value) -> std::collections::BTreeSet<String> {
    let mut out = Paths::default();
    walk(schema, schema, value, "", &mut out);
    out.found
}

/// The paths of every key `schema` defines, as the page writes them.
#[must_use]
pub fn schema_paths(schema: &Value) -> std::collections::BTreeSet<String> {
    let mut page = String::new();
    rows(&mut page, schema, schema, "");
    page.lines()
        .filter_map(|l| l.strip_prefix("| `")?.split('`').next())
        .map(str::to_string)
        .collect()
}

/// What [`walk`] finds: the keys printed that the schema defines, and those it does not.
#[derive(Default)]
struct Paths {
    found: std::collections::BTreeSet<String>,
    missing: Vec<String>,
}

fn walk(root: &Value, node: &Value, value: &Value, path: &str, out: &mut Paths) {
    let node = resolve(root, node);
    if let Some(alts) = node.get("anyOf").and_then(Value::as_array) {
        // The alternative that is not null.
        if let Some(a) = alts
            .iter()
            .find(|a| resolve(root, a).get("type").and_then(Value::as_str) != Some("null"))
        {
            walk(root, a, value, path, out);
        }
        return;
    }
    match value {
        Value::Object(map) => {
            if let Some(props) = node.get("properties").and_then(Value::as_object) {
                for (k, v) in map {
                    match props.get(k) {
                        Some(sub) => {
                            out.found.insert(format!("{path}{k}"));
                            walk(root, sub, v, &format!("{path}{k}."), out);
                        }
                        None => out.missing.push(format!("{path}{k}")),
                    }
                }
            } else if let Some(sub) = node.get("additionalProperties").filter(|s| s.is_object()) {
                for v in map.values() {
                    walk(root, sub, v, &format!("{path}NAME."), out);
                }
            }
        }
        Value::Array(items) => {
            let sub = node
                .get("items")
                .or_else(|| node.get("prefixItems").and_then(|p| p.get(0)));
            if let Some(sub) = sub {
                for v in items {
                    walk(
                        root,
                        sub,
                        v,
                        &format!("{}[].", path.trim_end_matches('.')),
                        out,
                    );
                }
            }
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_json_page_is_current() {
        assert!(
            crate::output::reference_page_is_current("json.md", &page()),
            "docs/reference/json.md is not what the report types define: \
             PTSA_WRITE_REFERENCE=1 cargo test -p ptsa-host-sim --lib reference"
        );
    }

    /// A key the types do not have is found, with its path; a map's own keys are not.
    #[test]
    fn an_undocumented_key_is_named() {
        let s = discover_schema();
        let v = serde_json::json!({
            "rows": 3,
            "nuisance": {"bias_shift_cm_s2": {"block-a": 0.1}},
            "effects": [{"name": "bias", "extra": 1}],
            "surprise": true
        });
        let mut got = undocumented(&s, &v);
        got.sort();
        assert_eq!(got, vec!["effects[].extra", "surprise"]);
    }
}
