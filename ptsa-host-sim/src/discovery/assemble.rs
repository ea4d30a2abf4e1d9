//! The result put together from what the stages found: the `--json` object's parts (the
//! per-observation table, the nuisance terms, the noise, the model equation, the effects,
//! the suspected gross errors, the steps), the Bode points, the warnings and the verdict.

use std::collections::BTreeMap;

use super::advice::Advice;
use super::data::{Data, TimeUnit};
use super::extend::Extended;
use super::fit::{Fitted, NoiseSource, Nuisance, Step};
use super::observation::{Observation, Quantity};
use super::outcome::{BodePoint, Discovery};
use super::outliers::{Screened, SetAside};
use super::problem::{Options, Problem, Selected};
use super::report::{
    EffectReport, FitCheck, Gain, JsonReport, ModelEquation, NoiseReport, NuisanceReport,
    OutlierReport, RowResult, SearchLimit, StabilityReport, StepReport, Term, TimeConstantReport,
    Unexplained, names,
};
use super::search::limit_note;
use super::sim::Simulator;
use super::slips::{self, SigmaSlip, UnitSlip};
use super::verdict;
use crate::model::caseframe::EmptyCells;
use crate::model::condition::Condition;
use crate::model::effects::{CandidateId, Effects};

/// What the stages found, for [`discovery`].
pub(crate) struct Found<'a> {
    /// The problem the stages worked on (rows, data without the rows set aside, the linear
    /// fit, simulator, options).
    pub p: Problem<'a>,
    /// The reader's record of the input cells that were empty and read as 0.
    pub empty: &'a [EmptyCells],
    /// Every row's baseline observations.
    pub baseline: &'a [Observation],
    /// The rows set aside as suspected gross errors.
    pub screened: &'a Screened,
    /// Values in another unit or with the sign reversed, analysed as given.
    pub unit_slip: Option<UnitSlip>,
    /// The selected terms.
    pub selected: Vec<Selected>,
    /// The selection's steps and the searches'.
    pub steps: Vec<Step>,
    /// The extended model.
    pub extended: Extended,
    /// Structure no candidate explains.
    pub unexplained: Unexplained,
    /// The gain out of sample.
    pub gain: Gain,
    /// Groups of candidates indistinguishable before any fit.
    pub groups: Vec<Vec<CandidateId>>,
    /// The advice.
    pub advice: Vec<Advice>,
    /// The stated sigmas against the scatter of the residuals.
    pub scatter: Option<SigmaSlip>,
    /// Each selected term refitted on disjoint parts of the data (in `selected`'s order).
    pub stability: Vec<StabilityReport>,
}

/// The result of the stages' findings: the `--json` object, its warnings and verdict, and
/// the typed result.
pub(crate) fn discovery(found: Found<'_>) -> Discovery {
    let Found {
        p,
        empty,
        baseline,
        screened,
        unit_slip,
        selected,
        steps,
        extended: ext,
        unexplained,
        gain,
        groups,
        advice,
        scatter,
        stability,
    } = found;
    let (rows, data, f, sim, opts) = (p.rows, p.data, p.f, p.sim, p.opts);
    let set_aside = &screened.set_aside;
    let outliers_json = outlier_reports(rows, empty, data, f, set_aside, opts, sim.g_cm_s2());
    let table = row_table(
        rows,
        data,
        f,
        baseline,
        &ext.resim,
        &ext.values,
        opts,
        set_aside,
    );
    let sigma_slip = scatter.clone().filter(|s| s.far);
    let effects_json = effect_reports(&selected, &stability, opts, sim);
    let warnings = report_warnings(
        &p,
        screened,
        (unit_slip.as_ref(), sigma_slip.as_ref()),
        &selected,
        &outliers_json,
        &effects_json,
    );
    let mut noise = noise_report(data, f);
    noise.stated_over_scatter = scatter.as_ref().map(|s| s.factor);
    let fit_check = fit_check(f, &ext, &unexplained);
    let mut d = Discovery {
        simulator: sim.name(),
        json: JsonReport {
            rows: data.n(),
            baseline: ext.baseline_fit,
            effects: effects_json,
            extended: ext.fit,
            model_equation: model_equation(f, &selected, sim.g_cm_s2()),
            calibration: super::calibration::calibration(&p, &selected),
            advice,
            nuisance: nuisance_report(data, f),
            fit_check,
            unexplained,
            gain,
            noise,
            family: names(&f.family),
            not_testable: names(&f.untestable),
            not_testable_nuisance: names(&f.untestable_nuisance),
            indistinguishable: groups.iter().map(|g| names(g)).collect(),
            table: table.clone(),
            verdict: String::new(),
            warnings,
            outliers: outliers_json,
            steps: steps.iter().map(step_report).collect(),
        },
        selected,
        table,
        steps,
        untestable: f.untestable.clone(),
        untestable_nuisance: f.untestable_nuisance.clone(),
        untoleranced: untoleranced(f, sim),
        confounded_groups: groups,
        family_size: f.family_size(),
        family: f.family.clone(),
        effects: ext.effects,
        options: opts.clone(),
        bode: bode(rows, sim, &ext.effects),
        sigma_slip,
    };
    d.json.verdict = verdict::verdict(&d);
    d
}

