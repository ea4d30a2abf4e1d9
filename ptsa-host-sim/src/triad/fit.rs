//! The triad's fit: three axes' model equations and their non-orthogonality, one
//! orientation per position shared by the three, by Gauss–Newton (`docs/method/discovery.md`,
//! "A triad").
//!
//! The model of a reading (cm/s²) of axis `j` in position `i`:
//!
//! ```text
//! f_i = g · R_i · n_i                      (block frame; n_i the nominal gravity's direction)
//! a   = (I + Γ) · f_i                      (what each axis's input axis sees)
//! u_j = b_j + (1 + k_j) · a_j + q_j · a_j²  (bias, scale-factor change, K_2)
//! ```
//!
//! `g` is the instrument file's local gravity; `R_i` is the identity with
//! [`Orientation::Exact`] and, with [`Orientation::Approximate`], the rotation by two angles
//! about two axes perpendicular to `n_i` (a rotation about gravity changes nothing); `Γ` has
//! a zero diagonal, `Γ_jk` the misalignment of axis `j`'s input axis toward the block's axis
//! `k`, rad: all six with exact orientations, the three below the diagonal with approximate
//! ones (the triad's frame: x along the x axis's input axis, y in the plane of the x and y
//! input axes). The correction users apply is `f = M·(u − b)`, `M = (diag(1 + k)·(I + Γ))⁻¹`
//! (with `K_2`, `u_j − b_j` less `q_j·((u_j − b_j)/(1 + k_j))²` first).

use std::fmt::Write as _;

use anyhow::{Result, bail};
use nalgebra::{DMatrix, Matrix3, Vector3};
use statrs::distribution::{ContinuousCDF as _, StudentsT};

use crate::stats;
use crate::triad::frame::Position;

/// The axes' names.
pub const AXES: [&str; 3] = ["x", "y", "z"];

/// What is known of the positions' orientations.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Orientation {
    /// The nominal orientations are the true ones (a precision fixture).
    #[default]
    Exact,
    /// Each position is the nominal one turned by a small unknown rotation, estimated.
    Approximate,
}

impl Orientation {
    /// The word of `--orientation` and of the JSON.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Orientation::Exact => "exact",
            Orientation::Approximate => "approximate",
        }
    }
}

/// The fit's options.
#[derive(Clone, Debug)]
pub struct Options {
    /// Exact or approximate orientations.
    pub orientation: Orientation,
    /// 1 σ of the readings of a row without `sigma_cm_s2`, cm/s² (`--sigma`).
    pub default_sigma_cm_s2: Option<f64>,
    /// Local gravity, cm/s² (the instrument file's).
    pub g_cm_s2: f64,
}

/// A value and its 1 σ.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate {
    /// The value.
    pub value: f64,
    /// Its 1 σ.
    pub sigma: f64,
}

/// Where the readings' sigmas came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SigmaSource {
    /// `sigma_cm_s2` or `--sigma` on every measured row.
    Stated,
    /// One σ for all readings, from the residuals (`χ²/dof`).
    Estimated,
}

/// The NIST-style |g| self-consistency check: per position with all three axes measured,
/// the magnitude of the corrected specific force against local gravity.
#[derive(Clone, Debug, Default)]
pub struct GCheck {
    /// Per position (those with three readings): its index and `|f̂| − g`, cm/s², and that
    /// difference's 1 σ from the readings' noise as the fit leaves it (its hat matrix).
    pub positions: Vec<(usize, f64, f64)>,
    /// RMS of `|f̂| − g` over the positions, cm/s².
    pub rms_cm_s2: f64,
    /// The largest `||f̂| − g|`, cm/s², and its position's index.
    pub worst: (f64, usize),
    /// RMS the readings' noise alone would give after the fit, cm/s².
    pub expected_rms_cm_s2: f64,
    /// `Σ ((|f̂| − g)/σ)²`.
    pub chi2: f64,
    /// `P(χ²_N ≥ chi2)`, N the positions (each difference standardised by its own σ; their
    /// correlation through the fit is left out).
    pub p_value: f64,
    /// `P(χ²_N ≤ chi2)`: the magnitudes agree with gravity far better than the noise allows
    /// when small (with exact orientations: a misfit across gravity, i.e. the fixture's
    /// orientation errors, taken for noise).
    pub p_lower: f64,
}

/// The triad's calibration.
#[derive(Clone, Debug)]
pub struct Triad {
    /// The orientation assumed.
    pub orientation: Orientation,
    /// Local gravity used, cm/s².
    pub g_cm_s2: f64,
    /// The positions, as read.
    pub positions: Vec<Position>,
    /// Biases `b_j`, cm/s².
    pub bias: [Estimate; 3],
    /// Scale-factor changes `k_j` from nominal, dimensionless.
    pub scale: [Estimate; 3],
    /// `Γ_jk`, rad; `None` on the diagonal and where fixed by the frame's convention.
    pub misalignment: [[Option<Estimate>; 3]; 3],
    /// `q_j` (`K_2` in (cm/s²)⁻¹), when the design separates it from the other terms.
    pub k2: Option<[Estimate; 3]>,
    /// Why `K_2` is not fitted, when it is not.
    pub k2_note: Option<String>,
    /// Per position, the estimated rotation from nominal (two angles, rad, about the axes
    /// `p_i` and `q_i`), with approximate orientations.
    pub angles: Vec<Option<[Estimate; 2]>>,
    /// Per position, each axis's residual (measured − fitted), cm/s².
    pub residuals: Vec<[Option<f64>; 3]>,
    /// The calibration parameters' names (bias, scale, misalignment, `K_2`), in the order of
    /// [`Triad::correlation`].
    pub names: Vec<String>,
    /// Their correlation matrix.
    pub correlation: Vec<Vec<f64>>,
    /// χ² of the fit against the sigmas (stated, or 1 per reading before scaling).
    pub chi2: f64,
    /// Readings (and angle priors) less fitted parameters.
    pub dof: usize,
    /// Readings fitted.
    pub readings: usize,
    /// Parameters fitted (angles included).
    pub parameters: usize,
    /// `P(χ²_dof ≥ chi2)` (stated sigmas; NaN when estimated).
    pub p_value: f64,
    /// Where the sigmas came from.
    pub sigma_source: SigmaSource,
    /// The estimated σ of a reading, cm/s² (estimated sigmas; else the RMS of the stated).
    pub sigma_cm_s2: f64,
    /// The factor on the classical errors (Birge ratio or the estimated σ's scaling of 1).
    pub sigma_scale: f64,
    /// `value ± coverage_factor·σ` is a 95 % interval (1.96, or Student's t at `dof`).
    pub coverage_factor: f64,
    /// The |g| check.
    pub g_check: GCheck,
    /// Gauss–Newton iterations.
    pub iterations: usize,
    /// Warnings, each a sentence (without `warning:`).
    pub warnings: Vec<String>,
}

