//! The `dynotraj` command line.

pub mod benchmark;
pub mod data_args;
pub mod dataset;
pub mod drives;
pub mod estimate;
pub mod estimated_args;
pub mod eval;
pub mod experiment;
pub mod fold_run;
pub mod forecast;
pub mod import;
pub mod interrupt;
pub mod model_args;
pub mod model_cost;
pub mod numbers;
pub mod pedestrians;
pub mod progress;
pub mod record_args;
pub mod sign;
#[cfg(feature = "images")]
pub mod simulate;
pub mod soak;
pub mod stream;
#[cfg(feature = "images")]
pub mod track;
pub mod train;
pub mod train_progress;

use anyhow::Context as _;
use clap::{Parser, Subcommand};

/// The version `--version` prints: the package's and the commit it was built from.
pub const VERSION: &str = concat!(env!("CARGO_PKG_VERSION"), " (commit ", env!("DYNOTRAJ_COMMIT"), ")");

/// dynotraj: trajectory forecasting from a vehicle's cameras, trained without ground truth.
///
/// Reads KITTI tracking data (labels, calibration, ego poses), builds the paper's trajectory
/// sources and scores forecasts with ADE, FDE and ACE. -v, -vv for more detail (RUST_LOG, when
/// set, chooses instead).
#[derive(Debug, Parser)]
#[command(name = "dynotraj", version = VERSION, about, long_about)]
pub struct Cli {
    /// More log detail: -v info, -vv debug, -vvv trace (the default shows warnings).
    #[arg(short, long, action = clap::ArgAction::Count, global = true, conflicts_with = "quiet")]
    pub verbose: u8,
    /// Errors only: no warnings and no progress lines.
    #[arg(short, long, global = true)]
    pub quiet: bool,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

impl Cli {
    /// The log filter the flags ask for.
    #[must_use]
    pub const fn log_level(&self) -> log::LevelFilter {
        dynotraj_core::log_level::from_flags(self.quiet, self.verbose)
    }
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Eligible objects and test instances per sequence (the paper's Table I).
    Dataset(dataset::DatasetArgs),
    /// The drives a manifest or a folder of layout folders and bags names, as `--drives` reads
    /// them: name, kind, path.
    Drives(drives::DrivesArgs),
    /// ADE, FDE and ACE of a predictor on a source, per sequence and weighted (Table IV).
    Eval(eval::EvalArgs),
    /// The estimator on the KITTI-driven simulator: camera and object RPE (Table III).
    Estimate(estimate::EstimateArgs),
    /// Trains the predictor on every sequence but the excluded ones; writes the model blob.
    Train(train::TrainArgs),
    /// Inference time per object and memory of the predictor, float and int8 (`bench` before).
    #[command(alias = "bench")]
    ModelCost(model_cost::ModelCostArgs),
    /// Leave-one-sequence-out training and testing per arm: the paper's Table IV.
    Experiment(experiment::ExperimentArgs),
    /// Generalisation benchmark: every sequence held out once in folds of whole sequences,
    /// several seeds, all arms; weighted and per-sequence tables, the deployment comparison.
    Benchmark(benchmark::BenchmarkArgs),
    /// The pedestrian benchmark: ETH/UCY, each scene held out once, constant velocity, the
    /// motion prior and the learned model (f32, int8) beside Trajectron++'s published figures.
    Pedestrians(pedestrians::PedestriansArgs),
    /// Renders an image sequence (stereo, depth, masks, truth) from KITTI labels and ego poses.
    #[cfg(feature = "images")]
    Simulate(simulate::SimulateArgs),
    /// The image front-end: a KITTI-layout image sequence to a tracks file (.dtt).
    #[cfg(feature = "images")]
    Track(track::TrackArgs),
    /// A ROS 2 bag (MCAP: stereo or RGB-D images, CameraInfo, detections) to a sequence in the
    /// KITTI tracking layout that `track` reads.
    Import(import::ImportArgs),
    /// A sequence in the KITTI tracking layout as a ROS 2 bag (MCAP), as a stereo rig records.
    ExportBag(import::ExportBagArgs),
    /// The edge's session in this process over a tracks recording or a simulated sequence: its
    /// forecasts, as `stream` writes them, without an edge process.
    Forecast(forecast::ForecastArgs),
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
    /// Shell completions on standard output: `dynotraj completions bash > /etc/bash_completion.d/dynotraj`.
    Completions {
        /// The shell.
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
    /// The manual page (roff) on standard output: `dynotraj man | man -l -`.
    Man,
}

impl Command {
    /// The command's name, as typed.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Self::Dataset(_) => "dataset",
            Self::Drives(_) => "drives",
            Self::Eval(_) => "eval",
            Self::Estimate(_) => "estimate",
            Self::Train(_) => "train",
            Self::ModelCost(_) => "model-cost",
            Self::Experiment(_) => "experiment",
            Self::Benchmark(_) => "benchmark",
            Self::Pedestrians(_) => "pedestrians",
            #[cfg(feature = "images")]
            Self::Simulate(_) => "simulate",
            #[cfg(feature = "images")]
            Self::Track(_) => "track",
            Self::Import(_) => "import",
            Self::ExportBag(_) => "export-bag",
            Self::Forecast(_) => "forecast",
            Self::Stream(_) => "stream",
            Self::Soak(_) => "soak",
            Self::Keygen(_) => "keygen",
            Self::Sign(_) => "sign",
            Self::Verify(_) => "verify",
            Self::Completions { .. } => "completions",
            Self::Man => "man",
        }
    }

