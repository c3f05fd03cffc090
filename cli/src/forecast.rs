//! `dynotraj forecast`: the edge's session run in this process over a tracks recording (or a
//! simulated sequence), with a model or with constant velocity, and its forecasts written as
//! `dynotraj stream` writes them. No edge process, no link, no pacing: the same bytes the edge
//! would receive, the same session code, the same answers.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::Context as _;
use clap::Args;
use dynotraj_bag::record::{Line, Pose, Recorder, RecordingSummary, Rgba, frame_time_ns, ground};
use dynotraj_core::geometry::{BevState, Point2};
use dynotraj_core::limits::{HORIZON, MAX_HISTORY};
use dynotraj_core::model::signed;
use dynotraj_core::predict::{Forecast, constant_velocity};
use dynotraj_core::wire::{DecoderStats, EstimateKind, FrameDecoder, LinkStats, Message, ObjectStates, Prediction};
use dynotraj_edge::{NoClock, Session, Split};
use dynotraj_eval::report::stream_report::predictions_data;
use dynotraj_eval::report::write_table_files;
use dynotraj_formats::model_file::read_model_file;
use dynotraj_formats::tracks_file::Tracks;
use dynotraj_link::stream::StreamResult;
use dynotraj_link::wire_io::WireSender;

use super::stream::{FORECASTS, REPLIES_BIN, TracksInputArgs};

/// Options of `dynotraj forecast`.
#[derive(Debug, Args)]
pub struct ForecastArgs {
    /// Where the tracks come from.
    #[command(flatten)]
    pub input: TracksInputArgs,
    /// Only the first N frames.
    #[arg(long, value_name = "N")]
    pub frames: Option<usize>,
    /// A model blob, signed (`dynotraj sign`, checked against the key this build's edge is
    /// provisioned with, as the edge would) or not (taken as a model linked into the edge).
    /// Without it the edge forecasts with constant velocity.
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// Folder for `forecasts.csv` / `.json` (frame, object_id, step, x, y: world bird's-eye,
    /// metres, as `dynotraj stream` writes them) and `replies.bin` (the edge's replies, wire
    /// frames).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Also write a recording to look at in Foxglove: an MCAP file (Foxglove's schemas, JSON)
    /// with, per frame, each object's history (`/objects/tracks`), its constant-velocity
    /// forecast (`/forecasts/cv`), with --model also the model's (`/forecasts/learned`), and the
    /// camera (`/tf`). A forecast is one sequence, so FILE is the recording itself.
    #[arg(long, value_name = "FILE")]
    pub record: Option<PathBuf>,
}

/// What an in-process session answered.
#[derive(Debug)]
pub struct Forecasts {
    /// The edge's replies, decoded, as a stream would have collected them.
    pub result: StreamResult,
    /// Camera frames sent.
    pub frames: usize,
}

/// Runs `dynotraj forecast`.
///
/// # Errors
/// Input, model or output errors, named.
pub fn run(args: &ForecastArgs) -> anyhow::Result<()> {
    crate::common::output_folder("--out", &args.out)?;
    let tracks = args.input.load(args.frames)?;
    let model = args.model.as_deref().map(model_blob).transpose()?;
    let out = forecast(&tracks, model.as_deref())?;
    write_table_files(&args.out, FORECASTS, &predictions_data(&out.result))?;
    let path = args.out.join(REPLIES_BIN);
    dynotraj_formats::atomic::write_file(&path, &out.result.raw)
        .with_context(|| format!("--out: writing {}", path.display()))?;
    if let Some(file) = &args.record {
        let forecaster = if args.model.is_some() { Forecaster::Learned } else { Forecaster::ConstantVelocity };
        let written = record(file, &tracks, &out.result, forecaster).context("--record")?;
        eprintln!("recorded {} ({} bytes)", written.path.display(), written.bytes);
    }
    let forecasts = out.result.replies.iter().filter(|m| matches!(m, Message::Prediction(_))).count();
    println!(
        "{} frames, {forecasts} forecasts ({}); written to {}",
        out.frames,
        out.result.forecaster().map_or_else(|| "forecaster not said".to_string(), |f| f.to_string()),
        args.out.display()
    );
    Ok(())
}

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
pub fn record(
    path: &Path,
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
    let mut rec = Recorder::create(path)?;
    let mut history: BTreeMap<u16, Vec<[f64; 3]>> = BTreeMap::new();
    for frame in &tracks.frames {
        let t = frame_time_ns(frame.frame, rate).with_context(|| format!("recording {}", path.display()))?;
        let mut lines = Vec::new();
        if let Some(s) = states.get(&frame.frame) {
            let c = &s.camera;
            let pose = Pose::from_camera_world(c.translation.map(f64::from), c.rotation.map(f64::from));
            rec.camera_transform("/tf", t, &pose)?;
            for o in s.objects.iter().filter(|o| o.state.is_finite()) {
                let points = history.entry(o.object_id).or_default();
                points.push(ground(o.state.x, o.state.y));
                lines.push(Line {
                    id: o.object_id.to_string(),
                    points: points.clone(),
                    color: HISTORY_COLOR,
                    thickness: 0.15,
                    metadata: vec![("class".into(), format!("{:?}", o.class))],
                });
            }
        }
        rec.lines("/objects/tracks", t, &lines)?;
        let edge: Vec<(u16, &[Point2])> =
            predictions.get(&frame.frame).into_iter().flatten().map(|p| (p.object_id, p.points.as_slice())).collect();
        match &cv {
            None => rec.lines("/forecasts/cv", t, &forecast_lines(&edge, "cv", FORECAST_COLOR))?,
            Some(cv) => {
                rec.lines("/forecasts/learned", t, &forecast_lines(&edge, "learned", FORECAST_COLOR))?;
                let ours: Vec<(u16, &[Point2])> =
                    cv.get(&frame.frame).into_iter().flatten().map(|(id, points)| (*id, points.as_slice())).collect();
                rec.lines("/forecasts/cv", t, &forecast_lines(&ours, "cv", CV_COLOR))?;
            }
        }
    }
    rec.finish()
}

