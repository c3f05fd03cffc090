//! The model-blob loader on arbitrary bytes; an accepted blob must also run a forecast without
//! panicking. An odd first byte of the input asks for the CRC to be repaired first, so the fuzzer
//! gets past the checksum to the header checks and to inference on arbitrary weights.
#![no_main]

use dynotraj_core::BevState;
use dynotraj_core::model::blob::ModelBlob;
use dynotraj_core::model::infer::LearnedPredictor;
use dynotraj_core::predict::Predictor;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|input: &[u8]| {
    let Some((&mode, data)) = input.split_first() else { return };
    let mut data = data.to_vec();
    if mode & 1 == 1 {
        repair_crc(&mut data);
    }
    if let Ok(blob) = ModelBlob::parse(&data) {
        let dt = blob.frame_period_s();
        let mut p = LearnedPredictor::new(blob);
        let history = [
            BevState { x: 0.0, y: 0.0, heading: 0.0, speed: 5.0 },
            BevState { x: 5.0 * dt, y: 0.0, heading: 0.0, speed: 5.0 },
        ];
        let mut out = [dynotraj_core::Point2::default(); dynotraj_core::limits::HORIZON];
        let _ = p.predict(&history, dt, &mut out);
    }
});

/// Writes the right CRC after the payload the header claims, where the input is long enough.
fn repair_crc(data: &mut [u8]) {
    let Some(len) = data.get(28..32).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize) else { return };
    let end = 32usize.saturating_add(len);
    if end.saturating_add(4) <= data.len() {
        let crc = dynotraj_core::wire::crc32(&data[..end]).to_le_bytes();
        data[end..end + 4].copy_from_slice(&crc);
    }
}
