//! The noise terms of IEEE Std 952's Allan-variance model, read from a deviation curve by a
//! weighted least-squares fit, each in cgs and in IEEE/navigation units.
//!
//! ```text
//! AVAR(τ) = 3·Q²/τ²  +  N²/τ  +  (2·ln 2/π)·B²  +  K²·τ/3  (+  R²·τ²/2)
//! ```
//!
//! * `Q`, quantization (ADEV slope −1): white noise on the velocity (for a pulse-rebalance
//!   loop, the count quantization: each gate's count misses the charge the loop stores at
//!   its two ends), cm/s;
//! * `N`, velocity random walk (slope −1/2): white acceleration noise, cm/s²/√Hz (the
//!   square root of the two-sided density, as IEEE Std 952 annex C writes it; the
//!   one-sided density is `√2·N`);
//! * `B`, bias instability (slope 0 at the flat bottom; `0.664·B` there), cm/s²;
//! * `K`, acceleration random walk (slope +1/2), cm/s²·√Hz (cm/s^2.5);
//! * `R`, rate ramp (slope +1): a steady drift of the acceleration, cm/s³. A counter
//!   record's analysis fits the first four; a record of readings all five.
//!
//! The fit: the four squared coefficients are the unknowns of a linear least squares on the
//! octave points' Allan variances, each weighted by its variance `2·AVAR²/ν` (ν its
//! equivalent degrees of freedom); the squared coefficients must be positive, so every
//! subset of the four terms is fitted and the best one with all coefficients positive kept
//! (a term left out is "not resolved"). The uncertainty of a coefficient comes from the
//! fit's covariance, scaled by the Birge ratio when the points scatter beyond their
//! weights (`stats::birge_ratio`). The octave points of an overlapping estimate are
//! positively correlated, which the fit ignores: the uncertainties are approximate, on the
//! small side.

use crate::stats;

/// Standard gravity for µg, cm/s² (the unit's definition, not the site's gravity).
pub const G0_CM_S2: f64 = 980.665;

/// The four terms.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Term {
    /// `Q`, slope −1.
    Quantization,
    /// `N`, slope −1/2.
    VelocityRandomWalk,
    /// `B`, slope 0.
    BiasInstability,
    /// `K`, slope +1/2.
    AccelerationRandomWalk,
    /// `R`, slope +1.
    RateRamp,
}

/// The terms a counter record's analysis fits, in the order of the fit's columns.
pub const TERMS: [Term; 4] = [
    Term::Quantization,
    Term::VelocityRandomWalk,
    Term::BiasInstability,
    Term::AccelerationRandomWalk,
];

/// The terms a record of readings' analysis fits: [`TERMS`] and the rate ramp.
pub const WITH_RATE_RAMP: [Term; 5] = [
    Term::Quantization,
    Term::VelocityRandomWalk,
    Term::BiasInstability,
    Term::AccelerationRandomWalk,
    Term::RateRamp,
];

