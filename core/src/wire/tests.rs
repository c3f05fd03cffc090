//! Framing and decoder tests: round trips at full capacity, arbitrary chunking, garbage,
//! bit flips, overflow and foreign versions.
#![allow(clippy::unwrap_used, clippy::indexing_slicing)]

extern crate std;

use std::vec::Vec;

use postcard::experimental::max_size::MaxSize;

use super::*;
use crate::geometry::{BevState, Point2};
use crate::limits::{HORIZON, MAX_OBJECTS};

/// A float without zero bytes, so that full messages are also COBS's worst case.
const F: f32 = 1.1;

/// Tiny deterministic generator (Knuth's MMIX LCG): tests need no dev-dependency.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> u32 {
        self.0 = self.0.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 33) as u32
    }
    fn below(&mut self, n: usize) -> usize {
        self.next() as usize % n
    }
}

fn full_frame_tracks() -> Message {
    let track = Track { track_id: u32::MAX, object_id: u16::MAX, class: ObjectClass::Misc, u: F, v: F, depth: F };
    Message::FrameTracks(FrameTracks {
        frame: u32::MAX,
        timestamp_us: u64::MAX,
        part: u16::MAX,
        parts: u16::MAX,
        tracks: core::iter::repeat_n(track, TRACKS_PER_MESSAGE).collect(),
    })
}

fn full_object_states() -> Message {
    let object = ObjectState {
        object_id: u16::MAX,
        class: ObjectClass::Misc,
        state: BevState { x: F, y: F, heading: F, speed: F },
        heading_rate: F,
        heading_known: true,
    };
    Message::ObjectStates(ObjectStates {
        frame: u32::MAX,
        timestamp_us: u64::MAX,
        kind: EstimateKind::Smoothed,
        camera: CameraPose { translation: [F; 3], rotation: [F; 4] },
        objects: core::iter::repeat_n(object, MAX_OBJECTS).collect(),
    })
}

fn prediction(points: usize) -> Message {
    Message::Prediction(Prediction {
        frame: u32::MAX,
        object_id: u16::MAX,
        dt: 0.05,
        points: (0..points).map(|k| Point2::new(k as f32, F)).collect(),
    })
}

fn full_model_chunk() -> Message {
    Message::ModelChunk(ModelChunk {
        blob_len: u32::MAX,
        blob_crc: u32::MAX,
        offset: u32::MAX,
        data: (0..MODEL_CHUNK_LEN).map(|i| (i | 1) as u8).collect(),
    })
}

fn full_link_stats() -> Message {
    let n = u32::MAX;
    Message::LinkStats(LinkStats {
        frames_sent: n,
        received: DecoderStats {
            frames_ok: n,
            crc_errors: n,
            cobs_errors: n,
            version_errors: n,
            decode_errors: n,
            overflows: n,
            bytes_discarded: n,
        },
    })
}

fn camera_info() -> Message {
    Message::CameraInfo(CameraInfo {
        fx: F,
        fy: F,
        cx: F,
        cy: F,
        stereo_fb: F,
        width: u16::MAX,
        height: u16::MAX,
        frame_rate_hz: F,
    })
}

fn full_frame_stats() -> Message {
    let n = u32::MAX;
    Message::FrameStats(FrameStats {
        frame: n,
        frames_lost: n,
        objects: u16::MAX,
        predictions: u16::MAX,
        objects_dropped: n,
        tracks_dropped: n,
        bytes_dropped: n,
        compute: n,
        unit: ComputeUnit::Instructions,
    })
}

/// Every variant at full capacity with the longest varints, and each variant's max size.
fn full_messages() -> [(Message, usize); 7] {
    [
        (full_frame_tracks(), FrameTracks::POSTCARD_MAX_SIZE),
        (full_object_states(), ObjectStates::POSTCARD_MAX_SIZE),
        (prediction(HORIZON), Prediction::POSTCARD_MAX_SIZE),
        (full_model_chunk(), ModelChunk::POSTCARD_MAX_SIZE),
        (full_link_stats(), LinkStats::POSTCARD_MAX_SIZE),
        (camera_info(), CameraInfo::POSTCARD_MAX_SIZE),
        (full_frame_stats(), FrameStats::POSTCARD_MAX_SIZE),
    ]
}

fn small_messages() -> [Message; 3] {
    [prediction(2), Message::LinkStats(LinkStats::default()), prediction(0)]
}

