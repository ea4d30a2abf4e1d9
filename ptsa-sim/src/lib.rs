//! The Kearfott 2401 accelerometer in the PTSA loop, simulated on the host.
//!
//! It closes the loop tick by tick: [`ptsa_core`] (the very code the firmware runs) against
//! an `f64` model of the pendulum of Draper report R-890. The analysis of measured records
//! and the command line `ptsa` are the crate `ptsa-host-sim`, built on this one.
//!
//! The crate in layers, each a folder; a layer uses only those above it (and the
//! foundation: [`stats`], [`text`]):
//!
//! * [`model`]: the instrument file, test conditions, the candidate registry, the plant of
//!   eq. 4.2, the loop design and the case-frame format.
//! * [`lab`]: lab set-ups (fixtures), test plans and the counter record's frequency response.
//! * [`simulation`]: the closed loop tick by tick and the batch engine that runs many;
//!   [`simulate_condition`] and [`simulate_difference`] are the entry points.
//! * [`stats`]: dense weighted least squares and the tail probabilities.
//! * [`text`]: numbers for a reader, and the generated reference pages' check.

pub mod lab;
pub mod model;
pub mod simulation;
pub mod stats;
pub mod text;

pub use model::condition::{CaseInputs, Condition};
pub use model::effects::{CandidateId, Effects};
pub use model::instrument::{Instrument, InstrumentError};
pub use simulation::sim::{
    SimDifference, SimOptions, SimResult, simulate_condition, simulate_difference,
};
