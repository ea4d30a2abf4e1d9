#![allow(missing_docs)] // criterion_group! generates undocumented items
//! Speed of the batch engine against the single loop, per core.
//!
//! `cargo bench -p ptsa-host-sim --bench batch` — criterion reports ticks per second
//! (`elem/s`, every lane's ticks) and the median time per iteration of:
//!
//! * `static_loop/single`: 16 static conditions over ±0.9 full scale with noise, each a
//!   settled [`ClosedLoop`] running `run_fast` (the path of `ptsa static`) for 64 000 ticks,
//!   one after the other; `static_loop/K/k`: the same 16 loops through [`Engine::run_fast`]
//!   with `k` lanes interleaved (`K/1`: one after the other, block by block, sharing the
//!   noise draws), on one thread (the per-core figure);
//! * `static_api/...`: the same as whole calls, `sim::run_static` 16 times against one
//!   `batch::run_static` (construction, settling and noise tables included);
//! * `dynamic_loop/...`: 16 dynamic conditions (`lab::fixtures::oscillating_spread`:
//!   angular oscillation about OA and IA+PA vibration at 10–47.5 Hz, with effects) running
//!   `run`;
//! * `dynamic_api/...`: `simulate_condition` 16 times against one `simulate_conditions`;
//! * `ident_loop/...`, `ident_api/...`: parameter identification, one dynamic condition (20 Hz
//!   about OA) with 16 instruments (spring 0–15 % stiffer,
//!   `lab::fixtures::shared_condition_spread`), one seed: the loops running `run`, and
//!   `simulate_condition` 16 times against one `simulate_jobs`.
//!
//! Ratios: divide the `single` time by the `K/k` time (the same ticks). `ptsa bench --batch 16`
//! (`--dynamic`, `--dynamic --shared-condition`) measures the `*_api` pairs from the command
//! line, on the same fixtures.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use ptsa_host_sim::lab::fixtures;
use ptsa_host_sim::simulation::batch::{Engine, Job};
use ptsa_host_sim::simulation::sim::{ClosedLoop, run_static, simulate_condition};
use ptsa_host_sim::{Condition, Effects, Instrument, SimOptions};
use std::hint::black_box;

const TICKS: u64 = 64_000;
const N: usize = 16;
const LANES: [usize; 5] = [1, 2, 4, 8, 16];

