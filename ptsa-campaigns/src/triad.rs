//! The triad campaign: three accelerometers on one block, calibrated blind by
//! `ptsa_host_sim::triad::fit` from readings generated here from the equations.
//!
//! A set is a design of static positions ([`TriadKind`]: 8, 12 or 24 positions on a
//! precision fixture, analysed with exact orientations; 24 or 37 positions placed by hand,
//! each turned from its nominal orientation by 0.5–1° about a random axis, analysed with
//! `--orientation approximate`) and a triad drawn at random:
//!
//! * bias `b_j` uniform in ±50 cm/s², scale-factor change `k_j` in ±2 %, all six
//!   misalignments `Γ_jk` in ±10 mrad, `K_2` in ±2000 µg/g² (a consumer MEMS triad's
//!   class);
//! * the reading of axis j in position i: `u_j = b_j + (1 + k_j)·a_j + q_j·a_j² + σ·N(0,1)`,
//!   `a = (I + Γ)·f_i`, `f_i = g·R_i·n_i` with `n_i` the nominal direction and `R_i` the
//!   hand placement's rotation (a rotation matrix built here from its axis and angle), `σ`
//!   uniform in 0.05–0.5 cm/s² per set; the sigma is written on every row in half of the
//!   sets, left for the fit to estimate in the other half.
//!
//! Nothing here calls the fit's code: the rotations, the triad frame's convention and the
//! truth in it are written in [`super::triad_gen`] (shared with the triad CLI tests and
//! benchmark; it uses nothing of `ptsa_host_sim`). With approximate orientations the fit
//! estimates the triad in its own frame (x along the x axis's input axis, y in the plane of
//! x and y): the truth is carried into that frame by Gram–Schmidt of the rows of `I + Γ` ([`in_triad_frame`]).
//!
//! Scored: every fitted coefficient against its truth, covered when
//! `|fitted − true| ≤ coverage_factor_95·σ`; the coverage per kind is asserted inside the
//! 99 % band of Binomial(n, 0.95) (the CI subset) and, in the full run, also within
//! 95 ± 2.5 %. A kind whose fit is refused fails. Every warning is a false alarm here (the
//! model is the generator's): the sets with one are asserted at most 5 % (one-sided
//! binomial test at 1 %).

use std::fmt::Write as _;
use std::time::Instant;

use ptsa_host_sim::triad::fit::{self, Orientation, Triad};
use ptsa_host_sim::triad::frame::Position;
use rayon::prelude::*;

use super::Draw as _;
use super::campaign::{Count, at_most_rate, binomial_interval, coverage_in_band, set_seed};

/// Local gravity of the sets, cm/s².
pub use super::triad_gen::G;

/// A design and how it is placed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TriadKind {
    /// The six faces and two opposite corners, precision fixture.
    Exact8,
    /// The twelve edge directions, precision fixture.
    Exact12,
    /// The 24 rotations of the cube applied to (1, 2, 3)/√14, precision fixture.
    Exact24,
    /// The same 24, placed by hand.
    Hand24,
    /// 24 + the 12 edges + one face, placed by hand.
    Hand37,
    /// The same 37 directions turned through by hand in one raw stream (a rest, turns and
    /// holds; [`super::triad_gen::stream_csv`]), cut and calibrated by
    /// `ptsa_host_sim::triad::stream`.
    Stream37,
}

impl TriadKind {
    /// Every kind, in table order.
    pub const ALL: [TriadKind; 6] = [
        TriadKind::Exact8,
        TriadKind::Exact12,
        TriadKind::Exact24,
        TriadKind::Hand24,
        TriadKind::Hand37,
        TriadKind::Stream37,
    ];