/// Where each parameter sits in the parameter vector.
#[derive(Clone, Debug)]
struct Layout {
    /// The fitted misalignments `(j, k)`.
    mis: Vec<(usize, usize)>,
    /// `K_2` fitted.
    k2: bool,
    /// Angles fitted (two per position).
    angles: bool,
    /// Positions.
    n: usize,
}

impl Layout {
    /// The first misalignment's index (after the three biases and three scale factors).
    const MIS0: usize = 6;
    fn k20(&self) -> usize {
        Self::MIS0 + self.mis.len()
    }
    /// Parameters before the angles.
    fn calib(&self) -> usize {
        self.k20() + if self.k2 { 3 } else { 0 }
    }
    fn angle0(&self, i: usize) -> usize {
        self.calib() + 2 * i
    }
    fn len(&self) -> usize {
        self.calib() + if self.angles { 2 * self.n } else { 0 }
    }
}

/// Two unit vectors perpendicular to `n` and to each other (`p × q = n`-handed).
fn perp_basis(n: [f64; 3]) -> (Vector3<f64>, Vector3<f64>) {
    let n = Vector3::from(n);
    let k = (0..3)
        .min_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs()))
        .unwrap_or(0);
    let mut e = Vector3::zeros();
    e[k] = 1.0;
    let p = n.cross(&e).normalize();
    let q = n.cross(&p);
    (p, q)
}

/// `n` turned by `α` about `p` and `β` about `q` (Rodrigues, the rotation vector
/// `α·p + β·q`).
fn turned(
    n: [f64; 3],
    basis: &(Vector3<f64>, Vector3<f64>),
    alpha: f64,
    beta: f64,
) -> Vector3<f64> {
    let n = Vector3::from(n);
    let phi = basis.0 * alpha + basis.1 * beta;
    let theta = phi.norm();
    if theta == 0.0 {
        return n;
    }
    let u = phi / theta;
    n * theta.cos() + u.cross(&n) * theta.sin() + u * u.dot(&n) * (1.0 - theta.cos())
}

/// The fitted readings of position `i` with parameters `x`, and the specific force.
fn predict(
    x: &[f64],
    l: &Layout,
    n: [f64; 3],
    basis: &(Vector3<f64>, Vector3<f64>),
    i: usize,
    g: f64,
) -> ([f64; 3], Vector3<f64>) {
    let f = if l.angles {
        turned(n, basis, x[l.angle0(i)], x[l.angle0(i) + 1]) * g
    } else {
        Vector3::from(n) * g
    };
    let gm = gamma(x, l);
    let a = (Matrix3::identity() + gm) * f;
    let mut u = [0.0; 3];
    for j in 0..3 {
        let q = if l.k2 { x[l.k20() + j] } else { 0.0 };
        u[j] = x[j] + (1.0 + x[3 + j]) * a[j] + q * a[j] * a[j];
    }
    (u, f)
}

/// `Γ` of `x`.
fn gamma(x: &[f64], l: &Layout) -> Matrix3<f64> {
    let mut gm = Matrix3::zeros();
    for (m, &(j, k)) in l.mis.iter().enumerate() {
        gm[(j, k)] = x[Layout::MIS0 + m];
    }
    gm
}

/// One reading (or an angle's prior): the position, the axis (3, 4: the prior on angle
/// 0, 1), its value and its 1 σ.
#[derive(Clone, Copy, Debug)]
struct Obs {
    pos: usize,
    axis: usize,
    value: f64,
    sigma: f64,
}

/// Weighted residuals and the weighted Jacobian's columns (of the model, `∂u/∂x / σ`).
fn evaluate(
    x: &[f64],
    l: &Layout,
    pos: &[Position],
    bases: &[(Vector3<f64>, Vector3<f64>)],
    obs: &[Obs],
    g: f64,
) -> (Vec<f64>, Vec<Vec<f64>>) {
    let m = obs.len();
    let mut r = vec![0.0; m];
    let mut cols = vec![vec![0.0; m]; l.len()];
    let preds: Vec<([f64; 3], Vector3<f64>)> = (0..pos.len())
        .map(|i| predict(x, l, pos[i].g_unit, &bases[i], i, g))
        .collect();
    let gm = Matrix3::identity() + gamma(x, l);
    // ∂f/∂angle by central differences (exact to ~1e-10 relative; the angles are small).
    let h = 1e-6;
    let df: Vec<[Vector3<f64>; 2]> = if l.angles {
        (0..pos.len())
            .map(|i| {
                let (a, b) = (x[l.angle0(i)], x[l.angle0(i) + 1]);
                let n = pos[i].g_unit;
                [
                    (turned(n, &bases[i], a + h, b) - turned(n, &bases[i], a - h, b))
                        * (g / (2.0 * h)),
                    (turned(n, &bases[i], a, b + h) - turned(n, &bases[i], a, b - h))
                        * (g / (2.0 * h)),
                ]
            })
            .collect()
    } else {
        Vec::new()
    };
    for (o_i, o) in obs.iter().enumerate() {
        let w = 1.0 / o.sigma;
        if o.axis >= 3 {
            let k = l.angle0(o.pos) + o.axis - 3;
            r[o_i] = (o.value - x[k]) * w;
            cols[k][o_i] = w;
            continue;
        }
        let (u, f) = &preds[o.pos];
        let j = o.axis;
        r[o_i] = (o.value - u[j]) * w;
        let a = (gm * f)[j];
        let q = if l.k2 { x[l.k20() + j] } else { 0.0 };
        let slope = 1.0 + x[3 + j] + 2.0 * q * a;
        cols[j][o_i] = w;
        cols[3 + j][o_i] = a * w;
        for (mi, &(jj, kk)) in l.mis.iter().enumerate() {
            if jj == j {
                cols[Layout::MIS0 + mi][o_i] = slope * f[kk] * w;
            }
        }
        if l.k2 {
            cols[l.k20() + j][o_i] = a * a * w;
        }
        if l.angles {
            for (t, d) in df[o.pos].iter().enumerate() {
                let da = (gm * d)[j];
                cols[l.angle0(o.pos) + t][o_i] = slope * da * w;
            }
        }
    }
    (r, cols)
}

