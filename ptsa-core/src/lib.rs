//! Bit-exact fixed-point model of the PTSA forced-binary pulse-torque rebalance loop.
//!
//! The United Aircraft PTSA (Draper report R-890, section 3, Fig. 3.2) rebalances a
//! pendulous accelerometer with a torquer current of constant magnitude whose sign is
//! switched on a 64 kHz clock. The demodulated pickoff goes through a compensation network,
//! is summed with a ramp at the 1 kHz limit-cycle frequency, and a quantizer switches the
//! current at the first zero crossing of that sum in each cycle. Every clock tick of the
//! positive polarity is one data pulse.
//!
//! This crate is that digital loop as firmware runs it: one call of [`Ptsa::tick`] per clock
//! tick, integer arithmetic only, no allocation, no `unsafe`, no floating point. The Q format
//! of every signal, the rounding of every product, every saturation bound and the order of
//! operations inside a tick are written down in `ARITHMETIC.md` (included below), so that a
//! C or HDL twin can be built bit for bit. The golden vectors in `tests/golden/` are the
//! contract.
//!
//! ```
//! use ptsa_core::{Config, Polarity};
//!
//! let ptsa = Config::DEFAULT.build().unwrap();
//! let mut state = ptsa.initial_state();
//! // With a null pickoff the crossing is at mid-cycle: 32 positive ticks out of 64.
//! let mut positive = 0;
//! for _ in 0..64 {
//!     if ptsa.tick(&mut state, 0).polarity == Polarity::Positive {
//!         positive += 1;
//!     }
//! }
//! assert_eq!(positive, 32);
//! ```
//!
//! Configuration is split from state (`ptsa.tick(&mut state, x)`): one validated, immutable
//! [`Ptsa`] can serve any number of [`State`]s, and a [`State`] is plain data that can be
//! reset, cloned, compared and digested.
#![doc = include_str!("../ARITHMETIC.md")]
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
// Every narrowing or widening conversion on the tick path must be visible and justified.
#![warn(clippy::cast_possible_truncation, clippy::cast_lossless)]

pub mod adc;
mod bridge;
mod config;
mod counter;
mod lane_ops;
mod lanes;
mod ptsa;
pub mod trace;

pub use bridge::{BridgeError, HBridge};
pub use config::{Coef, Config, ConfigError, Level, Pole};
pub use counter::{Count, Gate, GateFifo};
pub use lane_ops::{Each, LaneOps};
pub use lanes::{LaneTicks, Lanes, RegTicks, Regs};
pub use ptsa::{Fnv, Polarity, Ptsa, Saturations, State, Tick};

/// The crate's README (the page crates.io shows), compiled and run as a doctest so that its
/// example keeps working; it exists only under `cargo test --doc`.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

/// Fraction bits of the comparator domain ([`Level`]): the ramp amplitude, which is the
/// loop's full scale, is `1 << LEVEL_FRAC` comparator LSBs.
pub const LEVEL_FRAC: u32 = 24;

/// Ramp amplitude `R` in comparator LSBs (`1.0` in [`Level`]).
pub const RAMP_AMPLITUDE: i32 = 1 << LEVEL_FRAC;

/// Fraction bits of the per-sample gains `b0`, `b1`, `ki` ([`Coef`]).
pub const COEF_FRAC: u32 = 16;

/// Fraction bits of the lead pole `a1` ([`Pole`]); equal to [`COEF_FRAC`] so that the three
/// products of the lead section accumulate in one format.
pub const POLE_FRAC: u32 = 16;

/// Bound on the lead section's output, in comparator LSBs: the configuration is refused unless
/// it provably keeps `|lead| <= LEAD_LIMIT` for every input stream.
pub const LEAD_LIMIT: i32 = 1 << 30;

/// Bound on the integrator, in its own format (comparator LSBs with [`COEF_FRAC`] extra
/// fraction bits): `±1.0` full scale. This clamp is the anti-windup.
pub const INTEGRATOR_LIMIT: i64 = (RAMP_AMPLITUDE as i64) << COEF_FRAC;

/// Largest supported number of clock ticks per limit cycle.
pub const MAX_TICKS_PER_CYCLE: u16 = 4096;

const _: () = {
    // The formats must leave room for the sums they feed (see ARITHMETIC.md, "Bounds").
    assert!(LEVEL_FRAC + 2 <= 31);
    assert!(RAMP_AMPLITUDE % MAX_TICKS_PER_CYCLE as i32 == 0);
    assert!((LEAD_LIMIT as i64) + (INTEGRATOR_LIMIT >> COEF_FRAC) <= i32::MAX as i64);
    // One accumulator format for the whole lead section: no shifts between products.
    assert!(POLE_FRAC == COEF_FRAC);
};
