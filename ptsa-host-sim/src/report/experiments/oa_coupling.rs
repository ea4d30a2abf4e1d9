//! Section 6.3, Tables 6.2 and 6.3: single-axis angular oscillation about OA, IA horizontal
//! then vertical.
//!
//! Sign convention: every number here is **dynamic − static** (the condition minus its
//! reference at rest), the case frame's `measured_cm_s2`; the report tabulates
//! static − dynamic, so its values appear negated.

use anyhow::Result;
use rayon::prelude::*;

use crate::lab::fixtures;
use crate::model::effects::Effects;
use crate::model::instrument::Instrument;
use crate::output::{Figure, Output, Plot, Series, Table, XAxis, num, opt};
use crate::report::r890;
use crate::report::{Experiment, Finding, Setup, Sink, ticks_only};
use crate::simulation::sim::{SimOptions, simulate_difference};
use crate::simulation::work::Estimate;

/// One row of the OA-coupling experiment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OaRow {
    /// IA vertical (Table 6.3) or horizontal (Table 6.2).
    pub ia_vertical: bool,
    /// Frequency, Hz.
    pub freq_hz: f64,
    /// Amplitude, mrad (None: not measured, system resonance).
    pub amp_mrad: Option<f64>,
    /// Report's difference as dynamic − static (its static − dynamic negated), cm/s².
    pub report: Option<f64>,
    /// Simulated dynamic − static output, cm/s².
    pub simulated: Option<f64>,
    /// Largest `|θ|` during the run, rad.
    pub theta_max_rad: Option<f64>,
}

/// What [`run`] returns.
#[derive(Clone, Debug, PartialEq)]
pub struct OaRun {
    /// Table 6.2's rows, then Table 6.3's.
    pub rows: Vec<OaRow>,
    /// Tables, figures, notes.
    pub output: Output,
    /// Largest simulated |dynamic − static|, cm/s².
    pub max_simulated_cm_s2: f64,
    /// RMS of the report's rows, cm/s².
    pub report_rms_cm_s2: f64,
    /// The report's test uncertainty (section 6.1), cm/s².
    pub sigma_cm_s2: f64,
}

impl OaRun {
    /// The verdict in words, from the figures (not assumed): whether the simulated loop
    /// rectifies above the test uncertainty, and whether the report's rows scatter within
    /// it (RMS at most 1.5 σ, about where a χ² of so few rows stops being plausible).
    #[must_use]
    pub fn verdict(&self) -> String {
        let sim = if self.max_simulated_cm_s2 < self.sigma_cm_s2 {
            format!(
                "the simulated loop rectifies at most {:.4} cm/s², below the {} cm/s² test uncertainty",
                self.max_simulated_cm_s2, self.sigma_cm_s2
            )
        } else {
            format!(
                "the simulated loop rectifies up to {:.4} cm/s², above the {} cm/s² test uncertainty",
                self.max_simulated_cm_s2, self.sigma_cm_s2
            )
        };
        let rep = if self.report_rms_cm_s2 <= 1.5 * self.sigma_cm_s2 {
            format!(
                "the report's rows scatter with RMS {:.3} cm/s², within that uncertainty, so they show no rectified OA coupling, as the report concluded",
                self.report_rms_cm_s2
            )
        } else {
            format!(
                "the report's rows scatter with RMS {:.3} cm/s², more than that uncertainty explains: something in them is not noise",
                self.report_rms_cm_s2
            )
        };
        format!("{sim}; {rep}")
    }
}

/// The closed-loop ticks [`run`] runs: every row of Tables 6.2 and 6.3 with an amplitude,
/// as a difference.
///
/// # Errors
/// The report's transcriptions are malformed.
pub fn work(
    instr: &Instrument,
    opts: &SimOptions,
    lever_cm: [f64; 3],
) -> Result<crate::simulation::work::Ticks> {
    let mut t = crate::simulation::work::Ticks::ZERO;
    for (v, rows) in [(false, r890::table_6_2()?), (true, r890::table_6_3()?)] {
        for r in rows {
            if let Some(a) = r.amp_mrad {
                let s = fixtures::angular_oscillator(r.freq_hz, a, v, lever_cm);
                t += crate::simulation::work::difference(instr, &s.cond, opts);
            }
        }
    }
    Ok(t)
}