/// The smallest singular value of the columns, each scaled to unit norm, over the largest.
fn conditioning(cols: &[Vec<f64>]) -> f64 {
    let m = cols.first().map_or(0, Vec::len);
    let p = cols.len();
    if m < p || p == 0 {
        return 0.0;
    }
    let a = DMatrix::from_fn(m, p, |i, j| {
        let s = stats::norm(&cols[j]);
        if s > 0.0 { cols[j][i] / s } else { 0.0 }
    });
    let sv = a.singular_values();
    let max = sv.max();
    if max > 0.0 { sv.min() / max } else { 0.0 }
}

/// Columns scaled to unit norm, and the scales.
fn scaled(cols: &[Vec<f64>]) -> (Vec<Vec<f64>>, Vec<f64>) {
    let s: Vec<f64> = cols.iter().map(|c| stats::norm(c).max(1e-300)).collect();
    let c = cols
        .iter()
        .zip(&s)
        .map(|(c, s)| c.iter().map(|v| v / s).collect())
        .collect();
    (c, s)
}

/// Below this conditioning (smallest over largest singular value of the unit-scaled
/// Jacobian) the design is taken not to separate the parameters.
pub const CONDITION_MIN: f64 = 1e-7;

/// The misalignments fitted: all six with exact orientations, the three below the
/// diagonal with approximate ones.
fn misalignments(o: Orientation) -> Vec<(usize, usize)> {
    match o {
        Orientation::Exact => vec![(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)],
        Orientation::Approximate => vec![(1, 0), (2, 0), (2, 1)],
    }
}

/// Student's t quantile at 0.975 with `dof` degrees of freedom.
fn t975(dof: usize) -> f64 {
    #[allow(clippy::cast_precision_loss)]
    StudentsT::new(0.0, 1.0, dof.max(1) as f64).map_or(1.96, |d| d.inverse_cdf(0.975))
}

/// Fit the triad's calibration to `positions` read from the file `name`: the readings
/// checked and weighed, the unknowns laid out (`K_2` only where the design separates it),
/// Gauss–Newton, then the estimates, their covariance and the |g| check.
///
/// # Errors
/// No row measured; readings without a sigma beside rows with one (without `--sigma`);
/// fewer readings than unknowns; positions that do not determine the calibration (all in
/// one plane, too few, ...); a fit that does not converge. Each error names `name`.
pub fn fit(name: &str, positions: &[Position], opts: &Options) -> Result<Triad> {
    let source = sigma_source(name, positions, opts)?;
    let mut pb = Problem::new(positions, opts, source);
    let k2_note = pb.settle_layout(name)?;
    let (x, iterations) = pb.gauss_newton(name)?;
    let lin = pb.linearised(name, &x)?;
    let mut t = pb.triad(positions, opts, &x, &lin, k2_note, iterations);
    let resid_cov = pb.residual_covariances(positions.len(), &lin);
    t.g_check = g_check(&t, &resid_cov);
    t.warnings = warnings(&t);
    Ok(t)
}

/// Where the readings' sigmas come from, after the checks every reading must pass.
///
/// # Errors
/// An axis given as counts not yet converted; some measured rows with a sigma and some
/// without.
fn sigma_source(name: &str, positions: &[Position], opts: &Options) -> Result<SigmaSource> {
    if let Some((p, j)) = positions
        .iter()
        .find_map(|p| p.unconverted().map(|j| (p, j)))
    {
        bail!(
            "{name}:{}: the {} axis's counts are not converted to its reading; expected `triad::frame::with_counts` with the instrument's nominal scale factor before the fit",
            p.line,
            AXES[j]
        );
    }
    let stated = positions
        .iter()
        .filter(|p| p.is_measured())
        .filter(|p| p.sigma_cm_s2.is_some() || opts.default_sigma_cm_s2.is_some())
        .count();
    let measured = positions.iter().filter(|p| p.is_measured()).count();
    if stated != 0 && stated != measured {
        let p = positions
            .iter()
            .find(|p| p.is_measured() && p.sigma_cm_s2.is_none())
            .map_or(0, |p| p.line);
        bail!(
            "{name}:{p}: a measured row without `sigma_cm_s2` while {stated} other rows give one; expected it on every measured row or on none (or --sigma CM_S2 for the rows without it)"
        );
    }
    Ok(if stated > 0 {
        SigmaSource::Stated
    } else {
        SigmaSource::Estimated
    })
}

