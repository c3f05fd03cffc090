//! A sequence in the KITTI tracking layout written as a ROS 2 bag (a rosbag2 folder in MCAP
//! storage, [`crate::rosbag2`]), as a stereo rig's driver and a detector would record it: the
//! bag the import reads back, for the import's tests and for trying the import without a robot.
//!
//! Topics: `/stereo/left/image_raw`, `/stereo/right/image_raw` (`sensor_msgs/Image`, rgb8),
//! `/stereo/left/camera_info`, `/stereo/right/camera_info` (once per frame, the right camera's
//! `p[3] = -fx * baseline`), `/stereo/left/instances` (16UC1 instance ids, where the layout
//! has instance_02/), `/stereo/left/depth` (16UC1 millimetres, where it has depth_02/),
//! `/detections` (`vision_msgs/Detection2DArray`, where it has label_02/).
//! Header stamps are `start + k / rate`.

use std::path::Path;

use anyhow::{Context as _, ensure};
use dynotraj_formats::kitti::{read_calib, read_labels};

use crate::ros2::{
    self, BoundingBox2D, CAMERA_INFO, CameraInfo, DETECTION_2D_ARRAY, Detection2D, Detection2DArray, Header, IMAGE,
    Image, ObjectHypothesis, ObjectHypothesisWithPose, Point2D, Pose2D, Time,
};
use crate::rosbag2::Rosbag2Writer;

/// The stamp of the first frame: an arbitrary, recognisable time (2024-01-01 00:00:00 UTC).
pub const START_NS: i64 = 1_704_067_200_000_000_000;

/// The left camera's namespace.
pub const LEFT: &str = "/stereo/left";
/// The right camera's namespace.
pub const RIGHT: &str = "/stereo/right";
/// The detections' topic.
pub const DETECTIONS: &str = "/detections";

/// What a layout image becomes in the bag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Colour,
    Mask,
    /// depth_02's 1/256 m as millimetres (REP 118's 16UC1 depth).
    Depth,
}

fn image_message(path: &Path, header: Header, kind: Kind) -> anyhow::Result<Image> {
    let decoded = image::open(path).with_context(|| format!("reading {}", path.display()))?;
    let (width, height) = (decoded.width(), decoded.height());
    // 16UC1: REP 118's depth in millimetres, or instance ids as they are.
    let wide = |values: Vec<u16>| Image {
        header: header.clone(),
        height,
        width,
        encoding: "16UC1".into(),
        is_bigendian: 0,
        step: width * 2,
        data: values.iter().flat_map(|p| p.to_le_bytes()).collect(),
    };
    Ok(if kind == Kind::Depth {
        wide(decoded.to_luma16().as_raw().iter().map(|&v| (f64::from(v) * 1000.0 / 256.0).round() as u16).collect())
    } else if kind == Kind::Mask {
        wide(decoded.to_luma16().into_raw())
    } else {
        Image {
            header,
            height,
            width,
            encoding: "rgb8".into(),
            is_bigendian: 0,
            step: width * 3,
            data: decoded.to_rgb8().into_raw(),
        }
    })
}

/// What of a layout a bag carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BagContents {
    /// Everything the layout has: images, camera infos, and depth, instance masks and
    /// detections where it has them.
    Everything,
    /// The stereo images and their camera infos only, as a camera driver (or a converter such
    /// as kitti2mcap) records a drive: what says where the objects are is left to the
    /// front-end.
    CameraOnly,
}

