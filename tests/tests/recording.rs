//! `dynotraj forecast --record`, `dynotraj estimate --record` and `dynotraj track --record` on
//! the committed image-sim fixture, in both encodings, read back by Python's `mcap` package
//! (tests/python/read_recording.py), as a user's tools outside this workspace would: Foxglove's
//! schema names, every message decoded (Protobuf with the file's descriptors, or JSON matching
//! its channel's schema) and valid against Foxglove's official JSON Schema (npm
//! `@foxglove/schemas`), the expected topics with one message per frame.
//!
//! Needs `cargo build -p dynotraj-cli` first. The Python packages live in a virtual environment
//! outside the repository (`$DYNOTRAJ_VENV`, else `$HOME/.cache/dynotraj-venv`), made once from
//! tests/python/requirements.txt and reused; without python3, venv or pip the tests say they
//! skipped.

use std::path::{Path, PathBuf};
use std::process::Command;

use std::collections::BTreeMap;

use dynotraj_bag::record::partial_path;
use dynotraj_core::model::Dims;
use dynotraj_core::model::blob::Precision;
use dynotraj_core::wire::{EstimateKind, Message, ObjectStates, Prediction};
use dynotraj_eval::recording::forecast::cv_forecasts;
use dynotraj_link::in_process::forecast;
use dynotraj_sim::cost_inputs::random_blob;
use dynotraj_tests::edge_fixture::{dynotraj_command, scene_tracks};
use dynotraj_tests::manifest_dir;
use dynotraj_tests::python_env::{foxglove_json_schemas, or_skip, python};

/// Frames of the fixture's sequence 0000.
const FIXTURE_FRAMES: usize = 24;

fn fixture() -> PathBuf {
    manifest_dir().join("../sim/data/image_sim")
}

/// Runs `dynotraj COMMAND --kitti <fixture> --sequences 0000 ARGS`, which must succeed;
/// returns its stderr.
fn on_fixture(command: &str, args: &[&str]) -> String {
    let kitti = fixture();
    dynotraj(&[&[command, "--kitti", kitti.to_str().unwrap(), "--sequences", "0000"][..], args].concat())
}

/// Runs `dynotraj` with `args`, which must succeed; returns its stderr.
fn dynotraj(args: &[&str]) -> String {
    let out = dynotraj_command().args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "dynotraj {args:?} failed:\n{stderr}");
    stderr
}

/// Checks the recording at `path` is complete and reads it back with the Python script
/// (`script_args` after the file), against Foxglove's official schemas when npm can fetch
/// them (said when not); prints the script's summary.
fn read_back(path: &Path, command: &str, script_args: &[&str]) {
    assert!(path.is_file(), "{} was not written", path.display());
    assert!(!partial_path(path).exists(), "the temporary file of {} is left", path.display());
    let bytes = std::fs::metadata(path).unwrap().len();
    eprintln!("{}: {bytes} bytes", path.display());
    let Some(python) = or_skip(python(), "recording", "no Python environment to read the recording") else { return };
    let script = manifest_dir().join("python/read_recording.py");
    let mut cmd = Command::new(python);
    cmd.arg(script).arg(command).arg(path).args(script_args);
    let official = foxglove_json_schemas();
    match &official {
        Ok(dir) => {
            cmd.arg("--official-schemas").arg(dir);
        }
        Err(why) => dynotraj_testkit::skipped("recording_official_schemas", &format!("no official schemas: {why}")),
    }
    let out = cmd.output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    eprintln!("{stdout}");
    assert!(out.status.success(), "read_recording.py {command} {}: {}\n{stderr}", path.display(), out.status);
    if official.is_ok() {
        let checked: Vec<&str> = stdout.lines().filter(|l| l.contains("official schema")).collect();
        assert!(!checked.is_empty() && checked.iter().all(|l| l.ends_with(", 0 failed")), "{stdout}");
    }
}

/// [`read_back`] of the same run recorded in Foxglove's JSON encoding.
fn read_back_json(path: &Path, command: &str, script_args: &[&str]) {
    read_back(path, command, &[script_args, &["--encoding", "json"]].concat());
}

