//! Tables, CSV, plots (PNG and SVG) and atomic file writes for the experiments.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use anyhow::{Context, Result};
use plotters::prelude::*;

/// Write `bytes` to `path` atomically: a temporary file in the same folder, then a rename,
/// so a reader never sees half a file.
///
/// # Errors
/// Any I/O error, with the path.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path.parent().unwrap_or_else(|| Path::new("."));
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let name = path
        .file_name()
        .map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
    let tmp = dir.join(format!(".{name}.tmp{}", std::process::id()));
    std::fs::write(&tmp, bytes).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("renaming to {}", path.display()))?;
    Ok(())
}

/// A cell: a number (with its display precision) or text; `None` is a missing value.
#[derive(Clone, Debug, PartialEq)]
pub enum Cell {
    /// Number and decimals shown.
    Num(f64, usize),
    /// Text.
    Text(String),
    /// Missing (shown as `—`, empty in CSV).
    Missing,
}

impl Cell {
    fn show(&self) -> String {
        match self {
            Cell::Num(x, d) => format!("{x:.d$}", d = *d),
            Cell::Text(s) => s.clone(),
            Cell::Missing => "—".into(),
        }
    }
    fn csv(&self) -> String {
        match self {
            Cell::Num(x, _) => format!("{x}"),
            Cell::Text(s) => s.clone(),
            Cell::Missing => String::new(),
        }
    }
}

/// `Cell::Num` shorthand.
#[must_use]
pub fn num(x: f64, decimals: usize) -> Cell {
    Cell::Num(x, decimals)
}

/// `Cell::Text` shorthand.
#[must_use]
pub fn text(s: impl Into<String>) -> Cell {
    Cell::Text(s.into())
}

/// A result table.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Table {
    /// Title.
    pub title: String,
    /// Column names (with units).
    pub header: Vec<String>,
    /// Rows.
    pub rows: Vec<Vec<Cell>>,
}

impl Table {
    /// An empty table.
    #[must_use]
    pub fn new(title: &str, header: &[&str]) -> Self {
        Self {
            title: title.into(),
            header: header.iter().map(|s| (*s).to_string()).collect(),
            rows: Vec::new(),
        }
    }

    /// Aligned text.
    #[must_use]
    pub fn to_text(&self) -> String {
        let cells: Vec<Vec<String>> = self
            .rows
            .iter()
            .map(|r| r.iter().map(Cell::show).collect())
            .collect();
        let mut w: Vec<usize> = self.header.iter().map(|h| h.chars().count()).collect();
        for r in &cells {
            for (i, c) in r.iter().enumerate() {
                if i < w.len() {
                    w[i] = w[i].max(c.chars().count());
                }
            }
        }
        let mut s = format!("{}\n", self.title);
        let line = |s: &mut String, items: &[String]| {
            for (i, c) in items.iter().enumerate() {
                let pad = w[i].saturating_sub(c.chars().count());
                let _ = write!(s, "{}{}  ", " ".repeat(pad), c);
            }
            s.truncate(s.trim_end().len());
            s.push('\n');
        };
        line(&mut s, &self.header);
        for r in &cells {
            line(&mut s, r);
        }
        s
    }

    /// Markdown.
    #[must_use]
    pub fn to_markdown(&self) -> String {
        let mut s = format!(
            "| {} |\n|{}\n",
            self.header.join(" | "),
            "---|".repeat(self.header.len())
        );
        for r in &self.rows {
            let cells: Vec<String> = r.iter().map(Cell::show).collect();
            let _ = writeln!(s, "| {} |", cells.join(" | "));
        }
        s
    }

    /// CSV (header with units; missing values empty).
    ///
    /// # Errors
    /// Never in practice (in-memory writer).
    pub fn to_csv(&self) -> Result<String> {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(&self.header)?;
        for r in &self.rows {
            w.write_record(r.iter().map(Cell::csv))?;
        }
        Ok(String::from_utf8(w.into_inner()?)?)
    }
}

