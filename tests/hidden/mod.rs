//! Hidden-effect generator and campaign: synthetic measured sets built from a simulator
//! with one effect of the vocabulary hidden in them (random sign and size) or none, and the
//! scoring of the pipeline's blind answer (`tests/hidden_effects.rs`, `cargo xtask hidden`).
//! Test support: not part of `ptsa-host-sim`'s interface.
//!
//! Designs (chosen at random per set, redrawn until the hidden effect leaves a signature):
//! * **rate table**, like Table 6.1: 8–16 positions of IA in a vertical plane (the IA–PA
//!   plane turned about OA, or the IA–OA plane turned about PA), table rate 0.5–2 rad/s about
//!   the vertical, reference 0.05 rad/s;
//! * **two-axis oscillator**, like Appendix A: blocks of 4–8 phases each of linear vibration
//!   along IA+PA, IA+OA, OA rocking with PA vibration, and two-axis angular oscillation
//!   (IA+OA, IA+PA), and random three-axis vibration with OA rocking at random phases, at
//!   one frequency of 5–40 Hz, with gravity along a random case axis;
//! * both together.
//!
//! Noise: one sigma per set, uniform in 0.1–0.3 cm/s², written in `sigma_cm_s2` (in a
//! quarter of the sets the column is left out, so the pipeline falls back on its default
//! 0.3 cm/s², at or above the true noise). The hidden coefficient is `±s·SE`, `s` uniform
//! in 3–30, where SE is the standard error of that coefficient alone in this design with
//! the sigma the pipeline is given.

pub mod physics;

use std::fmt::Write as _;

use rayon::prelude::*;

use ptsa_host_sim::condition::Condition;
use ptsa_host_sim::discovery::sim::{AnalyticSimulator, Simulator, gross_effect_cm_s2};
use ptsa_host_sim::discovery::{Discovery, Options, discover};
use ptsa_host_sim::effects::{CandidateId, Effects, N_CANDIDATES};

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// The seeded generator of the sets (ChaCha8: the same stream on every machine).
pub type Rng = rand_chacha::ChaCha8Rng;

/// The draws the generator makes, on any [`rand::Rng`].
pub trait Draw: rand::Rng {
    /// Uniform in [0, 1).
    fn uniform(&mut self) -> f64 {
        self.random::<f64>()
    }
    /// Uniform in [lo, hi).
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        self.random_range(lo..hi)
    }
    /// Uniform integer in [lo, hi].
    fn int(&mut self, lo: usize, hi: usize) -> usize {
        self.random_range(lo..=hi)
    }
    /// Standard normal.
    fn normal(&mut self) -> f64 {
        self.sample(rand_distr::StandardNormal)
    }
    /// Random sign.
    fn sign(&mut self) -> f64 {
        if self.random::<bool>() { 1.0 } else { -1.0 }
    }
}

impl<R: rand::Rng + ?Sized> Draw for R {}

/// A generator seeded with `seed`.
#[must_use]
pub fn rng(seed: u64) -> Rng {
    rand::SeedableRng::seed_from_u64(seed)
}

/// What was hidden in a set.
#[derive(Clone, Debug)]
pub struct Truth {
    /// Hidden candidate, or `None` for a null set.
    pub id: Option<CandidateId>,
    /// Its coefficient, in the candidate's unit.
    pub coef: f64,
    /// `|coef|` in standard errors of that coefficient alone in this design.
    pub strength_se: f64,
    /// Design name.
    pub design: String,
    /// Noise sigma, cm/s².
    pub sigma_cm_s2: f64,
}

/// A synthetic measured set.
#[derive(Clone, Debug)]
pub struct HiddenSet {
    /// Rows in the case frame, with `measured_cm_s2` and `sigma_cm_s2`.
    pub rows: Vec<Condition>,
    /// What was hidden.
    pub truth: Truth,
}

fn up(axis: usize, sign: f64) -> [f64; 3] {
    let mut g = [0.0; 3];
    g[axis] = sign;
    g
}