fn encoded(msg: &Message) -> Vec<u8> {
    let mut buf: FrameBuf = [0; MAX_FRAME_LEN];
    let n = encode(msg, &mut buf).unwrap();
    buf[..n].to_vec()
}

/// A frame built independently of [`encode`], from the documented layout.
fn frame_of(version: u8, body: &[u8]) -> Vec<u8> {
    let mut payload = std::vec![version];
    payload.extend_from_slice(body);
    payload.extend_from_slice(&crc32(&payload).to_le_bytes());
    let mut frame = std::vec![0; cobs::max_encoding_length(payload.len())];
    let n = cobs::encode(&payload, &mut frame);
    frame.truncate(n);
    frame.insert(0, 0);
    frame.push(0);
    frame
}

fn decode_all(decoder: &mut FrameDecoder, bytes: &[u8]) -> Vec<Message> {
    decoder.feed(bytes).collect()
}

#[test]
fn sizes_and_budget() {
    std::println!(
        "MAX_MESSAGE_LEN = {MAX_MESSAGE_LEN}, MAX_PAYLOAD_LEN = {MAX_PAYLOAD_LEN}, \
         MAX_FRAME_LEN = {MAX_FRAME_LEN}, size_of::<FrameDecoder>() = {}",
        core::mem::size_of::<FrameDecoder>()
    );
    assert_eq!(MAX_PAYLOAD_LEN, MAX_MESSAGE_LEN + 5);
    // The documented COBS bound: one code byte per started 254-byte run, plus two delimiters.
    assert_eq!(MAX_FRAME_LEN, MAX_PAYLOAD_LEN + MAX_PAYLOAD_LEN.div_ceil(254) + 2);
    assert!(core::mem::size_of::<FrameDecoder>() <= MAX_FRAME_LEN + 64);
}

#[test]
fn every_variant_round_trips_at_full_capacity() {
    let mut largest = 0;
    for (msg, max) in full_messages() {
        let mut body = [0u8; MAX_MESSAGE_LEN];
        let body_len = postcard::to_slice(&msg, &mut body).unwrap().len();
        // The worst case reaches the derived bound exactly: the bound is tight.
        assert_eq!(body_len, 1 + max, "{msg:?}");
        largest = largest.max(body_len);

        let frame = encoded(&msg);
        assert!(frame.len() <= MAX_FRAME_LEN);
        assert_eq!(frame, frame_of(PROTOCOL_VERSION, &body[..body_len]), "layout as documented");
        assert_eq!(decode(&mut frame.clone()).unwrap(), msg);
        assert_eq!(decode(&mut frame[..frame.len() - 1].to_vec()).unwrap(), msg, "no delimiter");
        let mut decoder = FrameDecoder::new();
        assert_eq!(decode_all(&mut decoder, &frame), [msg]);
        assert_eq!(decoder.stats(), DecoderStats { frames_ok: 1, ..DecoderStats::default() });
    }
    assert_eq!(largest, MAX_MESSAGE_LEN);
}

#[test]
fn object_heading_known_travels_and_version_1_is_refused() {
    let states = |known: bool| {
        let object = ObjectState {
            object_id: 7,
            class: ObjectClass::Car,
            state: BevState { x: 1.0, y: 2.0, heading: 0.0, speed: 3.0 },
            heading_rate: 0.0,
            heading_known: known,
        };
        Message::ObjectStates(ObjectStates {
            frame: 3,
            timestamp_us: 4,
            kind: EstimateKind::Causal,
            camera: CameraPose::IDENTITY,
            objects: core::iter::once(object).collect(),
        })
    };
    let (unknown, known) = (encoded(&states(false)), encoded(&states(true)));
    assert_ne!(unknown, known, "the flag is on the wire");
    assert_eq!(decode(&mut unknown.clone()).unwrap(), states(false));
    assert_eq!(decode(&mut known.clone()).unwrap(), states(true));
    // A sender of protocol 1 (ObjectState without the flag) is refused, not misread.
    let mut body = [0u8; MAX_MESSAGE_LEN];
    let n = postcard::to_slice(&states(true), &mut body).unwrap().len();
    assert_eq!(PROTOCOL_VERSION, 2);
    assert_eq!(decode(&mut frame_of(1, &body[..n - 1])), Err(WireError::Version { found: 1 }));
}

