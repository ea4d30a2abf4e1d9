//! `ptsa correct`: a calibration (a `ptsa discover --json` result, or an instrument file
//! of the instrument's own values) applied to a record of readings or counts: per row the
//! specific force along IA that gives the reading, with its 1-sigma uncertainty, as CSV on
//! stdout or into a file (never replacing one without `--force`, written atomically), or
//! as one JSON object.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use clap::Args;
use ptsa_host_sim::discovery::correct as lib;
use ptsa_host_sim::discovery::correct_record::{
    CorrectedRecord, choose_calibration, correct_record,
};
use ptsa_host_sim::output::{count, write_atomic};
use ptsa_host_sim::triad::correct_record as triad_record;

use super::Ctx;
use crate::flags::values::{local_gravity_cm_s2, positive_cm_s2};
use crate::paths;

/// Arguments of `ptsa correct`.
#[derive(Args, Debug, Clone)]
pub struct CorrectArgs {
    /// Case-frame CSV file (docs/reference/case-frame-format.md) of absolute, static rows: each a reading in
    /// measured_cm_s2 (cm/s²) or counts in pulses and ticks (whole numbers, read as
    /// SF·(2P/T − 1) cm/s² with the instrument file's nominal SF), with the cross-axis
    /// inputs g_pa and g_oa in g (absent: 0, with a warning). g_ia is not read: it is what
    /// the correction recovers. Or a triad record (measured_x_cm_s2, measured_y_cm_s2,
    /// measured_z_cm_s2 in cm/s², or each axis's pulses_x, ticks_x, ...; sigma_cm_s2; no
    /// gravity columns needed), corrected with a triad's calibration into the specific-force
    /// vector with its covariance.
    #[arg(long, value_name = "FILE")]
    pub data: PathBuf,
    /// The calibration: the JSON of `ptsa discover --json` made with the same --instrument
    /// file (its effects, their standard errors and their correlation). Without it, the
    /// instrument file given with --instrument is taken as the instrument's own calibrated
    /// model, with no uncertainty of its own. For a triad record: the triad's calibration
    /// file (`discover --write-instrument` on a triad file) or its `discover --json`.
    #[arg(long, value_name = "FILE.json")]
    pub calibration: Option<PathBuf>,
    /// 1-sigma noise of a reading that states none (no sigma_cm_s2 cell), cm/s² (more than
    /// 0); added in quadrature to the counting error of a row given as counts.
    #[arg(long, value_name = "CM_S2", value_parser = positive_cm_s2)]
    pub sigma: Option<f64>,
    /// The local gravity at the test stand, cm/s² (970 to 990): replaces the instrument
    /// file's local_gravity_cm_s2 for this run (what g_ia = 1 means, and every value in
    /// g). The shipped mems and navigation classes give standard gravity, 980.665.
    #[arg(long, value_name = "CM_S2", value_parser = local_gravity_cm_s2)]
    pub local_gravity: Option<f64>,
    /// Write the CSV here instead of standard output (never an input; an existing file only
    /// with --force; the file appears whole or not at all).
    #[arg(short = 'o', long = "output", alias = "out", value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Replace an existing --output file.
    #[arg(long, requires = "out")]
    pub force: bool,
    /// Print exactly one JSON object instead of the CSV: the files, and each row's
    /// specific force (along IA, or a triad's three axes) in cm/s² with its uncertainty.
    /// Every key: docs/reference/json.md.
    #[arg(long)]
    pub json: bool,
}

/// The columns of the CSV, after `label`: the reading and its noise, the cross-axis inputs
/// held, the specific force along IA (cm/s² and g) and its uncertainty with its two parts.
const COLUMNS: [&str; 9] = [
    "reading_cm_s2",
    "sigma_reading_cm_s2",
    "a_pa_cm_s2",
    "a_oa_cm_s2",
    "a_ia_cm_s2",
    "a_ia_g",
    "sigma_a_ia_cm_s2",
    "sigma_noise_cm_s2",
    "sigma_calibration_cm_s2",
];

/// A correction to write: one axis's record, or a triad's.
pub enum Request {
    /// A single-axis case-frame record.
    Axis(AxisRequest),
    /// A triad record (`g_x`… not needed; three readings per row).
    Triad(TriadRequest),
}

/// A single-axis correction to write: every row corrected (or without a reading), the
/// warnings.
pub struct AxisRequest {
    data: PathBuf,
    calibration: String,
    instrument: String,
    /// The rows corrected, the warnings, the local gravity.
    rec: CorrectedRecord,
    /// The --output file, with what it held when --force replaces it.
    out: Option<(PathBuf, Option<String>)>,
    json: bool,
}

