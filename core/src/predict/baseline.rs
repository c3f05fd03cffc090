//! Baseline predictors: constant velocity (CV, and cv-fit along a fitted velocity) and constant
//! turn rate and acceleration (CTRA).

use super::fit::fitted_velocity;
use super::{Forecast, PredictError, Predictor, checked_forecast, checked_history, unicycle_step};
use crate::geometry::{BevState, Point2, angle_diff};

/// Constant velocity: the velocity of the last two positions, held for the whole horizon.
///
/// It reads positions only (not the source's heading or speed), so it is the same predictor on
/// every source.
///
/// # Errors
/// See [`PredictError`].
pub fn constant_velocity(history: &[BevState], dt: f32, out: &mut Forecast) -> Result<(), PredictError> {
    let h = checked_history(history, dt)?;
    let [.., prev, cur] = h else { return Err(PredictError::HistoryTooShort) };
    hold_velocity(cur, Point2::new((cur.x - prev.x) / dt, (cur.y - prev.y) / dt), dt, out)
}

/// Constant velocity along the current velocity of the least-squares parabola through the
/// history ([`fitted_velocity`]), from the current position (`cv-fit`: the learned model's
/// forecast at zero controls). Like [`constant_velocity`] it reads positions only.
///
/// # Errors
/// See [`PredictError`].
pub fn constant_velocity_fit(history: &[BevState], dt: f32, out: &mut Forecast) -> Result<(), PredictError> {
    let h = checked_history(history, dt)?;
    let (Some(cur), Some(v)) = (h.last(), fitted_velocity(h, dt)) else { return Err(PredictError::HistoryTooShort) };
    hold_velocity(cur, v, dt, out)
}

/// Fills `out` with the positions of `cur` moving at velocity `v` (m/s) for 1..=HORIZON frames.
fn hold_velocity(cur: &BevState, v: Point2, dt: f32, out: &mut Forecast) -> Result<(), PredictError> {
    for (k, p) in out.iter_mut().enumerate() {
        let t = (k + 1) as f32 * dt;
        *p = Point2::new(cur.x + v.x * t, cur.y + v.y * t);
    }
    checked_forecast(out)
}

/// Constant turn rate and acceleration on the unicycle, from the source's current heading and
/// speed; turn rate and acceleration are the last frame-to-frame changes of heading and speed,
/// clamped to the paper's limits. The speed stops at zero instead of reversing: a braking
/// vehicle halts, it does not drive backwards.
///
/// # Errors
/// See [`PredictError`].
pub fn ctra(history: &[BevState], dt: f32, out: &mut Forecast) -> Result<(), PredictError> {
    let h = checked_history(history, dt)?;
    let [.., prev, cur] = h else { return Err(PredictError::HistoryTooShort) };
    let turn_rate = angle_diff(cur.heading, prev.heading) / dt;
    let accel = (cur.speed - prev.speed) / dt;
    let mut s = *cur;
    for p in out.iter_mut() {
        let a = accel.max(-s.speed.max(0.0) / dt);
        s = unicycle_step(&s, turn_rate, a, dt);
        *p = s.position();
    }
    checked_forecast(out)
}

/// The baseline predictors as one [`Predictor`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Baseline {
    /// [`constant_velocity`].
    ConstantVelocity,
    /// [`constant_velocity_fit`].
    ConstantVelocityFit,
    /// [`ctra`].
    Ctra,
}

impl Baseline {
    /// Every baseline, in the order tables print them.
    pub const ALL: [Self; 3] = [Self::ConstantVelocity, Self::ConstantVelocityFit, Self::Ctra];

    /// The name in tables and on the command line.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::ConstantVelocity => "cv",
            Self::ConstantVelocityFit => "cv-fit",
            Self::Ctra => "ctra",
        }
    }
}

impl Predictor for Baseline {
    fn predict(&mut self, history: &[BevState], dt: f32, out: &mut Forecast) -> Result<(), PredictError> {
        match self {
            Self::ConstantVelocity => constant_velocity(history, dt, out),
            Self::ConstantVelocityFit => constant_velocity_fit(history, dt, out),
            Self::Ctra => ctra(history, dt, out),
        }
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing)]
mod tests {
    use super::*;
    use crate::limits::{HORIZON, MAX_TURN_RATE};

