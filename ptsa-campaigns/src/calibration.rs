//! The calibration-coverage campaign: tumbles generated from the IEEE Std 1293 model
//! equation of a pendulous accelerometer, written out here (never the candidate code), with
//! the instrument's absolute coefficients drawn per set; `ptsa discover --analytic`'s
//! `calibration` object must give intervals (k = 2) that cover the truth 95 ± 2.5 % of the
//! time.
//!
//! * **Designs**, drawn uniformly per set: an 8-, 12- or 24-point tumble about OA or PA (the
//!   axis at random), or two 24-point tumbles, about OA and about PA (`lab::plan::tumble`,
//!   the positions only).
//! * **Truth**, per set: `K_0` uniform in 15 000–25 000 µg; `K_1 = (1 + ε)·f_clk·g/SF` with
//!   `ε` uniform in ±500 ppm; `δ_o`, `δ_p` uniform in ±300 µrad; `K_2 = ±s·SE`, `s` uniform in
//!   6–20, where SE is `K_2`'s standard error in the design beside a bias, the scale factor,
//!   the misalignments the design tests and the drift in row order (the nuisance term the
//!   pipeline fits to absolute rows without `time_s`): strong enough that the selection
//!   names it (a `K_2` it does not name is left in the residual, and half of it in `K_0`).
//! * **Reading** of a position with specific force `a` (g, along IA, PA, OA): the net pulse
//!   rate `E = K_1·(K_0 + a_i + K_2·a_i² + δ_o·a_p − δ_p·a_o)` read through the file's nominal
//!   scale factor, `SF·E/f_clk` cm/s², plus white noise of one sigma per set, uniform in
//!   5–20 µg; `sigma_cm_s2` is written in three sets of four, estimated by the pipeline in
//!   the fourth.
//! * **Counts** ([`Source::Counts`], one set in three): each position's reading given
//!   instead as `pulses` and `ticks` over a gate of 10 s or 60 s at the instrument's clock
//!   (64 kHz), written from the equation of a forced-binary loop: `2P − T = E·T/f_clk`
//!   with `E` the net pulse rate above (its white noise included), plus the charge the
//!   loop holds at the gate's start, uniform over one pulse, the count taken whole:
//!   `P = ⌊(T + E·T/f_clk)/2 + c₀⌋` (so `P = T·d + c₀ − c₁`, `c₁` what it holds at the
//!   end). Its `sigma_cm_s2`, where written, is the white noise only: the counting error
//!   (`model::counts`, 28 µg on a 10 s gate, 4.6 µg on a 60 s one) is the pipeline's to
//!   add. `K_2`'s strength is drawn against the white noise and the counting error
//!   together. The other draws are those of a set of readings (the counts' own come from a
//!   second stream), so the readings' sets are the same as before counts were added.
//! * **Scored**: for every term the design tests (`K_0`, `K_1`, `K_2`; `δ_o` when a tumble
//!   turns about OA, `δ_p` when about PA), whether `|value − truth| ≤ expanded_k2`; a term
//!   the calibration does not give as measured counts as a miss (`unmeasured`).
//!
//! # Asserted
//!
//! Over the sets with stated sigmas, pooled over the terms and designs, both sources
//! together and the counted sets alone: coverage within 95 ± 2.5 % (the full run, [`Calibration::failures`] with `ci = false`) or, in the CI
//! subset, within the central 99 % of Binomial(n, 0.95) (k = 2 covers 95.45 % of a normal
//! error). The sets whose noise the pipeline estimates are reported, not asserted (their
//! standard errors are the larger of the classical and the heteroscedasticity-robust ones,
//! which covers more than 95 % on these tumbles).

use ptsa_host_sim::Instrument;
use ptsa_host_sim::discovery::{AnalyticSimulator, Options, discover};
use ptsa_host_sim::lab::plan::{Axis, tumble};
use ptsa_host_sim::model::condition::Condition;

use std::fmt::Write as _;

use super::campaign::binomial_interval;
use super::{Draw, rng};

