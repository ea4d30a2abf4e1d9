//! Host simulator of the Kearfott 2401 accelerometer in the PTSA loop.
//!
//! It closes the loop tick by tick: [`ptsa_core`] (the very code the firmware runs) against
//! an `f64` model of the pendulum, and reproduces the test programme of Draper report R-890.
//!
//! The crate in layers, each a folder; a layer uses only those above it and the foundation
//! (statistics; output for the layers of this crate). `model`, `lab`, `simulation` and
//! `stats` are the crate `ptsa-sim`, re-exported here under the same paths:
//!
//! * [`model`]: the instrument file, test conditions, the candidate registry, the plant of
//!   eq. 4.2, the loop design and the case-frame format.
//! * [`lab`]: lab set-ups (fixtures), test plans and the counter record's frequency response.
//! * [`simulation`]: the closed loop tick by tick and the batch engine that runs many;
//!   [`simulate_condition`] and [`simulate_difference`] are the entry points.
//! * [`stream`]: raw streams read fast and cut into their static intervals.
//! * [`noise`]: the Allan deviation of a static counter record and its noise terms, and
//!   the same for the simulated loop at rest (`ptsa noise`).
//! * [`discovery`]: what measured data say the model gets wrong.
//! * [`triad`]: three accelerometers on one block calibrated together (a triad file).
//! * [`report`]: the report programme of R-890 (experiments, tables, summary).
//! * [`session`]: what a command runs against (the instrument file loaded and checked).
//! * [`output`]: files, tables and plots, written whole or not at all.
//! * [`stats`]: dense weighted least squares and the tail probabilities.

pub mod discovery;
pub mod noise;
pub mod output;
pub mod report;
pub mod session;
pub mod stream;
pub mod triad;

// The crate `ptsa-sim` (model, lab, simulation, statistics), under the paths it had here.
pub use ptsa_sim::{lab, model, simulation, stats};

pub use model::condition::{CaseInputs, Condition};
pub use model::effects::{CandidateId, Effects};
pub use model::instrument::{Instrument, InstrumentError};
pub use simulation::sim::{
    SimDifference, SimOptions, SimResult, simulate_condition, simulate_difference,
};
