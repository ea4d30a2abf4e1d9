//! The whole report programme (`cargo ptsa` with no subcommand): every experiment of
//! [`crate::report::experiments`] and the discovery analysis of Tables 6.1–6.3, written into a
//! report folder that appears whole or not at all, with `summary.md` ([`summary`]).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};

use crate::lab::fixtures::TwoAxisKind;
use crate::model::instrument::Instrument;
use crate::output::{Output, StagedDir, write_atomic};
use crate::report::experiments::{
    anisoinertia, appendix_a, design, frequency_response, limit_cycle, monte_carlo, oa_coupling,
    tumble, waveform,
};
use crate::simulation::sim::SimOptions;
use crate::simulation::work::Estimate;

pub mod discovery;
pub mod experiments;
pub mod r890;
pub mod summary;

/// One step of the report programme (an experiment of [`experiments`], the discovery
/// section or the design): its name, its work counted before it runs, and its run. The
/// programme is the list of [`steps`]; its progress display, its work estimate ([`work`])
/// and its run ([`run`]) all come from that list.
pub trait Experiment: Sync {
    /// Its name (the progress line, the summary's timings, its files' stem).
    fn name(&self) -> &'static str;

    /// Its closed-loop ticks (and seconds of other work), counted before it runs.
    ///
    /// # Errors
    /// The report's transcriptions it reads are malformed.
    fn work(&self, s: Setup<'_>) -> Result<Estimate>;

    /// Run it: its tables and files into `to`.
    ///
    /// # Errors
    /// The experiment, a file or the output fails.
    fn run(&self, s: Setup<'_>, to: &mut Sink<'_>) -> Result<Finding>;
}

/// What every step runs with: the instrument and the run options.
#[derive(Clone, Copy, Debug)]
pub struct Setup<'a> {
    /// The instrument.
    pub instr: &'a Instrument,
    /// The run options.
    pub opts: &'a SimOptions,
}

/// Where a step's output goes: the report folder (being written) and the text output.
pub struct Sink<'a> {
    /// The folder of the step's files.
    pub dir: &'a Path,
    /// The tables, as text.
    pub out: &'a mut dyn Write,
}

impl Sink<'_> {
    /// An experiment's output: its tables on the text output, its files into the folder.
    ///
    /// # Errors
    /// The output or a file fails.
    pub fn emit(&mut self, o: &Output) -> Result<()> {
        o.print(self.out)?;
        o.write_files(self.dir)?;
        Ok(())
    }
}

/// What a step of the programme found (for [`Programme`] and the summary).
#[derive(Clone, Debug)]
pub enum Finding {
    /// Section 6.1.
    Tumble(tumble::TumbleRun),
    /// Table 6.1.
    Anisoinertia(anisoinertia::AnisoRun),
    /// Tables 6.2, 6.3.
    OaCoupling(oa_coupling::OaRun),
    /// Appendix A, one set-up.
    TwoAxis(TwoAxisKind, appendix_a::AppendixRun),
    /// Fig. 3.2.
    Waveform(Output),
    /// The closed loop's frequency response.
    Response(frequency_response::ResponseRun),
    /// The limit cycle across the range.
    LimitCycle(limit_cycle::LimitCycleRun),
    /// The tolerance box.
    MonteCarlo(monte_carlo::MonteCarloRun),
    /// The discovery section (Markdown), or why it is missing.
    Discovery(std::result::Result<String, String>),
    /// The design text.
    Design(String),
}

/// The steps of the programme, in order.
#[must_use]
pub fn steps() -> Vec<Box<dyn Experiment>> {
    vec![
        Box::new(tumble::Step),
        Box::new(anisoinertia::Step),
        Box::new(oa_coupling::Step),
        Box::new(appendix_a::Step(TwoAxisKind::Vibropendulous)),
        Box::new(appendix_a::Step(TwoAxisKind::Anisoelastic)),
        Box::new(appendix_a::Step(TwoAxisKind::Sculling)),
        Box::new(waveform::Step),
        Box::new(frequency_response::Step),
        Box::new(limit_cycle::Step),
        Box::new(monte_carlo::Step),
        Box::new(discovery::Step),
        Box::new(design::Step),
    ]
}