/// One plotted series.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend.
    pub name: String,
    /// Points.
    pub points: Vec<(f64, f64)>,
    /// Draw markers only (measured data) instead of a line.
    pub markers: bool,
}

impl Series {
    /// A line.
    #[must_use]
    pub fn line(name: &str, points: Vec<(f64, f64)>) -> Self {
        Self {
            name: name.into(),
            points,
            markers: false,
        }
    }
    /// Markers.
    #[must_use]
    pub fn markers(name: &str, points: Vec<(f64, f64)>) -> Self {
        Self {
            name: name.into(),
            points,
            markers: true,
        }
    }
}

/// A plot: title, axis labels (with units), series, log x axis or not.
#[derive(Clone, Debug, PartialEq)]
pub struct Plot {
    /// Title.
    pub title: String,
    /// X label.
    pub x_label: String,
    /// Y label.
    pub y_label: String,
    /// Series.
    pub series: Vec<Series>,
    /// Logarithmic x axis.
    pub log_x: bool,
}

static FONT: OnceLock<bool> = OnceLock::new();

/// Register DejaVu Sans (if present) as the plots' font. Returns whether text can be drawn.
fn font_ready() -> bool {
    *FONT.get_or_init(|| {
        let paths = [
            "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/dejavu/DejaVuSans.ttf",
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

/// Tick labels for an axis spanning `span`: enough decimals for about ten ticks, and no
/// "-0.0".
pub(crate) fn value_tick(span: f64) -> impl Fn(&f64) -> String {
    let step = (span / 10.0).abs().max(1e-9);
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let decimals = (-step.log10().floor()).clamp(0.0, 6.0) as usize;
    move |y: &f64| {
        let t = format!("{y:.decimals$}");
        if t.trim_start_matches('-')
            .chars()
            .all(|c| c == '0' || c == '.')
        {
            t.trim_start_matches('-').to_string()
        } else {
            t
        }
    }
}

fn bounds(plot: &Plot) -> (f64, f64, f64, f64) {
    let pts = plot
        .series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(|p| p.0.is_finite() && p.1.is_finite());
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for &(x, y) in pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !x0.is_finite() {
        return (0.0, 1.0, 0.0, 1.0);
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    let pad = ((y1 - y0) * 0.08).max(1e-9);
    if y1 - y0 < 1e-12 {
        (x0, x1, y0 - 1.0, y1 + 1.0)
    } else {
        (x0, x1, y0 - pad, y1 + pad)
    }
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    plot: &Plot,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let fonts = font_ready();
    let (x0, x1, y0, y1) = bounds(plot);
    let mut b = ChartBuilder::on(&root);
    b.margin(15);
    if fonts {
        b.caption(&plot.title, ("sans-serif", 20))
            .x_label_area_size(40)
            .y_label_area_size(70);
    }
    macro_rules! body {
        ($chart:expr) => {{
            let mut chart = $chart;
            if fonts {
                chart
                    .configure_mesh()
                    .x_desc(plot.x_label.as_str())
                    .y_desc(plot.y_label.as_str())
                    .y_label_formatter(&value_tick(y1 - y0))
                    .label_style(("sans-serif", 13))
                    .draw()
                    .map_err(|e| anyhow::anyhow!("{e:?}"))?;
            } else {
                chart
                    .configure_mesh()
                    .disable_x_mesh()
                    .disable_y_mesh()
                    .x_labels(0)
                    .y_labels(0)
                    .draw()
                    .map_err(|e| anyhow::anyhow!("{e:?}"))?;
            }
            for (k, s) in plot.series.iter().enumerate() {
                let c = COLORS[k % COLORS.len()];
                let pts: Vec<(f64, f64)> = s
                    .points
                    .iter()
                    .copied()
                    .filter(|p| p.0.is_finite() && p.1.is_finite())
                    .collect();
                let ann = if s.markers {
                    chart
                        .draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled())))
                        .map_err(|e| anyhow::anyhow!("{e:?}"))?
                } else {
                    chart
                        .draw_series(LineSeries::new(pts, c.stroke_width(2)))
                        .map_err(|e| anyhow::anyhow!("{e:?}"))?
                };
                if fonts {
                    ann.label(s.name.as_str()).legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2))
                    });
                }
            }
            if fonts {
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .label_font(("sans-serif", 13))
                    .draw()
                    .map_err(|e| anyhow::anyhow!("{e:?}"))?;
            }
        }};
    }
    if plot.log_x {
        let c = b
            .build_cartesian_2d((x0.max(1e-9)..x1).log_scale(), y0..y1)
            .map_err(|e| anyhow::anyhow!("{e:?}"))?;
        body!(c);
    } else {
        let c = b
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| anyhow::anyhow!("{e:?}"))?;
        body!(c);
    }
    root.present().map_err(|e| anyhow::anyhow!("{e:?}"))?;
    Ok(())
}

