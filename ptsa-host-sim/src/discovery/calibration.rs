//! The instrument's own model equation (`calibration` in the `--json` object): every term of
//! the IEEE Std 1293 model equation of a pendulous accelerometer as the instrument's
//! absolute value (the instrument file's nominal value plus the change the data measure),
//! with its 1 σ, its k = 2 expanded uncertainty and the correlation matrix. This is the one
//! calibration ptsa hands over: the text report, the sheet, `--write-instrument` and `ptsa
//! correct` all render or apply these values (`calibration.changes`).
//!
//! The equation and its signs (the convention):
//!
//! ```text
//! E/K_1 = K_0 + a_i + K_2·a_i² + K_3·a_i³ + δ_o·a_p − δ_p·a_o
//!         + K_ip·a_i·a_p + K_io·a_i·a_o + K_po·a_p·a_o + K_pp·a_p² + K_oo·a_o²
//! ```
//!
//! `E` the output (net pulses per second of the loop's clock; a loop-less instrument's
//! reading in its unit), `a_i`, `a_p`, `a_o` the specific force along IA, PA, OA in g; `δ_o`
//! the tilt of IA toward PA (a rotation about OA), `δ_p` the tilt of IA toward OA (about
//! PA), entering with a minus sign. Every term is **input-referred**: `K_0` is the input
//! that reads as zero, not the reading's offset (that is `reading_offset`).
//!
//! How the discovery's coefficients become these values. A reading in cm/s² is the counts
//! read through the nominal scale factor, `SF_nom·(2P/T − 1) = E·SF_nom/f_clk`; the model
//! is additive in the reading: `reading = a_i + Σ c_j·column_j` where the instrument file's
//! terms (`bias_cm_s2`, `[model_equation]`) are the reading's own coefficients
//! (**output-referred**) and discovery fits changes of them (`scale_factor` adds
//! `c·1e-6·a_i`, `misalignment.delta_p_rad` `c·a_p`, `misalignment.delta_o_rad` `c·a_o`,
//! `nonlinearity` `c·a_i²`, all in cm/s²). With `ε = 1e-6·(k1_ppm + c_scale_factor)` the
//! reading is `(1 + ε)·g·(E/K_1)`: every other term is the reading's coefficient divided by
//! `1 + ε`. So `K_0 = (A_b + c_bias)/(1 + ε)` (`A_b` the file's bias with the loop's own),
//! `δ_o = (δ_o,file + c_delta_p)/(1 + ε)`, `δ_p = (δ_p,file − c_delta_o)/(1 + ε)` (the
//! candidate `misalignment.delta_o_rad` is `−δ_p`'s change), `K_2 = (K_2,file +
//! c_nonlinearity)/(1 + ε)`, and `K_1 = K_1,base·(1 + ε)`. The uncertainties follow by
//! first-order propagation through the full covariance of the fitted coefficients.
//!
//! Which coefficients are fitted: the nuisance terms, then the core terms (`K_0`, `K_1`,
//! `δ_o`, `δ_p`, `K_2`: what every accelerometer calibration reports) that the data test,
//! named by the selection or not, then every selected term that is not doubtful, each
//! where its column is separable from those already fitted. A selected term outside the
//! core that is rivaled (a form outside the vocabulary fits in its place) or implausible
//! (beyond the file's bound) is doubtful: it is left out, so that it cannot move the core
//! terms, and listed in `doubtful` with its value and the core terms' values if it were
//! real. A tumble, which cannot tell `K_2` from `K_pp` (about OA) or `K_oo` (about PA) and
//! the bias, gives the second-order term to `K_2`, as the standard's tumble analysis does,
//! whichever of them the selection named (the other is listed `not_separable`, with a
//! note). A higher-order term the selection did not name is listed at its nominal value,
//! with what the data say of it when fitted beside the others (`if_fitted`). The values of
//! the selected terms can therefore differ from discovery's `effects` and `model_equation`
//! (the selection's fit), within their uncertainties when the extra terms are not
//! significant.
//!
//! Where it fails: the coverage of the k = 2 intervals was measured on tumbles written from
//! the equation (`cargo xtask hidden --calibration`, `ptsa-campaigns/src/calibration.rs`); a term
//! the model equation does not hold (a hysteresis, a temperature or time dependence) that the
//! selection does not name biases the terms whose columns it shares.

pub mod show;

pub use show::{equation_with_values, table, text_block};

use super::problem::{Problem, Selected};
use super::report::{
    Calibration, CalibrationChanges, CalibrationTerm, CoreValue, DoubtfulTerm, ReadingOffset,
};
use crate::model::effects::CandidateId;
use crate::model::instrument::Instrument;
use crate::stats::{birge_ratio, lsq, norm};

