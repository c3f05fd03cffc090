//! The entities every recording draws in the bird's-eye plane: an object's trail (its states so
//! far) and a forecast, each a [`Line`] with one style per kind, so that recordings of
//! different commands look alike in a viewer.

use std::collections::BTreeMap;

use super::{Line, Rgba};

/// Width of a trail, metres.
pub const TRAIL_THICKNESS: f64 = 0.15;
/// Width of a forecast, metres: wider than a trail, drawn over it.
pub const FORECAST_THICKNESS: f64 = 0.25;

/// An object's trail as a line entity (its id the object's).
#[must_use]
pub fn trail_line(id: impl ToString, points: Vec<[f64; 3]>, color: Rgba, metadata: Vec<(String, String)>) -> Line {
    Line { id: id.to_string(), points, color, thickness: TRAIL_THICKNESS, metadata }
}

/// A forecast as a line entity (its id the forecast object's).
#[must_use]
pub fn forecast_line(id: impl ToString, points: Vec<[f64; 3]>, color: Rgba, metadata: Vec<(String, String)>) -> Line {
    Line { id: id.to_string(), points, color, thickness: FORECAST_THICKNESS, metadata }
}

/// One key-value pair of an entity's metadata.
#[must_use]
pub fn meta(key: &str, value: impl ToString) -> Vec<(String, String)> {
    vec![(key.to_string(), value.to_string())]
}

/// The trails of many objects, growing a point per frame: each call adds an object's newest
/// point and gives its whole trail so far as a line.
#[derive(Debug, Clone)]
pub struct Trails {
    points: BTreeMap<u16, Vec<[f64; 3]>>,
    color: Rgba,
}

impl Trails {
    /// No trails yet, drawn in `color`.
    #[must_use]
    pub const fn new(color: Rgba) -> Self {
        Self { points: BTreeMap::new(), color }
    }

    /// Adds `point` to object `id`'s trail and gives the trail as a line with `metadata`.
    pub fn extend(&mut self, id: u16, point: [f64; 3], metadata: Vec<(String, String)>) -> Line {
        let points = self.points.entry(id).or_default();
        points.push(point);
        trail_line(id, points.clone(), self.color, metadata)
    }
}
