//! The compensator designed for the instrument file and the margins of the loop it makes.

use crate::model::design::{Design, margins};
use crate::model::instrument::Instrument;

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
