//! A triad's raw stream (`ptsa discover --data STREAM`): `time_s` and the three axes'
//! samples, no orientation, as a logger records a block turned by hand between positions
//! (`imu_tk`'s protocol: a rest, then each position held a few seconds). The stream is cut
//! into its static intervals (`stream::segment`), each interval becomes a position (its
//! mean readings), and the positions are calibrated from gravity alone: each position's
//! direction is unknown and fitted (approximate orientations about the direction the
//! first fit corrects the readings to).

use anyhow::{Result, bail};

use super::fit::{self, AXES, Orientation, Triad};
use super::frame::{self, Position};
use crate::model::caseframe;
use crate::model::instrument::{Instrument, ReadingUnit};
use crate::output::significant as sig;
use crate::stream::segment::{self, Detector, Interval, Segmentation};
use crate::stream::{self, Stream};

/// The stream's columns by axis: its readings in cm/s², or in the instrument's unit.
pub const MEASURED: [&str; 3] = ["measured_x_cm_s2", "measured_y_cm_s2", "measured_z_cm_s2"];
/// The stream's columns by axis in the instrument file's reading unit.
pub const READING: [&str; 3] = ["reading_x", "reading_y", "reading_z"];

/// How far an interval's readings' magnitude may be from the local gravity, as a fraction
/// of it, before it is not taken as a position (an instrument at rest feels gravity alone;
/// a bias or scale error of a consumer part stays well inside).
pub const MAGNITUDE_TOLERANCE: f64 = 0.25;

/// Fewest positions a calibration from gravity alone is tried with (nine coefficients
/// and two angles per position from three readings per position).
pub const MIN_POSITIONS: usize = 10;

/// Whether `bytes` are a triad stream: a header with `time_s` and the three axes'
/// `measured_*_cm_s2` or `reading_*`, and no nominal gravity.
#[must_use]
pub fn is_stream(bytes: &[u8]) -> bool {
    let cells = caseframe::header_cells(bytes);
    let has = |c: &str| cells.iter().any(|x| x == c);
    has("time_s")
        && !["g_x", "g_y", "g_z"].iter().any(|c| has(c))
        && (MEASURED.iter().all(|c| has(c)) || READING.iter().all(|c| has(c)))
}

/// Whether the file at `path` is a triad stream (false when it cannot be read: the reader
/// that follows says why).
#[must_use]
pub fn is_stream_file(path: &std::path::Path) -> bool {
    std::fs::read(path).is_ok_and(|b| is_stream(&b))
}

/// A stream read, in cm/s², with the unit it was given in.
#[derive(Clone, Debug)]
pub struct TriadStream {
    /// The samples: three channels, x, y, z, cm/s².
    pub stream: Stream,
    /// The unit the readings were written in.
    pub unit: ReadingUnit,
}

/// Read the stream `text` (`name` for messages): `measured_*_cm_s2` in cm/s², or
/// `reading_*` in the instrument file's reading unit.
///
/// # Errors
/// The stream's reader refuses it; `reading_*` without a reading unit in the file.
pub fn parse(name: &str, text: &str, instr: &Instrument) -> Result<TriadStream> {
    let header = columns_header(text);
    let (names, unit) = if MEASURED.iter().all(|c| header.iter().any(|h| h == c)) {
        (MEASURED, ReadingUnit::CmPerS2)
    } else {
        let unit = instr
            .reading_scale
            .as_ref()
            .map_or(ReadingUnit::CmPerS2, |r| r.unit);
        (READING, unit)
    };
    let factor = instr
        .reading_to_cm_s2(1.0, unit)
        .map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
    let what = AXES.map(|a| format!("the {a} axis's reading"));
    let what: Vec<&str> = what.iter().map(String::as_str).collect();
    let mut s = stream::parse(
        name,
        text,
        &names,
        &what,
        "`time_s,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2` (or reading_x, reading_y, reading_z in the instrument file's reading unit): one sample per row",
    )?;
    if unit != ReadingUnit::CmPerS2 {
        for c in &mut s.channels {
            for v in c.iter_mut() {
                *v *= factor;
            }
        }
    }
    Ok(TriadStream { stream: s, unit })
}

/// The header's cells of `text` (its first line not blank or a comment).
fn columns_header(text: &str) -> Vec<String> {
    caseframe::header_cells(text.as_bytes())
}

/// An interval not taken as a position, and why.
#[derive(Clone, Debug)]
pub struct Rejected {
    /// The interval.
    pub interval: Interval,
    /// Why, one clause.
    pub reason: String,
}

/// The stream cut into positions.
#[derive(Clone, Debug)]
pub struct Cut {
    /// What the detector found.
    pub segmentation: Segmentation,
    /// The intervals taken as positions, in time order.
    pub kept: Vec<Interval>,
    /// The intervals found static but not taken, with why (held too short included).
    pub rejected: Vec<Rejected>,
}