/// A design of the campaign.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Design {
    /// One tumble of `n` positions about `axis`.
    Tumble(usize, Axis),
    /// Two 24-point tumbles, about OA and about PA.
    Two24,
}

impl Design {
    /// Index in the tables (0: 8, 1: 12, 2: 24, 3: two 24).
    #[must_use]
    pub fn family(self) -> usize {
        match self {
            Design::Tumble(8, _) => 0,
            Design::Tumble(12, _) => 1,
            Design::Tumble(..) => 2,
            Design::Two24 => 3,
        }
    }

    /// The families' names.
    pub const NAMES: [&str; 4] = [
        "8-pt tumble",
        "12-pt tumble",
        "24-pt tumble",
        "two 24-pt tumbles",
    ];

    /// The positions, unmeasured.
    #[must_use]
    pub fn rows(self) -> Vec<Condition> {
        match self {
            Design::Tumble(n, axis) => tumbles(n, &[axis]),
            Design::Two24 => tumbles(24, &[Axis::Oa, Axis::Pa]),
        }
    }

    fn draw(r: &mut super::Rng) -> Self {
        let axis = if r.uniform() < 0.5 {
            Axis::Oa
        } else {
            Axis::Pa
        };
        match r.int(0, 3) {
            0 => Design::Tumble(8, axis),
            1 => Design::Tumble(12, axis),
            2 => Design::Tumble(24, axis),
            _ => Design::Two24,
        }
    }
}

/// The instrument's coefficients of one set (IEEE units, g-based).
#[derive(Clone, Copy, Debug)]
pub struct Truth {
    /// `K_0`, g.
    pub k0_g: f64,
    /// `K_1 = (1 + eps)·K_1,nom`.
    pub eps: f64,
    /// `δ_o`, rad.
    pub delta_o: f64,
    /// `δ_p`, rad.
    pub delta_p: f64,
    /// `K_2`, g/g².
    pub k2: f64,
}

/// The reading (cm/s²) of a position whose specific force is `a` (IA, PA, OA, g) at local
/// gravity `g` (cm/s²): the IEEE equation `E/K_1 = K_0 + a_i + K_2·a_i² + δ_o·a_p − δ_p·a_o`
/// with `K_1 = (1 + ε)·K_1,nom`, read through the nominal scale factor, i.e.
/// `(1 + ε)·g·(K_0 + a_i + …)` (for the PTSA loop, `SF·E/f_clk` with the nominal
/// `K_1,nom = f_clk·g/SF`). The one writer of the equation for this campaign and the
/// stability campaign's (`stability.rs`).
#[must_use]
pub fn reading_cm_s2(t: &Truth, g: f64, a: [f64; 3]) -> f64 {
    let [ai, ap, ao] = a;
    (1.0 + t.eps) * g * (t.k0_g + ai + t.k2 * ai * ai + t.delta_o * ap - t.delta_p * ao)
}

/// The tumbles of `n` positions about each of `axes`, one after the other (unmeasured).
#[must_use]
pub fn tumbles(n: usize, axes: &[Axis]) -> Vec<Condition> {
    axes.iter().flat_map(|&a| tumble(n, a)).collect()
}

/// `K_2`'s standard error (g/g² per g of noise) in `rows` beside a bias, the scale factor,
/// the tested misalignments and the drift in row order.
pub(super) fn k2_se(rows: &[Condition]) -> f64 {
    #[allow(clippy::cast_precision_loss)]
    let mut cols: Vec<Vec<f64>> = vec![
        rows.iter().map(|_| 1.0).collect(),
        rows.iter().map(|r| r.g[0]).collect(),
        (0..rows.len()).map(|i| i as f64).collect(),
    ];
    for k in [1, 2] {
        if rows.iter().any(|r| r.g[k].abs() > 1e-9) {
            cols.push(rows.iter().map(|r| r.g[k]).collect());
        }
    }
    cols.push(rows.iter().map(|r| r.g[0] * r.g[0]).collect());
    let refs: Vec<&[f64]> = cols.iter().map(Vec::as_slice).collect();
    let z = vec![0.0; rows.len()];
    let f = ptsa_host_sim::stats::lsq(&z, &refs).expect("a tumble's design has full rank");
    let j = cols.len() - 1;
    f.cov[(j, j)].sqrt()
}

