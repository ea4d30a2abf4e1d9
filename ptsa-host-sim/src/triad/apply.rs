//! A triad calibration to apply: the file `ptsa discover --write-instrument` writes for a
//! triad (one file for the three axes), read back from it or from a `discover --json`
//! result, and applied to three readings (`ptsa correct` on a triad record): the specific
//! force vector `f = M·(u − b)` with its 3×3 covariance (`docs/method/discovery.md`, "A triad").
//!
//! One file for the three axes, not one per axis: the correction needs the three readings
//! of a row at once (`Γ` mixes them), the three axes' parameters are correlated through the
//! positions they share (their orientations, estimated or not), and with approximate
//! orientations the frame `f` is given in is defined by the three axes together (x along
//! the x axis, y in the x–y plane). Per-axis files would lose the cross-axis covariance and
//! the frame.

use std::fmt::Write as _;

use anyhow::{Context as _, Result, bail};
use nalgebra::{Matrix3, Vector3};
use serde::Deserialize;

use super::fit::{AXES, Orientation, Triad};

/// The `format` key of a triad calibration file (and how it is recognised).
pub const FORMAT: &str = "ptsa triad calibration 1";

/// A triad's calibration, as applied: the model's parameters by name with their covariance.
#[derive(Clone, Debug, PartialEq)]
pub struct TriadCalibration {
    /// The frame of `f`: the block's (exact orientations) or the triad's own (approximate).
    pub orientation: Orientation,
    /// Local gravity of the calibration, cm/s² (to give `f` in g).
    pub g_cm_s2: f64,
    /// The parameters' names: `b_x`…, `k_x`…, `Γ_jk`…, `K2_x`… (as `Triad::names`).
    pub names: Vec<String>,
    /// Their values (cm/s², 1, rad, (cm/s²)⁻¹).
    pub values: Vec<f64>,
    /// Their covariance.
    pub cov: Vec<Vec<f64>>,
}

/// The model's parts of a parameter vector: `b`, `k`, `Γ`, `q`.
struct Parts {
    b: [f64; 3],
    k: [f64; 3],
    gamma: Matrix3<f64>,
    q: [f64; 3],
}

/// Where `name` sits in the model: bias, scale, misalignment (j, k) or `K_2` of axis j.
fn slot(name: &str) -> Option<(char, usize, usize)> {
    let axis = |c: char| AXES.iter().position(|a| a.starts_with(c));
    let mut ch = name.chars();
    if let Some(rest) = name.strip_prefix("Γ_") {
        let mut r = rest.chars();
        let (j, k) = (axis(r.next()?)?, axis(r.next()?)?);
        return (r.next().is_none() && j != k).then_some(('m', j, k));
    }
    let (kind, rest) = if let Some(r) = name.strip_prefix("K2_") {
        ('q', r)
    } else {
        let c = ch.next().filter(|c| matches!(c, 'b' | 'k'))?;
        (c, name.strip_prefix(&format!("{c}_"))?)
    };
    let mut r = rest.chars();
    let j = axis(r.next()?)?;
    (r.next().is_none() && matches!(kind, 'b' | 'k' | 'q')).then_some((kind, j, 0))
}

impl TriadCalibration {
    /// The calibration of a fit: its parameters, their sigmas and correlation.
    #[must_use]
    pub fn of(t: &Triad) -> Self {
        let mut values = Vec::with_capacity(t.names.len());
        let mut sigmas = Vec::with_capacity(t.names.len());
        for n in &t.names {
            let e = match slot(n) {
                Some(('b', j, _)) => t.bias[j],
                Some(('k', j, _)) => t.scale[j],
                Some(('m', j, k)) => t.misalignment[j][k].unwrap_or_default(),
                Some(('q', j, _)) => t.k2.map(|q| q[j]).unwrap_or_default(),
                _ => super::fit::Estimate::default(),
            };
            values.push(e.value);
            sigmas.push(e.sigma);
        }
        Self {
            orientation: t.orientation,
            g_cm_s2: t.g_cm_s2,
            cov: covariance(&sigmas, &t.correlation),
            names: t.names.clone(),
            values,
        }
    }

    /// The parameters' sigmas.
    #[must_use]
    pub fn sigmas(&self) -> Vec<f64> {
        (0..self.names.len())
            .map(|i| self.cov[i][i].max(0.0).sqrt())
            .collect()
    }

