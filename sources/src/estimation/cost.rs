//! Compute per frame of the estimator at the ECU's full budget: 16 objects x 128 points and 256
//! static tracks in every frame. The scene is synthetic (the KITTI sequences rarely fill the
//! budget): 16 cars in four rows ahead of the ego vehicle, all driving along with it at slightly
//! different speeds and weaving gently, simulated with [`dynotraj_sim::track_sim`] (noise,
//! outliers and track turnover as in `dynotraj estimate`). Parts are decoded before timing: the
//! time is the estimator's alone (assembly, ego-motion, 16 object fits, 17 smoother solves).

use std::time::Instant;

use dynotraj_core::estimate::{Estimator, EstimatorParams, Intrinsics, PoseEstimate, Pushed};
use dynotraj_core::wire::FrameTracks;
use dynotraj_formats::tracks_file::TracksFrame;
use dynotraj_sim::track_sim::{SimSpec, simulate};

use super::input::KITTI_IMAGE_SIZE;
use super::simulated::WINDOW;

/// Timing of a benchmark run.
#[derive(Debug, Clone, PartialEq)]
pub struct CostResult {
    /// Frames timed.
    pub frames: usize,
    /// Mean tracks per frame.
    pub tracks_per_frame: f64,
    /// Mean objects estimated per frame.
    pub objects_per_frame: f64,
    /// Per-frame times, microseconds, sorted.
    pub micros: Vec<f64>,
    /// Size of the estimator, bytes.
    pub state_bytes: usize,
}

impl CostResult {
    /// The `q`-quantile of the per-frame time, microseconds.
    #[must_use]
    pub fn quantile(&self, q: f64) -> f64 {
        let i = ((self.micros.len().saturating_sub(1)) as f64 * q).round() as usize;
        self.micros.get(i).copied().unwrap_or(f64::NAN)
    }

    /// Mean per-frame time, microseconds.
    #[must_use]
    pub fn mean(&self) -> f64 {
        self.micros.iter().sum::<f64>() / self.micros.len().max(1) as f64
    }
}

pub use dynotraj_sim::cost_inputs::estimator_scene as scene;

/// Runs the benchmark over `frames` frames (after `warmup` untimed ones), with `joint_sweeps`
/// sweeps of the joint camera-object solve per frame.
#[must_use]
pub fn measure(frames: usize, warmup: usize, seed: u64, joint_sweeps: u8) -> CostResult {
    let n = frames + warmup;
    let (cams, boxes) = scene(n);
    let intrinsics = Intrinsics::KITTI_0926;
    let spec = SimSpec::kitti(intrinsics, KITTI_IMAGE_SIZE, 0.1, seed);
    let sim = simulate(&cams, &boxes, &spec);
    let parts: Vec<Vec<FrameTracks>> = sim
        .iter()
        .map(|f| TracksFrame::split(f.frame, f.timestamp_us, &f.tracks).map(|t| t.parts).unwrap_or_default())
        .collect();
    let mut params = EstimatorParams::kitti(intrinsics, 0.1);
    params.joint_sweeps = joint_sweeps;
    let mut est: Box<Estimator<WINDOW>> = Box::new(Estimator::new(params, seed));
    let mut out = PoseEstimate::new();
    let mut micros = Vec::with_capacity(frames);
    let (mut tracks, mut objects) = (0usize, 0usize);
    for (k, frame) in parts.iter().enumerate() {
        let t0 = Instant::now();
        for p in frame {
            if let Pushed::Frame { .. } = est.push(p) {
                est.causal(&mut out);
            }
        }
        let dt = t0.elapsed().as_secs_f64() * 1e6;
        if k >= warmup {
            micros.push(dt);
            tracks += sim[k].tracks.len();
            objects += out.objects.len();
        }
    }
    micros.sort_by(f64::total_cmp);
    let timed = frames.max(1) as f64;
    CostResult {
        frames,
        tracks_per_frame: tracks as f64 / timed,
        objects_per_frame: objects as f64 / timed,
        micros,
        state_bytes: std::mem::size_of::<Estimator<WINDOW>>(),
    }
}
