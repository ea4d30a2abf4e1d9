//! The `"triad"` object of `ptsa discover --json` on a triad file: every key with its unit
//! and meaning (the contract; `docs/method/discovery.md`, "A triad", gives the convention).

use serde::Serialize;

use crate::triad::fit::{self, Orientation, SigmaSource, Triad};

/// `"triad"`: one calibration of three accelerometers on one block.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct TriadJson {
    /// `"exact"` (the nominal orientations are true) or `"approximate"` (each position's
    /// small rotation from nominal estimated too).
    pub orientation: &'static str,
    /// Local gravity used (the instrument file's), cm/s².
    pub local_gravity_cm_s2: f64,
    /// Positions in the file, and how many have a reading.
    pub positions: usize,
    /// Positions with at least one reading (fitted).
    pub positions_measured: usize,
    /// Readings fitted (axis × position).
    pub readings: usize,
    /// Parameters fitted, the positions' angles included.
    pub parameters: usize,
    /// Bias of each axis (x, y, z), cm/s²: `b` of `u = b + (1 + k)·a + K_2·a²`.
    pub bias_cm_s2: [f64; 3],
    /// 1 σ of `bias_cm_s2`, cm/s².
    pub bias_sigma_cm_s2: [f64; 3],
    /// The bias in IEEE 1293 units (`K_0`), µg (of the local gravity).
    pub bias_ug: [f64; 3],
    /// 1 σ of `bias_ug`, µg.
    pub bias_sigma_ug: [f64; 3],
    /// Scale-factor change from nominal of each axis, ppm (`k·10⁶`; the reading through the
    /// nominal scale factor is `(1 + k)` times the input).
    pub scale_factor_ppm: [f64; 3],
    /// 1 σ of `scale_factor_ppm`, ppm.
    pub scale_factor_sigma_ppm: [f64; 3],
    /// `Γ`, rad: row `j` is axis j's input axis, column `k` the block's axis it leans toward
    /// (`a = (I + Γ)·f`); the diagonal is 0, and with approximate orientations the three
    /// entries above the diagonal are 0 by the triad frame's convention (x along the x
    /// axis, y in the plane of the x and y axes).
    pub misalignment_rad: [[f64; 3]; 3],
    /// 1 σ of `misalignment_rad`, rad; `null` on the diagonal and where fixed by the
    /// convention.
    pub misalignment_sigma_rad: [[Option<f64>; 3]; 3],
    /// `K_2` of each axis, µg/g² (`null` when not fitted: `k2_note` says why).
    pub k2_ug_per_g2: Option<[f64; 3]>,
    /// 1 σ of `k2_ug_per_g2`, µg/g².
    pub k2_sigma_ug_per_g2: Option<[f64; 3]>,
    /// Why `K_2` is not fitted, when it is not.
    pub k2_note: Option<String>,
    /// `M` of the correction `f = M·(u − b)` users apply (`u` the three readings, cm/s²;
    /// with `K_2`, each `u_j − b_j` less `K_2·((u_j − b_j)/(1 + k_j))²` first):
    /// `M = (diag(1 + k)·(I + Γ))⁻¹`, dimensionless, row-major.
    pub correction_matrix: [[f64; 3]; 3],
    /// The correction as a formula, in words.
    pub correction_formula: String,
    /// The calibration parameters' names in the order of `correlation` (`b_x`, …, `k_x`,
    /// …, `Γ_xy`, …, `K2_x`, …).
    pub parameter_names: Vec<String>,
    /// Their correlation matrix.
    pub correlation: Vec<Vec<f64>>,
    /// `"stated"` (`sigma_cm_s2` or `--sigma` on every measured row) or `"estimated"` (one
    /// σ for all readings, from the residuals).
    pub sigma_source: &'static str,
    /// The readings' σ, cm/s²: the estimate, or the RMS of the stated ones.
    pub sigma_cm_s2: f64,
    /// The factor on the classical errors: the Birge ratio `√(χ²/dof)` when the stated
    /// sigmas are too small for the scatter (p < 0.05), the estimated σ's scaling, else 1.
    pub sigma_scale: f64,
    /// `value ± coverage_factor_95·σ` is a 95 % interval: 1.96 with believed stated sigmas,
    /// Student's t at `dof` when the σ comes from the residuals.
    pub coverage_factor_95: f64,
    /// χ² of the fit against the sigmas (with estimated sigmas, against 1 cm/s²).
    pub chi2: f64,
    /// Degrees of freedom: readings less parameters.
    pub dof: usize,
    /// `P(χ²_dof ≥ chi2)` with stated sigmas (`null` when estimated).
    pub p_value: Option<f64>,
    /// The NIST-style |g| self-consistency check: the calibration's quality figure.
    pub g_check: GCheckJson,
    /// Per position: its label, the estimated rotation from nominal and the residuals.
    pub rows: Vec<TriadRow>,
    /// Gauss–Newton iterations.
    pub iterations: usize,
    /// Warnings (each also on stderr after `warning:`).
    pub warnings: Vec<String>,
}

