//! Plots as PNG and SVG, drawn by plotters with one font lookup for the whole program.
//!
//! A [`Figure`] is one file pair (`<stem>.png`, `<stem>.svg`) of one or more stacked
//! [`Plot`] panels; a panel holds [`Series`] drawn as lines or markers, optionally with
//! error bars, on a linear or logarithmic x axis, or on rows (`x = 0, 1, …` labelled by the
//! rows' labels where they fit, else by 1-based row numbers). Every panel reserves headroom
//! for its legend, so the legend never covers a point, and long lines are thinned to the
//! envelope of at most [`MAX_LINE_POINTS`] points.

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use anyhow::Result;
use plotters::coord::Shift;
use plotters::coord::ranged1d::{Ranged, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use super::fs::{persist, temp_beside, write_atomic};

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Style {
    /// A line through the points (thinned beyond [`MAX_LINE_POINTS`]).
    Line,
    /// Filled circles.
    Points,
    /// Crosses (measured data).
    Crosses,
    /// Filled triangles.
    Triangles,
}

/// One plotted series.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend.
    pub name: String,
    /// Points.
    pub points: Vec<(f64, f64)>,
    /// How it is drawn.
    pub style: Style,
    /// Half-length of a vertical error bar at each point (empty: none).
    pub error_bars: Vec<f64>,
}

impl Series {
    fn new(name: &str, points: Vec<(f64, f64)>, style: Style) -> Self {
        Self {
            name: name.into(),
            points,
            style,
            error_bars: Vec::new(),
        }
    }
    /// A line.
    #[must_use]
    pub fn line(name: &str, points: Vec<(f64, f64)>) -> Self {
        Self::new(name, points, Style::Line)
    }
    /// Filled circles (computed values).
    #[must_use]
    pub fn markers(name: &str, points: Vec<(f64, f64)>) -> Self {
        Self::new(name, points, Style::Points)
    }
    /// Crosses (measured values).
    #[must_use]
    pub fn crosses(name: &str, points: Vec<(f64, f64)>) -> Self {
        Self::new(name, points, Style::Crosses)
    }
    /// Triangles.
    #[must_use]
    pub fn triangles(name: &str, points: Vec<(f64, f64)>) -> Self {
        Self::new(name, points, Style::Triangles)
    }
    /// With vertical error bars of half-length `half` (one per point).
    #[must_use]
    pub fn with_error_bars(mut self, half: Vec<f64>) -> Self {
        self.error_bars = half;
        self
    }
}

/// The x axis of a panel.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum XAxis {
    /// Linear.
    #[default]
    Linear,
    /// Logarithmic (positive x only).
    Log,
    /// Rows at `x = 0, 1, …, n−1`, ticked by these labels where every label is short and
    /// there are few rows, else by 1-based row numbers (a tick every few rows).
    Rows(Vec<String>),
}

/// One panel: title, axis labels (with units), series.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Plot {
    /// Title.
    pub title: String,
    /// X label.
    pub x_label: String,
    /// Y label.
    pub y_label: String,
    /// Series.
    pub series: Vec<Series>,
    /// The x axis.
    pub x_axis: XAxis,
    /// Draw a horizontal line at y = 0.
    pub zero_line: bool,
}

/// One figure: one or more panels stacked vertically, written to `<stem>.png`/`.svg`.
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    /// File stem, named after what the figure shows.
    pub stem: String,
    /// Panels, top to bottom.
    pub panels: Vec<Plot>,
}

impl Figure {
    /// A figure of one panel.
    #[must_use]
    pub fn single(stem: &str, plot: Plot) -> Self {
        Self {
            stem: stem.into(),
            panels: vec![plot],
        }
    }
}

static FONT: OnceLock<bool> = OnceLock::new();

/// Register a system TrueType font (`DejaVu Sans` or `Liberation Sans`) as the plots'
/// `sans-serif`, once for the program. Returns whether text can be drawn; without a font the
/// plots are drawn unlabelled.
pub fn font_ready() -> bool {
    *FONT.get_or_init(|| {
        let paths = [
            "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/TTF/DejaVuSans.ttf",
            "/usr/share/fonts/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
        ];
        for p in paths {
            if let Ok(bytes) = std::fs::read(p) {
                let leaked: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font("sans-serif", FontStyle::Normal, leaked).is_ok() {
                    return true;
                }
            }
        }
        false
    })
}