/// Table 6.1-like rate-table design.
fn rate_table(rng: &mut Rng) -> Vec<Condition> {
    let n = rng.int(8, 16);
    let other = if rng.uniform() < 0.5 { 1 } else { 2 }; // PA or OA in the vertical plane
    #[allow(clippy::cast_precision_loss)]
    let step = 360.0 / n as f64;
    let offset = if rng.uniform() < 0.5 {
        0.0
    } else {
        rng.range(0.0, step)
    };
    let w = rng.range(0.5, 2.0);
    (0..n)
        .map(|k| {
            #[allow(clippy::cast_precision_loss)]
            let phi = offset + step * (k + 1) as f64;
            let (s, c) = phi.to_radians().sin_cos();
            let mut u = [0.0; 3];
            u[0] = s;
            u[other] = c;
            Condition {
                label: format!(
                    "rate table IA {phi:.1} deg in IA-{} plane",
                    if other == 1 { "PA" } else { "OA" }
                ),
                g: u,
                w_rad_s: u.map(|x| w * x),
                ref_w_rad_s: u.map(|x| 0.05 * x),
                ..Condition::default()
            }
        })
        .collect()
}

/// Appendix A-like two-axis oscillator design.
fn two_axis(rng: &mut Rng) -> Vec<Condition> {
    let g = up(rng.int(0, 2), rng.sign());
    let freqs = [5.0, 10.0, 20.0, 40.0];
    let f = freqs[rng.int(0, 3)];
    let nph = rng.int(3, 8);
    let mut blocks: Vec<usize> = (0..6).filter(|_| rng.uniform() < 0.5).collect();
    while blocks.len() < 2 {
        let b = rng.int(0, 5);
        if !blocks.contains(&b) {
            blocks.push(b);
        }
    }
    blocks.sort_unstable();
    let mut rows = Vec::new();
    for b in blocks {
        let a1 = rng.range(100.0, 500.0);
        let a2 = rng.range(100.0, 500.0);
        let th1 = rng.range(0.5, 2.0);
        let th2 = rng.range(0.5, 2.0);
        for k in 0..nph {
            #[allow(clippy::cast_precision_loss)]
            let psi = 360.0 * k as f64 / nph as f64;
            let mut c = Condition {
                g,
                freq_hz: f,
                ..Condition::default()
            };
            let what = match b {
                0 => {
                    c.lin_cm_s2 = [a1, a2, 0.0];
                    c.lin_deg = [0.0, psi, 0.0];
                    "IA+PA vibration"
                }
                1 => {
                    c.lin_cm_s2 = [a1, 0.0, a2];
                    c.lin_deg = [0.0, 0.0, psi];
                    "IA+OA vibration"
                }
                2 => {
                    c.ang_mrad = [0.0, 0.0, th1];
                    c.lin_cm_s2 = [0.0, a2, 0.0];
                    c.lin_deg = [0.0, psi, 0.0];
                    "OA rocking + PA vibration"
                }
                3 => {
                    c.ang_mrad = [th1, 0.0, th2];
                    c.ang_deg = [0.0, 0.0, psi];
                    "IA+OA rocking"
                }
                4 => {
                    c.ang_mrad = [th1, th2, 0.0];
                    c.ang_deg = [0.0, psi, 0.0];
                    "IA+PA rocking"
                }
                _ => {
                    // Random three-axis vibration with OA rocking, random phases: partial
                    // correlations between every vibration candidate.
                    c.lin_cm_s2 = [0.0; 3].map(|_| rng.range(0.0, 500.0));
                    c.lin_deg = [0.0; 3].map(|_| rng.range(0.0, 360.0));
                    c.ang_mrad = [0.0, 0.0, rng.range(0.0, 2.0)];
                    c.ang_deg = [0.0, 0.0, rng.range(0.0, 360.0)];
                    "random vibration"
                }
            };
            c.label = format!("{what} {f} Hz phase {psi:.0} deg");
            rows.push(c);
        }
    }
    rows
}

