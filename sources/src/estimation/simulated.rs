//! One sequence end to end: simulate from its labels and ego poses, estimate, score.

use dynotraj_sim::image_sim::Optics;
use std::collections::BTreeSet;
use std::path::Path;
use std::time::Instant;

use anyhow::Context as _;
use dynotraj_core::limits::PAPER_FRAME_RATE_HZ;

use dynotraj_core::estimate::{
    EstimatorParams, EstimatorProfile, EstimatorStats, HOST_PROFILE, Intrinsics, SmootherParams,
};
use dynotraj_core::wire::{CameraInfo, ObjectClass};
use dynotraj_sim::track_sim::{SimFrame, SimSpec, simulate};

use super::hybrid::{HybridCounts, HybridParams, restrict_to, rewrite};
use super::input::{KITTI_IMAGE_SIZE, sim_input};
use super::runner::{EstimatorRun, Kind, run_estimator, run_parts};
use super::score::{RunScores, SmoothnessSum, TrajectorySmoothness, moving_objects, score_run, smoothness};
use crate::trajectory::label_tracks;
use dynotraj_formats::kitti::{SequenceData, TrackingDir};
use dynotraj_formats::tracks_file::TracksWriter;
use dynotraj_formats::tracks_file::{Tracks, TracksFrame};

/// The smoothing window of the command (DynoSAM's 20 frames).
pub const WINDOW: usize = dynotraj_core::estimate::DEFAULT_WINDOW;

/// How to simulate and estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct EvalOptions {
    /// Frame period, seconds.
    pub dt: f32,
    /// Object classes simulated.
    pub classes: Vec<ObjectClass>,
    /// Moving objects average at least this many metres per frame.
    pub min_step_m: f64,
    /// Seed of the simulator and of RANSAC.
    pub seed: u64,
    /// Pixel noise, pixels.
    pub pixel_sigma: f64,
    /// Disparity noise, pixels.
    pub disparity_sigma: f64,
    /// Outlier share.
    pub outlier_fraction: f64,
    /// Mean track lifetime, frames (0: unlimited).
    pub track_lifetime: usize,
    /// Object smoother prior.
    pub object_smoother: SmootherParams,
    /// Camera smoother prior.
    pub camera_smoother: SmootherParams,
    /// Use at most this many frames.
    pub max_frames: Option<usize>,
    /// Joint camera-object sweeps per frame (0: camera and objects smoothed apart).
    pub joint_sweeps: u8,
    /// Smoothing window, frames: [`WINDOW`] or [`EDGE_WINDOW`].
    pub window: usize,
    /// The estimator profile `window` and `joint_sweeps` came from.
    pub profile: &'static str,
    /// How object runs follow their points (all off by default).
    pub object_variants: ObjectVariants,
    /// The camera model of renderings ([`Optics::IDEAL`] by default).
    pub render_optics: Optics,
    /// How the front-end gives tracked points their depth on renderings.
    pub point_depth: PointDepthOptions,
    /// Score the object poses of DynoSAM's hybrid smoother run over the estimator's fits
    /// ([`super::hybrid`]) instead of the estimator's own, the fits' information multiplied by
    /// this weight (a measurement; off by default).
    pub hybrid_object_smoother: Option<f64>,
}

/// How the image front-end gives the points it sends their depth (the front-end's defaults
/// unless chosen otherwise, as an approach is measured against them).
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct PointDepthOptions {
    /// The dense disparity refined to sub-pixel at each point (else the dense value).
    pub subpixel: bool,
    /// Least distance of a newly sampled object point from its mask's edge, pixels.
    pub object_edge_margin_px: i32,
    /// The dense matcher runs on images shrunk by this factor (1 or 2); the points' sub-pixel
    /// refinement starts from its values at full resolution.
    pub stereo_downscale: i32,
    /// No dense matcher where the masks need no depth: each point matched along its row
    /// ([`dynotraj_frontend::StereoParams::row_match`]).
    pub row_match: bool,
    /// Where the front-end takes a rendering's object masks from.
    pub masks: dynotraj_sim::image_sim::RenderedMasks,
}

impl Default for PointDepthOptions {
    fn default() -> Self {
        Self {
            subpixel: true,
            object_edge_margin_px: 0,
            stereo_downscale: 1,
            row_match: false,
            masks: dynotraj_sim::image_sim::RenderedMasks::Ids,
        }
    }
}