#[test]
fn forecast_records_histories_and_forecasts() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("forecast");
    let rec = out.join("rec.mcap");
    let stderr = on_fixture("forecast", &["--out", out.to_str().unwrap(), "--record", rec.to_str().unwrap()]);
    assert!(stderr.contains("recorded"), "{stderr}");
    let frames = FIXTURE_FRAMES.to_string();
    read_back(&rec, "forecast", &["--frames", &frames, "--predictor", "cv"]);
    let json = out.join("rec-json.mcap");
    let args = ["--out", out.to_str().unwrap(), "--record", json.to_str().unwrap(), "--record-encoding", "json"];
    on_fixture("forecast", &args);
    read_back_json(&json, "forecast", &["--frames", &frames, "--predictor", "cv"]);
}

#[test]
fn forecast_with_a_model_records_learned_and_constant_velocity_forecasts() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("forecast");
    let rec = out.join("rec.mcap");
    // Random weights, unsigned: `forecast --model` takes an unsigned blob as linked into the
    // edge. Its frame period is the fixture's 20 Hz.
    let model = dir.path().join("random.int8");
    std::fs::write(&model, random_blob(&Dims::DEFAULT, Precision::Int8, 0.05)).unwrap();
    let stderr = on_fixture(
        "forecast",
        &["--model", model.to_str().unwrap(), "--out", out.to_str().unwrap(), "--record", rec.to_str().unwrap()],
    );
    assert!(stderr.contains("recorded"), "{stderr}");
    let frames = FIXTURE_FRAMES.to_string();
    read_back(&rec, "forecast", &["--frames", &frames, "--predictor", "learned", "--predictor", "cv"]);
}

/// The constant-velocity forecasts recorded beside a model's are the ones the edge makes
/// without a model: same objects, same frames, same points.
#[test]
fn cv_beside_a_model_is_what_the_edge_forecasts_without_one() {
    let tracks = scene_tracks(30);
    let blob = random_blob(&Dims::DEFAULT, Precision::Int8, 0.05);
    let learned = forecast(&tracks, Some(&blob)).unwrap();
    let mut states: BTreeMap<u32, &ObjectStates> = BTreeMap::new();
    let mut predictions: BTreeMap<u32, Vec<&Prediction>> = BTreeMap::new();
    for m in &learned.result.replies {
        match m {
            Message::ObjectStates(s) if s.kind == EstimateKind::Causal => {
                states.insert(s.frame, s);
            }
            Message::Prediction(p) => predictions.entry(p.frame).or_default().push(p),
            _ => {}
        }
    }
    let ours = cv_forecasts(&states, &predictions, 1.0 / tracks.camera.frame_rate_hz);
    let cv = forecast(&tracks, None).unwrap();
    let mut edge: BTreeMap<u32, Vec<(u16, Vec<dynotraj_core::geometry::Point2>)>> = BTreeMap::new();
    for m in &cv.result.replies {
        if let Message::Prediction(p) = m {
            edge.entry(p.frame).or_default().push((p.object_id, p.points.to_vec()));
        }
    }
    assert!(edge.values().map(Vec::len).sum::<usize>() > 100, "the scene's cars are forecast");
    assert_eq!(ours, edge);
}

#[test]
fn track_records_images_tracks_and_annotations() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("track");
    let rec = out.join("rec.mcap");
    let stderr = on_fixture("track", &["--out", out.to_str().unwrap(), "--record", rec.to_str().unwrap()]);
    assert!(stderr.contains("recorded"), "{stderr}");
    assert!(out.join("0000.dtt").is_file(), "the tracks file is still written");
    let frames = FIXTURE_FRAMES.to_string();
    read_back(&rec, "track", &["--frames", &frames]);
    let json = dir.path().join("rec-json.mcap");
    let args = ["--out", out.to_str().unwrap(), "--record", json.to_str().unwrap(), "--record-encoding", "json"];
    on_fixture("track", &args);
    read_back_json(&json, "track", &["--frames", &frames]);
}

#[test]
fn track_records_into_an_existing_folder_by_sequence() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("track");
    let folder = dir.path().join("recordings");
    std::fs::create_dir_all(&folder).unwrap();
    on_fixture("track", &["--frames", "3", "--out", out.to_str().unwrap(), "--record", folder.to_str().unwrap()]);
    let path = folder.join("0000.mcap");
    assert!(path.is_file(), "{} was not written", path.display());
    assert!(!partial_path(&path).exists());
}

