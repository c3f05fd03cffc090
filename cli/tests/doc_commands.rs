//! Every `dynotraj` command of docs/cli.md, run through the built binary on a small synthetic
//! KITTI layout: each exits 0 and prints (or writes) what docs/cli.md says it does. The slow
//! ones run on few frames, small networks and one epoch. (`stream`, `sign`, `verify`, `keygen`
//! and the edge run through their binaries in tests/tests/edge_sessions.rs and cli_errors.rs.)

use std::path::Path;
use std::process::Command;

use dynotraj_sim::drive::{DriveSpec, generate};
use dynotraj_sim::kitti_layout::write_sequence;

/// Runs the binary with `args`; asserts exit 0 and returns stdout and stderr together.
fn ok(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_dynotraj"))
        .args(args)
        .env_remove("DYNOTRAJ_KITTI")
        .output()
        .expect("runs the binary");
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "dynotraj {} exited {}:\n{text}", args.join(" "), out.status);
    text
}

fn says(text: &str, what: &str) {
    assert!(text.contains(what), "expected `{what}` in:\n{text}");
}

fn synthetic_kitti(root: &Path) {
    for (id, seed) in [("0000", 1), ("0001", 2), ("0002", 3)] {
        write_sequence(root, id, &generate(&DriveSpec { frames: 60, seed, ..DriveSpec::default() })).expect("writes");
    }
}

const SMALL_NET: [&str; 6] = ["--dims", "8,8,2,16", "--epochs", "1", "--batch", "16"];

#[test]
fn the_data_training_and_evaluation_commands_run() {
    let dir = tempfile::tempdir().expect("temp dir");
    synthetic_kitti(dir.path());
    let kitti = dir.path().to_str().expect("utf-8");
    let tracks = ["--ours-input", "tracks", "--rate", "10"];

    let t =
        ok(&[&["dataset", "--kitti", kitti, "--sequences", "0000,0001", "--source", "gt,estimated"][..], &tracks]
            .concat());
    says(&t, "eligible objects");
    let t = ok(&[
        &["eval", "--kitti", kitti, "--tests", "0000,0001", "--source", "gt,gt-ekf,estimated"][..],
        &["--predictor", "cv,cv-fit,ctra"][..],
        &tracks,
    ]
    .concat());
    says(&t, "ADE");

    let model_dir = dir.path().join("model");
    let model_s = model_dir.to_str().expect("utf-8");
    let blob = model_dir.join("model.blob");
    let blob_s = blob.to_str().expect("utf-8");
    let t = ok(&[
        &["train", "--kitti", kitti, "--source", "gt", "--exclude", "0000", "--out", model_s, "--rate", "10"][..],
        &SMALL_NET,
    ]
    .concat());
    says(&t, "trained gt on 0001,0002");
    for ext in ["", ".int8", ".safetensors"] {
        assert!(Path::new(&format!("{blob_s}{ext}")).is_file(), "train writes model.blob{ext}");
    }
    let predictors = format!("cv,model:{blob_s},model:{blob_s}.int8");
    let t = ok(&["eval", "--kitti", kitti, "--tests", "0000", "--predictor", &predictors, "--rate", "10"]);
    says(&t, "model model.blob.int8 on gt");

    let t = ok(&["model-cost", "--dims", "8,8,2,16"]);
    says(&t, "int8");
    let t = ok(&["model-cost", "--model", blob_s]);
    says(&t, "int8");
}

#[test]
fn the_experiment_and_benchmark_commands_write_their_reports() {
    let dir = tempfile::tempdir().expect("temp dir");
    synthetic_kitti(dir.path());
    let kitti = dir.path().to_str().expect("utf-8");
    let small = [&["--ours-input", "tracks", "--rate", "10", "--jobs", "2"][..], &SMALL_NET].concat();

    let report = dir.path().join("exp");
    let report_s = report.to_str().expect("utf-8");
    let arms = ["experiment", "--kitti", kitti, "--arms", "estimated,gt,gt-ekf", "--tests", "0000", "--out", report_s];
    let t = ok(&[&arms[..], &small].concat());
    says(&t, "learned int8 on estimated");
    assert!(report.join("REPORT.md").is_file() && report.join("table_iv.csv").is_file(), "{t}");

    let bench = dir.path().join("bench");
    let bench_s = bench.to_str().expect("utf-8");
    let args = ["benchmark", "--kitti", kitti, "--arms", "gt", "--folds", "3", "--seeds", "1", "--out", bench_s];
    let t = ok(&[&args[..], &small].concat());
    assert!(bench.join("REPORT.md").is_file(), "{t}");
}