#[test]
fn short_output_buffer_is_an_error() {
    let msg = prediction(HORIZON);
    let n = encoded(&msg).len();
    for len in 0..n {
        let mut out = std::vec![0u8; len];
        assert_eq!(encode(&msg, &mut out), Err(WireError::BufferTooSmall));
    }
}

#[test]
fn frames_reassemble_across_every_split() {
    let msgs = small_messages();
    let stream: Vec<u8> = msgs.iter().flat_map(encoded).collect();
    for at in 0..=stream.len() {
        let mut decoder = FrameDecoder::new();
        let mut got = decode_all(&mut decoder, &stream[..at]);
        got.extend(decoder.feed(&stream[at..]));
        assert_eq!(got, msgs, "split at {at}");
        assert_eq!(decoder.pending_len(), 0);
    }
    let mut decoder = FrameDecoder::new();
    let got: Vec<Message> =
        stream.iter().flat_map(|b| decoder.feed(core::slice::from_ref(b)).collect::<Vec<_>>()).collect();
    assert_eq!(got, msgs, "byte by byte");
}

#[test]
fn stopping_early_leaves_the_rest_for_later() {
    let msgs = small_messages();
    let stream: Vec<u8> = msgs.iter().flat_map(encoded).collect();
    let mut decoder = FrameDecoder::new();
    let mut feed = decoder.feed(&stream);
    assert_eq!(feed.next().as_ref(), Some(&msgs[0]));
    let rest = feed.remaining();
    assert_eq!(rest.len(), stream.len() - encoded(&msgs[0]).len());
    let got: Vec<Message> = decoder.feed(rest).collect();
    assert_eq!(got, msgs[1..]);
}

#[test]
fn garbage_between_frames_loses_no_frame_and_is_counted() {
    let mut rng = Lcg(7);
    let (mut stream, mut sent, mut garbage_discarded) = (Vec::new(), Vec::new(), 0);
    for i in 0..300 {
        let msg = if i % 3 == 0 { full_frame_tracks() } else { prediction(i % HORIZON) };
        stream.extend(encoded(&msg));
        sent.push(msg);
        // Garbage with stray zeros, ended by a delimiter (as a transmitter's sync byte would).
        let mut garbage: Vec<u8> =
            (0..rng.below(40)).map(|_| if rng.below(8) == 0 { 0 } else { rng.next() as u8 }).collect();
        garbage.push(0);
        // Each non-empty run is a rejected frame with its delimiter; empty runs are sync.
        garbage_discarded += garbage.split(|&b| b == 0).filter(|s| !s.is_empty()).map(|s| s.len() + 1).sum::<usize>();
        stream.extend(garbage);
    }
    let mut decoder = FrameDecoder::new();
    let mut got = Vec::new();
    let mut rest = &stream[..];
    while !rest.is_empty() {
        let (chunk, tail) = rest.split_at(rest.len().min(1 + rng.below(200)));
        got.extend(decoder.feed(chunk));
        rest = tail;
    }
    let stats = decoder.stats();
    assert_eq!(got, sent);
    assert_eq!(stats.frames_ok as usize, sent.len());
    assert_eq!(stats.bytes_discarded as usize, garbage_discarded);
    assert!(stats.frames_rejected() > 0);
    assert_eq!(stats.overflows, 0);
    assert_eq!(decoder.pending_len(), 0);
}

#[test]
fn a_flipped_bit_costs_only_its_frame() {
    let [a, b, c] = [prediction(HORIZON), prediction(3), Message::LinkStats(LinkStats::default())];
    let (fa, fb, fc) = (encoded(&a), encoded(&b), encoded(&c));
    for bit in 0..fa.len() * 8 {
        let mut flipped = fa.clone();
        flipped[bit / 8] ^= 1 << (bit % 8);

        // Each frame starts and ends with a delimiter, so any flip, delimiters included,
        // costs exactly the frame it hits.
        let stream: Vec<u8> = [&flipped[..], &fb, &fc].concat();
        let mut decoder = FrameDecoder::new();
        let got = decode_all(&mut decoder, &stream);
        let stats = decoder.stats();
        assert!(stats.frames_rejected() >= 1, "bit {bit} went undetected");
        assert_eq!(got, [b.clone(), c.clone()], "bit {bit}");
        assert!((1..=fa.len()).contains(&(stats.bytes_discarded as usize)), "bit {bit}");

        // Extra sync bytes between frames change nothing.
        let stream: Vec<u8> = [&[0][..], &flipped, &[0], &fb, &[0], &fc].concat();
        let got = decode_all(&mut FrameDecoder::new(), &stream);
        assert_eq!(got, [b.clone(), c.clone()], "bit {bit} with sync bytes");
    }
}

