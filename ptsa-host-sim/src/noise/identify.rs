//! What the simulation gets wrong about noise (`ptsa noise --counts FILE --identify`): the
//! measured Allan variance modelled as the simulated loop's, at the record's gate, length
//! and mean, plus candidates beyond it, each tested under Holm's step-down at 5 %
//! familywise.
//!
//! The model, at each octave τ the measured record has:
//!
//! ```text
//! AVAR_measured(τ) = AVAR_sim(τ; u) + c_N/τ + c_K·τ/3
//! ```
//!
//! * `AVAR_sim(τ; u)`: the instrument file's loop simulated at rest for as long as the
//!   record, at the acceleration that gives its mean (as `--compare`), with the pickoff
//!   noise `noise_uv_rms = u`, at each value of [`PICKOFF_GRID_UV`] and the file's own (one
//!   seed for all), and **interpolated linearly in `u²`** (noise power) between them, per τ;
//! * `c_N = N²`: a white acceleration noise (velocity random walk, cm/s²/√Hz);
//! * `c_K = K²`: a bias (acceleration) random walk (cm/s²·√Hz).
//!
//! Each point is weighted by the variance of the difference of two independent estimates:
//! `2·M²/ν_m + 2·S²/ν_s` with `M` the model's value (iterated from `S`), `S` the simulated
//! curve's, `ν` the EDFs of the two analyses (chi-squared EDF, [`super::EDF_METHOD`]). The
//! octave points are **taken as independent**: they are not (the same gates enter every
//! τ), and the campaign in docs/noise.md measures what that does to the rates.
//!
//! The candidates are selected forward, with Holm's thresholds (as discover selects): at
//! step `j` each candidate left is tested given those already selected, by the drop of
//! `χ²` it brings (`Δχ²`; for `N` and `K` its signed root, one-sided, a negative excess
//! being no evidence; for the pickoff noise against χ² with one degree of freedom, its
//! value profiled over `u ∈ [0, max grid]`), and the most significant is selected if its
//! p is at most [`ALPHA`]`/(3 − j)`; the first that is not ends the selection (white
//! acceleration noise and a raised pickoff noise both lift the curve: tested one by one
//! against the file's loop alone, both would be selected for either). The selected
//! candidates are then fitted together
//! (the pickoff noise by its profile with the selected linear terms refitted at each `u`)
//! and reported with a 95 % interval: `ĉ ± 1.96·se·b` for `c_N`, `c_K` (the square root of
//! its ends, the lower clipped at 0), `{u: Δχ²(u) ≤ 3.84·b²}` for the pickoff noise, `b`
//! the joint fit's Birge ratio `√(χ²/dof)` when above 1.
#![allow(
    clippy::cast_precision_loss,
    reason = "gate counts and grid indices, far below 2^52, as f64"
)]

use statrs::distribution::{ContinuousCDF as _, Normal};

use super::terms::Term;
use super::{Analysis, Record, simulate_record};
use crate::model::instrument::Instrument;
use crate::simulation::sim::SimOptions;

/// The pickoff noises the loop is simulated at, µV rms (the file's own value is added).
pub const PICKOFF_GRID_UV: [f64; 7] = [0.0, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0];

/// Steps of the pickoff noise's profile between 0 and the grid's largest value.
pub const PROFILE_STEPS: usize = 320;

/// Familywise level of the candidates' Holm step-down.
pub const ALPHA: f64 = 0.05;

/// `χ²₁(0.95)`: the profile's 95 % interval.
const CHI2_1_95: f64 = 3.841_458_820_694_124;

/// A candidate beyond the simulated loop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// White acceleration noise `N` (AVAR += N²/τ).
    WhiteAcceleration,
    /// Bias random walk `K` (AVAR += K²τ/3).
    RandomWalk,
    /// The pickoff noise `noise_uv_rms` other than the file's.
    Pickoff,
}

