//! Which of IEEE Std 952's terms a record of readings holds (`ptsa noise --readings FILE
//! --identify`), selected forward at Holm's thresholds (5 % familywise), with an interval.
//!
//! The model, at each octave `τ = m·τ₀` with `m` at most a quarter of the record:
//!
//! ```text
//! AVAR(τ) = 3·Q²/τ² + N²/τ + (2·ln 2/π)·B² + K²·τ/3 + R²·τ²/2
//! ```
//!
//! The points are compared on the log scale, as the loop's identification compares them
//! ([`super::identify`]): `r = ln M − ln S(θ) − b`, `M` the record's overlapping Allan
//! variance, `S(θ)` the model's at the squared coefficients `θ`, `b` each log's bias, and
//! `χ² = rᵀ C⁻¹ r` with `C` the covariance of `ln M` across the τ. `b` and `C` come from a
//! parametric bootstrap: [`REPLICAS`] records of the same length drawn at the terms fitted
//! so far ([`super::synth`]), the sample covariance's inverse scaled by `(ν − k − 1)/ν`
//! (ν = [`REPLICAS`] − 1, `k` points), which makes it unbiased for `C⁻¹`. The
//! chi-squared EDF of independent points does not describe an overlapping estimate's
//! octave points, which are correlated and, at long τ, far from normal.
//!
//! Selection: the best single term is taken first (a record always holds some noise);
//! then, at step `j`, each term left is tested by the drop `Δχ²` it brings when fitted with
//! those selected (its coefficient cannot be negative: `z = √Δχ²` against the one-sided
//! normal), and the most significant is selected if `p ≤ 0.05/(4 − j)`; the first that is
//! not ends the selection. The covariance is then drawn again at the selected fit and the
//! selection run again, until the selected set repeats (at most [`ROUNDS`] rounds).
//! Each step's test is made in the model of the terms selected before it, so the 5 %
//! familywise holds once the record's true terms are in; a true term not yet selected
//! leaves a rise or a fall another term of the same slope may take (the campaign in
//! docs/method/noise.md measures both the false inclusions and these misnamings).
//!
//! Each selected coefficient's interval: the joint fit's covariance of `θ` (Gauss–Newton
//! at the minimum), scaled by the Birge ratio `√(χ²/dof)` when above 1 and by Student's
//! two-sided point for `REPLICAS − 1` degrees of freedom (the weights are estimated from
//! that many records), the interval on `θ` then its square root (its lower end at 0 when
//! the interval on `θ` reaches it). The coverage is measured in docs/method/noise.md.
#![allow(
    clippy::cast_precision_loss,
    reason = "sample counts and averaging factors, far below 2^52, as f64"
)]

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use statrs::distribution::{ContinuousCDF as _, Normal};

use super::allan::{self, Sums};
use super::synth;
use super::terms::{Fitted, Term, WITH_RATE_RAMP};

/// Records drawn for each evaluation of the covariance.
pub const REPLICAS: usize = 200;

/// Familywise error rate of the selection.
pub const ALPHA: f64 = 0.05;

/// Rounds of selection at most (each with its covariance drawn at the fit before).
pub const ROUNDS: usize = 3;

/// The longest averaging factor compared, as a fraction of the record: a quarter (four
/// averaging windows; beyond, an estimate's log has a long tail toward zero).
pub const LONGEST: usize = 4;

/// Wall time of one replica per sample of the record, s (measured on this machine's
/// cores: drawing the terms, a flicker among them, and the octave Allan variances).
pub const SAMPLE_S: f64 = 8e-8;

/// The identification's estimated wall time for a record of `n` samples, s: every round's
/// replicas on the machine's cores.
#[must_use]
pub fn work_seconds(n: usize) -> f64 {
    (REPLICAS * ROUNDS) as f64 * n as f64 * SAMPLE_S / crate::simulation::work::cores()
}

/// One term's result.
#[derive(Clone, Debug, PartialEq)]
pub struct Candidate {
    /// Which term.
    pub term: Term,
    /// Selected.
    pub selected: bool,
    /// `z = √Δχ²` at the step it was last tested (the first term: none).
    pub z: Option<f64>,
    /// Its one-sided p.
    pub p: Option<f64>,
    /// The coefficient (cgs), with its 95 % interval, when selected.
    pub value: Option<(f64, f64, f64)>,
}

