//! The Estimated source from real images: where a KITTI tracking folder holds the stereo
//! images of a sequence (image_02/ and image_03/ for every frame, as a full KITTI download or
//! `dynotraj simulate` has them), the image front-end (OpenCV) tracks them and the core
//! estimator runs on its tracks, exactly as `dynotraj track` then `dynotraj estimate --tracks`
//! would. There is no truth then: no RPE and no common reference.
//!
//! Without real images, [`estimate_rendered`] renders the sequence with the image simulator
//! (textured boxes of the label sizes on the simulator's smoothed label paths, over a textured
//! ground and static structures, from the real ego poses and calibration) and runs the same
//! front-end and estimator on the rendering, with the simulator's truth kept for scoring.

use std::collections::BTreeMap;
use std::path::Path;

use dynotraj_core::estimate::{EstimatorParams, Intrinsics};

use dynotraj_sim::image_sim::{Camera, ImageSim, RenderedMasks};

use dynotraj_sim::track_sim::SimFrame;
use dynotraj_sim::track_sim::truth_association::{associate, name_truth_after};

use super::input::{SimInput, sim_input};
use super::rendered_cache::{self, RenderSettings};
use super::runner::EstimatorRun;
use super::score::{RunScores, moving_objects, score_run};
use super::simulated::{EvalOptions, run_sim_with_window};
#[cfg(feature = "images")]
use super::simulated::{params_for, run_with_window, sim_max_depth};
use dynotraj_formats::kitti::SequenceData;
#[cfg(feature = "images")]
use dynotraj_formats::tracks_file::TracksFrame;
#[cfg(feature = "images")]
use dynotraj_frontend::StageTimes;
#[cfg(feature = "images")]
use dynotraj_frontend::disparity_error::DisparityErrors;
#[cfg(feature = "images")]
use dynotraj_frontend::motion_scores::MotionScores;
#[cfg(feature = "images")]
use dynotraj_frontend::sequence::{DepthMode, ImageSequence, MaskMode};
#[cfg(feature = "images")]
use dynotraj_frontend::{FrontEnd, FrontEndStats, rendered};

/// What a build without the image front-end says where it would be needed.
pub const WITHOUT_IMAGES: &str = "this dynotraj was built without the image front-end (the cargo \
    feature `images`, which links OpenCV): rebuild with default features, or use \
    `--ours-input tracks` or an estimate cache that holds the rendering";

/// True when `dir` holds a left and a right image of every frame `0..frames` of `seq`.
#[must_use]
pub fn has_images(dir: &Path, seq: &str, frames: usize) -> bool {
    frames > 0
        && ["image_02", "image_03"].iter().all(|cam| {
            let folder = dir.join(cam).join(seq);
            (0..frames).all(|k| folder.join(format!("{k:06}.png")).is_file())
        })
}

/// Every file the image front-end reads for `seq` besides calibration and labels: the stereo
/// pair of each frame and, where the folder has them, its instance masks (in frame order).
#[must_use]
pub fn image_files(dir: &Path, seq: &str, frames: usize) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for cam in ["image_02", "image_03", "instance_02"] {
        let folder = dir.join(cam).join(seq);
        if cam == "instance_02" && !folder.is_dir() {
            continue;
        }
        out.extend((0..frames).map(|k| folder.join(format!("{k:06}.png"))));
    }
    out
}

/// Tracks the images of `seq` (stereo depth, masks from instance_02/ or the label boxes) and
/// runs the estimator on them with `opt`'s window, priors and seed.
///
/// # Errors
/// An unreadable image or calibration, or a front-end failure, with the file or frame named.
pub fn estimate_from_images(dir: &Path, seq: &str, opt: &EvalOptions) -> anyhow::Result<EstimatorRun> {
    #[cfg(not(feature = "images"))]
    {
        let _ = (dir, seq, opt);
        anyhow::bail!("sequence {seq}: {WITHOUT_IMAGES}");
    }
    #[cfg(feature = "images")]
    track_images(dir, seq, opt)
}

/// [`estimate_from_images`] with the front-end.
#[cfg(feature = "images")]
fn track_images(dir: &Path, seq: &str, opt: &EvalOptions) -> anyhow::Result<EstimatorRun> {
    let s = ImageSequence::open(dir, seq, DepthMode::Stereo, MaskMode::Auto)?;
    let [fx, fy, cx, cy] = s.intrinsics;
    let intrinsics = Intrinsics { fx: fx as f32, fy: fy as f32, cx: cx as f32, cy: cy as f32, stereo_fb: s.fb as f32 };
    let mut fe = FrontEnd::new(opt.point_depth.stereo(1.0), opt.point_depth.tracker(), s.fb as f32)?;
    let mut frames = Vec::new();
    s.track(&mut fe, opt.max_frames.unwrap_or(usize::MAX), 1.0 / f64::from(opt.dt), |frame, timestamp_us, tracks| {
        frames.push(
            TracksFrame::split(frame, timestamp_us, tracks).map_err(|e| anyhow::anyhow!("frame {frame}: {e:?}"))?,
        );
        Ok(())
    })?;
    let params = params_for(intrinsics, sim_max_depth(), opt.pixel_sigma.max(0.5), opt.disparity_sigma.max(0.5), opt);
    Ok(run_with_window(&frames, params, opt))
}