/// A fixed 48-row design (16 rate-table positions in the IA–PA plane, then 8 phases each of
/// IA+PA vibration, IA+OA vibration, OA rocking with PA vibration and IA+OA rocking at
/// 10 Hz with IA up), with `measured_cm_s2` from `sim` with `effects` plus noise of
/// `sigma` cm/s² (seeded): the size the speed target is stated for.
#[must_use]
pub fn design_48(sim: &dyn Simulator, effects: &Effects, sigma: f64, seed: u64) -> Vec<Condition> {
    let mut rng = rng(seed);
    let mut rows = Vec::new();
    for k in 0..16 {
        let phi = 22.5 * f64::from(k + 1);
        let (s, c) = phi.to_radians().sin_cos();
        rows.push(Condition {
            label: format!("rate table IA {phi} deg"),
            g: [s, c, 0.0],
            w_rad_s: [s, c, 0.0],
            ref_w_rad_s: [0.05 * s, 0.05 * c, 0.0],
            ..Condition::default()
        });
    }
    for (b, what) in [
        "IA+PA vibration",
        "IA+OA vibration",
        "OA rocking + PA vibration",
        "IA+OA rocking",
    ]
    .iter()
    .enumerate()
    {
        for k in 0..8 {
            let psi = 45.0 * f64::from(k);
            let mut c = Condition {
                g: [1.0, 0.0, 0.0],
                freq_hz: 10.0,
                ..Condition::default()
            };
            match b {
                0 => {
                    c.lin_cm_s2 = [300.0, 300.0, 0.0];
                    c.lin_deg = [0.0, psi, 0.0];
                }
                1 => {
                    c.lin_cm_s2 = [300.0, 0.0, 300.0];
                    c.lin_deg = [0.0, 0.0, psi];
                }
                2 => {
                    c.ang_mrad = [0.0, 0.0, 1.0];
                    c.lin_cm_s2 = [0.0, 300.0, 0.0];
                    c.lin_deg = [0.0, psi, 0.0];
                }
                _ => {
                    c.ang_mrad = [1.0, 0.0, 1.0];
                    c.ang_deg = [0.0, 0.0, psi];
                }
            }
            c.label = format!("{what} 10 Hz phase {psi} deg");
            rows.push(c);
        }
    }
    let clean: Vec<f64> = rows
        .par_iter()
        .map(|r| sim.difference_cm_s2(r, effects))
        .collect();
    for (r, y) in rows.iter_mut().zip(clean) {
        r.measured_cm_s2 = Some(y + sigma * rng.normal());
        r.sigma_cm_s2 = Some(sigma);
    }
    rows
}

/// Build one set with candidate `hidden` (or none) hidden, from `sim`.
#[must_use]
pub fn generate(seed: u64, hidden: Option<CandidateId>, sim: &dyn Simulator) -> HiddenSet {
    let mut rng = rng(seed);
    let sigma = rng.range(0.1, 0.3);
    let write_sigma = rng.uniform() >= 0.25;
    let stated = sigma;
    let (mut rows, mut design) = (Vec::new(), String::new());
    let mut se = f64::INFINITY;
    for _ in 0..50 {
        let kind = rng.int(0, 2);
        rows = match kind {
            0 => rate_table(&mut rng),
            1 => two_axis(&mut rng),
            _ => {
                let mut r = rate_table(&mut rng);
                r.extend(two_axis(&mut rng));
                r
            }
        };
        design = [
            "rate table",
            "two-axis oscillator",
            "rate table + two-axis oscillator",
        ][kind]
            .to_string();
        let Some(h) = hidden else { break };
        let e = Effects::only(h, 1.0);
        let analytic = AnalyticSimulator {
            g_cm_s2: sim.g_cm_s2(),
        };
        let col: Vec<f64> = rows
            .iter()
            .map(|r| analytic.difference_cm_s2(r, &e))
            .collect();
        let visible = rows.iter().zip(&col).any(|(r, &x)| {
            x.abs() > 1e-6 * gross_effect_cm_s2(r, &e, sim.g_cm_s2()) && x.abs() > 0.0
        });
        if visible {
            se = stated / norm(&col);
            break;
        }
    }
    let strength = if hidden.is_some() {
        rng.range(3.0, 30.0)
    } else {
        0.0
    };
    let coef = if hidden.is_some() && se.is_finite() {
        rng.sign() * strength * se
    } else {
        0.0
    };
    let effects = hidden.map_or(Effects::NONE, |h| Effects::only(h, coef));
    let clean: Vec<f64> = rows
        .par_iter()
        .map(|r| sim.difference_cm_s2(r, &effects))
        .collect();
    for (r, y) in rows.iter_mut().zip(clean) {
        r.measured_cm_s2 = Some(y + sigma * rng.normal());
        r.sigma_cm_s2 = write_sigma.then_some(sigma);
    }
    HiddenSet {
        rows,
        truth: Truth {
            id: hidden,
            coef,
            strength_se: if se.is_finite() { strength } else { 0.0 },
            design,
            sigma_cm_s2: sigma,
        },
    }
}