/// Every reading of `positions` with its sigma, and with approximate orientations each
/// measured position's two angle priors (indices into `positions`).
fn observations(positions: &[Position], opts: &Options, source: SigmaSource) -> Vec<Obs> {
    let g = opts.g_cm_s2;
    let approx = opts.orientation == Orientation::Approximate;
    let mut obs = Vec::new();
    for (i, p) in positions.iter().enumerate() {
        let s = p.sigma_cm_s2.or(opts.default_sigma_cm_s2).unwrap_or(1.0);
        for (j, m) in p.measured.iter().enumerate() {
            if let Some(v) = *m {
                // A fixture's stated orientation uncertainty, with exact orientations: the
                // reading's variance grows by (σ_θ·g)² times the share of gravity off its axis.
                let extra = match (approx, p.sigma_angle_rad) {
                    (false, Some(a)) => (a * g).powi(2) * (1.0 - p.g_unit[j].powi(2)).max(0.0),
                    _ => 0.0,
                };
                // An axis given as counts: its counting error, in quadrature with a stated
                // sigma (without one, the σ estimated from the residuals holds it).
                let counting = match source {
                    SigmaSource::Stated => p.counting_sigma_cm_s2[j].unwrap_or(0.0).powi(2),
                    SigmaSource::Estimated => 0.0,
                };
                obs.push(Obs {
                    pos: i,
                    axis: j,
                    value: v,
                    sigma: (s * s + extra + counting).sqrt(),
                });
            }
        }
        if approx
            && p.is_measured()
            && let Some(a) = p.sigma_angle_rad
        {
            for t in 0..2 {
                obs.push(Obs {
                    pos: i,
                    axis: 3 + t,
                    value: 0.0,
                    sigma: a,
                });
            }
        }
    }
    obs
}

/// The fit's problem: the measured positions, their observations and the unknowns.
struct Problem {
    /// The measured positions' indices in the file's, and those positions.
    used: Vec<usize>,
    pos: Vec<Position>,
    bases: Vec<(Vector3<f64>, Vector3<f64>)>,
    /// The observations, their positions indices into `pos`.
    obs: Vec<Obs>,
    layout: Layout,
    g: f64,
    source: SigmaSource,
    /// The readings among the observations.
    readings: usize,
}

/// The fit linearised at its solution: the weighted residuals, the Jacobian's columns at
/// unit norm and their scales, and the least-squares step there (its covariance).
struct Linear {
    r: Vec<f64>,
    sc: Vec<Vec<f64>>,
    s: Vec<f64>,
    fit: stats::LsqFit,
}

impl Problem {
    /// Only the measured positions have parameters (their angles); the others are kept as
    /// rows of the result.
    fn new(positions: &[Position], opts: &Options, source: SigmaSource) -> Self {
        let mut obs = observations(positions, opts, source);
        let readings = obs.iter().filter(|o| o.axis < 3).count();
        let used: Vec<usize> = (0..positions.len())
            .filter(|&i| positions[i].is_measured())
            .collect();
        let pos: Vec<Position> = used.iter().map(|&i| positions[i].clone()).collect();
        let mut remap = vec![usize::MAX; positions.len()];
        for (k, &i) in used.iter().enumerate() {
            remap[i] = k;
        }
        for o in &mut obs {
            o.pos = remap[o.pos];
        }
        Problem {
            bases: pos.iter().map(|p| perp_basis(p.g_unit)).collect(),
            layout: Layout {
                mis: misalignments(opts.orientation),
                k2: true,
                angles: opts.orientation == Orientation::Approximate,
                n: pos.len(),
            },
            used,
            pos,
            obs,
            g: opts.g_cm_s2,
            source,
            readings,
        }
    }

    fn evaluate(&self, x: &[f64]) -> (Vec<f64>, Vec<Vec<f64>>) {
        evaluate(x, &self.layout, &self.pos, &self.bases, &self.obs, self.g)
    }

    fn cost(&self, x: &[f64]) -> f64 {
        self.evaluate(x).0.iter().map(|v| v * v).sum()
    }

    /// Readings enough for the unknowns, and a design that separates them: `K_2` left out
    /// where it does not (the note says why).
    ///
    /// # Errors
    /// Fewer readings than unknowns without `K_2`; a design that does not determine the
    /// calibration without it.
    fn settle_layout(&mut self, name: &str) -> Result<Option<String>> {
        let approx = self.layout.angles;
        let without_k2 = Layout {
            k2: false,
            ..self.layout.clone()
        };
        if self.obs.len() <= without_k2.len() {
            bail!(
                "{name}: {} positions give {} readings for {} unknowns ({}); expected more readings than unknowns: more positions{}",
                self.pos.len(),
                self.readings,
                without_k2.len(),
                if approx {
                    "bias, scale factor and 3 misalignments, and 2 angles per position"
                } else {
                    "bias and scale factor per axis and 6 misalignments"
                },
                if approx {
                    ", or a precision fixture and --orientation exact"
                } else {
                    ""
                }
            );
        }
        let (_, cols) = self.evaluate(&vec![0.0; self.layout.len()]);
        if self.obs.len() > self.layout.len() && conditioning(&cols) >= CONDITION_MIN {
            return Ok(None);
        }
        self.layout.k2 = false;
        let note = if self.obs.len() <= self.layout.len() + 3 {
            "K_2 not fitted: the readings are too few for it too".to_string()
        } else {
            "K_2 not fitted: these positions do not separate it from the bias (each axis needs readings at two or more different |a|, e.g. 0 and 1 g)".to_string()
        };
        let (_, cols) = self.evaluate(&vec![0.0; self.layout.len()]);
        if conditioning(&cols) < CONDITION_MIN {
            bail!(
                "{name}: the {} positions do not determine the triad's calibration{}; expected positions whose gravity points in three independent directions, each axis seeing both signs (e.g. the six faces and more){}",
                self.pos.len(),
                planar_hint(&self.pos),
                if approx {
                    ", and with --orientation approximate enough tilted positions for the angles (e.g. 24)"
                } else {
                    ""
                }
            );
        }
        Ok(Some(note))
    }

