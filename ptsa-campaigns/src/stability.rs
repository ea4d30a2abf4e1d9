//! The stability null campaign: tumbles generated from the IEEE Std 1293 model equation
//! with constant coefficients (written out here, never the candidate code), analysed by
//! `ptsa_host_sim::discovery::discover`; no selected term may be marked unstable
//! (`stable: false`, docs/method/discovery.md section 8b) in more than the familywise 5 % of the
//! sets the stability stage is held at.
//!
//! * **Designs**, drawn uniformly per set: a 24- or 48-point tumble about OA or PA (the axis
//!   at random), or two of them, about OA and then about PA (`lab::plan::tumble`, the
//!   positions only; rows in that order, no `time_s`, so the halves in time are the two
//!   tumbles).
//! * **Instrument**, one of two per set: the shipped Kearfott 2401 file (`K_0` uniform in
//!   15 000–25 000 µg, the scale factor's change `ε` uniform in ±1000 ppm, `δ_o`, `δ_p`
//!   uniform in ±300 µrad, noise uniform in 5–20 µg), or the shipped loop-less `mems` file
//!   (`K_0` uniform in ±50 mg, `ε` uniform in ±4 %, `δ_o`, `δ_p` uniform in ±10 mrad, noise
//!   uniform in 0.2–2 mg).
//! * **`K_2`**: none in half the sets, `±s·SE` with `s` uniform in 6–20 in the other half
//!   (SE as in the calibration campaign: strong enough to be named).
//! * **Reading** of a position with specific force `a` (g along IA, PA, OA):
//!   `(1 + ε)·g·(K_0 + a_i + K_2·a_i² + δ_o·a_p − δ_p·a_o)` cm/s² (the IEEE equation's
//!   output read through the file's nominal scale factor; `calibration::reading_cm_s2`,
//!   the one writer of the equation for both campaigns) plus white noise;
//!   `sigma_cm_s2` is written in three sets of four, estimated by the pipeline in the
//!   fourth.
//! * **Scored**: a set is a false alarm when any selected term has `stable: false`.
//!
//! # Asserted
//!
//! The false alarms, over every set: at most the upper end of the central 99 % of
//! Binomial(n, 0.05) (the familywise level).

use ptsa_host_sim::Instrument;
use ptsa_host_sim::discovery::{AnalyticSimulator, Options, discover};
use ptsa_host_sim::lab::plan::Axis;
use ptsa_host_sim::model::condition::Condition;

use std::fmt::Write as _;

use super::calibration::{Truth, reading_cm_s2, tumbles};
use super::campaign::binomial_interval;
use super::{Draw, rng};

/// The familywise level of the stability stage.
pub const ALPHA: f64 = 0.05;

/// One generated set.
#[allow(clippy::struct_excessive_bools)] // each switch is one axis of the campaign's table
#[derive(Clone, Debug)]
pub struct Set {
    /// The `mems` file (else the Kearfott 2401).
    pub mems: bool,
    /// Positions per tumble (24 or 48).
    pub positions: usize,
    /// Two tumbles (about OA, then PA), else one.
    pub two_axes: bool,
    /// `sigma_cm_s2` written.
    pub stated: bool,
    /// A `K_2` in the truth.
    pub with_k2: bool,
    /// The scale factor's change from nominal.
    pub eps: f64,
    /// The measured rows.
    pub rows: Vec<Condition>,
}

impl Set {
    /// The instrument the set is analysed with.
    ///
    /// # Panics
    /// The shipped `mems` file does not load.
    #[must_use]
    pub fn instrument(&self) -> Instrument {
        if self.mems {
            Instrument::shipped("mems").expect("the shipped mems file")
        } else {
            Instrument::kearfott_2401()
        }
    }

    /// The set's class in the table: `[instrument][noise][k2]`.
    fn class(&self) -> (usize, usize, usize) {
        (
            usize::from(self.mems),
            usize::from(!self.stated),
            usize::from(self.with_k2),
        )
    }
}

