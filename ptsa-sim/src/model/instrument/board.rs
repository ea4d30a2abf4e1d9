//! The board's front end (`[board]`): the ADC's format and the torquer's current, as the
//! firmware sees them.

use ptsa_core::adc::{AdcFormat, Coding};

/// The board's front end (`[board]` of the instrument file): the converter that delivers the
/// tick's sample and the analogue stage in front of it. The amplifier's output
/// (`electronics.amplifier_gain` times the demodulated pickoff, plus
/// `electronics.adc_offset_mv`) goes through the front end, `v_pin = front_end_gain · v +
/// front_end_offset_v`, into the converter ([`ptsa_core::adc`]). The converter's range then
/// spans ±`adc_reference_v / 2 / front_end_gain` at the amplifier's output: the file's
/// `electronics.adc_full_scale_v` must say the same (it is the full scale the compensator is
/// designed for).
#[derive(Debug, Clone, PartialEq)]
pub struct Board {
    /// `board.name`, if given.
    pub name: Option<String>,
    /// Resolution, coding and alignment of the converter.
    pub adc: AdcFormat,
    /// Width of the converter's input range, V (`0..V_REF` offset binary, `±V_REF/2` two's
    /// complement).
    pub reference_v: f64,
    /// Gain from the amplifier's output to the converter's pin, V/V.
    pub front_end_gain: f64,
    /// Voltage at the converter's pin for 0 V at the amplifier's output, V (the level
    /// shift: `V_REF/2` centres a unipolar converter).
    pub front_end_offset_v: f64,
    /// The torquer current the board's current source is set to, mA, when the file gives it
    /// (it then sets [`super::Instrument::full_current_ma`]).
    pub torquer_current_ma: Option<f64>,
}

impl Board {
    /// The constant of the conversion that places the input in the converter's range and
    /// rounds, in units of the `i16` sample: half a step, plus 2^15 for a bipolar range.
    #[must_use]
    pub fn round_term(&self) -> f64 {
        let half = f64::from(self.adc.step()) / 2.0;
        match self.adc.coding() {
            Coding::OffsetBinary => half,
            Coding::TwosComplement => 32768.0 + half,
        }
    }

    /// The converter's full scale at the amplifier's output, ±V:
    /// `adc_reference_v / 2 / front_end_gain`.
    #[must_use]
    pub fn full_scale_v(&self) -> f64 {
        self.reference_v / 2.0 / self.front_end_gain
    }
}