/// How a set's positions give their measurement.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// `measured_cm_s2`, cm/s².
    Readings,
    /// `pulses` and `ticks` over a gate.
    Counts,
}

impl Source {
    /// The sources' names, in the tables' order.
    pub const NAMES: [&str; 2] = ["readings", "counts"];

    /// Index in the tables.
    #[must_use]
    pub fn index(self) -> usize {
        match self {
            Source::Readings => 0,
            Source::Counts => 1,
        }
    }
}

/// One generated set.
#[derive(Clone, Debug)]
pub struct Set {
    /// The design.
    pub design: Design,
    /// The truth.
    pub truth: Truth,
    /// Noise, g.
    pub noise_g: f64,
    /// `sigma_cm_s2` written.
    pub stated: bool,
    /// Readings or counts.
    pub source: Source,
    /// The gate, clock ticks (counts only).
    pub ticks: Option<f64>,
    /// The measured rows.
    pub rows: Vec<Condition>,
}

/// Generate set `index` of the campaign seeded `seed`.
#[must_use]
pub fn generate(seed: u64, index: u64) -> Set {
    let instr = Instrument::kearfott_2401();
    let mut r = rng(seed.wrapping_mul(1_000_003).wrapping_add(index));
    let design = Design::draw(&mut r);
    let noise_g = r.range(5e-6, 20e-6);
    let stated = index % 4 != 3;
    let source = if index % 3 == 1 {
        Source::Counts
    } else {
        Source::Readings
    };
    // The counts' own draws: a stream of their own.
    let mut rc = rng(seed.wrapping_mul(1_000_033).wrapping_add(index) ^ 0x00c0_47ed);
    let ticks = (source == Source::Counts).then(|| {
        let gate_s = if rc.uniform() < 0.5 { 10.0 } else { 60.0 };
        gate_s * instr.clock_hz
    });
    // The noise K_2 is drawn against: the white noise and, for counts, the counting error
    // of the model (`Var P` = 1/6 pulse², one pulse 2·SF/T), in g.
    let counting_g =
        ticks.map_or(0.0, |t| 2.0 * instr.sf_cm_s2 / t * (1.0f64 / 6.0).sqrt()) / instr.g_cm_s2;
    let mut rows = design.rows();
    let truth = Truth {
        k0_g: r.range(15_000e-6, 25_000e-6),
        eps: r.range(-500e-6, 500e-6),
        delta_o: r.range(-300e-6, 300e-6),
        delta_p: r.range(-300e-6, 300e-6),
        k2: r.sign() * r.range(6.0, 20.0) * k2_se(&rows) * noise_g.hypot(counting_g),
    };
    let sigma = noise_g * instr.g_cm_s2;
    for row in &mut rows {
        let u = reading_cm_s2(&truth, instr.g_cm_s2, row.g) + sigma * r.normal();
        if let Some(t) = ticks {
            // The net pulse rate E (pulses/s) of that reading; 2P − T = E·T/f_clk, with
            // the charge held at the gate's start uniform over one pulse.
            let e = u * instr.clock_hz / instr.sf_cm_s2;
            let net = e * t / instr.clock_hz;
            // P = (T + net)/2 + c₀, taken whole.
            row.pulses = Some((f64::midpoint(t, net) + rc.uniform()).floor());
            row.ticks = Some(t);
        } else {
            row.measured_cm_s2 = Some(u);
        }
        row.sigma_cm_s2 = stated.then_some(sigma);
    }
    Set {
        design,
        truth,
        noise_g,
        stated,
        source,
        ticks,
        rows,
    }
}

/// The terms scored, in the tables' order.
pub const TERMS: [&str; 5] = ["K_0", "K_1", "K_2", "δ_o", "δ_p"];

