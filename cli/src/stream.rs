//! `dynotraj stream`: sends a recorded (or simulated) tracks stream to an edge over TCP or a
//! serial port, paced at the camera rate, and collects its object states, forecasts and
//! per-frame statistics.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::Context as _;
use clap::Args;
use dynotraj_core::wire::Notice;

use super::data_args::{KITTI_ENV, kitti_or_env, one_sequence};
use super::progress::progress;
use dynotraj_eval::report::stream_report::{summary, write_stream_outputs};
use dynotraj_formats::tracks_file::{self, Tracks};
use dynotraj_link::endpoint::{Endpoint, connect};
use dynotraj_link::stream::{StreamOptions, stream};
use dynotraj_sources::estimation::simulated::simulated_stream;

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
        write_stream_outputs(dir, &result)?;
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
    if let Some(path) = &args.model
        && let Some(warning) = result.model_taken(path, &args.to)?
    {
        eprintln!("{warning}");
    }
    result.answered(&args.to, args.lockstep, args.timeout)
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
                simulated_stream(&dir, one_sequence(&self.sequences)?, frames)?
            }
        };
        if let Some(n) = frames {
            tracks.frames.truncate(n);
        }
        Ok(tracks)
    }
}