/// `"g_check"`: per position with all three axes measured, `|f̂| − g`, the magnitude of
/// the corrected specific force `f̂ = M·(u − b)` against the local gravity.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct GCheckJson {
    /// Positions checked (three readings each).
    pub positions: usize,
    /// RMS of `|f̂| − g`, cm/s².
    pub rms_cm_s2: f64,
    /// The same, µg.
    pub rms_ug: f64,
    /// The largest `||f̂| − g|`, cm/s².
    pub worst_cm_s2: f64,
    /// Its position's label.
    pub worst_position: String,
    /// The RMS the readings' noise alone gives, cm/s² (from their sigmas through `M`, less
    /// what the fit takes up: the hat matrix).
    pub expected_rms_cm_s2: f64,
    /// `Σ ((|f̂| − g)/σ)²` over the positions.
    pub chi2: f64,
    /// `P(χ²_N ≥ chi2)`, N the positions (each difference standardised by its own σ after
    /// the fit; their correlation through the fit is left out).
    pub p_value: f64,
    /// `p_value ≥ 0.01`: the magnitudes agree with the local gravity to the noise.
    pub consistent: bool,
    /// `P(χ²_N ≤ chi2)`: small when the magnitudes agree far better than the noise allows
    /// (with exact orientations, below 0.001, a warning: the misfit lies across gravity, as
    /// the fixture's orientation errors put it).
    pub p_lower: f64,
}

/// One position of the result.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct TriadRow {
    /// The row's label.
    pub label: String,
    /// Its line in the file.
    pub line: usize,
    /// Measured − fitted of each axis, cm/s² (`null`: not measured).
    pub residual_cm_s2: [Option<f64>; 3],
    /// `|f̂| − g`, cm/s² (`null` unless all three axes are measured).
    pub g_check_cm_s2: Option<f64>,
    /// With approximate orientations, the estimated rotation from nominal, µrad (its
    /// magnitude; the rotation about gravity is not observable and not counted).
    pub rotation_urad: Option<f64>,
    /// 1 σ of each of the two rotation angles (about two axes perpendicular to gravity),
    /// µrad.
    pub rotation_sigma_urad: Option<[f64; 2]>,
}

/// µg per cm/s² at local gravity `g`.
fn ug(g: f64) -> f64 {
    1e6 / g
}

