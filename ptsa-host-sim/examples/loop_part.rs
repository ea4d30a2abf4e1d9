//! The loop's own part of a record's Allan variance, `L(τ)`: the counts' Allan variance
//! less that of the acceleration drawn at its input, averaged over seeds, at octave τ, with
//! `L·m²` (constant where the loop's part is white phase noise, as the shortened simulation
//! of `noise --identify` on long records assumes beyond its split; docs/method/noise.md, "Long
//! records") and the input's expected Allan variance beside it.
//!
//! ```sh
//! cargo run --release -p ptsa-host-sim --example loop_part -- 65536 1.0 0.1 4
//! ```
//!
//! Arguments: gates of 10 ms, the pickoff noise (µV rms), the white acceleration noise `N`
//! at the input (cm/s²/√Hz), seeds. The input sits at 0.3 cm/s² along IA.

use anyhow::{Context as _, Result};
use ptsa_host_sim::Instrument;
use ptsa_host_sim::noise::{InputNoise, allan, record_gates};
use ptsa_host_sim::simulation::batch::{Engine, RecordJob};
use ptsa_host_sim::simulation::sim::SimOptions;

#[allow(clippy::cast_precision_loss, reason = "gate counts far below 2^52")]
fn main() -> Result<()> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, what: &str| -> Result<f64> {
        a.get(i)
            .with_context(|| format!("argument {}: {what}", i + 1))?
            .parse()
            .with_context(|| format!("argument {}: {what}, a number", i + 1))
    };
    let (gates, uv, n, seeds) = (
        arg(0, "gates")?,
        arg(1, "pickoff noise, uV rms")?,
        arg(2, "N, cm/s^2/rtHz")?,
        arg(3, "seeds")?,
    );
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let (gates, seeds) = (gates as u64, seeds as u64);
    let mut instr = Instrument::kearfott_2401();
    instr.noise_v_rms = uv * 1e-6;
    let ticks = 640u64;
    let tau0 = ticks as f64 / instr.clock_hz;
    let noise = InputNoise {
        white_cm_s2_rthz: n,
        walk_cm_s2_rthz: 0.0,
    };
    let ms: Vec<usize> = (0..32)
        .map(|k| 1usize << k)
        .take_while(|&m| 2 * m < usize::try_from(gates).unwrap_or(usize::MAX))
        .collect();
    let mut mean = vec![0.0; ms.len()];
    for s in 0..seeds {
        let opts = SimOptions {
            seed: 100 + s,
            ..SimOptions::default()
        };
        let input = noise.gate_accels(0.3, tau0, gates, !s);
        let job = RecordJob {
            instr: &instr,
            seed: opts.seed,
            accel_cm_s2: 0.3,
            gate_accels_cm_s2: &input,
        };
        let c = Engine::default().simulate_records(&[job], &opts, ticks, gates);
        let y: Vec<f64> = record_gates(&c[0], ticks, instr.clock_hz)
            .iter()
            .map(|g| g.indicated_cm_s2(instr.sf_cm_s2))
            .collect();
        let (counted, drawn) = (allan::Sums::new(&y), allan::Sums::new(&input));
        for (k, &m) in ms.iter().enumerate() {
            let d = drawn.avar(m).map_or(0.0, |x| x.0);
            mean[k] += (counted.avar(m).map_or(f64::NAN, |x| x.0) - d) / seeds as f64;
        }
    }
    println!("tau_s,loop_avar_cm2_s4,loop_avar_times_m2,input_expected_avar_cm2_s4");
    for (k, &m) in ms.iter().enumerate() {
        println!(
            "{},{:.4e},{:.4e},{:.4e}",
            m as f64 * tau0,
            mean[k],
            mean[k] * (m * m) as f64,
            noise.expected_avar(tau0, m)
        );
    }
    Ok(())
}
