//! The overlapping Allan deviation, the modified Allan deviation and the overlapping
//! Hadamard deviation of a series of contiguous gate averages (or evenly spaced samples), at
//! the averaging times asked for (octave, decade, all, or listed), with confidence intervals
//! at 95 % and at the level asked for, from equivalent degrees of freedom.
//!
//! # The quantities
//! The series is `y_k`, the mean acceleration over gate `k` (cm/s²), gates of length `τ₀`
//! back to back. Its running sum `S_k = Σ_{i<k} y_i` is the velocity `x_k = τ₀·S_k` (cm/s)
//! at the gates' boundaries: in the time-and-frequency vocabulary `y` is the "frequency"
//! and `x` the "phase". With `M` gates there are `N = M + 1` boundaries. At `τ = m·τ₀`:
//!
//! ```text
//! AVAR(τ)  = 1/(2·(N − 2m)) · Σ_{i=0}^{N−2m−1} ((S_{i+2m} − 2·S_{i+m} + S_i)/m)²
//! MVAR(τ)  = 1/(2·m⁴·(N − 3m + 1)) · Σ_{j=0}^{N−3m} (Σ_{i=j}^{j+m−1} (S_{i+2m} − 2·S_{i+m} + S_i))²
//! ```
//!
//! the overlapping estimator (every start `i`, stride 1) and the modified one (the inner
//! sum averages the boundaries over `m` before differencing). Both are computed in `O(N)`
//! per `τ` from prefix sums: the inner sum of MVAR is the third difference
//! `C_{j+3m} − 3·C_{j+2m} + 3·C_{j+m} − C_j` of `C_k = Σ_{i<k} S_i`. The overlapping
//! Hadamard variance, the second difference of the `m`-averages (blind to a linear drift of
//! `y`), is the third difference of `S`:
//!
//! ```text
//! HVAR(τ)  = 1/(6·(N − 3m)) · Σ_{i=0}^{N−3m−1} ((S_{i+3m} − 3·S_{i+2m} + 3·S_{i+m} − S_i)/m)²
//! ``` The mean of `y` and
//! the mean of `S` are taken out first (neither changes a second or third difference) to
//! keep the sums small.
//!
//! # Confidence intervals
//! `AVAR` estimated with `ν` equivalent degrees of freedom is distributed as
//! `AVAR·χ²_ν/ν`, so the 95 % interval of the deviation is
//! `[σ·√(ν/χ²_ν(0.975)), σ·√(ν/χ²_ν(0.025))]` (the quantiles of `statrs`'s χ²
//! distribution). `ν` is Greenhall's (Greenhall and Riley, 2003; [`super::edf`]) for the
//! overlapping and for the modified estimator, the algorithm Stable32 and allantools offer;
//! the noise type at each `τ` is identified by the lag-1 autocorrelation of the
//! `m`-averaged series (Riley and Greenhall, 2004; see [`noise_id`]). The simple
//! approximate formulas of Howe, Allan and Barnes (1981) for the overlapping estimator,
//! which NIST Special Publication 1065 tabulates, are [`edf_simple`], kept for comparison.

use statrs::distribution::{ChiSquared, ContinuousCDF};

use crate::output::significant as sig;

use super::edf::{self, Estimator};

/// Fewest points of the `m`-averaged series the lag-1 autocorrelation identifies a noise
/// type from (Riley and Greenhall recommend about 30).
pub const NOISE_ID_MIN_POINTS: usize = 30;

/// Most averages the noise identification reads (the first ones): beyond 2^20 the lag-1
/// autocorrelation's own scatter (about `1/√k`, 0.001) is far below the 0.25 steps it is
/// judged by, and a 10⁷-sample record would otherwise be differenced whole at every τ.
pub const NOISE_ID_MAX_POINTS: usize = 1 << 20;

/// How a point's noise type was decided.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoiseIdSource {
    /// The lag-1 autocorrelation of the `m`-averaged series.
    Acf,
    /// Too few averages at this `τ`: the type identified at the longest shorter `τ`.
    Inherited,
    /// Too few gates for any identification: white acceleration noise (`α = 0`) assumed.
    Assumed,
}

impl NoiseIdSource {
    /// Its name in the JSON.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Acf => "lag-1 acf",
            Self::Inherited => "inherited",
            Self::Assumed => "assumed",
        }
    }
}

