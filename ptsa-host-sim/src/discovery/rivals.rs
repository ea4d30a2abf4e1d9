//! Stage: forms outside the vocabulary that could stand in a named term's place.
//!
//! The confounding stage names the *candidates* a selected term cannot be told from; this
//! stage asks the same of the library's forms outside the vocabulary ([`super::library`]:
//! the history, the shapes in time and the products of three of the row's own inputs; not
//! the products with the row before, a large family of speculative forms that would hedge
//! a true cause at 6 SE in most tumbles without telling a lab what to do). A cross-axis cubic `k·a_PA³` in a tumble about OA is three quarters the
//! misalignment toward PA's column (`sin³φ = (3 sin φ − sin 3φ)/4`); a warm-up that lies on
//! the first quarter of a tumble taken in angle order shares the same part of the run with
//! it. Named without a word, either would send a lab to re-shim an instrument that is not
//! misaligned.
//!
//! For each plausible selected term `j`, on the final model's weighted columns: with `Q`
//! the span of every other term of the model (nuisance terms and the other plausible
//! selected terms), `r` the weighted target's residual off `Q`, `ĵ` the term's column's
//! part off `Q` (unit) and `L̂` a form's (unit), the model holds `j` at `χ² = |r|² − (r·ĵ)²`
//! and the form in its place at `|r|² − (r·L̂)²`. The form is a **rival** when the swap is
//! not significantly worse, `Δ = (r·ĵ)² − (r·L̂)²` tested as one degree of freedom on the
//! model's noise scale at level α (`fit::scaled_p`: with stated sigmas the larger of the χ²
//! and the F test; not significant means `p > α`), and the two columns share the part of
//! the data that decides, `|ĵ·L̂| ≥ 0.5` (the selection's rule for a partner). Forms whose
//! part off `Q` lies for more than half on one row (the outlier stage's question), and forms
//! that are a candidate's own column here (`|cos| > 0.9999` with a signature: the
//! confounding stage's business) are left out.
//!
//! A rival is not a test of the form (that is the unexplained search's, section 9); it says
//! that these data cannot tell the named term from a form the vocabulary does not hold. A
//! term with a rival stays in the fit, the model equation and the extended model; it is
//! named with its rivals, and a warning says what would tell them apart.

use super::data::Data;
use super::fit::{self, Fitted, Reference};
use super::library::Family;
use super::problem::Selected;
use super::report::Rival;
use super::unexplained::{orthonormal, partial};
use crate::stats::{abs_cos, norm};

/// `|ĵ·L̂|` from which a form that fits not significantly worse in a term's place is its
/// rival (the selection's partner rule).
const RIVAL_COS: f64 = 0.5;

/// `|cos|` of a form's weighted column with a candidate's signature above which the form is
/// that candidate here, not a rival from outside the vocabulary.
const CANDIDATE_COS: f64 = 0.9999;

/// Share of a form's part off the model on one row above which it is the outlier stage's
/// question, not a rival.
const ONE_ROW_SHARE: f64 = 0.5;

/// Rivals kept per term (the least distinguishable first).
pub const MAX_RIVALS: usize = 3;