    /// Gauss–Newton with step halving from the nominal: the solution and the iterations.
    ///
    /// # Errors
    /// The fit lost its rank, or did not converge in 50 iterations.
    fn gauss_newton(&self, name: &str) -> Result<(Vec<f64>, usize)> {
        let mut x = vec![0.0; self.layout.len()];
        let mut c = self.cost(&x);
        let mut iterations = 0;
        while iterations < 50 {
            iterations += 1;
            let (r, cols) = self.evaluate(&x);
            let (sc, s) = scaled(&cols);
            let refs: Vec<&[f64]> = sc.iter().map(Vec::as_slice).collect();
            let Some(step) = stats::lsq(&r, &refs) else {
                bail!(
                    "{name}: the triad's fit lost its rank at iteration {iterations}; expected positions that determine the calibration{}",
                    planar_hint(&self.pos)
                );
            };
            let delta: Vec<f64> = step.beta.iter().zip(&s).map(|(b, s)| b / s).collect();
            let mut t = 1.0;
            let mut accepted = false;
            for _ in 0..30 {
                let trial: Vec<f64> = x.iter().zip(&delta).map(|(a, d)| a + t * d).collect();
                let ct = self.cost(&trial);
                if ct <= c * (1.0 + 1e-12) {
                    x = trial;
                    let done = (c - ct).abs() <= 1e-10 * c.max(1e-30);
                    c = ct;
                    accepted = true;
                    if done {
                        return Ok((x, iterations));
                    }
                    break;
                }
                t /= 2.0;
            }
            if !accepted {
                return Ok((x, iterations));
            }
        }
        bail!(
            "{name}: the triad's fit did not converge in 50 Gauss–Newton iterations; expected positions near their nominal orientations (within a few degrees)"
        )
    }

    /// The fit linearised at `x`.
    ///
    /// # Errors
    /// The fit lost its rank.
    fn linearised(&self, name: &str, x: &[f64]) -> Result<Linear> {
        let (r, cols) = self.evaluate(x);
        let (sc, s) = scaled(&cols);
        let refs: Vec<&[f64]> = sc.iter().map(Vec::as_slice).collect();
        let Some(fit) = stats::lsq(&r, &refs) else {
            bail!(
                "{name}: the triad's fit lost its rank; expected positions that determine the calibration{}",
                planar_hint(&self.pos)
            );
        };
        Ok(Linear { r, sc, s, fit })
    }

    /// χ², its p-value (stated sigmas), the covariance's scale (the Birge ratio squared
    /// when stated sigmas understate the scatter, else the residuals' variance) and the
    /// 95 % coverage factor.
    fn figures(&self, lin: &Linear) -> (f64, usize, f64, f64, f64) {
        let chi2: f64 = lin.r.iter().map(|v| v * v).sum();
        let dof = self.obs.len() - self.layout.len();
        #[allow(clippy::cast_precision_loss)]
        let nu = dof as f64;
        let (p_value, scale2, factor) = match self.source {
            SigmaSource::Stated => {
                let b = stats::birge_ratio(chi2, dof);
                let p = stats::chi2_sf(chi2, nu);
                (p, b * b, if b > 1.0 { t975(dof) } else { 1.96 })
            }
            SigmaSource::Estimated => (f64::NAN, chi2 / nu, t975(dof)),
        };
        (chi2, dof, p_value, scale2, factor)
    }

    /// The covariance of parameters `a` and `b`, scaled.
    fn cov(lin: &Linear, scale2: f64, a: usize, b: usize) -> f64 {
        lin.fit.cov[(a, b)] / (lin.s[a] * lin.s[b]) * scale2
    }

    /// The parameters' names, in the layout's order.
    fn names(&self) -> Vec<String> {
        let mut names: Vec<String> = AXES.iter().map(|a| format!("b_{a}")).collect();
        names.extend(AXES.iter().map(|a| format!("k_{a}")));
        names.extend(
            self.layout
                .mis
                .iter()
                .map(|&(j, k)| format!("Γ_{}{}", AXES[j], AXES[k])),
        );
        if self.layout.k2 {
            names.extend(AXES.iter().map(|a| format!("K2_{a}")));
        }
        names
    }

    /// The result at `x`: estimates with their sigmas, correlation, angles, residuals.
    fn triad(
        &self,
        positions: &[Position],
        opts: &Options,
        x: &[f64],
        lin: &Linear,
        k2_note: Option<String>,
        iterations: usize,
    ) -> Triad {
        let (chi2, dof, p_value, scale2, factor) = self.figures(lin);
        let cov = |a: usize, b: usize| Self::cov(lin, scale2, a, b);
        let est = |k: usize| Estimate {
            value: x[k],
            sigma: cov(k, k).sqrt(),
        };
        let l = &self.layout;
        let mut misalignment = [[None; 3]; 3];
        for (m, &(j, k)) in l.mis.iter().enumerate() {
            misalignment[j][k] = Some(est(Layout::MIS0 + m));
        }
        let nc = l.calib();
        let correlation: Vec<Vec<f64>> = (0..nc)
            .map(|a| {
                (0..nc)
                    .map(|b| cov(a, b) / (cov(a, a) * cov(b, b)).sqrt())
                    .collect()
            })
            .collect();
        let mut angles = vec![None; positions.len()];
        let mut residuals = vec![[None; 3]; positions.len()];
        for (k, &i) in self.used.iter().enumerate() {
            if l.angles {
                angles[i] = Some([est(l.angle0(k)), est(l.angle0(k) + 1)]);
            }
            let pred = predict(x, l, self.pos[k].g_unit, &self.bases[k], k, self.g).0;
            for j in 0..3 {
                residuals[i][j] = positions[i].measured[j].map(|m| m - pred[j]);
            }
        }
        Triad {
            orientation: opts.orientation,
            g_cm_s2: self.g,
            positions: positions.to_vec(),
            bias: [est(0), est(1), est(2)],
            scale: [est(3), est(4), est(5)],
            misalignment,
            k2: l
                .k2
                .then(|| [est(l.k20()), est(l.k20() + 1), est(l.k20() + 2)]),
            k2_note,
            angles,
            residuals,
            names: self.names(),
            correlation,
            chi2,
            dof,
            readings: self.readings,
            parameters: l.len(),
            p_value,
            sigma_source: self.source,
            sigma_cm_s2: self.sigma_cm_s2(scale2),
            sigma_scale: scale2.sqrt(),
            coverage_factor: factor,
            g_check: GCheck::default(),
            iterations,
            warnings: Vec::new(),
        }
    }

