//! Showing a result: the text report, the per-row CSV table, the plots (PNG and SVG), and
//! the section of the no-argument report that analyses Tables 6.1–6.3.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};
use plotters::prelude::*;

use super::caseframe::write_atomic;
use super::method::{CANDIDATES, Discovery, Options, TEST_STATEMENT, discover};
use super::report_data;
use super::sim::Simulator;

fn names(idx: &[usize]) -> String {
    if idx.is_empty() {
        return "none".to_string();
    }
    idx.iter()
        .map(|&i| CANDIDATES[i].name)
        .collect::<Vec<_>>()
        .join(", ")
}

/// Human-readable report of one analysis.
#[must_use]
pub fn text_report(source: &str, d: &Discovery) -> String {
    let mut s = String::new();
    let j = &d.json;
    let _ = writeln!(
        s,
        "discover: {source} ({} fitted rows, {} simulator)",
        j.rows, d.simulator
    );
    let _ = writeln!(
        s,
        "\n{:<48} {:>9} {:>7} {:>9} {:>9} {:>9} {:>9}",
        "row", "measured", "sigma", "baseline", "resid", "extended", "resid"
    );
    for r in &d.table {
        let (m, rb, re) = match r.measured_cm_s2 {
            Some(m) => (
                format!("{m:9.3}"),
                format!("{:9.3}", nz(m - r.baseline_cm_s2)),
                format!("{:9.3}", nz(m - r.extended_cm_s2)),
            ),
            None => ("        -".into(), "        -".into(), "        -".into()),
        };
        let _ = writeln!(
            s,
            "{:<48} {m} {:7.3} {:9.3} {rb} {:9.3} {re}",
            truncate(&r.label, 48),
            r.sigma_cm_s2,
            nz(r.baseline_cm_s2),
            nz(r.extended_cm_s2)
        );
    }
    let _ = writeln!(
        s,
        "\nbaseline: RMS {:.3} cm/s², chi2 {:.2} for {} dof (p = {})",
        j.baseline.rms_cm_s2,
        j.baseline.chi2,
        j.baseline.dof,
        pfmt(j.baseline.p_value)
    );
    let _ = writeln!(
        s,
        "not testable here (no signature in this data set): {}",
        names(&d.untestable)
    );
    for g in &d.confounded_groups {
        let _ = writeln!(
            s,
            "indistinguishable here (|cos| > {}): {}",
            d.options.confound_cos,
            names(g)
        );
    }
    let _ = writeln!(
        s,
        "test: {TEST_STATEMENT}; family of {} candidates",
        d.family_size
    );
    for st in &d.steps {
        let _ = writeln!(
            s,
            "  {} {:<20} delta chi2 {:8.2}  p = {} (level {})",
            if st.added { "add " } else { "drop" },
            CANDIDATES[st.idx].name,
            st.delta_chi2,
            pfmt(st.p_value),
            pfmt(st.threshold)
        );
    }
    if d.selected.is_empty() {
        let _ = writeln!(
            s,
            "selected: none (no candidate is significant at familywise 5%)"
        );
    }
    for sel in &d.selected {
        let c = CANDIDATES[sel.idx];
        let conf: Vec<&str> = sel
            .confounded
            .iter()
            .map(|&(o, _)| CANDIDATES[o].name)
            .collect();
        let _ = writeln!(
            s,
            "selected: {} {} = {:.4} ± {:.4}{}",
            c.effect,
            c.key,
            sel.coef,
            sel.stderr,
            if conf.is_empty() {
                String::new()
            } else {
                format!("  (indistinguishable here from: {})", conf.join(", "))
            }
        );
    }
    let e = &j.extended;
    let _ = writeln!(
        s,
        "extended: RMS {:.3} cm/s², chi2 {:.2} for {} dof (p = {}): {}",
        e.rms_cm_s2,
        e.chi2,
        e.dof,
        pfmt(e.p_value),
        if e.p_value >= 0.05 {
            "the rest is consistent with the noise"
        } else {
            "the rest is NOT consistent with the stated noise"
        }
    );
    s
}

/// `x`, with values that print as ±0.000 made +0 (no "-0.000" in the table).
fn nz(x: f64) -> f64 {
    if x.abs() < 5e-4 { 0.0 } else { x }
}

/// A probability for humans: 3 decimals, or scientific below 0.001.
fn pfmt(p: f64) -> String {
    if p < 1e-3 {
        format!("{p:.2e}")
    } else {
        format!("{p:.3}")
    }
}

fn truncate(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_string()
    } else {
        s.chars().take(n - 1).collect::<String>() + "…"
    }
}

