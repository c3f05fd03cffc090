//! A ROS 2 bag in, through the built `dynotraj`: the committed rendered fixture written as a
//! bag (`export-bag`), imported back (`import`), and tracked: the tracks file is byte for byte
//! the one tracked from the fixture itself at the bag's rate, with instance masks and with the
//! detector's boxes; and the bag decodes with ROS 2's MCAP decoder in Python. A bag that another
//! tool wrote from the fixture (kitti2mcap) imports with no flags to the fixture's pixels and
//! projections.

use std::path::Path;

use dynotraj_tests::edge_fixture::dynotraj_command;
use dynotraj_tests::manifest_dir;
use dynotraj_tests::python_env::{kitti2mcap_python, or_skip, python};
use opencv::imgcodecs::{IMREAD_UNCHANGED, imread};
use opencv::prelude::*;

fn run(args: &[&str]) -> String {
    succeeded(dynotraj_command().args(args), &format!("dynotraj {args:?}"))
}

/// What `cmd` said on stdout and stderr, once it succeeded.
fn succeeded(cmd: &mut std::process::Command, what: &str) -> String {
    let out = cmd.output().unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{what}: {text}");
    text
}

#[test]
fn a_bag_of_the_fixture_imports_and_tracks_to_the_same_tracks() {
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("../sim/data/image_sim");
    let fixture = fixture.to_str().unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let p = |name: &str| tmp.path().join(name).to_str().unwrap().to_string();
    let said = run(&["export-bag", "--kitti", fixture, "--sequences", "0000", "--out", &p("bags")]);
    assert!(said.contains("wrote 24 frames"), "{said}");
    ros2_tools_read(Path::new(&p("bags/0000/0000_0.mcap")));
    let said = run(&["import", "--bag", &p("bags/0000"), "--out", &p("layout")]);
    assert!(said.contains("imported 24 frames at 10.00 Hz") && said.contains("66 detection boxes"), "{said}");
    assert!(said.contains("next: dynotraj track --kitti") && said.contains("--masks png"), "{said}");
    for masks in ["png", "detections"] {
        let direct = p(&format!("direct-{masks}"));
        let imported = p(&format!("imported-{masks}"));
        run(&["track", "--kitti", fixture, "--sequences", "0000", "--masks", masks, "--rate", "10", "--out", &direct]);
        // No --rate: the frame rate comes from the bag's stamps (times/), 10 Hz.
        run(&["track", "--kitti", &p("layout"), "--sequences", "0000", "--masks", masks, "--out", &imported]);
        let a = std::fs::read(Path::new(&direct).join("0000.dtt")).unwrap();
        let b = std::fs::read(Path::new(&imported).join("0000.dtt")).unwrap();
        assert!(a.len() > 1000, "{masks}: {} bytes", a.len());
        assert!(a == b, "{masks}: the imported bag tracks differently");
    }
}

/// The bag decodes with the ROS 2 MCAP decoder of Python's `mcap-ros2-support`, as ROS 2
/// tools read it (tests/python/read_bag.py); skipped, and said so, without Python.
fn ros2_tools_read(bag: &Path) {
    let Some(python) = or_skip(python(), "ros2_tools_read", "no Python environment to decode the bag") else {
        return;
    };
    let script = manifest_dir().join("python/read_bag.py");
    let out = std::process::Command::new(python).arg(script).arg(bag).arg("24").output().unwrap();
    let said = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    eprintln!("{said}");
    assert!(out.status.success(), "read_bag.py: {said}");
    assert!(
        said.contains("/stereo/left/image_raw: sensor_msgs/msg/Image, 24 messages; first: 497 x 150 rgb8"),
        "{said}"
    );
}

#[test]
fn a_bag_that_is_not_there_or_an_out_that_exists_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let missing = tmp.path().join("none.mcap");
    let out = dynotraj_command()
        .args(["import", "--bag", missing.to_str().unwrap(), "--out", tmp.path().join("o").to_str().unwrap()])
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{e}");
    assert!(e.contains("none.mcap: no such file or folder (expected an .mcap file or a ROS 2 bag folder)"), "{e}");
    let out = dynotraj_command()
        .args(["import", "--bag", missing.to_str().unwrap(), "--out", tmp.path().to_str().unwrap()])
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("already exists (an import writes a new folder)"), "{e}");
}

