//! `noise --counts FILE --compare`: the record against the loop of the instrument file,
//! simulated as long as the record, with its gate, at the acceleration that gives its mean.

use std::fmt::Write as _;

use anyhow::Result;

use super::json::ComparisonJson;
use super::{Analysis, Compared, Record};
use crate::model::instrument::Instrument;
use crate::output::significant as sig;
use crate::simulation::sim::SimOptions;

/// The record against the simulated loop (`--compare`).
#[derive(Clone, Debug)]
pub struct Comparison {
    /// The acceleration along IA simulated, cm/s².
    pub input_cm_s2: f64,
    /// The simulated record's mean, cm/s².
    pub simulated_mean_cm_s2: f64,
    /// The two deviations at each averaging time, and whether they differ.
    pub points: Vec<Compared>,
}

impl Comparison {
    /// Simulate the loop of `instr` with `opts` as long as `record`, with its gate, at the
    /// acceleration along IA that gives the mean of `measured` (its analysis), and compare
    /// the deviations tau by tau.
    ///
    /// # Errors
    /// The simulated record is refused by the record's checks (a loop that cannot count).
    pub fn simulate(
        instr: &Instrument,
        opts: &SimOptions,
        record: &Record,
        measured: &Analysis,
    ) -> Result<Self> {
        let ticks = record.gates[0].ticks;
        let gates = record.gates.len() as u64;
        let input_cm_s2 = measured.mean_cm_s2 - instr.bias_cm_s2 - instr.loop_bias_cm_s2(0.0);
        let g = super::simulate_record(instr, opts, input_cm_s2, ticks, gates);
        let lines: Vec<usize> = (0..g.len()).map(|k| k + 1).collect();
        let sim = super::check_record("the simulated record", g, &lines, instr.clock_hz)?;
        let s = Analysis::of(&sim, instr.sf_cm_s2, instr.clock_hz);
        Ok(Self {
            input_cm_s2,
            simulated_mean_cm_s2: s.mean_cm_s2,
            points: super::compare(&measured.points, &s.points),
        })
    }

    /// The warning on the record `name` when the deviations differ at some tau.
    #[must_use]
    pub fn warning(&self, name: &str) -> Option<String> {
        let n = self.points.iter().filter(|p| p.differs).count();
        (n > 0).then(|| {
            format!(
                "{name}: the simulated loop's Allan deviation differs from the record's at {} of {} taus (Holm, 5 % familywise): the instrument file's noise is not the instrument's there",
                n,
                self.points.len()
            )
        })
    }

    /// The JSON's `comparison`.
    #[must_use]
    pub fn json(&self) -> ComparisonJson {
        ComparisonJson::new(self.input_cm_s2, self.simulated_mean_cm_s2, &self.points)
    }

    /// The table `noise --compare` prints.
    #[must_use]
    pub fn text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "against the simulated loop ({} cm/s^2 along IA, simulated mean {} cm/s^2); differs: Holm at 5 % familywise over the taus:",
            sig(self.input_cm_s2, 8),
            sig(self.simulated_mean_cm_s2, 8)
        );
        let _ = writeln!(
            s,
            "{:>12} {:>12} {:>25} {:>12} {:>25} {:>8} {:>8}",
            "tau_s", "measured", "ci95", "simulated", "ci95", "z", "differs"
        );
        for c in &self.points {
            let _ = writeln!(
                s,
                "{:>12} {:>12.5e} {:>25} {:>12.5e} {:>25} {:>8.2} {:>8}",
                sig(c.measured.tau_s, 6),
                c.measured.adev,
                format!("[{:.4e}, {:.4e}]", c.measured.ci95_lo, c.measured.ci95_hi),
                c.simulated.adev,
                format!("[{:.4e}, {:.4e}]", c.simulated.ci95_lo, c.simulated.ci95_hi),
                c.z,
                if c.differs { "yes" } else { "no" }
            );
        }
        s
    }
}
