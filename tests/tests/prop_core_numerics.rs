//! Property tests of the core numerics on hostile input: angle wrapping, SE(3) exp/log, the
//! unicycle limits, the EKF and its fixed-lag smoother with missing and non-finite measurements,
//! the baselines, the metrics and the minimal pose solver on degenerate point sets (0-2 points,
//! identical, collinear, NaN, infinite, very large). The outputs must stay finite (or the call
//! must refuse) and nothing may panic.

use core::f32::consts::PI;

use dynotraj_core::estimate::rigid_from_three;
use dynotraj_core::geometry::{angle_diff, se3_exp, se3_log, wrap_angle};
use dynotraj_core::gt_ekf::{EkfParams, FixedLagRts, Measurement, UnicycleEkf};
use dynotraj_core::limits::{HORIZON, MAX_ACCEL, MAX_TURN_RATE};
use dynotraj_core::metrics::{ace, ade, fde};
use dynotraj_core::predict::{Forecast, constant_velocity, ctra, unicycle_step};
use dynotraj_core::{BevState, Point2};
use nalgebra::{Vector3, Vector6};
use proptest::prelude::*;

/// Any f32 at all, the awkward values made common.
fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -1.0e3f32..1.0e3,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(0.0f32),
        1 => prop::num::f32::ANY,
        1 => prop_oneof![Just(f32::MAX), Just(f32::MIN), Just(1.0e30f32), Just(-1.0e30f32)],
    ]
}

fn finite_f32(range: f32) -> impl Strategy<Value = f32> {
    -range..range
}

fn any_state() -> impl Strategy<Value = BevState> {
    (any_f32(), any_f32(), any_f32(), any_f32()).prop_map(|(x, y, heading, speed)| BevState { x, y, heading, speed })
}

fn any_measurement() -> impl Strategy<Value = Measurement> {
    (
        prop::option::of((any_f32(), any_f32()).prop_map(|(x, y)| Point2::new(x, y))),
        prop::option::of(any_f32()),
        prop::option::of(any_f32()),
    )
        .prop_map(|(position, heading, speed)| Measurement { position, heading, speed })
}

