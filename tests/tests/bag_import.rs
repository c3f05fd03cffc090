//! A ROS 2 bag in, through the built `dynotraj`: the committed rendered fixture written as a
//! bag (`export-bag`), imported back (`import`), and tracked: the tracks file is byte for byte
//! the one tracked from the fixture itself at the bag's rate, with instance masks and with the
//! detector's boxes; and the bag decodes with ROS 2's MCAP decoder in Python.

use std::path::Path;

use dynotraj_tests::edge_fixture::dynotraj_command;
use dynotraj_tests::manifest_dir;
use dynotraj_tests::python_env::python;

fn run(args: &[&str]) -> String {
    let out = dynotraj_command().args(args).output().unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "dynotraj {args:?}: {text}");
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
    ros2_tools_read(Path::new(&p("bags/0000.mcap")));
    let said = run(&["import", "--bag", &p("bags/0000.mcap"), "--out", &p("layout")]);
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
    let python = match python() {
        Ok(p) => p,
        Err(why) => {
            dynotraj_testkit::skipped("ros2_tools_read", &format!("no Python environment to decode the bag: {why}"));
            return;
        }
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
