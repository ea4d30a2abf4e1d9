//! The understated-sigma campaign: null sets (and sets with one effect at 6 SE) whose
//! stated sigma is the true noise divided by a factor, on two designs, and the pipeline's
//! blind answer (issue 21, item 5).
//!
//! | design | rows | noise, cm/s² | effect of the power rows, written here |
//! |---|---|---|---|
//! | R-890 Table 6.1 (`report::r890::table_6_1_case`: the dividing head on the rate table, IA at 45° steps, 1 rad/s against 0.05 rad/s) | 8 difference rows | 0.3 (the report's test uncertainty) | anisoinertia `k·(w_IA·w_PA − ref w_IA·ref w_PA)` |
//! | a 24-point tumble about OA, angle order | 24 absolute rows | 0.02 | misalignment toward PA `δ·a_PA` |
//!
//! * **Measurement**: the closed loop's noise-free reading of each row (the shipped file,
//!   run once; a difference row as condition − reference), plus the effect from the
//!   equation above, plus Gaussian noise of the design's sigma; `sigma_cm_s2` written as
//!   that sigma over the factor (1: stated right; 1.5, 2, 3, 4: understated). Nothing here
//!   calls the candidate code.
//! * **Strength** of the power rows: 6 SE, SE the coefficient's standard error alone in
//!   the design with the nuisance terms partialled out (Table 6.1: a bias shift and the
//!   row-order drift; the tumble: the drift), at the true noise; the sign at random.
//! * **Analysis**: [`discover`](ptsa_host_sim::discovery::discover) with the analytic
//!   simulator and the additive terms.
//! * **Scored**: on the nulls, any selection (a false selection); on the power rows, the
//!   effect named (exactly or as a confounded partner).
//!
//! # Asserted
//!
//! No refusal; false selections at most 5 % (one-sided binomial test at 1 %) on the
//! nulls stated right and 2× too small, on both designs. The other factors and the power
//! rows are reported.

use std::fmt::Write as _;
use std::sync::OnceLock;

use ptsa_host_sim::discovery::{self, Options, Selected, Simulator};
use ptsa_host_sim::lab::plan::{self, Axis};
use ptsa_host_sim::model::condition::{Condition, PA};
use ptsa_host_sim::report::r890;
use ptsa_host_sim::simulation::sim::{SimOptions, simulate_condition, simulate_difference};
use ptsa_host_sim::{CandidateId, Effects, Instrument};
use rayon::prelude::*;

use super::campaign::{Campaign, Columns, Count, Outcome, Run, at_most_rate};
use super::generate::residualize;
use super::statics::{drift_basis, static_force};
use super::{Draw, rng};

/// The factors the true noise is divided by in `sigma_cm_s2`.
pub const FACTORS: [f64; 5] = [1.0, 1.5, 2.0, 3.0, 4.0];
/// The factors whose nulls are asserted.
pub const ASSERTED: [f64; 2] = [1.0, 2.0];
/// Strength of the power rows, SE.
pub const POWER_SE: f64 = 6.0;

/// A design of the campaign.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum SigmaDesign {
    /// R-890 Table 6.1's 8 rows.
    Table61,
    /// A 24-point tumble about OA in angle order.
    Tumble24,
}

impl SigmaDesign {
    /// Name in tables.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            SigmaDesign::Table61 => "Table 6.1",
            SigmaDesign::Tumble24 => "tumble 24",
        }
    }

    /// The true noise, cm/s².
    #[must_use]
    pub fn sigma_cm_s2(self) -> f64 {
        match self {
            SigmaDesign::Table61 => 0.3,
            SigmaDesign::Tumble24 => 0.02,
        }
    }

    /// The rows, unmeasured.
    ///
    /// # Panics
    /// If the shipped Table 6.1 cannot be read.
    #[must_use]
    pub fn rows(self) -> Vec<Condition> {
        match self {
            SigmaDesign::Table61 => {
                let mut rows = r890::table_6_1_case().expect("the shipped Table 6.1");
                for r in &mut rows {
                    r.measured_cm_s2 = None;
                    r.sigma_cm_s2 = None;
                }
                rows
            }
            SigmaDesign::Tumble24 => plan::tumble(24, Axis::Oa),
        }
    }

    /// The candidate the power rows hide.
    #[must_use]
    pub fn effect(self) -> &'static [CandidateId] {
        match self {
            SigmaDesign::Table61 => &[CandidateId::Anisoinertia],
            SigmaDesign::Tumble24 => &[CandidateId::MisalignmentP],
        }
    }

    /// Each row's extra reading for a unit coefficient of the power rows' effect, from the
    /// equation in the module's table.
    #[must_use]
    pub fn unit_column(self, rows: &[Condition], g_cm_s2: f64) -> Vec<f64> {
        rows.iter()
            .map(|r| match self {
                SigmaDesign::Table61 => {
                    r.w_rad_s[0] * r.w_rad_s[1] - r.ref_w_rad_s[0] * r.ref_w_rad_s[1]
                }
                SigmaDesign::Tumble24 => static_force(r, g_cm_s2)[PA],
            })
            .collect()
    }

    /// The nuisance terms the pipeline fits to the design, as columns.
    fn nuisance(self, n: usize) -> Vec<Vec<f64>> {
        let mut b = drift_basis(n);
        if self == SigmaDesign::Table61 {
            b.push(vec![1.0; n]);
        }
        b
    }

    /// The closed loop's noise-free reading of every row, run once.
    fn base(self) -> &'static [f64] {
        static T61: OnceLock<Vec<f64>> = OnceLock::new();
        static T24: OnceLock<Vec<f64>> = OnceLock::new();
        let cell = match self {
            SigmaDesign::Table61 => &T61,
            SigmaDesign::Tumble24 => &T24,
        };
        cell.get_or_init(|| {
            let instr = Instrument::kearfott_2401();
            let opts = SimOptions {
                seed: 1,
                noise: false,
                ..SimOptions::default()
            };
            self.rows()
                .par_iter()
                .map(|r| match self {
                    SigmaDesign::Table61 => {
                        simulate_difference(&instr, r, &Effects::NONE, &opts).difference_cm_s2
                    }
                    SigmaDesign::Tumble24 => {
                        simulate_condition(&instr, r, &Effects::NONE, &opts).indicated_cm_s2
                    }
                })
                .collect()
        })
    }
}