/// Front-end object id to the id of the true object it followed
/// ([`dynotraj_sim::track_sim::truth_association::Association::truth_of`]).
pub type TrueIds = BTreeMap<u16, u16>;

/// A rendered sequence, tracked by the front-end, through the estimator.
#[derive(Debug, Clone)]
pub struct RenderedRun {
    /// The front-end's tracks with the simulator's truth, per frame.
    pub frames: Vec<SimFrame>,
    /// Where the front-end named its objects itself (box or motion masks), the true object id
    /// of each that followed one; `None` with the rendered ids, which are the truth's.
    pub truth_of: Option<TrueIds>,
    /// The estimator's outputs.
    pub run: EstimatorRun,
    /// RPE per output kind.
    pub scores: RunScores,
}

/// Renders sequence `id` (`data`) at `scale` of KITTI's resolution (1: 1242 x 375) with `opt`'s
/// classes, seed, frame period and frame limit, and tracks the rendering with the front-end
/// (SGBM stereo, `opt`'s masks, KLT); with `cache`, the frames are read from it when it holds
/// this rendering, and stored there otherwise. With masks other than the rendered ids, the
/// truth is also named after the front-end's objects ([`name_truth_after`]), and returned
/// beside the frames is the true object id of each of them (`None` with the rendered ids).
///
/// # Errors
/// A bad scale, a front-end failure, or a cache file that cannot be written, named.
pub fn render_and_track(
    id: &str,
    data: &SequenceData,
    opt: &EvalOptions,
    scale: f64,
    cache: Option<&Path>,
) -> anyhow::Result<(Vec<SimFrame>, Option<TrueIds>)> {
    anyhow::ensure!(
        scale.is_finite() && (0.05..=2.0).contains(&scale),
        "--render-scale: expected 0.05..=2, found {scale}"
    );
    let input = sim_input(data, &opt.classes);
    let n = frames_rendered(&input, opt);
    let settings = RenderSettings {
        classes: opt.classes.clone(),
        seed: opt.seed,
        scale,
        dt: opt.dt,
        frames: n,
        optics: opt.render_optics,
        point_depth: opt.point_depth,
    };
    let key = match cache {
        Some(_) => Some(rendered_cache::rendered_key(id, data, &settings)?),
        None => None,
    };
    let mut frames = if let Some(frames) = cache.zip(key).and_then(|(dir, key)| rendered_cache::load(dir, id, key)) {
        log::info!("sequence {id}: rendered front-end tracks read from the cache");
        frames
    } else {
        let sim = image_sim(input, opt, scale, n);
        let frames = track_rendering(&sim, n, opt, scale)?;
        if let (Some(dir), Some(key)) = (cache, key) {
            rendered_cache::store(dir, id, key, &frames)?;
        }
        frames
    };
    if opt.point_depth.masks == RenderedMasks::Ids {
        return Ok((frames, None));
    }
    // The front-end named the objects itself: the truth is named after them too.
    let association = associate(&frames, &rendered_intrinsics(scale));
    log::info!(
        "sequence {id}: {} front-end objects matched to a true object, {} not ({} of {} object points in their \
         matched boxes)",
        association.truth_of.len(),
        association.unmatched.len(),
        association.points_in_mapped_box,
        association.points
    );
    name_truth_after(&mut frames, &association);
    Ok((frames, Some(association.truth_of)))
}

/// Frames of `input` rendered under `opt`'s frame limit.
fn frames_rendered(input: &SimInput, opt: &EvalOptions) -> usize {
    opt.max_frames.map_or(input.camera_poses.len(), |m| m.min(input.camera_poses.len()))
}

/// The image simulator of the first `n` frames of `input` at `scale`, with `opt`'s camera model
/// and seed.
fn image_sim(input: SimInput, opt: &EvalOptions, scale: f64, n: usize) -> ImageSim {
    let boxes: Vec<_> = input.boxes.into_iter().filter(|b| (b.frame as usize) < n).collect();
    let camera = Camera { optics: opt.render_optics, ..render_camera(scale) };
    ImageSim::new(camera, input.camera_poses.get(..n).unwrap_or(&input.camera_poses), &boxes, opt.seed)
}

/// The front-end's tracks of the first `n` frames of the rendering `sim` made at `scale`, with
/// `opt`'s frame period and point depth.
#[cfg(feature = "images")]
fn track_rendering(sim: &ImageSim, n: usize, opt: &EvalOptions, scale: f64) -> anyhow::Result<Vec<SimFrame>> {
    let (stereo, tracker) = (opt.point_depth.stereo(scale), opt.point_depth.tracker());
    Ok(rendered::track_measured(sim, n, opt.dt, (stereo, tracker, opt.point_depth.masks), None, None)?.frames)
}

