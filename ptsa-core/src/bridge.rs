//! H-bridge driver over two embedded-hal output pins.

use embedded_hal::digital::OutputPin;

use crate::Polarity;

/// Error from one of the two legs.
///
/// It displays the failing leg and the pin's own error (by its `Debug` form, since
/// embedded-hal's pin errors need not implement `Display`):
///
/// ```
/// use ptsa_core::BridgeError;
/// let e: BridgeError<u8, ()> = BridgeError::LegA(3);
/// assert_eq!(e.to_string(), "H-bridge leg A: pin error 3");
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BridgeError<A, B> {
    /// Leg A's pin failed.
    LegA(A),
    /// Leg B's pin failed.
    LegB(B),
}

impl<A: core::fmt::Debug, B: core::fmt::Debug> core::fmt::Display for BridgeError<A, B> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::LegA(e) => write!(f, "H-bridge leg A: pin error {e:?}"),
            Self::LegB(e) => write!(f, "H-bridge leg B: pin error {e:?}"),
        }
    }
}

impl<A: core::fmt::Debug, B: core::fmt::Debug> core::error::Error for BridgeError<A, B> {}

/// The torquer's H-bridge (the PTSA's four-transistor switch), driven as two legs.
///
/// [`Polarity::Positive`] is leg A high and leg B low; [`Polarity::Negative`] the reverse.
/// On a change the leg that goes low is written first (break before make), and pins are
/// written only when the polarity changes, so a steady polarity costs no pin writes.
///
/// ```
/// use embedded_hal_mock::eh1::digital::{Mock, State, Transaction as T};
/// use ptsa_core::{HBridge, Polarity};
///
/// let a = Mock::new(&[T::set(State::Low), T::set(State::High), T::set(State::Low)]);
/// let b = Mock::new(&[T::set(State::Low), T::set(State::Low), T::set(State::High)]);
/// let mut bridge = HBridge::new(a, b).unwrap();
/// bridge.set(Polarity::Positive).unwrap();
/// bridge.set(Polarity::Positive).unwrap(); // no change: no writes
/// bridge.set(Polarity::Negative).unwrap();
/// let (mut a, mut b) = bridge.release();
/// a.done();
/// b.done();
/// ```
#[derive(Debug)]
pub struct HBridge<A, B> {
    leg_a: A,
    leg_b: B,
    current: Option<Polarity>,
}

impl<A: OutputPin, B: OutputPin> HBridge<A, B> {
    /// Take the two legs and drive both low (no torquer current).
    ///
    /// # Errors
    /// The first pin error.
    pub fn new(mut leg_a: A, mut leg_b: B) -> Result<Self, BridgeError<A::Error, B::Error>> {
        leg_a.set_low().map_err(BridgeError::LegA)?;
        leg_b.set_low().map_err(BridgeError::LegB)?;
        Ok(Self {
            leg_a,
            leg_b,
            current: None,
        })
    }

    /// Drive the torquer current in `polarity`.
    ///
    /// # Errors
    /// The first pin error; the bridge then counts as undriven and the next call writes
    /// both legs again.
    pub fn set(&mut self, polarity: Polarity) -> Result<(), BridgeError<A::Error, B::Error>> {
        if self.current == Some(polarity) {
            return Ok(());
        }
        self.current = None;
        match polarity {
            Polarity::Positive => {
                self.leg_b.set_low().map_err(BridgeError::LegB)?;
                self.leg_a.set_high().map_err(BridgeError::LegA)?;
            }
            Polarity::Negative => {
                self.leg_a.set_low().map_err(BridgeError::LegA)?;
                self.leg_b.set_high().map_err(BridgeError::LegB)?;
            }
        }
        self.current = Some(polarity);
        Ok(())
    }

    /// The polarity the bridge is driving, if any.
    #[must_use]
    pub fn polarity(&self) -> Option<Polarity> {
        self.current
    }

    /// Give the pins back (they keep their last level).
    pub fn release(self) -> (A, B) {
        (self.leg_a, self.leg_b)
    }
}
