//! The triad campaign (`ptsa_campaigns::triad`): triads of 8, 12 and 24 positions on a
//! precision fixture, of 24 and 37 positions placed by hand (0.5–1° from nominal), and of
//! 37 positions cut from a raw stream, generated from the equations and calibrated blind by `ptsa_host_sim::triad::fit`; the
//! 95 % intervals' coverage asserted.
//!
//! * `hidden_triad_ci`: [`CI_SETS`] sets of every design (in `cargo test --workspace`).
//! * `hidden_triad_campaign` (ignored): `PTSA_HIDDEN_SETS` sets per design (default 600),
//!   seed `PTSA_HIDDEN_SEED`, run by `cargo xtask hidden --triad`; also asserts 95 ± 2.5 %.
//! * `exact_orientations_on_a_hand_placed_block_are_flagged`: hand-placed sets analysed
//!   as if on a precision fixture: the χ² and the |g| check must say so.

use ptsa_campaigns::campaign::{assert_met, env};
use ptsa_campaigns::triad::{self, G, TriadKind, generate_triad};
use ptsa_host_sim::triad::fit::{self, Orientation};

/// Sets of every design in the CI test.
const CI_SETS: usize = 60;

#[test]
fn hidden_triad_ci() {
    let r = triad::run(CI_SETS, 2026);
    eprintln!("{}", r.table(true));
    assert_met("triad", &r.failures(true));
}

#[test]
#[ignore = "full campaign: cargo xtask hidden --triad --sets 600"]
fn hidden_triad_campaign() {
    let n: usize = env("PTSA_HIDDEN_SETS", 600);
    let seed: u64 = env("PTSA_HIDDEN_SEED", 4242);
    let r = triad::run(n, seed);
    eprintln!("{}", r.table(false));
    assert_met("triad", &r.failures(false));
}

/// A block placed by hand (0.5–1° from nominal) analysed with exact orientations, its
/// sigmas stated: the χ² test and the |g| check both flag it in every set; the same sets
/// with approximate orientations pass both in most.
#[test]
fn exact_orientations_on_a_hand_placed_block_are_flagged() {
    let design = TriadKind::Hand24.design();
    let mut approx_ok = 0;
    for s in 0..20 {
        let mut set = generate_triad(9000 + s, &design, true);
        for p in &mut set.positions {
            p.sigma_cm_s2 = Some(set.sigma);
        }
        let opts = |o| fit::Options {
            orientation: o,
            default_sigma_cm_s2: None,
            g_cm_s2: G,
        };
        let exact = fit::fit("hand.csv", &set.positions, &opts(Orientation::Exact)).unwrap();
        assert!(
            exact.p_value < fit::FLAG_P,
            "set {s}: χ² {} dof {} p {}",
            exact.chi2,
            exact.dof,
            exact.p_value
        );
        assert!(
            exact.g_check.p_value < fit::FLAG_P,
            "set {s}: g check rms {} expected {} p {}",
            exact.g_check.rms_cm_s2,
            exact.g_check.expected_rms_cm_s2,
            exact.g_check.p_value
        );
        assert!(
            exact
                .warnings
                .iter()
                .any(|w| w.contains("--orientation approximate"))
        );
        assert!(exact.warnings.iter().any(|w| w.contains("|g| check fails")));
        let approx = fit::fit("hand.csv", &set.positions, &opts(Orientation::Approximate)).unwrap();
        if approx.p_value >= fit::FLAG_P && approx.g_check.p_value >= fit::FLAG_P {
            approx_ok += 1;
        }
    }
    assert!(
        approx_ok >= 17,
        "{approx_ok} of 20 hand-placed sets pass with approximate orientations"
    );
}