    /// Its name in the table.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            TriadKind::Exact8 => "8 fixture",
            TriadKind::Exact12 => "12 fixture",
            TriadKind::Exact24 => "24 fixture",
            TriadKind::Hand24 => "24 by hand",
            TriadKind::Hand37 => "37 by hand",
            TriadKind::Stream37 => "37 stream",
        }
    }

    /// The nominal directions.
    #[must_use]
    pub fn design(self) -> Vec<[f64; 3]> {
        match self {
            TriadKind::Exact8 => {
                let c = 1.0 / 3f64.sqrt();
                let mut v = faces();
                v.push([c, c, c]);
                v.push([-c, -c, -c]);
                v
            }
            TriadKind::Exact12 => edges(),
            TriadKind::Exact24 | TriadKind::Hand24 => cube_turns([1.0, 2.0, 3.0]),
            TriadKind::Hand37 | TriadKind::Stream37 => {
                let mut v = cube_turns([1.0, 2.0, 3.0]);
                v.extend(edges());
                v.push([0.0, 0.0, 1.0]);
                v
            }
        }
    }

    /// Placed by hand (analysed with approximate orientations).
    #[must_use]
    pub fn by_hand(self) -> bool {
        matches!(
            self,
            TriadKind::Hand24 | TriadKind::Hand37 | TriadKind::Stream37
        )
    }
}

pub use super::triad_gen::{
    TriadTruth, cube_turns, dot, edges, faces, in_triad_frame, mul, rotation,
};

/// A generated set: its positions (readings filled in), its truth in the frame the fit
/// reports, its noise and whether the sigma is stated.
#[derive(Clone, Debug)]
pub struct TriadSet {
    /// The rows.
    pub positions: Vec<Position>,
    /// The truth (in the triad's frame for a set placed by hand).
    pub truth: TriadTruth,
    /// The noise, cm/s².
    pub sigma: f64,
}

/// The set of `seed` of `kind`: by hand (each position turned 0.5–1° about a random axis)
/// when `by_hand`, whatever the kind's own placement.
#[must_use]
pub fn generate_triad(seed: u64, design: &[[f64; 3]], by_hand: bool) -> TriadSet {
    let mut rng = super::rng(seed);
    let t = draw_truth(&mut rng);
    let sigma = rng.range(0.05, 0.5);
    let stated = rng.uniform() < 0.5;
    let positions = design
        .iter()
        .enumerate()
        .map(|(i, &n)| {
            let f = if by_hand {
                super::triad_gen::hand_placed(n, &mut rng)
            } else {
                n
            }
            .map(|x| x * G);
            let u = t.readings(f);
            let mut measured = [None; 3];
            for (j, m) in measured.iter_mut().enumerate() {
                *m = Some(u[j] + sigma * rng.normal());
            }
            Position {
                label: format!("p{}", i + 1),
                line: i + 2,
                time_s: None,
                g_nominal: n,
                g_unit: n,
                measured,
                counts: [None; 3],
                counting_sigma_cm_s2: [None; 3],
                sigma_cm_s2: stated.then_some(sigma),
                sigma_angle_rad: None,
            }
        })
        .collect();
    TriadSet {
        positions,
        truth: if by_hand { in_triad_frame(&t) } else { t },
        sigma,
    }
}

/// A raw stream of seed `seed` through `design`'s directions, each placed by hand: its
/// text, the truth in the triad's frame and each hold's true span (s).
#[must_use]
pub fn generate_stream(seed: u64, design: &[[f64; 3]]) -> (String, TriadTruth, Vec<(f64, f64)>) {
    let mut rng = super::rng(seed);
    let t = draw_truth(&mut rng);
    let spec = super::triad_gen::StreamSpec {
        sigma_cm_s2: rng.range(0.3, 3.0),
        ..super::triad_gen::StreamSpec::default()
    };
    let dirs: Vec<[f64; 3]> = design
        .iter()
        .map(|&n| super::triad_gen::hand_placed(n, &mut rng))
        .collect();
    let (text, spans) = super::triad_gen::stream_csv(&t, &dirs, &spec, &mut rng);
    (text, in_triad_frame(&t), spans)
}