/// The identification.
#[derive(Clone, Debug, PartialEq)]
pub struct Identification {
    /// The terms, in [`WITH_RATE_RAMP`]'s order.
    pub candidates: Vec<Candidate>,
    /// The averaging times compared, s.
    pub taus: Vec<f64>,
    /// The joint fit's `χ²`.
    pub chi2: f64,
    /// Degrees of freedom: averaging times less the selected terms.
    pub dof: usize,
    /// Records drawn in all.
    pub replicas: usize,
    /// Rounds of selection run.
    pub rounds: usize,
}

/// The points compared: the averaging factors, `τ` (s) and the record's Allan variance.
struct Curve {
    m: Vec<usize>,
    tau: Vec<f64>,
    ln_m: Vec<f64>,
}

/// The bootstrap at one fit: each log's bias and the whitening `L⁻¹` (`C = L·Lᵀ`).
struct Weights {
    bias: Vec<f64>,
    whiten: DMatrix<f64>,
}

/// A fit of a subset of the terms.
#[derive(Clone, Debug)]
struct Fit {
    terms: Vec<Term>,
    theta: Vec<f64>,
    chi2: f64,
    cov: DMatrix<f64>,
}

/// Why an identification could not be made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Failure {
    /// Fewer than three octave averaging times up to a quarter of the record.
    TooShort,
    /// The replicas' covariance is singular (they do not vary) or their bias not finite.
    Weights,
    /// No term could be fitted.
    Fit,
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::TooShort => "fewer than three octave averaging times up to a quarter of the record with a positive Allan variance; expected at least 16 samples that vary",
            Self::Weights => "the records drawn at the fitted terms do not vary (their covariance is singular): no noise term to draw them with",
            Self::Fit => "no term of the model could be fitted to the Allan variance",
        })
    }
}

/// Identify the terms of the readings `y` (cm/s², interval `tau0_s`) starting from the
/// fit `pilot` (the analysis's terms), drawing the replicas from `seed`; `progress` is
/// told each round.
///
/// # Errors
/// [`Failure`]: too short a record; replicas that do not vary; nothing fitted. A round
/// after the first that fails keeps the round before.
pub fn identify(
    y: &[f64],
    tau0_s: f64,
    pilot: &[Fitted],
    seed: u64,
    progress: &mut dyn FnMut(usize),
) -> Result<Identification, Failure> {
    let curve = curve(y, tau0_s).ok_or(Failure::TooShort)?;
    let mut generating: Vec<(Term, f64)> = pilot
        .iter()
        .filter_map(|f| f.value.map(|(c, _)| (f.term, c)))
        .collect();
    if generating.is_empty() {
        // A white noise at the shortest τ's level.
        generating.push((
            Term::VelocityRandomWalk,
            (curve.ln_m[0].exp() * curve.tau[0]).sqrt(),
        ));
    }
    // The last round's selection (as a set) and result: a later round that cannot be
    // made (a selection of the ramp alone draws identical replicas) keeps it.
    let mut last: Option<(Vec<Term>, Identification)> = None;
    let mut replicas = 0;
    for round in 0..ROUNDS {
        progress(round);
        let Some(w) = weights(
            &curve,
            y.len(),
            tau0_s,
            &generating,
            seed.wrapping_add(round as u64),
        ) else {
            return last.map(|l| l.1).ok_or(Failure::Weights);
        };
        replicas += REPLICAS;
        let Some((fit, tests)) = select(&curve, &w) else {
            return last.map(|l| l.1).ok_or(Failure::Fit);
        };
        generating = fit
            .terms
            .iter()
            .zip(&fit.theta)
            .map(|(&t, &th)| (t, th.sqrt()))
            .collect();
        let mut set = fit.terms.clone();
        set.sort_by_key(|t| WITH_RATE_RAMP.iter().position(|x| x == t));
        let settled = last.as_ref().is_some_and(|l| l.0 == set);
        let id = result(&curve, &fit, &tests, replicas, round + 1);
        if settled || round + 1 == ROUNDS {
            return Ok(id);
        }
        last = Some((set, id));
    }
    last.map(|l| l.1).ok_or(Failure::Fit)
}

