//! `dynotraj soak`: the host build of the edge (`dynotraj-edge`, started here) fed a long,
//! randomly damaged stream; prints what was sent, damaged, answered and lost, and the edge's
//! resident memory after the first frames and at the end.

use std::path::PathBuf;

use clap::Args;

use super::progress::progress;
use super::stream::TracksInputArgs;
use dynotraj_eval::report::stream_report::{soak_data, soak_summary};
use dynotraj_eval::report::write_table_files;
use dynotraj_formats::tracks_file::Tracks;
use dynotraj_link::edge_process::{EdgeProcess, edge_beside_this_program};
use dynotraj_link::soak::{SoakOptions, SoakReport, soak};

/// Options of `dynotraj soak`.
#[derive(Debug, Args)]
pub struct SoakArgs {
    /// Where the tracks come from; their frames are looped.
    #[command(flatten)]
    pub input: TracksInputArgs,
    /// Camera frames to send.
    #[arg(long, default_value_t = 100_000, value_name = "N")]
    pub frames: u64,
    /// Probability that a wire frame (one part) is damaged: a byte flipped, its tail dropped,
    /// or sent twice.
    #[arg(long, value_parser = crate::numbers::fraction, default_value_t = 0.01, value_name = "P")]
    pub fault_probability: f64,
    /// Seed of the faults.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Folder for the soak's figures as a one-row table, `soak.csv` and `soak.json`.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// The edge binary to start (default: `dynotraj-edge` beside this program; build both with
    /// `cargo build --release --bins`).
    #[arg(long, value_name = "PATH")]
    pub edge: Option<PathBuf>,
}

/// Runs the soak and prints its report.
///
/// # Errors
/// Input, edge start-up or link errors, named; a clean frame left unanswered.
pub fn run(args: &SoakArgs) -> anyhow::Result<()> {
    if let Some(dir) = &args.out {
        dynotraj_formats::atomic::output_folder("--out", dir)?;
    }
    let report = soak_edge(args)?;
    print!("{}", soak_summary(&report));
    if let Some(dir) = &args.out {
        write_table_files(dir, "soak", &soak_data(&report))?;
    }
    anyhow::ensure!(
        !report.interrupted,
        "interrupted after {} of {} frames; {} written",
        report.frames_sent,
        args.frames,
        if args.out.is_some() { "the summary and --out are" } else { "the summary is" }
    );
    anyhow::ensure!(report.clean_unanswered == 0, "{} clean frames were not answered", report.clean_unanswered);
    Ok(())
}

/// Starts the edge, soaks it and waits for it to exit.
///
/// # Errors
/// See [`run`].
pub fn soak_edge(args: &SoakArgs) -> anyhow::Result<SoakReport> {
    anyhow::ensure!(
        (0.0..=1.0).contains(&args.fault_probability),
        "--fault-probability: expected 0..=1, found {}",
        args.fault_probability
    );
    let base: Tracks = args.input.load(None)?;
    let binary = match &args.edge {
        Some(p) => p.clone(),
        None => edge_beside_this_program()?,
    };
    let edge = EdgeProcess::start(&binary)?;
    let (rx, tx) = edge.connect()?;
    let bar = std::sync::Arc::new(progress(args.frames, "frames sent"));
    let opt = SoakOptions {
        frames: args.frames,
        fault_probability: args.fault_probability,
        seed: args.seed,
        on_frame: Some(dynotraj_link::OnFrame(bar.hook().shared())),
        stop: Some(crate::interrupt::stop_flag()?),
        ..SoakOptions::default()
    };
    let report = soak(&base, rx, tx, &opt, Some(edge.id()))?;
    bar.finish_and_clear();
    let (last_words, status) = edge.wait()?;
    // The edge's last words (its session summary) go to our stderr.
    for l in last_words {
        eprintln!("{l}");
    }
    // A Ctrl-C reaches the edge too (one process group): its exit then is no fault of its own.
    anyhow::ensure!(status.success() || report.interrupted, "the edge exited with {status}");
    Ok(report)
}
