//! `dynotraj estimate --write-tracks` then `--tracks`: replaying a recorded tracks file gives the
//! estimates of the direct run bit for bit (same noise model, seed and rate), and the replay
//! writes the estimate files without any truth.

use clap::Parser as _;
use dynotraj_cli::estimate::{EstimateArgs, estimate_sequences, run};
use dynotraj_cli::{Cli, Command};
use dynotraj_eval::estimation::estimate_tracks;
use dynotraj_sim::drive::{DriveSpec, generate};
use dynotraj_sources::estimation::Kind;
use dynotraj_tests::synthetic_kitti::write_sequence;

fn args(list: &[&str]) -> EstimateArgs {
    let cli = Cli::try_parse_from(["dynotraj", "estimate"].iter().chain(list.iter()).copied()).unwrap();
    let Command::Estimate(a) = cli.command else { panic!("not the estimate command") };
    a
}

#[test]
fn a_replayed_tracks_file_gives_the_direct_estimates_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("kitti");
    write_sequence(&root, "0000", &generate(&DriveSpec::default()));
    let direct_out = dir.path().join("direct");
    let replay_out = dir.path().join("replay");
    // --write-tracks writes into --out, named as `dynotraj track` names its files.
    let tracks = direct_out.join("0000.dtt");
    let (root_s, tracks_s) = (root.to_str().unwrap(), tracks.to_str().unwrap());

    // The command itself: writes the tracks file and the direct run's files.
    let direct_args = args(&[
        "--ours-input",
        "tracks",
        "--kitti",
        root_s,
        "--sequence",
        "0000",
        "--seed",
        "3",
        "--write-tracks",
        "--out",
        direct_out.to_str().unwrap(),
    ]);
    run(&direct_args).unwrap();
    assert!(tracks.is_file());
    let replay_args = args(&["--tracks", tracks_s, "--seed", "3", "--out", replay_out.to_str().unwrap()]);
    run(&replay_args).unwrap();

    // Bit for bit: every estimate of every kind, compared as f32.
    let direct = estimate_sequences(&direct_args).unwrap().remove(0);
    let replay = replay_file(&replay_args, &tracks).unwrap();
    assert_eq!(replay.frames.len(), direct.frames);
    let mut objects = 0;
    for kind in Kind::ALL {
        assert_eq!(replay.run.of(kind), direct.run.of(kind), "{kind:?} estimates differ");
        objects += replay.run.of(kind).iter().flatten().map(|e| e.objects.len()).sum::<usize>();
    }
    assert!(objects > 0, "the drive's moving objects are estimated");
    assert_eq!(replay.run.stats, direct.run.stats);

    // A different seed changes RANSAC, so the comparison above can fail.
    let other = replay_file(&args(&["--tracks", tracks_s, "--seed", "4"]), &tracks).unwrap();
    assert_ne!(other.run.of(Kind::FrameToFrame), direct.run.of(Kind::FrameToFrame));

    // The replay's files: the same estimates, no truth anywhere. The clocks differ: a KITTI
    // sequence's files are stamped at KITTI's 10 Hz capture rate, a tracks file's at its camera
    // rate (here the run's 20 Hz, all the file knows), so stamps are left out of the comparison.
    let seq = direct_out.join("0000");
    let poses = |path: &std::path::Path| -> Vec<String> {
        let text = std::fs::read_to_string(path).unwrap();
        let tum = path.extension().is_some_and(|e| e == "tum");
        let strip = |l: &str| if tum { l.split_once(' ').map_or(l, |(_, rest)| rest).to_string() } else { l.into() };
        text.lines().filter(|l| !l.starts_with('#')).map(strip).collect()
    };
    for f in ["camera_smoothed.tum", "camera_causal.kitti", "camera_f2f.tum"] {
        assert_eq!(poses(&replay_out.join(f)), poses(&seq.join(f)), "{f}");
    }
    let note = std::fs::read_to_string(replay_out.join("camera_smoothed.tum")).unwrap();
    assert!(note.contains("rate, 20.000 Hz"), "{note}");
    let note = std::fs::read_to_string(seq.join("camera_smoothed.tum")).unwrap();
    assert!(note.contains("rate, 10.000 Hz"), "{note}");
    assert!(!replay_out.join("camera_truth.tum").exists());
    let log = std::fs::read_to_string(replay_out.join("log.csv")).unwrap();
    assert!(!log.contains(",truth,"));
    let direct_log = std::fs::read_to_string(seq.join("log.csv")).unwrap();
    // Every column but `time_s`, the second.
    let untimed = |l: &str| {
        let mut c: Vec<&str> = l.split(',').collect();
        c.remove(1);
        c.join(",")
    };
    let estimated: Vec<String> = direct_log.lines().filter(|l| !l.contains(",truth,")).map(untimed).collect();
    assert_eq!(log.lines().map(untimed).collect::<Vec<_>>(), estimated);

    // Bad input names the file.
    std::fs::write(&tracks, b"\x00garbage\x00").unwrap();
    let err = replay_file(&replay_args, &tracks).unwrap_err().to_string();
    assert!(err.contains("0000.dtt"), "{err}");
}

/// The estimator on a tracks file with the options `args` give, as `estimate --tracks` runs it.
fn replay_file(args: &EstimateArgs, tracks: &std::path::Path) -> Result<dynotraj_eval::estimation::Replay, String> {
    let options = args.options().map_err(|e| e.to_string())?;
    estimate_tracks(tracks, options, args.frames).map_err(|e| e.to_string())
}