/// The octave points up to a quarter of the record with a positive Allan variance.
fn curve(y: &[f64], tau0_s: f64) -> Option<Curve> {
    let sums = Sums::new(y);
    let mut c = Curve {
        m: Vec::new(),
        tau: Vec::new(),
        ln_m: Vec::new(),
    };
    for m in allan::octave_factors(y.len()) {
        if m * LONGEST > y.len() {
            break;
        }
        let a = sums.avar(m)?.0;
        if a > 0.0 && a.is_finite() {
            c.m.push(m);
            c.tau.push(m as f64 * tau0_s);
            c.ln_m.push(a.ln());
        }
    }
    (c.m.len() >= 3).then_some(c)
}

/// The bootstrap at `terms`: [`REPLICAS`] records drawn from `seed`, the bias of each
/// point's log (the mean of the logs less the log of the mean) and the whitening of their
/// covariance.
fn weights(
    curve: &Curve,
    n: usize,
    tau0_s: f64,
    terms: &[(Term, f64)],
    seed: u64,
) -> Option<Weights> {
    let logs: Vec<Vec<f64>> = (0..REPLICAS as u64)
        .into_par_iter()
        .map(|r| {
            let y = synth::readings(terms, n, tau0_s, mix(seed, r));
            let sums = Sums::new(&y);
            curve
                .m
                .iter()
                .map(|&m| sums.avar(m).map_or(f64::NAN, |a| a.0.ln()))
                .collect()
        })
        .collect();
    let k = curve.m.len();
    let reps = REPLICAS as f64;
    let mean: Vec<f64> = (0..k)
        .map(|i| logs.iter().map(|l| l[i]).sum::<f64>() / reps)
        .collect();
    let mut cov = DMatrix::from_fn(k, k, |i, j| {
        logs.iter()
            .map(|l| (l[i] - mean[i]) * (l[j] - mean[j]))
            .sum::<f64>()
            / (reps - 1.0)
    });
    // The inverse of a sample covariance of ν = REPLICAS − 1 degrees of freedom
    // overstates C⁻¹ by ν/(ν − k − 1) on average (Wishart): taken out.
    let nu = reps - 1.0;
    cov *= nu / (nu - k as f64 - 1.0);
    // Each log's bias: the mean of the logs less the log of the mean (Jensen's), so that
    // the records' own departures from the terms' shapes (a sampled flicker's first
    // octaves) stay out of it.
    let bias = (0..k)
        .map(|i| mean[i] - (logs.iter().map(|l| l[i].exp()).sum::<f64>() / reps).ln())
        .collect::<Vec<_>>();
    if bias.iter().any(|b| !b.is_finite()) {
        return None;
    }
    let l = cov.cholesky()?.l();
    let whiten = l.try_inverse()?;
    Some(Weights { bias, whiten })
}

