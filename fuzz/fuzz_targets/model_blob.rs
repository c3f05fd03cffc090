//! The model-blob loader on arbitrary bytes; an accepted blob must also run a forecast without
//! panicking.
#![no_main]

use dynotraj_core::BevState;
use dynotraj_core::model::blob::ModelBlob;
use dynotraj_core::model::infer::LearnedPredictor;
use dynotraj_core::predict::Predictor;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(blob) = ModelBlob::parse(data) {
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