/// A term of the model equation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coefficient {
    /// `K_0`, the bias.
    K0,
    /// `K_1`, the scale factor.
    K1,
    /// `K_2`, second order in `a_i`.
    K2,
    /// `K_3`, third order in `a_i`.
    K3,
    /// `δ_o`, IA tilted toward PA.
    DeltaO,
    /// `δ_p`, IA tilted toward OA.
    DeltaP,
    /// `K_ip`, the `a_i·a_p` cross-coupling.
    Kip,
    /// `K_io`, the `a_i·a_o` cross-coupling.
    Kio,
    /// `K_po`, the `a_p·a_o` cross-coupling.
    Kpo,
    /// `K_pp`, the `a_p²` cross-axis term.
    Kpp,
    /// `K_oo`, the `a_o²` cross-axis term.
    Koo,
}

/// One term's definition.
#[derive(Clone, Copy, Debug)]
pub struct TermDef {
    /// Which term.
    pub coefficient: Coefficient,
    /// Its IEEE Std 1293 symbol.
    pub symbol: &'static str,
    /// The candidate whose coefficient is its change.
    pub candidate: CandidateId,
    /// `+1`, or `−1` when the candidate's coefficient is the change of the term's negative
    /// (`δ_p`: the candidate `misalignment.delta_o_rad` adds `c·a_o = −δ_p·a_o`).
    pub sign: f64,
    /// Its cgs unit.
    pub unit_cgs: &'static str,
    /// A term every calibration reports (the bias, the scale factor, the misalignments and
    /// `K_2`): fitted whenever the data test it and its column is separable from the
    /// others', named by the selection or not.
    pub core: bool,
}

/// The model equation's terms, in the equation's order.
pub const TERMS: [TermDef; 11] = {
    use CandidateId as C;
    use Coefficient as K;
    const fn t(
        coefficient: Coefficient,
        symbol: &'static str,
        candidate: CandidateId,
        sign: f64,
        unit_cgs: &'static str,
    ) -> TermDef {
        TermDef {
            coefficient,
            symbol,
            candidate,
            sign,
            unit_cgs,
            core: matches!(
                coefficient,
                Coefficient::K0
                    | Coefficient::K1
                    | Coefficient::K2
                    | Coefficient::DeltaO
                    | Coefficient::DeltaP
            ),
        }
    }
    [
        t(K::K0, "K_0", C::Bias, 1.0, "cm/s²"),
        t(K::K1, "K_1", C::ScaleFactor, 1.0, "cm/s² full scale"),
        t(K::K2, "K_2", C::Nonlinearity, 1.0, "s²/cm"),
        t(K::K3, "K_3", C::Cubic, 1.0, "s⁴/cm²"),
        t(K::DeltaO, "δ_o", C::MisalignmentP, 1.0, "rad"),
        t(K::DeltaP, "δ_p", C::MisalignmentO, -1.0, "rad"),
        t(K::Kip, "K_ip", C::Vibropendulosity, 1.0, "s²/cm"),
        t(K::Kio, "K_io", C::Anisoelasticity, 1.0, "s²/cm"),
        t(K::Kpo, "K_po", C::CrossAxisPo, 1.0, "s²/cm"),
        t(K::Kpp, "K_pp", C::CrossAxisPp, 1.0, "s²/cm"),
        t(K::Koo, "K_oo", C::CrossAxisOo, 1.0, "s²/cm"),
    ]
};

/// The model equation, symbols only, for an instrument whose output `E` is in pulse/s.
pub const EQUATION: &str = "E/K_1 = K_0 + a_i + K_2·a_i² + K_3·a_i³ + δ_o·a_p − δ_p·a_o + K_ip·a_i·a_p + K_io·a_i·a_o + K_po·a_p·a_o + K_pp·a_p² + K_oo·a_o² (E the output in pulse/s, a_i, a_p, a_o the specific force along IA, PA, OA in g)";

/// The unit of `K_1`.
pub const SCALE_UNIT: &str = "(pulse/s)/g";

/// The unit of the output `E` of `instr`: pulse/s for the PTSA loop, else the reading's
/// unit (cm/s² for a reading given in cm/s², g or m/s² without a scale factor).
#[must_use]
pub fn output_unit(instr: &Instrument) -> String {
    if instr.has_loop {
        "pulse/s".to_string()
    } else {
        instr
            .reading_scale
            .as_ref()
            .map_or_else(|| "cm/s²".to_string(), |r| r.unit.name().to_string())
    }
}

/// [`EQUATION`] with the output unit of `instr`.
#[must_use]
pub fn equation(instr: &Instrument) -> String {
    EQUATION.replace(
        "E the output in pulse/s",
        &format!("E the output in {}", output_unit(instr)),
    )
}

/// `1e-6·k1_ppm` of the instrument file: its nominal scale-factor error.
fn file_eps(instr: &Instrument) -> f64 {
    1e-6 * instr.nominal_model_term(CandidateId::ScaleFactor)
}

/// The instrument file's nominal value of `term`, input-referred: `K_1` in [`SCALE_UNIT`],
/// every other term in its cgs unit ([`TermDef::unit_cgs`]), the reading's coefficient
/// ([`reading_nominal`]) divided by `1 + 1e-6·k1_ppm`.
#[must_use]
pub fn nominal(instr: &Instrument, term: Coefficient) -> f64 {
    let n = reading_nominal(instr, term);
    if term == Coefficient::K1 {
        n
    } else {
        n / (1.0 + file_eps(instr))
    }
}