    /// The σ of a reading: estimated, or the stated ones' RMS.
    fn sigma_cm_s2(&self, scale2: f64) -> f64 {
        match self.source {
            SigmaSource::Estimated => scale2.sqrt(),
            SigmaSource::Stated => {
                let v: Vec<f64> = self
                    .obs
                    .iter()
                    .filter(|o| o.axis < 3)
                    .map(|o| o.sigma)
                    .collect();
                #[allow(clippy::cast_precision_loss)]
                let ms = v.iter().map(|s| s * s).sum::<f64>() / v.len().max(1) as f64;
                ms.sqrt()
            }
        }
    }

    /// The covariance of each position's three residuals, cm/s²: D·(I − H)·D over its
    /// readings (H the fit's hat matrix, D their sigmas; with estimated sigmas scaled by
    /// the estimate), so that the |g| check is weighed against what the noise leaves after
    /// the fit has taken its share. Indexed by the file's positions (`n` of them).
    fn residual_covariances(&self, n: usize, lin: &Linear) -> Vec<Option<Matrix3<f64>>> {
        let scale_noise = match self.source {
            SigmaSource::Stated => 1.0,
            SigmaSource::Estimated => self.figures(lin).3,
        };
        let rows_of = |o: usize| -> Vec<f64> { lin.sc.iter().map(|c| c[o]).collect() };
        let mut resid_cov: Vec<Option<Matrix3<f64>>> = vec![None; n];
        for (k, &i) in self.used.iter().enumerate() {
            let idx: Vec<(usize, usize)> = self
                .obs
                .iter()
                .enumerate()
                .filter(|(_, o)| o.pos == k && o.axis < 3)
                .map(|(oi, o)| (oi, o.axis))
                .collect();
            if idx.len() < 3 {
                continue;
            }
            let a: Vec<nalgebra::DVector<f64>> = idx
                .iter()
                .map(|&(oi, _)| nalgebra::DVector::from_vec(rows_of(oi)))
                .collect();
            let ca: Vec<nalgebra::DVector<f64>> = a.iter().map(|r| &lin.fit.cov * r).collect();
            let mut v = Matrix3::zeros();
            for (x, &(ox, jx)) in idx.iter().enumerate() {
                for (y, &(oy, jy)) in idx.iter().enumerate() {
                    let h = a[x].dot(&ca[y]);
                    let delta = if x == y { 1.0 } else { 0.0 };
                    v[(jx, jy)] =
                        self.obs[ox].sigma * (delta - h) * self.obs[oy].sigma * scale_noise;
                }
            }
            resid_cov[i] = Some(v);
        }
        resid_cov
    }
}

/// ` (all positions' gravity lies in one plane: …)` when it does, else empty.
fn planar_hint(pos: &[Position]) -> String {
    let mut s = Matrix3::zeros();
    for p in pos {
        let n = Vector3::from(p.g_unit);
        s += n * n.transpose();
    }
    let ev = s.symmetric_eigen().eigenvalues;
    let (min, max) = (ev.min(), ev.max());
    if max > 0.0 && min < 1e-6 * max {
        " (all positions' gravity lies in one plane: the axis across it is never excited)".into()
    } else if pos.len() < 6 {
        format!(" ({} positions)", pos.len())
    } else {
        String::new()
    }
}

/// The corrected specific force of readings `u` (cm/s², all three): `K_2` removed per axis
/// (solved exactly by iteration), then `(I + Γ)⁻¹`.
#[must_use]
pub fn corrected(t: &Triad, u: [f64; 3]) -> [f64; 3] {
    let mut a = Vector3::zeros();
    for j in 0..3 {
        let c = u[j] - t.bias[j].value;
        let sf = 1.0 + t.scale[j].value;
        let q = t.k2.map_or(0.0, |k| k[j].value);
        let mut v = c / sf;
        for _ in 0..6 {
            v = (c - q * v * v) / sf;
        }
        a[j] = v;
    }
    let gm = Matrix3::identity() + gamma_of(t);
    let f = gm.try_inverse().unwrap_or_else(Matrix3::identity) * a;
    [f[0], f[1], f[2]]
}

/// `Γ` of a fitted triad.
#[must_use]
pub fn gamma_of(t: &Triad) -> Matrix3<f64> {
    let mut gm = Matrix3::zeros();
    for j in 0..3 {
        for k in 0..3 {
            if let Some(e) = t.misalignment[j][k] {
                gm[(j, k)] = e.value;
            }
        }
    }
    gm
}

/// `M = (diag(1 + k)·(I + Γ))⁻¹`, the matrix of `f = M·(u − b)`.
#[must_use]
pub fn matrix_m(t: &Triad) -> Matrix3<f64> {
    let d = Matrix3::from_diagonal(&Vector3::from(t.scale.map(|s| 1.0 + s.value)));
    (d * (Matrix3::identity() + gamma_of(t)))
        .try_inverse()
        .unwrap_or_else(Matrix3::identity)
}

