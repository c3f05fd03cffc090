//! `dynotraj eval`: ADE, FDE and ACE per sequence and their weighted average (Table IV layout).

use std::path::PathBuf;

use clap::Args;
use dynotraj_core::predict::Baseline;

use super::common::{DataArgs, PAPER_TEST_SEQUENCES, progress};
use crate::evaluate::{Forecaster, score_sequence};
use crate::model_file::ModelFile;
use crate::report::{ArmScores, Format, Table, forecast_table};
use crate::scene::Scene;
use crate::trajectory::{Source, eligible_runs};

/// A predictor `eval` can run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PredictorSpec {
    /// A baseline by its name ([`Baseline::name`]): cv (constant velocity from the last two
    /// positions), cv-fit (along the fitted current velocity), ctra (constant turn rate and
    /// acceleration on the unicycle, within the paper's limits).
    Baseline(Baseline),
    /// A trained model blob (f32 or int8) from `dynotraj train`.
    Model(PathBuf),
}

impl std::str::FromStr for PredictorSpec {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if let Some(b) = Baseline::ALL.into_iter().find(|b| b.name() == s) {
            return Ok(Self::Baseline(b));
        }
        s.strip_prefix("model:")
            .filter(|p| !p.is_empty())
            .map(|p| Self::Model(PathBuf::from(p)))
            .ok_or_else(|| format!("unknown predictor `{s}`: expected cv, cv-fit, ctra or model:PATH"))
    }
}

impl PredictorSpec {
    /// The name in tables.
    #[must_use]
    pub fn label(&self) -> String {
        match self {
            Self::Baseline(b) => b.name().into(),
            Self::Model(p) => format!(
                "model {}",
                p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
            ),
        }
    }
}

/// Options of `dynotraj eval`.
#[derive(Debug, Args)]
pub struct EvalArgs {
    /// Data options.
    #[command(flatten)]
    pub data: DataArgs,
    /// Trajectory sources, comma-separated: gt (labels), gt-ekf (forward EKF: causal), gt-rts
    /// (fixed-lag RTS smoother: its inputs have seen later frames, reported apart), estimated
    /// (Ours: the core estimator's newest-frame estimates on the KITTI-driven simulator:
    /// causal), estimated-smoothed (its estimates as they leave the smoothing window: saw later
    /// frames). Each source is scored against its own future (the paper's protocol).
    #[arg(long, value_delimiter = ',', default_value = "gt", value_name = "LIST")]
    pub source: Vec<Source>,
    /// Predictors, comma-separated: cv, cv-fit (constant velocity along the current velocity of
    /// a parabola fitted through the history: the learned model at zero controls), ctra, or
    /// model:PATH (a blob written by `dynotraj train`, f32 or int8; it must have been trained at
    /// the same --rate).
    #[arg(long, value_delimiter = ',', default_value = "cv", value_name = "LIST")]
    pub predictor: Vec<PredictorSpec>,
    /// Test sequences, comma-separated (default: the paper's 0000,0003,0005,0018,0020).
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    pub sequences: Vec<String>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Md)]
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
    let ids: Vec<String> = if args.sequences.is_empty() {
        PAPER_TEST_SEQUENCES.iter().map(ToString::to_string).collect()
    } else {
        args.sequences.clone()
    };
    let seqs = args.data.load_for(&ids, &args.source)?;

    let mut arms = Vec::new();
    let bar = progress((args.source.len() * args.predictor.len()) as u64, "scoring");
    for &source in &args.source {
        let runs: Vec<_> = seqs.iter().map(|s| eligible_runs(s.tracks_for(source), &rule)).collect();
        let scenes: Vec<Scene> = seqs.iter().map(|s| Scene::new(s.tracks_for(source), source, dt)).collect();
        for spec in &args.predictor {
            let model = match spec {
                PredictorSpec::Model(path) => Some(ModelFile::load(path)?),
                _ => None,
            };
            if let (PredictorSpec::Model(path), Some(m)) = (spec, &model) {
                let trained = m.blob().frame_period_s();
                // A model forecasts at the frame period it was trained at; any other gives no
                // forecast at all (every row `-`), so say so instead of printing that table.
                anyhow::ensure!(
                    (trained - dt).abs() <= 1e-6 * dt.max(trained),
                    "model {}: trained at {:.3} Hz, evaluated with --rate {:.3} Hz; give --rate {:.3}",
                    path.display(),
                    1.0 / trained,
                    1.0 / dt,
                    1.0 / trained
                );
            }
            let mut forecaster: Box<dyn Forecaster + '_> = match (spec, &model) {
                (PredictorSpec::Baseline(b), _) => Box::new(*b),
                (PredictorSpec::Model(_), Some(m)) => Box::new(m.predictor()),
                (PredictorSpec::Model(p), None) => anyhow::bail!("model {} not loaded", p.display()),
            };
            let mut arm = ArmScores { label: arm_label(spec, source), per_sequence: Vec::new() };
            let mut failed = 0;
            for (seq_runs, scene) in runs.iter().zip(&scenes) {
                let r = score_sequence(seq_runs, scene, forecaster.as_mut(), dt);
                arm.per_sequence.push(r.scores);
                failed += r.failed;
            }
            if failed > 0 {
                log::warn!("{}: {failed} instances could not be forecast", arm.label);
            }
            arms.push(arm);
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    Ok(forecast_table(&ids, &arms, &[]))
}

fn arm_label(p: &PredictorSpec, s: Source) -> String {
    let name = format!("{} on {}", p.label(), s.name());
    if s.is_causal() { name } else { format!("{name} (inputs saw later frames)") }
}
