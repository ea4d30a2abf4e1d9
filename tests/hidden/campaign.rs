//! A campaign: `sets` sets of every [`Kind`], analysed blind, scored, summarised in one
//! table, and checked against the asserted rates.
//!
//! Asserted (the campaign fails otherwise):
//!
//! * **coverage**: of the sets whose hidden candidate is named exactly at ≥ 6 SE, the
//!   fraction with `|z| ≤ 1.96` lies in the 99 % interval of Binomial(n, 0.95) (all
//!   candidates together; per candidate it is shown, and marked `!` outside its own band);
//! * **false selections**: the sets of each null kind that select anything are consistent
//!   with a rate of at most 5 % (one-sided binomial test: the campaign fails when
//!   `P(X ≥ k | n, 5 %) < RATE_TEST_LEVEL`, so that a pipeline at exactly 5 % fails one
//!   kind's check 1 % of the time at any size, and one at 20 % fails it almost surely at 35
//!   sets);
//! * **confident misnamings**: the same for the sets of each out-of-vocabulary, bias-shift
//!   and drift kind with a plausible selection and no warning of unexplained structure (the
//!   aliased out-of-vocabulary kinds, whose data no analyser can tell from a candidate's,
//!   are reported, not asserted);
//! * **detection**: ≥ 95 % of the candidate sets of ≥ 8 SE name the hidden candidate exactly
//!   or as a confounded partner (all candidates together).
//!
//! At CI sizes the detection rate gets an allowance of one binomial standard error.

use std::fmt::Write as _;
use std::time::Instant;

use ptsa_host_sim::discovery::{Options, Simulator, discover};
use rayon::prelude::*;

use super::generate::{Class, GenOptions, Kind, generate};
use super::physics::Generator;
use super::score::{Outcome, score};

/// Strengths at which detection power is reported, SE.
pub const THRESHOLDS: [f64; 4] = [3.0, 4.0, 6.0, 8.0];
/// Strength from which coverage is measured, SE.
pub const COVERAGE_FROM_SE: f64 = 6.0;
/// Strength from which detection is asserted, SE.
pub const DETECTION_FROM_SE: f64 = 8.0;
/// Asserted detection rate at [`DETECTION_FROM_SE`].
pub const DETECTION_MIN: f64 = 0.95;
/// Largest asserted false-selection and misnaming rate.
pub const RATE_MAX: f64 = 0.05;
/// Level of the one-sided binomial test of each false-selection and misnaming count
/// against [`RATE_MAX`].
pub const RATE_TEST_LEVEL: f64 = 0.01;
/// Nominal coverage of `|z| ≤ 1.96`.
pub const COVERAGE: f64 = 0.95;

/// A campaign's outcomes.
#[derive(Clone, Debug)]
pub struct Campaign {
    /// Sets per kind.
    pub sets_per_kind: usize,
    /// Campaign seed.
    pub seed: u64,
    /// Generator's name.
    pub generator: &'static str,
    /// Pipeline simulator's name.
    pub pipeline: &'static str,
    /// `(set seed, outcome)` of every set, kinds in table order.
    pub outcomes: Vec<(u64, Outcome)>,
    /// Wall time, s.
    pub seconds: f64,
}

/// Seed of set `k` of the kind at `kind_index`.
#[must_use]
pub fn set_seed(seed: u64, kind_index: usize, k: usize) -> u64 {
    seed.wrapping_mul(1_000_003)
        .wrapping_add((kind_index as u64 + 1) * 100_000 + k as u64)
}

/// Run `sets_per_kind` sets of every kind; `source` makes the data, `fit` is the pipeline's
/// simulator.
#[must_use]
pub fn run(sets_per_kind: usize, seed: u64, source: &Generator, fit: &dyn Simulator) -> Campaign {
    let t0 = Instant::now();
    let jobs: Vec<(u64, Kind)> = Kind::all()
        .into_iter()
        .enumerate()
        .flat_map(|(i, kind)| (0..sets_per_kind).map(move |k| (set_seed(seed, i, k), kind)))
        .collect();
    let opts = additive();
    let outcomes = jobs
        .par_iter()
        .map(|&(s, kind)| {
            let set = generate(s, kind, source, &GenOptions::default());
            let o = match discover(&set.rows, fit, &opts) {
                Ok(d) => score(&set, &d),
                Err(e) => {
                    let mut o = Outcome::blank(&set.truth);
                    o.error = Some(format!("{e:#}"));
                    o
                }
            };
            (s, o)
        })
        .collect();
    Campaign {
        sets_per_kind,
        seed,
        generator: source.name(),
        pipeline: fit.name(),
        outcomes,
        seconds: t0.elapsed().as_secs_f64(),
    }
}

/// `k` of `n`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Count {
    /// Hits.
    pub k: usize,
    /// Trials.
    pub n: usize,
}

