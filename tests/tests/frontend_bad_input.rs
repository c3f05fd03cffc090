//! Bad input to the front-end: missing frames, a missing right image, stereo images of
//! different sizes, an unreadable PNG (errors naming the file); a textureless image and boxes
//! with no depth inside (counted, no crash).

use std::path::Path;

use dynotraj_bag::sim_layout::write_sequence;
use dynotraj_frontend::sequence::{DepthMode, ImageSequence, MaskMode};
use dynotraj_frontend::{DepthInput, Detection, FrameInput, FrontEnd, MaskInput, StereoParams, TrackerParams};
use dynotraj_sim::drive::{DriveSpec, generate};
use dynotraj_sim::image_sim::{Camera, ImageSim};
use dynotraj_sim::track_sim::LabelBox;
use opencv::core::{CV_8UC1, Mat, Scalar};
use opencv::prelude::*;

/// A three-frame rendered sequence "0000" at a fifth of KITTI's size in a temporary folder.
fn layout() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let d = generate(&DriveSpec { frames: 3, ..DriveSpec::default() });
    let sim = ImageSim::new(Camera::kitti(0.2), &d.camera_poses, &LabelBox::of_drive(&d), 3);
    write_sequence(dir.path(), "0000", &sim, 3).unwrap();
    dir
}

fn png(dir: &Path, folder: &str, frame: u32) -> std::path::PathBuf {
    dir.join(folder).join("0000").join(format!("{frame:06}.png"))
}

#[test]
fn written_layout_loads_in_every_mode() {
    let dir = layout();
    for (depth, masks) in [
        (DepthMode::Stereo, MaskMode::Auto),
        (DepthMode::Given, MaskMode::Png),
        (DepthMode::Stereo, MaskMode::Boxes),
        (DepthMode::Given, MaskMode::Detections),
    ] {
        let s = ImageSequence::open(dir.path(), "0000", depth, masks).unwrap();
        assert_eq!((s.frames.clone(), s.size), (vec![0, 1, 2], (248, 75)));
        assert!((s.fb - 0.2 * 721.5377 * 0.537).abs() < 1e-3, "fb {}", s.fb);
        s.load(1).unwrap();
    }
}

#[test]
fn a_missing_frame_is_an_error_naming_the_file() {
    let dir = layout();
    std::fs::remove_file(png(dir.path(), "image_02", 1)).unwrap();
    let e = ImageSequence::open(dir.path(), "0000", DepthMode::Stereo, MaskMode::Auto).unwrap_err().to_string();
    assert!(e.contains("image_02/0000/000001.png") && e.contains("missing"), "{e}");
}

#[test]
fn capture_times_give_the_rate_and_bad_ones_are_named_by_line() {
    let dir = layout();
    let open = || ImageSequence::open(dir.path(), "0000", DepthMode::Stereo, MaskMode::Auto);
    assert_eq!(open().unwrap().measured_rate_hz(), None);
    std::fs::create_dir(dir.path().join("times")).unwrap();
    let times = dir.path().join("times/0000.txt");
    std::fs::write(&times, "0.0\n0.04\n0.08\n").unwrap();
    let rate = open().unwrap().measured_rate_hz().unwrap();
    assert!((rate - 25.0).abs() < 1e-9, "{rate}");
    for (text, expected) in [
        ("0.0\n0.04\nx\n", "line 3: a capture time in seconds, later than the line before, found `x`"),
        ("0.0\n0.04\n0.04\n", "line 3"),
        ("0.0\n0.04\n", "a capture time for each of the 3 frames, found 2"),
    ] {
        std::fs::write(&times, text).unwrap();
        let e = open().unwrap_err().to_string();
        assert!(e.contains("times/0000.txt") && e.contains(expected), "{e}");
    }
}

#[test]
fn a_missing_right_image_is_an_error_naming_the_file() {
    let dir = layout();
    std::fs::remove_file(png(dir.path(), "image_03", 2)).unwrap();
    let s = ImageSequence::open(dir.path(), "0000", DepthMode::Stereo, MaskMode::Auto).unwrap();
    let e = s.load(2).unwrap_err().to_string();
    assert!(e.contains("image_03/0000/000002.png"), "{e}");
}

#[test]
fn stereo_images_of_different_sizes_are_an_error_naming_the_file() {
    let dir = layout();
    let small = Mat::new_rows_cols_with_default(10, 20, CV_8UC1, Scalar::all(9.0)).unwrap();
    opencv::imgcodecs::imwrite(png(dir.path(), "image_03", 0).to_str().unwrap(), &small, &opencv::core::Vector::new())
        .unwrap();
    let s = ImageSequence::open(dir.path(), "0000", DepthMode::Stereo, MaskMode::Auto).unwrap();
    let e = s.load(0).unwrap_err().to_string();
    assert!(e.contains("image_03/0000/000000.png") && e.contains("20x10") && e.contains("248x75"), "{e}");
}