/// Per-row CSV table.
#[must_use]
pub fn table_csv(d: &Discovery) -> String {
    let mut s = String::from(
        "label,measured_cm_s2,sigma_cm_s2,baseline_cm_s2,extended_cm_s2,residual_baseline_cm_s2,residual_extended_cm_s2\n",
    );
    for r in &d.table {
        let q = if r.label.contains([',', '"']) {
            format!("\"{}\"", r.label.replace('"', "\"\""))
        } else {
            r.label.clone()
        };
        let (m, rb, re) =
            r.measured_cm_s2
                .map_or((String::new(), String::new(), String::new()), |m| {
                    (
                        format!("{m}"),
                        format!("{}", m - r.baseline_cm_s2),
                        format!("{}", m - r.extended_cm_s2),
                    )
                });
        let _ = writeln!(
            s,
            "{q},{m},{},{},{},{rb},{re}",
            r.sigma_cm_s2, r.baseline_cm_s2, r.extended_cm_s2
        );
    }
    s
}

/// Register a system TrueType font for the PNG backend once; false if none was found.
fn font_ready() -> bool {
    use std::sync::OnceLock;
    static OK: OnceLock<bool> = OnceLock::new();
    *OK.get_or_init(|| {
        for p in [
            "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/TTF/DejaVuSans.ttf",
            "/usr/share/fonts/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
        ] {
            if let Ok(bytes) = std::fs::read(p) {
                let leaked: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font("sans-serif", FontStyle::Normal, leaked).is_ok() {
                    return true;
                }
            }
        }
        false
    })
}

/// Write `<stem>.csv`, `<stem>.png` and `<stem>.svg` into `dir`.
///
/// # Errors
/// The directory or a file cannot be written.
pub fn write_outputs(dir: &Path, stem: &str, d: &Discovery) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    write_atomic(&dir.join(format!("{stem}.csv")), &table_csv(d))?;
    // Text needs a TrueType font (ab_glyph); without one the plots are drawn unlabelled.
    let text = font_ready();
    let svg = dir.join(format!("{stem}.svg"));
    draw(
        SVGBackend::new(&svg, (1000, 700)).into_drawing_area(),
        stem,
        d,
        text,
    )
    .map_err(|e| anyhow::anyhow!("{}: {e}", svg.display()))?;
    let png = dir.join(format!("{stem}.png"));
    draw(
        BitMapBackend::new(&png, (1000, 700)).into_drawing_area(),
        stem,
        d,
        text,
    )
    .map_err(|e| anyhow::anyhow!("{}: {e}", png.display()))?;
    Ok(())
}

