//! Host simulator of the Kearfott 2401 accelerometer in the PTSA loop.
//!
//! It closes the loop tick by tick: [`ptsa_core`] (the very code the firmware runs) against
//! an `f64` model of the pendulum, and reproduces the test programme of Draper report R-890.
//!
//! * [`instrument`]: the instrument file (Table 2.1 with tolerances), validated on load.
//! * [`plant`]: eq. 4.2 with spring, stops, torquer current rise, pickoff and demodulator,
//!   discretised exactly (zero-order hold).
//! * [`sim`]: the closed loop and the charge-balance estimator; [`simulate_condition`] and
//!   [`simulate_difference`] are the entry points.
//! * [`batch`]: many independent closed loops, lanes interleaved per core, all cores.
//! * [`design`]: the default compensator (`Config::DEFAULT`) and the loop's margins.
//! * [`work`]: work estimated before it runs and counted while it runs (ticks, stages).

pub mod batch;
pub mod bench;
pub mod condition;
pub mod design;
pub mod discovery;
pub mod effects;
pub mod experiments;
pub mod fixtures;
pub mod instrument;
pub mod output;
pub mod plan;
pub mod plant;
pub mod r890;
pub mod report;
pub mod response;
pub mod sim;
pub mod work;

pub use condition::{CaseInputs, Condition};
pub use effects::{CandidateId, Effects};
pub use instrument::{Instrument, InstrumentError};
pub use sim::{SimDifference, SimOptions, SimResult, simulate_condition, simulate_difference};