    fn st(x: f32, y: f32, heading: f32, speed: f32) -> BevState {
        BevState { x, y, heading, speed }
    }

    #[test]
    fn cv_extrapolates_the_last_displacement() {
        let h = [st(0.0, 0.0, 0.0, 0.0), st(1.0, 0.5, 0.0, 0.0)];
        let mut out = [Point2::default(); HORIZON];
        constant_velocity(&h, 0.1, &mut out).unwrap_or_default();
        assert!((out[0].x - 2.0).abs() < 1e-5 && (out[0].y - 1.0).abs() < 1e-5);
        assert!((out[HORIZON - 1].x - 31.0).abs() < 1e-3);
    }

    #[test]
    fn cv_fit_holds_the_current_velocity_of_the_fitted_parabola() {
        // Braking from 10 m/s at 2 m/s^2 over seven frames of 0.1 s: 8.8 m/s at the newest.
        let h: [BevState; 7] = core::array::from_fn(|k| {
            let t = k as f32 * 0.1;
            st(10.0 * t - t * t, 1.0, 0.0, 0.0)
        });
        let (mut fit, mut last) = ([Point2::default(); HORIZON], [Point2::default(); HORIZON]);
        constant_velocity_fit(&h, 0.1, &mut fit).unwrap_or_default();
        constant_velocity(&h, 0.1, &mut last).unwrap_or_default();
        let cur = h[6].x;
        assert!((fit[0].x - (cur + 0.88)).abs() < 1e-3, "{:?}", fit[0]);
        assert!((last[0].x - (cur + 0.89)).abs() < 1e-3, "the last displacement is half a frame older");
        assert!((fit[HORIZON - 1].y - 1.0).abs() < 1e-5);
        assert_eq!(Baseline::ConstantVelocityFit.predict(&h, 0.1, &mut last), Ok(()));
        assert_eq!(last, fit);
    }

    #[test]
    fn ctra_turn_is_clamped_and_braking_stops() {
        let dt = 0.1;
        let h = [st(0.0, 0.0, 0.0, 10.0), st(1.0, 0.0, 0.5, 10.0)];
        let mut out = [Point2::default(); HORIZON];
        assert_eq!(ctra(&h, dt, &mut out), Ok(()));
        // Heading after the horizon is 0.5 + 0.7 * 3 s at most: the path bends left but no more.
        let last = out[HORIZON - 1];
        let prev = out[HORIZON - 2];
        let final_heading = libm::atan2f(last.y - prev.y, last.x - prev.x);
        assert!(final_heading > 0.5, "it turns left ({final_heading})");
        assert!(final_heading <= 0.5 + MAX_TURN_RATE * dt * HORIZON as f32 + 0.05);
        assert!(libm::hypotf(last.x, last.y) > 20.0, "it goes on at about 10 m/s ({last:?})");
        let brake = [st(0.0, 0.0, 0.0, 2.0), st(0.2, 0.0, 0.0, 1.5)];
        assert_eq!(ctra(&brake, dt, &mut out), Ok(()));
        assert!(out.windows(2).all(|w| w[1].x >= w[0].x - 1e-6), "never reverses");
        assert!(out[0].x > 0.2, "it moves before it stops ({:?})", out[0]);
        assert!((out[HORIZON - 1].x - out[HORIZON - 2].x).abs() < 1e-6, "and it stops");
    }

    #[test]
    fn bad_inputs_are_errors() {
        let mut out = [Point2::default(); HORIZON];
        assert_eq!(constant_velocity(&[st(0.0, 0.0, 0.0, 0.0)], 0.1, &mut out), Err(PredictError::HistoryTooShort));
        let h = [st(0.0, 0.0, 0.0, 0.0), st(f32::NAN, 0.0, 0.0, 0.0)];
        assert_eq!(ctra(&h, 0.1, &mut out), Err(PredictError::NonFinite));
        assert_eq!(ctra(&[st(0.0, 0.0, 0.0, 0.0); 2], 0.0, &mut out), Err(PredictError::BadFramePeriod));
    }
}
