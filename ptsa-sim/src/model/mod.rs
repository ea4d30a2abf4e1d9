//! The model: what the instrument is and what it is put through.
//!
//! * [`instrument`]: the instrument file (Table 2.1 with tolerances), one parameter table
//!   that parse, get and set all use, validated on load.
//! * [`condition`]: a test condition (gravity, rates, centrifuge, oscillation) and its inputs
//!   along the instrument's axes.
//! * [`effects`]: the candidate registry: every candidate's properties in one table.
//! * [`plant`]: eq. 4.2 with spring, stops, torquer current rise, pickoff and demodulator,
//!   discretised exactly (zero-order hold).
//! * [`design`]: the default compensator (`Config::DEFAULT`) and the loop's margins.
//! * [`caseframe`]: the case-frame CSV format, its one reader and one writer.
//! * [`counts`]: counts in: an absolute row's pulses and ticks as its indicated
//!   acceleration, with the counting's own error.

pub mod caseframe;
pub mod condition;
pub mod counts;
pub mod design;
pub mod effects;
pub mod instrument;
pub mod plant;
pub mod reference;
