//! The report's test programme, one experiment per file. Each takes the instrument, the run
//! options and its own parameters (whose defaults are the report's plan, defined once here),
//! and returns a named result with its [`Output`](crate::output::Output): tables, figures and
//! summary lines, each file named after what it holds.
//!
//! * [`tumble`]: section 6.1, SF and bias from ±1 g (eqs. 6.1–6.4) and a 360° sweep;
//! * [`anisoinertia`]: Table 6.1 on the dividing head and rate table (eq. 6.5);
//! * [`oa_coupling`]: Tables 6.2 and 6.3 on the angular oscillator;
//! * [`appendix_a`]: vibropendulosity, anisoelasticity and sculling on the two-axis
//!   oscillator (Figs. A.2, A.4, A.5);
//! * [`waveform`]: Fig. 3.2's waveforms; [`frequency_response`]: the closed loop's small
//!   signal response against the linear model; [`limit_cycle`]: the limit cycle across and
//!   beyond the range;
//! * [`monte_carlo`]: margins over Table 2.1's tolerance box;
//! * [`design`]: the compensator and the loop's margins as text.

pub mod anisoinertia;
pub mod appendix_a;
pub mod design;
pub mod frequency_response;
pub mod limit_cycle;
pub mod monte_carlo;
pub mod oa_coupling;
pub mod tumble;
pub mod waveform;
