//! The current velocity of a short history by least squares: a parabola through its positions.
//!
//! Why: the last displacement of a labelled or estimated track carries the position noise of
//! two frames at full gain (a box centre that jitters by 5 cm moves a 20 Hz velocity by up to
//! 2 m/s), and a forecast held along it carries that noise to every step and from one forecast
//! to the next (ACE). A straight line through the history is steadier but trails every change
//! of speed or heading by half the history; on the tuning sequences (docs/decisions.md) that lag
//! cost more ADE than the noise it removed. A parabola's slope at the newest frame has no lag
//! under constant acceleration and, over seven frames, a noise variance 0.23 times the last
//! displacement's (the squared weights below sum to 0.464 against 2).

use crate::geometry::{BevState, Point2};
use crate::limits::MAX_STEPS;

/// The velocity (m/s) at the newest state of the least-squares parabola (per coordinate, over
/// time) through the positions of the newest [`MAX_STEPS`] states of `history` (oldest first,
/// one frame period `dt` apart). With two states it is the last displacement over `dt` (a line
/// is all two points fix). `None` with fewer than two states, a non-positive `dt` or a
/// non-finite result.
#[must_use]
pub fn fitted_velocity(history: &[BevState], dt: f32) -> Option<Point2> {
    parabola_fit(history, MAX_STEPS, dt).map(|f| f.velocity)
}

/// The slope and curvature of a least-squares parabola through a history's positions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParabolaFit {
    /// Velocity at the newest state, m/s.
    pub velocity: Point2,
    /// Velocity at the middle of the window, m/s: the direction the acceleration was measured
    /// along (on a bend it differs from the newest velocity's).
    pub mid_velocity: Point2,
    /// Acceleration (the parabola's second derivative), m/s^2; zero with two states.
    pub acceleration: Point2,
    /// States the fit used.
    pub states: usize,
}

/// [`fitted_velocity`] over the newest `window` states (at least two), with the acceleration of
/// the same parabola. A longer window trades lag for noise: the motion prior fits its velocity
/// over a short window and its acceleration and turn rate over a long one
/// ([`super::prior`]).
#[must_use]
pub fn parabola_fit(history: &[BevState], window: usize, dt: f32) -> Option<ParabolaFit> {
    let tail = history.get(history.len().saturating_sub(window)..)?;
    let cur = tail.last()?;
    let n = tail.len();
    if n < 2 || !(dt.is_finite() && dt > 0.0) {
        return None;
    }
    // Orthogonal polynomials on the centred frame indices u: 1, u and u^2 - mean(u^2), so each
    // coefficient is one projection. Positions are taken relative to the current one, so the
    // sums stay small in f32 far from the map origin.
    let half = (n - 1) as f32 / 2.0;
    let u = |i: usize| i as f32 - half;
    let mean_u2 = (0..n).map(|i| u(i) * u(i)).sum::<f32>() / n as f32;
    let q = |i: usize| u(i) * u(i) - mean_u2;
    let (su2, sq2) = (0..n).fold((0.0f32, 0.0f32), |(a, b), i| (a + u(i) * u(i), b + q(i) * q(i)));
    let (mut lin, mut quad) = (Point2::default(), Point2::default());
    for (i, s) in tail.iter().enumerate() {
        let (dx, dy) = (s.x - cur.x, s.y - cur.y);
        lin = Point2::new(lin.x + u(i) * dx, lin.y + u(i) * dy);
        quad = Point2::new(quad.x + q(i) * dx, quad.y + q(i) * dy);
    }
    // Slope at the newest index u = half: b1 + 2 b2 half; with two points there is no curvature.
    let curvature_gain = if sq2 > 0.0 { 2.0 * half / sq2 } else { 0.0 };
    let per_frame = |l: f32, c: f32| (l / su2 + curvature_gain * c) / dt;
    let velocity = Point2::new(per_frame(lin.x, quad.x), per_frame(lin.y, quad.y));
    // Second derivative 2 b2, per frame squared, in seconds.
    let second = |c: f32| if sq2 > 0.0 { 2.0 * c / sq2 / (dt * dt) } else { 0.0 };
    let acceleration = Point2::new(second(quad.x), second(quad.y));
    let mid_velocity = Point2::new(lin.x / su2 / dt, lin.y / su2 / dt);
    let finite = [velocity, acceleration, mid_velocity].iter().all(|p| p.x.is_finite() && p.y.is_finite());
    finite.then_some(ParabolaFit { velocity, mid_velocity, acceleration, states: n })
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::unwrap_used)]
mod tests {
    use super::*;

