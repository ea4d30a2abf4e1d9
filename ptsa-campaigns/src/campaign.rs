//! The campaign core shared by the three hidden-effect campaigns ([`super::effects`],
//! [`super::statics`], [`super::params`]): the set seeding, the run over the sets, the
//! scored outcome of each set, the printed table and the binomial assertions. A campaign
//! ([`Campaign`]) supplies only what is its own: its kinds, its generator of a set from a
//! seed, the truth of each set, the pipeline it tests, and its table's columns and
//! asserted rates.
//!
//! Seeding: set `k` of the kind at position `i` of [`Campaign::kinds`] has seed
//! [`set_seed`]`(seed, i, k)`, whether or not the kind is hidden
//! ([`Campaign::hidden`]): a campaign's sets do not depend on which others it runs.

use std::fmt::Write as _;
use std::time::Instant;

use ptsa_host_sim::CandidateId;
use ptsa_host_sim::discovery::Selected;
use ptsa_host_sim::discovery::{Discovery, Options, Simulator, discover};
use ptsa_host_sim::model::condition::Condition;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use statrs::distribution::{Binomial, DiscreteCDF as _};

/// Largest asserted false-selection and misnaming rate.
pub const RATE_MAX: f64 = 0.05;
/// Level of the one-sided binomial test of each false-selection and misnaming count
/// against [`RATE_MAX`].
pub const RATE_TEST_LEVEL: f64 = 0.01;
/// Asserted rate of naming a strong enough hidden effect (exactly or as a partner).
pub const DETECTION_MIN: f64 = 0.95;
/// Nominal coverage of `|z| ≤ 1.96`.
pub const COVERAGE: f64 = 0.95;

/// What a campaign supplies to the core.
pub trait Campaign: Sync + Sized {
    /// The unit the sets are seeded by: a kind of hidden effect (or a kind in a design).
    type Kind: Copy + Send + Sync;
    /// What a set hides, as its generator drew it.
    type Truth: Clone + Send + Sync;

    /// Sets are made and analysed in parallel; `false` when each set already keeps every
    /// core busy.
    const PARALLEL: bool = true;
    /// A selection of the truth counts as exact only when plausible (otherwise it is
    /// [`Outcome::implausible`]).
    const EXACT_NEEDS_PLAUSIBLE: bool = false;
    /// Width of the reason in front of each line of [`Run::notable`].
    const NOTABLE_WIDTH: usize = 16;

    /// Every kind, in table order; its position is its index in [`set_seed`].
    fn kinds(&self) -> Vec<Self::Kind>;
    /// Sets of `kind` are made (default: every kind).
    fn hidden(&self, _kind: Self::Kind) -> bool {
        true
    }
    /// The set of seed `seed` hiding `kind`: its rows, measured, and its truth.
    fn generate(&self, seed: u64, kind: Self::Kind) -> (Vec<Condition>, Self::Truth);
    /// The candidates that name the truth (empty: nothing is hidden).
    fn names<'a>(&self, truth: &'a Self::Truth) -> &'a [CandidateId];
    /// `(fitted − true)/SE` of `s`, a selection of one of the truth's names.
    fn z(&self, truth: &Self::Truth, s: &Selected) -> Option<f64>;
    /// The pipeline under test: its simulator and options.
    fn pipeline(&self) -> (&dyn Simulator, &Options);

    /// The table's first line.
    fn title(&self, run: &Run<Self>) -> String;
    /// The table's columns.
    fn columns(&self) -> Columns;
    /// The table's rows: a name and one cell per column of [`Campaign::columns`].
    fn rows(&self, run: &Run<Self>) -> Vec<(String, Vec<String>)>;
    /// What follows the rows: what the columns mean and what is asserted.
    fn legend(&self, run: &Run<Self>, ci: bool) -> String;
    /// The campaign's asserted rates that are not met (refusals apart). `ci`: the CI
    /// subset's assertions.
    fn checks(&self, run: &Run<Self>, ci: bool) -> Vec<String>;
    /// Why a set matters for the rates (`None`: it does not).
    fn notable(&self, o: &Outcome<Self::Truth>) -> Option<&'static str>;
    /// One line for the log.
    fn line(&self, o: &Outcome<Self::Truth>) -> String;
}