    fn parts(&self, v: &[f64]) -> Parts {
        let mut p = Parts {
            b: [0.0; 3],
            k: [0.0; 3],
            gamma: Matrix3::zeros(),
            q: [0.0; 3],
        };
        for (n, &x) in self.names.iter().zip(v) {
            match slot(n) {
                Some(('b', j, _)) => p.b[j] = x,
                Some(('k', j, _)) => p.k[j] = x,
                Some(('m', j, k)) => p.gamma[(j, k)] = x,
                Some(('q', j, _)) => p.q[j] = x,
                _ => {}
            }
        }
        p
    }

    /// `M = (diag(1 + k)·(I + Γ))⁻¹`.
    #[must_use]
    pub fn matrix_m(&self) -> Matrix3<f64> {
        let p = self.parts(&self.values);
        let d = Matrix3::from_diagonal(&Vector3::from(p.k.map(|k| 1.0 + k)));
        (d * (Matrix3::identity() + p.gamma))
            .try_inverse()
            .unwrap_or_else(Matrix3::identity)
    }

    /// What each axis sees, `a_j` (the `K_2` equation solved), and `f = (I + Γ)⁻¹·a`, for
    /// parameters `v` and readings `u`.
    fn force(&self, v: &[f64], u: [f64; 3]) -> (Vector3<f64>, Vector3<f64>, Parts) {
        let p = self.parts(v);
        let mut a = Vector3::zeros();
        for j in 0..3 {
            let c = u[j] - p.b[j];
            let sf = 1.0 + p.k[j];
            // u − b = (1 + k)·a + q·a²: the root near c/(1 + k), by Newton's method.
            let mut x = c / sf;
            for _ in 0..20 {
                let d = sf + 2.0 * p.q[j] * x;
                let dx = (sf * x + p.q[j] * x * x - c) / d;
                x -= dx;
                if dx.abs() <= 1e-15 * x.abs().max(1.0) {
                    break;
                }
            }
            a[j] = x;
        }
        let inv = (Matrix3::identity() + p.gamma)
            .try_inverse()
            .unwrap_or_else(Matrix3::identity);
        (inv * a, a, p)
    }

    /// Three readings corrected: `f` (cm/s²) and its covariance from the readings' noise
    /// (`var_u`, cm²/s⁴, independent) and from the calibration's covariance, each 3×3.
    #[must_use]
    pub fn correct(&self, u: [f64; 3], var_u: [f64; 3]) -> Corrected {
        let (f, a, p) = self.force(&self.values, u);
        // ∂f/∂u = (I + Γ)⁻¹·diag(1/(1 + k_j + 2 q_j a_j)).
        let inv = (Matrix3::identity() + p.gamma)
            .try_inverse()
            .unwrap_or_else(Matrix3::identity);
        let du = Matrix3::from_fn(|r, c| inv[(r, c)] / (1.0 + p.k[c] + 2.0 * p.q[c] * a[c]));
        let noise = du * Matrix3::from_diagonal(&Vector3::from(var_u)) * du.transpose();
        // ∂f/∂θ by central differences, a step of each parameter's own sigma (the model is
        // linear in b and nearly so in the rest).
        let sig = self.sigmas();
        let cols: Vec<Vector3<f64>> = (0..self.values.len())
            .map(|i| {
                let h = if sig[i] > 0.0 { sig[i] } else { 1e-9 };
                let (mut up, mut down) = (self.values.clone(), self.values.clone());
                up[i] += h;
                down[i] -= h;
                (self.force(&up, u).0 - self.force(&down, u).0) / (2.0 * h)
            })
            .collect();
        let mut cal = Matrix3::zeros();
        for (i, ci) in cols.iter().enumerate() {
            for (j, cj) in cols.iter().enumerate() {
                cal += ci * cj.transpose() * self.cov[i][j];
            }
        }
        Corrected {
            f: [f[0], f[1], f[2]],
            noise: mat(&noise),
            calibration: mat(&cal),
        }
    }