/// A kind: a design, the factor its sigma is understated by, and the strength of what is
/// hidden (0: a null).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SigmaKind {
    /// The design.
    pub design: SigmaDesign,
    /// True noise over the stated sigma.
    pub factor: f64,
    /// Strength of the hidden effect, SE (0: nothing hidden).
    pub strength_se: f64,
}

impl SigmaKind {
    /// Every kind, in table order: per design the nulls at every factor, then the power
    /// rows stated right and 2× too small.
    #[must_use]
    pub fn all() -> Vec<SigmaKind> {
        let mut v = Vec::new();
        for design in [SigmaDesign::Table61, SigmaDesign::Tumble24] {
            for factor in FACTORS {
                v.push(SigmaKind {
                    design,
                    factor,
                    strength_se: 0.0,
                });
            }
            for factor in ASSERTED {
                v.push(SigmaKind {
                    design,
                    factor,
                    strength_se: POWER_SE,
                });
            }
        }
        v
    }

    /// Name in tables.
    #[must_use]
    pub fn name(self) -> String {
        let what = if self.strength_se == 0.0 {
            "null".to_string()
        } else {
            format!("{} {} SE", self.design.effect()[0], self.strength_se)
        };
        format!("{}, {what}, sigma /{}", self.design.name(), self.factor)
    }
}

/// What a set hides.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct SigmaTruth {
    /// The kind.
    pub kind: SigmaKind,
    /// The hidden coefficient (0 for the nulls).
    pub coef: f64,
}

/// The campaign.
pub struct Sigma {
    /// The pipeline's simulator (analytic).
    pub sim: Box<dyn Simulator>,
    /// The pipeline's options (the additive terms).
    pub options: Options,
    /// The kinds run.
    pub kinds: Vec<SigmaKind>,
}

impl std::fmt::Debug for Sigma {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Sigma({})", self.sim.name())
    }
}

impl Sigma {
    /// The campaign over `kinds` (default: [`SigmaKind::all`]).
    #[must_use]
    pub fn new(kinds: Option<Vec<SigmaKind>>) -> Self {
        Sigma {
            sim: discovery::analytic(),
            options: super::effects::additive(),
            kinds: kinds.unwrap_or_else(SigmaKind::all),
        }
    }
}

/// Run `sets` sets of every kind of `kinds` (default: [`SigmaKind::all`]).
#[must_use]
pub fn run(sets: usize, seed: u64, kinds: Option<Vec<SigmaKind>>) -> Run<Sigma> {
    Run::new(Sigma::new(kinds), sets, seed)
}

/// A set's outcome.
pub type SigmaOutcome = Outcome<SigmaTruth>;

impl Campaign for Sigma {
    type Kind = SigmaKind;
    type Truth = SigmaTruth;

    fn kinds(&self) -> Vec<SigmaKind> {
        SigmaKind::all()
    }

    fn hidden(&self, kind: SigmaKind) -> bool {
        self.kinds.contains(&kind)
    }