/// The renderings' cache keys are made from this text, so a choice added later is written only
/// when it is made: the keys of renderings tracked without it stay as they were.
impl std::fmt::Debug for PointDepthOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut s = f.debug_struct("PointDepthOptions");
        s.field("subpixel", &self.subpixel)
            .field("object_edge_margin_px", &self.object_edge_margin_px)
            .field("stereo_downscale", &self.stereo_downscale);
        if self.row_match {
            s.field("row_match", &self.row_match);
        }
        if self.masks != dynotraj_sim::image_sim::RenderedMasks::Ids {
            s.field("masks", &self.masks);
        }
        s.finish()
    }
}

#[cfg(feature = "images")]
impl PointDepthOptions {
    /// The dense matcher's settings at KITTI's geometry for images scaled by `scale`.
    #[must_use]
    pub fn stereo(&self, scale: f64) -> dynotraj_frontend::StereoParams {
        dynotraj_frontend::StereoParams {
            downscale: self.stereo_downscale,
            row_match: self.row_match,
            ..dynotraj_frontend::StereoParams::kitti_at_scale(scale)
        }
    }

    /// The front-end's tracker settings with these choices.
    #[must_use]
    pub fn tracker(&self) -> dynotraj_frontend::TrackerParams {
        let d = dynotraj_frontend::TrackerParams::default();
        dynotraj_frontend::TrackerParams {
            subpixel: if self.subpixel { d.subpixel } else { None },
            object_edge_margin_px: self.object_edge_margin_px.max(0),
            ..d
        }
    }
}

/// Alternatives in how the estimator follows an object, each measured as an approach to the
/// estimated states' error (docs/decisions.md "Following the object"); the default is the
/// estimator's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObjectVariants {
    /// [`EstimatorParams::fuse_at_fit`].
    pub fuse_at_fit: bool,
    /// [`EstimatorParams::heading_realign_rad`].
    pub heading_realign_rad: Option<f32>,
    /// [`dynotraj_core::estimate::FitParams::shared_disparity_px`] of object fits.
    pub shared_disparity_px: f32,
    /// Whether causal estimates report the bird's-eye track
    /// ([`EstimatorParams::bev_track`], on by default).
    pub bev_track: bool,
}

impl Default for ObjectVariants {
    fn default() -> Self {
        Self {
            fuse_at_fit: false,
            heading_realign_rad: Some(dynotraj_core::estimate::REALIGN_REVERSED_RAD),
            shared_disparity_px: 0.0,
            bev_track: true,
        }
    }
}

impl EvalOptions {
    /// Sets `p`'s smoother priors, joint sweeps and object variants from these options.
    pub fn apply_to(&self, p: &mut EstimatorParams) {
        p.object_smoother = self.object_smoother;
        p.camera_smoother = self.camera_smoother;
        p.joint_sweeps = self.joint_sweeps;
        p.fuse_at_fit = self.object_variants.fuse_at_fit;
        p.heading_realign_rad = self.object_variants.heading_realign_rad;
        p.object_fit.shared_disparity_px = self.object_variants.shared_disparity_px;
        if !self.object_variants.bev_track {
            p.bev_track = None;
        }
    }
}

impl EvalOptions {
    /// The defaults of `dynotraj estimate` at frame period `dt`: every class of the default
    /// list (pedestrians included: they are in the scene even where nothing forecasts them),
    /// 0.5 px pixel and disparity noise, 5 % outliers, 40-frame mean track lifetime, seed 1,
    /// DynoSAM's priors and window, the joint solve's default sweeps, every frame.
    #[must_use]
    pub fn kitti(dt: f32) -> Self {
        let defaults = EstimatorParams::kitti(Intrinsics::KITTI_0926, dt);
        Self {
            dt,
            classes: ObjectClass::FORECAST.to_vec(),
            min_step_m: 0.1,
            seed: 1,
            pixel_sigma: 0.5,
            disparity_sigma: 0.5,
            outlier_fraction: 0.05,
            track_lifetime: 40,
            object_smoother: SmootherParams::VEHICLE_OBJECT,
            camera_smoother: defaults.camera_smoother,
            max_frames: None,
            joint_sweeps: HOST_PROFILE.joint_sweeps,
            window: HOST_PROFILE.window,
            profile: HOST_PROFILE.name,
            object_variants: ObjectVariants::default(),
            render_optics: Optics::IDEAL,
            point_depth: PointDepthOptions::default(),
            hybrid_object_smoother: None,
        }
    }