impl Count {
    /// One more trial, a hit or not.
    pub(crate) fn add(&mut self, hit: bool) {
        self.n += 1;
        self.k += usize::from(hit);
    }

    /// `k/n` (NaN when `n = 0`).
    #[must_use]
    pub fn rate(self) -> f64 {
        if self.n == 0 {
            f64::NAN
        } else {
            #[allow(clippy::cast_precision_loss)]
            let r = self.k as f64 / self.n as f64;
            r
        }
    }

    /// `k/n`, or `-` when `n = 0`.
    pub(crate) fn cell(self) -> String {
        if self.n == 0 {
            "-".into()
        } else {
            format!("{}/{}", self.k, self.n)
        }
    }

    /// More than [`RATE_MAX`] by the one-sided binomial test at [`RATE_TEST_LEVEL`].
    pub(crate) fn too_many(self) -> bool {
        self.n > 0
            && self.rate() > RATE_MAX
            && binomial_upper_tail(self.n, RATE_MAX, self.k) < RATE_TEST_LEVEL
    }
}

/// The figures of one table row.
#[derive(Clone, Debug, Default)]
pub struct RowStats {
    /// Sets.
    pub sets: usize,
    /// Named exactly, per threshold (sets with strength ≥ threshold).
    pub exact: [Count; 4],
    /// Named exactly or only as a partner, per threshold.
    pub either: [Count; 4],
    /// Named only as a partner (all strengths).
    pub partner_only: Count,
    /// `|z| ≤ 1.96` among the sets named exactly at ≥ 6 SE.
    pub coverage: Count,
    /// Candidates: sets with an unrelated extra selection; not nameable and aliased:
    /// confident misnamings; nulls: sets with any selection.
    pub false_or_misnamed: Count,
    /// Sets with any selection.
    pub any: Count,
    /// Sets with a row flagged as a suspected gross error (no gross error is injected: a
    /// false alarm of the outlier test).
    pub outliers: Count,
}

impl RowStats {
    fn add(&mut self, o: &Outcome) {
        let t = &o.truth;
        self.sets += 1;
        self.any.add(o.any_selection);
        self.outliers.add(!o.outliers.is_empty());
        match t.kind.class() {
            Class::Candidate => {
                for (j, &th) in THRESHOLDS.iter().enumerate() {
                    if t.strength_se >= th {
                        self.exact[j].add(o.exact);
                        self.either[j].add(o.exact_or_partner());
                    }
                }
                self.partner_only.add(o.partner_only);
                if o.exact
                    && t.strength_se >= COVERAGE_FROM_SE
                    && let Some(z) = o.z
                {
                    self.coverage.add(z.abs() <= 1.96);
                }
                self.false_or_misnamed.add(o.others > 0);
            }
            Class::NotNameable | Class::Aliased => {
                self.false_or_misnamed.add(o.confident_misnaming);
            }
            Class::Null => self.false_or_misnamed.add(o.any_selection),
        }
    }
}

/// `ln P(X = k)` for X ~ Binomial(n, p), every k.
fn binomial_ln_pmf(n: usize, p: f64) -> Vec<f64> {
    let q = 1.0 - p;
    #[allow(clippy::cast_precision_loss)]
    let mut v = vec![n as f64 * q.ln()];
    for k in 0..n {
        #[allow(clippy::cast_precision_loss)]
        let step = ((n - k) as f64 / (k + 1) as f64).ln() + (p / q).ln();
        let last = v[k];
        v.push(last + step);
    }
    v
}

/// The central interval of Binomial(n, p) holding `level` of it: `[q_(1−level)/2,
/// q_(1+level)/2]`, with `q_a` the smallest `k` with `P(X ≤ k) ≥ a`.
#[must_use]
pub fn binomial_interval(n: usize, p: f64, level: f64) -> (usize, usize) {
    let pmf: Vec<f64> = binomial_ln_pmf(n, p).into_iter().map(f64::exp).collect();
    let quantile = |a: f64| {
        let mut c = 0.0;
        for (k, x) in pmf.iter().enumerate() {
            c += x;
            if c >= a * (1.0 - 1e-12) {
                return k;
            }
        }
        n
    };
    (
        quantile((1.0 - level) / 2.0),
        quantile(f64::midpoint(1.0, level)),
    )
}

/// `P(X ≥ k)` for X ~ Binomial(n, p).
#[must_use]
pub fn binomial_upper_tail(n: usize, p: f64, k: usize) -> f64 {
    binomial_ln_pmf(n, p)
        .into_iter()
        .skip(k)
        .map(f64::exp)
        .sum::<f64>()
        .min(1.0)
}

/// One binomial standard error of a rate `p` over `n` sets.
fn binomial_se(p: f64, n: usize) -> f64 {
    #[allow(clippy::cast_precision_loss)]
    let s = (p * (1.0 - p) / n.max(1) as f64).sqrt();
    s
}

