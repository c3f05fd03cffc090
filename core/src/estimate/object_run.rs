//! One object's run: a contiguous stretch of frames in which it was seen, with its pose, its
//! frame-to-frame and smoothed motions, and the rules for starting, holding and ending.
//!
//! Life of a run: `Initialising` (seen once: a provisional pose at the robust centroid of its
//! points, world-aligned) -> `Tracking` (from its second frame, with `L_0` the provisional pose;
//! once the object has moved `heading_baseline_m` from it, the frame is turned once so that its
//! x axis points along that displacement, its heading, and a new output segment begins) ->
//! `Draining` (the object was not seen in a frame, or its motion was held too long: its frames
//! still in the smoother's window are emitted as they leave) -> `Free`.

use super::chain::{ChainScratch, Smoothness};
use super::frame::Obs;
use super::landmarks::{self, Landmarks, fuse, initial_landmarks, landmark_correspondences};
use super::lie::{Vec6, normalised, pose_to_lin};
use super::measure::{Correspondences, MotionMeasurement, measure_motion, robust_centroid};
use super::model::PointModel;
use super::output::{ObjectEstimate, object_estimate};
use super::params::EstimatorParams;
use super::path::{Emitted, SmoothedPath};
use super::rng::Pcg32;
use crate::geometry::{Point2, Pose3, se3_log};
use crate::wire::ObjectClass;
use nalgebra::{Translation3, UnitQuaternion, Vector3};

/// Radius around the median of an object's points within which points count for its centroid,
/// metres: larger than any road vehicle's half-length, smaller than the gap to a neighbour.
const CENTROID_RADIUS_M: f32 = 4.0;
/// Consecutive frames an object's motion may be held (fit failed) before its run ends and the
/// object is re-initialised from its points.
pub const MAX_HELD_FRAMES: u8 = 3;

/// Where a run is in its life.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunState {
    /// Unused slot.
    Free,
    /// Seen once: provisional pose only.
    Initialising,
    /// Seen in consecutive frames, with a pose.
    Tracking,
    /// Ended; its frames still in the window are emitted as they leave.
    Draining,
}

/// What a tracking step did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepOutcome {
    /// The motion was fitted.
    Measured,
    /// The fit failed and the previous motion was held.
    Held,
    /// The fit failed too often, or the first motion failed: the run must end and the object be
    /// re-initialised.
    Restart,
}

/// What an object step works on.
#[derive(Debug, Clone, Copy)]
pub struct PairContext<'a> {
    /// The object's points at k, sorted by id.
    pub current: &'a [Obs],
    /// Frame-to-frame camera pose at k.
    pub camera: &'a Pose3,
    /// The step leaving the window now, if any.
    pub leaving: Option<u32>,
}

/// One object's run; see the module docs.
#[derive(Debug, Clone)]
pub struct ObjectRun<const W: usize> {
    /// Life stage.
    pub state: RunState,
    /// Object id.
    pub object_id: u16,
    /// Class (of its first frame).
    pub class: ObjectClass,
    /// Provisional pose while initialising.
    provisional: Pose3,
    /// Step of the first frame.
    first_step: u32,
    /// Smoothed path (starts at the second frame, anchored at the first).
    path: SmoothedPath<W>,
    /// Frame-to-frame pose and world motion of the newest step.
    f2f: Pose3,
    f2f_motion: Pose3,
    /// Newest measured (or held) body motion.
    last_delta: Pose3,
    /// Bird's-eye origin of the first pose (for the heading baseline).
    origin: Point2,
    /// Whether the frame's heading comes from motion.
    heading_known: bool,
    /// Consecutive held frames.
    held: u8,
    /// Re-orientation count.
    segment: u16,
    /// Set by [`ObjectRun::measure`] when it added a step (true: measured, false: held),
    /// taken by [`ObjectRun::finish`].
    stepped: Option<bool>,
    /// The object's points in its frame.
    landmarks: Landmarks,
}

impl<const W: usize> Default for ObjectRun<W> {
    fn default() -> Self {
        Self::new()
    }
}

/// The pure rotation turning the bird's-eye heading by `angle` (about the up axis, -y).
fn yaw(angle: f32) -> Pose3 {
    Pose3::from_parts(Translation3::identity(), UnitQuaternion::from_axis_angle(&-Vector3::y_axis(), angle))
}

impl<const W: usize> ObjectRun<W> {
    /// A free slot.
    #[must_use]
    pub fn new() -> Self {
        Self {
            state: RunState::Free,
            object_id: 0,
            class: ObjectClass::Misc,
            provisional: Pose3::identity(),
            first_step: 0,
            path: SmoothedPath::new(),
            f2f: Pose3::identity(),
            f2f_motion: Pose3::identity(),
            last_delta: Pose3::identity(),
            origin: Point2::new(0.0, 0.0),
            heading_known: false,
            held: 0,
            segment: 0,
            stepped: None,
            landmarks: Landmarks::new(),
        }
    }

