//! A static counter record of the shipped loop with noises the instrument file does not
//! hold: a white acceleration noise `N` and a bias random walk `K` entering the plant's
//! input, and a pickoff noise of its own. For trying `ptsa noise --counts FILE --identify`
//! on records of any length (the 12-hour record of docs/method/noise.md's "Long records").
//!
//! ```sh
//! cargo run --release -p ptsa-host-sim --example noisy_record -- \
//!     --seconds 43200 --white 0.1 --walk 0.005 --pickoff-uv 1.0 --seed 1 rec.csv
//! ```
//!
//! Units: `--seconds` s of 10 ms gates (640 ticks of the 64 kHz clock), `--white`
//! cm/s²/√Hz, `--walk` cm/s²·√Hz, `--pickoff-uv` µV rms. The file must not exist.

use anyhow::{Context as _, Result, bail};
use ptsa_host_sim::Instrument;
use ptsa_host_sim::noise::{InputNoise, record_csv, record_gates};
use ptsa_host_sim::simulation::batch::{Engine, RecordJob};
use ptsa_host_sim::simulation::sim::SimOptions;

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let (mut seconds, mut white, mut walk, mut uv, mut seed) = (60.0, 0.0, 0.0, 0.5, 1u64);
    let mut out = None;
    while let Some(a) = args.next() {
        let mut value = |name: &str| -> Result<f64> {
            let v = args.next().with_context(|| format!("{name}: a value"))?;
            v.parse()
                .with_context(|| format!("{name} {v}: expected a number"))
        };
        match a.as_str() {
            "--seconds" => seconds = value("--seconds")?,
            "--white" => white = value("--white")?,
            "--walk" => walk = value("--walk")?,
            "--pickoff-uv" => uv = value("--pickoff-uv")?,
            "--seed" => {
                let v = args.next().context("--seed: a value")?;
                seed = v
                    .parse()
                    .with_context(|| format!("--seed {v}: a whole number"))?;
            }
            _ if a.starts_with("--") => bail!("{a}: not an option of this example"),
            _ => out = Some(a),
        }
    }
    let out = out.context("the record's file name")?;
    if std::path::Path::new(&out).exists() {
        bail!("{out}: exists; give a new name");
    }
    let mut instr = Instrument::kearfott_2401();
    instr.noise_v_rms = uv * 1e-6;
    let opts = SimOptions {
        seed,
        ..SimOptions::default()
    };
    let ticks = 640u64;
    #[allow(clippy::cast_precision_loss)]
    let tau0 = ticks as f64 / instr.clock_hz;
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let gates = (seconds / tau0).round() as u64;
    let noise = InputNoise {
        white_cm_s2_rthz: white,
        walk_cm_s2_rthz: walk,
    };
    let accels = noise.gate_accels(0.0, tau0, gates, !seed);
    let job = RecordJob {
        instr: &instr,
        seed,
        accel_cm_s2: 0.0,
        gate_accels_cm_s2: &accels,
    };
    let counts = Engine::default().simulate_records(&[job], &opts, ticks, gates);
    let comment = format!(
        "the shipped loop at rest with N = {white} cm/s^2/rtHz, K = {walk} cm/s^2.5 at its input and a pickoff noise of {uv} uV rms (seed {seed}; examples/noisy_record.rs)"
    );
    let g = record_gates(&counts[0], ticks, instr.clock_hz);
    ptsa_host_sim::output::fs::write_atomic(
        std::path::Path::new(&out),
        record_csv(&g, &[comment]).as_bytes(),
    )
}