    /// The calibration file's text (TOML, with comments: the model, the units, `M` and
    /// where it came from); `provenance` are `(key, value)` lines recorded under
    /// `[source]`.
    #[must_use]
    pub fn to_file(&self, provenance: &[(&str, String)]) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "# A triad's calibration written by `ptsa discover --write-instrument` (docs/method/discovery.md, \"A triad\").\n\
             # Apply it with `ptsa correct --data RECORD.csv --calibration THIS_FILE`.\n\
             #\n\
             # Model of a reading u_j of axis j (cm/s² through the nominal scale factor):\n\
             #   a = (I + Γ)·f,   u_j = b_j + (1 + k_j)·a_j + q_j·a_j²\n\
             # f the specific force, cm/s², in the {}.\n\
             # parameters: b_x, b_y, b_z (cm/s²); k_x, k_y, k_z (scale-factor change, 1);\n\
             # Γ_jk (rad, axis j toward axis k; absent: 0 by the frame's convention);\n\
             # K2_x, K2_y, K2_z (q, (cm/s²)⁻¹ = K_2 in g/g² over g; absent: not fitted).\n\
             # covariance = sigma_i·sigma_j·correlation_ij.",
            frame_words(self.orientation)
        );
        let m = self.matrix_m();
        let _ = writeln!(s, "# The correction f = M·(u − b) with");
        for r in 0..3 {
            let _ = writeln!(
                s,
                "#   {} [{:+.12} {:+.12} {:+.12}]",
                if r == 0 { "M =" } else { "   " },
                m[(r, 0)],
                m[(r, 1)],
                m[(r, 2)]
            );
        }
        let _ = writeln!(
            s,
            "# (with K_2: u_j − b_j less q_j·a_j² first, a_j solved).\n"
        );
        let list = |v: &[String]| v.join(", ");
        let nums = |v: &[f64]| v.iter().map(|x| format!("{x:e}")).collect::<Vec<_>>();
        let _ = writeln!(s, "format = \"{FORMAT}\"");
        let _ = writeln!(s, "orientation = \"{}\"", self.orientation.name());
        let _ = writeln!(s, "local_gravity_cm_s2 = {:?}", self.g_cm_s2);
        let _ = writeln!(
            s,
            "parameters = [{}]",
            list(
                &self
                    .names
                    .iter()
                    .map(|n| format!("\"{n}\""))
                    .collect::<Vec<_>>()
            )
        );
        let _ = writeln!(s, "values = [{}]", list(&nums(&self.values)));
        let sig = self.sigmas();
        let _ = writeln!(s, "sigmas = [{}]", list(&nums(&sig)));
        let _ = writeln!(s, "correlation = [");
        for i in 0..self.names.len() {
            let row: Vec<f64> = (0..self.names.len())
                .map(|j| {
                    let d = sig[i] * sig[j];
                    if i == j {
                        1.0
                    } else if d > 0.0 {
                        self.cov[i][j] / d
                    } else {
                        0.0
                    }
                })
                .collect();
            let _ = writeln!(s, "  [{}],", list(&nums(&row)));
        }
        let _ = writeln!(s, "]");
        if !provenance.is_empty() {
            let _ = writeln!(s, "\n[source]");
            for (k, v) in provenance {
                let _ = writeln!(s, "{} = {}", toml_string(k), toml_string(v));
            }
        }
        s
    }

    /// Read a triad calibration file; `name` names it in the errors.
    ///
    /// # Errors
    /// Not TOML, not this format, a parameter name that is not the model's, lengths that do
    /// not match, a value that is not finite, a sigma below 0, a correlation that is not
    /// symmetric with a unit diagonal and entries in [−1, 1].
    pub fn parse(name: &str, text: &str) -> Result<Self> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct File {
            format: String,
            orientation: String,
            local_gravity_cm_s2: f64,
            parameters: Vec<String>,
            values: Vec<f64>,
            sigmas: Vec<f64>,
            correlation: Vec<Vec<f64>>,
            #[allow(dead_code)] // recorded for the reader, not used
            source: Option<toml::Table>,
        }
        let f: File = toml::from_str(text).map_err(|e| {
            let msg = e.message().to_string();
            let at = e.span().map_or(String::new(), |sp| {
                let line = text[..sp.start].matches('\n').count() + 1;
                let col = sp.start - text[..sp.start].rfind('\n').map_or(0, |i| i + 1) + 1;
                format!(":{line}:{col}")
            });
            anyhow::anyhow!("{name}{at}: {msg}; expected a triad calibration file (`format = \"{FORMAT}\"`, written by `ptsa discover --write-instrument` on a triad file)")
        })?;
        if f.format != FORMAT {
            bail!(
                "{name}: format `{}`; expected `{FORMAT}` (a triad calibration file written by `ptsa discover --write-instrument`)",
                f.format
            );
        }
        let orientation = match f.orientation.as_str() {
            "exact" => Orientation::Exact,
            "approximate" => Orientation::Approximate,
            o => bail!("{name}: orientation `{o}`; expected `exact` or `approximate`"),
        };
        if !(f.local_gravity_cm_s2.is_finite() && f.local_gravity_cm_s2 > 0.0) {
            bail!(
                "{name}: local_gravity_cm_s2 = {}; expected a finite number of cm/s² above 0",
                f.local_gravity_cm_s2
            );
        }
        let n = f.parameters.len();
        check_names(name, &f.parameters)?;
        if f.values.len() != n || f.sigmas.len() != n || f.correlation.len() != n {
            bail!(
                "{name}: {n} parameters, {} values, {} sigmas and {} correlation rows; expected one of each per parameter",
                f.values.len(),
                f.sigmas.len(),
                f.correlation.len()
            );
        }
        let sigmas = check_numbers(name, &f.parameters, &f.values, &f.sigmas, &f.correlation)?;
        Ok(Self {
            orientation,
            g_cm_s2: f.local_gravity_cm_s2,
            cov: covariance(&sigmas, &f.correlation),
            names: f.parameters,
            values: f.values,
        })
    }

    /// The `"triad"` object of a `ptsa discover --json` result on a triad file.
    ///
    /// # Errors
    /// A key is missing or not what the `"triad"` object holds.
    pub fn from_json(name: &str, v: &serde_json::Value) -> Result<Self> {
        let t = v
            .get("triad")
            .with_context(|| format!("{name}: no `triad` object"))?;
        let num = |k: &str| t.get(k).and_then(serde_json::Value::as_f64);
        let arr3 = |k: &str| -> Option<[f64; 3]> {
            let a = t.get(k)?.as_array()?;
            (a.len() == 3).then_some(())?;
            Some([a[0].as_f64()?, a[1].as_f64()?, a[2].as_f64()?])
        };
        let cell = |k: &str, j: usize, c: usize| -> Option<f64> {
            t.get(k)?.as_array()?.get(j)?.as_array()?.get(c)?.as_f64()
        };
        let bad = |k: &str| {
            anyhow::anyhow!(
                "{name}: `triad.{k}` is missing or not what `ptsa discover --json` writes for a triad"
            )
        };
        let g = num("local_gravity_cm_s2").ok_or_else(|| bad("local_gravity_cm_s2"))?;
        let orientation = match t.get("orientation").and_then(serde_json::Value::as_str) {
            Some("exact") => Orientation::Exact,
            Some("approximate") => Orientation::Approximate,
            _ => return Err(bad("orientation")),
        };
        let names: Vec<String> = t
            .get("parameter_names")
            .and_then(serde_json::Value::as_array)
            .and_then(|a| {
                a.iter()
                    .map(|x| x.as_str().map(str::to_string))
                    .collect::<Option<_>>()
            })
            .ok_or_else(|| bad("parameter_names"))?;
        check_names(name, &names)?;
        let correlation: Vec<Vec<f64>> = t
            .get("correlation")
            .and_then(serde_json::Value::as_array)
            .and_then(|rows| {
                rows.iter()
                    .map(|r| {
                        r.as_array()
                            .and_then(|r| r.iter().map(serde_json::Value::as_f64).collect())
                    })
                    .collect::<Option<_>>()
            })
            .ok_or_else(|| bad("correlation"))?;
        let (b, sb) = (arr3("bias_cm_s2"), arr3("bias_sigma_cm_s2"));
        let (k, sk) = (arr3("scale_factor_ppm"), arr3("scale_factor_sigma_ppm"));
        let (q, sq) = (arr3("k2_ug_per_g2"), arr3("k2_sigma_ug_per_g2"));
        let mut values = Vec::new();
        let mut sigmas = Vec::new();
        for n in &names {
            let (x, s) = match slot(n) {
                Some(('b', j, _)) => (b.map(|v| v[j]), sb.map(|v| v[j])),
                Some(('k', j, _)) => (k.map(|v| v[j] * 1e-6), sk.map(|v| v[j] * 1e-6)),
                Some(('m', j, c)) => (
                    cell("misalignment_rad", j, c),
                    cell("misalignment_sigma_rad", j, c),
                ),
                Some(('q', j, _)) => (q.map(|v| v[j] / (g * 1e6)), sq.map(|v| v[j] / (g * 1e6))),
                _ => (None, None),
            };
            values.push(x.ok_or_else(|| bad(&format!("value of {n}")))?);
            sigmas.push(s.ok_or_else(|| bad(&format!("sigma of {n}")))?);
        }
        if correlation.len() != names.len() {
            return Err(bad("correlation"));
        }
        let sigmas = check_numbers(name, &names, &values, &sigmas, &correlation)?;
        Ok(Self {
            orientation,
            g_cm_s2: g,
            cov: covariance(&sigmas, &correlation),
            names,
            values,
        })
    }
}