/// Cut `s` into positions with `d`; `g_cm_s2` the local gravity an interval's readings must
/// be near.
///
/// # Errors
/// The detector refuses the stream (its message, with the stream's name); fewer than
/// [`MIN_POSITIONS`] intervals kept.
pub fn cut(s: &TriadStream, d: &Detector, g_cm_s2: f64) -> Result<Cut> {
    let st = &s.stream;
    let seg = segment::segment(&st.t, &st.channels, d).map_err(|e| {
        anyhow::anyhow!(
            "{}: {e} (a triad file with time_s and without g_x, g_y, g_z is read as a raw stream of samples; a file of positions needs each position's nominal gravity)",
            st.name
        )
    })?;
    let mut kept = Vec::new();
    let mut rejected: Vec<Rejected> = seg
        .short
        .iter()
        .filter(|iv| iv.samples() >= seg.window)
        .map(|iv| Rejected {
            interval: iv.clone(),
            reason: format!(
                "held {} s, less than --static-min-s {} s",
                sig(iv.held_s(seg.dt_s), 3),
                sig(d.min_static_s, 6)
            ),
        })
        .collect();
    for iv in &seg.intervals {
        let mag = iv.mean.iter().map(|v| v * v).sum::<f64>().sqrt();
        if (mag / g_cm_s2 - 1.0).abs() > MAGNITUDE_TOLERANCE {
            rejected.push(Rejected {
                interval: iv.clone(),
                reason: format!(
                    "its readings' magnitude is {} g, not 1 g within {:.0} %: not at rest under gravity alone",
                    sig(mag / g_cm_s2, 4),
                    MAGNITUDE_TOLERANCE * 100.0
                ),
            });
        } else {
            kept.push(iv.clone());
        }
    }
    rejected.sort_by_key(|r| r.interval.first);
    if kept.len() < MIN_POSITIONS {
        let unit_hint = if seg.intervals.len() >= MIN_POSITIONS {
            " (most static intervals are far from 1 g: are the readings in the unit said? measured_*_cm_s2 is cm/s², reading_* the instrument file's reading_unit)"
        } else {
            ""
        };
        bail!(
            "{}: {} positions found ({} static intervals held at least --static-min-s {} s, {} rejected){unit_hint}; expected at least {MIN_POSITIONS} for a calibration from gravity alone, 24 or more for a usable one: hold more positions, or look at --static-threshold ({}) and --static-min-s",
            st.name,
            kept.len(),
            seg.intervals.len(),
            sig(d.min_static_s, 6),
            rejected.len(),
            sig(d.threshold, 6)
        );
    }
    Ok(Cut {
        segmentation: seg,
        kept,
        rejected,
    })
}

/// The positions of the intervals `kept`, each labelled `s1`, `s2`, … with its mean time,
/// its mean readings and the direction `dirs[i]` as its nominal gravity.
fn positions(st: &Stream, kept: &[Interval], dirs: &[[f64; 3]]) -> Vec<Position> {
    kept.iter()
        .zip(dirs)
        .enumerate()
        .map(|(i, (iv, d))| Position {
            label: format!("s{}", i + 1),
            line: st.lines[iv.first],
            time_s: Some(0.5 * (iv.t0_s + iv.t1_s)),
            g_nominal: *d,
            g_unit: *d,
            measured: [Some(iv.mean[0]), Some(iv.mean[1]), Some(iv.mean[2])],
            counts: [None; 3],
            counting_sigma_cm_s2: [None; 3],
            sigma_cm_s2: None,
            sigma_angle_rad: None,
        })
        .collect()
}

/// `v` over its length.
fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    v.map(|x| x / n)
}

/// Calibrate the positions of `cut` from gravity alone: a first fit about each interval's
/// own reading direction, then the fit again about the directions the first one corrects
/// the readings to (the same minimum; each position's estimated turn then says how far the
/// second fit moved it, which is what the turn warnings read).
///
/// # Errors
/// The fit refuses the positions.
pub fn calibrate(
    s: &TriadStream,
    cut: &Cut,
    opts: &fit::Options,
) -> Result<(Triad, Vec<Position>)> {
    let opts = fit::Options {
        orientation: Orientation::Approximate,
        ..opts.clone()
    };
    let st = &s.stream;
    let raw: Vec<[f64; 3]> = cut
        .kept
        .iter()
        .map(|iv| unit([iv.mean[0], iv.mean[1], iv.mean[2]]))
        .collect();
    let first = fit::fit(&st.name, &positions(st, &cut.kept, &raw), &opts)?;
    let dirs: Vec<[f64; 3]> = cut
        .kept
        .iter()
        .map(|iv| unit(fit::corrected(&first, [iv.mean[0], iv.mean[1], iv.mean[2]])))
        .collect();
    // Written as a triad file and read back: the positions are those `--positions-out`
    // gives a person to edit (the nominal gravity's digits as written).
    let text = frame::to_csv(&positions(st, &cut.kept, &dirs), &[]);
    let p = frame::parse_bytes(&st.name, text.as_bytes())?;
    let mut p = p;
    for (q, iv) in p.iter_mut().zip(&cut.kept) {
        q.line = st.lines[iv.first];
    }
    let t = fit::fit(&st.name, &p, &opts)?;
    Ok((t, p))
}