type DrawResult<T> = std::result::Result<T, Box<dyn std::error::Error>>;

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    d: &Discovery,
    text: bool,
) -> DrawResult<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let (top, bottom) = root.split_vertically(400);
    let rows: Vec<(usize, &super::method::RowResult)> = d.table.iter().enumerate().collect();
    let n = rows.len().max(1);
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for (_, r) in &rows {
        for v in [
            r.measured_cm_s2.unwrap_or(0.0),
            r.baseline_cm_s2,
            r.extended_cm_s2,
        ] {
            lo = lo.min(v - r.sigma_cm_s2);
            hi = hi.max(v + r.sigma_cm_s2);
        }
    }
    if !(hi - lo).is_finite() || hi <= lo {
        lo = -1.0;
        hi = 1.0;
    }
    let pad = 0.1 * (hi - lo);
    // Headroom above the data for the legend box (upper right), so it never hides a point.
    let legend_room = 0.45 * (hi - lo);
    #[allow(clippy::cast_precision_loss)]
    let xmax = n as f64 - 0.5;
    // Ticks at whole rows only; short labels (IA angles, phases) name the rows of small
    // sets, else the 1-based row number of the data file.
    let labels: Vec<&str> = rows.iter().map(|(_, r)| r.label.as_str()).collect();
    let named = n <= 12
        && labels
            .iter()
            .all(|l| !l.is_empty() && l.chars().count() <= 14);
    let row_tick = move |x: &f64| -> String {
        let k = x.round();
        if (x - k).abs() > 1e-6 || k < 0.0 {
            return String::new();
        }
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let i = k as usize;
        match labels.get(i) {
            Some(l) if named => (*l).to_string(),
            Some(_) => (i + 1).to_string(),
            None => String::new(),
        }
    };
    let x_desc = if named {
        "row (label)"
    } else {
        "row (1 = first data row)"
    };
    let blue = RGBColor(31, 119, 180);
    let orange = RGBColor(255, 127, 14);
    let green = RGBColor(44, 160, 44);
    {
        let mut b = ChartBuilder::on(&top);
        b.margin(10);
        if text {
            b.caption(
                format!("{title}: measured, baseline and extended (cm/s²)"),
                ("sans-serif", 20),
            )
            .x_label_area_size(30)
            .y_label_area_size(60);
        }
        let mut chart = b.build_cartesian_2d(-0.5..xmax, (lo - pad)..(hi + pad + legend_room))?;
        let mut mesh = chart.configure_mesh();
        mesh.disable_x_mesh();
        if text {
            mesh.x_desc(x_desc)
                .x_labels(n + 1)
                .x_label_formatter(&row_tick)
                .y_label_formatter(&crate::output::value_tick(
                    hi - lo + 2.0 * pad + legend_room,
                ))
                .y_desc("condition − reference, cm/s²")
                .draw()?;
        } else {
            mesh.disable_y_mesh().x_labels(0).y_labels(0).draw()?;
        }
        #[allow(clippy::cast_precision_loss)]
        let pts = |f: &dyn Fn(&super::method::RowResult) -> Option<f64>| -> Vec<(f64, f64)> {
            rows.iter()
                .filter_map(|(i, r)| f(r).map(|v| (*i as f64, v)))
                .collect()
        };
        let base = pts(&|r| Some(r.baseline_cm_s2));
        let ext = pts(&|r| Some(r.extended_cm_s2));
        let meas = pts(&|r| r.measured_cm_s2);
        let s = chart.draw_series(LineSeries::new(base.clone(), orange.stroke_width(2)))?;
        if text {
            s.label("baseline")
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], orange));
        }
        chart.draw_series(base.iter().map(|&p| Circle::new(p, 3, orange.filled())))?;
        let s = chart.draw_series(LineSeries::new(ext.clone(), green.stroke_width(2)))?;
        if text {
            s.label("extended")
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], green));
        }
        chart.draw_series(
            ext.iter()
                .map(|&p| TriangleMarker::new(p, 4, green.filled())),
        )?;
        #[allow(clippy::cast_precision_loss)]
        chart.draw_series(rows.iter().filter_map(|(i, r)| {
            r.measured_cm_s2.map(|m| {
                PathElement::new(
                    vec![
                        (*i as f64, m - r.sigma_cm_s2),
                        (*i as f64, m + r.sigma_cm_s2),
                    ],
                    blue,
                )
            })
        }))?;
        let s = chart.draw_series(meas.iter().map(|&p| Cross::new(p, 5, blue.stroke_width(2))))?;
        if text {
            s.label("measured ± sigma")
                .legend(move |(x, y)| Cross::new((x + 10, y), 5, blue));
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()?;
        }
    }
    {
        let res: Vec<(usize, f64, f64, f64)> = rows
            .iter()
            .filter_map(|(i, r)| {
                r.measured_cm_s2.map(|m| {
                    (
                        *i,
                        m - r.baseline_cm_s2,
                        m - r.extended_cm_s2,
                        r.sigma_cm_s2,
                    )
                })
            })
            .collect();
        let mut rl = res
            .iter()
            .map(|r| r.1.min(r.2) - r.3)
            .fold(f64::INFINITY, f64::min);
        let mut rh = res
            .iter()
            .map(|r| r.1.max(r.2) + r.3)
            .fold(f64::NEG_INFINITY, f64::max);
        if !(rh - rl).is_finite() || rh <= rl {
            rl = -1.0;
            rh = 1.0;
        }
        let mut b = ChartBuilder::on(&bottom);
        b.margin(10);
        if text {
            b.caption(
                "residuals: measured − baseline, measured − extended",
                ("sans-serif", 18),
            )
            .x_label_area_size(30)
            .y_label_area_size(60);
        }
        let pad = 0.1 * (rh - rl);
        let room = 0.45 * (rh - rl);
        let mut chart = b.build_cartesian_2d(-0.5..xmax, (rl - pad)..(rh + pad + room))?;
        let mut mesh = chart.configure_mesh();
        mesh.disable_x_mesh();
        if text {
            mesh.x_desc(x_desc)
                .x_labels(n + 1)
                .x_label_formatter(&row_tick)
                .y_label_formatter(&crate::output::value_tick(rh - rl + 2.0 * pad + room))
                .y_desc("residual, cm/s²")
                .draw()?;
        } else {
            mesh.disable_y_mesh().x_labels(0).y_labels(0).draw()?;
        }
        chart.draw_series(LineSeries::new(vec![(-0.5, 0.0), (xmax, 0.0)], BLACK))?;
        #[allow(clippy::cast_precision_loss)]
        {
            let s = chart.draw_series(
                res.iter()
                    .map(|r| Circle::new((r.0 as f64 - 0.1, r.1), 4, orange.filled())),
            )?;
            if text {
                s.label("before (baseline)")
                    .legend(move |(x, y)| Circle::new((x + 10, y), 4, orange.filled()));
            }
            let s =
                chart
                    .draw_series(res.iter().map(|r| {
                        TriangleMarker::new((r.0 as f64 + 0.1, r.2), 5, green.filled())
                    }))?;
            if text {
                s.label("after (extended)")
                    .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 5, green.filled()));
                chart
                    .configure_series_labels()
                    .position(SeriesLabelPosition::UpperRight)
                    .background_style(WHITE.mix(0.8))
                    .border_style(BLACK)
                    .draw()?;
            }
        }
    }
    root.present()?;
    Ok(())
}

