//! `dynotraj eval`: ADE, FDE and ACE per sequence and their weighted average (Table IV layout).

use clap::Args;

use super::data_args::DataArgs;
use super::progress::progress;
use dynotraj_eval::predictors::PredictorSpec;
use dynotraj_eval::report::{Format, Table};
use dynotraj_eval::scores::{ScoresRequest, scores_table};
use dynotraj_sources::trajectory::Source;

/// Options of `dynotraj eval`.
#[derive(Debug, Args)]
pub struct EvalArgs {
    /// Data options.
    #[command(flatten)]
    pub data: DataArgs,
    /// Trajectory sources, comma-separated: gt (labels), gt-ekf (forward EKF: causal), gt-rts
    /// (fixed-lag RTS smoother: its inputs have seen later frames, reported apart), estimated
    /// (Ours: the core estimator's newest-frame estimates on the KITTI-driven simulator:
    /// causal), estimated-ekf (those through gt-ekf's forward EKF: causal), estimated-smoothed
    /// (its estimates as they leave the smoothing window: saw later
    /// frames). Each source is scored against its own future (the paper's protocol).
    #[arg(long, value_delimiter = ',', default_value = "gt", value_name = "LIST")]
    pub source: Vec<Source>,
    /// Predictors, comma-separated: cv, cv-fit (constant velocity along the current velocity of
    /// a parabola fitted through the history: the learned model at zero controls), ctra, or
    /// model:PATH (a blob written by `dynotraj train`, f32 or int8; it must have been trained at
    /// the same --rate).
    #[arg(long, value_delimiter = ',', default_value = "cv", value_name = "LIST")]
    pub predictor: Vec<PredictorSpec>,
    /// Test sequences, comma-separated (default: the paper's 0000,0003,0005,0018,0020), as
    /// `experiment --tests`.
    #[arg(long, value_delimiter = ',', value_parser = crate::numbers::sequence_id, value_name = "LIST")]
    pub tests: Vec<String>,
    /// Share of an object's previous forecast that its next one carries, 0 ..= 0.9, for every
    /// predictor given (consistent forecasts: lower ACE; 0 leaves each forecast as made).
    #[arg(long, value_parser = crate::numbers::non_negative_f32, default_value_t = 0.0, value_name = "SHARE")]
    pub carry: f32,
    /// Output format.
    #[arg(long, value_parser = crate::numbers::choices(&Format::CHOICES), default_value = "md")]
    pub format: Format,
}

/// Scores every (source, predictor) arm on every sequence and prints the table.
///
/// # Errors
/// Loading errors, named.
pub fn run(args: &EvalArgs) -> anyhow::Result<()> {
    print!("{}", table(args)?.render(args.format));
    Ok(())
}

/// Scores every (source, predictor) arm on every test sequence
/// ([`dynotraj_eval::scores::scores_table`]), with a progress bar.
///
/// # Errors
/// Loading errors, named.
pub fn table(args: &EvalArgs) -> anyhow::Result<Table> {
    let rule = args.data.rule()?;
    let ids = dynotraj_eval::experiment::paper::test_sequences("--tests", &args.tests)?;
    let request = ScoresRequest {
        rule: &rule,
        dt: args.data.dt()?,
        sources: &args.source,
        predictors: &args.predictor,
        carry: args.carry,
    };
    request.check()?;
    let seqs = args.data.load_for(&ids, &args.source)?;
    let bar = progress((args.source.len() * args.predictor.len() * rule.agent_types().len()) as u64, "scoring");
    let table = scores_table(&seqs, &request, &|n| bar.inc(n));
    bar.finish_and_clear();
    table
}
