//! The hidden-effect generator and the campaigns of the analyses: sets generated from the
//! equations, analysed blind, scored. Run by the tests crate (`tests/hidden_*.rs`, a CI
//! subset each), by `cargo xtask hidden` (the full campaigns) and by Python's
//! `python -m ptsa.campaign hidden` (every campaign in shards on Ray, [`shard`]).
//! A validation harness, not part of `ptsa-host-sim`'s interface.
//!
//! A set is a design ([`designs`]) whose measured values are made by the closed loop with
//! physics injected from the equations ([`physics`]: the instrument's anisoinertia, an
//! offset proof mass, products of the inputs as extra torques, bias changes between runs),
//! never by the candidate code the analyser's signatures come from; what is hidden
//! ([`generate::Kind`]) is one candidate's physics, physics out of the vocabulary, a bias
//! shift per block, a drift, or nothing (with homo- or heteroscedastic noise). The
//! campaign ([`effects`]) scores the pipeline's blind answer and reports detection power at
//! 3, 4, 6 and 8 standard errors, coverage of the coefficients, false selections and
//! confident misnamings in one table, and asserts the rates.
//!
//! Two campaigns of their own follow: [`params`] hides a change of the loop's parameters in
//! the instrument file (response tables), [`statics`] the model equation's static terms (an
//! IA tilt, a quadratic or cubic term, a bias change, a scale-factor error) as physics in
//! the plant, measured in tumbles and on a centrifuge.
//!
//! A fourth, [`lab`], hides the effects a test lab meets every day (a hysteresis in angle
//! and interleaved order, a bias and a scale factor changing with temperature) in a
//! 24-point tumble.
//!
//! A sixth, [`calibration`], is not a naming campaign: tumbles generated from the IEEE Std
//! 1293 model equation with the instrument's absolute coefficients drawn per set, scored on
//! whether the `calibration` object's k = 2 intervals cover them.
//! A seventh, [`triad`], stands apart from the pipeline: three accelerometers on one block,
//! their readings generated from the equations ([`triad_gen`], shared with the triad CLI
//! tests and benchmark), calibrated blind by `ptsa_host_sim::triad::fit`; it borrows the
//! core's counts and binomial bands.
//!
//! The four share one core ([`campaign`]): the set seeding, the run over the sets, the
//! scored outcome of a set ([`Outcome`]), the table and the binomial assertions; each
//! supplies its kinds, its generator, its truths and its table's columns
//! ([`campaign::Campaign`]).
//!
//! Noise: one sigma per set, uniform in 0.1–0.3 cm/s² (the heteroscedastic nulls have their
//! own), from the seeded `ChaCha8` generator, on top of the loop's own pickoff noise; in a
//! quarter of the sets (and in every heteroscedastic null) `sigma_cm_s2` is left out, so
//! the pipeline estimates it. The hidden coefficient is `±s·SE`, `s` uniform in 2–24, where
//! SE is that coefficient's standard error in this design with the nuisance terms the
//! pipeline always fits, from the design simulated once with a unit physical effect.

pub mod calibration;
pub mod campaign;
pub mod designs;
pub mod effects;
pub mod generate;
pub mod lab;
pub mod params;
pub mod physics;
pub mod shard;
pub mod sigma;
pub mod stability;
pub mod statics;
pub mod triad;
pub mod triad_gen;

#[cfg(test)]
mod outliers;
#[cfg(test)]
mod tests;

pub use campaign::{Campaign, Outcome, Run, binomial_interval};
pub use designs::{Design, design_48, design_48_rows, rate_table, two_axis};
pub use generate::{
    Class, GenOptions, HiddenSet, Kind, OUT_OF_VOCABULARY, Truth, candidate_physics, generate,
};
pub use physics::{Generator, Injection, Physics, Product};

/// The seeded generator of the sets (`ChaCha8`: the same stream on every machine).
pub type Rng = rand_chacha::ChaCha8Rng;

/// The draws the generator makes, on any [`rand::Rng`].
pub trait Draw: rand::Rng {
    /// Uniform in [0, 1).
    fn uniform(&mut self) -> f64 {
        self.random::<f64>()
    }
    /// Uniform in [lo, hi).
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        self.random_range(lo..hi)
    }
    /// Uniform integer in [lo, hi].
    fn int(&mut self, lo: usize, hi: usize) -> usize {
        self.random_range(lo..=hi)
    }
    /// Standard normal.
    fn normal(&mut self) -> f64 {
        self.sample(rand_distr::StandardNormal)
    }
    /// Random sign.
    fn sign(&mut self) -> f64 {
        if self.random::<bool>() { 1.0 } else { -1.0 }
    }
}

impl<R: rand::Rng + ?Sized> Draw for R {}

/// A generator seeded with `seed`.
#[must_use]
pub fn rng(seed: u64) -> Rng {
    rand::SeedableRng::seed_from_u64(seed)
}