impl Term {
    /// The JSON key.
    #[must_use]
    pub fn key(self) -> &'static str {
        match self {
            Self::Quantization => "quantization",
            Self::VelocityRandomWalk => "velocity_random_walk",
            Self::BiasInstability => "bias_instability",
            Self::AccelerationRandomWalk => "acceleration_random_walk",
            Self::RateRamp => "rate_ramp",
        }
    }

    /// IEEE Std 952's symbol.
    #[must_use]
    pub fn symbol(self) -> &'static str {
        match self {
            Self::Quantization => "Q",
            Self::VelocityRandomWalk => "N",
            Self::BiasInstability => "B",
            Self::AccelerationRandomWalk => "K",
            Self::RateRamp => "R",
        }
    }

    /// The ADEV slope on log–log axes.
    #[must_use]
    pub fn slope(self) -> f64 {
        match self {
            Self::Quantization => -1.0,
            Self::VelocityRandomWalk => -0.5,
            Self::BiasInstability => 0.0,
            Self::AccelerationRandomWalk => 0.5,
            Self::RateRamp => 1.0,
        }
    }

    /// `AVAR(τ)` of this term per unit squared coefficient.
    #[must_use]
    pub fn shape(self, tau_s: f64) -> f64 {
        match self {
            Self::Quantization => 3.0 / (tau_s * tau_s),
            Self::VelocityRandomWalk => 1.0 / tau_s,
            Self::BiasInstability => 2.0 * std::f64::consts::LN_2 / std::f64::consts::PI,
            Self::AccelerationRandomWalk => tau_s / 3.0,
            Self::RateRamp => tau_s * tau_s / 2.0,
        }
    }

    /// The coefficient (cgs) in each of its units: `(unit, factor)` with value in that unit
    /// = factor × cgs value. The first is the cgs unit.
    #[must_use]
    pub fn units(self) -> Vec<(&'static str, f64)> {
        let ug = 1.0 / (G0_CM_S2 * 1e-6);
        match self {
            // cm/s; m/s; µg·s (the velocity step over 1 s in µg).
            Self::Quantization => vec![("cm/s", 1.0), ("m/s", 0.01), ("ug*s", ug)],
            // cm/s²/√Hz = cm/s/√s; µg/√Hz; (m/s)/√h: 0.01 m/s per √s × 60 √s per √h.
            Self::VelocityRandomWalk => vec![
                ("cm/s^2/rtHz", 1.0),
                ("ug/rtHz", ug),
                ("(m/s)/rth", 0.01 * 60.0),
            ],
            Self::BiasInstability => vec![("cm/s^2", 1.0), ("ug", ug), ("mg", ug * 1e-3)],
            // cm/s^2.5; µg/√s; (m/s)/h^(3/2): 0.01 m/s per s^1.5 × 3600^1.5 s^1.5 per h^1.5.
            Self::AccelerationRandomWalk => vec![
                ("cm/s^2*rtHz", 1.0),
                ("ug/rts", ug),
                ("(m/s)/h^1.5", 0.01 * 3600f64.powf(1.5)),
            ],
            // cm/s³; µg/s; (m/s)/h²: 0.01 m/s per s² × 3600² s² per h².
            Self::RateRamp => vec![
                ("cm/s^3", 1.0),
                ("ug/s", ug),
                ("(m/s)/h^2", 0.01 * 3600.0 * 3600.0),
            ],
        }
    }
}

/// One term's fitted coefficient (cgs), or none when the fit leaves it out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fitted {
    /// Which term.
    pub term: Term,
    /// The coefficient in cgs and its standard error, if resolved.
    pub value: Option<(f64, f64)>,
}

/// The terms of [`TERMS`] fitted to points `(τ s, AVAR, edf)`; also the fit's `χ²` and
/// degrees of freedom. Every term is unresolved with fewer than two points.
#[must_use]
pub fn fit(points: &[(f64, f64, f64)]) -> (Vec<Fitted>, f64, usize) {
    fit_terms(points, &TERMS)
}