/// Seed of set `k` of the kind at `kind_index`.
#[must_use]
pub fn set_seed(seed: u64, kind_index: usize, k: usize) -> u64 {
    seed.wrapping_mul(1_000_003)
        .wrapping_add((kind_index as u64 + 1) * 100_000 + k as u64)
}

/// One selection as the scoring keeps it.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Named {
    /// The candidate.
    pub id: CandidateId,
    /// Its coefficient, in its unit.
    pub coef: f64,
    /// Standard error.
    pub stderr: f64,
    /// Within its plausibility bound (or tolerance).
    pub plausible: bool,
    /// Its confounded partners.
    pub partners: Vec<CandidateId>,
    /// Its coefficient agrees between parts of the data (`None`: not tested).
    pub stable: Option<bool>,
    /// The forms outside the vocabulary the data cannot tell it from.
    pub rivals: Vec<String>,
}

/// How the pipeline did on one set.
#[derive(Clone, Debug, Serialize, Deserialize)]
// Independent yes/no outcomes, each counted.
#[allow(clippy::struct_excessive_bools)]
pub struct Outcome<T> {
    /// The set's seed.
    pub seed: u64,
    /// What was hidden.
    pub truth: T,
    /// Something is hidden (the truth has a name).
    pub hidden: bool,
    /// What was selected.
    pub selected: Vec<Named>,
    /// A name of the truth is selected (plausible, where the campaign asks it).
    pub exact: bool,
    /// A name of the truth is selected but reported implausible (campaigns with
    /// [`Campaign::EXACT_NEEDS_PLAUSIBLE`]).
    pub implausible: bool,
    /// The truth is only named as a confounded partner of a selection.
    pub partner: bool,
    /// `(fitted − true)/SE` of the exact naming, in the named candidate's unit.
    pub z: Option<f64>,
    /// Selections that neither are nor name the truth.
    pub extra: usize,
    /// The unexplained-structure test fired.
    pub unexplained: bool,
    /// The form of its strongest proposal (`unexplained.proposals`), if any.
    pub proposal: Option<String>,
    /// Rows flagged as suspected gross errors (none is injected: false alarms).
    pub outliers: Vec<String>,
    /// How many warnings the result gives (`warnings` of the JSON).
    pub warnings: usize,
    /// The extended model's χ² tail probability (NaN when refused; `null` in JSON).
    pub extended_p: f64,
    /// The pipeline refused the set.
    pub error: Option<String>,
}

impl<T> Outcome<T> {
    /// Nothing selected.
    fn blank(seed: u64, truth: T, hidden: bool) -> Self {
        Outcome {
            seed,
            truth,
            hidden,
            selected: Vec::new(),
            exact: false,
            implausible: false,
            partner: false,
            z: None,
            extra: 0,
            unexplained: false,
            proposal: None,
            outliers: Vec::new(),
            warnings: 0,
            extended_p: f64::NAN,
            error: None,
        }
    }

    /// Named exactly or only as a confounded partner.
    #[must_use]
    pub fn exact_or_partner(&self) -> bool {
        self.exact || self.partner
    }

    /// Anything selected.
    #[must_use]
    pub fn any_selection(&self) -> bool {
        !self.selected.is_empty()
    }

    /// A plausible selection not flagged unstable between parts of the data and with no
    /// rival outside the vocabulary, while the test for unexplained structure found
    /// nothing: a named cause the output stands behind and does not warn about.
    #[must_use]
    pub fn confident_misnaming(&self) -> bool {
        self.selected
            .iter()
            .any(|s| s.plausible && s.stable != Some(false) && s.rivals.is_empty())
            && !self.unexplained
    }

    /// ` + unexplained` when the unexplained-structure test fired, for the log.
    #[must_use]
    pub fn unexplained_note(&self) -> &'static str {
        if self.unexplained {
            " + unexplained"
        } else {
            ""
        }
    }

    /// The rows flagged as gross errors and the refusal, for the log; `sep` before the
    /// refusal.
    #[must_use]
    pub fn outliers_and_error(&self, sep: &str) -> String {
        let mut s = String::new();
        if !self.outliers.is_empty() {
            let _ = write!(s, "  outliers: {}", self.outliers.join(", "));
        }
        if let Some(e) = &self.error {
            let _ = write!(s, "{sep}error: {e}");
        }
        s
    }

    /// Nothing in the result says that something is amiss: no warning, no unexplained
    /// structure, and the extended model consistent with the noise (χ² p ≥ 0.05).
    #[must_use]
    pub fn silent(&self) -> bool {
        self.error.is_none() && self.warnings == 0 && !self.unexplained && self.extended_p >= 0.05
    }

    /// Something hidden, a selection, and the truth neither selected nor named as a
    /// partner.
    #[must_use]
    pub fn misnamed(&self) -> bool {
        self.hidden && self.any_selection() && !self.exact && !self.partner
    }
}