/// Cut the stream `text` and calibrate it; refused (with why) when the positions found are
/// not the holds `spans`, one each, inside it.
///
/// # Errors
/// The stream refused; a position missed, split or outside its hold.
pub fn fit_stream(text: &str, spans: &[(f64, f64)]) -> Result<Triad, String> {
    use ptsa_host_sim::triad::stream as ts;
    let instr = ptsa_host_sim::Instrument::shipped("mems")?;
    let s = ts::parse("stream", text, &instr).map_err(|e| format!("{e:#}"))?;
    let cut = ts::cut(&s, &ptsa_host_sim::stream::segment::Detector::default(), G)
        .map_err(|e| format!("{e:#}"))?;
    if cut.kept.len() != spans.len() {
        return Err(format!(
            "{} positions found, {} held",
            cut.kept.len(),
            spans.len()
        ));
    }
    let dt = cut.segmentation.dt_s;
    for (iv, sp) in cut.kept.iter().zip(spans) {
        if iv.t0_s < sp.0 - 0.5 * dt || iv.t1_s > sp.1 + 0.5 * dt {
            return Err(format!(
                "a position found at {}–{} s outside its hold {}–{} s",
                iv.t0_s, iv.t1_s, sp.0, sp.1
            ));
        }
    }
    let opts = fit::Options {
        orientation: Orientation::Approximate,
        default_sigma_cm_s2: None,
        g_cm_s2: G,
    };
    ts::calibrate(&s, &cut, &opts)
        .map(|(t, _)| t)
        .map_err(|e| format!("{e:#}"))
}

/// A triad's coefficients drawn from a consumer MEMS triad's class: bias in ±50 cm/s²,
/// scale change in ±2 %, `K_2` in ±2000 µg/g², every misalignment in ±10 mrad.
fn draw_truth(rng: &mut super::Rng) -> TriadTruth {
    let mut t = TriadTruth::default();
    for j in 0..3 {
        t.b[j] = rng.range(-50.0, 50.0);
        t.k[j] = rng.range(-0.02, 0.02);
        t.q[j] = rng.range(-2000.0, 2000.0) * 1e-6 / G;
        for k in 0..3 {
            if j != k {
                t.gamma[j][k] = rng.range(-0.01, 0.01);
            }
        }
    }
    t
}

/// The coverage of one set: per group (bias, scale factor, misalignment, `K_2`), the
/// coefficients whose 95 % interval holds the truth.
#[must_use]
pub fn covered(fit: &Triad, truth: &TriadTruth) -> [Count; 4] {
    let mut c = [Count::default(); 4];
    let k = fit.coverage_factor;
    let hit = |e: fit::Estimate, t: f64| (e.value - t).abs() <= k * e.sigma;
    for j in 0..3 {
        c[0].add(hit(fit.bias[j], truth.b[j]));
        c[1].add(hit(fit.scale[j], truth.k[j]));
        for kk in 0..3 {
            if let Some(e) = fit.misalignment[j][kk] {
                c[2].add(hit(e, truth.gamma[j][kk]));
            }
        }
        if let Some(q) = fit.k2 {
            c[3].add(hit(q[j], truth.q[j]));
        }
    }
    c
}

/// One kind's outcome.
#[derive(Clone, Debug, Default)]
pub struct KindRun {
    /// Coverage per group.
    pub groups: [Count; 4],
    /// Sets fitted without `K_2`.
    pub no_k2: usize,
    /// Sets whose result warns (every warning is a false alarm here: the model is right).
    pub warned: Count,
    /// Refusals: seed and message.
    pub refused: Vec<(u64, String)>,
    /// Largest fit time of a set, s.
    pub slowest_s: f64,
}

impl KindRun {
    /// All groups together.
    #[must_use]
    pub fn all(&self) -> Count {
        self.groups.iter().fold(Count::default(), |a, c| Count {
            k: a.k + c.k,
            n: a.n + c.n,
        })
    }
}

/// The whole campaign: `sets` of every kind.
#[derive(Clone, Debug)]
pub struct TriadRun {
    /// Sets per kind.
    pub sets: usize,
    /// Campaign seed.
    pub seed: u64,
    /// Per kind, in [`TriadKind::ALL`]'s order.
    pub kinds: Vec<(TriadKind, KindRun)>,
    /// Wall time, s.
    pub seconds: f64,
}

/// One set's fit, as the campaign's counts keep it.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct SetScore {
    /// The set's seed.
    pub seed: u64,
    /// What the fit gave, or its refusal.
    pub result: Result<FitScore, String>,
    /// The fit's wall time, s (the table's slowest fit; the one figure that differs between
    /// runs).
    pub seconds: f64,
}

/// What a fit gave, scored.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct FitScore {
    /// Fitted without `K_2`.
    pub no_k2: bool,
    /// Its warnings (every one a false alarm here: the model is right).
    pub warnings: Vec<String>,
    /// Coverage per group ([`covered`]).
    pub groups: [Count; 4],
}

