//! The work estimates count the closed-loop ticks the work then runs: every experiment of
//! the report programme exactly, a discovery's part that always runs exactly, the whole
//! programme within what the discovery's re-simulation of an empty selection leaves out.
//!
//! One test in its own binary: the tick counter (`ptsa_host_sim::simulation::work::done`) is the
//! process's, and no other test may run beside it.

use ptsa_host_sim::discovery::cost::Cost;
use ptsa_host_sim::discovery::sim::ClosedLoopSimulator;
use ptsa_host_sim::discovery::{Options, discover};
use ptsa_host_sim::lab::fixtures::TwoAxisKind;
use ptsa_host_sim::report::experiments::appendix_a::{self, TwoAxisPlan};
use ptsa_host_sim::report::experiments::{
    anisoinertia, frequency_response, limit_cycle, monte_carlo, oa_coupling, tumble, waveform,
};
use ptsa_host_sim::simulation::work::{Ticks, done};
use ptsa_host_sim::{CandidateId, Instrument, SimOptions, report};

/// The ticks `f` runs.
fn counted(f: impl FnOnce()) -> Ticks {
    let before = done();
    f();
    let after = done();
    Ticks {
        fixed: after.fixed - before.fixed,
        dynamic: after.dynamic - before.dynamic,
    }
}

/// Every experiment's estimate and the ticks it ran.
fn experiments(
    i: &Instrument,
    opts: &SimOptions,
    dir: &std::path::Path,
) -> Vec<(&'static str, Ticks, Ticks)> {
    let opts = *opts;
    vec![
        (
            "tumble",
            tumble::work(i, &opts, 0.05),
            counted(|| {
                tumble::run(i, &opts, 0.05).unwrap();
            }),
        ),
        (
            "anisoinertia",
            anisoinertia::work(i, &opts, [0.0; 3]).unwrap(),
            counted(|| {
                anisoinertia::run(i, &opts, 3.4, [0.0; 3]).unwrap();
            }),
        ),
        (
            "oa-coupling",
            oa_coupling::work(i, &opts, [0.0; 3]).unwrap(),
            counted(|| {
                oa_coupling::run(i, &opts, [0.0; 3]).unwrap();
            }),
        ),
        (
            "sculling",
            appendix_a::work(i, &opts, &TwoAxisPlan::report(TwoAxisKind::Sculling)),
            counted(|| {
                appendix_a::run(i, &opts, &TwoAxisPlan::report(TwoAxisKind::Sculling)).unwrap();
            }),
        ),
        (
            "frequency response",
            frequency_response::work(i, &opts),
            counted(|| {
                frequency_response::run(i, &opts).unwrap();
            }),
        ),
        (
            "limit cycle",
            limit_cycle::work(i, &opts),
            counted(|| {
                limit_cycle::run(i, &opts).unwrap();
            }),
        ),
        (
            "monte carlo",
            monte_carlo::work(i, &opts, 16),
            counted(|| {
                monte_carlo::run(i, &opts, 16).unwrap();
            }),
        ),
        (
            "waveform",
            waveform::work(i, &opts, 3),
            counted(|| {
                waveform::run(i, &opts, 0.0, 3, dir).unwrap();
            }),
        ),
    ]
}

#[test]
#[allow(clippy::float_cmp)] // whole numbers of ticks, exactly
fn estimates_count_the_ticks_that_run() {
    let i = Instrument::kearfott_2401();
    let opts = SimOptions {
        warmup_s: 0.01,
        min_window_s: 0.01,
        ..SimOptions::default()
    };
    let tmp = tempfile::tempdir().unwrap();
    for (what, est, ran) in &experiments(&i, &opts, tmp.path()) {
        assert!(ran.total() > 0.0, "{what}: nothing counted");
        assert_eq!(est, ran, "{what}: estimated {est:?}, ran {ran:?}");
    }

    // A discovery that selects something (anisoinertia in the 48 rate-table and shaker
    // rows) runs exactly its part that always runs: baseline, central differences,
    // re-simulation.
    let sim = ClosedLoopSimulator {
        instrument: i.clone(),
        options: opts,
    };
    let rows = ptsa_host_sim::model::caseframe::read(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/synthetic-48.case.csv"),
    )
    .unwrap();
    let mut d = None;
    let ran = counted(|| d = Some(discover(&rows, &sim, &Options::default()).unwrap()));
    let d = d.unwrap();
    assert!(!d.selected.is_empty());
    assert!(d.selected.iter().all(|s| s.id.parameter_key().is_none()));
    let cost = Cost::of(&rows, &sim, CandidateId::ALL);
    assert!(cost.differences && cost.parameters > 0, "{cost:?}");
    assert_eq!(cost.ticks, ran, "discover: estimated {cost:?}, ran {ran:?}");

    // The whole programme: every experiment's ticks, and the discovery section's less the
    // re-simulation of the tables where nothing is selected (Tables 6.2 and 6.3).
    let est = report::work(&i, &opts).unwrap();
    let info = report::RunInfo {
        instrument: "shipped".into(),
        options: opts,
        threads: 1,
    };
    let ran = counted(|| {
        report::run(
            &i,
            &opts,
            info,
            &tmp.path().join("report"),
            &mut |_, _| {},
            &mut std::io::sink(),
        )
        .unwrap();
    });
    let ratio = ran.total() / est.ticks.total();
    assert!(
        (0.9..=1.0).contains(&ratio),
        "{ratio}: {est:?} against {ran:?}"
    );
}
