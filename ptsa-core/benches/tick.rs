#![allow(missing_docs)] // criterion_group! generates undocumented items
//! Cost of one PTSA tick on the host: `Ptsa::tick` per sample, and `Ptsa::process_block`.
//!
//! `cargo bench -p ptsa-core --bench tick` — criterion reports the median time per block of
//! 64 000 ticks (one second of the 64 kHz clock); divide by 64 000 for ns/tick.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use ptsa_core::{Config, Polarity, Tick};
use std::hint::black_box;

const TICKS: usize = 64_000;

fn samples() -> Vec<i16> {
    // Deterministic bell-shaped noise around a triangle, like a pickoff in closed loop.
    let mut x: u32 = 0x1234_5678;
    (0..u16::try_from(TICKS).expect("TICKS < 2^16"))
        .map(|i| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            let tri = (i32::from(i % 64) - 32).abs() * 60 - 960;
            let noise = i32::try_from(x >> 24).expect("8 bits");
            i16::try_from(tri + noise - 128).expect("within ±1100")
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let ptsa = Config::DEFAULT.build().expect("default config is valid");
    let input = samples();
    let mut g = c.benchmark_group("ptsa_core");
    g.throughput(Throughput::Elements(TICKS as u64));
    g.bench_function(BenchmarkId::new("tick", TICKS), |b| {
        let mut s = ptsa.initial_state();
        b.iter(|| {
            let mut pulses = 0u32;
            for &x in &input {
                let t = ptsa.tick(&mut s, black_box(x));
                pulses += u32::from(t.polarity == Polarity::Positive);
            }
            black_box(pulses)
        });
    });
    g.bench_function(BenchmarkId::new("process_block", TICKS), |b| {
        let mut s = ptsa.initial_state();
        let mut out = vec![
            Tick {
                polarity: Polarity::Positive,
                cycle_pulses: None,
                gate: None
            };
            TICKS
        ];
        b.iter(|| {
            ptsa.process_block(&mut s, black_box(&input), &mut out);
            black_box(&out);
        });
    });
    g.bench_function(BenchmarkId::new("closed_loop_toy", TICKS), |b| {
        // Tick plus a toy integrating pendulum: the dependency chain of a real closed loop.
        let mut s = ptsa.initial_state();
        b.iter(|| {
            let mut theta: i64 = 0;
            let mut pol = Polarity::Positive;
            for _ in 0..TICKS {
                theta += 1_000_000 - i64::from(pol.sign()) * 4_161_536;
                let x = i16::try_from(theta >> 16).unwrap_or(if theta < 0 {
                    i16::MIN
                } else {
                    i16::MAX
                });
                pol = ptsa.tick(&mut s, black_box(x)).polarity;
            }
            black_box(theta)
        });
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
