//! Host -> edge over the wire: a fixture drive's feature tracks, encoded in frame parts, with
//! garbage and a corrupted frame on the link, reach the edge session in chunks of any size; its
//! one frame assembler (the estimator's) counts every whole frame and the one it lost, and the
//! decoder every byte it dropped.

use dynotraj_core::estimate::Intrinsics;
use dynotraj_core::wire::{FrameBuf, MAX_FRAME_LEN, Message, encode, frame_parts};
use dynotraj_edge::{NoClock, Session};
use dynotraj_sim::drive::{DriveSpec, feature_tracks, generate};
use dynotraj_tests::edge_fixture::MemLink;
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

#[test]
fn edge_reassembles_frames_through_garbage_and_counts_losses() {
    let drive = generate(&DriveSpec { frames: 40, ..DriveSpec::default() });
    let frames = feature_tracks(&drive, 256, 128, 9);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    let i = Intrinsics::KITTI_0926;
    let camera = dynotraj_sources::estimation::simulated::camera_info(&i, 20.0);
    let mut buf: FrameBuf = [0; MAX_FRAME_LEN];
    let n = encode(&Message::CameraInfo(camera), &mut buf).unwrap();
    let mut stream = buf[..n].to_vec();
    let mut garbage = 0usize;
    let corrupt_frame = 17;
    for (k, tracks) in frames.iter().enumerate() {
        for (i, part) in frame_parts(k as u32, k as u64 * 50_000, tracks).unwrap().enumerate() {
            let mut buf: FrameBuf = [0; MAX_FRAME_LEN];
            let n = encode(&Message::FrameTracks(part), &mut buf).unwrap();
            if k == corrupt_frame && i == 0 {
                buf[n / 2] ^= 0x10;
            }
            stream.extend_from_slice(&buf[..n]);
        }
        // Line noise between frames (never a zero byte, so all of it is counted as dropped).
        let noise = rng.random_range(0..40);
        stream.extend((0..noise).map(|_| rng.random_range(1..=255u8)));
        garbage += noise;
    }
    let mut session: Box<Session<'static>> = Box::default();
    let mut sink = MemLink { input: &[], chunk: 1, output: Vec::new() };
    let mut rest = &stream[..];
    while !rest.is_empty() {
        let (chunk, tail) = rest.split_at(rng.random_range(1..=300).min(rest.len()));
        session.on_bytes(chunk, &mut sink, &mut NoClock).unwrap();
        rest = tail;
    }
    let s = session.pipeline().estimator().stats();
    let link = session.link().decoder_stats();
    assert_eq!(s.frames_processed as usize, frames.len() - 1, "every frame but the corrupted one");
    assert_eq!(s.frames_incomplete, 1);
    assert!(link.frames_rejected() >= 1);
    assert!(link.bytes_discarded as usize >= garbage);
}