    /// True when the run is seen in the current frame (initialising or tracking).
    #[must_use]
    pub fn is_live(&self) -> bool {
        matches!(self.state, RunState::Initialising | RunState::Tracking)
    }

    /// Frames of this run not yet emitted smoothed.
    #[must_use]
    pub fn pending(&self) -> usize {
        if self.state == RunState::Tracking || self.state == RunState::Draining { self.path.pending() } else { 0 }
    }

    /// Starts a run for `object_id` from its points at step `step`, seen by `camera`. `false`
    /// (and the slot stays free) when there are fewer than `min_points` points.
    #[allow(clippy::too_many_arguments)]
    pub fn initialise(
        &mut self,
        object_id: u16,
        class: ObjectClass,
        points: &[Obs],
        camera: &Pose3,
        model: &PointModel,
        step: u32,
        min_points: u16,
    ) -> bool {
        if points.len() < usize::from(min_points) {
            return false;
        }
        let Some(c) = robust_centroid(points, camera, model, CENTROID_RADIUS_M) else { return false };
        *self = Self::new();
        self.state = RunState::Initialising;
        self.object_id = object_id;
        self.class = class;
        self.provisional = Pose3::from_parts(Translation3::from(c.coords), UnitQuaternion::identity());
        self.first_step = step;
        self.origin = Point2::new(c.x, c.z);
        initial_landmarks(points, &(self.provisional.inverse() * camera), model, &mut self.landmarks);
        true
    }

    /// The pose the previous step's motion is measured from.
    fn frame_pose(&self) -> Pose3 {
        if self.state == RunState::Initialising { self.provisional } else { *self.path.current() }
    }

    /// Measures the motion from frame k-1 to frame k and adds it to the smoother's window
    /// (coupled to the camera motion `cx.camera` came from). Returns the outcome;
    /// [`ObjectRun::finish`] follows the window's solve (not after a restart, which adds nothing).
    #[allow(clippy::too_many_arguments)]
    pub fn measure(
        &mut self,
        cx: &PairContext<'_>,
        params: &EstimatorParams,
        model: &PointModel,
        rng: &mut Pcg32,
        corrs: &mut Correspondences,
        s: &Smoothness,
        scratch: &mut ChainScratch<W>,
    ) -> StepOutcome {
        let frame = self.frame_pose();
        // Source points: the landmarks, in the object's frame (at k-1, i.e. `frame`).
        let a = cx.camera.inverse() * frame;
        landmark_correspondences(&self.landmarks, cx.current, corrs);
        let measured = if corrs.len() >= usize::from(params.object_min_points) {
            measure_motion(corrs, &a, &self.last_delta, &params.object_fit, model, rng)
        } else {
            None
        };
        let mut outcome = StepOutcome::Measured;
        let measured = if self.state == RunState::Initialising {
            let Some(m) = measured else { return StepOutcome::Restart };
            Some(self.start_tracking(&m))
        } else {
            measured
        };
        match &measured {
            Some(m) => {
                self.held = 0;
                self.last_delta = m.delta;
            }
            None => {
                self.held = self.held.saturating_add(1);
                if self.held > MAX_HELD_FRAMES {
                    return StepOutcome::Restart;
                }
                outcome = StepOutcome::Held;
            }
        }
        // Frame-to-frame: the world motion H = L_(k-1) delta L_(k-1)^-1, chained.
        let frame = self.frame_pose();
        self.f2f_motion = normalised(frame * self.last_delta * frame.inverse());
        self.f2f = normalised(self.f2f_motion * self.f2f);
        let z = measured.as_ref().map(|m| (&m.xi, &m.information));
        // Camera k from object k as fitted: what couples this motion to the camera's.
        let lin = measured.as_ref().map_or([0.0; 6], |m| pose_to_lin(&(a * m.delta)));
        self.path.push(z, &lin, s, scratch);
        self.stepped = Some(outcome == StepOutcome::Measured);
        outcome
    }

