//! The discovery method: baseline, diagnosis (selection with familywise error control and
//! confounding detection), extension and re-simulation. See `docs/discovery.md`.

use std::collections::{BTreeMap, BTreeSet};

use rayon::prelude::*;
use serde::Serialize;

use super::sim::{AnalyticSimulator, Simulator, gross_effect_cm_s2};
use super::stats::{LsqFit, abs_cos, chi2_sf, f_sf, lsq, norm, residualize};
use crate::condition::Condition;
use crate::effects::{CandidateId, Effects, N_CANDIDATES, resolve_candidates};

/// Resolve a `--candidates` list: effect names (`lever_arm` = its three components) or
/// candidate names (`lever_arm.r_pa_cm`), comma separated. Empty = all.
///
/// # Errors
/// An unknown name (the message lists the known ones).
pub fn parse_candidates(list: &str) -> anyhow::Result<Vec<CandidateId>> {
    let mut out = BTreeSet::new();
    for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        out.extend(resolve_candidates(item).map_err(anyhow::Error::msg)?);
    }
    if out.is_empty() {
        return Ok(CandidateId::ALL.to_vec());
    }
    Ok(out.into_iter().collect())
}

/// Settings of the method.
#[derive(Clone, Debug)]
pub struct Options {
    /// Familywise error rate across all candidates (0.05).
    pub alpha: f64,
    /// `|cos|` above which two signatures are indistinguishable (0.99).
    pub confound_cos: f64,
    /// Sigma for rows without `sigma_cm_s2`, cm/s² (0.3).
    pub default_sigma_cm_s2: f64,
    /// The candidates tested (default: all).
    pub candidates: Vec<CandidateId>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            alpha: 0.05,
            confound_cos: 0.99,
            default_sigma_cm_s2: 0.3,
            candidates: CandidateId::ALL.to_vec(),
        }
    }
}

/// RMS and χ² of a set of residuals.
#[derive(Clone, Debug, Serialize)]
pub struct FitSummary {
    /// Root mean square of `measured − simulated`, cm/s².
    pub rms_cm_s2: f64,
    /// `Σ ((measured − simulated)/sigma)²`.
    pub chi2: f64,
    /// Degrees of freedom: fitted rows minus fitted coefficients.
    pub dof: usize,
    /// `P(χ²_dof ≥ chi2)`: below 0.05 the rest is not consistent with the stated noise.
    pub p_value: f64,
}

/// One selected effect, in the `--json` shape.
#[derive(Clone, Debug, Serialize)]
pub struct EffectReport {
    /// Effect name.
    pub name: String,
    /// Fitted coefficients of the selected components, keyed as in the vocabulary.
    pub coefficients: BTreeMap<String, f64>,
    /// Their standard errors.
    pub stderr: BTreeMap<String, f64>,
    /// Every candidate (component names for `lever_arm`) indistinguishable from a selected
    /// component in this data set.
    pub confounded_with: Vec<String>,
}

/// The `--json` object.
#[derive(Clone, Debug, Serialize)]
pub struct JsonReport {
    /// Number of rows with a measurement (the fitted rows).
    pub rows: usize,
    /// Baseline model against the measurements.
    pub baseline: FitSummary,
    /// Selected effects (empty when nothing is significant).
    pub effects: Vec<EffectReport>,
    /// Extended model (baseline + selected effects, re-simulated) against the measurements.
    pub extended: FitSummary,
}

/// One selected coefficient (typed form, for programs such as the hidden-effect tests).
#[derive(Clone, Debug)]
pub struct Selected {
    /// The candidate.
    pub id: CandidateId,
    /// Coefficient, in the candidate's unit.
    pub coef: f64,
    /// Standard error (scaled by the Birge ratio when the residual χ²/dof exceeds 1).
    pub stderr: f64,
    /// Candidates indistinguishable from this one here, with the factor `c` such that the
    /// other's signature ≈ `c ×` this one's (partialled on the other selected terms): those
    /// whose signature is parallel to it (`|cos| > confound_cos` given the other selected
    /// terms), and those that would fit the data not significantly worse in its place (the
    /// swap's χ² increase has p > alpha/m, with `|cos| ≥ 0.5`).
    pub confounded: Vec<(CandidateId, f64)>,
}

/// One decision of the stepwise procedure.
#[derive(Clone, Debug)]
pub struct Step {
    /// `true` = added, `false` = removed.
    pub added: bool,
    /// The candidate.
    pub id: CandidateId,
    /// Drop in χ² the candidate gives.
    pub delta_chi2: f64,
    /// Its p-value (the larger of the known-sigma χ² and the F test).
    pub p_value: f64,
    /// The Holm–Bonferroni threshold it was compared with.
    pub threshold: f64,
}

