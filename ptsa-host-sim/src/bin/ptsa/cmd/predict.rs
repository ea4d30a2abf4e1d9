//! `ptsa predict`: what the instrument should read in each row of a case-frame file, with
//! the baseline model or a discover result's effects, beside the measured values.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};
use clap::Args;
use ptsa_host_sim::Condition;
use ptsa_host_sim::discovery::{self, Simulator};
use ptsa_host_sim::model::condition::RowKind;
use ptsa_host_sim::model::effects::{CandidateId, Effects, REGISTRY};
use ptsa_host_sim::output::command_json::{PredictJson, PredictedRow};
use ptsa_host_sim::output::{Cell, Column, Table, num, significant, text};
use ptsa_host_sim::simulation::sim::SimOptions;
use ptsa_host_sim::simulation::work::Estimate;

use super::{Ctx, simulator};
use crate::flags::values::seed;
use crate::work;

/// Arguments of `ptsa predict`.
#[derive(Args, Debug, Clone)]
pub struct PredictArgs {
    /// Case-frame CSV file (docs/reference/case-frame-format.md): the conditions to predict (a
    /// `measured_cm_s2` column, if any, is shown beside the prediction).
    #[arg(long, value_name = "FILE")]
    pub data: PathBuf,
    /// The effects to put into the plant: the JSON of `ptsa discover --json` (or its
    /// `effects` array). Without it, the baseline model.
    #[arg(long, value_name = "FILE.json")]
    pub effects: Option<PathBuf>,
    /// Print exactly one JSON object: each row's predicted reading in cm/s² (a response
    /// row's gain and phase) and the simulator used. Every key: docs/reference/json.md.
    #[arg(long)]
    pub json: bool,
    /// Seed of the simulator's pickoff noise (closed loop): a whole number from 0 to
    /// 2^64 − 1, no unit.
    #[arg(long, default_value_t = SimOptions::default().seed, value_name = "N",
          value_parser = seed)]
    pub seed: u64,
    /// Use the quasi-static analytic model instead of the closed loop (always, for an
    /// instrument file without a PTSA loop).
    #[arg(long)]
    pub analytic: bool,
    /// The old spelling of --no-limit, accepted until the next release.
    #[arg(long, hide = true)]
    pub force: bool,
    #[command(flatten)]
    pub limit: crate::flags::LimitArg,
}

/// A prediction to make: the rows read, the effects loaded, the simulator chosen.
pub struct Request {
    /// The data file, for the title.
    data: PathBuf,
    rows: Vec<Condition>,
    effects: Effects,
    /// The standard error of each coefficient the effects file gives one for.
    sigmas: Vec<(CandidateId, f64)>,
    sim: Box<dyn Simulator>,
    json: bool,
    force: bool,
}

