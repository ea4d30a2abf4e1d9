//! The instrument's own model equation (`calibration` in `ptsa discover --json`): tumbles
//! generated here from the IEEE Std 1293 model equation written out (not from the candidate
//! code) with known absolute coefficients come back with those values within their k = 2
//! intervals; the CLI's text block, JSON and calibration sheet.

use ptsa_host_sim::Instrument;
use ptsa_host_sim::discovery::{AnalyticSimulator, Options, discover};
use ptsa_host_sim::lab::plan::{Axis, tumble};
use ptsa_host_sim::model::condition::Condition;
use rand::SeedableRng as _;
use rand_distr::Distribution as _;

/// The instrument's true coefficients, in the IEEE units (g-based).
#[derive(Clone, Copy, Debug)]
pub struct Truth {
    /// `K_0`, g.
    pub k0_g: f64,
    /// `K_1` relative to the file's nominal `f_clk·g/SF`: `K_1 = (1 + eps)·K_1,nom`.
    pub eps: f64,
    /// `δ_o` (IA toward PA), rad.
    pub delta_o: f64,
    /// `δ_p` (IA toward OA), rad.
    pub delta_p: f64,
    /// `K_2`, g/g².
    pub k2: f64,
}

/// The reading in cm/s² of a row whose specific force is `a` (IA, PA, OA) in g: the net
/// pulse rate from the IEEE equation `E = K_1·(K_0 + a_i + K_2·a_i² + δ_o·a_p − δ_p·a_o)`
/// read through the nominal scale factor, `SF·E/f_clk`.
#[must_use]
pub fn reading_cm_s2(t: &Truth, instr: &Instrument, a: [f64; 3]) -> f64 {
    let (a_i, a_p, a_o) = (a[0], a[1], a[2]);
    let k1 = (1.0 + t.eps) * instr.clock_hz * instr.g_cm_s2 / instr.sf_cm_s2;
    let e = k1 * (t.k0_g + a_i + t.k2 * a_i * a_i + t.delta_o * a_p - t.delta_p * a_o);
    instr.sf_cm_s2 * e / instr.clock_hz
}

/// Two 24-point tumbles (about OA and about PA) measured on `t` with white noise
/// `noise_g` (g), seeded.
fn tumbles(t: &Truth, instr: &Instrument, noise_g: f64, seed: u64) -> Vec<Condition> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let noise = rand_distr::Normal::new(0.0, noise_g * instr.g_cm_s2).unwrap();
    let mut rows = tumble(24, Axis::Oa);
    rows.extend(tumble(24, Axis::Pa));
    for r in &mut rows {
        r.measured_cm_s2 = Some(reading_cm_s2(t, instr, r.g) + noise.sample(&mut rng));
        r.sigma_cm_s2 = Some(noise_g * instr.g_cm_s2);
    }
    rows
}

fn term<'a>(v: &'a serde_json::Value, symbol: &str) -> &'a serde_json::Value {
    v["calibration"]["terms"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["symbol"] == symbol)
        .unwrap_or_else(|| panic!("no {symbol}"))
}

#[test]
fn a_tumble_from_the_ieee_equation_gives_back_its_absolute_coefficients() {
    let instr = Instrument::kearfott_2401();
    let truth = Truth {
        k0_g: 19_500e-6,
        eps: -2000e-6,
        delta_o: 120e-6,
        delta_p: -80e-6,
        k2: 30e-6,
    };
    let rows = tumbles(&truth, &instr, 10e-6, 7);
    let sim = AnalyticSimulator::for_instrument(&instr);
    let d = discover(&rows, &sim, &Options::for_instrument(&instr)).unwrap();
    let v = serde_json::to_value(&d.json).unwrap();
    eprintln!(
        "{}",
        serde_json::to_string_pretty(&v["calibration"]).unwrap()
    );
    let k1_nom = instr.clock_hz * instr.g_cm_s2 / instr.sf_cm_s2;
    for (symbol, want, unit) in [
        ("K_0", truth.k0_g * 1e6, "µg"),
        ("K_1", (1.0 + truth.eps) * k1_nom, "(pulse/s)/g"),
        ("δ_o", truth.delta_o * 1e6, "µrad"),
        ("δ_p", truth.delta_p * 1e6, "µrad"),
        ("K_2", truth.k2 * 1e6, "µg/g²"),
    ] {
        let t = term(&v, symbol);
        assert_eq!(t["unit"], unit, "{symbol}");
        assert_eq!(t["measured"], true, "{symbol}");
        let (value, u) = (
            t["value"].as_f64().unwrap(),
            t["expanded_k2"].as_f64().unwrap(),
        );
        assert!(
            (value - want).abs() <= u,
            "{symbol}: {value} ± {u} (k = 2) against the truth {want}"
        );
    }
    // K_1's change is its ppm from the file's nominal; K_0 in cm/s² beside µg.
    let k1 = term(&v, "K_1");
    let ppm = k1["change"].as_f64().unwrap();
    assert!(
        (ppm - truth.eps * 1e6).abs() <= 2.0 * k1["change_sigma"].as_f64().unwrap(),
        "{ppm}"
    );
    assert_eq!(k1["change_unit"], "ppm");
    let k0 = term(&v, "K_0");
    let cgs = k0["value_cgs"].as_f64().unwrap();
    assert!((cgs - truth.k0_g * instr.g_cm_s2).abs() <= 2.0 * k0["sigma_cgs"].as_f64().unwrap());
    // Terms these tumbles cannot test are listed at their nominal value, never as measured.
    // (`a_p·a_o` is 0 in both tumbles).
    let kpo = term(&v, "K_po");
    assert_eq!(kpo["measured"], false);
    assert_eq!(kpo["status"], "not_measured");
    assert_eq!(kpo["value"], kpo["nominal"]);
    assert!(kpo["sigma"].is_null());
    // A higher-order term tested and not named: nominal, with what the data say of it.
    let kip = term(&v, "K_ip");
    assert_eq!(kip["status"], "not_significant");
    assert_eq!(kip["measured"], false);
    assert!(kip["if_fitted"][1].as_f64().unwrap() > 0.0);
}