    fn at(x: f32, y: f32) -> BevState {
        BevState { x, y, heading: 0.0, speed: 0.0 }
    }

    #[test]
    fn constant_acceleration_gives_the_current_velocity_without_lag() {
        let dt = 0.05;
        // x: 10 m/s braking at 3 m/s^2; y: 2 m/s accelerating at 1 m/s^2; far from the origin.
        let track: [BevState; 9] = core::array::from_fn(|k| {
            let t = k as f32 * dt;
            at(1000.0 + 10.0 * t - 1.5 * t * t, -300.0 + 2.0 * t + 0.5 * t * t)
        });
        let v = fitted_velocity(&track, dt).unwrap();
        let t_now = 8.0 * dt;
        assert!((v.x - (10.0 - 3.0 * t_now)).abs() < 0.05 && (v.y - (2.0 + t_now)).abs() < 0.05, "{v:?}");
        let last = (track[8].x - track[7].x) / dt;
        assert!((last - (10.0 - 3.0 * t_now)).abs() > 0.07, "the last displacement lags half a frame: {last}");
    }

    #[test]
    fn the_long_fit_recovers_a_constant_acceleration() {
        let dt = 0.05;
        let track: [BevState; 21] = core::array::from_fn(|k| {
            let t = k as f32 * dt;
            at(500.0 + 12.0 * t - 1.5 * t * t, 20.0 + 0.5 * t * t)
        });
        let f = parabola_fit(&track, 21, dt).unwrap();
        assert_eq!(f.states, 21);
        assert!((f.acceleration.x + 3.0).abs() < 0.05 && (f.acceleration.y - 1.0).abs() < 0.05, "{f:?}");
        let t_now = 20.0 * dt;
        assert!((f.velocity.x - (12.0 - 3.0 * t_now)).abs() < 0.05, "{f:?}");
        assert_eq!(parabola_fit(&track, 7, dt).map(|f| f.velocity), fitted_velocity(&track, dt));
        assert_eq!(parabola_fit(&track[..2], 21, dt).unwrap().acceleration, Point2::default());
    }

    #[test]
    fn short_histories_and_bad_input() {
        let v2 = fitted_velocity(&[at(0.0, 0.0), at(0.3, -0.1)], 0.1).unwrap();
        assert!((v2.x - 3.0).abs() < 1e-5 && (v2.y + 1.0).abs() < 1e-5, "two states: the last displacement");
        let v3 = fitted_velocity(&[at(0.0, 0.0), at(1.0, 0.0), at(4.0, 0.0)], 1.0).unwrap();
        assert!((v3.x - 4.0).abs() < 1e-4, "three states: the parabola x = t^2 has slope 4 at t = 2, {v3:?}");
        assert!(fitted_velocity(&[at(0.0, 0.0)], 0.05).is_none());
        assert!(fitted_velocity(&[at(0.0, 0.0), at(1.0, 0.0)], 0.0).is_none());
        assert!(fitted_velocity(&[at(0.0, 0.0), at(f32::INFINITY, 0.0)], 0.05).is_none());
    }

    #[test]
    fn alternating_jitter_moves_the_fit_less_than_the_last_displacement() {
        // A 10 m/s track whose positions jitter by +-5 cm frame to frame.
        let jittered: [BevState; MAX_STEPS] =
            core::array::from_fn(|k| at(0.5 * k as f32, if k % 2 == 0 { 0.05 } else { -0.05 }));
        let v = fitted_velocity(&jittered, 0.05).unwrap();
        let last = (jittered[MAX_STEPS - 1].y - jittered[MAX_STEPS - 2].y) / 0.05;
        assert!((v.x - 10.0).abs() < 1e-3);
        assert!(v.y.abs() < 0.5 * last.abs(), "fit {} vs last displacement {last}", v.y);
    }
}
