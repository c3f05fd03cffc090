//! The motion prior: a damped constant-acceleration, constant-turn-rate forecast from a long
//! memory of the object's own positions, the floor the learned predictor corrects.
//!
//! Seven states (0.6 s of KITTI's real 10 Hz) hold too little to tell a braking car from noise:
//! an along-track acceleration estimated from them correlates about 0.1 with the future's, from
//! 21 states about 0.3 (docs/decisions.md). So the prior reads up to [`PRIOR_STATES`] states:
//! - the rollout starts at the current position along the velocity of a least-squares parabola
//!   over the newest `velocity_window` states ([`parabola_fit`]), at its speed (the source's
//!   heading when the object barely moves);
//! - along-track acceleration and turn rate come from a second parabola over the newest
//!   `trend_window` states: a = A.v/|v|, omega = (v x A)/|v|^2 with v the parabola's velocity
//!   at the window's middle, where A is measured (no turn below
//!   [`MOTION_HEADING_MIN_SPEED`]);
//! - step t of the horizon applies gain * decay^t times each, clamped to the paper's limits,
//!   with the acceleration floored so the speed stops at zero instead of reversing;
//! - the unicycle ([`unicycle_step`]) integrates those controls from the start.
//!
//! The learned predictor adds its controls to these (`model::infer`), so at zero output it
//! forecasts exactly this prior. Its settings are chosen per source on training data and stored
//! in the model blob; [`PriorSettings::OFF`] (velocity over seven states, no acceleration, no
//! turn) is the rollout start of the paper's setting, the `cv-fit` baseline.
//!
//! Positions only: like `cv`, the prior is the same predictor on every source.

use super::consistency::{Carry, MAX_CARRY};
use super::dynamics::{Dynamics, clamp_velocity_residual};
use super::fit::parabola_fit;
use super::{Forecast, PredictError, Predictor, checked_forecast, checked_history_of, clamp_controls, unicycle_step};
use crate::geometry::{AgentFrame, BevState, Point2};
use crate::limits::MAX_STEPS;
use crate::limits::{HORIZON, PRIOR_STATES};

/// Below this fitted speed (m/s) the direction of motion is mostly noise, so the rollout keeps
/// the source's heading.
pub const MOTION_HEADING_MIN_SPEED: f32 = 1.0;

/// Settings of the motion prior (see the module docs). Serializable so that a trained fold's
/// choice can be kept with it.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PriorSettings {
    /// States the velocity parabola spans, 2..=[`PRIOR_STATES`].
    pub velocity_window: u8,
    /// States the acceleration and turn-rate parabola spans, 3..=[`PRIOR_STATES`].
    pub trend_window: u8,
    /// Share of the estimated along-track acceleration applied at the first step,
    /// 0..=[`PriorSettings::MAX_GAIN`].
    pub accel_gain: f32,
    /// Share of the estimated turn rate applied at the first step, 0..=[`PriorSettings::MAX_GAIN`].
    pub turn_gain: f32,
    /// Factor per frame by which the applied acceleration fades, 0..=1.
    pub accel_decay: f32,
    /// Factor per frame by which the applied turn rate fades, 0..=1.
    pub turn_decay: f32,
    /// Percent of an object's forecast at the frame before that its next forecast carries
    /// ([`super::consistency`]), 0..=90: whoever forecasts the object frame after frame applies
    /// it ([`Predictor::carry`]); 0 leaves every forecast as made.
    pub carry_percent: u8,
}

impl PriorSettings {
    /// Largest gain a blob may hold.
    pub const MAX_GAIN: f32 = 1.5;

    /// No prior: velocity over the network's seven states, no acceleration, no turn. The rollout
    /// starts as the `cv-fit` baseline does, and the features' long-window columns read the
    /// same seven states (the paper's setting).
    pub const OFF: Self = Self {
        velocity_window: MAX_STEPS as u8,
        trend_window: MAX_STEPS as u8,
        accel_gain: 0.0,
        turn_gain: 0.0,
        accel_decay: 1.0,
        turn_decay: 1.0,
        carry_percent: 0,
    };

