//! The front-end on a rendered sequence: its tracks with the simulator's truth, per frame (the
//! estimator and its scores are the host's `estimation::end_to_end`).

use std::collections::BTreeSet;

use dynotraj_sim::image_sim::{ImageSim, RenderedMasks};
use dynotraj_sim::track_sim::{SimFrame, moving_objects};
use opencv::prelude::*;

use super::cost::input_with;
use super::disparity_error::{DisparityErrors, FrameTruth, SentPoint};
use super::error::{FrontEndError, cv};
use super::motion::{MotionParams, MotionSegmenter};
use super::motion_scores::{FrameSegments, MotionScores};
use super::pipeline::{FrontEnd, StageTimes};
use super::stats::FrontEndStats;
use super::stereo::StereoParams;
use super::tracker::TrackerParams;

/// What the front-end gave on a rendering: its tracks with the truth, per frame, and how it did.
#[derive(Debug, Clone)]
pub struct RenderingTracked {
    /// The front-end's tracks with the truth, per frame.
    pub frames: Vec<SimFrame>,
    /// Stage times.
    pub times: StageTimes,
    /// Front-end counters.
    pub stats: FrontEndStats,
}

/// Runs the front-end over the first `frames` frames of `sim` at `dt` seconds a frame with the
/// tracker's defaults, telling `on_frame` the frames done after each.
///
/// # Errors
/// An OpenCV failure.
pub fn track_with(
    sim: &ImageSim,
    frames: usize,
    dt: f32,
    stereo: StereoParams,
    on_frame: Option<&dyn Fn(u64)>,
) -> Result<RenderingTracked, FrontEndError> {
    track_measured(sim, frames, dt, (stereo, TrackerParams::default(), RenderedMasks::Ids), on_frame, None)
}

/// [`track_with`] with the tracker's parameters and the masks `masks`, adding each frame's sent
/// points, scored against the rendering's exact depth, to `errors`.
///
/// # Errors
/// An OpenCV failure.
pub fn track_measured(
    sim: &ImageSim,
    frames: usize,
    dt: f32,
    (stereo, tracker, masks): (StereoParams, TrackerParams, RenderedMasks),
    on_frame: Option<&dyn Fn(u64)>,
    mut errors: Option<&mut DisparityErrors>,
) -> Result<RenderingTracked, FrontEndError> {
    let cam = sim.camera;
    let mut fe = FrontEnd::new(stereo, tracker, cam.fb() as f32)?;
    let mut out = Vec::new();
    for k in 0..frames.min(sim.len()) {
        let Some(f) = sim.frame(k) else { break };
        let tracks = fe.process(input_with(&f, &cam, masks)?)?;
        if let Some(errors) = errors.as_deref_mut() {
            let truth = FrameTruth { depth: &f.depth, ids: &f.ids, width: cam.width, height: cam.height };
            let points: Vec<SentPoint> =
                tracks.iter().map(|t| SentPoint { u: t.u, v: t.v, depth_m: t.depth, object_id: t.object_id }).collect();
            errors.add_frame(&points, &truth, cam.fb() as f32);
        }
        let timestamp_us = (k as f64 * f64::from(dt) * 1e6).round() as u64;
        out.push(SimFrame { frame: f.frame, timestamp_us, tracks, camera: f.camera, objects: f.objects });
        if let Some(hook) = on_frame {
            hook(out.len() as u64);
        }
    }
    Ok(RenderingTracked { frames: out, times: fe.times, stats: fe.tracker.stats })
}

/// The front-end with motion masks ([`MaskInput::Motion`]) over the first `frames` frames of
/// `sim`, its masks scored into `scores` against the objects moving at least `min_step_m` a
/// frame ([`moving_objects`]).
///
/// # Errors
/// An OpenCV failure.
pub fn track_motion_scored(
    sim: &ImageSim,
    frames: usize,
    (stereo, tracker, motion): (StereoParams, TrackerParams, MotionParams),
    min_step_m: f64,
    scores: &mut MotionScores,
) -> Result<RenderingTracked, FrontEndError> {
    let cam = sim.camera;
    let n = frames.min(sim.len());
    let moving = moving_objects(sim.truth.iter().take(n).map(Vec::as_slice), min_step_m);
    let mut fe = FrontEnd::new(stereo, tracker, cam.fb() as f32)?;
    fe.motion = MotionSegmenter::new(motion);
    let mut out = Vec::new();
    for k in 0..n {
        let Some(f) = sim.frame(k) else { break };
        let tracks = fe.process(input_with(&f, &cam, RenderedMasks::Motion)?)?;
        let segments = fe.last_masks.data_typed::<u16>().map_err(cv("reading the masks"))?;
        let frame = FrameSegments {
            frame: k,
            width: cam.width,
            truth_ids: &f.ids,
            truth_depth: &f.depth,
            segments,
            moving: &moving,
            at_rest: &at_rest(sim, k, min_step_m),
        };
        scores.add_frame(&frame);
        scores.add_residuals(&fe.motion.judged, &frame);
        scores.add_fates(&fe.motion.fates, &frame);
        out.push(SimFrame { frame: f.frame, timestamp_us: 0, tracks, camera: f.camera, objects: f.objects });
    }
    scores.end_sequence();
    Ok(RenderingTracked { frames: out, times: fe.times, stats: fe.tracker.stats })
}

/// The objects of frame `k` of `sim` that moved less than `min_step_m` a frame on average over
/// the last [`REST_FRAMES`] frames (or as many as they were seen in).
fn at_rest(sim: &ImageSim, k: usize, min_step_m: f64) -> BTreeSet<u16> {
    let Some(now) = sim.truth.get(k) else { return BTreeSet::new() };
    let then = k.saturating_sub(REST_FRAMES);
    now.iter()
        .filter(|o| {
            (then..k)
                .find_map(|j| {
                    let before = sim.truth.get(j)?.iter().find(|b| b.object_id == o.object_id)?;
                    Some((o.pose.translation.vector - before.pose.translation.vector).norm() / (k - j) as f64)
                })
                .is_some_and(|step| step < min_step_m)
        })
        .map(|o| o.object_id)
        .collect()
}

/// The frames over which an object's motion decides whether it stands still in a frame.
const REST_FRAMES: usize = 3;