mod common;

use std::path::Path;
use std::process::{Command, Output};

/// Write the two tumbles of [`a_tumble_from_the_ieee_equation_gives_back_its_absolute_coefficients`]
/// as a case-frame file in `dir`.
fn tumble_file(dir: &Path) -> std::path::PathBuf {
    let instr = Instrument::kearfott_2401();
    let truth = Truth {
        k0_g: 19_500e-6,
        eps: -150e-6,
        delta_o: 120e-6,
        delta_p: -80e-6,
        k2: 30e-6,
    };
    let rows = tumbles(&truth, &instr, 10e-6, 3);
    let p = dir.join("tumble.case.csv");
    std::fs::write(&p, ptsa_host_sim::model::caseframe::to_csv(&rows, &[])).unwrap();
    p
}

/// `ptsa args` in `dir` with `SOURCE_DATE_EPOCH` set to `epoch` (or removed).
fn ptsa_at(dir: &Path, epoch: Option<&str>, args: &[&str]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_ptsa"));
    c.current_dir(dir).args(args);
    match epoch {
        Some(e) => c.env("SOURCE_DATE_EPOCH", e),
        None => c.env_remove("SOURCE_DATE_EPOCH"),
    };
    c.output().unwrap()
}

/// Every file of `dir` with its bytes.
fn contents(dir: &Path) -> Vec<(String, Vec<u8>)> {
    common::names(dir)
        .into_iter()
        .map(|n| {
            let b = std::fs::read(dir.join(&n)).unwrap();
            (n, b)
        })
        .collect()
}

const SHEET_ARGS: [&str; 6] = [
    "discover",
    "--data",
    "tumble.case.csv",
    "--analytic",
    "--no-plots",
    "--sheet",
];

#[test]
fn the_text_report_writes_the_instruments_own_model_equation() {
    let tmp = tempfile::tempdir().unwrap();
    tumble_file(tmp.path());
    let o = common::ptsa_in(tmp.path(), &SHEET_ARGS[..5]);
    let out = common::stdout(&o);
    assert!(o.status.success(), "{}", common::stderr(&o));
    assert!(
        out.contains("calibration: the instrument's own model equation"),
        "{out}"
    );
    // δ_p under its own sign, the equation written out with the values.
    assert!(out.contains("− (−"), "{out}");
    for symbol in ["K_0", "K_1", "K_2", "δ_o", "δ_p", "K_po"] {
        assert!(
            out.lines().any(|l| l.trim_start().starts_with(symbol)),
            "{symbol}: {out}"
        );
    }
    assert!(out.contains("not measured"), "{out}");
}