/// Generate set `index` of the campaign seeded `seed`.
///
/// # Panics
/// The shipped `mems` file does not load.
#[must_use]
pub fn generate(seed: u64, index: u64) -> Set {
    let mut r = rng(seed.wrapping_mul(1_000_003).wrapping_add(index));
    let mems = r.uniform() < 0.5;
    let positions = if r.uniform() < 0.5 { 24 } else { 48 };
    let two_axes = r.uniform() < 0.5;
    let stated = index % 4 != 3;
    let with_k2 = r.uniform() < 0.5;
    let axes: &[Axis] = if two_axes {
        &[Axis::Oa, Axis::Pa]
    } else if r.uniform() < 0.5 {
        &[Axis::Oa]
    } else {
        &[Axis::Pa]
    };
    let mut rows = tumbles(positions, axes);
    let (k0, eps, tilt, noise) = if mems {
        (
            r.range(-50e-3, 50e-3),
            r.range(-0.04, 0.04),
            10e-3,
            r.range(0.2e-3, 2e-3),
        )
    } else {
        (
            r.range(15_000e-6, 25_000e-6),
            r.range(-1000e-6, 1000e-6),
            300e-6,
            r.range(5e-6, 20e-6),
        )
    };
    let delta_o = r.range(-tilt, tilt);
    let delta_p = r.range(-tilt, tilt);
    let k2 = if with_k2 {
        r.sign() * r.range(6.0, 20.0) * super::calibration::k2_se(&rows) * noise
    } else {
        0.0
    };
    let mems_g = Instrument::shipped("mems")
        .expect("the shipped mems file")
        .g_cm_s2;
    let g = if mems {
        mems_g
    } else {
        Instrument::kearfott_2401().g_cm_s2
    };
    let sigma = noise * g;
    let truth = Truth {
        k0_g: k0,
        eps,
        delta_o,
        delta_p,
        k2,
    };
    for row in &mut rows {
        row.measured_cm_s2 = Some(reading_cm_s2(&truth, g, row.g) + sigma * r.normal());
        row.sigma_cm_s2 = stated.then_some(sigma);
    }
    Set {
        mems,
        positions,
        two_axes,
        stated,
        with_k2,
        eps,
        rows,
    }
}

/// One set's score, as the campaign's counts keep it.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct SetScore {
    /// `[kearfott, mems][stated, estimated][no K_2, K_2]` indices.
    pub class: (usize, usize, usize),
    /// `[24 one axis, 24 two axes, 48 one axis, 48 two axes]` index.
    pub design: usize,
    /// The set and what was flagged, for the table (empty when nothing was).
    pub flagged: String,
    /// The analysis scored.
    pub scored: Scored,
}

/// Set `index` of the campaign seeded `seed`, made and analysed.
///
/// # Panics
/// The analysis fails.
#[must_use]
pub fn piece(seed: u64, index: u64) -> SetScore {
    let set = generate(seed, index);
    let scored = score(&set);
    let flagged = if scored.unstable.is_empty() {
        String::new()
    } else {
        format!(
            "{} {}×{} ε {:.0} ppm {}: {}",
            if set.mems { "mems" } else { "kearfott" },
            if set.two_axes { 2 } else { 1 },
            set.positions,
            set.eps * 1e6,
            if set.stated { "stated" } else { "estimated" },
            scored.unstable.join("; ")
        )
    };
    SetScore {
        class: set.class(),
        design: usize::from(set.two_axes) + 2 * usize::from(set.positions == 48),
        flagged,
        scored,
    }
}

/// One set's analysis: the selected terms marked unstable, each with its smallest
/// p-value and split (`name split p`); and whether any term was tested.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Scored {
    /// The terms marked `stable: false`.
    pub unstable: Vec<String>,
    /// Some selected term was tested on a split.
    pub tested: bool,
}

/// Analyse one set.
///
/// # Panics
/// The analysis fails.
#[must_use]
pub fn score(set: &Set) -> Scored {
    let instr = set.instrument();
    let sim = AnalyticSimulator::for_instrument(&instr);
    let d = discover(&set.rows, &sim, &Options::for_instrument(&instr)).expect("analysis");
    let mut unstable = Vec::new();
    let mut tested = false;
    for e in &d.json.effects {
        tested |= e.stable.is_some();
        if e.stable == Some(false) {
            let worst = e
                .stability
                .tests
                .iter()
                .min_by(|a, b| a.p_value.total_cmp(&b.p_value));
            unstable.push(match worst {
                Some(t) => format!(
                    "{} {} chi2 {:.2} (on the p-value's noise scale {:.2}) p {:.4}",
                    t.name, t.split, t.chi2, t.statistic, t.p_value
                ),
                None => e.name.clone(),
            });
        }
    }
    if !unstable.is_empty() {
        let names: Vec<&str> = d.json.effects.iter().map(|e| e.name.as_str()).collect();
        unstable.push(format!("selected: {}", names.join(", ")));
    }
    Scored { unstable, tested }
}