/// Per-row table of the result.
#[derive(Clone, Debug, Serialize)]
pub struct RowResult {
    /// Row label.
    pub label: String,
    /// Measured difference, cm/s² (None = not measured, not fitted).
    pub measured_cm_s2: Option<f64>,
    /// Sigma used, cm/s².
    pub sigma_cm_s2: f64,
    /// Baseline model's difference, cm/s².
    pub baseline_cm_s2: f64,
    /// Extended model's difference, cm/s².
    pub extended_cm_s2: f64,
}

/// Everything the method found.
#[derive(Clone, Debug)]
pub struct Discovery {
    /// Simulator used for baseline and extension.
    pub simulator: &'static str,
    /// The JSON summary.
    pub json: JsonReport,
    /// Selected coefficients (index form).
    pub selected: Vec<Selected>,
    /// Per-row values.
    pub table: Vec<RowResult>,
    /// The stepwise decisions in order.
    pub steps: Vec<Step>,
    /// Candidates whose signature is identically zero in this data set (not testable).
    pub untestable: Vec<CandidateId>,
    /// Groups of testable candidates with pairwise `|cos| > confound_cos` (before any fit).
    pub confounded_groups: Vec<Vec<CandidateId>>,
    /// Number of hypotheses in the family (testable candidates).
    pub family_size: usize,
    /// The effects found, as coefficients for the plant.
    pub effects: Effects,
    /// The options used.
    pub options: Options,
}

/// Statement of the test, printed with every result.
pub const TEST_STATEMENT: &str = "forward-backward stepwise selection; each step tests the \
best remaining candidate by the larger p-value of (a) the chi-squared(1) test of its drop in \
chi2 against the stated sigmas and (b) the F(1, n-p) test against the residual scale, at the \
Holm-Bonferroni level alpha/(m-k) (m = testable candidates, k = already selected), so the \
familywise error rate over all candidates is at most alpha = 0.05";

/// Signature columns: `cols[c][i]` = analytic difference of fitted row `i` with a unit
/// coefficient of candidate `c` (exact for these linear terms), cm/s² per unit, with local
/// gravity `g_cm_s2`; and whether the column is identically zero here (every entry cancels
/// to rounding against the gross size of the term in the condition and its reference).
#[must_use]
pub fn signature_columns(rows: &[&Condition], g_cm_s2: f64) -> (Vec<Vec<f64>>, Vec<bool>) {
    let analytic = AnalyticSimulator { g_cm_s2 };
    let mut cols = Vec::with_capacity(N_CANDIDATES);
    let mut null = Vec::with_capacity(N_CANDIDATES);
    for &c in CandidateId::ALL {
        let e = Effects::only(c, 1.0);
        let col: Vec<f64> = rows
            .iter()
            .map(|r| analytic.difference_cm_s2(r, &e))
            .collect();
        let is_null = rows.iter().zip(&col).all(|(r, &x)| {
            x.abs() <= 1e-9 * gross_effect_cm_s2(r, &e, g_cm_s2) + f64::MIN_POSITIVE
        });
        cols.push(col);
        null.push(is_null);
    }
    (cols, null)
}

/// p-value of adding a term: drop `delta` in χ², new χ² `chi2_new` with `dof` left.
fn step_p(delta: f64, chi2_new: f64, dof: usize) -> f64 {
    if dof == 0 {
        return 1.0;
    }
    #[allow(clippy::cast_precision_loss)]
    let d = dof as f64;
    let p_known = chi2_sf(delta, 1.0);
    let scale = (chi2_new / d).max(f64::MIN_POSITIVE);
    let p_f = f_sf(delta / scale, 1.0, d);
    p_known.max(p_f)
}

struct Design<'a> {
    z: &'a [f64],
    u: &'a [Vec<f64>],
}

impl Design<'_> {
    fn fit(&self, set: &[CandidateId]) -> Option<LsqFit> {
        let cols: Vec<&[f64]> = set.iter().map(|&j| self.u[j.index()].as_slice()).collect();
        lsq(self.z, &cols)
    }
}

