//! Host simulator of the Kearfott 2401 accelerometer in the PTSA loop.
//!
//! It closes the loop tick by tick: [`ptsa_core`] (the very code the firmware runs) against
//! an `f64` model of the pendulum, and reproduces the test programme of Draper report R-890.

pub mod condition;
pub mod discovery;