#[test]
fn the_estimator_simulator_and_front_end_commands_run() {
    let dir = tempfile::tempdir().expect("temp dir");
    synthetic_kitti(dir.path());
    let kitti = dir.path().to_str().expect("utf-8");

    let t =
        ok(&["estimate", "--kitti", kitti, "--sequence", "0000", "--ours-input", "tracks", "--profile", "host,edge"]);
    says(&t, "object RPE_t");
    let recorded = dir.path().join("recorded");
    let recorded_s = recorded.to_str().expect("utf-8");
    let args = ["--ours-input", "tracks", "--write-tracks", "--out", recorded_s];
    ok(&[&["estimate", "--kitti", kitti, "--sequences", "0000"][..], &args].concat());
    let dtt = recorded.join("0000.dtt");
    let dtt_s = dtt.to_str().expect("utf-8");
    let poses = dir.path().join("poses");
    let t = ok(&["estimate", "--tracks", dtt_s, "--out", poses.to_str().expect("utf-8")]);
    assert!(std::fs::read_dir(&poses).expect("pose files written").count() > 0, "{t}");

    let sim = dir.path().join("sim");
    let sim_s = sim.to_str().expect("utf-8");
    let t =
        ok(&["simulate", "--kitti", kitti, "--sequence", "0000", "--out", sim_s, "--scale", "0.25", "--frames", "8"]);
    // Off a terminal: a progress line with the elapsed time at the first and the last frame.
    says(&t, "s] sequence 0000: frames rendered 1/8");
    says(&t, "s] sequence 0000: frames rendered 8/8");
    let t = ok(&["simulate", "--kitti", kitti, "--sequence", "0000", "--scale", "0.25", "--frames", "8", "--e2e"]);
    says(&t, "RPE");
    says(&t, "s] sequence 0000: frames rendered and tracked 8/8");
    let tracked = dir.path().join("tracked");
    let tracked_s = tracked.to_str().expect("utf-8");
    // Without --sequences: every sequence with images, here the one rendered.
    let t = ok(&["track", "--kitti", sim_s, "--out", tracked_s, "--counters"]);
    let dtt = tracked.join("0000.dtt");
    assert!(dynotraj_formats::tracks_file::read(&dtt).is_ok_and(|t| t.frames.len() == 8), "{t}");
    says(&t, "| static_tracked");
    says(&t, "s] frames tracked done: 8 steps");
    let t = ok(&["track", "--cost", "--frames", "2", "--counters"]);
    says(&t, "stereo");
    says(&t, "| counter");
    says(&t, "| static_tracked");
}

#[test]
fn the_version_completions_manual_and_log_flags_work() {
    let v = ok(&["--version"]);
    assert!(v.starts_with("dynotraj ") && v.contains("(commit "), "{v}");
    says(&ok(&["completions", "bash"]), "_dynotraj()");
    says(&ok(&["completions", "zsh"]), "#compdef dynotraj");
    let man = ok(&["man"]);
    says(&man, ".TH dynotraj 1");
    says(&man, "completions");
    // -q silences progress; -v is accepted by every command (a global flag).
    let dir = tempfile::tempdir().expect("temp dir");
    let sim = dir.path().join("sim");
    let sim_s = sim.to_str().expect("utf-8");
    let quiet = ok(&["-q", "simulate", "--drive", "--out", sim_s, "--scale", "0.25", "--frames", "3"]);
    assert!(!quiet.contains("frames rendered"), "{quiet}");
    let loud = ok(&["simulate", "-v", "--drive", "--out", sim_s, "--scale", "0.25", "--frames", "3"]);
    says(&loud, "frames rendered 3/3");
}
