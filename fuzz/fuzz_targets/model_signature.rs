//! The model-signature check on arbitrary bytes: never a panic; what it accepts (the seeds hold
//! a blob signed by the development key) goes on to the blob parser. An odd first byte of the input asks for a
//! well-formed trailer naming the trusted key to be written over the end, so the fuzzer gets
//! past the format checks to the curve arithmetic on arbitrary signatures.
#![no_main]

use dynotraj_core::model::signed;
use dynotraj_edge::provisioned::MODEL_KEY;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|input: &[u8]| {
    let Some((&mode, data)) = input.split_first() else { return };
    let mut data = data.to_vec();
    if mode & 1 == 1 {
        write_trailer(&mut data);
    }
    if let Ok(blob) = signed::verify(&data, &MODEL_KEY) {
        let _ = dynotraj_core::model::blob::ModelBlob::parse(blob);
    }
});

/// Overwrites the end of `data` with the magic and the trusted key's id (keeping the fuzzed
/// signature bytes), where the input is long enough.
fn write_trailer(data: &mut [u8]) {
    if let Some(at) = data.len().checked_sub(signed::TRAILER_LEN) {
        data[at..at + 4].copy_from_slice(&signed::SIGNATURE_MAGIC);
        data[at + 4..at + 12].copy_from_slice(&signed::key_id(&MODEL_KEY));
    }
}
