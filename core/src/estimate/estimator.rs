//! The estimator: frame assembly, ego-motion, object motions, smoothing and outputs, in fixed
//! memory. See the module docs of [`super`] for the method and the bad-input rules.

use heapless::Deque;
use nalgebra::Point3;

use super::camera::CameraTrack;
use super::motion_smoother::{ChainScratch, Smoothness};
use heapless::Vec;

use super::frame::{DepthRange, FrameAssembler, FrameBuffer, Obs, PartOutcome};
use super::joint::{JointScratch, JointSettings, solve_joint};
use super::measure::{Correspondences, Measuring};
use super::object_run::{NewestFit, ObjectRun, PairContext, RunState, StepOutcome, WindowExit};
use super::output::ObjectEstimate;
use super::output::PoseEstimate;
use super::params::EstimatorParams;
use super::point_model::PointModel;
use super::rng::Pcg32;
use super::stats::{EstimatorStats, add, bump};
use crate::geometry::Pose3;
use crate::limits::{MAX_OBJECTS, MAX_STATIC_TRACKS};
use crate::wire::FrameTracks;

use super::profile::DEFAULT_WINDOW;

/// One frame in the window.
#[derive(Debug, Clone, Copy, PartialEq)]
struct FrameInfo {
    step: u32,
    frame: u32,
    timestamp_us: u64,
    dt: f32,
}

/// What [`Estimator::push`] did with a part.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pushed {
    /// Stored; the frame is not complete yet.
    Pending,
    /// Rejected (see the stats).
    Rejected,
    /// The part completed a frame, which was estimated: [`Estimator::causal`] and
    /// [`Estimator::frame_to_frame`] describe it. `smoothed` says whether a frame left the
    /// window, in which case [`Estimator::smoothed`] holds its estimate.
    Frame {
        /// Whether a smoothed frame is available.
        smoothed: bool,
    },
}

/// The DynoSAM-style estimator with a fixed-lag smoother over `W` frames (`W >= 2`).
#[derive(Debug, Clone)]
pub struct Estimator<const W: usize = DEFAULT_WINDOW> {
    params: EstimatorParams,
    model: PointModel,
    object_smoothness: Smoothness,
    camera_smoothness: Smoothness,
    assembler: FrameAssembler,
    /// The frame being assembled, then estimated.
    frame: FrameBuffer,
    /// Frame k-1's static tracks (objects keep landmarks instead).
    previous_statics: Vec<Obs, MAX_STATIC_TRACKS>,
    has_previous: bool,
    window: Deque<FrameInfo, W>,
    step: u32,
    camera: CameraTrack<W>,
    runs: [ObjectRun<W>; MAX_OBJECTS],
    corrs: Correspondences,
    scratch: ChainScratch<W>,
    joint: JointScratch<W>,
    rng: Pcg32,
    stats: EstimatorStats,
    smoothed: PoseEstimate,
}

impl<const W: usize> Estimator<W> {
    const WINDOW_OK: () = assert!(W >= 2, "the smoothing window needs at least two frames");

    /// An estimator with `params`, its RANSAC sampling seeded with `seed` (runs repeat exactly).
    #[must_use]
    pub const fn new(params: EstimatorParams, seed: u64) -> Self {
        let () = Self::WINDOW_OK;
        Self {
            model: PointModel::new(&params),
            object_smoothness: Smoothness::new(&params.object_smoother),
            camera_smoothness: Smoothness::new(&params.camera_smoother),
            params,
            assembler: FrameAssembler::new(),
            frame: FrameBuffer::new(),
            previous_statics: Vec::new(),
            has_previous: false,
            window: Deque::new(),
            step: 0,
            camera: CameraTrack::new(),
            runs: [const { ObjectRun::new() }; MAX_OBJECTS],
            corrs: heapless::Vec::new(),
            scratch: ChainScratch::new(),
            joint: JointScratch::new(),
            rng: Pcg32::new(seed),
            stats: EstimatorStats::ZERO,
            smoothed: PoseEstimate::new(),
        }
    }