/// The instrument file's nominal value of `term` as the reading's own coefficient
/// (output-referred; `K_1` in [`SCALE_UNIT`] as in [`nominal`]).
///
/// This is the one place the nominal model-equation terms are looked up: the bias
/// (`bias_cm_s2` of `[electronics]`, or of `[instrument]` for a file without a loop, plus the
/// loop's own bias at `a_p = 0`, zero for a file with no pickoff phase error), the scale
/// factor (`scale_base` times `1 + model_equation.k1_ppm·1e-6`), `δ_o` (the file's
/// `model_equation.delta_o_rad` plus the loop's own bias per cm/s² of `a_p`), and every other
/// term from the file's `[model_equation]` section
/// ([`crate::model::instrument::Instrument::nominal_model_term`], 0 where absent; `δ_p`
/// under its own sign).
#[must_use]
pub fn reading_nominal(instr: &Instrument, term: Coefficient) -> f64 {
    // TERMS is in the enum's order (`terms_are_in_the_enums_order`).
    let def = &TERMS[term as usize];
    // The file's `[model_equation]` term, in the candidate's unit and sign.
    let file = instr.nominal_model_term(def.candidate);
    match term {
        Coefficient::K0 => file + instr.loop_bias_cm_s2(0.0),
        Coefficient::K1 => scale_base(instr) * (1.0 + 1e-6 * file),
        Coefficient::DeltaO => file + instr.loop_bias_cm_s2(1.0) - instr.loop_bias_cm_s2(0.0),
        // `+ 0.0`: a nominal 0 under the sign −1 is 0, not −0.
        _ => def.sign * file + 0.0,
    }
}

/// `K_1` before the file's `model_equation.k1_ppm`: for the PTSA loop `f_clk·g/SF` in
/// [`SCALE_UNIT`]; for an instrument without a loop its nominal reading per g
/// (`instrument.scale_factor_per_g`), or local gravity in (cm/s²)/g when it gives none.
fn scale_base(instr: &Instrument) -> f64 {
    if instr.has_loop {
        instr.clock_hz * instr.g_cm_s2 / instr.sf_cm_s2
    } else {
        instr
            .reading_scale
            .as_ref()
            .map_or(instr.g_cm_s2, |r| r.per_g)
    }
}

/// The unit of `K_1` for `instr` (with [`nominal`]).
#[must_use]
pub fn scale_unit(instr: &Instrument) -> String {
    if instr.has_loop {
        SCALE_UNIT.to_string()
    } else {
        format!("{}/g", output_unit(instr))
    }
}

/// How `K_1` is expressed, in words, for `instr`.
fn scale_words(instr: &Instrument) -> String {
    if !instr.has_loop {
        return format!(
            "K_1 in {}: the instrument's reading per g of input (no PTSA loop: its full scale in cm/s² is not defined, value_cgs is null); nominal {} from the file's instrument.scale_factor_per_g (local gravity when it gives none) and model_equation.k1_ppm",
            scale_unit(instr),
            nominal(instr, Coefficient::K1)
        );
    }
    format!(
        "K_1 in {SCALE_UNIT}: the net pulse rate (pulses up minus down per second of the {} Hz clock) per g of input; nominal f_clk·g/SF·(1 + k1_ppm·1e-6) = {} × {} / {} (the file's clock_hz, local_gravity_cm_s2, scale_factor_cm_s2, and model_equation.k1_ppm when given); the instrument's full scale in cm/s² is f_clk·g/K_1",
        instr.clock_hz, instr.clock_hz, instr.g_cm_s2, instr.sf_cm_s2
    )
}

/// Standard gravity, cm/s² (9.806 65 m/s², the shipped `mems` and `navigation` classes'
/// `local_gravity_cm_s2`).
pub const STANDARD_GRAVITY_CM_S2: f64 = 980.665;

/// Where the local gravity `g` of `instr` came from, in words: the file's key, and for
/// standard gravity the request to put the site's.
#[must_use]
pub fn gravity_source(instr: &Instrument) -> String {
    let key = if instr.has_loop {
        "electronics.local_gravity_cm_s2"
    } else {
        "instrument.local_gravity_cm_s2"
    };
    if instr.gravity_from_command_line {
        return "--local-gravity, in place of the instrument file's".to_string();
    }
    if (instr.g_cm_s2 - STANDARD_GRAVITY_CM_S2).abs() < 1e-9 {
        format!(
            "standard gravity, the instrument file's {key}: put your site's (--local-gravity, or {key} in the file); every value in g, and K_1, moves by the ratio of the two"
        )
    } else {
        format!("the instrument file's {key}")
    }
}

/// The factor from a term's cgs unit to its IEEE unit for local gravity `g` (cm/s²), and
/// the IEEE unit (for every term but `K_1`).
fn ieee(def: &TermDef, g: f64) -> (f64, &'static str) {
    let (_, unit, factor) = def.candidate.info().ieee;
    (factor(g), unit)
}

