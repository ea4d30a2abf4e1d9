//! One axis's raw stream (`ptsa discover --data STREAM --plan PLAN`): `time_s` and each
//! sample's reading (`measured_cm_s2`, or `reading` in the instrument file's unit), or a
//! counter record of gates (`pulses`, `ticks`: `ptsa record`'s output, a tumble logged by
//! the board), with no orientation. The stream is cut into its still intervals
//! ([`super::segment`]) and they fill the plan's rows in the order they were held: each
//! row's mean reading, or, for gates, the interval's pulses and ticks summed (a gate as
//! long as the interval, whose counting error the case frame's counts already carry).

use anyhow::{Result, bail};

use super::segment::{self, Detector, Interval, Segmentation};
use super::{Stream, parse as parse_stream};
use crate::model::caseframe;
use crate::model::condition::{Condition, RowKind};
use crate::model::instrument::{Instrument, ReadingUnit};
use crate::output::significant as sig;

/// The trim a gate record gets unless told (`--static-trim-s`), s: its counts sum to a
/// mean far more precise than a gate's quantization, which hides a turn's gentle start
/// and end from the window's variance (in `tests/cli_axis_stream.rs`, 10 s holds of 10 ms
/// gates read up to 96 counting errors off with no trim, 3.3 with 0.5 s, 2.2 with 1 s).
pub const COUNTS_TRIM_S: f64 = 1.0;

/// What each sample of the stream gives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// `measured_cm_s2` (or `reading` in this unit).
    Reading(ReadingUnit),
    /// A gate's `pulses` and `ticks`.
    Counts,
}

/// A single-axis stream read: channel 0 the indicated acceleration, cm/s²; for gates,
/// channels 1 and 2 each gate's pulses and ticks.
#[derive(Clone, Debug)]
pub struct AxisStream {
    /// The samples.
    pub stream: Stream,
    /// What they give.
    pub source: Source,
}

/// Whether `bytes` are one axis's stream: a header with `time_s` and `measured_cm_s2`,
/// `reading`, or `pulses` with `ticks`, and no case-frame input column (`g_ia`, `kind`,
/// …) nor a triad's.
#[must_use]
pub fn is_stream(bytes: &[u8]) -> bool {
    let cells = caseframe::header_cells(bytes);
    let has = |c: &str| cells.iter().any(|x| x == c);
    let reading = has("measured_cm_s2") || has("reading") || (has("pulses") && has("ticks"));
    let allowed = [
        "time_s",
        "measured_cm_s2",
        "reading",
        "pulses",
        "ticks",
        "label",
    ];
    has("time_s") && reading && cells.iter().all(|c| allowed.contains(&c.as_str()))
}

/// Whether the file at `path` is one axis's stream (false when it cannot be read).
#[must_use]
pub fn is_stream_file(path: &std::path::Path) -> bool {
    std::fs::read(path).is_ok_and(|b| is_stream(&b))
}

/// Read one axis's stream `text` (`name` for messages); `sf_cm_s2` turns counts into
/// cm/s², the instrument file's reading unit a `reading`.
///
/// # Errors
/// The stream's reader refuses it; a `reading` the file cannot convert; counts that are
/// not whole, or more pulses than ticks (their line).
pub fn parse(name: &str, text: &str, instr: &Instrument) -> Result<AxisStream> {
    let header = caseframe::header_cells(text.as_bytes());
    let has = |c: &str| header.iter().any(|x| x == c);
    let hint = "`time_s,measured_cm_s2` (or reading in the instrument file's reading unit, or a gate's pulses,ticks): one sample per row";
    if has("measured_cm_s2") || has("reading") {
        let (col, unit) = if has("measured_cm_s2") {
            ("measured_cm_s2", ReadingUnit::CmPerS2)
        } else {
            (
                "reading",
                instr
                    .reading_scale
                    .as_ref()
                    .map_or(ReadingUnit::CmPerS2, |r| r.unit),
            )
        };
        let factor = instr
            .reading_to_cm_s2(1.0, unit)
            .map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
        let mut s = parse_stream(name, text, &[col], &["the reading"], hint)?;
        if unit != ReadingUnit::CmPerS2 {
            for v in &mut s.channels[0] {
                *v *= factor;
            }
        }
        return Ok(AxisStream {
            stream: s,
            source: Source::Reading(unit),
        });
    }
    let mut s = parse_stream(
        name,
        text,
        &["pulses", "ticks"],
        &["the gate's pulses", "the gate's clock ticks"],
        hint,
    )?;
    let sf = instr.sf_cm_s2;
    let mut y = Vec::with_capacity(s.t.len());
    for (k, (&p, &t)) in s.channels[0].iter().zip(&s.channels[1]).enumerate() {
        if !caseframe::is_count(p) || !caseframe::is_count(t) || t <= 0.0 || p > t {
            bail!(
                "{name}:{}: pulses {p}, ticks {t}; expected whole numbers with 0 ≤ pulses ≤ ticks and ticks > 0",
                s.lines[k]
            );
        }
        y.push(crate::model::counts::indicated_cm_s2(p, t, sf));
    }
    s.channels.insert(0, y);
    Ok(AxisStream {
        stream: s,
        source: Source::Counts,
    })
}

