//! `dynotraj stream`: sends a recorded (or simulated) tracks stream to an edge over TCP or a
//! serial port, paced at the camera rate, and collects its object states, forecasts and
//! per-frame statistics.

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::Context as _;
use clap::Args;
use dynotraj_core::limits::PAPER_FRAME_RATE_HZ;
use dynotraj_core::wire::{Forecaster, Notice, ObjectClass};
use dynotraj_sim::track_sim::{SimSpec, simulate};

use super::common::{KITTI_ENV, kitti_or_env, one_sequence, progress};
use dynotraj_eval::report::stream_report::{frames_data, predictions_data, summary};
use dynotraj_eval::report::write_table_files;
use dynotraj_formats::kitti::TrackingDir;
use dynotraj_formats::tracks_file::{self, Tracks, TracksFrame};
use dynotraj_link::endpoint::{Endpoint, connect};
use dynotraj_link::stream::{StreamOptions, StreamResult, stream};
use dynotraj_sources::estimation::input::{KITTI_IMAGE_SIZE, sim_input};
use dynotraj_sources::estimation::simulated::camera_info;

/// Options of `dynotraj stream`.
#[derive(Debug, Args)]
pub struct StreamArgs {
    /// Where the tracks come from.
    #[command(flatten)]
    pub input: TracksInputArgs,
    /// Only the first N frames.
    #[arg(long, value_name = "N")]
    pub frames: Option<usize>,
    /// The edge: tcp://HOST:PORT or serial:PATH.
    #[arg(long, value_name = "ENDPOINT")]
    pub to: Endpoint,
    /// Frames per second to send at (default: the stream's camera rate; 0: as fast as possible).
    #[arg(long, value_parser = crate::numbers::send_rate, value_name = "HZ")]
    pub rate: Option<f64>,
    /// Send a frame only after the edge answered the previous one (no loss from overrun).
    #[arg(long)]
    pub lockstep: bool,
    /// A signed model blob (`dynotraj sign`) to load into the edge before the frames; the edge
    /// refuses, and counts, one not signed by the key it was built with.
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// Folder for what came back: `forecasts.csv` (frame, object_id, step, x, y: world
    /// bird's-eye, metres), `frames.csv` (per-frame latency, compute and losses) and
    /// `replies.bin` (the edge's replies as received, wire frames).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Seconds to wait for the edge: to connect, per answer in lockstep, for its goodbye.
    #[arg(long, value_parser = crate::numbers::seconds, default_value_t = 30.0, value_name = "S")]
    pub timeout: f64,
}

/// Runs `dynotraj stream`.
///
/// # Errors
/// Input, link or output errors, named.
pub fn run(args: &StreamArgs) -> anyhow::Result<()> {
    args.out.as_deref().map(|d| dynotraj_formats::atomic::output_folder("--out", d)).transpose()?;
    let tracks = args.input.load(args.frames)?;
    let model =
        args.model.as_ref().map(|p| dynotraj_formats::model_file::read_model_file(p).context("--model")).transpose()?;
    if let (Some(bytes), Some(p)) = (&model, &args.model)
        && let Err(e) = dynotraj_core::model::signed::split(bytes)
    {
        eprintln!(
            "warning: --model {}: {}; the edge will refuse it",
            p.display(),
            dynotraj_formats::model_signing::describe(&e)
        );
    }
    let timeout = Duration::from_secs_f64(args.timeout.max(0.0));
    let rate = args.rate.unwrap_or(f64::from(tracks.camera.frame_rate_hz));
    let stop = crate::interrupt::stop_flag()?;
    let bar = std::sync::Arc::new(progress(tracks.frames.len() as u64, "frames sent"));
    let opt = StreamOptions {
        rate_hz: (rate > 0.0).then_some(rate),
        lockstep: args.lockstep,
        reply_timeout: timeout,
        model,
        stop: Some(stop),
        on_frame: Some(dynotraj_link::OnFrame(bar.hook().shared())),
    };
    let (rx, tx) = connect(&args.to, timeout)?;
    let result = stream(&tracks, rx, tx, &opt);
    bar.finish_and_clear();
    if let Some(dir) = &args.out {
        write_outputs(dir, &result)?;
    }
    print!("{}", summary(&result, &args.to));
    anyhow::ensure!(!result.busy(), "edge {to}: {}; try again when its session ends", Notice::Busy, to = args.to);
    let stopped_early = |why: String| {
        anyhow::anyhow!(
            "{why} after {} of {} frames; what the edge answered is written",
            result.frames.len(),
            tracks.frames.len()
        )
    };
    if result.interrupted {
        return Err(stopped_early("interrupted".into()));
    }
    if let Some(e) = &result.link_error {
        return Err(stopped_early(format!("edge {}: {e}", args.to)));
    }
    refused_model(&result, args)?;
    unanswered(&result, &args.to, args.lockstep, args.timeout)
}

/// An error when the edge refused the model the stream sent (its forecasts were then not the
/// model's); written after the summary and files.
fn refused_model(result: &StreamResult, args: &StreamArgs) -> anyhow::Result<()> {
    let Some(path) = &args.model else { return Ok(()) };
    let refusal = result.notices.iter().find_map(|n| if let Notice::ModelRefused(r) = n { Some(*r) } else { None });
    if let Some(why) = refusal {
        anyhow::bail!(
            "edge {}: refused --model {}: {why}; its forecasts were not the model's ({})",
            args.to,
            path.display(),
            result.forecaster().map_or_else(|| "forecaster unknown".to_string(), |f| f.to_string())
        );
    }
    if !matches!(result.forecaster(), Some(Forecaster::Model { .. })) && !result.frames.is_empty() {
        eprintln!(
            "warning: edge {}: did not say that it forecasts with --model {} (an edge without session notices?)",
            args.to,
            path.display()
        );
    }
    Ok(())
}

