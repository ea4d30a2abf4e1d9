//! The batch engine: many independent closed loops, per core in groups of lanes, all cores
//! through rayon.
//!
//! Discovery, Monte Carlo and parameter identification run many independent closed loops.
//! The engine takes them all at once: [`Engine::run_static`], [`Engine::simulate_conditions`],
//! [`Engine::simulate_differences`], [`Engine::simulate_jobs`] (a different instrument and
//! seed per lane) and, on [`ClosedLoop`]s in any state, [`Engine::run`], [`Engine::run_fast`]
//! and [`Engine::measure`].
//!
//! # Bit for bit the single loop
//! A lane is a [`ClosedLoop`]'s two halves, its configuration (`config::LoopConfig`, read
//! only) and its state (`state::LoopState`, plain data), by reference: no copies. A lane's
//! tick is the single loop's tick: the same functions (`sim::static_block_fast`,
//! `kernel::static_tick`, `kernel::dynamic_tick`, the ADC, the noise source, the plant step,
//! the core's [`ptsa_core::Ptsa::tick`]), called with the same values in the same order. A
//! lane runs a program of steps that are the single loop's calls (`run`, `run_fast`,
//! `measure`'s window, `run_static`'s gate), each started and ended as the single loop does
//! (`LoopState::run_start`, `LoopState::end_run`), so the running totals are summed the same
//! way. This engine is a scheduler: it groups the lanes, shares what lanes in step have in
//! common (noise draws, a condition's phasor and inputs) and packs them for the kernels.
//! The pulses, the plant state (`f64` bits), the core state and the window results of every
//! lane are those of a [`ClosedLoop`] with the same instrument, condition, effects, options
//! and seed; the tests check it lane by lane, for every `lanes` setting.
//!
//! # Groups, lanes, threads
//! The lanes of a call are sorted by kind (static or dynamic) and length and cut into groups
//! (up to 16 lanes, fewer when there are fewer lanes than that per thread, so that every
//! thread gets a group); rayon runs the groups. The lanes of a group run in step until the
//! shortest current step ends; then the lanes start their next steps and those that are done
//! leave. Lanes in step that draw the same noise (the same seed and ADC, as in
//! [`Engine::run_static`] and [`Engine::simulate_conditions`]) draw it once, and each seed's
//! noise table is built once per call; dynamic lanes in step with the same condition (one
//! condition, many instruments or effects: identification, Monte Carlo) compute its phasor
//! and inputs once. Each lane may have its own instrument: the plant matrices, the ADC and
//! the stops are per lane anyway, so this costs nothing.
//!
//! How a group's lanes share a core is [`Engine::new`]'s `lanes`:
//!
//! * static lanes: `lanes = K ≥ 2` ([`LANES`] = 8 by default) run `K` loops side by side
//!   (in kernels of at most 8: 16 lanes are two kernels of 8, one after the other, each for
//!   the same ticks) through the one definition of the static tick, `kernel::static_tick`
//!   (the single loop runs it with one lane), compiled for the CPU's SIMD instructions at run
//!   time (`pulp`: AVX-512 where present, else AVX2); a kernel of 8 on a CPU with AVX-512
//!   runs the core's tick in its registers (`avx512`), others on arrays
//!   ([`ptsa_core::Each`]); `lanes = 1` runs one lane after the
//!   other, in blocks of 512 ticks, with the single loop's polarity-split fast path
//!   (`sim::static_block_fast`).
//! * dynamic lanes: `K` loops side by side through the one definition of the dynamic tick,
//!   `kernel::dynamic_tick` (the single loop runs it with one lane), packed once per run,
//!   in blocks of 128 ticks whose noise draws and, for lanes with the same condition, phasor
//!   and inputs are made once per block for the whole group; kernels of 8 with AVX-512 as
//!   the static ones.
//!
//! Its speed: `ptsa bench --batch N` (with `--dynamic`, `--shared-condition`) prints the
//! single and the batch rate, and `cargo bench -p ptsa-host-sim --bench batch` measures every
//! setting; the figures are in docs/method/host-sim.md, "Performance", and the dated ones
//! in docs/notes/performance.md.

use std::collections::HashMap;

use ptsa_core::{Each, LaneOps};
use rayon::prelude::*;

use crate::lab::fixtures;
use crate::model::condition::Condition;
use crate::model::effects::Effects;
use crate::model::instrument::Instrument;

use super::config::{Adc, LoopConfig, TickInputs};
use super::kernel::{self, DynLanes, DynState, StaticLanes, StaticState};
use super::noise::NoiseSource;
use super::sim::{
    self, BIAS_BLOCK, ClosedLoop, GateStart, SimDifference, SimOptions, SimResult, StaticRun,
    WindowStart, static_block_fast,
};
use super::simd::{self, SimdLevel};
use super::state::{LoopState, RunStart};
#[cfg(target_arch = "x86_64")]
use super::{avx2::Avx2, avx512::Avx512, simd::Registers};

/// Loops side by side per core by default (see the module docs; `benches/batch.rs`
/// measures 1, 2, 4, 8 and 16; with AVX-512, static lanes ran 1.60× the single loop with 4
/// and 1.82–1.86× with 8).
pub const LANES: usize = 8;

/// The most lanes interleaved per core an [`Engine`] takes.
pub const MAX_LANES: usize = 16;

/// The most lanes of a group (lanes in step on one thread, sharing their noise draws when
/// they can), when there are enough lanes for every thread.
const GROUP: usize = 16;

/// One closed-loop run of a batch with its own instrument and noise seed: the same as
/// [`sim::simulate_condition`]`(instr, cond, effects, &SimOptions { seed, ..opts })`.
#[derive(Clone, Copy, Debug)]
pub struct Job<'a> {
    /// The instrument (lanes may differ: parameter identification).
    pub instr: &'a Instrument,
    /// The condition.
    pub cond: &'a Condition,
    /// The effects, entering the plant as in [`sim::simulate_condition`].
    pub effects: Effects,
    /// Seed of the pickoff noise.
    pub seed: u64,
}

/// One counter record of a batch ([`Engine::simulate_records`]): the loop of `instr` at
/// rest but for an acceleration along IA, with its own pickoff-noise seed.
#[derive(Clone, Copy, Debug)]
pub struct RecordJob<'a> {
    /// The instrument.
    pub instr: &'a Instrument,
    /// Seed of the pickoff noise.
    pub seed: u64,
    /// The acceleration along IA during the settling, and during every gate when
    /// `gate_accels_cm_s2` is empty, cm/s².
    pub accel_cm_s2: f64,
    /// The acceleration along IA held over each gate, cm/s², one per gate (the condition
    /// set before the gate as [`ClosedLoop::set_condition`] sets it); empty: `accel_cm_s2`
    /// throughout.
    pub gate_accels_cm_s2: &'a [f64],
}

/// The batch engine with `lanes` lanes interleaved per core (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Engine {
    lanes: usize,
}

impl Default for Engine {
    fn default() -> Self {
        Self { lanes: LANES }
    }
}

impl Engine {
    /// An engine running `lanes` loops interleaved tick by tick per core (1: one after the
    /// other, block by block): a power of two from 1 to [`MAX_LANES`].
    ///
    /// # Panics
    /// If `lanes` is not a power of two in `1..=MAX_LANES`.
    #[must_use]
    pub fn new(lanes: usize) -> Self {
        assert!(
            lanes.is_power_of_two() && lanes <= MAX_LANES,
            "lanes = {lanes}: expected a power of two from 1 to {MAX_LANES}"
        );
        Self { lanes }
    }

    /// Lanes interleaved per core.
    #[must_use]
    pub fn lanes(&self) -> usize {
        self.lanes
    }

    /// [`sim::run_static`] for each acceleration along IA, cm/s² (`ticks` clock ticks in the
    /// gate after `opts.warmup_s` of settling, seed `opts.seed` for every lane).
    #[must_use]
    pub fn run_static(
        &self,
        instr: &Instrument,
        accels_cm_s2: &[f64],
        ticks: u64,
        opts: &SimOptions,
    ) -> Vec<StaticRun> {
        let noise = NoiseSource::new(opts.seed);
        let mut loops: Vec<ClosedLoop> = accels_cm_s2
            .par_iter()
            .map(|&a| {
                let cond = fixtures::along_ia(a, instr.g_cm_s2);
                ClosedLoop::with_noise(instr, &cond, &Effects::NONE, opts, noise.clone())
            })
            .collect();
        // `sim::run_static_with`'s calls of `run_fast`, as one run each for the settling and
        // the gate (a run does not depend on how it is cut into calls: the single loop cuts
        // them for its progress line only).
        let prog = vec![
            Step::RunFast(opts.warmup_ticks(instr.clock_hz)),
            Step::OpenGate,
            Step::RunFast(ticks),
            Step::CloseGate(ticks),
        ];
        let outs = self.execute(&mut loops, |_| prog.clone());
        outs.into_iter()
            .map(|o| match o {
                Some(Out::Gate(r)) => r,
                _ => unreachable!("a static run closes its gate"),
            })
            .collect()
    }