/// [`fit`] over the terms `terms` (every subset of them tried).
#[must_use]
pub fn fit_terms(points: &[(f64, f64, f64)], terms: &[Term]) -> (Vec<Fitted>, f64, usize) {
    let none = || {
        terms
            .iter()
            .map(|&term| Fitted { term, value: None })
            .collect::<Vec<_>>()
    };
    let pts: Vec<_> = points
        .iter()
        .copied()
        .filter(|p| p.1 > 0.0 && p.1.is_finite())
        .collect();
    if pts.len() < 2 {
        return (none(), 0.0, 0);
    }
    // z = AVAR/σ(AVAR), σ(AVAR) = AVAR·√(2/ν).
    let sig: Vec<f64> = pts.iter().map(|p| p.1 * (2.0 / p.2).sqrt()).collect();
    let z: Vec<f64> = pts.iter().zip(&sig).map(|(p, s)| p.1 / s).collect();
    let cols: Vec<Vec<f64>> = terms
        .iter()
        .map(|t| {
            pts.iter()
                .zip(&sig)
                .map(|(p, s)| t.shape(p.0) / s)
                .collect()
        })
        .collect();
    let mut best: Option<(f64, u32, stats::LsqFit)> = None;
    for mask in 1u32..(1 << terms.len()) {
        let chosen: Vec<&[f64]> = (0..terms.len())
            .filter(|k| mask >> k & 1 == 1)
            .map(|k| cols[k].as_slice())
            .collect();
        if chosen.len() > pts.len() {
            continue;
        }
        let Some(f) = stats::lsq(&z, &chosen) else {
            continue;
        };
        if f.beta.iter().any(|&b| b <= 0.0) {
            continue;
        }
        if best.as_ref().is_none_or(|(c, _, _)| f.chi2 < *c) {
            best = Some((f.chi2, mask, f));
        }
    }
    let Some((chi2, mask, f)) = best else {
        return (none(), 0.0, 0);
    };
    let p = f.beta.len();
    let dof = pts.len() - p;
    let scale = stats::birge_ratio(chi2, dof);
    let mut out = none();
    let mut j = 0;
    for (k, o) in out.iter_mut().enumerate() {
        if mask >> k & 1 == 1 {
            let c2 = f.beta[j];
            let s2 = f.cov[(j, j)].sqrt() * scale;
            let c = c2.sqrt();
            o.value = Some((c, s2 / (2.0 * c)));
            j += 1;
        }
    }
    (out, chi2, dof)
}

/// `AVAR(τ)` of the fitted terms, each and summed.
#[must_use]
pub fn model_avar(terms: &[Fitted], tau_s: f64) -> f64 {
    terms
        .iter()
        .filter_map(|t| t.value.map(|(c, _)| c * c * t.term.shape(tau_s)))
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A curve made of two known terms, points with plenty of degrees of freedom: the fit
    /// gives them back and leaves the others out.
    #[test]
    fn two_terms_come_back() {
        let (q, n) = (0.002, 0.05);
        let pts: Vec<(f64, f64, f64)> = (0..12)
            .map(|k| {
                let tau = 0.01 * 2f64.powi(k);
                let avar = 3.0 * q * q / (tau * tau) + n * n / tau;
                (tau, avar, 1e6)
            })
            .collect();
        let (f, chi2, _) = fit(&pts);
        assert!(chi2 < 1e-6, "{chi2}");
        let (qf, _) = f[0].value.unwrap();
        let (nf, _) = f[1].value.unwrap();
        assert!(
            (qf - q).abs() < 1e-6 * q && (nf - n).abs() < 1e-6 * n,
            "{f:?}"
        );
        assert!(f[2].value.is_none() && f[3].value.is_none(), "{f:?}");
        // Slope −1/2 read at τ = 1 s is N: the white term's ADEV there.
        let adev1 = model_avar(&f[1..2], 1.0).sqrt();
        assert!((adev1 - n).abs() < 1e-9);
    }

    /// The unit factors: 1 cm/s²/√Hz is 1019.7 µg/√Hz and 0.6 (m/s)/√h; 1 cm/s² is
    /// 1019.7 µg; 1 cm/s^2.5 is 2160 (m/s)/h^1.5.
    #[test]
    fn unit_factors() {
        let f = |t: Term, u: &str| t.units().into_iter().find(|x| x.0 == u).unwrap().1;
        assert!((f(Term::VelocityRandomWalk, "ug/rtHz") - 1019.716).abs() < 1e-3);
        assert!((f(Term::VelocityRandomWalk, "(m/s)/rth") - 0.6).abs() < 1e-12);
        assert!((f(Term::BiasInstability, "ug") - 1019.716).abs() < 1e-3);
        assert!((f(Term::AccelerationRandomWalk, "(m/s)/h^1.5") - 2160.0).abs() < 1e-9);
    }
}
