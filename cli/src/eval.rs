//! `dynotraj eval`: ADE, FDE and ACE per sequence and their weighted average (Table IV layout).

use clap::Args;
use dynotraj_core::predict::consistency::MAX_CARRY;
use dynotraj_core::predict::{Carried, Carry};

use super::data_args::{DataArgs, PAPER_TEST_SEQUENCES};
use super::progress::progress;
use dynotraj_eval::forecast_eval::score_sequence;
use dynotraj_eval::predictors::{LoadedPredictor, PredictorSpec};
use dynotraj_eval::report::{ArmScores, Format, Table, forecast_table};
use dynotraj_sources::scene::Scene;
use dynotraj_sources::trajectory::{EligibleRun, Source, eligible_runs};

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

/// Scores every (source, predictor) arm on every sequence: the Table IV layout.
///
/// # Errors
/// Loading errors, named.
pub fn table(args: &EvalArgs) -> anyhow::Result<Table> {
    let rule = args.data.rule()?;
    let dt = args.data.dt()?;
    let ids: Vec<String> = if args.tests.is_empty() {
        PAPER_TEST_SEQUENCES.iter().map(ToString::to_string).collect()
    } else {
        dynotraj_sources::drives::distinct_ids("--tests", args.tests.clone())?
    };
    if let Some(twice) = dynotraj_sources::drives::first_repeated(&args.predictor) {
        anyhow::bail!("--predictor: {} is given twice (its rows would repeat)", twice.label());
    }
    anyhow::ensure!(args.carry <= MAX_CARRY, "--carry {}: at most {MAX_CARRY}", args.carry);
    let seqs = args.data.load_for(&ids, &args.source)?;

    let loaded: Vec<LoadedPredictor> =
        args.predictor.iter().map(|spec| LoadedPredictor::load(spec, dt)).collect::<anyhow::Result<_>>()?;
    let agent_types = rule.agent_types();
    let mut arms = Vec::new();
    let bar = progress((args.source.len() * args.predictor.len() * agent_types.len()) as u64, "scoring");
    // Each agent type apart: a model forecasts only the agents of its dynamics, and a row
    // mixing agent types would hide which one a change helps.
    for (k, &agents) in agent_types.iter().enumerate() {
        let agent_rule = rule.for_agents(agents);
        for &source in &args.source {
            let runs: Vec<_> = seqs.iter().map(|s| eligible_runs(s.tracks_for(source), &agent_rule)).collect();
            if k > 0 && runs.iter().all(Vec::is_empty) {
                bar.inc(args.predictor.len() as u64);
                continue;
            }
            let scenes: Vec<Scene> = seqs.iter().map(|s| s.scene(source, dt)).collect();
            for (spec, loaded) in args.predictor.iter().zip(&loaded) {
                bar.inc(1);
                if !loaded.forecasts(agents) {
                    continue;
                }
                let label = arm_label(spec, source, args.carry);
                let label = if k == 0 { label } else { format!("{label}, {}", agents.agents()) };
                arms.push(score_arm(loaded, label, &runs, &scenes, (dt, args.carry)));
            }
        }
    }
    bar.finish_and_clear();
    Ok(forecast_table(&ids, &arms, &[]))
}

/// The scores of `loaded` (carrying `carry` of its last forecast) on every sequence's `runs`.
fn score_arm(
    loaded: &LoadedPredictor,
    label: String,
    runs: &[Vec<EligibleRun>],
    scenes: &[Scene],
    (dt, carry): (f32, f32),
) -> ArmScores {
    let mut forecaster = loaded.forecaster();
    let mut forecaster = Carried(forecaster.as_mut(), Carry::new(carry));
    let mut arm = ArmScores::new(label);
    let mut failed = 0;
    for (seq_runs, scene) in runs.iter().zip(scenes) {
        let r = score_sequence(seq_runs, scene, &mut forecaster, dt);
        arm.push_sequence(&r);
        failed += r.failed;
    }
    if failed > 0 {
        log::warn!("{}: {failed} instances could not be forecast", arm.label);
    }
    arm
}

fn arm_label(p: &PredictorSpec, s: Source, carry: f32) -> String {
    let carried = if carry > 0.0 { format!(" carrying {carry}") } else { String::new() };
    let name = format!("{}{carried} on {}", p.label(), s.name());
    if s.is_causal() { name } else { format!("{name} (inputs saw later frames)") }
}