    /// [`sim::simulate_condition`] for each `(condition, effects)`, all with `instr` and
    /// `opts` (seed `opts.seed` for every lane).
    #[must_use]
    pub fn simulate_conditions(
        &self,
        instr: &Instrument,
        jobs: &[(Condition, Effects)],
        opts: &SimOptions,
    ) -> Vec<SimResult> {
        let jobs: Vec<Job<'_>> = jobs
            .iter()
            .map(|(cond, effects)| Job {
                instr,
                cond,
                effects: *effects,
                seed: opts.seed,
            })
            .collect();
        self.simulate_jobs(&jobs, opts)
    }

    /// [`sim::simulate_difference`] for each `(condition, effects)`: the condition and its
    /// reference ([`Condition::reference`]) as two lanes.
    #[must_use]
    pub fn simulate_differences(
        &self,
        instr: &Instrument,
        jobs: &[(Condition, Effects)],
        opts: &SimOptions,
    ) -> Vec<SimDifference> {
        let refs: Vec<Condition> = jobs.iter().map(|(c, _)| c.reference()).collect();
        let lanes: Vec<Job<'_>> = jobs
            .iter()
            .zip(&refs)
            .flat_map(|((cond, effects), reference)| {
                [cond, reference].map(|cond| Job {
                    instr,
                    cond,
                    effects: *effects,
                    seed: opts.seed,
                })
            })
            .collect();
        let r = self.simulate_jobs(&lanes, opts);
        r.chunks_exact(2)
            .map(|p| SimDifference {
                condition: p[0],
                reference: p[1],
                difference_cm_s2: p[0].indicated_cm_s2 - p[1].indicated_cm_s2,
            })
            .collect()
    }

    /// [`sim::simulate_condition`] for each job, with its own instrument and seed and the
    /// rest of `opts` (warm-up, window, noise, harmonic, configuration). Each seed's noise
    /// table is built once and shared by its lanes.
    #[must_use]
    pub fn simulate_jobs(&self, jobs: &[Job<'_>], opts: &SimOptions) -> Vec<SimResult> {
        let mut loops = loops_of(jobs, opts);
        let outs = self.execute(&mut loops, |i| {
            let j = &jobs[i];
            let o = SimOptions {
                seed: j.seed,
                ..*opts
            };
            vec![
                Step::Run(o.warmup_ticks(j.instr.clock_hz)),
                Step::OpenWindow,
                Step::Run(sim::window_ticks(j.instr, j.cond, &o)),
                Step::CloseWindow,
            ]
        });
        outs.into_iter()
            .map(|o| match o {
                Some(Out::Window(r)) => r,
                _ => unreachable!("a simulated condition closes its window"),
            })
            .collect()
    }

    /// Counter records, one per job: the loop of the job's instrument and seed (the rest of
    /// `opts`: warm-up, noise, configuration) in `along_ia(accel_cm_s2)`, settled for
    /// `opts.warmup_s` with `run_fast`, then `gates` gates of `gate_ticks` back to back,
    /// each a `run_fast(gate_ticks)` after the job's acceleration for that gate is set (when
    /// it has them); the pulses counted in each gate. Bit for bit the single loop making
    /// the same calls (`noise::simulate_record` is that loop; the tests compare them).
    ///
    /// # Panics
    /// If a job's `gate_accels_cm_s2` is neither empty nor one per gate.
    #[must_use]
    pub fn simulate_records(
        &self,
        jobs: &[RecordJob<'_>],
        opts: &SimOptions,
        gate_ticks: u64,
        gates: u64,
    ) -> Vec<Vec<u32>> {
        for j in jobs {
            assert!(
                j.gate_accels_cm_s2.is_empty() || j.gate_accels_cm_s2.len() as u64 == gates,
                "one acceleration per gate, or none"
            );
        }
        let conds: Vec<Condition> = jobs
            .iter()
            .map(|j| fixtures::along_ia(j.accel_cm_s2, j.instr.g_cm_s2))
            .collect();
        let as_jobs: Vec<Job<'_>> = jobs
            .iter()
            .zip(&conds)
            .map(|(j, cond)| Job {
                instr: j.instr,
                cond,
                effects: Effects::NONE,
                seed: j.seed,
            })
            .collect();
        let mut loops = loops_of(&as_jobs, opts);
        let inputs: Vec<&[f64]> = jobs.iter().map(|j| j.gate_accels_cm_s2).collect();
        let outs = self.execute_with(&mut loops, &inputs, |i| {
            vec![
                Step::RunFast(opts.warmup_ticks(jobs[i].instr.clock_hz)),
                Step::Record(gate_ticks, gates),
            ]
        });
        outs.into_iter()
            .map(|o| match o {
                Some(Out::Counts(c)) => c,
                _ => unreachable!("a record closes its last gate"),
            })
            .collect()
    }

    /// [`ClosedLoop::run`]`(n)` for each loop.
    pub fn run(&self, loops: &mut [ClosedLoop], n: u64) {
        let _ = self.execute(loops, |_| vec![Step::Run(n)]);
    }

    /// [`ClosedLoop::run_fast`]`(n)` for each loop.
    pub fn run_fast(&self, loops: &mut [ClosedLoop], n: u64) {
        let _ = self.execute(loops, |_| vec![Step::RunFast(n)]);
    }

    /// [`ClosedLoop::measure`]`(n)` for each loop.
    #[must_use]
    pub fn measure(&self, loops: &mut [ClosedLoop], n: u64) -> Vec<SimResult> {
        self.measure_each(loops, &vec![n; loops.len()])
    }

    /// [`ClosedLoop::measure`]`(n[i])` for each loop `i` (windows of different lengths).
    ///
    /// # Panics
    /// If `n` and `loops` differ in length.
    #[must_use]
    pub fn measure_each(&self, loops: &mut [ClosedLoop], n: &[u64]) -> Vec<SimResult> {
        assert_eq!(n.len(), loops.len(), "one window length per loop");
        let outs = self.execute(loops, |i| {
            vec![Step::OpenWindow, Step::Run(n[i]), Step::CloseWindow]
        });
        outs.into_iter()
            .map(|o| match o {
                Some(Out::Window(r)) => r,
                _ => unreachable!("a measurement closes its window"),
            })
            .collect()
    }

    /// Run program `prog(i)` on loop `i`, every loop: sort the lanes into groups, the groups
    /// across rayon's threads. Returns each lane's output.
    fn execute(
        self,
        loops: &mut [ClosedLoop],
        prog: impl Fn(usize) -> Vec<Step>,
    ) -> Vec<Option<Out>> {
        self.execute_with(loops, &[], prog)
    }

    /// [`Engine::execute`] with each lane's accelerations per gate of a
    /// [`Step::Record`] (`inputs[i]` for lane `i`; none when `inputs` is shorter).
    fn execute_with(
        self,
        loops: &mut [ClosedLoop],
        inputs: &[&[f64]],
        prog: impl Fn(usize) -> Vec<Step>,
    ) -> Vec<Option<Out>> {
        let mut lanes: Vec<Lane<'_>> = loops
            .iter_mut()
            .enumerate()
            .map(|(i, lp)| Lane::new(lp, prog(i), inputs.get(i).copied().unwrap_or(&[])))
            .collect();
        let threads = rayon::current_num_threads().max(1);
        let per = lanes
            .len()
            .div_ceil(threads)
            .clamp(1, self.lanes.max(GROUP));
        let mut order: Vec<&mut Lane<'_>> = lanes.iter_mut().collect();
        // Lanes of one condition next to each other, so that dynamic ones share a group and
        // with it the phasor and inputs (identification's sides of a row, Monte Carlo).
        order.sort_by_cached_key(|l| (l.cfg.dynamic, l.total_ticks(), l.cfg.prep.key_bits()));
        let k = self.lanes;
        order.par_chunks_mut(per).for_each(|g| run_group(g, k));
        lanes.into_iter().map(|l| l.out).collect()
    }
}

/// [`Engine::run_static`] with the default engine.
#[must_use]
pub fn run_static(
    instr: &Instrument,
    accels_cm_s2: &[f64],
    ticks: u64,
    opts: &SimOptions,
) -> Vec<StaticRun> {
    Engine::default().run_static(instr, accels_cm_s2, ticks, opts)
}

/// [`Engine::simulate_conditions`] with the default engine.
#[must_use]
pub fn simulate_conditions(
    instr: &Instrument,
    jobs: &[(Condition, Effects)],
    opts: &SimOptions,
) -> Vec<SimResult> {
    Engine::default().simulate_conditions(instr, jobs, opts)
}

/// [`Engine::simulate_differences`] with the default engine.
#[must_use]
pub fn simulate_differences(
    instr: &Instrument,
    jobs: &[(Condition, Effects)],
    opts: &SimOptions,
) -> Vec<SimDifference> {
    Engine::default().simulate_differences(instr, jobs, opts)
}

/// [`Engine::simulate_jobs`] with the default engine.
#[must_use]
pub fn simulate_jobs(jobs: &[Job<'_>], opts: &SimOptions) -> Vec<SimResult> {
    Engine::default().simulate_jobs(jobs, opts)
}

/// The loop of each job (its instrument, condition, effects and seed, the rest of `opts`),
/// each seed's noise table built once and shared.
fn loops_of(jobs: &[Job<'_>], opts: &SimOptions) -> Vec<ClosedLoop> {
    let noise = noise_sources(jobs.iter().map(|j| j.seed));
    jobs.par_iter()
        .map(|j| {
            let o = SimOptions {
                seed: j.seed,
                ..*opts
            };
            ClosedLoop::with_noise(j.instr, j.cond, &j.effects, &o, noise[&j.seed].clone())
        })
        .collect()
}

/// The noise source of each distinct seed, built once (in parallel).
fn noise_sources(seeds: impl Iterator<Item = u64>) -> HashMap<u64, NoiseSource> {
    let mut distinct: Vec<u64> = seeds.collect();
    distinct.sort_unstable();
    distinct.dedup();
    distinct
        .into_par_iter()
        .map(|s| (s, NoiseSource::new(s)))
        .collect()
}

/// One step of a lane's program: one call of the single loop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Step {
    /// [`ClosedLoop::run`].
    Run(u64),
    /// [`ClosedLoop::run_fast`].
    RunFast(u64),
    /// The start of [`ClosedLoop::measure`]'s window.
    OpenWindow,
    /// The end of the window: its [`SimResult`] is the lane's output.
    CloseWindow,
    /// The start of [`sim::run_static`]'s gate.
    OpenGate,
    /// The end of a gate of so many ticks: its [`StaticRun`] is the lane's output.
    CloseGate(u64),
    /// A counter record: so many gates (the second) of so many ticks (the first) back to
    /// back, each a [`ClosedLoop::run_fast`] after the lane's acceleration for that gate
    /// is set (when it has them); the pulses of each gate are the lane's output.
    Record(u64, u64),
}

impl Step {
    fn ticks(self) -> u64 {
        match self {
            Step::Run(n) | Step::RunFast(n) => n,
            Step::Record(ticks, gates) => ticks.saturating_mul(gates),
            _ => 0,
        }
    }
}

/// What a lane's program produced.
#[derive(Clone, Debug)]
enum Out {
    Window(SimResult),
    Gate(StaticRun),
    /// The pulses of each gate of a [`Step::Record`].
    Counts(Vec<u32>),
}

/// A [`Step::Record`] in progress.
struct Recording {
    ticks: u64,
    /// Gates still to run, the one running included.
    left: u64,
    /// The core's pulse total at the running gate's start.
    p0: std::num::Wrapping<u32>,
    counts: Vec<u32>,
}

/// How a lane's current run ticks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Mode {
    /// A static condition with per-tick statistics ([`ClosedLoop::run`]).
    Static,
    /// A static condition without them ([`ClosedLoop::run_fast`]).
    StaticFast,
    /// A dynamic condition (or a harmonic requested).
    Dynamic,
}

/// One lane: a loop's configuration and state, its program and its run in progress.
struct Lane<'a> {
    cfg: &'a mut LoopConfig,
    st: &'a mut LoopState,
    /// The acceleration along IA of each gate of a [`Step::Record`], cm/s² (empty: the
    /// condition is kept).
    inputs: &'a [f64],
    record: Option<Recording>,
    prog: Vec<Step>,
    /// Index of the next step.
    next: usize,
    mode: Mode,
    /// Ticks of the current run and ticks left in it.
    n: u64,
    left: u64,
    /// Where the run in progress started (`None`: no run in progress, the lane is done).
    run: Option<RunStart>,
    window: Option<WindowStart>,
    gate: Option<GateStart>,
    out: Option<Out>,
}

impl<'a> Lane<'a> {
    fn new(lp: &'a mut ClosedLoop, prog: Vec<Step>, inputs: &'a [f64]) -> Self {
        Self {
            cfg: &mut lp.cfg,
            st: &mut lp.st,
            inputs,
            record: None,
            prog,
            next: 0,
            mode: Mode::Static,
            n: 0,
            left: 0,
            run: None,
            window: None,
            gate: None,
            out: None,
        }
    }

