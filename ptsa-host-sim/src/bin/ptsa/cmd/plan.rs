//! `ptsa plan`: a ready-to-run case-frame design (a tumble, a rate table, the shaker, a
//! centrifuge), on stdout or into a file that is never an input and replaces an existing
//! one only with `--force`.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand};
use ptsa_host_sim::Condition;
use ptsa_host_sim::lab::plan::{self, Axis};
use ptsa_host_sim::output::{count, write_atomic};

use super::Ctx;
use crate::flags::values::{
    amplitude_cm_s2, amplitude_mrad, arm_cm, g_level, lever_cm, positions, positive_hz, rate_rad_s,
    rate_table_axis,
};
use crate::paths;

/// Arguments of `ptsa plan`.
#[derive(Args, Debug, Clone)]
pub struct PlanArgs {
    /// The design.
    #[command(subcommand)]
    pub kind: PlanKind,
}

/// What `ptsa plan` writes.
#[derive(Subcommand, Debug, Clone)]
pub enum PlanKind {
    /// A multipoint tumble on a dividing head (IEEE Std 1293: 4, 8, 12 or 24 positions, or
    /// any number): absolute rows, IA at equally spaced angles in the plane of --axis.
    Tumble {
        /// Positions (2 to 360).
        #[arg(long, default_value_t = 24, value_name = "N", value_parser = positions)]
        positions: usize,
        /// The horizontal axis the dividing head turns about: oa (IA in the IA–PA plane), pa
        /// (IA in the IA–OA plane) or ia (IA horizontal, PA and OA turning).
        #[arg(long, value_enum, default_value = "oa")]
        axis: Axis,
        #[command(flatten)]
        count: CountArg,
        #[command(flatten)]
        out: PlanOut,
    },
    /// The dividing head on a rate table (Table 6.1's procedure): difference rows against a
    /// slow reference run.
    RateTable {
        /// IA positions (2 to 360).
        #[arg(long, default_value_t = 8, value_name = "N", value_parser = positions)]
        positions: usize,
        /// The dividing head's horizontal axis: oa (IA in the IA–PA plane, Table 6.1) or pa
        /// (IA in the IA–OA plane). Not ia: with IA along the head's axis the table's rate
        /// never reaches IA.
        #[arg(long, default_value = "oa", value_name = "oa|pa", value_parser = rate_table_axis)]
        axis: Axis,
        /// Table rate, rad/s.
        #[arg(long, default_value_t = 1.0, value_name = "RAD_S", value_parser = rate_rad_s)]
        rate_rad_s: f64,
        /// Rate of the reference run, rad/s.
        #[arg(long, default_value_t = 0.05, value_name = "RAD_S", value_parser = rate_rad_s)]
        ref_rate_rad_s: f64,
        /// Distance of the proof mass from the table axis, cm (0: centred).
        #[arg(long, default_value_t = 0.0, value_name = "CM", value_parser = lever_cm)]
        radius_cm: f64,
        #[command(flatten)]
        out: PlanOut,
    },
    /// The two-axis oscillator of Appendix A, IA up: blocks of phases of IA+PA and IA+OA
    /// vibration, OA rocking with PA vibration, and IA+OA rocking; difference rows.
    Shaker {
        /// Frequency, Hz (more than 0, at most 500).
        #[arg(long, default_value_t = 10.0, value_name = "HZ", value_parser = positive_hz)]
        freq_hz: f64,
        /// Vibration amplitude, cm/s².
        #[arg(long, default_value_t = 300.0, value_name = "CM_S2", value_parser = amplitude_cm_s2)]
        amplitude_cm_s2: f64,
        /// Rocking amplitude, mrad (0 to 100).
        #[arg(long, default_value_t = 1.0, value_name = "MRAD", value_parser = amplitude_mrad)]
        rock_mrad: f64,
        /// Phases per block (2 to 360).
        #[arg(long, default_value_t = 8, value_name = "N", value_parser = positions)]
        phases: usize,
        #[command(flatten)]
        out: PlanOut,
    },
    /// A centrifuge (IEEE Std 836): the proof mass at --radius-cm from the vertical spin
    /// axis, IA along the arm pointing at the axis and away from it, at each g level;
    /// absolute rows.
    Centrifuge {
        /// Arm length to the proof mass, cm (more than 0).
        #[arg(long, value_name = "CM", value_parser = arm_cm)]
        radius_cm: f64,
        /// The arm's push, in g (ω²R/g), comma separated, e.g. 2,5,10.
        #[arg(long, value_name = "G", value_delimiter = ',', required = true,
              value_parser = g_level)]
        g_levels: Vec<f64>,
        #[command(flatten)]
        count: CountArg,
        #[command(flatten)]
        out: PlanOut,
    },
    /// A triad's calibration: N static positions of a block carrying three accelerometers
    /// (docs/method/discovery.md, "A triad"): the block's nominal gravity g_x, g_y, g_z (g) and
    /// the three measured columns (cm/s²) to fill in, or with --count-columns each axis's counts.
    Triad {
        /// Positions: 6 (the faces), 8 (the faces and two corners), 12 (the edges), 24
        /// (every position tilted: for a block placed by hand) or 37 (24, the edges and a
        /// face).
        #[arg(long, default_value_t = 24, value_name = "N",
              value_parser = super::triad::design_positions)]
        positions: usize,
        /// Write empty pulses_x, ticks_x, pulses_y, ticks_y, pulses_z, ticks_z columns (each
        /// axis's counts over its gate: P pulses of positive torque in T clock ticks, whole
        /// numbers) in place of the measured columns; discover converts them to
        /// SF·(2P/T − 1) cm/s² with the instrument file's nominal SF (docs/reference/case-frame-format.md).
        #[arg(long = "count-columns", alias = "counts")]
        counts: bool,
        #[command(flatten)]
        out: PlanOut,
    },
}

