//! The triad's calibration sheet (`ptsa discover --data TRIAD.csv --sheet DIR`): one folder
//! written whole or not at all, as the single-axis sheet is (`discovery::sheet`, whose
//! provenance helpers it uses: SHA-256, the UTC date, the folder's check). For a folder
//! `DIR` named `NAME`:
//!
//! * `NAME.md`: the data file's name and SHA-256, the instrument file's, the date, the
//!   analysis; the model and the correction with its numbers; the three axes'
//!   coefficients and the non-orthogonality with 1 σ and the 95 % interval; the parameters'
//!   correlation; the fit's χ² and the |g| check; the design and residual table (per
//!   position its nominal gravity, each axis's residual, `|f̂| − g`, the estimated turn);
//!   the warnings and the residual plot;
//! * `NAME.csv`: one row per parameter (name, value, 1 σ, the 95 % interval's half-width,
//!   unit, and the same in IEEE 1293 units), after `#` lines with the provenance;
//! * `NAME-residuals.png` and `.svg`: each reading's residual with its 1 σ.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};

use super::fit::{AXES, SigmaSource, Triad};
use crate::discovery::sheet::check_target;
use crate::output::{Figure, Plot, Series, StagedDir, XAxis, significant};

/// What the triad's sheet (and its calibration file) records of its inputs.
pub struct Inputs<'a> {
    /// The data file as given, and its bytes as read.
    pub data: (&'a Path, &'a [u8]),
    /// The instrument file's name and text.
    pub instrument: (&'a str, &'a str),
    /// The sheet's time, seconds since 1970-01-01 UTC, and whether from `SOURCE_DATE_EPOCH`.
    pub time: (i64, bool),
    /// 1 σ of a reading that states none (`--sigma`), cm/s².
    pub default_sigma_cm_s2: Option<f64>,
}

fn file_name(p: &Path) -> String {
    p.file_name().map_or_else(
        || p.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// The provenance lines both files carry, `(what, value)`; also the triad calibration
/// file's `[source]`.
#[must_use]
pub fn provenance(s: &Inputs<'_>, t: &Triad) -> Vec<(&'static str, String)> {
    let mut v = crate::discovery::sheet::provenance(
        format!("{} ({} positions)", file_name(s.data.0), t.positions.len()),
        s.data.1,
        s.instrument,
        s.time,
    );
    v.push((
        "analysis",
        format!(
            "ptsa discover {} (triad, orientations {}; {} readings, {} parameters)",
            env!("CARGO_PKG_VERSION"),
            t.orientation.name(),
            t.readings,
            t.parameters
        ),
    ));
    v
}

/// 1 σ of reading `j` of position `i` as the fit weighed it, cm/s².
fn reading_sigma(t: &Triad, i: usize, j: usize, default: Option<f64>) -> f64 {
    let p = &t.positions[i];
    match t.sigma_source {
        SigmaSource::Estimated => t.sigma_cm_s2,
        SigmaSource::Stated => p
            .sigma_cm_s2
            .or(default)
            .unwrap_or(0.0)
            .hypot(p.counting_sigma_cm_s2[j].unwrap_or(0.0)),
    }
}

/// Each parameter: name, value, 1 σ, unit, and the value and σ in IEEE 1293 units with
/// their unit.
fn parameters(t: &Triad) -> Vec<(String, f64, f64, &'static str, f64, f64, &'static str)> {
    let g = t.g_cm_s2;
    let cal = super::apply::TriadCalibration::of(t);
    let sig = cal.sigmas();
    cal.names
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let (v, s) = (cal.values[i], sig[i]);
            let (unit, f, ieee) = if n.starts_with("b_") {
                ("cm/s²", 1e6 / g, "µg")
            } else if n.starts_with("k_") {
                ("1", 1e6, "ppm")
            } else if n.starts_with("Γ_") {
                ("rad", 1e6, "µrad")
            } else {
                // K_2 in µg/g² is q·g·10⁶.
                ("(cm/s²)⁻¹", g * 1e6, "µg/g²")
            };
            (n.clone(), v, s, unit, v * f, s * f, ieee)
        })
        .collect()
}

