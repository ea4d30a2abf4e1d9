//! Properties of the closed loop (plant + ptsa-core): sigma-delta exactness, the estimator
//! against long plain counts, the limit cycle, over-range and recovery.

use proptest::prelude::*;
use ptsa_host_sim::simulation::sim::{ClosedLoop, run_static};
use ptsa_host_sim::{Condition, Effects, Instrument, SimOptions, simulate_condition};

fn ia(a_cm_s2: f64) -> Condition {
    Condition {
        g: [a_cm_s2 / 980.4, 0.0, 0.0],
        ..Condition::default()
    }
}

/// One pulse over a gate of `ticks`, cm/s².
fn pulse(i: &Instrument, ticks: u64) -> f64 {
    #[allow(clippy::cast_precision_loss)]
    let t = ticks as f64;
    2.0 * i.sf_cm_s2 / t
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    /// For a constant input across ±95 % of full scale, the 1 s gate indicates the input
    /// plus the bias (the instrument's A_b and the loop's own, zero for the nominal file), and
    /// every limit cycle has exactly two current reversals.
    ///
    /// The plain count over a gate is off from the input by exactly the charge the pendulum
    /// and torquer hold at the gate's ends, which the loop keeps within about ±1 pulse
    /// (`ptsa-core/tests/properties.rs` measures the same band on a toy pendulum): so the
    /// plain count is within 2 pulses, not 1 (a 1-pulse bound failed for input 0.656 FS,
    /// seed 37: 1.09 pulses). The charge-balance estimator, which adds that stored charge
    /// back, is within 0.01 cm/s².
    #[test]
    fn sigma_delta_exactness(frac in -0.95f64..0.95, seed in 0u64..1000) {
        let i = Instrument::kearfott_2401();
        let opts = SimOptions { seed, ..SimOptions::default() };
        let a = frac * i.sf_cm_s2 - i.bias_cm_s2;
        let r = run_static(&i, a, 64_000, &opts);
        let expect = a + i.bias_cm_s2 + i.loop_bias_cm_s2(0.0);
        prop_assert!((r.indicated_cm_s2 - expect).abs() <= 2.0 * pulse(&i, 64_000),
            "a = {a}: indicated {} expected {expect}", r.indicated_cm_s2);
        let s = simulate_condition(&i, &ia(a), &Effects::default(), &opts);
        prop_assert_eq!(s.cycles, s.cycles_two_reversals);
        prop_assert!((s.indicated_cm_s2 - expect).abs() < 0.01, "estimator {} vs {expect}", s.indicated_cm_s2);
    }
}

/// The charge-balance estimator over 0.1 s agrees with plain pulse counting over 20 s to
/// within the count's own resolution (one pulse over 20 s = 0.033 cm/s²) and the noise.
#[test]
fn estimator_agrees_with_long_plain_counts() {
    let i = Instrument::kearfott_2401();
    let opts = SimOptions::default();
    for a in [-12_000.0, -980.4, 0.0, 333.3, 980.4, 15_000.0] {
        let est = simulate_condition(&i, &ia(a), &Effects::default(), &opts);
        let long = run_static(&i, a, 20 * 64_000, &opts);
        let tol = pulse(&i, 20 * 64_000) + 0.005;
        assert!(
            (est.indicated_cm_s2 - long.indicated_cm_s2).abs() <= tol,
            "a = {a}: estimator {} vs 20 s count {}",
            est.indicated_cm_s2,
            long.indicated_cm_s2
        );
        // The short window's plain count is coarse: one pulse over 0.1 s is 6.6 cm/s².
        assert!((est.count_cm_s2 - est.indicated_cm_s2).abs() <= 2.0 * pulse(&i, est.ticks));
    }
}

/// Beyond full scale the duty saturates (no reversals), the pendulum rides the stop, and
/// the output is clipped at the full scale; back in range the loop recovers within 50 ms.
#[test]
fn over_range_saturates_and_recovers() {
    let i = Instrument::kearfott_2401();
    let opts = SimOptions::default();
    let over = ia(1.3 * i.sf_cm_s2);
    let mut l = ClosedLoop::new(&i, &over, &Effects::default(), &opts);
    l.run(6400);
    let r = l.measure(6400);
    assert_eq!(r.cycles_two_reversals, 0, "{r:?}");
    assert!(r.stop_ticks > 0, "{r:?}");
    assert!((r.count_cm_s2 - i.sf_cm_s2).abs() < 1e-6, "{r:?}");
    assert!(l.core().saturations().integrator > 0);
    // Back in range.
    let a = 0.5 * i.sf_cm_s2;
    l.set_condition(&ia(a), &Effects::default());
    l.run(3200);
    let r = l.measure(6400);
    assert_eq!(r.cycles, r.cycles_two_reversals, "{r:?}");
    assert_eq!(r.stop_ticks, 0);
    assert!((r.indicated_cm_s2 - a - i.bias_cm_s2).abs() < 0.01, "{r:?}");
}

