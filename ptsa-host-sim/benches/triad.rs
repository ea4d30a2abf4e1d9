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

use std::fmt::Write as _;
use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use ptsa_host_sim::triad::fit::{self, Orientation};
use ptsa_host_sim::triad::frame;
use rand::{Rng as _, SeedableRng as _};
use rand_distr::Distribution as _;

const G: f64 = 980.4;

/// The 37 nominal directions.
fn design37() -> Vec<[f64; 3]> {
    let s14 = 1.0 / 14f64.sqrt();
    let base = [1.0, 2.0, 3.0];
    let perms: [([usize; 3], f64); 6] = [
        ([0, 1, 2], 1.0),
        ([1, 2, 0], 1.0),
        ([2, 0, 1], 1.0),
        ([1, 0, 2], -1.0),
        ([0, 2, 1], -1.0),
        ([2, 1, 0], -1.0),
    ];
    let mut v = Vec::new();
    for (p, parity) in perms {
        for signs in 0..8u32 {
            let sg: [f64; 3] = [0, 1, 2].map(|b| if signs >> b & 1 == 1 { -1.0 } else { 1.0 });
            if sg[0] * sg[1] * sg[2] * parity > 0.0 {
                v.push([0, 1, 2].map(|r| sg[r] * base[p[r]] * s14));
            }
        }
    }
    let s2 = 1.0 / 2f64.sqrt();
    for (j, k) in [(0, 1), (1, 2), (0, 2)] {
        for (a, b) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
            let mut n = [0.0; 3];
            n[j] = a * s2;
            n[k] = b * s2;
            v.push(n);
        }
    }
    v.push([0.0, 0.0, 1.0]);
    v
}

/// A triad file of the 37 positions, each turned 0.5–1° about a random axis, 0.1 cm/s² of
/// noise.
fn file() -> String {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(37);
    let noise = rand_distr::Normal::new(0.0, 0.1).unwrap();
    let (b, k) = ([12.0, -8.0, 30.0], [0.01, -0.005, 0.002]);
    let gm = [
        [0.0, 0.002, -0.003],
        [0.004, 0.0, 0.001],
        [-0.002, 0.003, 0.0],
    ];
    let mut s = String::from(
        "label,g_x,g_y,g_z,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2,sigma_cm_s2\n",
    );
    for (i, n) in design37().iter().enumerate() {
        let z: f64 = rng.random_range(-1.0..1.0);
        let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
        let rho = (1.0 - z * z).sqrt();
        let ax = [rho * phi.cos(), rho * phi.sin(), z];
        let ang = rng.random_range(0.5f64..1.0).to_radians();
        // n turned about ax by ang (Rodrigues).
        let c = ax[0] * n[0] + ax[1] * n[1] + ax[2] * n[2];
        let cr = [
            ax[1] * n[2] - ax[2] * n[1],
            ax[2] * n[0] - ax[0] * n[2],
            ax[0] * n[1] - ax[1] * n[0],
        ];
        let f: [f64; 3] = [0, 1, 2]
            .map(|r| G * (n[r] * ang.cos() + cr[r] * ang.sin() + ax[r] * c * (1.0 - ang.cos())));
        let u: Vec<String> = (0..3)
            .map(|j| {
                let a = f[j] + (0..3).map(|q| gm[j][q] * f[q]).sum::<f64>();
                format!("{:.5}", b[j] + (1.0 + k[j]) * a + noise.sample(&mut rng))
            })
            .collect();
        let _ = writeln!(
            s,
            "p{},{},{},{},{},0.1",
            i + 1,
            n[0],
            n[1],
            n[2],
            u.join(",")
        );
    }
    s
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
