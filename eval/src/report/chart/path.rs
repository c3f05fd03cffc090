//! Bird's-eye path charts: x/y positions in metres with one scale on both axes (a metre east is
//! as long as a metre north, so shapes and turns read true), one or more panels side by side
//! sharing one legend.

use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::legend::{self, Entry};
use super::{Drawing, Style, bounds, draw_axes, err, finite, stroke_width};

/// A dot on a path.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Marker {
    /// None.
    #[default]
    None,
    /// At the first point of each segment (where a trajectory starts).
    Start,
    /// At the last point of each segment (where a forecast is made: the current position).
    End,
}

/// One labelled path: one or more segments (a source seen in several runs is drawn without
/// joining them across its gaps).
#[derive(Debug, Clone, PartialEq)]
pub struct PathLine {
    /// Legend label; paths of one label share one legend entry.
    pub label: String,
    /// The segments, each (x, y) points in order.
    pub segments: Vec<Vec<(f64, f64)>>,
    /// How it is drawn.
    pub style: Style,
    /// Its dots.
    pub marker: Marker,
}

/// One plot of a path figure.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// Caption above the panel (empty: none).
    pub title: String,
    /// The paths.
    pub paths: Vec<PathLine>,
}

/// A bird's-eye figure: panels side by side, one legend.
#[derive(Debug, Clone, PartialEq)]
pub struct PathFigure {
    /// Caption above the panels.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// The panels, left to right.
    pub panels: Vec<Panel>,
    /// Image size, pixels.
    pub size: (u32, u32),
}

/// The ranges that show `data` (x and y ranges) at one scale on both axes in a plotting area
/// of `pixels` (width, height): the span that needs fewer metres per pixel is widened about its
/// centre.
#[must_use]
pub fn equal_scale(data: ((f64, f64), (f64, f64)), pixels: (u32, u32)) -> ((f64, f64), (f64, f64)) {
    let ((x0, x1), (y0, y1)) = data;
    let (w, h) = (f64::from(pixels.0.max(1)), f64::from(pixels.1.max(1)));
    let per_pixel = ((x1 - x0) / w).max((y1 - y0) / h);
    let widen = |a: f64, b: f64, n: f64| {
        let (mid, half) = ((a + b) / 2.0, per_pixel * n / 2.0);
        (mid - half, mid + half)
    };
    (widen(x0, x1, w), widen(y0, y1, h))
}

impl PathFigure {
    /// The legend: one entry per label, in order of first appearance.
    fn entries(&self) -> Vec<Entry> {
        let mut out: Vec<Entry> = Vec::new();
        for p in self.panels.iter().flat_map(|p| p.paths.iter()) {
            if !out.iter().any(|e| e.label == p.label) {
                out.push(Entry {
                    label: p.label.clone(),
                    colour: p.style.colour.rgb(out.len()),
                    dashed: p.style.dashed,
                    dot: p.marker != Marker::None,
                });
            }
        }
        out
    }

    fn draw_panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        panel: &Panel,
        entries: &[Entry],
    ) -> Result<(), String>
    where
        DB::ErrorType: 'static,
    {
        let area = if panel.title.is_empty() {
            area.clone()
        } else {
            area.titled(&panel.title, ("sans-serif", 15)).map_err(|x| err(&x))?
        };
        let points = panel.paths.iter().flat_map(|p| p.segments.iter().flatten());
        let data = bounds(points).ok_or_else(|| format!("panel `{}` has no finite point", panel.title))?;
        let builder = || {
            let mut b = ChartBuilder::on(&area);
            b.margin(12).x_label_area_size(44).y_label_area_size(64);
            b
        };
        // Building draws nothing without a caption: a first build measures the plotting area.
        let pixels =
            builder().build_cartesian_2d(0f64..1f64, 0f64..1f64).map_err(|x| err(&x))?.plotting_area().dim_in_pixel();
        let ((x0, x1), (y0, y1)) = equal_scale(data, pixels);
        let mut c = builder().build_cartesian_2d(x0..x1, y0..y1).map_err(|x| err(&x))?;
        draw_axes(&mut c, (self.x_label.as_str(), self.y_label.as_str()), ((x0, x1), (y0, y1)), 13)?;
        // Lines first, then the dots, so that no line hides where a path starts or a forecast is
        // made.
        let mut dots = Vec::new();
        for p in &panel.paths {
            let Some(entry) = entries.iter().find(|e| e.label == p.label) else { continue };
            for segment in &p.segments {
                let pts = finite(segment);
                let style = entry.colour.stroke_width(stroke_width(pts.len()));
                let dot = match p.marker {
                    Marker::None => None,
                    Marker::Start => pts.first(),
                    Marker::End => pts.last(),
                };
                dots.extend(dot.map(|&at| Circle::new(at, 4, entry.colour.filled())));
                if p.style.dashed {
                    c.draw_series(std::iter::once(DashedPathElement::new(pts, 6, 4, style))).map_err(|x| err(&x))?;
                } else {
                    c.draw_series(LineSeries::new(pts, style)).map_err(|x| err(&x))?;
                }
            }
        }
        c.draw_series(dots).map_err(|x| err(&x))?;
        Ok(())
    }
}

