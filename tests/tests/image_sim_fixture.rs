//! The committed rendered fixture (sim/data/image_sim): it loads through the KITTI-layout
//! reader, the front-end tracks it, and re-rendering with the recorded settings gives the same
//! pixels, depth and instance ids.

use std::path::PathBuf;

use dynotraj_frontend::image_io::read_u16;
use dynotraj_frontend::sequence::{DepthMode, ImageSequence, MaskMode};
use dynotraj_frontend::{FrontEnd, StereoParams, TrackerParams};
use dynotraj_sim::drive::{DriveSpec, generate};
use dynotraj_sim::image_sim::{Camera, ImageSim};
use dynotraj_sim::track_sim::LabelBox;
use opencv::imgcodecs::{IMREAD_COLOR, imread};
use opencv::prelude::*;

fn fixture() -> PathBuf {
    dynotraj_tests::manifest_dir().join("../sim/data/image_sim")
}

#[test]
fn fixture_matches_a_fresh_rendering() {
    let d = generate(&DriveSpec { frames: 24, seed: 1, ..DriveSpec::default() });
    let sim = ImageSim::new(Camera { noise: 0, ..Camera::kitti(0.4) }, &d.camera_poses, &LabelBox::of_drive(&d), 1);
    for k in [0usize, 23] {
        let f = sim.frame(k).unwrap();
        let png = |folder: &str| fixture().join(folder).join("0000").join(format!("{k:06}.png"));
        let left = imread(png("image_02").to_str().unwrap(), IMREAD_COLOR).unwrap();
        let bgr = left.data_bytes().unwrap();
        assert_eq!(bgr.len(), f.left.len());
        assert!(
            bgr.chunks_exact(3).zip(f.left.chunks_exact(3)).all(|(a, b)| a[0] == b[2] && a[1] == b[1] && a[2] == b[0]),
            "frame {k}: left pixels differ"
        );
        let ids = read_u16(&png("instance_02"), "ids").unwrap();
        assert_eq!(ids.data_typed::<u16>().unwrap(), &f.ids[..], "frame {k}: instance ids differ");
        let depth = read_u16(&png("depth_02"), "depth").unwrap();
        let want: Vec<u16> =
            f.depth.iter().map(|&z| (f64::from(z) * 256.0).round().clamp(0.0, 65535.0) as u16).collect();
        assert_eq!(depth.data_typed::<u16>().unwrap(), &want[..], "frame {k}: depth differs");
    }
}

#[test]
fn fixture_loads_and_the_front_end_tracks_it() {
    let s = ImageSequence::open(&fixture(), "0000", DepthMode::Stereo, MaskMode::Auto).unwrap();
    assert_eq!((s.frames.len(), s.size, s.masks()), (24, (497, 150), MaskMode::Png));
    let mut fe = FrontEnd::new(
        StereoParams { num_disparities: 64, ..StereoParams::kitti() },
        TrackerParams::default(),
        s.fb as f32,
    )
    .unwrap();
    for &k in &s.frames {
        let tracks = fe.process(s.load(k).unwrap()).unwrap();
        assert!(tracks.iter().filter(|t| t.is_static()).count() > 100, "frame {k}: few static tracks");
        assert!(tracks.iter().any(|t| t.object_id == 1), "frame {k}: the overtaking car (id 1) has no tracks");
    }
    assert!(fe.tracker.stats.static_survival() > 0.6, "{:?}", fe.tracker.stats);
}

#[test]
fn dynotraj_track_writes_a_tracks_file_of_the_fixture() {
    use clap::Parser as _;
    let out = tempfile::tempdir().unwrap();
    let file = out.path().join("0000.dtt");
    let cli = dynotraj_cli::Cli::try_parse_from([
        "dynotraj",
        "track",
        "--kitti",
        fixture().to_str().unwrap(),
        "--sequence",
        "0000",
        "--out",
        out.path().to_str().unwrap(),
        "--frames",
        "6",
        "--depth",
        "given",
    ])
    .unwrap();
    dynotraj_cli::run(cli).unwrap();
    let t = dynotraj_formats::tracks_file::read(&file).unwrap();
    assert_eq!(t.frames.len(), 6);
    assert_eq!((t.camera.width, t.camera.height), (497, 150));
    assert!((t.camera.stereo_fb - (0.4 * 721.5377 * 0.537) as f32).abs() < 1e-2, "{:?}", t.camera);
    assert!(t.frames.iter().all(|f| f.tracks().count() > 100));
    // Object 1's track ids persist from frame to frame (KLT keeps most of them).
    let ids = |k: usize| -> std::collections::BTreeSet<u32> {
        t.frames[k].tracks().filter(|x| x.object_id == 1).map(|x| x.track_id).collect()
    };
    let (a, b) = (ids(4), ids(5));
    assert!(
        a.intersection(&b).count() * 2 > b.len(),
        "object 1 lost most ids: {} of {}",
        a.intersection(&b).count(),
        b.len()
    );
}