/// How the pipeline did on one set.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// What was hidden.
    pub truth: Truth,
    /// The hidden effect was selected, by name or within a reported confounded group.
    pub detected: bool,
    /// For a detected effect: the coefficient is within 4 standard errors of the truth
    /// (through the confounding factor when it was found through a confounded partner).
    pub coef_within_4se: Option<bool>,
    /// `(estimate − truth)/stderr` of that coefficient.
    pub z: Option<f64>,
    /// Selected effects that are neither the hidden one nor confounded with it.
    pub false_discoveries: usize,
    /// Names selected, for the log.
    pub selected: Vec<String>,
}

/// Score the pipeline's answer `d` for set `set`.
#[must_use]
pub fn score(set: &HiddenSet, d: &Discovery) -> Outcome {
    let t = &set.truth;
    let mut detected = false;
    let mut coef_ok = None;
    let mut zval = None;
    let mut fd = 0;
    for s in &d.selected {
        let hit = match t.id {
            Some(h) if s.id == h => Some(1.0),
            Some(h) => s.confounded.iter().find(|(o, _)| *o == h).map(|&(_, f)| f),
            None => None,
        };
        if let Some(f) = hit {
            detected = true;
            let z = (s.coef - f * t.coef) / s.stderr;
            zval = Some(z);
            coef_ok = Some(z.abs() <= 4.0);
        } else {
            fd += 1;
        }
    }
    Outcome {
        truth: t.clone(),
        detected,
        coef_within_4se: coef_ok,
        z: zval,
        false_discoveries: fd,
        selected: d
            .selected
            .iter()
            .map(|s| s.id.info().name.to_string())
            .collect(),
    }
}

/// Rates measured by a campaign.
#[derive(Clone, Debug, Default)]
pub struct CampaignSummary {
    /// Sets with an effect of at least 8 standard errors.
    pub strong: usize,
    /// Of those, detected (right name or confounded group).
    pub strong_detected: usize,
    /// Detected strong sets whose coefficient is within 4 standard errors.
    pub strong_coef_ok: usize,
    /// Null sets.
    pub null: usize,
    /// Null sets with any selected effect.
    pub null_false: usize,
    /// Non-null sets with a selected effect other than the hidden one or its group.
    pub extra_false: usize,
    /// Non-null sets.
    pub nonnull: usize,
    /// Per-candidate `(strong, detected)`.
    pub per_candidate: Vec<(usize, usize)>,
    /// Printable log.
    pub log: String,
}

impl CampaignSummary {
    /// Detection rate over strong sets.
    #[must_use]
    pub fn detection_rate(&self) -> f64 {
        ratio(self.strong_detected, self.strong)
    }
    /// Coefficient-within-4-SE rate over detected strong sets.
    #[must_use]
    pub fn coef_rate(&self) -> f64 {
        ratio(self.strong_coef_ok, self.strong_detected)
    }
    /// False-discovery rate on null sets (sets with any selection / null sets).
    #[must_use]
    pub fn null_false_rate(&self) -> f64 {
        ratio(self.null_false, self.null)
    }
}

#[allow(clippy::cast_precision_loss)]
fn ratio(a: usize, b: usize) -> f64 {
    if b == 0 {
        f64::NAN
    } else {
        a as f64 / b as f64
    }
}

