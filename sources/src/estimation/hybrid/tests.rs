use dynotraj_core::estimate::ObjectEstimate;
use dynotraj_core::geometry::Pose3;
use dynotraj_core::metrics::RpeAccumulator;
use dynotraj_core::wire::ObjectClass;
use nalgebra::{Translation3, UnitQuaternion};

use super::*;

const FRAMES: usize = 60;
const WINDOW: usize = 8;

/// A car driving at 10 m/s (1 m per frame) along a gentle curve, seen by a camera at rest.
fn truth(k: usize) -> Pose3 {
    let t = k as f32;
    let yaw = 0.01 * t;
    Pose3::from_parts(
        Translation3::new(t, 0.0, 20.0 + 0.005 * t * t),
        UnitQuaternion::from_axis_angle(&-nalgebra::Vector3::y_axis(), yaw),
    )
}

/// A deterministic noise in [-1, 1].
fn noise(k: usize, axis: usize) -> f32 {
    let x = ((k * 7919 + axis * 104_729) % 1000) as f32 / 500.0 - 1.0;
    x * x.abs()
}

/// A run whose causal estimates hold the object at its fits, each fit the truth moved by
/// `sigma` times the noise along every axis (and a tenth of it in radians).
fn run_with_fits(sigma: f32) -> EstimatorRun {
    let mut run = EstimatorRun::empty(FRAMES);
    let info_t = 1.0 / (sigma * sigma).max(1e-6);
    let info = Mat6::from_diagonal(&Vec6::new(
        f64::from(info_t),
        f64::from(info_t),
        f64::from(info_t),
        f64::from(100.0 * info_t),
        f64::from(100.0 * info_t),
        f64::from(100.0 * info_t),
    ));
    for k in 0..FRAMES {
        let d = Vector6::from_fn(|i, _| noise(k, i) * if i < 3 { sigma } else { 0.1 * sigma });
        let fitted = truth(k) * se3_exp(&d);
        let mut e = PoseEstimate::new();
        e.frame = k as u32;
        let object = ObjectEstimate {
            object_id: 3,
            class: ObjectClass::Car,
            pose: fitted,
            motion: Pose3::identity(),
            bev: dynotraj_core::BevState::default(),
            heading_rate: 0.0,
            segment: 1,
            orientation: 1,
            heading_known: true,
        };
        e.objects.push(object).unwrap();
        run.causal[k] = Some(e.clone());
        run.smoothed[k] = Some(e);
        let information: [[f32; 6]; 6] = info.cast::<f32>().into();
        let previous_camera_from_object = run.fits.get(k.wrapping_sub(1)).map(|f| f[0].camera_from_object);
        run.fits[k].push(NewestFit {
            object_id: 3,
            class: ObjectClass::Car,
            orientation: 1,
            heading_known: true,
            camera_from_object: fitted,
            previous_camera_from_object,
            information,
        });
    }
    run
}

fn params() -> HybridParams {
    HybridParams {
        window: WINDOW,
        smoothness: [2500.0, 2500.0, 2500.0, 2.5e5, 2.5e5, 2.5e5],
        kinematic: [0.0, 100.0, 100.0, 1e4, 0.0, 1e4],
        fit_weight: 1.0,
    }
}

fn rpe(est: &[Option<PoseEstimate>]) -> f64 {
    let mut acc = RpeAccumulator::new();
    for (k, e) in est.iter().enumerate() {
        acc.push(&truth(k), &e.as_ref().unwrap().objects[0].pose);
    }
    acc.result().unwrap().translation
}

#[test]
fn exact_fits_are_kept() {
    let mut run = run_with_fits(0.0);
    let counts = rewrite(&mut run, &params());
    assert_eq!((counts.causal, counts.smoothed, counts.causal_left_out, counts.failed_solves), (FRAMES, FRAMES, 0, 0));
    for (k, e) in run.causal.iter().chain(&run.smoothed).enumerate() {
        let p = e.as_ref().unwrap().objects[0].pose;
        let t = truth(k % FRAMES);
        assert!((p.translation.vector - t.translation.vector).norm() < 1e-3, "frame {k}: {p:?} against {t:?}");
    }
}

#[test]
fn noisy_fits_are_smoothed_and_the_smoothed_poses_more_so() {
    let mut run = run_with_fits(0.3);
    let raw = rpe(&run.causal);
    rewrite(&mut run, &params());
    let (causal, smoothed) = (rpe(&run.causal), rpe(&run.smoothed));
    assert!(causal < 0.6 * raw, "causal RPE {causal:.3} m against the fits' {raw:.3} m");
    assert!(smoothed < causal, "smoothed RPE {smoothed:.3} m against causal {causal:.3} m");
}

/// Turns the object frame by a quarter turn from frame 30 on, as the estimator does: its
/// estimates from 30 and its smoothed ones still in its window (from 24, the window's
/// eight frames less the one that left it at 30) in the new frame.
fn turned_at_30(run: &mut EstimatorRun) -> Pose3 {
    let r = Pose3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_axis_angle(&-nalgebra::Vector3::y_axis(), std::f32::consts::FRAC_PI_2),
    );
    let turn = |e: &mut Option<PoseEstimate>| {
        for o in e.iter_mut().flat_map(|e| e.objects.iter_mut()) {
            o.orientation = 2;
            o.pose *= r;
        }
    };
    for k in 30..FRAMES {
        turn(&mut run.causal[k]);
        turn(&mut run.smoothed[k]);
        let f = &mut run.fits[k][0];
        f.orientation = 2;
        f.camera_from_object *= r;
        f.previous_camera_from_object = f.previous_camera_from_object.map(|m| m * r);
    }
    for k in 24..30 {
        turn(&mut run.smoothed[k]);
    }
    r
}

#[test]
fn a_turned_object_frame_turns_the_window() {
    let mut run = run_with_fits(0.0);
    let r = turned_at_30(&mut run);
    let counts = rewrite(&mut run, &params());
    assert_eq!(
        (counts.causal, counts.smoothed, counts.causal_left_out, counts.smoothed_left_out),
        (FRAMES, FRAMES, 0, 0)
    );
    for (kind, est) in [("causal", &run.causal), ("smoothed", &run.smoothed)] {
        for (k, e) in est.iter().enumerate() {
            let o = &e.as_ref().unwrap().objects[0];
            let t = if o.orientation == 2 { truth(k) * r } else { truth(k) };
            let (dt, dr) =
                ((o.pose.translation.vector - t.translation.vector).norm(), o.pose.rotation.angle_to(&t.rotation));
            assert!(dt < 5e-3 && dr < 1e-3, "{kind} frame {k}: {dt} m, {dr} rad off");
        }
    }
}

#[test]
fn a_turn_without_a_fit_starts_a_new_window() {
    let mut run = run_with_fits(0.0);
    turned_at_30(&mut run);
    // Frame 30 of the new orientation has no fit: nothing to start from, it is left out; so
    // are the smoothed frames the estimator turned and the old window did not.
    run.fits[30].clear();
    let counts = rewrite(&mut run, &params());
    assert_eq!((counts.causal, counts.causal_left_out), (FRAMES - 1, 1));
    assert_eq!((counts.smoothed, counts.smoothed_left_out), (FRAMES - 7, 7));
    assert!(run.causal[30].as_ref().unwrap().objects.is_empty());
    assert!(run.smoothed[30].as_ref().unwrap().objects.is_empty());
}
