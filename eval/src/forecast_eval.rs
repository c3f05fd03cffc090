//! Scoring forecasts on eligible runs: the paper's protocol, in which each source's forecasts are
//! scored against that source's own future, and scoring against one common reference (the
//! simulator's truth) on one common set of instances, which the paper cannot do.
//!
//! Against the common reference, a forecast is compared as a displacement from the current
//! frame: forecast point k minus the source's current position against true point k minus the
//! true current position. Each source's positions refer to its own point of the object (the
//! labels and the truth to the box, the estimator to the centroid of the object's first tracked
//! points), and a fixed offset between those points is not a forecast error. What remains is
//! the offset turned by the object's heading change over the horizon (offset x angle: about
//! 0.1 m for 2 m and 3 degrees). A source in its own world (the estimator's, which drifts from
//! the truth's as its camera errors add up) has the true displacement turned into its world by
//! the yaw between its camera and the true camera at the forecast's frame.

use dynotraj_core::limits::HORIZON;
use dynotraj_core::metrics::{ForecastScores, ace, ade, fde, step_errors};
use dynotraj_core::predict::{Forecast, PredictError, Predictor, carry_forward};
use dynotraj_core::{BevState, Point2};

use dynotraj_sources::scene::{Scene, SourcedRun};
use dynotraj_sources::trajectory::EligibleRun;

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

/// Displacement errors per step of the horizon, summed over scored forecasts: the mean at step
/// k is the FDE of a k-step horizon, and the mean of the first k of those means is its ADE (at
/// k = `HORIZON`, the scores' FDE and ADE).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct HorizonErrors {
    sums: [f64; HORIZON],
    count: u32,
}

impl HorizonErrors {
    /// Adds one forecast's errors against `truth` (both `HORIZON` points; others are left out).
    pub fn push(&mut self, forecast: &[Point2], truth: &[Point2]) {
        if forecast.len() != HORIZON {
            return;
        }
        let Some(errors) = step_errors(forecast, truth) else { return };
        for (sum, e) in self.sums.iter_mut().zip(errors) {
            *sum += f64::from(e);
        }
        self.count += 1;
    }

    /// Adds another's forecasts.
    pub fn merge(&mut self, other: &Self) {
        for (a, b) in self.sums.iter_mut().zip(&other.sums) {
            *a += b;
        }
        self.count += other.count;
    }

    /// Forecasts added.
    #[must_use]
    pub const fn count(&self) -> u32 {
        self.count
    }

    /// The mean error at each step k = 1..=`HORIZON` (FDE of a k-step horizon), metres; empty
    /// before any forecast.
    #[must_use]
    pub fn fde_by_step(&self) -> Vec<f64> {
        if self.count == 0 {
            return Vec::new();
        }
        self.sums.iter().map(|s| s / f64::from(self.count)).collect()
    }

    /// The ADE of each horizon k = 1..=`HORIZON` (the mean error over steps 1..=k), metres;
    /// empty before any forecast.
    #[must_use]
    pub fn ade_by_step(&self) -> Vec<f64> {
        let mut total = 0.0;
        self.fde_by_step()
            .iter()
            .enumerate()
            .map(|(i, e)| {
                total += e;
                total / (i + 1) as f64
            })
            .collect()
    }
}

/// Scores of one run.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ForecastRunScores {
    /// ADE, FDE and ACE means.
    pub scores: ForecastScores,
    /// Each scored instance, in frame order.
    pub instances: Vec<InstanceScore>,
    /// Instances the predictor refused (see [`PredictError`]); they are not scored.
    pub failed: u32,
    /// The scored forecasts' errors per horizon step.
    pub horizon: HorizonErrors,
    /// Each run's scores, in order (one entry for a single run's scores).
    pub runs: Vec<ForecastScores>,
}

/// What forecasts are scored against.
#[derive(Debug, Clone, Copy)]
pub enum Reference<'a> {
    /// The source's own future (the paper's protocol).
    OwnFuture,
    /// The tracks of `truth` (the simulator's true paths, by track id), as displacements from
    /// the current frame, at the instances (track id, frame) in `only`.
    Common {
        /// The reference paths.
        truth: &'a Scene,
        /// The instances scored.
        only: &'a std::collections::BTreeSet<(i32, u32)>,
        /// For a source in its own world (the estimator's), the yaw per frame that turns it
        /// into the truth's; `None` when the source is in the truth's world (the labels).
        world_yaw: Option<&'a std::collections::BTreeMap<u32, f32>>,
    },
}

