//! One object's run: a contiguous stretch of frames in which it was seen, with its pose, its
//! frame-to-frame and smoothed motions, and the rules for starting, holding and ending.
//!
//! Life of a run: `Initialising` (seen once: a provisional pose at the robust centroid of its
//! points, world-aligned) -> `Tracking` (from its second frame, with `L_0` the provisional pose;
//! once the object has moved `heading_baseline_m` from it, the frame is turned once so that its
//! x axis points along that displacement, its heading, and a new output segment begins) ->
//! `Draining` (the object was not seen in a frame, or its motion was held too long: its frames
//! still in the smoother's window are emitted as they leave) -> `Free`.

use super::bev_track::{BevTrack, BevTrackParams};
use super::frame::{ObjectPoints, Obs};
use super::landmarks::{
    self, Landmarks, fuse, initial_landmarks, landmark_correspondences, nearest_landmark_correspondences,
};
use super::lie::{Vec6, lin_to_pose, normalised, pose_to_lin};
use super::measure::{Correspondences, Measuring, MotionMeasurement, measure_motion, robust_centroid};
use super::motion_smoother::{ChainScratch, Smoothness};
use super::output::{ObjectEstimate, object_estimate};
use super::params::EstimatorParams;
use super::path::{Emitted, SmoothedPath};
use super::point_model::PointModel;
use super::rng::Pcg32;
use super::stats::EndCause;
use crate::geometry::{POSE3_IDENTITY, Point2, Pose3, se3_exp, se3_log};
use crate::wire::ObjectClass;
use nalgebra::{Point3, Translation3, UnitQuaternion, Vector2, Vector3};

mod heading;

/// Radius around the median of an object's points within which points count for its centroid,
/// metres: larger than any road vehicle's half-length, smaller than the gap to a neighbour.
const CENTROID_RADIUS_M: f32 = 4.0;
/// Consecutive frames an object's motion may be held before its run ends: frames in which its
/// fit failed, its points were out of range, or it was missing from the frame altogether (it
/// coasts on its last motion). Within this many frames it resumes with its identity, pose and
/// landmarks; after it the run ends and the object, if it comes back, is initialised afresh.
/// Five frames are half a second at KITTI's 10 Hz: a car passing behind another, a mask that
/// breaks for a few frames.
pub const MAX_HELD_FRAMES: u8 = 5;

/// Gives `track` the world centroid `c` of an object's points seen by `camera`: its bird's-eye
/// position, the bird's-eye direction it was seen along and its depth error under `model`.
fn observe_centroid(track: &mut BevTrack, c: &Point3<f32>, camera: &Pose3, model: &PointModel, p: &BevTrackParams) {
    let ray = c.coords - camera.translation.vector;
    let depth_sigma = model.depth_error((camera.inverse() * c).z, p.centroid_disparity_px);
    track.update_position(&Vector2::new(c.x, c.z), &Vector2::new(ray.x, ray.z), depth_sigma, p);
}

/// How far from its predicted place an object's point may lie from a landmark to be paired with
/// it when track ids fail ([`ObjectRun`]'s re-acquisition), metres: a few frames of coasting
/// drift, more than the spacing of an object's points.
const REACQUIRE_RADIUS_M: f32 = 0.6;
/// Pair-and-fit passes of a re-acquisition (an iterative-closest-point loop, cut short).
const REACQUIRE_PASSES: usize = 2;

/// The frame leaving the smoothing window, as a run's finish takes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindowExit {
    /// The step leaving the window, once it is full.
    pub leaving: Option<u32>,
    /// Its frame period, seconds.
    pub dt_leaving: f32,
    /// Conditions the leaving step on the camera as solved, before it is marginalised.
    pub front_shift: Option<Vec6>,
}

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
    /// The motion was held too often ([`MAX_HELD_FRAMES`]), or the first motion failed: the run
    /// must end, for the reason given, and the object be re-initialised.
    Restart(EndCause),
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
    /// Whether most of the object's tracks in this frame lay beyond the usable depth (a failed
    /// fit then counts as out of range).
    pub beyond_range: bool,
    /// Seconds since the previous frame.
    pub dt: f32,
}

