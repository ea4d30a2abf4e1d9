//! The reading's units: what a record of readings may be given in, and the nominal scale
//! that turns a reading into cm/s².

use super::Instrument;

/// The unit of a raw reading (a case-frame `reading_unit`, an instrument file's
/// `instrument.reading_unit`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReadingUnit {
    /// Volts (an analogue output).
    Volt,
    /// Milliamperes (a servo accelerometer's current output).
    MilliAmp,
    /// Least significant bits of a digital output.
    Lsb,
    /// g, local gravity (the instrument file's `local_gravity_cm_s2`).
    G,
    /// m/s².
    MPerS2,
    /// cm/s².
    CmPerS2,
}

impl ReadingUnit {
    /// Every unit, in the order messages list them.
    pub const ALL: &[ReadingUnit] = &[
        ReadingUnit::Volt,
        ReadingUnit::MilliAmp,
        ReadingUnit::Lsb,
        ReadingUnit::G,
        ReadingUnit::MPerS2,
        ReadingUnit::CmPerS2,
    ];

    /// Its name as written in files: `V`, `mA`, `LSB`, `g`, `m/s²`, `cm/s²`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            ReadingUnit::Volt => "V",
            ReadingUnit::MilliAmp => "mA",
            ReadingUnit::Lsb => "LSB",
            ReadingUnit::G => "g",
            ReadingUnit::MPerS2 => "m/s²",
            ReadingUnit::CmPerS2 => "cm/s²",
        }
    }

    /// The unit written `s` (its name, or `m/s2`, `m/s^2`, `cm/s2`, `cm/s^2`).
    #[must_use]
    pub fn parse(s: &str) -> Option<Self> {
        let s = s.trim();
        let s = s.replace("s^2", "s²").replace("s2", "s²");
        ReadingUnit::ALL.iter().copied().find(|u| u.name() == s)
    }

    /// The names of every unit, for messages: `V, mA, LSB, g, m/s², cm/s²`.
    #[must_use]
    pub fn names() -> String {
        ReadingUnit::ALL
            .iter()
            .map(|u| u.name())
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// A unit of acceleration, converted by its definition (g with the file's local
    /// gravity); the others (V, mA, LSB) only through a nominal scale factor.
    #[must_use]
    pub fn is_physical(self) -> bool {
        matches!(
            self,
            ReadingUnit::G | ReadingUnit::MPerS2 | ReadingUnit::CmPerS2
        )
    }
}

/// The nominal scale of an instrument's raw reading: `per_g` reading units per g of input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReadingScale {
    /// The reading's unit (V, mA or LSB).
    pub unit: ReadingUnit,
    /// Nominal scale factor, reading units per g (local gravity).
    pub per_g: f64,
}

impl Instrument {
    /// A raw reading `value` in `unit`, in cm/s²: a unit of acceleration by its definition
    /// (g with the file's local gravity), V, mA or LSB through the file's nominal scale
    /// factor when the file gives one in that unit.
    ///
    /// # Errors
    /// A reading in V, mA or LSB when the file gives no scale in that unit (the message
    /// names the keys to add).
    pub fn reading_to_cm_s2(&self, value: f64, unit: ReadingUnit) -> Result<f64, String> {
        match unit {
            ReadingUnit::CmPerS2 => Ok(value),
            ReadingUnit::MPerS2 => Ok(value * 100.0),
            ReadingUnit::G => Ok(value * self.g_cm_s2),
            _ => match self.reading_scale {
                Some(sc) if sc.unit == unit => Ok(value / sc.per_g * self.g_cm_s2),
                Some(sc) => Err(format!(
                    "a reading in {} needs a nominal scale factor in {} per g; the instrument file gives one in {} per g (instrument.reading_unit = \"{}\")",
                    unit.name(),
                    unit.name(),
                    sc.unit.name(),
                    sc.unit.name()
                )),
                None => Err(format!(
                    "a reading in {} needs the instrument file's nominal scale factor: expected instrument.reading_unit = \"{}\" and instrument.scale_factor_per_g (in {} per g) in its [instrument] table",
                    unit.name(),
                    unit.name(),
                    unit.name()
                )),
            },
        }
    }
}
