//! A KITTI tracking sequence as the simulator's input.

use dynotraj_core::estimate::Intrinsics;
use dynotraj_core::wire::ObjectClass;
use dynotraj_sim::track_sim::LabelBox;
use nalgebra::{Isometry3, Point3};

use dynotraj_formats::kitti::SequenceData;

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
    let boxes = data
        .labels
        .iter()
        .filter(|r| !r.is_dont_care() && !r.is_box_only())
        .filter_map(|r| {
            let class = ObjectClass::from_kitti_name(&r.object_type)?;
            if !classes.contains(&class) {
                return None;
            }
            Some(LabelBox {
                frame: u32::try_from(r.frame).ok()?,
                object_id: u16::try_from(r.track_id + 1).ok()?,
                class,
                size: [r.height, r.width, r.length],
                bottom_centre: Point3::new(r.x, r.y, r.z),
                rotation_y: r.rotation_y,
            })
        })
        .collect();
    SimInput { camera_poses: data.poses.clone(), boxes, intrinsics }
}