    fn total_ticks(&self) -> u64 {
        self.prog.iter().map(|s| s.ticks()).sum()
    }

    fn done(&self) -> bool {
        self.run.is_none()
    }

    /// Take the program's steps until one has ticks to run (started), or the program ends
    /// (the lane is then done).
    fn advance(&mut self) {
        if self.record.is_some() && self.next_gate() {
            return;
        }
        while let Some(&step) = self.prog.get(self.next) {
            self.next += 1;
            match step {
                Step::OpenWindow => self.window = Some(WindowStart::open(self.st)),
                Step::CloseWindow => {
                    let w = self.window.take().expect("window opened");
                    self.out = Some(Out::Window(w.close(self.cfg, self.st)));
                }
                Step::OpenGate => self.gate = Some(GateStart::open(self.st)),
                Step::CloseGate(ticks) => {
                    let g = self.gate.take().expect("gate opened");
                    self.out = Some(Out::Gate(g.close(self.cfg, self.st, ticks)));
                }
                Step::Record(ticks, gates) => {
                    self.record = Some(Recording {
                        ticks,
                        left: gates,
                        p0: self.st.core.total_pulses(),
                        counts: Vec::with_capacity(usize::try_from(gates).unwrap_or(0)),
                    });
                    if self.start_gate() {
                        return;
                    }
                }
                Step::Run(n) | Step::RunFast(n) => {
                    if self.start(n, matches!(step, Step::Run(_))) {
                        return;
                    }
                }
            }
        }
        self.run = None;
    }

    /// Start a run of `n` ticks (`stats`: [`ClosedLoop::run`], else `run_fast`); false when
    /// `n` is 0 (the run started and finished, as the single loop's does).
    fn start(&mut self, n: u64, stats: bool) -> bool {
        self.n = n;
        self.left = n;
        self.mode = if self.cfg.dynamic {
            self.st.sync_phasor(self.cfg);
            Mode::Dynamic
        } else if stats {
            Mode::Static
        } else {
            Mode::StaticFast
        };
        self.run = Some(self.st.run_start());
        if n > 0 {
            return true;
        }
        self.finish_run();
        false
    }

    /// The record's gate that ran has ended: its pulses counted; the next gate started
    /// (true), or, after the last, the counts are the lane's output (false).
    fn next_gate(&mut self) -> bool {
        let rec = self.record.as_mut().expect("a record in progress");
        let p1 = self.st.core.total_pulses();
        rec.counts.push((p1 - rec.p0).0);
        rec.p0 = p1;
        rec.left -= 1;
        self.start_gate()
    }

    /// Start the record's next gate, its acceleration set first (true), or end the record
    /// when no gate is left (false).
    fn start_gate(&mut self) -> bool {
        loop {
            let rec = self.record.as_mut().expect("a record in progress");
            if rec.left == 0 {
                let counts = std::mem::take(&mut rec.counts);
                self.record = None;
                self.out = Some(Out::Counts(counts));
                return false;
            }
            let (k, ticks) = (rec.counts.len(), rec.ticks);
            if let Some(&a) = self.inputs.get(k) {
                let cond = fixtures::along_ia(a, self.cfg.instr.g_cm_s2);
                self.cfg.set_condition(&cond, &Effects::NONE);
                // As `ClosedLoop::set_condition`.
                self.st.phasor_k = u64::MAX;
            }
            if self.start(ticks, false) {
                return true;
            }
            // A gate of no ticks: counted at once.
            let rec = self.record.as_mut().expect("a record in progress");
            rec.counts.push(0);
            rec.left -= 1;
        }
    }