    /// Whether the command takes SIGINT and SIGTERM as a request to stop and keep what it did
    /// ([`interrupt::stop_flag`]); every other command is ended by them at once
    /// ([`interrupt::end_on_signal`]).
    #[must_use]
    pub const fn stops_on_signal(&self) -> bool {
        matches!(self, Self::Stream(_) | Self::Soak(_) | Self::Experiment(_) | Self::Benchmark(_))
    }
}

/// Runs the parsed command line.
///
/// # Errors
/// Whatever the command reports; the message names the file, line or field at fault.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    progress::set_quiet(cli.quiet);
    match cli.command {
        Command::Dataset(a) => dataset::run(&a),
        Command::Drives(a) => drives::run(&a),
        Command::Eval(a) => eval::run(&a),
        Command::Estimate(a) => estimate::run(&a),
        Command::Train(a) => train::run(&a),
        Command::ModelCost(a) => model_cost::run(&a),
        Command::Experiment(a) => experiment::run(&a),
        Command::Benchmark(a) => benchmark::run(&a),
        Command::Pedestrians(a) => pedestrians::run_command(&a),
        #[cfg(feature = "images")]
        Command::Simulate(a) => simulate::run(&a),
        #[cfg(feature = "images")]
        Command::Track(a) => track::run(&a),
        Command::Import(a) => import::run(&a),
        Command::ExportBag(a) => import::export_bag(&a),
        Command::Forecast(a) => forecast::run(&a),
        Command::Stream(a) => stream::run(&a),
        Command::Soak(a) => soak::run(&a),
        Command::Keygen(a) => sign::keygen(&a),
        Command::Sign(a) => sign::sign(&a),
        Command::Verify(a) => sign::verify(&a),
        Command::Completions { shell } => {
            // Into memory first: clap_complete panics when its writer fails.
            let mut script = Vec::new();
            clap_complete::generate(shell, &mut <Cli as clap::CommandFactory>::command(), "dynotraj", &mut script);
            std::io::Write::write_all(&mut std::io::stdout(), &script).context("writing the completions")
        }
        Command::Man => {
            let man = clap_mangen::Man::new(<Cli as clap::CommandFactory>::command());
            man.render(&mut std::io::stdout()).context("writing the manual page")?;
            Ok(())
        }
    }
}