/// One averaging time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    /// Averaging factor `m` (gates per average).
    pub m: usize,
    /// `τ = m·τ₀`, s.
    pub tau_s: f64,
    /// Overlapping Allan deviation, in the series' unit (cm/s²).
    pub adev: f64,
    /// Lower end of its 95 % interval.
    pub ci95_lo: f64,
    /// Upper end of its 95 % interval.
    pub ci95_hi: f64,
    /// Equivalent degrees of freedom of the estimate.
    pub edf: f64,
    /// Terms of the overlapping sum, `N − 2m`.
    pub n_pairs: usize,
    /// Modified Allan deviation (`None` where `3m > N`).
    pub mdev: Option<f64>,
    /// Its 95 % interval (from [`Point::mdev_edf`]).
    pub mdev_ci95: Option<(f64, f64)>,
    /// The modified deviation's equivalent degrees of freedom (Greenhall's, at the noise
    /// type identified for the overlapping one).
    pub mdev_edf: Option<f64>,
    /// The power-law exponent `α` of the identified noise (`S_y ∝ f^α`: 2 white velocity
    /// ("phase") noise, 1 flicker velocity, 0 white acceleration, −1 flicker acceleration,
    /// −2 random-walk acceleration).
    pub alpha: i32,
    /// How `alpha` was decided.
    pub alpha_source: NoiseIdSource,
    /// The interval of `adev` at [`Settings::confidence`].
    pub ci: (f64, f64),
    /// The interval of `mdev` at [`Settings::confidence`].
    pub mdev_ci: Option<(f64, f64)>,
    /// The overlapping Hadamard deviation (`None` where `3m ≥ N` or not asked for).
    pub hdev: Option<f64>,
    /// Its equivalent degrees of freedom (Greenhall's `d = 3`, at the noise type
    /// identified with up to three differences, `alpha_h`).
    pub hdev_edf: Option<f64>,
    /// Its interval at [`Settings::confidence`].
    pub hdev_ci: Option<(f64, f64)>,
    /// The noise type the Hadamard deviation's EDF takes (`α` down to −4: the lag-1
    /// autocorrelation after up to three differences).
    pub alpha_h: i32,
}

/// Which averaging times to analyse (`ptsa noise --taus`).
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub enum Taus {
    /// `1, 2, 4, 8, …` times `τ₀` (the default).
    #[default]
    Octave,
    /// `1, 2, 4, 10, 20, 40, 100, …` times `τ₀` (Stable32's and allantools' decade).
    Decade,
    /// Every factor `1, 2, 3, …` (the all-tau analysis; `O(N²)` in all).
    All,
    /// The factors given, each `τ/τ₀`.
    Factors(Vec<usize>),
}

impl Taus {
    /// A named set of `--taus`: `octave`, `decade` or `all`.
    #[must_use]
    pub fn named(name: &str) -> Option<Self> {
        match name.trim() {
            "octave" => Some(Self::Octave),
            "decade" => Some(Self::Decade),
            "all" => Some(Self::All),
            _ => None,
        }
    }

    /// The factors of the averaging times `ts`, s, for a record of interval `tau0_s` and `n`
    /// gates or samples; `flag` names the option in a refusal.
    ///
    /// # Errors
    /// A time that is not a whole number of intervals, or beyond half the record.
    pub fn of_seconds(flag: &str, ts: &[f64], tau0_s: f64, n: usize) -> anyhow::Result<Self> {
        let mut m = Vec::with_capacity(ts.len());
        for &t in ts {
            if !(t > 0.0 && t.is_finite()) {
                anyhow::bail!("{flag} {t}: expected averaging times in s, more than 0");
            }
            let k = t / tau0_s;
            if (k - k.round()).abs() > 1e-6 * k.max(1.0) || k.round() < 1.0 {
                anyhow::bail!(
                    "{flag} {}: not a whole number of the record's {} s intervals; expected multiples of it",
                    sig(t, 8),
                    sig(tau0_s, 8)
                );
            }
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let k = k.round() as usize;
            if 2 * k > n {
                #[allow(clippy::cast_precision_loss)]
                let half = tau0_s * n as f64 / 2.0;
                anyhow::bail!(
                    "{flag} {}: beyond half the record ({} s); expected averaging times with at least one pair of averages",
                    sig(t, 8),
                    sig(half, 8)
                );
            }
            m.push(k);
        }
        Ok(Self::Factors(m))
    }