/// Set `s` of the kind at `kind_index` of [`TriadKind::ALL`], campaign seed `seed`, made
/// and fitted.
#[must_use]
pub fn piece(seed: u64, kind_index: usize, s: usize) -> SetScore {
    let kind = TriadKind::ALL[kind_index];
    let design = kind.design();
    let seed = set_seed(seed, kind_index, s);
    let score = |f: &Triad, truth: &TriadTruth| FitScore {
        no_k2: f.k2.is_none(),
        warnings: f.warnings.clone(),
        groups: covered(f, truth),
    };
    if kind == TriadKind::Stream37 {
        let (text, truth, spans) = generate_stream(seed, &design);
        let t = Instant::now();
        let r = fit_stream(&text, &spans).map(|f| score(&f, &truth));
        return SetScore {
            seed,
            result: r,
            seconds: t.elapsed().as_secs_f64(),
        };
    }
    let set = generate_triad(seed, &design, kind.by_hand());
    let opts = fit::Options {
        orientation: if kind.by_hand() {
            Orientation::Approximate
        } else {
            Orientation::Exact
        },
        default_sigma_cm_s2: None,
        g_cm_s2: G,
    };
    let t = Instant::now();
    let r = fit::fit("set", &set.positions, &opts)
        .map(|f| score(&f, &set.truth))
        .map_err(|e| format!("{e:#}"));
    SetScore {
        seed,
        result: r,
        seconds: t.elapsed().as_secs_f64(),
    }
}

/// Set `i` of a run of `sets` per kind, kind by kind in [`TriadKind::ALL`]'s order
/// ([`piece`]).
#[must_use]
pub fn piece_at(seed: u64, sets: usize, i: usize) -> SetScore {
    piece(seed, i / sets, i % sets)
}

/// Make and fit `sets` sets of every kind.
#[must_use]
pub fn run(sets: usize, seed: u64) -> TriadRun {
    let t0 = Instant::now();
    let pieces: Vec<SetScore> = (0..TriadKind::ALL.len() * sets)
        .into_par_iter()
        .map(|i| piece_at(seed, sets, i))
        .collect();
    from_pieces(sets, seed, pieces, t0.elapsed().as_secs_f64())
}

/// The run from every set's score ([`piece`]), kind by kind in [`TriadKind::ALL`]'s
/// order, `sets` each; `seconds` its wall time.
///
/// # Panics
/// If `pieces` is not `sets` per kind.
#[must_use]
pub fn from_pieces(sets: usize, seed: u64, pieces: Vec<SetScore>, seconds: f64) -> TriadRun {
    assert_eq!(pieces.len(), TriadKind::ALL.len() * sets, "sets per kind");
    let mut pieces = pieces.into_iter();
    let kinds = TriadKind::ALL
        .iter()
        .map(|&kind| {
            let mut k = KindRun::default();
            for p in pieces.by_ref().take(sets) {
                k.slowest_s = k.slowest_s.max(p.seconds);
                match p.result {
                    Ok(f) => {
                        k.no_k2 += usize::from(f.no_k2);
                        k.warned.add(!f.warnings.is_empty());
                        if !f.warnings.is_empty() && super::campaign::env_flag("PTSA_HIDDEN_LOG") {
                            eprintln!("{} set {}: {}", kind.name(), p.seed, f.warnings.join(" | "));
                        }
                        for (g, c) in k.groups.iter_mut().zip(f.groups) {
                            g.k += c.k;
                            g.n += c.n;
                        }
                    }
                    Err(e) => k.refused.push((p.seed, e)),
                }
            }
            (kind, k)
        })
        .collect();
    TriadRun {
        sets,
        seed,
        kinds,
        seconds,
    }
}

/// Largest distance of the full run's coverage from 95 %.
pub const COVERAGE_TOLERANCE: f64 = 0.025;

