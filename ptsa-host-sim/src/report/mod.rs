//! The whole report programme (`cargo ptsa` with no subcommand): every experiment of
//! [`crate::report::experiments`] and the discovery analysis of Tables 6.1–6.3, written into a
//! report folder that appears whole or not at all, with `summary.md` ([`summary`]).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Result;

use crate::discovery::Options;
use crate::discovery::sim::ClosedLoopSimulator;
use crate::lab::fixtures::TwoAxisKind;
use crate::model::instrument::Instrument;
use crate::output::{Output, StagedDir, write_atomic};
use crate::report::experiments::{
    anisoinertia, appendix_a, design, frequency_response, limit_cycle, monte_carlo, oa_coupling,
    tumble, waveform,
};
use crate::simulation::sim::SimOptions;

pub mod discovery;
pub mod experiments;
pub mod r890;
pub mod summary;

/// The steps of the programme, in order (for a progress display).
pub const STEPS: [&str; 12] = [
    "tumble",
    "anisoinertia",
    "oa-coupling",
    "vibropendulosity",
    "anisoelasticity",
    "sculling",
    "waveform",
    "frequency response",
    "limit cycle",
    "monte carlo",
    "discovery",
    "design",
];

/// How the programme was run (for the summary's first lines).
#[derive(Clone, Debug, PartialEq)]
pub struct RunInfo {
    /// The instrument file, as the user named it (or the shipped one).
    pub instrument: String,
    /// Run options.
    pub options: SimOptions,
    /// Worker threads.
    pub threads: usize,
}