/// The still intervals of `s` by `d`: the detector on the indicated acceleration.
///
/// # Errors
/// The detector refuses the stream.
pub fn cut(s: &AxisStream, d: &Detector) -> Result<Segmentation> {
    segment::segment(&s.stream.t, &s.stream.channels[..1], d)
        .map_err(|e| anyhow::anyhow!("{}: {e}", s.stream.name))
}

/// The plan's rows to fill: absolute rows without a measurement, in the file's order.
fn open_rows(plan: &[Condition]) -> Vec<usize> {
    (0..plan.len())
        .filter(|&i| plan[i].kind == RowKind::Absolute && !plan[i].is_measured())
        .collect()
}

/// Where the intervals stop following the plan: the first interval whose mean is not
/// its row's nominal `g·g_ia` plus the first interval's offset, within `tol` cm/s².
fn first_departure(means: &[f64], expected: &[f64], tol: f64) -> Option<(usize, f64, f64)> {
    let offset = means[0] - expected[0];
    means
        .iter()
        .zip(expected)
        .enumerate()
        .find(|(_, (m, e))| (*m - *e - offset).abs() > tol)
        .map(|(k, (m, e))| (k, *m, e + offset))
}

/// The plan `plan` (its name `plan_name`) with its open rows filled by the intervals of
/// `seg`, in order, and the open rows' indices: each row's `time_s` (the interval's middle) and its mean reading, or
/// its pulses and ticks summed over the interval's gates. `g_cm_s2` is the local
/// gravity, for the message when the counts differ.
///
/// # Errors
/// The plan has no open row; the intervals are more or fewer than its open rows (the
/// first interval that does not follow the plan's nominal readings named).
pub fn fill(
    s: &AxisStream,
    seg: &Segmentation,
    plan: &[Condition],
    plan_name: &str,
    g_cm_s2: f64,
) -> Result<(Vec<Condition>, Vec<usize>)> {
    let open = open_rows(plan);
    if open.is_empty() {
        bail!(
            "{plan_name}: no absolute row without a measurement; expected the plan of the positions held, in their order, its measured cells empty (`ptsa plan tumble`)"
        );
    }
    let st = &s.stream;
    let means: Vec<f64> = seg.intervals.iter().map(|iv| iv.mean[0]).collect();
    if means.len() != open.len() {
        let expected: Vec<f64> = open.iter().map(|&i| g_cm_s2 * plan[i].g[0]).collect();
        let n = means.len().min(expected.len());
        let place = first_departure(&means[..n], &expected[..n], 0.05 * g_cm_s2).map_or_else(
            || {
                format!(
                    "the first {n} follow the plan's nominal readings; the {} at the end",
                    if means.len() > open.len() {
                        "extra intervals are"
                    } else {
                        "missing positions are"
                    }
                )
            },
            |(k, m, e)| {
                let iv = &seg.intervals[k];
                format!(
                    "interval {} ({}) reads {} cm/s² where row `{}` expects about {} (its g_ia, with the first interval's offset): a position {} before it",
                    k + 1,
                    st.place(iv),
                    sig(m, 6),
                    plan[open[k]].label,
                    sig(e, 6),
                    if means.len() > open.len() { "extra" } else { "missing" }
                )
            },
        );
        bail!(
            "{}: {} still intervals for the {} positions of {plan_name}: {place}; expected one interval per position, in the plan's order (--static-threshold {} and --static-min-s {} s set what counts as one)",
            st.name,
            means.len(),
            open.len(),
            sig(seg.detector.threshold, 6),
            sig(seg.detector.min_static_s, 6)
        );
    }
    let mut rows = plan.to_vec();
    for (&i, iv) in open.iter().zip(&seg.intervals) {
        fill_row(&mut rows[i], s, iv);
    }
    Ok((rows, open))
}