    /// These options with `profile`'s window and joint sweeps.
    #[must_use]
    pub fn with_profile(self, profile: EstimatorProfile) -> Self {
        Self { window: profile.window, joint_sweeps: profile.joint_sweeps, profile: profile.name, ..self }
    }
}

/// The firmware's smoothing window (the edge profile's; fits the ECU's RAM).
pub const EDGE_WINDOW: usize = dynotraj_core::estimate::EDGE_WINDOW;

/// Runs the estimator with the window `opt.window` (one of the two compiled in).
///
/// # Panics
/// On another window: [`EvalOptions::window`] is checked where it is parsed.
#[must_use]
pub fn run_with_window(frames: &[TracksFrame], params: EstimatorParams, opt: &EvalOptions) -> EstimatorRun {
    match opt.window {
        EDGE_WINDOW => run_parts::<EDGE_WINDOW>(frames, params, opt.seed),
        WINDOW => run_parts::<WINDOW>(frames, params, opt.seed),
        w => panic!("window {w}: only {WINDOW} and {EDGE_WINDOW} are compiled in"),
    }
}

/// Runs the estimator with the window `opt.window` on simulated (or rendered and tracked) frames.
#[must_use]
pub fn run_sim_with_window(sim: &[SimFrame], params: EstimatorParams, opt: &EvalOptions) -> EstimatorRun {
    match opt.window {
        EDGE_WINDOW => run_estimator::<EDGE_WINDOW>(sim, params, opt.seed),
        _ => run_estimator::<WINDOW>(sim, params, opt.seed),
    }
}

/// What one sequence gave.
#[derive(Debug, Clone)]
pub struct SequenceResult {
    /// Sequence id.
    pub id: String,
    /// The estimator profile it ran with.
    pub profile: &'static str,
    /// Frames estimated.
    pub frames: usize,
    /// The moving-object threshold used, metres per frame.
    pub min_step_m: f64,
    /// RPE per kind.
    pub scores: RunScores,
    /// Smoothness of the moving objects: KITTI labels, simulator truth, then each kind in
    /// [`Kind::ALL`] order, all on the pairs the smoothed estimate covers.
    pub smoothness: [TrajectorySmoothness; 5],
    /// Estimator counters.
    pub stats: EstimatorStats,
    /// Wall time of estimation (decode included), seconds.
    pub estimate_seconds: f64,
    /// The simulated frames (truth and tracks).
    pub sim: Vec<SimFrame>,
    /// The estimator's outputs.
    pub run: EstimatorRun,
    /// The sequence's camera (what a tracks file of it carries).
    pub intrinsics: Intrinsics,
    /// With [`EvalOptions::hybrid_object_smoother`] (whose poses `scores` and `run` then
    /// hold), what the hybrid smoother replaced, and the estimator's own RPE on the same pairs.
    pub hybrid: Option<(HybridCounts, RunScores)>,
}

/// The estimator parameters for a sequence with `spec`'s camera and `opt`'s priors.
#[must_use]
pub fn estimator_params(spec: &SimSpec, opt: &EvalOptions) -> EstimatorParams {
    params_for(spec.intrinsics, spec.max_depth, spec.pixel_sigma, spec.disparity_sigma, opt)
}

/// The estimator parameters for a camera, the depth limit and noise of its tracks, and `opt`'s
/// frame period and priors (what a replayed tracks file needs: the same values give the same
/// parameters as the simulated run that wrote it).
#[must_use]
pub fn params_for(
    intrinsics: Intrinsics,
    max_depth: f64,
    pixel_sigma: f64,
    disparity_sigma: f64,
    opt: &EvalOptions,
) -> EstimatorParams {
    let mut p = EstimatorParams::kitti(intrinsics, opt.dt);
    // The noise model never goes below 0.1 px: a noise-free simulation would otherwise give
    // infinite information.
    p.pixel_sigma = pixel_sigma.max(0.1) as f32;
    p.disparity_sigma = disparity_sigma.max(0.1) as f32;
    p.max_depth = max_depth as f32;
    opt.apply_to(&mut p);
    p
}