const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(0, 0, 0),
];

/// Labelled ticks per axis (plotters' default).
const TICKS: usize = 11;

/// The labelled ticks of a linear axis over `range` (where plotters draws them).
fn linear_ticks(range: &Range<f64>) -> Vec<f64> {
    RangedCoordf64::from(range.clone()).key_points(TICKS)
}

/// Tick labels for a linear axis whose labelled ticks are `ticks`: every label with the
/// same number of decimals, the fewest (at most 9) that write every tick exactly, so an
/// axis of whole numbers reads `0, 500, 1000` (no `.0`), one of half steps `0.0, 0.5,
/// 1.0` and one of 0.0001 steps `0.0001`, not `0.00010`; no `-0`.
pub fn tick_format(ticks: &[f64]) -> impl Fn(&f64) -> String + use<> {
    let exact = |d: i32| {
        let p = 10f64.powi(d);
        ticks.iter().all(|t| {
            let x = t * p;
            (x.round() - x).abs() <= 1e-6_f64.max(1e-12 * x.abs())
        })
    };
    #[allow(clippy::cast_sign_loss)]
    let decimals = (0..=9).find(|&d| exact(d)).unwrap_or(9) as usize;
    move |y: &f64| {
        let t = format!("{y:.decimals$}");
        if t.starts_with('-') && t[1..].chars().all(|c| c == '0' || c == '.') {
            t[1..].to_string()
        } else {
            t
        }
    }
}

/// The width of the y-label area for tick labels up to `chars` characters long at the
/// plots' 13-pixel font, with room for the axis title: at least 75 pixels.
fn y_label_area(chars: usize) -> u32 {
    u32::try_from(chars).map_or(200, |c| (34 + 8 * c).clamp(75, 200))
}

/// Most points a line series is drawn with; longer series are thinned to the minimum and
/// maximum of each of `MAX_LINE_POINTS / 2` buckets, which keeps the envelope.
pub const MAX_LINE_POINTS: usize = 4000;

/// Thin a line series to at most [`MAX_LINE_POINTS`] points, keeping each bucket's minimum
/// and maximum in order.
#[must_use]
pub fn decimate(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    if points.len() <= MAX_LINE_POINTS {
        return points.to_vec();
    }
    let per = points.len().div_ceil(MAX_LINE_POINTS / 2);
    let mut out = Vec::with_capacity(MAX_LINE_POINTS);
    for chunk in points.chunks(per) {
        let (mut lo, mut hi) = (0, 0);
        for (k, p) in chunk.iter().enumerate() {
            if p.1 < chunk[lo].1 {
                lo = k;
            }
            if p.1 > chunk[hi].1 {
                hi = k;
            }
        }
        let (a, b) = (lo.min(hi), lo.max(hi));
        out.push(chunk[a]);
        if b != a {
            out.push(chunk[b]);
        }
    }
    out
}

/// The axis ranges of a panel: the data (error bars included) with 8 % padding, plus
/// headroom for the legend box (one line per series, about 4.5 % of the panel's height
/// each).
fn bounds(plot: &Plot) -> (Range<f64>, Range<f64>) {
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for s in &plot.series {
        for (k, &(x, y)) in s.points.iter().enumerate() {
            if !(x.is_finite() && y.is_finite()) || (plot.x_axis == XAxis::Log && x <= 0.0) {
                continue;
            }
            let e = s.error_bars.get(k).copied().unwrap_or(0.0).abs();
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y - e);
            y1 = y1.max(y + e);
        }
    }
    if plot.zero_line && y0.is_finite() {
        y0 = y0.min(0.0);
        y1 = y1.max(0.0);
    }
    if let XAxis::Rows(labels) = &plot.x_axis {
        #[allow(clippy::cast_precision_loss)]
        let n = labels.len().max(1) as f64;
        (x0, x1) = (-0.5, n - 0.5);
    }
    if !x0.is_finite() || !y0.is_finite() {
        return (0.0..1.0, 0.0..1.0);
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    let (lo, hi) = if y1 - y0 < 1e-12 * y0.abs().max(1e-12) {
        (y0 - 1.0, y1 + 1.0)
    } else {
        let pad = (y1 - y0) * 0.08;
        (y0 - pad, y1 + pad)
    };
    #[allow(clippy::cast_precision_loss)]
    let share = (0.045 * plot.series.len() as f64 + 0.03).min(0.6);
    let room = (hi - lo) * share / (1.0 - share);
    (x0..x1, lo..hi + room)
}