/// What rosbags' own tools make of an exported bag: AnyReader reads it as a rosbag2 bag
/// (tests/python/read_rosbag2.py), and rosbags-convert's copies of it (plain, zstd per file,
/// zstd per message) import with no flags to the layout the exported bag imports to. Skipped,
/// and said so, without Python.
#[test]
fn rosbags_reads_the_exported_bag_and_its_conversions_import_alike() {
    let Some(python) = or_skip(python(), "rosbags_reads_the_exported_bag", "no Python environment") else { return };
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("../sim/data/image_sim");
    let tmp = tempfile::tempdir().unwrap();
    let p = |name: &str| tmp.path().join(name).to_str().unwrap().to_string();
    run(&["export-bag", "--kitti", fixture.to_str().unwrap(), "--sequences", "0000", "--out", &p("bags")]);
    let out = std::process::Command::new(&python)
        .arg(manifest_dir().join("python/read_rosbag2.py"))
        .arg(p("bags/0000"))
        .output()
        .unwrap();
    let said = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    eprintln!("{said}");
    assert!(out.status.success(), "read_rosbag2.py: {said}");
    for line in [
        "/detections: vision_msgs/msg/Detection2DArray, 24 messages",
        "/stereo/left/camera_info: sensor_msgs/msg/CameraInfo, 24 messages",
        "/stereo/left/image_raw: sensor_msgs/msg/Image, 24 messages",
        "/stereo/right/image_raw: sensor_msgs/msg/Image, 24 messages",
        "messages: 168",
    ] {
        assert!(said.contains(line), "missing `{line}`:\n{said}");
    }
    let layout = |bag: &str, name: &str| {
        let said = run(&["import", "--bag", bag, "--out", &p(name)]);
        assert!(said.contains("imported 24 frames at 10.00 Hz"), "{said}");
        let labels = std::fs::read(tmp.path().join(name).join("label_02/0000.txt")).unwrap();
        let left = std::fs::read(tmp.path().join(name).join("image_02/0000/000023.png")).unwrap();
        (labels, left)
    };
    let exported = layout(&p("bags/0000"), "from-export");
    let convert = python.with_file_name("rosbags-convert");
    for (name, extra) in [
        ("copy", &[][..]),
        ("zstd-file", &["--compress", "zstd", "--compress-mode", "file"][..]),
        ("zstd-message", &["--compress", "zstd", "--compress-mode", "message"][..]),
    ] {
        let out = std::process::Command::new(&convert)
            .args(["--src", &p("bags/0000"), "--dst", &p(name), "--dst-storage", "mcap"])
            .args(extra)
            .output()
            .unwrap();
        assert!(out.status.success(), "rosbags-convert {name}: {}", String::from_utf8_lossy(&out.stderr));
        assert!(layout(&p(name), &format!("from-{name}")) == exported, "{name}: imports differently");
    }
    // rosbags' sqlite3 storage is named, with the conversion to use.
    let out = std::process::Command::new(&convert)
        .args(["--src", &p("bags/0000"), "--dst", &p("sqlite"), "--dst-storage", "sqlite3"])
        .output()
        .unwrap();
    assert!(out.status.success(), "rosbags-convert sqlite3: {}", String::from_utf8_lossy(&out.stderr));
    let out = dynotraj_command().args(["import", "--bag", &p("sqlite"), "--out", &p("from-sqlite")]).output().unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{e}");
    assert!(e.contains("a rosbag2 bag in sqlite3 storage: convert it to MCAP first"), "{e}");
}

