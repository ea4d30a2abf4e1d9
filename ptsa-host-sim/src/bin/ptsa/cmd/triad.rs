//! `ptsa discover --data FILE` on a triad file (`g_x`, `g_y`, `g_z`,
//! `measured_x_cm_s2`, …): one calibration of three accelerometers on one block
//! (`ptsa_host_sim::triad`), dispatched here from `discover`'s request. The flags that
//! belong to the single-axis analysis are refused, `--orientation` is this command's own.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::ValueEnum;
use ptsa_host_sim::triad::stream as tstream;
use ptsa_host_sim::triad::{self, apply::TriadCalibration, fit, frame, report::TriadJson, sheet};

use super::Ctx;
use super::discover::DiscoverArgs;
use crate::paths;

/// `--orientation`: what the positions' nominal gravity directions are worth.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OrientationArg {
    /// The nominal orientations are the true ones (a precision fixture, dividing head or
    /// cube: errors well below the noise over g, e.g. 10 µrad for 10 µg); the six
    /// misalignments are fitted relative to the block.
    Exact,
    /// Each position is its nominal orientation turned by a small unknown rotation (a block
    /// placed by hand, up to about 2°): two angles per position are fitted too (the turn
    /// about gravity cannot be seen), the three misalignments below the diagonal only (the
    /// triad's own frame: x along the x axis, y in the x–y plane); needs about 24 or more
    /// positions.
    Approximate,
}

impl From<OrientationArg> for fit::Orientation {
    fn from(o: OrientationArg) -> Self {
        match o {
            OrientationArg::Exact => fit::Orientation::Exact,
            OrientationArg::Approximate => fit::Orientation::Approximate,
        }
    }
}

