//! `dynotraj estimate` end to end on the first frames of a real KITTI sequence (skipped without
//! `../shared/kitti`): Table III layout, and the pose files and log that `--out` writes.

use clap::Parser;
use dynotraj_cli::estimate::estimate_sequences;
use dynotraj_cli::{Cli, Command};
use dynotraj_eval::estimation::pose_files::{FileClock, write_run};
use dynotraj_eval::report::estimator_tables::tables;

#[test]
fn estimate_prints_table_iii_and_writes_pose_files() {
    let Some(dir) = dynotraj_tests::kitti_training_dir() else { return };
    let out = tempfile::tempdir().expect("temp dir");
    let cli = Cli::parse_from([
        "dynotraj",
        "estimate",
        "--ours-input",
        "tracks",
        "--sim-kitti",
        dir.to_str().expect("utf-8 path"),
        "--sequence",
        "0003,0020",
        "--frames",
        "120",
    ]);
    let Command::Estimate(args) = cli.command else { panic!("not the estimate command") };
    let results = estimate_sequences(&args).expect("runs");
    assert_eq!(results.len(), 2);
    let t = tables(&results);
    assert_eq!(t.len(), 5, "three Table III blocks, the restarts and the smoothness table");
    for table in &t[..3] {
        // Two sequences, the average and DynoSAM's reference row.
        assert_eq!(table.rows.len(), 4);
        assert_eq!(table.rows[2][0], "average");
        assert!(table.rows[2][2].parse::<f64>().expect("camera RPE_t") < 0.05);
    }
    let seq = out.path().join("0003");
    write_run(&seq, &results[0].sim, &results[0].run, FileClock::KITTI).expect("writes");
    for f in ["camera_truth.tum", "camera_smoothed.tum", "camera_f2f.kitti", "log.csv"] {
        assert!(seq.join(f).is_file(), "{f} missing");
    }
    let tum = std::fs::read_to_string(seq.join("camera_causal.tum")).expect("reads");
    assert_eq!(tum.lines().filter(|l| !l.starts_with('#')).count(), 120);
    // KITTI's capture clock, 10 Hz, whatever rate the estimator ran at (the paper's 20 Hz by
    // default): said in every pose file and the README.
    assert!(
        tum.lines().any(|l| l
            == "# timestamps: seconds at the camera's rate, 10.000 Hz (one frame every 0.1000 s); the estimator \
                ran at 20.000 Hz"),
        "{tum}"
    );
    let frame_times: Vec<f64> =
        tum.lines().filter(|l| !l.starts_with('#')).map(|l| l.split(' ').next().unwrap().parse().unwrap()).collect();
    assert!((frame_times[1] - frame_times[0] - 0.1).abs() < 1e-9, "{:?}", &frame_times[..2]);
    let readme = std::fs::read_to_string(seq.join("README.txt")).expect("a README beside the pose files");
    assert!(
        readme.contains("10.000 Hz") && readme.contains("evo_rpe tum camera_truth.tum camera_smoothed.tum"),
        "{readme}"
    );
    let objects = std::fs::read_dir(seq.join("objects")).expect("objects folder").count();
    assert!(objects > 0);
    object_files_give_the_printed_rpe(&seq, &results[0]);
}

