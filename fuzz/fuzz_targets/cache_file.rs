//! The estimate and rendering cache readers on arbitrary bytes (the key taken from the first
//! eight, so that the key check passes as often as it fails): a value or a miss, never a panic.
#![no_main]

use dynotraj_sources::estimation::EstimatedTracks;
use dynotraj_sources::estimation::{cache, rendered_cache};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let key = data.first_chunk::<8>().map_or(0, |k| u64::from_le_bytes(*k));
    let _ = cache::decode::<EstimatedTracks>(data, key);
    let _ = rendered_cache::decode_frames(data, key);
});
