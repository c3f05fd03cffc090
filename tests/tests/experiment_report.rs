//! `dynotraj experiment --out DIR` end to end on a KITTI-layout folder written from the
//! fixtures' synthetic drive, with the Estimated arm beside GT: the report folder holds every
//! table as Markdown and CSV, the fold models and the fold cache, and a rerun trains nothing
//! and gives the same table.

use std::fs;

use clap::Parser as _;
use dynotraj_cli::{Cli, Command, experiment};
use dynotraj_eval::experiment::folds::Quiet;
use dynotraj_tests::synthetic_kitti::{FOUR_DRIVES, write_drives};

#[test]
fn the_report_folder_and_a_cached_rerun() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("kitti");
    write_drives(&root, &FOUR_DRIVES[..3]);
    let out = dir.path().join("report");
    let recordings = out.join("recordings");
    let args = [
        "dynotraj",
        "experiment",
        "--kitti",
        root.to_str().unwrap(),
        "--tests",
        "0000",
        "--arms",
        "estimated,gt",
        "--dims",
        "8,8,2,16",
        "--epochs",
        "1",
        "--batch",
        "16",
        "--rate",
        "10",
        "--ours-input",
        "tracks",
        "--out",
        out.to_str().unwrap(),
        "--record",
        recordings.to_str().unwrap(),
    ];
    let Command::Experiment(a) = Cli::try_parse_from(args).unwrap().command else {
        panic!("not the experiment command")
    };
    experiment::run(&a).unwrap();
    // The recording of the test sequence: per arm and frame, tracks, learned and cv forecasts.
    let bytes = fs::read(out.join("recordings/0000.mcap")).unwrap();
    let mut per_topic: std::collections::BTreeMap<String, (usize, usize)> = Default::default();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        assert_eq!(m.channel.schema.as_ref().unwrap().name, "foxglove.SceneUpdate");
        let update = <foxglove::messages::SceneUpdate as foxglove::Decode>::decode(&m.data[..]).unwrap();
        let e = per_topic.entry(m.channel.topic.clone()).or_default();
        e.0 += 1;
        e.1 += update.entities.len();
    }
    let topics: Vec<&str> = per_topic.keys().map(String::as_str).collect();
    assert_eq!(
        topics,
        [
            "/estimated/forecasts/cv",
            "/estimated/forecasts/learned",
            "/estimated/tracks",
            "/gt/forecasts/cv",
            "/gt/forecasts/learned",
            "/gt/tracks"
        ]
    );
    let frames = per_topic["/gt/tracks"].0;
    assert!(frames > 30 && per_topic.values().all(|(n, _)| *n == frames), "{per_topic:?}");
    for arm in ["gt", "estimated"] {
        let (learned, cv) =
            (per_topic[&format!("/{arm}/forecasts/learned")].1, per_topic[&format!("/{arm}/forecasts/cv")].1);
        assert!(learned > 0 && learned == cv, "{arm}: {learned} learned and {cv} cv forecasts");
    }

    let md = fs::read_to_string(out.join("REPORT.md")).unwrap();
    assert!(
        md.contains(
            "No eligible pedestrians in the test sequences, so no table scores them; no loaded sequence holds one"
        ),
        "the synthetic drives hold no pedestrian, and the report says so: {md}"
    );
    println!("{md}");
    // The captions and notes name what the Estimated arm ran on (here the track-level simulator).
    assert!(md.contains("against the truth of the track-level simulator"), "Table III caption");
    assert!(md.contains("`--ours-input tracks`") && !md.contains("image simulator's rendering"), "input note");
    for heading in [
        "## Table I",
        "## Table III: the estimator behind the Estimated arm, causal",
        "## Table IV",
        "## Table IV against one common reference",
        "## Deployment",
        "## Folds",
        "## Findings",
    ] {
        assert!(md.contains(heading), "{heading} missing");
    }
    assert!(md.contains("learned int8 on estimated") && md.contains("eligible objects (estimated)"));
    for stem in ["table_i", "table_iii_causal", "table_iii_smoothed", "table_iv", "table_iv_truth", "deployment"] {
        let csv = fs::read_to_string(out.join(format!("{stem}.csv"))).unwrap();
        assert!(csv.lines().count() > 2, "{stem}.csv: {csv}");
        assert!(out.join(format!("{stem}.md")).is_file());
    }
    // The paper's figures 2-5 for the drive's longest-seen mover, KITTI track 1: object 2 (no
    // sequence 0018 here), its bird's-eye trajectory and forecasts, the errors against the
    // horizon and the estimator's RPE over time.
    for fig in [
        "fig2_distance_0000_object2",
        "fig3_speed_0000_object2",
        "fig4_heading_0000_object2",
        "fig5_ace_0000_object2",
        "birdseye_0000_object2",
        "forecasts_0000_object2",
        "ade_horizon",
        "fde_horizon",
        "rpe_camera_0000",
        "rpe_objects_0000",
    ] {
        assert!(
            out.join(format!("figures/{fig}.png")).is_file() && out.join(format!("figures/{fig}.svg")).is_file(),
            "{fig}"
        );
        assert!(md.contains(&format!("figures/{fig}.png")), "{fig} not embedded");
    }
    for arm in ["estimated", "gt"] {
        assert!(out.join(format!("models/{arm}-0000.blob")).is_file());
        assert!(out.join(format!("models/{arm}-0000.blob.int8")).is_file());
    }
    let cached = fs::read_dir(out.join("cache")).unwrap().count();
    assert_eq!(
        cached,
        2 + 3,
        "two folds (one file each: both blobs and the report), three sequences' estimated tracks"
    );

    // Against the common reference every arm has the same instances: one instance row.
    // Columns: row_kind,arm,sequence,ade,fde,ace,instances,ace_pairs (labels have no comma).
    let truth = fs::read_to_string(out.join("table_iv_truth.csv")).unwrap();
    let counts: std::collections::BTreeSet<Vec<&str>> =
        truth.lines().filter(|l| l.starts_with("weighted_average,")).map(|l| l.split(',').skip(6).collect()).collect();
    assert_eq!(counts.len(), 1, "{truth}");
    assert!(counts.iter().all(|c| c.len() == 2 && c[0].parse::<u64>().is_ok_and(|n| n > 0)), "{truth}");
    assert!(md.contains("Against the simulator's truth: estimated against gt"), "{md}");

    let first = fs::read_to_string(out.join("table_iv.csv")).unwrap();
    let again = dynotraj_eval::experiment::request::experiment(&a.request().unwrap(), &Quiet).unwrap().result;
    assert!(again.folds.iter().all(|f| f.cached), "{:?}", again.folds);
    assert_eq!(
        again.table.render(dynotraj_eval::report::Format::Csv),
        first,
        "the cached rerun scores the same models"
    );
}
