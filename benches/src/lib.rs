//! Inputs of the criterion benchmarks in `benches/`: the estimator's full-budget scene, model
//! blobs with random weights, and a wire byte stream. They repeat what `dynotraj estimate
//! --bench` and `dynotraj bench` build (host/src/estimate/bench.rs, host/src/cli/bench.rs) so
//! that the benchmarks need only core and fixtures, not the host's OpenCV and candle.

use dynotraj_core::estimate::Intrinsics;
use dynotraj_core::model::Dims;
use dynotraj_core::model::blob::{Precision, blob_len, write_blob};
use dynotraj_core::wire::{FrameBuf, FrameTracks, Message, ObjectClass, encode, frame_parts};
use dynotraj_fixtures::track_sim::{LabelBox, SimSpec, simulate};
use nalgebra::{Isometry3, Point3};

/// KITTI's image size, pixels.
pub const KITTI_IMAGE_SIZE: (f64, f64) = (1242.0, 375.0);

/// Each frame's wire parts of the estimator benchmark's scene: 16 cars in four rows ahead of
/// the ego vehicle driving along with it, weaving gently, simulated with noise, outliers and
/// track turnover (the ECU's full budget: 16 objects x 128 points + 256 static tracks).
#[must_use]
pub fn estimator_scene(frames: usize, seed: u64) -> Vec<Vec<FrameTracks>> {
    let ego = 1.0; // metres per frame
    let cams: Vec<Isometry3<f64>> = (0..frames).map(|k| Isometry3::translation(0.0, 0.0, ego * k as f64)).collect();
    let mut boxes = Vec::new();
    for k in 0..frames {
        for i in 0..16u16 {
            let (row, col) = (f64::from(i / 4), f64::from(i % 4));
            let speed = ego + 0.01 * (f64::from(i % 5) - 2.0);
            let x = -6.0 + 4.0 * col + 0.5 * (0.05 * k as f64 + f64::from(i)).sin();
            let z = 9.0 + 6.0 * row + (speed - ego) * k as f64;
            boxes.push(LabelBox {
                frame: k as u32,
                object_id: i + 1,
                class: ObjectClass::Car,
                size: [1.5, 1.7, 4.2],
                bottom_centre: Point3::new(x, 1.65, z),
                rotation_y: -std::f64::consts::FRAC_PI_2 + 0.05 * (0.05 * k as f64 + f64::from(i)).cos(),
            });
        }
    }
    let spec = SimSpec::kitti(Intrinsics::KITTI_0926, KITTI_IMAGE_SIZE, 0.1, seed);
    simulate(&cams, &boxes, &spec)
        .iter()
        .map(|f| frame_parts(f.frame, f.timestamp_us, &f.tracks).map(Iterator::collect).unwrap_or_default())
        .collect()
}

/// A blob of `dims` with deterministic random weights (the generator of `dynotraj bench`).
///
/// # Panics
/// Never: the tensors have the shapes of `dims` by construction.
#[must_use]
pub fn random_blob(dims: &Dims, precision: Precision, dt: f32) -> Vec<u8> {
    let mut state = 0x2545_f491_u32;
    let tensors: Vec<Vec<f32>> = dims
        .tensors()
        .iter()
        .map(|(r, c)| {
            (0..r * c)
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 17;
                    state ^= state << 5;
                    (state as f32 / u32::MAX as f32 - 0.5) * 0.4
                })
                .collect()
        })
        .collect();
    let slices: Vec<&[f32]> = tensors.iter().map(Vec::as_slice).collect();
    let mut buf = vec![0; blob_len(dims, precision)];
    write_blob(dims, precision, dt, &slices, &mut buf).unwrap_or_else(|e| unreachable!("{e}"));
    buf
}

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