/// The |g| check of `t`, the residuals of position `i` of covariance `resid_cov[i]`.
fn g_check(t: &Triad, resid_cov: &[Option<Matrix3<f64>>]) -> GCheck {
    let m = matrix_m(t);
    let mut out = GCheck::default();
    for (i, p) in t.positions.iter().enumerate() {
        let ([Some(ux), Some(uy), Some(uz)], Some(v)) = (p.measured, resid_cov[i]) else {
            continue;
        };
        let f = Vector3::from(corrected(t, [ux, uy, uz]));
        let mag = f.norm();
        let d = mag - t.g_cm_s2;
        // σ of |f̂| − g: to first order it is the position's residuals through M onto
        // f̂/|f̂| (the fitted force has magnitude g).
        let grad = m.transpose() * (f / mag);
        let s = (grad.transpose() * v * grad)[(0, 0)].max(0.0).sqrt();
        out.positions.push((i, d, s));
    }
    let n = out.positions.len();
    if n == 0 {
        return out;
    }
    #[allow(clippy::cast_precision_loss)]
    let nf = n as f64;
    out.rms_cm_s2 = (out.positions.iter().map(|x| x.1 * x.1).sum::<f64>() / nf).sqrt();
    out.expected_rms_cm_s2 = (out.positions.iter().map(|x| x.2 * x.2).sum::<f64>() / nf).sqrt();
    out.worst = out
        .positions
        .iter()
        .map(|&(i, d, _)| (d.abs(), i))
        .fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a });
    out.chi2 = out.positions.iter().map(|x| (x.1 / x.2).powi(2)).sum();
    out.p_value = stats::chi2_sf(out.chi2, nf);
    out.p_lower = 1.0 - out.p_value;
    out
}

/// Below this tail probability the g check and the χ² flag the calibration.
pub const FLAG_P: f64 = 0.01;

/// Below this lower-tail probability of the |g| check's χ², with exact orientations, the
/// misfit is taken to lie across gravity (the fixture's orientation errors), not to be noise.
pub const ACROSS_P: f64 = 1e-3;

/// Largest estimated rotation from nominal within "small angles", rad (2°).
pub const SMALL_ANGLE_RAD: f64 = 0.035;

/// A tail probability for the text: 3 significant digits, or `< 1e-99`.
#[must_use]
pub fn p_text(p: f64) -> String {
    if p < 1e-99 {
        "< 1e-99".into()
    } else if p < 1e-3 {
        format!("= {p:.1e}")
    } else {
        format!("= {p:.3}")
    }
}

/// The warnings of a fit.
fn warnings(t: &Triad) -> Vec<String> {
    let mut w = Vec::new();
    if t.sigma_source == SigmaSource::Stated && t.p_value < FLAG_P {
        let mut s = format!(
            "the fit's χ² = {:.1} for {} degrees of freedom (p {}): the readings scatter more than their stated sigmas allow about the triad's model; the uncertainties are scaled by {:.2}",
            t.chi2,
            t.dof,
            p_text(t.p_value),
            t.sigma_scale
        );
        if t.orientation == Orientation::Exact {
            s.push_str(" (an orientation error of the fixture does this: with a hand-placed block use --orientation approximate)");
        }
        w.push(s);
    }
    let gc = &t.g_check;
    if !gc.positions.is_empty() && gc.p_value < FLAG_P {
        w.push(format!(
            "the |g| check fails: the corrected specific force's magnitude differs from the local gravity by {:.3} cm/s² RMS (worst {:.3} at `{}`) where the readings' noise gives {:.3} (p {}); the calibration does not describe these readings",
            gc.rms_cm_s2,
            gc.worst.0,
            t.positions[gc.worst.1].label,
            gc.expected_rms_cm_s2,
            p_text(gc.p_value)
        ));
    }
    if t.orientation == Orientation::Exact && gc.positions.len() >= 6 && gc.p_lower < ACROSS_P {
        w.push(format!(
            "the |g| check agrees with the local gravity far better than the readings' scatter allows ({:.3} cm/s² RMS where their σ gives {:.3}; P(χ² ≤ {:.1}) {}): the misfit lies across gravity, as an orientation error of the fixture does, not along it as noise would; with a hand-placed block use --orientation approximate",
            gc.rms_cm_s2,
            gc.expected_rms_cm_s2,
            gc.chi2,
            p_text(gc.p_lower)
        ));
    }
    if let Some((i, a)) = t
        .angles
        .iter()
        .enumerate()
        .filter_map(|(i, a)| a.map(|a| (i, a[0].value.hypot(a[1].value))))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        && a > SMALL_ANGLE_RAD
    {
        w.push(format!(
            "position `{}` is estimated {:.2}° from its nominal orientation, beyond the small angles the method assumes (2°); check its g_x, g_y, g_z",
            t.positions[i].label,
            a.to_degrees()
        ));
    }
    if let Some(n) = &t.k2_note {
        w.push(n.clone());
    }
    if t.dof < 3 {
        let mut s = String::new();
        let _ = write!(
            s,
            "only {} degrees of freedom: the noise and the model's adequacy are barely tested; measure more positions",
            t.dof
        );
        w.push(s);
    }
    w.extend(gravity_warning(t));
    w
}

