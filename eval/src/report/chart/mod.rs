//! Charts written as PNG and SVG with plotters: line charts ([`Chart`]) and bird's-eye path
//! charts with one scale on both axes ([`PathFigure`]).
//!
//! Every chart keeps its legend in a band to the right of the plot, so that no legend ever
//! covers data ([`legend`]), and labels its ticks with as many decimals as the tick step
//! needs ([`ticks`]): "20", not "20.0".
//!
//! Text is drawn with a TrueType font read from the system once per process:
//! `$DYNOTRAJ_FONT`, else DejaVu Sans (`fonts-dejavu-core`, which scripts/setup.sh installs).

mod legend;
mod line;
mod path;
pub mod ticks;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use anyhow::Context as _;
use plotters::coord::Shift;
use plotters::prelude::*;

pub use path::{Marker, Panel, PathFigure, PathLine};

/// The font file used when `DYNOTRAJ_FONT` is unset.
pub const DEFAULT_FONT: &str = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

/// The colour of a line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Colour {
    /// The palette's colour at the line's position in its chart.
    #[default]
    Auto,
    /// The palette's colour `n` (modulo its length): lines that belong together share one.
    Palette(usize),
    /// Near-black, for references (the truth, a history).
    Ink,
    /// Grey, for context.
    Grey,
}

/// How a line is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Style {
    /// Its colour.
    pub colour: Colour,
    /// Dashed (a baseline, a reference) rather than solid.
    pub dashed: bool,
}

/// One line of a chart.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// (x, y) points in x order; non-finite points are left out.
    pub points: Vec<(f64, f64)>,
    /// How it is drawn.
    pub style: Style,
}

impl Series {
    /// A solid line in the palette's next colour.
    #[must_use]
    pub fn new(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self { label: label.into(), points, style: Style::default() }
    }

    /// This line drawn with `style`.
    #[must_use]
    pub fn styled(self, style: Style) -> Self {
        Self { style, ..self }
    }
}

/// A line chart.
#[derive(Debug, Clone, PartialEq)]
pub struct Chart {
    /// Caption above the plot.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// The lines.
    pub series: Vec<Series>,
}

/// The size of a line chart's images, pixels.
pub const LINE_CHART_SIZE: (u32, u32) = (1000, 500);

fn register_font() -> Result<(), String> {
    static DONE: OnceLock<Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        let path = std::env::var_os("DYNOTRAJ_FONT").map_or_else(|| PathBuf::from(DEFAULT_FONT), PathBuf::from);
        let bytes = std::fs::read(&path).map_err(|e| {
            format!("reading the chart font {}: {e} (install fonts-dejavu-core or set DYNOTRAJ_FONT)", path.display())
        })?;
        // plotters keeps fonts for the life of the process.
        let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
        plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
            .map_err(|_| format!("{}: not a TrueType or OpenType font", path.display()))
    })
    .clone()
}

/// The palette (matplotlib's tab10 less its grey, which [`Colour::Grey`] is).
const PALETTE: [RGBColor; 9] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

impl Colour {
    /// The colour of a line drawn `index`-th in its chart.
    fn rgb(self, index: usize) -> RGBColor {
        match self {
            Self::Auto => PALETTE[index % PALETTE.len()],
            Self::Palette(n) => PALETTE[n % PALETTE.len()],
            Self::Ink => RGBColor(20, 20, 20),
            Self::Grey => RGBColor(150, 150, 150),
        }
    }
}

/// Points a line may have and still be drawn 2 pixels wide.
const WIDE_LINE_POINTS: usize = 250;

/// The stroke width of a line of `points` points: plotters draws a wide line as a polygon
/// with mitred joins, which spike far past the data (and across the axes) where a dense,
/// jagged line turns sharply; a dense line is drawn 1 pixel wide instead.
fn stroke_width(points: usize) -> u32 {
    if points > WIDE_LINE_POINTS { 1 } else { 2 }
}

/// The points of `points` that can be drawn.
fn finite(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    points.iter().copied().filter(|(x, y)| x.is_finite() && y.is_finite()).collect()
}