/// The allowance on an asserted rate over `n` sets: one binomial standard error at 5 % at
/// CI sizes (`ci`), none in a full campaign.
fn allowance(n: usize, ci: bool) -> f64 {
    if ci { binomial_se(RATE_MAX, n) } else { 0.0 }
}

impl Campaign {
    /// Per-kind figures, kinds in table order, then the candidates together.
    #[must_use]
    pub fn rows(&self) -> Vec<(String, Class, RowStats)> {
        let mut rows: Vec<(String, Class, RowStats)> = Vec::new();
        let mut all = RowStats::default();
        for kind in Kind::all() {
            let mut r = RowStats::default();
            for (_, o) in self.outcomes.iter().filter(|(_, o)| o.truth.kind == kind) {
                r.add(o);
                if kind.class() == Class::Candidate {
                    all.add(o);
                }
            }
            rows.push((kind.name(), kind.class(), r));
        }
        rows.push(("all candidates".into(), Class::Candidate, all));
        rows
    }

    /// The asserted rates that are not met (empty: the campaign passes). `ci`: allow one
    /// binomial standard error.
    #[must_use]
    pub fn failures(&self, ci: bool) -> Vec<String> {
        let mut f = Vec::new();
        let allow = |n: usize| allowance(n, ci);
        for (name, class, r) in self.rows() {
            let c = r.false_or_misnamed;
            match class {
                Class::Null | Class::NotNameable if c.too_many() => {
                    f.push(format!(
                        "{name}: {} {} = {:.1}%: P(>= {} of {}) = {:.4} at a true rate of 5%, below {RATE_TEST_LEVEL}",
                        if class == Class::Null {
                            "false selections"
                        } else {
                            "confident misnamings"
                        },
                        c.cell(),
                        100.0 * c.rate(),
                        c.k,
                        c.n,
                        binomial_upper_tail(c.n, RATE_MAX, c.k)
                    ));
                }
                Class::Candidate if name == "all candidates" => {
                    let cov = r.coverage;
                    if cov.n == 0 {
                        f.push(format!(
                            "coverage: no set named exactly at >= {COVERAGE_FROM_SE} SE"
                        ));
                    } else {
                        let (lo, hi) = binomial_interval(cov.n, COVERAGE, 0.99);
                        if cov.k < lo || cov.k > hi {
                            f.push(format!(
                                "coverage: |z| <= 1.96 in {} = {:.1}%, outside [{lo}, {hi}] (99% of Binomial({}, 0.95))",
                                cov.cell(),
                                100.0 * cov.rate(),
                                cov.n
                            ));
                        }
                    }
                    let d = r.either[THRESHOLDS
                        .iter()
                        .position(|&t| (t - DETECTION_FROM_SE).abs() < 1e-9)
                        .unwrap_or(3)];
                    let need = DETECTION_MIN - allow(d.n);
                    if d.n == 0 || d.rate() < need {
                        f.push(format!(
                            "detection (exact or partner) at >= {DETECTION_FROM_SE} SE: {} = {:.1}% < {:.1}%",
                            d.cell(),
                            100.0 * d.rate(),
                            100.0 * need
                        ));
                    }
                }
                _ => {}
            }
        }
        f
    }

    /// The sets that matter for the rates: misses at ≥ 6 SE, implausible namings, coverage
    /// outliers, false selections, confident misnamings, refusals, rows flagged as gross
    /// errors.
    #[must_use]
    pub fn notable(&self) -> String {
        let mut s = String::new();
        for (seed, o) in &self.outcomes {
            let t = &o.truth;
            let why = match t.kind.class() {
                _ if o.error.is_some() => Some("refused"),
                Class::Candidate => {
                    if !o.exact_or_partner() && t.strength_se >= COVERAGE_FROM_SE {
                        Some("missed at >= 6 SE")
                    } else if o.implausible {
                        Some("named implausible")
                    } else if o.exact
                        && t.strength_se >= COVERAGE_FROM_SE
                        && o.z.is_some_and(|z| z.abs() > 1.96)
                    {
                        Some("|z| > 1.96")
                    } else if o.others > 0 {
                        Some("extra selection")
                    } else {
                        None
                    }
                }
                Class::NotNameable => o.confident_misnaming.then_some("confident misnaming"),
                Class::Aliased => o.confident_misnaming.then_some("(aliased) misnaming"),
                Class::Null => o.any_selection.then_some("false selection"),
            };
            let why = why.or_else(|| (!o.outliers.is_empty()).then_some("outlier flagged"));
            if let Some(w) = why {
                let _ = writeln!(s, "{w:<20} {}", o.line(*seed));
            }
        }
        s
    }

