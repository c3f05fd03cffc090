//! Bird's-eye plane: points, object states and the projection from camera-convention frames.

use nalgebra::{Point3, Rotation3, Vector3};
use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};

/// A point on the bird's-eye plane, metres.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize, MaxSize)]
pub struct Point2 {
    /// First plane coordinate (camera x: right of the first camera pose), metres.
    pub x: f32,
    /// Second plane coordinate (camera z: forward of the first camera pose), metres.
    pub y: f32,
}

impl Point2 {
    /// A point from its coordinates.
    #[must_use]
    pub const fn new(x: f32, y: f32) -> Self {
        Self { x, y }
    }

    /// Euclidean distance to `other`.
    #[must_use]
    pub fn distance(&self, other: &Self) -> f32 {
        libm::hypotf(self.x - other.x, self.y - other.y)
    }
}

/// An object's bird's-eye state: what the predictors consume and the smoothers produce.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize, MaxSize)]
pub struct BevState {
    /// Position x, metres.
    pub x: f32,
    /// Position y, metres.
    pub y: f32,
    /// Heading, radians, counter-clockwise from the x axis, wrapped to (-pi, pi].
    pub heading: f32,
    /// Speed along the heading, m/s.
    pub speed: f32,
}

impl BevState {
    /// The position part.
    #[must_use]
    pub const fn position(&self) -> Point2 {
        Point2 { x: self.x, y: self.y }
    }

    /// True when every field is finite.
    #[must_use]
    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.heading.is_finite() && self.speed.is_finite()
    }
}

/// Projects a point of a camera-convention frame (x right, y down, z forward) onto the
/// bird's-eye plane: (x, z).
#[must_use]
pub fn bev_point(p: &Point3<f32>) -> Point2 {
    Point2 { x: p.x, y: p.z }
}

/// Bird's-eye heading of an object whose KITTI `rotation_y` is `ry` in a camera whose rotation
/// into the world frame is `r_world_cam`.
///
/// KITTI's `rotation_y` turns the object about the camera's y (down) axis; at 0 the object faces
/// the camera's x axis, so its forward axis in the camera frame is (cos ry, 0, -sin ry).
#[must_use]
pub fn bev_heading_of_rotation_y(ry: f32, r_world_cam: &Rotation3<f32>) -> f32 {
    let forward_cam = Vector3::new(libm::cosf(ry), 0.0, -libm::sinf(ry));
    let f = r_world_cam * forward_cam;
    libm::atan2f(f.z, f.x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f32::consts::FRAC_PI_2;

    #[test]
    fn rotation_y_zero_faces_camera_x_and_quarter_turn_faces_forward() {
        let id = Rotation3::identity();
        assert!(bev_heading_of_rotation_y(0.0, &id).abs() < 1e-6);
        // ry = -pi/2 points the object along +z (forward), which is +90 deg on the plane.
        assert!((bev_heading_of_rotation_y(-FRAC_PI_2, &id) - FRAC_PI_2).abs() < 1e-6);
        // A camera yawed left by 90 deg (about -y, i.e. about "up") turns headings by +90 deg.
        let yaw_left = Rotation3::from_axis_angle(&-Vector3::y_axis(), FRAC_PI_2);
        assert!((bev_heading_of_rotation_y(0.0, &yaw_left) - FRAC_PI_2).abs() < 1e-5);
    }

    #[test]
    fn point_distance() {
        assert!((Point2::new(0.0, 0.0).distance(&Point2::new(3.0, 4.0)) - 5.0).abs() < 1e-6);
        assert_eq!(bev_point(&Point3::new(1.0, 2.0, 3.0)), Point2::new(1.0, 3.0));
    }
}
