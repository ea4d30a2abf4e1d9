//! Hidden noise terms (`ptsa noise --readings FILE --identify`,
//! `ptsa_host_sim::noise::identify_terms`): static records of readings made here from the
//! physics of each term, sharing nothing with the identification's own replicas
//! (`noise::synth`): a velocity counter's quantization (a steady motion through a counter
//! of quantum `q`, so `Q = q/√12`), white acceleration noise and a random walk from a
//! xorshift generator and Box–Muller, a rate ramp, and flicker noise by Kasdin and
//! Walter's fractional integrator of order ½ (white of standard deviation `B` filtered by
//! `h_k = h_{k−1}(k − ½)/k`: one-sided density `B²/(π f)`, IEEE Std 952's `B`).
//!
//! * `hidden_terms_ci` (in `cargo test --workspace`, so in `cargo xtask ci`): [`CI_SETS`]
//!   records of each asserted kind, seed 2027.
//! * `hidden_terms_campaign` (ignored): `PTSA_HIDDEN_SETS` records per kind (default 200),
//!   seed `PTSA_HIDDEN_SEED` (default 4242), run by `cargo xtask hidden --noise-terms`.
//!
//! Asserted over the asserted kinds together: records with a term selected that is not in
//! them (one-sided binomial test at 1 % against the familywise 5 %), the 95 % intervals'
//! coverage of the true coefficients among the terms found (one-sided at 1 % against
//! 95 %, pooled over the terms; each term's count is printed), and every true term
//! found in at least 90 % of its records (a fixed floor, not a test). The kind with a weak
//! flicker (`N+B weak`: the flicker above the white noise over less than a decade of τ)
//! and the random walk in a record of 2^14 samples (`N+K short`: its rise over the last
//! two octaves) are printed, not asserted: there the identification often names the rise
//! another rising term (docs/method/noise.md).

use ptsa_campaigns::campaign::{assert_met, binomial_upper_tail, env};
use ptsa_host_sim::noise::identify_terms;
use ptsa_host_sim::noise::terms::{self, WITH_RATE_RAMP};
use rayon::prelude::*;

/// Records of each kind in the CI campaign (7 kinds, about 30 s on two cores).
const CI_SETS: usize = 30;

/// The sample interval, s.
const TAU0_S: f64 = 0.01;

/// One kind of record: its name, length, whether asserted, and its truth.
struct Kind {
    name: &'static str,
    samples: usize,
    asserted: bool,
    /// The velocity counter's quantum, cm/s (0: none).
    quantum_cm_s: f64,
    /// White acceleration noise, cm/s²/√Hz.
    white: f64,
    /// Flicker's B, cm/s².
    flicker: f64,
    /// Random walk K, cm/s^2.5.
    walk: f64,
    /// Rate ramp R, cm/s³.
    ramp: f64,
}

const KINDS: [Kind; 7] = [
    Kind {
        name: "N",
        samples: 1 << 14,
        asserted: true,
        quantum_cm_s: 0.0,
        white: 0.05,
        flicker: 0.0,
        walk: 0.0,
        ramp: 0.0,
    },
    Kind {
        name: "N+K",
        samples: 1 << 15,
        asserted: true,
        quantum_cm_s: 0.0,
        white: 0.05,
        flicker: 0.0,
        walk: 0.02,
        ramp: 0.0,
    },
    Kind {
        name: "N+K short",
        samples: 1 << 14,
        asserted: false,
        quantum_cm_s: 0.0,
        white: 0.05,
        flicker: 0.0,
        walk: 0.02,
        ramp: 0.0,
    },
    Kind {
        name: "N+R",
        samples: 1 << 14,
        asserted: true,
        quantum_cm_s: 0.0,
        white: 0.05,
        flicker: 0.0,
        walk: 0.0,
        ramp: 0.002,
    },
    Kind {
        name: "Q+N",
        samples: 1 << 14,
        asserted: true,
        quantum_cm_s: 0.0004,
        white: 0.0,
        flicker: 0.0,
        walk: 0.0,
        ramp: 0.0,
    },
    Kind {
        name: "N+B",
        samples: 1 << 13,
        asserted: true,
        quantum_cm_s: 0.0,
        white: 0.05,
        flicker: 0.1,
        walk: 0.0,
        ramp: 0.0,
    },
    Kind {
        name: "N+B weak",
        samples: 1 << 13,
        asserted: false,
        quantum_cm_s: 0.0,
        white: 0.05,
        flicker: 0.03,
        walk: 0.0,
        ramp: 0.0,
    },
];

/// The counter's dither per sample, in quanta: a white acceleration noise of its own.
const DITHER: f64 = 0.5;

