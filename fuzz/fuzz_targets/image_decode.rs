//! The bag import's PNG and JPEG decoding on arbitrary bytes, within its size limits: an image
//! or an error, never a panic or an allocation a header asks for.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = dynotraj_bag::import::decode_compressed_image(data);
});