impl Reference<'_> {
    /// The 30 points a forecast made at instance `s` (frame `frame`) of `run` is held to, in
    /// the source's world, or `None` when this instance is not scored.
    fn future(&self, run: &SourcedRun, s: usize, frame: u32) -> Option<Vec<Point2>> {
        match self {
            Self::OwnFuture => Some(run.states.get(s + 1..=s + HORIZON)?.iter().map(BevState::position).collect()),
            Self::Common { truth, only, world_yaw } => {
                if !only.contains(&(run.track_id, frame)) {
                    return None;
                }
                let current = run.states.get(s)?.position();
                let path = truth.run_at(run.track_id, frame)?;
                let k = usize::try_from(frame - path.first_frame).ok()?;
                let anchor = path.states.get(k)?.position();
                let future = path.states.get(k + 1..=k + HORIZON)?;
                // A true displacement, turned from the truth's world into the source's.
                let yaw = match world_yaw {
                    Some(m) => -*m.get(&frame)?,
                    None => 0.0,
                };
                let (sin, cos) = yaw.sin_cos();
                Some(
                    future
                        .iter()
                        .map(|p| {
                            let (dx, dy) = (p.x - anchor.x, p.y - anchor.y);
                            Point2::new(current.x + cos * dx - sin * dy, current.y + sin * dx + cos * dy)
                        })
                        .collect(),
                )
            }
        }
    }
}

/// The forecast of `forecaster` at instance `s` (an index into `run.states`) as scoring makes
/// it: the history is `run.states[..=s]` (the predictor keeps the newest frames it uses), the
/// neighbours the other runs of `scene` present at that frame, the observer `scene`'s.
///
/// # Errors
/// See [`PredictError`].
pub fn forecast_at(
    run: &SourcedRun,
    s: usize,
    scene: &Scene,
    forecaster: &mut dyn Predictor,
    dt: f32,
) -> Result<Forecast, PredictError> {
    let history = run.states.get(..=s).ok_or(PredictError::HistoryTooShort)?;
    let frame = run.first_frame + s as u32;
    let neighbours = scene.neighbours_at(run.track_id, frame);
    let mut forecast = [Point2::default(); HORIZON];
    forecaster.predict_in_context(history, &scene.context_at(&neighbours, frame), dt, &mut forecast)?;
    Ok(forecast)
}

/// Forecasts every test instance (indices into `run.states`) and scores each against the same
/// source's future. The history of instance s is `run.states[..=s]` (the predictor keeps the
/// newest frames it uses); neighbours are the other runs of `scene` present at the frame. ACE
/// pairs the forecasts of consecutive instances, each blended with the one before as the
/// forecaster's [`Predictor::carry`] says.
pub fn score_run(
    run: &SourcedRun,
    instances: std::ops::Range<usize>,
    scene: &Scene,
    forecaster: &mut dyn Predictor,
    dt: f32,
) -> ForecastRunScores {
    score_run_against(run, instances, scene, forecaster, dt, Reference::OwnFuture)
}