    /// Starts afresh with `params` and `seed`, in place: the same state as
    /// `Estimator::new(params, seed)` without building a second estimator on the stack (an MCU
    /// keeps the estimator in a static and has a few KiB of stack, less than this struct).
    ///
    /// Never inlined: the fresh parts it writes are built on its own stack frame, which is gone
    /// before the next frame is estimated.
    #[inline(never)]
    pub fn reset(&mut self, params: EstimatorParams, seed: u64) {
        let () = Self::WINDOW_OK;
        // Every field named (no `..`): a field added later fails to compile here until its reset
        // is written.
        let Self {
            params: own_params,
            model,
            object_smoothness,
            camera_smoothness,
            assembler,
            frame,
            previous_statics,
            has_previous,
            window,
            step,
            camera,
            runs,
            corrs,
            scratch,
            joint,
            rng,
            stats,
            smoothed,
        } = self;
        *model = PointModel::new(&params);
        *object_smoothness = Smoothness::new(&params.object_smoother);
        *camera_smoothness = Smoothness::new(&params.camera_smoother);
        *own_params = params;
        *assembler = FrameAssembler::new();
        frame.reset(0, 0);
        previous_statics.clear();
        *has_previous = false;
        window.clear();
        *step = 0;
        *camera = CameraTrack::new();
        for run in runs {
            *run = ObjectRun::new();
        }
        corrs.clear();
        *scratch = ChainScratch::new();
        *joint = JointScratch::new();
        *rng = Pcg32::new(seed);
        *stats = EstimatorStats::ZERO;
        smoothed.reset(0, 0);
    }

    /// The parameters.
    #[must_use]
    pub const fn params(&self) -> &EstimatorParams {
        &self.params
    }

    /// The counters.
    #[must_use]
    pub const fn stats(&self) -> &EstimatorStats {
        &self.stats
    }

    /// Takes one part of a frame; when it completes the frame, estimates it.
    pub fn push(&mut self, part: &FrameTracks) -> Pushed {
        let range = DepthRange { min: self.params.min_depth, max: self.params.max_depth };
        let outcome = self.assembler.accept(part, &mut self.frame, range, &mut self.stats);
        match outcome {
            PartOutcome::Pending => Pushed::Pending,
            PartOutcome::Rejected => Pushed::Rejected,
            PartOutcome::Complete => Pushed::Frame { smoothed: self.process() },
        }
    }

    /// The smoothed estimate of the frame that last left the window (see [`Pushed::Frame`]).
    #[must_use]
    pub const fn smoothed(&self) -> &PoseEstimate {
        &self.smoothed
    }

    /// The newest frame's index, time and period, if any frame was processed.
    fn newest(&self) -> Option<FrameInfo> {
        self.window.back().copied()
    }

    /// Fills `out` with the causal estimate of the newest frame: camera and objects as the
    /// smoother sees them now, from frames up to this one only.
    pub fn causal(&self, out: &mut PoseEstimate) {
        self.fill_newest(out, false);
    }

    /// Fills `out` with the frame-to-frame estimate of the newest frame (DynoSAM's front-end:
    /// motions from frame pairs only, chained).
    pub fn frame_to_frame(&self, out: &mut PoseEstimate) {
        self.fill_newest(out, true);
    }

    fn fill_newest(&self, out: &mut PoseEstimate, f2f: bool) {
        let Some(info) = self.newest() else {
            out.reset(0, 0);
            return;
        };
        out.reset(info.frame, info.timestamp_us);
        out.camera = if f2f { *self.camera.frame_to_frame() } else { *self.camera.causal() };
        for run in self.runs.iter().filter(|r| r.state == RunState::Tracking) {
            let e = if f2f { run.frame_to_frame(info.dt) } else { run.causal(info.dt) };
            if let Some(e) = e {
                let _ = out.objects.push(e);
            }
        }
    }

