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
//! **A form in the place of two terms.** A form can also stand for two selected terms at
//! once: in a tumble about OA taken in angle order the derived approach sign is a square
//! wave in step with the misalignment toward PA's column, and the two together take a
//! cubic's `sin 3φ` part as well as its `sin φ`, so the cubic is the rival of neither
//! alone. For every pair `{j, k}` of plausible selected terms, with `Q` the span of the
//! model's other terms and `P` that of the pair's parts off `Q`, the form is the pair's
//! rival when `Δ = |P r|² − (r·L̂)²`, tested as two degrees of freedom (under the form as
//! the truth, `Δ` is at most the drop of χ² the pair makes added to the form), is not
//! significant at `α/m`, `m` the family's size, and `|P L̂| ≥ 0.5`. The level is the
//! confounding stage's for a candidate partner: the selection chose the pair among the
//! family's candidates, and a pair so chosen fits the noise of the data as no form that
//! had no such choice can (at `α` the cubics taken for the misalignment and a hysteresis
//! were rivaled in none of the lab campaign's sets). The form is then the rival of both, with
//! `together_with` naming the other term. A single term keeps the level `α`: at `α/m`
//! the true causes of the lab campaign were hedged in twice as many sets.
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

/// Rivals kept per term, in its place alone and with a partner (the least
/// distinguishable first).
pub const MAX_RIVALS: usize = 3;

/// Find each selected term's rivals (sets `Selected::rivals`), on the final fit
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
    let forms = outside_forms(data, f);
    // The whole model: a term beyond its bound stays in it (a bound flags, it does not
    // remove).
    let keep: Vec<usize> = (0..cols.len()).collect();
    let dof = n.saturating_sub(keep.len());
    if dof == 0 || forms.is_empty() {
        return;
    }
    // The final model's χ² and the noise scale every swap is tested on.
    let whole: Vec<&[f64]> = keep.iter().map(|&c| cols[c]).collect();
    let chi2: f64 = partial(&z, &orthonormal(&whole))
        .iter()
        .map(|x| x * x)
        .sum();
    #[allow(clippy::cast_precision_loss)]
    let reference = Reference {
        s2: chi2 / dof as f64,
        dof: dof as f64,
        resid: Vec::new(),
    };
    // A pair is tested at the level the confounding stage gives a candidate partner: the
    // selection chose it among the family's m candidates, so the pair fits the noise of
    // these data better than a form that had no such choice.
    #[allow(clippy::cast_precision_loss)]
    let pair_level = alpha / f.family_size().max(1) as f64;
    let search = Search {
        data,
        f,
        cols: &cols,
        nn,
        z: &z,
        forms: &forms,
        reference: &reference,
        alpha,
        pair_level,
    };
    let mut found: Vec<Vec<Rival>> = vec![Vec::new(); selected.len()];
    for group in &groups(selected) {
        search.group(group, selected, &mut found);
    }
    for (s, rivals) in selected.iter_mut().zip(found) {
        s.rivals = ordered(rivals);
    }
}

/// One term, then every pair of terms, to be replaced by one form (a companion bias
/// stays in the model: it names no cause a form could stand in for).
fn groups(selected: &[Selected]) -> Vec<Vec<usize>> {
    let named: Vec<usize> = (0..selected.len())
        .filter(|&j| !selected[j].companion)
        .collect();
    let mut groups: Vec<Vec<usize>> = named.iter().map(|&j| vec![j]).collect();
    for (a, &j) in named.iter().enumerate() {
        for &k in &named[a + 1..] {
            groups.push(vec![j, k]);
        }
    }
    groups
}

/// What every group's rivals are sought with: the final fit's unit columns (the `nn`
/// nuisance ones first), its weighted target, the forms outside the vocabulary, the noise
/// scale of the final model, the levels.
struct Search<'a> {
    data: &'a Data,
    f: &'a Fitted,
    cols: &'a [&'a [f64]],
    nn: usize,
    z: &'a [f64],
    forms: &'a [(usize, Vec<f64>)],
    reference: &'a fit::Reference,
    alpha: f64,
    pair_level: f64,
}

