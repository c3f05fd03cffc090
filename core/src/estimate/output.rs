//! What the estimator outputs per frame, and its conversion to the wire.
//!
//! Three estimates exist for a frame: the frame-to-frame one (DynoSAM's front-end: each motion
//! from two frames, chained), the causal one (the newest frame of the fixed-lag smoother: what an
//! online vehicle knows at that frame) and the smoothed one (the frame as it leaves the smoother's
//! window, having seen `W - 1` later frames). Only the first two may feed a forecast's history.

use heapless::Vec;
use nalgebra::Vector3;

use super::lie::{Vec6, omega};
use crate::geometry::{BevState, POSE3_IDENTITY, Pose3, se3_exp, wrap_angle};
use crate::limits::MAX_OBJECTS;
use crate::wire::{CameraPose, EstimateKind, ObjectClass, ObjectState, ObjectStates};

/// One object's estimate at one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObjectEstimate {
    /// Object id.
    pub object_id: u16,
    /// Object class.
    pub class: ObjectClass,
    /// Object pose `L_k` in the world frame (camera convention of the first frame): origin at the
    /// centroid of the object's points when first seen, x axis along its heading once known.
    pub pose: Pose3,
    /// World-frame motion into this frame, `H = L_k L_(k-1)^-1`.
    pub motion: Pose3,
    /// Bird's-eye state: position of the pose origin, heading of the pose's x axis, speed; in a
    /// causal estimate with a bird's-eye track ([`super::EstimatorParams::bev_track`]) the
    /// track's position, speed and direction of travel instead.
    pub bev: BevState,
    /// Heading rate, rad/s, counter-clockwise seen from above.
    pub heading_rate: f32,
    /// Increments when the object's heading became known: a history (of bird's-eye states)
    /// must not span two segments.
    pub segment: u16,
    /// Increments whenever the object's frame is turned (its heading became known, or was
    /// realigned with its direction of travel). Its origin stays put, so bird's-eye positions
    /// run on, but body-frame poses of different orientations must not be paired (e.g. for RPE).
    pub orientation: u16,
    /// Whether the heading comes from the object's motion (false: the frame keeps the world's
    /// orientation because the object has not moved far enough yet).
    pub heading_known: bool,
}

/// The estimate of one frame: camera pose and objects.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseEstimate {
    /// Frame index.
    pub frame: u32,
    /// Capture time, microseconds.
    pub timestamp_us: u64,
    /// Camera pose `T_world_cam`.
    pub camera: Pose3,
    /// The objects estimated at this frame.
    pub objects: Vec<ObjectEstimate, MAX_OBJECTS>,
}

impl PoseEstimate {
    /// An empty estimate.
    #[must_use]
    pub const fn new() -> Self {
        Self { frame: 0, timestamp_us: 0, camera: POSE3_IDENTITY, objects: Vec::new() }
    }

    /// Empties it for `frame`.
    pub fn reset(&mut self, frame: u32, timestamp_us: u64) {
        self.frame = frame;
        self.timestamp_us = timestamp_us;
        self.camera = Pose3::identity();
        self.objects.clear();
    }

    /// The wire message of this estimate, labelled with `kind`.
    #[must_use]
    pub fn to_wire(&self, kind: EstimateKind) -> ObjectStates {
        let q = self.camera.rotation.coords;
        let t = self.camera.translation.vector;
        ObjectStates {
            frame: self.frame,
            timestamp_us: self.timestamp_us,
            kind,
            camera: CameraPose { translation: [t.x, t.y, t.z], rotation: [q.x, q.y, q.z, q.w] },
            objects: self
                .objects
                .iter()
                .map(|o| ObjectState {
                    object_id: o.object_id,
                    class: o.class,
                    state: o.bev,
                    heading_rate: o.heading_rate,
                    heading_known: o.heading_known,
                })
                .collect(),
        }
    }
}

impl Default for PoseEstimate {
    fn default() -> Self {
        Self::new()
    }
}

/// The bird's-eye heading of a pose's x axis (camera convention: plane (x, z)).
#[must_use]
pub fn bev_heading(pose: &Pose3) -> f32 {
    let f = pose.rotation * Vector3::x();
    libm::atan2f(f.z, f.x)
}

/// An object estimate from its pose and the body-frame twist of its motion into this frame over
/// `dt` seconds, in its segment and orientation.
#[must_use]
pub fn object_estimate(
    object_id: u16,
    class: ObjectClass,
    pose: &Pose3,
    xi: &Vec6,
    dt: f32,
    (segment, orientation): (u16, u16),
    heading_known: bool,
) -> ObjectEstimate {
    let delta = se3_exp(xi);
    let motion = pose * delta * pose.inverse();
    let t = delta.translation.vector;
    let dt = if dt > 0.0 { dt } else { 1.0 };
    let p = pose.translation.vector;
    // The body's up axis is -y (camera convention): a counter-clockwise turn seen from above is a
    // negative rotation about y.
    let heading_rate = -omega(xi).y / dt;
    ObjectEstimate {
        object_id,
        class,
        pose: *pose,
        motion,
        bev: BevState { x: p.x, y: p.z, heading: wrap_angle(bev_heading(pose)), speed: libm::hypotf(t.x, t.z) / dt },
        heading_rate,
        segment,
        orientation,
        heading_known,
    }
}