/// Score the pipeline's answer `d` on a set whose truth `names` name; `z` of each
/// selection of a name.
fn score<T>(
    seed: u64,
    truth: T,
    names: &[CandidateId],
    needs_plausible: bool,
    z: impl Fn(&Selected) -> Option<f64>,
    d: &Discovery,
) -> Outcome<T> {
    let mut o = Outcome::blank(seed, truth, !names.is_empty());
    let mut partner = false;
    // A bias fitted with a warm-up as the level it settles to names nothing.
    for s in d.selected.iter().filter(|s| !s.companion) {
        let partners: Vec<CandidateId> = s.confounded.iter().map(|&(c, _)| c).collect();
        if names.contains(&s.id) {
            if s.plausible || !needs_plausible {
                o.exact = true;
                if let Some(z) = z(s) {
                    o.z = Some(z);
                }
            } else {
                o.implausible = true;
            }
        } else if partners.iter().any(|c| names.contains(c)) {
            partner = true;
        } else {
            o.extra += 1;
        }
        o.selected.push(Named {
            id: s.id,
            coef: s.coef,
            stderr: s.stderr,
            plausible: s.plausible,
            partners,
            stable: s.stable,
            rivals: s.rivals.iter().map(|r| r.form.clone()).collect(),
        });
    }
    o.partner = partner && !o.exact && !o.implausible;
    o.unexplained = d.json.unexplained.detected;
    o.proposal = d.json.unexplained.proposals.first().map(|p| p.form.clone());
    o.outliers = d.json.outliers.iter().map(|x| x.row.clone()).collect();
    o.warnings = d.json.warnings.len();
    o.extended_p = d.json.extended.p_value;
    o
}

/// Analyse the set of seed `seed` blind with `c`'s pipeline and score it.
#[must_use]
pub fn analyse<C: Campaign>(
    c: &C,
    seed: u64,
    rows: &[Condition],
    truth: C::Truth,
) -> Outcome<C::Truth> {
    let names = c.names(&truth).to_vec();
    let (sim, opts) = c.pipeline();
    match discover(rows, sim, opts) {
        Ok(d) => score(
            seed,
            truth.clone(),
            &names,
            C::EXACT_NEEDS_PLAUSIBLE,
            |s| c.z(&truth, s),
            &d,
        ),
        Err(e) => {
            let mut o = Outcome::blank(seed, truth, !names.is_empty());
            o.error = Some(format!("{e:#}"));
            o
        }
    }
}

/// A campaign run: its outcomes, kinds in table order.
#[derive(Debug)]
pub struct Run<C: Campaign> {
    /// The campaign.
    pub campaign: C,
    /// Sets per kind.
    pub sets: usize,
    /// Campaign seed.
    pub seed: u64,
    /// Every set's outcome, kinds in table order.
    pub outcomes: Vec<Outcome<C::Truth>>,
    /// Wall time, s.
    pub seconds: f64,
}

/// Every set a run makes, in table order: its seed and its kind.
#[must_use]
pub fn jobs<C: Campaign>(c: &C, sets: usize, seed: u64) -> Vec<(u64, C::Kind)> {
    c.kinds()
        .into_iter()
        .enumerate()
        .flat_map(|(i, kind)| (0..sets).map(move |k| (set_seed(seed, i, k), kind)))
        .filter(|&(_, kind)| c.hidden(kind))
        .collect()
}

/// Make and analyse the set `job` (one of [`jobs`]).
#[must_use]
pub fn analyse_job<C: Campaign>(c: &C, job: (u64, C::Kind)) -> Outcome<C::Truth> {
    let (rows, truth) = c.generate(job.0, job.1);
    analyse(c, job.0, &rows, truth)
}

