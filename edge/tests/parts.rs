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
    let (loaded, rest) = l.finish().unwrap();
    assert_eq!((loaded, rest.len()), (&blob[..], 24), "the blob, and the rest of the buffer for another");

    // A lost chunk: the rest is rejected and the load never completes.
    let mut l = ModelLoader::new(&mut buf);
    assert_eq!(l.accept(&chunks[0]), ChunkOutcome::Stored);
    assert!(chunks[2..].iter().all(|c| l.accept(c) == ChunkOutcome::Rejected(ModelRefusal::OutOfOrder)));
    assert!(l.finish().is_none());

    // A corrupted byte (with the CRC of the true blob): every byte arrives, the CRC refuses it.
    let mut l = ModelLoader::new(&mut buf);
    let mut bad = chunks.clone();
    bad[3].data[5] ^= 1;
    let last = bad.iter().map(|c| l.accept(c)).last();
    assert_eq!(last, Some(ChunkOutcome::CrcMismatch));
    assert!(l.finish().is_none());
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
                orientation: segment,
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

#[test]
fn histories_keep_the_priors_long_memory_through_reorders_new_and_gone_objects() {
    use dynotraj_core::limits::PRIOR_STATES;
    let mut h = Histories::new();
    let mut buf = [BevState { x: 0.0, y: 0.0, heading: 0.0, speed: 0.0 }; PRIOR_STATES];
    // Object 1 for 30 frames; from frame 10 object 2; the order flips every frame; object 3
    // appears at frame 20 in front and object 2 leaves at frame 25.
    for k in 0..30u32 {
        let x1 = 100.0 + k as f32;
        let x2 = 200.0 + k as f32;
        let mut objects = vec![(1u16, 0u16, x1)];
        if (10..25).contains(&k) {
            objects.push((2, 0, x2));
        }
        if k % 2 == 1 {
            objects.reverse();
        }
        if k >= 20 {
            objects.insert(0, (3, 0, 300.0 + k as f32));
        }
        h.update(&estimate(k, &objects));
        for (hist, (id, _, x)) in h.current().iter().zip(&objects) {
            assert_eq!((hist.object_id, hist.states().last().unwrap().x), (*id, *x), "frame {k}: slot order");
        }
    }
    let one = h.current().iter().find(|x| x.object_id == 1).unwrap();
    let long = one.long_states(&mut buf);
    assert_eq!(long.len(), PRIOR_STATES, "21 states: 14 older positions and the 7 whole states");
    let xs: Vec<f32> = long.iter().map(|s| s.x).collect();
    let want: Vec<f32> = (9..30).map(|k| 100.0 + k as f32).collect();
    assert_eq!(xs, want, "oldest first, one per frame");
    assert!(h.current().iter().all(|x| x.object_id != 2), "object 2 left");
    let three = h.current().iter().find(|x| x.object_id == 3).unwrap();
    assert_eq!(three.long_states(&mut buf).len(), 10, "object 3 has been seen for 10 frames");
}