/// Whether row labels are used as tick labels (else row numbers).
fn named_rows(labels: &[String]) -> bool {
    labels.len() <= 12
        && labels
            .iter()
            .all(|l| !l.is_empty() && l.chars().count() <= 14)
}

/// Tick label of row axis position `x`.
fn row_tick(labels: &[String], x: f64) -> String {
    let k = x.round();
    if (x - k).abs() > 1e-6 || k < 0.0 {
        return String::new();
    }
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let i = k as usize;
    match labels.get(i) {
        Some(l) if named_rows(labels) => l.clone(),
        Some(_) => (i + 1).to_string(),
        None => String::new(),
    }
}

fn err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow::anyhow!("{e:?}")
}

/// Draw one panel on `area`.
fn draw_panel<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, plot: &Plot) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let fonts = font_ready();
    let (xr, yr) = bounds(plot);
    let yticks = linear_ticks(&yr);
    let ytick = tick_format(&yticks);
    let xtick = tick_format(&linear_ticks(&xr));
    let widest = yticks.iter().map(|y| ytick(y).chars().count()).max();
    let mut b = ChartBuilder::on(area);
    // Room on the right for half of the last x label.
    b.margin(12).margin_right(30);
    if fonts {
        b.caption(&plot.title, ("sans-serif", 18))
            .x_label_area_size(40)
            .y_label_area_size(y_label_area(widest.unwrap_or(0)));
    }
    // The mesh: labels and units with a font, a bare frame without one.
    macro_rules! mesh {
        ($chart:expr $(, $m:ident => $extra:expr)?) => {{
            let mut m = $chart.configure_mesh();
            if fonts {
                m.x_desc(plot.x_label.as_str())
                    .y_desc(plot.y_label.as_str())
                    .y_label_formatter(&ytick)
                    .label_style(("sans-serif", 13));
                $( let $m = &mut m; $extra; )?
            } else {
                m.disable_x_mesh().disable_y_mesh().x_labels(0).y_labels(0);
            }
            m.draw().map_err(err)?;
        }};
    }
    match &plot.x_axis {
        XAxis::Log => {
            let x = (xr.start.max(1e-12)..xr.end.max(2e-12)).log_scale();
            let mut chart = b.build_cartesian_2d(x, yr).map_err(err)?;
            // Four significant digits: `1`, `10`, `0.5`, `2e4`.
            let log_tick = |x: &f64| super::significant(*x, 4);
            mesh!(chart, m => m.x_label_formatter(&log_tick));
            draw_series(&mut chart, plot, fonts)
        }
        XAxis::Linear => {
            let mut chart = b.build_cartesian_2d(xr, yr).map_err(err)?;
            mesh!(chart, m => m.x_label_formatter(&xtick));
            draw_series(&mut chart, plot, fonts)
        }
        XAxis::Rows(labels) => {
            let n = labels.len();
            let every = if named_rows(labels) {
                1
            } else {
                n.div_ceil(20)
            };
            let formatter = |x: &f64| {
                let k = x.round();
                #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                let on_grid = k >= 0.0 && (k as usize).is_multiple_of(every);
                if on_grid {
                    row_tick(labels, *x)
                } else {
                    String::new()
                }
            };
            let mut chart = b.build_cartesian_2d(xr, yr).map_err(err)?;
            mesh!(chart, m => m.disable_x_mesh().x_labels(n + 1).x_label_formatter(&formatter));
            draw_series(&mut chart, plot, fonts)
        }
    }
}

