//! Property tests of the two byte-level input boundaries of the edge: the link's frame decoder
//! and the model-blob loader. Any bytes, cut into any chunks: no panic, every message the decoder
//! returns is counted, garbage never hides the next good frame, and a blob with any byte changed
//! is refused.

use dynotraj_core::geometry::Point2;
use dynotraj_core::limits::HORIZON;
use dynotraj_core::model::arch::Dims;
use dynotraj_core::model::blob::{ModelBlob, Precision, blob_len, write_blob};
use dynotraj_core::model::signed;
use dynotraj_core::wire::{FrameBuf, FrameDecoder, MAX_FRAME_LEN, Message, Prediction, encode};
use proptest::prelude::*;

fn prediction(frame: u32) -> Message {
    Message::Prediction(Prediction {
        frame,
        object_id: 3,
        dt: 0.05,
        points: (0..HORIZON).map(|k| Point2::new(k as f32, -(k as f32))).collect(),
    })
}

fn frame_bytes(msg: &Message) -> Vec<u8> {
    let mut buf: FrameBuf = [0; MAX_FRAME_LEN];
    let n = encode(msg, &mut buf).unwrap();
    buf[..n].to_vec()
}

/// Feeds `bytes` in chunks of the given sizes (cycled) and returns the messages.
fn feed_chunked(dec: &mut FrameDecoder, bytes: &[u8], cuts: &[usize]) -> Vec<Message> {
    let mut out = Vec::new();
    let mut rest = bytes;
    let mut i = 0;
    while !rest.is_empty() {
        let n = cuts.get(i % cuts.len().max(1)).copied().unwrap_or(rest.len()).clamp(1, rest.len());
        let (head, tail) = rest.split_at(n);
        out.extend(dec.feed(head));
        rest = tail;
        i += 1;
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn any_bytes_decode_without_panic_and_every_message_is_counted(
        bytes in prop::collection::vec(any::<u8>(), 0..8000),
        cuts in prop::collection::vec(1usize..2000, 1..8),
    ) {
        let mut dec = FrameDecoder::new();
        let got = feed_chunked(&mut dec, &bytes, &cuts);
        prop_assert_eq!(got.len() as u32, dec.stats().frames_ok);
    }

    #[test]
    fn garbage_never_hides_the_next_good_frame(
        garbage in prop::collection::vec(any::<u8>(), 0..4000),
        cuts in prop::collection::vec(1usize..600, 1..6),
        frame in any::<u32>(),
    ) {
        let good = prediction(frame);
        let mut stream = garbage.clone();
        stream.extend(frame_bytes(&good));
        let mut dec = FrameDecoder::new();
        let got = feed_chunked(&mut dec, &stream, &cuts);
        // The garbage may itself hold valid frames by chance; the good one must be the last.
        prop_assert_eq!(got.last(), Some(&good));
        prop_assert_eq!(dec.pending_len(), 0);
    }

    #[test]
    fn flipped_bytes_cost_only_their_frame(
        at in any::<prop::sample::Index>(),
        flip in 1u8..=255,
    ) {
        let [a, b, c] = [prediction(1), prediction(2), prediction(3)].map(|m| frame_bytes(&m));
        let mut stream = [a.clone(), b.clone(), c.clone()].concat();
        // Corrupt a byte of the middle frame.
        let i = a.len() + at.index(b.len());
        stream[i] ^= flip;
        let mut dec = FrameDecoder::new();
        let got: Vec<_> = dec.feed(&stream).collect();
        prop_assert_eq!(got.first(), Some(&prediction(1)));
        prop_assert_eq!(got.last(), Some(&prediction(3)));
        // Either the middle frame is lost (and counted) or the change was in a byte COBS
        // ignores... which it has none of: every byte counts, so exactly two survive.
        prop_assert_eq!(got.len(), 2);
        // Whatever was lost is counted: every frame is either delivered or rejected.
        let s = dec.stats();
        prop_assert_eq!(s.frames_ok, 2);
        prop_assert!(s.frames_rejected() >= 1, "{:?}", s);
    }

    #[test]
    fn any_bytes_are_refused_or_parsed_as_a_blob(bytes in prop::collection::vec(any::<u8>(), 0..4000)) {
        let _ = ModelBlob::parse(&bytes);
    }

    /// Arbitrary bytes, also ones ending in a well-formed trailer naming the trusted key, are
    /// never accepted as signed and never panic the verifier.
    #[test]
    fn any_bytes_are_refused_by_the_signature_check(
        mut bytes in prop::collection::vec(any::<u8>(), 0..600),
        with_trailer in any::<bool>(),
    ) {
        let key = dynotraj_edge::provisioned::MODEL_KEY;
        if with_trailer && bytes.len() >= signed::TRAILER_LEN {
            let at = bytes.len() - signed::TRAILER_LEN;
            bytes[at..at + 4].copy_from_slice(&signed::SIGNATURE_MAGIC);
            bytes[at + 4..at + 12].copy_from_slice(&signed::key_id(&key));
        }
        prop_assert!(signed::verify(&bytes, &key).is_err());
    }
}

/// A real blob with any single byte changed is refused (the CRC covers everything).
#[test]
fn every_single_byte_change_of_a_blob_is_refused() {
    let dims = Dims { enc: 4, edge: 4, k: 2, dec: 8 };
    let tensors: Vec<Vec<f32>> = dims
        .tensors()
        .iter()
        .map(|&(r, c)| (0..r * c).map(|i| ((i * 37 % 101) as f32 - 50.0) / 100.0).collect())
        .collect();
    let slices: Vec<&[f32]> = tensors.iter().map(Vec::as_slice).collect();
    for precision in [Precision::F32, Precision::Int8] {
        let mut blob = vec![0u8; blob_len(&dims, precision)];
        write_blob(&dims, precision, 0.05, &dynotraj_core::predict::PriorSettings::DEFAULT, &slices, &mut blob)
            .unwrap();
        assert!(ModelBlob::parse(&blob).is_ok());
        for i in 0..blob.len() {
            blob[i] ^= 0x5a;
            assert!(ModelBlob::parse(&blob).is_err(), "{precision:?}: byte {i} changed, still accepted");
            blob[i] ^= 0x5a;
        }
    }
}