/// The simulator's depth limit, metres (tracks beyond it are not simulated; a replayed tracks
/// file is estimated with the same limit).
#[must_use]
pub fn sim_max_depth() -> f64 {
    SimSpec::kitti(Intrinsics::KITTI_0926, KITTI_IMAGE_SIZE, 0.1, 0).max_depth
}

/// The camera model of a simulated sequence as it travels on the link (first message of a
/// tracks file).
#[must_use]
pub fn camera_info(intrinsics: &Intrinsics, rate_hz: f32) -> CameraInfo {
    CameraInfo {
        fx: intrinsics.fx,
        fy: intrinsics.fy,
        cx: intrinsics.cx,
        cy: intrinsics.cy,
        stereo_fb: intrinsics.stereo_fb,
        width: KITTI_IMAGE_SIZE.0 as u16,
        height: KITTI_IMAGE_SIZE.1 as u16,
        frame_rate_hz: rate_hz,
    }
}

/// Writes the simulated tracks of `sim` as a tracks file (`.dtt`): the link's byte stream.
///
/// # Errors
/// The file cannot be written, or a frame exceeds the wire's track budget.
pub fn write_tracks(path: &std::path::Path, camera: &CameraInfo, sim: &[SimFrame]) -> anyhow::Result<()> {
    let mut w = TracksWriter::create(path, camera)?;
    for f in sim {
        w.write_frame(f.frame, f.timestamp_us, &f.tracks)?;
    }
    w.finish()?;
    Ok(())
}

/// Simulates, estimates and scores sequence `data`.
#[must_use]
pub fn evaluate_sequence(id: &str, data: &SequenceData, opt: &EvalOptions) -> SequenceResult {
    let (sim, spec) = simulate_sequence(data, opt);
    score_sequence(id, data, opt, sim, estimator_params(&spec, opt), spec.intrinsics)
}

/// The track-level simulation of sequence `data` with `opt`'s classes, noise, seed and frame
/// limit, and the spec it was made with (what its estimator parameters follow from).
#[must_use]
pub fn simulate_sequence(data: &SequenceData, opt: &EvalOptions) -> (Vec<SimFrame>, SimSpec) {
    let input = sim_input(data, &opt.classes);
    let n = opt.max_frames.map_or(input.camera_poses.len(), |m| m.min(input.camera_poses.len()));
    let cams = &input.camera_poses[..n];
    let boxes: Vec<_> = input.boxes.iter().filter(|b| (b.frame as usize) < n).copied().collect();
    let spec = SimSpec {
        pixel_sigma: opt.pixel_sigma,
        disparity_sigma: opt.disparity_sigma,
        outlier_fraction: opt.outlier_fraction,
        track_lifetime: opt.track_lifetime,
        ..SimSpec::kitti(input.intrinsics, KITTI_IMAGE_SIZE, f64::from(opt.dt), opt.seed)
    };
    (simulate(cams, &boxes, &spec), spec)
}

/// Estimates the frames `sim` (simulated, or rendered and tracked, with their truth) of sequence
/// `id` with `params` and `opt`'s window, and scores the run; `intrinsics` is the camera of the
/// tracks.
#[must_use]
pub fn score_sequence(
    id: &str,
    data: &SequenceData,
    opt: &EvalOptions,
    sim: Vec<SimFrame>,
    params: EstimatorParams,
    intrinsics: Intrinsics,
) -> SequenceResult {
    let t0 = Instant::now();
    let mut run = run_sim_with_window(&sim, params, opt);
    let estimate_seconds = t0.elapsed().as_secs_f64();
    let own = opt.hybrid_object_smoother.map(|weight| (weight, run.clone()));
    let moving = moving_objects(&sim, opt.min_step_m);
    let hybrid = own.map(|(fit_weight, mut own)| {
        let counts = rewrite(&mut run, &HybridParams { fit_weight, ..HybridParams::of(&params, opt.window) });
        restrict_to(&mut own, &run);
        (counts, score_run(&sim, &own, &moving))
    });
    let scores = score_run(&sim, &run, &moving);
    let smoothness = smoothness_table(data, opt, &sim, &run, &moving);
    SequenceResult {
        id: id.to_string(),
        profile: opt.profile,
        frames: sim.len(),
        min_step_m: opt.min_step_m,
        scores,
        smoothness,
        stats: run.stats,
        estimate_seconds,
        sim,
        run,
        intrinsics,
        hybrid,
    }
}

