//! The MCAP container check of the bag import on arbitrary bytes (every record's length against
//! the file and the limits, a chunk's decompressed size), then, as the import does, every
//! message read and its payload decompressed when zstd: a verdict, never a panic or an
//! allocation the bytes ask for.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = dynotraj_bag::import::container::read_messages(data);
});