/// A run's fit of its newest frame: the object's pose measured absolutely, against its own
/// landmarks, before the smoother turns it into a motion. What a smoother that takes fits as
/// pose measurements reads (DynoSAM's hybrid formulation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewestFit {
    /// Object id.
    pub object_id: u16,
    /// Class (of its first frame).
    pub class: ObjectClass,
    /// The run's orientation count ([`ObjectEstimate::orientation`]): fits of different counts
    /// are in differently turned object frames.
    pub orientation: u16,
    /// Whether the object frame's heading comes from its motion.
    pub heading_known: bool,
    /// The fitted pose of the object in the camera it was measured from (camera from object).
    pub camera_from_object: Pose3,
    /// The previous frame's fitted pose, when it had one, in the object frame as it now is: a
    /// frame turned in between shows in it (the estimator turns its whole window).
    pub previous_camera_from_object: Option<Pose3>,
    /// Information of a right perturbation of that pose, `[rho; omega]` (the measured twist's,
    /// which for one frame's motion is the same to first order).
    pub information: [[f32; 6]; 6],
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
    /// Whether one of the held frames since the last measured one was coasted (object missing).
    coasted: bool,
    /// Step of the newest frame in the path.
    newest_step: u32,
    /// Step of the newest frame whose motion was measured: later frames of an ended run are
    /// extrapolations and are not emitted smoothed.
    last_measured_step: u32,
    /// Output segment: counts the heading becoming known.
    segment: u16,
    /// Counts the frame's turns.
    orientation: u16,
    /// Set by [`ObjectRun::measure`] when it added a step (true: measured, false: held),
    /// taken by [`ObjectRun::finish`].
    stepped: Option<bool>,
    /// The object's points in its frame.
    landmarks: Landmarks,
    /// The measured body translations since the frame was last oriented: the direction the
    /// object travels in its own frame, which for a vehicle is its x axis.
    travel: Vector3<f32>,
    /// The newest measured step's fitted object-from-camera pose, which its points are fused
    /// with when [`EstimatorParams::fuse_at_fit`] is set (see [`ObjectRun::finish`]).
    fitted: Option<Pose3>,
    /// The bird's-eye track the causal estimate reports (with [`EstimatorParams::bev_track`]).
    bev: BevTrack,
}

impl<const W: usize> Default for ObjectRun<W> {
    fn default() -> Self {
        Self::new()
    }
}

/// Whether objects of `class` move as road vehicles do (not sideways): everything but people.
/// Their motions get the vehicle kinematic prior once their heading is known.
#[must_use]
pub fn moves_like_a_vehicle(class: ObjectClass) -> bool {
    !class.is_person() && class != ObjectClass::Background
}

/// The pure rotation turning the bird's-eye heading by `angle` (about the up axis, -y).
fn yaw(angle: f32) -> Pose3 {
    Pose3::from_parts(Translation3::identity(), UnitQuaternion::from_axis_angle(&-Vector3::y_axis(), angle))
}

impl<const W: usize> ObjectRun<W> {
    /// A free slot.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            state: RunState::Free,
            object_id: 0,
            class: ObjectClass::Misc,
            provisional: POSE3_IDENTITY,
            first_step: 0,
            path: SmoothedPath::new(),
            f2f: POSE3_IDENTITY,
            f2f_motion: POSE3_IDENTITY,
            last_delta: POSE3_IDENTITY,
            origin: Point2::new(0.0, 0.0),
            heading_known: false,
            held: 0,
            coasted: false,
            newest_step: 0,
            last_measured_step: 0,
            segment: 0,
            orientation: 0,
            stepped: None,
            landmarks: Landmarks::new(),
            fitted: None,
            bev: BevTrack::new(),
            travel: Vector3::new(0.0, 0.0, 0.0),
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

    /// Starts a run for `object` from its points at step `step`, seen by `camera`. `false`
    /// (and the slot stays free) when there are fewer than `min_points` points.
    pub fn initialise(
        &mut self,
        object: &ObjectPoints,
        camera: &Pose3,
        model: &PointModel,
        step: u32,
        min_points: u16,
        bev: Option<&BevTrackParams>,
    ) -> bool {
        let (object_id, class, points) = (object.object_id, object.class, &object.points[..]);
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
        self.newest_step = step;
        self.last_measured_step = step;
        self.origin = Point2::new(c.x, c.z);
        initial_landmarks(points, &(self.provisional.inverse() * camera), model, &mut self.landmarks);
        if let Some(p) = bev {
            observe_centroid(&mut self.bev, &c, camera, model, p);
        }
        true
    }

    /// The pose the previous step's motion is measured from.
    fn frame_pose(&self) -> Pose3 {
        if self.state == RunState::Initialising { self.provisional } else { *self.path.current() }
    }