/// A triad calibration to run: the file read, the options, where the table goes.
pub struct Request {
    data: PathBuf,
    /// The data file's bytes as read (hashed on the sheet and the calibration file).
    data_bytes: Vec<u8>,
    positions: Vec<frame::Position>,
    /// A raw stream: read, and cut into its positions.
    stream: Option<(tstream::TriadStream, tstream::Cut)>,
    /// `--positions-out FILE`, and what it replaces.
    positions_out: Option<(PathBuf, Option<String>)>,
    options: fit::Options,
    json: bool,
    /// `STEM-triad.csv`'s folder, or `None` (`--no-plots`).
    table: Option<PathBuf>,
    /// `--sheet DIR`.
    sheet: Option<PathBuf>,
    /// `--write-instrument FILE`: the triad's calibration file.
    write_instrument: Option<PathBuf>,
    /// `--force`: an earlier sheet or calibration file may be replaced.
    force: bool,
    /// The sheet's time (`SOURCE_DATE_EPOCH` or now), read before the fit.
    time: (i64, bool),
    /// What `--force` replaces: the flag, the path, its time before, what it held.
    replaced: Vec<(&'static str, PathBuf, Option<std::time::SystemTime>, String)>,
}

/// The request for a triad file: the single-axis flags refused, the file read, the output
/// folder checked.
///
/// # Errors
/// A flag of the single-axis analysis; the file cannot be read or parsed; `--out` refused.
pub fn request(a: &DiscoverArgs, data: &std::path::Path, ctx: &Ctx) -> Result<Request> {
    let single = [
        ("--candidates", !a.candidates.is_empty()),
        ("--term", !a.terms.is_empty()),
        ("--analytic", a.analytic),
        ("--advice-out", a.advice_out.is_some()),
        ("--keep-outliers", a.keep_outliers),
        ("--units-as-given", a.units_as_given),
    ];
    if let Some((flag, _)) = single.iter().find(|(_, on)| *on) {
        bail!(
            "{flag} applies to a single-axis case-frame file, but {} is a triad file (g_x, g_y, g_z, measured_x_cm_s2, ...); expected the triad's options only: --orientation, --sigma, --json, --out, --no-plots, --sheet, --write-instrument, --force (docs/method/discovery.md, \"A triad\")",
            data.display()
        );
    }
    let data_bytes =
        std::fs::read(data).map_err(|e| anyhow::anyhow!("cannot read {}: {e}", data.display()))?;
    let name = data.display().to_string();
    let (detector, stream_flag) = a.detector();
    let (positions, stream) = if tstream::is_stream(&data_bytes) {
        if a.orientation == Some(OrientationArg::Exact) {
            bail!(
                "--orientation exact: {} is a raw stream, whose positions' orientations are not known but estimated from gravity; expected no --orientation (or approximate) with a stream",
                data.display()
            );
        }
        let text = String::from_utf8(data_bytes.clone())
            .map_err(|e| anyhow::anyhow!("{name}: not UTF-8 text ({e})"))?;
        let s = tstream::parse(&name, &text, &ctx.instr)?;
        let cut = tstream::cut(&s, &detector, ctx.instr.g_cm_s2)?;
        (Vec::new(), Some((s, cut)))
    } else {
        if let Some(flag) = stream_flag {
            bail!(
                "{flag} applies to a raw stream (time_s and the three axes' samples, no g_x, g_y, g_z), but {} is a triad file of positions; expected {flag} only with a stream",
                data.display()
            );
        }
        let mut positions = frame::parse_bytes(&name, &data_bytes)?;
        frame::with_counts(&mut positions, ctx.instr.sf_cm_s2);
        (positions, None)
    };
    let positions_out = match &a.positions_out {
        Some(p) => {
            let replaced = paths::output_file("--positions-out", p, a.force)?
                .then(|| paths::what_is_replaced(p));
            Some((p.clone(), replaced))
        }
        None => None,
    };
    let mut replaced = Vec::new();
    if let Some(p) = &a.write_instrument
        && paths::output_file("--write-instrument", p, a.force)?
    {
        let before = std::fs::metadata(p).and_then(|m| m.modified()).ok();
        replaced.push((
            "--write-instrument",
            p.clone(),
            before,
            paths::what_is_replaced(p),
        ));
    }
    if let Some(dir) = &a.sheet {
        paths::folder("--sheet", dir)?;
        if ptsa_host_sim::discovery::sheet::check_target(dir, a.force)? {
            let before = std::fs::metadata(dir).and_then(|m| m.modified()).ok();
            replaced.push(("--sheet", dir.clone(), before, "an earlier sheet".into()));
        }
    }
    let time = ptsa_host_sim::discovery::sheet::sheet_time()?;
    let table = if a.no_plots {
        None
    } else {
        paths::folder_with("--out", &a.out, &[table_name(data)])?;
        Some(a.out.clone())
    };
    Ok(Request {
        data: data.to_path_buf(),
        data_bytes,
        positions,
        stream,
        positions_out,
        options: fit::Options {
            orientation: a.orientation.unwrap_or(OrientationArg::Exact).into(),
            default_sigma_cm_s2: a.sigma,
            g_cm_s2: ctx.instr.g_cm_s2,
        },
        json: a.json,
        table,
        sheet: a.sheet.clone(),
        write_instrument: a.write_instrument.clone(),
        force: a.force,
        time,
        replaced,
    })
}

/// `STEM-triad.csv` of the data file (STEM: its name without `.csv`).
fn table_name(data: &std::path::Path) -> String {
    let stem = data
        .file_stem()
        .map_or_else(|| "triad".to_string(), |s| s.to_string_lossy().into_owned());
    format!("{stem}-triad.csv")
}

/// Fit, print (text, or with `--json` the text on stderr and one JSON object on stdout),
/// warn, and write the per-position table.
///
/// # Errors
/// The fit is refused; a write fails.
pub fn run(ctx: &Ctx, r: &Request, out: &mut dyn Write) -> Result<()> {
    let name = r.data.display().to_string();
    let (t, stream_text) = match &r.stream {
        Some((s, cut)) => {
            let (t, positions) = tstream::calibrate(s, cut, &r.options)?;
            if let Some((p, replaced)) = &r.positions_out {
                let csv = tstream::positions_csv(s, cut, &positions);
                ptsa_host_sim::output::fs::write_atomic(p, csv.as_bytes())?;
                if let Some(w) = replaced {
                    eprintln!(
                        "warning: --positions-out {}: replaced {w} (--force)",
                        p.display()
                    );
                }
                eprintln!(
                    "wrote {} ({} positions: `ptsa discover --data {} --orientation approximate` calibrates them again)",
                    p.display(),
                    positions.len(),
                    p.display()
                );
            }
            (t, tstream::text(s, cut))
        }
        None => (fit::fit(&name, &r.positions, &r.options)?, String::new()),
    };
    let text = format!("{stream_text}{}", triad::text(&t, &name));
    if r.json {
        eprint!("{text}");
        let mut j = serde_json::json!({
            "data": name,
            "instrument": ctx.name,
            "triad": TriadJson::of(&t),
        });
        if let Some((s, cut)) = &r.stream {
            j["stream"] = tstream::json(s, cut);
        }
        writeln!(out, "{j}")?;
    } else {
        write!(out, "{text}")?;
    }
    for w in &t.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(dir) = &r.table {
        let p = dir.join(table_name(&r.data));
        ptsa_host_sim::output::fs::write_atomic(&p, triad::table_csv(&t).as_bytes())?;
        eprintln!("wrote {}", p.display());
    }
    let inputs = sheet::Inputs {
        data: (&r.data, &r.data_bytes),
        instrument: (&ctx.name, &ctx.text),
        time: r.time,
        default_sigma_cm_s2: r.options.default_sigma_cm_s2,
    };
    if let Some(p) = &r.write_instrument {
        let text = TriadCalibration::of(&t).to_file(&sheet::provenance(&inputs, &t));
        ptsa_host_sim::output::fs::write_atomic(p, text.as_bytes())?;
        eprintln!(
            "wrote {} (the triad's calibration, one file for the three axes: apply it with `ptsa correct --calibration {}`)",
            p.display(),
            p.display()
        );
    }
    if let Some(dir) = &r.sheet {
        for f in sheet::write(dir, r.force, &inputs, &t)? {
            eprintln!("wrote {}", f.display());
        }
    }
    for (flag, p, before, w) in &r.replaced {
        if std::fs::metadata(p).and_then(|m| m.modified()).ok() != *before {
            eprintln!("warning: {flag} {}: replaced {w} (--force)", p.display());
        }
    }
    Ok(())
}

/// `ptsa plan triad --positions N`: a design the triad module knows.
///
/// # Errors
/// Not a whole number, or not one of `triad::DESIGNS`.
pub fn design_positions(s: &str) -> std::result::Result<usize, String> {
    let list = triad::DESIGNS
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join(", ");
    s.trim()
        .parse::<usize>()
        .ok()
        .filter(|n| triad::DESIGNS.contains(n))
        .ok_or_else(|| format!("expected one of the triad designs' position counts: {list}"))
}

/// The plan of `positions` positions: what it is, and the file's text.
#[must_use]
pub fn plan(positions: usize, counts: bool) -> (String, String) {
    let design = triad::design(positions).unwrap_or_default();
    let what = format!("{positions}-position triad");
    let fill = if counts {
        "Fill in pulses_x, ticks_x, pulses_y, ticks_y, pulses_z, ticks_z (each axis's counts over its gate: P pulses of positive torque in T clock ticks, whole numbers; read as SF*(2P/T - 1) cm/s² with the instrument file's nominal SF) and sigma_cm_s2 (the rest of a reading's noise, cm/s², or empty on every row),"
    } else {
        "Fill in measured_x_cm_s2, measured_y_cm_s2, measured_z_cm_s2 (each axis's reading through its nominal scale factor, cm/s²) and sigma_cm_s2,"
    };
    let comments = [
        format!(
            "Triad plan written by `ptsa plan triad`: {what} (g_x, g_y, g_z: the block's nominal gravity, g)."
        ),
        format!(
            "{fill} then `cargo ptsa discover --data FILE` (with --orientation approximate for a block placed by hand)."
        ),
    ];
    let refs: Vec<&str> = comments.iter().map(String::as_str).collect();
    (what, frame::plan_csv(&design, &refs, counts))
}
