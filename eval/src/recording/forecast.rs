//! The recording of the edge's forecasts over a tracks recording: each object's history as the
//! edge reported it, the edge's forecasts and, beside a model's, constant velocity's.

use std::collections::BTreeMap;
use std::path::Path;

use dynotraj_bag::record::{
    Line, Pose, Recorder, RecordingEncoding, RecordingSummary, Rgba, Trails, forecast_line, ground, meta,
};
use dynotraj_core::geometry::{BevState, Point2};
use dynotraj_core::limits::{HORIZON, MAX_HISTORY};
use dynotraj_core::predict::{Forecast, constant_velocity};
use dynotraj_core::wire::{EstimateKind, Message, ObjectStates, Prediction};
use dynotraj_formats::tracks_file::Tracks;
use dynotraj_link::stream::StreamResult;

/// Colour of the objects' histories.
const HISTORY_COLOR: Rgba = Rgba::opaque(0.2, 0.6, 1.0);
/// Colour of the edge's forecasts.
const FORECAST_COLOR: Rgba = Rgba::opaque(1.0, 0.4, 0.1);
/// Colour of the constant-velocity forecasts made here beside a model's, apart from the edge's.
const CV_COLOR: Rgba = Rgba::opaque(0.7, 0.7, 0.7);

/// What the edge forecast with in a run being recorded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Forecaster {
    /// Constant velocity (no model): its forecasts are the edge's own, on `/forecasts/cv`.
    ConstantVelocity,
    /// A learned model: its forecasts on `/forecasts/learned`, and constant velocity computed
    /// here on `/forecasts/cv` for comparison.
    Learned,
}

/// Writes the recording of a forecast run to `path`: per frame sent (log time: frame index
/// over the camera's frame rate), the camera's causal pose on `/tf`, each object's history on
/// `/objects/tracks` (its causal bird's-eye states so far, as the edge reported them) and its
/// forecasts from that frame, all as lines in the bird's-eye plane (z = 0). The edge's own
/// forecasts go to `/forecasts/cv` or `/forecasts/learned` (`forecaster`); with a learned
/// model, `/forecasts/cv` holds constant velocity ([`cv_forecasts`]) for the same objects and
/// frames, so the two can be compared. Every frame has one message per forecast and history
/// topic, empty when the edge said nothing of it.
///
/// # Errors
/// Writing errors, named.
pub fn record_forecasts(
    path: &Path,
    encoding: RecordingEncoding,
    tracks: &Tracks,
    result: &StreamResult,
    forecaster: Forecaster,
) -> anyhow::Result<RecordingSummary> {
    let rate = f64::from(tracks.camera.frame_rate_hz);
    let mut states: BTreeMap<u32, &ObjectStates> = BTreeMap::new();
    let mut predictions: BTreeMap<u32, Vec<&Prediction>> = BTreeMap::new();
    for m in &result.replies {
        match m {
            Message::ObjectStates(s) if s.kind == EstimateKind::Causal => {
                states.insert(s.frame, s);
            }
            Message::Prediction(p) => predictions.entry(p.frame).or_default().push(p),
            _ => {}
        }
    }
    let cv = match forecaster {
        Forecaster::ConstantVelocity => None,
        // The edge's frame period, 1 / the camera model's rate: its forecasts' dt too.
        Forecaster::Learned => Some(cv_forecasts(&states, &predictions, 1.0 / tracks.camera.frame_rate_hz)),
    };
    let mut rec = Recorder::create_with(path, encoding)?;
    let mut history = Trails::new(HISTORY_COLOR);
    for frame in &tracks.frames {
        let t = rec.frame_time(frame.frame, rate)?;
        let mut lines = Vec::new();
        if let Some(s) = states.get(&frame.frame) {
            let c = &s.camera;
            let pose = Pose::from_camera_world(c.translation.map(f64::from), c.rotation.map(f64::from));
            rec.camera_transform("/tf", t, &pose)?;
            for o in s.objects.iter().filter(|o| o.state.is_finite()) {
                let point = ground(o.state.x, o.state.y);
                lines.push(history.extend(o.object_id, point, meta("class", format!("{:?}", o.class))));
            }
        }
        rec.lines("/objects/tracks", t, &lines)?;
        let edge: Vec<(u16, &[Point2])> =
            predictions.get(&frame.frame).into_iter().flatten().map(|p| (p.object_id, p.points.as_slice())).collect();
        match &cv {
            None => rec.lines("/forecasts/cv", t, &forecast_entities(&edge, "cv", FORECAST_COLOR))?,
            Some(cv) => {
                rec.lines("/forecasts/learned", t, &forecast_entities(&edge, "learned", FORECAST_COLOR))?;
                let ours: Vec<(u16, &[Point2])> =
                    cv.get(&frame.frame).into_iter().flatten().map(|(id, points)| (*id, points.as_slice())).collect();
                rec.lines("/forecasts/cv", t, &forecast_entities(&ours, "cv", CV_COLOR))?;
            }
        }
    }
    rec.finish()
}

/// Forecasts (object id, bird's-eye points) as line entities, each labelled with `predictor`.
fn forecast_entities(forecasts: &[(u16, &[Point2])], predictor: &str, color: Rgba) -> Vec<Line> {
    forecasts
        .iter()
        .map(|(id, points)| {
            forecast_line(id, points.iter().map(|q| ground(q.x, q.y)).collect(), color, meta("predictor", predictor))
        })
        .collect()
}

/// Constant-velocity forecasts ([`constant_velocity`], [`HORIZON`] points `dt` apart) for each
/// (frame, object) the edge forecast, from the object's causal bird's-eye states up to that
/// frame as the edge reported them: its run of consecutive frames ending there, so that a lost
/// frame restarts the history as it does on the edge. Frame -> (object id, points); an object
/// whose history is too short or implausible for constant velocity has none.
///
/// The edge also restarts a history when the estimator re-orients an object's frame, which its
/// reports do not say. That does not matter here: the edge forecasts nothing from a history of
/// one state, and constant velocity reads the last two, so the forecasts are the ones the edge
/// makes without a model (tests/tests/recording.rs holds the two equal).
#[must_use]
pub fn cv_forecasts(
    states: &BTreeMap<u32, &ObjectStates>,
    predictions: &BTreeMap<u32, Vec<&Prediction>>,
    dt: f32,
) -> BTreeMap<u32, Vec<(u16, Vec<Point2>)>> {
    // Each object's current run: (frame of its newest state, its states, oldest first).
    let mut runs: BTreeMap<u16, (u32, Vec<BevState>)> = BTreeMap::new();
    let mut out: BTreeMap<u32, Vec<(u16, Vec<Point2>)>> = BTreeMap::new();
    for (&frame, s) in states {
        for o in &s.objects {
            let run = runs.entry(o.object_id).or_insert_with(|| (frame, Vec::new()));
            if run.0.checked_add(1) != Some(frame) {
                run.1.clear();
            }
            run.0 = frame;
            run.1.push(o.state);
            // Constant velocity reads the newest states only; the edge keeps as many.
            if run.1.len() > MAX_HISTORY + 1 {
                run.1.remove(0);
            }
        }
        for p in predictions.get(&frame).into_iter().flatten() {
            let Some((_, history)) = runs.get(&p.object_id).filter(|(last, _)| *last == frame) else { continue };
            let mut points: Forecast = [Point2::new(0.0, 0.0); HORIZON];
            if constant_velocity(history, dt, &mut points).is_ok() {
                out.entry(frame).or_default().push((p.object_id, points.to_vec()));
            }
        }
    }
    out
}