    /// Measures the motion from frame k-1 to frame k and adds it to the smoother's window
    /// (coupled to the camera motion `cx.camera` came from). Returns the outcome;
    /// [`ObjectRun::finish`] follows the window's solve (not after a restart, which adds nothing).
    pub fn measure(&mut self, cx: &PairContext<'_>, params: &EstimatorParams, m: &mut Measuring<'_, W>) -> StepOutcome {
        let (model, s) = (m.model, m.smoothness);
        let (rng, corrs, scratch) = (&mut *m.rng, &mut *m.corrs, &mut *m.scratch);
        if let Some(p) = &params.bev_track {
            self.bev.predict(cx.dt, p);
            if let Some(c) = robust_centroid(cx.current, cx.camera, model, CENTROID_RADIUS_M) {
                observe_centroid(&mut self.bev, &c, cx.camera, model, p);
            }
        }
        let frame = self.frame_pose();
        // Source points: the landmarks, in the object's frame (at k-1, i.e. `frame`).
        let a = cx.camera.inverse() * frame;
        let min_points = usize::from(params.object_min_points);
        landmark_correspondences(&self.landmarks, cx.current, corrs);
        let mut measured = if corrs.len() >= min_points {
            measure_motion(corrs, &a, &self.last_delta, &params.object_fit, model, rng)
        } else {
            None
        };
        if measured.is_none() && self.state == RunState::Tracking && cx.current.len() >= min_points {
            measured = self.reacquire(cx, &a, params, model, rng, corrs);
        }
        let measured = if self.state == RunState::Initialising {
            let Some(m) = measured else { return StepOutcome::Restart(EndCause::FitFailed) };
            Some(self.start_tracking(&m))
        } else {
            measured
        };
        let cause = if cx.beyond_range { EndCause::OutOfRange } else { EndCause::FitFailed };
        self.fitted = measured.as_ref().filter(|_| params.fuse_at_fit).map(|m| (a * m.delta).inverse());
        // Camera k from object k as fitted: what couples this motion to the camera's.
        let lin = measured.as_ref().map_or([0.0; 6], |m| pose_to_lin(&(a * m.delta)));
        self.step(measured.as_ref(), &lin, cause, s, scratch)
    }

    /// Finds the motion again when too few track ids match (new points after a loss): the
    /// points are paired with the nearest landmarks where the object is predicted to be (its
    /// last motion on), the motion fitted, and the pairing and fit repeated once from it.
    fn reacquire(
        &self,
        cx: &PairContext<'_>,
        a: &Pose3,
        params: &EstimatorParams,
        model: &PointModel,
        rng: &mut Pcg32,
        corrs: &mut Correspondences,
    ) -> Option<MotionMeasurement> {
        let mut guess = self.last_delta;
        let mut measured = None;
        for _ in 0..REACQUIRE_PASSES {
            let object_from_camera = (a * guess).inverse();
            nearest_landmark_correspondences(
                &self.landmarks,
                cx.current,
                &object_from_camera,
                model,
                REACQUIRE_RADIUS_M,
                corrs,
            );
            if corrs.len() < usize::from(params.object_min_points) {
                return measured;
            }
            let Some(m) = measure_motion(corrs, a, &guess, &params.object_fit, model, rng) else { return measured };
            guess = m.delta;
            measured = Some(m);
        }
        measured
    }

    /// Advances a tracking run whose object is missing from the frame by its last motion, with
    /// no measurement: it coasts for up to [`MAX_HELD_FRAMES`] frames, then must end
    /// (`StepOutcome::Restart` with `EndCause::Lost`). Its bird's-eye track moves `dt` on.
    pub fn coast(
        &mut self,
        s: &Smoothness,
        scratch: &mut ChainScratch<W>,
        dt: f32,
        bev: Option<&BevTrackParams>,
    ) -> StepOutcome {
        if self.state != RunState::Tracking {
            return StepOutcome::Restart(EndCause::Lost);
        }
        if let Some(p) = bev {
            self.bev.predict(dt, p);
        }
        self.step(None, &[0.0; 6], EndCause::Lost, s, scratch)
    }

    /// Adds one step: the measured motion, or (`None`) a hold of the previous one for `cause`.
    fn step(
        &mut self,
        measured: Option<&MotionMeasurement>,
        lin: &[f32; 6],
        cause: EndCause,
        s: &Smoothness,
        scratch: &mut ChainScratch<W>,
    ) -> StepOutcome {
        let mut outcome = StepOutcome::Measured;
        match measured {
            Some(m) => {
                self.held = 0;
                self.coasted = false;
                self.last_delta = m.delta;
                self.travel += m.delta.translation.vector;
            }
            None => {
                self.held = self.held.saturating_add(1);
                self.coasted |= cause == EndCause::Lost;
                if self.held > MAX_HELD_FRAMES {
                    return StepOutcome::Restart(cause);
                }
                outcome = StepOutcome::Held;
            }
        }
        self.newest_step = self.newest_step.wrapping_add(1);
        if measured.is_some() {
            self.last_measured_step = self.newest_step;
        }
        // Frame-to-frame: the world motion H = L_(k-1) delta L_(k-1)^-1, chained.
        let frame = self.frame_pose();
        self.f2f_motion = normalised(frame * self.last_delta * frame.inverse());
        self.f2f = normalised(self.f2f_motion * self.f2f);
        let z = measured.map(|m| (&m.xi, &m.information));
        self.path.push(z, lin, s, scratch);
        self.stepped = Some(outcome == StepOutcome::Measured);
        outcome
    }