/// Everything the programme computed.
#[derive(Clone, Debug)]
pub struct Programme {
    /// How it was run.
    pub info: RunInfo,
    /// The instrument.
    pub instrument: Instrument,
    /// Section 6.1.
    pub tumble: tumble::TumbleRun,
    /// Table 6.1.
    pub anisoinertia: anisoinertia::AnisoRun,
    /// Tables 6.2, 6.3.
    pub oa_coupling: oa_coupling::OaRun,
    /// Appendix A, one per set-up.
    pub appendix: Vec<(TwoAxisKind, appendix_a::AppendixRun)>,
    /// Fig. 3.2.
    pub waveform: Output,
    /// The closed loop's frequency response.
    pub response: frequency_response::ResponseRun,
    /// The limit cycle across the range.
    pub limit_cycle: limit_cycle::LimitCycleRun,
    /// The tolerance box.
    pub monte_carlo: monte_carlo::MonteCarloRun,
    /// The discovery section (Markdown), or why it is missing.
    pub discovery: std::result::Result<String, String>,
    /// The design text.
    pub design: String,
    /// Seconds per step.
    pub timings: Vec<(&'static str, f64)>,
    /// Wall time, s.
    pub wall_s: f64,
}

/// Run the programme into `target` (a folder that appears whole at the end, replacing an
/// older one, or not at all), printing each experiment's tables to `out` and calling
/// Seconds of the programme beyond its closed-loop ticks and its discovery's least squares
/// (the figures, the files, the margins of the tolerance box's corners), on the slow side
/// (`docs/host-sim.md`, "Work estimates").
pub const OVERHEAD_S: f64 = 1.0;

/// The work of [`run`] with `instr` and `opts`, counted before it runs: every experiment's
/// closed-loop ticks ([`tumble::work`], ...) and the part of the discovery section that
/// always runs ([`crate::discovery::cost`]).
///
/// # Errors
/// The report's transcriptions are malformed.
pub fn work(instr: &Instrument, opts: &SimOptions) -> Result<crate::simulation::work::Estimate> {
    let mut t = tumble::work(instr, opts, tumble::DEFAULT_GATE_S)
        + anisoinertia::work(instr, opts, [0.0; 3])?
        + oa_coupling::work(instr, opts, [0.0; 3])?
        + waveform::work(instr, opts, waveform::DEFAULT_CYCLES)
        + frequency_response::work(instr, opts)
        + limit_cycle::work(instr, opts)
        + monte_carlo::work(instr, opts, monte_carlo::DEFAULT_SAMPLES);
    for kind in [
        TwoAxisKind::Vibropendulous,
        TwoAxisKind::Anisoelastic,
        TwoAxisKind::Sculling,
    ] {
        t += appendix_a::work(instr, opts, &appendix_a::TwoAxisPlan::report(kind));
    }
    let sim = ClosedLoopSimulator {
        instrument: instr.clone(),
        options: *opts,
    };
    let mut other_s = OVERHEAD_S;
    for f in r890::case_files()? {
        let c = crate::discovery::cost::Cost::of(
            &f.rows,
            &sim,
            crate::model::effects::CandidateId::ALL,
        );
        t += c.ticks;
        other_s += c.seconds() - c.ticks.seconds();
    }
    Ok(crate::simulation::work::Estimate { ticks: t, other_s })
}

/// `step(k, name)` before step `k` of [`STEPS`].
///
/// # Errors
/// An experiment, a file or `out` fails; the target folder is then left as it was.
pub fn run(
    instr: &Instrument,
    opts: &SimOptions,
    info: RunInfo,
    target: &Path,
    step: &mut dyn FnMut(usize, &str),
    out: &mut dyn Write,
) -> Result<(Programme, PathBuf)> {
    let t0 = Instant::now();
    let staged = StagedDir::new(target)?;
    let dir = staged.path().to_path_buf();
    let mut timings = Vec::new();
    let mut last = Instant::now();
    let mut k = 0;
    let mut next = |timings: &mut Vec<(&'static str, f64)>| {
        if k > 0 {
            timings.push((STEPS[k - 1], last.elapsed().as_secs_f64()));
        }
        last = Instant::now();
        if k < STEPS.len() {
            step(k, STEPS[k]);
        }
        k += 1;
    };
    let emit = |o: &Output, out: &mut dyn Write| -> Result<()> {
        o.print(out)?;
        o.write_files(&dir)?;
        Ok(())
    };
    next(&mut timings);
    let tumble = tumble::run(instr, opts, tumble::DEFAULT_GATE_S)?;
    emit(&tumble.output, out)?;
    next(&mut timings);
    let aniso = anisoinertia::run(
        instr,
        opts,
        r890::section_6_2()?.anisoinertia_g_cm2,
        [0.0; 3],
    )?;
    emit(&aniso.output, out)?;
    next(&mut timings);
    let oa = oa_coupling::run(instr, opts, [0.0; 3])?;
    emit(&oa.output, out)?;
    let mut appendix = Vec::new();
    for kind in [
        TwoAxisKind::Vibropendulous,
        TwoAxisKind::Anisoelastic,
        TwoAxisKind::Sculling,
    ] {
        next(&mut timings);
        let r = appendix_a::run(instr, opts, &appendix_a::TwoAxisPlan::report(kind))?;
        emit(&r.output, out)?;
        appendix.push((kind, r));
    }
    next(&mut timings);
    let wave = waveform::run(
        instr,
        opts,
        waveform::DEFAULT_ACCEL_CM_S2,
        waveform::DEFAULT_CYCLES,
        &dir,
    )?;
    emit(&wave, out)?;
    next(&mut timings);
    let response = frequency_response::run(instr, opts)?;
    emit(&response.output, out)?;
    next(&mut timings);
    let limit = limit_cycle::run(instr, opts)?;
    emit(&limit.output, out)?;
    next(&mut timings);
    let mc = monte_carlo::run(instr, opts, monte_carlo::DEFAULT_SAMPLES)?;
    emit(&mc.output, out)?;
    next(&mut timings);
    let sim = ClosedLoopSimulator {
        instrument: instr.clone(),
        options: *opts,
    };
    let discovery = discovery::section(
        &sim,
        &Options::for_instrument(instr),
        Some(&dir.join("discover")),
    )
    .map_err(|e| format!("{e:#}"));
    next(&mut timings);
    let design = design::text(instr);
    write_atomic(&dir.join("design.txt"), design.as_bytes())?;
    next(&mut timings);
    let mut p = Programme {
        info,
        instrument: instr.clone(),
        tumble,
        anisoinertia: aniso,
        oa_coupling: oa,
        appendix,
        waveform: wave,
        response,
        limit_cycle: limit,
        monte_carlo: mc,
        discovery,
        design,
        timings,
        wall_s: 0.0,
    };
    p.wall_s = t0.elapsed().as_secs_f64();
    write_atomic(&dir.join("summary.md"), summary::render(&p)?.as_bytes())?;
    let path = staged.commit()?;
    Ok((p, path))
}