/// How an absolute design's readings are to be recorded.
#[derive(Args, Debug, Clone, Copy)]
pub struct CountArg {
    /// Write empty pulses and ticks columns (the counts over each position's gate: P pulses
    /// of positive torque in T clock ticks, whole numbers) in place of measured_cm_s2;
    /// discover and predict convert them to SF·(2P/T − 1) cm/s² with the instrument file's
    /// nominal SF (docs/reference/case-frame-format.md).
    #[arg(long = "count-columns", alias = "counts")]
    pub counts: bool,
}

/// Where `ptsa plan` writes.
#[derive(Args, Debug, Clone)]
pub struct PlanOut {
    /// Write the case-frame file here (default: standard output). An existing file is not
    /// replaced without --force: it may hold the lab's measurements.
    #[arg(short = 'o', long = "output", alias = "out", value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Replace an existing --output file (a warning says how many measured rows it held).
    #[arg(long, requires = "out")]
    pub force: bool,
}

/// A plan to write: its rows, what it is (for the file's comment) and where it goes.
pub struct Request {
    rows: Vec<Condition>,
    /// The design in words.
    what: String,
    dest: Dest,
    /// Columns written empty for the lab to fill in.
    also: &'static [&'static str],
    /// `pulses` and `ticks` in place of `measured_cm_s2` (`--count-columns`).
    counts: bool,
    /// The file's text when it is not case-frame rows (a triad plan).
    text: Option<String>,
}

/// Standard output, or a file (checked; with what it held when `--force` replaces it).
enum Dest {
    Stdout,
    File {
        path: PathBuf,
        replaced: Option<String>,
    },
}

impl PlanArgs {
    /// The request: the design's rows, the output file checked (and, when `--force`
    /// replaces one, what it holds, for the warning).
    ///
    /// # Errors
    /// The loop cannot be simulated; `--output` is an input, cannot be written, or exists
    /// without `--force`.
    pub fn request(self, ctx: &Ctx) -> Result<Request> {
        if let PlanKind::Triad {
            positions,
            counts,
            out,
        } = self.kind
        {
            let (what, text) = super::triad::plan(positions, counts);
            return Ok(Request {
                rows: Vec::new(),
                what,
                dest: dest(out)?,
                also: &[],
                counts: false,
                text: Some(text),
            });
        }
        // Refused like every subcommand that simulates: the plan is for this instrument.
        // (A file without a loop plans for the analytic model.)
        if ctx.instr.has_loop {
            ctx.config()?;
        }
        let (rows, what, out, counts) = self.kind.case_frame(ctx.instr.g_cm_s2);
        let also = lab_columns(&rows);
        Ok(Request {
            rows,
            what,
            dest: dest(out)?,
            also,
            counts,
            text: None,
        })
    }
}

