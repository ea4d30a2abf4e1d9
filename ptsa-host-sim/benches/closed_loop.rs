#![allow(missing_docs)] // criterion_group! generates undocumented items
//! Speed of the closed loop (plant + ptsa-core) on one core.
//!
//! `cargo bench -p ptsa-host-sim --bench closed_loop` — criterion reports the median time per
//! second of simulated time (64 000 ticks) for the static loop (`ptsa static`'s hot path),
//! with and without pickoff noise, `ptsa static`'s path without per-tick statistics
//! (`static_fast`), the bare plant step plus core tick, a dynamic condition (20 Hz oscillation about OA,
//! the OA-coupling test), plus one `simulate_difference` as discovery calls it.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use ptsa_host_sim::model::condition::OA;
use ptsa_host_sim::simulation::sim::ClosedLoop;
use ptsa_host_sim::{Condition, Effects, Instrument, SimOptions, simulate_difference};
use std::hint::black_box;

const TICKS: u64 = 64_000;

#[allow(clippy::needless_range_loop)]
fn bench(c: &mut Criterion) {
    let instr = Instrument::kearfott_2401();
    let static_cond = Condition {
        g: [1.0, 0.0, 0.0],
        ..Condition::default()
    };
    let mut dynamic = Condition {
        g: [1.0, 0.0, 0.0],
        freq_hz: 20.0,
        ..Condition::default()
    };
    dynamic.ang_mrad[OA] = 2.0;
    let mut g = c.benchmark_group("closed_loop");
    g.throughput(Throughput::Elements(TICKS));
    for (name, noise, cond) in [
        ("static", true, &static_cond),
        ("static_no_noise", false, &static_cond),
        ("dynamic_20hz", true, &dynamic),
    ] {
        let opts = SimOptions {
            noise,
            ..SimOptions::default()
        };
        let mut l = ClosedLoop::new(&instr, cond, &Effects::default(), &opts);
        l.run(6400);
        g.bench_function(name, |b| {
            b.iter(|| {
                l.run(black_box(TICKS));
                black_box(l.state())
            });
        });
    }
    // `ptsa static`'s path: no per-tick statistics.
    let mut l = ClosedLoop::new(
        &instr,
        &static_cond,
        &Effects::default(),
        &SimOptions::default(),
    );
    l.run_fast(6400);
    g.bench_function("static_fast", |b| {
        b.iter(|| {
            l.run_fast(black_box(TICKS));
            black_box(l.state())
        });
    });
    // The same plant step and the same ptsa-core tick with nothing else (no noise, no stops,
    // no statistics) in a straight loop. The plain C loop of the static case itself is timed
    // against `ptsa static` by `ptsa bench --compare-c` (benches/c_static/static_loop.c).
    let plant = ptsa_host_sim::model::plant::Plant::new(&instr, instr.spring_dyn_cm_rad);
    let z = plant.zoh[0];
    let d = instr.pendulosity_g_cm() * instr.g_cm_s2;
    let mut add = [[0.0; 4]; 2];
    for j in 0..4 {
        add[0][j] = z.gu[j] + z.gd[j] * d;
        add[1][j] = -z.gu[j] + z.gd[j] * d;
    }
    let ptsa = ptsa_core::Config::DEFAULT.build().expect("default config");
    let gain = instr.lsb_per_rad();
    let mut st = ptsa.initial_state();
    let mut x = [0.0f64; 4];
    let mut ui = 0usize;
    g.bench_function("bare_plant_and_core", |b| {
        b.iter(|| {
            for _ in 0..TICKS {
                let v = (x[3] * gain + 32768.5).clamp(0.0, 65535.0);
                #[allow(
                    clippy::cast_possible_truncation,
                    clippy::cast_sign_loss,
                    clippy::cast_possible_wrap
                )]
                let code = ((v as u32) as u16 ^ 0x8000) as i16;
                let tk = ptsa.tick(&mut st, code);
                x = z.step(&x, &add[ui]);
                ui = usize::from(tk.polarity != ptsa_core::Polarity::Positive);
            }
            black_box(x)
        });
    });
    g.finish();
    let mut g = c.benchmark_group("discovery_row");
    g.sample_size(20);
    let opts = SimOptions::default();
    g.bench_function("simulate_difference_20hz", |b| {
        b.iter(|| {
            black_box(simulate_difference(
                &instr,
                black_box(&dynamic),
                &Effects::default(),
                &opts,
            ))
        });
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