/// `seed` and the replica's index mixed (`SplitMix64`'s finaliser).
fn mix(seed: u64, r: u64) -> u64 {
    let mut z = seed ^ r.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// One test of a term left: its `z` and p.
type Test = (Term, f64, f64);

/// Forward selection with Holm's thresholds; the selected fit and each term's last test.
fn select(curve: &Curve, w: &Weights) -> Option<(Fit, Vec<Test>)> {
    let mut fit = WITH_RATE_RAMP
        .iter()
        .filter_map(|&t| fit_terms(curve, w, &[t]))
        .min_by(|a, b| a.chi2.total_cmp(&b.chi2))?;
    let mut tests: Vec<Test> = Vec::new();
    let family = WITH_RATE_RAMP.len() - 1;
    for step in 0..family {
        let left: Vec<Term> = WITH_RATE_RAMP
            .iter()
            .copied()
            .filter(|t| !fit.terms.contains(t))
            .collect();
        let mut best: Option<(Test, Fit)> = None;
        for &t in &left {
            let mut terms = fit.terms.clone();
            terms.push(t);
            let (z, with) = match fit_terms(curve, w, &terms) {
                Some(f) => ((fit.chi2 - f.chi2).max(0.0).sqrt(), Some(f)),
                None => (0.0, None),
            };
            let p = 1.0 - Normal::standard().cdf(z);
            tests.retain(|x| x.0 != t);
            tests.push((t, z, p));
            if let Some(f) = with
                && best.as_ref().is_none_or(|b| z > b.0.1)
            {
                best = Some(((t, z, p), f));
            }
        }
        match best {
            Some(((_, _, p), f)) if p <= ALPHA / (family - step) as f64 => fit = f,
            _ => break,
        }
    }
    Some((fit, tests))
}

/// The terms `terms` fitted by Levenberg–Marquardt in `ln θ` (so each stays positive),
/// their covariance in `θ` at the minimum; `None` when the fit fails.
fn fit_terms(curve: &Curve, w: &Weights, terms: &[Term]) -> Option<Fit> {
    let k = curve.m.len();
    if terms.len() >= k {
        return None;
    }
    let target: Vec<f64> = (0..k).map(|i| curve.ln_m[i] - w.bias[i]).collect();
    // Start: each term at a tenth of the most the curve allows it.
    let mut phi: Vec<f64> = terms
        .iter()
        .map(|t| {
            let most = (0..k)
                .map(|i| target[i].exp() / t.shape(curve.tau[i]))
                .fold(f64::INFINITY, f64::min);
            (0.1 * most / terms.len() as f64).ln()
        })
        .collect();
    let eval = |phi: &[f64]| -> (DVector<f64>, DMatrix<f64>) {
        let s: Vec<f64> = (0..k)
            .map(|i| {
                terms
                    .iter()
                    .zip(phi)
                    .map(|(t, p)| p.exp() * t.shape(curve.tau[i]))
                    .sum()
            })
            .collect();
        let r = DVector::from_fn(k, |i, _| target[i] - s[i].ln());
        // ∂r/∂φ_j = −θ_j·s_j/S.
        let jac = DMatrix::from_fn(k, terms.len(), |i, j| {
            -phi[j].exp() * terms[j].shape(curve.tau[i]) / s[i]
        });
        (&w.whiten * r, &w.whiten * jac)
    };
    let (mut rho, mut a) = eval(&phi);
    let mut chi2 = rho.norm_squared();
    let mut mu = 1e-3;
    for _ in 0..300 {
        let ata = a.transpose() * &a;
        let g = a.transpose() * &rho;
        let mut lhs = ata.clone();
        for j in 0..terms.len() {
            lhs[(j, j)] += mu * ata[(j, j)].max(1e-12);
        }
        let step = lhs.lu().solve(&(-g))?;
        let trial: Vec<f64> = phi
            .iter()
            .zip(step.iter())
            .map(|(p, d)| p + d.clamp(-5.0, 5.0))
            .collect();
        let (r2, a2) = eval(&trial);
        let c2 = r2.norm_squared();
        if c2.is_finite() && c2 <= chi2 {
            let done = chi2 - c2 < 1e-10 * chi2.max(1.0);
            phi = trial;
            rho = r2;
            a = a2;
            chi2 = c2;
            mu = (mu / 3.0).max(1e-12);
            if done {
                break;
            }
        } else {
            mu *= 4.0;
            if mu > 1e12 {
                break;
            }
        }
    }
    // Covariance in θ: the Jacobian in φ over θ (∂φ = ∂θ/θ).
    let theta: Vec<f64> = phi.iter().map(|p| p.exp()).collect();
    let a_theta = DMatrix::from_fn(k, terms.len(), |i, j| a[(i, j)] / theta[j]);
    let cov = (a_theta.transpose() * a_theta).try_inverse()?;
    Some(Fit {
        terms: terms.to_vec(),
        theta,
        chi2,
        cov,
    })
}

/// The identification from the selected fit and the tests.
fn result(
    curve: &Curve,
    fit: &Fit,
    tests: &[Test],
    replicas: usize,
    rounds: usize,
) -> Identification {
    let dof = curve.m.len() - fit.terms.len();
    let birge = if dof > 0 {
        (fit.chi2 / dof as f64).sqrt().max(1.0)
    } else {
        1.0
    };
    let t = crate::stats::t_two_sided_quantile(0.05, (REPLICAS - 1) as f64);
    let candidates = WITH_RATE_RAMP
        .iter()
        .map(|&term| {
            let test = tests.iter().find(|x| x.0 == term);
            let value = fit.terms.iter().position(|&x| x == term).map(|j| {
                let th = fit.theta[j];
                let half = t * birge * fit.cov[(j, j)].sqrt();
                (th.sqrt(), (th - half).max(0.0).sqrt(), (th + half).sqrt())
            });
            Candidate {
                term,
                selected: value.is_some(),
                z: test.map(|x| x.1),
                p: test.map(|x| x.2),
                value,
            }
        })
        .collect();
    Identification {
        candidates,
        taus: curve.tau.clone(),
        chi2: fit.chi2,
        dof,
        replicas,
        rounds,
    }
}

/// The test, for the JSON and the docs.
pub const TEST: &str = "AVAR(tau) = 3 Q^2/tau^2 + N^2/tau + (2 ln 2/pi) B^2 + K^2 tau/3 + R^2 tau^2/2 at the octave taus up to a quarter of the record, compared as ln AVAR with each log's bias (Jensen's, from the replicas) taken out, chi2 = r' C^-1 r with C the covariance of ln AVAR across the tau of records drawn at the terms fitted so far (its inverse made unbiased for the replicas' number); the best single term first, then forward selection with Holm thresholds (0.05/4, 0.05/3, 0.05/2, 0.05): each term left tested given those selected by the root of its drop of chi2 against the one-sided normal; the covariance drawn again at the selected fit until the selection repeats; 95 % intervals on each squared coefficient from the joint fit's covariance, times the Birge ratio above 1 and Student's two-sided 95 % point for the replicas less one degree of freedom, then square-rooted";

impl Identification {
    /// The table `ptsa noise --readings FILE --identify` prints.
    #[must_use]
    pub fn text(&self) -> String {
        use crate::output::significant as sig;
        use std::fmt::Write as _;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "identified terms (IEEE Std 952; {} taus up to {} s, {} records drawn in {} round{}; Holm at 5 % familywise; chi2 {:.1} on {} dof):",
            self.taus.len(),
            sig(self.taus.last().copied().unwrap_or(0.0), 4),
            self.replicas,
            self.rounds,
            if self.rounds == 1 { "" } else { "s" },
            self.chi2,
            self.dof
        );
        for c in &self.candidates {
            let test = match (c.z, c.p) {
                (Some(z), Some(p)) => format!("z {z:.2}, p {p:.2e}"),
                _ => "the best single term".to_string(),
            };
            match c.value {
                Some((v, lo, hi)) => {
                    let parts: Vec<String> = c
                        .term
                        .units()
                        .into_iter()
                        .map(|(u, k)| {
                            format!(
                                "{} [{}, {}] {u}",
                                sig(v * k, 4),
                                sig(lo * k, 4),
                                sig(hi * k, 4)
                            )
                        })
                        .collect();
                    let _ = writeln!(
                        s,
                        "  {} {}: selected ({test}): {} (95 %)",
                        c.term.symbol(),
                        c.term.key().replace('_', " "),
                        parts.join(" = ")
                    );
                }
                None => {
                    let _ = writeln!(
                        s,
                        "  {} {}: not selected ({test})",
                        c.term.symbol(),
                        c.term.key().replace('_', " ")
                    );
                }
            }
        }
        s
    }
}

/// The replicas' seed for the readings `y`: `seed` mixed with the readings' bits (a
/// hash), so that two records almost never share their replicas.
#[must_use]
pub fn record_seed(y: &[f64], seed: u64) -> u64 {
    let mut h = ptsa_core::Fnv::new();
    h.bytes(&seed.to_le_bytes());
    for v in y {
        h.bytes(&v.to_bits().to_le_bytes());
    }
    h.finish()
}
