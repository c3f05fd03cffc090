//! `dynotraj benchmark --out DIR` end to end on a KITTI-layout folder written from the
//! fixtures' synthetic drive: every sequence held out once, two seeds, the Estimated arm
//! beside GT; the report holds the weighted, goal, deployment and per-sequence tables, and the
//! result does not depend on the number of jobs, nor on the trainings being run in shards and
//! gathered.

use std::fs;

use clap::Parser as _;
use dynotraj_cli::{Cli, Command, benchmark};
use dynotraj_tests::synthetic_kitti::{FOUR_DRIVES, write_drives};

fn args(root: &str, out: &str, jobs: &str) -> benchmark::BenchmarkArgs {
    let args = [
        "dynotraj",
        "benchmark",
        "--kitti",
        root,
        "--arms",
        "gt,estimated",
        "--folds",
        "2",
        "--seeds",
        "1,2",
        "--dims",
        "8,8,2,8",
        "--epochs",
        "1",
        "--batch",
        "16",
        "--rate",
        "10",
        "--ours-input",
        "tracks",
        "--jobs",
        jobs,
        "--out",
        out,
    ];
    let Command::Benchmark(a) = Cli::try_parse_from(args).unwrap().command else { panic!("not the benchmark command") };
    a
}

#[test]
fn the_benchmark_report_and_its_independence_of_the_jobs() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("kitti");
    write_drives(&root, &FOUR_DRIVES);
    let (one, two) = (dir.path().join("one"), dir.path().join("two"));
    benchmark::run(&args(root.to_str().unwrap(), one.to_str().unwrap(), "1")).unwrap();
    // Two: three shards, as three machines of an array job would run them, then the gather.
    for shard in ["0/3", "1/3", "2/3"] {
        let mut a = args(root.to_str().unwrap(), two.to_str().unwrap(), "2");
        a.shard = Some(shard.parse().unwrap());
        benchmark::run(&a).unwrap();
        assert!(!two.join("REPORT.md").exists(), "a shard writes no report");
    }
    let folds_kept = fs::read_dir(two.join("cache"))
        .unwrap()
        .filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "fold"));
    assert_eq!(folds_kept.count(), 8, "every training of the three shards is in the fold cache");
    benchmark::run(&args(root.to_str().unwrap(), two.to_str().unwrap(), "2")).unwrap();

    let md = fs::read_to_string(one.join("REPORT.md")).unwrap();
    println!("{md}");
    for heading in [
        "# dynotraj generalisation benchmark",
        "## Weighted over every held-out instance, per seed",
        "## The goal per arm and seed",
        "## Deployment",
        "## Per held-out sequence, seed 2",
        "## Folds",
    ] {
        assert!(md.contains(heading), "{heading} missing");
    }
    assert!(md.contains("Folds (held out together): 0000, 0002 | 0001, 0003."), "{md}");
    let weighted = fs::read_to_string(one.join("weighted.csv")).unwrap();
    assert!(weighted.starts_with("row_kind,arm,seed,ade,fde,ace\n"), "{weighted}");
    assert!(
        weighted.contains("data,learned int8 on estimated,2,") && weighted.contains("spread,ctra on gt,,"),
        "{weighted}"
    );
    let deployment = fs::read_to_string(one.join("deployment_weighted.csv")).unwrap();
    for row in ["learned int8 trained on gt", "learned int8 trained on estimated", "cv (no training)"] {
        assert!(deployment.contains(row), "{row}: {deployment}");
    }
    // Four folds x two seeds x two arms, each model scored on every sequence of its fold.
    let folds = fs::read_to_string(one.join("folds.csv")).unwrap();
    assert_eq!(folds.lines().count(), 1 + 2 * 2 * 2, "{folds}");
    assert!(one.join("figures/ade_per_sequence.png").is_file() && one.join("figures/ade_per_sequence.svg").is_file());
    assert!(one.join("models/gt-0000+0002.blob.int8").is_file() && one.join("models/gt-0000+0002-s2.blob").is_file());
    for stem in [
        "weighted",
        "goal",
        "deployment_weighted",
        "truth_weighted",
        "per_sequence_seed1",
        "deployment_seed2",
        "table_i",
    ] {
        assert_eq!(
            fs::read_to_string(one.join(format!("{stem}.csv"))).unwrap(),
            fs::read_to_string(two.join(format!("{stem}.csv"))).unwrap(),
            "{stem}: one machine, and three shards gathered with two jobs, differ"
        );
    }
    for seed in ["1", "2"] {
        let goal = fs::read_to_string(one.join("goal.csv")).unwrap();
        assert!(goal.lines().any(|l| l.starts_with(&format!("gt,{seed},"))), "{goal}");
    }
}
