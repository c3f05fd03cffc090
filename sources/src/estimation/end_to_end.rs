//! Rendered sequence -> front-end -> core estimator, scored against the simulator's truth: the
//! whole image path with exact truth.

use dynotraj_core::estimate::EstimatorParams;
use dynotraj_sim::image_sim::ImageSim;
use dynotraj_sim::track_sim::SimFrame;

use super::score::moving_objects;
use super::simulated::WINDOW;
use super::{EstimatorRun, RunScores, run_estimator, score_run};
use crate::on_step::OnStep;
use dynotraj_frontend::error::FrontEndError;
use dynotraj_frontend::pipeline::StageTimes;
use dynotraj_frontend::rendered::{RenderingTracked, track_with};
use dynotraj_frontend::stats::FrontEndStats;
use dynotraj_frontend::stereo::StereoParams;

/// What an end-to-end run gave.
#[derive(Debug, Clone)]
pub struct EndToEnd {
    /// The front-end's tracks with the truth, per frame.
    pub frames: Vec<SimFrame>,
    /// Stage times.
    pub times: StageTimes,
    /// Front-end counters.
    pub stats: FrontEndStats,
    /// The estimator's outputs.
    pub run: EstimatorRun,
    /// RPE per output kind.
    pub scores: RunScores,
}

/// Runs the front-end over the first `frames` frames of `sim` at `dt` seconds a frame, then the
/// estimator (the host profile's window, the KITTI defaults), and scores objects moving at least
/// `min_step_m` per frame.
///
/// # Errors
/// An OpenCV failure.
pub fn run(
    sim: &ImageSim,
    frames: usize,
    dt: f32,
    stereo: StereoParams,
    min_step_m: f64,
) -> Result<EndToEnd, FrontEndError> {
    run_with(sim, frames, (dt, stereo), min_step_m, None)
}

/// [`run`] with its frame period and stereo settings as one pair, telling `on_frame` the frames
/// tracked after each.
///
/// # Errors
/// An OpenCV failure.
pub fn run_with(
    sim: &ImageSim,
    frames: usize,
    (dt, stereo): (f32, StereoParams),
    min_step_m: f64,
    on_frame: Option<&OnStep>,
) -> Result<EndToEnd, FrontEndError> {
    let hook = on_frame.map(|h| -> &dyn Fn(u64) { h.as_fn() });
    let RenderingTracked { frames: out, times, stats } = track_with(sim, frames, dt, stereo, hook)?;
    let params = EstimatorParams::kitti(sim.camera.intrinsics(), dt);
    let run = run_estimator::<WINDOW>(&out, params, 1);
    let moving = moving_objects(&out, min_step_m);
    let scores = score_run(&out, &run, &moving);
    Ok(EndToEnd { frames: out, times, stats, run, scores })
}