#[allow(clippy::too_many_lines)] // one benchmark group after another
fn bench(c: &mut Criterion) {
    let instr = Instrument::kearfott_2401();
    let opts = SimOptions::default();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a one-thread pool");
    let accels = fixtures::spread_accels(&instr, N);
    let settled = |conds: &[(Condition, Effects)]| -> Vec<ClosedLoop> {
        conds
            .iter()
            .map(|(cnd, e)| {
                let mut l = ClosedLoop::new(&instr, cnd, e, &opts);
                l.run(6400);
                l
            })
            .collect()
    };
    let statics: Vec<(Condition, Effects)> = accels
        .iter()
        .map(|&a| (fixtures::along_ia(a, instr.g_cm_s2), Effects::NONE))
        .collect();
    let dynamics = fixtures::oscillating_spread(N);

    // The loops alone.
    for (name, conds, fast) in [
        ("static_loop", &statics, true),
        ("dynamic_loop", &dynamics, false),
    ] {
        let mut g = c.benchmark_group(name);
        g.throughput(Throughput::Elements(TICKS * N as u64));
        let mut loops = settled(conds);
        g.bench_function("single", |b| {
            b.iter(|| {
                for l in &mut loops {
                    if fast {
                        l.run_fast(black_box(TICKS));
                    } else {
                        l.run(black_box(TICKS));
                    }
                }
                black_box(loops[0].state())
            });
        });
        for k in LANES {
            let e = Engine::new(k);
            let mut loops = settled(conds);
            g.bench_function(BenchmarkId::new("K", k), |b| {
                b.iter(|| {
                    pool.install(|| {
                        if fast {
                            e.run_fast(&mut loops, black_box(TICKS));
                        } else {
                            e.run(&mut loops, black_box(TICKS));
                        }
                    });
                    black_box(loops[0].state())
                });
            });
        }
        g.finish();
    }

    // Parameter identification: one condition, sixteen instruments.
    let (oa, instrs) = fixtures::shared_condition_spread(&instr, N);
    let ident = |i: &Instrument| {
        let mut l = ClosedLoop::new(i, &oa, &Effects::NONE, &opts);
        l.run(6400);
        l
    };
    let mut g = c.benchmark_group("ident_loop");
    g.throughput(Throughput::Elements(TICKS * N as u64));
    let mut loops: Vec<ClosedLoop> = instrs.iter().map(ident).collect();
    g.bench_function("single", |b| {
        b.iter(|| {
            for l in &mut loops {
                l.run(black_box(TICKS));
            }
            black_box(loops[0].state())
        });
    });
    for k in [1, 4, 8] {
        let e = Engine::new(k);
        let mut loops: Vec<ClosedLoop> = instrs.iter().map(ident).collect();
        g.bench_function(BenchmarkId::new("K", k), |b| {
            b.iter(|| {
                pool.install(|| e.run(&mut loops, black_box(TICKS)));
                black_box(loops[0].state())
            });
        });
    }
    g.finish();
    let mut g = c.benchmark_group("ident_api");
    g.sample_size(20);
    let settle = opts.warmup_ticks(instr.clock_hz);
    let window = ptsa_host_sim::simulation::sim::window_ticks(&instr, &oa, &opts);
    g.throughput(Throughput::Elements((settle + window) * N as u64));
    g.bench_function("single", |b| {
        b.iter(|| {
            instrs
                .iter()
                .map(|i| simulate_condition(i, &oa, &Effects::NONE, &opts))
                .collect::<Vec<_>>()
        });
    });
    let jobs: Vec<Job<'_>> = instrs
        .iter()
        .map(|i| Job {
            instr: i,
            cond: &oa,
            effects: Effects::NONE,
            seed: opts.seed,
        })
        .collect();
    for k in [1, 4] {
        let e = Engine::new(k);
        g.bench_function(BenchmarkId::new("K", k), |b| {
            b.iter(|| pool.install(|| e.simulate_jobs(&jobs, &opts)));
        });
    }
    g.finish();

    // Whole calls, construction and settling included.
    let mut g = c.benchmark_group("static_api");
    g.sample_size(20);
    let settle = opts.warmup_ticks(instr.clock_hz);
    g.throughput(Throughput::Elements((TICKS + settle) * N as u64));
    g.bench_function("single", |b| {
        b.iter(|| {
            accels
                .iter()
                .map(|&a| run_static(&instr, a, black_box(TICKS), &opts))
                .collect::<Vec<_>>()
        });
    });
    for k in LANES {
        let e = Engine::new(k);
        g.bench_function(BenchmarkId::new("K", k), |b| {
            b.iter(|| pool.install(|| e.run_static(&instr, &accels, black_box(TICKS), &opts)));
        });
    }
    g.finish();

    let mut g = c.benchmark_group("dynamic_api");
    g.sample_size(20);
    let ticks: u64 = dynamics
        .iter()
        .map(|(cnd, _)| settle + ptsa_host_sim::simulation::sim::window_ticks(&instr, cnd, &opts))
        .sum();
    g.throughput(Throughput::Elements(ticks));
    g.bench_function("single", |b| {
        b.iter(|| {
            dynamics
                .iter()
                .map(|(cnd, e)| simulate_condition(&instr, cnd, e, &opts))
                .collect::<Vec<_>>()
        });
    });
    for k in LANES {
        let e = Engine::new(k);
        g.bench_function(BenchmarkId::new("K", k), |b| {
            b.iter(|| pool.install(|| e.simulate_conditions(&instr, &dynamics, &opts)));
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