/// Three readings corrected.
#[derive(Clone, Debug, PartialEq)]
pub struct Corrected {
    /// The specific force, cm/s², in the calibration's frame.
    pub f: [f64; 3],
    /// Its covariance from the readings' noise, cm²/s⁴.
    pub noise: [[f64; 3]; 3],
    /// Its covariance from the calibration's (shared by every row corrected with it).
    pub calibration: [[f64; 3]; 3],
}

impl Corrected {
    /// The whole covariance, cm²/s⁴.
    #[must_use]
    pub fn covariance(&self) -> [[f64; 3]; 3] {
        [0, 1, 2].map(|r| [0, 1, 2].map(|c| self.noise[r][c] + self.calibration[r][c]))
    }

    /// `|f|`, cm/s², and its 1 σ (the whole covariance along `f/|f|`).
    #[must_use]
    pub fn magnitude(&self) -> (f64, f64) {
        let f = Vector3::from(self.f);
        let m = f.norm();
        if m == 0.0 {
            return (0.0, 0.0);
        }
        let e = f / m;
        let c = self.covariance();
        let mut v = 0.0;
        for r in 0..3 {
            for k in 0..3 {
                v += e[r] * c[r][k] * e[k];
            }
        }
        (m, v.max(0.0).sqrt())
    }
}

