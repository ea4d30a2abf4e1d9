//! Real records with a published answer (`data/public/`, `data/README.md`): an MPU-9250's
//! six-position calibration, three trials per axis, against the calibration its authors
//! published. With the shipped `mems` class as it is (its bias bound, 80 mg, is below the
//! part's 91 mg and 249 mg) every core coefficient of ptsa's calibration is within 2 σ of the
//! published one, and no structure is left unexplained for a term the class's bound
//! flagged (issue 43, items 3 and 4).

mod common;

use common::stdout;

/// The authors' model 3, mean of the three trials (`data/README.md`): `b` in g, then
/// `S_ii`, `S_pa`, `S_oa`.
const PUBLISHED: [(&str, [f64; 4]); 3] = [
    ("x", [0.090_864_8, 0.999_961_3, 0.007_025_8, 0.008_266_5]),
    ("y", [0.046_867_2, 1.000_192_1, 0.010_715_5, -0.006_050_4]),
    ("z", [-0.249_152_6, 1.022_051_7, -0.009_748_0, -0.004_476_0]),
];

fn discover(axis: &str) -> serde_json::Value {
    let data = format!(
        "{}/../data/public/mpu9250-trials-1-3-{axis}.case.csv",
        env!("CARGO_MANIFEST_DIR")
    );
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_ptsa"))
        .args([
            "--instrument",
            "mems",
            "discover",
            "--data",
            &data,
            "--no-plots",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_str(&stdout(&o)).unwrap()
}

fn term(v: &serde_json::Value, symbol: &str) -> (f64, f64) {
    let t = v["calibration"]["terms"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["symbol"] == symbol)
        .unwrap();
    (
        t["value"].as_f64().unwrap(),
        t["sigma"].as_f64().unwrap_or(f64::NAN),
    )
}

#[test]
fn the_mpu9250_calibration_agrees_with_the_published_one() {
    for (axis, [b, s, spa, soa]) in PUBLISHED {
        let v = discover(axis);
        let want = [
            ("K_0", b / s * 1e6),
            ("K_1", 16384.0 * s),
            ("δ_o", spa / s * 1e6),
            ("δ_p", -soa / s * 1e6),
        ];
        for (symbol, w) in want {
            let (value, sigma) = term(&v, symbol);
            // The figures of docs/method/discovery.md's table (`-- --nocapture`).
            eprintln!(
                "{axis} {symbol}: {value:.1} ± {sigma:.2} against the published {w:.1} ({:+.2} σ)",
                (value - w) / sigma
            );
            assert!(
                (value - w).abs() <= 2.0 * sigma,
                "{axis} {symbol}: {value} ± {sigma} against the published {w}"
            );
        }
        // The reading's offset is the authors' b (their model is output-referred).
        let o = &v["calibration"]["reading_offset"];
        let (off, sigma) = (o["value"].as_f64().unwrap(), o["sigma"].as_f64().unwrap());
        assert!(
            (off - b * 1e6).abs() <= 2.0 * sigma,
            "{axis}: offset {off} ± {sigma} µg"
        );
        // The x and z biases are beyond the class's 78.5 cm/s² (80 mg): flagged, and kept in
        // the model; y's 46 cm/s² is within it.
        let bias = v["effects"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["name"] == "bias")
            .unwrap();
        assert_eq!(bias["plausible"], axis == "y", "{axis}");
        // No library form is left for a term the bound flagged: x and y fit; z's one
        // finding is the replicated positions' lack of fit, no form of the library.
        let u = &v["unexplained"];
        for t in u["tests"].as_array().unwrap() {
            if t["name"] != "lack_of_fit" {
                assert!(t["p_value"].as_f64().unwrap() > 0.05, "{axis}: {t}");
            }
        }
        if axis != "z" {
            assert_eq!(u["detected"], false, "{axis}: {}", v["verdict"]);
        }
    }
}
