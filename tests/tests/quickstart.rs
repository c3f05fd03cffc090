//! The README's quickstart (scripts/quickstart.sh) runs on what the repository ships, with the
//! suite's own `dynotraj`: a bag written and imported, tracked, estimated, forecast, recorded;
//! and a bag with the cameras alone, whose moving objects the front-end finds itself.

use std::path::Path;

use dynotraj_tests::edge_fixture::dynotraj_command;

#[test]
fn the_quickstart_runs_on_a_fresh_clone_and_says_where_everything_went() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let tmp = tempfile::tempdir().unwrap();
    let bin = dynotraj_command().get_program().to_owned();
    let out = std::process::Command::new("bash")
        .arg(root.join("scripts/quickstart.sh"))
        .env("DYNOTRAJ_BIN", &bin)
        .env("DYNOTRAJ_QUICKSTART", tmp.path())
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .unwrap();
    let said = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{said}");
    for (what, path) in [
        ("the bag", "bags/0000/metadata.yaml"),
        ("the imported layout", "imported/image_02/0000/000023.png"),
        ("the tracks", "tracks/0000.dtt"),
        ("the estimate with truth", "estimate-truth.mcap"),
        ("the forecasts", "forecast/forecasts.csv"),
        ("the forecasts' recording", "forecast.mcap"),
        ("the forecasts from the bag without masks or detections", "camera-forecast/forecasts.csv"),
    ] {
        assert!(tmp.path().join(path).is_file(), "{what}: {path} missing\n{said}");
    }
    assert!(said.contains("imported 24 frames at 10.00 Hz") && said.contains("24 frames,"), "{said}");
    // The camera-only bag holds nothing that says where the objects are: the front-end found
    // them itself, and the edge forecast them.
    assert!(said.contains("--masks motion"), "{said}");
    let forecasts = std::fs::read_to_string(tmp.path().join("camera-forecast/forecasts.csv")).unwrap();
    assert!(forecasts.lines().count() > 1, "no forecast from motion masks:\n{forecasts}");
}
