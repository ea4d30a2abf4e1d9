//! Showing a result: the text report, the per-row CSV table, the plots (PNG and SVG).

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;

use super::fit::TEST_STATEMENT;
use super::outcome::Discovery;
use super::report::{FitSummary, RowResult};
use crate::model::condition::RowKind;
use crate::model::effects::CandidateId;
use crate::output::{Figure, Output, Plot, Series, Table, XAxis, num, opt, text};

fn names(ids: &[CandidateId]) -> String {
    if ids.is_empty() {
        return "none".to_string();
    }
    ids.iter()
        .map(|&i| i.info().name)
        .collect::<Vec<_>>()
        .join(", ")
}

/// `value ± se` with as many digits as the standard error warrants (two significant digits
/// of the error), in scientific notation when the magnitude calls for it.
#[must_use]
pub fn estimate(value: f64, se: f64) -> String {
    let mag = value.abs().max(se.abs());
    if !(mag.is_finite()) || mag == 0.0 {
        return format!("{value} ± {se}");
    }
    if !(1e-3..1e6).contains(&mag) {
        let e = mag.log10().floor();
        let scale = 10f64.powf(e);
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let d = if se > 0.0 {
            ((scale / se).log10().ceil() + 1.0).clamp(1.0, 8.0) as usize
        } else {
            4
        };
        return format!("{:.d$}e{e} ± {:.d$}e{e}", value / scale, se / scale);
    }
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let d = if se > 0.0 {
        (1.0 - se.log10().floor()).clamp(0.0, 9.0) as usize
    } else {
        4
    };
    format!("{value:.d$} ± {se:.d$}")
}

/// `n thing` or `n things`.
fn count(n: usize, thing: &str) -> String {
    if n == 1 {
        format!("1 {thing}")
    } else {
        format!("{n} {thing}s")
    }
}

/// Human-readable report of one analysis: its sections in order, each a function below.
#[must_use]
pub fn text_report(source: &str, d: &Discovery) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "discover: {source} ({}, {} simulator)",
        count(d.json.rows, "fitted row"),
        d.simulator
    );
    let sections: [fn(&mut String, &Discovery); 11] = [
        warnings,
        rows,
        baseline_noise_nuisance,
        not_tested,
        gross_errors,
        selection,
        selected,
        extended,
        calibration_and_advice,
        unexplained,
        gain_and_verdict,
    ];
    for section in sections {
        section(&mut s, d);
    }
    s
}

/// The run's warnings.
fn warnings(s: &mut String, d: &Discovery) {
    let j = &d.json;
    for w in &j.warnings {
        let _ = writeln!(s, "warning: {w}");
    }
}

/// The row table: measured, baseline and extended, with the residuals.
fn rows(s: &mut String, d: &Discovery) {
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
            "{:<48} {m} {:7.3} {:9.3} {rb} {:9.3} {re}{}",
            truncate(&r.label, 48),
            r.sigma_cm_s2,
            nz(r.baseline_cm_s2),
            nz(r.extended_cm_s2),
            match (r.outlier, d.options.keep_outliers) {
                (false, _) => "",
                (true, false) => "  <- suspected gross error, set aside",
                (true, true) => "  <- suspected gross error, kept",
            }
        );
    }
}

