//! A KITTI tracking sequence as the simulator's input.

use std::path::Path;

use anyhow::Context as _;
use dynotraj_core::estimate::Intrinsics;
use dynotraj_core::wire::ObjectClass;
use dynotraj_sim::drive::{DriveSpec, generate};
use dynotraj_sim::image_sim::{Camera, ImageSim};
use dynotraj_sim::track_sim::LabelBox;
use nalgebra::Isometry3;

use dynotraj_formats::kitti::{SequenceData, TrackingDir};

/// KITTI tracking image size (width, height), pixels (image_02 of the 2011_09_26 drives;
/// other drives differ by a few pixels).
pub const KITTI_IMAGE_SIZE: (f64, f64) = (1242.0, 375.0);

/// What the simulator needs from a sequence.
#[derive(Debug, Clone)]
pub struct SimInput {
    /// Camera-0 poses per frame.
    pub camera_poses: Vec<Isometry3<f64>>,
    /// Labelled boxes of the selected classes.
    pub boxes: Vec<LabelBox>,
    /// Rectified camera-0 intrinsics from `P0`, stereo `f b` from `P1` (camera 1 is camera 0
    /// moved by the baseline, so `P1[0][3] = -fx b`).
    pub intrinsics: Intrinsics,
}

/// The simulator input of `data`, keeping labels of `classes` (KITTI ids must fit `u16` and not
/// be 0, which is the static id on the wire: ids are shifted by one).
#[must_use]
pub fn sim_input(data: &SequenceData, classes: &[ObjectClass]) -> SimInput {
    let p0 = data.calib.p[0];
    let p1 = data.calib.p[1];
    let intrinsics = Intrinsics {
        fx: p0[(0, 0)] as f32,
        fy: p0[(1, 1)] as f32,
        cx: p0[(0, 2)] as f32,
        cy: p0[(1, 2)] as f32,
        stereo_fb: (p0[(0, 3)] - p1[(0, 3)]) as f32,
    };
    let boxes = LabelBox::of_labels(&data.labels, classes);
    SimInput { camera_poses: data.poses.clone(), boxes, intrinsics }
}

/// The image simulator for sequence `id` of a KITTI folder with the objects of `classes`
/// (`kitti` = (folder, id, classes)), or for the built-in synthetic drive without one; its
/// first `frames` frames with a limit (the drive: 60 by default), noise seeded by `seed`.
///
/// # Errors
/// Loading errors, named.
pub fn image_sim(
    kitti: Option<(&Path, &str, &[ObjectClass])>,
    camera: Camera,
    frames: Option<usize>,
    seed: u64,
) -> anyhow::Result<ImageSim> {
    match kitti {
        Some((dir, id, classes)) => {
            let data = TrackingDir::open(dir)?
                .load_sequence(id)
                .with_context(|| format!("loading KITTI tracking sequence {id}"))?;
            let input = sim_input(&data, classes);
            let n = frames.map_or(input.camera_poses.len(), |m| m.min(input.camera_poses.len()));
            let boxes: Vec<LabelBox> = input.boxes.into_iter().filter(|b| (b.frame as usize) < n).collect();
            Ok(ImageSim::new(camera, input.camera_poses.get(..n).unwrap_or_default(), &boxes, seed))
        }
        None => {
            let d = generate(&DriveSpec { frames: frames.unwrap_or(60), seed, ..DriveSpec::default() });
            Ok(ImageSim::new(camera, &d.camera_poses, &LabelBox::of_drive(&d), seed))
        }
    }
}