/// Run the method on `rows` with `sim` for baseline and re-simulation.
///
/// # Errors
/// No row has a measurement.
pub fn discover(
    rows: &[Condition],
    sim: &dyn Simulator,
    opts: &Options,
) -> anyhow::Result<Discovery> {
    let fitted: Vec<usize> = (0..rows.len())
        .filter(|&i| rows[i].measured_cm_s2.is_some())
        .collect();
    let n = fitted.len();
    if n == 0 {
        anyhow::bail!("no row has a value in `measured_cm_s2`: nothing to fit");
    }
    let sigma: Vec<f64> = rows
        .iter()
        .map(|r| r.sigma_cm_s2.unwrap_or(opts.default_sigma_cm_s2))
        .collect();
    // 1. Baseline: every row (measured or not, for the table), by the simulator.
    let baseline: Vec<f64> = rows
        .par_iter()
        .map(|r| sim.difference_cm_s2(r, &Effects::NONE))
        .collect();
    let y: Vec<f64> = fitted
        .iter()
        .map(|&i| rows[i].measured_cm_s2.unwrap_or(0.0))
        .collect();
    let z: Vec<f64> = fitted
        .iter()
        .zip(&y)
        .map(|(&i, yi)| (yi - baseline[i]) / sigma[i])
        .collect();

    // 2. Diagnose.
    let fitted_rows: Vec<&Condition> = fitted.iter().map(|&i| &rows[i]).collect();
    let (cols, null) = signature_columns(&fitted_rows, sim.g_cm_s2());
    let mut u = vec![vec![0.0; n]; N_CANDIDATES];
    let mut scale = [0.0; N_CANDIDATES];
    let mut testable = Vec::new();
    let mut untestable = Vec::new();
    for &c in &opts.candidates {
        let w: Vec<f64> = fitted
            .iter()
            .enumerate()
            .map(|(k, &i)| cols[c.index()][k] / sigma[i])
            .collect();
        let s = norm(&w);
        if null[c.index()] || s == 0.0 {
            untestable.push(c);
            continue;
        }
        u[c.index()] = w.iter().map(|x| x / s).collect();
        scale[c.index()] = s;
        testable.push(c);
    }
    let m = testable.len();
    let d = Design { z: &z, u: &u };
    let min_partial = (1.0 - opts.confound_cos * opts.confound_cos)
        .max(0.0)
        .sqrt();

    let mut set: Vec<CandidateId> = Vec::new();
    let mut steps = Vec::new();
    let mut visited: BTreeSet<Vec<CandidateId>> = BTreeSet::new();
    visited.insert(vec![]);
    for _ in 0..(4 * m + 4) {
        let chi2_set = d.fit(&set).map_or(f64::INFINITY, |f| f.chi2);
        // Forward.
        let mut best: Option<(CandidateId, f64, f64)> = None;
        for &c in &testable {
            if set.contains(&c) || set.len() + 2 > n {
                continue;
            }
            let basis: Vec<&[f64]> = set.iter().map(|&j| u[j.index()].as_slice()).collect();
            if norm(&residualize(&u[c.index()], &basis)) < min_partial {
                continue; // indistinguishable from the current model
            }
            let mut trial = set.clone();
            trial.push(c);
            let Some(f) = d.fit(&trial) else { continue };
            let delta = chi2_set - f.chi2;
            let p = step_p(delta, f.chi2, n - trial.len());
            // Ties (identical signatures up to rounding) go to the earlier candidate in the
            // vocabulary; the other is reported as confounded.
            if best.is_none_or(|(_, bp, _)| p < bp * (1.0 - 1e-9)) {
                best = Some((c, p, delta));
            }
        }
        #[allow(clippy::cast_precision_loss)]
        let thr_add = opts.alpha / (m - set.len()).max(1) as f64;
        if let Some((c, p, delta)) = best
            && p <= thr_add
        {
            let mut next = set.clone();
            next.push(c);
            next.sort_unstable();
            if visited.insert(next.clone()) {
                set = next;
                steps.push(Step {
                    added: true,
                    id: c,
                    delta_chi2: delta,
                    p_value: p,
                    threshold: thr_add,
                });
                continue;
            }
        }
        // Backward: drop the weakest term if it no longer passes its level.
        if set.is_empty() {
            break;
        }
        let Some(full) = d.fit(&set) else { break };
        let mut worst: Option<(CandidateId, f64, f64)> = None;
        for &c in &set {
            let rest: Vec<CandidateId> = set.iter().copied().filter(|&j| j != c).collect();
            let Some(f) = d.fit(&rest) else { continue };
            let delta = f.chi2 - full.chi2;
            let p = step_p(delta, full.chi2, n - set.len());
            if worst.is_none_or(|(_, wp, _)| p > wp * (1.0 + 1e-9)) {
                worst = Some((c, p, delta));
            }
        }
        #[allow(clippy::cast_precision_loss)]
        let thr_keep = opts.alpha / (m + 1 - set.len()).max(1) as f64;
        if let Some((c, p, delta)) = worst
            && p > thr_keep
        {
            let next: Vec<CandidateId> = set.iter().copied().filter(|&j| j != c).collect();
            if visited.insert(next.clone()) {
                set = next;
                steps.push(Step {
                    added: false,
                    id: c,
                    delta_chi2: delta,
                    p_value: p,
                    threshold: thr_keep,
                });
                continue;
            }
        }
        break;
    }
    set.sort_unstable();

    // Final fit, standard errors and confounding.
    let final_fit = d.fit(&set).unwrap_or_else(|| LsqFit {
        beta: vec![0.0; set.len()],
        cov: nalgebra::DMatrix::zeros(set.len(), set.len()),
        chi2: z.iter().map(|v| v * v).sum(),
        resid: z.clone(),
    });
    let dof_fit = n - set.len();
    #[allow(clippy::cast_precision_loss)]
    let birge = if dof_fit > 0 {
        (final_fit.chi2 / dof_fit as f64).sqrt().max(1.0)
    } else {
        1.0
    };
    let mut selected = Vec::new();
    let mut effects = Effects::NONE;
    for (k, &c) in set.iter().enumerate() {
        let coef = final_fit.beta[k] / scale[c.index()];
        let stderr = final_fit.cov[(k, k)].sqrt() / scale[c.index()] * birge;
        effects.add(c, coef);
        let others: Vec<&[f64]> = set
            .iter()
            .filter(|&&j| j != c)
            .map(|&j| u[j.index()].as_slice())
            .collect();
        let a = residualize(&u[c.index()], &others);
        let mut confounded = Vec::new();
        for &o in &testable {
            if o == c || set.contains(&o) {
                continue;
            }
            let b = residualize(&u[o.index()], &others);
            if norm(&b) < 1e-12 {
                continue;
            }
            let cos = abs_cos(&a, &b);
            // Structural: the signatures are (nearly) parallel given the other terms.
            let structural = cos > opts.confound_cos;
            // Statistical: swapping this term for the other does not make the fit
            // significantly worse at the family's Bonferroni level.
            let statistical = cos >= 0.5 && {
                let swapped: Vec<CandidateId> =
                    set.iter().map(|&j| if j == c { o } else { j }).collect();
                d.fit(&swapped).is_some_and(|f| {
                    let delta = (f.chi2 - final_fit.chi2).max(0.0);
                    #[allow(clippy::cast_precision_loss)]
                    let level = opts.alpha / m.max(1) as f64;
                    step_p(delta, final_fit.chi2, dof_fit) > level
                })
            };
            if structural || statistical {
                // Factor in physical units: col_o ≈ f × col_c.
                let dot: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
                let f = dot / a.iter().map(|x| x * x).sum::<f64>() * scale[o.index()]
                    / scale[c.index()];
                confounded.push((o, f));
            }
        }
        selected.push(Selected {
            id: c,
            coef,
            stderr,
            confounded,
        });
    }

    // Pairwise groups before any fit (for the identifiability report).
    let mut confounded_groups: Vec<Vec<CandidateId>> = Vec::new();
    for (a_i, &a) in testable.iter().enumerate() {
        for &b in &testable[a_i + 1..] {
            if abs_cos(&u[a.index()], &u[b.index()]) > opts.confound_cos {
                if let Some(g) = confounded_groups
                    .iter_mut()
                    .find(|g| g.contains(&a) || g.contains(&b))
                {
                    for x in [a, b] {
                        if !g.contains(&x) {
                            g.push(x);
                        }
                    }
                } else {
                    confounded_groups.push(vec![a, b]);
                }
            }
        }
    }

    // 3. Extend and re-simulate.
    let extended: Vec<f64> = if effects.is_zero() {
        baseline.clone()
    } else {
        rows.par_iter()
            .map(|r| sim.difference_cm_s2(r, &effects))
            .collect()
    };
    let summary = |pred: &[f64], p: usize| -> FitSummary {
        let res: Vec<f64> = fitted.iter().zip(&y).map(|(&i, yi)| yi - pred[i]).collect();
        #[allow(clippy::cast_precision_loss)]
        let rms = (res.iter().map(|r| r * r).sum::<f64>() / n as f64).sqrt();
        let chi2: f64 = fitted
            .iter()
            .zip(&res)
            .map(|(&i, r)| (r / sigma[i]).powi(2))
            .sum();
        let dof = n.saturating_sub(p);
        #[allow(clippy::cast_precision_loss)]
        let p_value = chi2_sf(chi2, dof as f64);
        FitSummary {
            rms_cm_s2: rms,
            chi2,
            dof,
            p_value,
        }
    };
    let base_summary = summary(&baseline, 0);
    let ext_summary = summary(&extended, set.len());

    // JSON effects: group components by effect.
    let mut reports: Vec<EffectReport> = Vec::new();
    for s in &selected {
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
                });
                reports.len() - 1
            });
        let r = &mut reports[pos];
        r.coefficients.insert(cand.key.to_string(), s.coef);
        r.stderr.insert(cand.key.to_string(), s.stderr);
        for &(o, _) in &s.confounded {
            let name = o.info().name.to_string();
            if !r.confounded_with.contains(&name) {
                r.confounded_with.push(name);
            }
        }
    }
    let table = rows
        .iter()
        .enumerate()
        .map(|(i, r)| RowResult {
            label: r.label.clone(),
            measured_cm_s2: r.measured_cm_s2,
            sigma_cm_s2: sigma[i],
            baseline_cm_s2: baseline[i],
            extended_cm_s2: extended[i],
        })
        .collect();
    Ok(Discovery {
        simulator: sim.name(),
        json: JsonReport {
            rows: n,
            baseline: base_summary,
            effects: reports,
            extended: ext_summary,
        },
        selected,
        table,
        steps,
        untestable,
        confounded_groups,
        family_size: m,
        effects,
        options: opts.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn analytic() -> AnalyticSimulator {
        AnalyticSimulator::for_instrument(&crate::Instrument::kearfott_2401())
    }
    use crate::discovery::show;
    use crate::r890 as report_data;

    #[test]
    fn table_6_1_names_anisoinertia_confounded_with_the_pa_lever_arm() {
        let rows = report_data::table_6_1_case().unwrap();
        let d = discover(&rows, &analytic(), &Options::default()).unwrap();
        eprintln!("{}", show::text_report("table 6.1", &d));
        assert_eq!(d.json.effects.len(), 1);
        let e = &d.json.effects[0];
        assert_eq!(e.name, "anisoinertia");
        assert_eq!(e.confounded_with, vec!["lever_arm.r_pa_cm".to_string()]);
        let k = e.coefficients["k_ai_cm"];
        // 1.47 cm/s² mean at the 45° rows over w_IA·w_PA = 0.5·(1 − 0.05²).
        assert!((k - 1.47 / (0.5 * (1.0 - 0.0025))).abs() < 1e-9, "{k}");
        assert!(d.json.extended.rms_cm_s2 < 0.25 * d.json.baseline.rms_cm_s2);
        assert!(d.json.extended.p_value > 0.05);
    }

    #[test]
    fn tables_6_2_and_6_3_are_null() {
        for rows in [
            report_data::table_6_2_case().unwrap(),
            report_data::table_6_3_case().unwrap(),
        ] {
            let d = discover(&rows, &analytic(), &Options::default()).unwrap();
            eprintln!("{}", show::text_report("oa coupling", &d));
            assert!(d.json.effects.is_empty());
        }
    }

    #[test]
    fn the_report_story_holds_with_the_closed_loop() {
        let sim = crate::discovery::sim::closed_loop(1);
        let t0 = std::time::Instant::now();
        let d = discover(
            &report_data::table_6_1_case().unwrap(),
            &*sim,
            &Options::default(),
        )
        .unwrap();
        eprintln!(
            "{}
{:.3} s",
            show::text_report("table 6.1 (closed loop)", &d),
            t0.elapsed().as_secs_f64()
        );
        assert_eq!(d.json.effects.len(), 1);
        assert_eq!(d.json.effects[0].name, "anisoinertia");
        assert!((d.json.effects[0].coefficients["k_ai_cm"] - 2.95).abs() < 0.1);
        for rows in [
            report_data::table_6_2_case().unwrap(),
            report_data::table_6_3_case().unwrap(),
        ] {
            let t0 = std::time::Instant::now();
            let d = discover(&rows, &*sim, &Options::default()).unwrap();
            eprintln!(
                "{}
{:.3} s",
                show::text_report("oa coupling (closed loop)", &d),
                t0.elapsed().as_secs_f64()
            );
            assert!(d.json.effects.is_empty());
        }
    }
}