/// The positions as a triad file for `--positions-out`: `# ` lines saying where they came
/// from, the detector's settings and each interval's time, lines and samples, then the
/// positions (`discover --data FILE --orientation approximate` calibrates it again).
#[must_use]
pub fn positions_csv(s: &TriadStream, cut: &Cut, positions: &[Position]) -> String {
    let st = &s.stream;
    let mut comments = vec![
        format!(
            "positions cut from the stream {} by `ptsa discover` (its static intervals: {}; readings in {})",
            st.name,
            cut.segmentation.settings(),
            s.unit.name()
        ),
        "g_x, g_y, g_z: each position's direction as the stream's calibration corrects its readings (not a fixture's: fit with --orientation approximate); measured_*: the interval's mean, cm/s²".to_string(),
    ];
    for (p, iv) in positions.iter().zip(&cut.kept) {
        comments.push(format!(
            "{}: {}, {} samples",
            p.label,
            st.place(iv),
            iv.samples()
        ));
    }
    for r in &cut.rejected {
        comments.push(format!(
            "not a position: {}: {}",
            st.place(&r.interval),
            r.reason
        ));
    }
    let refs: Vec<&str> = comments.iter().map(String::as_str).collect();
    frame::to_csv(positions, &refs)
}

/// What the detector found, for a person: the settings, the rest's level, the positions'
/// count and lengths, each rejected interval with why, and the gaps.
#[must_use]
pub fn text(s: &TriadStream, cut: &Cut) -> String {
    use std::fmt::Write as _;
    let st = &s.stream;
    let seg = &cut.segmentation;
    let d = &seg.detector;
    let mut out = String::new();
    let held: Vec<f64> = cut.kept.iter().map(|iv| iv.held_s(seg.dt_s)).collect();
    let (lo, hi) = held
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), h| (a.min(*h), b.max(*h)));
    let _ = writeln!(
        out,
        "stream {}: {} samples every {} s ({} s), readings in {}; static where the variance over --static-window-s {} s ({} samples), summed over the axes, is at most --static-threshold {} times the first --rest-s {} s's ({} (cm/s^2)^2, so {}): {} positions held {}–{} s, {} % of the samples static",
        st.name,
        st.t.len(),
        sig(seg.dt_s, 6),
        sig(st.t[st.t.len() - 1] - st.t[0] + seg.dt_s, 6),
        s.unit.name(),
        sig(d.window_s, 6),
        seg.window,
        sig(d.threshold, 6),
        sig(d.rest_s, 6),
        sig(seg.rest_variance, 3),
        sig(seg.limit_variance, 3),
        cut.kept.len(),
        sig(lo, 3),
        sig(hi, 3),
        sig(100.0 * seg.static_fraction, 3)
    );
    for r in &cut.rejected {
        let _ = writeln!(
            out,
            "  not a position: {}: {}",
            st.place(&r.interval),
            r.reason
        );
    }
    for (k, dt) in &st.gaps {
        let _ = writeln!(
            out,
            "  a gap of {} s before line {} (more than 5 sample intervals): a static interval across it is two",
            sig(*dt, 4),
            st.lines[*k]
        );
    }
    out
}

/// The cut as JSON (`"stream"` beside `"triad"`).
#[must_use]
pub fn json(s: &TriadStream, cut: &Cut) -> serde_json::Value {
    let st = &s.stream;
    let seg = &cut.segmentation;
    let d = &seg.detector;
    let iv = |iv: &Interval| {
        serde_json::json!({
            "start_s": iv.t0_s,
            "end_s": iv.t1_s,
            "lines": [st.lines[iv.first], st.lines[iv.last]],
            "samples": iv.samples(),
            "mean_cm_s2": iv.mean,
            "std_cm_s2": iv.std,
        })
    };
    serde_json::json!({
        "samples": st.t.len(),
        "sample_interval_s": seg.dt_s,
        "reading_unit": s.unit.name(),
        "rest_s": d.rest_s,
        "window_s": d.window_s,
        "window_samples": seg.window,
        "threshold": d.threshold,
        "min_static_s": d.min_static_s,
        "rest_variance_cm2_s4": seg.rest_variance,
        "limit_variance_cm2_s4": seg.limit_variance,
        "static_fraction": seg.static_fraction,
        "positions": cut.kept.iter().map(iv).collect::<Vec<_>>(),
        "rejected": cut.rejected.iter().map(|r| {
            let mut v = iv(&r.interval);
            v["reason"] = r.reason.clone().into();
            v
        }).collect::<Vec<_>>(),
        "gaps": st.gaps.iter().map(|(k, dt)| serde_json::json!({"line": st.lines[*k], "gap_s": dt})).collect::<Vec<_>>(),
    })
}
