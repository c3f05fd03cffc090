//! RAM of the estimator against the ECU budget (docs/architecture.md, "Budgets": 128 KiB for
//! the whole edge image with 16 objects x 128 points + 256 static tracks). The estimator's state is every byte it keeps
//! between frames and all its scratch: it allocates nothing and its stack use is a few KiB.
//! Each bound is a budget, not a measurement: growing past it must be a decision, made here.

use core::mem::size_of;

use dynotraj_core::estimate::frame::FrameBuffer;
use dynotraj_core::estimate::joint::JointScratch;
use dynotraj_core::estimate::{
    ChainScratch, ChainSmoother, DEFAULT_WINDOW, EDGE_WINDOW, Estimator, Landmarks, ObjectRun, PoseEstimate,
};
use dynotraj_core::model::LearnedPredictor;
use dynotraj_edge::LinkDecoder;

fn report(name: &str, size: usize, budget: usize) {
    println!("{name:<40} {size:>7} B (budget {budget} B)");
    assert!(size <= budget, "{name} is {size} B, over its {budget} B budget");
}

#[test]
fn estimator_state_fits_the_ecu_budget() {
    const W: usize = DEFAULT_WINDOW;
    report("estimate::FrameBuffer (one frame)", size_of::<FrameBuffer>(), 28 * 1024);
    report("estimate::Landmarks (one object)", size_of::<Landmarks>(), 1_600);
    report("estimate::ChainSmoother<20>", size_of::<ChainSmoother<W>>(), 2_800);
    report("estimate::ObjectRun<20>", size_of::<ObjectRun<W>>(), 4_900);
    report("estimate::ChainScratch<20>", size_of::<ChainScratch<W>>(), 2_304);
    report("estimate::JointScratch<20>", size_of::<JointScratch<W>>(), 3_200);
    report("estimate::PoseEstimate", size_of::<PoseEstimate>(), 1_600);
    // The default window (DynoSAM's 20 frames) is for the host; it does not fit the ECU.
    let host = size_of::<Estimator<W>>();
    report("estimate::Estimator<20> (host)", host, 124 * 1024);
    // The firmware's window: the whole edge image, estimator, link loop and one predictor, with
    // 8 KiB left for the stack (painted-stack measurements of the firmware belong to the edge
    // crate).
    let est = size_of::<Estimator<EDGE_WINDOW>>();
    report("estimate::Estimator<EDGE_WINDOW> (firmware, edge profile)", est, 100 * 1024);
    let image = est + size_of::<LinkDecoder>() + size_of::<LearnedPredictor<'_>>() + 8 * 1024;
    report("estimator<EDGE> + edge + predictor + 8 KiB stack", image, 128 * 1024);
    // Each frame of window costs what the constant's docs say (about 2.5 KiB).
    let per_frame = (host - est) / (W - EDGE_WINDOW);
    report("bytes per frame of window", per_frame, 2_600);
}
