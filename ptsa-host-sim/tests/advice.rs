//! The advice closes the loop: data with a known truth whose design confounds it, discover
//! names the confounding and advises rows; the advised rows are measured (simulated with
//! the same truth) and appended; discover then names the truth with no confounding left.

use ptsa_host_sim::discovery::sim::{AnalyticSimulator, Simulator};
use ptsa_host_sim::discovery::{Options, advice, discover, show};
use ptsa_host_sim::lab::plan::{self, Axis};
use ptsa_host_sim::{CandidateId, Condition, Effects, Instrument};
use rand::SeedableRng as _;
use rand_distr::Distribution as _;

/// Measure `rows` with `truth` and Gaussian noise of `sigma` cm/s², stated.
fn measure(rows: &mut [Condition], sim: &dyn Simulator, truth: &Effects, sigma: f64, seed: u64) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let noise = rand_distr::Normal::new(0.0, sigma).unwrap();
    for r in rows {
        r.measured_cm_s2 = Some(sim.absolute_cm_s2(r, truth) + noise.sample(&mut rng));
        r.sigma_cm_s2 = Some(sigma);
    }
}

#[test]
fn advised_rows_tell_a_cubic_from_the_scale_factor_of_a_four_point_tumble() {
    // At 0°, 90°, 180° and 270° about OA, a_IA is g, 0, −g, 0: a_IA³ = g²·a_IA in every
    // position, so a cubic K3 and a scale-factor change K1 fit these rows exactly alike
    // (IEEE Std 1293's reason for more positions). Discover must say so and advise rows
    // that separate them; with those rows measured, the cubic alone is named.
    let instr = Instrument::kearfott_2401();
    let sim = AnalyticSimulator::for_instrument(&instr);
    // 0.05 cm/s² (about 50 µg) at 1 g, inside the file's plausibility bound.
    let g = instr.g_cm_s2;
    let k3 = 0.05 / (g * g * g);
    let truth = Effects::only(CandidateId::Cubic, k3);
    let mut rows = plan::tumble(4, Axis::Oa);
    measure(&mut rows, &sim, &truth, 0.002, 11);
    let opts = Options::for_instrument(&instr);
    let before = discover(&rows, &sim, &opts).unwrap();
    eprintln!("{}", show::text_report("4-point tumble", &before));
    let names = |d: &ptsa_host_sim::discovery::Discovery| -> Vec<CandidateId> {
        d.selected.iter().map(|s| s.id).collect()
    };
    // The exact tie goes to the first-order term, said to be indistinguishable from the
    // cubic.
    assert_eq!(names(&before), [CandidateId::ScaleFactor]);
    assert!(
        before.selected[0]
            .confounded
            .iter()
            .any(|(o, _)| *o == CandidateId::Cubic),
        "{:?}",
        before.selected[0].confounded
    );
    let separating = before
        .json
        .advice
        .iter()
        .find(|a| a.separates.iter().any(|n| n == "cubic"))
        .expect("advice to separate the cubic");
    assert!(!separating.add_rows.is_empty(), "{}", separating.note);
    assert!(separating.add_rows.len() <= advice::MAX_ROWS);
    let mut extra = advice::all_rows(std::slice::from_ref(separating));
    measure(&mut extra, &sim, &truth, 0.002, 12);
    rows.extend(extra);
    let after = discover(&rows, &sim, &opts).unwrap();
    eprintln!("{}", show::text_report("with the advised rows", &after));
    assert_eq!(names(&after), [CandidateId::Cubic]);
    let s = &after.selected[0];
    assert!(s.confounded.is_empty(), "{:?}", s.confounded);
    assert!(s.plausible && !after.json.unexplained.detected);
    assert!(
        (s.coef - k3).abs() < 3.0 * s.stderr,
        "{} ± {}",
        s.coef,
        s.stderr
    );
}