/// The panel's series, error bars, zero line and legend.
fn draw_series<'a, DB, X>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, RangedCoordf64>>,
    plot: &Plot,
    fonts: bool,
) -> Result<()>
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    if plot.zero_line {
        let r = chart.x_range();
        chart
            .draw_series(LineSeries::new(vec![(r.start, 0.0), (r.end, 0.0)], BLACK))
            .map_err(err)?;
    }
    for (k, s) in plot.series.iter().enumerate() {
        let c = COLORS[k % COLORS.len()];
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .collect();
        if !s.error_bars.is_empty() {
            chart
                .draw_series(
                    s.points
                        .iter()
                        .zip(&s.error_bars)
                        .filter(|&(&(x, y), &e)| x.is_finite() && y.is_finite() && e.is_finite())
                        .map(|(&(x, y), &e)| PathElement::new(vec![(x, y - e), (x, y + e)], c)),
                )
                .map_err(err)?;
        }
        let ann = match s.style {
            Style::Line => chart
                .draw_series(LineSeries::new(decimate(&pts), c.stroke_width(2)))
                .map_err(err)?,
            Style::Points => chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled())))
                .map_err(err)?,
            Style::Crosses => chart
                .draw_series(pts.iter().map(|&p| Cross::new(p, 5, c.stroke_width(2))))
                .map_err(err)?,
            Style::Triangles => chart
                .draw_series(pts.iter().map(|&p| TriangleMarker::new(p, 5, c.filled())))
                .map_err(err)?,
        };
        if fonts {
            let style = s.style;
            ann.label(s.name.as_str())
                .legend(move |(x, y)| legend_mark(style, c, x, y));
        }
    }
    if fonts && !plot.series.is_empty() {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 13))
            .draw()
            .map_err(err)?;
    }
    Ok(())
}

/// The legend's sample of a series style.
fn legend_mark<DB: DrawingBackend>(
    style: Style,
    c: RGBColor,
    x: i32,
    y: i32,
) -> DynElement<'static, DB, (i32, i32)> {
    match style {
        Style::Line => PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)).into_dyn(),
        Style::Points => Circle::new((x + 9, y), 4, c.filled()).into_dyn(),
        Style::Crosses => Cross::new((x + 9, y), 5, c.stroke_width(2)).into_dyn(),
        Style::Triangles => TriangleMarker::new((x + 9, y), 5, c.filled()).into_dyn(),
    }
}

/// Draw `fig` on `root`, its panels stacked with equal heights.
fn draw_figure<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, fig: &Figure) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(err)?;
    let n = fig.panels.len().max(1);
    let areas = root.split_evenly((n, 1));
    for (area, panel) in areas.iter().zip(&fig.panels) {
        draw_panel(area, panel)?;
    }
    root.present().map_err(err)?;
    Ok(())
}

/// Pixel size of a figure of `panels` panels.
fn size(panels: usize) -> (u32, u32) {
    let n = u32::try_from(panels.max(1)).unwrap_or(1);
    (960, 300 + 300 * n)
}

/// Draw `fig` into `dir` as `<stem>.png` and `<stem>.svg` (each written atomically).
/// Without a usable font the plots are drawn without text.
///
/// # Errors
/// Drawing or I/O errors.
pub fn write_figure(dir: &Path, fig: &Figure) -> Result<Vec<PathBuf>> {
    let png = dir.join(format!("{}.png", fig.stem));
    let svg = dir.join(format!("{}.svg", fig.stem));
    let wh = size(fig.panels.len());
    write_png(&png, wh, |area| draw_figure(&area, fig))?;
    let mut s = String::new();
    draw_figure(
        &SVGBackend::with_string(&mut s, wh).into_drawing_area(),
        fig,
    )?;
    write_atomic(&svg, s.as_bytes())?;
    Ok(vec![png, svg])
}

