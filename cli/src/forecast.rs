//! `dynotraj forecast`: the edge's session run in this process over a tracks recording (or a
//! simulated sequence), with a model or with constant velocity, and its forecasts written as
//! `dynotraj stream` writes them. No edge process, no link, no pacing: the same bytes the edge
//! would receive, the same session code, the same answers.

use std::path::PathBuf;

use anyhow::Context as _;
use clap::Args;
use dynotraj_core::wire::Message;
use dynotraj_eval::recording::forecast::{Forecaster, record_forecasts};
use dynotraj_eval::recording::recorded;
use dynotraj_eval::report::stream_report::predictions_data;
use dynotraj_eval::report::write_table_files;
use dynotraj_link::in_process::{edge_model_blob, forecast};

use super::stream::TracksInputArgs;
use dynotraj_eval::report::stream_report::{FORECASTS, REPLIES_BIN};

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
    /// Also write a recording to look at in Foxglove: an MCAP file (Foxglove's schemas; --record-encoding)
    /// with, per frame, each object's history (`/objects/tracks`), its constant-velocity
    /// forecast (`/forecasts/cv`), with --model also the model's (`/forecasts/learned`), and the
    /// camera (`/tf`). A forecast is one sequence, so FILE is the recording itself.
    #[arg(long, value_name = "FILE")]
    pub record: Option<PathBuf>,
    /// The recordings' encoding.
    #[command(flatten)]
    pub record_encoding: crate::record_args::RecordEncodingArgs,
}

/// Runs `dynotraj forecast`.
///
/// # Errors
/// Input, model or output errors, named.
pub fn run(args: &ForecastArgs) -> anyhow::Result<()> {
    dynotraj_formats::atomic::output_folder("--out", &args.out)?;
    let tracks = args.input.load(args.frames)?;
    let model = args.model.as_deref().map(edge_model_blob).transpose()?;
    let out = forecast(&tracks, model.as_deref())?;
    write_table_files(&args.out, FORECASTS, &predictions_data(&out.result))?;
    let path = args.out.join(REPLIES_BIN);
    dynotraj_formats::atomic::write_file(&path, &out.result.raw)
        .with_context(|| format!("--out: writing {}", path.display()))?;
    if let Some(file) = &args.record {
        let forecaster = if args.model.is_some() { Forecaster::Learned } else { Forecaster::ConstantVelocity };
        let written = record_forecasts(file, args.record_encoding.into(), &tracks, &out.result, forecaster)
            .context("--record")?;
        eprintln!("{}", recorded(&written));
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
