//! A record of readings made of IEEE Std 952's terms ([`super::terms`]), drawn from a seed:
//! the replicas `noise --readings FILE --identify` simulates at the terms it has fitted
//! ([`super::identify_terms`]).
//!
//! Each sample `y_i` (cm/s², interval `τ₀`) is the sum of
//!
//! * quantization `Q` (cm/s): `(v_i − v_{i−1})/τ₀`, `v` white with standard deviation `Q`
//!   (Allan variance `3Q²/τ²` exactly);
//! * white acceleration noise `N` (cm/s²/√Hz, two-sided): white with variance `N²/τ₀`
//!   (`N²/τ` exactly);
//! * bias instability `B` (cm/s²): flicker noise as a sum of first-order Gauss–Markov
//!   processes, one per octave of correlation time from `τ₀` to four times the record,
//!   each of variance `ln 2·B²/π`; an octave's worth of equal-variance Lorentzians has
//!   the one-sided density `h/f` with `h = σ²/ln 2`, whose Allan variance `2·ln 2·h` is
//!   `(2·ln 2/π)·B²`: within 10 % from 16 to 1024 samples of a 2¹⁴-sample record (the
//!   test below), 15 % low at 4 samples. The identification takes only the replicas'
//!   spread and each log's bias from them, never their mean, so that departure does not
//!   enter its fit. A process with a correlation time of 16 samples or more is stepped
//!   once per eighth of it and held;
//! * acceleration random walk `K` (cm/s^2.5): steps of variance `K²τ₀` (`K²τ/3` for
//!   `τ ≫ τ₀`);
//! * rate ramp `R` (cm/s³): `R·t`, which adds `R²τ²/2` and no randomness.
#![allow(
    clippy::cast_precision_loss,
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "sample counts and octave indices, far below 2^52, as f64 and back"
)]

use rand::SeedableRng as _;
use rand_distr::Distribution as _;

use super::terms::Term;

/// `n` readings (cm/s²) at interval `tau0_s` with the terms `coefficients` (each a term
/// and its coefficient in cgs, as [`Term::units`]' first unit), drawn from `seed`
/// (`ChaCha8`).
#[must_use]
pub fn readings(coefficients: &[(Term, f64)], n: usize, tau0_s: f64, seed: u64) -> Vec<f64> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut y = vec![0.0; n];
    for &(term, c) in coefficients {
        if c == 0.0 {
            continue;
        }
        match term {
            Term::Quantization => quantization(&mut y, c / tau0_s, &mut rng),
            Term::VelocityRandomWalk => {
                let s = c / tau0_s.sqrt();
                for v in &mut y {
                    *v += s * normal(&mut rng);
                }
            }
            Term::BiasInstability => flicker(&mut y, c, &mut rng),
            Term::AccelerationRandomWalk => {
                let s = c * tau0_s.sqrt();
                let mut w = 0.0;
                for v in &mut y {
                    *v += w;
                    w += s * normal(&mut rng);
                }
            }
            Term::RateRamp => {
                for (i, v) in y.iter_mut().enumerate() {
                    *v += c * tau0_s * i as f64;
                }
            }
        }
    }
    y
}

fn normal(rng: &mut rand_chacha::ChaCha8Rng) -> f64 {
    rand_distr::StandardNormal.sample(rng)
}

/// The differences of a white velocity of standard deviation `s · τ₀` over `τ₀`.
fn quantization(y: &mut [f64], s: f64, rng: &mut rand_chacha::ChaCha8Rng) {
    let mut last = s * normal(rng);
    for v in y {
        let now = s * normal(rng);
        *v += now - last;
        last = now;
    }
}

/// Flicker noise of bias instability `b` (cm/s²) added to `y`: the Gauss–Markov sum.
fn flicker(y: &mut [f64], b: f64, rng: &mut rand_chacha::ChaCha8Rng) {
    let sigma = (std::f64::consts::LN_2 / std::f64::consts::PI).sqrt() * b;
    let n = y.len();
    // Correlation times 2^j samples, j = 0 … until four times the record.
    let top = (4.0 * n as f64).log2().ceil() as i32;
    for j in 0..=top {
        let t = 2f64.powi(j);
        let hold = if j >= 4 { 1usize << (j - 3) } else { 1 };
        let phi = (-(hold as f64) / t).exp();
        let kick = sigma * (1.0 - phi * phi).sqrt();
        let mut x = sigma * normal(rng);
        for chunk in y.chunks_mut(hold) {
            for v in chunk {
                *v += x;
            }
            x = phi * x + kick * normal(rng);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::allan::Sums;

    /// Each term alone, averaged over records, has the Allan variance of its shape
    /// (the random walk's `K²τ/3` within its discrete correction, the flicker's plateau
    /// within 10 % from 16 samples on).
    #[test]
    fn each_term_has_its_allan_variance() {
        let (n, tau0) = (1 << 14, 0.01);
        for (term, c, ms, tol) in [
            (Term::Quantization, 0.003, vec![1, 4, 64], 0.05),
            (Term::VelocityRandomWalk, 0.05, vec![1, 8, 128], 0.05),
            (Term::BiasInstability, 0.02, vec![16, 128, 1024], 0.10),
            (Term::AccelerationRandomWalk, 0.4, vec![64, 256], 0.10),
            (Term::RateRamp, 0.5, vec![1, 16, 1024], 1e-9),
        ] {
            let reps = 40u32;
            for &m in &ms {
                let mean: f64 = (0..reps)
                    .map(|s| {
                        let y = readings(&[(term, c)], n, tau0, u64::from(s));
                        Sums::new(&y).avar(m).unwrap().0
                    })
                    .sum::<f64>()
                    / f64::from(reps);
                let tau = m as f64 * tau0;
                let want = c * c * term.shape(tau);
                assert!(
                    (mean / want - 1.0).abs() < tol,
                    "{term:?} m {m}: {mean} against {want}"
                );
            }
        }
    }
}
