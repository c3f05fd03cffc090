//! Inputs of the criterion benchmarks in `benches/`: the estimator's full-budget scene, model
//! blobs with random weights, and a wire byte stream; the scene and the blobs are the ones
//! `dynotraj estimate --cost` and `dynotraj model-cost` time (the simulators' `cost_inputs`), so that the
//! benchmarks need only core and sim, not the front-end's OpenCV or training's candle.

use dynotraj_core::estimate::Intrinsics;
use dynotraj_core::wire::{FrameBuf, FrameTracks, Message, encode, frame_parts};
use dynotraj_sim::cost_inputs;
use dynotraj_sim::track_sim::{SimSpec, simulate};

/// KITTI's image size, pixels.
pub const KITTI_IMAGE_SIZE: (f64, f64) = (1242.0, 375.0);

/// Each frame's wire parts of the estimator benchmark's scene
/// ([`dynotraj_sim::cost_inputs::estimator_scene`]), simulated with noise, outliers and
/// track turnover (16 objects x 128 points + 256 static tracks).
#[must_use]
pub fn estimator_scene(frames: usize, seed: u64) -> Vec<Vec<FrameTracks>> {
    let (cams, boxes) = cost_inputs::estimator_scene(frames);
    let spec = SimSpec::kitti(Intrinsics::KITTI_0926, KITTI_IMAGE_SIZE, 0.1, seed);
    simulate(&cams, &boxes, &spec)
        .iter()
        .map(|f| frame_parts(f.frame, f.timestamp_us, &f.tracks).map(Iterator::collect).unwrap_or_default())
        .collect()
}

pub use dynotraj_sim::cost_inputs::random_blob;

/// `parts` framed for the link, one after another: the byte stream a decoder reads.
#[must_use]
pub fn wire_stream(parts: &[Vec<FrameTracks>]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut buf: FrameBuf = [0; dynotraj_core::wire::MAX_FRAME_LEN];
    for p in parts.iter().flatten() {
        let n = encode(&Message::FrameTracks(p.clone()), &mut buf).unwrap_or(0);
        out.extend_from_slice(buf.get(..n).unwrap_or_default());
    }
    out
}
