//! The int8 model is held to the float model on real forecasts: a model trained briefly on
//! KITTI labels (all sequences but 0000), then both precisions forecast every test instance of
//! 0000 and 0003. Mean ADE must differ by at most 2 cm; the largest per-step deviation is
//! printed.

use dynotraj_core::limits::HORIZON;
use dynotraj_core::metrics::ade;
use dynotraj_core::model::blob::Precision;
use dynotraj_core::predict::Predictor as _;
use dynotraj_core::{BevState, Point2};
use dynotraj_formats::kitti::TrackingDir;
use dynotraj_formats::model_file::ModelFile;
use dynotraj_sources::sequence::load_ground_truth;
use dynotraj_sources::trajectory::{EligibilityRule, Source, eligible_runs};
use dynotraj_tests::kitti_training_dir;
use dynotraj_train::{TrainConfig, train_fold};

#[test]
fn int8_forecasts_stay_within_two_centimetres_of_float() {
    let Some(root) = kitti_training_dir() else { return };
    let dir = TrackingDir::open(&root).unwrap();
    let dt = 0.05;
    let seqs: Vec<_> = dir.sequences().unwrap().iter().map(|id| load_ground_truth(&dir, id, dt).unwrap()).collect();
    let mut config = TrainConfig::new(&seqs, vec!["0000".into(), "0003".into()], Source::Gt);
    config.hyper.epochs = 1;
    // Keep the trained epoch even where the untrained model (zero controls) scores better:
    // that one would make the comparison trivial.
    config.hyper.keep_untrained_if_better = false;
    // Full-strength trained outputs, and one epoch over the instances as they are: this test
    // is about quantisation, not about training well.
    config.hyper.shrink = false;
    config.mirror = false;
    let model = train_fold(&config).unwrap();
    assert_eq!(model.report.best_epoch, 1, "the trained epoch must be kept");
    let f32_file = ModelFile::from_bytes(model.blob(Precision::F32).unwrap(), "f32").unwrap();
    let int8_file = ModelFile::from_bytes(model.blob(Precision::Int8).unwrap(), "int8").unwrap();
    let (mut pf, mut pq) = (f32_file.predictor(), int8_file.predictor());

    let (mut sum_diff, mut n, mut worst_step) = (0.0f64, 0usize, 0.0f32);
    for seq in seqs.iter().filter(|s| s.id == "0000" || s.id == "0003") {
        let scene = seq.scene(Source::Gt, dt);
        for run in eligible_runs(&seq.tracks, &EligibilityRule::default()) {
            let sourced = scene.run_at(run.track_id, run.first_frame).unwrap();
            for s in run.instances() {
                let neighbours = scene.neighbours_at(run.track_id, run.first_frame + s as u32);
                let history = &sourced.states[..=s];
                let truth: Vec<Point2> = sourced.states[s + 1..=s + HORIZON].iter().map(BevState::position).collect();
                let (mut a, mut b) = ([Point2::default(); HORIZON], [Point2::default(); HORIZON]);
                let context = scene.context_at(&neighbours, run.first_frame + s as u32);
                pf.predict_in_context(history, &context, dt, &mut a).unwrap();
                pq.predict_in_context(history, &context, dt, &mut b).unwrap();
                sum_diff += f64::from((ade(&a, &truth).unwrap() - ade(&b, &truth).unwrap()).abs());
                worst_step = a.iter().zip(&b).map(|(p, q)| p.distance(q)).fold(worst_step, f32::max);
                n += 1;
            }
        }
    }
    let mean = sum_diff / n as f64;
    println!(
        "{n} instances: mean |ADE f32 - ADE int8| = {:.4} m, largest per-step deviation {:.4} m",
        mean, worst_step
    );
    assert!(n > 300);
    assert!(mean <= 0.02, "int8 strays {mean} m from float on average");
}
