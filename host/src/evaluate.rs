//! Scoring forecasts on eligible runs: the paper's protocol, in which each source's forecasts are
//! scored against that source's own future.

use dynotraj_core::limits::HORIZON;
use dynotraj_core::metrics::{ace, ade, fde, ForecastScores};
use dynotraj_core::predict::{Forecast, PredictError, Predictor};
use dynotraj_core::{BevState, Point2};

/// Scores of one run, with the count of instances whose forecast failed.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RunScores {
    /// ADE, FDE and ACE means.
    pub scores: ForecastScores,
    /// Instances the predictor refused (see [`PredictError`]); they are not scored.
    pub failed: u32,
}

/// Forecasts every test instance of a run whose per-frame states are `states` (one source), and
/// scores each against the same states' future.
///
/// The history of the instance at index s is `states[s - MAX_HISTORY ..= s]` (clipped at the run
/// start); the predictor sees nothing after s. ACE pairs the forecasts of consecutive instances.
pub fn score_run(states: &[BevState], instances: std::ops::Range<usize>, predictor: &mut dyn Predictor, dt: f32) -> RunScores {
    let mut out = RunScores::default();
    let mut previous: Option<Forecast> = None;
    for s in instances {
        let Some(future) = states.get(s + 1..=s + HORIZON) else { break };
        let history = &states[..=s];
        let mut forecast = [Point2::default(); HORIZON];
        match predictor.predict(history, dt, &mut forecast) {
            Ok(()) => {
                let truth: Vec<Point2> = future.iter().map(BevState::position).collect();
                if let (Some(a), Some(f)) = (ade(&forecast, &truth), fde(&forecast, &truth)) {
                    out.scores.ade.push(a);
                    out.scores.fde.push(f);
                }
                if let Some(c) = previous.as_ref().and_then(|p| ace(p, &forecast)) {
                    out.scores.ace.push(c);
                }
                previous = Some(forecast);
            }
            Err(PredictError::HistoryTooShort | PredictError::NonFinite | PredictError::BadFramePeriod) => {
                out.failed += 1;
                previous = None;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynotraj_core::predict::Baseline;

    #[test]
    fn cv_is_exact_on_constant_velocity_and_counts_pairs() {
        let states: Vec<BevState> =
            (0..40).map(|k| BevState { x: 0.5 * k as f32, y: 0.1 * k as f32, heading: 0.0, speed: 0.0 }).collect();
        let r = score_run(&states, 1..10, &mut Baseline::ConstantVelocity, 0.1);
        assert_eq!(r.scores.ade.count(), 9);
        assert_eq!(r.scores.ace.count(), 8);
        assert!(r.scores.ade.value().unwrap_or(1.0) < 1e-4);
        assert!(r.scores.ace.value().unwrap_or(1.0) < 1e-4);
    }
}