/// Run `sets_per_effect` sets for every candidate and `null_sets` null sets, seeds derived
/// from `seed`; `gen_sim` builds the data, `fit_sim` is what the pipeline uses.
#[must_use]
pub fn campaign(
    sets_per_effect: usize,
    null_sets: usize,
    seed: u64,
    gen_sim: &dyn Simulator,
    fit_sim: &dyn Simulator,
) -> CampaignSummary {
    let mut jobs: Vec<(u64, Option<CandidateId>)> = Vec::new();
    for &c in CandidateId::ALL {
        for k in 0..sets_per_effect {
            jobs.push((
                seed.wrapping_mul(1_000_003)
                    .wrapping_add((c.index() as u64 + 1) * 100_000 + k as u64),
                Some(c),
            ));
        }
    }
    for k in 0..null_sets {
        jobs.push((
            seed.wrapping_mul(1_000_003)
                .wrapping_add(900_000 + k as u64),
            None,
        ));
    }
    let opts = Options::default();
    let outcomes: Vec<Outcome> = jobs
        .par_iter()
        .map(|&(s, h)| {
            let set = generate(s, h, gen_sim);
            match discover(&set.rows, fit_sim, &opts) {
                Ok(d) => score(&set, &d),
                Err(_) => Outcome {
                    truth: set.truth.clone(),
                    detected: false,
                    coef_within_4se: None,
                    z: None,
                    false_discoveries: 0,
                    selected: vec![],
                },
            }
        })
        .collect();
    let mut s = CampaignSummary {
        per_candidate: vec![(0, 0); N_CANDIDATES],
        ..CampaignSummary::default()
    };
    for o in &outcomes {
        let name = o.truth.id.map_or("(none)", |h| h.info().name);
        let _ = writeln!(
            s.log,
            "{name:<20} {:>5.1} SE  {:<32} sigma {:.2}  -> {:<40} detected {:<5} z {}",
            o.truth.strength_se,
            o.truth.design,
            o.truth.sigma_cm_s2,
            if o.selected.is_empty() {
                "-".to_string()
            } else {
                o.selected.join(",")
            },
            o.detected,
            o.z.map_or("-".to_string(), |z| format!("{z:+.2}"))
        );
        match o.truth.id {
            None => {
                s.null += 1;
                if !o.selected.is_empty() {
                    s.null_false += 1;
                }
            }
            Some(h) => {
                s.nonnull += 1;
                if o.false_discoveries > 0 {
                    s.extra_false += 1;
                }
                if o.truth.strength_se >= 8.0 {
                    s.strong += 1;
                    s.per_candidate[h.index()].0 += 1;
                    if o.detected {
                        s.strong_detected += 1;
                        s.per_candidate[h.index()].1 += 1;
                        if o.coef_within_4se == Some(true) {
                            s.strong_coef_ok += 1;
                        }
                    }
                }
            }
        }
    }
    let _ = writeln!(s.log, "\nper candidate (sets >= 8 SE: detected/total):");
    for (c, (n, k)) in s.per_candidate.iter().enumerate() {
        let _ = writeln!(s.log, "  {:<20} {k}/{n}", CandidateId::ALL[c].info().name);
    }
    let _ = writeln!(
        s.log,
        "\ndetection (>= 8 SE): {}/{} = {:.1}%\ncoefficient within 4 SE: {}/{} = {:.1}%\n\
         false discoveries on null sets: {}/{} = {:.1}%\nnon-null sets with an extra (unrelated) selection: {}/{}",
        s.strong_detected,
        s.strong,
        100.0 * s.detection_rate(),
        s.strong_coef_ok,
        s.strong_detected,
        100.0 * s.coef_rate(),
        s.null_false,
        s.null,
        100.0 * s.null_false_rate(),
        s.extra_false,
        s.nonnull
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn analytic() -> AnalyticSimulator {
        AnalyticSimulator::for_instrument(&ptsa_host_sim::Instrument::kearfott_2401())
    }

    /// Null sets whose stated sigma is a third of the true noise: the F half of the test
    /// keeps the familywise rate at 5% or less.
    #[test]
    fn understated_sigma_does_not_inflate_false_discoveries() {
        let mut false_sets = 0;
        let n = 300;
        for k in 0..n {
            let mut set = generate(10_000 + k, None, &analytic());
            for r in &mut set.rows {
                let s = r.sigma_cm_s2.unwrap_or(0.3);
                let m = r.measured_cm_s2.unwrap_or(0.0);
                // noise ×3, stated sigma unchanged
                r.measured_cm_s2 = Some(3.0 * m);
                r.sigma_cm_s2 = Some(s);
            }
            let d = discover(&set.rows, &analytic(), &Options::default()).unwrap();
            if !d.selected.is_empty() {
                false_sets += 1;
            }
        }
        eprintln!("understated sigma: {false_sets}/{n} null sets with a selection");
        assert!(f64::from(false_sets) <= 0.05 * f64::from(u32::try_from(n).unwrap()) + 3.0);
    }

    /// A whole lever-arm vector hidden in a Table 6.1-like design: the IA component is
    /// found by name, the PA component through anisoinertia's confounding.
    #[test]
    fn whole_lever_arm_vector_in_a_rate_table_design() {
        let mut rng = rng(3);
        let mut rows = rate_table(&mut rng);
        for r in &mut rows {
            let [a, b, c] = r.g;
            r.g = [a, b.abs().max(c.abs()) * (b + c).signum(), 0.0];
            r.w_rad_s = r.g.map(|x| x * 1.5);
            r.ref_w_rad_s = r.g.map(|x| x * 0.05);
        }
        let mut truth = Effects::NONE;
        truth.add_lever_arm_cm([2.0, -3.0, 5.0]);
        for r in &mut rows {
            r.measured_cm_s2 = Some(analytic().difference_cm_s2(r, &truth) + 0.2 * rng.normal());
            r.sigma_cm_s2 = Some(0.2);
        }
        let d = discover(&rows, &analytic(), &Options::default()).unwrap();
        eprintln!(
            "{}",
            ptsa_host_sim::discovery::show::text_report("lever arm vector", &d)
        );
        let names: Vec<&str> = d.selected.iter().map(|s| s.id.info().name).collect();
        assert!(names.contains(&"lever_arm.r_ia_cm"), "{names:?}");
        assert!(names.contains(&"anisoinertia"), "{names:?}");
        assert!(
            d.json
                .effects
                .iter()
                .any(|e| e.confounded_with.contains(&"lever_arm.r_pa_cm".to_string()))
        );
        assert!(
            !d.json
                .effects
                .iter()
                .any(|e| e.coefficients.contains_key("r_oa_cm"))
        );
    }

    /// `data/synthetic-48.case.csv` is what [`design_48`] makes (anisoinertia 3.0 cm hidden,
    /// noise 0.2 cm/s², seed 5, analytic model, so it is exactly reproducible). With
    /// `PTSA_WRITE_REPORT_DATA=1` the test rewrites it instead.
    #[test]
    fn synthetic_48_file_is_what_the_generator_makes() {
        use ptsa_host_sim::discovery::caseframe;
        let truth = Effects::only(CandidateId::Anisoinertia, 3.0);
        let rows = design_48(&analytic(), &truth, 0.2, 5);
        let text = caseframe::to_csv(
            &rows,
            &[
                "Synthetic example, not measured: 16 rate-table rows and 32 two-axis-oscillator rows",
                "(ptsa_tests::hidden::design_48) with anisoinertia k_ai_cm = 3.0 hidden and noise 0.2 cm/s^2, seed 5.",
                "Generated by the test ptsa_tests::hidden::synthetic_48_file_is_what_the_generator_makes; do not edit.",
            ],
        );
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/synthetic-48.case.csv");
        if std::env::var_os("PTSA_WRITE_REPORT_DATA").is_some() {
            std::fs::write(&path, &text).unwrap();
        }
        let shipped = std::fs::read_to_string(&path).unwrap();
        assert_eq!(
            shipped, text,
            "data/synthetic-48.case.csv differs from the generator"
        );
    }
}
