//! Run `N` ticks of the default loop on a deterministic pickoff stream (toy closed loop), for
//! instruction counting:
//!
//! ```text
//! cargo build --release -p ptsa-core --example ticks
//! valgrind --tool=callgrind --callgrind-out-file=/dev/null target/release/examples/ticks 1000000
//! valgrind --tool=callgrind --callgrind-out-file=/dev/null target/release/examples/ticks 2000000
//! ```
//!
//! The difference of the two totals ("Collected") divided by 1 000 000 is the cost of one
//! tick plus the toy plant's few integer operations.

use ptsa_core::{Config, Polarity};
use std::hint::black_box;

fn main() {
    let n: u64 = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(1_000_000);
    let ptsa = Config::DEFAULT
        .build()
        .expect("default configuration is valid");
    let mut s = ptsa.initial_state();
    let mut theta: i64 = 0;
    let mut pol = Polarity::Positive;
    let mut pulses = 0u64;
    for _ in 0..n {
        // Toy integrating pendulum at +0.24 of full scale (see tests/properties.rs).
        theta += 1_000_000 - i64::from(pol.sign()) * 4_161_536;
        let x = i16::try_from((theta >> 16).clamp(-32_768, 32_767)).unwrap_or(0);
        let t = ptsa.tick(&mut s, black_box(x));
        pol = t.polarity;
        pulses += u64::from(pol == Polarity::Positive);
    }
    println!("{n} ticks, {pulses} pulses, digest {:016x}", s.digest());
}
