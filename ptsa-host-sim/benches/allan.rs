#![allow(missing_docs)] // criterion_group! generates undocumented items
//! Speed of the Allan analysis of `ptsa noise` (issue 24, item 4: a 10⁶-gate record in
//! under 1 s).
//!
//! `cargo bench -p ptsa-host-sim --bench allan` — criterion reports the median time per
//! iteration of:
//!
//! * `allan/analyse_1e6`: the overlapping and modified Allan deviations of 10⁶ gates at
//!   every octave τ (19 of them), each with its noise identification (lag-1
//!   autocorrelation), EDF and 95 % interval (`noise::allan::analyse`);
//! * `allan/analysis_1e6`: the same and the noise terms' fit, as `ptsa noise` runs it on a
//!   record already read (`noise::Analysis::of_series`);
//! * `allan/readings_parse_1e6`: a record of readings of 10⁶ rows (`time_s,reading`, the
//!   text already in memory) read into samples, as `ptsa noise --readings` does
//!   (`noise::readings::parse`: the header, the cells, the spacing check).
//!
//! The series is white noise plus a random walk (seeded), so the noise identification
//! differences it at some τ.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use ptsa_host_sim::Instrument;
use ptsa_host_sim::model::instrument::ReadingUnit;
use ptsa_host_sim::noise::{Analysis, allan, readings};
use rand::SeedableRng as _;
use rand_distr::{Distribution as _, Normal};

fn series(n: usize) -> Vec<f64> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let nd = Normal::new(0.0, 1.0).unwrap();
    let mut walk = 0.0;
    (0..n)
        .map(|_| {
            walk += 1e-3 * nd.sample(&mut rng);
            18.7 + 30.0 * nd.sample(&mut rng) + walk
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let y = series(1_000_000);
    let mut g = c.benchmark_group("allan");
    g.sample_size(20);
    g.bench_function("analyse_1e6", |b| {
        b.iter(|| allan::analyse(black_box(&y), 0.01));
    });
    g.bench_function("analysis_1e6", |b| {
        b.iter(|| Analysis::of_series(black_box(&y), 0.01, 21_121.1, 64_000.0));
    });
    let mut text = String::from("time_s,reading\n");
    for (k, v) in y.iter().enumerate() {
        use std::fmt::Write as _;
        #[allow(clippy::cast_precision_loss)]
        let t = k as f64 * 0.01;
        let _ = writeln!(text, "{t:.2},{v:.6}");
    }
    let instr = Instrument::kearfott_2401();
    g.bench_function("readings_parse_1e6", |b| {
        b.iter(|| {
            readings::parse(
                "bench",
                black_box(&text),
                ReadingUnit::CmPerS2,
                &instr,
                0.01,
            )
            .map(|r| r.y.len())
        });
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
