//! The host closed loop as a golden vector (`tests/golden/host_closed_loop.in`).
//!
//! The pickoff samples that the host's closed loop fed to ptsa-core during a tumble
//! (+1 g along IA, then −1 g), with the polarities the host decided, recorded in comment
//! lines `# host <one + or - per tick>`. `tests/golden.rs` checks that the expected output
//! has exactly those polarities, and the firmware replays the vector on the emulated
//! Cortex-M4: matching it shows that the MCU closes the same loop.
//!
//! Re-record (after a change to the plant or the core) with `cargo xtask golden --overwrite`,
//! which runs this test with `PTSA_WRITE_GOLDEN=1`.

use std::fmt::Write as _;
use std::path::PathBuf;

use ptsa_core::{Config, Polarity, trace};
use ptsa_host_sim::simulation::sim::ClosedLoop;
use ptsa_host_sim::{Condition, Effects, Instrument, SimOptions};

/// Ticks in each orientation (three 0.1 s gates).
const TICKS_PER_POSITION: u64 = 3 * 6400;

fn generate() -> String {
    let instr = Instrument::kearfott_2401();
    let opts = SimOptions {
        config: Config {
            gate_ticks: 6400,
            ..Config::DEFAULT
        },
        ..SimOptions::default()
    };
    let up = Condition {
        g: [1.0, 0.0, 0.0],
        ..Condition::default()
    };
    let down = Condition {
        g: [-1.0, 0.0, 0.0],
        ..Condition::default()
    };
    let mut codes = Vec::new();
    let mut pols = String::new();
    let mut l = ClosedLoop::new(&instr, &up, &Effects::default(), &opts);
    let mut record = |v: &ptsa_host_sim::simulation::sim::TickView| {
        codes.push(v.code);
        pols.push(if v.decided == Polarity::Positive {
            '+'
        } else {
            '-'
        });
    };
    l.run_observed(TICKS_PER_POSITION, &mut record);
    l.set_condition(&down, &Effects::default());
    l.run_observed(TICKS_PER_POSITION, &mut record);

    let mut s = String::new();
    let _ = writeln!(
        s,
        "# ptsa golden vector `host_closed_loop`: the host's closed loop (Kearfott 2401, Table 2.1,"
    );
    let _ = writeln!(
        s,
        "# pickoff noise seed {}), +1 g along IA for {TICKS_PER_POSITION} ticks, then -1 g",
        opts.seed
    );
    let _ = writeln!(
        s,
        "# recorded by ptsa-host-sim/tests/golden_trace.rs; `# host` lines: the polarities the host decided"
    );
    for chunk in pols.as_bytes().chunks(64) {
        let _ = writeln!(s, "# host {}", String::from_utf8_lossy(chunk));
    }
    let _ = trace::write_config(&mut s, &opts.config);
    s.push('\n');
    for c in codes {
        let _ = writeln!(s, "{c}");
    }
    s
}

fn golden(ext: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/golden")
        .join(format!("host_closed_loop.{ext}"))
}

#[test]
fn host_closed_loop_is_the_committed_golden_vector() {
    let input = generate();
    if std::env::var_os("PTSA_WRITE_GOLDEN").is_some() {
        let mut out = String::new();
        let mut r = trace::GoldenRunner::new();
        r.feed(input.as_bytes(), &mut out).unwrap();
        r.finish(&mut out).unwrap();
        std::fs::write(golden("in"), &input).unwrap();
        std::fs::write(golden("out"), out).unwrap();
        eprintln!("wrote {}", golden("in").display());
        return;
    }
    let committed = std::fs::read_to_string(golden("in")).expect("committed host_closed_loop.in");
    assert!(
        committed == input,
        "the host closed loop no longer produces tests/golden/host_closed_loop.in; \
         re-record with `cargo xtask golden --overwrite` if the change is intended"
    );
}
