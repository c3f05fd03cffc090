//! `dynotraj train` end to end on a KITTI-layout folder written from the fixtures' synthetic
//! drive: it trains, writes the f32 blob, the int8 blob and the checkpoint, and what it wrote
//! is a model core can run.

use dynotraj_core::predict::Predictor as _;
use std::fs;

use clap::Parser as _;
use dynotraj_cli::{Cli, Command, train};
use dynotraj_core::Point2;
use dynotraj_core::limits::HORIZON;
use dynotraj_core::model::blob::{ModelBlob, Precision};
use dynotraj_core::model::{Dims, LearnedPredictor};
use dynotraj_core::predict::Context;
use dynotraj_sim::drive::{DriveSpec, generate};
use dynotraj_tests::synthetic_kitti::write_sequence;
use dynotraj_train::export::load_checkpoint;

#[test]
fn train_writes_blobs_and_a_checkpoint_that_core_runs() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("kitti");
    write_sequence(&root, "0000", &generate(&DriveSpec::default()));
    write_sequence(&root, "0001", &generate(&DriveSpec { seed: 8, label_noise_m: 0.05, ..DriveSpec::default() }));
    let model_dir = dir.path().join("model");
    let out = model_dir.join("model.blob");
    let args = [
        "dynotraj",
        "train",
        "--kitti",
        root.to_str().unwrap(),
        "--source",
        "gt-ekf",
        "--exclude",
        "0001",
        "--out",
        model_dir.to_str().unwrap(),
        "--dims",
        "8,8,2,16",
        "--epochs",
        "2",
        "--batch",
        "16",
        "--rate",
        "10",
    ];
    let Command::Train(a) = Cli::try_parse_from(args).unwrap().command else { panic!("not the train command") };
    train::run(&a).unwrap();

    let dims = Dims { enc: 8, edge: 8, k: 2, dec: 16 };
    let f32_bytes = fs::read(&out).unwrap();
    let blob = ModelBlob::parse(&f32_bytes).unwrap();
    assert_eq!((blob.dims(), blob.precision(), blob.frame_period_s()), (dims, Precision::F32, 0.1));
    let int8_bytes = fs::read(model_dir.join("model.blob.int8")).unwrap();
    assert_eq!(ModelBlob::parse(&int8_bytes).unwrap().precision(), Precision::Int8);
    let (net, _, dt, _) = load_checkpoint(&model_dir.join("model.blob.safetensors")).unwrap();
    assert_eq!((net.dims, dt), (dims, 0.1));

    // The trained model forecasts a straight drive at 10 m/s as something finite and moving.
    let history: Vec<_> =
        (0..7).map(|k| dynotraj_core::BevState { x: k as f32, y: 0.0, heading: 0.0, speed: 10.0 }).collect();
    let mut forecast = [Point2::default(); HORIZON];
    LearnedPredictor::new(blob).predict_in_context(&history, &Context::NONE, 0.1, &mut forecast).unwrap();
    assert!(forecast.iter().all(|p| p.x.is_finite() && p.y.is_finite()));
    // The unicycle rollout starts at the current 10 m/s and brakes at 4 m/s^2 at most: even a
    // barely trained model goes on for at least 12.5 m in 3 s.
    let travelled = forecast[HORIZON - 1].x - history[history.len() - 1].x;
    assert!(travelled > 12.0, "the forecast moves on: {travelled} m in 3 s");

    // Evaluated at another rate than it was trained at, the model is refused with the reason
    // (it used to give a table of "-" and exit 0).
    let predictor = format!("model:{}", out.display());
    let eval_at = |rate: &str| {
        let argv = ["dynotraj", "eval", "--kitti", root.to_str().unwrap(), "--tests", "0001", "--predictor"];
        let argv: Vec<&str> = argv.iter().copied().chain([predictor.as_str(), "--rate", rate]).collect();
        let Command::Eval(a) = Cli::try_parse_from(argv).unwrap().command else { panic!("not the eval command") };
        dynotraj_cli::eval::table(&a)
    };
    let e = eval_at("20").unwrap_err().to_string();
    assert!(e.contains("trained at 10.000 Hz, evaluated with --rate 20.000 Hz"), "{e}");
    assert!(eval_at("10").is_ok());

    // Every flag is documented.
    let help = Cli::try_parse_from(["dynotraj", "train", "--help"]).unwrap_err().to_string();
    for flag in [
        "--kitti",
        "--source",
        "--exclude",
        "--sequences",
        "--out",
        "--dims",
        "--rate",
        "--epochs",
        "--batch",
        "--seed",
        "--precision",
    ] {
        assert!(help.contains(flag), "{flag} missing from --help");
    }
}