impl PredictArgs {
    /// The files the command reads, by their flags: no output may replace them.
    pub fn inputs(&self) -> [(&'static str, Option<&Path>); 2] {
        [
            ("--data", Some(&self.data)),
            ("--effects", self.effects.as_deref()),
        ]
    }

    /// The request: the case-frame file read and checked, the effects file read, the
    /// simulator.
    ///
    /// # Errors
    /// The loop cannot be simulated; a file cannot be read or is not what it should be.
    pub fn request(self, ctx: &Ctx) -> Result<Request> {
        let config = ctx.model_config(self.seed)?;
        let mut frame = ptsa_host_sim::model::caseframe::read_frame(&self.data)?;
        frame.convert_readings(&self.data.display().to_string(), &ctx.instr)?;
        // Counts in: shown as the readings they give with the file's nominal SF.
        let rows = ptsa_host_sim::model::counts::with_counts(&frame.rows, ctx.instr.sf_cm_s2);
        let (effects, sigmas) = match &self.effects {
            Some(p) => load_effects(p)?,
            None => (Effects::NONE, Vec::new()),
        };
        Ok(Request {
            rows,
            effects,
            sigmas,
            sim: simulator(&ctx.instr, config, self.analytic, self.seed),
            json: self.json,
            force: self.force,
            data: self.data,
        })
    }
}

/// Predict every row (refused beyond the work limit without `--no-limit`); the table or the
/// JSON on `out`.
///
/// # Errors
/// Refused work; stdout cannot be written.
pub fn run(req: &Request, out: &mut dyn Write) -> Result<()> {
    let est = estimate(&req.rows, &*req.sim, req.force)?;
    let p = work::Progress::start("predict", &est);
    let pred = discovery::predict(&req.rows, &*req.sim, &req.effects);
    p.finish();
    if req.json {
        writeln!(out, "{}", json(&req.rows, &pred, req.sim.name()))?;
    } else {
        write!(out, "{}", table(req, &pred))?;
        writeln!(
            out,
            "(cm/s²; a difference row is condition − reference, an absolute row the indicated acceleration; a response row's gain is output over input amplitude, its phase output minus input in degrees)"
        )?;
    }
    Ok(())
}

/// The work of `ptsa predict`: one observation of every row, refused beyond the limit
/// without `--force`.
fn estimate(rows: &[Condition], sim: &dyn Simulator, force: bool) -> Result<Estimate> {
    let ticks = sim.pass_cost(&rows.iter().collect::<Vec<_>>());
    work::check(
        Estimate {
            ticks,
            other_s: 0.0,
        },
        force,
        "predict",
        None,
        "fewer rows, or rows of shorter periods",
    )
}

/// `{"rows": [...], "simulator": name}` (`closed-loop`, `analytic`, or `loop-less analytic`
/// for an instrument file without a PTSA loop): a response row has no acceleration to predict, so its
/// `predicted_cm_s2` is null and its gain and phase come as `predicted_gain`,
/// `predicted_phase_deg`.
fn json(rows: &[Condition], pred: &[Vec<f64>], simulator: &str) -> serde_json::Value {
    let rows = rows
        .iter()
        .zip(pred)
        .map(|(r, p)| {
            let response = r.kind == RowKind::Response;
            PredictedRow {
                label: r.label.clone(),
                predicted_cm_s2: if response { None } else { p.first().copied() },
                predicted_gain: response.then(|| p.first().copied()),
                predicted_phase_deg: response.then(|| p.get(1).copied()),
            }
        })
        .collect();
    let v = PredictJson {
        rows,
        simulator: simulator.to_string(),
    };
    serde_json::to_value(v).expect("plain data")
}

/// The prediction table: a title line naming the file, the simulator and the effects, then
/// one line per row (two for a response row: its gain and its phase) with the measured
/// value and the residual where the row has one (`-` where not).
fn table(req: &Request, pred: &[Vec<f64>]) -> String {
    let mut t = Table::new(
        "predict",
        &format!(
            "predict: {} ({} simulator, {})",
            req.data.display(),
            req.sim.name(),
            effects_text(&req.effects, &req.sigmas)
        ),
        &["row", "kind", "predicted", "measured", "residual"],
    );
    // A measured value and its residual with `d` decimals, or missing.
    let line = |label: String, kind: &str, p: f64, m: Option<f64>, d: usize| -> Vec<Cell> {
        let (ms, res) = m.map_or((Cell::Missing, Cell::Missing), |m| {
            (num(m, d), num(m - p, d))
        });
        vec![text(label), text(kind), num(p, 4), ms, res]
    };
    for (r, p) in req.rows.iter().zip(pred) {
        let v = |k: usize| p.get(k).copied().unwrap_or(f64::NAN);
        if r.kind == RowKind::Response {
            t.rows.push(line(
                format!("{} (gain)", r.label),
                "response",
                v(0),
                r.measured_gain,
                4,
            ));
            t.rows.push(line(
                format!("{} (phase, deg)", r.label),
                "response",
                v(1),
                r.measured_phase_deg,
                3,
            ));
        } else {
            t.rows.push(line(
                r.label.clone(),
                r.kind.name(),
                v(0),
                r.measured_cm_s2,
                3,
            ));
        }
    }
    // The numbers keep the sign of a value that rounds to zero (`-0.0000`), as this
    // table always has.
    t.to_fixed_text(&[
        Column::left(48).gap(0).clipped(),
        Column::right(10),
        Column::right(14).signed_zero(),
        Column::right(12).missing("-").signed_zero(),
        Column::right(10).missing("-").signed_zero(),
    ])
}

/// The effects of a `ptsa discover --json` result file (`predict --effects`), and the
/// standard error of each coefficient the file gives one for (its `"stderr"`).
fn load_effects(p: &Path) -> Result<(Effects, Vec<(CandidateId, f64)>)> {
    let v = discovery::read_result_json(p, &p.display().to_string())?;
    let effects = discovery::effects_from_json(&v).with_context(|| p.display().to_string())?;
    let list = v.get("effects").unwrap_or(&v);
    let mut sigmas = Vec::new();
    for item in list.as_array().into_iter().flatten() {
        let name = item.get("name").and_then(serde_json::Value::as_str);
        let errs = item.get("stderr").and_then(serde_json::Value::as_object);
        for (key, se) in errs.into_iter().flatten() {
            let id = REGISTRY
                .iter()
                .find(|c| Some(c.effect) == name && c.key == key);
            if let (Some(c), Some(se)) = (id, se.as_f64().filter(|x| x.is_finite() && *x > 0.0)) {
                sigmas.push((c.id, se));
            }
        }
    }
    Ok((effects, sigmas))
}

/// What `predict` runs with: `baseline model`, or `with NAME = VALUE UNIT, ...`, each
/// coefficient with the digits its standard error in `sigmas` warrants, else four.
fn effects_text(effects: &Effects, sigmas: &[(CandidateId, f64)]) -> String {
    if effects.is_zero() {
        return "baseline model".to_string();
    }
    let list: Vec<String> = effects
        .nonzero()
        .map(|(id, c)| {
            let value = sigmas
                .iter()
                .find(|s| s.0 == id)
                .map_or_else(|| significant(c, 4), |s| discovery::show::estimate(c, s.1));
            format!("{} = {value} {}", id.info().name, id.info().unit)
        })
        .collect();
    format!("with {}", list.join(", "))
}
