//! The agent frame: a planar frame at an agent's position with its x axis along its heading,
//! in which the predictor's features and the motion prior's trends are expressed.

use super::{BevState, Point2};

/// The agent frame of a current state: origin at its position, x along its heading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AgentFrame {
    origin: Point2,
    heading: f32,
    cos: f32,
    sin: f32,
}

impl AgentFrame {
    /// The frame of `current`: at its position, along its heading.
    #[must_use]
    pub fn of(current: &BevState) -> Self {
        Self::new(current.position(), current.heading)
    }

    /// The frame at `origin` with its x axis along `heading`.
    #[must_use]
    pub fn new(origin: Point2, heading: f32) -> Self {
        let (sin, cos) = super::trig::sin_cos(heading);
        Self { origin, heading, cos, sin }
    }

    /// The frame's heading in the world, radians.
    #[must_use]
    pub const fn heading(&self) -> f32 {
        self.heading
    }

    /// A world point in this frame.
    #[must_use]
    pub fn to_agent(&self, p: &Point2) -> Point2 {
        let (dx, dy) = (p.x - self.origin.x, p.y - self.origin.y);
        Point2::new(self.cos * dx + self.sin * dy, -self.sin * dx + self.cos * dy)
    }

    /// A world vector (a velocity, an acceleration) in this frame's axes.
    #[must_use]
    pub fn rotate_to_agent(&self, v: &Point2) -> Point2 {
        Point2::new(self.cos * v.x + self.sin * v.y, -self.sin * v.x + self.cos * v.y)
    }

    /// A point of this frame in the world.
    #[must_use]
    pub fn to_world(&self, p: &Point2) -> Point2 {
        Point2::new(self.origin.x + self.cos * p.x - self.sin * p.y, self.origin.y + self.sin * p.x + self.cos * p.y)
    }
}