#[test]
fn an_out_that_cannot_be_a_folder_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("taken");
    fs::write(&file, b"a file").unwrap();
    // The data folder does not exist either: the --out error coming first shows that nothing
    // was loaded, let alone trained, before it.
    let missing = dir.path().join("no-kitti");
    let args = [
        "dynotraj",
        "train",
        "--kitti",
        missing.to_str().unwrap(),
        "--exclude",
        "0000",
        "--out",
        file.to_str().unwrap(),
    ];
    let Command::Train(a) = Cli::try_parse_from(args).unwrap().command else { panic!("not the train command") };
    let e = format!("{:#}", train::run(&a).unwrap_err());
    assert!(e.starts_with("--out ") && e.contains("taken") && e.contains("expected a folder"), "{e}");
    let args = ["dynotraj", "soak", "--kitti", missing.to_str().unwrap(), "--out", file.to_str().unwrap()];
    let Command::Soak(a) = Cli::try_parse_from(args).unwrap().command else { panic!("not the soak command") };
    let e = format!("{:#}", dynotraj_cli::soak::run(&a).unwrap_err());
    assert!(e.starts_with("--out ") && e.contains("expected a folder"), "{e}");
    // Every other command that writes a folder checks it first too.
    let (kitti, out) = (missing.to_str().unwrap(), file.to_str().unwrap());
    for command in [
        &["experiment"][..],
        &["benchmark"][..],
        &["estimate"][..],
        &["track", "--sequences", "0000"][..],
        &["simulate", "--sequences", "0000"][..],
        &["stream", "--sequences", "0000", "--to", "tcp://127.0.0.1:9"][..],
    ] {
        let args = [&["dynotraj"][..], command, &["--kitti", kitti, "--out", out][..]].concat();
        let e = format!("{:#}", dynotraj_cli::run(Cli::try_parse_from(&args).unwrap()).unwrap_err());
        assert!(e.starts_with("--out ") && e.contains("expected a folder"), "{}: {e}", command[0]);
    }
}

#[test]
fn training_flags_out_of_range_are_refused_before_any_sequence_is_loaded() {
    let dir = tempfile::tempdir().unwrap();
    // The data folder does not exist: a flag error coming first shows that nothing was loaded.
    let missing = dir.path().join("no-kitti");
    let kitti = missing.to_str().unwrap();
    for (flags, named) in [
        (&["--epochs", "0"][..], "--epochs"),
        (&["--restarts", "0"][..], "--restarts"),
        (&["--val-fraction", "0.9", "--ema-decay", "1"][..], "--ema-decay"),
    ] {
        for command in ["experiment", "benchmark"] {
            let args = [&["dynotraj", command, "--kitti", kitti][..], flags].concat();
            let e = format!("{:#}", dynotraj_cli::run(Cli::try_parse_from(&args).unwrap()).unwrap_err());
            assert!(e.contains(named) && !e.contains("no-kitti"), "{command} {flags:?}: {e}");
        }
    }
    // A test sequence given twice needs no data to be wrong either.
    let args = ["dynotraj", "experiment", "--kitti", kitti, "--tests", "0003,0003"];
    let e = format!("{:#}", dynotraj_cli::run(Cli::try_parse_from(args).unwrap()).unwrap_err());
    assert!(e.contains("--tests: 0003 is given twice") && !e.contains("no-kitti"), "{e}");
}

/// A pedestrian model: `train --dynamics single-integrator` trains on the pedestrians alone, a
/// drive without any says so, and `eval` scores the blob on pedestrians only, beside cv.
#[test]
fn a_pedestrian_model_trains_on_kitti_pedestrians_and_scores_only_them() {
    let dir = tempfile::tempdir().unwrap();
    let synthetic = dir.path().join("synthetic");
    write_sequence(&synthetic, "0000", &generate(&DriveSpec::default()));
    write_sequence(&synthetic, "0001", &generate(&DriveSpec { seed: 8, ..DriveSpec::default() }));
    let model_dir = dir.path().join("walkers");
    let train = |kitti: &str, sequences: &str, exclude: &str| {
        let args = [
            "dynotraj",
            "train",
            "--kitti",
            kitti,
            "--sequences",
            sequences,
            "--exclude",
            exclude,
            "--source",
            "gt",
            "--dynamics",
            "single-integrator",
            "--out",
            model_dir.to_str().unwrap(),
            "--epochs",
            "2",
            "--rate",
            "10",
        ];
        let Command::Train(a) = Cli::try_parse_from(args).unwrap().command else { panic!("not the train command") };
        train::run(&a)
    };
    let e = format!("{:#}", train(synthetic.to_str().unwrap(), "0000,0001", "0001").unwrap_err());
    assert!(e.contains("no training instances of pedestrians"), "{e}");

    let Some(kitti) = dynotraj_tests::kitti_training_dir() else { return };
    let kitti = kitti.to_str().unwrap();
    train(kitti, "0001,0011,0013", "0013").unwrap();
    let blob = fs::read(model_dir.join("model.blob.int8")).unwrap();
    assert_eq!(ModelBlob::parse(&blob).unwrap().dynamics(), dynotraj_core::predict::Dynamics::SingleIntegrator);
    let model = format!("model:{}", model_dir.join("model.blob.int8").display());
    let args = ["dynotraj", "eval", "--kitti", kitti, "--tests", "0013", "--source", "gt", "--rate", "10"];
    let predictors = format!("cv,{model}");
    let args = [&args[..], &["--predictor", &predictors]].concat();
    let Command::Eval(a) = Cli::try_parse_from(&args).unwrap().command else { panic!("not the eval command") };
    let table = dynotraj_cli::eval::table(&a).unwrap().render(dynotraj_eval::report::Format::Md);
    let rows: Vec<&str> = table.lines().filter(|l| l.contains(" on gt")).collect();
    assert!(rows.iter().any(|r| r.contains("cv on gt") && !r.contains("pedestrians")), "{table}");
    assert!(rows.iter().any(|r| r.contains("cv on gt, pedestrians")), "{table}");
    assert!(rows.iter().any(|r| r.contains("model.blob.int8 on gt, pedestrians")), "{table}");
    assert!(!rows.iter().any(|r| r.contains("model.blob.int8 on gt |")), "a walkers' model scores no vehicle: {table}");
}