/// The sheet in Markdown (`NAME.md`), with the residual plot `plot` beside it.
#[must_use]
pub fn markdown(s: &Inputs<'_>, t: &Triad, plot: &str) -> String {
    let mut m = String::from("# Calibration sheet: accelerometer triad\n\n| | |\n|---|---|\n");
    for (k, v) in provenance(s, t) {
        let _ = writeln!(m, "| {k} | `{v}` |");
    }
    let _ = writeln!(
        m,
        "\n## Calibration\n\nThe fit's report (1 σ; the 95 % interval is value ± {:.2} σ):\n\n```text\n{}```\n",
        t.coverage_factor,
        super::text(t, &file_name(s.data.0))
    );
    m.push_str("## Parameters\n\n| parameter | value | 1 σ | unit | value | 1 σ | unit | 95 % ± |\n|---|---|---|---|---|---|---|---|\n");
    for (n, v, sg, unit, vi, si, ieee) in parameters(t) {
        let _ = writeln!(
            m,
            "| {n} | {} | {} | {unit} | {} | {} | {ieee} | {} |",
            significant(v, 7),
            significant(sg, 3),
            significant(vi, 7),
            significant(si, 3),
            significant(si * t.coverage_factor, 3)
        );
    }
    if t.names.len() > 1 {
        m.push_str("\n## Correlation of the parameters\n\n| |");
        for n in &t.names {
            let _ = write!(m, " {n} |");
        }
        m.push_str("\n|---|");
        m.push_str(&"---|".repeat(t.names.len()));
        m.push('\n');
        for (i, n) in t.names.iter().enumerate() {
            let _ = write!(m, "| {n} |");
            for r in &t.correlation[i] {
                let _ = write!(
                    m,
                    " {} |",
                    if r.is_finite() {
                        format!("{r:+.3}")
                    } else {
                        "—".into()
                    }
                );
            }
            m.push('\n');
        }
    }
    m.push_str("\n## Design and residuals\n\nPer position: the block's nominal gravity (g), each axis's residual (measured − fitted, cm/s²), the |g| check `|f̂| − g` (cm/s²) and, with approximate orientations, the estimated turn from nominal (µrad).\n\n| position | line | g_x | g_y | g_z | residual x | residual y | residual z | \\|f̂\\| − g | turn µrad |\n|---|---|---|---|---|---|---|---|---|---|\n");
    let cell = |v: Option<f64>| v.map_or_else(|| "—".to_string(), |v| significant(v, 5));
    for (i, p) in t.positions.iter().enumerate() {
        let gc = t.g_check.positions.iter().find(|x| x.0 == i).map(|x| x.1);
        let turn = t.angles[i].map(|a| a[0].value.hypot(a[1].value) * 1e6);
        let _ = writeln!(
            m,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            p.label.replace('|', "\\|"),
            p.line,
            significant(p.g_nominal[0], 6),
            significant(p.g_nominal[1], 6),
            significant(p.g_nominal[2], 6),
            cell(t.residuals[i][0]),
            cell(t.residuals[i][1]),
            cell(t.residuals[i][2]),
            cell(gc),
            cell(turn)
        );
    }
    let _ = writeln!(m, "\n![residuals]({plot})");
    if !t.warnings.is_empty() {
        m.push_str("\n## Warnings\n\n");
        for w in &t.warnings {
            let _ = writeln!(m, "* {w}");
        }
    }
    m
}