/// One term's interval against its truth.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub struct Scored {
    /// Index into [`TERMS`].
    pub term: usize,
    /// Measured and `|value − truth| ≤ expanded_k2`.
    pub covered: bool,
    /// Given as measured.
    pub measured: bool,
    /// `(value − truth)/sigma` (NaN when not measured).
    pub z: f64,
}

/// One set's scores, as the campaign's counts keep them.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct SetScores {
    /// Index of the set's source in [`Source::NAMES`].
    pub source: usize,
    /// The pipeline estimated the noise (it was not stated).
    pub estimated: bool,
    /// The design's family ([`Design::family`]).
    pub family: usize,
    /// Each term's interval against its truth.
    pub scored: Vec<Scored>,
}

/// Set `index` of the campaign seeded `seed`, made and scored.
///
/// # Panics
/// The analysis fails or has no calibration.
#[must_use]
pub fn piece(seed: u64, index: u64) -> SetScores {
    let set = generate(seed, index);
    SetScores {
        source: set.source.index(),
        estimated: !set.stated,
        family: set.design.family(),
        scored: score(&set),
    }
}

/// The scored terms of one set's analysis.
///
/// # Panics
/// The analysis fails or has no calibration.
#[must_use]
pub fn score(set: &Set) -> Vec<Scored> {
    let instr = Instrument::kearfott_2401();
    let sim = AnalyticSimulator::for_instrument(&instr);
    let d = discover(&set.rows, &sim, &Options::for_instrument(&instr)).expect("analysis");
    let c = d.json.calibration.expect("a calibration");
    let k1_nom = instr.clock_hz * instr.g_cm_s2 / instr.sf_cm_s2;
    let t = set.truth;
    let truths = [
        t.k0_g * 1e6,
        (1.0 + t.eps) * k1_nom,
        t.k2 * 1e6,
        t.delta_o * 1e6,
        t.delta_p * 1e6,
    ];
    let tests_p = set.rows.iter().any(|r| r.g[1].abs() > 1e-9);
    let tests_o = set.rows.iter().any(|r| r.g[2].abs() > 1e-9);
    TERMS
        .iter()
        .enumerate()
        .filter(|&(k, _)| (k != 3 || tests_p) && (k != 4 || tests_o))
        .map(|(k, symbol)| {
            let term = c.terms.iter().find(|x| x.symbol == *symbol).expect("term");
            let (Some(s), Some(u)) = (term.sigma, term.expanded_k2) else {
                return Scored {
                    term: k,
                    covered: false,
                    measured: false,
                    z: f64::NAN,
                };
            };
            let err = term.value - truths[k];
            Scored {
                term: k,
                covered: term.measured && err.abs() <= u,
                measured: term.measured,
                z: err / s,
            }
        })
        .collect()
}

/// A count of intervals: covering, of.
#[derive(Clone, Copy, Debug, Default)]
pub struct Count {
    /// Covering the truth.
    pub covered: usize,
    /// Scored.
    pub n: usize,
    /// Not given as measured.
    pub unmeasured: usize,
}

impl Count {
    fn add(&mut self, s: &Scored) {
        self.n += 1;
        self.covered += usize::from(s.covered);
        self.unmeasured += usize::from(!s.measured);
    }

    /// Coverage, percent.
    #[must_use]
    pub fn percent(self) -> f64 {
        #[allow(clippy::cast_precision_loss)]
        let p = 100.0 * self.covered as f64 / self.n.max(1) as f64;
        p
    }
}

/// The campaign's counts: `[readings, counts][stated, estimated][design family][term]`.
#[derive(Clone, Debug, Default)]
pub struct Calibration {
    /// Sets run.
    pub sets: usize,
    /// The counts.
    pub counts: [[[[Count; 5]; 4]; 2]; 2],
}

impl Calibration {
    /// Run `sets` sets seeded `seed` (in parallel).
    #[must_use]
    pub fn run(sets: usize, seed: u64) -> Self {
        use rayon::prelude::*;
        let pieces: Vec<SetScores> = (0..sets as u64)
            .into_par_iter()
            .map(|i| piece(seed, i))
            .collect();
        Calibration::from_pieces(sets, &pieces)
    }