impl TriadRun {
    /// The table.
    #[must_use]
    pub fn table(&self, ci: bool) -> String {
        let mut s = format!(
            "triad campaign: {} sets per kind, seed {}, {:.1} s\n",
            self.sets, self.seed, self.seconds
        );
        let _ = writeln!(
            s,
            "{:<12} {:>10} {:>10} {:>10} {:>10} | {:>11} {:>6} {:>8} | {:>5} {:>8}",
            "design",
            "bias",
            "scale",
            "misalign",
            "K_2",
            "all",
            "no K_2",
            "warned",
            "refused",
            "max ms"
        );
        for (kind, k) in &self.kinds {
            let _ = writeln!(
                s,
                "{:<12} {:>10} {:>10} {:>10} {:>10} | {:>11} {:>6} {:>8} | {:>7} {:>8.1}",
                kind.name(),
                k.groups[0].cell(),
                k.groups[1].cell(),
                k.groups[2].cell(),
                k.groups[3].cell(),
                k.all().coverage_marked(),
                k.no_k2,
                k.warned.marked(),
                k.refused.len(),
                k.slowest_s * 1e3
            );
        }
        let _ = writeln!(
            s,
            "cells: coefficients whose 95 % interval (± coverage_factor_95·σ) holds the truth; `!`: outside the 99 % band of Binomial(n, 0.95); warned: sets with a warning (false alarms: the model is right), `!` beyond 5 % by the one-sided binomial test at 1 %{}",
            if ci {
                ""
            } else {
                "; the full run also asserts 95 ± 2.5 % per design"
            }
        );
        for f in self.failures(ci) {
            let _ = writeln!(s, "NOT MET: {f}");
        }
        s
    }

    /// The asserted rates that are not met.
    #[must_use]
    pub fn failures(&self, ci: bool) -> Vec<String> {
        let mut f = Vec::new();
        for (kind, k) in &self.kinds {
            for (seed, e) in &k.refused {
                f.push(format!("{}: set {seed} refused: {e}", kind.name()));
            }
            let all = k.all();
            if let Some(e) =
                at_most_rate(&format!("{}: sets with a warning", kind.name()), k.warned)
            {
                f.push(e);
            }
            if let Some(e) = coverage_in_band(all, 1) {
                f.push(format!("{}: {e}", kind.name()));
            }
            if !ci && (all.rate() - 0.95).abs() > COVERAGE_TOLERANCE {
                let (lo, hi) = binomial_interval(all.n, 0.95, 0.99);
                f.push(format!(
                    "{}: coverage {} = {:.1} %, beyond 95 ± 2.5 % (the 99 % band is [{lo}, {hi}])",
                    kind.name(),
                    all.cell(),
                    100.0 * all.rate()
                ));
            }
        }
        f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn designs_have_their_sizes_and_unit_directions() {
        for (kind, n) in TriadKind::ALL.iter().zip([8, 12, 24, 24, 37, 37]) {
            let d = kind.design();
            assert_eq!(d.len(), n, "{kind:?}");
            assert!(d.iter().all(|v| (dot(*v, *v) - 1.0).abs() < 1e-12));
        }
        let mut c = cube_turns([1.0, 2.0, 3.0]);
        c.sort_by(|a, b| a.partial_cmp(b).unwrap());
        c.dedup();
        assert_eq!(c.len(), 24);
    }

    /// The truth carried into the triad's frame reads the same: the x axis's reading needs
    /// only the force's component along the x input axis, and the frame's Γ' is lower
    /// triangular.
    #[test]
    fn the_triad_frame_keeps_the_readings() {
        let t = TriadTruth {
            k: [0.01, -0.02, 0.005],
            q: [1e-6, -2e-6, 5e-7],
            gamma: [
                [0.0, 0.004, -0.007],
                [0.002, 0.0, 0.009],
                [-0.006, 0.003, 0.0],
            ],
            ..TriadTruth::default()
        };
        let c = in_triad_frame(&t);
        assert!(
            [c.gamma[0][1], c.gamma[0][2], c.gamma[1][2]]
                .iter()
                .all(|x| x.abs() < 1e-15),
            "{:?}",
            c.gamma
        );
        let r0 = [1.0, 0.004, -0.007];
        let n0 = dot(r0, r0).sqrt();
        let ex = r0.map(|x| x / n0);
        for f in [[G, 0.0, 0.0], [0.0, G, 0.0], [300.0, -400.0, 800.0]] {
            let a = f[0] + t.gamma[0][1] * f[1] + t.gamma[0][2] * f[2];
            let u = (1.0 + t.k[0]) * a + t.q[0] * a * a;
            let fx = dot(f, ex);
            let ux = (1.0 + c.k[0]) * fx + c.q[0] * fx * fx;
            assert!((u - ux).abs() < 1e-9, "{u} {ux}");
        }
    }
}