/// A bag made by kitti2mcap (tests/python/kitti2mcap-requirements.txt), a converter of KITTI
/// raw drives to ROS 2 MCAP that users run on their own drives, imports with no flags: its
/// topics are found by name and type, and the layout holds the fixture's frames, pixels, 10 Hz
/// stamps and stereo projections. The fixture is written as a raw drive first
/// (tests/python/kitti_raw_from_layout.py), as that is what kitti2mcap reads. Skipped, and said
/// so, without Python or the package index.
#[test]
fn a_kitti2mcap_bag_imports_with_no_flags() {
    let Some(python) = or_skip(kitti2mcap_python(), "a_kitti2mcap_bag_imports_with_no_flags", "no kitti2mcap") else {
        return;
    };
    let fixture = manifest_dir().join("../sim/data/image_sim");
    let tmp = tempfile::tempdir().unwrap();
    let p = |name: &str| tmp.path().join(name).to_str().unwrap().to_string();
    let python_run = |args: &[&str]| {
        let said = succeeded(std::process::Command::new(&python).args(args), &format!("python {args:?}"));
        eprintln!("{said}");
        said
    };
    let script = manifest_dir().join("python/kitti_raw_from_layout.py");
    python_run(&[script.to_str().unwrap(), fixture.to_str().unwrap(), "0000", &p("raw"), "2011_09_26", "0001"]);
    let bag = p("drive.mcap");
    let said = python_run(&[
        "-m",
        "kitti2mcap",
        "--date",
        "2011_09_26",
        "--drive",
        "0001",
        "--kitti-dir",
        &p("raw"),
        "--output",
        &bag,
        "--cameras",
        "2,3",
        "--no-lidar",
        "--no-imu",
    ]);
    let frames = std::fs::read_dir(fixture.join("image_02/0000")).unwrap().count();
    assert!(said.contains(&format!("{frames} frames, cameras=[2, 3], lidar=False, imu=False")), "{said}");

    let said = run(&["import", "--bag", &bag, "--out", &p("layout")]);
    let listed: Vec<&str> = said.lines().take_while(|l| !l.starts_with("imported")).map(str::trim).collect();
    assert_eq!(
        listed,
        [
            "left: /kitti/camera_color_left/image_raw",
            "right: /kitti/camera_color_right/image_raw",
            "left camera info: /kitti/camera_color_left/camera_info",
            "right camera info: /kitti/camera_color_right/camera_info",
        ],
        "{said}"
    );
    // Nothing dropped: images without a frame would be listed before ` into`.
    assert!(
        said.contains(&format!(
            "imported {frames} frames at 10.00 Hz (measured from the left stamps), 0 detection boxes into"
        )),
        "{said}"
    );
    let layout = tmp.path().join("layout");
    for folder in ["image_02", "image_03"] {
        assert_eq!(std::fs::read_dir(layout.join(folder).join("0000")).unwrap().count(), frames, "{folder}");
        for k in 0..frames {
            let png = |root: &Path| root.join(folder).join("0000").join(format!("{k:06}.png"));
            let (a, b) = (png(&fixture), png(&layout));
            let (a, b) = (
                imread(a.to_str().unwrap(), IMREAD_UNCHANGED).unwrap(),
                imread(b.to_str().unwrap(), IMREAD_UNCHANGED).unwrap(),
            );
            // The import writes the pixels it decoded with its own PNG encoder: the pixels are
            // the fixture's, the file's bytes need not be.
            assert!(!a.empty() && !b.empty(), "{folder} frame {k}: an image that does not decode");
            assert_eq!((a.size().unwrap(), a.typ()), (b.size().unwrap(), b.typ()), "{folder} frame {k}");
            assert!(a.data_bytes().unwrap() == b.data_bytes().unwrap(), "{folder} frame {k}: the pixels differ");
        }
    }
    let times = std::fs::read_to_string(layout.join("times/0000.txt")).unwrap();
    let want: String = (0..frames).map(|k| format!("{:.9}\n", k as f64 * 0.1)).collect();
    assert_eq!(times, want);
    let source = dynotraj_formats::kitti::read_calib(fixture.join("calib/0000.txt")).unwrap();
    let imported = dynotraj_formats::kitti::read_calib(layout.join("calib/0000.txt")).unwrap();
    for cam in [2, 3] {
        for (a, b) in source.p[cam].iter().zip(imported.p[cam].iter()) {
            assert!(
                (a - b).abs() <= 1e-6 * a.abs().max(b.abs()),
                "P{cam}: {} imported as {}",
                source.p[cam],
                imported.p[cam]
            );
        }
    }
}