impl Drawing for PathFigure {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String>
    where
        DB::ErrorType: 'static,
    {
        if self.panels.is_empty() {
            return Err("the figure has no panel".into());
        }
        root.fill(&WHITE).map_err(|x| err(&x))?;
        // Room above the title: plotters sets it flush with the top edge.
        let body = root.margin(8, 0, 0, 0).titled(&self.title, ("sans-serif", 20)).map_err(|x| err(&x))?;
        let entries = self.entries();
        let (plots, band) = legend::split(&body, &entries)?;
        for (area, panel) in plots.split_evenly((1, self.panels.len())).iter().zip(&self.panels) {
            self.draw_panel(area, panel, &entries)?;
        }
        legend::draw(&band, &entries)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::chart::{Colour, write_paths};

    #[test]
    fn one_scale_on_both_axes() {
        // 10 m by 2 m of data in 400 x 400 pixels: the y span widens to 10 m.
        let ((x0, x1), (y0, y1)) = equal_scale(((0.0, 10.0), (4.0, 6.0)), (400, 400));
        assert!((x1 - x0 - 10.0).abs() < 1e-9 && (y1 - y0 - 10.0).abs() < 1e-9);
        assert!(((y0 + y1) / 2.0 - 5.0).abs() < 1e-9, "about the centre");
        // 2 m by 2 m in 800 x 400 pixels: 4 m across, 2 m up.
        let ((x0, x1), (y0, y1)) = equal_scale(((0.0, 2.0), (0.0, 2.0)), (800, 400));
        assert!((x1 - x0 - 4.0).abs() < 1e-9 && (y1 - y0 - 2.0).abs() < 1e-9);
    }

    #[test]
    fn a_path_figure_is_written_as_png_and_svg() {
        let dir = tempfile::tempdir().unwrap();
        let line = |label: &str, dy: f64, style: Style, marker: Marker| PathLine {
            label: label.into(),
            segments: vec![(0..20).map(|k| (f64::from(k), dy + 0.01 * f64::from(k * k))).collect(), vec![(25.0, 5.0)]],
            style,
            marker,
        };
        let panel = |title: &str| Panel {
            title: title.into(),
            paths: vec![
                line("labels (gt)", 0.0, Style::default(), Marker::Start),
                line("truth", 0.3, Style { colour: Colour::Ink, dashed: true }, Marker::None),
            ],
        };
        let figure = PathFigure {
            title: "bird's-eye".into(),
            x_label: "world x (m)".into(),
            y_label: "world y (m)".into(),
            panels: vec![panel("a"), panel("b")],
            size: (1200, 500),
        };
        let [png, svg] = write_paths(&figure, &dir.path().join("paths")).unwrap();
        assert_eq!(&std::fs::read(png).unwrap()[1..4], b"PNG");
        let text = std::fs::read_to_string(svg).unwrap();
        assert_eq!(text.matches("\nlabels (gt)\n").count(), 1, "one legend entry per label");
        assert!(text.contains("world y (m)"));
        let empty = PathFigure { panels: vec![Panel { title: "none".into(), paths: vec![] }], ..figure };
        assert!(write_paths(&empty, &dir.path().join("empty")).is_err());
    }
}