impl Kind {
    /// The true coefficients in [`WITH_RATE_RAMP`]'s order (cgs).
    fn truth(&self) -> [f64; 5] {
        let dither_n = DITHER * self.quantum_cm_s / TAU0_S.sqrt();
        [
            self.quantum_cm_s / 12f64.sqrt(),
            self.white.hypot(dither_n),
            self.flicker,
            self.walk,
            self.ramp,
        ]
    }

    /// The record drawn from `seed`, cm/s².
    fn record(&self, seed: u64) -> Vec<f64> {
        let mut rng = XorShift(seed.wrapping_mul(0x2545_F491_4F6C_DD1D) | 1);
        let n = self.samples;
        let flicker = kasdin_flicker(n, self.flicker, &mut rng);
        let (sw, sk) = (self.white / TAU0_S.sqrt(), self.walk * TAU0_S.sqrt());
        let (q, steady) = (self.quantum_cm_s, 37.3 * self.quantum_cm_s);
        let (mut walk, mut v, mut counted) = (0.0, 0.0, 0.0);
        (0..n)
            .map(|i| {
                #[allow(clippy::cast_precision_loss)]
                let t = i as f64 * TAU0_S;
                let a = sw * rng.normal() + walk + self.ramp * t + flicker[i];
                walk += sk * rng.normal();
                if q == 0.0 {
                    return a;
                }
                // The velocity moves through the counter steadily, with a dither.
                v += steady + a * TAU0_S + DITHER * q * rng.normal();
                let c = (v / q).floor() * q;
                let reading = (c - counted - steady) / TAU0_S;
                counted = c;
                reading
            })
            .collect()
    }
}

/// Marsaglia's xorshift64 with Box–Muller.
struct XorShift(u64);

impl XorShift {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        #[allow(clippy::cast_precision_loss)]
        let u = ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
        u
    }

    fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// Kasdin and Walter's flicker of IEEE Std 952's `b` (cm/s²), `n` samples.
fn kasdin_flicker(n: usize, b: f64, rng: &mut XorShift) -> Vec<f64> {
    if b == 0.0 {
        return vec![0.0; n];
    }
    let w: Vec<f64> = (0..n).map(|_| b * rng.normal()).collect();
    let mut h = vec![1.0; n];
    for k in 1..n {
        #[allow(clippy::cast_precision_loss)]
        let kf = k as f64;
        h[k] = h[k - 1] * (kf - 0.5) / kf;
    }
    (0..n)
        .map(|i| (0..=i).map(|k| h[k] * w[i - k]).sum())
        .collect()
}

/// One kind's counts.
#[derive(Default)]
struct Tally {
    records: usize,
    /// Records with a term selected that is not in them.
    false_any: usize,
    /// Per term: records in which it was selected and is not in them.
    false_terms: [usize; 5],
    /// Per term: records in which it is true, found, and covered by its interval.
    present: [usize; 5],
    found: [usize; 5],
    covered: [usize; 5],
}

/// Identify `sets` records of `kind` from `seed`.
fn run_kind(kind: &Kind, sets: usize, seed: u64) -> Tally {
    let truth = kind.truth();
    let outcomes: Vec<[(bool, bool, bool); 5]> = (0..sets as u64)
        .into_par_iter()
        .map(|s| {
            let y = kind.record(seed.wrapping_mul(1_000_003).wrapping_add(s));
            let points = ptsa_host_sim::noise::allan::analyse(&y, TAU0_S);
            let (pilot, _, _) = terms::fit_terms(
                &points
                    .iter()
                    .map(|p| (p.tau_s, p.adev * p.adev, p.edf))
                    .collect::<Vec<_>>(),
                &WITH_RATE_RAMP,
            );
            let id = identify_terms::identify(
                &y,
                TAU0_S,
                &pilot,
                identify_terms::record_seed(&y, seed),
                &mut |_| {},
            )
            .expect("a record of 2^13 samples has averaging times");
            let mut out = [(false, false, false); 5];
            for (k, c) in id.candidates.iter().enumerate() {
                let t = truth[k];
                let covered = c.value.is_some_and(|(_, lo, hi)| lo <= t && t <= hi);
                out[k] = (c.selected, t > 0.0, covered);
            }
            out
        })
        .collect();
    let mut tally = Tally {
        records: sets,
        ..Tally::default()
    };
    for o in &outcomes {
        tally.false_any += usize::from(o.iter().any(|&(sel, present, _)| sel && !present));
        for (k, &(sel, present, covered)) in o.iter().enumerate() {
            tally.false_terms[k] += usize::from(sel && !present);
            if present {
                tally.present[k] += 1;
                tally.found[k] += usize::from(sel);
                tally.covered[k] += usize::from(sel && covered);
            }
        }
    }
    tally
}