    /// The factors for `M` gates, each with at least one overlapping pair (`2m ≤ M`),
    /// ascending, each once.
    #[must_use]
    pub fn factors(&self, gates: usize) -> Vec<usize> {
        let max = gates / 2;
        let mut v: Vec<usize> = match self {
            Self::Octave => return octave_factors(gates),
            Self::Decade => {
                let mut v = Vec::new();
                let mut p = 1usize;
                while p <= max {
                    v.extend([p, 2 * p, 4 * p].into_iter().filter(|&m| m <= max));
                    p = p.saturating_mul(10);
                }
                v
            }
            Self::All => (1..=max).collect(),
            Self::Factors(f) => f.iter().copied().filter(|&m| m >= 1 && m <= max).collect(),
        };
        v.sort_unstable();
        v.dedup();
        v
    }
}

/// What [`analyse_with`] computes at each factor beyond the overlapping deviation.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// The averaging times.
    pub taus: Taus,
    /// The confidence level of the intervals besides 95 % (0 to 1, exclusive).
    pub confidence: f64,
    /// Compute the Hadamard deviation.
    pub hadamard: bool,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            taus: Taus::Octave,
            confidence: 0.95,
            hadamard: false,
        }
    }
}

/// The averaging factors `1, 2, 4, …` up to `M/2` for `M` gates (at least one overlapping
/// pair).
#[must_use]
pub fn octave_factors(gates: usize) -> Vec<usize> {
    let mut v = Vec::new();
    let mut m = 1usize;
    while 2 * m <= gates {
        v.push(m);
        m *= 2;
    }
    v
}

/// Prefix sums of `v` after taking out its mean: `out[0] = 0`, `out[k] = Σ_{i<k}(v_i − v̄)`.
fn centred_prefix(v: &[f64]) -> Vec<f64> {
    #[allow(clippy::cast_precision_loss)]
    let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
    let mut out = Vec::with_capacity(v.len() + 1);
    let mut acc = 0.0;
    out.push(0.0);
    for x in v {
        acc += x - mean;
        out.push(acc);
    }
    out
}

/// The series' running sums: `S` (length `N = M + 1`) and `C`, the prefix sums of `S`
/// centred (length `N + 1`), made when the modified variance first asks for it.
pub struct Sums {
    s: Vec<f64>,
    c: std::sync::OnceLock<Vec<f64>>,
}

impl Sums {
    /// From the gate averages `y`.
    #[must_use]
    pub fn new(y: &[f64]) -> Self {
        Self {
            s: centred_prefix(y),
            c: std::sync::OnceLock::new(),
        }
    }

    /// Boundaries `N`.
    #[must_use]
    pub fn n(&self) -> usize {
        self.s.len()
    }

    /// The overlapping Allan variance at factor `m` and its number of terms, `O(N)`;
    /// `None` when `2m ≥ N`.
    #[must_use]
    pub fn avar(&self, m: usize) -> Option<(f64, usize)> {
        let n = self.n();
        if m == 0 || 2 * m >= n {
            return None;
        }
        let s = &self.s;
        let terms = n - 2 * m;
        let sum: f64 = (0..terms)
            .map(|i| {
                let d = s[i + 2 * m] - 2.0 * s[i + m] + s[i];
                d * d
            })
            .sum();
        #[allow(clippy::cast_precision_loss)]
        let (mf, tf) = (m as f64, terms as f64);
        Some((sum / (2.0 * tf * mf * mf), terms))
    }

    /// The overlapping Allan variance with its number of terms and, when `hadamard`, the
    /// overlapping Hadamard variance at factor `m`, from one pass over the running sums
    /// (each as [`Sums::avar`] and [`Sums::hvar`] give it).
    #[must_use]
    pub fn avar_hvar(&self, m: usize, hadamard: bool) -> (Option<(f64, usize)>, Option<f64>) {
        let n = self.n();
        if !hadamard || m == 0 || 3 * m >= n {
            return (self.avar(m), if hadamard { self.hvar(m) } else { None });
        }
        let s = &self.s;
        let (a_terms, h_terms) = (n - 2 * m, n - 3 * m);
        let (mut a, mut h) = (0.0, 0.0);
        for i in 0..h_terms {
            let (s0, s1, s2, s3) = (s[i], s[i + m], s[i + 2 * m], s[i + 3 * m]);
            let d2 = s2 - 2.0 * s1 + s0;
            let d3 = s3 - 3.0 * s2 + 3.0 * s1 - s0;
            a += d2 * d2;
            h += d3 * d3;
        }
        for i in h_terms..a_terms {
            let d2 = s[i + 2 * m] - 2.0 * s[i + m] + s[i];
            a += d2 * d2;
        }
        #[allow(clippy::cast_precision_loss)]
        let (mf, af, hf) = (m as f64, a_terms as f64, h_terms as f64);
        (
            Some((a / (2.0 * af * mf * mf), a_terms)),
            Some(h / (6.0 * hf * mf * mf)),
        )
    }