    fn generate(&self, seed: u64, kind: SigmaKind) -> (Vec<Condition>, SigmaTruth) {
        let mut r = rng(seed);
        let g = Instrument::kearfott_2401().g_cm_s2;
        let design = kind.design;
        let mut rows = design.rows();
        let col = design.unit_column(&rows, g);
        let part = norm(&residualize(&col, &design.nuisance(rows.len())));
        let sigma = design.sigma_cm_s2();
        let coef = if kind.strength_se > 0.0 && part > 0.0 {
            r.sign() * kind.strength_se * sigma / part
        } else {
            0.0
        };
        for ((row, &b), &c) in rows.iter_mut().zip(design.base()).zip(&col) {
            row.measured_cm_s2 = Some(b + coef * c + sigma * r.normal());
            row.sigma_cm_s2 = Some(sigma / kind.factor);
        }
        (rows, SigmaTruth { kind, coef })
    }

    fn names<'a>(&self, truth: &'a SigmaTruth) -> &'a [CandidateId] {
        if truth.kind.strength_se > 0.0 {
            truth.kind.design.effect()
        } else {
            &[]
        }
    }

    fn z(&self, t: &SigmaTruth, s: &Selected) -> Option<f64> {
        (s.stderr > 0.0).then(|| (s.coef - t.coef) / s.stderr)
    }

    fn pipeline(&self) -> (&dyn Simulator, &Options) {
        (&*self.sim, &self.options)
    }

    fn title(&self, run: &Run<Self>) -> String {
        format!(
            "understated-sigma campaign: {} sets per kind, seed {}; data: the closed loop's reading of each row + Gaussian noise \
             (Table 6.1: 0.3 cm/s², tumble: 0.02 cm/s²), sigma_cm_s2 = that / factor; pipeline: {} simulator, additive terms; {:.1} s",
            run.sets,
            run.seed,
            self.sim.name(),
            run.seconds
        )
    }

    fn columns(&self) -> Columns {
        Columns {
            name: ("kind", 44),
            groups: vec![
                vec![("sets", 5)],
                vec![("any sel", 9), ("rate", 6), ("95% interval", 14)],
                vec![("named", 9)],
            ],
        }
    }

    fn rows(&self, run: &Run<Self>) -> Vec<(String, Vec<String>)> {
        let mut v = Vec::new();
        for kind in SigmaKind::all()
            .into_iter()
            .filter(|k| self.kinds.contains(k))
        {
            let (any, named) = counts(run, kind);
            let (lo, hi) = clopper_pearson(any.k, any.n);
            let null = kind.strength_se == 0.0;
            v.push((
                kind.name(),
                vec![
                    any.n.to_string(),
                    if null { any.marked() } else { any.cell() },
                    format!("{:.1}%", 100.0 * any.rate()),
                    format!("[{:.1}, {:.1}]", 100.0 * lo, 100.0 * hi),
                    if null { "-".into() } else { named.cell() },
                ],
            ));
        }
        v
    }

    fn legend(&self, _run: &Run<Self>, _ci: bool) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "any sel: sets with a selection (nulls: false selections; ! when P(>= k of n) at 5% is below 0.01); rate and its\n\
             95% Clopper-Pearson interval; named: the hidden effect selected or named as a confounded partner.\n\
             Asserted: no refusal; false selections at most 5% on the nulls with the sigma stated right and 2x too small."
        );
        s
    }

    fn checks(&self, run: &Run<Self>, _ci: bool) -> Vec<String> {
        SigmaKind::all()
            .into_iter()
            .filter(|k| {
                self.kinds.contains(k) && k.strength_se == 0.0 && ASSERTED.contains(&k.factor)
            })
            .filter_map(|k| {
                at_most_rate(&format!("false selections, {}", k.name()), counts(run, k).0)
            })
            .collect()
    }

    fn notable(&self, o: &SigmaOutcome) -> Option<&'static str> {
        if o.error.is_some() {
            Some("refused")
        } else if !o.hidden {
            o.any_selection().then_some("false selection")
        } else if !o.exact_or_partner() {
            Some("missed")
        } else {
            None
        }
    }

    fn line(&self, o: &SigmaOutcome) -> String {
        let t = &o.truth;
        format!(
            "{:<44} seed {:<12} {:+.3e} -> [{}]{}",
            t.kind.name(),
            o.seed,
            t.coef,
            super::campaign::selection_text(&o.selected),
            o.outliers_and_error("  "),
        )
    }
}

/// Sets with a selection, and sets naming the truth (exactly or as a partner), of `kind`.
fn counts(run: &Run<Sigma>, kind: SigmaKind) -> (Count, Count) {
    run.stats(
        |o| o.truth.kind == kind,
        |s: &mut (Count, Count), o| {
            s.0.add(o.any_selection());
            s.1.add(o.exact_or_partner());
        },
    )
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// The 95 % Clopper–Pearson interval of a rate, `k` of `n` (the library's, from statrs'
/// Beta quantiles; its test checks them against the binomial tails).
#[must_use]
pub fn clopper_pearson(k: usize, n: usize) -> (f64, f64) {
    ptsa_host_sim::stats::clopper_pearson(k as u64, n as u64, 0.95)
}
