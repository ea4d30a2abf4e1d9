//! The result in words: the verdict (one paragraph), the warnings (what the user must know
//! before reading the result: the slips' and suspected gross errors' lines first), and a
//! fitted parameter's sentence.

use std::fmt::Write as _;

use super::data::Data;
use super::fit::{Fitted, NoiseSource};
use super::outcome::Discovery;
use super::outliers;
use super::problem::Selected;
use super::report::{EffectReport, FitCheck, OutlierReport, ParameterValue, SplitTest, names};
use super::search::limit_note;
use super::sim::Simulator;
use super::slips;

impl ParameterValue {
    /// `"damping 114 361 ± 511 dyn·cm·s, nominal 76 400, tolerance 45 840 to 106 960: out of
    /// tolerance"`, in words.
    #[must_use]
    pub fn sentence(&self, name: &str, unit: &str) -> String {
        let value = match self.mirror {
            Some(m) => format!(
                "{} {unit} or {} {unit} (the mirror image about the nominal fits as well: these data give the size of the change, not its sign)",
                super::show::estimate(self.fitted, self.sigma),
                super::show::estimate(m, self.sigma)
            ),
            None => format!("{} {unit}", super::show::estimate(self.fitted, self.sigma)),
        };
        format!(
            "{name} {value}, nominal {} {unit}, tolerance {} to {} {unit}: {}",
            self.nominal,
            self.tolerance[0],
            self.tolerance[1],
            if self.within_tolerance {
                "within tolerance"
            } else {
                "OUT OF TOLERANCE"
            }
        )
    }
}

/// The warnings first in the report: an instrument file without a PTSA loop (what the
/// analysis then is), and the slips: each suspected gross error, more of them than the
/// search sets aside, stated sigmas far from the scatter, a search through the closed loop
/// that ended at its grid's end.
pub(crate) fn slip_warnings(
    outliers: &[OutlierReport],
    beyond_cap: Option<(&str, outliers::Found)>,
    sigma: Option<&slips::SigmaSlip>,
    selected: &[Selected],
    sim: &dyn Simulator,
) -> Vec<String> {
    let mut w = Vec::new();
    if let Some(i) = sim.instrument().filter(|i| !i.has_loop) {
        w.push(format!(
            "the instrument file describes an accelerometer without a PTSA loop ({}): the analytic model is used (the model equation of the specific force, no loop dynamics), and no parameter of a loop is a candidate",
            i.display_name()
        ));
    }
    for o in outliers {
        w.push(format!(
            "row `{}` is a suspected gross error: measured {} cm/s², but the model selected without it expects {} (residual {} cm/s², {} σ; p = {} over the {} rows tested, familywise); likely cause: {}; {}",
            o.row,
            crate::output::significant(o.measured_cm_s2, 6),
            super::show::estimate(o.expected_cm_s2, o.sigma_cm_s2),
            crate::output::significant(o.residual_cm_s2, 4),
            crate::output::significant(o.studentized.abs(), 3),
            super::show::pfmt(o.p_value),
            o.rows_tested,
            o.cause,
            if o.kept {
                "kept in the fit (--keep-outliers)"
            } else {
                "the selection is made without it (--keep-outliers keeps it)"
            }
        ));
    }
    if let Some((label, b)) = beyond_cap {
        w.push(format!(
            "more than {} rows look like gross errors: after setting aside {}, row `{label}` still does (p = {}): the model, not a few rows, fails these data; check the file as a whole (a unit or sign slip in part of it, a shifted column, the wrong instrument file)",
            outliers::MAX_OUTLIERS,
            outliers
                .iter()
                .map(|o| format!("`{}`", o.row))
                .collect::<Vec<_>>()
                .join(", "),
            super::show::pfmt(b.p_family)
        ));
    }
    if let Some(s) = sigma {
        w.push(s.message());
    }
    for s in selected {
        if let Some(l) = s.search_limit {
            w.push(limit_note(s.id, l, sim));
        }
    }
    w
}

