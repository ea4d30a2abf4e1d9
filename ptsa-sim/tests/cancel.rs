//! Cancellation (`work::cancel`): a test binary of its own, because the flag is the
//! process's and would stop any other test's simulation running beside it.

use std::panic::{AssertUnwindSafe, catch_unwind};

use ptsa_sim::model::instrument::Instrument;
use ptsa_sim::simulation::sim::{SimOptions, run_static};
use ptsa_sim::simulation::work::{self, Cancelled};

#[test]
fn a_cancelled_run_unwinds_with_cancelled_and_runs_again_after_resume() {
    let instr = Instrument::kearfott_2401();
    let opts = SimOptions::default();
    let run = || run_static(&instr, 100.0, 64_000, &opts);
    let before = run();
    work::cancel();
    let r = catch_unwind(AssertUnwindSafe(run));
    work::resume();
    let payload = r.expect_err("a cancelled run ends at its checkpoint");
    assert!(payload.is::<Cancelled>());
    assert_eq!(run(), before);
}
