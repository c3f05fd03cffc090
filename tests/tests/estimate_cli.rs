//! `dynotraj estimate` end to end on the first frames of a real KITTI sequence (skipped without
//! `../shared/kitti`): Table III layout, and the pose files and log that `--out` writes.

use clap::Parser;
use dynotraj_host::cli::estimate::{evaluate, tables};
use dynotraj_host::cli::{Cli, Command};
use dynotraj_host::estimate::files::write_run;

#[test]
fn estimate_prints_table_iii_and_writes_pose_files() {
    let Some(dir) = dynotraj_tests::kitti_training_dir() else { return };
    let out = tempfile::tempdir().expect("temp dir");
    let cli = Cli::parse_from([
        "dynotraj",
        "estimate",
        "--sim-kitti",
        dir.to_str().expect("utf-8 path"),
        "--sequence",
        "0003,0020",
        "--frames",
        "40",
    ]);
    let Command::Estimate(args) = cli.command else { panic!("not the estimate command") };
    let results = evaluate(&args).expect("runs");
    assert_eq!(results.len(), 2);
    let t = tables(&results);
    assert_eq!(t.len(), 4, "three Table III blocks and the smoothness table");
    for table in &t[..3] {
        // Two sequences, the average and DynoSAM's reference row.
        assert_eq!(table.rows.len(), 4);
        assert_eq!(table.rows[2][0], "average");
        assert!(table.rows[2][2].parse::<f64>().expect("camera RPE_t") < 0.05);
    }
    let seq = out.path().join("0003");
    write_run(&seq, &results[0].sim, &results[0].run).expect("writes");
    for f in ["camera_truth.tum", "camera_smoothed.tum", "camera_f2f.kitti", "log.csv"] {
        assert!(seq.join(f).is_file(), "{f} missing");
    }
    let tum = std::fs::read_to_string(seq.join("camera_causal.tum")).expect("reads");
    assert_eq!(tum.lines().filter(|l| !l.starts_with('#')).count(), 40);
    let objects = std::fs::read_dir(seq.join("objects")).expect("objects folder").count();
    assert!(objects > 0);
}