/// A count of sets: false alarms, of.
#[derive(Clone, Copy, Debug, Default)]
pub struct Count {
    /// Sets with a term marked unstable.
    pub flagged: usize,
    /// Sets.
    pub n: usize,
    /// Sets where no term was tested.
    pub untested: usize,
}

impl Count {
    fn add(&mut self, s: &Scored) {
        self.n += 1;
        self.flagged += usize::from(!s.unstable.is_empty());
        self.untested += usize::from(!s.tested);
    }

    fn cell(self) -> String {
        #[allow(clippy::cast_precision_loss)]
        let pct = 100.0 * self.flagged as f64 / self.n.max(1) as f64;
        format!("{}/{} {pct:.1}%", self.flagged, self.n)
    }
}

/// The campaign's counts.
#[derive(Clone, Debug, Default)]
pub struct Stability {
    /// Sets run.
    pub sets: usize,
    /// `[kearfott, mems][stated, estimated][no K_2, K_2]`.
    pub counts: [[[Count; 2]; 2]; 2],
    /// Per design `[24 one axis, 24 two axes, 48 one axis, 48 two axes]`.
    pub designs: [Count; 4],
    /// The flagged sets: index, what was flagged.
    pub flagged: Vec<(usize, String)>,
}

impl Stability {
    /// Run `sets` sets seeded `seed` (in parallel).
    #[must_use]
    pub fn run(sets: usize, seed: u64) -> Self {
        use rayon::prelude::*;
        let pieces: Vec<SetScore> = (0..sets as u64)
            .into_par_iter()
            .map(|i| piece(seed, i))
            .collect();
        Stability::from_pieces(sets, pieces)
    }

    /// The campaign's counts from every set's score ([`piece`]), in the sets' order.
    #[must_use]
    pub fn from_pieces(sets: usize, pieces: Vec<SetScore>) -> Self {
        let mut c = Stability {
            sets,
            ..Stability::default()
        };
        for (i, p) in pieces.into_iter().enumerate() {
            let (a, b, k) = p.class;
            c.counts[a][b][k].add(&p.scored);
            c.designs[p.design].add(&p.scored);
            if !p.scored.unstable.is_empty() {
                c.flagged.push((i, p.flagged));
            }
        }
        c
    }

    /// Every set.
    #[must_use]
    pub fn pooled(&self) -> Count {
        let mut p = Count::default();
        for d in &self.designs {
            p.flagged += d.flagged;
            p.n += d.n;
            p.untested += d.untested;
        }
        p
    }

    /// The table: false alarms per class and design, and the flagged sets.
    #[must_use]
    pub fn table(&self) -> String {
        let mut s = format!(
            "stability false alarms: {} sets of constant truths, sets with a selected term marked unstable (flagged/sets)\n",
            self.sets
        );
        let _ = writeln!(
            s,
            "{:<22}{:>16}{:>16}{:>16}{:>16}",
            "", "stated", "stated, K_2", "estimated", "estimated, K_2"
        );
        for (a, name) in ["kearfott-2401", "mems"].iter().enumerate() {
            let _ = write!(s, "{name:<22}");
            for b in 0..2 {
                for k in 0..2 {
                    let _ = write!(s, "{:>16}", self.counts[a][b][k].cell());
                }
            }
            s.push('\n');
        }
        for (d, name) in [
            "24 points, one axis",
            "24 points, two axes",
            "48 points, one axis",
            "48 points, two axes",
        ]
        .iter()
        .enumerate()
        {
            let _ = writeln!(s, "  {name:<22}{:>16}", self.designs[d].cell());
        }
        let p = self.pooled();
        let _ = writeln!(
            s,
            "  pooled: {} ({} sets with no term tested)",
            p.cell(),
            p.untested
        );
        for (i, what) in &self.flagged {
            let _ = writeln!(s, "  set {i}: {what}");
        }
        s
    }

    /// What is not met: the pooled false alarms above the central 99 % of
    /// Binomial(n, 0.05).
    #[must_use]
    pub fn failures(&self) -> Vec<String> {
        let p = self.pooled();
        let (_, hi) = binomial_interval(p.n, ALPHA, 0.99);
        if p.flagged > hi {
            vec![format!(
                "NOT MET: {} of {} sets of constant truths have a term marked unstable, above the central 99 % of Binomial({}, {ALPHA}) (at most {hi})",
                p.flagged, p.n, p.n
            )]
        } else {
            Vec::new()
        }
    }
}
