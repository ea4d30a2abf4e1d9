#![allow(missing_docs)] // criterion_group! generates undocumented items
//! Speed of the triad's calibration (`ptsa discover --data` on a triad file).
//!
//! `cargo bench -p ptsa-host-sim --bench triad` — criterion reports the median time per
//! iteration of:
//!
//! * `triad/approximate_37`: 37 positions (the 24 cube turns of (1, 2, 3)/√14, the 12 edge
//!   directions and one face) placed by hand, each 0.5–1° from nominal, fitted with
//!   approximate orientations (9 coefficients + 3 `K_2` + 74 angles from 111 readings): the
//!   file's text parsed and `triad::fit::fit` run, as the command does;
//! * `triad/exact_37`: the same readings with exact orientations (the 15 coefficients).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use ptsa_host_sim::triad::fit::{self, Orientation};
use ptsa_host_sim::triad::frame;
use rand::SeedableRng as _;

/// The triad generator written from the equations (shared with the triad campaign and the
/// CLI tests; it uses nothing of `ptsa_host_sim`).
#[path = "../../tests/hidden/triad_gen.rs"]
mod triad_gen;
use triad_gen::{G, TriadTruth};

/// A triad file of the 37 positions, each turned 0.5–1° about a random axis, 0.1 cm/s² of
/// noise.
fn file() -> String {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(37);
    let truth = TriadTruth {
        b: [12.0, -8.0, 30.0],
        k: [0.01, -0.005, 0.002],
        gamma: [
            [0.0, 0.002, -0.003],
            [0.004, 0.0, 0.001],
            [-0.002, 0.003, 0.0],
        ],
        q: [0.0; 3],
    };
    let rows: Vec<([f64; 3], [f64; 3])> = triad_gen::design37()
        .into_iter()
        .map(|n| {
            let f = triad_gen::hand_placed(n, &mut rng).map(|x| x * G);
            let u = truth
                .readings(f)
                .map(|u| u + 0.1 * triad_gen::normal(&mut rng));
            (n, u)
        })
        .collect();
    triad_gen::triad_csv(&rows, Some(0.1), "")
}

fn bench(c: &mut Criterion) {
    let text = file();
    let mut g = c.benchmark_group("triad");
    for (name, orientation) in [
        ("approximate_37", Orientation::Approximate),
        ("exact_37", Orientation::Exact),
    ] {
        let opts = fit::Options {
            orientation,
            default_sigma_cm_s2: None,
            g_cm_s2: G,
        };
        g.bench_function(name, |bch| {
            bch.iter(|| {
                let p = frame::parse_bytes("t.csv", black_box(text.as_bytes())).unwrap();
                black_box(fit::fit("t.csv", &p, &opts).unwrap())
            });
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