/// Make and analyse the sets `jobs`, in their order.
fn analyse_jobs<C: Campaign>(c: &C, jobs: &[(u64, C::Kind)]) -> Vec<Outcome<C::Truth>> {
    if C::PARALLEL {
        jobs.par_iter().map(|&j| analyse_job(c, j)).collect()
    } else {
        jobs.iter().map(|&j| analyse_job(c, j)).collect()
    }
}

impl<C: Campaign> Run<C> {
    /// Make and analyse `sets` sets of every kind `campaign` hides.
    #[must_use]
    pub fn new(campaign: C, sets: usize, seed: u64) -> Self {
        let t0 = Instant::now();
        let outcomes = analyse_jobs(&campaign, &jobs(&campaign, sets, seed));
        let seconds = t0.elapsed().as_secs_f64();
        Run {
            campaign,
            sets,
            seed,
            outcomes,
            seconds,
        }
    }

    /// The figures of the sets `keep` keeps, gathered by `add`.
    pub fn stats<S: Default>(
        &self,
        keep: impl Fn(&Outcome<C::Truth>) -> bool,
        add: impl Fn(&mut S, &Outcome<C::Truth>),
    ) -> S {
        let mut s = S::default();
        for o in self.outcomes.iter().filter(|o| keep(o)) {
            add(&mut s, o);
        }
        s
    }

    /// The asserted rates that are not met (empty: the campaign passes): every refusal,
    /// then the campaign's own checks. `ci`: the CI subset's assertions.
    #[must_use]
    pub fn failures(&self, ci: bool) -> Vec<String> {
        let mut f: Vec<String> = self
            .outcomes
            .iter()
            .filter_map(|o| {
                o.error
                    .as_ref()
                    .map(|e| format!("set {} refused: {e}", o.seed))
            })
            .collect();
        f.extend(self.campaign.checks(self, ci));
        f
    }

    /// The sets that matter for the rates, one line each after the reason.
    #[must_use]
    pub fn notable(&self) -> String {
        let mut s = String::new();
        for o in &self.outcomes {
            if let Some(w) = self.campaign.notable(o) {
                let _ = writeln!(
                    s,
                    "{w:<width$} {}",
                    self.campaign.line(o),
                    width = C::NOTABLE_WIDTH
                );
            }
        }
        s
    }

    /// Every set, one line each.
    #[must_use]
    pub fn log(&self) -> String {
        self.outcomes.iter().fold(String::new(), |mut s, o| {
            let _ = writeln!(s, "{}", self.campaign.line(o));
            s
        })
    }

    /// The one table: title, columns, rows, legend and the verdict.
    #[must_use]
    pub fn table(&self, ci: bool) -> String {
        let c = &self.campaign;
        let cols = c.columns();
        let mut s = c.title(self);
        s.push('\n');
        let headers: Vec<String> = cols.cells().map(|(h, _)| h.to_string()).collect();
        cols.line(&mut s, cols.name.0, &headers);
        for (name, cells) in c.rows(self) {
            cols.line(&mut s, &name, &cells);
        }
        s.push_str(&c.legend(self, ci));
        let failures = self.failures(ci);
        if failures.is_empty() {
            let _ = writeln!(s, "asserted rates: all met");
        } else {
            for f in &failures {
                let _ = writeln!(s, "NOT MET: {f}");
            }
        }
        s
    }
}