    /// Takes the window's solution `xs` (`None`: the solve failed, counted in `solve_failures`),
    /// emits the leaving step if it is this run's (`dt_leaving` is its frame period; `front_shift`
    /// conditions it on the camera as solved before it is marginalised), and, for a run measured
    /// in this frame, fuses its points (`current`, seen by `camera`) into its landmarks. A
    /// draining run frees itself once nothing is pending.
    #[allow(clippy::too_many_arguments)]
    pub fn finish(
        &mut self,
        xs: Option<&[Vec6]>,
        s: &Smoothness,
        leaving: Option<u32>,
        front_shift: Option<Vec6>,
        dt_leaving: f32,
        fuse_with: Option<(&[Obs], &Pose3, &PointModel, f32)>,
        solve_failures: &mut u32,
    ) -> Option<ObjectEstimate> {
        let stepped = self.stepped.take();
        let emitted = match self.path.apply(xs, s, leaving, stepped.is_some(), front_shift) {
            Ok(e) => e,
            Err(_) => {
                *solve_failures = solve_failures.saturating_add(1);
                None
            }
        };
        if stepped == Some(true)
            && let Some((current, camera, model, inlier_px)) = fuse_with
        {
            let object_from_camera = self.path.current().inverse() * camera;
            fuse(&mut self.landmarks, current, &object_from_camera, model, inlier_px);
        }
        let out = emitted.map(|e| self.estimate(&e, dt_leaving));
        if self.state == RunState::Draining && self.path.pending() == 0 {
            self.state = RunState::Free;
        }
        out
    }

    /// Whether [`ObjectRun::measure`] added a step that [`ObjectRun::finish`] has not taken.
    #[must_use]
    pub const fn stepped(&self) -> bool {
        self.stepped.is_some()
    }

    /// The smoothed path (its chain is this object's part of the joint solve).
    #[must_use]
    pub const fn path(&self) -> &SmoothedPath<W> {
        &self.path
    }

    /// Sets the first pose `L_0` (the provisional one: the robust centroid, world-aligned) and
    /// takes the first motion; the heading follows once the object has moved far enough
    /// ([`ObjectRun::reorient_if_moved`]).
    fn start_tracking(&mut self, m: &MotionMeasurement) -> MotionMeasurement {
        self.path.start(self.provisional, self.first_step);
        self.f2f = self.provisional;
        self.state = RunState::Tracking;
        *m
    }

    /// Re-orients the frame along the displacement since the first pose once it exceeds
    /// `baseline` metres, for an object whose heading is not yet known. Returns whether it did.
    pub fn reorient_if_moved(&mut self, baseline: f32) -> bool {
        if self.heading_known || self.state != RunState::Tracking {
            return false;
        }
        let p = self.path.current().translation.vector;
        let (dx, dz) = (p.x - self.origin.x, p.z - self.origin.y);
        let moved = libm::hypotf(dx, dz);
        if moved.is_nan() || moved < baseline {
            return false;
        }
        // The new frame is upright with its x axis along the displacement: this also removes
        // any roll and pitch the frame picked up from noisy motions.
        let target = yaw(libm::atan2f(dz, dx));
        let r = Pose3::from_parts(Translation3::identity(), self.path.current().rotation.inverse() * target.rotation);
        self.path.reframe(&r);
        landmarks::reframe(&mut self.landmarks, &r);
        self.f2f *= r;
        self.last_delta = r.inverse() * self.last_delta * r;
        self.heading_known = true;
        self.segment = self.segment.wrapping_add(1);
        true
    }

    /// Emits the leaving step for a draining run; frees the run once nothing is pending.
    pub fn drain(
        &mut self,
        s: &Smoothness,
        scratch: &mut ChainScratch<W>,
        leaving: u32,
        dt_leaving: f32,
    ) -> Option<ObjectEstimate> {
        let e = self.path.drain(s, scratch, leaving).ok().flatten();
        let out = e.map(|e| self.estimate(&e, dt_leaving));
        if self.path.pending() == 0 {
            self.state = RunState::Free;
        }
        out
    }

    fn estimate(&self, e: &Emitted, dt: f32) -> ObjectEstimate {
        object_estimate(self.object_id, self.class, &e.pose, &e.xi, dt, self.segment, self.heading_known)
    }

    /// The causal estimate of the newest frame (tracking runs only).
    #[must_use]
    pub fn causal(&self, dt: f32) -> Option<ObjectEstimate> {
        (self.state == RunState::Tracking).then(|| {
            object_estimate(
                self.object_id,
                self.class,
                self.path.causal(),
                self.path.causal_xi(),
                dt,
                self.segment,
                self.heading_known,
            )
        })
    }

    /// The frame-to-frame estimate of the newest frame (tracking runs only).
    #[must_use]
    pub fn frame_to_frame(&self, dt: f32) -> Option<ObjectEstimate> {
        (self.state == RunState::Tracking).then(|| {
            object_estimate(
                self.object_id,
                self.class,
                &self.f2f,
                &se3_log(&self.last_delta),
                dt,
                self.segment,
                self.heading_known,
            )
        })
    }
}