    /// The settings of the `prior` row where no training chose them (`dynotraj eval`): per
    /// setting, the value the benchmark's four folds chose most often on their training
    /// sequences for the estimated source (what a vehicle's own camera gives), a tie going to
    /// the milder value (docs/decisions.md).
    pub const DEFAULT: Self = Self {
        velocity_window: 3,
        trend_window: 7,
        accel_gain: 0.75,
        turn_gain: 0.75,
        accel_decay: 0.95,
        turn_decay: 0.9,
        carry_percent: 60,
    };

    /// True when every field is within its documented range.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        let window = |w: u8, least: usize| (least..=PRIOR_STATES).contains(&usize::from(w));
        let unit = |v: f32| (0.0..=1.0).contains(&v);
        let gain = |v: f32| (0.0..=Self::MAX_GAIN).contains(&v);
        window(self.velocity_window, 2)
            && window(self.trend_window, 3)
            && gain(self.accel_gain)
            && gain(self.turn_gain)
            && unit(self.accel_decay)
            && unit(self.turn_decay)
            && f32::from(self.carry_percent) <= 100.0 * MAX_CARRY
    }

    /// The share of the previous forecast carried ([`Self::carry_percent`]).
    #[must_use]
    pub fn carry(&self) -> Carry {
        Carry::new(f32::from(self.carry_percent) / 100.0)
    }

    /// States of history the prior reads (the longer of its two windows).
    #[must_use]
    pub fn states(&self) -> usize {
        usize::from(self.velocity_window.max(self.trend_window)).min(PRIOR_STATES)
    }
}

/// The long-window estimates of an object's motion, raw (before gains and limits).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Trend {
    /// Speed of the trend parabola at its window's middle, m/s.
    pub speed: f32,
    /// Along-track acceleration, m/s^2.
    pub accel: f32,
    /// Turn rate, rad/s (0 below [`MOTION_HEADING_MIN_SPEED`]).
    pub turn_rate: f32,
}

/// Physical controls (turn rate rad/s, acceleration m/s^2) for each step of the horizon.
pub type Controls = [[f32; 2]; HORIZON];

/// The prior of one history: where the rollout starts and the controls it applies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PriorPlan {
    /// The agent frame: current position, x along the start velocity.
    pub frame: AgentFrame,
    /// Initial speed, m/s.
    pub speed: f32,
    /// The long-window estimates (also the predictor's features).
    pub trend: Trend,
    /// The prior's controls, within the paper's limits, speed never below zero.
    pub controls: Controls,
}

/// The prior plan of `history` (oldest first, current last; the newest
/// [`PriorSettings::states`] are read) at frame period `dt`. `None` with fewer than two states,
/// a bad `dt` or non-finite fits.
#[must_use]
pub fn plan(history: &[BevState], settings: &PriorSettings, dt: f32) -> Option<PriorPlan> {
    let cur = history.last()?;
    let v = parabola_fit(history, usize::from(settings.velocity_window), dt)?.velocity;
    let speed = libm::hypotf(v.x, v.y);
    if !speed.is_finite() {
        return None;
    }
    let heading = if speed >= MOTION_HEADING_MIN_SPEED { libm::atan2f(v.y, v.x) } else { cur.heading };
    let frame = AgentFrame::new(cur.position(), heading);
    let fit = parabola_fit(history, usize::from(settings.trend_window), dt)?;
    let trend = trend_of(fit.mid_velocity, fit.acceleration, &frame);
    let mut controls = [[0.0; 2]; HORIZON];
    let (mut fade_a, mut fade_w, mut v) = (settings.accel_gain, settings.turn_gain, speed);
    for c in &mut controls {
        let (w, a) = clamp_controls(fade_w * trend.turn_rate, fade_a * trend.accel);
        let a = a.max(-v.max(0.0) / dt);
        *c = [w, a];
        v += a * dt;
        fade_a *= settings.accel_decay;
        fade_w *= settings.turn_decay;
    }
    Some(PriorPlan { frame, speed, trend, controls })
}

