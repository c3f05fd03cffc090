//! The link's frame decoder on arbitrary bytes, cut at an arbitrary point: no panic, every
//! returned message counted, nothing pending after a final delimiter.
#![no_main]

use dynotraj_core::wire::FrameDecoder;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let cut = usize::from(data.first().copied().unwrap_or(0)).min(data.len());
    let (a, b) = data.split_at(cut);
    let mut dec = FrameDecoder::new();
    let mut n = 0u32;
    for chunk in [a, b, &[0u8][..]] {
        n += dec.feed(chunk).count() as u32;
    }
    assert_eq!(n, dec.stats().frames_ok);
    assert_eq!(dec.pending_len(), 0);
});