    /// The campaign's counts from every set's scores ([`piece`]).
    #[must_use]
    pub fn from_pieces(sets: usize, pieces: &[SetScores]) -> Self {
        let mut c = Calibration {
            sets,
            ..Calibration::default()
        };
        for p in pieces {
            for x in &p.scored {
                c.counts[p.source][usize::from(p.estimated)][p.family][x.term].add(x);
            }
        }
        c
    }

    /// Pooled over designs and terms, for stated (`0`) or estimated (`1`) sigmas, over
    /// the sources `sources` (indices of [`Source::NAMES`]).
    #[must_use]
    pub fn pooled(&self, noise: usize, sources: &[usize]) -> Count {
        let mut p = Count::default();
        for &src in sources {
            for fam in &self.counts[src][noise] {
                for k in fam {
                    p.covered += k.covered;
                    p.n += k.n;
                    p.unmeasured += k.unmeasured;
                }
            }
        }
        p
    }

    /// The table: coverage per design and term, stated and estimated sigmas.
    #[must_use]
    pub fn table(&self) -> String {
        let mut s = format!(
            "calibration coverage: {} sets, k = 2 intervals of the absolute coefficients against the truth (covered/scored, unmeasured)\n",
            self.sets
        );
        for (src, sname) in Source::NAMES.iter().enumerate() {
            for (noise, name) in ["stated sigma", "estimated sigma"].iter().enumerate() {
                let _ = write!(s, "{:<24}", format!("{sname}, {name}"));
                for t in TERMS {
                    let _ = write!(s, "{t:>20}");
                }
                s.push('\n');
                self.rows(&mut s, src, noise);
                let p = self.pooled(noise, &[src]);
                let _ = writeln!(
                    s,
                    "  pooled: {}/{} = {:.1} % ({} unmeasured)",
                    p.covered,
                    p.n,
                    p.percent(),
                    p.unmeasured
                );
            }
        }
        for (noise, name) in ["stated sigma", "estimated sigma"].iter().enumerate() {
            let p = self.pooled(noise, &[0, 1]);
            let _ = writeln!(
                s,
                "{name}, readings and counts pooled: {}/{} = {:.1} % ({} unmeasured)",
                p.covered,
                p.n,
                p.percent(),
                p.unmeasured
            );
        }
        s
    }

    /// The table's rows of one source and noise: one per design family.
    fn rows(&self, s: &mut String, src: usize, noise: usize) {
        for (f, fname) in Design::NAMES.iter().enumerate() {
            let _ = write!(s, "  {fname:<22}");
            for k in &self.counts[src][noise][f] {
                let cell = if k.n == 0 {
                    "—".to_string()
                } else {
                    format!(
                        "{}/{} {:.1}% ({})",
                        k.covered,
                        k.n,
                        k.percent(),
                        k.unmeasured
                    )
                };
                let _ = write!(s, "{cell:>20}");
            }
            s.push('\n');
        }
    }

    /// What is not met: the stated-sigma sets' pooled coverage, over both sources and over
    /// the counted sets alone, within 95 ± 2.5 % (`ci`: within the central 99 % of
    /// Binomial(n, 0.95)).
    #[must_use]
    pub fn failures(&self, ci: bool) -> Vec<String> {
        let mut f = Vec::new();
        for (what, sources) in [("", &[0, 1][..]), (" of the counted sets", &[1][..])] {
            let p = self.pooled(0, sources);
            if ci {
                let (lo, hi) = binomial_interval(p.n, 0.95, 0.99);
                if p.covered < lo || p.covered > hi {
                    f.push(format!(
                        "NOT MET: stated-sigma coverage{what} {}/{} outside the central 99 % of Binomial({}, 0.95), [{lo}, {hi}]",
                        p.covered, p.n, p.n
                    ));
                }
            } else if (p.percent() - 95.0).abs() > 2.5 {
                f.push(format!(
                    "NOT MET: stated-sigma coverage{what} {:.1} % ({}/{}) outside 95 ± 2.5 %",
                    p.percent(),
                    p.covered,
                    p.n
                ));
            }
        }
        f
    }
}
