//! The camera's track: ego-motion from static tracks, frame to frame and smoothed.

use super::fit::fit_pose;
use super::frame::Obs;
use super::lie::Vec6;
use super::lie::normalised;
use super::measure::{
    Measuring, MotionMeasurement, correspondences, inverse_information, plausible, twist_measurement,
};
use super::motion_smoother::{ChainScratch, Smoothness};
use super::params::FitParams;
use super::path::{Emitted, SmoothedPath};
use crate::geometry::{POSE3_IDENTITY, Pose3, se3_log};

/// What one camera step produced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraStep {
    /// Whether the smoother broke down (the causal pose was held).
    pub solve_failed: bool,
    /// The smoothed pose of the leaving step, if it was the camera's.
    pub emitted: Option<Emitted>,
}

/// The camera's poses: frame-to-frame (never revised, used to measure objects) and smoothed.
#[derive(Debug, Clone)]
pub struct CameraTrack<const W: usize> {
    /// Smoothed path of the camera motions.
    path: SmoothedPath<W>,
    /// Frame-to-frame pose at the newest step.
    f2f: Pose3,
    /// The newest frame-to-frame motion `T_(k-1)^-1 T_k`.
    increment: Pose3,
    /// Whether a first frame was seen.
    started: bool,
}

impl<const W: usize> Default for CameraTrack<W> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const W: usize> CameraTrack<W> {
    /// A camera not yet started.
    #[must_use]
    pub const fn new() -> Self {
        Self { path: SmoothedPath::new(), f2f: POSE3_IDENTITY, increment: POSE3_IDENTITY, started: false }
    }

    /// Whether the first frame was seen.
    #[must_use]
    pub const fn started(&self) -> bool {
        self.started
    }

    /// The frame-to-frame pose of the newest frame.
    #[must_use]
    pub const fn frame_to_frame(&self) -> &Pose3 {
        &self.f2f
    }

    /// The causal pose of the newest frame: its current estimate, from frames up to it only,
    /// the pose the frame's objects were placed against (within the last solve's correction).
    /// Not the path's chain of newest motions: that chain is never revised, so it drifts away
    /// from the world the objects are placed in (on 0009 by 25 m in 600 frames).
    #[must_use]
    pub const fn causal(&self) -> &Pose3 {
        self.path.current()
    }

    /// Starts at the world origin on step `step` (the world frame is the first camera frame).
    pub fn start(&mut self, step: u32) {
        self.path.start(Pose3::identity(), step);
        self.f2f = Pose3::identity();
        self.increment = Pose3::identity();
        self.started = true;
    }

    /// Fits the ego-motion from frame k-1's static tracks `previous` to frame k's `current`, or
    /// holds the previous motion when the fit fails; advances the frame-to-frame pose and adds
    /// the step to the smoother's window, coupled to the motion the objects of this frame are
    /// measured against (the frame-to-frame one). Returns whether the motion was fitted.
    /// [`CameraTrack::finish`] follows the window's solve.
    pub fn measure(&mut self, previous: &[Obs], current: &[Obs], fp: &FitParams, m: &mut Measuring<'_, W>) -> bool {
        let (model, s) = (m.model, m.smoothness);
        let (rng, corrs, scratch) = (&mut *m.rng, &mut *m.corrs, &mut *m.scratch);
        // Source: camera k-1; the fitted pose maps camera k-1 into camera k, i.e. the inverse of
        // the increment n = T_(k-1)^-1 T_k.
        correspondences(previous, current, &Pose3::identity(), model, corrs);
        let guess = self.increment.inverse();
        let measured: Option<MotionMeasurement> = fit_pose(corrs, Some(&guess), fp, model, rng).ok().and_then(|fit| {
            let n = fit.pose.inverse();
            if !plausible(&n, fp) {
                return None;
            }
            let info = inverse_information(&fit.pose, &fit.information)?;
            twist_measurement(&n, &info, fit.inliers)
        });
        let fitted = measured.is_some();
        if let Some(m) = &measured {
            self.increment = m.delta;
        }
        self.f2f = normalised(self.f2f * self.increment);
        let z = measured.as_ref().map(|m| (&m.xi, &m.information));
        let c_bar = se3_log(&self.increment);
        let mut lin = [0.0f32; 6];
        lin.iter_mut().zip(c_bar.iter()).for_each(|(a, b)| *a = *b);
        self.path.push(z, &lin, s, scratch);
        fitted
    }

    /// Takes the window's solution (`None`: the solve failed, the causal pose holds) and emits
    /// the leaving step if it is the camera's.
    pub fn finish(&mut self, xs: Option<&[Vec6]>, s: &Smoothness, leaving: Option<u32>) -> CameraStep {
        let (emitted, solve_failed) = match self.path.apply(xs, s, leaving, true, None) {
            Ok(e) => (e, false),
            Err(_) => (None, true),
        };
        CameraStep { solve_failed, emitted }
    }

    /// The pose of the newest frame as the current estimate of the frame before it, moved by the
    /// newest (measured or held) ego-motion: what objects are measured against in the joint
    /// solve, between [`CameraTrack::measure`] and [`CameraTrack::finish`].
    #[must_use]
    pub fn measurement_pose(&self) -> Pose3 {
        if self.path.chain().is_empty() { self.f2f } else { normalised(self.path.current() * self.increment) }
    }

    /// The smoothed path (its chain is the camera's part of the joint solve).
    #[must_use]
    pub const fn path(&self) -> &SmoothedPath<W> {
        &self.path
    }

    /// Emits the leaving step without a new frame (flushing at the end of a stream).
    pub fn drain(&mut self, s: &Smoothness, scratch: &mut ChainScratch<W>, leaving: u32) -> Option<Emitted> {
        self.path.drain(s, scratch, leaving).ok().flatten()
    }
}
