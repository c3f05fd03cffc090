//! The dynamically-extended unicycle of Trajectron++, with the paper's control limits.
//!
//! Trajectron++ stores limits but never applies them; the paper applies |turn rate| <= 0.7 rad/s
//! and |acceleration| <= 4 m/s^2, so every step here clamps its controls first.

use crate::geometry::trig::sin_cos;
use crate::geometry::{BevState, wrap_angle};
use crate::limits::{MAX_ACCEL, MAX_TURN_RATE};

/// Below this turn rate (rad/s) the straight-line form is used (Trajectron++'s threshold).
const STRAIGHT_TURN_RATE: f32 = 0.01;

/// Clamps (turn rate, acceleration) to the paper's limits. NaN controls become 0.
#[must_use]
pub fn clamp_controls(turn_rate: f32, accel: f32) -> (f32, f32) {
    let clamp = |v: f32, lim: f32| if v.is_nan() { 0.0 } else { v.clamp(-lim, lim) };
    (clamp(turn_rate, MAX_TURN_RATE), clamp(accel, MAX_ACCEL))
}

/// One step of `dt` seconds under controls (turn rate, acceleration), clamped first.
///
/// Closed form for |omega| > 0.01 (exact integration of the unicycle with constant controls);
/// otherwise the straight-line form, which (as in NVlabs' adaptive-prediction, unlike Trajectron++)
/// still advances the heading by omega * dt.
#[must_use]
pub fn unicycle_step(s: &BevState, turn_rate: f32, accel: f32, dt: f32) -> BevState {
    let (w, a) = clamp_controls(turn_rate, accel);
    let (phi, v) = (s.heading, s.speed);
    let phi1 = phi + w * dt;
    let (x, y) = if w.abs() > STRAIGHT_TURN_RATE {
        let (s0, c0) = sin_cos(phi);
        let (s1, c1) = sin_cos(phi1);
        (
            s.x + (a / (w * w)) * (c1 - c0) + (v / w) * (s1 - s0) + (a / w) * s1 * dt,
            s.y - (v / w) * (c1 - c0) + (a / (w * w)) * (s1 - s0) - (a / w) * c1 * dt,
        )
    } else {
        // Travel along the mid-step heading: second-order accurate in omega * dt, so the two
        // branches meet at the threshold.
        let d = v * dt + 0.5 * a * dt * dt;
        let mid = phi + 0.5 * w * dt;
        let (sm, cm) = sin_cos(mid);
        (s.x + d * cm, s.y + d * sm)
    };
    BevState { x, y, heading: wrap_angle(phi1), speed: v + a * dt }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Integrates the unicycle ODE numerically with many small Euler steps.
    fn integrate(s: &BevState, w: f32, a: f32, dt: f32) -> BevState {
        let n = 20_000;
        let h = dt / n as f32;
        let (mut x, mut y, mut phi, mut v) = (s.x as f64, s.y as f64, s.heading as f64, s.speed as f64);
        for _ in 0..n {
            x += v * phi.cos() * h as f64;
            y += v * phi.sin() * h as f64;
            phi += w as f64 * h as f64;
            v += a as f64 * h as f64;
        }
        BevState { x: x as f32, y: y as f32, heading: wrap_angle(phi as f32), speed: v as f32 }
    }

    #[test]
    fn closed_form_matches_the_ode() {
        let s = BevState { x: 1.0, y: -2.0, heading: 0.3, speed: 8.0 };
        for (w, a) in [(0.5, 1.0), (-0.3, -2.0), (0.005, 3.0), (0.0, 0.0), (0.69, -3.9)] {
            let got = unicycle_step(&s, w, a, 0.5);
            let want = integrate(&s, w, a, 0.5);
            assert!((got.x - want.x).abs() < 2e-3 && (got.y - want.y).abs() < 2e-3, "{w} {a}: {got:?} vs {want:?}");
            assert!((got.heading - want.heading).abs() < 1e-4);
            assert!((got.speed - want.speed).abs() < 1e-4);
        }
    }

    #[test]
    fn controls_are_clamped_to_the_paper_limits() {
        let s = BevState { x: 0.0, y: 0.0, heading: 0.0, speed: 5.0 };
        let dt = 0.1;
        let hard = unicycle_step(&s, 3.0, 20.0, dt);
        let limit = unicycle_step(&s, MAX_TURN_RATE, MAX_ACCEL, dt);
        assert_eq!(hard, limit);
        assert!((hard.heading - MAX_TURN_RATE * dt).abs() < 1e-6);
        assert!((hard.speed - (5.0 + MAX_ACCEL * dt)).abs() < 1e-6);
        let back = unicycle_step(&s, -3.0, -20.0, dt);
        assert!((back.heading + MAX_TURN_RATE * dt).abs() < 1e-6);
        assert!((back.speed - (5.0 - MAX_ACCEL * dt)).abs() < 1e-6);
        assert_eq!(clamp_controls(f32::NAN, f32::NAN), (0.0, 0.0));
    }
}