    /// The overlapping Hadamard variance at factor `m`, `O(N)`; `None` when `3m ≥ N`.
    #[must_use]
    pub fn hvar(&self, m: usize) -> Option<f64> {
        let n = self.n();
        if m == 0 || 3 * m >= n {
            return None;
        }
        let s = &self.s;
        let terms = n - 3 * m;
        let sum: f64 = (0..terms)
            .map(|i| {
                let d = s[i + 3 * m] - 3.0 * s[i + 2 * m] + 3.0 * s[i + m] - s[i];
                d * d
            })
            .sum();
        #[allow(clippy::cast_precision_loss)]
        let (mf, tf) = (m as f64, terms as f64);
        Some(sum / (6.0 * tf * mf * mf))
    }

    /// The modified Allan variance at factor `m`, `O(N)`; `None` when `3m > N`.
    #[must_use]
    pub fn mvar(&self, m: usize) -> Option<f64> {
        let n = self.n();
        if m == 0 || 3 * m > n {
            return None;
        }
        let c = self.c.get_or_init(|| centred_prefix(&self.s));
        let terms = n - 3 * m + 1;
        let sum: f64 = (0..terms)
            .map(|j| {
                let d = c[j + 3 * m] - 3.0 * c[j + 2 * m] + 3.0 * c[j + m] - c[j];
                d * d
            })
            .sum();
        #[allow(clippy::cast_precision_loss)]
        let (mf, tf) = (m as f64, terms as f64);
        Some(sum / (2.0 * mf.powi(4) * tf))
    }
}

/// The lag-1 autocorrelation of `z` (0 for a constant series).
fn lag1(z: &[f64]) -> f64 {
    #[allow(clippy::cast_precision_loss)]
    let mean = z.iter().sum::<f64>() / z.len() as f64;
    let den: f64 = z.iter().map(|v| (v - mean) * (v - mean)).sum();
    if den <= 0.0 {
        return 0.0;
    }
    let num: f64 = z.windows(2).map(|w| (w[0] - mean) * (w[1] - mean)).sum();
    num / den
}

/// The power-law noise type `α` of the averages of `y` over `m` gates (non-overlapping),
/// by the lag-1 autocorrelation method of Riley and Greenhall (2004) for frequency-like
/// data: with `r₁` the lag-1 autocorrelation and `δ = r₁/(1 + r₁)`, the series is
/// differenced (at most twice) until `δ < 0.25`; then `α = −2·(δ + d)` rounded, for `d`
/// differences. `None` with fewer than [`NOISE_ID_MIN_POINTS`] averages.
#[must_use]
pub fn noise_id(y: &[f64], m: usize) -> Option<i32> {
    noise_ids(y, m).map(|(allan, _)| allan)
}

/// [`noise_id`] for the Allan variances (differencing at most twice, `α` from −2 to 2) and
/// for the Hadamard variance (three times, down to −4), from one pass over the averages.
#[must_use]
pub fn noise_ids(y: &[f64], m: usize) -> Option<(i32, i32)> {
    let k = (y.len() / m.max(1)).min(NOISE_ID_MAX_POINTS);
    if k < NOISE_ID_MIN_POINTS {
        return None;
    }
    #[allow(clippy::cast_precision_loss)]
    let mut z: Vec<f64> = y
        .chunks_exact(m)
        .take(k)
        .map(|c| c.iter().sum::<f64>() / m as f64)
        .collect();
    let mut allan = None;
    let mut d = 0;
    loop {
        let r1 = lag1(&z);
        let delta = r1 / (1.0 + r1);
        #[allow(clippy::cast_possible_truncation)]
        let alpha = (-2.0 * (delta + f64::from(d))).round() as i32;
        if allan.is_none() && (delta < 0.25 || d >= 2) {
            allan = Some(alpha.clamp(-2, 2));
        }
        if delta < 0.25 || d >= 3 {
            return Some((allan.unwrap_or(-2), alpha.clamp(-4, 2)));
        }
        z = z.windows(2).map(|w| w[1] - w[0]).collect();
        d += 1;
    }
}