impl Search<'_> {
    /// The forms that stand in the place of `group` (one term or two) not significantly
    /// worse, added to each member's rivals in `found`.
    fn group(&self, group: &[usize], selected: &[Selected], found: &mut [Vec<Rival>]) {
        let nn = self.nn;
        let others: Vec<&[f64]> = (0..self.cols.len())
            .filter(|&c| c < nn || !group.contains(&(c - nn)))
            .map(|c| self.cols[c])
            .collect();
        let q = orthonormal(&others);
        let r = partial(self.z, &q);
        let parts: Vec<Vec<f64>> = group
            .iter()
            .map(|&j| partial(self.cols[nn + j], &q))
            .collect();
        if parts.iter().any(|p| norm(p) < 1e-6) {
            return;
        }
        let refs: Vec<&[f64]> = parts.iter().map(Vec::as_slice).collect();
        let span = orthonormal(&refs);
        if span.len() < group.len() {
            return;
        }
        // What the group explains of the target off the rest of the model.
        let held: f64 = span.iter().map(|b| dot(b, &r).powi(2)).sum();
        let partner = |j: usize| {
            group
                .iter()
                .find(|&&k| k != j)
                .map(|&k| selected[k].id.info().key.to_string())
        };
        for (k, unit) in self.forms {
            let part = partial(unit, &q);
            let pn = norm(&part);
            if pn < 1e-6 || part.iter().fold(0.0_f64, |m, x| m.max(x * x)) > ONE_ROW_SHARE * pn * pn
            {
                continue;
            }
            let cos = span
                .iter()
                .map(|b| dot(b, &part).powi(2))
                .sum::<f64>()
                .sqrt()
                / pn;
            if cos < RIVAL_COS {
                continue;
            }
            let b = dot(&part, &r) / pn;
            // Under the form as the truth, the swap's χ² increase is at most the drop of
            // χ² the group would make added to the form: χ² with one degree of freedom
            // per term of the group.
            #[allow(clippy::cast_precision_loss)]
            let df = group.len() as f64;
            let p_value =
                fit::scaled_p((held - b * b).max(0.0), df, self.f.stated(), self.reference);
            let level = if group.len() == 1 {
                self.alpha
            } else {
                self.pair_level
            };
            if p_value > level {
                for &j in group {
                    found[j].push(Rival {
                        form: self.data.shapes[*k].form.clone(),
                        family: self.data.shapes[*k].family.name(),
                        cos,
                        p_value,
                        together_with: partner(j),
                    });
                }
            }
        }
    }
}

/// The library's forms outside the vocabulary, on `f`'s rows weighted and unit (with their
/// index in `data.shapes`), less those that are a candidate's own column here.
fn outside_forms(data: &Data, f: &Fitted) -> Vec<(usize, Vec<f64>)> {
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
    data.shapes
        .iter()
        .enumerate()
        .filter(|(_, s)| !matches!(s.family, Family::Basis | Family::HistoryProducts))
        .filter_map(|(k, s)| {
            let w = weigh(&s.col);
            let scale = norm(&w);
            (scale > 0.0 && !signatures.iter().any(|g| abs_cos(g, &w) > CANDIDATE_COS))
                .then(|| (k, w.iter().map(|x| x / scale).collect()))
        })
        .collect()
}

/// A term's rivals in the order they are reported: alone before with a partner.
fn ordered(mut rivals: Vec<Rival>) -> Vec<Rival> {
    // Alone before with a partner, each the least distinguishable first.
    rivals.sort_by(|x, y| {
        x.together_with
            .is_some()
            .cmp(&y.together_with.is_some())
            .then(y.p_value.total_cmp(&x.p_value))
    });
    // A form once (alone before with a partner); at most [`MAX_RIVALS`] of each kind.
    let mut seen: Vec<String> = Vec::new();
    let mut alone = 0;
    let mut paired = 0;
    rivals.retain(|v| {
        let count = if v.together_with.is_some() {
            &mut paired
        } else {
            &mut alone
        };
        let keep = !seen.contains(&v.form) && *count < MAX_RIVALS;
        if keep {
            *count += 1;
            seen.push(v.form.clone());
        }
        keep
    });
    rivals
}

/// `a·b`.
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
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
        tumble(seed, truth, extra)
            .selected
            .iter()
            .find(|s| s.id == CandidateId::MisalignmentP)
            .map(|s| s.rivals.iter().map(|r| r.form.clone()).collect())
    }

    /// The same tumble's discovery.
    fn tumble(
        seed: u64,
        truth: &Effects,
        extra: impl Fn(f64) -> f64,
    ) -> crate::discovery::Discovery {
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
        discover(&rows, &sim, &Options::default()).unwrap()
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

    /// A cubic in `a_PA` (about 15 SE alone) that the selection takes for the
    /// misalignment toward PA and a hysteresis together, in 60 drawn sets: `a_PA^3` is the
    /// rival of both in every such set (of one alone, or of the pair with the other named in
    /// `together_with`), and of the pair together in at least one.
    #[test]
    fn a_cubic_taken_for_two_terms_is_the_rival_of_the_pair() {
        let mut pairs = 0;
        let mut rivaled = 0;
        let mut together = 0;
        for seed in 0..60 {
            let d = tumble(seed, &Effects::NONE, |a| 1.2e-10 * a.powi(3));
            let ids: Vec<CandidateId> = d.selected.iter().map(|s| s.id).collect();
            if ids.contains(&CandidateId::MisalignmentP) && ids.contains(&CandidateId::Hysteresis) {
                pairs += 1;
                // The rival of each: in its place alone, or with the other term.
                let joint = |id: CandidateId, other: &str| {
                    d.selected.iter().find(|s| s.id == id).is_some_and(|s| {
                        s.rivals.iter().any(|r| {
                            r.form == "a_PA^3"
                                && r.together_with.as_deref().is_none_or(|o| o == other)
                        })
                    })
                };
                rivaled += usize::from(
                    joint(CandidateId::MisalignmentP, "h_cm_s2")
                        && joint(CandidateId::Hysteresis, "delta_p_rad"),
                );
                together += usize::from(d.selected.iter().any(|s| {
                    s.rivals
                        .iter()
                        .any(|r| r.form == "a_PA^3" && r.together_with.is_some())
                }));
            }
        }
        assert!(pairs >= 1, "the cubic never taken for the pair in 60 sets");
        assert_eq!(
            rivaled, pairs,
            "{rivaled} of {pairs} pairs rivaled by a_PA^3"
        );
        assert!(together >= 1, "a_PA^3 never the rival of the pair together");
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