    /// Every set, one line each.
    #[must_use]
    pub fn log(&self) -> String {
        let mut s = String::new();
        for (seed, o) in &self.outcomes {
            let _ = writeln!(s, "{}", o.line(*seed));
        }
        s
    }

    /// The one table; `ci` as in [`Campaign::failures`].
    #[must_use]
    #[allow(clippy::too_many_lines)] // one report table, row by row
    pub fn table(&self, ci: bool) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "hidden-effect campaign: {} sets per kind, seed {}; data: {}; pipeline: {} simulator; {:.1} s",
            self.sets_per_kind, self.seed, self.generator, self.pipeline, self.seconds
        );
        let _ = writeln!(
            s,
            "{:<26} {:>4} | {:>9} {:>9} {:>9} {:>9} | {:>9} {:>9} {:>9} {:>9} | {:>8} | {:>9} | {:>9} | {:>9} | {:>9}",
            "hidden kind",
            "sets",
            "ex>=3",
            "ex>=4",
            "ex>=6",
            "ex>=8",
            "e|p>=3",
            "e|p>=4",
            "e|p>=6",
            "e|p>=8",
            "partner",
            "coverage",
            "false/mis",
            "any sel",
            "outliers"
        );
        let failing = self.failures(ci);
        for (name, class, r) in self.rows() {
            let cov = if r.coverage.n == 0 {
                "-".to_string()
            } else {
                let (lo, hi) = binomial_interval(r.coverage.n, COVERAGE, 0.99);
                let mark = if r.coverage.k < lo || r.coverage.k > hi {
                    "!"
                } else {
                    ""
                };
                format!("{}{mark}", r.coverage.cell())
            };
            let fm = match class {
                Class::Candidate | Class::Aliased => format!("({})", r.false_or_misnamed.cell()),
                _ => {
                    let c = r.false_or_misnamed;
                    let mark = if c.n > 0
                        && c.rate() > RATE_MAX
                        && binomial_upper_tail(c.n, RATE_MAX, c.k) < RATE_TEST_LEVEL
                    {
                        "!"
                    } else {
                        ""
                    };
                    format!("{}{mark}", c.cell())
                }
            };
            let cells = |c: &[Count; 4]| -> Vec<String> {
                if class == Class::Candidate {
                    c.iter().map(|x| x.cell()).collect()
                } else {
                    vec![String::new(); 4]
                }
            };
            let ex = cells(&r.exact);
            let ei = cells(&r.either);
            let _ = writeln!(
                s,
                "{name:<26} {:>4} | {:>9} {:>9} {:>9} {:>9} | {:>9} {:>9} {:>9} {:>9} | {:>8} | {:>9} | {:>9} | {:>9} | {:>9}",
                r.sets,
                ex[0],
                ex[1],
                ex[2],
                ex[3],
                ei[0],
                ei[1],
                ei[2],
                ei[3],
                if class == Class::Candidate {
                    r.partner_only.cell()
                } else {
                    String::new()
                },
                cov,
                fm,
                r.any.cell(),
                r.outliers.cell()
            );
        }
        let _ = writeln!(
            s,
            "ex>=T: named exactly (selected, plausible) among the sets of >= T SE; e|p: exactly or only as a confounded partner;\n\
             partner: named only as a partner (all strengths); coverage: |z| <= 1.96 among exact namings at >= 6 SE (! outside the\n\
             99% interval of Binomial(n, 0.95)); false/mis: nulls: any selection, oov/bias/drift: confident misnaming (plausible\n\
             selection, no unexplained-structure warning); in brackets, not asserted: candidates: an unrelated extra selection,\n\
             aliased oov (the design's data are those of an in-vocabulary set): confident misnaming;\n\
             any sel: sets with any selection; outliers: sets with a row flagged as a suspected gross error (none is injected). Asserted: coverage over all candidates; e|p>=8 >= 95% over all candidates{}; false/mis per kind\n\
             consistent with at most 5% (! when P(>= k of n) at 5% is below 0.01).",
            if ci {
                " (less one binomial standard error at this size)"
            } else {
                ""
            }
        );
        if failing.is_empty() {
            let _ = writeln!(s, "asserted rates: all met");
        } else {
            for f in &failing {
                let _ = writeln!(s, "NOT MET: {f}");
            }
        }
        s
    }
}

/// The campaign's vocabulary, the additive terms: the loop's parameters have no signature
/// above the closed loop's noise in these difference designs, and their finite differences
/// through the loop would cost five times the rest; they are hidden (in the instrument
/// file) by the parameter campaign instead.
#[must_use]
pub fn additive() -> Options {
    Options {
        candidates: ptsa_host_sim::CandidateId::ALL
            .iter()
            .filter(|c| c.parameter_key().is_none())
            .copied()
            .collect(),
        ..Options::default()
    }
}
