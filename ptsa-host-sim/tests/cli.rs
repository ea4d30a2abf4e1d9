//! The `ptsa` binary's contract: `static --json` prints exactly one object.

use std::process::Command;

#[test]
fn static_json_is_one_object_with_eq_6_1() {
    let out = Command::new(env!("CARGO_BIN_EXE_ptsa"))
        .args([
            "static",
            "--accel-cm-s2",
            "-250.5",
            "--seconds",
            "0.5",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(text.lines().count(), 1, "{text}");
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let o = v.as_object().unwrap();
    let keys: Vec<&str> = o.keys().map(String::as_str).collect();
    assert_eq!(keys.len(), 4);
    for k in ["ticks", "pulses", "indicated_cm_s2", "saturated"] {
        assert!(o.contains_key(k), "{text}");
    }
    assert_eq!(o["saturated"], false);
    let t = o["ticks"].as_u64().unwrap();
    let p = o["pulses"].as_u64().unwrap();
    assert_eq!(t, 32_000);
    #[allow(clippy::cast_precision_loss)]
    let x = 21121.1 * (2.0 * p as f64 / t as f64 - 1.0);
    let got = o["indicated_cm_s2"].as_f64().unwrap();
    assert!((got - x).abs() < 1e-9, "{got} vs {x}");
    // Within one pulse over the gate of the input (the loop's own bias is 0 for the shipped
    // file; the measured A_b only with --with-bias).
    assert!((got - -250.5).abs() <= 2.0 * 21121.1 / 32_000.0, "{got}");
    let out = Command::new(env!("CARGO_BIN_EXE_ptsa"))
        .args([
            "static",
            "--accel-cm-s2",
            "-250.5",
            "--seconds",
            "0.5",
            "--json",
            "--with-bias",
        ])
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let got = v["indicated_cm_s2"].as_f64().unwrap();
    assert!(
        (got - (-250.5 + 18.7)).abs() <= 2.0 * 21121.1 / 32_000.0,
        "{got}"
    );
}

#[test]
fn bad_instrument_file_is_refused_with_position() {
    let dir = std::env::temp_dir().join(format!("ptsa-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("bad.toml");
    let text = include_str!("../../data/kearfott-2401.toml").replace(
        "damping_dyn_cm_s = { value = 76400.0",
        "damping_dyn_cm_s = { value = \"fast\"",
    );
    std::fs::write(&f, text).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_ptsa"))
        .args([
            "--instrument",
            f.to_str().unwrap(),
            "static",
            "--accel-cm-s2",
            "0",
            "--seconds",
            "0.01",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.toml:"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
