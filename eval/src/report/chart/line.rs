//! Drawing a line chart: title, plot with its axes, legend band.

use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::legend::{self, Entry};
use super::{Chart, Drawing, LINE_CHART_SIZE, bounds, draw_axes, err, finite, stroke_width};

impl Drawing for Chart {
    fn size(&self) -> (u32, u32) {
        LINE_CHART_SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String>
    where
        DB::ErrorType: 'static,
    {
        let ((x0, x1), (y0, y1)) =
            bounds(self.series.iter().flat_map(|s| s.points.iter())).ok_or("the chart has no finite point")?;
        root.fill(&WHITE).map_err(|x| err(&x))?;
        // Room above the title: plotters sets it flush with the top edge.
        let body = root.margin(8, 0, 0, 0).titled(&self.title, ("sans-serif", 20)).map_err(|x| err(&x))?;
        let entries: Vec<Entry> = self
            .series
            .iter()
            .enumerate()
            .map(|(i, s)| Entry {
                label: s.label.clone(),
                colour: s.style.colour.rgb(i),
                dashed: s.style.dashed,
                dot: false,
            })
            .collect();
        let (plot, band) = legend::split(&body, &entries)?;
        let mut c = ChartBuilder::on(&plot)
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|x| err(&x))?;
        draw_axes(&mut c, (self.x_label.as_str(), self.y_label.as_str()), ((x0, x1), (y0, y1)), 14)?;
        for (s, e) in self.series.iter().zip(&entries) {
            let pts = finite(&s.points);
            let style = e.colour.stroke_width(stroke_width(pts.len()));
            if s.style.dashed {
                c.draw_series(std::iter::once(DashedPathElement::new(pts, 6, 4, style))).map_err(|x| err(&x))?;
            } else {
                c.draw_series(LineSeries::new(pts, style)).map_err(|x| err(&x))?;
            }
        }
        legend::draw(&band, &entries)
    }
}