/// Forecasts (object id, bird's-eye points) as line entities, each labelled with `predictor`.
fn forecast_lines(forecasts: &[(u16, &[Point2])], predictor: &str, color: Rgba) -> Vec<Line> {
    forecasts
        .iter()
        .map(|(id, points)| Line {
            id: id.to_string(),
            points: points.iter().map(|q| ground(q.x, q.y)).collect(),
            color,
            thickness: 0.25,
            metadata: vec![("predictor".into(), predictor.to_string())],
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

/// The model blob of the file at `path`: a signed one verified against the provisioned key.
fn model_blob(path: &Path) -> anyhow::Result<Vec<u8>> {
    let bytes = read_model_file(path).context("--model")?;
    let blob = match signed::verify(&bytes, &dynotraj_edge::provisioned::MODEL_KEY) {
        Ok(blob) => blob.to_vec(),
        Err(signed::SignatureError::Unsigned) => bytes,
        Err(e) => anyhow::bail!("--model {}: {}", path.display(), dynotraj_formats::model_signing::describe(&e)),
    };
    dynotraj_core::model::blob::ModelBlob::parse_exact(&blob)
        .map_err(|e| anyhow::anyhow!("--model {}: expected a model blob, {e}", path.display()))?;
    Ok(blob)
}

/// The edge's session over `tracks` in this process: the host's side of the link (camera
/// model, every frame's parts, the goodbye) as bytes into [`Session::run`], its replies
/// decoded. With `model`, the session forecasts with it.
///
/// # Errors
/// A model the edge refuses, or a message that cannot be encoded.
pub fn forecast(tracks: &Tracks, model: Option<&[u8]>) -> anyhow::Result<Forecasts> {
    let mut host = WireSender::new(Vec::new());
    host.send(&Message::CameraInfo(tracks.camera))?;
    for frame in &tracks.frames {
        for part in &frame.parts {
            host.send(&Message::FrameTracks(part.clone()))?;
        }
    }
    let frames_sent = u32::try_from(host.sent() + 1).unwrap_or(u32::MAX);
    host.send(&Message::LinkStats(LinkStats { frames_sent, received: DecoderStats::default() }))?;
    let input = host.into_writer();
    let mut session: Box<Session<'_>> = Box::new(match model {
        Some(blob) => Session::with_model(blob).map_err(|e| anyhow::anyhow!("--model: the edge refuses it: {e}"))?,
        None => Session::new(),
    });
    let mut link = Split(input.as_slice(), Vec::new());
    session.run(&mut link, &mut NoClock).map_err(|e| anyhow::anyhow!("the in-process edge: {e:?}"))?;
    let raw = link.1;
    let replies: Vec<Message> = FrameDecoder::new().feed(&raw).collect();
    let notices = replies.iter().filter_map(|m| if let Message::Notice(n) = m { Some(*n) } else { None }).collect();
    let edge_link = replies.iter().find_map(|m| if let Message::LinkStats(l) = m { Some(*l) } else { None });
    let result = StreamResult { replies, raw, notices, edge_link, ..StreamResult::default() };
    Ok(Forecasts { result, frames: tracks.frames.len() })
}
