//! The tracks-file reader on arbitrary bytes: an error naming the offset, or tracks.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = dynotraj_formats::tracks_file::parse(Path::new("fuzz.dtt"), data);
});
