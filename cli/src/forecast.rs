//! `dynotraj forecast`: the edge's session run in this process over a tracks recording (or a
//! simulated sequence), with a model or with constant velocity, and its forecasts written as
//! `dynotraj stream` writes them. No edge process, no link, no pacing: the same bytes the edge
//! would receive, the same session code, the same answers.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::Context as _;
use clap::Args;
use dynotraj_bag::record::{Line, Pose, Recorder, RecordingSummary, Rgba, frame_time_ns};
use dynotraj_core::model::signed;
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
    /// with, per frame, each object's history (`/objects/tracks`), its forecast
    /// (`/forecasts/cv`, or `/forecasts/learned` with --model) and the camera (`/tf`). A forecast
    /// is one sequence, so FILE is the recording itself.
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
    std::fs::write(&path, &out.result.raw).with_context(|| format!("--out: writing {}", path.display()))?;
    if let Some(file) = &args.record {
        let predictor = if args.model.is_some() { "learned" } else { "cv" };
        let written = record(file, &tracks, &out.result, predictor).context("--record")?;
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
/// Colour of the forecasts.
const FORECAST_COLOR: Rgba = Rgba::opaque(1.0, 0.4, 0.1);

/// Writes the recording of a forecast run to `path`: per frame sent (log time: frame index
/// over the camera's frame rate), the camera's causal pose on `/tf`, each object's history on
/// `/objects/tracks` (its causal bird's-eye states so far, as the edge reported them) and its
/// forecast from that frame on `/forecasts/<predictor>`, both as lines in the bird's-eye plane
/// (z = 0). Every frame has one message per topic, empty when the edge said nothing of it.
///
/// # Errors
/// Writing errors, named.
pub fn record(
    path: &Path,
    tracks: &Tracks,
    result: &StreamResult,
    predictor: &str,
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
    let forecasts_topic = format!("/forecasts/{predictor}");
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
        let forecasts: Vec<Line> = predictions
            .get(&frame.frame)
            .into_iter()
            .flatten()
            .map(|p| Line {
                id: p.object_id.to_string(),
                points: p.points.iter().map(|q| ground(q.x, q.y)).collect(),
                color: FORECAST_COLOR,
                thickness: 0.25,
                metadata: vec![("predictor".into(), predictor.to_string())],
            })
            .collect();
        rec.lines(&forecasts_topic, t, &forecasts)?;
    }
    rec.finish()
}

/// A bird's-eye position on the recording's ground plane.
fn ground(x: f32, y: f32) -> [f64; 3] {
    [f64::from(x), f64::from(y), 0.0]
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