    /// The fits of the newest frame's measured object runs (see [`NewestFit`]), each against
    /// the camera of [`Estimator::causal`].
    pub fn newest_fits(&self) -> impl Iterator<Item = NewestFit> + '_ {
        self.runs.iter().filter_map(ObjectRun::newest_fit)
    }

    /// The newest frame's static points in the world frame (the bounded map: at most
    /// [`crate::limits::MAX_STATIC_TRACKS`]), by track id.
    pub fn map_points(&self) -> impl Iterator<Item = (u32, Point3<f32>)> + '_ {
        let statics = if self.has_previous { &self.previous_statics[..] } else { &[] };
        let cam = *self.camera.frame_to_frame();
        statics.iter().map(move |o| (o.track_id, cam.transform_point(&self.model.back_project(o.u(), o.v(), o.depth))))
    }

    /// Emits the smoothed estimates of every frame still in the window, oldest first, ending the
    /// stream. The estimator then starts afresh with the next frame.
    pub fn flush(&mut self, mut out: impl FnMut(&PoseEstimate)) {
        while let Some(info) = self.window.front().copied() {
            self.smoothed.reset(info.frame, info.timestamp_us);
            if let Some(e) = self.camera.drain(&self.camera_smoothness, &mut self.scratch, info.step) {
                self.smoothed.camera = e.pose;
            }
            let Self { runs, joint, object_smoothness, scratch, stats, smoothed, .. } = self;
            let solve =
                JointSolve { joint, smoothness: object_smoothness, leaving: Some(info.step), dt_leaving: info.dt };
            for run in runs.iter_mut().filter(|r| r.state == RunState::Tracking || r.state == RunState::Draining) {
                if let Some(e) = solve.finish(run, scratch, None, &mut stats.numerical_failures) {
                    let _ = smoothed.objects.push(e);
                }
            }
            self.window.pop_front();
            out(&self.smoothed);
        }
        for run in &mut self.runs {
            *run = ObjectRun::new();
        }
        self.camera = CameraTrack::new();
        self.assembler = FrameAssembler::new();
        self.has_previous = false;
    }

    /// Estimates the frame just assembled in the current buffer, phase by phase. Returns whether
    /// a frame left the window (its smoothed estimate is then in `self.smoothed`).
    ///
    /// Each phase is never inlined: they run once a frame, so the calls cost nothing, and their
    /// locals then share the stack one phase at a time instead of adding up in one frame
    /// (measured on the MCU: 6.9 KiB in the caller with every phase inlined).
    #[inline(never)]
    fn process(&mut self) -> bool {
        bump(&mut self.stats.frames_processed);
        let step = self.step;
        self.step = self.step.wrapping_add(1);
        let has_previous = self.has_previous && self.camera.started();
        let w = self.advance_window(step, has_previous);
        self.measure_camera(step, has_previous, w.leaving);
        // The camera pose objects are measured against. Jointly: the camera's current estimate at
        // k-1 (the one the objects' poses at k-1 were solved with) moved by the new ego-motion, so
        // an object's measured motion and the camera motion it is coupled to share one frame
        // (with the never-revised frame-to-frame pose instead, each camera correction would move
        // an object only until its next measurement pulled it back). Uncoupled: frame-to-frame.
        let camera_now =
            if self.params.joint_sweeps > 0 { self.camera.measurement_pose() } else { *self.camera.frame_to_frame() };
        self.coast_missing(has_previous, w.dt);
        if let Some(s) = w.leaving {
            self.drain_ended(s, w.dt_leaving);
        }
        self.measure_objects(step, has_previous, &camera_now, &w);
        self.solve_window(has_previous, &camera_now, &w);
        // Copied in place: heapless's `clone_from` builds the copy on the stack first (3 KiB).
        self.previous_statics.clear();
        let _ = self.previous_statics.extend_from_slice(&self.frame.statics);
        self.has_previous = true;
        let emitted = w.leaving.is_some();
        if emitted {
            self.window.pop_front();
        }
        emitted
    }

    /// The time step: this frame's period (the nominal one when its timestamp is unusable)
    /// enters the window; the frame leaving it, if the window is full, is named.
    #[inline(never)]
    fn advance_window(&mut self, step: u32, has_previous: bool) -> WindowStep {
        let cur = &self.frame;
        let dt = match self.window.back() {
            Some(last) if has_previous => {
                let d = cur.timestamp_us.checked_sub(last.timestamp_us).map(|us| us as f32 * 1e-6);
                match d {
                    Some(d) if d > 0.0 && d <= self.params.max_dt => d,
                    _ => {
                        bump(&mut self.stats.timestamps_replaced);
                        self.params.nominal_dt
                    }
                }
            }
            _ => self.params.nominal_dt,
        };
        // Frames leave the window as it fills, so there is always room here.
        let _ = self.window.push_back(FrameInfo { step, frame: cur.frame, timestamp_us: cur.timestamp_us, dt });
        let leaving_info = if self.window.is_full() { self.window.front().copied() } else { None };
        if let Some(i) = leaving_info {
            self.smoothed.reset(i.frame, i.timestamp_us);
        }
        WindowStep { leaving: leaving_info.map(|i| i.step), dt_leaving: leaving_info.map_or(dt, |i| i.dt), dt }
    }

    /// The camera: its ego-motion measured from the static tracks (solved jointly with the
    /// objects later), or, without a previous frame, a new world frame begun.
    #[inline(never)]
    fn measure_camera(&mut self, step: u32, has_previous: bool, leaving: Option<u32>) {
        if has_previous {
            let mut m = Measuring {
                model: &self.model,
                rng: &mut self.rng,
                corrs: &mut self.corrs,
                smoothness: &self.camera_smoothness,
                scratch: &mut self.scratch,
            };
            let fitted =
                self.camera.measure(&self.previous_statics, &self.frame.statics, &self.params.camera_fit, &mut m);
            if !fitted {
                bump(&mut self.stats.camera_motion_held);
            }
            return;
        }
        if self.camera.started()
            && let Some(s) = leaving
            && let Some(e) = self.camera.drain(&self.camera_smoothness, &mut self.scratch, s)
        {
            self.smoothed.camera = e.pose;
        }
        self.camera.start(step);
    }

    /// Runs whose object is missing from this frame coast on their last motion (for at most
    /// MAX_HELD_FRAMES frames, then they end); one seen only once is dropped.
    #[inline(never)]
    fn coast_missing(&mut self, has_previous: bool, dt: f32) {
        let Self { runs, frame, stats, object_smoothness, scratch, params, .. } = self;
        for run in runs.iter_mut() {
            if !run.is_live() || frame.object(run.object_id).is_some() {
                continue;
            }
            if run.state == RunState::Initialising {
                bump(&mut stats.objects_not_initialised);
                run.state = RunState::Free;
            } else if !has_previous {
                run.state = RunState::Draining;
            } else if let StepOutcome::Restart(cause) =
                run.coast(object_smoothness, scratch, dt, params.bev_track.as_ref())
            {
                stats.run_ended(cause);
                run.state = RunState::Draining;
            } else {
                bump(&mut stats.object_frames_coasted);
            }
        }
    }

    /// Ended runs emit their frame `leaving` the window.
    #[inline(never)]
    fn drain_ended(&mut self, leaving: u32, dt_leaving: f32) {
        let Self { runs, joint, object_smoothness, scratch, stats, smoothed, .. } = self;
        let solve = JointSolve { joint, smoothness: object_smoothness, leaving: Some(leaving), dt_leaving };
        for run in runs.iter_mut().filter(|r| r.state == RunState::Draining) {
            if let Some(e) = solve.finish(run, scratch, None, &mut stats.numerical_failures) {
                let _ = smoothed.objects.push(e);
            }
        }
    }

    /// Every object of this frame: its run measures it (and ends on a failed restart), or a new
    /// run starts in a free slot.
    #[inline(never)]
    fn measure_objects(&mut self, step: u32, has_previous: bool, camera_now: &Pose3, w: &WindowStep) {
        let Self { frame, runs, stats, params, model, rng, corrs, object_smoothness, scratch, joint, smoothed, .. } =
            self;
        // A run that ends here emits its frame leaving the window, solved as the ended ones are.
        let drain = JointSolve { joint, smoothness: object_smoothness, leaving: w.leaving, dt_leaving: w.dt_leaving };
        for obj in &frame.objects {
            let live = runs.iter().position(|r| r.is_live() && r.object_id == obj.object_id);
            let mut restart = live.is_none();
            if let (Some(i), true) = (live, has_previous) {
                let beyond_range = usize::from(obj.beyond_range) > obj.points.len();
                let cx = PairContext {
                    current: &obj.points,
                    camera: camera_now,
                    leaving: w.leaving,
                    beyond_range,
                    dt: w.dt,
                };
                let Some(run) = runs.get_mut(i) else { continue };
                let was_coasting = run.coasted_since_fit();
                let was_initialising = run.state == RunState::Initialising;
                let mut m = Measuring { model, rng, corrs, smoothness: object_smoothness, scratch };
                match run.measure(&cx, params, &mut m) {
                    StepOutcome::Measured => {
                        if was_coasting {
                            bump(&mut stats.objects_resumed);
                        }
                        if was_initialising {
                            bump(&mut stats.runs_tracked);
                        }
                    }
                    StepOutcome::Held => bump(&mut stats.object_motion_held),
                    StepOutcome::Restart(cause) => {
                        bump(&mut stats.object_motion_held);
                        if run.state == RunState::Initialising {
                            bump(&mut stats.objects_not_initialised);
                            run.state = RunState::Free;
                        } else {
                            stats.run_ended(cause);
                            run.state = RunState::Draining;
                            if w.leaving.is_some()
                                && let Some(e) = drain.finish(run, scratch, None, &mut stats.numerical_failures)
                            {
                                let _ = smoothed.objects.push(e);
                            }
                        }
                        restart = true;
                    }
                }
            } else if let Some(i) = live {
                // Live but without a previous frame (a new world frame began): start again.
                if let Some(run) = runs.get_mut(i) {
                    run.state = RunState::Free;
                }
                restart = true;
            }
            // An object with no usable point (all beyond range) starts no run.
            if !restart || obj.points.is_empty() {
                continue;
            }
            if live.is_none() && runs.iter().any(|r| r.state == RunState::Draining && r.object_id == obj.object_id) {
                bump(&mut stats.objects_returned);
            }
            let Some(slot) = free_slot(runs, stats) else { continue };
            if slot.initialise(obj, camera_now, model, step, params.object_min_points, params.bev_track.as_ref()) {
                bump(&mut stats.objects_initialised);
            } else {
                bump(&mut stats.objects_not_initialised);
            }
        }
    }

    /// The joint solve of camera and object motions over the window, then every path takes its
    /// solution (and emits its frame leaving the window).
    #[inline(never)]
    fn solve_window(&mut self, has_previous: bool, camera_now: &Pose3, w: &WindowStep) {
        if has_previous {
            self.joint_solve();
            let xs = (!self.joint.camera_solution().is_empty()).then(|| self.joint.camera_solution());
            let r = self.camera.finish(xs, &self.camera_smoothness, w.leaving);
            if self.params.joint_sweeps == 0 {
                // No coupling: objects are smoothed alone, against the frame-to-frame camera.
                self.joint.unload_camera();
            }
            if r.solve_failed {
                bump(&mut self.stats.numerical_failures);
            }
            if let Some(e) = r.emitted {
                self.smoothed.camera = e.pose;
            }
        } else {
            self.joint.unload_camera();
        }
        let Self { runs, frame, joint, object_smoothness, scratch, stats, smoothed, params, model, .. } = self;
        let inlier_px = params.object_fit.inlier_px;
        let solve = JointSolve { joint, smoothness: object_smoothness, leaving: w.leaving, dt_leaving: w.dt_leaving };
        for run in runs.iter_mut().filter(|r| r.stepped()) {
            let points = frame.object(run.object_id).map(|o| &o.points[..]).unwrap_or(&[]);
            let fuse_with = (points, camera_now, &*model, inlier_px);
            if let Some(e) = solve.finish(run, scratch, Some(fuse_with), &mut stats.numerical_failures) {
                let _ = smoothed.objects.push(e);
            }
            if let Some(p) = &params.bev_track {
                run.update_bev_velocity(w.dt, p);
            }
            if run.reorient_if_moved(params) {
                bump(&mut stats.objects_reoriented);
            }
        }
    }
}