/// Along-track acceleration and turn rate of acceleration `acc` measured where the velocity
/// was `v` (the window's middle: projected on the newest direction instead, a bend's
/// centripetal part would leak into the along-track term); below walking pace the direction
/// is noise, so the frame's axis stands in and there is no turn.
fn trend_of(v: Point2, acc: Point2, frame: &AgentFrame) -> Trend {
    let speed = libm::hypotf(v.x, v.y);
    if speed >= MOTION_HEADING_MIN_SPEED {
        Trend {
            speed,
            accel: (acc.x * v.x + acc.y * v.y) / speed,
            turn_rate: (v.x * acc.y - v.y * acc.x) / (speed * speed),
        }
    } else {
        Trend { speed, accel: frame.rotate_to_agent(&acc).x, turn_rate: 0.0 }
    }
}

/// The plan rolled out one step at a time, with a residual added to each step under the
/// agent's [`Dynamics`]: the learned predictor steps it as its decoder produces each residual,
/// so no horizon of residuals is ever stored. A zero residual gives the prior itself, bit for
/// bit: the learned predictor and [`MotionPrior`] share this arithmetic.
#[derive(Debug, Clone)]
pub struct Rollout<'p> {
    plan: &'p PriorPlan,
    state: BevState,
    dt: f32,
    dynamics: Dynamics,
    /// A single integrator's integrated residual velocity (agent frame, metres).
    offset: Point2,
}

impl<'p> Rollout<'p> {
    /// At the plan's start, for a unicycle.
    #[must_use]
    pub const fn new(plan: &'p PriorPlan, dt: f32) -> Self {
        Self::with_dynamics(plan, dt, Dynamics::Unicycle)
    }

    /// At the plan's start, under `dynamics`.
    #[must_use]
    pub const fn with_dynamics(plan: &'p PriorPlan, dt: f32, dynamics: Dynamics) -> Self {
        Self {
            plan,
            state: BevState { x: 0.0, y: 0.0, heading: 0.0, speed: plan.speed },
            dt,
            dynamics,
            offset: Point2 { x: 0.0, y: 0.0 },
        }
    }

    /// Step `t` (0-based) with `residual` (physical units of the dynamics: turn rate and
    /// acceleration added to the prior's controls, or a velocity added to the prior's): the
    /// world position after it (`None` past the horizon).
    pub fn step(&mut self, t: usize, residual: [f32; 2]) -> Option<Point2> {
        let c = self.plan.controls.get(t)?;
        let position = match self.dynamics {
            Dynamics::Unicycle => {
                self.state = unicycle_step(&self.state, c[0] + residual[0], c[1] + residual[1], self.dt);
                self.state.position()
            }
            Dynamics::SingleIntegrator => {
                self.state = unicycle_step(&self.state, c[0], c[1], self.dt);
                self.offset.x += clamp_velocity_residual(residual[0]) * self.dt;
                self.offset.y += clamp_velocity_residual(residual[1]) * self.dt;
                Point2::new(self.state.x + self.offset.x, self.state.y + self.offset.y)
            }
        };
        Some(self.plan.frame.to_world(&position))
    }
}

/// Rolls `plan` out with zero residual into `out`: the prior's forecast.
pub fn roll_out(plan: &PriorPlan, dt: f32, out: &mut Forecast) {
    let mut r = Rollout::new(plan, dt);
    for (t, o) in out.iter_mut().enumerate() {
        if let Some(p) = r.step(t, [0.0; 2]) {
            *o = p;
        }
    }
}

/// The motion prior as a [`Predictor`] of its own (the `prior` row of the tables).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionPrior(pub PriorSettings);

impl Predictor for MotionPrior {
    fn predict(&mut self, history: &[BevState], dt: f32, out: &mut Forecast) -> Result<(), PredictError> {
        let h = checked_history_of(history, dt, self.0.states())?;
        let p = plan(h, &self.0, dt).ok_or(PredictError::HistoryTooShort)?;
        roll_out(&p, dt, out);
        checked_forecast(out)
    }

