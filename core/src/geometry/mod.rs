//! Geometry: planar points and states, angle wrapping, SE(3)/SE(2) helpers and the projection of
//! camera-frame quantities onto the bird's-eye plane.
//!
//! Conventions (KITTI / OpenCV): a camera frame has x right, y down, z forward. The bird's-eye
//! plane of a camera-convention world frame is its (x, z) plane, which with up = -y is
//! right-handed, so bird's-eye angles turn counter-clockwise seen from above. This is DynoSAM's
//! evaluation convention: a point (x, y, z) maps to the z-up point (x, z, -y).

mod agent_frame;
mod angle;
mod bev;
mod norm_bound;
mod pinhole;
mod se3;
pub mod trig;

pub use agent_frame::AgentFrame;
pub use angle::{angle_diff, wrap_angle};
pub use bev::{BevState, Point2, bev_heading_of_rotation_y, bev_point};
pub use norm_bound::NormBound;
pub use pinhole::back_project;
pub use se3::{POSE3_IDENTITY, Pose3, rotation_angle, rotation_of_scaled_axis, se2_of_bev, se3_exp, se3_log};