    /// Takes the window's solution `xs` (`None`: the solve failed, counted in `solve_failures`),
    /// emits the frame leaving the window if it is this run's (see `WindowExit`), and, for a
    /// run measured in this frame, fuses its points (`fuse_with`: the frame's points, the camera
    /// they were seen by, the point model, the inlier bound) into its landmarks. A draining run
    /// frees itself once nothing is pending.
    pub fn finish(
        &mut self,
        xs: Option<&[Vec6]>,
        s: &Smoothness,
        exit: WindowExit,
        fuse_with: Option<(&[Obs], &Pose3, &PointModel, f32)>,
        solve_failures: &mut u32,
    ) -> Option<ObjectEstimate> {
        let WindowExit { leaving, dt_leaving, front_shift } = exit;
        let stepped = self.stepped.take();
        let emitted = match self.path.apply(xs, s, leaving, stepped.is_some(), front_shift) {
            Ok(e) => e,
            Err(_) => {
                *solve_failures = solve_failures.saturating_add(1);
                None
            }
        };
        let fitted = self.fitted.take();
        if stepped == Some(true)
            && let Some((current, camera, model, inlier_px)) = fuse_with
        {
            let object_from_camera = fitted.unwrap_or_else(|| self.path.current().inverse() * camera);
            fuse(&mut self.landmarks, current, &object_from_camera, model, inlier_px);
        }
        // An ended run's frames after its last measured one were extrapolated: not emitted.
        let extrapolated = self.state == RunState::Draining && leaving.is_some_and(|j| j > self.last_measured_step);
        let out = emitted.filter(|_| !extrapolated).map(|e| self.estimate(&e, dt_leaving));
        if self.state == RunState::Draining && self.path.pending() == 0 {
            self.state = RunState::Free;
        }
        out
    }

    /// Whether the run coasted through a frame its object was missing from since its last
    /// measured motion.
    #[must_use]
    pub const fn coasted_since_fit(&self) -> bool {
        self.coasted
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

    /// This run's estimate at `pose` with the body twist `xi` over `dt` seconds.
    fn estimate_at(&self, pose: &Pose3, xi: &Vec6, dt: f32) -> ObjectEstimate {
        object_estimate(self.object_id, self.class, pose, xi, dt, (self.segment, self.orientation), self.heading_known)
    }

    fn estimate(&self, e: &Emitted, dt: f32) -> ObjectEstimate {
        self.estimate_at(&e.pose, &e.xi, dt)
    }

    /// Gives the bird's-eye track the newest causal motion's velocity (over `dt` seconds):
    /// after the window's solve, for a tracking run.
    pub fn update_bev_velocity(&mut self, dt: f32, p: &BevTrackParams) {
        if self.state != RunState::Tracking || dt.partial_cmp(&0.0) != Some(core::cmp::Ordering::Greater) {
            return;
        }
        let pose = self.path.causal();
        let t = pose.rotation * se3_exp(self.path.causal_xi()).translation.vector / dt;
        self.bev.update_velocity(&Vector2::new(t.x, t.z), p);
    }

    /// The fit of the newest frame, when this tracking run's motion was measured in it.
    #[must_use]
    pub fn newest_fit(&self) -> Option<NewestFit> {
        if self.state != RunState::Tracking || self.last_measured_step != self.newest_step {
            return None;
        }
        let chain = self.path.chain();
        let newest = chain.len().checked_sub(1)?;
        let slot = chain.slot(newest)?;
        let previous = newest.checked_sub(1).and_then(|i| chain.slot(i)).filter(|s| s.measured);
        slot.measured.then(|| NewestFit {
            object_id: self.object_id,
            class: self.class,
            orientation: self.orientation,
            heading_known: self.heading_known,
            camera_from_object: lin_to_pose(&slot.lin),
            previous_camera_from_object: previous.map(|s| lin_to_pose(&s.lin)),
            information: slot.info.into(),
        })
    }

    /// The causal estimate of the newest frame (tracking runs only).
    #[must_use]
    pub fn causal(&self, dt: f32) -> Option<ObjectEstimate> {
        (self.state == RunState::Tracking).then(|| {
            let mut e = self.estimate_at(self.path.causal(), self.path.causal_xi(), dt);
            self.bev.report(&mut e.bev);
            e
        })
    }

    /// The frame-to-frame estimate of the newest frame (tracking runs only).
    #[must_use]
    pub fn frame_to_frame(&self, dt: f32) -> Option<ObjectEstimate> {
        (self.state == RunState::Tracking).then(|| self.estimate_at(&self.f2f, &se3_log(&self.last_delta), dt))
    }
}