/// Equivalent degrees of freedom of the overlapping Allan variance at factor `m` from `n`
/// boundaries ("phase" points, gates + 1) for the noise type `alpha`: the simple
/// approximate formulas of Howe, Allan and Barnes (1981) as NIST SP 1065 (2008) tabulates
/// them (section 5.3); at least 1.
///
/// * `α = 2`: `(N + 1)(N − 2m) / (2(N − m))`
/// * `α = 1`: `exp(√(ln((N − 1)/(2m)) · ln((2m + 1)(N − 1)/4)))`
/// * `α = 0`: `(3(N − 1)/(2m) − 2(N − 2)/N) · 4m²/(4m² + 5)`
/// * `α = −1`: `2(N − 2)²/(2.3N − 4.9)` for `m = 1`, else `5N²/(4m(N + 3m))`
/// * `α = −2`: `(N − 2)/m · ((N − 1)² − 3m(N − 1) + 4m²)/(N − 3)²`
#[must_use]
pub fn edf_simple(n: usize, m: usize, alpha: i32) -> f64 {
    #[allow(clippy::cast_precision_loss)]
    let (nf, mf) = (n as f64, m as f64);
    let v = match alpha {
        2 => (nf + 1.0) * (nf - 2.0 * mf) / (2.0 * (nf - mf)),
        1 => {
            let a = ((nf - 1.0) / (2.0 * mf)).ln();
            let b = ((2.0 * mf + 1.0) * (nf - 1.0) / 4.0).ln();
            (a * b).max(0.0).sqrt().exp()
        }
        0 => {
            (3.0 * (nf - 1.0) / (2.0 * mf) - 2.0 * (nf - 2.0) / nf) * 4.0 * mf * mf
                / (4.0 * mf * mf + 5.0)
        }
        -1 => {
            if m == 1 {
                2.0 * (nf - 2.0).powi(2) / (2.3 * nf - 4.9)
            } else {
                5.0 * nf * nf / (4.0 * mf * (nf + 3.0 * mf))
            }
        }
        _ => {
            (nf - 2.0) / mf * ((nf - 1.0).powi(2) - 3.0 * mf * (nf - 1.0) + 4.0 * mf * mf)
                / (nf - 3.0).powi(2)
        }
    };
    if v.is_finite() { v.max(1.0) } else { 1.0 }
}