/// Draw `plot` to `stem.png` and `stem.svg` (each written atomically). Without a usable
/// font the plots are drawn without text.
///
/// # Errors
/// Drawing or I/O errors.
pub fn write_plot(stem: &Path, plot: &Plot) -> Result<Vec<PathBuf>> {
    let dir = stem.parent().unwrap_or_else(|| Path::new("."));
    std::fs::create_dir_all(dir)?;
    let name = stem
        .file_name()
        .map_or_else(|| "plot".into(), |n| n.to_string_lossy().into_owned());
    let png = dir.join(format!("{name}.png"));
    let svg = dir.join(format!("{name}.svg"));
    let tmp_png = dir.join(format!(".{name}.tmp{}.png", std::process::id()));
    {
        let root = BitMapBackend::new(&tmp_png, (900, 560)).into_drawing_area();
        draw(root, plot)?;
    }
    std::fs::rename(&tmp_png, &png)?;
    let mut s = String::new();
    {
        let root = SVGBackend::with_string(&mut s, (900, 560)).into_drawing_area();
        draw(root, plot)?;
    }
    write_atomic(&svg, s.as_bytes())?;
    Ok(vec![png, svg])
}

/// An experiment's output: its tables and plots, written as `name.csv` (first table;
/// further tables `name-2.csv`...) and `name.png`/`name.svg` (further plots `name-2`...).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Output {
    /// File stem.
    pub name: String,
    /// Tables.
    pub tables: Vec<Table>,
    /// Plots.
    pub plots: Vec<Plot>,
    /// Extra text (summary lines).
    pub notes: Vec<String>,
}

impl Output {
    /// Print the tables and notes, write the CSVs and plots into `dir`. Plot failures are
    /// reported as warnings, not errors.
    ///
    /// # Errors
    /// I/O errors on CSV.
    pub fn emit(&self, dir: &Path, print: bool) -> Result<Vec<PathBuf>> {
        let mut files = Vec::new();
        for (k, t) in self.tables.iter().enumerate() {
            let f = if k == 0 {
                dir.join(format!("{}.csv", self.name))
            } else {
                dir.join(format!("{}-{}.csv", self.name, k + 1))
            };
            if print && t.rows.len() <= 40 {
                println!("{}", t.to_text());
            } else if print {
                println!("{}: {} rows, in {}\n", t.title, t.rows.len(), f.display());
            }
            write_atomic(&f, t.to_csv()?.as_bytes())?;
            files.push(f);
        }
        if print {
            for n in &self.notes {
                println!("{n}");
            }
        }
        for (k, p) in self.plots.iter().enumerate() {
            let stem = if k == 0 {
                dir.join(&self.name)
            } else {
                dir.join(format!("{}-{}", self.name, k + 1))
            };
            match write_plot(&stem, p) {
                Ok(mut f) => files.append(&mut f),
                Err(e) => eprintln!("warning: plot {} not written: {e:#}", stem.display()),
            }
        }
        Ok(files)
    }
}
