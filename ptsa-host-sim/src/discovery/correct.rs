//! `ptsa correct`: a calibration applied to a record of readings. Each absolute row's
//! reading (its `measured_cm_s2`, or its counts through the nominal scale factor) is
//! turned back into the specific force along IA that gives it, by inverting the
//! instrument's static model equation (the analytic model of the instrument file with the
//! calibration's effects, [`AnalyticSimulator::absolute_cm_s2`]) for `a_IA` with the row's
//! cross-axis inputs `a_PA`, `a_OA` held; its 1-sigma uncertainty comes from the reading's
//! own noise and from the calibration's covariance, both carried through the model's
//! slope (`docs/method/discovery.md`, `ptsa correct`). Also where every reading given as counts
//! becomes a value before it is fitted or corrected ([`counts_in`]).

use anyhow::{Context as _, Result, bail};

use super::calibration::{Coefficient, TERMS};
use super::sim::{AnalyticSimulator, Simulator};
use crate::model::condition::{Condition, IA, OA, PA, RowKind};
use crate::model::effects::{CandidateId, Effects};
use crate::model::instrument::Instrument;

/// The rows with their counts (`pulses`, `ticks`) turned into their readings with the
/// nominal scale factor of `sim`'s instrument ([`crate::model::counts::with_counts`]);
/// the rows as they are when none gives counts.
///
/// # Errors
/// A row gives counts and `sim` has no instrument file to take the scale factor from.
pub fn counts_in(rows: &[Condition], sim: &dyn Simulator) -> Result<Vec<Condition>> {
    if !crate::model::counts::any_counts(rows) {
        return Ok(rows.to_vec());
    }
    let Some(instr) = sim.instrument() else {
        anyhow::bail!(
            "rows give their readings as counts (`pulses`, `ticks`), but the {} simulator has no instrument file; expected one whose nominal scale factor (`electronics.scale_factor_cm_s2`) converts them",
            sim.name()
        );
    };
    Ok(crate::model::counts::with_counts(rows, instr.sf_cm_s2))
}

/// A calibration to apply: the instrument's model (the instrument file and the fitted
/// effects) and the covariance of the effects' coefficients.
pub struct Calibration {
    sim: AnalyticSimulator,
    effects: Effects,
    /// The fitted coefficients with a standard error, in the effects' units.
    terms: Vec<Term>,
    /// Their covariance, in the same order.
    cov: Vec<Vec<f64>>,
    /// The candidates the calibration's data could not test (`not_testable`): the
    /// calibration holds nothing of them, whatever the instrument has.
    untested: Vec<CandidateId>,
    /// The model-equation terms the calibration does not apply (not measured), each with
    /// the uncertainty it enters with.
    unapplied: Vec<Unapplied>,
    /// What the caller should hear about the calibration (each a warning's text).
    pub notes: Vec<String>,
}

impl Calibration {
    /// The instrument file's own model, with no uncertainty of its own (a file written
    /// with the instrument's calibrated values).
    #[must_use]
    pub fn of_instrument(instr: &Instrument) -> Self {
        Self {
            sim: AnalyticSimulator::for_instrument(instr),
            effects: Effects::NONE,
            terms: Vec::new(),
            cov: Vec::new(),
            untested: Vec::new(),
            unapplied: Vec::new(),
            notes: vec![
                "the instrument file carries no uncertainty of its values: each corrected value's sigma holds the reading's noise only".to_string(),
            ],
        }
    }

