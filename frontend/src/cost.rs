//! Front-end throughput at KITTI resolution (1242 x 375): frames rendered in memory by the image
//! simulator (the synthetic drive: ground, buildings, poles, three objects), then stereo, masks
//! from the rendered instance ids, and tracking, each timed. Rendering is not timed.

use std::collections::BTreeMap;

use dynotraj_sim::drive::{DriveSpec, generate};
use dynotraj_sim::image_sim::{Camera, ImageSim, RenderedFrame, RenderedMasks};
use dynotraj_sim::track_sim::LabelBox;
use opencv::core::Mat;
use opencv::imgproc::{COLOR_BGR2GRAY, cvt_color};

use super::error::{FrontEndError, cv};
use super::image_io::{bgr_from_rgb, u16_from_buffer};
use super::masks::Detection;
use super::pipeline::{DepthInput, FrameInput, FrontEnd, MaskInput, StageTimes};
use super::stats::FrontEndStats;
use super::stereo::StereoParams;
use super::tracker::TrackerParams;

/// Grey `Mat` of a rendered RGB buffer.
///
/// # Errors
/// An OpenCV failure.
pub fn grey_of(rgb: &[u8], cam: &Camera) -> Result<Mat, FrontEndError> {
    let bgr = bgr_from_rgb(rgb, cam.width, cam.height)?;
    let mut grey = Mat::default();
    cvt_color(&bgr, &mut grey, COLOR_BGR2GRAY, 0).map_err(cv("grey conversion"))?;
    Ok(grey)
}

/// The front-end input of a rendered frame: stereo pair and the rendered instance ids (classes
/// from the truth).
///
/// # Errors
/// An OpenCV failure.
pub fn input_of(f: &RenderedFrame, cam: &Camera) -> Result<FrameInput, FrontEndError> {
    let classes: BTreeMap<_, _> = f.objects.iter().map(|o| (o.object_id, o.class)).collect();
    Ok(FrameInput {
        left: grey_of(&f.left, cam)?,
        depth: DepthInput::Right(grey_of(&f.right, cam)?),
        masks: MaskInput::Labels(u16_from_buffer(&f.ids, cam.width, cam.height)?, classes),
    })
}

/// The front-end input of a rendered frame with the masks `masks`.
///
/// # Errors
/// An OpenCV failure.
pub fn input_with(f: &RenderedFrame, cam: &Camera, masks: RenderedMasks) -> Result<FrameInput, FrontEndError> {
    let mut input = input_of(f, cam)?;
    match masks {
        RenderedMasks::Ids => {}
        RenderedMasks::Boxes => input.masks = MaskInput::Boxes(boxes_of(f, cam)),
        RenderedMasks::Motion => input.masks = MaskInput::Motion(cam.intrinsics()),
    }
    Ok(input)
}

/// The rendered objects' 2D boxes (extent of their visible pixels), as a detector would give
/// them, without ids.
#[must_use]
pub fn boxes_of(f: &RenderedFrame, cam: &Camera) -> Vec<Detection> {
    f.objects
        .iter()
        .filter_map(|o| {
            let mut b = [f32::MAX, f32::MAX, f32::MIN, f32::MIN];
            for (i, _) in f.ids.iter().enumerate().filter(|(_, id)| **id == o.object_id) {
                let (u, v) = ((i % cam.width) as f32, (i / cam.width) as f32);
                b = [b[0].min(u), b[1].min(v), b[2].max(u), b[3].max(v)];
            }
            (b[0] <= b[2]).then_some(Detection { bbox: b, class: o.class, object_id: None })
        })
        .collect()
}

/// Times `frames` frames of the synthetic drive at KITTI resolution with `tracker`'s settings;
/// masks from the rendered instance ids, from the objects' 2D boxes refined by depth with IoU
/// ids, or found by motion segmentation (`masks`).
///
/// # Errors
/// An OpenCV failure.
pub fn run(
    frames: usize,
    (stereo, tracker): (StereoParams, TrackerParams),
    masks: RenderedMasks,
) -> Result<(StageTimes, FrontEndStats), FrontEndError> {
    let drive = generate(&DriveSpec { frames: frames.max(2), ..DriveSpec::default() });
    let sim = ImageSim::new(Camera::kitti(1.0), &drive.camera_poses, &LabelBox::of_drive(&drive), 1);
    let mut fe = FrontEnd::new(stereo, tracker, sim.camera.fb() as f32)?;
    for k in 0..sim.len() {
        let Some(f) = sim.frame(k) else { break };
        fe.process(input_with(&f, &sim.camera, masks)?)?;
    }
    Ok((fe.times, fe.tracker.stats))
}
