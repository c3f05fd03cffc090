//! The edge's small parts: the model loader and the object histories. (Its presence also makes
//! `cargo test` build the `dynotraj-edge` binary that the workspace tests run.)

use dynotraj_core::estimate::{ObjectEstimate, PoseEstimate};
use dynotraj_core::geometry::{BevState, Pose3};
use dynotraj_core::wire::{ModelRefusal, ObjectClass, crc32, model_chunks};
use dynotraj_edge::history::{HISTORY_LEN, Histories};
use dynotraj_edge::model_load::{ChunkOutcome, ModelLoader};

#[test]
fn model_loader_accepts_only_a_whole_blob_with_its_crc() {
    let blob: Vec<u8> = (0..1000u32).map(|i| (i * 31 % 251) as u8).collect();
    let chunks: Vec<_> = model_chunks(&blob).unwrap().collect();
    let mut buf = vec![0u8; 1024];

    let mut l = ModelLoader::new(&mut buf);
    let outcomes: Vec<_> = chunks.iter().map(|c| l.accept(c)).collect();
    assert_eq!(outcomes.last(), Some(&ChunkOutcome::Complete));
    assert!(outcomes[..outcomes.len() - 1].iter().all(|o| *o == ChunkOutcome::Stored));
    assert_eq!(l.finish(), Some(&blob[..]));

    // A lost chunk: the rest is rejected and the load never completes.
    let mut l = ModelLoader::new(&mut buf);
    assert_eq!(l.accept(&chunks[0]), ChunkOutcome::Stored);
    assert!(chunks[2..].iter().all(|c| l.accept(c) == ChunkOutcome::Rejected(ModelRefusal::OutOfOrder)));
    assert_eq!(l.finish(), None);

    // A corrupted byte (with the CRC of the true blob): every byte arrives, the CRC refuses it.
    let mut l = ModelLoader::new(&mut buf);
    let mut bad = chunks.clone();
    bad[3].data[5] ^= 1;
    let last = bad.iter().map(|c| l.accept(c)).last();
    assert_eq!(last, Some(ChunkOutcome::CrcMismatch));
    assert_eq!(l.finish(), None);
    assert_ne!(crc32(&blob), 0);

    // Too big for the buffer.
    let mut small = vec![0u8; 100];
    let mut l = ModelLoader::new(&mut small);
    assert_eq!(l.accept(&chunks[0]), ChunkOutcome::Rejected(ModelRefusal::TooLarge { capacity: 100 }));
}

fn estimate(frame: u32, objects: &[(u16, u16, f32)]) -> PoseEstimate {
    let mut e = PoseEstimate::new();
    e.reset(frame, u64::from(frame) * 50_000);
    for &(id, segment, x) in objects {
        e.objects
            .push(ObjectEstimate {
                object_id: id,
                class: ObjectClass::Car,
                pose: Pose3::identity(),
                motion: Pose3::identity(),
                bev: BevState { x, y: 0.0, heading: 0.0, speed: 1.0 },
                heading_rate: 0.0,
                segment,
                heading_known: true,
            })
            .unwrap();
    }
    e
}

#[test]
fn histories_follow_objects_across_consecutive_frames_only() {
    let mut h = Histories::new();
    for k in 0..10u32 {
        h.update(&estimate(k, &[(1, 0, k as f32), (2, 0, 10.0 + k as f32)]));
    }
    let cur = h.current();
    assert_eq!(cur.len(), 2);
    assert_eq!(cur[0].states().len(), HISTORY_LEN, "capped at the predictor's history");
    assert_eq!(cur[0].states().last().unwrap().x, 9.0);
    assert_eq!(cur[0].states()[0].x, (10 - HISTORY_LEN) as f32, "oldest first");
    // Frame 11 (frame 10 lost): histories restart; object 2 re-oriented (segment 1) restarts too.
    h.update(&estimate(11, &[(1, 0, 11.0)]));
    assert_eq!(h.current().len(), 1);
    assert_eq!(h.current()[0].states().len(), 1);
    h.update(&estimate(12, &[(1, 0, 12.0), (2, 1, 0.0)]));
    assert_eq!(h.current()[0].states().len(), 2);
    h.update(&estimate(13, &[(1, 0, 13.0), (2, 2, 0.0)]));
    assert_eq!(h.current()[1].states().len(), 1, "a new segment restarts the history");
}