    /// A `ptsa discover --json` result `v` made with the instrument file `instr`: its
    /// calibration (`calibration.changes`: the fitted changes with their covariance, the
    /// values the sheet and `--write-instrument` give). A result without them (made before
    /// ptsa had them) is read through its selected `effects`, their standard errors and the
    /// `model_equation` correlation, with a note.
    ///
    /// # Errors
    /// The calibration changes a parameter of the instrument file's loop (the analytic
    /// model equation has no term for it), a candidate is unknown, or a number is not
    /// finite (a standard error below 0).
    pub fn from_discover_json(v: &serde_json::Value, instr: &Instrument) -> Result<Self> {
        let Applied {
            effects,
            terms,
            cov,
            mut notes,
            statuses,
        } = if let Some(a) = changes(v)? {
            a
        } else {
            selected_effects(v)?
        };
        let params: Vec<&str> = effects
            .nonzero()
            .filter(|(id, _)| id.parameter_key().is_some())
            .map(|(id, _)| id.info().name)
            .collect();
        if !params.is_empty() {
            bail!(
                "the calibration changes the loop parameter(s) {}, which `correct` cannot apply: it inverts the static model equation, which has no term for a loop parameter; expected a calibration of the model equation's terms (`ptsa discover --analytic`, or `--candidates` without the loop's parameters)",
                params
                    .iter()
                    .map(|p| format!("`{p}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        notes.extend(partner_notes(v));
        let untested = untested(v);
        let unapplied = unapplied(v, instr, statuses, &mut notes);
        if effects.is_zero() && terms.is_empty() {
            notes.push(
                "the calibration measured no term: the instrument file's model is applied as it is, with no uncertainty of its own".to_string(),
            );
        }
        Ok(Self {
            sim: AnalyticSimulator::for_instrument(instr),
            effects,
            terms,
            cov,
            untested,
            unapplied,
            notes,
        })
    }

    /// Local gravity of the instrument file, cm/s².
    #[must_use]
    pub fn g_cm_s2(&self) -> f64 {
        self.sim.g_cm_s2()
    }

    /// The calibration's warm-up, if it has one: its name, amplitude (cm/s²) and time
    /// constant (s; `None` for a grid point, whose τ is a fraction of each file's span).
    /// It acts on a row only through the row's time since power-on (`time_s`).
    #[must_use]
    pub fn warm_up(&self) -> Option<(&'static str, f64, Option<f64>)> {
        self.effects
            .nonzero()
            .find(|(id, _)| id.profiled())
            .map(|(id, a)| {
                let tau = (id == CandidateId::WarmUp).then(|| self.effects.warm_up_tau_s());
                (id.info().name, a, tau)
            })
    }

    /// The reading the model gives for `row` with `a_IA` = `x` g and effects `e`, cm/s².
    fn reading(&self, row: &Condition, x: f64, e: &Effects) -> f64 {
        let mut r = row.clone();
        r.g[IA] = x;
        self.sim.absolute_cm_s2(&r, e)
    }
}

/// A model-equation term the calibration does not apply: not measured by it (its status
/// is not `selected` or `fitted`; docs/method/discovery.md, `ptsa correct`).
#[derive(Clone, Debug)]
struct Unapplied {
    /// Which term.
    term: Coefficient,
    /// The 1 σ it enters with, in its IEEE change unit (µg, ppm, µrad, µg/g², µg/g³):
    /// `√(change² + σ²)` when the data measured it (`fitted`, or `not_significant` with
    /// `if_fitted`), its plausibility bound over √3 (uniform within the bound) when they did
    /// not (`not_measured`, `not_separable`).
    sigma_ieee: f64,
    /// The applied terms (the selected ones) whose columns took up part of it over the
    /// calibration's design, with how much of each.
    absorbed: Vec<(Coefficient, f64)>,
    /// Whether `sigma_ieee` is the plausibility bound's (the data did not measure it).
    from_bound: bool,
}

impl Unapplied {
    /// What of the term's column at `a` (`a_i`, `a_p`, `a_o` in g) the applied terms do not hold.
    fn left_over(&self, a: [f64; 3]) -> f64 {
        column(self.term, a)
            - self
                .absorbed
                .iter()
                .map(|&(t, c)| c * column(t, a))
                .sum::<f64>()
    }
}

/// A term's column in the model equation at `a` (`a_i`, `a_p`, `a_o` in g), dimensionless: its
/// contribution to `E/K_1` in g is its IEEE value (10⁻⁶ of its change unit) times this.
fn column(t: Coefficient, [i, p, o]: [f64; 3]) -> f64 {
    match t {
        Coefficient::K0 => 1.0,
        Coefficient::K1 => i,
        Coefficient::K2 => i * i,
        Coefficient::K3 => i * i * i,
        Coefficient::DeltaO => p,
        Coefficient::DeltaP => -o,
        Coefficient::Kip => i * p,
        Coefficient::Kio => i * o,
        Coefficient::Kpo => p * o,
        Coefficient::Kpp => p * p,
        Coefficient::Koo => o * o,
    }
}

/// The terms of `calibration.terms` the result does not apply, each with its uncertainty
/// and, from `calibration.design_g`, the part of its column the selected terms took up; a
/// note when the result has no `calibration` object or no design.
fn unapplied(
    v: &serde_json::Value,
    instr: &Instrument,
    applied: &[&str],
    notes: &mut Vec<String>,
) -> Vec<Unapplied> {
    let Some(terms) = v
        .get("calibration")
        .and_then(|c| c.get("terms"))
        .and_then(serde_json::Value::as_array)
    else {
        notes.push("the calibration gives no `calibration` object (a `ptsa discover --json` result has one): the model-equation terms it did not select carry no uncertainty in the corrected values' sigmas".to_string());
        return Vec::new();
    };
    let g = instr.g_cm_s2;
    let def_of = |t: &serde_json::Value| {
        let sym = t.get("symbol").and_then(serde_json::Value::as_str)?;
        TERMS.iter().find(|d| d.symbol == sym)
    };
    let selected: Vec<Coefficient> = terms
        .iter()
        .filter(|t| status(t).is_some_and(|st| applied.contains(&st)))
        .filter_map(|t| def_of(t).map(|d| d.coefficient))
        .collect();
    let design: Vec<[f64; 3]> = v
        .get("calibration")
        .and_then(|c| c.get("design_g"))
        .and_then(serde_json::Value::as_array)
        .map(|rows| {
            rows.iter()
                .filter_map(|r| {
                    let r = r.as_array()?;
                    Some([
                        r.first()?.as_f64()?,
                        r.get(1)?.as_f64()?,
                        r.get(2)?.as_f64()?,
                    ])
                })
                .collect()
        })
        .unwrap_or_default();
    if design.is_empty() {
        notes.push("the calibration gives no design (`calibration.design_g`): the terms it did not select enter the sigmas with their whole column, as if its selected terms had taken up none of them".to_string());
    }
    let num = |t: &serde_json::Value, k: &str| t.get(k).and_then(serde_json::Value::as_f64);
    let mut out = Vec::new();
    for t in terms {
        let (Some(def), Some(st)) = (def_of(t), status(t)) else {
            continue;
        };
        if applied.contains(&st) {
            continue;
        }
        let nominal = num(t, "nominal").unwrap_or(0.0);
        let measured = match st {
            "fitted" => num(t, "change")
                .zip(num(t, "change_sigma"))
                .map(|(c, s)| c.hypot(s)),
            _ => t
                .get("if_fitted")
                .and_then(serde_json::Value::as_array)
                .and_then(|a| Some((a.first()?.as_f64()? - nominal).hypot(a.get(1)?.as_f64()?))),
        };
        let from_bound = measured.is_none();
        let sigma_ieee = measured.unwrap_or_else(|| {
            let c = def.candidate.info();
            c.bound.limit(instr) * (c.ieee.2)(g) / 3f64.sqrt()
        });
        if !(sigma_ieee.is_finite() && sigma_ieee > 0.0) {
            continue;
        }
        out.push(Unapplied {
            term: def.coefficient,
            sigma_ieee,
            absorbed: absorbed(def.coefficient, &selected, &design),
            from_bound,
        });
    }
    out
}

/// What a result's calibration applies.
struct Applied {
    /// The effects put into the instrument file's model.
    effects: Effects,
    /// Each one's 1 σ, in the effects' units.
    terms: Vec<Term>,
    /// Their covariance.
    cov: Vec<Vec<f64>>,
    /// What the caller should hear about it.
    notes: Vec<String>,
    /// The statuses of `calibration.terms` whose terms it applies: the calibration's every
    /// measured term, or an older result's selected ones.
    statuses: &'static [&'static str],
}

/// The calibration's changes (`calibration.changes`) as effects, each candidate with its
/// 1 σ, and their covariance; `None` for a result without them.
///
/// # Errors
/// An unknown candidate, lists of different lengths, or a number that is not finite.
fn changes(v: &serde_json::Value) -> Result<Option<Applied>> {
    let Some(c) = v.get("calibration").and_then(|c| c.get("changes")) else {
        return Ok(None);
    };
    let at = "calibration.changes";
    let list = |k: &str| {
        c.get(k)
            .and_then(serde_json::Value::as_array)
            .ok_or_else(|| anyhow::anyhow!("{at}: expected the array \"{k}\""))
    };
    let number = |x: &serde_json::Value, what: String| {
        x.as_f64()
            .filter(|x| x.is_finite())
            .ok_or_else(|| anyhow::anyhow!("{at}.{what}: expected a finite number, found {x}"))
    };
    let (names, values, sigmas) = (list("candidates")?, list("values")?, list("sigmas")?);
    let rows = list("covariance")?;
    let n = names.len();
    if values.len() != n || sigmas.len() != n || rows.len() != n {
        bail!(
            "{at}: {n} candidates but {} values, {} sigmas and {} covariance rows; expected one of each per candidate",
            values.len(),
            sigmas.len(),
            rows.len()
        );
    }
    let mut e = Effects::NONE;
    let mut terms = Vec::with_capacity(n);
    for (j, name) in names.iter().enumerate() {
        let id = name
            .as_str()
            .and_then(CandidateId::from_name)
            .ok_or_else(|| anyhow::anyhow!("{at}.candidates[{j}]: {name} is not a candidate"))?;
        e.add(id, number(&values[j], format!("values[{j}]"))?);
        let se = number(&sigmas[j], format!("sigmas[{j}]"))?;
        if se < 0.0 {
            bail!("{at}.sigmas[{j}]: {se}; expected a standard error of 0 or more");
        }
        terms.push((id, se));
    }
    let mut cov = vec![vec![0.0; n]; n];
    for (i, row) in rows.iter().enumerate() {
        let row = row.as_array().filter(|r| r.len() == n).ok_or_else(|| {
            anyhow::anyhow!("{at}.covariance[{i}]: expected an array of {n} numbers")
        })?;
        for (j, x) in row.iter().enumerate() {
            cov[i][j] = number(x, format!("covariance[{i}][{j}]"))?;
        }
    }
    if let Some(tau) = c.get("warm_up_tau_s").and_then(serde_json::Value::as_f64) {
        e = e.with_warm_up_tau_s(tau);
    }
    Ok(Some(Applied {
        effects: e,
        terms,
        cov,
        notes: Vec::new(),
        statuses: &["selected", "fitted"],
    }))
}

/// The effects of a `ptsa discover --json` result (the whole object, or its `effects`
/// array): each entry's `name` and `coefficients` keys name a candidate of the registry;
/// `warm_up.a_cm_s2` takes its time constant from the entry's `time_constant.tau_s` (s).
///
/// # Errors
/// Not such an object, an effect name or coefficient key that is not in the registry, or
/// `warm_up.a_cm_s2` without a positive `time_constant.tau_s`.
pub fn effects_from_json(v: &serde_json::Value) -> Result<Effects> {
    let list = v.get("effects").unwrap_or(v);
    let Some(list) = list.as_array() else {
        anyhow::bail!(
            "expected the JSON of `ptsa discover --json` (an object with \"effects\") or its \"effects\" array"
        );
    };
    let mut e = Effects::NONE;
    for (k, item) in list.iter().enumerate() {
        let name = item
            .get("name")
            .and_then(serde_json::Value::as_str)
            .with_context(|| format!("effects[{k}]: expected a \"name\""))?;
        let coefs = item
            .get("coefficients")
            .and_then(serde_json::Value::as_object)
            .with_context(|| format!("effects[{k}] ({name}): expected \"coefficients\""))?;
        for (key, val) in coefs {
            let id = crate::model::effects::REGISTRY
                .iter()
                .find(|c| c.effect == name && c.key == key)
                .map(|c| c.id)
                .with_context(|| {
                    format!(
                        "effects[{k}]: `{name}.{key}` is not a candidate; expected one of: {}",
                        crate::model::effects::REGISTRY
                            .iter()
                            .map(|c| format!("{}.{}", c.effect, c.key))
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                })?;
            let x = val.as_f64().filter(|x| x.is_finite()).with_context(|| {
                format!("effects[{k}]: `{name}.{key}`: expected a finite number")
            })?;
            e.add(id, x);
            if id == CandidateId::WarmUp {
                let tau = item
                    .get("time_constant")
                    .and_then(|t| t.get("tau_s"))
                    .and_then(serde_json::Value::as_f64)
                    .filter(|t| t.is_finite() && *t > 0.0)
                    .with_context(|| {
                        format!(
                            "effects[{k}]: `{name}.{key}` needs its time constant: expected \"time_constant\": {{\"tau_s\": τ}} with τ > 0 in s, as `ptsa discover --json` writes it"
                        )
                    })?;
                e = e.with_warm_up_tau_s(tau);
            }
        }
    }
    Ok(e)
}

/// An older result without `calibration.changes`: its selected effects with their
/// standard errors (`effects[].stderr`) and correlation (`model_equation`), and a note.
///
/// # Errors
/// As [`effects_from_json`], or a standard error that is not a number of 0 or more.
fn selected_effects(v: &serde_json::Value) -> Result<Applied> {
    let effects = effects_from_json(v)?;
    let (terms, mut notes) = standard_errors(v, &effects)?;
    notes.insert(0, "the result has no `calibration.changes` (made before ptsa had them): its selected effects are applied, which are not the calibration its sheet gives; run discover again for one calibration".to_string());
    let n = terms.len();
    let mut cov: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| if i == j { terms[i].1 * terms[i].1 } else { 0.0 })
                .collect()
        })
        .collect();
    match correlation(v) {
        Some((names, rho)) => {
            let at = |id: CandidateId| names.iter().position(|n| *n == id.info().name);
            for i in 0..n {
                for j in 0..n {
                    if let (true, Some(a), Some(b)) = (i != j, at(terms[i].0), at(terms[j].0)) {
                        cov[i][j] = rho[a][b].unwrap_or(0.0) * terms[i].1 * terms[j].1;
                    }
                }
            }
        }
        None if n > 1 => notes.push(
            "the calibration gives no `model_equation` correlation: its terms are taken as uncorrelated, which may misstate the corrected values' sigmas".to_string(),
        ),
        None => {}
    }
    Ok(Applied {
        effects,
        terms,
        cov,
        notes,
        statuses: &["selected"],
    })
}

/// A calibration term's `status`.
fn status(t: &serde_json::Value) -> Option<&str> {
    t.get("status").and_then(serde_json::Value::as_str)
}

/// How much of each selected term's column takes up `term`'s over `design` (least squares;
/// nothing when the design is empty or the fit fails).
fn absorbed(
    term: Coefficient,
    selected: &[Coefficient],
    design: &[[f64; 3]],
) -> Vec<(Coefficient, f64)> {
    if design.is_empty() || selected.is_empty() {
        return Vec::new();
    }
    let z: Vec<f64> = design.iter().map(|&a| column(term, a)).collect();
    let cols: Vec<Vec<f64>> = selected
        .iter()
        .map(|&s| design.iter().map(|&a| column(s, a)).collect())
        .collect();
    let refs: Vec<&[f64]> = cols.iter().map(Vec::as_slice).collect();
    crate::stats::lsq(&z, &refs)
        .map_or_else(Vec::new, |f| selected.iter().copied().zip(f.beta).collect())
}

/// The model equation's term names and their correlation (`null` entries, which a term
/// without variance gives, as `None`), if the JSON holds them.
/// A fitted coefficient and its standard error, in the effect's unit.
type Term = (CandidateId, f64);

/// The standard error of each of `effects`' coefficients (`effects[].stderr`), with a note
/// for each that has none.
fn standard_errors(v: &serde_json::Value, effects: &Effects) -> Result<(Vec<Term>, Vec<String>)> {
    let mut notes = Vec::new();
    let mut terms: Vec<(CandidateId, f64)> = Vec::new();
    for (id, _) in effects.nonzero() {
        let c = id.info();
        let se = v
            .get("effects")
            .and_then(serde_json::Value::as_array)
            .and_then(|list| {
                list.iter()
                    .find(|e| e.get("name").and_then(serde_json::Value::as_str) == Some(c.effect))
            })
            .and_then(|e| e.get("stderr"))
            .and_then(|s| s.get(c.key));
        match se {
                Some(x) => match x.as_f64().filter(|x| x.is_finite() && *x >= 0.0) {
                    Some(x) => terms.push((id, x)),
                    None => bail!(
                        "effects: the standard error of `{}.{}` is {x}; expected a finite number of {} of 0 or more",
                        c.effect,
                        c.key,
                        c.unit
                    ),
                },
                None => notes.push(format!(
                    "the calibration gives no standard error of `{}.{}`: its uncertainty is not in the corrected values' sigmas",
                    c.effect, c.key
                )),
            }
    }
    Ok((terms, notes))
}

/// A note for each effect the calibration's data could not tell from others
/// (`effects[].confounded_with`).
fn partner_notes(v: &serde_json::Value) -> Vec<String> {
    let mut notes = Vec::new();
    for e in v
        .get("effects")
        .and_then(serde_json::Value::as_array)
        .into_iter()
        .flatten()
    {
        let partners: Vec<&str> = e
            .get("confounded_with")
            .and_then(serde_json::Value::as_array)
            .into_iter()
            .flatten()
            .filter_map(serde_json::Value::as_str)
            .collect();
        if let (Some(name), false) = (
            e.get("name").and_then(serde_json::Value::as_str),
            partners.is_empty(),
        ) {
            notes.push(format!(
                    "the calibration's `{name}` is indistinguishable in its data from {}: at inputs its positions did not span, a row may be corrected by the wrong one of them",
                    partners
                        .iter()
                        .map(|p| format!("`{p}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
        }
    }
    notes
}

/// The model-equation candidates the calibration's data could not test (`not_testable`).
fn untested(v: &serde_json::Value) -> Vec<CandidateId> {
    v.get("not_testable")
        .and_then(serde_json::Value::as_array)
        .into_iter()
        .flatten()
        .filter_map(serde_json::Value::as_str)
        .filter_map(CandidateId::from_name)
        .filter(|id| id.parameter_key().is_none())
        .collect()
}

/// The model equation's term names and their correlation matrix.
type Correlation = (Vec<String>, Vec<Vec<Option<f64>>>);

fn correlation(v: &serde_json::Value) -> Option<Correlation> {
    let m = v.get("model_equation")?;
    let names: Vec<String> = m
        .get("terms")?
        .as_array()?
        .iter()
        .map(|t| {
            t.get("name")
                .and_then(serde_json::Value::as_str)
                .map(str::to_string)
        })
        .collect::<Option<_>>()?;
    let rho: Vec<Vec<Option<f64>>> = m
        .get("correlation")?
        .as_array()?
        .iter()
        .map(|row| {
            row.as_array()
                .map(|r| r.iter().map(serde_json::Value::as_f64).collect())
        })
        .collect::<Option<_>>()?;
    (rho.len() == names.len() && rho.iter().all(|r| r.len() == names.len())).then_some((names, rho))
}

/// One row corrected.
#[derive(Clone, Debug, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct Corrected {
    /// The reading, cm/s² (`measured_cm_s2`, or the counts' `SF·(2P/T − 1)`).
    pub reading_cm_s2: f64,
    /// The reading's 1-sigma noise: the stated sigma (or the default), the counting's and
    /// the fixture's, in quadrature, cm/s².
    pub sigma_reading_cm_s2: f64,
    /// The cross-axis input along PA held, cm/s² (the row's `g_pa` times local gravity).
    pub a_pa_cm_s2: f64,
    /// The cross-axis input along OA held, cm/s² (the row's `g_oa` times local gravity).
    pub a_oa_cm_s2: f64,
    /// The specific force along IA that the model says gives the reading, cm/s².
    pub a_ia_cm_s2: f64,
    /// The same in g (of the instrument file's local gravity).
    pub a_ia_g: f64,
    /// The 1-sigma uncertainty of `a_ia_cm_s2`, cm/s²: `sigma_noise_cm_s2` and
    /// `sigma_calibration_cm_s2` in quadrature.
    pub sigma_a_ia_cm_s2: f64,
    /// The part of `sigma_a_ia_cm_s2` from the reading's noise, cm/s².
    pub sigma_noise_cm_s2: f64,
    /// The part of `sigma_a_ia_cm_s2` from the calibration's covariance, cm/s² (shared by
    /// every row corrected with the same calibration: the rows' errors are correlated
    /// through it).
    pub sigma_calibration_cm_s2: f64,
}

/// Whether the candidate named `name` is a model-equation term `cal` enters at its
/// plausibility bound (not measured by the calibration's data).
#[must_use]
pub fn at_its_bound(cal: &Calibration, name: &str) -> bool {
    cal.unapplied
        .iter()
        .any(|u| u.from_bound && TERMS[u.term as usize].candidate.info().name == name)
}

/// The terms the calibration could not test that act on `row` at its corrected input
/// (`c.a_ia_g` along IA): their error is in neither the row's value nor its sigma. A term
/// acts when, at its plausibility bound, it would move the reading by more than a tenth of
/// the row's noise (a level table's `a_IA·a_OA` of a few µg² does not).
#[must_use]
pub fn untested_terms(cal: &Calibration, row: &Condition, c: &Corrected) -> Vec<CandidateId> {
    let mut r = row.clone();
    r.g[IA] = c.a_ia_g;
    let g = cal.g_cm_s2();
    let inputs = r.inputs_at(0.0, g);
    let floor = 0.1 * c.sigma_noise_cm_s2.max(1e-9 * g);
    let instr = cal.sim.instrument();
    cal.untested
        .iter()
        .copied()
        .filter(|id| {
            let bound = instr.map_or(1.0, |i| id.info().bound.limit(i));
            (id.term_cm_s2(&inputs) * bound).abs() > floor
        })
        .collect()
}

/// Why a row cannot be corrected (the caller names the file and line).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// Not an absolute row.
    Kind(RowKind),
    /// Rates, an oscillation or a centrifuge arm.
    NotStatic,
    /// No specific force along IA gives the reading (the model's slope vanishes, or the
    /// search does not converge).
    NoSolution,
}

/// Correct one row (after `with_counts` and `with_history`): `None` when it has no
/// reading; `default_sigma_cm_s2` is its noise when it states none (`sigma_cm_s2`).
///
/// # Errors
/// The row is not absolute, not static, or no specific force gives its reading.
pub fn correct_row(
    cal: &Calibration,
    row: &Condition,
    default_sigma_cm_s2: Option<f64>,
) -> Result<Option<Corrected>, Refusal> {
    if row.kind != RowKind::Absolute {
        return Err(Refusal::Kind(row.kind));
    }
    if !row.is_static() || row.w_rad_s.iter().any(|&w| w != 0.0) || row.radius_cm != 0.0 {
        return Err(Refusal::NotStatic);
    }
    let Some(y) = row.measured_cm_s2 else {
        return Ok(None);
    };
    let g = cal.g_cm_s2();
    let e = &cal.effects;
    let f = |x: f64| cal.reading(row, x, e);
    // Newton's method from the linear model's answer; the slope by central differences
    // (the model is a polynomial of degree 3 at most in a_IA).
    let slope = |x: f64| {
        let h = 1e-4;
        (f(x + h) - f(x - h)) / (2.0 * h)
    };
    let (f0, f1) = (f(0.0), f(1.0));
    let span = f1 - f0;
    if !span.is_finite() || span == 0.0 {
        return Err(Refusal::NoSolution);
    }
    let mut x = (y - f0) / span;
    let mut converged = false;
    for _ in 0..100 {
        let d = slope(x);
        if !d.is_finite() || d.abs() < 1e-9 * g {
            return Err(Refusal::NoSolution);
        }
        let dx = (f(x) - y) / d;
        x -= dx;
        if !x.is_finite() {
            return Err(Refusal::NoSolution);
        }
        if dx.abs() <= 1e-14 * x.abs().max(1.0) {
            converged = true;
            break;
        }
    }
    if !converged || (f(x) - y).abs() > 1e-9 * y.abs().max(g) {
        return Err(Refusal::NoSolution);
    }
    // cm/s² of reading per cm/s² along IA.
    let d = slope(x) / g;
    let sigma_reading = row
        .sigma_cm_s2
        .or(default_sigma_cm_s2)
        .unwrap_or(0.0)
        .hypot(row.counting_sigma_cm_s2.unwrap_or(0.0))
        .hypot(row.fixture_sigma_cm_s2(g));
    let sigma_noise = sigma_reading / d.abs();
    // The reading's change per coefficient (exact for terms linear in it).
    let jac: Vec<f64> = cal
        .terms
        .iter()
        .map(|&(id, se)| {
            let h = if se > 0.0 { se } else { 1.0 };
            let (mut up, mut down) = (*e, *e);
            up.add(id, h);
            down.add(id, -h);
            (cal.reading(row, x, &up) - cal.reading(row, x, &down)) / (2.0 * h)
        })
        .collect();
    let mut var = 0.0;
    for (i, ji) in jac.iter().enumerate() {
        for (j, jj) in jac.iter().enumerate() {
            var += ji * cal.cov[i][j] * jj;
        }
    }
    // The terms not applied: each at its uncertainty times what of its column the applied
    // terms did not take up over the calibration's design.
    let at = [x, row.g[PA], row.g[OA]];
    for u in &cal.unapplied {
        var += (u.sigma_ieee * 1e-6 * g * u.left_over(at)).powi(2);
    }
    let sigma_cal = var.max(0.0).sqrt() / d.abs();
    let a = x * g;
    Ok(Some(Corrected {
        reading_cm_s2: y,
        sigma_reading_cm_s2: sigma_reading,
        a_pa_cm_s2: row.g[PA] * g,
        a_oa_cm_s2: row.g[OA] * g,
        a_ia_cm_s2: a,
        a_ia_g: x,
        sigma_a_ia_cm_s2: sigma_noise.hypot(sigma_cal),
        sigma_noise_cm_s2: sigma_noise,
        sigma_calibration_cm_s2: sigma_cal,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(g_pa: f64, y: f64) -> Condition {
        Condition {
            label: "r".into(),
            kind: RowKind::Absolute,
            g: [0.0, g_pa, 0.0],
            measured_cm_s2: Some(y),
            sigma_cm_s2: Some(0.01),
            ..Condition::default()
        }
    }

    /// The inverse of the model: the reading the model gives at a known `a_IA` comes back
    /// as that `a_IA`; the noise is divided by the slope; a term's standard error adds its
    /// part of the reading at that input.
    #[test]
    fn the_model_equation_is_inverted() {
        let instr = Instrument::kearfott_2401();
        let effects = Effects::NONE
            .with(CandidateId::Bias, 0.5)
            .with(CandidateId::ScaleFactor, -150.0)
            .with(CandidateId::MisalignmentP, 1e-4)
            .with(CandidateId::Nonlinearity, 2e-8);
        let v = serde_json::json!({
            "effects": [
                {"name": "bias", "coefficients": {"k0_cm_s2": 0.5}, "stderr": {"k0_cm_s2": 0.002}},
                {"name": "scale_factor", "coefficients": {"k1_ppm": -150.0}, "stderr": {"k1_ppm": 3.0}},
                {"name": "misalignment", "coefficients": {"delta_p_rad": 1e-4}, "stderr": {"delta_p_rad": 0.0}},
                {"name": "nonlinearity", "coefficients": {"k2_s2_cm": 2e-8}, "stderr": {"k2_s2_cm": 0.0}},
            ],
        });
        let cal = Calibration::from_discover_json(&v, &instr).unwrap();
        let g = cal.g_cm_s2();
        for (a_g, g_pa) in [(0.7, 0.3), (-1.0, 0.0), (0.0, 1.0), (2.5, -0.2)] {
            let mut r = row(g_pa, 0.0);
            r.g[IA] = a_g;
            let y = cal.sim.absolute_cm_s2(&r, &effects);
            let c = correct_row(&cal, &row(g_pa, y), None).unwrap().unwrap();
            assert!((c.a_ia_cm_s2 - a_g * g).abs() < 1e-9, "{a_g}: {c:?}");
            let slope = 1.0 - 150e-6 + 2.0 * 2e-8 * a_g * g;
            assert!((c.sigma_noise_cm_s2 - 0.01 / slope).abs() < 1e-9, "{c:?}");
            // Bias and scale factor, uncorrelated (no model_equation): 0.002 and 3 ppm of
            // the input.
            let want = 0.002f64.hypot(3e-6 * a_g * g) / slope;
            assert!(
                (c.sigma_calibration_cm_s2 / want - 1.0).abs() < 1e-6,
                "{a_g}: {} against {want}",
                c.sigma_calibration_cm_s2
            );
        }
        assert!(cal.notes.iter().any(|n| n.contains("uncorrelated")));
        // A correlation of 1 between bias and scale factor adds the parts.
        let mut v2 = v.clone();
        v2["model_equation"] = serde_json::json!({
            "terms": [{"name": "bias"}, {"name": "scale_factor"}, {"name": "misalignment.delta_p_rad"}, {"name": "nonlinearity"}],
            "correlation": [[1.0, 1.0, 0.0, 0.0], [1.0, 1.0, 0.0, 0.0], [0.0, 0.0, null, null], [0.0, 0.0, null, null]],
        });
        let cal2 = Calibration::from_discover_json(&v2, &instr).unwrap();
        let mut r = row(0.0, 0.0);
        r.g[IA] = 1.0;
        let y = cal2.sim.absolute_cm_s2(&r, &effects);
        let c = correct_row(&cal2, &row(0.0, y), None).unwrap().unwrap();
        let slope = 1.0 - 150e-6 + 2.0 * 2e-8 * g;
        assert!(
            (c.sigma_calibration_cm_s2 / ((0.002 + 3e-6 * g) / slope) - 1.0).abs() < 1e-6,
            "{c:?}"
        );
    }

    #[test]
    fn rows_that_cannot_be_corrected_are_refused() {
        let cal = Calibration::of_instrument(&Instrument::kearfott_2401());
        let mut r = row(0.0, 1.0);
        r.kind = RowKind::Difference;
        assert_eq!(
            correct_row(&cal, &r, None),
            Err(Refusal::Kind(RowKind::Difference))
        );
        let mut r = row(0.0, 1.0);
        r.w_rad_s = [0.0, 0.0, 1.0];
        assert_eq!(correct_row(&cal, &r, None), Err(Refusal::NotStatic));
        let mut r = row(0.0, 1.0);
        r.measured_cm_s2 = None;
        assert_eq!(correct_row(&cal, &r, None), Ok(None));
        // A loop parameter cannot be applied.
        let v = serde_json::json!({"calibration": {"changes": {
            "candidates": ["torquer_sf"], "values": [0.01], "sigmas": [0.001],
            "units": ["mA/g"], "covariance": [[1e-6]], "warm_up_tau_s": null}}});
        let m = Calibration::from_discover_json(&v, &Instrument::kearfott_2401())
            .err()
            .unwrap()
            .to_string();
        assert!(m.contains("`torquer_sf`"), "{m}");
    }

    /// The calibration's changes are what is applied, with their covariance; the selected
    /// effects of the same result are not.
    #[test]
    fn the_calibrations_changes_are_applied() {
        let instr = Instrument::kearfott_2401();
        let v = serde_json::json!({
            "effects": [{"name": "bias", "coefficients": {"k0_cm_s2": 9.0}, "stderr": {"k0_cm_s2": 1.0}}],
            "calibration": {"changes": {
                "candidates": ["bias", "scale_factor"], "values": [0.5, -150.0],
                "sigmas": [0.002, 3.0], "units": ["cm/s²", "ppm"],
                "covariance": [[4e-6, 0.006], [0.006, 9.0]], "warm_up_tau_s": null}},
        });
        let cal = Calibration::from_discover_json(&v, &instr).unwrap();
        let truth = Effects::NONE
            .with(CandidateId::Bias, 0.5)
            .with(CandidateId::ScaleFactor, -150.0);
        let g = cal.g_cm_s2();
        let mut r = row(0.0, 0.0);
        r.g[IA] = 1.0;
        let y = cal.sim.absolute_cm_s2(&r, &truth);
        let c = correct_row(&cal, &row(0.0, y), None).unwrap().unwrap();
        assert!((c.a_ia_cm_s2 - g).abs() < 1e-9, "{c:?}");
        // Correlation +1 (0.006 = 0.002 × 3): the parts add.
        let slope = 1.0 - 150e-6;
        let want = (0.002 + 3e-6 * g) / slope;
        assert!(
            (c.sigma_calibration_cm_s2 / want - 1.0).abs() < 1e-6,
            "{c:?}"
        );
        assert!(cal.notes.iter().all(|n| !n.contains("calibration.changes")));
        // Malformed: a length that does not match, a name that is no candidate.
        let mut bad = v.clone();
        bad["calibration"]["changes"]["values"] = serde_json::json!([0.5]);
        let m = Calibration::from_discover_json(&bad, &instr)
            .err()
            .unwrap()
            .to_string();
        assert!(m.contains("2 candidates but 1 values"), "{m}");
        let mut bad = v.clone();
        bad["calibration"]["changes"]["candidates"][0] = serde_json::json!("bais");
        let m = Calibration::from_discover_json(&bad, &instr)
            .err()
            .unwrap()
            .to_string();
        assert!(
            m.contains("calibration.changes.candidates[0]: \"bais\" is not a candidate"),
            "{m}"
        );
    }
}
