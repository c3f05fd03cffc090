//! `dynotraj benchmark` stopped by SIGTERM while it trains: it stops between folds, says how
//! far it got and that a rerun continues from the fold cache, writes no report, exits 1.

use std::io::{BufRead as _, BufReader};
use std::process::Stdio;

use dynotraj_tests::edge_fixture::dynotraj_command;
use dynotraj_tests::synthetic_kitti::write_drives;

#[test]
fn a_benchmark_stopped_by_sigterm_keeps_its_folds_and_writes_no_report() {
    let dir = tempfile::tempdir().unwrap();
    let kitti = dir.path().join("kitti");
    write_drives(&kitti, &[("0000", 1), ("0001", 8), ("0002", 9), ("0003", 10)]);
    let out = dir.path().join("report");
    let mut child = dynotraj_command()
        .args(["benchmark", "--kitti", kitti.to_str().unwrap(), "--arms", "gt", "--folds", "2"])
        .args(["--seeds", "1,2,3,4,5,6", "--epochs", "40", "--patience", "40", "--jobs", "1", "--rate", "10"])
        .args(["--out", out.to_str().unwrap()])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let mut said = String::new();
    // The first fold's line: training has started and one fold is in the cache.
    while stderr.read_line(&mut said).unwrap() > 0 {
        if said.contains("fold 1/12") {
            break;
        }
    }
    assert!(said.contains("fold 1/12"), "{said}");
    let killed = std::process::Command::new("kill").args(["-TERM", &child.id().to_string()]).status().unwrap();
    assert!(killed.success());
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut stderr, &mut rest).unwrap();
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(1), "{said}{rest}");
    assert!(rest.contains("interrupted after") && rest.contains("of 12 folds"), "{rest}");
    assert!(rest.contains("a rerun with the same --out continues from them"), "{rest}");
    assert!(!out.join("REPORT.md").exists(), "no report that looks complete");
    let kept = std::fs::read_dir(out.join("cache"))
        .unwrap()
        .filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "fold"));
    assert!(kept.count() >= 1, "the folds trained before the signal are kept");
}