#[test]
fn overlong_frame_is_counted_and_the_next_decodes() {
    let next = prediction(5);
    for junk_len in [MAX_FRAME_LEN - 2, MAX_FRAME_LEN - 1, 3 * MAX_FRAME_LEN + 17] {
        let mut stream = std::vec![0x55u8; junk_len];
        stream.push(0);
        stream.extend(encoded(&next));
        let mut decoder = FrameDecoder::new();
        let mut got = Vec::new();
        for chunk in stream.chunks(97) {
            got.extend(decoder.feed(chunk));
        }
        let stats = decoder.stats();
        assert_eq!(got, core::slice::from_ref(&next));
        assert_eq!(stats.bytes_discarded as usize, junk_len + 1);
        // MAX_FRAME_LEN - 2 bytes (a frame without its delimiters) still fit the buffer: a bad
        // frame, not an overflow.
        let overflow = junk_len >= MAX_FRAME_LEN - 1;
        assert_eq!(stats.overflows, u32::from(overflow), "{junk_len} bytes");
        assert_eq!(stats.frames_rejected(), 1);
    }
}

#[test]
fn foreign_version_and_bad_bodies_are_rejected_and_counted() {
    let msg = prediction(4);
    let mut body = [0u8; MAX_MESSAGE_LEN];
    let body = postcard::to_slice(&msg, &mut body).unwrap().to_vec();
    let foreign = frame_of(PROTOCOL_VERSION + 1, &body);
    let unknown_variant = frame_of(PROTOCOL_VERSION, &[5]);
    let trailing = frame_of(PROTOCOL_VERSION, &[&body[..], &[1]].concat());
    let too_short = [0x05, 1, 2, 3, 4, 0]; // four payload bytes: no room for version and CRC

    assert_eq!(decode(&mut foreign.clone()), Err(WireError::Version { found: PROTOCOL_VERSION + 1 }));
    assert_eq!(decode(&mut unknown_variant.clone()), Err(WireError::Decode));
    assert_eq!(decode(&mut trailing.clone()), Err(WireError::Decode));
    assert_eq!(decode(&mut too_short.clone()), Err(WireError::Crc));
    assert_eq!(decode(&mut [0x05, 0x01, 0x00][..]), Err(WireError::Cobs));
    assert_eq!(decode(&mut [0x02, 0x00, 0x01][..]), Err(WireError::Cobs), "zero inside");

    let good = encoded(&msg);
    let bad = [&foreign[..], &good, &unknown_variant, &trailing, &too_short, &[0x05, 0x01, 0x00], &good].concat();
    let mut decoder = FrameDecoder::new();
    assert_eq!(decode_all(&mut decoder, &bad), [msg.clone(), msg]);
    let stats = decoder.stats();
    let expected = DecoderStats {
        frames_ok: 2,
        crc_errors: 1,
        cobs_errors: 1,
        version_errors: 1,
        decode_errors: 2,
        overflows: 0,
        // Everything but the good frames, less the leading sync byte of the three rejected
        // frames built by `frame_of` (sync bytes are not data, so they are not discarded).
        bytes_discarded: (bad.len() - 2 * good.len() - 3) as u32,
    };
    assert_eq!(stats, expected);
}

#[test]
fn an_unterminated_tail_is_counted_when_the_stream_ends() {
    let mut d = FrameDecoder::new();
    assert_eq!(d.feed(&[b'A'; 1000]).count(), 0);
    assert_eq!((d.pending_len(), d.stats().bytes_discarded), (1000, 0));
    d.finish();
    assert_eq!((d.pending_len(), d.stats().bytes_discarded), (0, 1000));
    // An overlong tail already counted is not counted twice.
    let mut d = FrameDecoder::new();
    let _ = d.feed(&[b'A'; MAX_FRAME_LEN + 10]).count();
    let counted = d.stats().bytes_discarded;
    d.finish();
    assert_eq!(d.stats().bytes_discarded, counted);
}