/// The table, and the failures of the asserted rates.
fn campaign(sets: usize, seed: u64) -> (String, Vec<String>) {
    use std::fmt::Write as _;
    let mut table = format!(
        "hidden noise terms: {sets} records per kind, seed {seed}, tau0 {TAU0_S} s\n| kind | samples | records with a term not in them | found | covered (95 %) |\n|---|---|---|---|---|\n"
    );
    let (mut n, mut false_any, mut found_all, mut covered_all) = (0, 0, 0, 0);
    let mut failures = Vec::new();
    for (i, kind) in KINDS.iter().enumerate() {
        let t = run_kind(kind, sets, seed.wrapping_add(i as u64));
        let cells: Vec<String> = (0..5)
            .filter(|&k| t.present[k] > 0)
            .map(|k| {
                format!(
                    "{} {}/{}",
                    WITH_RATE_RAMP[k].symbol(),
                    t.found[k],
                    t.present[k]
                )
            })
            .collect();
        let wrong: Vec<String> = (0..5)
            .filter(|&k| t.false_terms[k] > 0)
            .map(|k| format!("{} {}", WITH_RATE_RAMP[k].symbol(), t.false_terms[k]))
            .collect();
        let cov: Vec<String> = (0..5)
            .filter(|&k| t.present[k] > 0)
            .map(|k| {
                format!(
                    "{} {}/{}",
                    WITH_RATE_RAMP[k].symbol(),
                    t.covered[k],
                    t.found[k]
                )
            })
            .collect();
        let _ = writeln!(
            table,
            "| {}{} | {} | {}/{} ({}) | {} | {} |",
            kind.name,
            if kind.asserted { "" } else { " (not asserted)" },
            kind.samples,
            t.false_any,
            t.records,
            if wrong.is_empty() {
                "none".to_string()
            } else {
                wrong.join(", ")
            },
            cells.join(", "),
            cov.join(", ")
        );
        if !kind.asserted {
            continue;
        }
        n += t.records;
        false_any += t.false_any;
        for (k, term) in WITH_RATE_RAMP.iter().enumerate() {
            found_all += t.found[k];
            covered_all += t.covered[k];
            #[allow(clippy::cast_precision_loss)]
            if t.present[k] > 0 && (t.found[k] as f64) < 0.9 * t.present[k] as f64 {
                failures.push(format!(
                    "{}: {} found in {}/{} records, expected at least 90 %",
                    kind.name,
                    term.symbol(),
                    t.found[k],
                    t.present[k]
                ));
            }
        }
    }
    let p_false = binomial_upper_tail(n, 0.05, false_any);
    // P(X ≤ covered) for X ~ Bin(found, 0.95) = P(found − X ≥ found − covered), the
    // misses Bin(found, 0.05).
    let p_cover = binomial_upper_tail(found_all, 0.05, found_all - covered_all);
    let (f_lo, f_hi) = clopper_pearson(false_any, n);
    let (c_lo, c_hi) = clopper_pearson(covered_all, found_all);
    let _ = writeln!(
        table,
        "asserted kinds: records with a term not in them {false_any}/{n} = {:.1} % [{:.1}, {:.1}] (P(X >= k) under 5 %: {p_false:.3}); covered {covered_all}/{found_all} = {:.1} % [{:.1}, {:.1}] (P of as few under 95 %: {p_cover:.3}); [ ] Clopper-Pearson 95 %",
        pct(false_any, n),
        100.0 * f_lo,
        100.0 * f_hi,
        pct(covered_all, found_all),
        100.0 * c_lo,
        100.0 * c_hi
    );
    if p_false < 0.01 {
        failures.push(format!(
            "records with a term not in them {false_any}/{n}: beyond the familywise 5 % (p {p_false:.4})"
        ));
    }
    if p_cover < 0.01 {
        failures.push(format!(
            "coverage {covered_all}/{found_all}: below 95 % (p {p_cover:.4})"
        ));
    }
    (table, failures)
}

/// `100·k/n`.
fn pct(k: usize, n: usize) -> f64 {
    #[allow(clippy::cast_precision_loss)]
    let r = 100.0 * k as f64 / n.max(1) as f64;
    r
}

/// The Clopper–Pearson 95 % interval of a proportion `k/n` (the library's).
fn clopper_pearson(k: usize, n: usize) -> (f64, f64) {
    ptsa_host_sim::stats::clopper_pearson(k as u64, n as u64, 0.95)
}

#[test]
fn hidden_terms_ci() {
    let (table, failures) = campaign(CI_SETS, 2027);
    eprintln!("{table}");
    assert_met("hidden-noise-terms", &failures);
}

#[test]
#[ignore = "full campaign: cargo xtask hidden --noise-terms --sets 200"]
fn hidden_terms_campaign() {
    let (table, failures) = campaign(env("PTSA_HIDDEN_SETS", 200), env("PTSA_HIDDEN_SEED", 4242));
    eprintln!("{table}");
    assert_met("hidden-noise-terms", &failures);
}