/// What the user must know before reading the result.
/// The rows that record `approach` where it is not used: difference rows (their reference
/// is read after the same approach, so a hysteresis cancels in the difference) and
/// response rows; a warning naming the first few, or `None`.
pub(crate) fn unused_approach(rows: &[crate::model::condition::Condition]) -> Option<String> {
    let unused: Vec<&str> = rows
        .iter()
        .filter(|r| r.approach.is_some() && r.kind != crate::model::condition::RowKind::Absolute)
        .map(|r| r.label.as_str())
        .collect();
    if unused.is_empty() {
        return None;
    }
    let mut shown: Vec<String> = unused.iter().take(3).map(|l| format!("`{l}`")).collect();
    if unused.len() > 3 {
        shown.push("…".to_string());
    }
    Some(format!(
        "{} record `approach` but {} not absolute ({}): the column is not used there (a difference row's reference is read after the same approach, so a hysteresis cancels in the difference; a response row's gain and phase do not see one); expected `approach` on absolute rows (a tumble or centrifuge position) only",
        crate::output::count(unused.len() as u64, "difference or response row"),
        if unused.len() == 1 {
            "it is"
        } else {
            "they are"
        },
        shown.join(", ")
    ))
}

pub(crate) fn warnings(data: &Data, f: &Fitted, selected: &[Selected]) -> Vec<String> {
    let mut w = Vec::new();
    let n = data.n();
    if n < f.n_nuisance() + 2 {
        w.push(format!(
            "too few measured rows: {n} row{} against {} nuisance term{} (bias shifts and drift): nothing beyond them can be tested",
            if n == 1 { "" } else { "s" },
            f.n_nuisance(),
            if f.n_nuisance() == 1 { "" } else { "s" }
        ));
    }
    if f.family.is_empty() && selected.is_empty() {
        w.push(format!(
            "nothing could be tested: no candidate has a signature in these rows outside the nuisance terms (not testable: {})",
            names(&[f.untestable.clone(), f.untestable_nuisance.clone()].concat()).join(", ")
        ));
    }
    if f.family.is_empty() && !selected.is_empty() {
        w.push(format!(
            "no candidate has a first-order signature in these rows (not testable to first order: {}); the loop's parameters were scanned through the closed loop over their tolerance bands, and what is selected comes from that scan",
            names(&[f.untestable.clone(), f.untestable_nuisance.clone()].concat()).join(", ")
        ));
    }
    if f.noise == NoiseSource::Residuals {
        w.push("no sigma_cm_s2 and no replicated rows: the noise is estimated from the residuals (see noise.caveat)".to_string());
    }
    for s in selected.iter().filter(|s| !s.plausible) {
        let (name, unit) = (s.id.info().name, s.id.info().unit);
        w.push(if let Some(p) = &s.parameter {
            format!(
                "{name} = {} {unit} lies outside the instrument file's tolerance ({} to {} {unit}): either this instrument is out of its specification, or another cause imitates the change",
                super::show::estimate(p.fitted, p.sigma),
                crate::output::significant(p.tolerance[0], 6),
                crate::output::significant(p.tolerance[1], 6)
            )
        } else {
            format!(
                "{name} = {} {unit} is beyond the instrument class's bound: either the part is out of its class, or the bound is not this part's (the instrument file's [plausibility]); the term stays in the model every later test reads",
                super::show::estimate(s.coef, s.stderr)
            )
        });
    }
    w
}

