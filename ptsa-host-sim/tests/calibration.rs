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