/// The weighted least-squares fit of the calibration: the nuisance terms and `ids`.
struct CalFit {
    /// The candidates fitted, in order.
    ids: Vec<CandidateId>,
    /// Their coefficients, in the candidates' units.
    coef: Vec<f64>,
    /// Their covariance (the standard errors as discovery's: the Birge ratio when χ²
    /// rejects the sigmas, HC3 when they are estimated, whichever is larger).
    cov: Vec<Vec<f64>>,
    /// Residual degrees of freedom.
    dof: usize,
}

/// The candidate's column over the fitted subset, weighted by `1/σ` and scaled to unit
/// norm, with the scale; `None` without a signature or with a zero column.
fn unit_column(p: &Problem<'_>, id: CandidateId) -> Option<(Vec<f64>, f64)> {
    let f = p.f;
    let sig = p.data.signatures.iter().find(|s| s.id == id)?;
    let c: Vec<f64> = f
        .subset
        .iter()
        .enumerate()
        .map(|(k, &i)| sig.col[i] / f.sigma[k])
        .collect();
    let s = norm(&c);
    if s == 0.0 || !s.is_finite() {
        return None;
    }
    Some((c.iter().map(|x| x / s).collect(), s))
}

/// The fitted candidates (`ids`) whose columns, with the nuisance terms', make up `id`'s:
/// what a term that is not separable cannot be told from.
fn spanned_by(p: &Problem<'_>, ids: &[CandidateId], id: CandidateId) -> Vec<CandidateId> {
    let Some((target, _)) = unit_column(p, id) else {
        return Vec::new();
    };
    let nn = p.f.n_nuisance();
    let unit = p.f.unit_columns();
    let cols: Vec<(CandidateId, Vec<f64>)> = ids
        .iter()
        .filter_map(|&o| Some((o, unit_column(p, o)?.0)))
        .collect();
    let mut refs: Vec<&[f64]> = unit.iter().take(nn).copied().collect();
    refs.extend(cols.iter().map(|(_, c)| c.as_slice()));
    let Some(fit) = lsq(&target, &refs) else {
        return Vec::new();
    };
    cols.iter()
        .enumerate()
        .filter(|&(j, _)| fit.beta[nn + j].abs() > 1e-3)
        .map(|(_, (o, _))| *o)
        .collect()
}

/// Fit the nuisance terms and `ids` to the problem's subset; `None` when a column is
/// missing, zero or dependent on the others.
fn fit_terms(p: &Problem<'_>, ids: &[CandidateId]) -> Option<CalFit> {
    let f = p.f;
    let nn = f.n_nuisance();
    let unit = f.unit_columns();
    if unit.len() < nn {
        return None;
    }
    let z = f.weighted_target();
    let mut cols: Vec<Vec<f64>> = Vec::new();
    let mut scales = Vec::new();
    for &id in ids {
        let (c, sc) = unit_column(p, id)?;
        cols.push(c);
        scales.push(sc);
    }
    let mut refs: Vec<&[f64]> = unit[..nn].to_vec();
    refs.extend(cols.iter().map(Vec::as_slice));
    let fit = lsq(&z, &refs)?;
    let dof = z.len().saturating_sub(refs.len());
    let birge = birge_ratio(fit.chi2, dof);
    let stated = f.stated();
    let m = ids.len();
    let se: Vec<f64> = (0..m)
        .map(|j| {
            let jj = nn + j;
            let classical = fit.cov[(jj, jj)].sqrt() * birge;
            let robust = if stated { 0.0 } else { fit.se_hc3[jj] };
            classical.max(robust) / scales[j]
        })
        .collect();
    let cov = (0..m)
        .map(|a| {
            (0..m)
                .map(|b| {
                    let (ia, ib) = (nn + a, nn + b);
                    let d = (fit.cov[(ia, ia)] * fit.cov[(ib, ib)]).sqrt();
                    let r = if d > 0.0 { fit.cov[(ia, ib)] / d } else { 0.0 };
                    r * se[a] * se[b]
                })
                .collect()
        })
        .collect();
    Some(CalFit {
        ids: ids.to_vec(),
        coef: (0..m).map(|j| fit.beta[nn + j] / scales[j]).collect(),
        cov,
        dof,
    })
}

/// A term's absolute value and its gradient with respect to the fitted coefficients.
struct Absolute {
    /// In the IEEE unit (`K_1`: [`SCALE_UNIT`]).
    value: f64,
    /// In cgs.
    value_cgs: f64,
    /// `∂value/∂coef` over the fit's coefficients.
    grad: Vec<f64>,
    /// `∂value_cgs/∂coef`.
    grad_cgs: Vec<f64>,
}

impl Absolute {
    /// Its 1 σ under the fit's covariance, in the IEEE unit.
    fn sigma(&self, fit: &CalFit) -> f64 {
        quad(&self.grad, &fit.cov, &self.grad).max(0.0).sqrt()
    }
}

/// The instrument file's terms that every absolute value starts from.
#[derive(Clone, Copy)]
struct Nominals<'a> {
    instr: &'a Instrument,
    /// Local gravity, cm/s².
    g: f64,
}

impl Nominals<'_> {
    /// `1e-6·k1_ppm` of the file.
    fn eps(self) -> f64 {
        file_eps(self.instr)
    }
}