impl Kind {
    /// Its JSON key.
    #[must_use]
    pub fn key(self) -> &'static str {
        match self {
            Kind::WhiteAcceleration => "white_acceleration",
            Kind::RandomWalk => "bias_random_walk",
            Kind::Pickoff => "pickoff_noise",
        }
    }

    /// The noise term of [`super::terms`] it is, for `N` and `K`.
    #[must_use]
    pub fn term(self) -> Option<Term> {
        match self {
            Kind::WhiteAcceleration => Some(Term::VelocityRandomWalk),
            Kind::RandomWalk => Some(Term::AccelerationRandomWalk),
            Kind::Pickoff => None,
        }
    }

    /// Its units and the factor from the first (cgs, or µV for the pickoff noise).
    #[must_use]
    pub fn units(self) -> Vec<(&'static str, f64)> {
        self.term()
            .map_or_else(|| vec![("uV rms", 1.0)], Term::units)
    }
}

/// All candidates, in the report's order.
pub const KINDS: [Kind; 3] = [Kind::WhiteAcceleration, Kind::RandomWalk, Kind::Pickoff];

/// One candidate's test and, when selected, its value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// Which.
    pub kind: Kind,
    /// Its test statistic alone against the file's loop: `z` for `N` and `K`, `Δχ²` for the
    /// pickoff noise.
    pub statistic: f64,
    /// Its p-value.
    pub p: f64,
    /// Selected by Holm's step-down at [`ALPHA`].
    pub selected: bool,
    /// When selected: the value and its 95 % interval, in the first unit of
    /// [`Kind::units`] (`N` in cm/s²/√Hz, `K` in cm/s²·√Hz, the pickoff noise in µV).
    pub value: Option<(f64, f64, f64)>,
    /// For the pickoff noise: the interval reaches the grid's end (open above).
    pub open_above: bool,
}

/// The identification.
#[derive(Clone, Debug)]
pub struct Identification {
    /// The acceleration along IA simulated, cm/s².
    pub input_cm_s2: f64,
    /// The file's pickoff noise, µV.
    pub file_uv: f64,
    /// The pickoff noises simulated, µV (sorted).
    pub grid_uv: Vec<f64>,
    /// The octave τ used, s.
    pub taus: Vec<f64>,
    /// `χ²` of the file's loop alone, and its degrees of freedom (the τ).
    pub chi2_file: f64,
    /// The candidates in [`KINDS`]' order.
    pub candidates: Vec<Candidate>,
}

impl Identification {
    /// The candidate of `kind`.
    #[must_use]
    pub fn get(&self, kind: Kind) -> Option<&Candidate> {
        self.candidates.iter().find(|c| c.kind == kind)
    }
}

/// The simulated curves at the grid's pickoff noises.
struct Curves {
    grid_uv: Vec<f64>,
    /// Per grid value, per τ: (AVAR, EDF).
    avar: Vec<Vec<(f64, f64)>>,
}