impl PlanKind {
    /// A case-frame design (any but the triad's, with local gravity `g_cm_s2`, cm/s², for a
    /// centrifuge's speeds): its rows, the design in words, where it goes, and whether its
    /// readings are to be recorded as counts.
    fn case_frame(self, g_cm_s2: f64) -> (Vec<Condition>, String, PlanOut, bool) {
        match self {
            PlanKind::Tumble {
                positions,
                axis,
                count,
                out,
            } => (
                plan::tumble(positions, axis),
                format!("{positions}-point tumble about {axis:?}").to_lowercase(),
                out,
                count.counts,
            ),
            PlanKind::RateTable {
                positions,
                axis,
                rate_rad_s,
                ref_rate_rad_s,
                radius_cm,
                out,
            } => (
                plan::rate_table(positions, axis, rate_rad_s, ref_rate_rad_s, radius_cm),
                format!(
                    "rate table, {positions} positions about {axis:?}, {rate_rad_s} rad/s against {ref_rate_rad_s} rad/s, arm {radius_cm} cm"
                ),
                out,
                false,
            ),
            PlanKind::Shaker {
                freq_hz,
                amplitude_cm_s2,
                rock_mrad,
                phases,
                out,
            } => (
                plan::shaker(freq_hz, amplitude_cm_s2, rock_mrad, phases),
                format!(
                    "two-axis oscillator at {freq_hz} Hz, {amplitude_cm_s2} cm/s^2, rocking {rock_mrad} mrad, {phases} phases per block"
                ),
                out,
                false,
            ),
            PlanKind::Centrifuge {
                radius_cm,
                g_levels,
                count,
                out,
            } => (
                plan::centrifuge(radius_cm, &g_levels, g_cm_s2),
                format!(
                    "centrifuge, arm {radius_cm} cm, at {} g, IA in and out",
                    g_levels
                        .iter()
                        .map(|g| format!("{g}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                out,
                count.counts,
            ),
            PlanKind::Triad { .. } => unreachable!("a triad plan returned above"),
        }
    }
}

/// The columns a lab records beside each reading of absolute rows (a tumble, a
/// centrifuge), written empty for it to fill in; none for other designs.
fn lab_columns(rows: &[Condition]) -> &'static [&'static str] {
    if rows
        .iter()
        .any(|r| r.kind == ptsa_host_sim::model::condition::RowKind::Absolute)
    {
        &["temp_c", "approach"]
    } else {
        &[]
    }
}

/// Standard output, or the `--output` file checked (and, when `--force` replaces one, what it
/// holds).
fn dest(out: PlanOut) -> Result<Dest> {
    Ok(match out.out {
        None => Dest::Stdout,
        Some(path) => {
            let replaced = paths::output_file("--output", &path, out.force)?
                .then(|| paths::what_is_replaced(&path));
            Dest::File { path, replaced }
        }
    })
}

/// Write the plan as a case-frame file with two comment lines (what it is, what to do
/// with it): into its file (appearing whole), or on `out`.
///
/// # Errors
/// The file or stdout cannot be written.
pub fn run(req: &Request, out: &mut dyn Write) -> Result<()> {
    let mut comments = vec![
        format!("Test plan written by `ptsa plan`: {}.", req.what),
        if req.counts {
            "Fill in pulses and ticks (each position's counts over its gate: P pulses of positive torque in T clock ticks, whole numbers), then `cargo ptsa discover --data FILE`: they are read as SF*(2P/T - 1) cm/s^2 with the instrument file's nominal SF."
        } else {
            "Fill in measured_cm_s2 (and sigma_cm_s2) from the lab, then `cargo ptsa discover --data FILE`."
        }
        .to_string(),
    ];
    if !req.also.is_empty() {
        comments.push(
            "Also temp_c (the instrument's temperature, °C) on every row if it was logged, and approach (up or down: whether the input along IA rose or fell to the reading) if recorded; rows in the order measured (or give time_s)."
                .to_string(),
        );
    }
    let refs: Vec<&str> = comments.iter().map(String::as_str).collect();
    let text = match &req.text {
        Some(t) => t.clone(),
        None if req.counts => {
            ptsa_host_sim::model::caseframe::to_csv_counts(&req.rows, &refs, req.also)
        }
        None => ptsa_host_sim::model::caseframe::to_csv_with(&req.rows, &refs, req.also),
    };
    match &req.dest {
        Dest::File { path, replaced } => {
            write_atomic(path, text.as_bytes())?;
            let rows = text.lines().filter(|l| !l.starts_with('#')).count() - 1;
            eprintln!("wrote {} ({})", path.display(), count(rows as u64, "row"));
            if let Some(w) = replaced {
                eprintln!(
                    "warning: --output {}: replaced {w} (--force)",
                    path.display()
                );
            }
        }
        Dest::Stdout => write!(out, "{text}")?,
    }
    Ok(())
}
