//! The ETH/UCY recordings as shipped (../shared/trajectories/eth_ucy): every file read, the
//! benchmark's windows found, and constant velocity's and the untrained prior's figures on a
//! held-out scene as the benchmark prints them. Skips with a message when the data is absent.

use dynotraj_core::model::arch::Dims;
use dynotraj_core::predict::Dynamics;
use dynotraj_eval::pedestrian_benchmark::{BenchmarkOptions, RECORDINGS, SCENES, recording_path, run_scene};
use dynotraj_formats::eth_ucy::{PERIOD_S, read};
use dynotraj_sources::pedestrian_windows::windows;
use dynotraj_tests::shared_eth_ucy;
use dynotraj_train::Hyper;

#[test]
fn every_recording_reads_and_the_hotel_scene_scores_cv_as_the_field_does() {
    let Some(data) = shared_eth_ucy("ETH/UCY benchmark check") else { return };
    for name in RECORDINGS {
        for split in ["all_data", "train", "val"] {
            let r = read(&recording_path(&data, split, name)).unwrap();
            assert!(r.observations() > 400 && r.pedestrians() > 10, "{name} {split}: {r:?}");
        }
    }
    // Every window of the whole eth recording: 8 observed positions, 12 to come.
    let eth = read(&recording_path(&data, "all_data", "biwi_eth")).unwrap();
    let w = windows(&eth, PERIOD_S);
    assert_eq!(w.len(), 364);
    assert!(w.iter().all(|w| w.history.len() == 8 && w.future.len() == 12));
    // The hotel scene without training: cv is the standard baseline, about 0.3 m ADE (the
    // field's constant-velocity figures on hotel are 0.3-0.4 m), and the prior tuned on the other
    // recordings stays within a few percent of it.
    let options = BenchmarkOptions {
        data,
        scenes: vec!["hotel".into()],
        dims: Dims::DEFAULT,
        hyper: Hyper::default(),
        dynamics: Dynamics::SingleIntegrator,
        train: false,
    };
    let hotel = SCENES.into_iter().find(|s| s.name == "hotel").unwrap();
    let r = run_scene(hotel, &options, &mut |_| {}).unwrap();
    let cv = r.total("cv").unwrap().ade.value().unwrap();
    let prior = r.total("prior").unwrap().ade.value().unwrap();
    eprintln!("hotel: {} windows, cv ADE {cv:.3}, prior ADE {prior:.3}", r.windows);
    assert_eq!(r.windows, 1197);
    assert!((0.25..0.40).contains(&cv), "cv ADE {cv}");
    assert!((prior / cv - 1.0).abs() < 0.05, "prior {prior} against cv {cv}");
}
