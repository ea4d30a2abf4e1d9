//! `ptsa`: the host simulator's command line (filled in by the host-sim issue).

fn main() {
    let c = ptsa_core::Config::DEFAULT;
    println!(
        "ptsa-core default loop: {} ticks per cycle",
        c.ticks_per_cycle
    );
}