/// The baseline's fit, the noise and the nuisance terms.
fn baseline_noise_nuisance(s: &mut String, d: &Discovery) {
    let j = &d.json;
    let _ = writeln!(
        s,
        "\nbaseline: {}, chi2 {:.2} for {} dof (p = {})",
        rms_text(&j.baseline),
        j.baseline.chi2,
        j.baseline.dof,
        pfmt(j.baseline.p_value)
    );
    let noise = &j.noise;
    let _ = writeln!(
        s,
        "noise: {}{}",
        match noise.source {
            "stated" => "sigma as stated (sigma_cm_s2 or --sigma)".to_string(),
            src => format!(
                "sigma estimated from the {src}: {}",
                noise
                    .sigma_cm_s2
                    .iter()
                    .map(|(g, v)| format!("{g} {v:.3} cm/s²"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        },
        noise
            .caveat
            .as_deref()
            .map_or_else(String::new, |c| format!(" ({c})"))
    );
    let nu = &j.nuisance;
    let mut parts: Vec<String> = nu
        .bias_shift_cm_s2
        .iter()
        .map(|(b, v)| format!("bias shift {b} {v:+.3} cm/s²"))
        .collect();
    if let Some(v) = nu.drift_cm_s2_per_s {
        parts.push(format!("drift {v:+.3e} cm/s² per s"));
    }
    if let Some(v) = nu.drift_cm_s2_per_row {
        parts.push(format!("drift {v:+.4} cm/s² per row"));
    }
    let _ = writeln!(
        s,
        "nuisance terms (always in the model, never discoveries): {}",
        if parts.is_empty() {
            "none".to_string()
        } else {
            parts.join(", ")
        }
    );
}

/// The candidates these rows cannot test, and those that cannot be told apart.
fn not_tested(s: &mut String, d: &Discovery) {
    let unseen: Vec<CandidateId> = d
        .untestable
        .iter()
        .copied()
        .filter(|id| !d.untoleranced.contains(id))
        .collect();
    if !unseen.is_empty() {
        let _ = writeln!(
            s,
            "not testable here (no signature in this data set): {}",
            names(&unseen)
        );
    }
    if !d.untoleranced.is_empty() {
        let _ = writeln!(
            s,
            "not candidates (the instrument file gives them no tolerance): {}",
            names(&d.untoleranced)
        );
    }
    if !d.untestable_nuisance.is_empty() {
        let _ = writeln!(
            s,
            "not testable here (spanned by the nuisance terms): {}",
            names(&d.untestable_nuisance)
        );
    }
    for g in &d.confounded_groups {
        let _ = writeln!(
            s,
            "indistinguishable here (|cos| > {}): {}",
            d.options.confound_cos,
            names(g)
        );
    }
}

/// The suspected gross errors.
fn gross_errors(s: &mut String, d: &Discovery) {
    let j = &d.json;
    if j.outliers.is_empty() {
        let _ = writeln!(
            s,
            "suspected gross errors: none (each value against the model selected without it, externally studentized, familywise {})",
            super::outliers::ALPHA
        );
    } else {
        for o in &j.outliers {
            let _ = writeln!(
                s,
                "suspected gross error: `{}` residual {} cm/s² ({} σ), p = {} over {} rows (familywise), {}",
                o.row,
                crate::output::significant(o.residual_cm_s2, 4),
                crate::output::significant(o.studentized.abs(), 3),
                pfmt(o.p_value),
                o.rows_tested,
                if o.kept {
                    "kept in the fit (--keep-outliers)"
                } else {
                    "set aside: the selection below is made without it (--keep-outliers keeps it)"
                }
            );
        }
    }
}

/// The test, the family and the steps of the selection.
fn selection(s: &mut String, d: &Discovery) {
    let j = &d.json;
    let _ = writeln!(s, "test: {TEST_STATEMENT}");
    if d.family.is_empty() {
        let _ = writeln!(s, "family: empty: nothing could be tested in these rows");
    } else {
        let profiled = d.family.iter().filter(|c| c.profiled()).count();
        let _ = writeln!(
            s,
            "family: {}{}: {}",
            if d.family_size == 1 {
                "1 hypothesis".to_string()
            } else {
                format!("{} hypotheses", d.family_size)
            },
            if profiled > 1 {
                format!(
                    " (the warm-up's {profiled} time constants one of them, its p-value corrected for the search over τ)"
                )
            } else {
                String::new()
            },
            names(&d.family)
        );
    }
    for st in &d.steps {
        let name = match st.replaces {
            Some(old) => format!("{} -> {}", old.info().name, st.id.info().name),
            None => st.id.info().name.to_string(),
        };
        let _ = writeln!(
            s,
            "  {} {:<20} delta chi2 {:8.2}  p = {} (level {})",
            match (st.added, st.replaces) {
                (_, Some(_)) => "swap",
                (true, None) => "add ",
                (false, None) => "drop",
            },
            name,
            st.delta_chi2,
            pfmt(st.p_value),
            pfmt(st.threshold)
        );
        if let Some(note) = &st.note {
            let _ = writeln!(s, "       ({note})");
        }
    }
    if d.selected.is_empty() && !d.family.is_empty() {
        let _ = writeln!(
            s,
            "selected: none (no candidate is significant at familywise 5%)"
        );
    }
    if !d.selected.is_empty() && j.calibration.is_some() {
        let _ = writeln!(
            s,
            "selected terms, each as its change from the instrument file in the selection's fit (the reading's convention); the instrument's values are the calibration's, below:"
        );
    }
}

/// Each selected term with its value, rivals and marks.
fn selected(s: &mut String, d: &Discovery) {
    for sel in &d.selected {
        let c = sel.id.info();
        let conf: Vec<&str> = sel.confounded.iter().map(|&(o, _)| o.info().name).collect();
        if let Some(p) = &sel.parameter {
            let _ = writeln!(
                s,
                "selected: {}{}{}{}",
                p.sentence(c.name, c.unit),
                if conf.is_empty() {
                    String::new()
                } else {
                    format!("  (indistinguishable here from: {})", conf.join(", "))
                },
                if sel.search_limit.is_some() {
                    "  AT THE END OF THE SEARCH GRID (see the warning)"
                } else {
                    ""
                },
                marks(sel)
            );
            continue;
        }
        // The model equation's symbol beside the candidate's key: one name per term, as
        // the calibration's table gives both.
        let symbol = super::calibration::TERMS
            .iter()
            .find(|t| t.candidate == sel.id)
            .map_or(String::new(), |t| format!(" ({})", t.symbol));
        let _ = writeln!(
            s,
            "selected: {} {}{symbol} = {} {}{}{}{}",
            c.effect,
            c.key,
            estimate(sel.coef, sel.stderr),
            c.unit,
            if conf.is_empty() {
                String::new()
            } else {
                format!("  (indistinguishable here from: {})", conf.join(", "))
            },
            if sel.plausible {
                String::new()
            } else {
                format!(
                    "  BEYOND THE CLASS'S BOUND (±{} {}): the part is out of its class, or the bound is not this part's",
                    crate::output::significant(d.options.limits[sel.id.index()], 4),
                    c.unit
                )
            },
            marks(sel)
        );
        if let Some(t) = &sel.time_constant {
            let _ = writeln!(
                s,
                "  time constant τ = {} s (95 %: {} to {} s, the profile of chi2 over τ with the other terms refitted); amplitude there A = {} cm/s² (τ's uncertainty included){}",
                crate::output::significant(t.tau_s, 3),
                t.interval_s
                    .0
                    .map_or("below the search's 1/64 of the span".to_string(), |v| {
                        crate::output::significant(v, 3)
                    }),
                t.interval_s
                    .1
                    .map_or("beyond twice the span".to_string(), |v| {
                        crate::output::significant(v, 3)
                    }),
                estimate(t.amplitude_cm_s2, t.amplitude_se_cm_s2),
                t.grid_tau_s.map_or(String::new(), |g| format!(
                    "; the model holds {} at the grid's τ = {} s",
                    c.key,
                    crate::output::significant(g, 3)
                ))
            );
        }
    }
}

/// The extended model's fit and, without a calibration, its model equation.
fn extended(s: &mut String, d: &Discovery) {
    let j = &d.json;
    let e = &j.extended;
    let _ = writeln!(
        s,
        "extended: {}, chi2 {:.2} for {} dof (p = {}): {}",
        rms_text(e),
        e.chi2,
        e.dof,
        pfmt(e.p_value),
        if e.p_value >= 0.05 {
            "the rest is consistent with the noise"
        } else {
            "the rest is NOT consistent with the noise"
        }
    );
    // The selection's terms as a model equation, only where there is no calibration: with
    // one, the calibration below is the instrument's model equation, and a second set of
    // values in another convention would only be confused with it.
    if !j.model_equation.terms.is_empty() && j.calibration.is_none() {
        let _ = writeln!(
            s,
            "model equation (IEEE Std 1293 units, 1 σ): {}",
            j.model_equation
                .terms
                .iter()
                .map(|t| format!("{} = {} {}", t.symbol, estimate(t.value, t.sigma), t.unit))
                .collect::<Vec<_>>()
                .join("; ")
        );
        if j.model_equation.terms.len() > 1 {
            let _ = writeln!(
                s,
                "  correlation: {}",
                j.model_equation
                    .correlation
                    .iter()
                    .map(|r| format!(
                        "[{}]",
                        r.iter()
                            .map(|x| format!("{x:+.2}"))
                            .collect::<Vec<_>>()
                            .join(" ")
                    ))
                    .collect::<Vec<_>>()
                    .join(" ")
            );
        }
    }
}

/// The calibration and the advice.
fn calibration_and_advice(s: &mut String, d: &Discovery) {
    let j = &d.json;
    if let Some(c) = j
        .calibration
        .as_ref()
        .filter(|c| c.terms.iter().any(|t| t.measured))
    {
        s.push_str(&super::calibration::text_block(c));
    }
    for a in &j.advice {
        let _ = writeln!(s, "advice: {}", a.note);
        for r in &a.rows {
            let _ = writeln!(s, "  add: {}", r.label);
        }
    }
}

/// The search for structure the model does not explain.
fn unexplained(s: &mut String, d: &Discovery) {
    let j = &d.json;
    let u = &j.unexplained;
    if u.tests.is_empty() {
        let _ = writeln!(
            s,
            "unexplained structure: not tested (no replicated rows for a lack-of-fit test and no varying input for the generic basis); the extended model's chi2 above is the only check"
        );
    } else {
        let _ = writeln!(
            s,
            "unexplained structure: {} (p = {}; {})",
            if u.detected {
                format!("YES, {}", u.hint)
            } else {
                "none found".to_string()
            },
            pfmt(u.p_value),
            u.tests
                .iter()
                .map(|t| format!("{} p = {}", t.name, pfmt(t.p_value)))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    for p in &u.proposals {
        let _ = writeln!(
            s,
            "  proposal (a form the residual follows, not a cause): {} × {:.4e} ± {:.2e} {} (p = {}, {}){}",
            p.form,
            p.coefficient,
            p.se,
            p.unit,
            pfmt(p.p_value),
            p.family,
            if p.indistinguishable_from.is_empty() {
                String::new()
            } else {
                format!(
                    "; indistinguishable here from {}",
                    p.indistinguishable_from.join(", ")
                )
            }
        );
    }
    for t in &u.terms {
        let _ = match (t.coefficient, t.se, t.p_value) {
            (Some(c), Some(e), Some(pv)) => writeln!(
                s,
                "{}: {:.4e} ± {:.2e} {} (p = {} as a step after the selection, {})",
                t.key,
                c,
                e,
                t.unit,
                pfmt(pv),
                if t.significant {
                    "significant"
                } else {
                    "not significant"
                }
            ),
            _ => writeln!(
                s,
                "{}: not testable here (0 in every fitted row, or a combination of the model's terms)",
                t.key
            ),
        };
    }
}

/// The out-of-sample gain and the verdict.
fn gain_and_verdict(s: &mut String, d: &Discovery) {
    let j = &d.json;
    let g = &j.gain;
    let _ = writeln!(
        s,
        "gain ({}): RMS in sample {:.3}, cross-validated {:.3} against {:.3} for the baseline with its nuisance terms, {}; gain 95 % interval [{:.3}, {:.3}]",
        g.method,
        g.rms_in_sample_cm_s2,
        g.rms_cross_validated_cm_s2,
        g.baseline_rms_cross_validated_cm_s2,
        g.unit,
        g.ci95_rms_cm_s2[0],
        g.ci95_rms_cm_s2[1]
    );
    let _ = writeln!(s, "verdict: {}", j.verdict);
}

/// `x`, with values that print as ±0.000 made +0 (no "-0.000" in the table).
fn nz(x: f64) -> f64 {
    if x.abs() < 5e-4 { 0.0 } else { x }
}

/// The selected line's marks: the forms outside the vocabulary it cannot be told from, and
/// whether its coefficient disagrees between parts of the data.
fn marks(sel: &super::problem::Selected) -> String {
    let mut m = String::new();
    if sel.companion {
        m.push_str(
            "  (fitted with the warm-up as the level it settles to: not a cause of its own)",
        );
    }
    if !sel.rivals.is_empty() {
        let forms: Vec<&str> = sel.rivals.iter().map(|r| r.form.as_str()).collect();
        let _ = write!(
            m,
            "  (indistinguishable here from {}, outside the vocabulary: see the warning)",
            forms.join(", ")
        );
    }
    if sel.stable == Some(false) {
        m.push_str(
            "  NOT STABLE between parts of the data (see the warning): not given as the cause",
        );
    }
    m
}

/// A probability for humans: 3 decimals, or scientific below 0.001.
pub(crate) fn pfmt(p: f64) -> String {
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

/// The per-row table (`<stem>.csv`): label, measured, sigma, baseline, extended and both
/// residuals, cm/s².
#[must_use]
pub fn row_table(stem: &str, d: &Discovery) -> Table {
    let mut t = Table::new(
        stem,
        &format!("{stem}: measured, baseline and extended per row (cm/s²)"),
        &[
            "label",
            "measured_cm_s2",
            "sigma_cm_s2",
            "baseline_cm_s2",
            "extended_cm_s2",
            "residual_baseline_cm_s2",
            "residual_extended_cm_s2",
        ],
    );
    for r in &d.table {
        let m = r.measured_cm_s2;
        t.rows.push(vec![
            text(r.label.clone()),
            opt(m, 3),
            num(r.sigma_cm_s2, 3),
            num(r.baseline_cm_s2, 3),
            num(r.extended_cm_s2, 3),
            opt(m.map(|m| m - r.baseline_cm_s2), 3),
            opt(m.map(|m| m - r.extended_cm_s2), 3),
        ]);
    }
    t
}

/// The figure of the rows measured in cm/s² (difference and absolute rows): measured ±
/// sigma with the baseline and the extended model per row, then the residuals before and
/// after. `None` when there are no such rows.
#[must_use]
pub fn figure(stem: &str, d: &Discovery) -> Option<Figure> {
    let rows: Vec<&RowResult> = d
        .table
        .iter()
        .filter(|r| r.quantity == "value_cm_s2")
        .collect();
    if rows.is_empty() {
        return None;
    }
    let labels: Vec<String> = rows.iter().map(|r| r.label.clone()).collect();
    let few = labels.len() <= 12;
    #[allow(clippy::cast_precision_loss)]
    let at = |i: usize| i as f64;
    let per_row = |f: &dyn Fn(&RowResult) -> Option<f64>| -> Vec<(f64, f64)> {
        rows.iter()
            .enumerate()
            .filter_map(|(i, r)| f(r).map(|v| (at(i), v)))
            .collect()
    };
    let base = per_row(&|r| Some(r.baseline_cm_s2));
    let ext = per_row(&|r| Some(r.extended_cm_s2));
    let meas = per_row(&|r| r.measured_cm_s2);
    let sig: Vec<f64> = rows
        .iter()
        .filter(|r| r.measured_cm_s2.is_some())
        .map(|r| r.sigma_cm_s2)
        .collect();
    let (b, e) = if few {
        (
            Series::line("baseline", base),
            Series::line("extended", ext),
        )
    } else {
        (
            Series::markers("baseline", base),
            Series::triangles("extended", ext),
        )
    };
    let has = |k: RowKind| rows.iter().any(|r| r.kind == k);
    let y_label = match (has(RowKind::Difference), has(RowKind::Absolute)) {
        (true, true) => "condition − reference, or indicated (absolute rows), cm/s²",
        (false, true) => "mean indicated acceleration, cm/s²",
        _ => "condition − reference, cm/s²",
    };
    let top = Plot {
        title: format!("{stem}: measured, baseline and extended"),
        x_label: if few {
            "row (label)"
        } else {
            "row (1 = first data row)"
        }
        .into(),
        y_label: y_label.into(),
        series: vec![
            Series::crosses("measured ± sigma", meas).with_error_bars(sig),
            b,
            e,
        ],
        x_axis: XAxis::Rows(labels.clone()),
        zero_line: false,
    };
    let before = per_row(&|r| r.measured_cm_s2.map(|m| m - r.baseline_cm_s2));
    let after = per_row(&|r| r.measured_cm_s2.map(|m| m - r.extended_cm_s2));
    let bottom = Plot {
        title: "residuals: measured − baseline, measured − extended".into(),
        x_label: top.x_label.clone(),
        y_label: "residual, cm/s²".into(),
        series: vec![
            Series::markers(
                "before (baseline)",
                before.into_iter().map(|(x, y)| (x - 0.1, y)).collect(),
            ),
            Series::triangles(
                "after (extended)",
                after.into_iter().map(|(x, y)| (x + 0.1, y)).collect(),
            ),
        ],
        x_axis: XAxis::Rows(labels),
        zero_line: true,
    };
    Some(Figure {
        stem: stem.into(),
        panels: vec![top, bottom],
    })
}

/// The figure of the response rows, `<stem>-bode`: gain and phase against frequency
/// (measured ± sigma, the closed loop's baseline and extended predictions at the measured
/// frequencies, and the linear loop model's Bode curves without and with the fitted
/// parameters), then the residuals of gain and phase over their sigmas before and after.
/// `None` without response rows.
#[must_use]
pub fn response_figure(stem: &str, d: &Discovery) -> Option<Figure> {
    let of = |q: &str| -> Vec<&RowResult> {
        d.table
            .iter()
            .filter(|r| r.quantity == q && r.freq_hz.is_some())
            .collect()
    };
    let (gain, phase) = (of("gain"), of("phase_deg"));
    if gain.is_empty() && phase.is_empty() {
        return None;
    }
    let corrected = d.selected.iter().any(|s| s.parameter.is_some());
    let panel = |rows: &[&RowResult], k: usize, title: &str, y: &str| -> Plot {
        let pts = |f: &dyn Fn(&RowResult) -> Option<f64>| -> Vec<(f64, f64)> {
            rows.iter()
                .filter_map(|r| Some((r.freq_hz?, f(r)?)))
                .collect()
        };
        let measured: Vec<&&RowResult> =
            rows.iter().filter(|r| r.measured_cm_s2.is_some()).collect();
        let mut series = vec![
            Series::crosses("measured ± sigma", pts(&|r| r.measured_cm_s2))
                .with_error_bars(measured.iter().map(|r| r.sigma_cm_s2).collect()),
            Series::markers(
                "closed loop, instrument file",
                pts(&|r| Some(r.baseline_cm_s2)),
            ),
            Series::triangles("closed loop, extended", pts(&|r| Some(r.extended_cm_s2))),
        ];
        if !d.bode.is_empty() {
            series.push(Series::line(
                "linear model, instrument file",
                d.bode.iter().map(|b| (b.freq_hz, b.nominal[k])).collect(),
            ));
            if corrected {
                series.push(Series::line(
                    "linear model, fitted parameters",
                    d.bode.iter().map(|b| (b.freq_hz, b.corrected[k])).collect(),
                ));
            }
        }
        Plot {
            title: title.into(),
            x_label: "input frequency, Hz".into(),
            y_label: y.into(),
            series,
            x_axis: XAxis::Log,
            zero_line: false,
        }
    };
    let resid = |rows: &[&RowResult], name: &str, y: &str| -> Plot {
        let pts = |f: &dyn Fn(&RowResult) -> Option<f64>| -> Vec<(f64, f64)> {
            rows.iter()
                .filter_map(|r| Some((r.freq_hz?, f(r)? / r.sigma_cm_s2)))
                .collect()
        };
        Plot {
            title: format!(
                "{name} residuals over sigma: before (instrument file) and after (extended)"
            ),
            x_label: "input frequency, Hz".into(),
            y_label: y.into(),
            series: vec![
                Series::markers("before", pts(&|r| r.residual_cm_s2)),
                Series::triangles("after", pts(&|r| r.residual_extended_cm_s2)),
            ],
            x_axis: XAxis::Log,
            zero_line: true,
        }
    };
    let mut panels = Vec::new();
    if !gain.is_empty() {
        panels.push(panel(
            &gain,
            0,
            &format!("{stem}: closed-loop gain"),
            "gain (output amplitude / input amplitude)",
        ));
    }
    if !phase.is_empty() {
        panels.push(panel(
            &phase,
            1,
            &format!("{stem}: closed-loop phase"),
            "phase (output − input), deg",
        ));
    }
    if !gain.is_empty() {
        panels.push(resid(&gain, "gain", "gain residual / sigma"));
    }
    if !phase.is_empty() {
        panels.push(resid(&phase, "phase", "phase residual / sigma"));
    }
    Some(Figure {
        stem: format!("{stem}-bode"),
        panels,
    })
}

/// The table and the figure of one analysis, as an [`Output`].
#[must_use]
pub fn output(stem: &str, d: &Discovery) -> Output {
    Output {
        tables: vec![row_table(stem, d)],
        plots: [figure(stem, d), response_figure(stem, d)]
            .into_iter()
            .flatten()
            .collect(),
        notes: Vec::new(),
    }
}

/// Write `<stem>.csv`, `<stem>.png` and `<stem>.svg` into `dir`.
///
/// # Errors
/// The directory or a file cannot be written.
pub fn write_outputs(dir: &Path, stem: &str, d: &Discovery) -> Result<Vec<std::path::PathBuf>> {
    output(stem, d).write_files(dir)
}

/// `RMS 0.123 cm/s²`, or with response rows only `RMS 1.23 σ (residual over its
/// uncertainty)`.
fn rms_text(f: &FitSummary) -> String {
    if f.rms_cm_s2.is_finite() {
        format!("RMS {:.3} cm/s²", f.rms_cm_s2)
    } else {
        format!(
            "RMS {:.3} σ (each residual over its uncertainty)",
            f.rms_normalised
        )
    }
}
