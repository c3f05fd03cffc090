//! The KITTI oxts parser on arbitrary text: an error or a value, never a panic.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = dynotraj_formats::kitti::parse_oxts(text, Path::new("fuzz.txt"));
    }
});