/// An error when the edge did not answer as the stream needs: no frame at all, or (in lockstep,
/// where every frame waits for its answer) not every frame. The summary and files are written
/// first, so nothing received is lost.
fn unanswered(result: &StreamResult, to: &Endpoint, lockstep: bool, timeout_s: f64) -> anyhow::Result<()> {
    let sent = result.frames.len();
    let answered = result.frames.iter().filter(|f| f.stats.is_some()).count();
    anyhow::ensure!(
        sent == 0 || answered > 0,
        "edge {to}: {sent} frames sent and none answered within --timeout {timeout_s} s (is an edge serving that link?)"
    );
    anyhow::ensure!(
        !lockstep || answered == sent,
        "edge {to}: {} of {sent} frames unanswered in lockstep (the edge stopped or stalled)",
        sent - answered
    );
    Ok(())
}

/// The forecasts' file stem in `--out` (`.csv` and `.json`).
pub const FORECASTS: &str = "forecasts";
/// Per-frame latency, compute and losses (`.csv` and `.json`).
pub const FRAMES: &str = "frames";
/// The edge's replies as received.
pub const REPLIES_BIN: &str = "replies.bin";

/// Writes what came back into the folder `dir`: the forecasts and per-frame tables as CSV and
/// JSON, the raw replies.
///
/// # Errors
/// A file that cannot be written, named.
fn write_outputs(dir: &Path, result: &StreamResult) -> anyhow::Result<()> {
    write_table_files(dir, FORECASTS, &predictions_data(result))?;
    write_table_files(dir, FRAMES, &frames_data(result))?;
    let path = dir.join(REPLIES_BIN);
    dynotraj_formats::atomic::write_file(&path, &result.raw)
        .with_context(|| format!("--out: writing {}", path.display()))
}

/// Where a one-stream command (stream, soak, forecast) takes its tracks: a tracks file, or the
/// track-level simulator's stream of one sequence of a KITTI folder.
#[derive(Debug, Args)]
pub struct TracksInputArgs {
    /// A tracks file (.dtt), as `dynotraj track` writes it.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["kitti", "sequences"])]
    pub tracks: Option<PathBuf>,
    /// A KITTI tracking split folder (default: $DYNOTRAJ_KITTI): the sequence's labels and ego
    /// poses drive the track-level simulator (as `dynotraj estimate` does).
    #[arg(long, value_name = "DIR")]
    pub kitti: Option<PathBuf>,
    /// The KITTI sequence to simulate, e.g. 0000 (one: a stream is one sequence).
    #[arg(long = "sequences", visible_alias = "sequence", value_delimiter = ',', value_parser = crate::numbers::sequence_id, value_name = "ID")]
    pub sequences: Vec<String>,
}

impl TracksInputArgs {
    /// The tracks file when one is given, else the simulated stream of the one sequence of the
    /// KITTI folder (`--kitti`, else `$DYNOTRAJ_KITTI`); only the first `frames` with a limit.
    ///
    /// # Errors
    /// No input, not exactly one sequence, or loading errors, named.
    pub fn load(&self, frames: Option<usize>) -> anyhow::Result<Tracks> {
        let mut tracks = match &self.tracks {
            Some(path) => tracks_file::read(path)?,
            None => {
                let dir = kitti_or_env(self.kitti.as_deref()).with_context(|| {
                    format!("--tracks FILE, or a KITTI folder (--kitti DIR or ${KITTI_ENV}), is needed")
                })?;
                simulated(&dir, one_sequence(&self.sequences)?, frames)?
            }
        };
        if let Some(n) = frames {
            tracks.frames.truncate(n);
        }
        Ok(tracks)
    }
}

/// The track-level simulator's stream for a KITTI sequence at the paper's 20 Hz.
///
/// # Errors
/// Loading errors, named.
pub fn simulated(dir: &Path, id: &str, frames: Option<usize>) -> anyhow::Result<Tracks> {
    let data =
        TrackingDir::open(dir)?.load_sequence(id).with_context(|| format!("loading KITTI tracking sequence {id}"))?;
    let input = sim_input(&data, &ObjectClass::FORECAST);
    let n = frames.map_or(input.camera_poses.len(), |m| m.min(input.camera_poses.len()));
    let boxes: Vec<_> = input.boxes.iter().filter(|b| (b.frame as usize) < n).copied().collect();
    let dt = 1.0 / f64::from(PAPER_FRAME_RATE_HZ);
    let spec = SimSpec::kitti(input.intrinsics, KITTI_IMAGE_SIZE, dt, 1);
    let sim = simulate(&input.camera_poses[..n], &boxes, &spec);
    let camera = camera_info(&input.intrinsics, PAPER_FRAME_RATE_HZ);
    let frames = sim
        .iter()
        .map(|f| TracksFrame::split(f.frame, f.timestamp_us, &f.tracks).with_context(|| format!("frame {}", f.frame)))
        .collect::<anyhow::Result<_>>()?;
    Ok(Tracks { camera, frames })
}