/// One warning per selected term that these data cannot tell from a form outside the
/// vocabulary, with what would tell them apart.
pub(crate) fn rival_warnings(selected: &[Selected], timed: bool) -> Vec<String> {
    let mut w = Vec::new();
    for s in selected.iter().filter(|s| !s.rivals.is_empty()) {
        let c = s.id.info();
        let forms: Vec<String> = s
            .rivals
            .iter()
            .map(|r| match &r.together_with {
                None => format!("{} (p = {})", r.form, super::show::pfmt(r.p_value)),
                Some(o) => format!(
                    "{} in its place and {o}'s together (p = {})",
                    r.form,
                    super::show::pfmt(r.p_value)
                ),
            })
            .collect();
        let in_time = s
            .rivals
            .iter()
            .any(|r| r.family == "time_shapes" || r.family.starts_with("history"));
        w.push(format!(
            "{} = {} {} cannot be told here from {}, outside the vocabulary: in its place the fit is not significantly worse, so these data do not say which it is; before acting on it, measure where the two differ ({})",
            c.name,
            super::show::estimate(s.coef, s.stderr),
            c.unit,
            forms.join(", "),
            match (in_time, timed) {
                (true, true) => "the positions in another order, interleaved or reversed, and after a warm-up: the advice lists the rows",
                (true, false) => "the positions in another order, interleaved or reversed, and after a warm-up: the advice lists the rows; these rows give no time_s, so their order stands in for time, and a warm-up or drift in them looks like this",
                _ => "a tumble about another axis, or the same positions at another g level",
            }
        ));
    }
    w
}

/// What a lab should do about a coefficient that disagrees between the parts of `split`.
fn stability_advice(split: &str) -> &'static str {
    match split {
        "time" => {
            "repeat the positions in another order (interleaved, or reversed) and look for a warm-up, a temperature change or a drift that is not linear in time"
        }
        "approach" => "measure each position approached from both sides and look for a hysteresis",
        _ => "compare the blocks' set-ups (mounting, reference runs, temperature)",
    }
}

/// A failed stability test in words: `first half in time 5.6e-5 ± 0.9e-5 against second
/// half in time 0.3e-5 ± 1.1e-5, difference -5.3e-5 ± 1.2e-5 (chi2 ... p = ..., familywise
/// level ...)`; the chi2 is the test's statistic on the noise scale its p-value used.
fn split_text(t: &SplitTest, unit: &str) -> String {
    let parts: Vec<String> = t
        .parts
        .iter()
        .map(|p| {
            format!(
                "{} {} {unit}",
                p.part,
                super::show::estimate(p.coefficient, p.stderr)
            )
        })
        .collect();
    // Two parts: their difference from their whole covariance (the parts share the
    // nuisance terms, so it is not the parts' standard errors combined), on the test's
    // noise scale, as the statistic.
    let difference = t.difference.map_or(String::new(), |[d, se]| {
        format!(", difference {} {unit}", super::show::estimate(d, se))
    });
    format!(
        "{}{difference} (chi2 {:.1} for {} dof, p = {}, familywise level {})",
        parts.join(" against "),
        t.statistic,
        t.dof,
        super::show::pfmt(t.p_value),
        super::show::pfmt(t.threshold)
    )
}

/// One warning per selected term whose coefficient disagrees between parts of the data
/// (`effects`: the JSON's effects, with their stability tests).
pub(crate) fn stability_warnings(selected: &[Selected], effects: &[EffectReport]) -> Vec<String> {
    let mut w = Vec::new();
    for s in selected.iter().filter(|s| s.stable == Some(false)) {
        let c = s.id.info();
        let failed: Vec<&SplitTest> = effects
            .iter()
            .flat_map(|e| &e.stability.tests)
            .filter(|t| t.name == c.name && !t.agrees)
            .collect();
        let mut advice: Vec<&str> = failed.iter().map(|t| stability_advice(t.split)).collect();
        advice.dedup();
        w.push(format!(
            "{} = {} {} is not stable: {}; its value depends on when or how it was measured, which a fixed property of the instrument does not, so it is not given as the cause: {}",
            c.name,
            super::show::estimate(s.coef, s.stderr),
            c.unit,
            failed
                .iter()
                .map(|t| split_text(t, c.unit))
                .collect::<Vec<_>>()
                .join("; "),
            advice.join("; ")
        ));
    }
    w
}