/// The `p` quantile of χ² with `k` degrees of freedom (`k > 0`, `0 < p < 1`): bisection on
/// `ln x` of `statrs`'s χ² distribution function (its own `inverse_cdf` gives NaN for small
/// `p` at `k = 1`), to a relative 1e-12.
#[must_use]
pub fn chi2_quantile(p: f64, k: f64) -> f64 {
    let Ok(d) = ChiSquared::new(k) else {
        return f64::NAN;
    };
    if !(p > 0.0 && p < 1.0) {
        return f64::NAN;
    }
    let (mut lo, mut hi) = ((1e-300f64).ln(), (k + 50.0 * (2.0 * k).sqrt() + 200.0).ln());
    while hi - lo > 1e-12 {
        let mid = 0.5 * (lo + hi);
        if d.cdf(mid.exp()) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (0.5 * (lo + hi)).exp()
}

/// The 95 % interval `[lo, hi]` of a deviation `dev` estimated with `edf` degrees of
/// freedom.
#[must_use]
pub fn ci95(dev: f64, edf: f64) -> (f64, f64) {
    interval(dev, edf, 0.95)
}

/// The two-sided interval at `confidence` (0 to 1) of a deviation `dev` estimated with
/// `edf` degrees of freedom: `[σ·√(ν/χ²_ν(1 − a/2)), σ·√(ν/χ²_ν(a/2))]`, `a = 1 − confidence`.
#[must_use]
pub fn interval(dev: f64, edf: f64, confidence: f64) -> (f64, f64) {
    let a = 1.0 - confidence;
    let lo = dev * (edf / chi2_quantile(1.0 - a / 2.0, edf)).sqrt();
    let hi = dev * (edf / chi2_quantile(a / 2.0, edf)).sqrt();
    (lo, hi)
}

/// The overlapping and modified Allan deviations of the gate averages `y` (gates of
/// `tau0_s` seconds, back to back) at the octave factors ([`octave_factors`]), each with
/// its noise type, equivalent degrees of freedom and 95 % interval.
#[must_use]
pub fn analyse(y: &[f64], tau0_s: f64) -> Vec<Point> {
    analyse_with(y, tau0_s, &Settings::default())
}

/// [`analyse`] at the factors of `settings.taus`, with intervals at its confidence too and,
/// when asked, the Hadamard deviation.
#[must_use]
pub fn analyse_with(y: &[f64], tau0_s: f64, settings: &Settings) -> Vec<Point> {
    use rayon::prelude::*;
    let sums = Sums::new(y);
    let n = sums.n();
    let factors: Vec<usize> = settings
        .taus
        .factors(y.len())
        .into_iter()
        .filter(|&m| 2 * m < n)
        .collect();
    // Each factor's estimates and noise types on their own, in parallel; then, in order,
    // the types a factor inherits and the intervals.
    let raw: Vec<Raw> = factors
        .par_iter()
        .map(|&m| {
            // Each averaging time a point where a host's Ctrl-C may stop the analysis.
            crate::simulation::work::checkpoint();
            let (avar, hvar) = sums.avar_hvar(m, settings.hadamard);
            Raw {
                m,
                avar: avar.map_or((f64::NAN, 0), |a| a),
                mdev: sums.mvar(m).map(f64::sqrt),
                hdev: hvar.map(f64::sqrt),
                ids: if settings.hadamard {
                    noise_ids(y, m)
                } else {
                    noise_id(y, m).map(|a| (a, a))
                },
            }
        })
        .collect();
    let mut last: Option<i32> = None;
    let mut last_h: Option<i32> = None;
    raw.into_iter()
        .map(|r| {
            let (alpha, alpha_source) = identified(r.ids.map(|i| i.0), &mut last);
            let alpha_h = if settings.hadamard {
                identified(r.ids.map(|i| i.1), &mut last_h).0
            } else {
                alpha
            };
            point(
                &r,
                (alpha, alpha_source, alpha_h),
                n,
                tau0_s,
                settings.confidence,
            )
        })
        .collect()
}

/// One factor's estimates before its noise type is settled.
struct Raw {
    m: usize,
    /// The overlapping Allan variance and its terms.
    avar: (f64, usize),
    mdev: Option<f64>,
    hdev: Option<f64>,
    /// The noise types identified here (Allan, Hadamard), if there are averages enough.
    ids: Option<(i32, i32)>,
}

/// The point of `r` with its noise types, from `n` phase points, the intervals at 95 % and
/// at `confidence`.
fn point(
    r: &Raw,
    (alpha, alpha_source, alpha_h): (i32, NoiseIdSource, i32),
    n: usize,
    tau0_s: f64,
    confidence: f64,
) -> Point {
    let m = r.m;
    let adev = r.avar.0.sqrt();
    let edf = edf::edf(Estimator::Overlapping, alpha, m, n).unwrap_or(1.0);
    let (lo, hi) = ci95(adev, edf);
    let mdev_edf = r.mdev.and(edf::edf(Estimator::Modified, alpha, m, n));
    let hdev_edf = r.hdev.and(edf::edf(Estimator::Hadamard, alpha_h, m, n));
    let conf = |d: Option<f64>, e: Option<f64>| d.zip(e).map(|(d, e)| interval(d, e, confidence));
    #[allow(clippy::cast_precision_loss)]
    let tau_s = m as f64 * tau0_s;
    Point {
        m,
        tau_s,
        adev,
        ci95_lo: lo,
        ci95_hi: hi,
        edf,
        n_pairs: r.avar.1,
        mdev: r.mdev,
        mdev_ci95: r.mdev.zip(mdev_edf).map(|(d, e)| ci95(d, e)),
        mdev_edf,
        alpha,
        alpha_source,
        ci: interval(adev, edf, confidence),
        mdev_ci: conf(r.mdev, mdev_edf),
        hdev: r.hdev,
        hdev_edf,
        hdev_ci: conf(r.hdev, hdev_edf),
        alpha_h,
    }
}

/// The noise type at a factor from its identification `id` (`None`: too few averages),
/// else the last one identified (`last`, updated), else white acceleration assumed.
fn identified(id: Option<i32>, last: &mut Option<i32>) -> (i32, NoiseIdSource) {
    match (id, *last) {
        (Some(a), _) => {
            *last = Some(a);
            (a, NoiseIdSource::Acf)
        }
        (None, Some(a)) => (a, NoiseIdSource::Inherited),
        (None, None) => (0, NoiseIdSource::Assumed),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use rand::SeedableRng as _;
    use rand_distr::{Distribution as _, Normal};

    /// The overlapping Allan variance straight from its definition: the means of `m`
    /// consecutive gates, every start, differences of adjacent means (`O(N·m)`).
    fn avar_by_definition(y: &[f64], m: usize) -> f64 {
        let mean = |a: usize| y[a..a + m].iter().sum::<f64>() / m as f64;
        let starts = y.len() + 1 - 2 * m;
        (0..starts)
            .map(|i| (mean(i + m) - mean(i)).powi(2))
            .sum::<f64>()
            / (2.0 * starts as f64)
    }

    /// The modified Allan variance from its definition: the velocities `x_k`, the second
    /// differences at lag `m`, averaged over `m` starts, squared (`O(N·m)`).
    fn mvar_by_definition(y: &[f64], tau0: f64, m: usize) -> f64 {
        let mut x = vec![0.0];
        for v in y {
            x.push(x[x.len() - 1] + v * tau0);
        }
        let n = x.len();
        let terms = n - 3 * m + 1;
        let mut sum = 0.0;
        for j in 0..terms {
            let mut inner = 0.0;
            for i in j..j + m {
                inner += x[i + 2 * m] - 2.0 * x[i + m] + x[i];
            }
            sum += inner * inner;
        }
        let tau = m as f64 * tau0;
        sum / (2.0 * (m as f64).powi(2) * tau * tau * terms as f64)
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]
        /// The `O(N)` deviations agree with the definitions on drawn series (offset, drift
        /// and scale drawn too).
        #[test]
        fn prefix_sums_agree_with_the_definition(
            y in proptest::collection::vec(-5.0f64..5.0, 8..300),
            offset in -1e3f64..1e3,
            drift in -1.0f64..1.0,
        ) {
            let y: Vec<f64> = y.iter().enumerate().map(|(k, v)| offset + drift * k as f64 + v).collect();
            let tau0 = 0.01;
            let sums = Sums::new(&y);
            for m in octave_factors(y.len()) {
                let want = avar_by_definition(&y, m);
                let (got, pairs) = sums.avar(m).unwrap();
                prop_assert_eq!(pairs, y.len() + 1 - 2 * m);
                prop_assert!((got - want).abs() <= 1e-9 * want.max(1e-12), "m {} {} {}", m, got, want);
                if let Some(got) = sums.mvar(m) {
                    let want = mvar_by_definition(&y, tau0, m);
                    prop_assert!((got - want).abs() <= 1e-8 * want.max(1e-12), "mod m {} {} {}", m, got, want);
                } else {
                    prop_assert!(3 * m > y.len() + 1);
                }
            }
        }
    }

    /// A short sequence by hand: y = 1, 3, 2, 6 (τ₀ = 1 s). m = 1: adjacent differences
    /// 2, −1, 4, squares 4 + 1 + 16 = 21 over 2·3 = 6: AVAR = 3.5. m = 2: means of
    /// (1, 3) and (2, 6) are 2 and 4, one pair, (4 − 2)² / 2 = 2. MVAR at m = 1 equals
    /// AVAR (3.5); at m = 2 it needs 3m = 6 > N = 5 boundaries: none.
    #[test]
    fn a_sequence_computed_by_hand() {
        let y = [1.0, 3.0, 2.0, 6.0];
        let s = Sums::new(&y);
        let (a1, p1) = s.avar(1).unwrap();
        assert!((a1 - 3.5).abs() < 1e-12 && p1 == 3, "{a1}");
        let (a2, p2) = s.avar(2).unwrap();
        assert!((a2 - 2.0).abs() < 1e-12 && p2 == 1, "{a2}");
        assert!((s.mvar(1).unwrap() - 3.5).abs() < 1e-12);
        assert!(s.mvar(2).is_none());
        assert_eq!(octave_factors(4), [1, 2]);
    }

    /// A linear drift `y = D·t`: adjacent means of `m` gates differ by `D·m·τ₀`, so
    /// ADEV(τ) = D·τ/√2 exactly; MDEV as well (every inner term is the same).
    #[test]
    fn a_linear_drift_gives_d_tau_over_root_2() {
        let (d, tau0) = (0.3, 0.5);
        let y: Vec<f64> = (0..1000).map(|k| d * tau0 * f64::from(k)).collect();
        for p in analyse(&y, tau0) {
            let want = d * p.tau_s / 2f64.sqrt();
            assert!((p.adev - want).abs() < 1e-9 * want, "{p:?}");
            if let Some(md) = p.mdev {
                assert!((md - want).abs() < 1e-9 * want, "{p:?}");
            }
        }
    }

    /// White acceleration noise of σ per gate: ADEV(τ) = σ/√m in expectation, inside the
    /// 95 % intervals, the noise identified as α = 0 where there are enough averages.
    #[test]
    fn white_noise_falls_as_one_over_root_m() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let sigma = 2.0;
        let nd = Normal::new(0.0, sigma).unwrap();
        let y: Vec<f64> = (0..65_536).map(|_| nd.sample(&mut rng)).collect();
        let pts = analyse(&y, 0.01);
        let mut outside = 0;
        for p in &pts {
            let want = sigma / (p.m as f64).sqrt();
            if want < p.ci95_lo || want > p.ci95_hi {
                outside += 1;
            }
            if p.alpha_source == NoiseIdSource::Acf {
                assert_eq!(p.alpha, 0, "{p:?}");
            }
        }
        // 15 octaves at 95 % each, correlated: one outside is possible, three are not.
        assert!(outside <= 2, "{outside} of {} outside: {pts:?}", pts.len());
        assert!((pts[0].adev - sigma).abs() < 0.02 * sigma);
    }

    /// The noise types the lag-1 autocorrelation must tell apart: white velocity (the
    /// differences of white noise, α = 2), white acceleration (α = 0), random-walk
    /// acceleration (α = −2).
    #[test]
    fn noise_id_tells_the_power_laws_apart() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let nd = Normal::new(0.0, 1.0).unwrap();
        let w: Vec<f64> = (0..4001).map(|_| nd.sample(&mut rng)).collect();
        let white_pm: Vec<f64> = w.windows(2).map(|p| p[1] - p[0]).collect();
        let mut acc = 0.0;
        let rw: Vec<f64> = w
            .iter()
            .map(|v| {
                acc += v;
                acc
            })
            .collect();
        assert_eq!(noise_id(&white_pm, 1), Some(2));
        assert_eq!(noise_id(&w, 1), Some(0));
        assert_eq!(noise_id(&w, 4), Some(0));
        assert_eq!(noise_id(&rw, 1), Some(-2));
        assert_eq!(noise_id(&w[..100], 4), None);
    }

    /// χ² quantiles against printed tables (Abramowitz and Stegun, table 26.8, to the
    /// table's digits).
    #[test]
    fn chi2_quantiles_match_the_tables() {
        for (p, k, want) in [
            (0.975, 1.0, 5.023_89),
            (0.025, 1.0, 0.000_982_069),
            (0.975, 10.0, 20.4832),
            (0.025, 10.0, 3.246_97),
            (0.975, 100.0, 129.561),
            (0.025, 100.0, 74.2219),
            (0.5, 2.0, 1.386_29),
        ] {
            let got = chi2_quantile(p, k);
            assert!(
                (got - want).abs() < 2e-5 * want.max(1.0),
                "{p} {k}: {got} {want}"
            );
        }
    }

    /// The EDF formulas at values worked by hand: white PM, N = 101, m = 1:
    /// 102·99/(2·100) = 50.49; white FM, N = 101, m = 1: (3·100/2 − 2·99/101)·4/9 =
    /// (150 − 1.960 396)·4/9 = 65.795 38; flicker FM, m = 1: 2·99²/(2.3·101 − 4.9) =
    /// 19 602/227.4 = 86.1961; random-walk FM, N = 101, m = 10:
    /// 99/10 · (10 000 − 3000 + 400)/98² = 9.9·7400/9604 = 7.628 07.
    #[test]
    fn edf_formulas_at_hand_worked_values() {
        for (alpha, m, want) in [
            (2, 1, 50.49),
            (0, 1, 65.795_38),
            (-1, 1, 86.1961),
            (-2, 10, 7.628_07),
        ] {
            let got = edf_simple(101, m, alpha);
            assert!((got - want).abs() < 1e-4 * want, "α {alpha}: {got} {want}");
        }
        // Flicker PM at its edge (N − 1 = 2m): the first logarithm is 0, edf = e⁰ = 1.
        assert!((edf_simple(101, 50, 1) - 1.0).abs() < 1e-12);
        // The interval is wider above than below, and holds the estimate.
        let (lo, hi) = ci95(1.0, 10.0);
        assert!(lo < 1.0 && hi > 1.0 && hi - 1.0 > 1.0 - lo, "{lo} {hi}");
    }
}