/// Row `r` measured by the interval `iv`.
fn fill_row(r: &mut Condition, s: &AxisStream, iv: &Interval) {
    r.time_s = Some(0.5 * (iv.t0_s + iv.t1_s));
    match s.source {
        Source::Reading(_) => r.measured_cm_s2 = Some(iv.mean[0]),
        Source::Counts => {
            let c = &s.stream.channels;
            r.pulses = Some(c[1][iv.first..=iv.last].iter().sum());
            r.ticks = Some(c[2][iv.first..=iv.last].iter().sum());
        }
    }
}

/// The filled plan (`rows`, the filled ones `open`) as a case-frame file: `# ` lines saying
/// where each row's measurement came from (the stream, the detector's settings, each
/// interval's time, lines and samples), then the rows.
#[must_use]
pub fn filled_csv(
    s: &AxisStream,
    seg: &Segmentation,
    (rows, open): (&[Condition], &[usize]),
    plan_name: &str,
) -> String {
    let st = &s.stream;
    let mut comments = vec![format!(
        "the plan {plan_name} filled from the stream {} by `ptsa discover` (its still intervals: {}); {}",
        st.name,
        seg.settings(),
        match s.source {
            Source::Reading(u) => format!(
                "measured_cm_s2: each interval's mean reading (given in {})",
                u.name()
            ),
            Source::Counts => "pulses, ticks: each interval's gates summed".to_string(),
        }
    )];
    for (&i, iv) in open.iter().zip(&seg.intervals) {
        comments.push(format!(
            "{}: {}, {} samples",
            rows[i].label,
            st.place(iv),
            iv.samples()
        ));
    }
    let refs: Vec<&str> = comments.iter().map(String::as_str).collect();
    match s.source {
        Source::Reading(_) => caseframe::to_csv_with(rows, &refs, &["time_s"]),
        Source::Counts => caseframe::to_csv_counts(rows, &refs, &["time_s"]),
    }
}

/// What the detector found, for a person (one line, then each short run held at least a
/// window, and the gaps).
#[must_use]
pub fn text(s: &AxisStream, seg: &Segmentation) -> String {
    use std::fmt::Write as _;
    let st = &s.stream;
    let d = &seg.detector;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "stream {}: {} {} every {} s ({} s); still where the variance over --static-window-s {} s ({} samples) is at most --static-threshold {} times the first --rest-s {} s's ({} (cm/s^2)^2, so {}): {} intervals, {} % of the samples still",
        st.name,
        st.t.len(),
        if s.source == Source::Counts {
            "gates"
        } else {
            "samples"
        },
        sig(seg.dt_s, 6),
        sig(st.t[st.t.len() - 1] - st.t[0] + seg.dt_s, 6),
        sig(d.window_s, 6),
        seg.window,
        sig(d.threshold, 6),
        sig(d.rest_s, 6),
        sig(seg.rest_variance, 3),
        sig(seg.limit_variance, 3),
        seg.intervals.len(),
        sig(100.0 * seg.static_fraction, 3)
    );
    for iv in seg.short.iter().filter(|iv| iv.samples() >= seg.window) {
        let _ = writeln!(
            out,
            "  not a position: {}: held {} s, less than --static-min-s {} s",
            st.place(iv),
            sig(iv.held_s(seg.dt_s), 3),
            sig(d.min_static_s, 6)
        );
    }
    out
}