/// A local gravity the data disagree with: the three scale factors share one change,
/// significant (beyond 3 σ) and alike across the axes (their spread about it consistent
/// with their σ, p ≥ 0.01). A calibration from gravity alone cannot tell a common
/// scale-factor error from a wrong gravity; the warning names the gravity that would
/// explain it.
fn gravity_warning(t: &Triad) -> Option<String> {
    let k = t.scale.map(|e| e.value);
    let w = t
        .scale
        .map(|e| 1.0 / (e.sigma * e.sigma).max(f64::MIN_POSITIVE));
    let sw: f64 = w.iter().sum();
    let mean = k.iter().zip(&w).map(|(k, w)| k * w).sum::<f64>() / sw;
    let sigma = sw.sqrt().recip();
    let spread: f64 = k.iter().zip(&w).map(|(k, w)| (k - mean).powi(2) * w).sum();
    let alike = stats::chi2_sf(spread, 2.0) >= FLAG_P;
    if !(alike && mean.abs() > 3.0 * sigma && sigma.is_finite()) {
        return None;
    }
    Some(format!(
        "the three axes' scale factors share one change of {:.0} ± {:.0} ppm, alike across the axes: if their nominal scale factors are right, the local gravity is {:.3} cm/s², not the {} cm/s² used (a calibration from gravity alone cannot tell the two apart); check the site's gravity (local_gravity_cm_s2, or --local-gravity)",
        mean * 1e6,
        sigma * 1e6,
        t.g_cm_s2 * (1.0 + mean),
        t.g_cm_s2
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pos(n: [f64; 3], u: [f64; 3]) -> Position {
        Position {
            label: String::new(),
            line: 0,
            time_s: None,
            g_nominal: n,
            g_unit: n,
            measured: u.map(Some),
            counts: [None; 3],
            counting_sigma_cm_s2: [None; 3],
            sigma_cm_s2: Some(0.01),
            sigma_angle_rad: None,
        }
    }

    /// Readings made by hand from the matrix form (no noise) come back.
    #[test]
    fn recovers_an_exact_triad() {
        let g = 980.0;
        let bias = [1.0, -2.0, 0.5];
        let k = [1e-3, -2e-3, 5e-4];
        let gm = Matrix3::new(0.0, 1e-3, -2e-3, 3e-3, 0.0, 1.5e-3, -1e-3, 2e-3, 0.0);
        let s = 1.0 / 2f64.sqrt();
        let dirs = [
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [s, s, 0.0],
            [0.0, s, s],
            [s, 0.0, -s],
            [-s, -s, 0.0],
        ];
        let rows: Vec<Position> = dirs
            .iter()
            .map(|&n| {
                let a = (Matrix3::identity() + gm) * Vector3::from(n) * g;
                pos(n, [0, 1, 2].map(|j| bias[j] + (1.0 + k[j]) * a[j]))
            })
            .collect();
        let t = fit(
            "t",
            &rows,
            &Options {
                orientation: Orientation::Exact,
                default_sigma_cm_s2: None,
                g_cm_s2: g,
            },
        )
        .unwrap();
        for j in 0..3 {
            assert!((t.bias[j].value - bias[j]).abs() < 1e-8, "{:?}", t.bias);
            assert!((t.scale[j].value - k[j]).abs() < 1e-10);
            for kk in 0..3 {
                if j != kk {
                    assert!((t.misalignment[j][kk].unwrap().value - gm[(j, kk)]).abs() < 1e-10);
                }
            }
            assert!(t.k2.unwrap()[j].value.abs() < 1e-12);
        }
        assert!(t.chi2 < 1e-6 && t.g_check.rms_cm_s2 < 1e-6);
        let f = corrected(&t, rows[6].measured.map(Option::unwrap));
        assert!((f[0] - g * s).abs() < 1e-6 && (f[1] - g * s).abs() < 1e-6 && f[2].abs() < 1e-6);
    }

    /// A fixture known to 1 mrad (`sigma_angle_urad`): with exact orientations the
    /// readings' variance takes the orientation error in and the χ² passes, where without
    /// it the χ² fails; with approximate orientations the angles get the prior (two more
    /// observations per position).
    #[test]
    fn a_stated_orientation_uncertainty_is_weighed() {
        use rand::SeedableRng as _;
        use rand_distr::Distribution as _;
        let g = 980.0;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let tilt = rand_distr::Normal::new(0.0, 1e-3).unwrap();
        let noise = rand_distr::Normal::new(0.0, 0.01).unwrap();
        let s = 1.0 / 14f64.sqrt();
        let mut dirs = Vec::new();
        for sx in [1.0, -1.0] {
            for sy in [1.0, -1.0] {
                for sz in [1.0, -1.0] {
                    for p in [[1.0, 2.0, 3.0], [3.0, 1.0, 2.0], [2.0, 3.0, 1.0]] {
                        dirs.push([sx * p[0] * s, sy * p[1] * s, sz * p[2] * s]);
                    }
                }
            }
        }
        let rows: Vec<Position> = dirs
            .iter()
            .map(|&n| {
                let d = Vector3::new(
                    tilt.sample(&mut rng),
                    tilt.sample(&mut rng),
                    tilt.sample(&mut rng),
                );
                let f = (Vector3::from(n) + d.cross(&Vector3::from(n))).normalize() * g;
                let mut p = pos(n, [0, 1, 2].map(|j| f[j] + noise.sample(&mut rng)));
                p.sigma_angle_rad = Some(1e-3);
                p
            })
            .collect();
        let opts = |o| Options {
            orientation: o,
            default_sigma_cm_s2: None,
            g_cm_s2: g,
        };
        let with = fit("t", &rows, &opts(Orientation::Exact)).unwrap();
        assert!(with.p_value > FLAG_P, "χ² {} dof {}", with.chi2, with.dof);
        let bare: Vec<Position> = rows
            .iter()
            .map(|p| Position {
                sigma_angle_rad: None,
                ..p.clone()
            })
            .collect();
        let without = fit("t", &bare, &opts(Orientation::Exact)).unwrap();
        assert!(
            without.p_value < FLAG_P,
            "χ² {} dof {}",
            without.chi2,
            without.dof
        );
        let approx = fit("t", &rows, &opts(Orientation::Approximate)).unwrap();
        let free = fit("t", &bare, &opts(Orientation::Approximate)).unwrap();
        assert_eq!(approx.dof, free.dof + 2 * rows.len());
        assert!(approx.p_value > FLAG_P && free.p_value > FLAG_P);
    }

    #[test]
    fn positions_in_one_plane_are_refused() {
        let rows: Vec<Position> = (0..8)
            .map(|i| {
                let a = f64::from(i) * std::f64::consts::FRAC_PI_4;
                pos(
                    [a.cos(), a.sin(), 0.0],
                    [980.0 * a.cos(), 980.0 * a.sin(), 0.0],
                )
            })
            .collect();
        let e = fit(
            "p.csv",
            &rows,
            &Options {
                orientation: Orientation::Exact,
                default_sigma_cm_s2: None,
                g_cm_s2: 980.0,
            },
        )
        .unwrap_err()
        .to_string();
        assert!(e.starts_with("p.csv:") && e.contains("one plane"), "{e}");
    }
}