/// The absolute value of `def` from the fit (its candidate among `fit.ids`) and the file's
/// nominal terms `n`: `K_1 = K_1,base·(1 + ε)`, every other term the reading's coefficient
/// over `1 + ε`, with `ε` the file's `k1_ppm` and the fitted change together.
fn absolute(def: &TermDef, fit: &CalFit, n: Nominals<'_>) -> Option<Absolute> {
    let m = fit.ids.len();
    let at = |id: CandidateId| fit.ids.iter().position(|&x| x == id);
    let j = at(def.candidate)?;
    let s = at(CandidateId::ScaleFactor);
    let eps = n.eps() + s.map_or(0.0, |s| 1e-6 * fit.coef[s]);
    let r = 1.0 / (1.0 + eps);
    let read = reading_nominal(n.instr, def.coefficient);
    let mut grad = vec![0.0; m];
    let mut grad_cgs = vec![0.0; m];
    if def.coefficient == Coefficient::K1 {
        // K_1 = K_1,base·(1 + ε) (its full scale in cm/s², f_clk·g/K_1, is made by the
        // caller).
        let base = read / (1.0 + n.eps());
        grad[j] = base * 1e-6;
        return Some(Absolute {
            value: base * (1.0 + eps),
            value_cgs: f64::NAN,
            grad,
            grad_cgs,
        });
    }
    let (k, _) = ieee(def, n.g);
    let c = fit.coef[j];
    let cgs = (read + def.sign * c) * r;
    grad_cgs[j] = def.sign * r;
    if let Some(s) = s {
        grad_cgs[s] = -(read + def.sign * c) * r * r * 1e-6;
    }
    grad = grad_cgs.iter().map(|x| x * k).collect();
    Some(Absolute {
        value: cgs * k,
        value_cgs: cgs,
        grad,
        grad_cgs,
    })
}

/// `aᵀ·C·b`.
fn quad(a: &[f64], c: &[Vec<f64>], b: &[f64]) -> f64 {
    a.iter()
        .enumerate()
        .map(|(i, x)| x * c[i].iter().zip(b).map(|(y, z)| y * z).sum::<f64>())
        .sum()
}

/// The marks a selected term carries.
fn marks(s: &Selected) -> Vec<&'static str> {
    let mut m = Vec::new();
    if s.stable == Some(false) {
        m.push("unstable");
    }
    if !s.rivals.is_empty() {
        m.push("rivaled");
    }
    if !s.plausible {
        m.push("implausible");
    }
    if !s.confounded.is_empty() {
        m.push("confounded");
    }
    m
}

/// Whether `id` is one of the core terms (`K_0`, `K_1`, `δ_o`, `δ_p`, `K_2`).
fn is_core(id: CandidateId) -> bool {
    TERMS.iter().any(|d| d.core && d.candidate == id)
}

/// Why a selected term is doubtful for the calibration (empty: it is not): outside the
/// core terms, rivaled or implausible. A core term is always fitted, whatever its marks.
#[must_use]
pub fn doubtful_why(s: &Selected) -> Vec<&'static str> {
    if is_core(s.id) {
        return Vec::new();
    }
    let mut why = Vec::new();
    if !s.rivals.is_empty() {
        why.push("rivaled");
    }
    if !s.plausible {
        why.push("implausible");
    }
    why
}

/// The calibration's own fit: the core terms the data test and the selected terms that
/// are not doubtful, each where its column is separable from those before it.
struct Fitting {
    /// The candidates fitted.
    ids: Vec<CandidateId>,
    /// Their fit.
    fit: CalFit,
    /// Model-equation terms whose columns the fitted ones span, with those.
    not_separable: Vec<(CandidateId, Vec<CandidateId>)>,
    /// Selected terms outside the model equation that could not be fitted beside the others.
    left_out: Vec<CandidateId>,
}

/// Fit the nuisance terms, the core terms the data test (in the equation's order), then
/// `trusted`, each where its column is separable from what is already fitted. A tumble
/// cannot tell `K_2` from `K_pp` (about OA) or `K_oo` (about PA) and the bias: the core
/// term takes it, as in the standard's tumble analysis, whichever the selection named.
fn fit_calibration(p: &Problem<'_>, trusted: &[CandidateId]) -> Option<Fitting> {
    let tested = |id: CandidateId| p.f.family.contains(&id);
    let mut ids: Vec<CandidateId> = Vec::new();
    let mut fit = fit_terms(p, &ids)?;
    let mut not_separable: Vec<(CandidateId, Vec<CandidateId>)> = Vec::new();
    let mut left_out: Vec<CandidateId> = Vec::new();
    let core = TERMS
        .iter()
        .filter(|d| d.core && tested(d.candidate))
        .map(|d| d.candidate);
    for id in core.chain(trusted.iter().copied()) {
        if ids.contains(&id) || not_separable.iter().any(|(o, _)| *o == id) {
            continue;
        }
        let mut trial = ids.clone();
        trial.push(id);
        if let Some(t) = fit_terms(p, &trial) {
            ids = trial;
            fit = t;
        } else if id.model_equation_term() {
            not_separable.push((id, spanned_by(p, &ids, id)));
        } else {
            left_out.push(id);
        }
    }
    Some(Fitting {
        ids,
        fit,
        not_separable,
        left_out,
    })
}