    /// The current run has run all its ticks: its end, as the single loop's.
    fn finish_run(&mut self) {
        if let Some(start) = self.run.take() {
            let dynamic = self.mode == Mode::Dynamic;
            self.st
                .end_run(start, self.n, dynamic, self.mode != Mode::StaticFast);
        }
    }
}

/// Run a group of lanes to the end of their programs, at most `k` interleaved at a time.
fn run_group(group: &mut [&mut Lane<'_>], k: usize) {
    for l in group.iter_mut() {
        l.advance();
    }
    let mut active: Vec<&mut Lane<'_>> = group
        .iter_mut()
        .filter(|l| !l.done())
        .map(|l| &mut **l)
        .collect();
    while !active.is_empty() {
        let m = active.iter().map(|l| l.left).min().unwrap_or(0);
        active.sort_by_key(|l| l.mode);
        let mut rest = &mut active[..];
        while !rest.is_empty() {
            // Lanes in the same mode with the same core configuration (the kernels share it).
            let (mode, ptsa) = (rest[0].mode, rest[0].cfg.ptsa);
            let same = rest.iter().take_while(|l| l.mode == mode).count();
            rest[..same].sort_by_key(|l| l.cfg.ptsa != ptsa);
            let same = rest[..same]
                .iter()
                .take_while(|l| l.cfg.ptsa == ptsa)
                .count();
            let (now, later) = rest.split_at_mut(same);
            run_mode(now, mode, m, k);
            crate::simulation::work::count(m * now.len() as u64, mode == Mode::Dynamic);
            rest = later;
        }
        for l in &mut active {
            l.left -= m;
            if l.left == 0 {
                l.finish_run();
                l.advance();
            }
        }
        active.retain(|l| !l.done());
    }
}

/// `m` ticks of lanes all in `mode`, in kernels of `k` lanes and then, for the rest, of
/// the largest powers of two that fit.
fn run_mode(lanes: &mut [&mut Lane<'_>], mode: Mode, m: u64, k: usize) {
    let (mut cfg, mut st): (Vec<&LoopConfig>, Vec<&mut LoopState>) =
        lanes.iter_mut().map(|l| (&*l.cfg, &mut *l.st)).unzip();
    if mode == Mode::Dynamic {
        dynamic_blocks(&cfg, &mut st, m, k);
        return;
    }
    if k == 1 || !SimdLevel::current().static_kernels() {
        if mode == Mode::Static {
            static_blocks::<true>(&cfg, &mut st, m);
        } else {
            static_blocks::<false>(&cfg, &mut st, m);
        }
        return;
    }
    let (mut cfg, mut st) = (&mut cfg[..], &mut st[..]);
    while !cfg.is_empty() {
        let s = chunk(cfg.len(), k.min(STATIC_KERNEL_LANES));
        let (c_now, c_later) = std::mem::take(&mut cfg).split_at_mut(s);
        let (s_now, s_later) = std::mem::take(&mut st).split_at_mut(s);
        match (mode, s) {
            (Mode::Static, 8) => static_kernel::<8, true>(c_now, s_now, m),
            (Mode::Static, 4) => static_kernel::<4, true>(c_now, s_now, m),
            (Mode::Static, 2) => static_kernel::<2, true>(c_now, s_now, m),
            (Mode::Static, _) => static_kernel::<1, true>(c_now, s_now, m),
            (Mode::StaticFast, 8) => static_kernel::<8, false>(c_now, s_now, m),
            (Mode::StaticFast, 4) => static_kernel::<4, false>(c_now, s_now, m),
            (Mode::StaticFast, 2) => static_kernel::<2, false>(c_now, s_now, m),
            (Mode::StaticFast, _) => static_kernel::<1, false>(c_now, s_now, m),
            (Mode::Dynamic, _) => unreachable!("dynamic lanes run above"),
        }
        (cfg, st) = (c_later, s_later);
    }
}

/// The most lanes of one static kernel: more lanes run as several kernels of this many, one
/// after the other. Measured with AVX-512 (`ptsa bench --batch 16 --lanes 16`, while this
/// change was made): one kernel of 16 lanes ran at 140-150 Mticks/s, the compiler keeping
/// its lanes' state in memory, where kernels of 8 run at about 400.
const STATIC_KERNEL_LANES: usize = 8;

/// Lanes of the next kernel out of `n` lanes left: `k`, or the largest power of two that
/// fits.
fn chunk(n: usize, k: usize) -> usize {
    if n >= k { k } else { 1 << n.ilog2() }
}

/// The lanes that draw the same noise: classes of lane indices, in order, each lane with
/// the same generator state, the same table and the same ADC as the first of its class.
fn stream_classes(cfg: &[&LoopConfig], st: &[&mut LoopState]) -> Vec<Vec<usize>> {
    let mut classes: Vec<(&NoiseSource, [u64; 5], Vec<usize>)> = Vec::new();
    for (l, (c, s)) in cfg.iter().zip(st).enumerate() {
        let bits = c.adc.bits();
        match classes
            .iter_mut()
            .find(|(r, a, _)| *a == bits && r.same_stream(&s.rng))
        {
            Some(class) => class.2.push(l),
            None => classes.push((&s.rng, bits, vec![l])),
        }
    }
    classes.into_iter().map(|c| c.2).collect()
}

/// Give every lane of each class the generator of the first (which drew for all).
fn share_streams(st: &mut [&mut LoopState], classes: &[Vec<usize>]) {
    for class in classes {
        let rng = st[class[0]].rng.clone();
        for &l in &class[1..] {
            st[l].rng = rng.clone();
        }
    }
}

/// `m` ticks of static lanes one after the other, in blocks of [`BIAS_BLOCK`] ticks: each
/// lane runs a block with the single loop's own code (`sim::static_block_fast`, the fast
/// path split by polarity, or [`kernel::static_tick`] with one lane and the per-tick
/// statistics). Lanes in step with the same noise generator and ADC share the block of the
/// ADC's additive terms, drawn once (from the first lane of their class, whose generator the
/// others take at the end).
#[inline(never)]
fn static_blocks<const STATS: bool>(cfg: &[&LoopConfig], st: &mut [&mut LoopState], m: u64) {
    let classes = stream_classes(cfg, st);
    let mut bias = [0.0; BIAS_BLOCK];
    let mut left = m;
    while left > 0 {
        #[allow(clippy::cast_possible_truncation)]
        let b = left.min(BIAS_BLOCK as u64) as usize;
        for class in &classes {
            let adc = &cfg[class[0]].adc;
            let rng = &mut st[class[0]].rng;
            for v in &mut bias[..b] {
                *v = adc.bias(rng);
            }
            for &l in class {
                if STATS {
                    lane_block_stats(cfg[l], st[l], &bias[..b]);
                } else {
                    static_block_fast(cfg[l], st[l], &bias[..b]);
                }
            }
        }
        left -= b as u64;
    }
    share_streams(st, &classes);
}

/// One block of a static lane with statistics: `ClosedLoop::run`'s static loop (the tick of
/// [`kernel::static_tick`] with one lane).
#[inline(never)]
fn lane_block_stats(cfg: &LoopConfig, st: &mut LoopState, bias: &[f64]) {
    let (o, lane) = (Each::<1>, StaticLanes::new([cfg]));
    let mut s = StaticState::load(o, [&*st]);
    for &v in bias {
        let _ = kernel::static_tick::<1, _, true>(o, &lane, &mut s, &[v]);
    }
    s.store(o, [st]);
}

/// `m` ticks of `K` static lanes side by side: [`kernel::static_tick`] with `K` lanes, the
/// same definition the single loop runs with one, compiled for this CPU's SIMD instructions
/// ([`simd::dispatch`]); the lanes share the core's configuration (see [`run_mode`]).
/// Eight lanes run the core's tick in the registers of the CPU's SIMD level ([`SimdLevel`]:
/// `avx512`, the 32-bit lanes in one `ymm` and the flags in one mask register; `avx2`, the
/// flags as 32-bit masks), others in arrays that the compiler vectorises ([`Each`]). Lanes in step with the same noise generator and the same
/// ADC draw the same additive terms: they are drawn once (the usual batch: one instrument,
/// one seed).
#[inline(never)]
fn static_kernel<const K: usize, const STATS: bool>(
    cfg: &[&LoopConfig],
    st: &mut [&mut LoopState],
    m: u64,
) {
    #[cfg(target_arch = "x86_64")]
    if K == 8 {
        match SimdLevel::current() {
            SimdLevel::Avx512 => {
                if let Some(o) = Avx512::new() {
                    return static_kernel_in::<_, STATS>(o, cfg, st, m);
                }
            }
            SimdLevel::Avx2 => {
                if let Some(o) = Avx2::new() {
                    return static_kernel_in::<_, STATS>(o, cfg, st, m);
                }
            }
            SimdLevel::Sse2 => {}
        }
    }
    static_kernel_with::<K, _, STATS>(Each::<K>, cfg, st, m, |op| simd::dispatch(op));
}

/// [`static_kernel`] with eight lanes in registers `o`, compiled for their instructions.
#[cfg(target_arch = "x86_64")]
fn static_kernel_in<O: Registers, const STATS: bool>(
    o: O,
    cfg: &[&LoopConfig],
    st: &mut [&mut LoopState],
    m: u64,
) {
    static_kernel_with::<8, _, STATS>(o, cfg, st, m, |op| {
        pulp::Simd::vectorize(o.simd(), op);
    });
}

/// [`static_kernel`] with the lane operations `o`, its ticks run by `run` (which compiles
/// them for the CPU's SIMD instructions).
#[allow(
    clippy::inline_always,
    reason = "one copy per kind of lanes, with its dispatch"
)]
#[inline(always)]
fn static_kernel_with<const K: usize, O: LaneOps<K>, const STATS: bool>(
    o: O,
    cfg: &[&LoopConfig],
    st: &mut [&mut LoopState],
    m: u64,
    run: impl FnOnce(StaticTicks<'_, '_, K, O, STATS>),
) {
    let cfg: [&LoopConfig; K] = std::array::from_fn(|l| cfg[l]);
    let p = StaticLanes::new(cfg);
    let mut s = StaticState::<K, O>::load(o, std::array::from_fn(|l| &*st[l]));
    let shared =
        (1..K).all(|l| st[l].rng.same_stream(&st[0].rng) && cfg[l].adc.bits() == cfg[0].adc.bits());
    // The generators in locals for the run (a shared one may then stay in a register).
    let mut rngs: [NoiseSource; K] = std::array::from_fn(|l| st[l].rng.clone());
    run(StaticTicks {
        o,
        p: &p,
        st: &mut s,
        adc: cfg.map(|c| c.adc),
        rngs: &mut rngs,
        shared,
        m,
    });
    for (l, rng) in rngs.into_iter().enumerate() {
        st[l].rng = rng;
    }
    if shared {
        share_streams(st, &[(0..K).collect()]);
    }
    let mut it = st.iter_mut();
    s.store(
        o,
        std::array::from_fn(|_| &mut **it.next().expect("K lanes")),
    );
}

/// `m` ticks of [`static_kernel`]'s lanes, as one call compiled for the CPU's SIMD
/// instructions ([`simd::dispatch`]).
struct StaticTicks<'a, 'b, const K: usize, O: LaneOps<K>, const STATS: bool> {
    o: O,
    p: &'a StaticLanes<'b, K>,
    st: &'a mut StaticState<K, O>,
    adc: [Adc; K],
    rngs: &'a mut [NoiseSource; K],
    shared: bool,
    m: u64,
}

impl<const K: usize, O: LaneOps<K>, const STATS: bool> pulp::WithSimd
    for StaticTicks<'_, '_, K, O, STATS>
{
    type Output = ();

    #[allow(
        clippy::inline_always,
        reason = "compiled inside the dispatch's target features"
    )]
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) {
        // The state in a local for the run, and the choice of the noise draws made once
        // outside the loop: behind the reference the compiler kept the lanes' state in
        // memory (one invocation of `ptsa bench --batch 16 --lanes 8`, AVX-512: 357
        // Mticks/s, 371 with the state in a local).
        let mut st = *self.st;
        let (o, p, m) = (self.o, self.p, self.m);
        if self.shared {
            let (adc, rng) = (&self.adc[0], &mut self.rngs[0]);
            static_ticks::<K, O, STATS>(o, p, &mut st, m, |bias| *bias = [adc.bias(rng); K]);
        } else {
            let (adc, rngs) = (&self.adc, &mut *self.rngs);
            static_ticks::<K, O, STATS>(o, p, &mut st, m, |bias| {
                for (l, b) in bias.iter_mut().enumerate() {
                    *b = adc[l].bias(&mut rngs[l]);
                }
            });
        }
        *self.st = st;
    }
}

