//! Monte Carlo over Table 2.1's tolerance box: the margins of the linearised loop at every
//! corner (all toleranced parameters at a limit) when there are at most
//! [`MAX_EXHAUSTIVE`] of them, else at random corners; and a closed-loop run of the worst
//! eight corners at 0.9 of full scale.
//!
//! The compensator stays the one designed for the nominal instrument (`opts.config`) and the
//! torquer current stays at its regulated value while the parameters move, as in hardware;
//! so a corner's full scale, `g·I/current_scale_factor`, differs from the nominal SF, and the
//! closed-loop check reports that scale-factor change and what is left after it.

use anyhow::Result;
use rand::{Rng as _, SeedableRng as _};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::lab::fixtures;
use crate::model::design::margins;
use crate::model::effects::Effects;
use crate::model::instrument::{Instrument, Tolerance};
use crate::output::{Figure, Output, Plot, Series, Table, num, text};
use crate::report::{Experiment, Finding, Setup, Sink, ticks_only};
use crate::simulation::sim::SimOptions;
use crate::simulation::work::Estimate;

/// Up to this many toleranced parameters every corner is visited.
pub const MAX_EXHAUSTIVE: usize = 14;
/// Default number of random corners beyond [`MAX_EXHAUSTIVE`] parameters.
pub const DEFAULT_SAMPLES: usize = 1024;
/// Fraction of full scale of the closed-loop check.
pub const CHECK_FRACTION: f64 = 0.9;

/// One corner.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Corner {
    /// Bit k set = toleranced parameter k at its upper limit.
    pub bits: u64,
    /// Phase margin, deg.
    pub phase_margin_deg: f64,
    /// Gain margin, dB.
    pub gain_margin_db: f64,
    /// Crossover, Hz.
    pub crossover_hz: f64,
}

/// Closed-loop check of one corner at [`CHECK_FRACTION`] of its full scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CornerCheck {
    /// The corner's full scale over the nominal (configured) SF, minus 1, ppm.
    pub sf_change_ppm: f64,
    /// Indicated with the configured SF minus the input (and bias): the scale-factor change
    /// times the input, cm/s².
    pub error_cm_s2: f64,
    /// What is left once the corner's own SF is used: `indicated·SF_corner/SF − input`,
    /// cm/s².
    pub residual_cm_s2: f64,
    /// Largest `|θ|`, rad.
    pub theta_max_rad: f64,
    /// Every cycle had two reversals and the pendulum never reached a stop.
    pub ok: bool,
}

/// What [`run`] returns.
#[derive(Clone, Debug, PartialEq)]
pub struct MonteCarloRun {
    /// Every corner visited, sorted by phase margin (worst first).
    pub corners: Vec<Corner>,
    /// The closed-loop checks of the first eight corners.
    pub checks: Vec<CornerCheck>,
    /// Worst phase margin, deg.
    pub worst_phase_margin_deg: f64,
    /// Worst gain margin, dB.
    pub worst_gain_margin_db: f64,
    /// Tables, figure, notes.
    pub output: Output,
}

/// The instrument with the toleranced parameters at the corner `bits`.
fn corner(instr: &Instrument, bits: u64) -> Instrument {
    let mut i = instr.clone();
    for (k, t) in instr.tolerances.iter().enumerate() {
        let v = if bits >> k & 1 == 1 { t.hi } else { t.lo };
        // Every key comes from the file's own tolerance list, so `set` knows it.
        let _ = i.set(t.key, v);
    }
    i
}

/// Corners [`run`] visits: every one up to [`MAX_EXHAUSTIVE`] toleranced parameters, else
/// `samples`.
#[must_use]
pub fn corners(instr: &Instrument, samples: usize) -> usize {
    let n = instr.tolerances.len();
    if n <= MAX_EXHAUSTIVE { 1 << n } else { samples }
}

