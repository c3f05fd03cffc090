//! Static feature detection spread over the image: Shi-Tomasi corners (OpenCV's
//! `goodFeaturesToTrack`, as DynoSAM's GFTT) away from existing tracks and objects, then
//! bucketed on a grid so that no region takes more than its share. Spread matters for
//! ego-motion: corners bunched on one building constrain rotation badly.

use opencv::core::{Mat, Point, Point2f, Scalar, Vector};
use opencv::imgproc::{FILLED, LINE_8, circle, good_features_to_track};
use opencv::prelude::*;

use super::error::{FrontEndError, cv};

/// Detection parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectParams {
    /// Grid columns.
    pub grid_cols: usize,
    /// Grid rows.
    pub grid_rows: usize,
    /// Smallest distance between features, pixels.
    pub min_distance: f64,
    /// Corner quality relative to the strongest corner (GFTT's `qualityLevel`).
    pub quality: f64,
}

impl Default for DetectParams {
    fn default() -> Self {
        Self { grid_cols: 8, grid_rows: 3, min_distance: 10.0, quality: 0.01 }
    }
}

/// New corners and how many grid cells had none (textureless regions).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Detected {
    /// The new corners, strongest first within the grid's shares.
    pub points: Vec<Point2f>,
    /// Grid cells without a single corner.
    pub empty_cells: usize,
}

/// Up to `want` new corners of `grey` where `allowed` (8-bit, non-zero = allowed) permits,
/// at least `min_distance` from every point of `existing`.
///
/// # Errors
/// An OpenCV failure.
pub fn detect(
    grey: &Mat,
    allowed: &Mat,
    existing: &[Point2f],
    want: usize,
    p: &DetectParams,
) -> Result<Detected, FrontEndError> {
    let (cols, rows) = (p.grid_cols.max(1), p.grid_rows.max(1));
    let (w, h) = (grey.cols().max(1) as f32, grey.rows().max(1) as f32);
    let cell_of = |q: &Point2f| -> usize {
        let c = ((q.x / w * cols as f32) as usize).min(cols - 1);
        let r = ((q.y / h * rows as f32) as usize).min(rows - 1);
        r * cols + c
    };
    let mut mask = allowed.try_clone().map_err(cv("copying the detection mask"))?;
    let radius = p.min_distance.round() as i32;
    let mut per_cell = vec![0usize; cols * rows];
    for q in existing {
        circle(
            &mut mask,
            Point::new(q.x.round() as i32, q.y.round() as i32),
            radius,
            Scalar::all(0.0),
            FILLED,
            LINE_8,
            0,
        )
        .map_err(cv("masking existing tracks"))?;
        per_cell[cell_of(q)] += 1;
    }
    let mut found = Detected::default();
    if want == 0 {
        return Ok(found);
    }
    let mut corners = Vector::<Point2f>::new();
    // Ask for more than needed so that crowded cells can give way to empty ones.
    let ask = i32::try_from(3 * want).unwrap_or(i32::MAX);
    good_features_to_track(grey, &mut corners, ask, p.quality, p.min_distance, &mask, 3, false, 0.04)
        .map_err(cv("goodFeaturesToTrack"))?;
    let share = (existing.len() + want).div_ceil(cols * rows);
    let mut taken = vec![false; corners.len()];
    let mut has_corner = vec![false; cols * rows];
    for (i, q) in corners.iter().enumerate() {
        let c = cell_of(&q);
        has_corner[c] = true;
        if found.points.len() < want && per_cell[c] < share {
            per_cell[c] += 1;
            found.points.push(q);
            taken[i] = true;
        }
    }
    // Cells without texture leave room: fill it with the strongest corners left anywhere.
    for (i, q) in corners.iter().enumerate() {
        if found.points.len() >= want {
            break;
        }
        if !taken[i] {
            found.points.push(q);
        }
    }
    found.empty_cells = has_corner.iter().zip(&per_cell).filter(|(h, n)| !**h && **n == 0).count();
    Ok(found)
}