/// The instrument's own model equation from the problem and the final selection; `None`
/// without an instrument file (the simulator has none).
#[must_use]
pub(crate) fn calibration(p: &Problem<'_>, selected: &[Selected]) -> Option<Calibration> {
    let instr = p.sim.instrument()?;
    let g = p.sim.g_cm_s2();
    let sel: Vec<CandidateId> = selected.iter().map(|s| s.id).collect();
    let trusted: Vec<CandidateId> = selected
        .iter()
        .filter(|s| doubtful_why(s).is_empty())
        .map(|s| s.id)
        .collect();
    let Fitting {
        ids,
        fit,
        not_separable,
        left_out,
    } = fit_calibration(p, &trusted)?;
    let ctx = TermCtx {
        p,
        n: Nominals { instr, g },
        selected,
        fit: &fit,
        ids: &ids,
        not_separable: &not_separable,
    };
    let (terms, grads): (Vec<CalibrationTerm>, Vec<Option<Vec<f64>>>) =
        TERMS.iter().map(|def| term_of(&ctx, def)).unzip();
    let correlation = grads
        .iter()
        .map(|a| {
            grads
                .iter()
                .map(|b| {
                    let (a, b) = (a.as_ref()?, b.as_ref()?);
                    let d = (quad(a, &fit.cov, a) * quad(b, &fit.cov, b)).sqrt();
                    (d > 0.0).then(|| quad(a, &fit.cov, b) / d)
                })
                .collect()
        })
        .collect();
    let doubtful: Vec<DoubtfulTerm> = selected
        .iter()
        .filter(|s| !doubtful_why(s).is_empty())
        .map(|s| doubtful_term(&ctx, s))
        .collect();
    let trusted_sel: Vec<CandidateId> = sel
        .iter()
        .copied()
        .filter(|id| trusted.contains(id))
        .collect();
    let (noise, mut notes) = notes(p.f, &trusted_sel, fit.dof);
    notes.extend(left_out_notes(p, &ids, &left_out, &not_separable, &sel));
    Some(Calibration {
        equation: equation(instr),
        scale_factor: scale_words(instr),
        reading_offset: reading_offset(&ctx, &terms[Coefficient::K0 as usize]),
        changes: changes(&fit, selected),
        terms,
        correlation,
        dof: fit.dof,
        noise,
        notes,
        design_g: p
            .rows
            .iter()
            .filter(|r| r.kind == crate::model::condition::RowKind::Absolute && r.is_static())
            .map(|r| r.g)
            .collect(),
        local_gravity_cm_s2: g,
        gravity_source: gravity_source(instr),
        doubtful,
    })
}

/// The fit as changes from the instrument file (`calibration.changes`), with the
/// warm-up's time constant from the selection when the fit holds it.
fn changes(fit: &CalFit, selected: &[Selected]) -> CalibrationChanges {
    let warm_up_tau_s = fit
        .ids
        .contains(&CandidateId::WarmUp)
        .then(|| {
            selected
                .iter()
                .find_map(|s| s.time_constant.as_ref().map(|t| t.tau_s))
        })
        .flatten();
    CalibrationChanges {
        candidates: fit
            .ids
            .iter()
            .map(|id| id.info().name.to_string())
            .collect(),
        values: fit.coef.clone(),
        sigmas: (0..fit.ids.len())
            .map(|j| fit.cov[j][j].max(0.0).sqrt())
            .collect(),
        units: fit
            .ids
            .iter()
            .map(|id| id.info().unit.to_string())
            .collect(),
        covariance: fit.cov.clone(),
        warm_up_tau_s,
    }
}

/// `K_0` as the reading's offset: the reading's coefficient of the bias, `K_0·(1 + ε)`.
fn reading_offset(ctx: &TermCtx<'_, '_>, k0: &CalibrationTerm) -> ReadingOffset {
    let n = ctx.n;
    let (k, _) = ieee(&TERMS[Coefficient::K0 as usize], n.g);
    let read = reading_nominal(n.instr, Coefficient::K0);
    let j = ctx.fit.ids.iter().position(|&x| x == CandidateId::Bias);
    let (value_cgs, sigma_cgs) = match j {
        Some(j) => (
            read + ctx.fit.coef[j],
            Some(ctx.fit.cov[j][j].max(0.0).sqrt()),
        ),
        None => (read, None),
    };
    let value = value_cgs * k;
    let sigma = sigma_cgs.map(|s| s * k);
    ReadingOffset {
        value,
        sigma,
        value_cgs,
        sigma_cgs,
        differs: (value - k0.value).abs() > k0.sigma.unwrap_or(0.0),
    }
}

