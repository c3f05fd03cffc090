//! The estimator profiles are what runs: the edge (firmware and host builds) estimates with the
//! edge profile's parameters and window, and `dynotraj estimate --profile edge` with the same,
//! so the accuracy the host reports for the edge profile is the ECU's.

use dynotraj_core::estimate::{EDGE_PROFILE, EDGE_WINDOW, HOST_PROFILE, Intrinsics};
use dynotraj_core::limits::PAPER_FRAME_RATE_HZ;
use dynotraj_edge::Pipeline;
use dynotraj_sources::estimation::from_images::{render_camera, rendered_params};
use dynotraj_sources::estimation::simulated::EvalOptions;

#[test]
fn the_edge_runs_the_edge_profile() {
    let dt = 1.0 / PAPER_FRAME_RATE_HZ;
    let edge: Box<Pipeline<'_>> = Box::default();
    assert_eq!(edge.estimator().params(), &EDGE_PROFILE.params(Intrinsics::KITTI_0926, dt));
    assert_eq!(EDGE_WINDOW, EDGE_PROFILE.window);
    assert_eq!(dynotraj_edge::EDGE_WINDOW, EDGE_PROFILE.window);
}

#[test]
fn the_host_runs_each_profile_as_named() {
    let dt = 1.0 / PAPER_FRAME_RATE_HZ;
    let camera = render_camera(1.0).intrinsics();
    for profile in [HOST_PROFILE, EDGE_PROFILE] {
        let opt = EvalOptions::kitti(dt).with_profile(profile);
        assert_eq!((opt.window, opt.profile), (profile.window, profile.name));
        assert_eq!(rendered_params(1.0, &opt), profile.params(camera, dt), "{} profile", profile.name);
    }
    assert_ne!(HOST_PROFILE.params(camera, dt), EDGE_PROFILE.params(camera, dt));
}
