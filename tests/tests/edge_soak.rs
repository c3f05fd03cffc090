//! A short soak of the host build of the edge: 2,000 frames of a simulated drive, looped, over
//! a link that damages about 2 % of the wire frames. Every clean frame is answered, the
//! answered and the lost frames add up to the frames sent, and the edge's resident memory does
//! not grow (`dynotraj soak` runs the 100,000-frame version).

use dynotraj_eval::report::stream_report::soak_summary;
use dynotraj_link::edge_process::EdgeProcess;
use dynotraj_link::soak::{SoakOptions, soak};
use dynotraj_sim::drive::{DriveSpec, generate};
use dynotraj_sources::estimation::simulated::simulated_stream;
use dynotraj_tests::synthetic_kitti::write_sequence;

#[test]
fn a_faulty_link_loses_only_damaged_frames_and_memory_stays_flat() {
    let dir = tempfile::tempdir().unwrap();
    write_sequence(dir.path(), "0000", &generate(&DriveSpec::default()));
    let tracks = simulated_stream(dir.path(), "0000", None).unwrap();
    let edge = EdgeProcess::start(&dynotraj_tests::edge_fixture::edge_binary()).unwrap();
    let (rx, tx) = edge.connect().unwrap();
    let options = SoakOptions { frames: 2000, fault_probability: 0.02, seed: 7, ..SoakOptions::default() };
    let r = soak(&tracks, rx, tx, &options, Some(edge.id())).unwrap();
    let (_, status) = edge.wait().unwrap();
    assert!(status.success(), "the edge exited with {status}");
    println!("{}", soak_summary(&r));
    assert_eq!(r.frames_sent, 2000);
    assert!(r.faults_injected() > 20 && r.faults.iter().all(|&n| n > 0), "{:?}", r.faults);
    assert!(r.damaged_frames > 0);
    assert_eq!(r.clean_unanswered, 0, "no clean frame lost");
    assert_eq!(r.answered + u64::from(r.edge_frames_lost), r.frames_sent, "answered + counted lost = sent");
    assert!(r.answered >= r.frames_sent - r.damaged_frames, "only damaged frames are lost");
    let link = r.edge_link.expect("the edge said goodbye");
    assert!(link.received.frames_rejected() > 0 && link.received.bytes_discarded > 0, "{link:?}");
    let (start, end) = r.edge_memory.expect("edge memory read from /proc");
    assert!(end.rss_kib <= start.rss_kib + 64, "edge memory grew: {start:?} -> {end:?}");
}

/// SIGTERM (or Ctrl-C) stops a soak the way it stops a stream: it says goodbye, prints its
/// summary, writes `--out`, and exits 1 naming how far it got.
#[test]
fn a_soak_stopped_by_sigterm_writes_its_summary_and_out_and_exits_non_zero() {
    let dir = tempfile::tempdir().unwrap();
    write_sequence(dir.path(), "0000", &generate(&DriveSpec::default()));
    let out = dir.path().join("out");
    let edge = dynotraj_tests::edge_fixture::edge_binary();
    let child = dynotraj_tests::edge_fixture::dynotraj_command()
        .args(["soak", "--sequences", "0000", "--frames", "100000000", "--fault-probability", "0.01"])
        .arg("--kitti")
        .arg(dir.path())
        .arg("--out")
        .arg(&out)
        .arg("--edge")
        .arg(&edge)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_secs(2));
    let killed = std::process::Command::new("kill").args(["-TERM", &child.id().to_string()]).status().unwrap();
    assert!(killed.success());
    let result = child.wait_with_output().unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&result.stdout), String::from_utf8_lossy(&result.stderr));
    assert_eq!(result.status.code(), Some(1), "stdout:\n{stdout}\nstderr:\n{stderr}");
    assert!(stderr.contains("interrupted after") && stderr.contains("the summary and --out are written"), "{stderr}");
    assert!(stdout.contains("edge memory"), "the summary is printed: {stdout}");
    let table = std::fs::read_to_string(out.join("soak.csv")).expect("--out written");
    assert_eq!(table.lines().count(), 2, "{table}");
}

/// A soak stopped part way counts only the frames it sent: every clean one answered.
#[test]
fn a_stopped_soak_counts_only_what_it_sent() {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};
    let tracks = dynotraj_tests::edge_fixture::scene_tracks(10);
    let (mut edge, lines, addr) =
        dynotraj_tests::edge_fixture::spawn_listening_edge(&["--listen", "tcp://127.0.0.1:0", "--sessions", "1"]);
    let endpoint = dynotraj_link::endpoint::Endpoint::Tcp(addr);
    let (rx, tx) = dynotraj_link::endpoint::connect(&endpoint, std::time::Duration::from_secs(10)).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let opt = dynotraj_link::soak::SoakOptions {
        frames: 1_000,
        fault_probability: 0.02,
        on_frame: Some(dynotraj_link::OnFrame(Arc::new(move |n| {
            if n == 60 {
                flag.store(true, Ordering::Relaxed);
            }
        }))),
        stop: Some(stop),
        ..dynotraj_link::soak::SoakOptions::default()
    };
    let r = dynotraj_link::soak::soak(&tracks, rx, tx, &opt, None).unwrap();
    let rest: Vec<String> = lines.map_while(Result::ok).collect();
    assert!(edge.wait().unwrap().success(), "{rest:?}");
    assert!(r.interrupted);
    assert_eq!(r.frames_sent, 60);
    assert_eq!(r.clean_unanswered, 0, "{r:?}");
    assert_eq!(r.answered + u64::from(r.edge_frames_lost), 60, "{r:?}");
}