/// A doubtful selected term: its value if it were real, fitted beside the calibration's
/// terms, and the core terms' values in that fit.
fn doubtful_term(ctx: &TermCtx<'_, '_>, s: &Selected) -> DoubtfulTerm {
    let def = TERMS.iter().find(|d| d.candidate == s.id);
    let mut trial = ctx.ids.to_vec();
    trial.push(s.id);
    let with = fit_terms(ctx.p, &trial);
    let unit = def.map_or_else(
        || s.id.info().unit.to_string(),
        |d| ieee(d, ctx.n.g).1.to_string(),
    );
    let mut out = DoubtfulTerm {
        candidate: s.id.info().name.to_string(),
        symbol: def.map(|d| d.symbol.to_string()),
        why: doubtful_why(s),
        if_real: None,
        unit,
        core_with_it: Vec::new(),
        not_separable_from: Vec::new(),
    };
    let Some(t) = with else {
        out.not_separable_from = spanned_by(ctx.p, ctx.ids, s.id)
            .iter()
            .map(|o| o.info().name.to_string())
            .collect();
        return out;
    };
    let j = t.ids.len() - 1;
    out.if_real = def.map_or(Some([t.coef[j], t.cov[j][j].max(0.0).sqrt()]), |d| {
        absolute(d, &t, ctx.n).map(|a| [a.value, a.sigma(&t)])
    });
    out.core_with_it = TERMS
        .iter()
        .filter(|d| d.core && d.candidate != s.id)
        .filter_map(|d| {
            let a = absolute(d, &t, ctx.n)?;
            Some(CoreValue {
                symbol: d.symbol.to_string(),
                value: a.value,
                sigma: a.sigma(&t),
                unit: term_unit(d, ctx.n),
            })
        })
        .collect();
    out
}

/// The unit `term`'s value is given in: [`scale_unit`] for `K_1`, the IEEE unit otherwise.
fn term_unit(def: &TermDef, n: Nominals<'_>) -> String {
    if def.coefficient == Coefficient::K1 {
        scale_unit(n.instr)
    } else {
        ieee(def, n.g).1.to_string()
    }
}

/// The noise's source and the notes of a calibration: terms of the fit outside the model
/// equation, a noise estimated with few degrees of freedom (`dof`, the fit's).
fn notes(f: &super::fit::Fitted, sel: &[CandidateId], dof: usize) -> (&'static str, Vec<String>) {
    let mut notes = Vec::new();
    let outside: Vec<&str> = sel
        .iter()
        .filter(|id| !id.model_equation_term())
        .map(|id| id.info().name)
        .collect();
    if !outside.is_empty() {
        notes.push(format!(
            "fitted beside the model equation's terms: {} (not terms of the model equation; what they do to the reading is carried by them, not by K_0, K_1 or the misalignments)",
            outside.join(", ")
        ));
    }
    let noise = match f.noise {
        super::fit::NoiseSource::Stated => "stated",
        super::fit::NoiseSource::Replicates => "replicates",
        super::fit::NoiseSource::Residuals => "residuals",
    };
    if !f.stated() && dof < 30 {
        #[allow(clippy::cast_precision_loss)]
        let t = statrs::distribution::StudentsT::new(0.0, 1.0, dof.max(1) as f64)
            .map_or(f64::NAN, |d| {
                statrs::distribution::ContinuousCDF::inverse_cdf(&d, 0.975)
            });
        notes.push(format!(
            "the noise is estimated ({noise}) with {dof} degrees of freedom, so the uncertainties are themselves uncertain: for 95 % with a noise known to {dof} degrees of freedom Student's t gives k = {t:.2}"
        ));
    }
    (noise, notes)
}