/// The verdict's first sentence, on the rows set aside as suspected gross errors (none
/// when there are none).
fn gross_errors_sentence(d: &Discovery) -> String {
    let j = &d.json;
    let mut v = String::new();
    if !j.outliers.is_empty() {
        let one = j.outliers.len() == 1;
        let rows: Vec<String> = j.outliers.iter().map(|o| format!("`{}`", o.row)).collect();
        let causes: Vec<&str> = j
            .outliers
            .iter()
            .map(|o| o.cause.split([':', ';']).next().unwrap_or_default())
            .collect();
        let _ = write!(
            v,
            "{} {} {} ({}); {}. ",
            if one { "Row" } else { "Rows" },
            rows.join(", "),
            if one {
                "is a suspected gross error"
            } else {
                "are suspected gross errors"
            },
            causes.join("; "),
            match (d.options.keep_outliers, one) {
                (true, _) => "kept in the fit (--keep-outliers)",
                (false, true) => "set aside: what follows is without it",
                (false, false) => "set aside: what follows is without them",
            }
        );
    }
    v
}

/// The verdict's sentences on the selected terms (`named`: each one in words, in
/// `selected`'s order): the stable ones as selected, those whose coefficient disagrees
/// between parts of the data apart, as no cause, with what to do before acting on them.
fn selected_sentences(
    v: &mut String,
    selected: &[Selected],
    named: Vec<String>,
    effects: &[EffectReport],
) {
    let mut steady: Vec<String> = Vec::new();
    let mut shifting: Vec<String> = Vec::new();
    for (s, t) in selected.iter().zip(named) {
        if s.stable == Some(false) {
            shifting.push(t);
        } else {
            steady.push(t);
        }
    }
    if !steady.is_empty() {
        let _ = write!(v, "Selected: {}.", steady.join("; "));
    }
    if !shifting.is_empty() {
        let mut advice: Vec<&str> = effects
            .iter()
            .flat_map(|e| &e.stability.tests)
            .filter(|t| !t.agrees)
            .map(|t| stability_advice(t.split))
            .collect();
        advice.sort_unstable();
        advice.dedup();
        let one = shifting.len() == 1;
        let _ = write!(
            v,
            "{}Not given as a cause, because {} not stable (its value on one part of the data disagrees with another's, so it depends on when or how it was measured): {}; before acting on {}, {}.",
            if steady.is_empty() { "" } else { " " },
            if one { "it is" } else { "they are" },
            shifting.join("; "),
            if one { "it" } else { "them" },
            advice.join("; ")
        );
    }
}

/// "The model does not fit these data …" when the fit check fails (`found`: the library
/// search named a form; else the sentence says it named none).
#[must_use]
pub fn misfit_sentence(c: &FitCheck, found: bool) -> Option<String> {
    if c.fits != Some(false) {
        return None;
    }
    Some(format!(
        "The model does not fit these data ({}, p = {:.2e}): its values hold only as far as what is left is noise, and something outside it is in the data{}.",
        c.statistic,
        c.p_value.unwrap_or(f64::NAN),
        if found {
            ""
        } else {
            "; the library search names no form for it, so look at the residuals (their plot and table) before using the calibration"
        }
    ))
}