/// The warnings, in the order the report gives them: values in another unit first, then
/// the rows set aside and the stated sigmas far from the scatter (`slips`: the unit slip
/// and the sigma slip), the fit's, an unused `approach` column, the selected terms found
/// unstable (`effects`), and those with rivals.
fn report_warnings(
    p: &Problem<'_>,
    screened: &Screened,
    slips: (Option<&UnitSlip>, Option<&SigmaSlip>),
    selected: &[Selected],
    outliers: &[OutlierReport],
    effects: &[EffectReport],
) -> Vec<String> {
    let (unit_slip, sigma_slip) = slips;
    let mut warnings = verdict::slip_warnings(
        outliers,
        screened.beyond_cap.as_ref().map(|(l, b)| (l.as_str(), *b)),
        sigma_slip,
        selected,
        p.sim,
    );
    if let Some(slip) = unit_slip {
        warnings.insert(0, slip.kept_message());
    }
    warnings.extend(verdict::warnings(p.data, p.f, selected));
    warnings.extend(verdict::unused_approach(p.rows));
    warnings.extend(verdict::stability_warnings(selected, effects));
    warnings.extend(verdict::rival_warnings(
        selected,
        p.data.time_unit == TimeUnit::Seconds,
    ));
    warnings
}

/// The parameters `f` cannot test that the simulator's instrument file gives no tolerance
/// (none without an instrument file).
fn untoleranced(f: &Fitted, sim: &dyn Simulator) -> Vec<CandidateId> {
    sim.instrument().map_or_else(Vec::new, |i| {
        f.untestable
            .iter()
            .copied()
            .filter(|id| id.parameter_key().is_some_and(|k| i.tolerance(k).is_none()))
            .collect()
    })
}