/// `run_fast` (no statistics) keeps the count, the applied-command sum and the state exact:
/// the same seed gives the same pulses and the same estimate as `run`.
#[test]
fn fast_run_matches_full_run() {
    let i = Instrument::kearfott_2401();
    let opts = SimOptions::default();
    let c = ia(1234.5);
    let mut a = ClosedLoop::new(&i, &c, &Effects::default(), &opts);
    let mut b = a.clone();
    a.run(10_007);
    b.run_fast(10_007);
    assert_eq!(a.core(), b.core());
    assert_eq!(a.totals().sum_u, b.totals().sum_u);
    assert_eq!(a.totals().ticks, b.totals().ticks);
    assert_eq!(a.ticks(), b.ticks());
    let (ra, rb) = (a.measure(6400), b.measure(6400));
    assert_eq!(ra.pulses, rb.pulses);
    assert!((ra.indicated_cm_s2 - rb.indicated_cm_s2).abs() < 1e-12);
}

/// A constant extra torque `P·δ` through the physics hook reads as a change of δ in the
/// indicated acceleration.
#[test]
fn extra_physics_enters_as_a_torque() {
    use std::sync::Arc;

    use ptsa_host_sim::CaseInputs;
    use ptsa_host_sim::model::plant::NX;
    use ptsa_host_sim::simulation::sim::{ExtraPhysics, simulate_condition_with};

    #[derive(Debug)]
    struct Push(f64);
    impl ExtraPhysics for Push {
        fn torque_dyn_cm(&self, _: f64, _: &CaseInputs, _: &[f64; NX]) -> f64 {
            self.0
        }
    }
    let i = Instrument::kearfott_2401();
    let opts = SimOptions::default();
    let c = ia(500.0);
    let base = simulate_condition(&i, &c, &Effects::default(), &opts).indicated_cm_s2;
    let pushed = simulate_condition_with(
        &i,
        &c,
        &Effects::default(),
        &opts,
        Arc::new(Push(i.pendulosity_g_cm() * 1.0)),
    )
    .indicated_cm_s2;
    assert!((pushed - base - 1.0).abs() < 1e-3, "{base} {pushed}");
}

/// Bits of everything a run leaves behind: the plant state and every running total.
fn run_bits(l: &ClosedLoop) -> Vec<u64> {
    let mut v: Vec<u64> = l.state().iter().map(|x| x.to_bits()).collect();
    v.extend(l.totals().bits());
    v
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, ..ProptestConfig::default() })]

    /// A run's result does not depend on how its ticks are cut into calls: `n` ticks in one
    /// `run` against the same ticks in calls of drawn lengths, bit for bit, on a condition
    /// oscillating along IA (the phasor is a function of the absolute tick index, exact every
    /// 4096 ticks) and on a static one (the running totals carry through the calls).
    #[test]
    fn a_run_does_not_depend_on_how_it_is_cut(
        freq_hz in 1.0f64..200.0,
        amp in 0.0f64..15_000.0,
        accel in -15_000.0f64..15_000.0,
        cuts in prop::collection::vec(1u64..9000, 1..6),
        seed in 0u64..1000,
    ) {
        let i = Instrument::kearfott_2401();
        let opts = SimOptions { seed, ..SimOptions::default() };
        let oscillating = Condition {
            freq_hz,
            lin_cm_s2: [amp, 0.0, 0.0],
            ..ia(accel)
        };
        for cond in [oscillating, ia(accel)] {
            let n: u64 = cuts.iter().sum();
            let mut whole = ClosedLoop::new(&i, &cond, &Effects::NONE, &opts);
            whole.run(n);
            let mut cut = ClosedLoop::new(&i, &cond, &Effects::NONE, &opts);
            for &m in &cuts {
                cut.run(m);
            }
            prop_assert_eq!(run_bits(&whole), run_bits(&cut), "{:?} in calls of {:?}", cond, cuts);
        }
    }
}