/// The closed-loop ticks [`run`] runs: the checks of the worst eight corners (each at its
/// own corner's settings, which leave the clock and the window as they are).
#[must_use]
pub fn work(
    instr: &Instrument,
    opts: &SimOptions,
    samples: usize,
) -> crate::simulation::work::Ticks {
    let c = fixtures::along_ia(CHECK_FRACTION * instr.actual_sf_cm_s2(), instr.g_cm_s2);
    #[allow(clippy::cast_precision_loss)]
    let n = corners(instr, samples).min(8) as f64;
    crate::simulation::work::condition(instr, &c, opts).times(n)
}

/// The Monte Carlo; `samples` random corners (seeded by `opts.seed`) when the box has more
/// than [`MAX_EXHAUSTIVE`] parameters.
///
/// # Errors
/// None today (kept for symmetry with the other experiments).
pub fn run(instr: &Instrument, opts: &SimOptions, samples: usize) -> Result<MonteCarloRun> {
    let tol = &instr.tolerances;
    let n = tol.len();
    let bits: Vec<u64> = if n <= MAX_EXHAUSTIVE {
        (0..(1u64 << n)).collect()
    } else {
        let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
        (0..samples).map(|_| rng.random::<u64>()).collect()
    };
    let mut corners: Vec<Corner> = bits
        .par_iter()
        .map(|&b| {
            let m = margins(&corner(instr, b), &opts.config);
            Corner {
                bits: b,
                phase_margin_deg: m.phase_margin_deg,
                gain_margin_db: m.gain_margin_db,
                crossover_hz: m.crossover_hz,
            }
        })
        .collect();
    corners.sort_by(|a, b| a.phase_margin_deg.total_cmp(&b.phase_margin_deg));
    let worst_pm = corners.first().map_or(f64::NAN, |r| r.phase_margin_deg);
    let worst_gm = corners
        .iter()
        .map(|r| r.gain_margin_db)
        .fold(f64::INFINITY, f64::min);
    let checks = check_worst(instr, &corners, opts);
    let t = worst_table(&corners, &checks);
    let keys = keys_table(tol);
    #[allow(clippy::cast_precision_loss)]
    let ranked: Vec<(f64, f64)> = corners
        .iter()
        .enumerate()
        .map(|(k, r)| (k as f64, r.phase_margin_deg))
        .collect();
    let nominal = margins(instr, &opts.config);
    let worst_residual = checks
        .iter()
        .map(|c| c.residual_cm_s2.abs())
        .fold(0.0, f64::max);
    let notes = vec![format!(
        "monte-carlo: {} corners; worst phase margin {worst_pm:.2} deg, worst gain margin {worst_gm:.2} dB (nominal {:.2} deg, {:.2} dB at {:.1} Hz); closed loop of the 8 worst corners at {CHECK_FRACTION} FS: {}; their indicated values differ from the input only by each corner's scale-factor change (largest residual after it {worst_residual:.4} cm/s^2)",
        corners.len(),
        nominal.phase_margin_deg,
        nominal.gain_margin_db,
        nominal.crossover_hz,
        if checks.iter().all(|c| c.ok) {
            "all stable, two reversals per cycle"
        } else {
            "SOME FAILED"
        }
    )];
    let plot = Plot {
        title: "Phase margin over the tolerance-box corners (sorted)".into(),
        x_label: "corner rank".into(),
        y_label: "phase margin, deg".into(),
        series: vec![Series::line("phase margin", ranked)],
        ..Plot::default()
    };
    Ok(MonteCarloRun {
        corners,
        checks,
        worst_phase_margin_deg: worst_pm,
        worst_gain_margin_db: worst_gm,
        output: Output {
            tables: vec![t, keys],
            plots: vec![Figure::single("monte-carlo-phase-margin", plot)],
            notes,
        },
    })
}

