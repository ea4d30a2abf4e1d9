//! The simulation: the closed loop tick by tick, and the engine that runs many.
//!
//! * `config`: a loop's configuration, built once from the instrument file, the condition,
//!   the effects and the options; what every tick reads.
//! * `state`: a loop's state, plain data; what every tick changes.
//! * `noise`: the pickoff noise source.
//! * `kernel`: the tick of a static and of a dynamic condition, once, for any number of
//!   loops side by side (`(&config, &mut state)` lanes).
//! * `avx512`: eight lanes of the core's tick in AVX-512 registers (a `ptsa_core::LaneOps`),
//!   which the batch engine's static kernel runs on a CPU that has them.
//! * [`sim`]: the closed loop [`sim::ClosedLoop`] (one configuration and one state), the
//!   charge-balance estimator; [`sim::simulate_condition`] and [`sim::simulate_difference`]
//!   are the entry points.
//! * [`batch`]: many independent closed loops, lanes per core, all cores: a scheduler of the
//!   kernels over the loops' configurations and states.
//! * [`pil`]: the parameters of the firmware's processor-in-the-loop image and the host's
//!   gates of the same run.
//! * [`work`]: work estimated before it runs and counted while it runs (ticks, stages).

#[cfg(target_arch = "x86_64")]
mod avx512;
pub mod batch;
mod config;
mod kernel;
mod noise;
pub mod pil;
pub mod sim;
mod state;
pub mod work;
