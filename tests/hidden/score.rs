//! The scoring of the pipeline's blind answer on one set.

use ptsa_host_sim::discovery::Discovery;

use super::generate::{HiddenSet, Truth};

/// How the pipeline did on one set.
#[derive(Clone, Debug)]
// Independent yes/no outcomes, each counted.
#[allow(clippy::struct_excessive_bools)]
pub struct Outcome {
    /// What was hidden.
    pub truth: Truth,
    /// The hidden candidate itself is selected, within its plausibility bound.
    pub exact: bool,
    /// The hidden candidate is not selected but is in a selected one's `confounded`.
    pub partner_only: bool,
    /// The hidden candidate is selected but reported implausible.
    pub implausible: bool,
    /// For an exact selection, `(estimate − truth)/stderr`.
    pub z: Option<f64>,
    /// Selections other than the hidden candidate and the partners that name it.
    pub others: usize,
    /// Anything selected.
    pub any_selection: bool,
    /// A plausible selection while the test for unexplained structure found nothing: a named
    /// cause the output does not warn about.
    pub confident_misnaming: bool,
    /// The test for unexplained structure fired.
    pub unexplained: bool,
    /// What was selected (`?` after an implausible one), for the log.
    pub selected: Vec<String>,
    /// Rows the pipeline flagged as suspected gross errors (none was injected: every one
    /// is a false alarm of the outlier test).
    pub outliers: Vec<String>,
    /// The pipeline refused the set.
    pub error: Option<String>,
}

/// Score the pipeline's answer `d` for `set`.
#[must_use]
pub fn score(set: &HiddenSet, d: &Discovery) -> Outcome {
    let t = &set.truth;
    let mut o = Outcome::blank(t);
    let mut partner = false;
    for s in &d.selected {
        if Some(s.id) == t.candidate {
            if s.plausible {
                o.exact = true;
                o.z = Some((s.coef - t.coef) / s.stderr);
            } else {
                o.implausible = true;
            }
        } else if t
            .candidate
            .is_some_and(|h| s.confounded.iter().any(|&(c, _)| c == h))
        {
            partner = true;
        } else {
            o.others += 1;
        }
    }
    o.partner_only = partner && !o.exact && !o.implausible;
    o.any_selection = !d.selected.is_empty();
    o.unexplained = d.json.unexplained.detected;
    o.confident_misnaming = d.selected.iter().any(|s| s.plausible) && !o.unexplained;
    o.outliers = d.json.outliers.iter().map(|x| x.row.clone()).collect();
    o.selected = d
        .selected
        .iter()
        .map(|s| {
            let mut n = s.id.info().name.to_string();
            if !s.plausible {
                n.push('?');
            }
            n
        })
        .collect();
    o
}

impl Outcome {
    /// Nothing selected.
    #[must_use]
    pub fn blank(t: &Truth) -> Self {
        Outcome {
            truth: t.clone(),
            exact: false,
            partner_only: false,
            implausible: false,
            z: None,
            others: 0,
            any_selection: false,
            confident_misnaming: false,
            unexplained: false,
            selected: Vec::new(),
            outliers: Vec::new(),
            error: None,
        }
    }

    /// Named exactly or only as a confounded partner.
    #[must_use]
    pub fn exact_or_partner(&self) -> bool {
        self.exact || self.partner_only
    }

    /// One line for the log.
    #[must_use]
    pub fn line(&self, seed: u64) -> String {
        let t = &self.truth;
        let verdict = if self.exact {
            "exact"
        } else if self.partner_only {
            "partner only"
        } else if self.implausible {
            "named implausible"
        } else if t.candidate.is_some() {
            "missed"
        } else {
            "-"
        };
        format!(
            "{:<26} seed {seed:<20} {:>5.1} SE{} {:<22} {:>2} rows  sigma {}{}{}{}{} -> [{}]{}  {}{}{}{}",
            t.kind.name(),
            t.strength_se,
            if t.capped { "*" } else { " " },
            t.design.name(),
            t.rows,
            t.sigma,
            if t.sigma_written {
                ""
            } else {
                " (not written)"
            },
            if t.blocks > 1 {
                format!(", {} blocks", t.blocks)
            } else {
                String::new()
            },
            if t.time_written { ", time_s" } else { "" },
            t.outside_vocabulary.map_or(String::new(), |x| format!(
                ", {x:.2} outside the vocabulary"
            )),
            self.selected.join(", "),
            if self.unexplained {
                " + unexplained"
            } else {
                ""
            },
            verdict,
            self.z.map_or(String::new(), |z| format!(" z {z:+.2}")),
            if self.outliers.is_empty() {
                String::new()
            } else {
                format!("  outliers: {}", self.outliers.join(", "))
            },
            self.error
                .as_ref()
                .map_or(String::new(), |e| format!(" error: {e}"))
        )
    }
}