/// What the time step of one frame decided about the window.
struct WindowStep {
    /// The step of the frame leaving the window, once it is full.
    leaving: Option<u32>,
    /// The frame period of the frame leaving (this frame's when none leaves).
    dt_leaving: f32,
    /// This frame's period.
    dt: f32,
}

/// An object's chain solved with the camera held at the joint solution.
struct JointSolve<'a, const W: usize> {
    joint: &'a JointScratch<W>,
    smoothness: &'a Smoothness,
    leaving: Option<u32>,
    dt_leaving: f32,
}

impl<const W: usize> JointSolve<'_, W> {
    /// Solves `run`'s chain and hands it the result (see [`ObjectRun::finish`]); `fuse_with`
    /// (the frame's points, the camera, the model, the inlier bound) refines its landmarks,
    /// none for a run that has ended.
    fn finish(
        &self,
        run: &mut ObjectRun<W>,
        scratch: &mut ChainScratch<W>,
        fuse_with: Option<(&[Obs], &Pose3, &PointModel, f32)>,
        failures: &mut u32,
    ) -> Option<ObjectEstimate> {
        let (chain, first) = (run.path().chain(), run.path().first_slot_step());
        let n = chain.solve_with(self.smoothness, scratch, |i| self.joint.object_extra(chain, first, i));
        let shift = self.joint.front_shift(chain, first);
        let exit = WindowExit { leaving: self.leaving, dt_leaving: self.dt_leaving, front_shift: shift };
        run.finish(n.map(|n| scratch.solution(n)), self.smoothness, exit, fuse_with, failures)
    }
}