/// The analysis of the report's Tables 6.1, 6.2 and 6.3 as a Markdown section, for the
/// no-argument report. Writes the tables and plots into `out` when given; the Markdown links
/// to the plots relative to `out`'s parent (where the report's summary is expected).
///
/// # Errors
/// The shipped transcriptions are malformed or an output cannot be written.
pub fn report_section(sim: &dyn Simulator, opts: &Options, out: Option<&Path>) -> Result<String> {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "## Discovery: what the baseline model misses in Tables 6.1–6.3\n"
    );
    let _ = writeln!(s, "Method: `docs/discovery.md`. Test: {TEST_STATEMENT}.\n");
    let _ = writeln!(
        s,
        "| data | rows | baseline RMS (cm/s²) | baseline χ² | selected | coefficient ± SE | indistinguishable from | extended RMS | extended χ² (p) |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|");
    let mut details = String::new();
    for (name, _, rows) in report_data::case_files()? {
        let d = discover(&rows, sim, opts)?;
        let j = &d.json;
        let sel = if d.selected.is_empty() {
            ("none".to_string(), "—".to_string(), "—".to_string())
        } else {
            let n: Vec<String> = d
                .selected
                .iter()
                .map(|x| CANDIDATES[x.idx].name.to_string())
                .collect();
            let c: Vec<String> = d
                .selected
                .iter()
                .map(|x| format!("{:.2} ± {:.2} {}", x.coef, x.stderr, CANDIDATES[x.idx].key))
                .collect();
            let f: Vec<String> = d
                .selected
                .iter()
                .flat_map(|x| {
                    x.confounded
                        .iter()
                        .map(|&(o, _)| CANDIDATES[o].name.to_string())
                })
                .collect();
            (
                n.join(", "),
                c.join(", "),
                if f.is_empty() {
                    "—".into()
                } else {
                    f.join(", ")
                },
            )
        };
        let _ = writeln!(
            s,
            "| {name} | {} | {:.3} | {:.2} | {} | {} | {} | {:.3} | {:.2} ({:.2}) |",
            j.rows,
            j.baseline.rms_cm_s2,
            j.baseline.chi2,
            sel.0,
            sel.1,
            sel.2,
            j.extended.rms_cm_s2,
            j.extended.chi2,
            j.extended.p_value
        );
        let _ = writeln!(details, "\n```text\n{}```", text_report(name, &d));
        if let Some(dir) = out {
            let stem = name.trim_end_matches(".case.csv");
            write_outputs(dir, stem, &d)?;
            // The Markdown is meant to sit in `out`'s parent (the report folder).
            let rel = dir.file_name().map_or_else(
                || dir.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            );
            let _ = writeln!(details, "\n![{stem}]({rel}/{stem}.svg)");
        }
    }
    s.push_str(&details);
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::discovery::sim::AnalyticSimulator;

    #[test]
    fn report_section_writes_tables_and_plots() {
        let dir = std::env::temp_dir().join(format!("ptsa-discover-{}", std::process::id()));
        let md = report_section(&AnalyticSimulator, &Options::default(), Some(&dir)).unwrap();
        assert!(md.contains("anisoinertia") && md.contains("lever_arm.r_pa_cm"));
        for stem in ["r890-table-6.1", "r890-table-6.2", "r890-table-6.3"] {
            for ext in ["csv", "png", "svg"] {
                let p = dir.join(format!("{stem}.{ext}"));
                assert!(
                    std::fs::metadata(&p)
                        .map(|m| m.len() > 100)
                        .unwrap_or(false),
                    "{}",
                    p.display()
                );
            }
        }
        if std::env::var_os("PTSA_KEEP_PLOTS").is_none() {
            let _ = std::fs::remove_dir_all(&dir);
        } else {
            eprintln!("{md}\nplots in {}", dir.display());
        }
    }
}