/// What the frame of `f` is, in words.
#[must_use]
pub fn frame_words(o: Orientation) -> &'static str {
    match o {
        Orientation::Exact => "block's frame",
        Orientation::Approximate => "triad's frame (x along the x axis, y in the x–y plane)",
    }
}

fn mat(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    [0, 1, 2].map(|r| [0, 1, 2].map(|c| m[(r, c)]))
}

fn covariance(sigmas: &[f64], rho: &[Vec<f64>]) -> Vec<Vec<f64>> {
    (0..sigmas.len())
        .map(|i| {
            (0..sigmas.len())
                .map(|j| {
                    let r = if i == j {
                        1.0
                    } else {
                        rho.get(i).and_then(|r| r.get(j)).copied().unwrap_or(0.0)
                    };
                    let r = if r.is_finite() { r } else { 0.0 };
                    r * sigmas[i] * sigmas[j]
                })
                .collect()
        })
        .collect()
}

/// Every name a parameter of the model, each once, with the biases and scale factors.
fn check_names(name: &str, names: &[String]) -> Result<()> {
    for (i, n) in names.iter().enumerate() {
        if slot(n).is_none() {
            bail!(
                "{name}: parameter `{n}` is not one of the triad model's (b_x, k_x, Γ_xy, K2_x, … for the axes x, y, z)"
            );
        }
        if names[..i].contains(n) {
            bail!("{name}: parameter `{n}` appears twice");
        }
    }
    for a in AXES {
        for p in ["b", "k"] {
            if !names.iter().any(|n| *n == format!("{p}_{a}")) {
                bail!(
                    "{name}: no parameter `{p}_{a}`; expected the three biases and scale-factor changes at least"
                );
            }
        }
    }
    Ok(())
}

/// The values finite, the sigmas finite and 0 or more, the correlation symmetric with a
/// unit diagonal (entries of a parameter without variance may be anything finite or NaN,
/// as the fit writes them); returns the sigmas.
fn check_numbers(
    name: &str,
    names: &[String],
    values: &[f64],
    sigmas: &[f64],
    rho: &[Vec<f64>],
) -> Result<Vec<f64>> {
    for (i, n) in names.iter().enumerate() {
        if !values[i].is_finite() {
            bail!(
                "{name}: the value of `{n}` is {}; expected a finite number",
                values[i]
            );
        }
        if !(sigmas[i].is_finite() && sigmas[i] >= 0.0) {
            bail!(
                "{name}: the sigma of `{n}` is {}; expected a finite number of 0 or more",
                sigmas[i]
            );
        }
        if rho[i].len() != names.len() {
            bail!(
                "{name}: correlation row {} (`{n}`) has {} entries; expected {}",
                i + 1,
                rho[i].len(),
                names.len()
            );
        }
        for (j, m) in names.iter().enumerate() {
            let (a, b) = (rho[i][j], rho[j][i]);
            let ok = if i == j {
                sigmas[i] == 0.0 || (a - 1.0).abs() <= 1e-9
            } else {
                (a.is_nan() && b.is_nan())
                    || ((-1.0 - 1e-9..=1.0 + 1e-9).contains(&a) && (a - b).abs() <= 1e-9)
            };
            if !ok {
                bail!(
                    "{name}: the correlation of `{n}` with `{m}` is {a} (and {b} the other way round); expected a symmetric matrix with 1 on its diagonal and entries in [−1, 1]"
                );
            }
        }
    }
    Ok(sigmas.to_vec())
}