#[test]
fn the_sheet_holds_the_provenance_the_table_and_the_residuals() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tumble_file(tmp.path());
    let mut args = SHEET_ARGS.to_vec();
    args.push("sn3-sheet");
    let o = ptsa_at(tmp.path(), Some("1790000000"), &args);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let dir = tmp.path().join("sn3-sheet");
    assert_eq!(
        common::names(&dir),
        [
            "sn3-sheet-residuals.png",
            "sn3-sheet-residuals.svg",
            "sn3-sheet.csv",
            "sn3-sheet.md"
        ]
    );
    let md = std::fs::read_to_string(dir.join("sn3-sheet.md")).unwrap();
    let hash = ptsa_host_sim::discovery::sheet::hex(&ptsa_host_sim::discovery::sheet::sha256(
        &std::fs::read(&data).unwrap(),
    ));
    for needle in [
        "tumble.case.csv (48 rows)",
        hash.as_str(),
        "2026-09-21 14:13:20 UTC (SOURCE_DATE_EPOCH)",
        "kearfott-2401.toml",
        "− δ_p·a_o",
        "| K_0 |",
        "## Design",
        "| tumble 90 deg (IA-PA plane, about OA) | absolute | 1 | 0 | 0 |",
        "## Residuals",
        "![residuals](sn3-sheet-residuals.svg)",
    ] {
        assert!(md.contains(needle), "`{needle}` not in the sheet:\n{md}");
    }
    let csv = std::fs::read_to_string(dir.join("sn3-sheet.csv")).unwrap();
    assert!(csv.contains(&format!("# data SHA-256: {hash}")), "{csv}");
    let k0 = csv.lines().find(|l| l.starts_with("K_0,")).unwrap();
    assert!(k0.ends_with(",µg,") || k0.contains(",µg,"), "{k0}");
    // The same data and date give the same sheet, byte for byte.
    let mut again = SHEET_ARGS.to_vec();
    again.push("second-sheet");
    let o = ptsa_at(tmp.path(), Some("1790000000"), &again);
    assert!(o.status.success(), "{}", common::stderr(&o));
    assert_eq!(
        std::fs::read(tmp.path().join("second-sheet/second-sheet.csv"))
            .unwrap()
            .len(),
        std::fs::read(dir.join("sn3-sheet.csv")).unwrap().len()
    );
    let strip = |s: String, name: &str| s.replace(name, "NAME");
    assert_eq!(
        strip(
            std::fs::read_to_string(tmp.path().join("second-sheet/second-sheet.md")).unwrap(),
            "second-sheet"
        ),
        strip(md, "sn3-sheet")
    );
}

#[test]
fn an_existing_sheet_is_kept_byte_for_byte_without_force() {
    let tmp = tempfile::tempdir().unwrap();
    tumble_file(tmp.path());
    let mut args = SHEET_ARGS.to_vec();
    args.push("sheet");
    let o = ptsa_at(tmp.path(), Some("1790000000"), &args);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let dir = tmp.path().join("sheet");
    let before = contents(&dir);
    // Another date: a replaced sheet would differ.
    let o = ptsa_at(tmp.path(), Some("1800000000"), &args);
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("--sheet sheet: the folder exists and is not replaced without --force"),
        "{err}"
    );
    common::assert_clean_of(&err, &[]);
    assert!(o.stdout.is_empty());
    assert_eq!(contents(&dir), before);
    // With --force, an earlier sheet is replaced whole.
    args.push("--force");
    let o = ptsa_at(tmp.path(), Some("1800000000"), &args);
    let err = common::stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("warning: --sheet"), "{err}");
    let md = std::fs::read_to_string(dir.join("sheet.md")).unwrap();
    assert!(md.contains("2027-01-15 08:00:00 UTC"), "{md}");
}

#[test]
fn force_never_replaces_a_folder_that_is_not_a_sheet() {
    let tmp = tempfile::tempdir().unwrap();
    tumble_file(tmp.path());
    let dir = tmp.path().join("logbook");
    std::fs::create_dir(&dir).unwrap();
    std::fs::write(dir.join("notes.txt"), b"the only copy").unwrap();
    let mut args = SHEET_ARGS.to_vec();
    args.extend(["logbook", "--force"]);
    let o = ptsa_at(tmp.path(), None, &args);
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("not an earlier sheet"), "{err}");
    common::assert_clean_of(&err, &[]);
    assert_eq!(
        contents(&dir),
        [("notes.txt".to_string(), b"the only copy".to_vec())]
    );
}

#[test]
fn a_malformed_source_date_epoch_is_refused_before_any_work() {
    let tmp = tempfile::tempdir().unwrap();
    tumble_file(tmp.path());
    let before = contents(tmp.path());
    let mut args = SHEET_ARGS.to_vec();
    args.push("s");
    let o = ptsa_at(tmp.path(), Some("yesterday"), &args);
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("SOURCE_DATE_EPOCH=yesterday: expected whole seconds since 1970-01-01"),
        "{err}"
    );
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    common::assert_clean_of(&err, &[]);
    assert!(o.stdout.is_empty());
    assert_eq!(contents(tmp.path()), before);
}

#[test]
fn a_sheet_is_refused_without_data_or_over_a_file() {
    let tmp = tempfile::tempdir().unwrap();
    // Without --data there is no calibration of an instrument to write (clap: exit 2).
    let o = common::ptsa_in(tmp.path(), &["discover", "--sheet", "s"]);
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("--data"), "{err}");
    assert!(common::names(tmp.path()).is_empty());
    // A file where the folder would go is kept and refused before any work.
    tumble_file(tmp.path());
    std::fs::write(tmp.path().join("notes.md"), b"the logbook").unwrap();
    let before = contents(tmp.path());
    let mut args = SHEET_ARGS.to_vec();
    args.push("notes.md");
    let o = ptsa_at(tmp.path(), None, &args);
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("--sheet notes.md: this is a file; expected a folder"),
        "{err}"
    );
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    common::assert_clean_of(&err, &[]);
    assert_eq!(contents(tmp.path()), before);
}