/// The per-observation table: every observation of every row (measured or not; a row set
/// aside as a suspected gross error with its measurement and the model's values, marked).
#[allow(clippy::too_many_arguments)] // the model's pieces the table shows
fn row_table(
    rows: &[Condition],
    data: &Data,
    f: &Fitted,
    baseline: &[Observation],
    resim: &[Observation],
    extended: &[f64],
    opts: &Options,
    set_aside: &[SetAside],
) -> Vec<RowResult> {
    let mut out = Vec::new();
    // The observation of each (row, slot), if fitted.
    let mut fitted: Vec<[Option<usize>; 2]> = vec![[None; 2]; rows.len()];
    for k in (0..data.n()).rev() {
        fitted[data.rows[k]][usize::from(data.quantity[k] == Quantity::Phase)] = Some(k);
    }
    for (i, r) in rows.iter().enumerate() {
        // The baseline's and the re-simulation's values, quantity by quantity (the two are
        // of one kind: `extend` makes sure).
        let pairs = baseline[i].entries().into_iter().zip(resim[i].entries());
        for ((q, b), (_, re)) in pairs {
            let (quantity, suffix) = match q {
                Quantity::Gain => ("gain", " (gain)"),
                Quantity::Phase => ("phase_deg", " (phase)"),
                Quantity::Value => ("value_cm_s2", ""),
            };
            let o = usize::from(q == Quantity::Phase);
            let k = fitted[i][o];
            let aside = set_aside.iter().find(|a| a.row == i && o == 0);
            let (measured, sigma, ext) = match (k, aside) {
                (Some(k), _) => (Some(data.y[k]), f.sigma[k], extended[k]),
                (None, Some(a)) => (
                    Some(a.y),
                    a.stated
                        .or_else(|| {
                            f.group_sigma
                                .iter()
                                .find(|(g, _)| *g == a.group)
                                .map(|&(_, s)| s)
                        })
                        .unwrap_or(f64::NAN),
                    re + f.nuisance_for(a.block, a.shift, a.drifts, a.time),
                ),
                (None, None) => (
                    None,
                    r.sigma_cm_s2
                        .or(opts.default_sigma_cm_s2)
                        .unwrap_or(f64::NAN),
                    re,
                ),
            };
            debug_assert!(aside.is_none_or(|a| (a.base - b).abs() <= 1e-9 * a.base.abs().max(1.0)));
            out.push(RowResult {
                label: format!("{}{suffix}", r.label),
                freq_hz: (r.kind == crate::model::condition::RowKind::Response)
                    .then_some(r.freq_hz),
                kind: r.kind,
                quantity,
                measured_cm_s2: measured,
                sigma_cm_s2: sigma,
                baseline_cm_s2: b,
                residual_cm_s2: measured.map(|m| m - b),
                extended_cm_s2: ext,
                residual_extended_cm_s2: measured.map(|m| m - ext),
                outlier: aside.is_some(),
            });
        }
    }
    out
}

/// The nuisance terms' values and standard errors.
fn nuisance_report(data: &Data, f: &Fitted) -> NuisanceReport {
    let mut r = NuisanceReport::default();
    let mut se_blocks = serde_json::Map::new();
    for (j, t) in f.nuisance.iter().enumerate() {
        match *t {
            Nuisance::Block(b) => {
                let name = data.block_names[b].clone();
                r.bias_shift_cm_s2.insert(name.clone(), f.coef[j]);
                se_blocks.insert(name, f.se[j].into());
            }
            Nuisance::Drift => {
                let key = match data.time_unit {
                    TimeUnit::Seconds => {
                        r.drift_cm_s2_per_s = Some(f.coef[j]);
                        "drift_cm_s2_per_s"
                    }
                    TimeUnit::Row => {
                        r.drift_cm_s2_per_row = Some(f.coef[j]);
                        "drift_cm_s2_per_row"
                    }
                };
                r.stderr.insert(key.into(), f.se[j].into());
            }
        }
    }
    r.stderr.insert(
        "bias_shift_cm_s2".into(),
        serde_json::Value::Object(se_blocks),
    );
    r
}

fn noise_report(data: &Data, f: &Fitted) -> NoiseReport {
    let sigma_cm_s2 = f
        .group_sigma
        .iter()
        .map(|&(g, s)| (data.group_names[g].clone(), s))
        .collect();
    let (source, caveat) = match f.noise {
        NoiseSource::Stated => ("stated", None),
        NoiseSource::Replicates => (
            "replicates",
            Some("sigma estimated from the scatter of replicated rows (pure error) per variance group; groups without replicates use the model's residuals".to_string()),
        ),
        NoiseSource::Residuals => (
            "residuals",
            Some("sigma estimated from the model's residuals per variance group (no sigma_cm_s2 and no replicated rows): it holds whatever the model does not explain, so it can only be too large, and the tests use the heteroscedasticity-robust error as well".to_string()),
        ),
    };
    NoiseReport {
        source,
        sigma_cm_s2,
        caveat,
        stated_over_scatter: None,
    }
}

