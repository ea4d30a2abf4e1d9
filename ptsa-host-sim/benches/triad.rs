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
//! * `triad/exact_37`: the same readings with exact orientations (the 15 coefficients);
//! * `triad_stream/stream_51175` and `triad_stream/stream_1000000`: a raw stream of that
//!   many samples at 100 Hz (the 37 directions turned through by hand, a rest of 50 s,
//!   holds of 8–16 s or 260–280 s; the generator's `stream_csv`, cut at that many rows):
//!   the text parsed, cut into its positions and calibrated from gravity alone
//!   (`triad::stream::{parse, cut, calibrate}`), as `ptsa discover --data STREAM` does.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use ptsa_host_sim::triad::fit::{self, Orientation};
use ptsa_host_sim::triad::frame;
use rand::SeedableRng as _;

/// The triad generator written from the equations (shared with the triad campaign and the
/// CLI tests; it uses nothing of `ptsa_host_sim`).
#[path = "../../ptsa-campaigns/src/triad_gen.rs"]
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

/// A stream of `rows` samples through the 37 directions, holds in `hold_s`.
fn stream(rows: usize, hold_s: (f64, f64)) -> String {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(51);
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
    let dirs: Vec<[f64; 3]> = triad_gen::design37()
        .into_iter()
        .map(|n| triad_gen::hand_placed(n, &mut rng))
        .collect();
    let spec = triad_gen::StreamSpec {
        rest_s: 50.0,
        hold_s,
        ..triad_gen::StreamSpec::default()
    };
    let (text, _) = triad_gen::stream_csv(&truth, &dirs, &spec, &mut rng);
    // The comment, the header and `rows` samples.
    let mut out: String = text.lines().take(rows + 2).collect::<Vec<_>>().join("\n");
    out.push('\n');
    out
}

fn bench_stream(c: &mut Criterion) {
    use ptsa_host_sim::stream::segment::Detector;
    use ptsa_host_sim::triad::stream as ts;
    let instr = ptsa_host_sim::Instrument::shipped("mems").unwrap();
    let opts = fit::Options {
        orientation: Orientation::Approximate,
        default_sigma_cm_s2: None,
        g_cm_s2: G,
    };
    let mut g = c.benchmark_group("triad_stream");
    g.sample_size(10);
    for (rows, hold) in [(51_175, (8.0, 16.0)), (1_000_000, (260.0, 280.0))] {
        let text = stream(rows, hold);
        g.bench_function(format!("stream_{rows}"), |bch| {
            bch.iter(|| {
                let s = ts::parse("s.csv", black_box(&text), &instr).unwrap();
                let cut = ts::cut(&s, &Detector::default(), G).unwrap();
                black_box(ts::calibrate(&s, &cut, &opts).unwrap())
            });
        });
    }
    g.finish();
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

criterion_group!(benches, bench, bench_stream);
criterion_main!(benches);
