//! Lab set-ups: the fixtures (tumble, centrifuge, shaker), test plans written from them, and
//! the frequency-response analysis of counter records.
//!
//! * [`fixtures`]: the set-ups and the conditions they give.
//! * [`plan`]: `ptsa plan`, a design written as a case-frame file to fill.
//! * [`response`]: `ptsa response`, a counter record's frequency response.
//! * [`record`]: `ptsa record`, the firmware's log of gate reports turned into a counter
//!   record.

pub mod fixtures;
pub mod plan;
pub mod record;
pub mod response;