/// Smoothness of labels, truth and each kind, on the frame pairs of the smoothed estimate.
fn smoothness_table(
    data: &SequenceData,
    opt: &EvalOptions,
    sim: &[SimFrame],
    run: &EstimatorRun,
    moving: &BTreeSet<u16>,
) -> [TrajectorySmoothness; 5] {
    let (_, pairs) = smoothness(run.of(Kind::Smoothed), moving);
    let gt = label_tracks(data, opt.dt);
    let mut labels = SmoothnessSum::default();
    let mut truth = SmoothnessSum::default();
    let dt = f64::from(opt.dt);
    for &(object_id, i) in &pairs {
        let kitti_id = kitti_track_id(object_id);
        if let Some(t) = gt.iter().find(|t| t.track_id == kitti_id) {
            let at = |frame: usize| t.frames.iter().position(|&f| f as usize == frame).map(|j| t.states[j]);
            if let (Some(a), Some(b)) = (at(i), at(i + 1)) {
                labels.push(&a, &b);
            }
        }
        // The simulator truth's states: position and heading of the box, speed by backward
        // finite difference (forward at the first frame of a run).
        let state = |k: usize| -> Option<dynotraj_core::BevState> {
            let o = sim.get(k)?.objects.iter().find(|o| o.object_id == object_id)?;
            let p = o.pose.translation.vector;
            let f = o.pose.rotation * nalgebra::Vector3::x();
            let neighbour = if k > 0 { sim[k - 1].objects.iter().find(|q| q.object_id == object_id) } else { None }
                .or_else(|| sim.get(k + 1).and_then(|s| s.objects.iter().find(|q| q.object_id == object_id)));
            let speed = neighbour.map_or(0.0, |q| {
                let d = q.pose.translation.vector - p;
                d.x.hypot(d.z) / dt
            });
            Some(dynotraj_core::BevState {
                x: p.x as f32,
                y: p.z as f32,
                heading: f.z.atan2(f.x) as f32,
                speed: speed as f32,
            })
        };
        if let (Some(a), Some(b)) = (state(i), state(i + 1)) {
            truth.push(&a, &b);
        }
    }
    let kinds = Kind::ALL.map(|k| {
        let (s, _) = smoothness(run.of(k), moving);
        s.result()
    });
    // The kinds are measured on their own pairs; the smoothed one is on exactly `pairs`.
    [labels.result(), truth.result(), kinds[0], kinds[1], kinds[2]]
}

/// The track-level simulator's stream for sequence `id` of the KITTI folder `dir` at the
/// paper's 20 Hz, its first `frames` frames with a limit.
///
/// # Errors
/// Loading errors, named.
pub fn simulated_stream(dir: &Path, id: &str, frames: Option<usize>) -> anyhow::Result<Tracks> {
    let data =
        TrackingDir::open(dir)?.load_sequence(id).with_context(|| format!("loading KITTI tracking sequence {id}"))?;
    let input = sim_input(&data, &ObjectClass::FORECAST);
    let n = frames.map_or(input.camera_poses.len(), |m| m.min(input.camera_poses.len()));
    let boxes: Vec<_> = input.boxes.iter().filter(|b| (b.frame as usize) < n).copied().collect();
    let dt = 1.0 / f64::from(PAPER_FRAME_RATE_HZ);
    let spec = SimSpec::kitti(input.intrinsics, KITTI_IMAGE_SIZE, dt, 1);
    let sim = simulate(&input.camera_poses[..n], &boxes, &spec);
    let camera = camera_info(&input.intrinsics, PAPER_FRAME_RATE_HZ);
    let frames = sim
        .iter()
        .map(|f| TracksFrame::split(f.frame, f.timestamp_us, &f.tracks).with_context(|| format!("frame {}", f.frame)))
        .collect::<anyhow::Result<_>>()?;
    Ok(Tracks { camera, frames })
}

/// The KITTI track id of wire object id `object` (the truth's tracks and the estimates number
/// them alike: the wire's id is the track id + 1).
pub(crate) fn kitti_track_id(object: u16) -> i32 {
    i32::from(object) - 1
}
