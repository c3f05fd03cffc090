//! Forecasting: unicycle dynamics with the paper's limits (and a pedestrian's single
//! integrator, `dynamics`), and the baseline predictors.
//!
//! A forecast is made at the current frame s from a history of bird's-eye states, oldest first,
//! whose last element is frame s; it holds positions for frames s+1 ..= s+HORIZON.

mod baseline;
pub mod consistency;
pub mod dynamics;
mod fit;
pub mod prior;
mod unicycle;

pub use baseline::{Baseline, constant_velocity, constant_velocity_fit, ctra};
pub use consistency::{Carry, ForecastMemory, carry_forward};
pub use dynamics::Dynamics;
pub use fit::{ParabolaFit, fitted_velocity, parabola_fit};
pub use prior::{MotionPrior, PriorPlan, PriorSettings};
pub use unicycle::{clamp_controls, unicycle_step};

use crate::geometry::{BevState, Point2};
use crate::limits::{HORIZON, MAX_ABS_POSITION, MAX_ABS_SPEED, MAX_HISTORY, MIN_HISTORY};

/// Positions for the next [`HORIZON`] frames.
pub type Forecast = [Point2; HORIZON];

/// Why a forecast could not be made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PredictError {
    /// The history holds fewer than `MIN_HISTORY + 1` states (history plus the current frame).
    HistoryTooShort,
    /// A history state has a non-finite or implausible field (beyond
    /// [`crate::limits::MAX_ABS_POSITION`] or [`crate::limits::MAX_ABS_SPEED`]), or the
    /// forecast left the finite range.
    NonFinite,
    /// The frame period is not a positive finite number.
    BadFramePeriod,
}

/// A forecaster of one object's future positions.
pub trait Predictor {
    /// Fills `out` with the positions of the next [`HORIZON`] frames after the last state of
    /// `history` (oldest first, current last; the network reads the last `MAX_HISTORY + 1`
    /// states, the motion prior up to `PRIOR_STATES`).
    ///
    /// # Errors
    /// See [`PredictError`].
    fn predict(&mut self, history: &[BevState], dt: f32, out: &mut Forecast) -> Result<(), PredictError>;

    /// [`Self::predict`] knowing what else the scene holds (`context`: the other objects, the
    /// observer). A predictor that reads only its own object's history (the baselines, the
    /// motion prior) ignores it.
    ///
    /// # Errors
    /// See [`PredictError`].
    fn predict_in_context(
        &mut self,
        history: &[BevState],
        context: &Context<'_>,
        dt: f32,
        out: &mut Forecast,
    ) -> Result<(), PredictError> {
        let _ = context;
        self.predict(history, dt, out)
    }

    /// The share of an object's forecast at the frame before that its next forecast carries
    /// ([`consistency`]): whoever forecasts an object frame after frame applies it. None unless
    /// the predictor says otherwise.
    fn carry(&self) -> Carry {
        Carry::NONE
    }
}

/// The predictor `.0`, whose forecasts carry the share `.1` of the previous one
/// ([`Predictor::carry`]), as it makes them otherwise.
#[derive(Debug)]
pub struct Carried<'p, P: ?Sized>(pub &'p mut P, pub Carry);

impl<P: Predictor + ?Sized> Predictor for Carried<'_, P> {
    fn predict(&mut self, history: &[BevState], dt: f32, out: &mut Forecast) -> Result<(), PredictError> {
        self.0.predict(history, dt, out)
    }

    fn predict_in_context(
        &mut self,
        history: &[BevState],
        context: &Context<'_>,
        dt: f32,
        out: &mut Forecast,
    ) -> Result<(), PredictError> {
        self.0.predict_in_context(history, context, dt, out)
    }

    fn carry(&self) -> Carry {
        self.1
    }
}

/// What a forecast may know beyond its object's own history.
#[derive(Debug, Clone, Copy, Default)]
pub struct Context<'a> {
    /// The other objects' histories, each ending at the same current frame.
    pub neighbours: &'a [&'a [BevState]],
    /// Where the observing camera is at the current frame, in the histories' world, when known:
    /// the object's range from it says how far its depth can be trusted.
    pub observer: Option<Point2>,
}

impl<'a> Context<'a> {
    /// Nothing beyond the object's own history.
    pub const NONE: Context<'static> = Context { neighbours: &[], observer: None };

    /// The other objects' histories, the observer unknown.
    #[must_use]
    pub const fn with_neighbours(neighbours: &'a [&'a [BevState]]) -> Self {
        Self { neighbours, observer: None }
    }
}

/// `Ok` when every point of `out` is finite: the last guard of a forecast (a tiny `dt` can
/// still blow a finite history up).
///
/// # Errors
/// [`PredictError::NonFinite`] otherwise.
pub fn checked_forecast(out: &Forecast) -> Result<(), PredictError> {
    if out.iter().all(|p| p.x.is_finite() && p.y.is_finite()) { Ok(()) } else { Err(PredictError::NonFinite) }
}

/// Checks a history and frame period, and returns the usable tail (at most `MAX_HISTORY + 1`
/// states, at least `MIN_HISTORY + 1`).
///
/// # Errors
/// See [`PredictError`].
pub fn checked_history(history: &[BevState], dt: f32) -> Result<&[BevState], PredictError> {
    checked_history_of(history, dt, MAX_HISTORY + 1)
}

/// [`checked_history`] for a predictor that reads up to `states` states (the motion prior's long
/// memory): the usable tail holds at most that many, and every one of them must be plausible.
///
/// # Errors
/// See [`PredictError`].
pub fn checked_history_of(history: &[BevState], dt: f32, states: usize) -> Result<&[BevState], PredictError> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(PredictError::BadFramePeriod);
    }
    if history.len() < MIN_HISTORY + 1 {
        return Err(PredictError::HistoryTooShort);
    }
    let tail = history.get(history.len().saturating_sub(states.max(MIN_HISTORY + 1))..).unwrap_or(history);
    let plausible = |s: &BevState| {
        s.is_finite()
            && s.x.abs() <= MAX_ABS_POSITION
            && s.y.abs() <= MAX_ABS_POSITION
            && s.speed.abs() <= MAX_ABS_SPEED
    };
    if tail.iter().all(plausible) { Ok(tail) } else { Err(PredictError::NonFinite) }
}