/// Whether the final model fits: with stated sigmas, its χ²; with the noise estimated, the
/// replicated rows' lack of fit; else it cannot be told.
fn fit_check(f: &Fitted, ext: &Extended, u: &Unexplained) -> FitCheck {
    let (test, p_value, statistic) = if f.noise == NoiseSource::Stated {
        (
            "chi2_stated",
            Some(ext.fit.p_value),
            format!(
                "χ² {:.2} for {} dof with the stated sigmas",
                ext.fit.chi2, ext.fit.dof
            ),
        )
    } else if let Some(t) = u.tests.iter().find(|t| t.name == "lack_of_fit") {
        (
            "lack_of_fit",
            Some(t.p_value),
            "the replicated rows' means against their pure error".to_string(),
        )
    } else {
        ("none", None, String::new())
    };
    FitCheck {
        fits: p_value.map(|p| p >= 0.05),
        test,
        p_value,
        statistic,
    }
}

/// The selected terms in IEEE Std 1293 units, with the correlation of the final fit.
fn model_equation(f: &Fitted, selected: &[Selected], g_cm_s2: f64) -> ModelEquation {
    let nn = f.n_nuisance();
    let terms = selected
        .iter()
        .map(|s| {
            let c = s.id.info();
            let (symbol, unit, factor) = c.ieee;
            let k = factor(g_cm_s2);
            let (value, sigma) = s
                .parameter
                .as_ref()
                .map_or((s.coef * k, s.stderr * k), |p| (p.fitted, p.sigma));
            Term {
                name: c.name.to_string(),
                symbol: symbol.to_string(),
                value,
                unit: unit.to_string(),
                sigma,
            }
        })
        .collect();
    let m = selected.len();
    let cov = |i: usize, j: usize| f.fit.cov.get((nn + i, nn + j)).copied().unwrap_or(0.0);
    let correlation = (0..m)
        .map(|i| {
            (0..m)
                .map(|j| {
                    let d = (cov(i, i) * cov(j, j)).sqrt();
                    if d > 0.0 { cov(i, j) / d } else { f64::NAN }
                })
                .collect()
        })
        .collect();
    ModelEquation { terms, correlation }
}

/// Group selected coefficients by effect for the JSON.
fn effect_reports(
    selected: &[Selected],
    stability: &[StabilityReport],
    opts: &Options,
    sim: &dyn Simulator,
) -> Vec<EffectReport> {
    let mut reports: Vec<EffectReport> = Vec::new();
    for (k, s) in selected.iter().enumerate() {
        let cand = s.id.info();
        let pos = reports
            .iter()
            .position(|r| r.name == cand.effect)
            .unwrap_or_else(|| {
                reports.push(EffectReport {
                    name: cand.effect.to_string(),
                    coefficients: BTreeMap::new(),
                    stderr: BTreeMap::new(),
                    confounded_with: vec![],
                    plausible: true,
                    bounds: BTreeMap::new(),
                    parameter: s.parameter.clone(),
                    search_limit: None,
                    stable: s.stable,
                    stability: StabilityReport::default(),
                    rivals: Vec::new(),
                    time_constant: None,
                    companion_of: s.companion.then(|| "warm_up".to_string()),
                });
                reports.len() - 1
            });
        let r = &mut reports[pos];
        // An effect is stable when every component tested is, unstable when one is not.
        r.stable = match (r.stable, s.stable) {
            (Some(false), _) | (_, Some(false)) => Some(false),
            (Some(true), _) | (_, Some(true)) => Some(true),
            (None, None) => None,
        };
        if let Some(st) = stability.get(k) {
            r.stability.tests.extend(st.tests.iter().cloned());
            for n in &st.not_tested {
                if !r.stability.not_tested.contains(n) {
                    r.stability.not_tested.push(n.clone());
                }
            }
        }
        for v in &s.rivals {
            if !r.rivals.iter().any(|o| o.form == v.form) {
                r.rivals.push(v.clone());
            }
        }
        if let Some(t) = &s.time_constant {
            r.time_constant = Some(TimeConstantReport {
                tau_s: t.tau_s,
                interval_95_s: [t.interval_s.0, t.interval_s.1],
                amplitude_cm_s2: t.amplitude_cm_s2,
                amplitude_se_cm_s2: t.amplitude_se_cm_s2,
                grid_key: cand.key.to_string(),
            });
        }
        r.coefficients.insert(cand.key.to_string(), s.coef);
        r.stderr.insert(cand.key.to_string(), s.stderr);
        if s.parameter.is_none() {
            r.bounds
                .insert(cand.key.to_string(), opts.limits[s.id.index()]);
        }
        r.plausible &= s.plausible;
        if let Some(l) = s.search_limit {
            r.search_limit = Some(SearchLimit {
                name: cand.name.to_string(),
                value: s.parameter.as_ref().map_or(l, |p| p.nominal + l),
                note: limit_note(s.id, l, sim),
            });
        }
        for &(o, _) in &s.confounded {
            let name = o.info().name.to_string();
            if !r.confounded_with.contains(&name) {
                r.confounded_with.push(name);
            }
        }
    }
    reports
}

