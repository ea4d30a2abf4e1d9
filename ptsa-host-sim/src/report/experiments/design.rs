//! The compensator designed for the instrument file and the margins of the loop it makes.

use crate::model::design::{Design, margins};
use crate::model::instrument::Instrument;
use crate::report::{Experiment, Finding, Setup, Sink};
use crate::simulation::work::Estimate;

/// The design (text) for an instrument, with the margins of the linearised loop.
#[must_use]
pub fn text(instr: &Instrument) -> String {
    let d = Design::for_instrument(instr);
    let m = margins(instr, &d.config());
    format!(
        "{d}  margins (linearised loop incl. delay, current lag, demodulator): crossover {:.1} Hz, phase margin {:.1} deg, gain margin {:.1} dB\n",
        m.crossover_hz, m.phase_margin_deg, m.gain_margin_db
    )
}

/// The step of the report programme (see [`crate::report::Experiment`]).
#[derive(Clone, Copy, Debug)]
pub struct Step;

impl Experiment for Step {
    fn name(&self) -> &'static str {
        "design"
    }

    fn work(&self, s: Setup<'_>) -> anyhow::Result<Estimate> {
        let _ = s;
        Ok(Estimate::default())
    }

    fn run(&self, s: Setup<'_>, to: &mut Sink<'_>) -> anyhow::Result<Finding> {
        let t = text(s.instr);
        crate::output::write_atomic(&to.dir.join("design.txt"), t.as_bytes())?;
        Ok(Finding::Design(t))
    }
}