fn any_point3() -> impl Strategy<Value = Vector3<f32>> {
    (any_f32(), any_f32(), any_f32()).prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

fn state_is_finite(s: &BevState) -> bool {
    s.x.is_finite() && s.y.is_finite() && s.heading.is_finite() && s.speed.is_finite()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn wrapped_angles_lie_in_minus_pi_to_pi(a in finite_f32(1.0e4), b in finite_f32(1.0e4)) {
        let w = wrap_angle(a);
        prop_assert!((-PI..=PI).contains(&w), "wrap({a}) = {w}");
        // Same direction as the input (tolerance grows with |a|: f32 has ~7 digits).
        let tol = 1e-3 + a.abs() * 4.0 * f32::EPSILON;
        prop_assert!((w.sin() - a.sin()).abs() < tol && (w.cos() - a.cos()).abs() < tol);
        let d = angle_diff(a, b);
        prop_assert!((-PI..=PI).contains(&d), "diff({a}, {b}) = {d}");
    }

    #[test]
    fn wrapping_non_finite_angles_does_not_panic(a in any_f32(), b in any_f32()) {
        let _ = wrap_angle(a);
        let _ = angle_diff(a, b);
    }

    #[test]
    fn se3_log_inverts_exp_below_pi(
        rho in prop::array::uniform3(finite_f32(50.0)),
        axis in prop::array::uniform3(finite_f32(1.0)),
        angle in 0.0f32..3.0,
    ) {
        let n = Vector3::from(axis);
        prop_assume!(n.norm() > 1e-3);
        let w = n.normalize() * angle;
        let xi = Vector6::new(rho[0], rho[1], rho[2], w.x, w.y, w.z);
        let back = se3_log(&se3_exp(&xi));
        let err = (back - xi).norm();
        prop_assert!(err < 1e-3 * (1.0 + xi.norm()), "xi {xi:?} -> {back:?}");
    }

    #[test]
    fn se3_of_any_twist_does_not_panic(xi in prop::array::uniform6(any_f32())) {
        let p = se3_exp(&Vector6::from(xi));
        let _ = se3_log(&p);
    }

    #[test]
    fn unicycle_steps_respect_the_limits(
        s in (finite_f32(1e3), finite_f32(1e3), finite_f32(10.0), 0.0f32..40.0)
            .prop_map(|(x, y, heading, speed)| BevState { x, y, heading, speed }),
        turn in any_f32(),
        accel in any_f32(),
        dt in 0.01f32..0.2,
    ) {
        let next = unicycle_step(&s, turn, accel, dt);
        if turn.is_finite() && accel.is_finite() {
            prop_assert!(state_is_finite(&next), "{s:?} {turn} {accel} -> {next:?}");
            let dv = next.speed - s.speed;
            prop_assert!(dv.abs() <= MAX_ACCEL * dt * (1.0 + 1e-4) + 1e-4, "dv {dv}");
            let dh = angle_diff(next.heading, s.heading);
            prop_assert!(dh.abs() <= MAX_TURN_RATE * dt * (1.0 + 1e-4) + 1e-4, "dh {dh}");
            // Never further than the fastest allowed speed over the step.
            let moved = ((next.x - s.x).powi(2) + (next.y - s.y).powi(2)).sqrt();
            let vmax = s.speed.abs() + MAX_ACCEL * dt;
            prop_assert!(moved <= vmax * dt * (1.0 + 1e-3) + 1e-3, "moved {moved}");
        }
    }

    #[test]
    fn ekf_stays_finite_on_any_measurements(zs in prop::collection::vec(any_measurement(), 0..60)) {
        let mut ekf = UnicycleEkf::new(EkfParams::vehicle(0.05));
        for z in &zs {
            let _ = ekf.step(z);
            if let Some(s) = ekf.state() {
                prop_assert!(state_is_finite(&s), "{s:?} after {z:?}");
            }
        }
    }

    #[test]
    fn fixed_lag_smoother_stays_finite_on_any_measurements(
        zs in prop::collection::vec(any_measurement(), 0..60),
    ) {
        let mut rts: FixedLagRts<20> = FixedLagRts::new(EkfParams::vehicle(0.05));
        for z in &zs {
            if let Some(s) = rts.push(z) {
                prop_assert!(state_is_finite(&s), "{s:?}");
            }
        }
        let mut bad = 0;
        rts.smooth_into(|_, s| if !state_is_finite(&s) { bad += 1 });
        prop_assert_eq!(bad, 0);
    }

    #[test]
    fn baselines_refuse_or_forecast_finite_points(
        history in prop::collection::vec(any_state(), 0..8),
        dt in prop_oneof![Just(0.05f32), Just(0.0f32), Just(-1.0f32), Just(f32::NAN), 0.001f32..1.0],
    ) {
        let mut out: Forecast = [Point2::new(0.0, 0.0); HORIZON];
        for f in [constant_velocity, ctra] {
            if f(&history, dt, &mut out).is_ok() {
                prop_assert!(out.iter().all(|p| p.x.is_finite() && p.y.is_finite()), "{out:?}");
            }
        }
    }

    #[test]
    fn metrics_take_any_lengths_and_values(
        a in prop::collection::vec((any_f32(), any_f32()).prop_map(|(x, y)| Point2::new(x, y)), 0..40),
        b in prop::collection::vec((any_f32(), any_f32()).prop_map(|(x, y)| Point2::new(x, y)), 0..40),
    ) {
        let _ = (ade(&a, &b), fde(&a, &b), ace(&a, &b));
        if a.is_empty() || b.is_empty() {
            prop_assert!(ade(&a, &b).is_none() && fde(&a, &b).is_none());
        }
    }

    #[test]
    fn minimal_pose_solver_refuses_or_returns_a_rigid_motion(
        src in prop::array::uniform3(any_point3()),
        dst in prop::array::uniform3(any_point3()),
    ) {
        if let Some(p) = rigid_from_three(&src, &dst) {
            prop_assert!(p.translation.vector.iter().all(|v| v.is_finite()));
            let r = p.rotation.to_rotation_matrix();
            let ortho = (r.matrix() * r.matrix().transpose() - nalgebra::Matrix3::identity()).norm();
            prop_assert!(ortho < 1e-3, "not a rotation: {r:?}");
        }
    }

    #[test]
    fn minimal_pose_solver_refuses_degenerate_triangles(
        a in prop::array::uniform3(finite_f32(100.0)),
        dir in prop::array::uniform3(finite_f32(1.0)),
        t in prop::array::uniform3(finite_f32(10.0)),
        s in prop::array::uniform3(finite_f32(10.0)),
    ) {
        let a = Vector3::from(a);
        let d = Vector3::from(dir);
        // Collinear (incl. identical, d = 0) source points leave the rotation unobservable.
        let src = [a + d * t[0], a + d * t[1], a + d * t[2]];
        let dst = [a + d * s[0], a + Vector3::new(1.0, 2.0, 3.0), a - Vector3::new(3.0, 1.0, 2.0)];
        prop_assert!(rigid_from_three(&src, &dst).is_none());
    }
}

/// A few and then no points: the solver and the smoother say no instead of inventing a pose.
#[test]
fn identical_and_huge_points_are_refused() {
    let p = Vector3::new(1.0e30, -1.0e30, 1.0e30);
    assert!(rigid_from_three(&[p; 3], &[p; 3]).is_none());
    let z = Vector3::zeros();
    assert!(rigid_from_three(&[z; 3], &[Vector3::x(), Vector3::y(), Vector3::z()]).is_none());
    let nan = Vector3::new(f32::NAN, 0.0, 0.0);
    assert!(
        rigid_from_three(&[nan, Vector3::y(), Vector3::z()], &[Vector3::x(), Vector3::y(), Vector3::z()]).is_none()
    );
}

/// The input the property test shrank the EKF failure to: a 3.4e38 position, then 0. The filter
/// used to reach inf; now the implausible position is treated as missing.
#[test]
fn regression_ekf_huge_position_then_zero() {
    let at = |x: f32| Measurement { position: Some(Point2::new(x, 0.0)), heading: None, speed: None };
    let none = Measurement::default();
    let mut ekf = UnicycleEkf::new(EkfParams::vehicle(0.05));
    for z in [at(f32::MAX), none, at(0.0), none] {
        let _ = ekf.step(&z);
        assert!(ekf.state().is_none_or(|s| state_is_finite(&s)), "{:?}", ekf.state());
    }
    assert!(ekf.state().is_some(), "the plausible position initialises the filter");
}

/// The input the property test shrank the CV failure to: a jump to y = 3.4e38 in 1 ms.
#[test]
fn regression_cv_huge_jump_is_refused() {
    let s = |y: f32| BevState { x: 0.0, y, heading: 0.0, speed: 0.0 };
    let mut out: Forecast = [Point2::new(0.0, 0.0); HORIZON];
    assert!(constant_velocity(&[s(0.0), s(f32::MAX)], 0.001, &mut out).is_err());
    assert!(constant_velocity(&[s(0.0), s(1.0)], 0.001, &mut out).is_ok());
}
