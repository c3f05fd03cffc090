//! The `dataset` and `eval` commands end to end on a KITTI-layout folder written from the
//! fixtures' synthetic drive, where the right answers are known; and bad files fail with the
//! file, line and field named.

use std::fs;

use clap::Parser as _;
use dynotraj_cli::{Cli, Command, dataset, eval};
use dynotraj_eval::report::Table;
use dynotraj_sim::drive::{DriveSpec, generate};
use dynotraj_tests::synthetic_kitti::write_sequence;

fn cli(args: &[&str]) -> Command {
    Cli::try_parse_from(std::iter::once("dynotraj").chain(args.iter().copied())).unwrap().command
}

fn cell<'a>(t: &'a Table, row: usize, column: &str) -> &'a str {
    let c = t.headers.iter().position(|h| h == column).unwrap();
    &t.rows[row][c]
}

#[test]
fn dataset_and_eval_on_a_synthetic_drive() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().to_str().unwrap();
    write_sequence(dir.path(), "0000", &generate(&DriveSpec::default()));
    write_sequence(dir.path(), "0001", &generate(&DriveSpec { frames: 31, ..DriveSpec::default() }));

    let Command::Dataset(args) = cli(&["dataset", "--kitti", root]) else { panic!() };
    let t = dataset::table(&args).unwrap();
    // 0000: the car (60 frames: 29 instances) and the cyclist (40 frames: 9); the parked car
    // does not move. 0001: 31 frames are one short of eligible.
    assert_eq!(cell(&t, 0, "0000"), "2");
    assert_eq!(cell(&t, 1, "0000"), "38");
    assert_eq!(cell(&t, 0, "0001"), "-");
    assert_eq!(cell(&t, 1, "sum"), "38");

    let Command::Eval(args) =
        cli(&["eval", "--kitti", root, "--tests", "0000", "--source", "gt,gt-ekf", "--predictor", "cv,cv-fit,ctra"])
    else {
        panic!()
    };
    let t = eval::table(&args).unwrap();
    let ade = |arm: &str| -> f64 {
        let row = t.rows.iter().position(|r| r[0] == "ADE" && r[1] == arm).unwrap();
        cell(&t, row, "avg").parse().unwrap()
    };
    // Exact labels on smooth unicycle paths: CTRA recovers the motion almost exactly (the
    // paths use turn rates and accelerations within the limits), CV drifts on the curve.
    assert!(ade("ctra on gt") < 0.05, "{t:?}");
    assert!(ade("cv on gt") > ade("ctra on gt"));
    // The parabola's slope is the current velocity; the last displacement is half a frame old.
    assert!(ade("cv-fit on gt") < ade("cv on gt"), "{t:?}");
    assert!(ade("cv on gt-ekf").is_finite());
    let instances = t.rows.last().unwrap();
    assert_eq!(instances[2], "38 (36)");
}

#[test]
fn bad_files_fail_with_file_line_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().to_str().unwrap();
    write_sequence(dir.path(), "0000", &generate(&DriveSpec::default()));
    let labels = dir.path().join("label_02/0000.txt");
    let mut text = fs::read_to_string(&labels).unwrap();
    text = text.replacen(" Cyclist ", " Cyclist x ", 1);
    fs::write(&labels, text).unwrap();
    let Command::Dataset(args) = cli(&["dataset", "--kitti", root]) else { panic!() };
    let err = format!("{:#}", dataset::table(&args).unwrap_err());
    println!("{err}");
    assert!(err.contains("0000.txt") && err.contains("line"), "{err}");

    write_sequence(dir.path(), "0000", &generate(&DriveSpec::default()));
    let poses = dir.path().join("ego_poses_orbslam3/0000.txt");
    let short: String = fs::read_to_string(&poses).unwrap().lines().take(50).map(|l| format!("{l}\n")).collect();
    fs::write(&poses, short).unwrap();
    let err = format!("{:#}", dataset::table(&args).unwrap_err());
    println!("{err}");
    assert!(err.contains("50") && err.contains("60"), "frame counts named: {err}");

    let Command::Dataset(args) = cli(&["dataset", "--kitti", "/nonexistent/kitti"]) else { panic!() };
    let err = format!("{:#}", dataset::table(&args).unwrap_err());
    assert!(err.contains("/nonexistent/kitti"), "{err}");
}

#[test]
fn a_test_sequence_given_twice_is_named_by_its_option() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().to_str().unwrap();
    write_sequence(dir.path(), "0000", &generate(&DriveSpec::default()));
    let Command::Eval(args) = cli(&["eval", "--kitti", root, "--tests", "0000,0000"]) else { panic!() };
    let err = format!("{:#}", eval::table(&args).unwrap_err());
    assert!(err.starts_with("--tests: 0000 is given twice"), "{err}");
    let Command::Eval(args) = cli(&["eval", "--kitti", root, "--tests", "0000", "--predictor", "cv,prior,cv"]) else {
        panic!()
    };
    let err = format!("{:#}", eval::table(&args).unwrap_err());
    assert!(err.starts_with("--predictor: cv is given twice"), "{err}");
}

#[test]
fn a_folder_without_sequences_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    fs::create_dir(dir.path().join("label_02")).unwrap();
    let Command::Dataset(args) = cli(&["dataset", "--kitti", dir.path().to_str().unwrap()]) else { panic!() };
    let err = format!("{:#}", dataset::table(&args).unwrap_err());
    assert!(err.contains("label_02") && err.contains("no sequence"), "{err}");
}

#[test]
fn bench_labels_a_models_rows_by_the_blobs_precision() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    // `--out` keeps each --dims set's random int8 blob.
    let Command::ModelCost(a) = cli(&["model-cost", "--dims", "8,8,2,16", "--iterations", "1", "--out", out]) else {
        panic!()
    };
    let t = dynotraj_eval::model_cost::model_cost_table(&a.request().unwrap()).unwrap();
    let labels: Vec<&str> = (0..2).map(|r| cell(&t, r, "predictor")).collect();
    assert_eq!(labels, ["f32 (random weights, unicycle)", "int8 (random weights, unicycle)"]);
    let blob = dir.path().join("random-8,8,2,16.int8");
    let Command::ModelCost(a) = cli(&["model-cost", "--model", blob.to_str().unwrap(), "--iterations", "1"]) else {
        panic!()
    };
    let t = dynotraj_eval::model_cost::model_cost_table(&a.request().unwrap()).unwrap();
    let models: Vec<&str> =
        (0..t.rows.len()).map(|r| cell(&t, r, "predictor")).filter(|p| p.contains("random-8,8,2,16")).collect();
    assert_eq!(models, [format!("int8 ({}, unicycle)", blob.display())], "an int8 blob is timed once, as int8");
    // The pedestrian model's cost: a single integrator's blob, kept and read back as one.
    let Command::ModelCost(a) =
        cli(&["model-cost", "--dynamics", "single-integrator", "--iterations", "1", "--out", out])
    else {
        panic!()
    };
    let t = dynotraj_eval::model_cost::model_cost_table(&a.request().unwrap()).unwrap();
    assert_eq!(cell(&t, 1, "predictor"), "int8 (random weights, single integrator)");
    let file = dynotraj_formats::model_file::ModelFile::load(&dir.path().join("random-8,8,3,8.int8")).unwrap();
    assert_eq!(file.blob().dynamics(), dynotraj_core::predict::Dynamics::SingleIntegrator);
}