/// `v` as a TOML basic string.
fn toml_string(v: &str) -> String {
    let mut s = String::from("\"");
    for c in v.chars() {
        match c {
            '"' => s.push_str("\\\""),
            '\\' => s.push_str("\\\\"),
            c if c.is_control() => {
                let _ = write!(s, "\\u{:04X}", u32::from(c));
            }
            c => s.push(c),
        }
    }
    s.push('"');
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cal(orientation: Orientation) -> TriadCalibration {
        let names: Vec<String> = [
            "b_x", "b_y", "b_z", "k_x", "k_y", "k_z", "Γ_yx", "Γ_zx", "Γ_zy", "K2_x", "K2_y",
            "K2_z",
        ]
        .map(String::from)
        .to_vec();
        let values = vec![
            12.0, -8.0, 30.0, 0.01, -0.005, 0.002, 4e-3, -2e-3, 3e-3, 2e-6, -1e-6, 0.0,
        ];
        let sigmas = [
            0.1, 0.1, 0.08, 5e-5, 5e-5, 5e-5, 6e-5, 6e-5, 6e-5, 1e-7, 1e-7, 1e-7,
        ];
        let mut rho = vec![vec![0.0; 12]; 12];
        for (i, r) in rho.iter_mut().enumerate() {
            r[i] = 1.0;
        }
        rho[0][3] = 0.5;
        rho[3][0] = 0.5;
        TriadCalibration {
            orientation,
            g_cm_s2: 980.4,
            cov: covariance(&sigmas, &rho),
            names,
            values,
        }
    }

    /// The readings the model gives for a known `f` come back as that `f`; the noise's
    /// covariance is `∂f/∂u` applied to the readings' variances; the file and the JSON
    /// give back the same calibration.
    #[test]
    fn the_model_is_inverted_and_the_file_reads_back() {
        let c = cal(Orientation::Approximate);
        let p = c.parts(&c.values);
        for f in [
            [980.4, 0.0, 0.0],
            [300.0, -500.0, 700.0],
            [-1.0, 2.0, -900.0],
        ] {
            let a = (Matrix3::identity() + p.gamma) * Vector3::from(f);
            let u: [f64; 3] =
                [0, 1, 2].map(|j| p.b[j] + (1.0 + p.k[j]) * a[j] + p.q[j] * a[j] * a[j]);
            let r = c.correct(u, [0.01, 0.04, 0.09]);
            for j in 0..3 {
                assert!((r.f[j] - f[j]).abs() < 1e-9, "{f:?}: {r:?}");
            }
            // Nearly the identity: each axis's own variance.
            assert!((r.noise[1][1] / 0.04 - 1.0).abs() < 0.05, "{r:?}");
            // The bias's variance is in the calibration's part.
            assert!(r.calibration[0][0] >= 0.9 * 0.01, "{r:?}");
        }
        let text = c.to_file(&[("data", "a \"quoted\" name".into())]);
        let back = TriadCalibration::parse("f.toml", &text).unwrap();
        assert_eq!(back.names, c.names);
        assert_eq!(back.orientation, c.orientation);
        for i in 0..12 {
            assert!((back.values[i] - c.values[i]).abs() <= 1e-12 * c.values[i].abs());
            for j in 0..12 {
                assert!((back.cov[i][j] - c.cov[i][j]).abs() <= 1e-12 * c.cov[i][i].max(1e-30));
            }
        }
    }

    #[test]
    fn a_broken_file_is_refused_with_its_place() {
        let c = cal(Orientation::Exact);
        let text = c.to_file(&[]);
        let e = TriadCalibration::parse("f.toml", &text.replace("values = [", "values = [x"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("f.toml:"), "{e}");
        let e = TriadCalibration::parse("f.toml", &text.replace("\"b_y\"", "\"b_w\""))
            .unwrap_err()
            .to_string();
        assert!(e.contains("`b_w`"), "{e}");
        let e = TriadCalibration::parse("f.toml", &text.replace(FORMAT, "something else"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("expected `ptsa triad calibration 1`"), "{e}");
    }
}