/// Writes sequence `seq` of the layout at `dir` (frames 0.. while image_02 has them) as the bag
/// folder `out` at `rate_hz` with `contents`; returns the frames written.
///
/// # Errors
/// A missing or unreadable file of the layout, named; an output that cannot be written.
pub fn layout_to_bag(dir: &Path, seq: &str, out: &Path, rate_hz: f64, contents: BagContents) -> anyhow::Result<usize> {
    ensure!(rate_hz.is_finite() && rate_hz > 0.0, "frame rate: expected Hz > 0, found {rate_hz}");
    let calib_path = dir.join("calib").join(format!("{seq}.txt"));
    let calib = read_calib(&calib_path).with_context(|| format!("reading {}", calib_path.display()))?;
    let labels_path = dir.join("label_02").join(format!("{seq}.txt"));
    let everything = contents == BagContents::Everything;
    let labels = if everything && labels_path.is_file() { read_labels(&labels_path)? } else { Vec::new() };
    // Written under a staging name and renamed when finished: a bag cut short is not left
    // under the name of a complete one.
    let mut bag = Rosbag2Writer::create(out).with_context(|| format!("writing {}", out.display()))?;
    let mut write_all = || -> anyhow::Result<usize> {
        let mut frames = 0;
        loop {
            let name = format!("{frames:06}.png");
            let left = dir.join("image_02").join(seq).join(&name);
            if !left.is_file() {
                break;
            }
            let stamp = Time::from_nanos(START_NS + (frames as f64 * 1e9 / rate_hz).round() as i64);
            let log_ns = u64::try_from(stamp.nanos()).unwrap_or(0);
            for (ns, folder, cam) in [(LEFT, "image_02", 2), (RIGHT, "image_03", 3)] {
                let header =
                    Header { stamp, frame_id: format!("{}_optical", ns.trim_start_matches('/').replace('/', "_")) };
                let img = image_message(&dir.join(folder).join(seq).join(&name), header.clone(), Kind::Colour)?;
                let p = calib.p.get(cam).copied().unwrap_or_default();
                let info = CameraInfo {
                    header: header.clone(),
                    height: img.height,
                    width: img.width,
                    distortion_model: "plumb_bob".into(),
                    d: vec![0.0; 5],
                    k: [p[(0, 0)], p[(0, 1)], p[(0, 2)], p[(1, 0)], p[(1, 1)], p[(1, 2)], 0.0, 0.0, 1.0],
                    r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
                    p: std::array::from_fn(|i| p[(i / 4, i % 4)]),
                    ..CameraInfo::default()
                };
                bag.write(&format!("{ns}/image_raw"), IMAGE, log_ns, &ros2::encode(&img)?)?;
                bag.write(&format!("{ns}/camera_info"), CAMERA_INFO, log_ns, &ros2::encode(&info)?)?;
                for (folder, topic, kind) in
                    [("instance_02", "instances", Kind::Mask), ("depth_02", "depth", Kind::Depth)]
                {
                    let file = dir.join(folder).join(seq).join(&name);
                    if everything && cam == 2 && file.is_file() {
                        let msg = image_message(&file, header.clone(), kind)?;
                        bag.write(&format!("{ns}/{topic}"), IMAGE, log_ns, &ros2::encode(&msg)?)?;
                    }
                }
            }
            if !labels.is_empty() {
                let detections = labels
                    .iter()
                    .filter(|r| r.frame == frames && !r.is_dont_care())
                    .map(|r| Detection2D {
                        results: vec![ObjectHypothesisWithPose {
                            hypothesis: ObjectHypothesis {
                                class_id: r.object_type.to_lowercase(),
                                score: r.score.unwrap_or(1.0),
                            },
                            ..ObjectHypothesisWithPose::default()
                        }],
                        bbox: BoundingBox2D {
                            center: Pose2D {
                                position: Point2D {
                                    x: (r.bbox_left + r.bbox_right) / 2.0,
                                    y: (r.bbox_top + r.bbox_bottom) / 2.0,
                                },
                                theta: 0.0,
                            },
                            size_x: r.bbox_right - r.bbox_left,
                            size_y: r.bbox_bottom - r.bbox_top,
                        },
                        id: r.track_id.to_string(),
                        ..Detection2D::default()
                    })
                    .collect();
                let msg =
                    Detection2DArray { header: Header { stamp, frame_id: "stereo_left_optical".into() }, detections };
                bag.write(DETECTIONS, DETECTION_2D_ARRAY, log_ns, &ros2::encode(&msg)?)?;
            }
            frames += 1;
        }
        if frames == 0 {
            anyhow::bail!("{}: no left images 000000.png ...", dir.join("image_02").join(seq).display());
        }
        Ok(frames)
    };
    // Whatever fails (a full disk, a bad image), the staging folder goes and the error names
    // the bag being written.
    write_all().and_then(|frames| bag.finish().map(|_| frames)).with_context(|| format!("writing {}", out.display()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynotraj_sim::drive::{DriveSpec, generate};
    use dynotraj_sim::image_sim::{Camera, ImageSim};
    use dynotraj_sim::track_sim::LabelBox;

    #[test]
    fn a_bag_that_cannot_be_written_whole_is_named_and_leaves_nothing() {
        let tmp = tempfile::tempdir().unwrap();
        let d = generate(&DriveSpec { frames: 3, seed: 1, ..DriveSpec::default() });
        let sim = ImageSim::new(Camera { noise: 0, ..Camera::kitti(0.1) }, &d.camera_poses, &LabelBox::of_drive(&d), 1);
        crate::sim_layout::write_sequence(tmp.path(), "0000", &sim, 3).unwrap();
        std::fs::write(tmp.path().join("image_02/0000/000001.png"), b"not a png").unwrap();
        let out = tmp.path().join("bags/0000");
        std::fs::create_dir_all(out.parent().unwrap()).unwrap();
        let e = format!("{:#}", layout_to_bag(tmp.path(), "0000", &out, 10.0, BagContents::Everything).unwrap_err());
        assert!(e.starts_with(&format!("writing {}", out.display())) && e.contains("000001.png"), "{e}");
        assert_eq!(std::fs::read_dir(out.parent().unwrap()).unwrap().count(), 0, "no bag and no temporary file");
    }
}