    fn carry(&self) -> Carry {
        self.0.carry()
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::limits::{MAX_ACCEL, MAX_TURN_RATE};
    use crate::predict::constant_velocity_fit;

    fn track(n: usize, dt: f32, accel: f32, turn: f32, speed: f32) -> [BevState; PRIOR_STATES] {
        let mut s = BevState { x: 100.0, y: -40.0, heading: 0.4, speed };
        let mut out = [s; PRIOR_STATES];
        for o in out.iter_mut().take(n) {
            *o = s;
            s = unicycle_step(&s, turn, accel, dt);
        }
        out
    }

    #[test]
    fn off_is_the_cv_fit_baseline() {
        let h = track(PRIOR_STATES, 0.05, -2.0, 0.3, 12.0);
        let (mut a, mut b) = ([Point2::default(); HORIZON], [Point2::default(); HORIZON]);
        MotionPrior(PriorSettings::OFF).predict(&h, 0.05, &mut a).unwrap();
        constant_velocity_fit(&h, 0.05, &mut b).unwrap();
        for (x, y) in a.iter().zip(&b) {
            assert!(x.distance(y) < 1e-3, "{x:?} vs {y:?}");
        }
    }

    #[test]
    fn a_steady_turn_and_braking_are_recovered_and_carried_on() {
        let dt = 0.05;
        let h = track(PRIOR_STATES, dt, -1.5, 0.25, 10.0);
        let s = PriorSettings {
            accel_gain: 1.0,
            turn_gain: 1.0,
            accel_decay: 1.0,
            turn_decay: 1.0,
            ..PriorSettings::DEFAULT
        };
        let p = plan(&h, &s, dt).unwrap();
        assert!((p.trend.accel + 1.5).abs() < 0.1 && (p.trend.turn_rate - 0.25).abs() < 0.02, "{:?}", p.trend);
        // The truth carried on: the prior follows it within centimetres over the horizon.
        let mut truth = h[PRIOR_STATES - 1];
        let mut out = [Point2::default(); HORIZON];
        MotionPrior(s).predict(&h, dt, &mut out).unwrap();
        for o in &out {
            truth = unicycle_step(&truth, 0.25, -1.5, dt);
            assert!(o.distance(&truth.position()) < 0.1, "{o:?} vs {truth:?}");
        }
    }

    #[test]
    fn controls_fade_stay_within_the_limits_and_never_reverse() {
        let dt = 0.05;
        let h = track(PRIOR_STATES, dt, -3.9, 0.69, 6.0);
        let s = PriorSettings {
            accel_gain: 1.5,
            turn_gain: 1.5,
            accel_decay: 0.9,
            turn_decay: 0.8,
            ..PriorSettings::DEFAULT
        };
        let p = plan(&h, &s, dt).unwrap();
        let mut v = p.speed;
        for c in &p.controls {
            assert!(c[0].abs() <= MAX_TURN_RATE && c[1].abs() <= MAX_ACCEL, "{c:?}");
            v += c[1] * dt;
            assert!(v >= -1e-5, "speed {v}");
        }
        assert!(p.controls[HORIZON - 1][0].abs() < p.controls[0][0].abs() * 0.01, "the turn fades");
    }

    #[test]
    fn settings_out_of_range_are_invalid() {
        assert!(PriorSettings::OFF.is_valid() && PriorSettings::DEFAULT.is_valid());
        for bad in [
            PriorSettings { velocity_window: 1, ..PriorSettings::DEFAULT },
            PriorSettings { trend_window: PRIOR_STATES as u8 + 1, ..PriorSettings::DEFAULT },
            PriorSettings { accel_gain: -0.1, ..PriorSettings::DEFAULT },
            PriorSettings { turn_gain: f32::NAN, ..PriorSettings::DEFAULT },
            PriorSettings { accel_decay: 1.1, ..PriorSettings::DEFAULT },
        ] {
            assert!(!bad.is_valid(), "{bad:?}");
        }
    }

    #[test]
    fn short_histories_still_forecast() {
        let h = track(2, 0.05, 0.0, 0.0, 8.0);
        let mut out = [Point2::default(); HORIZON];
        MotionPrior(PriorSettings::DEFAULT).predict(&h[..2], 0.05, &mut out).unwrap();
        assert!((out[0].distance(&h[1].position()) - 0.4).abs() < 1e-3);
        assert_eq!(
            MotionPrior(PriorSettings::DEFAULT).predict(&h[..1], 0.05, &mut out),
            Err(PredictError::HistoryTooShort)
        );
    }
}