/// Find each plausible selected term's rivals (sets `Selected::rivals`), on the final fit
/// `f` of `data` at level `alpha`. Does nothing when the fit's columns do not line up with
/// `selected` (a parameter found through the closed loop only).
pub(crate) fn find(data: &Data, f: &Fitted, selected: &mut [Selected], alpha: f64) {
    let cols = f.unit_columns();
    let nn = f.n_nuisance();
    if cols.len() != nn + selected.len() {
        return;
    }
    let z = f.weighted_target();
    let n = z.len();
    let weigh = |raw: &[f64]| -> Vec<f64> {
        f.subset
            .iter()
            .enumerate()
            .map(|(k, &i)| raw[i] * f.weight(k))
            .collect()
    };
    // The forms outside the vocabulary, weighted and unit, that are no candidate's column.
    let signatures: Vec<Vec<f64>> = data
        .signatures
        .iter()
        .filter(|s| !s.null)
        .map(|s| weigh(&s.col))
        .filter(|w| norm(w) > 0.0)
        .collect();
    let forms: Vec<(usize, Vec<f64>)> = data
        .shapes
        .iter()
        .enumerate()
        .filter(|(_, s)| !matches!(s.family, Family::Basis | Family::HistoryProducts))
        .filter_map(|(k, s)| {
            let w = weigh(&s.col);
            let scale = norm(&w);
            (scale > 0.0 && !signatures.iter().any(|g| abs_cos(g, &w) > CANDIDATE_COS))
                .then(|| (k, w.iter().map(|x| x / scale).collect()))
        })
        .collect();
    let keep: Vec<usize> = (0..cols.len())
        .filter(|&c| c < nn || selected[c - nn].plausible)
        .collect();
    let dof = n.saturating_sub(keep.len());
    if dof == 0 || forms.is_empty() {
        return;
    }
    for j in 0..selected.len() {
        if !selected[j].plausible {
            continue;
        }
        let others: Vec<&[f64]> = keep
            .iter()
            .filter(|&&c| c != nn + j)
            .map(|&c| cols[c])
            .collect();
        let q = orthonormal(&others);
        let r = partial(&z, &q);
        let jp = partial(cols[nn + j], &q);
        let jn = norm(&jp);
        if jn < 1e-6 {
            continue;
        }
        let a: f64 = jp.iter().zip(&r).map(|(x, y)| x * y).sum::<f64>() / jn;
        let chi2 = (r.iter().map(|x| x * x).sum::<f64>() - a * a).max(0.0);
        #[allow(clippy::cast_precision_loss)]
        let reference = Reference {
            s2: chi2 / dof as f64,
            dof: dof as f64,
            resid: Vec::new(),
        };
        let mut rivals: Vec<Rival> = Vec::new();
        for (k, unit) in &forms {
            let part = partial(unit, &q);
            let pn = norm(&part);
            if pn < 1e-6 || part.iter().fold(0.0_f64, |m, x| m.max(x * x)) > ONE_ROW_SHARE * pn * pn
            {
                continue;
            }
            let cos = jp.iter().zip(&part).map(|(x, y)| x * y).sum::<f64>() / (jn * pn);
            if cos.abs() < RIVAL_COS {
                continue;
            }
            let b: f64 = part.iter().zip(&r).map(|(x, y)| x * y).sum::<f64>() / pn;
            let delta = a * a - b * b;
            let p_value = fit::scaled_p(delta.max(0.0), 1.0, f.stated(), &reference);
            if p_value > alpha {
                rivals.push(Rival {
                    form: data.shapes[*k].form.clone(),
                    family: data.shapes[*k].family.name(),
                    cos: cos.abs(),
                    p_value,
                });
            }
        }
        // The least distinguishable first; among equals, the simpler form.
        rivals.sort_by(|x, y| y.p_value.total_cmp(&x.p_value));
        rivals.truncate(MAX_RIVALS);
        selected[j].rivals = rivals;
    }
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng as _;
    use rand_distr::Distribution as _;

    use crate::discovery::pipeline::discover;
    use crate::discovery::problem::Options;
    use crate::discovery::sim::{AnalyticSimulator, Simulator};
    use crate::model::condition::{Condition, PA};
    use crate::model::effects::{CandidateId, Effects};
    use crate::model::instrument::Instrument;

    /// A 24-point tumble about OA, in angle order, whose readings are the analytic
    /// simulator's plus `extra(a_PA)` (cm/s², `a_PA` the row's gravity along PA), with
    /// 0.02 cm/s² of noise drawn from `seed`: the misalignment's rivals
    /// (`None` when it is not selected).
    fn rivals(seed: u64, truth: &Effects, extra: impl Fn(f64) -> f64) -> Option<Vec<String>> {
        let instr = Instrument::kearfott_2401();
        let sim = AnalyticSimulator::for_instrument(&instr);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let noise = rand_distr::Normal::new(0.0, 0.02).unwrap();
        let mut rows: Vec<Condition> = crate::lab::plan::tumble(24, crate::lab::plan::Axis::Oa);
        for r in &mut rows {
            let a_pa = instr.g_cm_s2 * r.g[PA];
            r.measured_cm_s2 =
                Some(sim.absolute_cm_s2(r, truth) + extra(a_pa) + noise.sample(&mut rng));
            r.sigma_cm_s2 = Some(0.02);
        }
        let d = discover(&rows, &sim, &Options::default()).unwrap();
        d.selected
            .iter()
            .find(|s| s.id == CandidateId::MisalignmentP)
            .map(|s| s.rivals.iter().map(|r| r.form.clone()).collect())
    }

    /// A cubic in `a_PA` (`1.2e-10 s⁴/cm² · a_PA³`, about 15 SE alone) is taken for the
    /// misalignment toward PA, and `a_PA^3` is named as its rival in most of 20 drawn sets.
    #[test]
    fn a_cubic_in_a_pa_is_the_misalignments_rival() {
        let mut named = 0;
        let mut with_rival = 0;
        for seed in 0..20 {
            if let Some(r) = rivals(seed, &Effects::NONE, |a| 1.2e-10 * a.powi(3)) {
                named += 1;
                with_rival += usize::from(r.iter().any(|f| f == "a_PA^3"));
            }
        }
        assert!(named >= 15, "the cubic taken for δ_p in {named} of 20");
        assert!(with_rival * 4 >= named * 3, "{with_rival} of {named}");
    }

    /// A true misalignment at about 30 SE has no rival in any of 10 drawn sets: the cubic
    /// would leave a tenth of its χ² unexplained.
    #[test]
    fn a_strong_misalignment_has_no_rival() {
        let truth = Effects::only(CandidateId::MisalignmentP, 2e-4);
        for seed in 0..10 {
            let r = rivals(seed, &truth, |_| 0.0).expect("the misalignment selected");
            assert!(r.is_empty(), "seed {seed}: {r:?}");
        }
    }
}