impl Curves {
    /// The simulated AVAR and EDF at `u` µV, per τ: linear in `u²` between grid values.
    fn at(&self, u: f64) -> Vec<(f64, f64)> {
        let g = &self.grid_uv;
        let k = g
            .windows(2)
            .position(|w| u <= w[1])
            .unwrap_or(g.len().saturating_sub(2));
        let (a, b) = (g[k], g[(k + 1).min(g.len() - 1)]);
        let t = if b > a {
            ((u * u - a * a) / (b * b - a * a)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        self.avar[k]
            .iter()
            .zip(&self.avar[(k + 1).min(g.len() - 1)])
            .map(|(&(sa, ea), &(sb, eb))| (sa + t * (sb - sa), ea.min(eb)))
            .collect()
    }
}

/// The weighted least-squares fit of the linear terms `kinds` (N, K) to `measured − sim`:
/// the coefficients (`c = N²` or `K²`), their standard errors, and `χ²`.
fn fit_linear(
    measured: &[(f64, f64, f64)],
    sim: &[(f64, f64)],
    kinds: &[Kind],
) -> (Vec<f64>, Vec<f64>, f64) {
    let shapes: Vec<Vec<f64>> = kinds
        .iter()
        .filter_map(|k| k.term())
        .map(|t| measured.iter().map(|&(tau, _, _)| t.shape(tau)).collect())
        .collect();
    let mut coef = vec![0.0; shapes.len()];
    let mut se = vec![f64::INFINITY; shapes.len()];
    let mut chi2 = 0.0;
    // Weights from the model's value, iterated from the simulated curve's.
    for _ in 0..4 {
        let var: Vec<f64> = measured
            .iter()
            .zip(sim)
            .enumerate()
            .map(|(i, (&(_, _, nu_m), &(s, nu_s)))| {
                let m = (s + shapes.iter().zip(&coef).map(|(x, c)| c * x[i]).sum::<f64>()).max(s);
                2.0 * m * m / nu_m + 2.0 * s * s / nu_s
            })
            .collect();
        let resid: Vec<f64> = measured.iter().zip(sim).map(|(m, s)| m.1 - s.0).collect();
        if shapes.is_empty() {
            chi2 = resid.iter().zip(&var).map(|(r, v)| r * r / v).sum();
            break;
        }
        // Normal equations, at most 2 × 2.
        let n = shapes.len();
        let mut a = vec![vec![0.0; n]; n];
        let mut b = vec![0.0; n];
        for i in 0..measured.len() {
            for p in 0..n {
                b[p] += shapes[p][i] * resid[i] / var[i];
                for q in 0..n {
                    a[p][q] += shapes[p][i] * shapes[q][i] / var[i];
                }
            }
        }
        let inv = if n == 1 {
            vec![vec![1.0 / a[0][0]]]
        } else {
            let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
            vec![
                vec![a[1][1] / det, -a[0][1] / det],
                vec![-a[1][0] / det, a[0][0] / det],
            ]
        };
        for p in 0..n {
            coef[p] = (0..n).map(|q| inv[p][q] * b[q]).sum();
            se[p] = inv[p][p].sqrt();
        }
        chi2 = (0..measured.len())
            .map(|i| {
                let r = resid[i] - (0..n).map(|p| coef[p] * shapes[p][i]).sum::<f64>();
                r * r / var[i]
            })
            .sum();
    }
    (coef, se, chi2)
}

/// The profile of the pickoff noise: `(u, χ²(u))` over `[0, max grid]` with the linear
/// terms `kinds` refitted at each `u`.
fn profile(m: &[(f64, f64, f64)], curves: &Curves, kinds: &[Kind]) -> Vec<(f64, f64)> {
    let top = curves.grid_uv.last().copied().unwrap_or(0.0);
    (0..=PROFILE_STEPS)
        .map(|i| {
            let u = top * i as f64 / PROFILE_STEPS as f64;
            (u, fit_linear(m, &curves.at(u), kinds).2)
        })
        .collect()
}

/// Identify, for the record `record` analysed as `measured`, the candidates beyond the
/// instrument file's loop (`opts`: seed, settling, configuration of the simulations).
/// `progress(done, total)` counts the simulations.
#[must_use]
#[allow(
    clippy::too_many_lines,
    reason = "one procedure: simulate the grid, select forward, fit the selected, in order"
)]
pub fn identify(
    instr: &Instrument,
    opts: &SimOptions,
    record: &Record,
    measured: &Analysis,
    progress: &mut dyn FnMut(usize, usize),
) -> Identification {
    let input_cm_s2 = measured.mean_cm_s2 - instr.bias_cm_s2 - instr.loop_bias_cm_s2(0.0);
    let file_uv = instr.noise_v_rms * 1e6;
    let mut grid_uv: Vec<f64> = PICKOFF_GRID_UV.to_vec();
    if !grid_uv.iter().any(|&u| (u - file_uv).abs() < 1e-9) {
        grid_uv.push(file_uv);
    }
    grid_uv.sort_by(f64::total_cmp);
    let ticks = record.gates[0].ticks;
    let gates = record.gates.len() as u64;
    let mut avar = Vec::with_capacity(grid_uv.len());
    for (k, &u) in grid_uv.iter().enumerate() {
        progress(k, grid_uv.len());
        let mut i = instr.clone();
        i.noise_v_rms = u * 1e-6;
        let g = simulate_record(&i, opts, input_cm_s2, ticks, gates);
        let y: Vec<f64> = g
            .iter()
            .map(|g| g.indicated_cm_s2(instr.sf_cm_s2))
            .collect();
        let s = Analysis::of_series(&y, record.tau0_s, instr.sf_cm_s2, instr.clock_hz);
        avar.push(
            measured
                .points
                .iter()
                .map(|p| {
                    s.points
                        .iter()
                        .find(|q| q.m == p.m)
                        .map_or((f64::NAN, 1.0), |q| (q.adev * q.adev, q.edf))
                })
                .collect::<Vec<_>>(),
        );
    }
    progress(grid_uv.len(), grid_uv.len());
    let curves = Curves { grid_uv, avar };
    // The τ both curves have, with a positive simulated AVAR at every grid value.
    let keep: Vec<usize> = (0..measured.points.len())
        .filter(|&i| {
            curves
                .avar
                .iter()
                .all(|c| c[i].0.is_finite() && c[i].0 > 0.0)
        })
        .collect();
    let m: Vec<(f64, f64, f64)> = keep
        .iter()
        .map(|&i| {
            let p = &measured.points[i];
            (p.tau_s, p.adev * p.adev, p.edf)
        })
        .collect();
    let curves = Curves {
        avar: curves
            .avar
            .iter()
            .map(|c| keep.iter().map(|&i| c[i]).collect())
            .collect(),
        grid_uv: curves.grid_uv,
    };
    let at_file = curves.at(file_uv);
    let chi2_file = fit_linear(&m, &at_file, &[]).2;
    let normal = Normal::standard();
    // The best fit of a set of candidates: χ², the pickoff noise (the file's unless in the
    // set), the linear terms' coefficients and standard errors (in the set's order).
    let best = |set: &[Kind]| -> (f64, f64, Vec<f64>, Vec<f64>) {
        let linear: Vec<Kind> = set
            .iter()
            .copied()
            .filter(|k| *k != Kind::Pickoff)
            .collect();
        let u = if set.contains(&Kind::Pickoff) {
            profile(&m, &curves, &linear)
                .into_iter()
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map_or(file_uv, |x| x.0)
        } else {
            file_uv
        };
        let (c, se, chi2) = fit_linear(&m, &curves.at(u), &linear);
        (chi2, u, c, se)
    };
    let mut candidates: Vec<Candidate> = KINDS
        .iter()
        .map(|&kind| Candidate {
            kind,
            statistic: f64::NAN,
            p: 1.0,
            selected: false,
            value: None,
            open_above: false,
        })
        .collect();
    // Forward selection with Holm's thresholds: at step j the most significant of the
    // candidates left, given those selected, is selected if its p is at most
    // ALPHA/(3 − j); the first that is not ends the selection.
    let mut chosen: Vec<Kind> = Vec::new();
    for step in 0..KINDS.len() {
        let base = best(&chosen).0;
        let mut tested: Vec<(usize, f64, f64)> = Vec::new();
        for (i, c) in candidates.iter().enumerate().filter(|(_, c)| !c.selected) {
            let mut set = chosen.clone();
            set.push(c.kind);
            let (chi2, _, coef, _) = best(&set);
            let d = (base - chi2).max(0.0);
            let (stat, p) = if c.kind == Kind::Pickoff {
                (d, crate::stats::chi2_sf(d, 1.0))
            } else {
                // One-sided: a negative excess is no evidence.
                let lin = set.iter().filter(|k| **k != Kind::Pickoff).count();
                let z = d.sqrt() * coef.get(lin - 1).copied().unwrap_or(0.0).signum();
                (z, if z.is_finite() { normal.sf(z) } else { 1.0 })
            };
            tested.push((i, stat, p));
        }
        for &(i, stat, p) in &tested {
            candidates[i].statistic = stat;
            candidates[i].p = p;
        }
        let Some(&(i, _, p)) = tested.iter().min_by(|a, b| a.2.total_cmp(&b.2)) else {
            break;
        };
        if p <= ALPHA / (KINDS.len() - step) as f64 {
            candidates[i].selected = true;
            chosen.push(candidates[i].kind);
        } else {
            break;
        }
    }
    // The selected ones fitted together: their values and 95 % intervals.
    let linear: Vec<Kind> = chosen
        .iter()
        .copied()
        .filter(|k| *k != Kind::Pickoff)
        .collect();
    let (chi2_best, u_hat, coef, se) = best(&chosen);
    // The Birge ratio of the joint fit widens the intervals where the model misfits (the
    // count pattern dithered by the added noise is not the undithered one plus a term).
    let birge2 = (chi2_best / m.len().saturating_sub(chosen.len()).max(1) as f64).max(1.0);
    if chosen.contains(&Kind::Pickoff) {
        let prof = profile(&m, &curves, &linear);
        let min = prof.iter().map(|x| x.1).fold(f64::INFINITY, f64::min);
        let inside: Vec<f64> = prof
            .iter()
            .filter(|x| x.1 - min <= CHI2_1_95 * birge2)
            .map(|x| x.0)
            .collect();
        let lo = inside.first().copied().unwrap_or(u_hat);
        let hi = inside.last().copied().unwrap_or(u_hat);
        let top = curves.grid_uv.last().copied().unwrap_or(0.0);
        if let Some(c) = candidates.iter_mut().find(|c| c.kind == Kind::Pickoff) {
            c.value = Some((u_hat, lo, hi));
            c.open_above = hi >= top;
        }
    }
    for (j, kind) in linear.iter().enumerate() {
        let root = |c: f64| c.max(0.0).sqrt();
        if let Some(c) = candidates.iter_mut().find(|c| c.kind == *kind) {
            c.value = Some((
                root(coef[j]),
                root(coef[j] - 1.96 * se[j] * birge2.sqrt()),
                root(coef[j] + 1.96 * se[j] * birge2.sqrt()),
            ));
        }
    }
    Identification {
        input_cm_s2,
        file_uv,
        grid_uv: curves.grid_uv.clone(),
        taus: m.iter().map(|x| x.0).collect(),
        chi2_file,
        candidates,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Interpolation in `u²`: at a grid value the grid's curve; halfway in power between
    /// two grid values, halfway between their curves.
    #[test]
    fn curves_interpolate_in_noise_power() {
        let c = Curves {
            grid_uv: vec![0.0, 1.0, 2.0],
            avar: vec![vec![(1.0, 10.0)], vec![(3.0, 20.0)], vec![(7.0, 30.0)]],
        };
        assert!((c.at(1.0)[0].0 - 3.0).abs() < 1e-12);
        assert!((c.at(0.0)[0].0 - 1.0).abs() < 1e-12);
        assert!((c.at(0.5f64.sqrt())[0].0 - 2.0).abs() < 1e-12);
        assert!((c.at(2.5f64.sqrt())[0].0 - 5.0).abs() < 1e-12);
    }

    /// A white-acceleration excess written exactly into the measured curve comes back
    /// exactly (c = N²), with nothing left over.
    #[test]
    fn a_linear_excess_comes_back_exactly() {
        let taus = [0.01, 0.02, 0.04, 0.08, 0.16, 0.32];
        let sim: Vec<(f64, f64)> = taus.iter().map(|t| (1e-2 / (t * t), 100.0)).collect();
        let m: Vec<(f64, f64, f64)> = taus
            .iter()
            .zip(&sim)
            .map(|(&t, s)| (t, s.0 + 0.09 / t + 0.04 * t / 3.0, 200.0))
            .collect();
        let (c, se, chi2) = fit_linear(&m, &sim, &[Kind::WhiteAcceleration, Kind::RandomWalk]);
        assert!(
            (c[0] - 0.09).abs() < 1e-9 && (c[1] - 0.04).abs() < 1e-9,
            "{c:?}"
        );
        assert!(se.iter().all(|s| *s > 0.0) && chi2 < 1e-12, "{se:?} {chi2}");
    }
}