/// Tables 6.2 and 6.3 with the proof mass at `lever_cm` (IA, PA, OA) from the table axis, cm.
///
/// # Errors
/// The report's transcriptions are malformed.
pub fn run(instr: &Instrument, opts: &SimOptions, lever_cm: [f64; 3]) -> Result<OaRun> {
    let mut cases = Vec::new();
    for r in r890::table_6_2()? {
        cases.push((false, r));
    }
    for r in r890::table_6_3()? {
        cases.push((true, r));
    }
    let rows: Vec<OaRow> = cases
        .par_iter()
        .map(|&(v, r)| {
            let (sim, th) = match r.amp_mrad {
                Some(a) => {
                    let s = fixtures::angular_oscillator(r.freq_hz, a, v, lever_cm);
                    let d = simulate_difference(instr, &s.cond, &s.effects(&Effects::NONE), opts);
                    (Some(d.difference_cm_s2), Some(d.condition.theta_max_rad))
                }
                None => (None, None),
            };
            OaRow {
                ia_vertical: v,
                freq_hz: r.freq_hz,
                amp_mrad: r.amp_mrad,
                report: r.static_minus_dynamic_cm_s2.map(|x| -x),
                simulated: sim,
                theta_max_rad: th,
            }
        })
        .collect();
    let mut tables = Vec::new();
    let mut plots = Vec::new();
    for (v, stem, title) in [
        (
            false,
            "oa-coupling-table-6-2",
            "Table 6.2: OA coupling, IA horizontal (dynamic − static)",
        ),
        (
            true,
            "oa-coupling-table-6-3",
            "Table 6.3: OA coupling, IA vertical (dynamic − static)",
        ),
    ] {
        let (t, figure) = table_and_figure(&rows, v, stem, title);
        tables.push(t);
        plots.push(figure);
    }
    let max_sim = rows
        .iter()
        .filter_map(|r| r.simulated)
        .fold(0.0f64, |m, x| m.max(x.abs()));
    let rms_rep = {
        let v: Vec<f64> = rows.iter().filter_map(|r| r.report).collect();
        #[allow(clippy::cast_precision_loss)]
        let n = v.len().max(1) as f64;
        (v.iter().map(|x| x * x).sum::<f64>() / n).sqrt()
    };
    let sigma = r890::section_6_1()?.test_uncertainty_cm_s2;
    let mut run = OaRun {
        rows,
        output: Output {
            tables,
            plots,
            notes: Vec::new(),
        },
        max_simulated_cm_s2: max_sim,
        report_rms_cm_s2: rms_rep,
        sigma_cm_s2: sigma,
    };
    run.output
        .notes
        .push(format!("oa-coupling: {}", run.verdict()));
    Ok(run)
}

/// The table and figure of the `rows` with IA vertical (`v`) or horizontal.
fn table_and_figure(rows: &[OaRow], v: bool, stem: &str, title: &str) -> (Table, Figure) {
    let mut t = Table::new(
        stem,
        title,
        &[
            "freq Hz",
            "amp mrad",
            "report dynamic-static cm/s^2",
            "simulated dynamic-static cm/s^2",
            "max |theta| urad",
        ],
    );
    let mine: Vec<&OaRow> = rows.iter().filter(|r| r.ia_vertical == v).collect();
    for r in &mine {
        t.rows.push(vec![
            num(r.freq_hz, 1),
            opt(r.amp_mrad, 1),
            opt(r.report, 2),
            opt(r.simulated, 4),
            opt(r.theta_max_rad.map(|x| x * 1e6), 1),
        ]);
    }
    let figure = Figure::single(
        stem,
        Plot {
            title: title.into(),
            x_label: "frequency, Hz".into(),
            y_label: "dynamic − static output, cm/s^2".into(),
            series: vec![
                Series::crosses(
                    "report (negated: dynamic − static)",
                    mine.iter()
                        .filter_map(|r| r.report.map(|x| (r.freq_hz, x)))
                        .collect(),
                ),
                Series::markers(
                    "simulated",
                    mine.iter()
                        .filter_map(|r| r.simulated.map(|x| (r.freq_hz, x)))
                        .collect(),
                ),
            ],
            x_axis: XAxis::Log,
            zero_line: true,
        },
    );
    (t, figure)
}

/// The step of the report programme (see [`crate::report::Experiment`]).
#[derive(Clone, Copy, Debug)]
pub struct Step;

impl Experiment for Step {
    fn name(&self) -> &'static str {
        "oa-coupling"
    }

    fn work(&self, s: Setup<'_>) -> Result<Estimate> {
        Ok(ticks_only(work(s.instr, s.opts, [0.0; 3])?))
    }

    fn run(&self, s: Setup<'_>, to: &mut Sink<'_>) -> Result<Finding> {
        let r = run(s.instr, s.opts, [0.0; 3])?;
        to.emit(&r.output)?;
        Ok(Finding::OaCoupling(r))
    }
}