impl<const W: usize> Estimator<W> {
    /// Block Gauss-Seidel over the window ([`super::joint`]): the camera alone first, then
    /// [`JOINT_SWEEPS`] sweeps of (every object with the camera held, the camera with the
    /// objects held). Leaves the camera's solution in `self.joint`; an empty one if its solve
    /// failed (objects are then solved alone).
    fn joint_solve(&mut self) {
        let Self { camera, runs, joint, scratch, camera_smoothness, object_smoothness, params, .. } = self;
        let objects = || {
            runs.iter()
                .filter(|r| matches!(r.state, RunState::Tracking | RunState::Draining))
                .map(|r| (r.path().chain(), r.path().first_slot_step()))
        };
        let path = camera.path();
        let settings = JointSettings {
            camera_prior: camera_smoothness,
            object_prior: object_smoothness,
            sweeps: params.joint_sweeps,
        };
        solve_joint(joint, path.chain(), path.first_slot_step(), settings, scratch, objects);
    }
}

/// A slot for a new run: a free one, else the draining run with the fewest frames still to
/// emit (its pending frames are lost and counted).
fn free_slot<'a, const W: usize>(
    runs: &'a mut [ObjectRun<W>; MAX_OBJECTS],
    stats: &mut EstimatorStats,
) -> Option<&'a mut ObjectRun<W>> {
    let i = match runs.iter().position(|r| r.state == RunState::Free) {
        Some(i) => i,
        None => {
            let (i, lost) = runs
                .iter()
                .enumerate()
                .filter(|(_, r)| r.state == RunState::Draining)
                .map(|(i, r)| (i, r.pending()))
                .min_by_key(|(_, p)| *p)?;
            bump(&mut stats.runs_evicted);
            add(&mut stats.smoothed_frames_lost, lost);
            i
        }
    };
    runs.get_mut(i)
}