/// `m` ticks of `K` static lanes, each tick's ADC terms from `draw`.
#[allow(clippy::inline_always, reason = "per-tick path")]
#[inline(always)]
fn static_ticks<const K: usize, O: LaneOps<K>, const STATS: bool>(
    o: O,
    p: &StaticLanes<'_, K>,
    st: &mut StaticState<K, O>,
    m: u64,
    mut draw: impl FnMut(&mut [f64; K]),
) {
    let mut bias = [0.0; K];
    for _ in 0..m {
        draw(&mut bias);
        let _ = kernel::static_tick::<K, O, STATS>(o, p, st, &bias);
    }
}

/// Ticks of [`dynamic_blocks`]' blocks (its buffers stay in the first-level cache).
const DYN_BLOCK: usize = 128;

/// `m` ticks of dynamic lanes, in blocks of [`DYN_BLOCK`] ticks, `k` lanes side by side
/// through [`kernel::dynamic_tick`] (the single loop runs it with one lane), compiled for
/// this CPU's SIMD instructions ([`simd::dispatch`]); the rest of the lanes in the largest
/// powers of two that fit. The kernels' lanes are packed once; before each block, lanes
/// drawing the same noise draw it once, and lanes in step with the same condition and clock
/// (parameter identification, Monte Carlo: one condition, many instruments or effects)
/// compute the phasor and the condition's inputs of the block once
/// ([`LoopConfig::dynamic_inputs`]).
#[inline(never)]
fn dynamic_blocks(cfg: &[&LoopConfig], st: &mut [&mut LoopState], m: u64, k: usize) {
    let n = cfg.len();
    let noise = stream_classes(cfg, st);
    let inputs = input_classes(cfg, st);
    let mut noise_of = vec![0; n];
    for (c, class) in noise.iter().enumerate() {
        for &l in class {
            noise_of[l] = c;
        }
    }
    let mut inputs_of = vec![0; n];
    for (c, class) in inputs.iter().enumerate() {
        for &l in class {
            inputs_of[l] = c;
        }
    }
    // The kernels' lanes, packed once for the whole run.
    let mut packs = Vec::new();
    let mut first = 0;
    while first < n {
        let s = chunk(n - first, k);
        packs.push(DynKernel::new(
            &cfg[first..first + s],
            &st[first..first + s],
            first,
        ));
        first += s;
    }
    let mut bias = vec![[0.0; DYN_BLOCK]; noise.len()];
    let mut given = vec![[TickInputs::default(); DYN_BLOCK]; inputs.len()];
    let mut phasor: Vec<(f64, f64)> = inputs.iter().map(|c| st[c[0]].phasor).collect();
    let mut done = 0;
    while done < m {
        #[allow(clippy::cast_possible_truncation)]
        let b = (m - done).min(DYN_BLOCK as u64) as usize;
        for (class, buf) in noise.iter().zip(&mut bias) {
            let (adc, rng) = (&cfg[class[0]].adc, &mut st[class[0]].rng);
            for v in &mut buf[..b] {
                *v = adc.bias(rng);
            }
        }
        for ((class, buf), sc) in inputs.iter().zip(&mut given).zip(&mut phasor) {
            let (c, k0) = (cfg[class[0]], st[class[0]].k + done);
            for (t, ti) in (0u64..).zip(&mut buf[..b]) {
                *ti = c.dynamic_inputs(k0 + t, sc);
            }
        }
        for pack in &mut packs {
            let block = Block {
                bias: &bias,
                given: &given,
                noise_of: &noise_of,
                inputs_of: &inputs_of,
                b,
            };
            match pack {
                DynKernel::K16(p) => p.run(&block),
                DynKernel::K8(p) => p.run(&block),
                #[cfg(target_arch = "x86_64")]
                DynKernel::K8Avx512(p) => p.run_in_registers(&block),
                #[cfg(target_arch = "x86_64")]
                DynKernel::K8Avx2(p) => p.run_in_registers(&block),
                DynKernel::K4(p) => p.run(&block),
                DynKernel::K2(p) => p.run(&block),
                DynKernel::K1(p) => p.run(&block),
            }
        }
        done += b as u64;
    }
    for pack in &packs {
        match pack {
            DynKernel::K16(p) => p.store(st),
            DynKernel::K8(p) => p.store(st),
            #[cfg(target_arch = "x86_64")]
            DynKernel::K8Avx512(p) => p.store(st),
            #[cfg(target_arch = "x86_64")]
            DynKernel::K8Avx2(p) => p.store(st),
            DynKernel::K4(p) => p.store(st),
            DynKernel::K2(p) => p.store(st),
            DynKernel::K1(p) => p.store(st),
        }
    }
    share_streams(st, &noise);
    for (class, sc) in inputs.iter().zip(phasor) {
        for &l in class {
            st[l].phasor = sc;
            st[l].phasor_k = st[l].k;
        }
    }
}

/// The dynamic lanes that compute the same phasor and inputs: classes of lane indices, each
/// lane with the same condition (bits), clock and phasor constants, tick index and phasor
/// as the first of its class.
fn input_classes(cfg: &[&LoopConfig], st: &[&mut LoopState]) -> Vec<Vec<usize>> {
    let key = |c: &LoopConfig, s: &LoopState| {
        debug_assert_eq!(s.phasor_k, s.k, "the phasor synced at the start of the run");
        let mut key: Vec<u64> = [c.t_s, c.w, c.sr, c.cr, s.phasor.0, s.phasor.1]
            .iter()
            .map(|x| x.to_bits())
            .collect();
        key.extend(c.prep.key_bits());
        key.push(s.k);
        key
    };
    let mut classes: Vec<(Vec<u64>, Vec<usize>)> = Vec::new();
    for (l, (c, s)) in cfg.iter().zip(st).enumerate() {
        let k = key(c, s);
        match classes.iter_mut().find(|(c, _)| *c == k) {
            Some(c) => c.1.push(l),
            None => classes.push((k, vec![l])),
        }
    }
    classes.into_iter().map(|c| c.1).collect()
}

/// One block of [`dynamic_blocks`]: the ADC's additive terms of each noise class, the
/// phasor and inputs of each input class, each lane's classes, the ticks.
struct Block<'a> {
    bias: &'a [[f64; DYN_BLOCK]],
    given: &'a [[TickInputs; DYN_BLOCK]],
    noise_of: &'a [usize],
    inputs_of: &'a [usize],
    b: usize,
}

