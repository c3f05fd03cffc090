//! The `dynotraj` command line.

pub mod bench;
pub mod benchmark;
pub mod common;
pub mod dataset;
pub mod estimate;
pub mod eval;
pub mod experiment;
pub mod fold_run;
pub mod interrupt;
pub mod numbers;
pub mod progress;
pub mod sign;
pub mod simulate;
pub mod soak;
pub mod stream;
pub mod track;
pub mod train;
pub mod train_progress;

use clap::{Parser, Subcommand};

/// dynotraj: trajectory forecasting from a vehicle's cameras, trained without ground truth.
///
/// Reads KITTI tracking data (labels, calibration, ego poses), builds the paper's trajectory
/// sources and scores forecasts with ADE, FDE and ACE. Set RUST_LOG=info for more detail.
#[derive(Debug, Parser)]
#[command(name = "dynotraj", version, about, long_about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Eligible objects and test instances per sequence (the paper's Table I).
    Dataset(dataset::DatasetArgs),
    /// ADE, FDE and ACE of a predictor on a source, per sequence and weighted (Table IV).
    Eval(eval::EvalArgs),
    /// The estimator on the KITTI-driven simulator: camera and object RPE (Table III).
    Estimate(estimate::EstimateArgs),
    /// Trains the predictor on every sequence but the excluded ones; writes the model blob.
    Train(train::TrainArgs),
    /// Inference time per object and memory of the predictor, float and int8.
    Bench(bench::BenchArgs),
    /// Leave-one-sequence-out training and testing per arm: the paper's Table IV.
    Experiment(experiment::ExperimentArgs),
    /// Generalisation benchmark: every sequence held out once in folds of whole sequences,
    /// several seeds, all arms; weighted and per-sequence tables, the deployment comparison.
    Benchmark(benchmark::BenchmarkArgs),
    /// Renders an image sequence (stereo, depth, masks, truth) from KITTI labels and ego poses.
    Simulate(simulate::SimulateArgs),
    /// The image front-end: a KITTI-layout image sequence to a tracks file (.dtt).
    Track(track::TrackArgs),
    /// Streams feature tracks to an edge (TCP or serial) and collects its forecasts.
    Stream(stream::StreamArgs),
    /// A long stream into the host build of the edge over a link with random faults: losses
    /// counted, clean frames all answered, the edge's memory at start and end.
    Soak(soak::SoakArgs),
    /// A new Ed25519 key pair for signing model blobs.
    Keygen(sign::KeygenArgs),
    /// Signs a model blob, as an edge requires of a model sent over its link.
    Sign(sign::SignArgs),
    /// Checks a signed model blob against a public key.
    Verify(sign::VerifyArgs),
}

/// Runs the parsed command line.
///
/// # Errors
/// Whatever the command reports; the message names the file, line or field at fault.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Dataset(a) => dataset::run(&a),
        Command::Eval(a) => eval::run(&a),
        Command::Estimate(a) => estimate::run(&a),
        Command::Train(a) => train::run(&a),
        Command::Bench(a) => bench::run(&a),
        Command::Experiment(a) => experiment::run(&a),
        Command::Benchmark(a) => benchmark::run(&a),
        Command::Simulate(a) => simulate::run(&a),
        Command::Track(a) => track::run(&a),
        Command::Stream(a) => stream::run(&a),
        Command::Soak(a) => soak::run(&a),
        Command::Keygen(a) => sign::keygen(&a),
        Command::Sign(a) => sign::sign(&a),
        Command::Verify(a) => sign::verify(&a),
    }
}