/// Every estimated object file read back and scored against its truth file as evo would (the
/// poses paired by timestamp, consecutive lines of a file paired) gives the printed object RPE
/// of its kind: same pairs, same RMSEs to file precision. So no file holds a placeholder pose or
/// a pair across a restart.
fn object_files_give_the_printed_rpe(
    seq: &std::path::Path,
    result: &dynotraj_sources::estimation::simulated::SequenceResult,
) {
    use dynotraj_core::metrics::RpeAccumulator;
    use dynotraj_formats::kitti::{read_poses, read_tum};
    use dynotraj_sources::estimation::runner::Kind;
    use dynotraj_sources::estimation::score::moving_objects;

    let micros = |t: f64| (t * 1e6).round() as i64;
    let moving = moving_objects(&result.sim, result.min_step_m);
    let mut files = 0;
    // objects/runs.csv: each run's RPE as dynotraj scores it, by (object, kind, run).
    let runs_csv = std::fs::read_to_string(seq.join("objects/runs.csv")).expect("runs.csv");
    let listed: std::collections::HashMap<(String, String, String), (f64, f64)> = runs_csv
        .lines()
        .skip(1)
        .filter_map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            Some(((c[0].into(), c[1].into(), c[2].into()), (c[6].parse().ok()?, c[7].parse().ok()?)))
        })
        .collect();
    let mut kitti_runs = 0;
    for (kind, printed) in Kind::ALL.iter().zip(&result.scores.kinds) {
        let mut all = RpeAccumulator::new();
        for id in &moving {
            let truth_path = seq.join(format!("objects/{id}_truth.tum"));
            let truth: std::collections::HashMap<i64, _> =
                read_tum(&truth_path).expect("truth file").into_iter().map(|(t, p)| (micros(t), p)).collect();
            for n in 1.. {
                let path = seq.join(format!("objects/{id}_{}_{n}.tum", kind.name()));
                if !path.exists() {
                    break;
                }
                files += 1;
                let mut acc = RpeAccumulator::new();
                for (t, p) in read_tum(&path).expect("object file") {
                    let q =
                        truth.get(&micros(t)).unwrap_or_else(|| panic!("{}: {t} s has no truth pose", path.display()));
                    acc.push(&q.cast::<f32>(), &p.cast::<f32>());
                }
                all.merge(&acc);
                // The run's row in runs.csv is this file's RPE.
                let key = (id.to_string(), kind.name().to_string(), n.to_string());
                let (t_m, r_deg) = listed[&key];
                let got = acc.result().expect("a run has a pair");
                assert!((got.translation - t_m).abs() <= 1e-4 * t_m + 1e-6, "{key:?}: {} vs {t_m}", got.translation);
                assert!((got.rotation.to_degrees() - r_deg).abs() <= 1e-4 * r_deg + 1e-5, "{key:?}");
                // The smoothed runs also as KITTI files, paired by line: the same RPE.
                if *kind == Kind::Smoothed {
                    let est = read_poses(seq.join(format!("objects/{id}_smoothed_{n}.kitti"))).expect("kitti run");
                    let tru = read_poses(seq.join(format!("objects/{id}_truth_{n}.kitti"))).expect("kitti truth");
                    assert_eq!(est.len(), tru.len());
                    let mut by_line = RpeAccumulator::new();
                    for (q, p) in tru.iter().zip(&est) {
                        by_line.push(&q.cast::<f32>(), &p.cast::<f32>());
                    }
                    let k = by_line.result().expect("pairs");
                    assert!(
                        (k.translation - t_m).abs() <= 1e-4 * t_m + 1e-6,
                        "{key:?}: kitti {} vs {t_m}",
                        k.translation
                    );
                    kitti_runs += 1;
                }
            }
        }
        let (got, want) = (all.result(), printed.object);
        assert_eq!(got.map(|r| r.pairs), want.map(|r| r.pairs), "{}: pairs in the files", kind.name());
        if let (Some(g), Some(w)) = (got, want) {
            for (what, a, b) in [("RPE_t", g.translation, w.translation), ("RPE_r", g.rotation, w.rotation)] {
                assert!((a - b).abs() <= 1e-4 * b.abs() + 1e-7, "{}: {what} {a} from files, {b} printed", kind.name());
            }
        }
    }
    assert!(files > 0 && kitti_runs > 0, "object files were written and read");
    println!("{files} object run files scored against their truth files: the printed RPE");
}

#[test]
fn estimate_runs_a_rendering_with_both_profiles_and_keeps_its_tracks() {
    use dynotraj_sources::estimation::runner::Kind;

    let Some(dir) = dynotraj_tests::kitti_training_dir() else { return };
    let cache = tempfile::tempdir().expect("temp dir");
    let cli = Cli::parse_from([
        "dynotraj",
        "estimate",
        "--kitti",
        dir.to_str().expect("utf-8 path"),
        "--sequence",
        "0003",
        "--frames",
        "14",
        "--render-scale",
        "0.5",
        "--profile",
        "host,edge",
        "--estimate-cache",
        cache.path().to_str().expect("utf-8 path"),
        "--jobs",
        "1",
    ]);
    let Command::Estimate(args) = cli.command else { panic!("not the estimate command") };
    let results = estimate_sequences(&args).expect("runs");
    let profiles: Vec<&str> = results.iter().map(|r| r.profile).collect();
    assert_eq!(profiles, ["host", "edge"]);
    // One rendering for both profiles, kept in the cache.
    let kept: Vec<String> = std::fs::read_dir(cache.path())
        .expect("cache")
        .map(|e| e.expect("entry").file_name().into_string().expect("utf-8"))
        .collect();
    assert_eq!(kept.len(), 1, "{kept:?}");
    assert!(kept[0].starts_with("rendered-0003-"), "{kept:?}");
    // The profiles differ where they should: the edge's 8-frame window smooths differently.
    assert_ne!(results[0].run.of(Kind::Smoothed), results[1].run.of(Kind::Smoothed));
    for r in &results {
        let camera = r.scores.kinds[1].camera.expect("camera RPE");
        assert!(camera.translation < 0.05, "{} profile: camera RPE_t {} m", r.profile, camera.translation);
    }
    // A rerun reads the rendering back: the same estimates.
    let again = estimate_sequences(&args).expect("reruns");
    assert_eq!(again[1].run.of(Kind::Causal), results[1].run.of(Kind::Causal));
    let t = tables(&results);
    assert_eq!(t.len(), 10, "five tables per profile");
    assert!(t[0].headers[0].ends_with("[host profile]"), "{}", t[0].headers[0]);
    assert!(t[5].headers[0].ends_with("[edge profile]"), "{}", t[5].headers[0]);
}
