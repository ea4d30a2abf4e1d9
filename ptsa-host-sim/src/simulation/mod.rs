//! The simulation: the closed loop tick by tick, and the engine that runs many.
//!
//! * [`sim`]: the closed loop and the charge-balance estimator; [`sim::simulate_condition`]
//!   and [`sim::simulate_difference`] are the entry points.
//! * `kernel`: the tick of a static condition, once, for any number of loops side by side.
//! * [`batch`]: many independent closed loops, lanes per core, all cores.
//! * [`work`]: work estimated before it runs and counted while it runs (ticks, stages).

pub mod batch;
pub(crate) mod kernel;
pub mod sim;
pub mod work;