/// The outlier search's findings in the `--json` shape, with their likely causes.
fn outlier_reports(
    rows: &[Condition],
    empty: &[EmptyCells],
    data: &Data,
    f: &Fitted,
    set_aside: &[SetAside],
    opts: &Options,
    g: f64,
) -> Vec<OutlierReport> {
    set_aside
        .iter()
        .map(|a| {
            let t = &a.found.test;
            let expected = a.y - t.error;
            let others: Vec<(&str, f64)> = (0..data.n())
                .filter(|&k| data.quantity[k] == Quantity::Value && data.rows[k] != a.row)
                .map(|k| {
                    (
                        rows[data.rows[k]].label.as_str(),
                        data.base[k] + f.predict(data, k),
                    )
                })
                .collect();
            OutlierReport {
                row: rows[a.row].label.clone(),
                residual_cm_s2: t.error,
                p_value: a.found.p_family,
                studentized: t.t,
                dof: t.dof,
                rows_tested: a.found.tested,
                measured_cm_s2: a.y,
                expected_cm_s2: expected,
                sigma_cm_s2: t.error_se,
                cause: slips::cause(
                    a.y,
                    expected,
                    t.error_se,
                    empty.iter().find(|e| e.row == a.row),
                    &others,
                    g,
                ),
                kept: opts.keep_outliers,
            }
        })
        .collect()
}

/// A step in the `--json` shape.
fn step_report(s: &Step) -> StepReport {
    StepReport {
        action: match (s.added, s.replaces) {
            (_, Some(_)) => "swap",
            (true, None) => "add",
            (false, None) => "drop",
        },
        name: s.id.info().name.to_string(),
        replaces: s.replaces.map(|r| r.info().name.to_string()),
        delta_chi2: s.delta_chi2,
        p_value: s.p_value,
        threshold: s.threshold,
        note: s.note.clone(),
    }
}

/// Points of the linear loop model's Bode plot, 80 per the response rows' frequency span
/// (a factor of 2 beyond it either side), log-spaced.
fn bode(rows: &[Condition], sim: &dyn Simulator, effects: &Effects) -> Vec<BodePoint> {
    let f: Vec<f64> = rows
        .iter()
        .filter(|r| r.kind == crate::model::condition::RowKind::Response && r.freq_hz > 0.0)
        .map(|r| r.freq_hz)
        .collect();
    let (Some(lo), Some(hi)) = (
        f.iter().copied().reduce(f64::min),
        f.iter().copied().reduce(f64::max),
    ) else {
        return Vec::new();
    };
    let (lo, hi) = ((lo / 2.0).ln(), (hi * 2.0).ln());
    (0..80)
        .filter_map(|k| {
            let freq_hz = (lo + (hi - lo) * f64::from(k) / 79.0).exp();
            Some(BodePoint {
                freq_hz,
                nominal: sim.linear_response(freq_hz, &Effects::NONE)?,
                corrected: sim.linear_response(freq_hz, effects)?,
            })
        })
        .collect()
}