/// A kernel of [`dynamic_blocks`] by its lane count (and eight lanes in AVX-512 or AVX2
/// registers).
enum DynKernel<'a> {
    K16(Box<DynPack<'a, 16>>),
    K8(Box<DynPack<'a, 8>>),
    #[cfg(target_arch = "x86_64")]
    K8Avx512(Box<DynPack<'a, 8, Avx512>>),
    #[cfg(target_arch = "x86_64")]
    K8Avx2(Box<DynPack<'a, 8, Avx2>>),
    K4(Box<DynPack<'a, 4>>),
    K2(Box<DynPack<'a, 2>>),
    K1(Box<DynPack<'a, 1>>),
}

impl<'a> DynKernel<'a> {
    /// The lanes `cfg`, `st` (1, 2, 4, 8 or 16 of them, the first at `first` in the call's
    /// lanes) packed: eight in the registers of the CPU's SIMD level ([`SimdLevel`]), the
    /// others on arrays.
    fn new(cfg: &[&'a LoopConfig], st: &[&mut LoopState], first: usize) -> Self {
        #[cfg(target_arch = "x86_64")]
        let level = SimdLevel::current();
        let (c, t) = (cfg, st);
        match cfg.len() {
            16 => Self::K16(Box::new(DynPack::new(Each, c, t, first))),
            #[cfg(target_arch = "x86_64")]
            8 if level == SimdLevel::Avx512
                && let Some(o) = Avx512::new() =>
            {
                Self::K8Avx512(Box::new(DynPack::new(o, c, t, first)))
            }
            #[cfg(target_arch = "x86_64")]
            8 if level == SimdLevel::Avx2
                && let Some(o) = Avx2::new() =>
            {
                Self::K8Avx2(Box::new(DynPack::new(o, c, t, first)))
            }
            8 => Self::K8(Box::new(DynPack::new(Each, c, t, first))),
            4 => Self::K4(Box::new(DynPack::new(Each, c, t, first))),
            2 => Self::K2(Box::new(DynPack::new(Each, c, t, first))),
            _ => Self::K1(Box::new(DynPack::new(Each, c, t, first))),
        }
    }
}

/// `K` dynamic lanes packed for [`kernel::dynamic_tick`] with the lane operations `O`: their
/// constants and state, and the index of the first in the call's lanes.
struct DynPack<'a, const K: usize, O: LaneOps<K> = Each<K>> {
    o: O,
    p: DynLanes<'a, K>,
    st: DynState<K, O>,
    first: usize,
}

impl<'a, const K: usize, O: LaneOps<K>> DynPack<'a, K, O> {
    fn new(o: O, cfg: &[&'a LoopConfig], st: &[&mut LoopState], first: usize) -> Self {
        Self {
            o,
            p: DynLanes::new(std::array::from_fn(|l| cfg[l])),
            st: DynState::load(o, std::array::from_fn(|l| &*st[l])),
            first,
        }
    }

    /// One block of ticks, as one call for [`simd::dispatch`] or another dispatch.
    fn ticks<'s>(&'s mut self, block: &'s Block<'_>) -> DynTicks<'s, 'a, 's, K, O> {
        DynTicks {
            o: self.o,
            p: &self.p,
            st: &mut self.st,
            block,
            first: self.first,
        }
    }

    /// One block of ticks, compiled for this CPU's SIMD instructions
    /// ([`simd::dispatch`]).
    #[inline(never)]
    fn run(&mut self, block: &Block<'_>) {
        simd::dispatch(self.ticks(block));
    }

    /// The lanes' state back into theirs (`st` is the call's lanes).
    fn store(&self, st: &mut [&mut LoopState]) {
        let mut it = st[self.first..self.first + K].iter_mut();
        self.st.store(
            self.o,
            std::array::from_fn(|_| &mut **it.next().expect("K lanes")),
        );
    }
}

#[cfg(target_arch = "x86_64")]
impl<O: Registers> DynPack<'_, 8, O> {
    /// One block of ticks, compiled for the registers' instructions (the lanes exist only
    /// where the CPU has them).
    #[inline(never)]
    fn run_in_registers(&mut self, block: &Block<'_>) {
        let simd = self.o.simd();
        pulp::Simd::vectorize(simd, self.ticks(block));
    }
}

/// A block of a [`DynPack`]'s lanes, as one call compiled for the CPU's SIMD
/// instructions ([`simd::dispatch`]).
struct DynTicks<'a, 'b, 'c, const K: usize, O: LaneOps<K>> {
    o: O,
    p: &'a DynLanes<'b, K>,
    st: &'a mut DynState<K, O>,
    block: &'a Block<'c>,
    first: usize,
}

impl<const K: usize, O: LaneOps<K>> pulp::WithSimd for DynTicks<'_, '_, '_, K, O> {
    type Output = ();

    #[allow(
        clippy::inline_always,
        reason = "compiled inside the dispatch's target features"
    )]
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) {
        let Block {
            bias,
            given,
            noise_of,
            inputs_of,
            b,
        } = *self.block;
        let f = self.first;
        let noise: [&[f64; DYN_BLOCK]; K] = std::array::from_fn(|l| &bias[noise_of[f + l]]);
        let inputs: [&[TickInputs; DYN_BLOCK]; K] =
            std::array::from_fn(|l| &given[inputs_of[f + l]]);
        // The state in a local for the block, so that it may stay in registers.
        let mut st = *self.st;
        for t in 0..b {
            let v: [f64; K] = std::array::from_fn(|l| noise[l][t]);
            let ti: [&TickInputs; K] = std::array::from_fn(|l| &inputs[l][t]);
            let _ = kernel::dynamic_tick::<K, O>(self.o, self.p, &mut st, &v, &ti);
        }
        *self.st = st;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::condition::{IA, OA, PA};
    use crate::model::effects::CandidateId;
    use crate::simulation::sim::{simulate_condition, simulate_difference};
    use proptest::prelude::*;

    /// Every number of a window result, floats as bits.
    fn result_bits(r: &SimResult) -> Vec<u64> {
        vec![
            r.indicated_cm_s2.to_bits(),
            r.count_cm_s2.to_bits(),
            r.ticks,
            r.pulses,
            r.window_s.to_bits(),
            r.theta_rms_rad.to_bits(),
            r.theta_max_rad.to_bits(),
            r.cycles,
            r.cycles_two_reversals,
            r.stop_ticks,
            r.harmonic_amp_cm_s2.to_bits(),
            r.harmonic_deg.to_bits(),
            r.harmonic_torque_amp_cm_s2.to_bits(),
            r.harmonic_torque_deg.to_bits(),
        ]
    }

    fn static_bits(r: &StaticRun) -> (u64, u64, u64, bool) {
        (r.ticks, r.pulses, r.indicated_cm_s2.to_bits(), r.saturated)
    }

    /// The whole state of a loop: plant (bits), core, totals (bits), ticks, the noise
    /// generator, the applied command and the reversal count.
    fn assert_same_loop(a: &ClosedLoop, b: &ClosedLoop, what: &str) {
        assert_eq!(
            a.state().map(f64::to_bits),
            b.state().map(f64::to_bits),
            "{what}: plant state"
        );
        assert_eq!(a.core(), b.core(), "{what}: core state");
        assert_eq!(a.totals().bits(), b.totals().bits(), "{what}: totals");
        assert_eq!(a.ticks(), b.ticks(), "{what}: ticks");
        assert_eq!(
            a.st.u.to_bits(),
            b.st.u.to_bits(),
            "{what}: applied command"
        );
        assert_eq!(
            a.st.rng.clone().normal().to_bits(),
            b.st.rng.clone().normal().to_bits(),
            "{what}: noise"
        );
        assert_eq!(
            (a.st.reversals, a.st.prev_positive),
            (b.st.reversals, b.st.prev_positive),
            "{what}: reversals"
        );
    }

    fn instr() -> Instrument {
        Instrument::kearfott_2401()
    }

    /// Static conditions from well inside to beyond full scale (both stops), with rates,
    /// gravity along PA and OA; and dynamic ones: a 20 Hz angular oscillation about OA
    /// (the OA-coupling test), IA+PA vibration at 37 Hz, a slow oscillation about IA with
    /// rates, an oscillation near full scale that hits a stop.
    fn conditions(i: &Instrument) -> Vec<Condition> {
        let fs = i.sf_cm_s2 / i.g_cm_s2;
        let mut v: Vec<Condition> = [-1.4, -1.02, -0.97, -0.5, 0.0, 0.31, 0.9, 0.99, 1.05, 1.3]
            .iter()
            .map(|&f| fixtures::along_ia(f * i.sf_cm_s2, i.g_cm_s2))
            .collect();
        v.push(Condition {
            g: [0.4, 0.9, 0.17],
            w_rad_s: [0.3, 0.4, -0.2],
            ..Condition::default()
        });
        let mut oa = Condition {
            g: [0.0, 1.0, 0.0],
            freq_hz: 20.0,
            ..Condition::default()
        };
        oa.ang_mrad[OA] = 2.0;
        v.push(oa);
        let mut vib = Condition {
            g: [0.2, 0.98, 0.0],
            freq_hz: 37.0,
            ..Condition::default()
        };
        vib.lin_cm_s2[IA] = 500.0;
        vib.lin_cm_s2[PA] = 300.0;
        vib.lin_deg[PA] = 30.0;
        v.push(vib);
        let mut slow = Condition {
            g: [0.7, 0.7, 0.1],
            w_rad_s: [0.1, 0.05, 0.0],
            freq_hz: 7.5,
            ..Condition::default()
        };
        slow.ang_mrad[IA] = 3.0;
        slow.ang_deg[IA] = 45.0;
        v.push(slow);
        let mut near = Condition {
            g: [0.97 * fs, 0.0, 0.0],
            freq_hz: 50.0,
            ..Condition::default()
        };
        near.lin_cm_s2[IA] = 0.1 * i.sf_cm_s2;
        v.push(near);
        v
    }

    fn effects() -> Effects {
        Effects::only(CandidateId::Sculling, 2e-3)
            .with(CandidateId::Anisoinertia, 3.0)
            .with(CandidateId::LeverArmPa, 1.5)
            .with(CandidateId::Vibropendulosity, 1e-6)
            .with(CandidateId::Nonlinearity, -2e-7)
    }

    /// Short runs for the tests (settling and windows of 20 ms).
    fn short(seed: u64, noise: bool, harmonic: u32) -> SimOptions {
        SimOptions {
            seed,
            noise,
            harmonic,
            warmup_s: 0.02,
            min_window_s: 0.02,
            ..SimOptions::default()
        }
    }

    fn engines() -> [Engine; 5] {
        [1, 2, 4, 8, 16].map(Engine::new)
    }

    #[test]
    fn batch_run_static_matches_run_static() {
        let i = instr();
        // 13 lanes: not a multiple of any K but 1; from −1.4 to +1.4 full scale.
        let accels: Vec<f64> = (0..13)
            .map(|j| (-1.4 + 2.8 * f64::from(j) / 12.0) * i.sf_cm_s2)
            .collect();
        for noise in [true, false] {
            let opts = short(11, noise, 0);
            let want: Vec<_> = accels
                .iter()
                .map(|&a| static_bits(&sim::run_static(&i, a, 3_001, &opts)))
                .collect();
            assert!(want.iter().any(|w| w.3) && want.iter().any(|w| !w.3));
            for e in engines() {
                let got: Vec<_> = e
                    .run_static(&i, &accels, 3_001, &opts)
                    .iter()
                    .map(static_bits)
                    .collect();
                assert_eq!(got, want, "K = {}, noise {noise}", e.lanes());
            }
        }
    }

    /// A gate longer than the single loop's progress chunk: the single loop cuts it into
    /// calls, the batch engine runs it as one; the counts and the state are the same bits.
    #[test]
    fn a_gate_longer_than_a_progress_chunk_is_not_cut() {
        let i = instr();
        let opts = short(5, true, 0);
        let ticks = sim::PROGRESS_CHUNK + 12_345;
        let accels = [0.3 * i.sf_cm_s2, -0.7 * i.sf_cm_s2];
        let want: Vec<_> = accels
            .iter()
            .map(|&a| static_bits(&sim::run_static(&i, a, ticks, &opts)))
            .collect();
        for e in [Engine::new(1), Engine::new(2)] {
            let got: Vec<_> = e
                .run_static(&i, &accels, ticks, &opts)
                .iter()
                .map(static_bits)
                .collect();
            assert_eq!(got, want, "K = {}", e.lanes());
        }
    }

    #[test]
    fn batch_run_static_with_a_harmonic_matches() {
        // A harmonic sends the static loop down the dynamic path.
        let i = instr();
        let accels = [-0.5 * i.sf_cm_s2, 10.0, 1.2 * i.sf_cm_s2];
        let opts = short(5, true, 2);
        let want: Vec<_> = accels
            .iter()
            .map(|&a| static_bits(&sim::run_static(&i, a, 2_000, &opts)))
            .collect();
        let got: Vec<_> = Engine::new(2)
            .run_static(&i, &accels, 2_000, &opts)
            .iter()
            .map(static_bits)
            .collect();
        assert_eq!(got, want);
    }

    #[test]
    fn batch_simulate_conditions_matches_simulate_condition() {
        let i = instr();
        let conds = conditions(&i);
        let e = effects();
        // Every condition with and without effects: 30 lanes of mixed kinds and lengths
        // (the dynamic windows are whole periods of 20, 37, 7.5 and 50 Hz).
        let jobs: Vec<(Condition, Effects)> = conds
            .iter()
            .flat_map(|c| [(c.clone(), Effects::NONE), (c.clone(), e)])
            .collect();
        for (noise, harmonic) in [(true, 0), (false, 0), (true, 1)] {
            let opts = short(3, noise, harmonic);
            let want: Vec<_> = jobs
                .iter()
                .map(|(c, e)| result_bits(&simulate_condition(&i, c, e, &opts)))
                .collect();
            let windows: std::collections::BTreeSet<u64> = want.iter().map(|w| w[2]).collect();
            assert!(
                windows.len() >= 4,
                "lanes of different lengths: {windows:?}"
            );
            assert!(want.iter().any(|w| w[9] > 0), "some lane on a stop");
            for eng in engines() {
                let got: Vec<_> = eng
                    .simulate_conditions(&i, &jobs, &opts)
                    .iter()
                    .map(result_bits)
                    .collect();
                for (j, (g, w)) in got.iter().zip(&want).enumerate() {
                    assert_eq!(
                        g,
                        w,
                        "K = {}, noise {noise}, harmonic {harmonic}, lane {j}: {}",
                        eng.lanes(),
                        jobs[j].0.label
                    );
                }
            }
        }
    }

    #[test]
    fn batch_simulate_differences_matches_simulate_difference() {
        let i = instr();
        let e = effects();
        let jobs: Vec<(Condition, Effects)> = conditions(&i)
            .into_iter()
            .map(|mut c| {
                c.ref_w_rad_s = [0.05, 0.0, 0.01];
                (c, e)
            })
            .collect();
        let opts = short(9, true, 0);
        let got = Engine::new(4).simulate_differences(&i, &jobs, &opts);
        assert_eq!(got.len(), jobs.len());
        for ((c, e), g) in jobs.iter().zip(&got) {
            let w = simulate_difference(&i, c, e, &opts);
            assert_eq!(
                result_bits(&g.condition),
                result_bits(&w.condition),
                "{}",
                c.label
            );
            assert_eq!(
                result_bits(&g.reference),
                result_bits(&w.reference),
                "{}",
                c.label
            );
            assert_eq!(g.difference_cm_s2.to_bits(), w.difference_cm_s2.to_bits());
        }
    }

    #[test]
    fn lanes_with_their_own_instruments_and_seeds_match() {
        // Parameter identification: every lane a slightly different instrument.
        let base = instr();
        let instrs: Vec<Instrument> = (0..7)
            .map(|j| {
                let mut i = base.clone();
                let f = 1.0 + 0.01 * f64::from(j);
                i.spring_dyn_cm_rad *= f;
                i.damping_dyn_cm_s /= f;
                i.pendulosity_dyn_cm_per_g *= 1.0 + 0.001 * f64::from(j);
                i.noise_v_rms *= f;
                i
            })
            .collect();
        let conds = conditions(&base);
        let jobs: Vec<Job<'_>> = instrs
            .iter()
            .enumerate()
            .flat_map(|(j, i)| {
                let c = &conds[(3 * j) % conds.len()];
                let d = &conds[(3 * j + 11) % conds.len()];
                [(c, 100 + j as u64), (d, 7)].map(|(cond, seed)| Job {
                    instr: i,
                    cond,
                    effects: if j % 2 == 0 { effects() } else { Effects::NONE },
                    seed,
                })
            })
            .collect();
        let opts = short(0, true, 0);
        let got = Engine::new(8).simulate_jobs(&jobs, &opts);
        for (j, g) in jobs.iter().zip(&got) {
            let o = SimOptions {
                seed: j.seed,
                ..opts
            };
            let w = simulate_condition(j.instr, j.cond, &j.effects, &o);
            assert_eq!(result_bits(g), result_bits(&w), "{}", j.cond.label);
        }
    }

    #[test]
    fn identification_lanes_share_inputs_and_noise_and_match() {
        // One condition, eight instruments, one seed: the lanes share the noise draws and
        // (dynamic) the phasor and the inputs. With the second harmonic measured.
        let base = instr();
        let instrs: Vec<Instrument> = (0..8)
            .map(|j| {
                let mut i = base.clone();
                i.spring_dyn_cm_rad *= 1.0 + 0.02 * f64::from(j);
                i.anisoinertia_g_cm2 += 0.5 * f64::from(j);
                i
            })
            .collect();
        let conds = conditions(&base);
        for cond in [&conds[11], &conds[12], &conds[3]] {
            let jobs: Vec<Job<'_>> = instrs
                .iter()
                .map(|i| Job {
                    instr: i,
                    cond,
                    effects: effects(),
                    seed: 17,
                })
                .collect();
            for harmonic in [0, 2] {
                let opts = short(17, true, harmonic);
                for k in [1, 4] {
                    let got = Engine::new(k).simulate_jobs(&jobs, &opts);
                    for (j, g) in jobs.iter().zip(&got) {
                        let w = simulate_condition(j.instr, j.cond, &j.effects, &opts);
                        assert_eq!(result_bits(g), result_bits(&w), "K = {k}, {}", cond.label);
                    }
                }
            }
        }
    }

    #[test]
    fn lanes_step_by_step_match_single_loops() {
        // The low-level calls on loops in mid-run, every lane's whole state after each:
        // runs with and without statistics, windows of different lengths, runs of no tick.
        // Lanes 0-5 share a seed (built apart: equal noise tables, not the same one), so
        // that the static and the dynamic lanes among them share their noise draws.
        let i = instr();
        let conds = conditions(&i);
        let e = effects();
        let opts = short(21, true, 0);
        let start: Vec<ClosedLoop> = conds
            .iter()
            .enumerate()
            .map(|(j, c)| {
                let eff = if j % 3 == 0 { Effects::NONE } else { e };
                let seed = if j < 6 { 5 } else { j as u64 };
                ClosedLoop::new(&i, c, &eff, &SimOptions { seed, ..opts })
            })
            .collect();
        for k in [1, 4, 16] {
            step_by_step(&start, Engine::new(k));
        }
    }

    /// The checks of [`lanes_step_by_step_match_single_loops`] with `eng`.
    fn step_by_step(start: &[ClosedLoop], eng: Engine) {
        let mut single = start.to_vec();
        let mut lanes = start.to_vec();
        let lens: Vec<u64> = (0..single.len() as u64).map(|j| 500 + 97 * j).collect();
        let check = |a: &[ClosedLoop], b: &[ClosedLoop], what: &str| {
            for (j, (x, y)) in a.iter().zip(b).enumerate() {
                assert_same_loop(x, y, &format!("K = {}, {what}, lane {j}", eng.lanes()));
            }
        };
        for l in &mut single {
            l.run(1_234);
        }
        eng.run(&mut lanes, 1_234);
        check(&lanes, &single, "run");
        for l in &mut single {
            l.run_fast(777);
        }
        eng.run_fast(&mut lanes, 777);
        check(&lanes, &single, "run_fast");
        for l in &mut single {
            l.run(0);
            l.run_fast(0);
        }
        eng.run(&mut lanes, 0);
        eng.run_fast(&mut lanes, 0);
        check(&lanes, &single, "no ticks");
        let want: Vec<_> = single
            .iter_mut()
            .zip(&lens)
            .map(|(l, &n)| result_bits(&l.measure(n)))
            .collect();
        let got: Vec<_> = eng
            .measure_each(&mut lanes, &lens)
            .iter()
            .map(result_bits)
            .collect();
        assert_eq!(got, want);
        check(&lanes, &single, "measure_each");
        let want: Vec<_> = single
            .iter_mut()
            .map(|l| result_bits(&l.measure(640)))
            .collect();
        let got: Vec<_> = eng
            .measure(&mut lanes, 640)
            .iter()
            .map(result_bits)
            .collect();
        assert_eq!(got, want);
        check(&lanes, &single, "measure");
    }

    #[test]
    fn lanes_with_different_core_configurations_match() {
        // The interleaved kernels share the core's configuration: lanes are grouped by it.
        let i = instr();
        let conds = conditions(&i);
        let configs = [
            ptsa_core::Config::DEFAULT,
            ptsa_core::Config {
                noise_shaping: true,
                gate_ticks: 6400,
                ..ptsa_core::Config::DEFAULT
            },
        ];
        let start: Vec<ClosedLoop> = conds
            .iter()
            .enumerate()
            .map(|(j, c)| {
                let opts = SimOptions {
                    config: configs[j % 2],
                    ..short(8, true, 0)
                };
                ClosedLoop::new(&i, c, &Effects::NONE, &opts)
            })
            .collect();
        for k in [1, 2, 8] {
            let mut single = start.clone();
            let mut lanes = start.clone();
            for l in &mut single {
                l.run(3_000);
                l.run_fast(1_000);
            }
            Engine::new(k).run(&mut lanes, 3_000);
            Engine::new(k).run_fast(&mut lanes, 1_000);
            for (j, (a, b)) in lanes.iter().zip(&single).enumerate() {
                assert_same_loop(a, b, &format!("K = {k}, lane {j}"));
            }
        }
    }

    #[test]
    fn same_stream_is_the_same_numbers() {
        let (a, b, c) = (
            NoiseSource::new(5),
            NoiseSource::new(5),
            NoiseSource::new(6),
        );
        assert!(a.same_stream(&b) && a.same_stream(&a.clone()) && !a.same_stream(&c));
        let mut d = a.clone();
        let _ = d.normal();
        assert!(!a.same_stream(&d));
    }

    #[test]
    fn one_thread_and_the_pool_agree() {
        // Groups fill to K on one thread and split across the pool's threads otherwise.
        let i = instr();
        let jobs: Vec<(Condition, Effects)> =
            conditions(&i).into_iter().map(|c| (c, effects())).collect();
        let opts = short(4, true, 0);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("a pool");
        for e in [Engine::new(8), Engine::new(16)] {
            let one = pool.install(|| e.simulate_conditions(&i, &jobs, &opts));
            let all = e.simulate_conditions(&i, &jobs, &opts);
            let bits = |v: &[SimResult]| v.iter().map(result_bits).collect::<Vec<_>>();
            assert_eq!(bits(&one), bits(&all));
        }
    }

    #[test]
    fn empty_batches() {
        let i = instr();
        let opts = short(1, true, 0);
        assert!(run_static(&i, &[], 100, &opts).is_empty());
        assert!(simulate_conditions(&i, &[], &opts).is_empty());
        assert!(simulate_differences(&i, &[], &opts).is_empty());
        Engine::new(4).run(&mut [], 10);
    }

    fn arb_condition() -> impl Strategy<Value = Condition> {
        (
            prop::array::uniform3(-1.6f64..1.6),
            prop::array::uniform3(-0.5f64..0.5),
            prop_oneof![Just(0.0), 2.0f64..80.0],
            prop::array::uniform3(prop_oneof![Just(0.0), -800.0f64..800.0]),
            prop::array::uniform3(prop_oneof![Just(0.0), -4.0f64..4.0]),
            prop::array::uniform3(-180.0f64..180.0),
            prop_oneof![Just(0.0), 1.0f64..50.0],
        )
            .prop_map(|(g, w, f, lin, ang, deg, r)| Condition {
                label: "random".into(),
                g,
                w_rad_s: w,
                radius_cm: r,
                freq_hz: f,
                lin_cm_s2: lin,
                lin_deg: deg,
                ang_mrad: ang,
                ang_deg: [deg[1], deg[2], deg[0]],
                ..Condition::default()
            })
    }

    fn arb_effects() -> impl Strategy<Value = Effects> {
        prop::collection::vec(prop_oneof![Just(0.0), -1e-2f64..1e-2], 8).prop_map(|c| {
            let mut e = Effects::NONE;
            for (id, v) in CandidateId::ALL.iter().zip(c) {
                e.set(*id, v);
            }
            e
        })
    }

    /// Random conditions, and copies of some of them that differ in one input only (a
    /// centrifuge arm, a gravity component, a rate, the vibration's amplitude or phase),
    /// so that lanes which share most of their inputs meet in one batch.
    fn arb_batch() -> impl Strategy<Value = Vec<(Condition, Effects)>> {
        (
            prop::collection::vec((arb_condition(), arb_effects()), 1..8),
            prop::collection::vec(
                (
                    any::<prop::sample::Index>(),
                    0usize..5,
                    0usize..3,
                    -60.0f64..60.0,
                ),
                0..8,
            ),
        )
            .prop_map(|(mut jobs, edits)| {
                for (i, field, j, v) in edits {
                    let (mut c, e) = jobs[i.index(jobs.len())].clone();
                    match field {
                        0 => c.radius_cm = v.abs(),
                        1 => c.g[j] = v / 60.0,
                        2 => c.w_rad_s[j] = v / 120.0,
                        3 => c.lin_cm_s2[j] = 10.0 * v,
                        _ => c.lin_deg[j] = 3.0 * v,
                    }
                    jobs.push((c, e));
                }
                jobs
            })
    }

    /// The regression case of a hand-written grouping key that left out the centrifuge arm:
    /// two conditions that differ only in `radius_cm` (same rate, same oscillation) came
    /// back from one lane group both with the first one's value (108.7001 cm/s²).
    #[test]
    fn centrifuge_arms_are_not_merged() {
        let i = instr();
        let arm = |r: f64| Condition {
            label: format!("r{r}"),
            kind: crate::model::condition::RowKind::Absolute,
            w_rad_s: [0.0, 0.0, 3.0],
            radius_cm: r,
            freq_hz: 5.0,
            lin_cm_s2: [10.0, 0.0, 0.0],
            ..Condition::default()
        };
        let jobs = vec![(arm(10.0), Effects::NONE), (arm(20.0), Effects::NONE)];
        let opts = short(1, true, 0);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("a pool");
        for k in [1, 2, 8] {
            let got = pool.install(|| Engine::new(k).simulate_conditions(&i, &jobs, &opts));
            for ((c, e), g) in jobs.iter().zip(&got) {
                let w = simulate_condition(&i, c, e, &opts);
                assert_eq!(result_bits(g), result_bits(&w), "K = {k}, {}", c.label);
            }
            assert!(
                (got[1].indicated_cm_s2 - got[0].indicated_cm_s2).abs() > 50.0,
                "K = {k}: {} and {}",
                got[0].indicated_cm_s2,
                got[1].indicated_cm_s2
            );
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

        /// Random batches of random conditions (static and dynamic, inside and beyond full
        /// scale, centrifuge arms, and near-copies that share most inputs), effects, seeds,
        /// lane counts and thread counts (the groups are cut by the threads there are).
        #[test]
        fn random_batches_match_the_single_loop(
            jobs in arb_batch(),
            seed in 0u64..1000,
            noise in any::<bool>(),
            lanes in prop::sample::select(vec![1usize, 2, 4, 8, 16]),
            threads in prop::sample::select(vec![1usize, 2, 8]),
        ) {
            let i = instr();
            let opts = SimOptions { warmup_s: 0.005, min_window_s: 0.005, ..short(seed, noise, 0) };
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a pool");
            let got = pool.install(|| Engine::new(lanes).simulate_conditions(&i, &jobs, &opts));
            for ((c, e), g) in jobs.iter().zip(&got) {
                let w = simulate_condition(&i, c, e, &opts);
                prop_assert_eq!(result_bits(g), result_bits(&w), "{:?}", c);
            }
        }
    }
}