impl TriadJson {
    /// The JSON of a fit.
    #[must_use]
    pub fn of(t: &Triad) -> Self {
        let g = t.g_cm_s2;
        let m = fit::matrix_m(t);
        let gc = &t.g_check;
        let check_of = |i: usize| gc.positions.iter().find(|x| x.0 == i).map(|x| x.1);
        TriadJson {
            orientation: t.orientation.name(),
            local_gravity_cm_s2: g,
            positions: t.positions.len(),
            positions_measured: t.positions.iter().filter(|p| p.is_measured()).count(),
            readings: t.readings,
            parameters: t.parameters,
            bias_cm_s2: t.bias.map(|e| e.value),
            bias_sigma_cm_s2: t.bias.map(|e| e.sigma),
            bias_ug: t.bias.map(|e| e.value * ug(g)),
            bias_sigma_ug: t.bias.map(|e| e.sigma * ug(g)),
            scale_factor_ppm: t.scale.map(|e| e.value * 1e6),
            scale_factor_sigma_ppm: t.scale.map(|e| e.sigma * 1e6),
            misalignment_rad: t
                .misalignment
                .map(|r| r.map(|e| e.map_or(0.0, |e| e.value))),
            misalignment_sigma_rad: t.misalignment.map(|r| r.map(|e| e.map(|e| e.sigma))),
            // q (cm/s²)⁻¹ → K_2 in g/g² is q·g; in µg/g², q·g·10⁶.
            k2_ug_per_g2: t.k2.map(|k| k.map(|e| e.value * g * 1e6)),
            k2_sigma_ug_per_g2: t.k2.map(|k| k.map(|e| e.sigma * g * 1e6)),
            k2_note: t.k2_note.clone(),
            correction_matrix: [0, 1, 2].map(|r| [0, 1, 2].map(|c| m[(r, c)])),
            correction_formula: formula(t),
            parameter_names: t.names.clone(),
            correlation: t.correlation.clone(),
            sigma_source: match t.sigma_source {
                SigmaSource::Stated => "stated",
                SigmaSource::Estimated => "estimated",
            },
            sigma_cm_s2: t.sigma_cm_s2,
            sigma_scale: t.sigma_scale,
            coverage_factor_95: t.coverage_factor,
            chi2: t.chi2,
            dof: t.dof,
            p_value: (t.sigma_source == SigmaSource::Stated).then_some(t.p_value),
            g_check: GCheckJson {
                positions: gc.positions.len(),
                rms_cm_s2: gc.rms_cm_s2,
                rms_ug: gc.rms_cm_s2 * ug(g),
                worst_cm_s2: gc.worst.0,
                worst_position: t
                    .positions
                    .get(gc.worst.1)
                    .map(|p| p.label.clone())
                    .unwrap_or_default(),
                expected_rms_cm_s2: gc.expected_rms_cm_s2,
                chi2: gc.chi2,
                p_value: gc.p_value,
                consistent: gc.positions.is_empty() || gc.p_value >= fit::FLAG_P,
                p_lower: gc.p_lower,
            },
            rows: t
                .positions
                .iter()
                .enumerate()
                .map(|(i, p)| TriadRow {
                    label: p.label.clone(),
                    line: p.line,
                    residual_cm_s2: t.residuals[i],
                    g_check_cm_s2: check_of(i),
                    rotation_urad: t.angles[i].map(|a| a[0].value.hypot(a[1].value) * 1e6),
                    rotation_sigma_urad: t.angles[i].map(|a| a.map(|e| e.sigma * 1e6)),
                })
                .collect(),
            iterations: t.iterations,
            warnings: t.warnings.clone(),
        }
    }
}

/// The correction users apply, written out with its numbers.
#[must_use]
pub fn formula(t: &Triad) -> String {
    let m = fit::matrix_m(t);
    let row = |r: usize| format!("[{:+.9} {:+.9} {:+.9}]", m[(r, 0)], m[(r, 1)], m[(r, 2)]);
    let b = t.bias.map(|e| format!("{:+.5}", e.value));
    let mut s = format!(
        "f = M·(u − b), u the readings (x, y, z) in cm/s² through the nominal scale factors, b = ({}) cm/s², M = [{}; {}; {}] (rows x, y, z) = (diag(1 + k)·(I + Γ))⁻¹",
        b.join(", "),
        row(0),
        row(1),
        row(2)
    );
    if let Some(k2) = t.k2 {
        let q: Vec<String> = k2.iter().map(|e| format!("{:+.4e}", e.value)).collect();
        let _ = std::fmt::Write::write_fmt(
            &mut s,
            format_args!(
                "; with K_2 first: u_j − b_j less q_j·((u_j − b_j)/(1 + k_j))², q = ({}) (cm/s²)⁻¹ (K_2 in g/g² over g)",
                q.join(", ")
            ),
        );
    }
    if t.orientation == Orientation::Approximate {
        s.push_str("; f in the triad's frame (x along the x axis, y in the x–y plane)");
    } else {
        s.push_str("; f in the block's frame");
    }
    s
}
