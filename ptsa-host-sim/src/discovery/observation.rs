//! What a row is observed as, measured or simulated: a difference or absolute row's value
//! in cm/s², or a response row's gain and phase ([`Observation`]); and which of those an
//! observation of the fitted data is ([`Quantity`]).

use crate::model::condition::RowKind;

/// What an observation of a row is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    /// `measured_cm_s2` of a difference or absolute row, cm/s².
    Value,
    /// A response row's gain.
    Gain,
    /// A response row's phase, degrees.
    Phase,
}

impl Quantity {
    /// Its unit.
    #[must_use]
    pub fn unit(self) -> &'static str {
        match self {
            Quantity::Value => "cm/s²",
            Quantity::Gain => "",
            Quantity::Phase => "deg",
        }
    }
}

/// A row's observations as a simulator predicts them (or their scatter): one value for a
/// difference or absolute row, a gain and a phase for a response row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Observation {
    /// A difference row's condition − reference or an absolute row's indicated
    /// acceleration, cm/s².
    Value(f64),
    /// A response row's gain (output amplitude over input amplitude) and phase (output
    /// minus input), degrees.
    Response {
        /// Gain, dimensionless.
        gain: f64,
        /// Phase, degrees.
        phase_deg: f64,
    },
}

impl Observation {
    /// The observation of a row of kind `kind` with every quantity `x` (0 for "no
    /// scatter").
    #[must_use]
    pub fn uniform(kind: RowKind, x: f64) -> Self {
        match kind {
            RowKind::Response => Observation::Response {
                gain: x,
                phase_deg: x,
            },
            RowKind::Difference | RowKind::Absolute => Observation::Value(x),
        }
    }

    /// Its quantity `q`; `None` when it has none (a value's gain, a response's value).
    #[must_use]
    pub fn get(&self, q: Quantity) -> Option<f64> {
        match (*self, q) {
            (Observation::Value(v), Quantity::Value) => Some(v),
            (Observation::Response { gain, .. }, Quantity::Gain) => Some(gain),
            (Observation::Response { phase_deg, .. }, Quantity::Phase) => Some(phase_deg),
            _ => None,
        }
    }

    /// Its quantities and their values, in order: `[(Value, v)]` or `[(Gain, gain),
    /// (Phase, phase)]`.
    #[must_use]
    pub fn entries(&self) -> Vec<(Quantity, f64)> {
        match *self {
            Observation::Value(v) => vec![(Quantity::Value, v)],
            Observation::Response { gain, phase_deg } => {
                vec![(Quantity::Gain, gain), (Quantity::Phase, phase_deg)]
            }
        }
    }

    /// The values alone, in order: `[cm/s²]` or `[gain, phase_deg]` (the flat form of the
    /// CLI's prediction table and of [`super::sim::runs_of`]).
    #[must_use]
    pub fn values(&self) -> Vec<f64> {
        self.entries().into_iter().map(|(_, x)| x).collect()
    }

    /// Whether `other` holds the same quantities (a value, or a gain and a phase).
    #[must_use]
    pub fn same_kind(&self, other: &Observation) -> bool {
        matches!(
            (self, other),
            (Observation::Value(_), Observation::Value(_))
                | (Observation::Response { .. }, Observation::Response { .. })
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_observation_holds_only_its_own_quantities() {
        let v = Observation::Value(2.5);
        let r = Observation::Response {
            gain: 0.9,
            phase_deg: -12.0,
        };
        assert_eq!(v.get(Quantity::Value), Some(2.5));
        assert_eq!(v.get(Quantity::Gain), None);
        assert_eq!(r.get(Quantity::Value), None);
        assert_eq!(r.get(Quantity::Phase), Some(-12.0));
        assert_eq!(r.values(), [0.9, -12.0]);
        assert!(!v.same_kind(&r) && r.same_kind(&Observation::uniform(RowKind::Response, 0.0)));
        assert_eq!(
            Observation::uniform(RowKind::Difference, 0.0),
            Observation::Value(0.0)
        );
    }
}