/// The estimate of a step that counts closed-loop ticks only.
#[must_use]
pub fn ticks_only(ticks: crate::simulation::work::Ticks) -> Estimate {
    Estimate {
        ticks,
        other_s: 0.0,
    }
}

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

impl Programme {
    /// The programme of the findings of its steps (each kind once, the set-ups of Appendix
    /// A in order), with the seconds of each step and the wall time still to set.
    ///
    /// # Errors
    /// A step the summary needs is missing.
    pub fn of(
        info: RunInfo,
        instr: &Instrument,
        found: Vec<Finding>,
        timings: Vec<(&'static str, f64)>,
    ) -> Result<Self> {
        let (mut tumble, mut aniso, mut oa, mut wave, mut response) =
            (None, None, None, None, None);
        let (mut limit, mut mc, mut discovery, mut design) = (None, None, None, None);
        let mut appendix = Vec::new();
        for f in found {
            match f {
                Finding::Tumble(r) => tumble = Some(r),
                Finding::Anisoinertia(r) => aniso = Some(r),
                Finding::OaCoupling(r) => oa = Some(r),
                Finding::TwoAxis(kind, r) => appendix.push((kind, r)),
                Finding::Waveform(o) => wave = Some(o),
                Finding::Response(r) => response = Some(r),
                Finding::LimitCycle(r) => limit = Some(r),
                Finding::MonteCarlo(r) => mc = Some(r),
                Finding::Discovery(r) => discovery = Some(r),
                Finding::Design(t) => design = Some(t),
            }
        }
        let missing = |what: &str| format!("the programme has no {what} step");
        Ok(Self {
            info,
            instrument: instr.clone(),
            tumble: tumble.with_context(|| missing("tumble"))?,
            anisoinertia: aniso.with_context(|| missing("anisoinertia"))?,
            oa_coupling: oa.with_context(|| missing("OA coupling"))?,
            appendix,
            waveform: wave.with_context(|| missing("waveform"))?,
            response: response.with_context(|| missing("frequency response"))?,
            limit_cycle: limit.with_context(|| missing("limit cycle"))?,
            monte_carlo: mc.with_context(|| missing("Monte Carlo"))?,
            discovery: discovery.with_context(|| missing("discovery"))?,
            design: design.with_context(|| missing("design"))?,
            timings,
            wall_s: 0.0,
        })
    }
}

/// Seconds of the programme beyond its closed-loop ticks and its discovery's least squares
/// (the figures, the files, the margins of the tolerance box's corners), on the slow side
/// (`docs/method/host-sim.md`, "Work estimates").
pub const OVERHEAD_S: f64 = 1.0;

/// The work of [`run`] with `instr` and `opts`, counted before it runs: every step's
/// ([`Experiment::work`]) and [`OVERHEAD_S`].
///
/// # Errors
/// The report's transcriptions are malformed.
pub fn work(instr: &Instrument, opts: &SimOptions) -> Result<Estimate> {
    let mut e = Estimate {
        other_s: OVERHEAD_S,
        ..Estimate::default()
    };
    for step in steps() {
        let w = step.work(Setup { instr, opts })?;
        e.ticks += w.ticks;
        e.other_s += w.other_s;
    }
    Ok(e)
}

/// Run the programme ([`steps`]) into `target` (a folder that appears whole at the end,
/// replacing an older one, or not at all), printing each experiment's tables to `out` and
/// calling `step(k, name)` before step `k`.
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
    let mut found = Vec::new();
    for (k, e) in steps().iter().enumerate() {
        step(k, e.name());
        let t = Instant::now();
        let mut to = Sink {
            dir: &dir,
            out: &mut *out,
        };
        found.push(e.run(Setup { instr, opts }, &mut to)?);
        timings.push((e.name(), t.elapsed().as_secs_f64()));
    }
    let mut p = Programme::of(info, instr, found, timings)?;
    p.wall_s = t0.elapsed().as_secs_f64();
    write_atomic(&dir.join("summary.md"), summary::render(&p)?.as_bytes())?;
    let path = staged.commit()?;
    Ok((p, path))
}
