//! A short soak of the host build of the edge: 2,000 frames of a simulated drive, looped, over
//! a link that damages about 2 % of the wire frames. Every clean frame is answered, the
//! answered and the lost frames add up to the frames sent, and the edge's resident memory does
//! not grow (`dynotraj soak` runs the 100,000-frame version).

use dynotraj_cli::soak::{SoakArgs, soak_edge};
use dynotraj_eval::report::stream_report::soak_summary;
use dynotraj_sim::drive::{DriveSpec, generate};
use dynotraj_tests::synthetic_kitti::write_sequence;

#[test]
fn a_faulty_link_loses_only_damaged_frames_and_memory_stays_flat() {
    let dir = tempfile::tempdir().unwrap();
    write_sequence(dir.path(), "0000", &generate(&DriveSpec::default()));
    let args = SoakArgs {
        tracks: None,
        kitti: Some(dir.path().to_path_buf()),
        sequences: vec!["0000".into()],
        frames: 2000,
        fault_probability: 0.02,
        seed: 7,
        out: None,
        edge: Some(dynotraj_tests::edge_fixture::edge_binary()),
    };
    let r = soak_edge(&args).unwrap();
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