#[test]
fn an_unreadable_png_is_an_error_naming_the_file() {
    let dir = layout();
    std::fs::write(png(dir.path(), "image_02", 1), b"\x89PNG\r\n\x1a\nnot really").unwrap();
    let s = ImageSequence::open(dir.path(), "0000", DepthMode::Stereo, MaskMode::Auto).unwrap();
    let e = s.load(1).unwrap_err().to_string();
    assert!(e.contains("image_02/0000/000001.png") && e.contains("cannot decode"), "{e}");
    // An 8-bit image where a 16-bit mask is expected is refused too.
    std::fs::copy(png(dir.path(), "image_02", 0), png(dir.path(), "instance_02", 0)).unwrap();
    let e = s.load(0).unwrap_err().to_string();
    assert!(e.contains("instance_02/0000/000000.png") && e.contains("16-bit"), "{e}");
}

#[test]
fn a_textureless_frame_and_boxes_without_depth_are_counted_not_fatal() {
    let grey = Mat::new_rows_cols_with_default(120, 400, CV_8UC1, Scalar::all(128.0)).unwrap();
    let mut fe =
        FrontEnd::new(StereoParams { num_disparities: 32, ..StereoParams::kitti() }, TrackerParams::default(), 100.0)
            .unwrap();
    let boxes = vec![Detection {
        bbox: [50.0, 20.0, 150.0, 90.0],
        class: dynotraj_core::wire::ObjectClass::Car,
        object_id: None,
    }];
    for _ in 0..3 {
        let input = FrameInput {
            left: grey.clone(),
            depth: DepthInput::Right(grey.clone()),
            masks: MaskInput::Boxes(boxes.clone()),
        };
        let tracks = fe.process(input).unwrap();
        assert!(tracks.is_empty());
    }
    let s = fe.tracker.stats;
    assert_eq!(s.frames, 3);
    assert_eq!(s.textureless_cells, 3 * 24, "every grid cell of every frame is empty");
    assert_eq!(s.empty_masks, 3, "the box has no depth inside: an empty mask per frame");
    // A mask over a flat region: counted as textureless.
    let mut labels = Mat::new_rows_cols_with_default(120, 400, opencv::core::CV_16UC1, Scalar::all(0.0)).unwrap();
    for v in 30..60 {
        for u in 30..80 {
            *labels.at_2d_mut::<u16>(v, u).unwrap() = 5;
        }
    }
    let depth = Mat::new_rows_cols_with_default(120, 400, opencv::core::CV_32F, Scalar::all(10.0)).unwrap();
    let classes = [(5u16, dynotraj_core::wire::ObjectClass::Car)].into_iter().collect();
    fe.process(FrameInput {
        left: grey.clone(),
        depth: DepthInput::Depth(depth),
        masks: MaskInput::Labels(labels, classes),
    })
    .unwrap();
    assert_eq!(fe.tracker.stats.textureless_objects, 1);
}

#[test]
fn objects_beyond_the_capacity_are_dropped_and_counted() {
    use dynotraj_core::limits::{MAX_OBJECTS, MAX_POINTS_PER_OBJECT, MAX_STATIC_TRACKS};
    // A textured image (a fixed hash pattern), 20 objects of 40 x 40 px, depth 5..25 m by object.
    let (w, h) = (900, 200);
    let mut grey = Mat::new_rows_cols_with_default(h, w, CV_8UC1, Scalar::all(0.0)).unwrap();
    let mut labels = Mat::new_rows_cols_with_default(h, w, opencv::core::CV_16UC1, Scalar::all(0.0)).unwrap();
    let mut depth = Mat::new_rows_cols_with_default(h, w, opencv::core::CV_32F, Scalar::all(30.0)).unwrap();
    for v in 0..h {
        for u in 0..w {
            *grey.at_2d_mut::<u8>(v, u).unwrap() =
                (dynotraj_sim::image_sim::texture::hash((u / 3 * 7919 + v / 3 * 104_729) as u32) & 0xff) as u8;
            let (col, row) = (u / 45, v / 100);
            if u % 45 < 40 && v % 100 < 40 && row == 0 && col < 20 {
                *labels.at_2d_mut::<u16>(v, u).unwrap() = (col + 1) as u16;
                *depth.at_2d_mut::<f32>(v, u).unwrap() = 5.0 + col as f32;
            }
        }
    }
    let classes = (1..=20u16).map(|id| (id, dynotraj_core::wire::ObjectClass::Car)).collect();
    let mut fe = FrontEnd::new(StereoParams::kitti(), TrackerParams::default(), 100.0).unwrap();
    let tracks = fe
        .process(FrameInput { left: grey, depth: DepthInput::Depth(depth), masks: MaskInput::Labels(labels, classes) })
        .unwrap();
    let objects: std::collections::BTreeSet<u16> =
        tracks.iter().filter(|t| !t.is_static()).map(|t| t.object_id).collect();
    assert_eq!(objects.len(), MAX_OBJECTS);
    // Nearest first: the four farthest (ids 17-20) are the ones dropped.
    assert!(objects.iter().all(|&id| id <= 16), "{objects:?}");
    assert_eq!(fe.tracker.stats.objects_dropped, 4);
    assert!(tracks.iter().filter(|t| t.is_static()).count() <= MAX_STATIC_TRACKS);
    for id in objects {
        assert!(tracks.iter().filter(|t| t.object_id == id).count() <= MAX_POINTS_PER_OBJECT);
    }
}