/// The closed-loop check of the worst corners (the first 8 of `corners`), as one batch
/// (per-lane instruments; every lane bit-identical to its own `simulate_condition`).
fn check_worst(instr: &Instrument, corners: &[Corner], opts: &SimOptions) -> Vec<CornerCheck> {
    let worst: Vec<(Instrument, f64, crate::Condition)> = corners
        .iter()
        .take(8)
        .map(|r| {
            let i = corner(instr, r.bits);
            let a = CHECK_FRACTION * i.actual_sf_cm_s2() - i.bias_cm_s2;
            let c = fixtures::along_ia(a, i.g_cm_s2);
            (i, a, c)
        })
        .collect();
    let jobs: Vec<crate::simulation::batch::Job<'_>> = worst
        .iter()
        .map(|(i, _, c)| crate::simulation::batch::Job {
            instr: i,
            cond: c,
            effects: Effects::NONE,
            seed: opts.seed,
        })
        .collect();
    let results = crate::simulation::batch::simulate_jobs(&jobs, opts);
    worst
        .iter()
        .zip(&results)
        .map(|((i, a, _), s)| {
            let (i, a) = (i, *a);
            let sf_corner = i.actual_sf_cm_s2();
            let truth = a + i.bias_cm_s2 + i.loop_bias_cm_s2(0.0);
            CornerCheck {
                sf_change_ppm: (sf_corner / i.sf_cm_s2 - 1.0) * 1e6,
                error_cm_s2: s.indicated_cm_s2 - truth,
                residual_cm_s2: s.indicated_cm_s2 * sf_corner / i.sf_cm_s2 - truth,
                theta_max_rad: s.theta_max_rad,
                ok: s.cycles == s.cycles_two_reversals && s.stop_ticks == 0,
            }
        })
        .collect()
}

/// The worst `corners` with their closed-loop `checks`.
fn worst_table(corners: &[Corner], checks: &[CornerCheck]) -> Table {
    let mut t = Table::new(
        "monte-carlo-worst-corners",
        &format!(
            "Monte Carlo over the Table 2.1 tolerance box: {} corners, worst 8 (closed loop at {CHECK_FRACTION} of each corner's full scale)",
            corners.len()
        ),
        &[
            "corner",
            "phase margin deg",
            "gain margin dB",
            "crossover Hz",
            "limit cycle",
            "SF change ppm",
            "indicated - input cm/s^2",
            "after the corner's SF cm/s^2",
            "max |theta| urad",
        ],
    );
    for (r, c) in corners.iter().zip(checks) {
        t.rows.push(vec![
            text(format!("{:#06x}", r.bits)),
            num(r.phase_margin_deg, 2),
            num(r.gain_margin_db, 2),
            num(r.crossover_hz, 1),
            text(if c.ok { "2 reversals/cycle" } else { "FAILED" }),
            num(c.sf_change_ppm, 0),
            num(c.error_cm_s2, 2),
            num(c.residual_cm_s2, 4),
            num(c.theta_max_rad * 1e6, 1),
        ]);
    }
    t
}

/// What each corner bit stands for.
fn keys_table(tol: &[Tolerance]) -> Table {
    let mut keys = Table::new(
        "monte-carlo-corner-bits",
        "Corner bits (bit k set = parameter k at its upper limit)",
        &["bit", "parameter", "low", "nominal", "high"],
    );
    for (k, tl) in tol.iter().enumerate() {
        keys.rows.push(vec![
            text(k.to_string()),
            text(tl.key),
            num(tl.lo, 4),
            num(tl.nominal, 4),
            num(tl.hi, 4),
        ]);
    }
    keys
}

/// The step of the report programme (see [`crate::report::Experiment`]).
#[derive(Clone, Copy, Debug)]
pub struct Step;

impl Experiment for Step {
    fn name(&self) -> &'static str {
        "monte carlo"
    }

    fn work(&self, s: Setup<'_>) -> Result<Estimate> {
        Ok(ticks_only(work(s.instr, s.opts, DEFAULT_SAMPLES)))
    }

    fn run(&self, s: Setup<'_>, to: &mut Sink<'_>) -> Result<Finding> {
        let r = run(s.instr, s.opts, DEFAULT_SAMPLES)?;
        to.emit(&r.output)?;
        Ok(Finding::MonteCarlo(r))
    }
}
