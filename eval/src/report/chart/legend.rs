//! The legend in a band of its own to the right of the plot, sized to its longest label: a
//! legend inside the plotting area covers whatever lines pass under it.

use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::err;

/// Legend text size, pixels.
const FONT_SIZE: u32 = 14;
/// Length of a line's sample, pixels.
const SAMPLE: i32 = 26;
/// Space around and between a band's entries, pixels.
const PAD: i32 = 8;
/// Height of one entry, pixels.
const ROW: i32 = 22;
/// Where the first entry sits below the band's top: level with the top of the plot.
const TOP: i32 = 14;

/// A plot area and its legend band.
pub type Split<DB> = (DrawingArea<DB, Shift>, DrawingArea<DB, Shift>);

/// One entry: a sample of the line (colour, dashed or not, marker) and its label.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// Label.
    pub label: String,
    /// Line colour.
    pub colour: RGBColor,
    /// Dashed line.
    pub dashed: bool,
    /// A dot on the sample (the line's points carry one).
    pub dot: bool,
}

/// Splits `area` into the plot (left) and the legend band (right) that fits `entries`; the
/// band is empty when there is nothing to list.
///
/// # Errors
/// A label the font cannot measure.
pub fn split<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, entries: &[Entry]) -> Result<Split<DB>, String> {
    let font: TextStyle<'_> = ("sans-serif", FONT_SIZE).into();
    let mut widest = 0;
    for e in entries {
        let (w, _) = area.estimate_text_size(&e.label, &font).map_err(|x| err(&x))?;
        widest = widest.max(w);
    }
    let band = if entries.is_empty() { 0 } else { widest as i32 + SAMPLE + 4 * PAD };
    let (w, _) = area.dim_in_pixel();
    Ok(area.split_horizontally(w as i32 - band.min(w as i32 / 2)))
}

/// Draws `entries` into `band`, one per row from the top.
///
/// # Errors
/// A drawing error of the backend.
pub fn draw<DB: DrawingBackend>(band: &DrawingArea<DB, Shift>, entries: &[Entry]) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    if entries.is_empty() {
        return Ok(());
    }
    let (w, _) = band.dim_in_pixel();
    let bottom = TOP + PAD + ROW * entries.len() as i32;
    band.draw(&Rectangle::new([(PAD / 2, TOP), (w as i32 - PAD / 2, bottom)], BLACK.stroke_width(1)))
        .map_err(|x| err(&x))?;
    for (i, e) in entries.iter().enumerate() {
        let y = TOP + PAD + ROW * i as i32 + ROW / 2;
        let (x0, x1) = (PAD + PAD / 2, PAD + PAD / 2 + SAMPLE);
        let style = e.colour.stroke_width(2);
        if e.dashed {
            band.draw(&DashedPathElement::new(vec![(x0, y), (x1, y)], 5, 3, style)).map_err(|x| err(&x))?;
        } else {
            band.draw(&PathElement::new(vec![(x0, y), (x1, y)], style)).map_err(|x| err(&x))?;
        }
        if e.dot {
            band.draw(&Circle::new(((x0 + x1) / 2, y), 4, e.colour.filled())).map_err(|x| err(&x))?;
        }
        let font = ("sans-serif", FONT_SIZE).into_font().color(&BLACK).pos(Pos::new(HPos::Left, VPos::Center));
        band.draw_text(&e.label, &font, (x1 + PAD, y)).map_err(|x| err(&x))?;
    }
    Ok(())
}