/// The notes on selected terms the calibration's fit could not hold beside the core terms.
fn left_out_notes(
    p: &Problem<'_>,
    ids: &[CandidateId],
    left_out: &[CandidateId],
    not_separable: &[(CandidateId, Vec<CandidateId>)],
    sel: &[CandidateId],
) -> Vec<String> {
    let names = |v: &[CandidateId]| -> String {
        v.iter()
            .map(|o| o.info().name)
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut notes = Vec::new();
    for (id, with) in not_separable.iter().filter(|(id, _)| sel.contains(id)) {
        notes.push(format!(
            "{} was selected, but these data cannot separate it from {}: the calibration gives those and lists it at its nominal value",
            id.info().name,
            names(with)
        ));
    }
    for &id in left_out {
        notes.push(format!(
            "{} was selected, but these data cannot separate it from {}: the calibration's fit leaves it out (if it is real, those terms carry it)",
            id.info().name,
            names(&spanned_by(p, ids, id))
        ));
    }
    notes
}

/// What [`term_of`] needs.
struct TermCtx<'a, 'p> {
    p: &'a Problem<'p>,
    n: Nominals<'a>,
    selected: &'a [Selected],
    fit: &'a CalFit,
    ids: &'a [CandidateId],
    not_separable: &'a [(CandidateId, Vec<CandidateId>)],
}

/// A term at its nominal value, with the marks of its selection.
fn nominal_term(ctx: &TermCtx<'_, '_>, def: &TermDef) -> CalibrationTerm {
    let (instr, g) = (ctx.n.instr, ctx.n.g);
    let id = def.candidate;
    let n = nominal(instr, def.coefficient);
    let is_k1 = def.coefficient == Coefficient::K1;
    let (k, _) = ieee(def, g);
    let unit = term_unit(def, ctx.n);
    let nominal_value = if is_k1 { n } else { n * k };
    let s = ctx.selected.iter().find(|s| s.id == id);
    CalibrationTerm {
        symbol: def.symbol.to_string(),
        candidate: id.info().name.to_string(),
        value: nominal_value,
        sigma: None,
        expanded_k2: None,
        unit: unit.clone(),
        nominal: nominal_value,
        change: 0.0,
        change_sigma: None,
        change_unit: if is_k1 { "ppm".into() } else { unit },
        value_cgs: if is_k1 { full_scale(instr, g, n) } else { n },
        sigma_cgs: None,
        unit_cgs: def.unit_cgs.to_string(),
        measured: false,
        status: "not_measured",
        marks: s.map(marks).unwrap_or_default(),
        confounded_with: s.map_or_else(Vec::new, |s| {
            s.confounded
                .iter()
                .map(|(o, _)| o.info().name.to_string())
                .collect()
        }),
        if_fitted: None,
    }
}

/// The full scale in cm/s² of a loop whose `K_1` is `k1` (`f_clk·g/K_1`); NaN without a loop.
fn full_scale(instr: &Instrument, g: f64, k1: f64) -> f64 {
    if instr.has_loop {
        instr.clock_hz * g / k1
    } else {
        f64::NAN
    }
}

/// One term of the calibration and its gradient over the fit's coefficients (`None` when
/// not measured).
fn term_of(ctx: &TermCtx<'_, '_>, def: &TermDef) -> (CalibrationTerm, Option<Vec<f64>>) {
    let mut term = nominal_term(ctx, def);
    let id = def.candidate;
    let is_k1 = def.coefficient == Coefficient::K1;
    let (instr, g) = (ctx.n.instr, ctx.n.g);
    let sel = ctx.selected.iter().find(|s| s.id == id);
    let selected = sel.is_some();
    if let Some(a) = absolute(def, ctx.fit, ctx.n) {
        let sigma = a.sigma(ctx.fit);
        term.value = a.value;
        term.sigma = Some(sigma);
        term.expanded_k2 = Some(2.0 * sigma);
        term.measured = true;
        term.status = if selected { "selected" } else { "fitted" };
        let n = term.nominal;
        if is_k1 {
            term.change = (a.value / n - 1.0) * 1e6;
            term.change_sigma = Some(sigma / n * 1e6);
            term.value_cgs = full_scale(instr, g, a.value);
            term.sigma_cgs = Some(term.value_cgs * sigma / a.value);
        } else {
            term.change = a.value - n;
            term.change_sigma = Some(sigma);
            term.value_cgs = a.value_cgs;
            term.sigma_cgs = Some(quad(&a.grad_cgs, &ctx.fit.cov, &a.grad_cgs).max(0.0).sqrt());
        }
        return (term, Some(a.grad));
    }
    if sel.is_some_and(|s| !doubtful_why(s).is_empty()) {
        // Selected, but left out of the calibration: nominal, with what it would be.
        let mut trial = ctx.ids.to_vec();
        trial.push(id);
        term.status = "doubtful";
        term.if_fitted = fit_terms(ctx.p, &trial)
            .and_then(|t| absolute(def, &t, ctx.n).map(|a| [a.value, a.sigma(&t)]));
    } else if let Some((_, with)) = ctx.not_separable.iter().find(|(o, _)| *o == id) {
        term.status = "not_separable";
        term.confounded_with = with.iter().map(|o| o.info().name.to_string()).collect();
    } else if ctx.p.f.family.contains(&id) {
        let mut trial = ctx.ids.to_vec();
        trial.push(id);
        if let Some(t) = fit_terms(ctx.p, &trial)
            .and_then(|t| absolute(def, &t, ctx.n).map(|a| [a.value, a.sigma(&t)]))
        {
            term.status = "not_significant";
            term.if_fitted = Some(t);
        } else {
            term.status = "not_separable";
            term.confounded_with = spanned_by(ctx.p, ctx.ids, id)
                .iter()
                .map(|o| o.info().name.to_string())
                .collect();
        }
    }
    (term, None)
}

#[cfg(test)]
mod tests {
    use super::{Coefficient, TERMS};

    /// [`super::nominal`] finds a term's row by its enum discriminant.
    #[test]
    fn terms_are_in_the_enums_order() {
        for (i, d) in TERMS.iter().enumerate() {
            assert_eq!(d.coefficient as usize, i, "{}", d.symbol);
        }
        assert_eq!(TERMS.len(), Coefficient::Koo as usize + 1);
    }

    /// A nominal 0 under the sign −1 (`δ_p`) is written 0, not −0.
    #[test]
    fn a_zero_nominal_is_not_negative_zero() {
        let instr = crate::Instrument::kearfott_2401();
        let n = super::nominal(&instr, Coefficient::DeltaP);
        assert!(n == 0.0 && n.is_sign_positive(), "{n}");
    }
}