/// A PNG of `w × h` pixels at `path`, drawn by `draw` and written whole or not at all.
/// The pixels are drawn into memory and encoded into the open temporary file (the same
/// encoder and settings as plotters' own), never reopened by its name: after a signal's
/// clean-up has removed the temporary, nothing makes it again.
///
/// # Errors
/// Drawing or writing fails; the message names `path`.
pub fn write_png(
    path: &Path,
    (w, h): (u32, u32),
    draw: impl FnOnce(DrawingArea<BitMapBackend<'_>, Shift>) -> Result<()>,
) -> Result<()> {
    use anyhow::Context as _;
    use image::ImageEncoder as _;
    let mut pixels = vec![0u8; 3 * w as usize * h as usize];
    draw(BitMapBackend::with_buffer(&mut pixels, (w, h)).into_drawing_area())?;
    let tmp = temp_beside(path)?;
    let mut out = std::io::BufWriter::new(tmp.as_file());
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(&pixels, w, h, image::ColorType::Rgb8)
        .with_context(|| format!("cannot write {}", path.display()))?;
    std::io::Write::flush(&mut out).with_context(|| format!("cannot write {}", path.display()))?;
    drop(out);
    persist(tmp, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_the_envelope() {
        let pts: Vec<(f64, f64)> = (0..100_000)
            .map(|k| (f64::from(k), f64::from(if k == 54_321 { 9 } else { k % 7 })))
            .collect();
        let d = decimate(&pts);
        assert!(d.len() <= MAX_LINE_POINTS);
        assert!(d.iter().any(|p| (p.1 - 9.0).abs() < 1e-12));
        assert!(d.iter().any(|p| p.1.abs() < 1e-12));
        assert!(d.windows(2).all(|w| w[0].0 < w[1].0));
    }

    /// Tick labels: whole-number axes without `.0`, the same decimals along an axis, the
    /// fewest that write every tick (plotters' floating-point ticks included), no `-0`; and
    /// the ticks plotters draws for a few ranges read as expected.
    #[test]
    fn tick_labels_have_the_digits_their_ticks_need() {
        let show = |ticks: &[f64]| -> Vec<String> {
            let f = tick_format(ticks);
            ticks.iter().map(f).collect()
        };
        assert_eq!(
            show(&[0.0, 500.0, 1000.0, 4000.0]),
            ["0", "500", "1000", "4000"]
        );
        assert_eq!(show(&[0.0, 0.5, 1.0, 1.5]), ["0.0", "0.5", "1.0", "1.5"]);
        assert_eq!(
            show(&[-0.0001, 0.0, 0.000_1, 0.000_2 + 1e-19, 0.1 * 0.003]),
            ["-0.0001", "0.0000", "0.0001", "0.0002", "0.0003"]
        );
        assert_eq!(show(&[-0.0, 2.0]), ["0", "2"]);
        assert_eq!(tick_format(&[0.0, 0.5])(&-0.0001), "0.0");
        // plotters' own ticks over ranges of the report's figures.
        for (range, want) in [
            (-120.0..4100.0, vec!["0", "500", "1000"]),
            (0.0..360.0, vec!["0", "50", "100"]),
            (-0.000_12..0.000_45, vec!["-0.0001", "0.0000", "0.0001"]),
            (-2.2..2.8, vec!["-2.0", "-1.5", "-1.0"]),
        ] {
            let ticks = linear_ticks(&range);
            let labels = show(&ticks);
            assert_eq!(labels[..want.len()], want[..], "{range:?}: {labels:?}");
        }
        assert_eq!(y_label_area(4), 75);
        assert!(y_label_area(12) > 75);
    }

    #[test]
    fn legend_headroom_and_rows() {
        let p = Plot {
            series: vec![Series::markers("a", vec![(0.0, -1.0), (1.0, 1.0)])],
            x_axis: XAxis::Rows(vec!["45".into(), "90".into()]),
            ..Plot::default()
        };
        let (x, y) = bounds(&p);
        assert_eq!(x, -0.5..1.5);
        assert!(y.start < -1.0 && y.end > 1.2, "{y:?}");
        let labels: Vec<String> = (0..30).map(|k| format!("row {k}")).collect();
        assert_eq!(row_tick(&labels, 4.0), "5");
        assert_eq!(row_tick(&labels[..2], 1.0), "row 1");
        assert_eq!(row_tick(&labels, 4.5), "");
    }
}
