//! The test designs (rows without measurements):
//!
//! * **rate table**, like Table 6.1: 8–16 positions of IA in a vertical plane (the IA–PA
//!   plane turned about OA, or the IA–OA plane turned about PA), table rate 0.5–2 rad/s about
//!   the vertical, reference 0.05 rad/s;
//! * **two-axis oscillator**, like Appendix A: blocks of 3–8 phases each of linear vibration
//!   along IA+PA, IA+OA, OA rocking with PA vibration, and two-axis angular oscillation
//!   (IA+OA, IA+PA), and random three-axis vibration with OA rocking at random phases, at
//!   one frequency of 5–40 Hz, with gravity along a random case axis;
//! * both together;
//! * the fixed 48-row design of the speed target ([`design_48_rows`]).

use ptsa_host_sim::discovery::sim::Simulator;
use ptsa_host_sim::model::condition::Condition;
use ptsa_host_sim::model::effects::Effects;
use rayon::prelude::*;

use super::{Draw, Rng, rng};

/// A design's kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Design {
    /// Table 6.1-like rate table.
    RateTable,
    /// Appendix A-like two-axis oscillator.
    TwoAxis,
    /// Both.
    Combined,
    /// [`design_48_rows`].
    FortyEight,
}

impl Design {
    /// Name in logs.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Design::RateTable => "rate table",
            Design::TwoAxis => "two-axis oscillator",
            Design::Combined => "rate table + two-axis",
            Design::FortyEight => "design 48",
        }
    }

    /// The rows of a design of this kind; `plane` forces the rate table's vertical plane
    /// (1 = IA–PA, 2 = IA–OA).
    #[must_use]
    pub fn rows(self, rng: &mut Rng, plane: Option<usize>) -> Vec<Condition> {
        match self {
            Design::RateTable => rate_table(rng, plane),
            Design::TwoAxis => two_axis(rng),
            Design::Combined => {
                let mut r = rate_table(rng, plane);
                r.extend(two_axis(rng));
                r
            }
            Design::FortyEight => design_48_rows(),
        }
    }
}

fn up(axis: usize, sign: f64) -> [f64; 3] {
    let mut g = [0.0; 3];
    g[axis] = sign;
    g
}

/// Table 6.1-like rate-table design; `plane` = 1 (IA–PA) or 2 (IA–OA), else random.
#[must_use]
pub fn rate_table(rng: &mut Rng, plane: Option<usize>) -> Vec<Condition> {
    let n = rng.int(8, 16);
    let other = plane.unwrap_or_else(|| if rng.uniform() < 0.5 { 1 } else { 2 });
    #[allow(clippy::cast_precision_loss)]
    let step = 360.0 / n as f64;
    let offset = if rng.uniform() < 0.5 {
        0.0
    } else {
        rng.range(0.0, step)
    };
    let w = rng.range(0.5, 2.0);
    (0..n)
        .map(|k| {
            #[allow(clippy::cast_precision_loss)]
            let phi = offset + step * (k + 1) as f64;
            let (s, c) = phi.to_radians().sin_cos();
            let mut u = [0.0; 3];
            u[0] = s;
            u[other] = c;
            Condition {
                label: format!(
                    "rate table IA {phi:.1} deg in IA-{} plane",
                    if other == 1 { "PA" } else { "OA" }
                ),
                g: u,
                w_rad_s: u.map(|x| w * x),
                ref_w_rad_s: u.map(|x| 0.05 * x),
                ..Condition::default()
            }
        })
        .collect()
}