/// The conclusion in one paragraph: what was named (and how plausible), what stays
/// unexplained, and the cross-validated gain.
#[must_use]
pub fn verdict(d: &Discovery) -> String {
    let j = &d.json;
    let mut v = gross_errors_sentence(d);
    if let Some(sg) = &d.sigma_slip {
        let _ = write!(
            v,
            "The stated sigmas are {} times the scatter of the residuals: {} ",
            crate::output::significant(sg.factor, 2),
            if sg.factor >= 1.0 {
                "too large to see effects of the size of the scatter."
            } else {
                "too small, or the data hold structure no candidate explains."
            }
        );
    }
    if d.family.is_empty() && d.selected.is_empty() {
        v.push_str("Nothing could be tested in these rows (no candidate has a signature here).");
    } else if d.selected.is_empty() {
        let _ = write!(
            v,
            "No candidate of the {} tested ({}) is significant at familywise 5 %.",
            d.family_size,
            names(&d.family).join(", ")
        );
    } else {
        let named: Vec<String> = d
            .selected
            .iter()
            .map(|s| {
                let c = s.id.info();
                if let Some(p) = &s.parameter {
                    let mut t = p.sentence(c.name, c.unit);
                    if !s.confounded.is_empty() {
                        let o: Vec<&str> = s.confounded.iter().map(|(o, _)| o.info().name).collect();
                        let _ = write!(t, " (indistinguishable here from {})", o.join(", "));
                    }
                    return t;
                }
                let mut t = format!(
                    "{} = {} {}",
                    if c.name.contains('.') { c.name.to_string() } else { format!("{} {}", c.name, c.key) },
                    super::show::estimate(s.coef, s.stderr),
                    c.unit
                );
                if s.companion {
                    t.push_str(" (the level the warm-up settles to, fitted with it: not a cause of its own)");
                    return t;
                }
                if !s.plausible {
                    t.push_str(" (beyond the class's bound: the part is out of its class, or the bound is not this part's)");
                }
                if !s.confounded.is_empty() {
                    let o: Vec<&str> = s.confounded.iter().map(|(o, _)| o.info().name).collect();
                    let _ = write!(t, " (indistinguishable here from {})", o.join(", "));
                }
                if !s.rivals.is_empty() {
                    let o: Vec<&str> = s.rivals.iter().map(|r| r.form.as_str()).collect();
                    let _ = write!(
                        t,
                        " (or a form outside the vocabulary these data cannot tell from it: {})",
                        o.join(", ")
                    );
                }
                t
            })
            .collect();
        selected_sentences(&mut v, &d.selected, named, &j.effects);
    }
    if let Some(s) = misfit_sentence(&j.fit_check, j.unexplained.detected) {
        v.push(' ');
        v.push_str(&s);
    }
    if j.unexplained.detected {
        let _ = write!(
            v,
            " The simulation still gets something wrong that no candidate explains: {} (p = {:.2e}).",
            j.unexplained.hint, j.unexplained.p_value
        );
    }
    let g = &j.gain;
    let _ = write!(
        v,
        " Out of sample ({}): RMS {:.3} {u} with the selected terms against {:.3} for the baseline with its nuisance terms; gain {:.3} {u}, 95 % interval [{:.3}, {:.3}].",
        g.method,
        g.rms_cross_validated_cm_s2,
        g.baseline_rms_cross_validated_cm_s2,
        g.baseline_rms_cross_validated_cm_s2 - g.rms_cross_validated_cm_s2,
        g.ci95_rms_cm_s2[0],
        g.ci95_rms_cm_s2[1],
        u = g.unit
    );
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_parameter_whose_mirror_fits_is_given_without_its_sign() {
        let mut p = ParameterValue {
            key: "pickoff.phase_angle_deg".into(),
            nominal: 0.0,
            fitted: 15.0,
            sigma: 0.5,
            tolerance: [-10.0, 10.0],
            within_tolerance: false,
            mirror: None,
        };
        let one = p.sentence("pickoff_phase", "deg");
        assert!(
            one.starts_with("pickoff_phase 15.00 ± 0.50 deg, nominal 0 deg"),
            "{one}"
        );
        p.mirror = Some(-15.0);
        let both = p.sentence("pickoff_phase", "deg");
        assert!(
            both.starts_with(
                "pickoff_phase 15.00 ± 0.50 deg or -15.00 ± 0.50 deg (the mirror image"
            ),
            "{both}"
        );
        assert!(both.contains("not its sign"), "{both}");
    }
}