/// The range of finite `points`, padded by 5 % of each span (1 when a span is empty), or
/// `None` when there is no finite point.
fn bounds<'a>(points: impl Iterator<Item = &'a (f64, f64)>) -> Option<((f64, f64), (f64, f64))> {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for &(x, y) in points.filter(|(x, y)| x.is_finite() && y.is_finite()) {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !x0.is_finite() {
        return None;
    }
    let pad = |a: f64, b: f64| if b > a { ((b - a) * 0.05).max(1e-9) } else { 1.0 };
    let (px, py) = (pad(x0, x1), pad(y0, y1));
    Some(((x0 - px, x1 + px), (y0 - py, y1 + py)))
}

/// Draws the grid and both axes with their descriptions (`labels`: x, y) and tick labels with
/// only the decimals each axis's step needs, in `font` px (descriptions one px larger).
fn draw_axes<DB: DrawingBackend>(
    c: &mut ChartContext<
        '_,
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
    labels: (&str, &str),
    (x, y): ((f64, f64), (f64, f64)),
    font: u32,
) -> Result<(), String> {
    let (dx, dy) = (ticks::decimals_for(x, ticks::LABELS), ticks::decimals_for(y, ticks::LABELS));
    let fx = |v: &f64| ticks::format_tick(*v, dx);
    let fy = |v: &f64| ticks::format_tick(*v, dy);
    c.configure_mesh()
        .x_desc(labels.0)
        .y_desc(labels.1)
        .x_labels(ticks::LABELS)
        .y_labels(ticks::LABELS)
        .x_label_formatter(&fx)
        .y_label_formatter(&fy)
        .label_style(("sans-serif", font))
        .axis_desc_style(("sans-serif", font + 1))
        .draw()
        .map_err(|x| err(&x))
}

/// A plotters error as text (the backends' error types differ).
fn err(e: &dyn std::fmt::Display) -> String {
    e.to_string()
}

/// Something drawn the same way into a PNG and an SVG.
trait Drawing {
    /// Image size, pixels.
    fn size(&self) -> (u32, u32);

    /// Draws onto `root`.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String>
    where
        DB::ErrorType: 'static;
}

/// Writes `drawing` as `stem.png` and `stem.svg`; returns both paths.
fn write_both(drawing: &impl Drawing, stem: &Path) -> anyhow::Result<[PathBuf; 2]> {
    register_font().map_err(anyhow::Error::msg)?;
    let png = stem.with_extension("png");
    let svg = stem.with_extension("svg");
    {
        let root = BitMapBackend::new(&png, drawing.size()).into_drawing_area();
        drawing.draw(&root).and_then(|()| root.present().map_err(|e| err(&e)))
    }
    .map_err(anyhow::Error::msg)
    .with_context(|| format!("drawing {}", png.display()))?;
    {
        let root = SVGBackend::new(&svg, drawing.size()).into_drawing_area();
        drawing.draw(&root).and_then(|()| root.present().map_err(|e| err(&e)))
    }
    .map_err(anyhow::Error::msg)
    .with_context(|| format!("drawing {}", svg.display()))?;
    Ok([png, svg])
}

/// Writes `chart` as `stem.png` and `stem.svg` ([`LINE_CHART_SIZE`]); returns both paths.
///
/// # Errors
/// No font, no finite point, or a file that cannot be written, named.
pub fn write_chart(chart: &Chart, stem: &Path) -> anyhow::Result<[PathBuf; 2]> {
    write_both(chart, stem)
}

/// Writes `figure` as `stem.png` and `stem.svg`; returns both paths.
///
/// # Errors
/// No font, a panel with no finite point, or a file that cannot be written, named.
pub fn write_paths(figure: &PathFigure, stem: &Path) -> anyhow::Result<[PathBuf; 2]> {
    write_both(figure, stem)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_chart_is_written_as_png_and_svg() {
        let dir = tempfile::tempdir().unwrap();
        let chart = Chart {
            title: "speed".into(),
            x_label: "time (s; frames at 20 Hz)".into(),
            y_label: "m/s".into(),
            series: vec![
                Series::new("gt", (0..50).map(|k| (f64::from(k) * 0.15, (f64::from(k) * 0.3).sin())).collect()),
                Series::new("estimated", vec![(0.0, 0.5), (1.0, f64::NAN), (7.35, 0.7)])
                    .styled(Style { colour: Colour::Palette(0), dashed: true }),
            ],
        };
        let [png, svg] = write_chart(&chart, &dir.path().join("speed")).unwrap();
        let bytes = std::fs::read(png).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        let text = std::fs::read_to_string(svg).unwrap();
        assert!(text.contains("<svg") && text.contains("estimated"), "legend text in the SVG");
        assert!(text.contains("time (s; frames at 20 Hz)"), "the x axis label");
        // Whole-second ticks read "7", never "7.0"; the y axis's 0.5 steps "0.5", never "0.50"
        // (plotters writes each text on a line of its own).
        assert!(text.contains("\n7\n") && !text.contains("\n7.0\n"), "{text}");
        assert!(text.contains("\n-0.5\n") && !text.contains("\n0.50\n"), "{text}");
        let empty = Chart { series: vec![], ..chart };
        assert!(write_chart(&empty, &dir.path().join("empty")).is_err());
    }
}