/// A table's layout: the name column (left-aligned), then groups of right-aligned cells,
/// the groups parted by ` | `.
#[derive(Clone, Debug)]
pub struct Columns {
    /// The name column's header and width.
    pub name: (&'static str, usize),
    /// Groups of `(header, width)`.
    pub groups: Vec<Vec<(&'static str, usize)>>,
}

impl Columns {
    /// Every cell column, in order.
    fn cells(&self) -> impl Iterator<Item = (&'static str, usize)> + '_ {
        self.groups.iter().flatten().copied()
    }

    /// One line of `name` and `cells` (one per cell column).
    fn line(&self, s: &mut String, name: &str, cells: &[String]) {
        let mut cells = cells.iter();
        let groups: Vec<String> = self
            .groups
            .iter()
            .map(|g| {
                g.iter()
                    .map(|&(_, w)| format!("{:>w$}", cells.next().map_or("", String::as_str)))
                    .collect::<Vec<_>>()
                    .join(" ")
            })
            .collect();
        let _ = writeln!(s, "{name:<w$} {}", groups.join(" | "), w = self.name.1);
    }
}

/// `k` of `n`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Count {
    /// Hits.
    pub k: usize,
    /// Trials.
    pub n: usize,
}

impl Count {
    /// One more trial, a hit or not.
    pub fn add(&mut self, hit: bool) {
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
    #[must_use]
    pub fn cell(self) -> String {
        if self.n == 0 {
            "-".into()
        } else {
            format!("{}/{}", self.k, self.n)
        }
    }

    /// `k/n`, also when `n = 0`.
    #[must_use]
    pub fn fraction(self) -> String {
        format!("{}/{}", self.k, self.n)
    }

    /// More than [`RATE_MAX`] by the one-sided binomial test at [`RATE_TEST_LEVEL`].
    #[must_use]
    pub fn too_many(self) -> bool {
        self.n > 0
            && self.rate() > RATE_MAX
            && binomial_upper_tail(self.n, RATE_MAX, self.k) < RATE_TEST_LEVEL
    }

    /// The cell, marked `!` when [`Count::too_many`].
    #[must_use]
    pub fn marked(self) -> String {
        format!("{}{}", self.cell(), if self.too_many() { "!" } else { "" })
    }

    /// The cell, marked `!` when outside the 99 % band of Binomial(n, [`COVERAGE`]).
    #[must_use]
    pub fn coverage_marked(self) -> String {
        if self.n == 0 {
            return "-".into();
        }
        let (lo, hi) = binomial_interval(self.n, COVERAGE, 0.99);
        let mark = if self.k < lo || self.k > hi { "!" } else { "" };
        format!("{}{mark}", self.cell())
    }
}

/// How the hidden effects of strength ≥ [`Naming::FROM_SE`] were named: the figures the
/// statics and parameter campaigns share, and their columns.
#[derive(Clone, Copy, Debug, Default)]
pub struct Naming {
    /// Named exactly, among the strong sets.
    pub exact: Count,
    /// Named exactly or as a partner, among the strong sets.
    pub either: Count,
    /// Named only as a partner (all strengths).
    pub partner: Count,
    /// `|z| ≤ 1.96` among the exact namings of the strong sets.
    pub coverage: Count,
}

impl Naming {
    /// Strength from which detection and coverage are asserted, SE.
    pub const FROM_SE: f64 = 6.0;

    /// A table's columns: `hidden sets | ex>=6 e|p>=6 | partner | coverage`, then `rest`.
    #[must_use]
    pub fn columns(rest: Vec<Vec<(&'static str, usize)>>) -> Columns {
        let mut groups = vec![
            vec![("sets", 5)],
            vec![("ex>=6", 9), ("e|p>=6", 9)],
            vec![("partner", 8)],
            vec![("coverage", 9)],
        ];
        groups.extend(rest);
        Columns {
            name: ("hidden", 14),
            groups,
        }
    }

    /// The cells of [`Naming::columns`] after `sets`, each count as `cell` writes it.
    #[must_use]
    pub fn cells(self, cell: impl Fn(Count) -> String) -> [String; 4] {
        [self.exact, self.either, self.partner, self.coverage].map(cell)
    }

    /// One more set hiding something, of `strength_se`; `true` when it is strong and
    /// missed.
    pub fn add<T>(&mut self, o: &Outcome<T>, strength_se: f64) -> bool {
        self.partner.add(o.partner);
        if strength_se < Self::FROM_SE {
            return false;
        }
        self.exact.add(o.exact);
        self.either.add(o.exact_or_partner());
        if o.exact
            && let Some(z) = o.z
        {
            self.coverage.add(z.abs() <= 1.96);
        }
        !o.exact_or_partner()
    }
}

/// The selected terms of a set as one line of a failure listing: `name coef±se`, `?` when
/// implausible, `~ partners` when confounded, joined by `; `.
#[must_use]
pub fn selection_text(selected: &[Named]) -> String {
    let sel: Vec<String> = selected
        .iter()
        .map(|s| {
            let mut x = format!("{} {:.3e}±{:.1e}", s.id, s.coef, s.stderr);
            if !s.plausible {
                x.push('?');
            }
            if s.stable == Some(false) {
                x.push_str(" UNSTABLE");
            }
            if !s.rivals.is_empty() {
                let _ = write!(x, " | {}", s.rivals.join("/"));
            }
            if !s.partners.is_empty() {
                let p: Vec<&str> = s.partners.iter().map(|c| c.info().name).collect();
                let _ = write!(x, " ~ {}", p.join("/"));
            }
            x
        })
        .collect();
    sel.join("; ")
}

/// `what` (a count of sets) is more than [`RATE_MAX`] explains: the failure, or `None`.
#[must_use]
pub fn at_most_rate(what: &str, c: Count) -> Option<String> {
    c.too_many().then(|| {
        format!(
            "{what}: {} = {:.1}%: P(>= {} of {}) = {:.4} at a true rate of 5%, below {RATE_TEST_LEVEL}",
            c.cell(),
            100.0 * c.rate(),
            c.k,
            c.n,
            binomial_upper_tail(c.n, RATE_MAX, c.k)
        )
    })
}

/// Coverage `c` (of `|z| ≤ 1.96`) outside the 99 % band of Binomial(n, [`COVERAGE`]), once
/// there are `from` namings: the failure, or `None`.
#[must_use]
pub fn coverage_in_band(c: Count, from: usize) -> Option<String> {
    if c.n < from.max(1) {
        return (from == 0).then(|| "coverage: no set named exactly".to_string());
    }
    let (lo, hi) = binomial_interval(c.n, COVERAGE, 0.99);
    (c.k < lo || c.k > hi).then(|| {
        format!(
            "coverage: |z| <= 1.96 in {} = {:.1}%, outside [{lo}, {hi}] (99% of Binomial({}, 0.95))",
            c.cell(),
            100.0 * c.rate(),
            c.n
        )
    })
}

/// Detection `c` (`what`) below [`DETECTION_MIN`], less one binomial standard error at 5 %
/// at CI sizes (`ci`): the failure, or `None`.
#[must_use]
pub fn detected(what: &str, c: Count, ci: bool) -> Option<String> {
    #[allow(clippy::cast_precision_loss)]
    let allow = if ci {
        (RATE_MAX * (1.0 - RATE_MAX) / c.n.max(1) as f64).sqrt()
    } else {
        0.0
    };
    let need = DETECTION_MIN - allow;
    (c.n == 0 || c.rate() < need).then(|| {
        format!(
            "{what}: {} = {:.1}% < {:.1}%",
            c.cell(),
            100.0 * c.rate(),
            100.0 * need
        )
    })
}

/// Binomial(n, p) (statrs).
fn binomial(n: usize, p: f64) -> Binomial {
    Binomial::new(p, n as u64).expect("a probability from 0 to 1")
}

/// The central interval of Binomial(n, p) holding `level` of it: `[q_(1−level)/2,
/// q_(1+level)/2]`, with `q_a` the smallest `k` with `P(X ≤ k) ≥ a` (a relative slack of
/// 1e-12 on `a`, so that a sum that lands a rounding below it still counts).
#[must_use]
pub fn binomial_interval(n: usize, p: f64, level: f64) -> (usize, usize) {
    let b = binomial(n, p);
    let quantile = |a: f64| {
        (0..=n)
            .find(|&k| b.cdf(k as u64) >= a * (1.0 - 1e-12))
            .unwrap_or(n)
    };
    (
        quantile((1.0 - level) / 2.0),
        quantile(f64::midpoint(1.0, level)),
    )
}

/// `P(X ≥ k)` for X ~ Binomial(n, p).
#[must_use]
pub fn binomial_upper_tail(n: usize, p: f64, k: usize) -> f64 {
    if k == 0 {
        return 1.0;
    }
    binomial(n, p).sf(k as u64 - 1)
}

/// Every asserted rate met, or a panic listing those that are not (`what`: the campaign).
///
/// # Panics
/// When `failures` is not empty.
pub fn assert_met(what: &str, failures: &[String]) {
    assert!(
        failures.is_empty(),
        "{what} rates not met:\n{}",
        failures.join("\n")
    );
}

/// `key` from the environment, or `default`.
#[must_use]
pub fn env<T: std::str::FromStr>(key: &str, default: T) -> T {
    std::env::var(key)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// `key` is set to `1` in the environment.
#[must_use]
pub fn env_flag(key: &str) -> bool {
    std::env::var(key).is_ok_and(|v| v == "1")
}
