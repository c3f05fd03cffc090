//! Accuracy of the estimator on the track-level simulator: a synthetic drive (always), and the
//! first frames of a real KITTI sequence's labels and ego poses (when `../shared/kitti` is
//! there). Noise-free tracks must give a near-exact camera and objects; noisy tracks must stay
//! within bounds, with the smoother no worse than frame-to-frame.

use std::collections::BTreeSet;

use dynotraj_core::estimate::{DEFAULT_WINDOW, EstimatorParams, Intrinsics};
use dynotraj_sim::drive::{DriveSpec, generate};
use dynotraj_sim::track_sim::{LabelBox, SimFrame, SimSpec, simulate};
use dynotraj_sources::estimation::runner::{EstimatorRun, Kind, run_estimator};
use dynotraj_sources::estimation::score::{RunScores, moving_objects, score_run};

fn run(frames: &[SimFrame], spec: &SimSpec) -> (EstimatorRun, RunScores, BTreeSet<u16>) {
    let mut params = EstimatorParams::kitti(spec.intrinsics, spec.dt as f32);
    params.pixel_sigma = spec.pixel_sigma.max(0.1) as f32;
    params.disparity_sigma = spec.disparity_sigma.max(0.1) as f32;
    let run = run_estimator::<DEFAULT_WINDOW>(frames, params, 7);
    let moving = moving_objects(frames, 0.1);
    let scores = score_run(frames, &run, &moving);
    (run, scores, moving)
}

fn print(name: &str, s: &RunScores) {
    for (k, kind) in Kind::ALL.iter().enumerate() {
        let c = s.kinds[k].camera.expect("camera scored");
        let o = s.kinds[k].object;
        println!(
            "{name} {:>9}: camera {:.4} m {:.4} deg, objects {} of {}: {:?}",
            kind.name(),
            c.translation,
            c.rotation.to_degrees(),
            s.kinds[k].objects,
            s.moving_objects,
            o.map(|o| (o.translation, o.rotation.to_degrees(), o.pairs))
        );
    }
}

fn drive_frames(spec: &SimSpec) -> Vec<SimFrame> {
    let drive = generate(&DriveSpec { frames: 80, ..DriveSpec::default() });
    simulate(&drive.camera_poses, &LabelBox::of_drive(&drive), spec)
}

#[test]
fn noise_free_tracks_give_a_near_exact_camera_and_objects() {
    let spec = SimSpec::kitti(Intrinsics::KITTI_0926, (1242.0, 375.0), 0.1, 1).noise_free();
    let frames = drive_frames(&spec);
    let (run, s, moving) = run(&frames, &spec);
    print("noise-free", &s);
    assert_eq!(moving.len(), 2, "the overtaking car and the cyclist move");
    for k in 0..3 {
        let c = s.kinds[k].camera.expect("camera");
        assert!(c.translation < 0.002 && c.rotation.to_degrees() < 0.01, "{c:?}");
        let o = s.kinds[k].object.expect("objects");
        assert!(o.translation < 0.03 && o.rotation.to_degrees() < 0.2, "{:?}: {o:?}", Kind::ALL[k]);
    }
    assert_eq!(run.stats.camera_motion_held, 0);
}

#[test]
fn noisy_tracks_stay_bounded_and_the_smoother_helps() {
    let spec = SimSpec::kitti(Intrinsics::KITTI_0926, (1242.0, 375.0), 0.1, 2);
    let frames = drive_frames(&spec);
    let (_, s, _) = run(&frames, &spec);
    print("noisy", &s);
    let cam = s.kinds[2].camera.expect("camera");
    assert!(cam.translation < 0.01 && cam.rotation.to_degrees() < 0.05, "{cam:?}");
    let f2f = s.kinds[0].object.expect("objects");
    let smoothed = s.kinds[2].object.expect("objects");
    assert!(smoothed.translation < 0.2 && smoothed.rotation.to_degrees() < 1.0, "{smoothed:?}");
    assert!(smoothed.translation <= f2f.translation, "smoothed {smoothed:?} vs f2f {f2f:?}");
}

#[test]
fn real_kitti_labels_and_ego_poses_first_frames() {
    let Some(dir) = dynotraj_tests::kitti_training_dir() else { return };
    let data =
        dynotraj_formats::kitti::TrackingDir::open(&dir).expect("opens").load_sequence("0020").expect("loads 0020");
    let input = dynotraj_sources::estimation::input::sim_input(&data, &dynotraj_core::wire::ObjectClass::KITTI);
    let n = 120;
    let boxes: Vec<LabelBox> = input.boxes.iter().filter(|b| (b.frame as usize) < n).copied().collect();
    let spec = SimSpec::kitti(input.intrinsics, (1242.0, 375.0), 0.1, 3);
    let frames = simulate(&input.camera_poses[..n], &boxes, &spec);
    let (_, s, _) = run(&frames, &spec);
    print("kitti 0020", &s);
    let cam = s.kinds[2].camera.expect("camera");
    assert!(cam.translation < 0.01, "{cam:?}");
    let f2f = s.kinds[0].object.expect("objects");
    let smoothed = s.kinds[2].object.expect("objects");
    assert!(
        smoothed.translation < 0.3 && smoothed.translation < f2f.translation,
        "smoothed {smoothed:?} vs f2f {f2f:?}"
    );
}