/// The parameters as CSV (`NAME.csv`), after `#` lines with the provenance.
///
/// # Errors
/// Never in practice (in-memory writer).
pub fn csv(s: &Inputs<'_>, t: &Triad) -> Result<String> {
    let mut out = String::new();
    for (k, v) in provenance(s, t) {
        let _ = writeln!(out, "# {k}: {v}");
    }
    let _ = writeln!(
        out,
        "# model: a = (I + Γ)·f, u_j = b_j + (1 + k_j)·a_j + q_j·a_j²; f in the {}; coverage factor of the 95 % interval {}",
        super::apply::frame_words(t.orientation),
        t.coverage_factor
    );
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "parameter",
        "value",
        "sigma",
        "unit",
        "value_ieee",
        "sigma_ieee",
        "unit_ieee",
        "half_width_95_ieee",
    ])?;
    for (n, v, sg, unit, vi, si, ieee) in parameters(t) {
        w.write_record([
            n,
            format!("{v}"),
            format!("{sg}"),
            unit.to_string(),
            format!("{vi}"),
            format!("{si}"),
            ieee.to_string(),
            format!("{}", si * t.coverage_factor),
        ])?;
    }
    out.push_str(&String::from_utf8(w.into_inner()?)?);
    Ok(out)
}

/// A series' points and their error bars.
type Points = (Vec<(f64, f64)>, Vec<f64>);

/// The residual plot: every reading's residual with its 1 σ, positions in order, x, y, z.
#[must_use]
pub fn residual_figure(stem: &str, t: &Triad, default_sigma: Option<f64>) -> Figure {
    let mut series = Vec::new();
    let mut labels = Vec::new();
    let mut at = 0usize;
    let mut per_axis: [Points; 3] = Default::default();
    for (i, p) in t.positions.iter().enumerate() {
        for j in 0..3 {
            if let Some(r) = t.residuals[i][j] {
                #[allow(clippy::cast_precision_loss)]
                per_axis[j].0.push((at as f64, r));
                per_axis[j].1.push(reading_sigma(t, i, j, default_sigma));
                labels.push(format!("{} {}", p.label, AXES[j]));
                at += 1;
            }
        }
    }
    for (j, (pts, bars)) in per_axis.into_iter().enumerate() {
        if !pts.is_empty() {
            series.push(
                Series::crosses(&format!("axis {} ± 1 σ", AXES[j]), pts).with_error_bars(bars),
            );
        }
    }
    Figure::single(
        stem,
        Plot {
            title: format!("{stem}: each reading's residual against the triad's model, ± 1 σ"),
            x_label: "reading".into(),
            y_label: "measured − fitted, cm/s²".into(),
            series,
            x_axis: XAxis::Rows(labels),
            zero_line: true,
        },
    )
}

/// Write the sheet folder `dir` whole (a staged folder renamed into place); `replace`
/// (`--force`) replaces an earlier sheet.
///
/// # Errors
/// The folder exists and may not be replaced (`discovery::sheet::check_target`); a file
/// cannot be written (nothing appears then).
pub fn write(dir: &Path, replace: bool, s: &Inputs<'_>, t: &Triad) -> Result<Vec<PathBuf>> {
    check_target(dir, replace)?;
    let name = file_name(dir);
    let staged = StagedDir::new(dir)?;
    let plot_stem = format!("{name}-residuals");
    let mut files = crate::output::write_figure(
        staged.path(),
        &residual_figure(&plot_stem, t, s.default_sigma_cm_s2),
    )?;
    let md = staged.path().join(format!("{name}.md"));
    crate::output::write_atomic(&md, markdown(s, t, &format!("{plot_stem}.svg")).as_bytes())?;
    let csv_path = staged.path().join(format!("{name}.csv"));
    crate::output::write_atomic(&csv_path, csv(s, t)?.as_bytes())?;
    files.extend([md, csv_path]);
    let dir = staged
        .commit()
        .with_context(|| format!("--sheet {}", dir.display()))?;
    Ok(files
        .iter()
        .filter_map(|f| f.file_name().map(|n| dir.join(n)))
        .collect())
}