/// Appendix A-like two-axis oscillator design.
#[must_use]
pub fn two_axis(rng: &mut Rng) -> Vec<Condition> {
    let g = up(rng.int(0, 2), rng.sign());
    let freqs = [5.0, 10.0, 20.0, 40.0];
    let f = freqs[rng.int(0, 3)];
    let nph = rng.int(3, 8);
    let mut blocks: Vec<usize> = (0..6).filter(|_| rng.uniform() < 0.5).collect();
    while blocks.len() < 2 {
        let b = rng.int(0, 5);
        if !blocks.contains(&b) {
            blocks.push(b);
        }
    }
    blocks.sort_unstable();
    let mut rows = Vec::new();
    for b in blocks {
        let a1 = rng.range(100.0, 500.0);
        let a2 = rng.range(100.0, 500.0);
        let th1 = rng.range(0.5, 2.0);
        let th2 = rng.range(0.5, 2.0);
        for k in 0..nph {
            #[allow(clippy::cast_precision_loss)]
            let psi = 360.0 * k as f64 / nph as f64;
            let mut c = Condition {
                g,
                freq_hz: f,
                ..Condition::default()
            };
            let what = match b {
                0 => {
                    c.lin_cm_s2 = [a1, a2, 0.0];
                    c.lin_deg = [0.0, psi, 0.0];
                    "IA+PA vibration"
                }
                1 => {
                    c.lin_cm_s2 = [a1, 0.0, a2];
                    c.lin_deg = [0.0, 0.0, psi];
                    "IA+OA vibration"
                }
                2 => {
                    c.ang_mrad = [0.0, 0.0, th1];
                    c.lin_cm_s2 = [0.0, a2, 0.0];
                    c.lin_deg = [0.0, psi, 0.0];
                    "OA rocking + PA vibration"
                }
                3 => {
                    c.ang_mrad = [th1, 0.0, th2];
                    c.ang_deg = [0.0, 0.0, psi];
                    "IA+OA rocking"
                }
                4 => {
                    c.ang_mrad = [th1, th2, 0.0];
                    c.ang_deg = [0.0, psi, 0.0];
                    "IA+PA rocking"
                }
                _ => {
                    // Random three-axis vibration with OA rocking, random phases: partial
                    // correlations between every vibration candidate.
                    c.lin_cm_s2 = [0.0; 3].map(|_| rng.range(0.0, 500.0));
                    c.lin_deg = [0.0; 3].map(|_| rng.range(0.0, 360.0));
                    c.ang_mrad = [0.0, 0.0, rng.range(0.0, 2.0)];
                    c.ang_deg = [0.0, 0.0, rng.range(0.0, 360.0)];
                    "random vibration"
                }
            };
            c.label = format!("{what} {f} Hz phase {psi:.0} deg");
            rows.push(c);
        }
    }
    rows
}

/// A fixed 48-row design: 16 rate-table positions in the IA–PA plane, then 8 phases each of
/// IA+PA vibration, IA+OA vibration, OA rocking with PA vibration and IA+OA rocking at
/// 10 Hz with IA up (the size the speed target is stated for).
#[must_use]
pub fn design_48_rows() -> Vec<Condition> {
    let mut rows = Vec::new();
    for k in 0..16 {
        let phi = 22.5 * f64::from(k + 1);
        let (s, c) = phi.to_radians().sin_cos();
        rows.push(Condition {
            label: format!("rate table IA {phi} deg"),
            g: [s, c, 0.0],
            w_rad_s: [s, c, 0.0],
            ref_w_rad_s: [0.05 * s, 0.05 * c, 0.0],
            ..Condition::default()
        });
    }
    for (b, what) in [
        "IA+PA vibration",
        "IA+OA vibration",
        "OA rocking + PA vibration",
        "IA+OA rocking",
    ]
    .iter()
    .enumerate()
    {
        for k in 0..8 {
            let psi = 45.0 * f64::from(k);
            let mut c = Condition {
                g: [1.0, 0.0, 0.0],
                freq_hz: 10.0,
                ..Condition::default()
            };
            match b {
                0 => {
                    c.lin_cm_s2 = [300.0, 300.0, 0.0];
                    c.lin_deg = [0.0, psi, 0.0];
                }
                1 => {
                    c.lin_cm_s2 = [300.0, 0.0, 300.0];
                    c.lin_deg = [0.0, 0.0, psi];
                }
                2 => {
                    c.ang_mrad = [0.0, 0.0, 1.0];
                    c.lin_cm_s2 = [0.0, 300.0, 0.0];
                    c.lin_deg = [0.0, psi, 0.0];
                }
                _ => {
                    c.ang_mrad = [1.0, 0.0, 1.0];
                    c.ang_deg = [0.0, 0.0, psi];
                }
            }
            c.label = format!("{what} 10 Hz phase {psi} deg");
            rows.push(c);
        }
    }
    rows
}

/// [`design_48_rows`] with `measured_cm_s2` from `sim` with `effects` plus noise of `sigma`
/// cm/s² (seeded).
///
/// This makes the example file `data/synthetic-48.case.csv` only. Unlike the hidden-effect
/// generator it uses the candidate model itself (`effects` through `sim`, the analytic
/// simulator in the file's test), which is fine for an example and keeps the file exactly
/// reproducible; it must not be used to test the analyser.
#[must_use]
pub fn design_48(sim: &dyn Simulator, effects: &Effects, sigma: f64, seed: u64) -> Vec<Condition> {
    let mut rng = rng(seed);
    let mut rows = design_48_rows();
    let clean: Vec<f64> = rows
        .par_iter()
        .map(|r| sim.difference_cm_s2(r, effects))
        .collect();
    for (r, y) in rows.iter_mut().zip(clean) {
        r.measured_cm_s2 = Some(y + sigma * rng.normal());
        r.sigma_cm_s2 = Some(sigma);
    }
    rows
}
