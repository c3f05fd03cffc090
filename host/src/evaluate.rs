//! Scoring forecasts on eligible runs: the paper's protocol, in which each source's forecasts are
//! scored against that source's own future.

use dynotraj_core::limits::HORIZON;
use dynotraj_core::metrics::{ace, ade, fde, ForecastScores};
use dynotraj_core::model::LearnedPredictor;
use dynotraj_core::predict::{Baseline, Forecast, PredictError, Predictor};
use dynotraj_core::{BevState, Point2};

use crate::scene::{Scene, SourcedRun};
use crate::trajectory::EligibleRun;

/// Anything that forecasts one object from its history and its neighbours' histories.
pub trait Forecaster {
    /// Fills `out` for the object whose history is `history` (oldest first, current last).
    ///
    /// # Errors
    /// See [`PredictError`].
    fn forecast(&mut self, history: &[BevState], neighbours: &[&[BevState]], dt: f32, out: &mut Forecast) -> Result<(), PredictError>;
}

impl Forecaster for Baseline {
    fn forecast(&mut self, history: &[BevState], _neighbours: &[&[BevState]], dt: f32, out: &mut Forecast) -> Result<(), PredictError> {
        self.predict(history, dt, out)
    }
}

impl Forecaster for LearnedPredictor<'_> {
    fn forecast(&mut self, history: &[BevState], neighbours: &[&[BevState]], dt: f32, out: &mut Forecast) -> Result<(), PredictError> {
        self.predict_with_neighbours(history, neighbours, dt, out)
    }
}

/// The scores of one forecast.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InstanceScore {
    /// Frame the forecast was made at.
    pub frame: u32,
    /// Its ADE, metres.
    pub ade: f32,
    /// Its FDE, metres.
    pub fde: f32,
    /// ACE with the previous frame's forecast, metres, when that one exists.
    pub ace: Option<f32>,
}

/// Scores of one run.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunScores {
    /// ADE, FDE and ACE means.
    pub scores: ForecastScores,
    /// Each scored instance, in frame order.
    pub instances: Vec<InstanceScore>,
    /// Instances the predictor refused (see [`PredictError`]); they are not scored.
    pub failed: u32,
}

/// Forecasts every test instance (indices into `run.states`) and scores each against the same
/// source's future. The history of instance s is `run.states[..=s]` (the predictor keeps the
/// newest frames it uses); neighbours are the other runs of `scene` present at the frame. ACE
/// pairs the forecasts of consecutive instances.
pub fn score_run(run: &SourcedRun, instances: std::ops::Range<usize>, scene: &Scene, forecaster: &mut dyn Forecaster, dt: f32) -> RunScores {
    let mut out = RunScores::default();
    let mut previous: Option<Forecast> = None;
    for s in instances {
        let Some(future) = run.states.get(s + 1..=s + HORIZON) else { break };
        let frame = run.first_frame + s as u32;
        let neighbours = scene.neighbours_at(run.track_id, frame);
        let mut forecast = [Point2::default(); HORIZON];
        match forecaster.forecast(&run.states[..=s], &neighbours, dt, &mut forecast) {
            Ok(()) => {
                let truth: Vec<Point2> = future.iter().map(BevState::position).collect();
                let (Some(a), Some(f)) = (ade(&forecast, &truth), fde(&forecast, &truth)) else { continue };
                out.scores.ade.push(a);
                out.scores.fde.push(f);
                let c = previous.as_ref().and_then(|p| ace(p, &forecast));
                if let Some(c) = c {
                    out.scores.ace.push(c);
                }
                out.instances.push(InstanceScore { frame, ade: a, fde: f, ace: c });
                previous = Some(forecast);
            }
            Err(_) => {
                out.failed += 1;
                previous = None;
            }
        }
    }
    out
}

/// Scores `forecaster` on every eligible run of one sequence through `scene` (the sequence's
/// tracks through the source being scored).
pub fn score_sequence(runs: &[EligibleRun], scene: &Scene, forecaster: &mut dyn Forecaster, dt: f32) -> RunScores {
    let mut total = RunScores::default();
    for run in runs {
        let Some(sourced) = scene.run_at(run.track_id, run.first_frame) else { continue };
        let r = score_run(sourced, run.instances(), scene, forecaster, dt);
        total.scores.merge(&r.scores);
        total.instances.extend(r.instances);
        total.failed += r.failed;
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trajectory::{Source, Track};
    use dynotraj_core::wire::ObjectClass;

    #[test]
    fn cv_is_exact_on_constant_velocity_and_counts_pairs() {
        let frames: Vec<u32> = (0..40).collect();
        let states: Vec<BevState> = frames.iter().map(|&k| BevState { x: 0.5 * k as f32, y: 0.1 * k as f32, heading: 0.0, speed: 0.0 }).collect();
        let scene = Scene::new(&[Track { track_id: 1, class: ObjectClass::Car, frames, states }], Source::Gt, 0.1);
        let r = score_run(&scene.runs[0], 1..10, &scene, &mut Baseline::ConstantVelocity, 0.1);
        assert_eq!(r.scores.ade.count(), 9);
        assert_eq!(r.scores.ace.count(), 8);
        assert_eq!(r.instances.len(), 9);
        assert!(r.scores.ade.value().unwrap_or(1.0) < 1e-4);
        assert!(r.scores.ace.value().unwrap_or(1.0) < 1e-4);
    }
}
