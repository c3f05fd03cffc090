//! Size budgets of core's state types (bytes), against the ECU's 128 KiB of RAM for the whole
//! edge image (docs/architecture.md, "Budgets"). Each bound is a budget, not a measurement: a change that grows a type
//! past it must be a decision, made here.

use core::mem::size_of;

use dynotraj_core::gt_ekf::{FixedLagRts, UnicycleEkf};
use dynotraj_core::metrics::{ForecastScores, RpeAccumulator};
use dynotraj_core::model::{LearnedPredictor, Scratch};
use dynotraj_core::predict::Forecast;
use dynotraj_core::wire::{FrameDecoder, MAX_FRAME_LEN, Message};
use dynotraj_edge::LinkDecoder;

fn report(name: &str, size: usize, budget: usize) {
    println!("{name:<28} {size:>6} B (budget {budget} B)");
    assert!(size <= budget, "{name} is {size} B, over its {budget} B budget");
}

#[test]
fn core_state_types_fit_their_budgets() {
    report("wire::MAX_FRAME_LEN", MAX_FRAME_LEN, 1_536);
    report("wire::FrameDecoder", size_of::<FrameDecoder>(), 1_536);
    report("wire::Message", size_of::<Message>(), 2_048);
    report("gt_ekf::UnicycleEkf", size_of::<UnicycleEkf>(), 128);
    report("gt_ekf::FixedLagRts<20>", size_of::<FixedLagRts<20>>(), 4_864);
    report("predict::Forecast", size_of::<Forecast>(), 240);
    report("metrics::ForecastScores", size_of::<ForecastScores>(), 64);
    report("metrics::RpeAccumulator", size_of::<RpeAccumulator>(), 128);
    report("edge::LinkDecoder", size_of::<LinkDecoder>(), 1_600);
    // Inference scratch is sized by the largest widths a blob may declare (MAX_ENC, MAX_DEC...),
    // so one predictor serves every model this build accepts.
    report("model::Scratch", size_of::<Scratch>(), 8_192);
    report("model::LearnedPredictor", size_of::<LearnedPredictor<'_>>(), 8_320);
    // One EKF per tracked object, the link state and one predictor (objects are forecast one
    // after another) stay far inside 128 KiB.
    let per_ecu = 16 * size_of::<UnicycleEkf>() + size_of::<LinkDecoder>() + size_of::<LearnedPredictor<'_>>();
    report("16 EKFs + edge + predictor", per_ecu, 128 * 1024);
}