impl CorrectArgs {
    /// The files the command reads, by their flags: no output may replace them.
    pub fn inputs(&self) -> [(&'static str, Option<&Path>); 2] {
        [
            ("--data", Some(&self.data)),
            ("--calibration", self.calibration.as_deref()),
        ]
    }

    /// The request: the calibration read, every row corrected (the work is small), the
    /// output checked.
    ///
    /// # Errors
    /// Neither --calibration nor --instrument; a file that cannot be read or is not what it
    /// should be; a row that is not absolute and static, or whose reading no specific force
    /// gives; no row with a reading; --output an input, or existing without --force.
    pub fn request(self, ctx: &Ctx, instrument_given: bool) -> Result<Request> {
        if ptsa_host_sim::triad::frame::is_triad_file(&self.data) {
            return self.triad_request(ctx).map(Request::Triad);
        }
        let (cal, calibration, flag) = self.calibration(ctx, instrument_given)?;
        let out = self.out_checked()?;
        let rec = correct_record(&self.data, &ctx.instr, &cal, &flag, self.sigma)?;
        Ok(Request::Axis(AxisRequest {
            data: self.data,
            calibration,
            instrument: ctx.name.clone(),
            rec,
            out,
            json: self.json,
        }))
    }

    /// The --output file checked, with what it holds when --force replaces it.
    fn out_checked(&self) -> Result<Option<(PathBuf, Option<String>)>> {
        Ok(match &self.out {
            Some(p) => {
                let replaced = paths::output_file("--output", p, self.force)?
                    .then(|| paths::what_is_replaced(p));
                Some((p.clone(), replaced))
            }
            None => None,
        })
    }

    /// A triad record: the triad calibration read (a triad calibration file or a triad's
    /// `discover --json`), every row with three readings corrected.
    ///
    /// # Errors
    /// No --calibration, or one that is not a triad's; the record cannot be read; no row
    /// has three readings; --output refused.
    fn triad_request(&self, ctx: &Ctx) -> Result<TriadRequest> {
        let Some(p) = &self.calibration else {
            bail!(
                "{} is a triad record (three axes' readings per row); expected --calibration FILE: a triad's calibration file (`ptsa discover --data TRIAD.csv --write-instrument FILE`) or the triad's `ptsa discover --json` result",
                self.data.display()
            );
        };
        let flag = format!("--calibration {}", p.display());
        let cal = triad_record::read_calibration(p, &flag, &self.data)?;
        let out = self.out_checked()?;
        let corrected =
            triad_record::correct_triad(&self.data, cal, ctx.instr.sf_cm_s2, self.sigma)?;
        Ok(TriadRequest {
            data: self.data.clone(),
            calibration: p.display().to_string(),
            instrument: ctx.name.clone(),
            corrected,
            out,
            json: self.json,
        })
    }

    /// The calibration to apply, what it is (for the output) and its flag with its file
    /// (for messages).
    ///
    /// # Errors
    /// Neither --calibration nor --instrument; the calibration cannot be read or is not a
    /// `ptsa discover --json` result `correct` can apply.
    fn calibration(
        &self,
        ctx: &Ctx,
        instrument_given: bool,
    ) -> Result<(lib::Calibration, String, String)> {
        choose_calibration(
            self.calibration.as_deref(),
            &self.data,
            &ctx.instr,
            &ctx.name,
            instrument_given,
        )
    }
}

/// The CSV: a comment line naming the data, the calibration and the instrument file, the
/// header, one line per row (empty cells for a row without a reading). Numbers in Rust's
/// shortest round-trip form.
fn csv(req: &AxisRequest) -> String {
    let mut s = format!(
        "# ptsa correct --data {}: {} applied (instrument file {}, local gravity {} cm/s^2); units in the column names, sigmas 1 sigma\nlabel,{}\n",
        req.data.display(),
        req.calibration,
        req.instrument,
        req.rec.g_cm_s2,
        COLUMNS.join(",")
    );
    for (r, _, c) in &req.rec.rows {
        let cells = c.as_ref().map(|c| {
            [
                c.reading_cm_s2,
                c.sigma_reading_cm_s2,
                c.a_pa_cm_s2,
                c.a_oa_cm_s2,
                c.a_ia_cm_s2,
                c.a_ia_g,
                c.sigma_a_ia_cm_s2,
                c.sigma_noise_cm_s2,
                c.sigma_calibration_cm_s2,
            ]
            .to_vec()
        });
        s.push_str(&csv_line(&r.label, cells.as_deref(), COLUMNS.len()));
    }
    s
}

/// One CSV line: `label` quoted as the case-frame writer quotes (a label starting with `#`
/// would read as a comment), then `cells` in Rust's shortest round-trip form, or `n` empty
/// cells for a row without a reading.
fn csv_line(label: &str, cells: Option<&[f64]>, n: usize) -> String {
    let label = if label.contains([',', '"', '\n', '\r'])
        || label.starts_with('#')
        || label.trim() != label
    {
        format!("\"{}\"", label.replace('"', "\"\""))
    } else {
        label.to_string()
    };
    let cells: Vec<String> = match cells {
        Some(c) => c.iter().map(|x| format!("{x}")).collect(),
        None => vec![String::new(); n],
    };
    format!("{label},{}\n", cells.join(","))
}

/// The JSON object (`--json`).
fn json(req: &AxisRequest) -> serde_json::Value {
    req.rec.json(
        &req.data.display().to_string(),
        &req.calibration,
        &req.instrument,
    )
}

/// Write the corrected rows: the warnings on stderr, the CSV (or JSON) on `out` or into
/// the --output file.
///
/// # Errors
/// The file or stdout cannot be written.
pub fn run(req: &Request, out: &mut dyn Write) -> Result<()> {
    let (warnings, text, target, corrected) = match req {
        Request::Axis(r) => (
            &r.rec.warnings,
            if r.json {
                format!("{}\n", json(r))
            } else {
                csv(r)
            },
            &r.out,
            r.rec.rows.iter().filter(|r| r.2.is_some()).count(),
        ),
        Request::Triad(r) => (
            &r.corrected.warnings,
            if r.json {
                format!("{}\n", triad_json(r))
            } else {
                triad_csv(r)
            },
            &r.out,
            r.corrected.rows.iter().filter(|r| r.c.is_some()).count(),
        ),
    };
    for w in warnings {
        eprintln!("warning: {w}");
    }
    match target {
        Some((p, replaced)) => {
            write_atomic(p, text.as_bytes())?;
            eprintln!(
                "wrote {} ({} corrected)",
                p.display(),
                count(corrected as u64, "row")
            );
            if let Some(w) = replaced {
                eprintln!("warning: --output {}: replaced {w} (--force)", p.display());
            }
        }
        None => write!(out, "{text}")?,
    }
    Ok(())
}

/// A triad correction to write.
pub struct TriadRequest {
    data: PathBuf,
    calibration: String,
    instrument: String,
    corrected: triad_record::CorrectedTriad,
    out: Option<(PathBuf, Option<String>)>,
    json: bool,
}

/// The triad CSV's columns after `label`: the readings and their noise, `f` and `|f|` with
/// their 1 σ, `f`'s whole covariance (six entries) and each axis's σ from the noise and
/// from the calibration.
const TRIAD_COLUMNS: [&str; 26] = [
    "reading_x_cm_s2",
    "reading_y_cm_s2",
    "reading_z_cm_s2",
    "sigma_reading_x_cm_s2",
    "sigma_reading_y_cm_s2",
    "sigma_reading_z_cm_s2",
    "f_x_cm_s2",
    "f_y_cm_s2",
    "f_z_cm_s2",
    "f_magnitude_cm_s2",
    "sigma_f_x_cm_s2",
    "sigma_f_y_cm_s2",
    "sigma_f_z_cm_s2",
    "sigma_f_magnitude_cm_s2",
    "cov_xx_cm2_s4",
    "cov_xy_cm2_s4",
    "cov_xz_cm2_s4",
    "cov_yy_cm2_s4",
    "cov_yz_cm2_s4",
    "cov_zz_cm2_s4",
    "sigma_noise_x_cm_s2",
    "sigma_noise_y_cm_s2",
    "sigma_noise_z_cm_s2",
    "sigma_calibration_x_cm_s2",
    "sigma_calibration_y_cm_s2",
    "sigma_calibration_z_cm_s2",
];

/// The cells of a corrected triad row, in [`TRIAD_COLUMNS`]' order.
fn triad_cells(
    p: &ptsa_host_sim::triad::frame::Position,
    sig: [f64; 3],
    c: &ptsa_host_sim::triad::apply::Corrected,
) -> Vec<f64> {
    let u = p.measured.map(|x| x.unwrap_or(f64::NAN));
    let cov = c.covariance();
    let (mag, smag) = c.magnitude();
    let mut v = Vec::with_capacity(TRIAD_COLUMNS.len());
    v.extend(u);
    v.extend(sig);
    v.extend(c.f);
    v.push(mag);
    v.extend([0, 1, 2].map(|j| cov[j][j].max(0.0).sqrt()));
    v.push(smag);
    v.extend([
        cov[0][0], cov[0][1], cov[0][2], cov[1][1], cov[1][2], cov[2][2],
    ]);
    v.extend([0, 1, 2].map(|j| c.noise[j][j].max(0.0).sqrt()));
    v.extend([0, 1, 2].map(|j| c.calibration[j][j].max(0.0).sqrt()));
    v
}

/// The triad CSV: a `#` line naming the data, the calibration, the frame; the header; one
/// line per row (empty cells for a row without three readings).
fn triad_csv(req: &TriadRequest) -> String {
    let mut s = format!(
        "# ptsa correct --data {}: the triad calibration {} applied (instrument file {} for counts; local gravity {} cm/s^2); f = the specific force in the {}; units in the column names, sigmas 1 sigma, cov the whole covariance of f\nlabel,{}\n",
        req.data.display(),
        req.calibration,
        req.instrument,
        req.corrected.cal.g_cm_s2,
        ptsa_host_sim::triad::apply::frame_words(req.corrected.cal.orientation),
        TRIAD_COLUMNS.join(",")
    );
    for r in &req.corrected.rows {
        let cells = r.c.as_ref().map(|(sig, c)| triad_cells(&r.p, *sig, c));
        s.push_str(&csv_line(&r.p.label, cells.as_deref(), TRIAD_COLUMNS.len()));
    }
    s
}

/// The triad JSON (`--json`).
fn triad_json(req: &TriadRequest) -> serde_json::Value {
    req.corrected.json(
        &req.data.display().to_string(),
        &req.calibration,
        &req.instrument,
    )
}