/// Renders the first `opt.max_frames` frames of sequence `id` (`data`) at KITTI's resolution
/// with `opt`'s classes, seed, frame period and point depth, tracks them and
/// scores the disparity of every point the front-end sends against the rendering's exact depth.
///
/// # Errors
/// A front-end failure.
#[cfg(feature = "images")]
pub fn disparity_errors(
    id: &str,
    data: &SequenceData,
    opt: &EvalOptions,
) -> anyhow::Result<(DisparityErrors, FrontEndStats)> {
    let (stereo, tracker) = (opt.point_depth.stereo(1.0), opt.point_depth.tracker());
    let input = sim_input(data, &opt.classes);
    let n = frames_rendered(&input, opt);
    let sim = image_sim(input, opt, 1.0, n);
    let mut errors = DisparityErrors::default();
    let tracked =
        rendered::track_measured(&sim, n, opt.dt, (stereo, tracker, opt.point_depth.masks), None, Some(&mut errors))
            .map_err(|e| anyhow::anyhow!("sequence {id}: {e}"))?;
    Ok((errors, tracked.stats))
}

/// Renders the first `opt.max_frames` frames of sequence `id` (`data`) as
/// [`disparity_errors`] does, tracks them with motion masks and scores the masks against the
/// objects moving at least `opt.min_step_m` a frame; with the front-end's stage times and
/// counters.
///
/// # Errors
/// A front-end failure.
#[cfg(feature = "images")]
pub fn motion_masks_scored(
    id: &str,
    data: &SequenceData,
    opt: &EvalOptions,
) -> anyhow::Result<(MotionScores, StageTimes, FrontEndStats)> {
    let (stereo, tracker) = (opt.point_depth.stereo(1.0), opt.point_depth.tracker());
    let input = sim_input(data, &opt.classes);
    let n = frames_rendered(&input, opt);
    let sim = image_sim(input, opt, 1.0, n);
    let mut scores = MotionScores::default();
    let tracked = rendered::track_motion_scored(
        &sim,
        n,
        (stereo, tracker, dynotraj_frontend::motion::MotionParams::default()),
        opt.min_step_m,
        &mut scores,
    )
    .map_err(|e| anyhow::anyhow!("sequence {id}: {e}"))?;
    Ok((scores, tracked.times, tracked.stats))
}

/// Without the front-end a rendering cannot be tracked.
#[cfg(not(feature = "images"))]
fn track_rendering(_: &ImageSim, _: usize, _: &EvalOptions, _: f64) -> anyhow::Result<Vec<SimFrame>> {
    anyhow::bail!(WITHOUT_IMAGES)
}

/// The camera renderings are made with at `scale`.
#[must_use]
pub fn render_camera(scale: f64) -> Camera {
    Camera { noise: 2, ..Camera::kitti(scale) }
}

/// The estimator's camera model of a rendering at `scale`.
#[must_use]
pub fn rendered_intrinsics(scale: f64) -> Intrinsics {
    render_camera(scale).intrinsics()
}

/// The estimator parameters for tracks of a rendering at `scale`: the KITTI defaults with the
/// render camera and `opt`'s frame period, priors, joint sweeps and object variants.
#[must_use]
pub fn rendered_params(scale: f64, opt: &EvalOptions) -> EstimatorParams {
    let mut params = EstimatorParams::kitti(rendered_intrinsics(scale), opt.dt);
    opt.apply_to(&mut params);
    params
}

/// Renders and tracks sequence `id` ([`render_and_track`], cached in `cache`) and runs the
/// estimator with `opt`'s window, priors and joint sweeps on the front-end's tracks, scored
/// against the simulator's truth (objects moving at least `opt.min_step_m` per frame).
///
/// # Errors
/// As [`render_and_track`].
pub fn estimate_rendered(
    id: &str,
    data: &SequenceData,
    opt: &EvalOptions,
    scale: f64,
    cache: Option<&Path>,
) -> anyhow::Result<RenderedRun> {
    let (frames, truth_of) = render_and_track(id, data, opt, scale, cache)?;
    let run = run_sim_with_window(&frames, rendered_params(scale, opt), opt);
    let moving = moving_objects(&frames, opt.min_step_m);
    let scores = score_run(&frames, &run, &moving);
    Ok(RenderedRun { frames, truth_of, run, scores })
}

#[cfg(all(test, not(feature = "images")))]
mod tests_without_images {
    use super::*;

    #[test]
    fn a_build_without_the_front_end_names_the_feature_it_lacks() {
        let dir = tempfile::tempdir().unwrap();
        let err = estimate_from_images(dir.path(), "0000", &EvalOptions::kitti(0.1)).unwrap_err();
        assert!(format!("{err:#}").contains("feature `images`"), "{err:#}");
        let camera = render_camera(0.1);
        let sim = ImageSim::new(camera, &[], &[], 1);
        let err = track_rendering(&sim, 0, &EvalOptions::kitti(0.1), 0.1).unwrap_err();
        assert!(format!("{err:#}").contains("feature `images`"), "{err:#}");
    }
}