#[test]
fn estimate_records_camera_objects_truth_and_points() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("estimate");
    let rec = out.join("rec.mcap");
    on_fixture(
        "estimate",
        &["--ours-input", "tracks", "--out", out.to_str().unwrap(), "--record", rec.to_str().unwrap()],
    );
    let frames = FIXTURE_FRAMES.to_string();
    read_back(&rec, "estimate", &["--frames", &frames]);
    let json = dir.path().join("rec-json.mcap");
    on_fixture(
        "estimate",
        &["--ours-input", "tracks", "--record", json.to_str().unwrap(), "--record-encoding", "json"],
    );
    read_back_json(&json, "estimate", &["--frames", &frames]);
}

#[test]
fn estimate_with_several_profiles_records_a_folder() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("recordings");
    on_fixture("estimate", &["--ours-input", "tracks", "--profile", "host,edge", "--record", rec.to_str().unwrap()]);
    for profile in ["host", "edge"] {
        let path = rec.join(profile).join("0000.mcap");
        assert!(path.is_file(), "{} was not written", path.display());
        assert!(!partial_path(&path).exists());
    }
}

/// rerun's own converter (`rerun mcap convert`, rerun-sdk 0.41) turns every channel of the
/// Protobuf recordings into typed data: rerun's archetypes (Transform3D, InstancePoses3D,
/// Points3D, EncodedImage) or, for the schemas rerun has no archetype of (SceneUpdate,
/// ImageAnnotations), the decoded message; never `McapMessage:data`, the opaque blob that JSON
/// channels become. Skipped, and said so, without rerun's environment.
#[test]
fn rerun_reads_every_recording_channel_as_typed_data() {
    let Some(python) = or_skip(
        dynotraj_tests::python_env::rerun_python(),
        "rerun_reads_every_recording_channel",
        "no rerun environment",
    ) else {
        return;
    };
    let rerun = python.with_file_name("rerun");
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    on_fixture("track", &["--frames", "6", "--out", &p("t"), "--record", &p("track.mcap")]);
    on_fixture("estimate", &["--ours-input", "tracks", "--record", &p("estimate.mcap")]);
    dynotraj(&["forecast", "--tracks", &p("t/0000.dtt"), "--out", &p("f"), "--record", &p("forecast.mcap")]);
    let rerun_run = |args: &[&str]| {
        let out = Command::new(&rerun).args(args).env("RERUN_ANALYTICS", "0").output().unwrap();
        let said = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
        assert!(out.status.success(), "rerun {args:?}: {said}");
        said
    };
    for name in ["track", "estimate", "forecast"] {
        let (mcap, rrd) = (p(&format!("{name}.mcap")), p(&format!("{name}.rrd")));
        rerun_run(&["mcap", "convert", "--disable-raw-fallback", &mcap, "-o", &rrd]);
        let printed = rerun_run(&["rrd", "print", &rrd]);
        // Each data chunk: "... - /topic - data columns: [Column:name ...]".
        let mut typed: BTreeMap<String, String> = BTreeMap::new();
        for line in printed.lines().filter(|l| l.contains(" - data columns: [")) {
            let (head, columns) = line.split_once(" - data columns: [").unwrap();
            let topic = head.rsplit(" - ").next().unwrap().to_string();
            if topic.starts_with("/__") || columns.starts_with("McapChannel:") {
                continue;
            }
            assert!(!columns.contains("McapMessage:data"), "{name}: {topic} is an opaque blob: {columns}");
            typed.insert(topic, columns.trim_end_matches(']').to_string());
        }
        let summary = read_summary(&mcap);
        for topic in &summary {
            assert!(typed.contains_key(topic), "{name}: {topic} has no typed data in rerun:\n{printed}");
        }
        eprintln!("{name}: {typed:#?}");
    }
}

/// The topics of the recording at `path`.
fn read_summary(path: &str) -> Vec<String> {
    let bytes = std::fs::read(path).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    summary.channels.values().map(|c| c.topic.clone()).collect()
}
