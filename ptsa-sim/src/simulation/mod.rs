//! The simulation: the closed loop tick by tick, and the engine that runs many.
//!
//! * `config`: a loop's configuration, built once from the instrument file, the condition,
//!   the effects and the options; what every tick reads.
//! * `state`: a loop's state, plain data; what every tick changes.
//! * `noise`: the pickoff noise source.
//! * `kernel`: the tick of a static and of a dynamic condition, once, for any number of
//!   loops side by side (`(&config, &mut state)` lanes).
//! * [`simd`]: which SIMD instructions the batch engine's kernels use (the CPU's best, or
//!   fewer with `PTSA_SIMD`); `avx512`, `avx2`: eight lanes of the core's tick in AVX-512 or
//!   AVX2 registers (each a `ptsa_core::LaneOps`), which the kernels of eight run.
//! * [`sim`]: the closed loop [`sim::ClosedLoop`] (one configuration and one state), the
//!   charge-balance estimator; [`sim::simulate_condition`] and [`sim::simulate_difference`]
//!   are the entry points.
//! * [`batch`]: many independent closed loops, lanes per core, all cores: a scheduler of the
//!   kernels over the loops' configurations and states.
//! * [`pil`]: the parameters of the firmware's processor-in-the-loop image and the host's
//!   gates of the same run.
//! * [`work`]: work estimated before it runs and counted while it runs (ticks, stages).

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
mod avx512;
pub mod batch;
mod config;
mod kernel;
#[cfg(all(test, target_arch = "x86_64"))]
mod lane_tests;
mod noise;
pub mod pil;
pub mod sim;
pub mod simd;
mod state;
pub mod work;
pub mod yield_study;
