//! Line charts written as PNG and SVG with plotters.
//!
//! Text is drawn with a TrueType font read from the system once per process:
//! `$DYNOTRAJ_FONT`, else DejaVu Sans (`fonts-dejavu-core`, which scripts/setup.sh installs).

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use anyhow::Context as _;
use plotters::prelude::*;

/// The font file used when `DYNOTRAJ_FONT` is unset.
pub const DEFAULT_FONT: &str = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

/// One line of a chart.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// (x, y) points in x order; non-finite points are left out.
    pub points: Vec<(f64, f64)>,
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

const COLOURS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

fn bounds(chart: &Chart) -> Option<((f64, f64), (f64, f64))> {
    let pts = chart.series.iter().flat_map(|s| s.points.iter()).filter(|(x, y)| x.is_finite() && y.is_finite());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for &(x, y) in pts {
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

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, plotters::coord::Shift>, chart: &Chart) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |e: &dyn std::fmt::Display| e.to_string();
    root.fill(&WHITE).map_err(|x| e(&x))?;
    let ((x0, x1), (y0, y1)) = bounds(chart).ok_or("the chart has no finite point")?;
    let mut c = ChartBuilder::on(&root)
        .caption(&chart.title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|x| e(&x))?;
    c.configure_mesh()
        .x_desc(chart.x_label.as_str())
        .y_desc(chart.y_label.as_str())
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|x| e(&x))?;
    for (i, s) in chart.series.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        let pts: Vec<(f64, f64)> = s.points.iter().copied().filter(|(x, y)| x.is_finite() && y.is_finite()).collect();
        c.draw_series(LineSeries::new(pts, colour.stroke_width(2)))
            .map_err(|x| e(&x))?
            .label(s.label.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2)));
    }
    c.configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(|x| e(&x))?;
    root.present().map_err(|x| e(&x))?;
    Ok(())
}

/// Writes `chart` as `stem.png` (900 x 500) and `stem.svg`; returns both paths.
///
/// # Errors
/// No font, no finite point, or a file that cannot be written, named.
pub fn write_chart(chart: &Chart, stem: &Path) -> anyhow::Result<[PathBuf; 2]> {
    register_font().map_err(anyhow::Error::msg)?;
    let png = stem.with_extension("png");
    let svg = stem.with_extension("svg");
    draw(BitMapBackend::new(&png, (900, 500)).into_drawing_area(), chart)
        .map_err(anyhow::Error::msg)
        .with_context(|| format!("drawing {}", png.display()))?;
    draw(SVGBackend::new(&svg, (900, 500)).into_drawing_area(), chart)
        .map_err(anyhow::Error::msg)
        .with_context(|| format!("drawing {}", svg.display()))?;
    Ok([png, svg])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_chart_is_written_as_png_and_svg() {
        let dir = tempfile::tempdir().unwrap();
        let chart = Chart {
            title: "speed".into(),
            x_label: "frame".into(),
            y_label: "m/s".into(),
            series: vec![
                Series {
                    label: "gt".into(),
                    points: (0..50).map(|k| (f64::from(k), (f64::from(k) * 0.3).sin())).collect(),
                },
                Series { label: "estimated".into(), points: vec![(0.0, 0.5), (10.0, f64::NAN), (49.0, 0.7)] },
            ],
        };
        let [png, svg] = write_chart(&chart, &dir.path().join("speed")).unwrap();
        let bytes = std::fs::read(png).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        let text = std::fs::read_to_string(svg).unwrap();
        assert!(text.contains("<svg") && text.contains("estimated"), "legend text in the SVG");
        let empty = Chart { series: vec![], ..chart };
        assert!(write_chart(&empty, &dir.path().join("empty")).is_err());
    }
}
