//! When an object's frame turns: once, onto its first heading when it has moved far enough, and
//! (vehicles) again whenever its measured travel leaves the frame's x axis by too much.

use nalgebra::{Translation3, Vector3};

use super::{ObjectRun, RunState, landmarks, moves_like_a_vehicle, yaw};
use crate::estimate::params::EstimatorParams;
use crate::geometry::Pose3;

impl<const W: usize> ObjectRun<W> {
    /// Re-orients the frame along the displacement since the first pose once it exceeds
    /// `heading_baseline_m`, or, once the run has `heading_max_wait_frames` frames,
    /// `heading_min_baseline_m`, for an object whose heading is not yet known; a vehicle's
    /// motions then get `params.vehicle_kinematics`. Afterwards, with `heading_realign_rad`
    /// set, a vehicle's frame is turned again whenever its measured travel over
    /// `heading_baseline_m` leaves its x axis by more than that: the first heading comes from a
    /// short, noisy baseline, and a frame turned off the direction of travel sets the kinematic
    /// prior against the measurements. Each turn starts a new orientation (RPE does not pair
    /// across it). Returns whether it turned.
    pub fn reorient_if_moved(&mut self, params: &EstimatorParams) -> bool {
        if self.state != RunState::Tracking {
            return false;
        }
        if self.heading_known {
            return self.realign(params);
        }
        let (baseline, max_wait, min_baseline) =
            (params.heading_baseline_m, params.heading_max_wait_frames, params.heading_min_baseline_m);
        let p = self.path.current().translation.vector;
        let (dx, dz) = (p.x - self.origin.x, p.z - self.origin.y);
        let moved = libm::hypotf(dx, dz);
        let frames = self.newest_step.wrapping_sub(self.first_step);
        let needed = if frames >= u32::from(max_wait) { baseline.min(min_baseline) } else { baseline };
        if moved.is_nan() || moved < needed {
            return false;
        }
        // The new frame is upright with its x axis along the displacement: this also removes
        // any roll and pitch the frame picked up from noisy motions.
        let target = yaw(libm::atan2f(dz, dx));
        let r = Pose3::from_parts(Translation3::identity(), self.path.current().rotation.inverse() * target.rotation);
        self.turn(&r);
        self.heading_known = true;
        self.segment = self.segment.wrapping_add(1);
        if let Some(k) = params.vehicle_kinematics.filter(|_| moves_like_a_vehicle(self.class)) {
            self.path.set_kinematic(k.information());
        }
        true
    }

    /// Turns a vehicle's frame onto its measured direction of travel (see
    /// [`ObjectRun::reorient_if_moved`]).
    fn realign(&mut self, params: &EstimatorParams) -> bool {
        let t = self.travel;
        let Some(limit) = params.heading_realign_rad else { return false };
        if !moves_like_a_vehicle(self.class) || libm::hypotf(t.x, t.z) < params.heading_baseline_m {
            return false;
        }
        self.travel = Vector3::new(0.0, 0.0, 0.0);
        let angle = libm::atan2f(t.z, t.x);
        // A NaN angle never turns the frame.
        if libm::fabsf(angle).partial_cmp(&limit) != Some(core::cmp::Ordering::Greater) {
            return false;
        }
        self.turn(&yaw(angle));
        true
    }

    /// Turns the frame by the rotation `r` (body frame), starting a new orientation.
    fn turn(&mut self, r: &Pose3) {
        self.path.reframe(r);
        landmarks::reframe(&mut self.landmarks, r);
        self.f2f *= r;
        self.last_delta = r.inverse() * self.last_delta * r;
        self.travel = Vector3::new(0.0, 0.0, 0.0);
        self.orientation = self.orientation.wrapping_add(1);
    }
}