/// As [`score_run`], against `reference`; instances it does not score are skipped (and end the
/// ACE pairing, as a refused forecast does).
pub fn score_run_against(
    run: &SourcedRun,
    instances: std::ops::Range<usize>,
    scene: &Scene,
    forecaster: &mut dyn Predictor,
    dt: f32,
    reference: Reference<'_>,
) -> ForecastRunScores {
    let mut out = ForecastRunScores::default();
    let mut previous: Option<Forecast> = None;
    for s in instances {
        if run.states.get(s + 1..=s + HORIZON).is_none() {
            break;
        }
        let frame = run.first_frame + s as u32;
        let Some(truth) = reference.future(run, s, frame) else {
            previous = None;
            continue;
        };
        match forecast_at(run, s, scene, forecaster, dt) {
            Ok(mut forecast) => {
                if let Some(p) = &previous {
                    carry_forward(p, forecaster.carry(), &mut forecast);
                }
                let (Some(a), Some(f)) = (ade(&forecast, &truth), fde(&forecast, &truth)) else { continue };
                out.scores.ade.push(a);
                out.scores.fde.push(f);
                out.horizon.push(&forecast, &truth);
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

/// The (track id, frame) of every test instance of `runs`.
#[must_use]
pub fn instance_keys(runs: &[EligibleRun]) -> std::collections::BTreeSet<(i32, u32)> {
    runs.iter().flat_map(|r| r.instances().map(move |s| (r.track_id, r.first_frame + s as u32))).collect()
}

/// Scores `forecaster` on every eligible run of one sequence through `scene` (the sequence's
/// tracks through the source being scored).
pub fn score_sequence(
    runs: &[EligibleRun],
    scene: &Scene,
    forecaster: &mut dyn Predictor,
    dt: f32,
) -> ForecastRunScores {
    score_sequence_against(runs, scene, forecaster, dt, Reference::OwnFuture)
}

/// As [`score_sequence`], against `reference`.
pub fn score_sequence_against(
    runs: &[EligibleRun],
    scene: &Scene,
    forecaster: &mut dyn Predictor,
    dt: f32,
    reference: Reference<'_>,
) -> ForecastRunScores {
    let mut total = ForecastRunScores::default();
    for run in runs {
        let Some(sourced) = scene.run_at(run.track_id, run.first_frame) else { continue };
        let r = score_run_against(sourced, run.instances(), scene, forecaster, dt, reference);
        total.scores.merge(&r.scores);
        total.runs.push(r.scores);
        total.horizon.merge(&r.horizon);
        total.instances.extend(r.instances);
        total.failed += r.failed;
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynotraj_core::predict::Baseline;
    use dynotraj_core::wire::ObjectClass;
    use dynotraj_sources::trajectory::{ObjectTrack, Source};

    #[test]
    fn cv_is_exact_on_constant_velocity_and_counts_pairs() {
        let frames: Vec<u32> = (0..40).collect();
        let states: Vec<BevState> = frames
            .iter()
            .map(|&k| BevState { x: 0.5 * k as f32, y: 0.1 * k as f32, heading: 0.0, speed: 0.0 })
            .collect();
        let scene =
            Scene::new(&[ObjectTrack { track_id: 1, class: ObjectClass::Car, frames, states }], Source::Gt, 0.1);
        let r = score_run(&scene.runs[0], 1..10, &scene, &mut Baseline::ConstantVelocity, 0.1);
        assert_eq!(r.scores.ade.count(), 9);
        assert_eq!(r.scores.ace.count(), 8);
        assert_eq!(r.instances.len(), 9);
        assert!(r.scores.ade.value().unwrap_or(1.0) < 1e-4);
        assert!(r.scores.ace.value().unwrap_or(1.0) < 1e-4);
    }

    #[test]
    fn errors_by_horizon_step_end_at_the_scores_ade_and_fde() {
        let frames: Vec<u32> = (0..60).collect();
        // A bend: cv's error grows with the horizon.
        let states: Vec<BevState> = frames
            .iter()
            .map(|&k| BevState { x: 0.5 * k as f32, y: 0.004 * (k * k) as f32, heading: 0.0, speed: 0.0 })
            .collect();
        let scene =
            Scene::new(&[ObjectTrack { track_id: 1, class: ObjectClass::Car, frames, states }], Source::Gt, 0.1);
        let r = score_run(&scene.runs[0], 1..25, &scene, &mut Baseline::ConstantVelocity, 0.1);
        assert_eq!(r.horizon.count(), r.scores.fde.count());
        let (fde, ade) = (r.horizon.fde_by_step(), r.horizon.ade_by_step());
        assert_eq!((fde.len(), ade.len()), (HORIZON, HORIZON));
        let close = |a: f64, b: f64| (a - b).abs() < 1e-4 * b.abs().max(1.0);
        assert!(close(fde[HORIZON - 1], r.scores.fde.value().unwrap_or(f64::NAN)), "{fde:?}");
        assert!(close(ade[HORIZON - 1], r.scores.ade.value().unwrap_or(f64::NAN)), "{ade:?}");
        assert!(fde.windows(2).all(|w| w[0] < w[1]), "a bend's error grows with the horizon: {fde:?}");
        assert!(close(ade[0], fde[0]) && ade[HORIZON - 1] < fde[HORIZON - 1]);
        assert!(HorizonErrors::default().fde_by_step().is_empty());
    }

    #[test]
    fn the_common_reference_ignores_a_fixed_offset_and_scores_only_shared_instances() {
        let frames: Vec<u32> = (0..40).collect();
        let line = |dx: f32, bend: f32| -> Vec<BevState> {
            frames
                .iter()
                .map(|&k| BevState { x: dx + 0.5 * k as f32, y: bend * (k as f32).powi(2), heading: 0.0, speed: 0.0 })
                .collect()
        };
        let track = |states| ObjectTrack { track_id: 1, class: ObjectClass::Car, frames: frames.clone(), states };
        // The source refers to a point 5 m ahead of the truth's; the truth bends away.
        let source = Scene::new(&[track(line(5.0, 0.0))], Source::Gt, 0.1);
        let truth = Scene::new(&[track(line(0.0, 0.01))], Source::Gt, 0.1);
        let only: std::collections::BTreeSet<(i32, u32)> = [(1, 2), (1, 3), (1, 7)].into();
        let common = Reference::Common { truth: &truth, only: &only, world_yaw: None };
        let r = score_run_against(&source.runs[0], 1..10, &source, &mut Baseline::ConstantVelocity, 0.1, common);
        assert_eq!(r.instances.iter().map(|i| i.frame).collect::<Vec<_>>(), vec![2, 3, 7]);
        assert_eq!(r.scores.ace.count(), 1, "pairs only of consecutive scored instances");
        // Straight cv against the bend: the error is the bend's displacement, not the 5 m offset.
        // At frame 2 the truth's displacement after k steps is 0.01 ((2 + k)^2 - 4), the
        // straight forecast's is 0 across.
        let bend_ade = (1..=30).map(|k| 0.01 * (((2 + k) * (2 + k) - 4) as f32)).sum::<f32>() / 30.0;
        let first = r.instances[0].ade;
        assert!((first - bend_ade).abs() < 1e-3, "{first} vs {bend_ade}");
        // With its own future the straight source is exact.
        let own = score_run(&source.runs[0], 1..10, &source, &mut Baseline::ConstantVelocity, 0.1);
        assert!(own.scores.ade.value().unwrap_or(1.0) < 1e-4);
    }

    #[test]
    fn the_common_reference_turns_the_truth_into_the_sources_world() {
        let frames: Vec<u32> = (0..40).collect();
        let track = |dx: f32, dy: f32| ObjectTrack {
            track_id: 1,
            class: ObjectClass::Car,
            frames: frames.clone(),
            states: frames
                .iter()
                .map(|&k| BevState { x: dx * k as f32, y: dy * k as f32, heading: 0.0, speed: 0.0 })
                .collect(),
        };
        // The source's world is the truth's turned by a quarter turn: the truth's +x is its +y.
        let source = Scene::new(&[track(0.0, 0.5)], Source::Gt, 0.1);
        let truth = Scene::new(&[track(0.5, 0.0)], Source::Gt, 0.1);
        let only: std::collections::BTreeSet<(i32, u32)> = (1..10).map(|f| (1, f)).collect();
        let yaw: std::collections::BTreeMap<u32, f32> =
            frames.iter().map(|&f| (f, -std::f32::consts::FRAC_PI_2)).collect();
        let score = |world_yaw| {
            let r = score_run_against(
                &source.runs[0],
                1..10,
                &source,
                &mut Baseline::ConstantVelocity,
                0.1,
                Reference::Common { truth: &truth, only: &only, world_yaw },
            );
            r.scores.ade.value().unwrap_or(f64::NAN)
        };
        assert!(score(Some(&yaw)) < 1e-4, "{}", score(Some(&yaw)));
        assert!(score(None) > 5.0, "unaligned worlds disagree: {}", score(None));
    }
}
