//! Faults on the link into the edge: a fault-injecting transport corrupts, drops and
//! duplicates bytes of a 16-car fixture stream. The edge keeps running, counts what it lost,
//! and is back in step at the next good frame: its estimates and forecasts then equal, bit for
//! bit, those of an edge that was sent only the undamaged frames.

use std::convert::Infallible;

use dynotraj_core::wire::{FrameStats, Message};
use dynotraj_edge::{NoClock, Session, Transport};
use dynotraj_tests::edge_fixture::{decode_all, encode_all, host_messages, outputs, scene_tracks};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// What happens to the bytes at one offset of the clean stream.
#[derive(Debug, Clone, Copy)]
enum Fault {
    /// XOR a byte.
    Flip(u8),
    /// Lose this many bytes.
    Drop(usize),
    /// Send this many bytes twice.
    Duplicate(usize),
}

/// Delivers a clean stream with faults applied at given offsets, in reads of varying size.
struct FaultyLink {
    bytes: Vec<u8>,
    at: usize,
    rng: Xoshiro256PlusPlus,
    written: Vec<u8>,
}

impl FaultyLink {
    fn new(clean: &[u8], mut faults: Vec<(usize, Fault)>, seed: u64) -> Self {
        faults.sort_by_key(|f| std::cmp::Reverse(f.0));
        let mut bytes = clean.to_vec();
        // From the end, so earlier offsets stay valid.
        for (at, f) in faults {
            match f {
                Fault::Flip(mask) => bytes[at] ^= mask,
                Fault::Drop(n) => {
                    bytes.drain(at..at + n);
                }
                Fault::Duplicate(n) => {
                    let copy = bytes[at..at + n].to_vec();
                    bytes.splice(at..at, copy);
                }
            }
        }
        Self { bytes, at: 0, rng: Xoshiro256PlusPlus::seed_from_u64(seed), written: Vec::new() }
    }
}

impl embedded_io::ErrorType for FaultyLink {
    type Error = Infallible;
}

impl embedded_io::Read for FaultyLink {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let n = self.rng.random_range(1..=buf.len()).min(self.bytes.len() - self.at);
        buf[..n].copy_from_slice(&self.bytes[self.at..self.at + n]);
        self.at += n;
        Ok(n)
    }
}

impl embedded_io::Write for FaultyLink {
    fn write(&mut self, bytes: &[u8]) -> Result<usize, Infallible> {
        self.written.extend_from_slice(bytes);
        Ok(bytes.len())
    }
    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

impl Transport for FaultyLink {}

fn run(link: &mut impl Transport<Error = Infallible>) -> Box<Session<'static>> {
    let mut s = Box::new(Session::new());
    s.run(link, &mut NoClock).unwrap();
    s
}

fn frame_stats(replies: &[Message]) -> Vec<FrameStats> {
    replies.iter().filter_map(|m| if let Message::FrameStats(s) = m { Some(*s) } else { None }).collect()
}

/// Byte ranges of each message in the encoded stream.
fn spans(messages: &[Message]) -> Vec<std::ops::Range<usize>> {
    let mut at = 0;
    messages
        .iter()
        .map(|m| {
            let n = encode_all(std::slice::from_ref(m)).len();
            at += n;
            at - n..at
        })
        .collect()
}

#[test]
fn edge_survives_corrupted_dropped_and_duplicated_bytes_and_resynchronises() {
    let tracks = scene_tracks(12);
    let messages = host_messages(&tracks, None);
    let clean = encode_all(&messages);
    let span = spans(&messages);
    // Message index of part `p` of frame `k` (message 0 is the camera model).
    let parts_per_frame: Vec<usize> = tracks.frames.iter().map(|f| f.parts.len()).collect();
    let index = |k: usize, p: usize| 1 + parts_per_frame[..k].iter().sum::<usize>() + p;

    let faults = vec![
        (span[index(3, 5)].start + 40, Fault::Flip(0x24)), // frame 3: a part corrupted
        (span[index(6, 0)].start + 10, Fault::Drop(span[index(6, 0)].len())), // frame 6: bytes lost across two parts
        (span[index(8, 2)].start, Fault::Duplicate(span[index(8, 2)].len())), // frame 8: a part twice
        (span[index(9, 7)].start + 3, Fault::Duplicate(57)), // frame 9: a burst repeated inside a part
    ];
    let mut link = FaultyLink::new(&clean, faults, 7);
    let session = run(&mut link);
    let replies = decode_all(&link.written);

    // The reference: an edge sent only the frames that survived (3, 6 and 9 lost).
    let lost = [3usize, 6, 9];
    let mut kept = tracks.clone();
    kept.frames = tracks.frames.iter().enumerate().filter(|(k, _)| !lost.contains(k)).map(|(_, f)| f.clone()).collect();
    let mut clean_link = FaultyLink::new(&encode_all(&host_messages(&kept, None)), vec![], 7);
    run(&mut clean_link);
    let reference = decode_all(&clean_link.written);
    assert_eq!(
        outputs(&replies),
        outputs(&reference),
        "after each loss the edge is back in step with the next good frame"
    );

    let stats = frame_stats(&replies);
    let answered: Vec<u32> = stats.iter().map(|s| s.frame).collect();
    assert_eq!(answered, [0, 1, 2, 4, 5, 7, 8, 10, 11]);
    assert_eq!(stats.iter().map(|s| s.frames_lost).collect::<Vec<_>>(), [0, 0, 0, 1, 1, 2, 2, 3, 3]);
    assert!(stats.last().unwrap().bytes_dropped > 0);

    let link_stats = session.link_stats().received;
    assert!(link_stats.crc_errors + link_stats.cobs_errors >= 3, "{link_stats:?}");
    assert!(session.pipeline().estimator().stats().parts_duplicate >= 1, "the repeated part is recognised");
    assert_eq!(session.pipeline().estimator().stats().frames_incomplete, 3);
    assert!(session.ended(), "the goodbye arrived and ended the session");
}

#[test]
fn edge_counts_every_frame_under_random_faults() {
    let tracks = scene_tracks(12);
    let messages = host_messages(&tracks, None);
    let clean = encode_all(&messages);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
    // About one fault per 100 KB (a frame carries about 50 KB, so about half the frames are
    // hit); the camera model and the goodbye are kept intact.
    let span = spans(&messages);
    let body = span[1].start..span[span.len() - 1].start - 200;
    let faults: Vec<(usize, Fault)> = (0..clean.len() / 100_000)
        .map(|_| {
            let at = rng.random_range(body.clone());
            let f = match rng.random_range(0..3) {
                0 => Fault::Flip(rng.random_range(1..=255)),
                1 => Fault::Drop(rng.random_range(1..100)),
                _ => Fault::Duplicate(rng.random_range(1..100)),
            };
            (at, f)
        })
        .collect();
    let mut link = FaultyLink::new(&clean, faults, 3);
    let session = run(&mut link);
    let stats = frame_stats(&decode_all(&link.written));
    let last = stats.last().expect("some frames survive");
    // Every frame is either answered or counted lost (frames after the last answered one are
    // not known to be lost yet).
    assert_eq!(stats.len() as u32 + last.frames_lost, last.frame + 1 - stats[0].frame);
    assert!(session.link_stats().received.frames_rejected() > 0);
    assert!(last.bytes_dropped > 0);
    assert!(session.ended());
    println!(
        "random faults: {} of 12 frames answered, {} lost, {} bytes dropped",
        stats.len(),
        last.frames_lost,
        last.bytes_dropped
    );
}
